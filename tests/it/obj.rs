//! The Wavefront OBJ loader (src/io/obj.rs, docs/obj.md): real files from the field load with
//! what they declare and render on the GPU as the CPU reference does; faces are triangulated
//! correctly (concave ones too), normals and texture coordinates kept, MTL materials mapped by
//! the documented rule; a missing MTL or texture is a warning naming it; every bad input is an
//! error at its file, line and column, never a panic.
use crate::common;

use glam::{DVec2, DVec3};
use irt::io::obj::{material_kind, parse};
use irt::io::{load, LoadError};
use irt::scene::{MaterialKind, Mesh, Scene, Wrap};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

const ORIGIN: &str = "test.obj";
/// Three vertices for faces to use.
const TRIANGLE: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";

fn models() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/models")
}

fn load_model(relative: &str) -> Scene {
    load(&models().join(relative)).unwrap_or_else(|e| panic!("{e}"))
}

fn parse_str(src: &str) -> Result<Scene, LoadError> {
    parse(src.as_bytes(), ORIGIN)
}

/// A new empty directory for one test's files.
fn fresh_dir(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("obj").join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Writes `files` (name, contents) into a fresh directory; returns the path of the first.
fn write_files(test: &str, files: &[(&str, &[u8])]) -> PathBuf {
    let dir = fresh_dir(test);
    for (name, bytes) in files {
        std::fs::write(dir.join(name), bytes).unwrap();
    }
    dir.join(files[0].0)
}

// ---- Warnings ----------------------------------------------------------------------------------

/// Every warning logged in this test process (tests run in parallel: each looks for its own
/// file's name in them).
static WARNINGS: Mutex<Vec<String>> = Mutex::new(Vec::new());

struct Capture;

impl log::Log for Capture {
    fn enabled(&self, m: &log::Metadata) -> bool {
        m.level() <= log::Level::Warn
    }
    fn log(&self, r: &log::Record) {
        if self.enabled(r.metadata()) {
            WARNINGS.lock().unwrap().push(r.args().to_string());
        }
    }
    fn flush(&self) {}
}

fn warnings_naming(needle: &str) -> Vec<String> {
    static INSTALL: std::sync::Once = std::sync::Once::new();
    INSTALL.call_once(|| {
        log::set_logger(&Capture).unwrap();
        log::set_max_level(log::LevelFilter::Warn);
    });
    WARNINGS.lock().unwrap().iter().filter(|w| w.contains(needle)).cloned().collect()
}

/// Loads `path` with the logger installed; returns the scene and the warnings that name `path`.
fn load_warned(path: &Path) -> (Scene, Vec<String>) {
    warnings_naming("");
    let scene = load(path).unwrap_or_else(|e| panic!("{e}"));
    (scene, warnings_naming(&path.parent().unwrap().display().to_string()))
}

fn assert_warned(warnings: &[String], words: &[&str]) {
    assert!(
        warnings.iter().any(|w| words.iter().all(|x| w.contains(x))),
        "no warning with {words:?} in {warnings:#?}"
    );
}

// ---- Geometry ----------------------------------------------------------------------------------

/// Twice the area of each triangle along `normal` (negative if wound against it).
fn signed_areas(mesh: &Mesh, normal: DVec3) -> Vec<f64> {
    mesh.indices
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
            (b - a).cross(c - a).dot(normal)
        })
        .collect()
}

/// Newell's normal of a polygon: its direction is the polygon's facing, its length twice its
/// area (for a polygon joined to a hole by a bridge, the area without the hole).
fn newell(p: &[DVec3]) -> DVec3 {
    (0..p.len()).map(|i| p[i].cross(p[(i + 1) % p.len()])).sum()
}

#[test]
fn a_concave_face_is_triangulated_into_exactly_its_area() {
    // An L (six corners, one reflex) and a comb whose fan from the first corner would cover the
    // gaps between its teeth.
    let l = [(0., 0.), (2., 0.), (2., 1.), (1., 1.), (1., 2.), (0., 2.)];
    let mut comb = vec![(0.0, 0.0), (9.0, 0.0)];
    for k in (0..5).rev() {
        let x = 2.0 * k as f64;
        comb.extend([(x + 1.0, 3.0), (x + 1.0, 1.0), (x, 1.0), (x, 3.0)]);
    }
    comb.truncate(comb.len() - 3);
    for polygon in [&l[..], &comb[..]] {
        let mut src: String = polygon.iter().map(|(x, y)| format!("v {x} {y} 0\n")).collect();
        src += &format!("f {}\n", (1..=polygon.len()).map(|i| i.to_string()).collect::<Vec<_>>().join(" "));
        let scene = parse_str(&src).unwrap_or_else(|e| panic!("{e}"));
        let mesh = &scene.meshes[0];
        // n - 2 triangles, fewer where corners make no turn (the comb has some).
        assert!(mesh.indices.len() <= polygon.len() - 2);
        if polygon.len() == l.len() {
            assert_eq!(mesh.indices.len(), 4);
        }
        let points: Vec<DVec3> = polygon.iter().map(|&(x, y)| DVec3::new(x, y, 0.0)).collect();
        let area = newell(&points).z;
        let areas = signed_areas(mesh, DVec3::Z);
        assert!(areas.iter().all(|&a| a > 0.0), "every triangle wound like the face: {areas:?}");
        assert!((areas.iter().sum::<f64>() - area).abs() < 1e-12, "covers the face exactly once");
    }
}

