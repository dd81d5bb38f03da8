//! `irt convert` and the TOML writer: every scene irt can load, written as TOML (and its
//! textures as PNG files), loads back as the same scene bit for bit (compared through `{:?}`,
//! which tells -0.0 from 0.0 and prints each f64 with the digits that identify it, and texels
//! compared with `==`).
use crate::common;

use glam::{DVec2, DVec3};
use irt::io::toml::parse_str;
use irt::io::toml_write::{to_files, to_toml, SceneFiles};
use irt::scene::*;
use proptest::prelude::*;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::{AtomicUsize, Ordering};

fn bits(scene: &Scene) -> String {
    format!("{scene:?}")
}

/// A new empty directory for one round trip (tests run in parallel, proptest many times).
fn fresh_dir() -> PathBuf {
    static NEXT: AtomicUsize = AtomicUsize::new(0);
    let n = NEXT.fetch_add(1, Ordering::Relaxed);
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("convert/round-trip-{n}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Writes the TOML as `dir/<stem>.toml` and the textures beside it; returns the TOML's path.
fn write_files(dir: &Path, stem: &str, files: &SceneFiles) -> PathBuf {
    for (name, png) in &files.textures {
        std::fs::write(dir.join(name), png).unwrap();
    }
    let path = dir.join(format!("{stem}.toml"));
    std::fs::write(&path, &files.toml).unwrap();
    path
}

/// Writes `scene` as files, loads them, and checks both the scene and a second writing.
fn round_trip(name: &str, scene: &Scene) {
    let dir = fresh_dir();
    let files = to_files(scene, "scene").unwrap_or_else(|e| panic!("{name}: {e}"));
    assert_eq!(files.textures.len(), scene.textures.len());
    let path = write_files(&dir, "scene", &files);
    let back = irt::io::load(&path).unwrap_or_else(|e| panic!("{name}: {e}\n{}", files.toml));
    assert_eq!(bits(&back), bits(scene), "{name} changed on the way through TOML");
    // The Debug form shows a checksum of the texels; compare them all.
    for (b, t) in back.textures.iter().zip(&scene.textures) {
        assert!(b.texels == t.texels, "{name}: the texels of texture '{}' changed", t.name);
    }
    let again = to_files(&back, "scene").unwrap();
    assert_eq!(again.toml, files.toml, "{name}: writing is not deterministic");
    assert_eq!(again.textures, files.textures, "{name}: writing the PNGs is not deterministic");
    std::fs::remove_dir_all(&dir).unwrap();
}

fn repo(path: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(path)
}

#[test]
fn every_scene_file_round_trips() {
    let mut count = 0;
    let files = |dir: &str| std::fs::read_dir(repo(dir)).unwrap().map(|e| e.unwrap().path());
    for path in files("scenes")
        .chain(files("scenes/spd"))
        .filter(|p| p.is_file() && p.extension().is_some_and(|e| e != "md"))
    {
        let scene = irt::io::load(&path).unwrap_or_else(|e| panic!("{e}"));
        round_trip(&path.display().to_string(), &scene);
        count += 1;
    }
    assert!(count >= 20, "only {count} scenes");
    round_trip("the built-in default scene", &default_scene());
}

#[test]
fn every_gltf_sample_round_trips() {
    for name in ["Box.gltf", "BoxTextured.gltf", "Duck.gltf", "Duck.glb"] {
        let path = common::shared_scene("gltf").join(name);
        round_trip(name, &irt::io::load(&path).unwrap_or_else(|e| panic!("{e}")));
    }
}

/// Animated glTF (tests/data/models/animated): the motion chains (quaternion keys, cubic
/// tangents, fixed node transforms) come back from the TOML bit for bit.
#[test]
fn every_animated_gltf_round_trips() {
    let mut count = 0;
    for entry in std::fs::read_dir(repo("tests/data/models/animated")).unwrap() {
        let path = entry.unwrap().path();
        let scene = irt::io::load(&path).unwrap_or_else(|e| panic!("{e}"));
        assert!(scene.is_animated(), "{}", path.display());
        round_trip(&path.display().to_string(), &scene);
        count += 1;
    }
    assert!(count >= 4, "only {count} animated files");
}

/// The real PLY models (tests/data/models): vertex and face colours (one mesh and material per
/// colour group), normals and texture coordinates, all three encodings.
#[test]
fn every_ply_model_round_trips() {
    let mut count = 0;
    for entry in std::fs::read_dir(repo("tests/data/models")).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "ply") {
            round_trip(&path.display().to_string(), &irt::io::load(&path).unwrap_or_else(|e| panic!("{e}")));
            count += 1;
        }
    }
    assert!(count >= 4, "only {count} PLY models");
}

