//! [`Scene`] → the native TOML format (docs/scene-format.md), losslessly: loading the text gives
//! back the same scene, bit for bit. `irt convert` writes any loadable scene with it.
//!
//! Numbers use Rust's shortest round-trip formatting (`{:?}` on f64: the fewest digits that
//! parse back to the same bits, always with a `.` or an exponent so that TOML reads a float).
//! Meshes are written inline. Every table is a list of `(key, Value)` pairs, so a new primitive
//! is one more loop in [`to_toml`].

use crate::scene::{MaterialKind, Scene};
use glam::DVec3;
use std::collections::HashSet;
use std::fmt::Write;

/// A value as the writer lays it out.
enum Value<'a> {
    Float(f64),
    Int(u64),
    Str(&'a str),
    Vec3(DVec3),
    /// One vector per line (mesh positions and normals).
    Vec3s(&'a [DVec3]),
    /// One triangle per line.
    Triangles(&'a [[u32; 3]]),
}

/// The scene as TOML. The scene should be valid ([`Scene::validate`]): TOML has no spelling for
/// NaN that the loader would accept, and the loader rejects what `validate` rejects.
pub fn to_toml(scene: &Scene) -> String {
    let names = material_names(scene);
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
    let shadows = t.shadows.to_string();
    #[rustfmt::skip]
    table(&mut out, "[trace]", &[
        ("max_depth", Value::Int(t.max_depth.into())),
        ("weight_cutoff", Value::Float(t.weight_cutoff)),
        ("shadows", Value::Str(&shadows)),
    ]);
    for l in &scene.lights {
        // `intensity` is left at 1: color × 1 is the colour, bit for bit.
        #[rustfmt::skip]
        table(&mut out, "[[light]]", &[
            ("position", Value::Vec3(l.position)),
            ("color", Value::Vec3(l.color)),
            ("radius", Value::Float(l.radius)),
        ]);
    }
    for (m, name) in scene.materials.iter().zip(&names) {
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
        table(&mut out, "[[material]]", &e);
    }
    let material = |index: u32| Value::Str(names.get(index as usize).map_or("", String::as_str));
    for s in &scene.spheres {
        #[rustfmt::skip]
        table(&mut out, "[[sphere]]", &[
            ("center", Value::Vec3(s.center)),
            ("radius", Value::Float(s.radius)),
            ("material", material(s.material)),
        ]);
    }
    for c in &scene.cones {
        #[rustfmt::skip]
        table(&mut out, "[[cone]]", &[
            ("base", Value::Vec3(c.base)),
            ("base_radius", Value::Float(c.base_radius)),
            ("apex", Value::Vec3(c.apex)),
            ("apex_radius", Value::Float(c.apex_radius)),
            ("material", material(c.material)),
        ]);
    }
    for m in &scene.meshes {
        let mut e = vec![
            ("material", material(m.material)),
            ("positions", Value::Vec3s(&m.positions)),
            ("indices", Value::Triangles(&m.indices)),
        ];
        if let Some(n) = &m.normals {
            e.push(("normals", Value::Vec3s(n)));
        }
        table(&mut out, "[[mesh]]", &e);
    }
    out
}

/// Material names as written: each scene name, with a suffix where a name repeats (materials
/// are referred to by name, so names must be unique in the file).
fn material_names(scene: &Scene) -> Vec<String> {
    let mut taken = HashSet::new();
    scene
        .materials
        .iter()
        .map(|m| {
            let mut name = m.name.clone();
            let mut k = 2;
            while !taken.insert(name.clone()) {
                name = format!("{} #{k}", m.name);
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
        Value::Vec3s(vs) => lines(out, vs, |out, v| vec3(out, *v)),
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
