//! Batch on a render farm: a picture cut into N tiles, each rendered by its own command (one task
//! of a Slurm job array, one pod of a Kubernetes Indexed Job), then merged. A tile is a band of
//! whole rows of the conventional frame's tiles, traced with the same entry point, samples and
//! seeds as the whole picture, so the merge is the picture `irt render` writes, bit for bit.
//!
//! What a farm needs of the command (../shared/DISTRIBUTED.md): it is deterministic and
//! idempotent — a tile already written is left alone, a tile is written atomically or not at
//! all — and the merge refuses while any tile is missing, or when tiles of another render are
//! mixed in, and then writes nothing.

use crate::dist::wire::{SceneMsg, State};
use crate::gpu::device::Device;
use crate::gpu::layout::TILE_H;
use crate::image::Image;
use crate::render::frame::HostFrame;
use crate::render::pieces::split_settings;
use crate::render::{Mode, RenderError, Session, Settings};
use crate::scene::Scene;
use std::fmt;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::str::FromStr;

/// Tile `index` of `count` (from 0), as `--tile I/N` names it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TileSpec {
    pub index: u32,
    pub count: u32,
}

impl FromStr for TileSpec {
    type Err = crate::ParseError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let bad = || {
            crate::ParseError::new(
                "tile",
                format!("tile `{s}`: expected I/N, tile I (from 0) of N, e.g. 0/4 (with a job array: $SLURM_ARRAY_TASK_ID/4)"),
            )
        };
        let (i, n) = s.split_once('/').ok_or_else(bad)?;
        let (index, count) =
            (i.trim().parse::<u32>().map_err(|_| bad())?, n.trim().parse::<u32>().map_err(|_| bad())?);
        if count == 0 || index >= count {
            return Err(crate::ParseError::new(
                "tile",
                format!("tile `{s}`: I counts from 0 and must be below N"),
            ));
        }
        Ok(TileSpec { index, count })
    }
}