#[test]
fn the_lightwave_ring_is_triangulated_into_its_area() {
    // One 66-corner face: a ring joined to its hole by a bridge, all in the plane x = -1.146.
    let path = models().join("concave/concave_polygon.obj");
    let src = std::fs::read_to_string(&path).unwrap();
    let positions: Vec<DVec3> = src
        .lines()
        .filter_map(|l| l.strip_prefix("v "))
        .map(|l| {
            let n: Vec<f64> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
            DVec3::new(n[0], n[1], n[2])
        })
        .collect();
    let face: Vec<DVec3> = src
        .lines()
        .find_map(|l| l.strip_prefix("f "))
        .unwrap()
        .split_whitespace()
        .map(|c| positions[c.split('/').next().unwrap().parse::<usize>().unwrap() - 1])
        .collect();
    assert_eq!(face.len(), 66);
    let normal = newell(&face);
    let scene = load_model("concave/concave_polygon.obj");
    assert_eq!(scene.meshes.len(), 1);
    let mesh = &scene.meshes[0];
    let areas = signed_areas(mesh, normal.normalize());
    assert!(areas.iter().all(|&a| a > 0.0), "every triangle faces the ring's way");
    let covered: f64 = areas.iter().sum();
    assert!((covered - normal.length()).abs() < 1e-9 * normal.length(), "{covered} vs {}", normal.length());
    // The face's normal (`vn 1 0 -0`) on every vertex: smooth shading from the file.
    assert_eq!(mesh.normals.as_ref().unwrap(), &vec![DVec3::X; mesh.positions.len()]);
    // "Kd 0.141176 0.184314 0.411765", "Ks 0 0 0": diffuse in Kd.
    assert_eq!(scene.materials[0].name, "test");
    assert_eq!(
        scene.materials[0].kind,
        MaterialKind::Diffuse { color: DVec3::new(0.141176, 0.184314, 0.411765) }
    );
}

#[test]
fn normals_and_texture_coordinates_are_kept_one_per_vertex() {
    // A quad whose corners share positions with a triangle that has other normals: the quad's
    // four (v, vt, vn) become four vertices, and the triangle's corners new ones.
    let src = "v 0 0 0\nv 2 0 0\nv 2 2 0\nv 0 2 0\n\
               vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
               vn 0 0 2\nvn 0 0.6 0.8\n\
               f 1/1/1 2/2/1 3/3/1 4/4/1\n\
               f -4/-4/-1 -3/-3/-1 -2/-2/-1\n";
    let scene = parse_str(src).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.meshes.len(), 1);
    let m = &scene.meshes[0];
    assert_eq!((m.positions.len(), m.indices.len()), (7, 3));
    let (normals, uvs) = (m.normals.as_ref().unwrap(), m.uvs.as_ref().unwrap());
    for (i, p) in m.positions.iter().enumerate().take(4) {
        // Normalised; v turned over (irt reads v down from the top of the image, OBJ up).
        assert_eq!(normals[i], DVec3::Z);
        assert_eq!(uvs[i], DVec2::new(p.x / 2.0, 1.0 - p.y / 2.0));
    }
    assert!(normals[4..].iter().all(|&n| n == DVec3::new(0.0, 0.6, 0.8)));
    // Untextured, so the texture coordinates are kept but read by nothing; diffuse default.
    assert_eq!(scene.materials.len(), 1);
    assert_eq!(scene.materials[0].kind, MaterialKind::Diffuse { color: DVec3::splat(0.8) });
}

#[test]
fn faces_with_and_without_normals_go_to_separate_meshes() {
    let path = write_files(
        "mixed",
        &[(
            "mixed.obj",
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvn 0 0 1\nvn 0 0 0\n\
              f 1//1 2//1 3//1\nf 2 4 3\nf 2//1 4 3//1\nf 1//2 2//1 3//1\n",
        )],
    );
    let (scene, warnings) = load_warned(&path);
    // The first face has normals; the second none; the third mixes (its normals dropped);
    // the fourth uses a zero normal (flat).
    assert_eq!(scene.meshes.len(), 2);
    assert_eq!(scene.meshes[0].normals.as_ref().map(Vec::len), Some(3));
    assert_eq!(scene.meshes[0].indices.len(), 1);
    assert!(scene.meshes[1].normals.is_none());
    assert_eq!(scene.meshes[1].indices.len(), 3);
    assert_warned(&warnings, &["mixed.obj:9:", "mixes corners"]);
    assert_warned(&warnings, &["mixed.obj:10:", "zero normal"]);
}

