//! The TOML scene format: every scene file loads, every feature reaches the [`Scene`], and bad
//! input gives an error that names the file, the line and column of the offending value, and
//! what is wrong — never a panic.
use crate::common;

use glam::{DVec2, DVec3};
use irt::io::toml::{parse_str, EMPTY_SCENE};
use irt::io::{load, load_with_limit, LoadError};
use irt::scene::{Filter, MaterialKind, Scene, Wrap};
use proptest::prelude::*;
use std::path::{Path, PathBuf};

const ORIGIN: &str = "test.toml";

/// A minimal valid scene; tests append tables to it or replace parts of it.
const BASE: &str = r#"
[camera]
eye = [0, 1, 5]
look_at = [0, 0, 0]
width = 16
height = 12

[[material]]
name = "white"
type = "diffuse"

[[sphere]]
center = [0, 0, 0]
radius = 1
material = "white"
"#;

fn parse(src: &str) -> Result<Scene, LoadError> {
    parse_str(src, ORIGIN)
}

fn with(extra: &str) -> String {
    format!("{BASE}\n{extra}")
}

/// Asserts that `src` fails at the last `at` with a message containing every one of `words`.
fn fails_at(src: &str, at: &str, words: &[&str]) -> LoadError {
    common::assert_fails_at(parse(src), src, ORIGIN, at, words)
}

fn tmp_file(name: &str, contents: &[u8]) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("scene_toml");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, contents).unwrap();
    path
}

fn scenes_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes")
}

// ---- Files --------------------------------------------------------------------------------

#[test]
fn missing_file_names_the_path_and_the_reason() {
    let e = load(Path::new("no/such/dir/scene.toml")).unwrap_err();
    assert_eq!((e.line, e.column), (None, None));
    let text = e.to_string();
    assert!(text.starts_with("no/such/dir/scene.toml: "), "{text}");
    assert!(text.contains("No such file"), "{text}");
}

#[test]
fn unknown_extension_lists_the_supported_ones() {
    let e = load(Path::new("scene.3ds")).unwrap_err();
    assert!(e.message.contains("extension") && e.message.contains(".toml"), "{e}");
    let e = load(Path::new("no_extension")).unwrap_err();
    assert!(e.message.contains(".toml"), "{e}");
}

#[test]
fn extension_is_case_insensitive() {
    let path = tmp_file("upper.TOML", BASE.as_bytes());
    load(&path).unwrap_or_else(|e| panic!("{e}"));
}

#[test]
fn file_above_the_size_limit_is_refused() {
    let path = tmp_file("big.toml", BASE.as_bytes());
    let e = load_with_limit(&path, 64).unwrap_err();
    assert!(e.message.contains("limited to 64 bytes"), "{e}");
    assert!(load_with_limit(&path, BASE.len() as u64).is_ok());
}

#[test]
fn invalid_utf8_is_reported_at_the_bad_byte() {
    let mut bytes = BASE.as_bytes().to_vec();
    bytes.extend_from_slice(b"# caf\xe9\n");
    let e = load(&tmp_file("latin1.toml", &bytes)).unwrap_err();
    let lines = BASE.matches('\n').count() + 1;
    assert_eq!((e.line, e.column), (Some(lines), Some(6)), "{e}");
    assert!(e.message.contains("UTF-8"), "{e}");
}

#[test]
fn every_scene_file_loads() {
    let mut count = 0;
    for entry in std::fs::read_dir(scenes_dir()).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "toml") {
            let scene = load(&path).unwrap_or_else(|e| panic!("{e}"));
            assert!(scene.primitive_count() > 0, "{}", path.display());
            count += 1;
        }
    }
    assert!(count >= 8, "only {count} scene files");
}

#[test]
fn the_built_in_default_scene_is_the_file_and_uses_every_feature() {
    let scene = irt::scene::default_scene();
    scene.validate().unwrap();
    assert_eq!(scene, load(&scenes_dir().join("default.toml")).unwrap());
    assert_eq!((scene.camera.width, scene.camera.height), (640, 480));
    let has = |f: fn(&MaterialKind) -> bool| scene.materials.iter().any(|m| f(&m.kind));
    assert!(has(|k| matches!(k, MaterialKind::Diffuse { .. })));
    assert!(has(|k| matches!(k, MaterialKind::Metal { .. })));
    assert!(has(|k| matches!(k, MaterialKind::Dielectric { .. })));
    assert!(has(|k| matches!(k, MaterialKind::Polished { .. })));
    assert!(!scene.lights.is_empty() && scene.ambient.sky != scene.ambient.ground);
    assert!(scene.triangle_count() > 0 && scene.triangle_count() < 500);
}

#[test]
fn the_example_in_the_format_docs_loads() {
    let docs = std::fs::read_to_string(scenes_dir().join("../docs/scene-format.md")).unwrap();
    // The complete scene under "## Example" (earlier blocks are fragments of one table).
    let example = docs
        .split("## Example")
        .nth(1)
        .and_then(|s| s.split("```toml\n").nth(1))
        .and_then(|s| s.split("```").next())
        .expect("a toml block under ## Example");
    let scene = parse_str(example, "docs/scene-format.md").unwrap_or_else(|e| panic!("{e}"));
    assert_eq!((scene.materials.len(), scene.spheres.len(), scene.meshes.len()), (4, 2, 4));
}

// ---- Every feature reaches the Scene -------------------------------------------------------