#[test]
fn every_obj_model_round_trips() {
    for name in
        ["cornell/cornell_box.obj", "concave/concave_polygon.obj", "spider/spider.obj", "spot/spot.obj"]
    {
        let path = repo("tests/data/models").join(name);
        round_trip(name, &irt::io::load(&path).unwrap_or_else(|e| panic!("{e}")));
    }
}

/// The default scene with every field away from its default and awkward values everywhere.
fn awkward() -> Scene {
    let mut s = default_scene();
    s.background = DVec3::new(-0.0, 5e-324, 1e300);
    s.camera.vfov_deg = 0.1 + 0.2;
    s.camera.up = DVec3::new(1e-300, 1.0, -0.0);
    s.ambient.up = DVec3::new(0.0, 0.0, 7.0);
    s.lights[0].radius = 1.0 / 3.0;
    s.lights.push(Light {
        position: DVec3::splat(-1e-10),
        color: DVec3::new(123.456, 0.0, 1e-7),
        radius: 0.0,
    });
    s.trace = TraceSettings {
        max_depth: 8,
        weight_cutoff: 0.0,
        shadows: ShadowMode::Shell { falloff: Falloff::Disc, combine: Combine::Product },
        soft: false,
    };
    s.materials[0].name = "quote \" backslash \\ newline \n tab \t bell \u{7} é 🦀".into();
    s.materials[1].name = String::new();
    // Textures with names no file system would take, every wrap and filter, alpha 0 and 255.
    let texels =
        (0..6u8).map(|i| [i * 51, 255 - i, i.wrapping_mul(97), [0, 255, 1][i as usize % 3]]).collect();
    s.textures = vec![
        Texture {
            name: "../up/and \"away\"\\ C:\\x é.png\n".into(),
            width: 3,
            height: 2,
            texels,
            wrap: [Wrap::Mirror, Wrap::Clamp],
            filter: Filter::Nearest,
        },
        Texture {
            name: String::new(),
            width: 1,
            height: 1,
            texels: vec![[1, 2, 3, 4]],
            wrap: [Wrap::Repeat, Wrap::Mirror],
            filter: Filter::Linear,
        },
    ];
    let textured: Vec<_> = s
        .materials
        .iter()
        .enumerate()
        .filter(|(_, m)| !matches!(m.kind, MaterialKind::Dielectric { .. }))
        .map(|(i, _)| i)
        .collect();
    assert!(textured.len() >= 2, "the default scene has colour materials to texture");
    s.materials[textured[0]].texture = Some(0);
    s.materials[textured[1]].texture = Some(1);
    let odd = [DVec2::new(-0.0, 5e-324), DVec2::new(1e300, -1e-300), DVec2::new(0.1 + 0.2, -7.5)];
    let m = &mut s.meshes[0];
    m.uvs = Some((0..m.positions.len()).map(|i| odd[i % odd.len()]).collect());
    s
}

#[test]
fn awkward_values_and_names_round_trip() {
    round_trip("awkward", &awkward());
    for shadows in ["hard", "bundle:1", "bundle:256:fixed", "shell:smoothstep:min"] {
        let mut s = awkward();
        s.trace.shadows = shadows.parse().unwrap();
        round_trip(shadows, &s);
    }
}

#[test]
fn texture_file_names_are_unique_and_safe() {
    let s = awkward();
    let names = irt::io::toml_write::texture_file_names(&s, "out");
    assert_eq!(names, ["out.0.___up_and__away___C__x___png_.png", "out.1.png"]);
}

