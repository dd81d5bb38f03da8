//! Particles: PLY files of points alone load as spheres in every encoding, coloured by a field
//! through a colour map whose ends are the range's ends; bad files fail with their place;
//! `[[particles]]` places them in a TOML scene and `irt convert` keeps them; the GPU draws
//! them as the f64 reference does, on the BVH and on the grid.
//!
//! The files are written by tests/it/ply.rs's own encoder, not by irt's writer.
use crate::common;
use crate::ply::{ply, ASCII, BE, ENCODINGS, LE, V};

use glam::DVec3;
use irt::io::ply::{parse_model, parse_particles};
use irt::io::stage::Model;
use irt::scene::colour_map::{ColourMap, MAP_LEVELS};
use irt::scene::particles::{auto_radius, ParticleStyle, Radius};
use irt::scene::MaterialKind;

const XYZ: &str = "property float x\nproperty float y\nproperty float z\n";

/// Four points with a radius and two fields (`temperature` first, then `pressure`).
fn four(format: &str) -> Vec<u8> {
    let header = format!(
        "element vertex 4\n{XYZ}property double radius\nproperty float temperature\nproperty int pressure\n"
    );
    let row = |x: f32, r: f64, t: f32, p: i32| {
        vec![V::F32(x), V::F32(0.0), V::F32(1.0), V::F64(r), V::F32(t), V::I32(p)]
    };
    ply(
        format,
        &header,
        &[row(0.0, 0.5, 10.0, 7), row(1.0, 0.25, 20.0, 3), row(2.0, 1.0, 15.0, 5), row(3.0, 0.125, 30.0, 9)],
    )
}

fn model(bytes: &[u8]) -> Model {
    parse_model(bytes, "points.ply").unwrap_or_else(|e| panic!("{e}"))
}

fn colour(m: &Model, sphere: usize) -> DVec3 {
    match m.materials[m.spheres[sphere].material as usize].kind {
        MaterialKind::Diffuse { color } => color,
        ref other => panic!("{other:?}"),
    }
}

#[test]
fn the_three_encodings_give_the_same_particles() {
    let models: Vec<Model> = ENCODINGS.iter().map(|f| model(&four(f))).collect();
    let m = &models[0];
    assert_eq!(m.spheres.len(), 4);
    assert!(m.meshes.is_empty());
    assert_eq!(m.spheres.iter().map(|s| s.radius).collect::<Vec<_>>(), [0.5, 0.25, 1.0, 0.125]);
    assert_eq!(m.spheres[2].center, DVec3::new(2.0, 0.0, 1.0));
    for other in &models[1..] {
        assert_eq!(other.spheres, m.spheres);
        assert_eq!(other.materials, m.materials);
    }
    // Coloured by the first field, temperature, over its own range 10..30, with viridis.
    let legend = m.particles[0].legend.as_ref().expect("a legend");
    assert_eq!(
        (legend.field.as_str(), legend.lo, legend.hi, legend.map),
        ("temperature", 10.0, 30.0, ColourMap::Viridis)
    );
    assert_eq!(m.materials.len(), MAP_LEVELS);
}

#[test]
fn the_range_ends_are_the_map_ends() {
    let m = model(&four(LE));
    let map = ColourMap::Viridis;
    assert_eq!(colour(&m, 0), map.level_colour(0), "the lowest value");
    assert_eq!(colour(&m, 3), map.level_colour(MAP_LEVELS - 1), "the highest value");
    // 15 is a quarter of the way: level round(0.25 * 255) = 64.
    assert_eq!(colour(&m, 2), map.level_colour(64));
    // A range given: values outside it take its ends; another field and map.
    let style = ParticleStyle {
        field: Some("pressure".into()),
        map: ColourMap::Inferno,
        range: Some([4.0, 8.0]),
        ..Default::default()
    };
    let m = parse_particles(&four(BE), "points.ply", &style).unwrap();
    let inferno = ColourMap::Inferno;
    assert_eq!(colour(&m, 1), inferno.level_colour(0), "3 is below the range");
    assert_eq!(colour(&m, 3), inferno.level_colour(MAP_LEVELS - 1), "9 is above it");
    assert_eq!(colour(&m, 2), inferno.level_colour(64), "5 is a quarter of 4..8");
}

