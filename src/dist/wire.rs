//! What the ranks say to each other, as bytes: plain little-endian records, no MPI here, so every
//! message round-trips in unit tests. The distributed layer (`dist::master`, `dist::worker`)
//! sends them with one tag per kind ([`Tag`]).

use crate::render::{Mode, PixelOrder, Schedule, Settings};
use crate::scene::Camera;
use glam::DVec3;

/// Bumped whenever a message's layout changes: ranks of another protocol or build refuse to
/// work together ([`Hello`]).
pub const PROTOCOL: u32 = 3;

/// The MPI tag of each kind of message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(i32)]
pub enum Tag {
    /// Worker → master: who it is and what it runs on, or why it cannot ([`Hello`]).
    Hello = 1,
    /// Master → worker: the scene ([`SceneMsg`]).
    Scene = 2,
    /// Worker → master: the scene is loaded and set up on its device ([`Ready`]).
    Ready = 3,
    /// Master → worker: the camera, settings and time ([`State`]).
    State = 4,
    /// Master → worker: a piece of work ([`Work`]).
    Work = 5,
    /// Worker → master: its pixels ([`Pixels`]).
    Pixels = 6,
    /// Master → worker: the job is over.
    Bye = 7,
    /// Master → worker: a part of a file the worker asked for in [`Ready::need`] ([`FilePart`]).
    File = 8,
}

impl Tag {
    pub fn code(self) -> i32 {
        self as i32
    }
}

/// A message that does not decode: a truncated or foreign record.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
#[error("a {what} message does not decode: {why}")]
pub struct WireError {
    pub what: &'static str,
    pub why: String,
}

/// Little-endian record writer.
#[derive(Default)]
pub struct Writer(pub Vec<u8>);

impl Writer {
    pub fn u8(&mut self, v: u8) -> &mut Self {
        self.0.push(v);
        self
    }
    pub fn u32(&mut self, v: u32) -> &mut Self {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }
    pub fn u64(&mut self, v: u64) -> &mut Self {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }
    pub fn f32(&mut self, v: f32) -> &mut Self {
        self.u32(v.to_bits())
    }
    pub fn f64(&mut self, v: f64) -> &mut Self {
        self.u64(v.to_bits())
    }
    pub fn bool(&mut self, v: bool) -> &mut Self {
        self.u8(v as u8)
    }
    pub fn bytes(&mut self, v: &[u8]) -> &mut Self {
        self.u64(v.len() as u64);
        self.0.extend_from_slice(v);
        self
    }
    pub fn str(&mut self, v: &str) -> &mut Self {
        self.bytes(v.as_bytes())
    }
    pub fn vec3(&mut self, v: DVec3) -> &mut Self {
        self.f64(v.x).f64(v.y).f64(v.z)
    }
    /// `None` as 0, `Some(v)` as 1 and `v`.
    pub fn opt<T>(&mut self, v: Option<T>, put: impl FnOnce(&mut Self, T)) -> &mut Self {
        match v {
            None => self.u8(0),
            Some(v) => {
                self.u8(1);
                put(self, v);
                self
            }
        }
    }
}

/// Little-endian record reader: every read checks what is left.
pub struct Reader<'a> {
    bytes: &'a [u8],
    what: &'static str,
}