#[test]
fn repeated_texture_names_are_made_unique() {
    let mut s = awkward();
    for t in &mut s.textures {
        t.name = "same".into();
    }
    let files = to_files(&s, "scene").unwrap();
    let back = irt::io::load(&write_files(&fresh_dir(), "scene", &files)).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(back.textures[1].name, "same #2");
    let mut renamed = back;
    renamed.textures.iter_mut().for_each(|t| t.name = "same".into());
    assert_eq!(bits(&renamed), bits(&s), "everything but the names is unchanged, references included");
}

#[test]
fn repeated_material_names_are_made_unique() {
    let mut s = default_scene();
    for m in &mut s.materials {
        m.name = "same".into();
    }
    let back = parse_str(&to_toml(&s, &[]), "repeated").unwrap_or_else(|e| panic!("{e}"));
    let names: std::collections::HashSet<_> = back.materials.iter().map(|m| &m.name).collect();
    assert_eq!(names.len(), s.materials.len());
    // Everything but the names is unchanged, references included.
    let mut renamed = back;
    renamed.materials.iter_mut().for_each(|m| m.name = "same".into());
    assert_eq!(bits(&renamed), bits(&s));
}

// ---- Random scenes -------------------------------------------------------------------------

/// Any finite f64: normal and subnormal numbers and zeros of both signs, all exponents.
fn finite() -> impl Strategy<Value = f64> + Clone {
    use prop::num::f64::*;
    POSITIVE | NEGATIVE | NORMAL | SUBNORMAL | ZERO
}

fn vec3(s: impl Strategy<Value = f64> + Clone) -> impl Strategy<Value = DVec3> {
    (s.clone(), s.clone(), s).prop_map(|(x, y, z)| DVec3::new(x, y, z))
}

fn any_vec3() -> impl Strategy<Value = DVec3> {
    vec3(finite())
}

fn colour() -> impl Strategy<Value = DVec3> {
    vec3(0.0..=1.0f64)
}

/// A small texture: any size up to 5x3, any texels (alpha included), any wrap and filter.
fn texture(i: usize) -> impl Strategy<Value = Texture> {
    let wrap = || prop::sample::select(Wrap::NAMES.map(|(_, w)| w).to_vec());
    (1u32..=5, 1u32..=3).prop_flat_map(move |(width, height)| {
        let texels = prop::collection::vec(any::<[u8; 4]>(), (width * height) as usize);
        let filter = prop::sample::select(Filter::NAMES.map(|(_, f)| f).to_vec());
        (texels, wrap(), wrap(), filter, "(?s).{0,6}").prop_map(move |(texels, u, v, filter, name)| Texture {
            name: format!("{i}{name}"),
            width,
            height,
            texels,
            wrap: [u, v],
            filter,
        })
    })
}

fn material(i: usize, textures: usize) -> impl Strategy<Value = Material> {
    let kind = prop_oneof![
        colour().prop_map(|color| MaterialKind::Diffuse { color }),
        (colour(), 0.0..1e4f64).prop_map(|(color, exponent)| MaterialKind::Metal { color, exponent }),
        (1e-3..4.0f64, 0.0..1e4f64).prop_map(|(eta, exponent)| MaterialKind::Dielectric { eta, exponent }),
        (colour(), 1e-3..4.0f64, 0.0..1e4f64).prop_map(|(color, eta, exponent)| MaterialKind::Polished {
            color,
            eta,
            exponent
        }),
    ];
    // Any characters, control characters and quotes included; the index keeps names unique.
    let texture = prop::option::of(0..textures.max(1) as u32);
    (kind, "(?s).{0,6}", texture).prop_map(move |(kind, name, texture)| Material {
        name: format!("{i}{name}"),
        // A dielectric has no colour to texture.
        texture: texture.filter(|_| textures > 0 && !matches!(kind, MaterialKind::Dielectric { .. })),
        kind,
    })
}

