//! The NFF loader (src/io/nff.rs, docs/nff.md): every command reaches the [`Scene`] as
//! documented, and bad input gives an error with the file, line and column of the offending
//! token and what was expected — never a panic.
use crate::common;

use glam::DVec3;
use irt::io::nff::parse_str;
use irt::io::LoadError;
use irt::scene::{MaterialKind, Scene};
use proptest::prelude::*;

const ORIGIN: &str = "test.nff";

/// A minimal valid file; tests append commands to it or replace parts of it.
const BASE: &str = "v
from 0 0 5
at 0 0 0
up 0 1 0
angle 40
hither 0.1
resolution 16 12
l 1 2 3
f 1 0.5 0.25 0.8 0 0 0 0
s 0 0 0 1
";

fn parse(src: &str) -> Result<Scene, LoadError> {
    parse_str(src, ORIGIN)
}

fn with(extra: &str) -> String {
    format!("{BASE}{extra}\n")
}

/// Asserts that `src` fails at the last `at` with a message containing every one of `words`.
fn fails_at(src: &str, at: &str, words: &[&str]) -> LoadError {
    common::assert_fails_at(parse(src), src, ORIGIN, at, words)
}

/// Asserts that `src` fails at its very end (a command cut short).
fn fails_at_end(src: &str, words: &[&str]) {
    let e = parse(src).expect_err("the scene should be rejected");
    let line = src.matches('\n').count() + 1;
    let column = src.rsplit('\n').next().unwrap().chars().count() + 1;
    assert_eq!((e.line, e.column), (Some(line), Some(column)), "wrong position for: {e}");
    for w in words {
        assert!(e.message.contains(w), "message lacks '{w}': {e}");
    }
}

const ALL_COMMANDS: &str = "# every command, in the forms real files use
b 0.1 0.2 0.3
v
from 1 2 3
at 0 0 0
up 0 0 1
angle 45
hither 1
resolution 64 32
l 10 10 10
l -10 10 10 0.5 0.25 1
l 0 -10 10
f 1 0.5 0.25 0.8 0 100000 0 0
s 0 0 1 0.5
f 1 1 1 0.1 0.1 101 0.9 1.5   # glass
s 1 0 1 0.25
f 0.5 0.5 0.5 0.5 0.5 4 0 0
c 0 0 0 0.1 0 0 2 0.1
c
1 1 0 0.3
1 1 1 0
c 2 2 0 -0.2 2 2 1 -0.1
f 1 0.9 0.8 0.02 0.9 30 0 0
p 6
0 0 0
2 0 0
2 1 0
1 1 0
1 2 0
0 2 0
pp 3
0 0 3 0 0 2
1 0 3 0 0 3
0 1 3 0 0 1
f 1 0.5 0.25 0.8 0 100000 0 0
s 0 0 -1 0.5
p 3 0 0 4 1 0 4 0 1 4
";

#[test]
fn every_command_reaches_the_scene() {
    let s = parse(ALL_COMMANDS).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.background, DVec3::new(0.1, 0.2, 0.3));
    let c = &s.camera;
    assert_eq!(
        (c.eye, c.look_at, c.up, c.width, c.height),
        (DVec3::new(1.0, 2.0, 3.0), DVec3::ZERO, DVec3::Z, 64, 32)
    );
    assert_eq!(c.vfov_deg, irt::io::nff::vfov_from_nff_angle(45.0, 32));
    // Lights without a colour get SPD's sqrt(n)/(2n) for n = 3 lights; a colour is kept.
    let default = 3f64.sqrt() / 6.0;
    let colours: Vec<DVec3> = s.lights.iter().map(|l| l.color).collect();
    assert_eq!(colours, [DVec3::splat(default), DVec3::new(0.5, 0.25, 1.0), DVec3::splat(default)]);
    assert!(s.lights.iter().all(|l| l.radius == 0.0));
    assert_eq!(s.ambient.sky, DVec3::ZERO, "NFF has no ambient light");

    // Four distinct surfaces; the repeated first one is shared.
    let kinds: Vec<&MaterialKind> = s.materials.iter().map(|m| &m.kind).collect();
    assert_eq!(kinds.len(), 4);
    assert_eq!(*kinds[0], MaterialKind::Diffuse { color: DVec3::new(0.8, 0.4, 0.2) });
    assert_eq!(*kinds[1], MaterialKind::Dielectric { eta: 1.5, exponent: 101.0 });
    assert!(matches!(kinds[2], MaterialKind::Polished { .. }));
    assert_eq!(*kinds[3], MaterialKind::Metal { color: 0.9 * DVec3::new(1.0, 0.9, 0.8), exponent: 30.0 });
    let sphere_materials: Vec<u32> = s.spheres.iter().map(|s| s.material).collect();
    assert_eq!(sphere_materials, [0, 1, 0]);

    // Cones: one line, three lines, both radii negative (NFF: seen from inside).
    let cones: Vec<(f64, f64, u32)> =
        s.cones.iter().map(|c| (c.base_radius, c.apex_radius, c.material)).collect();
    assert_eq!(cones, [(0.1, 0.1, 2), (0.3, 0.0, 2), (0.2, 0.1, 2)]);
    assert_eq!((s.cones[1].base, s.cones[1].apex), (DVec3::new(1.0, 1.0, 0.0), DVec3::ONE));

    // Polygons: the concave hexagon becomes 4 triangles, the pp triangle keeps its normals, and
    // each (material, normals) pair is one mesh.
    assert_eq!(s.meshes.len(), 3);
    let (hexagon, patch, last) = (&s.meshes[0], &s.meshes[1], &s.meshes[2]);
    assert_eq!((hexagon.material, hexagon.indices.len(), hexagon.normals.is_none()), (3, 4, true));
    assert_eq!((patch.material, patch.indices.len()), (3, 1));
    let normals = patch.normals.as_ref().expect("pp has vertex normals");
    assert!(normals.iter().all(|n| *n == DVec3::Z), "normalised: {normals:?}");
    assert_eq!((last.material, last.positions[2]), (0, DVec3::new(0.0, 1.0, 4.0)));
    assert_eq!(s.primitive_count(), 3 + 3 + 4 + 1 + 1);
}