impl<'a> Reader<'a> {
    pub fn new(bytes: &'a [u8], what: &'static str) -> Self {
        Reader { bytes, what }
    }
    fn fail(&self, why: impl Into<String>) -> WireError {
        WireError { what: self.what, why: why.into() }
    }
    fn take(&mut self, n: usize) -> Result<&'a [u8], WireError> {
        if self.bytes.len() < n {
            return Err(self.fail(format!("{} bytes short", n - self.bytes.len())));
        }
        let (a, b) = self.bytes.split_at(n);
        self.bytes = b;
        Ok(a)
    }
    pub fn u8(&mut self) -> Result<u8, WireError> {
        Ok(self.take(1)?[0])
    }
    pub fn u32(&mut self) -> Result<u32, WireError> {
        Ok(u32::from_le_bytes(self.take(4)?.try_into().expect("4 bytes")))
    }
    pub fn u64(&mut self) -> Result<u64, WireError> {
        Ok(u64::from_le_bytes(self.take(8)?.try_into().expect("8 bytes")))
    }
    pub fn f32(&mut self) -> Result<f32, WireError> {
        Ok(f32::from_bits(self.u32()?))
    }
    pub fn f64(&mut self) -> Result<f64, WireError> {
        Ok(f64::from_bits(self.u64()?))
    }
    pub fn bool(&mut self) -> Result<bool, WireError> {
        match self.u8()? {
            0 => Ok(false),
            1 => Ok(true),
            b => Err(self.fail(format!("{b} is not a boolean"))),
        }
    }
    pub fn bytes(&mut self) -> Result<&'a [u8], WireError> {
        let n = self.u64()?;
        let n = usize::try_from(n).map_err(|_| self.fail(format!("a length of {n}")))?;
        self.take(n)
    }
    pub fn str(&mut self) -> Result<&'a str, WireError> {
        let b = self.bytes()?;
        std::str::from_utf8(b).map_err(|_| self.fail("text that is not UTF-8"))
    }
    pub fn vec3(&mut self) -> Result<DVec3, WireError> {
        Ok(DVec3::new(self.f64()?, self.f64()?, self.f64()?))
    }
    pub fn opt<T>(
        &mut self,
        get: impl FnOnce(&mut Self) -> Result<T, WireError>,
    ) -> Result<Option<T>, WireError> {
        match self.u8()? {
            0 => Ok(None),
            1 => Ok(Some(get(self)?)),
            b => Err(self.fail(format!("{b} is not an option's flag"))),
        }
    }
    /// A value written by its `Display` and read back by its `FromStr` (the command line's
    /// spelling of a schedule, an order, a shadow mode, an accelerator).
    pub fn parsed<T: std::str::FromStr>(&mut self) -> Result<T, WireError>
    where
        T::Err: std::fmt::Display,
    {
        let s = self.str()?;
        s.parse().map_err(|e: T::Err| self.fail(format!("`{s}`: {e}")))
    }
    /// The record ends here.
    pub fn end(self) -> Result<(), WireError> {
        if self.bytes.is_empty() {
            Ok(())
        } else {
            Err(self.fail(format!("{} bytes too many", self.bytes.len())))
        }
    }
}

/// A worker's first word: the protocol and build it speaks, and the device it opened (or why it
/// could not).
#[derive(Clone, Debug, PartialEq)]
pub struct Hello {
    pub protocol: u32,
    /// `CARGO_PKG_VERSION` and the build's id ([`build_id`]).
    pub version: String,
    /// The adapter's name and driver, or why no device opened.
    pub device: Result<String, String>,
}

/// What identifies this build: the package version and the protocol. Two ranks that say
/// different things do not work together.
pub fn build_id() -> String {
    format!("irt {} (protocol {PROTOCOL})", env!("CARGO_PKG_VERSION"))
}

impl Hello {
    pub fn encode(&self) -> Vec<u8> {
        let mut w = Writer::default();
        w.u32(self.protocol).str(&self.version);
        match &self.device {
            Ok(d) => w.u8(0).str(d),
            Err(e) => w.u8(1).str(e),
        };
        w.0
    }
    pub fn decode(b: &[u8]) -> Result<Self, WireError> {
        let mut r = Reader::new(b, "hello");
        let protocol = r.u32()?;
        let version = r.str()?.to_string();
        let device = match r.u8()? {
            0 => Ok(r.str()?.to_string()),
            _ => Err(r.str()?.to_string()),
        };
        r.end()?;
        Ok(Hello { protocol, version, device })
    }
}