const ALL_FEATURES: &str = r#"
background = [0.1, 0.2, 0.3]

[camera]
eye = [1, 2, 3]
look_at = [0, 1, 0]
up = [0, 0, 1]
fov = 30.5
width = 320
height = 200

[ambient]
sky = [0.5, 0.6, 0.7]
ground = [0.1, 0.05, 0.0]
up = [0, 0, 1]

[[light]]
position = [5, 5, 5]
color = [1.0, 0.5, 0.25]
intensity = 2
radius = 0.25

[[light]]
position = [-5, 5, 5]

[trace]
max_depth = 3
weight_cutoff = 0.01

# Relative to the scene file's directory; `test.toml` is in the current one, the crate root.
[[texture]]
name = "tiles"
file = "scenes/textures/checker.png"
wrap = ["mirror", "clamp"]
filter = "nearest"

[[material]]
name = "matte"
type = "diffuse"
color = [0.5, 0.25, 0.125]
texture = "tiles"

[[material]]
name = "steel"
type = "metal"

[[material]]
name = "water"
type = "dielectric"
eta = 1.33
exponent = 500

[[material]]
name = "lacquer"
type = "polished"
color = [0.1, 0.2, 0.3]
exponent = 10

[[sphere]]
center = [0, 1, 0]
radius = 0.5
material = "water"

[[mesh]]
material = "steel"
positions = [[0, 0, 0], [1, 0, 0], [0, 1, 0]]
normals = [[0, 0, 2], [0, 0, 1], [0, 0, 1]]
uvs = [[0, 0], [1, 0], [0.5, 1]]
indices = [[0, 1, 2]]
translate = [10, 0, 0]
scale = 2

[[mesh]]
material = "matte"
shape = "quad"
center = [0, -1, 0]
size = [4, 2]

[[mesh]]
material = "matte"
shape = "quad"
corners = [[0, 0, 0], [0, 0, 1], [1, 0, 1], [1, 0, 0]]

[[mesh]]
material = "lacquer"
shape = "box"
min = [0, 0, 0]
max = [1, 1, 1]
scale = [1, 2, 3]
translate = [0, 0, -5]

[[mesh]]
material = "lacquer"
shape = "icosphere"
center = [0, 3, 0]
radius = 2
subdivisions = 1
"#;

#[test]
fn every_feature_reaches_the_scene() {
    let s = parse(ALL_FEATURES).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.background, DVec3::new(0.1, 0.2, 0.3));
    let c = &s.camera;
    assert_eq!((c.eye, c.look_at, c.up), (DVec3::new(1.0, 2.0, 3.0), DVec3::Y, DVec3::Z));
    assert_eq!((c.vfov_deg, c.width, c.height), (30.5, 320, 200));
    let a = &s.ambient;
    assert_eq!((a.sky, a.ground, a.up), (DVec3::new(0.5, 0.6, 0.7), DVec3::new(0.1, 0.05, 0.0), DVec3::Z));
    // Light colour is colour times intensity; the defaults are white, 1 and a point light.
    assert_eq!((s.lights[0].color, s.lights[0].radius), (DVec3::new(2.0, 1.0, 0.5), 0.25));
    assert_eq!((s.lights[1].color, s.lights[1].radius), (DVec3::ONE, 0.0));
    assert_eq!((s.trace.max_depth, s.trace.weight_cutoff), (3, 0.01));

    let kinds: Vec<_> = s.materials.iter().map(|m| (m.name.as_str(), m.kind.clone())).collect();
    assert_eq!(kinds[0], ("matte", MaterialKind::Diffuse { color: DVec3::new(0.5, 0.25, 0.125) }));
    assert_eq!(kinds[1], ("steel", MaterialKind::Metal { color: DVec3::splat(0.9), exponent: 64.0 }));
    assert_eq!(kinds[2], ("water", MaterialKind::Dielectric { eta: 1.33, exponent: 500.0 }));
    let lacquer = MaterialKind::Polished { color: DVec3::new(0.1, 0.2, 0.3), eta: 1.5, exponent: 10.0 };
    assert_eq!(kinds[3], ("lacquer", lacquer));

    assert_eq!((s.spheres[0].center, s.spheres[0].radius, s.spheres[0].material), (DVec3::Y, 0.5, 2));

    let [inline, quad, corners, cuboid, ico] = s.meshes.as_slice() else { panic!("5 meshes") };
    assert_eq!(inline.material, 1);
    assert_eq!(inline.positions[1], DVec3::new(12.0, 0.0, 0.0), "scaled, then translated");
    assert_eq!(inline.normals.as_ref().unwrap()[0], DVec3::Z, "normals are made unit length");
    assert_eq!(inline.indices, vec![[0, 1, 2]]);
    assert_eq!(inline.uvs, Some(vec![DVec2::ZERO, DVec2::X, DVec2::new(0.5, 1.0)]));
    assert_eq!(s.textures.len(), 1);
    let t = &s.textures[0];
    assert_eq!((t.name.as_str(), t.width, t.height, t.texels.len()), ("tiles", 8, 8, 64));
    assert_eq!((t.wrap, t.filter), ([Wrap::Mirror, Wrap::Clamp], Filter::Nearest));
    assert_eq!(s.materials.iter().map(|m| m.texture).collect::<Vec<_>>(), [Some(0), None, None, None]);
    assert_eq!(quad.indices.len(), 2);
    assert!(quad.positions.iter().all(|p| p.y == -1.0 && p.x.abs() == 2.0 && p.z.abs() == 1.0));
    assert_eq!(corners.positions[2], DVec3::new(1.0, 0.0, 1.0));
    assert_eq!((cuboid.positions.len(), cuboid.indices.len()), (8, 12));
    assert_eq!(cuboid.positions[7], DVec3::new(1.0, 2.0, -2.0));
    assert_eq!((ico.indices.len(), ico.material), (80, 3));
    assert!(ico.positions.iter().all(|p| ((*p - DVec3::new(0.0, 3.0, 0.0)).length() - 2.0).abs() < 1e-12));
}