impl fmt::Display for TileSpec {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// Why a file's bytes are not a tile.
#[derive(Debug, thiserror::Error)]
pub enum TileDecodeError {
    #[error("not an irt tile (irt render --tile writes them)")]
    NotATile,
    #[error("tile format {0} (this irt reads {FORMAT})")]
    Format(u32),
    #[error("its header is inconsistent (tile {index} of {count}, {width}x{height}, rows {y0}..{y1})")]
    Header { index: u32, count: u32, width: u32, height: u32, y0: u32, y1: u32 },
    #[error("{have} bytes where its header promises {want}")]
    Length { have: usize, want: usize },
}

/// What a farm command can fail with.
#[derive(Debug, thiserror::Error)]
pub enum FarmError {
    #[error("--tile {spec}: a {height}-pixel-high image has {rows} rows of tiles ({TILE_H} pixels each), so N can be at most {rows}")]
    TooManyTiles { spec: TileSpec, height: u32, rows: u32 },
    #[error("{0} cannot be cut into tiles: drop it")]
    Unsupported(&'static str),
    #[error("{0}")]
    Io(String),
    #[error("{path}: {why}")]
    BadTile { path: PathBuf, why: TileDecodeError },
    #[error("{dir}: tile {index} of {count} is already there from another render ({why}): give this render a directory of its own, or delete the old tiles")]
    Foreign { dir: PathBuf, index: u32, count: u32, why: String },
    #[error("{dir}: no tiles (irt render SCENE --tile I/N --out {dir} writes them)")]
    NoTiles { dir: PathBuf },
    #[error("{dir}: {missing} of {count} tiles missing ({list}); nothing written")]
    Missing { dir: PathBuf, missing: usize, count: u32, list: String },
    #[error("{dir}: the tiles belong to different renders: {first} and {other} ({why}); nothing written")]
    Mixed { dir: PathBuf, first: String, other: String, why: String },
    #[error(transparent)]
    Render(#[from] RenderError),
}

/// The rows of a `height`-pixel image that tile `spec` covers: whole rows of the frame's tiles,
/// split as evenly as they go.
pub fn tile_rows(height: u32, spec: TileSpec) -> Result<Range<u32>, FarmError> {
    let rows = height.div_ceil(TILE_H);
    if spec.count > rows {
        return Err(FarmError::TooManyTiles { spec, height, rows });
    }
    let at = |i: u32| ((i as u64 * rows as u64 / spec.count as u64) as u32 * TILE_H).min(height);
    Ok(at(spec.index)..at(spec.index + 1))
}

/// Which render a tile belongs to: the scene as sent to MPI workers (its TOML, textures and the
/// digests of its particle files: a file changed between two tiles' runs is another render) and
/// the settings and camera it is traced with, hashed. Two tiles merge only if their keys agree.
pub fn render_key(scene: &Scene, settings: &Settings) -> Result<u64, FarmError> {
    let files = crate::io::toml_write::to_files(scene, "scene").map_err(|e| FarmError::Io(e.to_string()))?;
    let state = State { version: 0, camera: scene.camera.clone(), settings: settings.clone(), time: 0.0 };
    let mut parts = files.textures;
    for p in &scene.particles {
        let (len, digest) = crate::dist::files::file_digest(std::path::Path::new(&p.file))
            .map_err(|e| FarmError::Io(format!("{}: {e}", p.file)))?;
        parts.push((p.file.clone(), [len.to_le_bytes(), digest.to_le_bytes()].concat()));
    }
    parts.push(("state".into(), state.encode()));
    Ok(SceneMsg { toml: files.toml, textures: parts, files: Vec::new(), hash: 0 }.content_hash())
}

/// One rendered tile: where it lies in which render, and its pixels (linear radiance, the rows
/// `rows` of a `width`×`height` picture).
#[derive(Clone, Debug, PartialEq)]
pub struct Tile {
    pub key: u64,
    pub spec: TileSpec,
    pub width: u32,
    pub height: u32,
    pub rows: Range<u32>,
    pub pixels: Vec<[f32; 3]>,
}

const MAGIC: &[u8; 8] = b"irt-tile";
const FORMAT: u32 = 1;
const HEADER: usize = 8 + 4 + 8 + 4 * 6;

impl Tile {
    /// The file name of tile `spec` in a tile directory.
    pub fn file_name(spec: TileSpec) -> String {
        format!("tile-{}-of-{}.irt-tile", spec.index, spec.count)
    }

    pub fn encode(&self) -> Vec<u8> {
        let mut b = Vec::with_capacity(HEADER + self.pixels.len() * 12);
        b.extend_from_slice(MAGIC);
        b.extend_from_slice(&FORMAT.to_le_bytes());
        b.extend_from_slice(&self.key.to_le_bytes());
        for v in [self.spec.index, self.spec.count, self.width, self.height, self.rows.start, self.rows.end] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        for p in &self.pixels {
            for c in p {
                b.extend_from_slice(&c.to_le_bytes());
            }
        }
        b
    }

    /// A tile from its file's bytes; with `header_only`, without its pixels.
    pub fn decode(bytes: &[u8], header_only: bool) -> Result<Tile, TileDecodeError> {
        if bytes.len() < HEADER || &bytes[..8] != MAGIC {
            return Err(TileDecodeError::NotATile);
        }
        let u32_at = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().expect("4 bytes"));
        if u32_at(8) != FORMAT {
            return Err(TileDecodeError::Format(u32_at(8)));
        }
        let key = u64::from_le_bytes(bytes[12..20].try_into().expect("8 bytes"));
        let [index, count, width, height, y0, y1] = std::array::from_fn(|i| u32_at(20 + 4 * i));
        let spec = TileSpec { index, count };
        let expected = tile_rows(height, spec).ok().filter(|r| *r == (y0..y1) && width > 0 && index < count);
        if expected.is_none() {
            return Err(TileDecodeError::Header { index, count, width, height, y0, y1 });
        }
        let n = width as usize * (y1 - y0) as usize;
        let pixels = if header_only {
            Vec::new()
        } else {
            if bytes.len() != HEADER + n * 12 {
                return Err(TileDecodeError::Length { have: bytes.len(), want: HEADER + n * 12 });
            }
            bytes[HEADER..]
                .chunks_exact(12)
                .map(|c| {
                    std::array::from_fn(|k| {
                        f32::from_le_bytes(c[4 * k..4 * k + 4].try_into().expect("4 bytes"))
                    })
                })
                .collect()
        };
        Ok(Tile { key, spec, width, height, rows: y0..y1, pixels })
    }

    /// How two tiles' renders differ, if they do.
    fn differs(&self, other: &Tile) -> Option<String> {
        if [self.width, self.height] != [other.width, other.height] {
            Some(format!("{}x{} and {}x{}", self.width, self.height, other.width, other.height))
        } else if self.spec.count != other.spec.count {
            Some(format!("split into {} and into {} tiles", self.spec.count, other.spec.count))
        } else if self.key != other.key {
            Some("another scene or other settings".into())
        } else {
            None
        }
    }
}

/// The key of the render whose tiles `render_tile(scene, settings, …)` makes, before making
/// any: what tells a farm task its tile is already done.
pub fn tile_key(scene: &Scene, settings: &Settings) -> Result<u64, FarmError> {
    render_key(scene, &tile_settings(settings.clone())?)
}

/// The settings tiles are traced with; `settings` as `irt render` would trace the whole picture.
fn tile_settings(settings: Settings) -> Result<Settings, FarmError> {
    if let Mode::Frameless { .. } = settings.mode {
        return Err(FarmError::Unsupported(
            "the frameless mode (a farm renders still pictures: --mode conventional --samples N)",
        ));
    }
    split_settings(settings).map_err(FarmError::Unsupported)
}

/// Renders tile `spec` of `scene` on `ctx`: the pixels of its rows exactly as the whole
/// picture has them. `progress(done, total)` counts pixels traced.
pub fn render_tile<D: Device>(
    ctx: &D,
    scene: Scene,
    settings: Settings,
    spec: TileSpec,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<Tile, FarmError> {
    let settings = tile_settings(settings)?;
    let [width, height] = [scene.camera.width, scene.camera.height];
    let rows = tile_rows(height, spec)?;
    let key = render_key(&scene, &settings)?;
    let samples = settings.max_samples.max(1);
    let mut session = Session::from_scene(ctx, scene, settings)?;
    let mut frame = HostFrame::new(width, rows.len() as u32);
    let total = frame.sums.len() as u64 * samples as u64;
    let mut done = 0;
    for k in 0..samples {
        session.trace_rows_as_tiles(ctx, rows.clone(), k, &mut frame, &mut |n| {
            done += n;
            progress(done, total);
        })?;
    }
    Ok(Tile { key, spec, width, height, rows, pixels: frame.image().pixels })
}

/// What [`write_tile`] did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Written {
    New,
    /// The same tile of the same render was there: left as it was.
    AlreadyThere,
}

/// Whether tile `spec` of the render `key` is already in `dir` (then a farm task has nothing to
/// do); an error if another render's tile has its name.
pub fn tile_done(dir: &Path, spec: TileSpec, key: u64, [width, height]: [u32; 2]) -> Result<bool, FarmError> {
    let path = dir.join(Tile::file_name(spec));
    let Ok(bytes) = std::fs::read(&path) else { return Ok(false) };
    let old = Tile::decode(&bytes, true).map_err(|why| FarmError::BadTile { path: path.clone(), why })?;
    let ours = Tile { key, spec, width, height, rows: old.rows.clone(), pixels: Vec::new() };
    match old.differs(&ours) {
        None => Ok(true),
        Some(why) => Err(FarmError::Foreign { dir: dir.into(), index: spec.index, count: spec.count, why }),
    }
}

/// Writes `tile` into `dir` (made if missing) atomically: a task killed mid-write leaves no
/// tile, only a temporary file the next write replaces. A tile already there of the same
/// render is left alone.
pub fn write_tile(dir: &Path, tile: &Tile) -> Result<Written, FarmError> {
    if tile_done(dir, tile.spec, tile.key, [tile.width, tile.height])? {
        return Ok(Written::AlreadyThere);
    }
    std::fs::create_dir_all(dir).map_err(|e| FarmError::Io(format!("creating {}: {e}", dir.display())))?;
    let path = dir.join(Tile::file_name(tile.spec));
    match create_whole(&path, &tile.encode()) {
        Ok(true) => Ok(Written::New),
        // Another task of the farm wrote it meanwhile: the same render's tile, or an error.
        Ok(false) => match tile_done(dir, tile.spec, tile.key, [tile.width, tile.height])? {
            true => Ok(Written::AlreadyThere),
            false => Err(FarmError::Io(format!(
                "{} appeared while this tile was traced, unreadable",
                path.display()
            ))),
        },
        Err(e) => Err(FarmError::Io(format!("writing {}: {e}", path.display()))),
    }
}

/// Creates `path` holding `bytes`, whole or not at all, even if the process is killed midway:
/// the bytes go to an unnamed file in the directory (`O_TMPFILE`), which is given its name only
/// once complete and synced, and which the kernel removes if the process dies first. `false`
/// if `path` exists (it is never replaced). File systems without unnamed files (NFS) get a
/// named temporary file instead, which a kill can leave behind (never under the tile's name).
fn create_whole(path: &Path, bytes: &[u8]) -> std::io::Result<bool> {
    use std::io::Write as _;
    use std::os::unix::ffi::OsStrExt as _;
    use std::os::unix::fs::OpenOptionsExt as _;
    use std::os::unix::io::AsRawFd as _;
    let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let exists = |e: &std::io::Error| e.kind() == std::io::ErrorKind::AlreadyExists;
    match std::fs::OpenOptions::new().write(true).mode(0o644).custom_flags(libc::O_TMPFILE).open(dir) {
        Ok(mut f) => {
            f.write_all(bytes)?;
            f.sync_all()?;
            let from = std::ffi::CString::new(format!("/proc/self/fd/{}", f.as_raw_fd())).expect("no NUL");
            let to = std::ffi::CString::new(path.as_os_str().as_bytes())
                .map_err(|_| std::io::Error::new(std::io::ErrorKind::InvalidInput, "a NUL in the path"))?;
            // SAFETY: two NUL-terminated paths that outlive the call.
            let r = unsafe {
                libc::linkat(
                    libc::AT_FDCWD,
                    from.as_ptr(),
                    libc::AT_FDCWD,
                    to.as_ptr(),
                    libc::AT_SYMLINK_FOLLOW,
                )
            };
            match r {
                0 => Ok(true),
                _ => {
                    let e = std::io::Error::last_os_error();
                    if exists(&e) {
                        Ok(false)
                    } else {
                        Err(e)
                    }
                }
            }
        }
        Err(_) => {
            let name = path.file_name().map_or(String::new(), |n| n.to_string_lossy().into_owned());
            let tmp = dir.join(format!(".{name}.{}.partial", std::process::id()));
            let result = (|| {
                let mut f = std::fs::File::create(&tmp)?;
                f.write_all(bytes)?;
                f.sync_all()?;
                match std::fs::hard_link(&tmp, path) {
                    Ok(()) => Ok(true),
                    Err(e) if exists(&e) => Ok(false),
                    Err(e) => Err(e),
                }
            })();
            let _ = std::fs::remove_file(&tmp);
            result
        }
    }
}

/// The picture of the tiles in `dir`: refused while any is missing or when they belong to
/// different renders.
pub fn merge(dir: &Path) -> Result<Image, FarmError> {
    let entries =
        std::fs::read_dir(dir).map_err(|e| FarmError::Io(format!("reading {}: {e}", dir.display())))?;
    let mut paths: Vec<PathBuf> = entries
        .flatten()
        .map(|e| e.path())
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with("tile-") && n.ends_with(".irt-tile"))
        })
        .collect();
    paths.sort();
    let read = |p: &Path, header_only| {
        let bytes = std::fs::read(p).map_err(|e| FarmError::Io(format!("reading {}: {e}", p.display())))?;
        Tile::decode(&bytes, header_only).map_err(|why| FarmError::BadTile { path: p.into(), why })
    };
    // Headers first: nothing is read in full, nor written, until every tile is there.
    let mut headers = Vec::with_capacity(paths.len());
    for p in &paths {
        headers.push((p.clone(), read(p, true)?));
    }
    let Some((first_path, first)) = headers.first().cloned() else {
        return Err(FarmError::NoTiles { dir: dir.into() });
    };
    for (p, t) in &headers {
        if let Some(why) = first.differs(t) {
            let name = |p: &Path| p.file_name().map_or(String::new(), |n| n.to_string_lossy().into_owned());
            return Err(FarmError::Mixed { dir: dir.into(), first: name(&first_path), other: name(p), why });
        }
    }
    let count = first.spec.count;
    let missing: Vec<u32> = (0..count).filter(|i| !headers.iter().any(|(_, t)| t.spec.index == *i)).collect();
    if !missing.is_empty() {
        let list = missing.iter().map(u32::to_string).collect::<Vec<_>>().join(", ");
        return Err(FarmError::Missing { dir: dir.into(), missing: missing.len(), count, list });
    }
    let (width, height) = (first.width, first.height);
    let mut pixels = vec![[0.0; 3]; width as usize * height as usize];
    for (p, h) in &headers {
        let t = read(p, false)?;
        let start = (h.rows.start * width) as usize;
        pixels[start..start + t.pixels.len()].copy_from_slice(&t.pixels);
    }
    Ok(Image { width, height, pixels })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tiles_cover_every_row_once_in_whole_tile_rows() {
        for height in [1u32, 2, 3, 17, 120, 481] {
            let rows = height.div_ceil(TILE_H);
            for count in (1..=rows).filter(|n| [1, 2, 3, 7, rows].contains(n)) {
                let mut next = 0;
                for index in 0..count {
                    let r = tile_rows(height, TileSpec { index, count }).unwrap();
                    assert_eq!(r.start, next, "{height} {index}/{count}");
                    assert!(r.start.is_multiple_of(TILE_H) && r.end > r.start);
                    next = r.end;
                }
                assert_eq!(next, height);
            }
            assert!(matches!(
                tile_rows(height, TileSpec { index: 0, count: rows + 1 }),
                Err(FarmError::TooManyTiles { .. })
            ));
        }
    }

    /// A particle file whose bytes change between two tiles' runs makes them another render.
    #[test]
    fn the_key_holds_the_particle_files_bytes() {
        let dir = std::env::temp_dir().join(format!("irt-farm-key-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("p.ply");
        let write = |z: f32| {
            let table = crate::io::ply::PointTable {
                positions: vec![[0.0, 0.0, 0.0], [1.0, 0.0, z]],
                fields: vec![("f".into(), vec![1.0, 2.0])],
            };
            crate::io::ply::write_points(
                &table,
                crate::io::ply::Encoding::Ascii,
                std::fs::File::create(&file).unwrap(),
            )
            .unwrap();
        };
        write(0.0);
        let scene = crate::io::load(&file).unwrap();
        let settings = Settings::default();
        let key = render_key(&scene, &settings).unwrap();
        assert_eq!(render_key(&scene, &settings).unwrap(), key);
        write(0.5);
        assert_ne!(render_key(&scene, &settings).unwrap(), key, "the file changed");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn tile_specs_parse_and_refuse_in_words() {
        assert_eq!("3/7".parse::<TileSpec>().unwrap(), TileSpec { index: 3, count: 7 });
        for bad in ["7/7", "1/0", "x/2", "3", "-1/4", ""] {
            let e = bad.parse::<TileSpec>().unwrap_err().to_string();
            assert!(e.contains("tile"), "{bad}: {e}");
        }
    }

    #[test]
    fn a_tile_file_round_trips_and_a_damaged_one_is_refused() {
        let t = Tile {
            key: 0xfeed,
            spec: TileSpec { index: 1, count: 3 },
            width: 3,
            height: 6,
            rows: 2..4,
            pixels: (0..6).map(|i| [i as f32, 0.5, -1.0]).collect(),
        };
        assert_eq!(tile_rows(6, t.spec).unwrap(), 2..4);
        let b = t.encode();
        assert_eq!(Tile::decode(&b, false).unwrap(), t);
        assert!(matches!(Tile::decode(&b[..b.len() - 1], false), Err(TileDecodeError::Length { .. })));
        assert!(Tile::decode(b"not a tile at all, no", false).is_err());
        let mut wrong_rows = b.clone();
        wrong_rows[36] = 9;
        assert!(matches!(Tile::decode(&wrong_rows, true), Err(TileDecodeError::Header { .. })));
    }
}