#[test]
fn a_position_used_in_many_ways_is_one_vertex_per_way() {
    // Twelve normals for the same three positions: 36 vertices, past the short list each
    // position keeps (8 entries); the same faces again add triangles but no vertex.
    let normals: String = (0..12).map(|k| format!("vn 0 {} 1\n", k as f64 / 12.0)).collect();
    let faces: String = (1..=12).map(|k| format!("f 1//{k} 2//{k} 3//{k}\n")).collect();
    let scene = parse_str(&format!("{TRIANGLE}{normals}{faces}{faces}")).unwrap_or_else(|e| panic!("{e}"));
    let mesh = &scene.meshes[0];
    assert_eq!((mesh.positions.len(), mesh.indices.len()), (36, 24));
    assert_eq!(mesh.indices[..12], mesh.indices[12..]);
    let normals = mesh.normals.as_ref().unwrap();
    for (k, t) in mesh.indices[..12].iter().enumerate() {
        let expected = DVec3::new(0.0, k as f64 / 12.0, 1.0).normalize();
        assert!(t.iter().all(|&i| normals[i as usize] == expected), "face {k}");
    }
}

#[test]
fn faces_without_area_are_skipped_and_counted() {
    let src = format!("{TRIANGLE}v 2 0 0\nf 1 2 3\nf 1 2 4\nf 2 2 2\n");
    let scene = parse_str(&src).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.triangle_count(), 1);
    let e = parse_str(&format!("{TRIANGLE}v 2 0 0\nf 1 2 4\n")).unwrap_err();
    assert!(e.message.contains("no faces to render"), "{e}");
}

#[test]
fn lines_points_and_unknown_statements_are_ignored_with_a_warning() {
    let path = write_files(
        "ignored",
        &[(
            "ignored.obj",
            b"v 0 0 0\nv 1 0 0\nv 0 1 0 0.5 0.5 0.5\nl 1 2 3\np 1\nl 2 3\ncurv 0 1 1 2\n\
              g a b\no thing\ns 1\nfrobnicate 7\nf 1 2 3\n",
        )],
    );
    let (scene, warnings) = load_warned(&path);
    // The polyline `l 1 2 3` is not filled as a triangle: only the face is drawn.
    assert_eq!(scene.triangle_count(), 1);
    assert_warned(&warnings, &["ignored.obj:4:", "`l` ignored (2 times)", "lines"]);
    assert_warned(&warnings, &["ignored.obj:5:", "`p` ignored"]);
    assert_warned(&warnings, &["ignored.obj:7:", "`curv` ignored", "free-form"]);
    assert_warned(&warnings, &["ignored.obj:11:", "`frobnicate` ignored", "unknown"]);
    assert_warned(&warnings, &["ignored.obj:3:", "vertex colours"]);
    assert!(!warnings.iter().any(|w| w.contains("`g`") || w.contains("`s`") || w.contains("`o`")));
}

#[test]
fn text_that_is_not_utf8_in_a_comment_or_name_loads() {
    let mut src = b"# Export\xe9 par un vieux programme\n".to_vec();
    src.extend(format!("{TRIANGLE}usemtl caf\u{e9}\nf 1 2 3\n").as_bytes());
    let scene = parse(&src, ORIGIN).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.triangle_count(), 1);
    assert_eq!(scene.materials[0].name, "café");
}

// ---- Materials ---------------------------------------------------------------------------------