#[test]
fn defaults_fill_in_what_is_left_out() {
    let s = parse(BASE).unwrap();
    assert_eq!((s.camera.up, s.camera.vfov_deg), (DVec3::Y, 45.0));
    assert_eq!((s.background, s.ambient.sky, s.ambient.ground), (DVec3::ZERO, DVec3::ZERO, DVec3::ZERO));
    assert!(s.lights.is_empty(), "no lights is allowed (ambient only)");
    assert_eq!(s.trace, Default::default());
    let no_size = BASE.replace("width = 16\nheight = 12\n", "");
    let c = parse(&no_size).unwrap().camera;
    assert_eq!((c.width, c.height), (640, 480));
}

// ---- Errors point at the offending value ---------------------------------------------------

#[test]
fn syntax_error_has_line_and_column() {
    let src = BASE.replace("radius = 1", "radius = = 1");
    fails_at(&src, "= 1", &[]);
    let src = with("[[sphere]\n");
    let e = parse(&src).unwrap_err();
    assert_eq!(e.line, Some(common::position_of(&src, "[[sphere]\n").0), "{e}");
}

#[test]
fn unknown_material_name_points_at_the_reference() {
    let src = BASE.replace("material = \"white\"", "material = \"whte\"");
    fails_at(&src, "\"whte\"", &["unknown material 'whte'", "'white'"]);
}

#[test]
fn unknown_material_name_without_materials() {
    let src = BASE.replace("name = \"white\"\ntype = \"diffuse\"", "name = \"x\"\ntype = \"diffuse\"");
    fails_at(&src, "\"white\"", &["unknown material 'white'", "'x'"]);
}

#[test]
fn negative_radius() {
    fails_at(&BASE.replace("radius = 1", "radius = -1.5"), "-1.5", &["`radius`", "greater than 0", "-1.5"]);
}

#[test]
fn nan_and_infinite_numbers() {
    fails_at(&BASE.replace("center = [0, 0, 0]", "center = [0, nan, 0]"), "[0, nan", &["NaN", "finite"]);
    fails_at(&BASE.replace("eye = [0, 1, 5]", "eye = [0, 1, -inf]"), "[0, 1, -inf", &["`eye`", "-inf"]);
    fails_at(&BASE.replace("radius = 1", "radius = inf"), "inf", &["`radius`", "inf"]);
    fails_at(&with("[[light]]\nposition = [1, 1, 1]\nintensity = nan"), "nan", &["`intensity`"]);
}

#[test]
fn vector_of_the_wrong_length() {
    fails_at(
        &BASE.replace("look_at = [0, 0, 0]", "look_at = [0, 0]"),
        "[0, 0]\n",
        &["`look_at`", "3 numbers", "2"],
    );
}

#[test]
fn wrong_type_of_value() {
    fails_at(&BASE.replace("radius = 1", "radius = \"big\""), "\"big\"", &["string", "f64"]);
}

#[test]
fn unknown_key_lists_the_known_ones() {
    fails_at(
        &with("[[light]]\nposition = [1, 1, 1]\ncolour = [1, 1, 1]"),
        "colour",
        &["unknown field `colour`", "`color`"],
    );
    fails_at(&format!("lights = []\n{BASE}"), "lights", &["unknown field `lights`", "`light`"]);
}

#[test]
fn key_that_does_not_apply_to_the_material_type() {
    let src = with("[[material]]\nname = \"m\"\ntype = \"diffuse\"\neta = 1.5");
    fails_at(&src, "1.5", &["`eta` does not apply to a diffuse material", "`color`"]);
    let src = with("[[material]]\nname = \"g\"\ntype = \"dielectric\"\ncolor = [1, 1, 1]");
    fails_at(&src, "[1, 1, 1]", &["`color` does not apply to a dielectric material", "`eta`, `exponent`"]);
}

#[test]
fn unknown_material_type() {
    let src = with("[[material]]\nname = \"m\"\ntype = \"plastic\"");
    fails_at(&src, "\"plastic\"", &["plastic", "diffuse", "metal", "dielectric", "polished"]);
}

#[test]
fn material_out_of_range_points_at_its_table() {
    let src = with("[[material]]\nname = \"hot\"\ntype = \"metal\"\ncolor = [2, 0, 0]");
    fails_at(&src, "[[material]]\nname = \"hot\"", &["material 'hot'", "[0, 1]"]);
}

#[test]
fn duplicate_material_name() {
    let src = with("[[material]]\nname = \"white\"\ntype = \"metal\"");
    let first_line = common::position_of(BASE, "name = \"white\"").0;
    fails_at(
        &src,
        "\"white\"\ntype = \"metal\"",
        &["'white'", &format!("already defined on line {first_line}")],
    );
}

const INLINE: &str = "[[mesh]]\nmaterial = \"white\"\npositions = [[0, 0, 0], [1, 0, 0], [0, 1, 0]]\n";

