//! GPU images against the independent f64 CPU reference, per pixel, on the scenes in `scenes/`.
//!
//! Metric: per-channel absolute error in display space (clamped, sRGB-encoded, [0, 1]; 1/255 is
//! one output level), see `irt::metrics`. Tolerances, and why:
//! - `p999` (99.9th percentile) ≤ 2/255: away from discontinuities f32 and f64 agree to far below
//!   one output level; the worst 0.1% are where they legitimately decide differently.
//! - `bad_pixels` (pixels off by more than 2/255) ≤ 0.25%: a pixel-centre ray that passes within
//!   f32 rounding of a silhouette, a shadow boundary or a critical angle may be decided
//!   differently by the two tracers, and then the pixel differs by up to the full contrast of
//!   that edge. Such pixels are isolated and rare; a real bug (wrong normal, wrong Fresnel, a
//!   missed grid cell) changes whole regions and blows both bounds.
//! - no NaN or infinity anywhere.
//! On failure the GPU, reference and diff images are written to target/golden/.
mod common;

use irt::gpu::{RenderOptions, Renderer};
use irt::image::Image;
use irt::metrics::{compare, diff_image};
use irt::scene::Scene;
use std::path::PathBuf;

const P999: f64 = 2.0 / 255.0;
const BAD_PIXELS: f64 = 0.0025;

fn reference_image(scene: &Scene) -> Image {
    let r = irt::reference::render(scene);
    Image {
        width: r.width,
        height: r.height,
        pixels: r.pixels.iter().map(|p| [p.x as f32, p.y as f32, p.z as f32]).collect(),
    }
}

fn check(name: &str, scene: Scene) {
    let ctx = common::gpu();
    let renderer = Renderer::new(&ctx, &scene, RenderOptions::default()).expect("renderer");
    let gpu = renderer.render(&ctx, &mut |_, _| {}).image;
    let reference = reference_image(&scene);
    let diff = compare(&gpu, &reference);
    println!("{name}: {diff}");
    let ok = diff.p999 <= P999 && diff.bad_pixels <= BAD_PIXELS && diff.non_finite == 0;
    if !ok {
        let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target/golden");
        std::fs::create_dir_all(&dir).unwrap();
        gpu.save_png(&dir.join(format!("{name}-gpu.png"))).unwrap();
        reference.save_png(&dir.join(format!("{name}-ref.png"))).unwrap();
        diff_image(&gpu, &reference, 8.0).save_png(&dir.join(format!("{name}-diff.png"))).unwrap();
        panic!("{name}: GPU differs from the reference: {diff}\n(images in {})", dir.display());
    }
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
fn default_scene() {
    let mut scene = irt::scene::default_scene();
    // Half resolution keeps the brute-force reference to a few seconds.
    scene.camera.width /= 2;
    scene.camera.height /= 2;
    check("default", scene);
}