#[test]
fn the_mtl_rule_maps_onto_the_four_materials() {
    let (kd, ks) = (DVec3::new(0.8, 0.4, 0.2), DVec3::splat(0.5));
    let k = |kd, ks, ns, ni, d, illum| material_kind(kd, ks, ns, ni, d, illum);
    // Transparent: illum 4, 6, 7 or 9, or d < 1; Ni the index (1.5 where it says 1 or nothing).
    for illum in [4, 6, 7, 9] {
        assert_eq!(
            k(kd, ks, Some(50.0), Some(1.33), 1.0, Some(illum)),
            MaterialKind::Dielectric { eta: 1.33, exponent: 50.0 }
        );
    }
    assert_eq!(
        k(kd, ks, None, Some(1.0), 0.5, Some(2)),
        MaterialKind::Dielectric { eta: 1.5, exponent: 128.0 }
    );
    assert_eq!(k(kd, ks, None, None, 0.99, None), MaterialKind::Dielectric { eta: 1.5, exponent: 128.0 });
    // No specular part, or an illumination model without one: diffuse in Kd.
    assert_eq!(k(kd, DVec3::ZERO, Some(10.0), None, 1.0, Some(2)), MaterialKind::Diffuse { color: kd });
    assert_eq!(k(kd, ks, Some(10.0), None, 1.0, Some(1)), MaterialKind::Diffuse { color: kd });
    assert_eq!(k(kd, ks, Some(10.0), None, 1.0, Some(0)), MaterialKind::Diffuse { color: kd });
    // Kd under a tenth of Ks: metal in Ks, whatever the model.
    for illum in [None, Some(2), Some(3)] {
        assert_eq!(
            k(DVec3::splat(0.04), ks, Some(200.0), None, 1.0, illum),
            MaterialKind::Metal { color: ks, exponent: 200.0 }
        );
    }
    // Ray-traced reflection (illum 3, 5, 8): a coat reflecting Ks at normal incidence.
    for illum in [3, 5, 8] {
        let MaterialKind::Polished { color, eta, exponent } = k(kd, ks, Some(20.0), None, 1.0, Some(illum))
        else {
            panic!("polished")
        };
        assert_eq!((color, exponent), (kd, 20.0));
        assert!((((eta - 1.0) / (eta + 1.0)).powi(2) - 0.5).abs() < 1e-12, "R0 = Ks");
    }
    // A highlight alone (illum 2 or none): a plastic coat of index Ni, else 1.5.
    assert_eq!(
        k(kd, ks, Some(20.0), Some(1.45), 1.0, Some(2)),
        MaterialKind::Polished { color: kd, eta: 1.45, exponent: 20.0 }
    );
    assert_eq!(
        k(kd, ks, None, Some(1.0), 1.0, None),
        MaterialKind::Polished { color: kd, eta: 1.5, exponent: 128.0 }
    );
    // Ns is clamped to [1, 10000]: Ns 0 would be a highlight of constant strength.
    assert_eq!(
        k(kd, ks, Some(0.0), None, 1.0, None),
        MaterialKind::Polished { color: kd, eta: 1.5, exponent: 1.0 }
    );
    assert_eq!(
        k(DVec3::ZERO, ks, Some(1e6), None, 1.0, None),
        MaterialKind::Metal { color: ks, exponent: 10_000.0 }
    );
}

#[test]
fn mtl_statements_reach_the_materials() {
    let mtl = b"# a library\n\
        newmtl glass\nKd 1 1 1\nKs 1 1 1\nNi 1.33\nd 0.2\nillum 2\n\
        newmtl clear\nTr 0.5\n\
        newmtl opaque\nTr 0\nKd 0.25\nKs 0\n\
        newmtl chrome\n  Kd 0 0 0   # black\n  Ks 0.9 0.8 0.7\n  Ns 300\n\
        newmtl grey\n\
        newmtl halo\nd -halo 0.5\nKd spectral file.rfl\n";
    let obj = format!(
        "mtllib lib.mtl  # a comment, not a second library\n{TRIANGLE}{}",
        ["glass", "clear", "opaque", "chrome", "grey", "halo"]
            .map(|m| format!("usemtl {m}\nf 1 2 3\n"))
            .concat()
    );
    let path = write_files("statements", &[("scene.obj", obj.as_bytes()), ("lib.mtl", mtl)]);
    let (scene, warnings) = load_warned(&path);
    let kinds: Vec<_> = scene.materials.iter().map(|m| (m.name.as_str(), m.kind.clone())).collect();
    assert_eq!(
        kinds,
        [
            ("glass", MaterialKind::Dielectric { eta: 1.33, exponent: 128.0 }),
            ("clear", MaterialKind::Dielectric { eta: 1.5, exponent: 128.0 }),
            ("opaque", MaterialKind::Diffuse { color: DVec3::splat(0.25) }),
            ("chrome", MaterialKind::Metal { color: DVec3::new(0.9, 0.8, 0.7), exponent: 300.0 }),
            ("grey", MaterialKind::Diffuse { color: DVec3::splat(0.8) }),
            ("halo", MaterialKind::Dielectric { eta: 1.5, exponent: 128.0 }),
        ]
    );
    assert_warned(&warnings, &["lib.mtl:21:", "spectral", "ignored"]);
    assert!(!warnings.iter().any(|w| w.contains("not found")), "{warnings:#?}");
    // One mesh per material, in the order of use.
    assert_eq!(scene.meshes.iter().map(|m| m.material).collect::<Vec<_>>(), [0, 1, 2, 3, 4, 5]);
}

/// A 2x1 PNG: red, then blue.
fn tiny_png() -> Vec<u8> {
    irt::io::png::encode(2, 1, &[[255, 0, 0, 255], [0, 0, 255, 255]]).unwrap()
}

