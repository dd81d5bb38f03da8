//! Scene files → [`crate::scene::Scene`]. Errors name the file and the place in it (line and
//! column; for glTF, the JSON object).
//!
//! [`load`] picks a parser by file extension from [`FORMATS`]; each parser turns the file into a
//! validated [`Scene`] and reports problems as a [`LoadError`] pointing at the offending value.

pub mod gltf;
pub mod nff;
pub mod obj;
pub mod ply;
pub mod png;
mod scalar;
pub mod shapes;
pub mod spd;
pub mod stage;
pub mod stress_plate;
pub mod toml;
pub mod toml_write;
pub mod volume;

use crate::scene::{InvalidScene, Scene};
use glam::DVec3;
use std::io::Read;
use std::path::Path;

/// Files above this size are refused before reading. Text formats are parsed into a document
/// tree that costs tens of bytes per number, so this already means gigabytes of memory; meshes
/// that need more belong in a binary format.
pub const MAX_SCENE_FILE_BYTES: u64 = 256 << 20;
/// Loader limits on counts, well inside what the GPU records can index (`PrimRef` has 30 bits),
/// so that a typo (an icosphere in a loop, a runaway generator) is an error and not a hang.
pub const MAX_SPHERES: usize = 1 << 24;
/// Spheres a particle file (or all of a scene's together) may hold: past the paper's 35 million
/// (PAPER.md §9), 2.7 GB of host spheres, well inside `PrimRef`'s 30 bits.
pub const MAX_PARTICLES: usize = 1 << 26;
pub const MAX_TRIANGLES: usize = 1 << 24;
pub const MAX_VERTICES: usize = 1 << 24;
pub const MAX_CONES: usize = 1 << 22;
pub const MAX_MATERIALS: usize = 1 << 16;

/// Why a scene could not be loaded, with the position in the file when one is known.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{path}{}: {message}", position(*.line, *.column))]
pub struct LoadError {
    /// The file (or a description such as `<built-in default scene>`).
    pub path: String,
    /// 1-based line.
    pub line: Option<usize>,
    /// 1-based column, counted in characters.
    pub column: Option<usize>,
    pub message: String,
}

fn position(line: Option<usize>, column: Option<usize>) -> String {
    match (line, column) {
        (Some(l), Some(c)) => format!(":{l}:{c}"),
        (Some(l), None) => format!(":{l}"),
        _ => String::new(),
    }
}

impl LoadError {
    /// An error about the file as a whole.
    pub fn new(path: &str, message: impl Into<String>) -> Self {
        LoadError { path: path.into(), line: None, column: None, message: message.into() }
    }

    /// An error at byte `offset` of `src`.
    pub fn at(path: &str, src: &str, offset: usize, message: impl Into<String>) -> Self {
        let (line, column) = line_column(src, offset);
        LoadError { line: Some(line), column: Some(column), ..Self::new(path, message) }
    }
}

/// 1-based line and character column of byte `offset` in `src`. Offsets past the end or inside
/// a character are moved back to a character start, so any offset is safe.
pub fn line_column(src: &str, offset: usize) -> (usize, usize) {
    let mut offset = offset.min(src.len());
    while !src.is_char_boundary(offset) {
        offset -= 1;
    }
    let before = &src[..offset];
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    (before.matches('\n').count() + 1, before[line_start..].chars().count() + 1)
}

/// Parses a model file's bytes (`origin` as for [`Format::parse`]) into geometry and materials.
pub type ModelParser = fn(&[u8], &str) -> Result<stage::Model, LoadError>;

/// A scene file format: the extensions it claims, the largest file it reads (refused before
/// reading) and its parser (`bytes`, `origin` for messages; `origin` is the file's path, and glTF
/// finds external buffers relative to it). Model formats also give their geometry and
/// materials alone (`model`), which a TOML scene's `[[model]]` places.
pub struct Format {
    pub name: &'static str,
    pub extensions: &'static [&'static str],
    pub max_bytes: u64,
    pub parse: fn(&[u8], &str) -> Result<Scene, LoadError>,
    pub model: Option<ModelParser>,
}

/// Every format [`load`] understands, tried in order by extension.
pub const FORMATS: &[Format] = &[
    Format {
        name: "TOML",
        extensions: &["toml"],
        max_bytes: MAX_SCENE_FILE_BYTES,
        parse: parse_toml,
        model: None,
    },
    Format {
        name: "glTF 2.0",
        extensions: &["gltf", "glb"],
        max_bytes: MAX_SCENE_FILE_BYTES,
        parse: gltf::parse,
        model: Some(gltf_model),
    },
    // NFF is read line by line, not into a tree: its limit is its own (src/io/nff.rs).
    Format {
        name: "NFF",
        extensions: &["nff"],
        max_bytes: nff::MAX_FILE_BYTES,
        parse: parse_nff,
        model: None,
    },
    // Its limit is its own: the largest mesh irt takes, as text (src/io/obj.rs says why).
    Format {
        name: "Wavefront OBJ",
        extensions: &["obj"],
        max_bytes: obj::MAX_FILE_BYTES,
        parse: obj::parse,
        model: Some(obj::parse_model),
    },
    // Binary PLY is the format of big scans; its limit is its own (src/io/ply.rs says why).
    Format {
        name: "PLY",
        extensions: &["ply"],
        max_bytes: ply::MAX_FILE_BYTES,
        parse: ply::parse,
        model: Some(ply::parse_model),
    },
];