#[test]
fn vertex_index_out_of_range() {
    let src = with(&format!("{INLINE}indices = [[0, 1, 2], [0, 1, 3]]"));
    fails_at(&src, "[0, 1, 3]", &["vertex index 3 is out of range", "3 vertices"]);
    let src = with(&format!("{INLINE}indices = [[0, -1, 2]]"));
    fails_at(&src, "[0, -1, 2]", &["vertex index -1"]);
    let src = with(&format!("{INLINE}indices = [[0, 1]]"));
    fails_at(&src, "[0, 1]]", &["3 vertex indices", "found 2"]);
}

#[test]
fn normals_count_must_match_positions() {
    let src = with(&format!("{INLINE}indices = [[0, 1, 2]]\nnormals = [[0, 0, 1], [0, 0, 1]]"));
    fails_at(&src, "[[0, 0, 1], [0, 0, 1]]", &["`normals` has 2 entries", "`positions` has 3"]);
    let src = with(&format!("{INLINE}indices = [[0, 1, 2]]\nnormals = [[0, 0, 1], [0, 0, 0], [0, 0, 1]]"));
    fails_at(&src, "[0, 0, 0]", &["normal must not be zero"]);
}

#[test]
fn mesh_keys_depend_on_the_shape() {
    let src =
        with("[[mesh]]\nmaterial = \"white\"\nshape = \"box\"\nmin = [0, 0, 0]\nmax = [1, 1, 1]\nradius = 2");
    fails_at(&src, "2", &["`radius` does not apply to a box", "`min`, `max`"]);
    let src = with("[[mesh]]\nmaterial = \"white\"\npositions = []\nindices = []\nsize = [1, 1]");
    fails_at(&src, "[1, 1]", &["`size` does not apply to an inline mesh"]);
    let src = with("[[mesh]]\nmaterial = \"white\"\nshape = \"icosphere\"\ncenter = [0, 0, 0]");
    fails_at(&src, "[[mesh]]", &["an icosphere needs `radius`"]);
    let src = with("[[mesh]]\nmaterial = \"white\"\nshape = \"cone\"");
    fails_at(&src, "\"cone\"", &["cone", "quad", "box", "icosphere"]);
}

#[test]
fn shape_parameters_are_checked() {
    let mesh = "[[mesh]]\nmaterial = \"white\"\n";
    let src = with(&format!("{mesh}shape = \"icosphere\"\ncenter = [0, 0, 0]\nradius = 1\nsubdivisions = 7"));
    fails_at(&src, "7", &["at most 6"]);
    let src = with(&format!("{mesh}shape = \"box\"\nmin = [0, 0, 0]\nmax = [1, 0, 1]"));
    fails_at(&src, "[1, 0, 1]", &["`max` must be greater than `min`"]);
    let src = with(&format!("{mesh}shape = \"quad\"\ncenter = [0, 0, 0]\nsize = [1, 0]"));
    fails_at(&src, "[1, 0]", &["`size`"]);
    let src = with(&format!("{mesh}shape = \"quad\"\ncorners = [[0, 0, 0], [1, 0, 0], [1, 0, 1]]"));
    fails_at(&src, "[[0, 0, 0], [1", &["4 points", "found 3"]);
    let src = with(&format!("{mesh}shape = \"quad\"\ncenter = [0, 0, 0]\ncorners = []"));
    fails_at(&src, "[0, 0, 0]\ncorners", &["either `corners` or `center` and `size`"]);
    let src = with(&format!("{mesh}shape = \"box\"\nmin = [0, 0, 0]\nmax = [1, 1, 1]\nscale = [1, -1, 1]"));
    fails_at(&src, "[1, -1, 1]", &["`scale` must be greater than 0"]);
    let src = with(&format!("{mesh}shape = \"box\"\nmin = [0, 0, 0]\nmax = [1, 1, 1]\nscale = \"big\""));
    fails_at(&src, "\"big\"", &["a number or a list"]);
}

#[test]
fn zero_and_huge_resolution_point_at_the_camera() {
    let src = BASE.replace("width = 16", "width = 0");
    fails_at(&src, "[camera]", &["resolution 0x12"]);
    let src = BASE.replace("width = 16", "width = 100000");
    fails_at(&src, "[camera]", &["resolution 100000x12", "exceeds"]);
    let src = BASE.replace("width = 16", "width = -1");
    fails_at(&src, "-1", &["u32"]);
}

#[test]
fn scene_validation_errors_point_at_their_table() {
    fails_at(&BASE.replace("look_at = [0, 0, 0]", "look_at = [0, 1, 5]"), "[camera]", &["look_at equals"]);
    let light = "[[light]]\nposition = [1, 1, 1]\n";
    fails_at(
        &with(&format!("{light}{light}intensity = -1")),
        "[[light]]\nposition = [1, 1, 1]\ni",
        &["light 1"],
    );
    fails_at(&with("[trace]\nmax_depth = 99"), "[trace]", &["max_depth"]);
    fails_at(&with("[ambient]\nsky = [-1, 0, 0]"), "[ambient]", &["ambient.sky"]);
}

#[test]
fn too_many_lights_points_at_the_first_extra_one() {
    let lights: String =
        (0..=irt::scene::MAX_LIGHTS).map(|i| format!("[[light]]\nposition = [{i}, 1, 1]\n")).collect();
    let src = with(&lights);
    fails_at(
        &src,
        &format!("[[light]]\nposition = [{}, ", irt::scene::MAX_LIGHTS),
        &["too many [[light]]", "16"],
    );
}

