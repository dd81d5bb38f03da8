//! `irt stability`: how far the f32 GPU path drifts from the f64 reference as a scene moves away
//! from the origin (docs/stability.md).

use crate::gpu::{GpuContext, RenderOptions, Renderer};
use crate::metrics::{compare, ImageDiff};
use crate::reference;
use crate::scene::Scene;
use glam::DVec3;

/// Distances of the precision table, in units of the scene.
pub const DISTANCES: [f64; 6] = [0.0, 1e3, 1e4, 1e5, 1e6, 1e7];

/// The direction scenes are moved in: off every axis, so all three coordinates grow.
pub fn offset(distance: f64) -> DVec3 {
    DVec3::new(1.0, 0.8, -0.6).normalize() * distance
}

/// GPU against the reference for `scene` moved `distance` from where it is.
pub fn measure(ctx: &GpuContext, scene: &Scene, distance: f64) -> Result<ImageDiff, String> {
    let s = scene.transformed(1.0, offset(distance));
    let gpu = Renderer::new(ctx, &s, RenderOptions::default())?.render(ctx, &mut |_, _| {}).image;
    let r = reference::render(&s);
    let reference = crate::image::Image {
        width: r.width,
        height: r.height,
        pixels: r.pixels.iter().map(|p| [p.x as f32, p.y as f32, p.z as f32]).collect(),
    };
    Ok(compare(&gpu, &reference))
}

/// One Markdown row per distance.
pub fn markdown_table(rows: &[(f64, ImageDiff)]) -> String {
    let mut s = String::from(
        "| distance from origin | max error | p99.9 | RMSE | pixels > 2/255 | NaN/Inf |\n|---|---|---|---|---|---|\n",
    );
    for (d, diff) in rows {
        s += &format!(
            "| {d:e} | {:.1}/255 | {:.1}/255 | {:.5} | {:.3}% | {} |\n",
            diff.max * 255.0,
            diff.p999 * 255.0,
            diff.rmse,
            diff.bad_pixels * 100.0,
            diff.non_finite
        );
    }
    s
}