fn parse_toml(bytes: &[u8], origin: &str) -> Result<Scene, LoadError> {
    toml::parse_str(utf8(bytes, origin)?, origin)
}

/// A glTF file's meshes, materials and textures, without its camera and lights.
fn gltf_model(bytes: &[u8], origin: &str) -> Result<stage::Model, LoadError> {
    let scene = gltf::parse(bytes, origin)?;
    Ok(stage::Model {
        meshes: scene.meshes,
        materials: scene.materials,
        textures: scene.textures,
        motions: scene.motions,
        ..Default::default()
    })
}

fn parse_nff(bytes: &[u8], origin: &str) -> Result<Scene, LoadError> {
    nff::parse_str(utf8(bytes, origin)?, origin)
}

/// A vertex normal as loaders keep it: unchanged when it is unit length to within 1e-14 (so a
/// scene written by `irt convert` loads back bit for bit), else normalised; None when zero or
/// not finite.
pub fn unit_normal(n: DVec3) -> Option<DVec3> {
    if (n.length_squared() - 1.0).abs() <= 1e-14 {
        return Some(n);
    }
    n.try_normalize()
}

/// The text of a text format, or an error at the first byte that is not UTF-8.
pub(crate) fn utf8<'a>(bytes: &'a [u8], origin: &str) -> Result<&'a str, LoadError> {
    std::str::from_utf8(bytes).map_err(|e| {
        let valid = std::str::from_utf8(&bytes[..e.valid_up_to()]).unwrap_or_default();
        LoadError::at(origin, valid, valid.len(), "the file is not valid UTF-8 text")
    })
}

/// `base`, or `base (2)`, `base (3)`, … : the first that is not `taken` (loaders name materials
/// and textures after what the file calls them, and scene names must be unique).
pub(crate) fn unique_name(base: String, taken: impl Fn(&str) -> bool) -> String {
    let mut name = base.clone();
    let mut k = 2;
    while taken(&name) {
        name = format!("{base} ({k})");
        k += 1;
    }
    name
}

/// Loads and validates a scene file, choosing the format by its extension.
pub fn load(path: &Path) -> Result<Scene, LoadError> {
    load_with_limit(path, u64::MAX)
}

/// [`load`] with a size limit in bytes below the format's own (tests use a small one).
pub fn load_with_limit(path: &Path, max_bytes: u64) -> Result<Scene, LoadError> {
    let origin = path.display().to_string();
    if volume::is_volume(path) {
        return load_volume_staged(path);
    }
    let format = format_of(path).ok_or_else(|| {
        let supported: Vec<String> = FORMATS
            .iter()
            .flat_map(|f| f.extensions.iter().map(move |e| format!(".{e} ({})", f.name)))
            .collect();
        LoadError::new(&origin, format!("unknown scene file extension; supported: {}", supported.join(", ")))
    })?;
    let bytes = read_limited(path, max_bytes.min(format.max_bytes), "scene file")
        .map_err(|m| LoadError::new(&origin, m))?;
    (format.parse)(&bytes, &origin)
}

/// A volume file alone on the default stage: its isosurface halfway through its samples' range
/// (`--iso` picks another), in the default volume material, framed and lit as a model is.
fn load_volume_staged(path: &Path) -> Result<Scene, LoadError> {
    let grid = volume::load(path)?;
    let iso = toml::volume::default_iso(&grid);
    let mut scene = stage::stage(stage::Model::default());
    let material = toml::volume::default_material(&mut scene);
    let v = crate::scene::volume::Volume::new(
        std::sync::Arc::new(grid),
        glam::DAffine3::IDENTITY,
        vec![crate::scene::volume::Iso { value: iso, material }],
        Some(path.to_path_buf()),
    );
    let model = stage::Model { volumes: vec![v], materials: scene.materials, ..Default::default() };
    let scene = stage::stage(model);
    scene.validate().map_err(|e| LoadError::new(&path.display().to_string(), e.to_string()))?;
    Ok(scene)
}

/// Loads a model file (a format with a `model` parser: what `[[model]]` accepts) as geometry
/// and materials without a stage.
pub fn load_model(path: &Path) -> Result<stage::Model, LoadError> {
    let origin = path.display().to_string();
    let models = || {
        let names: Vec<String> = FORMATS
            .iter()
            .filter(|f| f.model.is_some())
            .flat_map(|f| f.extensions.iter().map(move |e| format!(".{e} ({})", f.name)))
            .collect();
        LoadError::new(&origin, format!("not a model file; models are {}", names.join(", ")))
    };
    let format = format_of(path).ok_or_else(models)?;
    let parse = format.model.ok_or_else(models)?;
    let bytes = read_limited(path, format.max_bytes, "model file").map_err(|m| LoadError::new(&origin, m))?;
    parse(&bytes, &origin)
}