/// The scene, as the lossless native TOML, its textures' PNGs (`io::toml_write`) and the files
/// it names that may be too big to send to every worker (particle files): the worker reads such
/// a file where the master did when it holds the same bytes there, else asks for it
/// ([`Ready::need`]). The worker checks the hash of what arrived.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneMsg {
    pub toml: String,
    pub textures: Vec<(String, Vec<u8>)>,
    pub files: Vec<SharedFile>,
    /// [`SceneMsg::content_hash`] of the above, as the master computed it.
    pub hash: u64,
}

/// A file the scene's TOML names by `name` (beside it): where rank 0 read it, and its length
/// and digest ([`super::files::Digest`]), by which a worker knows it sees the same bytes.
#[derive(Clone, Debug, PartialEq)]
pub struct SharedFile {
    pub name: String,
    pub path: String,
    pub len: u64,
    pub digest: u64,
}

impl SceneMsg {
    /// FNV-1a over the TOML, every texture's name and bytes and every shared file's name, length
    /// and digest (its path is where rank 0 read it, not what it holds).
    pub fn content_hash(&self) -> u64 {
        let mut h = 0xcbf2_9ce4_8422_2325u64;
        let mut eat = |b: &[u8]| {
            for &x in b {
                h = (h ^ x as u64).wrapping_mul(0x0100_0000_01b3);
            }
        };
        eat(self.toml.as_bytes());
        for (n, b) in &self.textures {
            eat(n.as_bytes());
            eat(b);
        }
        for f in &self.files {
            eat(f.name.as_bytes());
            eat(&f.len.to_le_bytes());
            eat(&f.digest.to_le_bytes());
        }
        h
    }
    pub fn encode(&self) -> Vec<u8> {
        let mut w = Writer::default();
        w.str(&self.toml).u32(self.textures.len() as u32);
        for (n, b) in &self.textures {
            w.str(n).bytes(b);
        }
        w.u32(self.files.len() as u32);
        for f in &self.files {
            w.str(&f.name).str(&f.path).u64(f.len).u64(f.digest);
        }
        w.u64(self.hash);
        w.0
    }
    pub fn decode(b: &[u8]) -> Result<Self, WireError> {
        let mut r = Reader::new(b, "scene");
        let toml = r.str()?.to_string();
        let n = r.u32()?;
        let mut textures = Vec::new();
        for _ in 0..n {
            textures.push((r.str()?.to_string(), r.bytes()?.to_vec()));
        }
        let n = r.u32()?;
        let mut files = Vec::new();
        for _ in 0..n {
            let (name, path) = (r.str()?.to_string(), r.str()?.to_string());
            files.push(SharedFile { name, path, len: r.u64()?, digest: r.u64()? });
        }
        let hash = r.u64()?;
        r.end()?;
        Ok(SceneMsg { toml, textures, files, hash })
    }
}

/// A part of shared file `index` of the newest scene, at `offset`: the parts of a file come in
/// order (MPI keeps a pair's messages in order), each at most [`super::files::PART_BYTES`].
#[derive(Clone, Debug, PartialEq)]
pub struct FilePart {
    pub index: u32,
    pub offset: u64,
    pub bytes: Vec<u8>,
}

impl FilePart {
    pub fn encode(&self) -> Vec<u8> {
        let mut w = Writer::default();
        w.u32(self.index).u64(self.offset).bytes(&self.bytes);
        w.0
    }
    pub fn decode(b: &[u8]) -> Result<Self, WireError> {
        let mut r = Reader::new(b, "file part");
        let (index, offset) = (r.u32()?, r.u64()?);
        let bytes = r.bytes()?.to_vec();
        r.end()?;
        Ok(FilePart { index, offset, bytes })
    }
}

/// A worker's scene is set up: the hash of what it received (the master compares) and what
/// setting it up took.
#[derive(Clone, Debug, PartialEq)]
pub struct Ready {
    pub hash: u64,
    /// Why the scene could not be loaded or set up on the device (`None`: it was).
    pub error: Option<String>,
    /// The shared files the worker cannot read where rank 0 did, each with why: rank 0 sends
    /// them ([`FilePart`]) and the worker says it is ready again. Empty: the scene is set up.
    pub need: Vec<(u32, String)>,
}

