//! GPU images against the independent f64 CPU reference, per pixel, on the scenes in `scenes/`.
//!
//! Metric and tolerances: `common::assert_matches_reference`.
mod common;

use irt::scene::Scene;
use std::path::PathBuf;

fn check(name: &str, scene: Scene) {
    let ctx = common::gpu();
    let gpu = common::render_gpu(&ctx, &scene);
    common::assert_matches_reference(name, &gpu, &common::reference_image(&scene));
}

fn scene_file(name: &str) -> Scene {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name);
    irt::io::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn diffuse() {
    check("diffuse", scene_file("diffuse.toml"));
}

#[test]
fn metal() {
    check("metal", scene_file("metal.toml"));
}

#[test]
fn dielectric() {
    check("dielectric", scene_file("dielectric.toml"));
}

#[test]
fn polished() {
    check("polished", scene_file("polished.toml"));
}

#[test]
fn ambient_only() {
    check("ambient", scene_file("ambient.toml"));
}

#[test]
fn hard_shadows() {
    check("shadows", scene_file("shadows.toml"));
}

#[test]
fn triangle_meshes() {
    check("mesh", scene_file("mesh.toml"));
}

#[test]
fn cones() {
    check("cones", scene_file("cones.toml"));
}

#[test]
fn default_scene() {
    let mut scene = irt::scene::default_scene();
    // Half resolution keeps the brute-force reference to a few seconds.
    scene.camera.width /= 2;
    scene.camera.height /= 2;
    check("default", scene);
}
