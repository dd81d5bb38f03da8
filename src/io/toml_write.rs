//! [`Scene`] → the native TOML format (docs/scene-format.md), losslessly: loading the text gives
//! back the same scene, bit for bit. `irt convert` writes any loadable scene with it.
//!
//! Numbers use Rust's shortest round-trip formatting (`{:?}` on f64: the fewest digits that
//! parse back to the same bits, always with a `.` or an exponent so that TOML reads a float).
//! Meshes are written inline. Every table is a list of `(key, Value)` pairs, so a new primitive
//! is one more loop in [`to_toml`].
//!
//! Textures live in PNG files beside the TOML. [`to_files`] gives the text and every PNG with
//! the file name the text refers to; the caller writes them into one directory. [`to_toml`] is
//! the text alone, for a caller that names (and writes) the texture files itself.

use super::png;
use crate::scene::particles::{Particles, Radius};
use crate::scene::{Channel, Interpolation, MaterialKind, Motion, Rotation, Scene, Stage, Target, Trs};
use glam::{DQuat, DVec2, DVec3};
use std::collections::HashSet;
use std::fmt::Write;

/// A texture [`to_files`] could not encode as PNG.
#[derive(Debug, thiserror::Error)]
#[error("texture '{texture}': {error}")]
pub struct TextureError {
    /// The texture's name in the scene.
    pub texture: String,
    pub error: png::PngError,
}

/// For callers whose errors are still text (`app::viewer::write_scene`).
impl From<TextureError> for String {
    fn from(e: TextureError) -> String {
        e.to_string()
    }
}

/// A scene as the files that hold it: the TOML text and one PNG per texture.
pub struct SceneFiles {
    pub toml: String,
    /// `(file name, PNG bytes)` for each texture, in scene order. The names are plain file
    /// names (no directory); the TOML refers to them relative to its own directory.
    pub textures: Vec<(String, Vec<u8>)>,
}

/// The scene as files, for a TOML file whose name without `.toml` is `stem`: texture `i` goes to
/// `<stem>.<i>.png`, or `<stem>.<i>.<name>.png` with the texture's name made safe
/// ([`texture_file_names`]). PNG is lossless, so loading the files gives back the same texels.
pub fn to_files(scene: &Scene, stem: &str) -> Result<SceneFiles, TextureError> {
    files_naming(scene, stem, None)
}

/// The scene as files for a directory of its own (a worker rank's, which may not see rank 0's
/// file system): as [`to_files`], but particle file `i` named `<stem>.<i>.particles.ply` and
/// volume file `j` `<stem>.<j>.volume.<its extension>` beside the TOML rather than by their paths. Also gives each such name with the file it stands for.
pub fn to_files_beside(
    scene: &Scene,
    stem: &str,
) -> Result<(SceneFiles, Vec<(String, std::path::PathBuf)>), TextureError> {
    let particles: Vec<_> = (0..scene.particles.len()).map(|i| format!("{stem}.{i}.particles.ply")).collect();
    // A volume keeps its file's extension (the loader knows the format by it).
    let volumes: Vec<_> = scene
        .volumes
        .iter()
        .enumerate()
        .map(|(i, v)| {
            let name = v.file.as_ref().and_then(|f| f.file_name()).map(|n| n.to_string_lossy().into_owned());
            let ext = name.as_deref().and_then(|n| n.split_once('.')).map_or("nrrd", |(_, e)| e);
            format!("{stem}.{i}.volume.{ext}")
        })
        .collect();
    let files = files_naming(scene, stem, Some((&particles, &volumes)))?;
    let canonical = |f: &std::path::Path| std::fs::canonicalize(f).unwrap_or(f.to_path_buf());
    let sources = scene
        .particles
        .iter()
        .map(|p| canonical(std::path::Path::new(&p.file)))
        .chain(scene.volumes.iter().map(|v| v.file.as_deref().map(canonical).unwrap_or_default()));
    Ok((files, particles.into_iter().chain(volumes).zip(sources).collect()))
}

/// [`to_files`], particle and volume files named as [`to_toml_naming`] names them.
fn files_naming(
    scene: &Scene,
    stem: &str,
    beside: Option<(&[String], &[String])>,
) -> Result<SceneFiles, TextureError> {
    let names = texture_file_names(scene, stem);
    let textures = scene
        .textures
        .iter()
        .zip(&names)
        .map(|(t, file)| {
            let png = png::encode(t.width, t.height, &t.texels)
                .map_err(|error| TextureError { texture: t.name.clone(), error })?;
            Ok((file.clone(), png))
        })
        .collect::<Result<_, TextureError>>()?;
    Ok(SceneFiles { toml: to_toml_naming(scene, &names, beside), textures })
}

