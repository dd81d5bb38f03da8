//! The files a scene names that are too big to put in every scene message (particle files): a
//! worker that sees rank 0's file, with the same bytes, reads it where it is; one that does not
//! asks for it, and rank 0 streams it over in parts that the worker writes into its private
//! directory as they come. On one machine reading took 1.8 s less of a 35M-sphere set-up (33.2 s
//! against 35.0 s) than rank 0 sending the 700 MB file to two workers, one after the other; a
//! sender's cost grows with the workers while readers read side by side, so sending is the
//! fallback (docs/large-models.md, "Across MPI ranks").

use super::cluster::Cluster;
use super::wire::{FilePart, SceneMsg, SharedFile, Tag};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

/// The most bytes one [`FilePart`] carries: far below MPI's 2^31-element count, and a bounded
/// buffer on both sides however big the file.
pub const PART_BYTES: usize = 64 << 20;

/// A digest of a file's bytes, eight at a time (a fraction of a second for a 35M-particle file:
/// each worker that reads the file itself runs it to know it sees rank 0's bytes). Not
/// cryptographic: it catches a stale or different copy, not an adversary.
#[derive(Clone, Debug)]
pub struct Digest {
    h: u64,
    len: u64,
    tail: Vec<u8>,
}

impl Default for Digest {
    fn default() -> Self {
        Digest { h: 0xcbf2_9ce4_8422_2325, len: 0, tail: Vec::with_capacity(8) }
    }
}

impl Digest {
    fn word(&mut self, w: u64) {
        // Each step is a bijection of h (xor, odd multiply, rotate), so one changed word always
        // changes the digest; the rotation carries high bits down.
        self.h = (self.h ^ w).wrapping_mul(0x0100_0000_01b3).rotate_left(29);
    }

    pub fn update(&mut self, mut bytes: &[u8]) {
        self.len += bytes.len() as u64;
        if !self.tail.is_empty() {
            let n = (8 - self.tail.len()).min(bytes.len());
            self.tail.extend_from_slice(&bytes[..n]);
            bytes = &bytes[n..];
            if self.tail.len() < 8 {
                return;
            }
            let w = u64::from_le_bytes(self.tail[..].try_into().expect("8 bytes"));
            self.word(w);
            self.tail.clear();
        }
        let mut words = bytes.chunks_exact(8);
        for w in &mut words {
            self.word(u64::from_le_bytes(w.try_into().expect("8 bytes")));
        }
        self.tail.extend_from_slice(words.remainder());
    }

    pub fn finish(mut self) -> u64 {
        let mut last = [0u8; 8];
        last[..self.tail.len()].copy_from_slice(&self.tail);
        self.word(u64::from_le_bytes(last));
        self.word(self.len);
        self.h
    }
}

/// The length and [`Digest`] of the file at `path`.
pub fn file_digest(path: &Path) -> std::io::Result<(u64, u64)> {
    let mut file = std::fs::File::open(path)?;
    let mut digest = Digest::default();
    let mut buf = vec![0u8; 1 << 20];
    loop {
        let n = file.read(&mut buf)?;
        if n == 0 {
            break;
        }
        digest.update(&buf[..n]);
    }
    let len = digest.len;
    Ok((len, digest.finish()))
}

/// Rank 0: sends file `index` of the scene (`file`, at `path`) to `rank` in parts; a rank that
/// takes no part for `deadline` ends the job ([`Cluster::send_within`]).
pub fn send(
    cluster: &Cluster,
    rank: i32,
    index: u32,
    file: &SharedFile,
    path: &Path,
    deadline: std::time::Duration,
) -> std::io::Result<()> {
    let mut f = std::fs::File::open(path)?;
    let mut offset = 0u64;
    loop {
        let mut bytes = Vec::with_capacity(PART_BYTES);
        (&mut f).take(PART_BYTES as u64).read_to_end(&mut bytes)?;
        if bytes.is_empty() {
            break;
        }
        let n = bytes.len() as u64;
        let doing = format!("sending it {}", file.path);
        cluster.send_within(rank, Tag::File, &FilePart { index, offset, bytes }.encode(), deadline, &doing);
        offset += n;
    }
    if offset != file.len {
        let why = format!("it holds {offset} bytes now, {} when the scene was sent: it changed", file.len);
        return Err(std::io::Error::other(why));
    }
    Ok(())
}