fn mesh(materials: usize) -> impl Strategy<Value = Mesh> {
    (prop::collection::vec(any_vec3(), 1..6), any::<bool>(), any::<bool>(), 0..materials).prop_flat_map(
        |(positions, smooth, textured, material)| {
            let n = positions.len() as u32;
            let normals = prop::collection::vec(vec3(-1.0..1.0f64), positions.len()).prop_map(move |v| {
                v.into_iter().map(|n| n.try_normalize().unwrap_or(DVec3::X)).collect::<Vec<_>>()
            });
            let uvs = prop::collection::vec((finite(), finite()), positions.len())
                .prop_map(|v| v.into_iter().map(|(u, v)| DVec2::new(u, v)).collect::<Vec<_>>());
            let indices = prop::collection::vec([0..n, 0..n, 0..n], 0..5);
            (Just(positions), normals, uvs, indices).prop_map(move |(positions, normals, uvs, indices)| {
                Mesh {
                    positions,
                    normals: smooth.then_some(normals),
                    uvs: textured.then_some(uvs),
                    indices,
                    material: material as u32,
                }
            })
        },
    )
}

fn scene() -> impl Strategy<Value = Scene> {
    // No textures in half the scenes, so that untextured scenes stay well covered.
    (1usize..4, prop_oneof![Just(0usize), 1usize..4]).prop_flat_map(|(materials, textures)| {
        // Moderate camera vectors: with extreme ones the view frame overflows and validate refuses.
        let moderate = || vec3(-1e6..1e6f64);
        let camera = (moderate(), moderate(), moderate(), 1e-3..179.9f64, 1u32..4000, 1u32..4000).prop_map(
            |(eye, look_at, up, vfov_deg, width, height)| Camera {
                eye,
                look_at,
                up,
                vfov_deg,
                width,
                height,
            },
        );
        let light = (any_vec3(), vec3(0.0..1e3f64), 0.0..10.0f64)
            .prop_map(|(position, color, radius)| Light { position, color, radius });
        let ambient = (vec3(0.0..4.0f64), vec3(0.0..4.0f64), any_vec3())
            .prop_map(|(sky, ground, up)| Ambient { sky, ground, up });
        let sphere = (any_vec3(), prop::num::f64::POSITIVE, 0..materials)
            .prop_map(|(center, radius, m)| Sphere { center, radius, material: m as u32 });
        let cone = (any_vec3(), prop::num::f64::POSITIVE, any_vec3(), 0.0..1e3f64, 0..materials).prop_map(
            |(base, base_radius, apex, apex_radius, m)| Cone {
                base,
                base_radius,
                apex,
                apex_radius,
                material: m as u32,
            },
        );
        let shadows = prop_oneof![
            Just(ShadowMode::Hard),
            (1..=MAX_BUNDLE, any::<bool>())
                .prop_map(|(samples, rotate)| ShadowMode::Bundle { samples, rotate }),
            (0..3usize, any::<bool>()).prop_map(|(f, p)| ShadowMode::Shell {
                falloff: Falloff::ALL[f],
                combine: if p { Combine::Product } else { Combine::Min }
            }),
        ];
        let trace =
            (1..=MAX_TRACE_DEPTH, 0.0..1.0f64, shadows).prop_map(|(max_depth, weight_cutoff, shadows)| {
                TraceSettings { max_depth, weight_cutoff, shadows, soft: false }
            });
        let all_materials: Vec<_> = (0..materials).map(|i| material(i, textures)).collect();
        let all_textures: Vec<_> = (0..textures).map(texture).collect();
        (
            camera,
            prop::collection::vec(light, 0..3),
            ambient,
            vec3(0.0..10.0f64),
            all_materials,
            prop::collection::vec(sphere, 1..3),
            prop::collection::vec(mesh(materials), 0..3),
            prop::collection::vec(cone, 0..3),
            (trace, all_textures),
        )
            .prop_map(
                |(
                    camera,
                    lights,
                    ambient,
                    background,
                    materials,
                    spheres,
                    meshes,
                    cones,
                    (trace, textures),
                )| Scene {
                    camera,
                    lights,
                    ambient,
                    background,
                    materials,
                    spheres,
                    meshes,
                    cones,
                    textures,
                    trace,
                    motions: Vec::new(),
                    particles: Vec::new(),
                    volumes: Vec::new(),
                    patches: Vec::new(),
                },
            )
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn random_scenes_round_trip_bit_for_bit(scene in scene()) {
        // Random cameras are sometimes degenerate (up along the view): not a scene to write.
        prop_assume!(scene.validate().is_ok());
        round_trip("random", &scene);
    }
}

// ---- The command ---------------------------------------------------------------------------

fn irt(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_irt")).args(args).output().expect("irt runs")
}

fn tmp(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("convert");
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

#[test]
fn convert_writes_a_toml_that_loads_as_the_same_scene() {
    let input = common::shared_scene("gltf/Duck.glb");
    let out = tmp("duck.toml");
    let _ = std::fs::remove_file(&out);
    let run = irt(&["convert", input.to_str().unwrap(), out.to_str().unwrap()]);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let original = irt::io::load(&input).unwrap();
    assert_eq!(bits(&irt::io::load(&out).unwrap()), bits(&original));
    let leftovers = std::fs::read_dir(out.parent().unwrap())
        .unwrap()
        .filter(|e| e.as_ref().unwrap().file_name().to_string_lossy().ends_with(".tmp"))
        .count();
    assert_eq!(leftovers, 0, "the write is atomic: no temporary file is left");
}

/// `irt convert` itself on a binary PLY with colour groups.
#[test]
fn convert_writes_a_ply_as_a_toml_that_loads_as_the_same_scene() {
    let input = repo("tests/data/models/reference.ply");
    let out = tmp("reference.toml");
    let _ = std::fs::remove_file(&out);
    let run = irt(&["convert", input.to_str().unwrap(), out.to_str().unwrap()]);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let original = irt::io::load(&input).unwrap();
    assert!(original.materials.len() > 1);
    assert_eq!(bits(&irt::io::load(&out).unwrap()), bits(&original));
}

#[test]
fn convert_writes_an_obj_model_and_its_texture_as_the_same_scene() {
    let input = repo("tests/data/models/spot/spot.obj");
    let dir = fresh_dir();
    let out = dir.join("spot.toml");
    let run = irt(&["convert", input.to_str().unwrap(), out.to_str().unwrap()]);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let original = irt::io::load(&input).unwrap();
    assert_eq!(original.textures.len(), 1);
    let back = irt::io::load(&out).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(bits(&back), bits(&original));
    assert!(back.textures[0].texels == original.textures[0].texels);
}

#[test]
fn convert_writes_the_textures_beside_the_toml_and_says_so() {
    let input = repo("scenes/textured.toml");
    let dir = fresh_dir();
    let out = dir.join("tiles.toml");
    let run = irt(&["convert", input.to_str().unwrap(), out.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    let original = irt::io::load(&input).unwrap();
    assert_eq!(original.textures.len(), 2);
    let names = irt::io::toml_write::texture_file_names(&original, "tiles");
    for name in &names {
        assert!(dir.join(name).is_file(), "{name} was not written");
        assert!(
            stderr.contains(&format!("wrote {}", dir.join(name).display())),
            "{name} not reported: {stderr}"
        );
        let file = format!("file = \"{name}\"");
        assert!(std::fs::read_to_string(&out).unwrap().contains(&file), "the TOML lacks {file}");
    }
    let mut written: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
    written.sort();
    assert_eq!(
        written,
        ["tiles.0.checker.png", "tiles.1.checker__smooth.png", "tiles.toml"],
        "and nothing else"
    );
    let back = irt::io::load(&out).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(bits(&back), bits(&original));
    assert_eq!(back.textures, original.textures);
    // Converting the converted scene re-encodes its textures to the same scene again.
    let again = dir.join("again.toml");
    let run = irt(&["convert", out.to_str().unwrap(), again.to_str().unwrap()]);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    assert_eq!(bits(&irt::io::load(&again).unwrap()), bits(&original));
}

#[test]
fn convert_refuses_bad_arguments_with_a_message() {
    let fails = |args: &[&str], words: &[&str]| {
        let run = irt(args);
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success() && !stderr.contains("panicked"), "{stderr}");
        for w in words {
            assert!(stderr.contains(w), "stderr lacks '{w}': {stderr}");
        }
    };
    let out = tmp("x.toml");
    fails(&["convert", "scenes/default.toml", tmp("x.png").to_str().unwrap()], &["must be a .toml file"]);
    fails(&["convert", "no/such/scene.glb", out.to_str().unwrap()], &["no/such/scene.glb", "No such file"]);
    fails(&["convert", "scenes/default.toml", "no/such/dir/x.toml"], &["does not exist"]);
    fails(&["convert", "scenes/default.toml"], &["OUTPUT"]);
}
