//! `irt convert` and the TOML writer: every scene irt can load, written as TOML, loads back as
//! the same scene bit for bit (compared through `{:?}`, which tells -0.0 from 0.0 and prints
//! each f64 with the digits that identify it).
mod common;

use glam::DVec3;
use irt::io::toml::parse_str;
use irt::io::toml_write::to_toml;
use irt::scene::*;
use proptest::prelude::*;
use std::path::PathBuf;
use std::process::Command;

fn bits(scene: &Scene) -> String {
    format!("{scene:?}")
}

/// Writes `scene`, loads the text, and checks both the scene and a second writing.
fn round_trip(name: &str, scene: &Scene) {
    let text = to_toml(scene);
    let back = parse_str(&text, name).unwrap_or_else(|e| panic!("{e}\n{text}"));
    assert_eq!(bits(&back), bits(scene), "{name} changed on the way through TOML");
    assert_eq!(to_toml(&back), text, "{name}: writing is not deterministic");
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
    };
    s.materials[0].name = "quote \" backslash \\ newline \n tab \t bell \u{7} é 🦀".into();
    s.materials[1].name = String::new();
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
fn repeated_material_names_are_made_unique() {
    let mut s = default_scene();
    for m in &mut s.materials {
        m.name = "same".into();
    }
    let back = parse_str(&to_toml(&s), "repeated").unwrap_or_else(|e| panic!("{e}"));
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

fn material(i: usize) -> impl Strategy<Value = Material> {
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
    (kind, "(?s).{0,6}").prop_map(move |(kind, name)| Material {
        name: format!("{i}{name}"),
        kind,
        texture: None,
    })
}

fn mesh(materials: usize) -> impl Strategy<Value = Mesh> {
    (prop::collection::vec(any_vec3(), 1..6), any::<bool>(), 0..materials).prop_flat_map(
        |(positions, smooth, material)| {
            let n = positions.len() as u32;
            let normals = prop::collection::vec(vec3(-1.0..1.0f64), positions.len()).prop_map(move |v| {
                v.into_iter().map(|n| n.try_normalize().unwrap_or(DVec3::X)).collect::<Vec<_>>()
            });
            let indices = prop::collection::vec([0..n, 0..n, 0..n], 0..5);
            (Just(positions), normals, indices).prop_map(move |(positions, normals, indices)| Mesh {
                positions,
                normals: smooth.then_some(normals),
                uvs: None,
                indices,
                material: material as u32,
            })
        },
    )
}

fn scene() -> impl Strategy<Value = Scene> {
    (1usize..4).prop_flat_map(|materials| {
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
                TraceSettings { max_depth, weight_cutoff, shadows }
            });
        let all_materials: Vec<_> = (0..materials).map(material).collect();
        (
            camera,
            prop::collection::vec(light, 0..3),
            ambient,
            vec3(0.0..10.0f64),
            all_materials,
            prop::collection::vec(sphere, 1..3),
            prop::collection::vec(mesh(materials), 0..3),
            prop::collection::vec(cone, 0..3),
            trace,
        )
            .prop_map(
                |(camera, lights, ambient, background, materials, spheres, meshes, cones, trace)| Scene {
                    camera,
                    lights,
                    ambient,
                    background,
                    materials,
                    spheres,
                    meshes,
                    cones,
                    textures: vec![],
                    trace,
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