#[test]
fn missing_camera() {
    let src = "[[material]]\nname = \"w\"\ntype = \"diffuse\"\n[[sphere]]\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"w\"\n";
    let e = parse(src).unwrap_err();
    assert!(e.message.contains("missing field `camera`"), "{e}");
}

#[test]
fn empty_scene_is_an_error() {
    let no_sphere = &BASE[..BASE.find("[[sphere]]").unwrap()];
    let e = parse(no_sphere).unwrap_err();
    assert_eq!(e.message, EMPTY_SCENE);
    assert_eq!(e.to_string(), format!("{ORIGIN}: {EMPTY_SCENE}"));
    let empty_mesh = format!("{no_sphere}[[mesh]]\nmaterial = \"white\"\npositions = []\nindices = []\n");
    assert_eq!(parse(&empty_mesh).unwrap_err().message, EMPTY_SCENE);
}

// ---- No input panics -----------------------------------------------------------------------
//
// Random text mostly exercises the TOML parser; the edits below also keep the text valid TOML
// often enough (whole lines, single values) to reach the scene checks and shape generators.

/// Character-level noise: brackets, quotes, separators, non-ASCII.
const NOISE: &[&str] =
    &["[", "]", "[[", "]]", "{", "}", "=", ",", "\"", "'", "\n", "#", ".", "é", "\u{0}", "🦀"];

/// Whole lines: table headers and keys, valid or not in the table they land in.
const LINES: &[&str] = &[
    "[[mesh]]",
    "[[sphere]]",
    "[[light]]",
    "[[material]]",
    "[camera]",
    "[ambient]",
    "[trace]",
    "shape = \"icosphere\"",
    "shape = \"box\"",
    "shape = \"quad\"",
    "subdivisions = 6",
    "[[texture]]",
    "texture = \"tiles\"",
    "file = \"scenes/textures/checker.png\"",
    "wrap = [\"clamp\", \"tile\"]",
    "filter = \"nearest\"",
    "uvs = [[0, 0], [1, 0], [0, 1]]",
    "uvs = [[0, 0], [1, 0], [0, 1], [1, 1]]",
    "radius = -1",
    "material = \"matte\"",
    "name = \"steel\"",
    "type = \"metal\"",
    "eta = 1.5",
    "exponent = -3",
    "positions = [[0, 0, 0], [1, 0, 0]]",
    "indices = [[0, 1, 9]]",
    "normals = [[0, 0, 0]]",
    "corners = [[0, 0, 0], [1, 0, 0], [1, 0, 1], [0, 0, 1]]",
    "min = [1, 1, 1]",
    "max = [0, 0, 0]",
    "center = [0, 0, 0]",
    "size = [1, 1]",
    "scale = 0",
    "translate = [1e308, 0, 0]",
    "width = 0",
    "position = [0, 0, 0]",
    "max_depth = 0",
    "up = [0, 0, 0]",
    "fov = 180",
];

/// Replacements for a number: not finite, negative, huge, or not a number at all.
const VALUES: &[&str] = &[
    "nan",
    "inf",
    "-inf",
    "-1",
    "0",
    "7",
    "1e308",
    "-1e308",
    "1e-320",
    "99999999999",
    "4294967296",
    "\"white\"",
    "[]",
    "[1]",
    "[0, 0, 0]",
    "[[0, 1, 2]]",
    "{}",
    "true",
];

#[derive(Clone, Debug)]
enum Edit {
    DeleteChars { at: usize, len: usize },
    InsertNoise { at: usize, pick: usize },
    DeleteLine { line: usize },
    InsertLine { line: usize, pick: usize },
    ReplaceNumber { nth: usize, pick: usize },
}

/// Edits that keep the text valid TOML most of the time, so the scene checks run.
fn structured_edit() -> impl Strategy<Value = Edit> {
    let n = any::<usize>();
    prop_oneof![
        n.prop_map(|line| Edit::DeleteLine { line }),
        (n, n).prop_map(|(line, pick)| Edit::InsertLine { line, pick }),
        (n, n).prop_map(|(nth, pick)| Edit::ReplaceNumber { nth, pick }),
    ]
}

fn any_edit() -> impl Strategy<Value = Edit> {
    let n = any::<usize>();
    prop_oneof![
        (n, 1usize..40).prop_map(|(at, len)| Edit::DeleteChars { at, len }),
        (n, n).prop_map(|(at, pick)| Edit::InsertNoise { at, pick }),
        structured_edit(),
    ]
}

fn pick<'a>(list: &[&'a str], i: usize) -> &'a str {
    list[i % list.len()]
}

/// Applies `edits` to the characters of `src` (so the result stays valid UTF-8).
fn mutate(src: &str, edits: &[Edit]) -> String {
    let mut chars: Vec<char> = src.chars().collect();
    for edit in edits {
        let line_starts: Vec<usize> = (0..=chars.len()).filter(|&i| i == 0 || chars[i - 1] == '\n').collect();
        let line_start = |line: usize| line_starts[line % line_starts.len()];
        match *edit {
            Edit::DeleteChars { at, len } => {
                let at = at % (chars.len() + 1);
                chars.drain(at..(at + len).min(chars.len()));
            }
            Edit::InsertNoise { at, pick: p } => {
                let at = at % (chars.len() + 1);
                chars.splice(at..at, pick(NOISE, p).chars());
            }
            Edit::DeleteLine { line } => {
                let at = line_start(line);
                let end = chars[at..].iter().position(|&c| c == '\n').map_or(chars.len(), |i| at + i + 1);
                chars.drain(at..end);
            }
            Edit::InsertLine { line, pick: p } => {
                let at = line_start(line);
                chars.splice(at..at, format!("{}\n", pick(LINES, p)).chars());
            }
            Edit::ReplaceNumber { nth, pick: p } => {
                let numbers = number_runs(&chars);
                if let Some(run) = numbers.get(nth % numbers.len().max(1)) {
                    chars.splice(run.clone(), pick(VALUES, p).chars());
                }
            }
        }
    }
    chars.into_iter().collect()
}