/// Why a worker could not take a scene's files.
#[derive(Debug, thiserror::Error)]
pub enum FileError {
    #[error("writing {0}: {1}")]
    Write(PathBuf, std::io::Error),
    #[error(
        "{name} arrived with {got} bytes and digest {digest:016x}; rank 0 sent {len} bytes, {sent:016x}"
    )]
    Digest { name: String, got: u64, digest: u64, len: u64, sent: u64 },
    #[error("{name}: a part of bytes {at}..{end} arrived after {had} of its {len} bytes")]
    Part { name: String, at: u64, end: u64, had: u64, len: u64 },
    #[error("a part of file {0} arrived that no scene is waiting for")]
    Unexpected(u32),
}

/// A scene arriving on a worker: its private directory, where the TOML and textures are written
/// and each shared file is linked (where this rank sees rank 0's bytes) or written as it comes.
/// The directory goes when the arrival does.
pub struct Arrival {
    pub msg: SceneMsg,
    dir: PathBuf,
    coming: Vec<Coming>,
}

/// A shared file on its way: where its parts go, and what came so far.
struct Coming {
    index: u32,
    out: std::fs::File,
    digest: Digest,
}

impl Arrival {
    /// Writes `msg`'s TOML and textures into `dir` (made anew) and links each shared file this
    /// rank can read with the bytes rank 0 read. Returns the arrival and the files it still
    /// needs, each with why it cannot read it (`unseen`: as if it could read none).
    pub fn begin(
        msg: SceneMsg,
        dir: PathBuf,
        unseen: bool,
    ) -> Result<(Arrival, Vec<(u32, String)>), FileError> {
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).map_err(|e| FileError::Write(dir.clone(), e))?;
        let mut arrival = Arrival { msg, dir, coming: Vec::new() };
        let write =
            |path: PathBuf, bytes: &[u8]| std::fs::write(&path, bytes).map_err(|e| FileError::Write(path, e));
        for (name, png) in &arrival.msg.textures {
            write(arrival.dir.join(name), png)?;
        }
        write(arrival.toml(), arrival.msg.toml.as_bytes())?;
        let mut need = Vec::new();
        for (i, f) in arrival.msg.files.iter().enumerate() {
            let here = arrival.dir.join(&f.name);
            let seen = match unseen {
                true => Err(format!("{}: hidden by IRT_FAULT=unseen-files", f.path)),
                false => same_bytes(f),
            };
            match seen {
                Ok(()) => {
                    std::os::unix::fs::symlink(&f.path, &here).map_err(|e| FileError::Write(here, e))?
                }
                Err(why) => {
                    let out = std::fs::File::create(&here).map_err(|e| FileError::Write(here, e))?;
                    arrival.coming.push(Coming { index: i as u32, out, digest: Digest::default() });
                    need.push((i as u32, why));
                }
            }
        }
        Ok((arrival, need))
    }

    /// The scene's TOML, in the arrival's directory.
    pub fn toml(&self) -> PathBuf {
        self.dir.join("scene.toml")
    }

    /// Every shared file is here.
    pub fn complete(&self) -> bool {
        self.coming.is_empty()
    }

    /// Writes a part of a file on its way; a file whose last part came is checked against the
    /// length and digest rank 0 sent.
    pub fn take(&mut self, part: FilePart) -> Result<(), FileError> {
        let at = self.coming.iter().position(|c| c.index == part.index);
        let Some(at) = at else { return Err(FileError::Unexpected(part.index)) };
        let c = &mut self.coming[at];
        let f = &self.msg.files[part.index as usize];
        let path = self.dir.join(&f.name);
        if part.offset != c.digest.len || c.digest.len + part.bytes.len() as u64 > f.len {
            let (at, end, had) = (part.offset, part.offset + part.bytes.len() as u64, c.digest.len);
            return Err(FileError::Part { name: f.name.clone(), at, end, had, len: f.len });
        }
        c.out.write_all(&part.bytes).map_err(|e| FileError::Write(path.clone(), e))?;
        c.digest.update(&part.bytes);
        if c.digest.len == f.len {
            c.out.flush().map_err(|e| FileError::Write(path, e))?;
            let c = self.coming.remove(at);
            let (got, digest) = (c.digest.len, c.digest.finish());
            if digest != f.digest {
                return Err(FileError::Digest {
                    name: f.name.clone(),
                    got,
                    digest,
                    len: f.len,
                    sent: f.digest,
                });
            }
        }
        Ok(())
    }
}