fn format_of(path: &Path) -> Option<&'static Format> {
    let ext = path.extension()?.to_str()?;
    FORMATS.iter().find(|f| f.extensions.iter().any(|e| e.eq_ignore_ascii_case(ext)))
}

/// Why [`read_limited`] read no bytes. The messages do not name the file: callers put them
/// after its name (a [`LoadError`], a warning).
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    #[error("cannot read the {what}: {error}")]
    Io { what: &'static str, error: std::io::Error },
    /// Too big by its metadata.
    #[error("{what} is {size} bytes; {what}s are limited to {max_bytes} bytes")]
    TooBig { what: &'static str, size: u64, max_bytes: u64 },
    /// Too big by the bytes read: a file whose size is not known up front (a pipe).
    #[error("{what} is more than {max_bytes} bytes; {what}s are limited to {max_bytes} bytes")]
    TooLong { what: &'static str, max_bytes: u64 },
}

/// Its message, for a [`LoadError`] (`LoadError::new(origin, e)`), whose message is text.
impl From<ReadError> for String {
    fn from(e: ReadError) -> String {
        e.to_string()
    }
}

/// Reads at most `max_bytes` of a `what` (a "scene file", a glTF buffer "file"). The metadata
/// check refuses big files without touching them; the bounded read also catches files whose size
/// is not known up front (pipes, `/dev/zero`).
pub(crate) fn read_limited(path: &Path, max_bytes: u64, what: &'static str) -> Result<Vec<u8>, ReadError> {
    let cannot = |error| ReadError::Io { what, error };
    let file = std::fs::File::open(path).map_err(cannot)?;
    let size = file.metadata().map_err(cannot)?.len();
    if size > max_bytes {
        return Err(ReadError::TooBig { what, size, max_bytes });
    }
    let mut bytes = Vec::with_capacity(size as usize);
    file.take(max_bytes.saturating_add(1)).read_to_end(&mut bytes).map_err(cannot)?;
    if bytes.len() as u64 > max_bytes {
        return Err(ReadError::TooLong { what, max_bytes });
    }
    Ok(bytes)
}

// ---- Loading for commands ------------------------------------------------------------------

/// Files from this size on get a spinner while they are read and parsed.
const SPINNER_FROM_BYTES: u64 = 16 << 20;

/// Scenes from this many primitives on show setup progress and timings; smaller ones set up in
/// milliseconds and log them (`RUST_LOG=info`).
pub const LARGE_SCENE_PRIMITIVES: usize = 200_000;

/// A line about loading or setting up a scene of `primitives`: on stderr for large scenes (whose
/// user is waiting), else logged.
pub fn report(primitives: usize, line: String) {
    if primitives >= LARGE_SCENE_PRIMITIVES {
        eprintln!("{line}");
    } else {
        log::info!("{line}");
    }
}

/// The scene a command names, else the built-in default scene: [`load`], with a spinner on a
/// terminal while a large file is read and parsed, and what it took reported.
pub fn load_or_default(path: Option<&Path>) -> Result<Scene, LoadError> {
    let Some(path) = path else { return Ok(crate::scene::default_scene()) };
    let size = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
    let bar = if size >= SPINNER_FROM_BYTES {
        let bar = indicatif::ProgressBar::new_spinner();
        bar.set_style(
            indicatif::ProgressStyle::with_template("{spinner} {msg} {elapsed}").expect("valid template"),
        );
        bar.set_message(format!("loading {} ({} MiB)", path.display(), size >> 20));
        bar.enable_steady_tick(std::time::Duration::from_millis(120));
        bar
    } else {
        indicatif::ProgressBar::hidden()
    };
    let t = std::time::Instant::now();
    let scene = load(path);
    bar.finish_and_clear();
    let scene = scene?;
    report(
        scene.primitive_count(),
        format!(
            "loaded {} in {:.2} s: {} spheres, {} triangles, {} cones",
            path.display(),
            t.elapsed().as_secs_f64(),
            scene.spheres.len(),
            scene.triangle_count(),
            scene.cones.len()
        ),
    );
    Ok(scene)
}

/// Why [`check_renderable`] refused a scene (named `origin`).
#[derive(Debug, PartialEq, thiserror::Error)]
pub enum Unrenderable {
    #[error("{origin} cannot be rendered: {error}")]
    Invalid { origin: String, error: InvalidScene },
    #[error("{origin} has no primitives: nothing to render")]
    Empty { origin: String },
}

/// Whether `scene` (named `origin` in the message) can be rendered: valid, and not empty.
pub fn check_renderable(scene: &Scene, origin: &str) -> Result<(), Unrenderable> {
    scene.validate().map_err(|error| Unrenderable::Invalid { origin: origin.into(), error })?;
    if scene.primitive_count() == 0 {
        return Err(Unrenderable::Empty { origin: origin.into() });
    }
    Ok(())
}