#[test]
fn map_kd_is_a_base_colour_texture_with_its_options() {
    let mtl =
        b"newmtl tiled\nKd 1 0.5 1\nmap_Kd -s 2 3 1 -o 0.5 0.25 -clamp on -bm 0.2 textures\\my tex.png\n\
                newmtl plain\nmap_Kd -blendu off textures/my tex.png\n";
    let obj = format!("mtllib lib.mtl\n{TRIANGLE}vt 0 0\nvt 1 0\nvt 0 1\nusemtl tiled\nf 1/1 2/2 3/3\nusemtl plain\nf 1/1 2/2 3/3\n");
    let dir = fresh_dir("map_kd");
    std::fs::create_dir(dir.join("textures")).unwrap();
    std::fs::write(dir.join("textures/my tex.png"), tiny_png()).unwrap();
    std::fs::write(dir.join("lib.mtl"), mtl).unwrap();
    std::fs::write(dir.join("scene.obj"), obj).unwrap();
    let scene = load(&dir.join("scene.obj")).unwrap_or_else(|e| panic!("{e}"));
    // One image under two wraps: two textures, one per -clamp setting, uniquely named.
    assert_eq!(scene.textures.len(), 2);
    assert_eq!(scene.textures[0].name, "textures\\my tex.png");
    assert_eq!(scene.textures[1].name, "textures/my tex.png");
    assert_eq!((scene.textures[0].wrap, scene.textures[1].wrap), ([Wrap::Clamp; 2], [Wrap::Repeat; 2]));
    assert_eq!(scene.textures[0].texels, vec![[255, 0, 0, 255], [0, 0, 255, 255]]);
    assert_eq!(scene.materials[0].kind, MaterialKind::Diffuse { color: DVec3::new(1.0, 0.5, 1.0) });
    assert_eq!((scene.materials[0].texture, scene.materials[1].texture), (Some(0), Some(1)));
    // -s 2 3, -o 0.5 0.25: (u, v) → (0.5 + 2u, 1 - (0.25 + 3v)); without options (u, 1 - v).
    // The vertices are (0,0,0), (1,0,0), (0,1,0) with (u, v) = (x, y).
    for (m, f) in [
        (0, (|p: DVec3| DVec2::new(0.5 + 2.0 * p.x, 0.75 - 3.0 * p.y)) as fn(DVec3) -> DVec2),
        (1, |p| DVec2::new(p.x, 1.0 - p.y)),
    ] {
        let mesh = &scene.meshes[m];
        let uvs = mesh.uvs.as_ref().unwrap();
        assert_eq!(uvs.len(), 3);
        for (p, uv) in mesh.positions.iter().zip(uvs) {
            assert_eq!(*uv, f(*p), "material {m} at {p}");
        }
    }
}

#[test]
fn a_missing_mtl_or_texture_loads_with_a_warning_naming_it() {
    let mtl = b"newmtl gone\nKd 0.5 0.5 0.5\nmap_Kd gone.png\nnewmtl photo\nKd 1 1 1\nmap_Kd photo.jpg\n";
    let obj = format!(
        "mtllib nowhere.mtl\nmtllib lib.mtl\n{TRIANGLE}usemtl gone\nf 1 2 3\nusemtl photo\nf 1 2 3\nusemtl unknown\nf 1 2 3\n"
    );
    let path = write_files(
        "missing",
        &[("scene.obj", obj.as_bytes()), ("lib.mtl", mtl), ("photo.jpg", b"\xff\xd8\xff\xe0 not really")],
    );
    let (scene, warnings) = load_warned(&path);
    let dir = path.parent().unwrap().display().to_string();
    assert_warned(&warnings, &["scene.obj:1:", &format!("{dir}/nowhere.mtl"), "not found"]);
    assert_warned(&warnings, &["lib.mtl:3:", &format!("{dir}/gone.png"), "not found", "colour alone"]);
    assert_warned(&warnings, &["lib.mtl:6:", "photo.jpg", "not a PNG"]);
    assert_warned(&warnings, &["scene.obj:10:", "'unknown' is not defined"]);
    assert!(scene.textures.is_empty());
    assert!(scene.materials.iter().all(|m| m.texture.is_none()));
    assert_eq!(scene.materials[0].kind, MaterialKind::Diffuse { color: DVec3::splat(0.5) });
}

// ---- Real files --------------------------------------------------------------------------------

/// Triangles the file's faces make (an n-gon makes n - 2; a face without area none), read
/// from the text without irt's loader (these files use positive vertex indices, or -1 to -4).
fn declared_triangles(path: &Path) -> usize {
    let src = std::fs::read_to_string(path).unwrap();
    let mut positions = Vec::new();
    let mut triangles = 0;
    for line in src.lines().map(str::trim) {
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.first() {
            Some(&"v") => positions.push(DVec3::new(
                words[1].parse().unwrap(),
                words[2].parse().unwrap(),
                words[3].parse().unwrap(),
            )),
            Some(&"f") => {
                let face: Vec<DVec3> = words[1..]
                    .iter()
                    .map(|c| {
                        let i: i64 = c.split('/').next().unwrap().parse().unwrap();
                        positions[if i < 0 { positions.len() as i64 + i } else { i - 1 } as usize]
                    })
                    .collect();
                if newell(&face) != DVec3::ZERO {
                    triangles += face.len() - 2;
                }
            }
            _ => {}
        }
    }
    triangles
}