/// Character ranges of the numbers in `chars` (runs of number characters holding a digit).
fn number_runs(chars: &[char]) -> Vec<std::ops::Range<usize>> {
    let is_number_char = |c: char| c.is_ascii_digit() || "+-.e".contains(c);
    let mut runs = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        let end = (i..chars.len()).find(|&j| !is_number_char(chars[j])).unwrap_or(chars.len());
        if chars[i..end].iter().any(char::is_ascii_digit) {
            runs.push(i..end);
        }
        i = end + 1;
    }
    runs
}

fn check_no_panic(src: &str) {
    match parse(src) {
        Ok(scene) => {
            scene.validate().expect("what parse_str returns is valid");
            assert!(scene.primitive_count() > 0);
        }
        Err(e) => {
            assert!(!e.message.is_empty());
            // Positions are 1-based and inside the text.
            if let Some(line) = e.line {
                assert!(line >= 1 && line <= src.lines().count().max(1) + 1, "{e}");
                assert!(e.column.is_some_and(|c| c >= 1), "{e}");
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

    #[test]
    fn edited_scenes_never_panic(
        base in prop::sample::select(vec![BASE, ALL_FEATURES]),
        edits in prop::collection::vec(structured_edit(), 1..4),
    ) {
        check_no_panic(&mutate(base, &edits));
    }

    #[test]
    fn mutated_scenes_never_panic(
        base in prop::sample::select(vec![BASE, ALL_FEATURES]),
        edits in prop::collection::vec(any_edit(), 1..8),
    ) {
        check_no_panic(&mutate(base, &edits));
    }

    #[test]
    fn random_text_never_panics(src in ".{0,200}") {
        check_no_panic(&src);
    }
}

#[test]
fn cones_reach_the_scene_and_bad_cones_point_at_their_value() {
    let s = parse(&with(
        "[[cone]]\nbase = [0, 0, 0]\napex = [0, 2, 0]\nradius = 0.5\nmaterial = \"white\"\n\
         [[cone]]\nbase = [1, 0, 0]\napex = [1, 1, 0]\nbase_radius = 0.5\napex_radius = 0\nmaterial = \"white\"",
    ))
    .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.cones.len(), 2);
    assert_eq!(
        (s.cones[0].base_radius, s.cones[0].apex_radius, s.cones[0].apex),
        (0.5, 0.5, DVec3::new(0.0, 2.0, 0.0))
    );
    assert_eq!((s.cones[1].base_radius, s.cones[1].apex_radius), (0.5, 0.0));
    assert_eq!(s.primitive_count(), 3);

    let cone = "[[cone]]\nbase = [0, 0, 0]\napex = [0, 1, 0]\nmaterial = \"white\"\n";
    fails_at(&with(&format!("{cone}radius = -1")), "-1", &["radius", "at least 0"]);
    fails_at(&with(&format!("{cone}radius = 1\nbase_radius = 2")), "1\nbase", &["either `radius`"]);
    fails_at(&with(&format!("{cone}base_radius = 2")), "[[cone]]", &["needs `radius`"]);
    fails_at(&with(&format!("{cone}radius = 0")), "[[cone]]", &["cone 0 radii", "not both 0"]);
    let flat = cone.replace("[0, 1, 0]", "[0, 0, 0]");
    fails_at(&with(&format!("{flat}radius = 1")), "[[cone]]", &["cone 0", "same point"]);
    fails_at(&with(&format!("{cone}radius = 1\nheight = 2")), "height", &["unknown field"]);
}

// ---- Textures ------------------------------------------------------------------------------

/// The texels of `checker.png` in [`texture_dir`]: 2x2, every alpha.
const CHECKER: [[u8; 4]; 4] = [[255, 0, 0, 255], [0, 255, 0, 128], [0, 0, 255, 0], [10, 20, 30, 40]];

/// A PNG signature and IHDR header declaring `w`x`h` RGBA8 pixels, and no image data: decoding
/// it fails, so an error about its size proves it was refused from the header.
fn png_header(w: u32, h: u32) -> Vec<u8> {
    let mut b = b"\x89PNG\r\n\x1a\n\0\0\0\x0dIHDR".to_vec();
    b.extend_from_slice(&w.to_be_bytes());
    b.extend_from_slice(&h.to_be_bytes());
    b.extend_from_slice(&[8, 6, 0, 0, 0, 0, 0, 0, 0]);
    b
}

/// A directory with texture files: `checker.png` (a real PNG, [`CHECKER`]), `text.png` (not a
/// PNG), `huge.png` (declares 100000x100000), `4k.png` (declares 4096x4096, the largest texture).
/// Written once: tests run in parallel, and rewriting a file another test is reading would race.
fn texture_dir() -> PathBuf {
    static DIR: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    DIR.get_or_init(|| {
        let png = irt::io::png::encode(2, 2, &CHECKER).unwrap();
        tmp_file("text.png", b"GIF89a, or so it says");
        tmp_file("huge.png", &png_header(100_000, 100_000));
        tmp_file("4k.png", &png_header(4096, 4096));
        tmp_file("checker.png", &png).parent().unwrap().to_path_buf()
    })
    .clone()
}

/// Parses `src` as if it were the file `textured.toml` in [`texture_dir`].
fn parse_textured(src: &str) -> (String, Result<Scene, LoadError>) {
    let origin = texture_dir().join("textured.toml").display().to_string();
    let result = parse_str(src, &origin);
    (origin, result)
}

fn textured_fails_at(src: &str, at: &str, words: &[&str]) -> LoadError {
    let (origin, result) = parse_textured(src);
    common::assert_fails_at(result, src, &origin, at, words)
}

const TEXTURE: &str = "[[texture]]\nname = \"checker\"\nfile = \"checker.png\"\n";

#[test]
fn textures_reach_the_scene() {
    let src = with(&format!(
        "{TEXTURE}\
         [[texture]]\nname = \"odd\"\nfile = \"./checker.png\"\nwrap = [\"mirror\", \"clamp\"]\nfilter = \"nearest\"\n\
         [[texture]]\nname = \"clamped\"\nfile = \"checker.png\"\nwrap = \"clamp\"\n\
         [[material]]\nname = \"tiled\"\ntype = \"polished\"\ntexture = \"odd\"\n\
         {INLINE}indices = [[0, 1, 2]]\nuvs = [[0, 0], [1.5, -0.0], [0, 1e300]]\n\
         [[mesh]]\nmaterial = \"tiled\"\nshape = \"quad\"\ncenter = [0, 0, 0]\nsize = [1, 1]\n\
         uvs = [[0, 0], [0, 1], [1, 1], [1, 0]]\nscale = 2"
    ));
    let (_, result) = parse_textured(&src);
    let s = result.unwrap_or_else(|e| panic!("{e}"));
    let [checker, odd, clamped] = s.textures.as_slice() else { panic!("3 textures") };
    assert_eq!((checker.name.as_str(), checker.width, checker.height), ("checker", 2, 2));
    assert_eq!(checker.texels, CHECKER, "texels as in the file, alpha kept");
    assert_eq!((checker.wrap, checker.filter), ([Wrap::Repeat; 2], Filter::Linear), "the defaults");
    assert_eq!((odd.wrap, odd.filter), ([Wrap::Mirror, Wrap::Clamp], Filter::Nearest));
    assert_eq!(odd.texels, CHECKER);
    assert_eq!(clamped.wrap, [Wrap::Clamp; 2]);
    assert_eq!((s.materials[0].texture, s.materials[1].texture), (None, Some(1)));
    let uvs = s.meshes[0].uvs.as_ref().unwrap();
    assert_eq!(uvs[1], DVec2::new(1.5, -0.0));
    assert!(uvs[1].y.is_sign_negative() && uvs[2].y == 1e300);
    let quad = &s.meshes[1];
    assert_eq!(quad.uvs.as_deref(), Some(&[DVec2::ZERO, DVec2::Y, DVec2::ONE, DVec2::X][..]), "not scaled");
    assert_eq!(quad.positions[0], DVec3::new(-1.0, 0.0, -1.0), "corner 0 is (-x, -z)");
    assert_eq!(s.meshes[0].positions.len(), 3);
}

#[test]
fn the_textured_example_scene_uses_textures() {
    let s = load(&scenes_dir().join("textured.toml")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.textures.len(), 2);
    assert_eq!((s.textures[0].width, s.textures[0].height), (8, 8));
    assert_eq!(s.textures[0].texels, s.textures[1].texels, "one file, two samplers");
    assert!(s.materials.iter().filter(|m| m.texture.is_some()).count() >= 2);
    assert!(s.meshes.iter().all(|m| m.uvs.is_some()));
    let file = std::fs::metadata(scenes_dir().join("textures/checker.png")).unwrap().len();
    assert!(file < 1024, "the example texture is small ({file} bytes)");
}

#[test]
fn missing_texture_file_names_the_path() {
    let src = with("[[texture]]\nname = \"t\"\nfile = \"no/such.png\"");
    let e = textured_fails_at(&src, "\"no/such.png\"", &["cannot read the texture file", "No such file"]);
    let path = texture_dir().join("no/such.png");
    assert!(e.message.contains(&path.display().to_string()), "the path relative to the scene: {e}");
}

#[test]
fn texture_file_that_is_not_a_png() {
    let src = with("[[texture]]\nname = \"t\"\nfile = \"text.png\"");
    textured_fails_at(&src, "\"text.png\"", &["text.png", "is not a PNG", "PNG textures only"]);
}

#[test]
fn texture_too_large_is_refused_from_its_header() {
    let src = with("[[texture]]\nname = \"t\"\nfile = \"huge.png\"");
    let e = textured_fails_at(&src, "\"huge.png\"", &["huge.png", "100000x100000 pixels", "16777216"]);
    assert!(!e.message.contains("decode"), "refused before decoding: {e}");
}

#[test]
fn textures_too_large_together_are_refused_before_decoding() {
    // Two 4096² images are the most a scene may hold; a third is refused before anything is
    // decoded (decoding these headers-only files would fail with another message).
    let big = |i: usize| format!("[[texture]]\nname = \"t{i}\"\nfile = \"4k.png\"\n");
    let src = with(&(0..3).map(big).collect::<String>());
    textured_fails_at(&src, "\"4k.png\"", &["50331648 pixels together", "at most 33554432"]);
}

#[test]
fn too_many_textures_points_at_the_first_extra_one() {
    let n = irt::scene::MAX_TEXTURES;
    let tables: String =
        (0..=n).map(|i| format!("[[texture]]\nname = \"t{i}\"\nfile = \"x.png\"\n")).collect();
    let src = with(&tables);
    textured_fails_at(
        &src,
        &format!("[[texture]]\nname = \"t{n}\""),
        &["too many [[texture]]", &n.to_string()],
    );
}

#[test]
fn unknown_texture_name_on_a_material() {
    let src = with(&format!("{TEXTURE}[[material]]\nname = \"m\"\ntype = \"metal\"\ntexture = \"chekcer\""));
    textured_fails_at(&src, "\"chekcer\"", &["unknown texture 'chekcer'", "(textures defined: 'checker')"]);
    let src = with("[[material]]\nname = \"m\"\ntype = \"diffuse\"\ntexture = \"checker\"");
    fails_at(&src, "\"checker\"", &["unknown texture 'checker'", "defines no [[texture]]"]);
}

#[test]
fn texture_on_a_dielectric() {
    let src = with(&format!(
        "{TEXTURE}[[material]]\nname = \"glass\"\ntype = \"dielectric\"\ntexture = \"checker\""
    ));
    textured_fails_at(
        &src,
        "\"checker\"",
        &["a dielectric material has no colour to texture", "diffuse, metal"],
    );
}

#[test]
fn duplicate_texture_name() {
    let first_line = common::position_of(&with(TEXTURE), "\"checker\"").0;
    let src = with(&format!("{TEXTURE}{TEXTURE}"));
    textured_fails_at(
        &src,
        "\"checker\"",
        &["texture 'checker' is already defined", &format!("on line {first_line}")],
    );
}

#[test]
fn texture_needs_name_and_file() {
    fails_at(&with("[[texture]]\nname = \"t\""), "[[texture]]", &["missing field `file`"]);
    fails_at(&with("[[texture]]\nfile = \"t.png\""), "[[texture]]", &["missing field `name`"]);
    fails_at(
        &with("[[texture]]\nname = \"t\"\nfile = \"t.png\"\nsize = 2"),
        "size",
        &["unknown field `size`"],
    );
}

#[test]
fn bad_wrap_and_filter_words() {
    let expected = ["\"repeat\", \"clamp\", \"mirror\""];
    let src = with(&format!("{TEXTURE}wrap = \"tile\""));
    textured_fails_at(&src, "\"tile\"", &[&["unknown `wrap` \"tile\""][..], &expected].concat());
    let src = with(&format!("{TEXTURE}wrap = [\"repeat\", \"Clamp\"]"));
    textured_fails_at(&src, "[\"repeat\"", &["unknown `wrap` \"Clamp\""]);
    let src = with(&format!("{TEXTURE}wrap = [\"repeat\"]"));
    textured_fails_at(&src, "[\"repeat\"]", &["`wrap` needs 2 modes", "found 1"]);
    let src = with(&format!("{TEXTURE}wrap = 3"));
    textured_fails_at(&src, "3", &["a wrap mode", "[u mode, v mode]"]);
    let src = with(&format!("{TEXTURE}filter = \"cubic\""));
    textured_fails_at(&src, "\"cubic\"", &["unknown `filter` \"cubic\"", "\"nearest\", \"linear\""]);
}

#[test]
fn uvs_count_must_match_the_vertices() {
    let src = with(&format!("{INLINE}indices = [[0, 1, 2]]\nuvs = [[0, 0], [1, 0]]"));
    fails_at(&src, "[[0, 0], [1, 0]]", &["`uvs` has 2 entries", "`positions` has 3 vertices"]);
    let quad = "[[mesh]]\nmaterial = \"white\"\nshape = \"quad\"\ncenter = [0, 0, 0]\nsize = [1, 1]\n";
    let src = with(&format!("{quad}uvs = [[0, 0], [1, 0], [1, 1]]"));
    fails_at(&src, "[[0, 0], [1, 0], [1, 1]]", &["`uvs` has 3 entries", "a quad has 4 vertices"]);
    let src = with(&format!("{INLINE}indices = [[0, 1, 2]]\nuvs = [[0, 0], [1, 0], [0, 1, 0]]"));
    fails_at(&src, "[0, 1, 0]", &["`uvs` needs 2 numbers", "found 3"]);
    let src =
        with("[[mesh]]\nmaterial = \"white\"\nshape = \"box\"\nmin = [0, 0, 0]\nmax = [1, 1, 1]\nuvs = []");
    fails_at(&src, "[]", &["`uvs` does not apply to a box"]);
}

#[test]
fn non_finite_uv() {
    let src = with(&format!("{INLINE}indices = [[0, 1, 2]]\nuvs = [[0, 0], [0, nan], [0, 1]]"));
    fails_at(&src, "[0, nan]", &["`uvs` contains NaN", "finite"]);
    let src = with(&format!("{INLINE}indices = [[0, 1, 2]]\nuvs = [[0, 0], [1, 0], [-inf, 1]]"));
    fails_at(&src, "[-inf, 1]", &["`uvs` contains -inf"]);
}