#[test]
fn the_files_are_found_by_extension() {
    let dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR"));
    let path = dir.join("scene.NFF");
    std::fs::write(&path, BASE).unwrap();
    assert_eq!(irt::io::load(&path).unwrap(), parse(BASE).unwrap());
    let e = irt::io::load(&dir.join("x.3ds")).unwrap_err();
    assert!(e.message.contains(".nff (NFF)") && e.message.contains(".obj (Wavefront OBJ)"), "{e}");
}

#[test]
fn unknown_command() {
    fails_at(&with("sphere 0 0 0 1"), "sphere", &["unknown command `sphere`", "v, b, l, f, c, s, p, pp"]);
    fails_at(&with("S 0 0 0 1"), "S 0", &["unknown command `S`"]);
    // One number too many before a command reads as a number in command position.
    fails_at(&with("s 0 0 0 1 2"), "2", &["expected a command", "the number `2`"]);
}

#[test]
fn missing_numbers() {
    fails_at_end(&with("s 0 0 0"), &["sphere radius", "`s` on line 11", "end of the file"]);
    fails_at_end(&with("c 0 0 0 1 0 0 1"), &["cone apex radius", "end of the file"]);
    fails_at_end(&with("f 1 1 1 0.5 0.5 3"), &["T", "end of the file"]);
    fails_at_end(&with("p 3 0 0 0 1 0 0"), &["polygon vertex coordinate", "end of the file"]);
    // A command where a number belongs: the polygon has fewer vertices than it says.
    let src = with("p 4\n0 0 0\n1 0 0\n1 1 0\ns 0 0 0 1");
    fails_at(&src, "s 0 0 0 1", &["expected polygon vertex coordinate (a number)", "found `s`"]);
    fails_at(&with("s 0 0 x 1"), "x", &["expected sphere centre (a number) for `s`, found `x`"]);
}

#[test]
fn non_finite_numbers() {
    for bad in ["inf", "-inf", "nan", "NaN", "1e999"] {
        let src = with(&format!("s 0 0 0 {bad}"));
        fails_at(&src, bad, &["sphere radius", "must be finite"]);
    }
    fails_at(&with("l 1 2 inf"), "inf", &["light position", "finite"]);
}

#[test]
fn bad_polygon_vertex_counts() {
    fails_at(&with("p 2 0 0 0 1 0 0"), "2 0 0 0", &["vertex count 2 is out of range: 3 to 4096"]);
    fails_at(&with("p 5000"), "5000", &["vertex count 5000 is out of range"]);
    fails_at(&with("p 99999999999999999999"), "99999999999999999999", &["out of range"]);
    fails_at(&with("p -3"), "-3", &["out of range"]);
    fails_at(&with("p 3.5"), "3.5", &["whole number"]);
    fails_at(&with("pp x"), "x", &["expected vertex count (a whole number) for `pp`"]);
    fails_at(
        &with("pp 3 0 0 0 0 0 0 1 0 0 0 0 1 0 1 0 0 0 1"),
        "0 0 0 1 0 0",
        &["vertex normal must not be zero"],
    );
}