impl Ready {
    pub fn encode(&self) -> Vec<u8> {
        let mut w = Writer::default();
        w.u64(self.hash).opt(self.error.as_deref(), |w, e| {
            w.str(e);
        });
        w.u32(self.need.len() as u32);
        for (i, why) in &self.need {
            w.u32(*i).str(why);
        }
        w.0
    }
    pub fn decode(b: &[u8]) -> Result<Self, WireError> {
        let mut r = Reader::new(b, "ready");
        let hash = r.u64()?;
        let error = r.opt(|r| Ok(r.str()?.to_string()))?;
        let mut need = Vec::new();
        for _ in 0..r.u32()? {
            need.push((r.u32()?, r.str()?.to_string()));
        }
        r.end()?;
        Ok(Ready { hash, error, need })
    }
}

/// What a worker's session traces with: a small versioned message, sent as it changes.
#[derive(Clone, Debug, PartialEq)]
pub struct State {
    /// Bumped by the master at every change; work and pixels name the state they belong to.
    pub version: u64,
    pub camera: Camera,
    pub settings: Settings,
    /// The animation's time, in seconds.
    pub time: f64,
}

fn put_camera(w: &mut Writer, c: &Camera) {
    w.vec3(c.eye).vec3(c.look_at).vec3(c.up).f64(c.vfov_deg).u32(c.width).u32(c.height);
}

fn get_camera(r: &mut Reader) -> Result<Camera, WireError> {
    Ok(Camera {
        eye: r.vec3()?,
        look_at: r.vec3()?,
        up: r.vec3()?,
        vfov_deg: r.f64()?,
        width: r.u32()?,
        height: r.u32()?,
    })
}

fn put_mode(w: &mut Writer, m: &Mode) {
    match *m {
        Mode::Bands => {
            w.u8(0);
        }
        Mode::Conventional { schedule, workers } => {
            w.u8(1).str(&schedule.to_string()).u32(workers);
        }
        Mode::Frameless { order, slice, present_every, blend, jitter_pairs } => {
            w.u8(2).str(&order.to_string()).u32(slice).u32(present_every);
            w.opt(blend, |w, a| {
                w.f32(a);
            })
            .bool(jitter_pairs);
        }
    }
}

fn get_mode(r: &mut Reader) -> Result<Mode, WireError> {
    Ok(match r.u8()? {
        0 => Mode::Bands,
        1 => Mode::Conventional { schedule: r.parsed::<Schedule>()?, workers: r.u32()? },
        _ => Mode::Frameless {
            order: r.parsed::<PixelOrder>()?,
            slice: r.u32()?,
            present_every: r.u32()?,
            blend: r.opt(|r| r.f32())?,
            jitter_pairs: r.bool()?,
        },
    })
}

fn put_settings(w: &mut Writer, s: &Settings) {
    put_mode(w, &s.mode);
    w.opt(s.shadows, |w, m| {
        w.str(&m.to_string());
    });
    w.opt(s.light_radius, |w, r| {
        w.f64(r);
    });
    w.opt(s.max_depth, |w, d| {
        w.u32(d);
    });
    w.bool(s.f64).u32(s.max_samples).u32(s.waves).str(&s.accel.to_string());
    w.bool(s.count_rays).bool(s.simd_stats).bool(s.uber_shader).bool(s.corner_rays);
    w.opt(s.max_scene_rows, |w, m| {
        w.u32(m);
    });
    w.opt(s.deal, |w, d| {
        w.u32(d);
    });
    w.opt(s.max_buffer_rays, |w, m| {
        w.u64(m);
    });
}

fn get_settings(r: &mut Reader) -> Result<Settings, WireError> {
    Ok(Settings {
        mode: get_mode(r)?,
        shadows: r.opt(|r| r.parsed())?,
        light_radius: r.opt(|r| r.f64())?,
        max_depth: r.opt(|r| r.u32())?,
        f64: r.bool()?,
        max_samples: r.u32()?,
        waves: r.u32()?,
        accel: r.parsed()?,
        count_rays: r.bool()?,
        simd_stats: r.bool()?,
        uber_shader: r.bool()?,
        corner_rays: r.bool()?,
        max_scene_rows: r.opt(|r| r.u32())?,
        deal: r.opt(|r| r.u32())?,
        max_buffer_rays: r.opt(|r| r.u64())?,
    })
}