/// File names for the scene's textures, unique (the index) and safe on any file system: the
/// texture's name is kept only in ASCII letters, digits, `-` and `_` (others become `_`, at
/// most 32 of them, a trailing `.png` dropped) and left out when nothing is left of it.
pub fn texture_file_names(scene: &Scene, stem: &str) -> Vec<String> {
    scene
        .textures
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let name = t.name.strip_suffix(".png").or(t.name.strip_suffix(".PNG")).unwrap_or(&t.name);
            let safe: String = name
                .chars()
                .take(32)
                .map(|c| if c.is_ascii_alphanumeric() || c == '-' || c == '_' { c } else { '_' })
                .collect();
            if safe.chars().all(|c| c == '_') {
                format!("{stem}.{i}.png")
            } else {
                format!("{stem}.{i}.{safe}.png")
            }
        })
        .collect()
}

/// A value as the writer lays it out.
enum Value<'a> {
    Float(f64),
    Int(u64),
    Str(&'a str),
    Vec3(DVec3),
    /// `[a, b]` on one line.
    Pair([f64; 2]),
    /// One vector per line (mesh positions and normals).
    Vec3s(&'a [DVec3]),
    /// One `[u, v]` per line (mesh texture coordinates).
    Vec2s(&'a [DVec2]),
    /// `[a, b]` on one line.
    Strs(&'a [&'a str]),
    /// One triangle per line.
    Triangles(&'a [[u32; 3]]),
}

/// The scene as TOML, texture `i` read from `texture_files[i]` (a path relative to the TOML's
/// directory; one per texture). The scene should be valid ([`Scene::validate`]): TOML has no
/// spelling for NaN that the loader would accept, and the loader rejects what `validate` rejects.
pub fn to_toml(scene: &Scene, texture_files: &[String]) -> String {
    to_toml_naming(scene, texture_files, None)
}

/// [`to_toml`], particle file `i` and volume file `j` named `beside.0[i]` and `beside.1[j]` if
/// given, else by their absolute paths.
fn to_toml_naming(scene: &Scene, texture_files: &[String], beside: Option<(&[String], &[String])>) -> String {
    assert_eq!(texture_files.len(), scene.textures.len(), "one file name per texture");
    let names = unique_names(scene.materials.iter().map(|m| m.name.as_str()));
    let texture_names = unique_names(scene.textures.iter().map(|t| t.name.as_str()));
    let mut out = String::from("# An irt scene (docs/scene-format.md).\n");
    entries(&mut out, &[("background", Value::Vec3(scene.background))]);
    let c = &scene.camera;
    table(
        &mut out,
        "[camera]",
        &[
            ("eye", Value::Vec3(c.eye)),
            ("look_at", Value::Vec3(c.look_at)),
            ("up", Value::Vec3(c.up)),
            ("fov", Value::Float(c.vfov_deg)),
            ("width", Value::Int(c.width.into())),
            ("height", Value::Int(c.height.into())),
        ],
    );
    let a = &scene.ambient;
    let ambient = [("sky", Value::Vec3(a.sky)), ("ground", Value::Vec3(a.ground)), ("up", Value::Vec3(a.up))];
    table(&mut out, "[ambient]", &ambient);
    let t = &scene.trace;
    let shadows = if t.soft { "soft".to_string() } else { t.shadows.to_string() };
    #[rustfmt::skip]
    table(&mut out, "[trace]", &[
        ("max_depth", Value::Int(t.max_depth.into())),
        ("weight_cutoff", Value::Float(t.weight_cutoff)),
        ("shadows", Value::Str(&shadows)),
    ]);
    let motion = |out: &mut String, kind: &str, target: Target| {
        if let Some(a) = scene.motions.iter().find(|a| a.target == target) {
            write_motion(out, kind, &a.motion);
        }
    };
    for (i, l) in scene.lights.iter().enumerate() {
        // `intensity` is left at 1: color × 1 is the colour, bit for bit.
        #[rustfmt::skip]
        table(&mut out, "[[light]]", &[
            ("position", Value::Vec3(l.position)),
            ("color", Value::Vec3(l.color)),
            ("radius", Value::Float(l.radius)),
        ]);
        motion(&mut out, "light", Target::Light(i as u32));
    }
    for ((t, name), file) in scene.textures.iter().zip(&texture_names).zip(texture_files) {
        let wrap = t.wrap.map(|w| w.name());
        let mut e = vec![("name", Value::Str(name)), ("file", Value::Str(file))];
        e.push(match wrap {
            [u, v] if u == v => ("wrap", Value::Str(u)),
            _ => ("wrap", Value::Strs(&wrap)),
        });
        e.push(("filter", Value::Str(t.filter.name())));
        table(&mut out, "[[texture]]", &e);
    }
    // A particle file's spheres and levels are written as its `[[particles]]` table.
    let of_particles = |range: fn(&Particles) -> &std::ops::Range<usize>, i: usize| {
        scene.particles.iter().any(|p| range(p).contains(&i))
    };
    for (m, name) in scene
        .materials
        .iter()
        .zip(&names)
        .enumerate()
        .filter(|(i, _)| !of_particles(|p| &p.materials, *i))
        .map(|(_, m)| m)
    {
        let mut e = vec![("name", Value::Str(name))];
        match &m.kind {
            MaterialKind::Diffuse { color } => {
                e.extend([("type", Value::Str("diffuse")), ("color", Value::Vec3(*color))])
            }
            MaterialKind::Metal { color, exponent } => e.extend([
                ("type", Value::Str("metal")),
                ("color", Value::Vec3(*color)),
                ("exponent", Value::Float(*exponent)),
            ]),
            MaterialKind::Dielectric { eta, exponent } => e.extend([
                ("type", Value::Str("dielectric")),
                ("eta", Value::Float(*eta)),
                ("exponent", Value::Float(*exponent)),
            ]),
            MaterialKind::Polished { color, eta, exponent } => e.extend([
                ("type", Value::Str("polished")),
                ("color", Value::Vec3(*color)),
                ("eta", Value::Float(*eta)),
                ("exponent", Value::Float(*exponent)),
            ]),
        }
        if let Some(t) = m.texture {
            e.push(("texture", Value::Str(texture_names.get(t as usize).map_or("", String::as_str))));
        }
        table(&mut out, "[[material]]", &e);
    }
    let material = |index: u32| Value::Str(names.get(index as usize).map_or("", String::as_str));
    for (i, s) in scene.spheres.iter().enumerate() {
        if of_particles(|p| &p.spheres, i) {
            continue;
        }
        #[rustfmt::skip]
        table(&mut out, "[[sphere]]", &[
            ("center", Value::Vec3(s.center)),
            ("radius", Value::Float(s.radius)),
            ("material", material(s.material)),
        ]);
        motion(&mut out, "sphere", Target::Sphere(i as u32));
    }
    for (i, c) in scene.cones.iter().enumerate() {
        #[rustfmt::skip]
        table(&mut out, "[[cone]]", &[
            ("base", Value::Vec3(c.base)),
            ("base_radius", Value::Float(c.base_radius)),
            ("apex", Value::Vec3(c.apex)),
            ("apex_radius", Value::Float(c.apex_radius)),
            ("material", material(c.material)),
        ]);
        motion(&mut out, "cone", Target::Cone(i as u32));
    }
    for (i, m) in scene.meshes.iter().enumerate() {
        let mut e = vec![
            ("material", material(m.material)),
            ("positions", Value::Vec3s(&m.positions)),
            ("indices", Value::Triangles(&m.indices)),
        ];
        if let Some(n) = &m.normals {
            e.push(("normals", Value::Vec3s(n)));
        }
        if let Some(uv) = &m.uvs {
            e.push(("uvs", Value::Vec2s(uv)));
        }
        table(&mut out, "[[mesh]]", &e);
        motion(&mut out, "mesh", Target::Mesh(i as u32));
    }
    for (i, p) in scene.particles.iter().enumerate() {
        let file = match beside {
            Some((names, _)) => names[i].clone(),
            None => std::fs::canonicalize(&p.file).map_or(p.file.clone(), |f| f.display().to_string()),
        };
        write_particles(&mut out, p, &file);
    }
    let material_name = |index: u32| names.get(index as usize).cloned().unwrap_or_default();
    for (i, v) in scene.volumes.iter().enumerate() {
        let file = match beside {
            Some((_, names)) => names[i].clone(),
            None => v.file.as_ref().map_or(String::new(), |f| {
                std::fs::canonicalize(f).map_or(f.display().to_string(), |f| f.display().to_string())
            }),
        };
        super::toml::volume::write(&mut out, v, &file, &material_name);
    }
    for p in &scene.patches {
        super::toml::patch::write(&mut out, p, &material_name(p.material));
    }
    out
}

/// A `[[particles]]` table: the file as `file` names it (by default its absolute path: the TOML
/// may be written anywhere), and the style with the field and range it resolved to, so that the
/// file is drawn as it was.
fn write_particles(out: &mut String, p: &Particles, file: &str) {
    let mut e = vec![("file", Value::Str(file))];
    match &p.style.radius {
        Radius::Auto => {}
        Radius::Value(r) => e.push(("radius", Value::Float(*r))),
        Radius::Field(f) => e.push(("radius", Value::Str(f))),
    }
    if let Some(l) = &p.legend {
        e.extend([("field", Value::Str(&l.field)), ("map", Value::Str(l.map.name()))]);
        // A field of one value has no rising range to write; it is found again from the file.
        if l.lo < l.hi {
            e.push(("range", Value::Pair([l.lo, l.hi])));
        }
    }
    e.extend([
        ("scale", Value::Float(p.scale)),
        ("rotate", Value::Vec3(p.rotate_deg)),
        ("translate", Value::Vec3(p.translate)),
    ]);
    table(out, "[[particles]]", &e);
}

/// `[[kind.motion]]` stages: a fixed stage as its `matrix`, a keyed one with its held values
/// as keys and each channel as a `[kind.motion.property]` sub-table (tangents written out, so a
/// cubic channel loads back bit for bit).
fn write_motion(out: &mut String, kind: &str, m: &Motion) {
    for stage in &m.stages {
        let _ = write!(out, "\n[[{kind}.motion]]\n");
        match stage {
            Stage::Fixed(a) => {
                let (l, t) = (a.matrix3, a.translation);
                out.push_str("matrix = [");
                for (r, row) in [l.row(0), l.row(1), l.row(2)].iter().enumerate() {
                    if r > 0 {
                        out.push_str(", ");
                    }
                    numbers(out, &[row.x, row.y, row.z, t[r]]);
                }
                out.push_str("]\n");
            }
            Stage::Keyed { translation, rotation, scale, rest } => {
                let held = Trs::default();
                if translation.is_none() && rest.translation != held.translation {
                    entries(out, &[("translate", Value::Vec3(rest.translation))]);
                }
                if rotation.is_none() && rest.rotation != held.rotation {
                    out.push_str("quaternion = ");
                    numbers(out, &rest.rotation.to_array());
                    out.push('\n');
                }
                if scale.is_none() && rest.scale != held.scale {
                    entries(out, &[("scale", Value::Vec3(rest.scale))]);
                }
                if let Some(c) = translation {
                    channel(out, &format!("{kind}.motion.translate"), c, |v| v.to_array().to_vec());
                }
                match rotation {
                    Some(Rotation::EulerDegrees(c)) => {
                        channel(out, &format!("{kind}.motion.rotate"), c, |v| v.to_array().to_vec())
                    }
                    Some(Rotation::Quaternion(c)) => {
                        channel(out, &format!("{kind}.motion.quaternion"), c, |q: &DQuat| {
                            q.to_array().to_vec()
                        })
                    }
                    None => {}
                }
                if let Some(c) = scale {
                    channel(out, &format!("{kind}.motion.scale"), c, |v| v.to_array().to_vec());
                }
            }
        }
    }
}

fn channel<T>(out: &mut String, header: &str, c: &Channel<T>, parts: impl Fn(&T) -> Vec<f64>) {
    let _ = write!(out, "\n[{header}]\ninterpolation = ");
    string(out, c.interpolation.name());
    out.push_str("\ntimes = ");
    numbers(out, &c.times);
    out.push('\n');
    let cubic = c.interpolation == Interpolation::CubicSpline;
    let column = |k: usize| -> Vec<Vec<f64>> {
        if cubic {
            c.values.iter().skip(k).step_by(3).map(&parts).collect()
        } else {
            c.values.iter().map(&parts).collect()
        }
    };
    let mut list = |key: &str, items: Vec<Vec<f64>>| {
        out.push_str(key);
        out.push_str(" = ");
        lines(out, &items, |out, v| numbers(out, v));
        out.push('\n');
    };
    list("values", column(if cubic { 1 } else { 0 }));
    if cubic {
        list("in_tangents", column(0));
        list("out_tangents", column(2));
    }
}

/// `[a, b, …]` on one line.
fn numbers(out: &mut String, v: &[f64]) {
    out.push('[');
    for (i, x) in v.iter().enumerate() {
        if i > 0 {
            out.push_str(", ");
        }
        float(out, *x);
    }
    out.push(']');
}

/// Material or texture names as written: each scene name, with a suffix where a name repeats
/// (materials and textures are referred to by name, so names must be unique in the file).
fn unique_names<'a>(names: impl Iterator<Item = &'a str>) -> Vec<String> {
    let mut taken = HashSet::new();
    names
        .map(|original| {
            let mut name = original.to_string();
            let mut k = 2;
            while !taken.insert(name.clone()) {
                name = format!("{original} #{k}");
                k += 1;
            }
            name
        })
        .collect()
}

fn table(out: &mut String, header: &str, e: &[(&str, Value)]) {
    out.push('\n');
    out.push_str(header);
    out.push('\n');
    entries(out, e);
}

fn entries(out: &mut String, e: &[(&str, Value)]) {
    for (key, value) in e {
        out.push_str(key);
        out.push_str(" = ");
        write_value(out, value);
        out.push('\n');
    }
}

fn write_value(out: &mut String, v: &Value) {
    match v {
        Value::Float(x) => float(out, *x),
        Value::Int(n) => write!(out, "{n}").unwrap(),
        Value::Str(s) => string(out, s),
        Value::Vec3(v) => vec3(out, *v),
        Value::Pair([a, b]) => {
            out.push('[');
            float(out, *a);
            out.push_str(", ");
            float(out, *b);
            out.push(']');
        }
        Value::Vec3s(vs) => lines(out, vs, |out, v| vec3(out, *v)),
        Value::Vec2s(vs) => lines(out, vs, |out, v| {
            out.push('[');
            float(out, v.x);
            out.push_str(", ");
            float(out, v.y);
            out.push(']');
        }),
        Value::Strs(ss) => {
            out.push('[');
            for (i, s) in ss.iter().enumerate() {
                if i > 0 {
                    out.push_str(", ");
                }
                string(out, s);
            }
            out.push(']');
        }
        Value::Triangles(ts) => {
            lines(out, ts, |out, t| write!(out, "[{}, {}, {}]", t[0], t[1], t[2]).unwrap())
        }
    }
}

/// Shortest round-trip digits; Rust's `{:?}` always includes a `.` or an exponent.
fn float(out: &mut String, x: f64) {
    write!(out, "{x:?}").unwrap();
}

fn vec3(out: &mut String, v: DVec3) {
    out.push('[');
    float(out, v.x);
    out.push_str(", ");
    float(out, v.y);
    out.push_str(", ");
    float(out, v.z);
    out.push(']');
}

/// A multi-line array, one item per line.
fn lines<T>(out: &mut String, items: &[T], item: impl Fn(&mut String, &T)) {
    if items.is_empty() {
        out.push_str("[]");
        return;
    }
    out.push_str("[\n");
    for x in items {
        out.push_str("  ");
        item(out, x);
        out.push_str(",\n");
    }
    out.push(']');
}

/// A TOML basic string: quotes, backslashes and control characters escaped.
fn string(out: &mut String, s: &str) {
    out.push('"');
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\t' => out.push_str("\\t"),
            '\r' => out.push_str("\\r"),
            c if c.is_control() => write!(out, "\\u{:04X}", c as u32).unwrap(),
            c => out.push(c),
        }
    }
    out.push('"');
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floats_are_toml_floats_with_the_shortest_digits() {
        let text = |x: f64| {
            let mut s = String::new();
            float(&mut s, x);
            s
        };
        assert_eq!(text(1.0), "1.0");
        assert_eq!(text(0.1), "0.1");
        assert_eq!(text(-0.0), "-0.0");
        assert_eq!(text(1e300), "1e300");
        assert_eq!(text(0.800000011920929), "0.800000011920929");
    }

    #[test]
    fn strings_escape_what_toml_needs() {
        let mut s = String::new();
        string(&mut s, "a\"b\\c\nd\u{7f}é");
        assert_eq!(s, r#""a\"b\\c\nd\u007Fé""#);
    }
}
