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

/// p99.9 and max error (in 1/255 steps) against distance, log–log, as SVG.
pub fn plot_svg(rows: &[(f64, ImageDiff)], title: &str, path: &std::path::Path) -> Result<(), String> {
    use plotters::prelude::*;
    let err = |e: &dyn std::fmt::Display| format!("plotting {}: {e}", path.display());
    // Distance 0 is drawn at 1 (log axis); errors below 0.01/255 at 0.01.
    let pts = |f: fn(&ImageDiff) -> f64| -> Vec<(f64, f64)> {
        rows.iter().map(|(d, diff)| (d.max(1.0), (f(diff) * 255.0).max(0.01))).collect()
    };
    let (max, p999) = (pts(|d| d.max), pts(|d| d.p999));
    let x_hi = rows.iter().map(|r| r.0).fold(10.0, f64::max) * 2.0;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (800, 500)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 20))
            .margin(20)
            .x_label_area_size(45)
            .y_label_area_size(60)
            .build_cartesian_2d((0.5..x_hi).log_scale(), (0.005..300.0).log_scale())
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .x_desc("distance from the origin (scene units; 0 drawn at 1)")
            .y_desc("error vs f64 reference (1/255 steps)")
            .draw()
            .map_err(|e| err(&e))?;
        for (data, colour, label) in [(max, RED, "max"), (p999, BLUE, "99.9th percentile")] {
            chart
                .draw_series(LineSeries::new(data.clone(), colour.stroke_width(2)))
                .map_err(|e| err(&e))?
                .label(label)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour));
            chart
                .draw_series(data.iter().map(|&p| Circle::new(p, 4, colour.filled())))
                .map_err(|e| err(&e))?;
        }
        chart.configure_series_labels().border_style(BLACK).draw().map_err(|e| err(&e))?;
        root.present().map_err(|e| err(&e))?;
    }
    crate::image::write_atomic(path, svg.as_bytes()).map_err(|e| err(&e))
}