impl State {
    pub fn encode(&self) -> Vec<u8> {
        let mut w = Writer::default();
        w.u64(self.version);
        put_camera(&mut w, &self.camera);
        put_settings(&mut w, &self.settings);
        w.f64(self.time);
        w.0
    }
    pub fn decode(b: &[u8]) -> Result<Self, WireError> {
        let mut r = Reader::new(b, "state");
        let version = r.u64()?;
        let camera = get_camera(&mut r)?;
        let settings = get_settings(&mut r)?;
        let time = r.f64()?;
        r.end()?;
        Ok(State { version, camera, settings, time })
    }
}

/// What a piece of work covers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Piece {
    /// Tiles `[first, end)` of the conventional frame's tile grid (a chunk of the schedule).
    Tiles { first: u32, end: u32 },
    /// Positions `[first, first + len)` of the frameless pixel order's pass.
    Slice { first: u64, len: u64 },
}

/// A piece of work: which sample of which state it traces.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Work {
    /// The master's number for it (the pixels come back under it).
    pub id: u64,
    /// The [`State::version`] it belongs to.
    pub state: u64,
    /// The sample index (a conventional frame's, a frameless visit's).
    pub sample: u32,
    pub piece: Piece,
}

impl Work {
    pub fn encode(&self) -> Vec<u8> {
        let mut w = Writer::default();
        w.u64(self.id).u64(self.state).u32(self.sample);
        match self.piece {
            Piece::Tiles { first, end } => w.u8(0).u32(first).u32(end),
            Piece::Slice { first, len } => w.u8(1).u64(first).u64(len),
        };
        w.0
    }
    pub fn decode(b: &[u8]) -> Result<Self, WireError> {
        let mut r = Reader::new(b, "work");
        let (id, state, sample) = (r.u64()?, r.u64()?, r.u32()?);
        let piece = match r.u8()? {
            0 => Piece::Tiles { first: r.u32()?, end: r.u32()? },
            _ => Piece::Slice { first: r.u64()?, len: r.u64()? },
        };
        r.end()?;
        Ok(Work { id, state, sample, piece })
    }
}

/// A piece of work's pixels, in the piece's order (`render::modes::chunk_pixels` for tiles, the
/// order's positions for a slice): rgb radiance, and the most loop iterations any of them ran.
#[derive(Clone, Debug, PartialEq)]
pub struct Pixels {
    pub id: u64,
    pub state: u64,
    pub max_loop_iterations: u32,
    pub values: Vec<[f32; 3]>,
}

