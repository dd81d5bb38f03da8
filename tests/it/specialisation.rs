//! Shader specialisation (docs/specialisation.md): the pipeline compiled for what a scene uses
//! (primitive kinds, shadow mode) draws the same image as the uber-pipeline, which has every
//! primitive kind and shadow mode compiled in and picks at run time.
use crate::common;

use irt::render::Session;
use irt::scene::{Scene, ShadowMode};
use std::path::Path;

fn load(path: &str, size: u32) -> Scene {
    let mut s =
        irt::io::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join(path)).unwrap_or_else(|e| panic!("{e}"));
    (s.camera.width, s.camera.height) = (size, size * 3 / 4);
    s
}

#[test]
fn specialised_pipelines_draw_what_the_uber_pipeline_draws() {
    let ctx = common::gpu();
    let mut scenes = vec![
        ("balls (spheres only)", load("scenes/spd/balls_s2.nff", 96)),
        ("gears (triangles only)", load("scenes/spd/gears_s1.nff", 96)),
        ("jacks (spheres and cylinders)", load("scenes/spd/jacks_s2.nff", 96)),
        ("mesh.toml (meshes, vertex normals)", load("scenes/mesh.toml", 96)),
        ("Duck.glb (textured triangles)", load("tests/data/scenes/gltf/Duck.glb", 96)),
        ("BoxTextured.gltf (textured triangles)", load("tests/data/scenes/gltf/BoxTextured.gltf", 96)),
    ];
    for mode in ["bundle:16", "shell"] {
        let mut s = load("scenes/cones.toml", 96);
        s.lights.iter_mut().for_each(|l| l.radius = 0.5);
        s.trace.shadows = mode.parse::<ShadowMode>().unwrap();
        scenes.push((if mode == "shell" { "cones, shell shadows" } else { "cones, bundle shadows" }, s));
    }
    // Shell shadows with the grid walk compiled out (balls: a floor of two triangles, tested
    // in the object loop) and in (mesh.toml: a 320-triangle icosphere beside small meshes); the
    // uber-pipeline always walks.
    for (name, path, radius) in [
        ("balls, shell shadows", "scenes/spd/balls_s2.nff", 0.25),
        ("mesh.toml, shell shadows", "scenes/mesh.toml", 0.5),
    ] {
        let mut s = load(path, 96);
        s.lights.iter_mut().for_each(|l| l.radius = radius);
        s.trace.shadows = "shell".parse::<ShadowMode>().unwrap();
        scenes.push((name, s));
    }
    // Diffuse only (the peer workload): the pipeline traces the eye ray alone, without the ray
    // stack (`SECONDARY_RAYS` false); the uber-pipeline has every material kind and the stack.
    for (name, path) in
        [("balls, diffuse only", "scenes/spd/balls_s2.nff"), ("mesh.toml, diffuse only", "scenes/mesh.toml")]
    {
        let s = irt::lab::peer::primary_shadow(&load(path, 96));
        assert!(s.materials.iter().all(|m| matches!(m.kind, irt::scene::MaterialKind::Diffuse { .. })));
        scenes.push((name, s));
    }
    for (name, scene) in scenes {
        let render = |uber_shader| {
            let mut r = Session::new(
                &ctx,
                &scene,
                irt::render::Settings { uber_shader, ..irt::render::Settings::bands() },
            )
            .expect("renderer");
            (r.variant, r.picture(&ctx, &mut |_, _| {}).image)
        };
        let ((spec_variant, spec), (uber_variant, uber)) = (render(false), render(true));
        // Texture code is compiled in exactly when a material has a texture.
        assert_eq!(spec_variant.textures, scene.materials.iter().any(|m| m.texture.is_some()), "{name}");
        assert_ne!(spec_variant, uber_variant, "{name}: the scene needs everything?");
        // The shell walk only where a shell ray needs it: a mesh larger than
        // SHELL_DIRECT_TRIANGLES (mesh.toml's icosphere; cones.toml's floor is a quad).
        assert_eq!(spec_variant.shell_walk, name == "mesh.toml, shell shadows", "{name}");
        // Same equations on the same inputs; only dead code differs, so the images agree to the
        // last bits (LLVM may still schedule a few operations differently: 1e-6 relative).
        let worst = spec
            .pixels
            .iter()
            .zip(&uber.pixels)
            .flat_map(|(a, b)| {
                (0..3).map(move |c| (a[c] - b[c]).abs() / a[c].abs().max(b[c].abs()).max(1e-3))
            })
            .fold(0.0f32, f32::max);
        println!("{name}: {spec_variant:?} vs uber: worst relative difference {worst:e}");
        assert!(worst <= 1e-6, "{name}: specialised and uber images differ by {worst}");
    }
}