#[test]
fn out_of_range_values() {
    fails_at(&with("f 1 1 1 1.5 0 0 0 0"), "1.5", &["Kd 1.5 is out of range: 0 to 1"]);
    fails_at(&with("f 1 -0.1 1 0.5 0 0 0 0"), "-0.1", &["surface colour -0.1 is out of range"]);
    fails_at(&with("f 1 1 1 0.5 0.5 -2 0 0"), "-2", &["Shine -2 is out of range: at least 0"]);
    fails_at(&with("f 1 1 1 0.5 0.5 2 0.5 0"), "0\n", &["index of refraction 0", "T is 0"]);
    fails_at(&with("b 0 -1 0"), "-1", &["background colour"]);
    fails_at(&with("l 0 0 0 1 -1 1"), "-1", &["light colour"]);
    fails_at(&with("s 0 0 0 0"), "0\n", &["sphere radius 0 is out of range: greater than 0"]);
    fails_at(&with("s 0 0 0 -1"), "-1", &["sphere radius"]);
    fails_at(&with("c 0 0 0 1 0 0 1 -1"), "-1", &["cone radii", "both negative"]);
    fails_at(&with("c 0 0 0 0 0 0 1 0"), "c 0", &["radii are both 0"]);
    fails_at(&with("c 1 2 3 1 1 2 3 1"), "c 1", &["same point"]);
    fails_at(&BASE.replace("angle 40", "angle 180"), "180", &["`angle` 180 is out of range"]);
    fails_at(&BASE.replace("angle 40", "angle 0"), "0\nhither", &["`angle` 0"]);
    fails_at(&BASE.replace("hither 0.1", "hither -1"), "-1", &["`hither` -1"]);
    fails_at(
        &BASE.replace("resolution 16 12", "resolution 0 12"),
        "0 12",
        &["resolution width 0 is out of range: 1 to 16384"],
    );
    fails_at(&BASE.replace("resolution 16 12", "resolution 16 20000"), "20000", &["resolution height"]);
    // Within the limit per side but too many pixels in all: found by the scene's check, blamed on `v`.
    fails_at(&BASE.replace("resolution 16 12", "resolution 16384 16384"), "v\n", &["exceeds"]);
}

#[test]
fn structure_errors() {
    let no_surface = BASE.replace("f 1 0.5 0.25 0.8 0 0 0 0\n", "");
    fails_at(&no_surface, "s 0", &["`s` comes before any surface `f`"]);
    fails_at(&with("v"), "v\n", &["a second `v`; the first is on line 1"]);
    fails_at(&with("b 0 0 0\nb 1 1 1"), "b 1", &["a second `b`; the first is on line 11"]);
    let e = parse(&BASE.replacen(
        "v\nfrom 0 0 5\nat 0 0 0\nup 0 1 0\nangle 40\nhither 0.1\nresolution 16 12\n",
        "",
        1,
    ))
    .unwrap_err();
    assert_eq!((e.line, e.message.contains("no viewpoint")), (None, true), "{e}");
    let e = parse(&BASE.replace("s 0 0 0 1\n", "")).unwrap_err();
    assert!(e.message.contains("no objects"), "{e}");
    fails_at(
        &BASE.replace("at 0 0 0", "up 0 0 0"),
        "up 0 0 0",
        &["expected `at`, found `up`", "in that order"],
    );
    // An `up` along the view is found by the scene's check and blamed on the viewpoint.
    fails_at(&BASE.replace("up 0 1 0", "up 0 0 -2"), "v\n", &["camera.up", "parallel"]);
    let lights = "l 0 0 9\n".repeat(15); // 16 with the one in BASE
    fails_at(&with(&format!("{lights}l 0 0 10")), "l 0 0 10", &["too many lights: at most 16"]);
    // Comments run to the end of the line, wherever they start.
    let commented = with("# s 0 0 0 x\ns 1 1 1 0.5 # the end");
    assert_eq!(parse(&commented).unwrap().spheres.len(), 2);
}

#[test]
fn invalid_utf8_is_reported_at_the_bad_byte() {
    let dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR"));
    let path = dir.join("bad-utf8.nff");
    let mut bytes = BASE.as_bytes().to_vec();
    bytes.extend_from_slice(b"s 0 0 \xff 1\n");
    std::fs::write(&path, bytes).unwrap();
    let e = irt::io::load(&path).unwrap_err();
    assert_eq!((e.line, e.column), (Some(11), Some(7)), "{e}");
}

proptest! {
    // Random edits of a real SPD file (tokens dropped, repeated, replaced by odd words and
    // numbers) give a scene or an error, never a panic; errors always carry a position or are
    // about the file as a whole.
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]
    #[test]
    fn edited_files_never_panic(edits in prop::collection::vec((0usize..1000, 0usize..6, 0usize..8), 1..6)) {
        let src = include_str!("../../scenes/spd/tree_s3.nff");
        let mut tokens: Vec<String> = src.split_whitespace().map(String::from).collect();
        const ODD: [&str; 8] = ["p", "pp", "c", "-1", "0", "1e308", "nan", "3.5"];
        for (at, op, word) in edits {
            let i = at % tokens.len();
            match op {
                0 => { tokens.remove(i); }
                1 => { let t = tokens[i].clone(); tokens.insert(i, t); }
                2 | 3 => tokens[i] = ODD[word].to_string(),
                4 => tokens.insert(i, ODD[word].to_string()),
                _ => tokens.truncate(i + 1),
            }
            if tokens.is_empty() { break; }
        }
        let text = tokens.join(" ");
        if let Err(e) = parse(&text) {
            prop_assert!(!e.message.is_empty());
        }
    }
}