#[test]
fn without_a_radius_the_spacing_gives_one_and_a_field_can_hold_it() {
    let rows: Vec<Vec<V>> =
        (0..100).map(|i| vec![V::F32((i % 10) as f32), V::F32((i / 10) as f32), V::F32(0.0)]).collect();
    let m = model(&ply(ASCII, &format!("element vertex 100\n{XYZ}"), &rows));
    let r = auto_radius(DVec3::ZERO, DVec3::new(9.0, 9.0, 0.0), 100);
    assert!(m.spheres.iter().all(|s| s.radius == r), "{r}");
    // No field: one plain material, no legend.
    assert_eq!(m.materials.len(), 1);
    assert!(m.particles[0].legend.is_none());
    // The radius from a field of another name, one radius for all, and the field then colours.
    let style = ParticleStyle { radius: Radius::Field("temperature".into()), ..Default::default() };
    let m = parse_particles(&four(ASCII), "p.ply", &style).unwrap();
    assert_eq!(m.spheres[1].radius, 20.0);
    // `radius` is now a field like any other, the first, so it colours.
    assert_eq!(m.particles[0].legend.as_ref().unwrap().field, "radius");
    let style = ParticleStyle { radius: Radius::Value(0.01), ..Default::default() };
    let m = parse_particles(&four(LE), "p.ply", &style).unwrap();
    assert!(m.spheres.iter().all(|s| s.radius == 0.01));
}

fn fails(bytes: &[u8], style: &ParticleStyle, words: &[&str]) -> String {
    let e = parse_particles(bytes, "bad.ply", style).expect_err("the file should be refused").to_string();
    for w in words {
        assert!(e.contains(w), "message lacks '{w}': {e}");
    }
    e
}

#[test]
fn bad_particle_files_fail_with_their_place() {
    let plain = ParticleStyle::default();
    // A field or radius field that the file lacks: the message lists the fields it has.
    let e = fails(
        &four(LE),
        &ParticleStyle { field: Some("stress".into()), ..Default::default() },
        &["no field `stress`"],
    );
    assert!(e.contains("radius, temperature, pressure") && e.starts_with("bad.ply:4:"), "{e}");
    fails(
        &four(LE),
        &ParticleStyle { radius: Radius::Field("size".into()), ..Default::default() },
        &["no radius field `size`"],
    );
    // NaN coordinates: in ASCII at its line, in binary at its byte.
    let header = format!("element vertex 2\n{XYZ}");
    let nan = [vec![V::F32(0.0), V::F32(0.0), V::F32(0.0)], vec![V::F32(1.0), V::F32(f32::NAN), V::F32(0.0)]];
    fails(&ply(ASCII, &header, &nan), &plain, &["bad.ply:10:3:", "y of vertex 1 is NaN", "finite"]);
    let e = fails(&ply(BE, &header, &nan), &plain, &["at byte", "y of vertex 1 is NaN"]);
    assert!(!e.contains(":10:"), "{e}");
    // More points declared than the file holds.
    let short = ply(LE, &format!("element vertex 1000000\n{XYZ}"), &nan);
    fails(&short, &plain, &["the header declares 1000000"]);
    let short = ply(ASCII, &format!("element vertex 3\n{XYZ}"), &nan[..1]);
    fails(&short, &plain, &["the file ends before vertex 1; the header declares 3"]);
    // A radius that is not positive.
    let rows = [vec![V::F32(0.0), V::F32(0.0), V::F32(0.0), V::F32(-1.0)]];
    fails(
        &ply(LE, &format!("element vertex 1\n{XYZ}property float radius\n"), &rows),
        &plain,
        &["radius of point 0 is -1"],
    );
    // Past the limit, from the header, before anything is allocated.
    fails(&ply(LE, &format!("element vertex 100000000\n{XYZ}"), &[]), &plain, &["100000000 points", "limit"]);
    // A mesh is not particles.
    let mesh = ply(
        LE,
        &format!("element vertex 0\n{XYZ}element face 0\nproperty list uchar int vertex_indices\n"),
        &[],
    );
    fails(&mesh, &plain, &["not a file of points", "[[model]]"]);
}

/// A directory of its own for a test's files.
fn dir(name: &str) -> std::path::PathBuf {
    let d = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("particles-{name}"));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

const CAMERA: &str = "[camera]\neye = [1.5, 3, 9]\nlook_at = [1.5, 0, 1]\nwidth = 96\nheight = 64\n\n[[light]]\nposition = [3, 5, 8]\n";