#[test]
fn the_real_files_load_with_what_they_declare() {
    for (file, materials, textures, normals, uvs) in [
        ("cornell/cornell_box.obj", 4, 0, false, false),
        ("concave/concave_polygon.obj", 1, 0, true, false),
        ("spider/spider.obj", 4, 0, true, true),
        ("spot/spot.obj", 1, 1, false, true),
    ] {
        let path = models().join(file);
        let s = load_model(file);
        assert_eq!(s.triangle_count(), declared_triangles(&path), "{file}");
        assert_eq!((s.materials.len(), s.textures.len()), (materials, textures), "{file}");
        assert!(s.meshes.iter().all(|m| m.normals.is_some() == normals), "{file}: normals");
        assert!(s.meshes.iter().all(|m| m.uvs.is_some() == uvs), "{file}: texture coordinates");
        // Staged: the framing camera and the light, as every model without them gets.
        assert_eq!(s.lights.len(), 1, "{file}");
        assert!(s.ambient.sky.max_element() > 0.0);
    }
}

#[test]
fn the_cornell_box_reads_both_libraries_and_warns_about_its_textures() {
    let (s, warnings) = load_warned(&models().join("cornell/cornell_box.obj"));
    let names: Vec<&str> = s.materials.iter().map(|m| m.name.as_str()).collect();
    // In the order faces first use them; `blue` (the front wall) has no face left.
    assert_eq!(names, ["white", "light", "green", "red"]);
    let kind = |n: &str| s.materials.iter().find(|m| m.name == n).unwrap().kind.clone();
    assert_eq!(kind("white"), MaterialKind::Diffuse { color: DVec3::ONE });
    assert_eq!(kind("red"), MaterialKind::Diffuse { color: DVec3::X });
    // light: "Ni 1.25", "d 0.8" (cornell_box2.mtl): not opaque, so glass of index 1.25.
    assert_eq!(kind("light"), MaterialKind::Dielectric { eta: 1.25, exponent: 128.0 });
    assert_warned(&warnings, &["cornell_box.mtl:13:", "this diffuse texture has spaces.jpg", "not found"]);
    assert_warned(&warnings, &["cornell_box2.mtl:20:", "dummy_texture.png", "not found"]);
}

#[test]
fn the_spider_keeps_its_colours_where_its_textures_are_jpeg() {
    let (s, warnings) = load_warned(&models().join("spider/spider.obj"));
    assert!(s.textures.is_empty());
    // `map_Kd .\SpiderTex.jpg`: found through the backslash, refused as a JPEG.
    assert_warned(&warnings, &["spider.mtl:", "SpiderTex.jpg", "not a PNG"]);
    assert_warned(&warnings, &["spider.mtl:", "drkwood2.jpg", "not found"]);
    let skin = s.materials.iter().find(|m| m.name == "Skin").unwrap();
    assert_eq!(skin.kind, MaterialKind::Diffuse { color: DVec3::new(0.827451, 0.792157, 0.772549) });
}

#[test]
fn spot_samples_its_texture() {
    let s = load_model("spot/spot.obj");
    let t = &s.textures[0];
    assert_eq!((t.width, t.height, t.name.as_str()), (1024, 1024, "spot_texture.png"));
    assert_eq!(s.materials[0].texture, Some(0));
    // The mean colour where the surface reads the texture: Spot's white hide with its
    // patches, not the image's black background.
    let uvs = s.meshes[0].uvs.as_ref().unwrap();
    let mean = uvs.iter().map(|&uv| irt::reference::sample_texture(t, uv)).sum::<DVec3>() / uvs.len() as f64;
    assert!(mean.min_element() > 0.3, "{mean}");
}

#[test]
fn a_model_in_a_toml_scene_finds_its_libraries_and_textures_beside_the_obj() {
    // The scene is elsewhere: Spot's MTL and PNG must be found relative to spot.obj, not to it.
    let obj = models().join("spot/spot.obj");
    let dir = fresh_dir("model");
    let src = format!(
        "[camera]\neye = [0, 0.5, 4]\nlook_at = [0, 0, 0]\nfov = 40\nwidth = 48\nheight = 36\n\n\
         [[light]]\nposition = [3, 5, 4]\ncolor = [1, 1, 1]\n\n\
         [[model]]\nfile = {:?}\nrotate = [0, 90, 0]\ntranslate = [0, -0.2, 0]\n",
        obj.display().to_string()
    );
    std::fs::write(dir.join("scene.toml"), &src).unwrap();
    let scene = load(&dir.join("scene.toml")).unwrap_or_else(|e| panic!("{e}"));
    let alone = irt::io::load_model(&obj).unwrap();
    assert_eq!(scene.triangle_count(), alone.meshes.iter().map(|m| m.indices.len()).sum::<usize>());
    assert_eq!(scene.textures.len(), 1);
    assert!(scene.textures[0].texels == alone.textures[0].texels);
    assert_eq!(scene.materials[0].texture, Some(0));
    assert_eq!(scene.meshes[0].uvs, alone.meshes[0].uvs, "the texture coordinates are not moved");
    let ctx = common::gpu();
    common::assert_matches_reference(
        "obj-model-spot",
        &common::render_gpu(&ctx, &scene),
        &common::reference_image(&scene),
    );
}