impl Drop for Arrival {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// Whether this rank reads `f`'s bytes at its path (`Err`: why not, in words for rank 0's log).
fn same_bytes(f: &SharedFile) -> Result<(), String> {
    let (len, digest) = file_digest(Path::new(&f.path)).map_err(|e| format!("{}: {e}", f.path))?;
    match (len, digest) == (f.len, f.digest) {
        true => Ok(()),
        false => Err(format!("{} holds other bytes here ({len} bytes, rank 0 read {})", f.path, f.len)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// However the bytes are split into updates, the digest is the same; one changed or added
    /// byte changes it.
    #[test]
    fn digest_is_split_free_and_sees_one_byte() {
        let bytes: Vec<u8> = (0..1000u32).map(|i| (i * 7919 % 251) as u8).collect();
        let whole = {
            let mut d = Digest::default();
            d.update(&bytes);
            d.finish()
        };
        for split in [1, 3, 7, 8, 9, 500] {
            let mut d = Digest::default();
            for c in bytes.chunks(split) {
                d.update(c);
            }
            assert_eq!(d.finish(), whole, "in parts of {split}");
        }
        for at in [0, 5, 8, 999] {
            let mut other = bytes.clone();
            other[at] ^= 0x80;
            let mut d = Digest::default();
            d.update(&other);
            assert_ne!(d.finish(), whole, "byte {at} changed");
        }
        let mut longer = bytes.clone();
        longer.push(0);
        let mut d = Digest::default();
        d.update(&longer);
        assert_ne!(d.finish(), whole, "a zero byte more");
    }

    /// A file that arrives in parts is written whole and checked; a wrong byte is named.
    #[test]
    fn an_arrival_takes_parts_and_checks_them() {
        let dir = std::env::temp_dir().join(format!("irt-files-test-{}", std::process::id()));
        let bytes: Vec<u8> = (0..100u8).collect();
        let mut d = Digest::default();
        d.update(&bytes);
        let file =
            SharedFile { name: "p.ply".into(), path: "/nowhere/p.ply".into(), len: 100, digest: d.finish() };
        let msg = SceneMsg { toml: "# empty".into(), textures: vec![], files: vec![file], hash: 0 };
        let (mut a, need) = Arrival::begin(msg.clone(), dir.clone(), false).unwrap();
        assert_eq!(need.len(), 1);
        assert!(need[0].1.contains("/nowhere/p.ply"), "{}", need[0].1);
        a.take(FilePart { index: 0, offset: 0, bytes: bytes[..60].to_vec() }).unwrap();
        assert!(!a.complete());
        a.take(FilePart { index: 0, offset: 60, bytes: bytes[60..].to_vec() }).unwrap();
        assert!(a.complete());
        assert_eq!(std::fs::read(dir.join("p.ply")).unwrap(), bytes);
        assert!(matches!(
            a.take(FilePart { index: 0, offset: 0, bytes: vec![] }),
            Err(FileError::Unexpected(0))
        ));
        drop(a);
        assert!(!dir.exists(), "the directory goes with the arrival");

        let (mut a, _) = Arrival::begin(msg.clone(), dir.clone(), false).unwrap();
        let e = a.take(FilePart { index: 0, offset: 60, bytes: vec![0; 40] }).unwrap_err().to_string();
        assert!(e.contains("bytes 60..100 arrived after 0 of its 100"), "{e}");
        drop(a);

        let (mut a, _) = Arrival::begin(msg, dir.clone(), false).unwrap();
        let mut wrong = bytes.clone();
        wrong[42] = 0;
        let e = a.take(FilePart { index: 0, offset: 0, bytes: wrong }).unwrap_err().to_string();
        assert!(e.contains("p.ply arrived with 100 bytes"), "{e}");
    }
}