#[test]
fn toml_places_particles_and_convert_keeps_them() {
    let d = dir("toml");
    std::fs::write(d.join("points.ply"), four(BE)).unwrap();
    let toml = format!(
        "{CAMERA}\n[[material]]\nname = \"red\"\ntype = \"diffuse\"\ncolor = [0.8, 0.1, 0.1]\n\n[[sphere]]\ncenter = [0, -3, 0]\nradius = 1\nmaterial = \"red\"\n\n\
         [[particles]]\nfile = \"points.ply\"\nfield = \"pressure\"\nmap = \"coolwarm\"\nrange = [0, 10]\nscale = 2\ntranslate = [0, 1, 0]\n"
    );
    let path = d.join("scene.toml");
    std::fs::write(&path, &toml).unwrap();
    let scene = irt::io::load(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.spheres.len(), 5);
    // Scaled by 2 (centres and radii), then moved up by 1; the sphere of the file is kept first.
    assert_eq!(scene.spheres[3].center, DVec3::new(4.0, 1.0, 2.0));
    assert_eq!(scene.spheres[3].radius, 2.0);
    let p = &scene.particles[0];
    assert_eq!((p.spheres.clone(), p.materials.clone()), (1..5, 1..1 + MAP_LEVELS));
    assert!(scene.materials[1].name.starts_with("points.ply:"), "{}", scene.materials[1].name);
    let legend = p.legend.as_ref().unwrap();
    assert_eq!(
        (legend.field.as_str(), legend.lo, legend.hi, legend.map),
        ("pressure", 0.0, 10.0, ColourMap::Coolwarm)
    );

    // Convert: the particles by reference (not 256 materials and a [[sphere]] a particle), and
    // the written scene loads back to the same spheres and colours wherever it is written.
    let written = irt::io::toml_write::to_toml(&scene, &[]);
    assert_eq!(written.matches("[[particles]]").count(), 1, "{written}");
    assert_eq!(written.matches("[[sphere]]").count(), 1);
    assert_eq!(written.matches("[[material]]").count(), 1);
    let elsewhere = dir("toml-converted").join("converted.toml");
    std::fs::write(&elsewhere, &written).unwrap();
    let back = irt::io::load(&elsewhere).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(back.spheres, scene.spheres);
    let colours = |s: &irt::scene::Scene| -> Vec<MaterialKind> {
        s.spheres.iter().map(|sp| s.materials[sp.material as usize].kind.clone()).collect()
    };
    assert_eq!(colours(&back), colours(&scene));

    // Bad tables: each at its value.
    for (table, words) in [
        ("map = \"jet\"", &["unknown colour map `jet`", "viridis"][..]),
        ("range = [3, 1]", &["must rise"]),
        ("radius = -2", &["a radius is a finite number > 0"]),
        ("field = \"colour\"", &["no field `colour`", "radius, temperature, pressure"]),
        ("scale = [1, 2, 3]", &["invalid type"]),
    ] {
        let bad = format!("{CAMERA}\n[[particles]]\nfile = \"points.ply\"\n{table}\n");
        std::fs::write(&path, &bad).unwrap();
        let e = irt::io::load(&path).expect_err(table).to_string();
        for w in words {
            assert!(e.contains(w), "{table}: message lacks '{w}': {e}");
        }
    }
    // A file of points given as a [[model]] would lose its spheres: refused, naming the table.
    std::fs::write(&path, format!("{CAMERA}\n[[model]]\nfile = \"points.ply\"\n")).unwrap();
    let e = irt::io::load(&path).unwrap_err().to_string();
    assert!(e.contains("place it with [[particles]]"), "{e}");
    std::fs::write(&path, format!("{CAMERA}\n[[particles]]\nfile = \"scene.toml\"\n")).unwrap();
    let e = irt::io::load(&path).unwrap_err().to_string();
    assert!(e.contains("PLY files of points"), "{e}");
}

/// A particle file alone is staged (framed, lit) and drawn on the GPU as the f64 reference draws
/// it, on the BVH and on the grid (`assert_matches_reference`'s tolerances).
#[test]
fn particles_render_as_the_reference_draws_them() {
    let plate = irt::io::stress_plate::plate(600);
    let mut bytes = Vec::new();
    irt::io::ply::write_points(&plate, irt::io::ply::Encoding::BinaryLittleEndian, &mut bytes).unwrap();
    let mut scene = irt::io::ply::parse(&bytes, "plate.ply").unwrap();
    scene.camera.width = 96;
    scene.camera.height = 72;
    assert_eq!(scene.spheres.len(), plate.positions.len());
    let ctx = common::gpu();
    let reference = common::reference_image(&scene);
    for accel in [irt::accel::AccelChoice::Bvh, irt::accel::AccelChoice::Grid] {
        let settings = irt::render::Settings { accel, ..irt::render::Settings::bands() };
        let gpu = common::render_gpu_with(&ctx, &scene, settings);
        common::assert_matches_reference(&format!("particles-{accel}"), &gpu, &reference);
    }
    // The stage frames the whole plate: the picture's corners are background, its centre is not
    // (the hole is off-centre in the framed view, so the centre row is sampled across).
    let bg = irt::io::stage::DEFAULT_BACKGROUND.as_vec3().to_array();
    let at = |x: u32, y: u32| reference.pixels[(y * reference.width + x) as usize];
    assert_eq!(at(0, 0), bg);
    assert!((0..96).any(|x| at(x, 36) != bg));
}