// ---- GPU against the CPU reference ---------------------------------------------------------

fn golden(file: &str) {
    let mut scene = load_model(file);
    scene.camera.width = 96;
    scene.camera.height = 72;
    let ctx = common::gpu();
    let gpu = common::render_gpu(&ctx, &scene);
    common::assert_matches_reference(
        &format!("obj-{}", file.replace('/', "-")),
        &gpu,
        &common::reference_image(&scene),
    );
}

#[test]
fn golden_cornell_box() {
    golden("cornell/cornell_box.obj");
}

#[test]
fn golden_spider() {
    golden("spider/spider.obj");
}

#[test]
fn golden_spot_textured() {
    golden("spot/spot.obj");
}

#[test]
fn golden_concave_ring() {
    golden("concave/concave_polygon.obj");
}

// ---- Errors ------------------------------------------------------------------------------------

/// Asserts that `src` fails at the last `at` with a message containing every one of `words`.
fn fails_at(src: &str, at: &str, words: &[&str]) -> LoadError {
    common::assert_fails_at(parse_str(src), src, ORIGIN, at, words)
}

#[test]
fn bad_numbers_are_errors_at_the_number() {
    fails_at(&format!("{TRIANGLE}v 1 2 x3\n"), "x3", &["a number", "`x3`"]);
    fails_at(&format!("{TRIANGLE}v 1 nan 2\n"), "nan", &["finite"]);
    fails_at(&format!("{TRIANGLE}v 1 1e999 2\n"), "1e999", &["finite"]);
    fails_at(&format!("{TRIANGLE}vn 0 -inf 1\n"), "-inf", &["finite"]);
    fails_at(&format!("{TRIANGLE}vt 0.5 inf\n"), "inf", &["finite"]);
    fails_at(&format!("{TRIANGLE}vt 0.5 0.5,\n"), "0.5,", &["a number"]);
    fails_at(&format!("{TRIANGLE}v 1 2\n"), "v 1 2", &["3 to 7 numbers", "has 2"]);
    fails_at(&format!("{TRIANGLE}v 1 2 3 4 5 6 7 8\n"), "8", &["3 to 7", "has 8"]);
    fails_at(&format!("{TRIANGLE}vn 1 2\n"), "vn", &["3 numbers", "has 2"]);
    fails_at(&format!("{TRIANGLE}vt\n"), "vt", &["1 to 3", "has 0"]);
}

#[test]
fn bad_face_indices_are_errors_at_the_index() {
    fails_at(&format!("{TRIANGLE}f 1 2 4\n"), "4", &["vertex index 4", "out of range", "3 `v` lines"]);
    fails_at(&format!("{TRIANGLE}f 1 2 0\n"), "0\n", &["index 0", "start at 1"]);
    fails_at(&format!("{TRIANGLE}f -1 -2 -4\n"), "-4", &["vertex index -4", "out of range"]);
    fails_at(&format!("{TRIANGLE}f 1/5 2 3\n"), "5 2", &["texture coordinate index 5", "0 `vt` lines"]);
    fails_at(
        &format!("{TRIANGLE}vn 0 0 1\nf 1//1 2//2 3//1\n"),
        "2 3//1",
        &["normal index 2", "1 `vn` lines"],
    );
    fails_at(&format!("{TRIANGLE}f 1 2.5 3\n"), "2.5", &["whole number"]);
    fails_at(&format!("{TRIANGLE}f 1 2 99999999999999999999\n"), "99999999999999999999", &["whole number"]);
    fails_at(&format!("{TRIANGLE}f 1/1/1/1 2 3\n"), "1/1/1/1", &["not a face vertex"]);
    fails_at(&format!("{TRIANGLE}f 1 2\n"), "f 1 2", &["at least 3 vertices", "has 2"]);
    fails_at(&format!("{TRIANGLE}f\n"), "f\n", &["at least 3 vertices", "has 0"]);
    // An index counts what is defined before the face, not after it.
    fails_at(&format!("{TRIANGLE}f 1 2 4\nv 1 1 0\n"), "4\n", &["vertex index 4"]);
    let many = format!("{TRIANGLE}f {}\n", "1 ".repeat(irt::io::shapes::MAX_POLYGON_VERTICES + 1));
    let e = parse_str(&many).unwrap_err();
    assert!(e.message.contains("more than 4096 vertices") && e.line == Some(4), "{e}");
}

#[test]
fn statements_without_their_name_are_errors() {
    fails_at(&format!("{TRIANGLE}usemtl   \nf 1 2 3\n"), "usemtl", &["needs a name"]);
    fails_at(&format!("{TRIANGLE}mtllib\n"), "mtllib", &["needs a name"]);
}