impl Pixels {
    pub fn encode(&self) -> Vec<u8> {
        let mut w = Writer::default();
        w.u64(self.id).u64(self.state).u32(self.max_loop_iterations).u64(self.values.len() as u64);
        w.0.reserve(12 * self.values.len());
        for v in &self.values {
            w.f32(v[0]).f32(v[1]).f32(v[2]);
        }
        w.0
    }
    pub fn decode(b: &[u8]) -> Result<Self, WireError> {
        let mut r = Reader::new(b, "pixels");
        let (id, state, max_loop_iterations) = (r.u64()?, r.u64()?, r.u32()?);
        let n = r.u64()? as usize;
        if n > b.len() / 12 {
            return Err(r.fail(format!("{n} pixels in {} bytes", b.len())));
        }
        let mut values = Vec::with_capacity(n);
        for _ in 0..n {
            values.push([r.f32()?, r.f32()?, r.f32()?]);
        }
        r.end()?;
        Ok(Pixels { id, state, max_loop_iterations, values })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::ShadowMode;

    #[test]
    fn every_message_round_trips() {
        let hello = Hello { protocol: PROTOCOL, version: build_id(), device: Ok("llvmpipe (Mesa)".into()) };
        assert_eq!(Hello::decode(&hello.encode()), Ok(hello));
        let failed = Hello { protocol: 0, version: "x".into(), device: Err("no Vulkan".into()) };
        assert_eq!(Hello::decode(&failed.encode()), Ok(failed));
        let textures = vec![("a.png".to_string(), vec![1u8, 2, 3])];
        let files = vec![SharedFile { name: "p.ply".into(), path: "/d/p.ply".into(), len: 9, digest: 4 }];
        let mut scene = SceneMsg { toml: "[camera]".into(), textures, files, hash: 0 };
        scene.hash = scene.content_hash();
        assert_eq!(SceneMsg::decode(&scene.encode()), Ok(scene.clone()));
        // What a file holds is in the hash; where rank 0 read it is not.
        let mut moved = scene.clone();
        moved.files[0].path = "/e/p.ply".into();
        assert_eq!(moved.content_hash(), scene.hash);
        moved.files[0].digest = 5;
        assert_ne!(moved.content_hash(), scene.hash);
        for ready in [
            Ready { hash: 7, error: None, need: vec![] },
            Ready { hash: 0, error: Some("bad".into()), need: vec![] },
            Ready { hash: 0, error: None, need: vec![(0, "no such file".into()), (2, "another".into())] },
        ] {
            assert_eq!(Ready::decode(&ready.encode()), Ok(ready));
        }
        let part = FilePart { index: 1, offset: 1 << 40, bytes: vec![7; 5] };
        assert_eq!(FilePart::decode(&part.encode()), Ok(part));
        let camera = crate::scene::default_scene().camera;
        let modes = [
            Mode::Bands,
            Mode::Conventional { schedule: Schedule::Guided, workers: 3 },
            Mode::Frameless {
                order: PixelOrder::Dissolve,
                slice: 77,
                present_every: 2,
                blend: Some(0.25),
                jitter_pairs: true,
            },
            Mode::frameless(),
        ];
        for mode in modes {
            let settings = Settings {
                mode,
                shadows: Some(ShadowMode::Bundle { samples: 9, rotate: false }),
                light_radius: Some(0.3),
                max_depth: Some(4),
                f64: true,
                max_scene_rows: Some(5),
                deal: Some(0),
                max_buffer_rays: Some(1 << 17),
                ..Settings::default()
            };
            let state = State { version: 9, camera: camera.clone(), settings, time: 1.5 };
            assert_eq!(State::decode(&state.encode()), Ok(state));
        }
        for piece in [Piece::Tiles { first: 3, end: 19 }, Piece::Slice { first: 1 << 33, len: 16384 }] {
            let work = Work { id: 5, state: 2, sample: 7, piece };
            assert_eq!(Work::decode(&work.encode()), Ok(work));
        }
        let pixels =
            Pixels { id: 1, state: 2, max_loop_iterations: 3, values: vec![[1.0, -0.5, f32::MAX]; 3] };
        assert_eq!(Pixels::decode(&pixels.encode()), Ok(pixels));
    }

    /// A cut or padded record is an error naming the message, never a panic or a wrong value.
    #[test]
    fn truncated_and_padded_records_are_refused() {
        let work = Work { id: 5, state: 2, sample: 7, piece: Piece::Tiles { first: 0, end: 1 } }.encode();
        for n in 0..work.len() {
            let e = Work::decode(&work[..n]).unwrap_err();
            assert_eq!(e.what, "work");
        }
        let mut long = work.clone();
        long.push(0);
        assert!(Work::decode(&long).unwrap_err().why.contains("too many"));
        let pixels = Pixels { id: 1, state: 1, max_loop_iterations: 0, values: vec![[0.0; 3]; 4] }.encode();
        let mut lying = pixels.clone();
        lying[20..28].copy_from_slice(&u64::MAX.to_le_bytes());
        assert!(Pixels::decode(&lying).is_err());
    }
}