#[test]
fn counts_past_the_limits_are_refused_before_parsing() {
    use irt::io::{MAX_TRIANGLES, MAX_VERTICES};
    // One `v` too many; the numbers after the limit are never parsed (the last is not one).
    let src = format!("{}v 0 0 x\n", "v 0 0 0\n".repeat(MAX_VERTICES));
    let e = parse_str(&src).unwrap_err();
    assert_eq!((e.line, e.column), (Some(MAX_VERTICES + 1), Some(1)), "{e}");
    assert!(e.message.contains(&format!("more than {MAX_VERTICES} vertices")), "{e}");
    // Faces of 4096 corners make 4094 triangles each: the first line past the limit is refused.
    let face = format!("f {}\n", "1 ".repeat(4096));
    let lines = MAX_TRIANGLES / 4094 + 1;
    let e = parse_str(&format!("{TRIANGLE}{}", face.repeat(lines))).unwrap_err();
    assert_eq!(e.line, Some(3 + lines), "{e}");
    assert!(e.message.contains(&format!("more than {MAX_TRIANGLES} triangles")), "{e}");
}

#[test]
fn too_many_materials_are_refused_at_the_first_face_past_the_limit() {
    let n = irt::io::MAX_MATERIALS + 1;
    let src: String =
        TRIANGLE.to_string() + &(0..n).map(|i| format!("usemtl m{i}\nf 1 2 3\n")).collect::<String>();
    fails_at(&src, "f 1 2 3", &["one more than irt's limit of 65536"]);
}

/// Loads an OBJ that uses `mtl` as its library; the error must be at the last `at` of the MTL.
fn mtl_fails_at(test: &str, mtl: &str, at: &str, words: &[&str]) {
    let obj = format!("mtllib lib.mtl\n{TRIANGLE}usemtl m\nf 1 2 3\n");
    let path = write_files(test, &[("scene.obj", obj.as_bytes()), ("lib.mtl", mtl.as_bytes())]);
    let origin = path.with_file_name("lib.mtl").display().to_string();
    common::assert_fails_at(load(&path), mtl, &origin, at, words);
}

#[test]
fn bad_mtl_statements_are_errors_in_the_mtl_file() {
    mtl_fails_at("mtl-number", "newmtl m\nKd 0.5 0.5 x\n", "x", &["a number"]);
    mtl_fails_at("mtl-two", "newmtl m\nKd 0.5 0.5\n", "Kd", &["r g b, or r alone"]);
    mtl_fails_at("mtl-negative", "newmtl m\nKs -1 0 0\n", "-1", &["must not be negative"]);
    mtl_fails_at("mtl-nan", "newmtl m\nNs nan\n", "nan", &["finite"]);
    mtl_fails_at("mtl-ns", "newmtl m\nNs -3\n", "-3", &["out of range"]);
    mtl_fails_at("mtl-d", "newmtl m\nd 1.5\n", "1.5", &["out of range: 0 to 1"]);
    mtl_fails_at("mtl-tr", "newmtl m\nTr -0.5\n", "-0.5", &["out of range: 0 to 1"]);
    mtl_fails_at("mtl-ni", "newmtl m\nNi 0\n", "0\n", &["greater than 0"]);
    mtl_fails_at("mtl-illum", "newmtl m\nillum 11\n", "11", &["0 to 10"]);
    mtl_fails_at("mtl-before", "Kd 1 1 1\nnewmtl m\n", "Kd", &["before any `newmtl`"]);
    mtl_fails_at("mtl-name", "newmtl   \n", "newmtl", &["needs a name"]);
    mtl_fails_at("mtl-clamp", "newmtl m\nmap_Kd -clamp maybe t.png\n", "maybe", &["`on` or `off`"]);
    mtl_fails_at("mtl-scale", "newmtl m\nmap_Kd -s t.png\n", "-s", &["1 to 3 numbers"]);
    mtl_fails_at("mtl-file", "newmtl m\nmap_Kd -blendu on\n", "-blendu", &["a file name"]);
    mtl_fails_at("mtl-offset", "newmtl m\nmap_Kd -o 1 inf t.png\n", "inf", &["finite"]);
}

#[test]
fn a_bad_png_texture_is_an_error_naming_it() {
    let obj = format!("mtllib lib.mtl\n{TRIANGLE}usemtl m\nf 1 2 3\n");
    let mut png = tiny_png();
    png.truncate(png.len() - 8);
    let path = write_files(
        "bad-png",
        &[("scene.obj", obj.as_bytes()), ("lib.mtl", b"newmtl m\nmap_Kd t.png\n"), ("t.png", &png)],
    );
    let e = load(&path).unwrap_err();
    assert_eq!((e.path, e.line), (path.with_file_name("lib.mtl").display().to_string(), Some(2)));
    assert!(e.message.contains("t.png") && e.message.contains("cannot decode"), "{}", e.message);
}
