//! `irt stability`: how far the GPU, in f32 and in f64, drifts from the f64 reference as a scene
//! moves away from the origin, and what f64 costs (docs/stability.md).

use crate::gpu::device::Device;
use crate::metrics::{compare, ImageDiff};
use crate::reference;
use crate::render::{RenderError, Session, Settings};
use crate::scene::Scene;
use glam::DVec3;
use std::time::Duration;

/// Distances of the precision table, in units of the scene.
pub const DISTANCES: [f64; 6] = [0.0, 1e3, 1e4, 1e5, 1e6, 1e7];

/// The direction scenes are moved in: off every axis, so all three coordinates grow.
pub fn offset(distance: f64) -> DVec3 {
    DVec3::new(1.0, 0.8, -0.6).normalize() * distance
}

/// One distance of the table: the GPU in f32 and in f64 against the reference, and their frame
/// times (median of 3 warm frames each).
#[derive(Clone, Debug)]
pub struct Row {
    pub distance: f64,
    pub f32: ImageDiff,
    pub f64: ImageDiff,
    pub f32_time: Duration,
    pub f64_time: Duration,
}

/// Measures `scene` moved `distance` from where it is, in `base`'s mode and accelerator with f32
/// and with f64 arithmetic.
pub fn measure<D: Device>(
    ctx: &D,
    scene: &Scene,
    base: &Settings,
    distance: f64,
) -> Result<Row, RenderError> {
    let s = scene.transformed(1.0, offset(distance));
    let r = reference::render(&s);
    let reference = crate::image::Image {
        width: r.width,
        height: r.height,
        pixels: r.pixels.iter().map(|p| [p.x as f32, p.y as f32, p.z as f32]).collect(),
    };
    let run = |f64| -> Result<(ImageDiff, Duration), RenderError> {
        let mut session = Session::new(ctx, &s, Settings { f64, ..base.clone() })?;
        let image = session.try_picture(ctx, &mut |_, _| {}).map_err(Into::into)?.image;
        let (time, _) = session.try_median_picture_times(ctx, 3).map_err(Into::into)?;
        Ok((compare(&image, &reference), time))
    };
    let ((f32, f32_time), (f64, f64_time)) = (run(false)?, run(true)?);
    Ok(Row { distance, f32, f64, f32_time, f64_time })
}

/// One Markdown row per distance.
pub fn markdown_table(rows: &[Row]) -> String {
    let mut s = String::from(
        "| distance from origin | f32 max | f32 p99.9 | f32 pixels > 2/255 | f64 max | f64 p99.9 | f64 pixels > 2/255 | f64 time / f32 time | NaN/Inf |\n|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        s += &format!(
            "| {:e} | {:.1}/255 | {:.1}/255 | {:.3}% | {:.1}/255 | {:.1}/255 | {:.3}% | {:.2} | {} |\n",
            r.distance,
            r.f32.max * 255.0,
            r.f32.p999 * 255.0,
            r.f32.bad_pixels * 100.0,
            r.f64.max * 255.0,
            r.f64.p999 * 255.0,
            r.f64.bad_pixels * 100.0,
            r.f64_time.as_secs_f64() / r.f32_time.as_secs_f64(),
            r.f32.non_finite + r.f64.non_finite
        );
    }
    s
}

/// p99.9 and max error (in 1/255 steps) against distance, log–log, as SVG.
pub fn plot_svg(rows: &[Row], title: &str, path: &std::path::Path) -> Result<(), super::plot::PlotError> {
    use plotters::prelude::*;
    // Distance 0 is drawn at 1 (log axis); errors below 0.01/255 at 0.01.
    let pts = |f: fn(&Row) -> f64| -> Vec<(f64, f64)> {
        rows.iter().map(|r| (r.distance.max(1.0), (f(r) * 255.0).max(0.01))).collect()
    };
    let series = [
        (pts(|r| r.f32.max), RED, "f32 max"),
        (pts(|r| r.f32.p999), BLUE, "f32 99.9th percentile"),
        (pts(|r| r.f64.max), MAGENTA, "f64 max"),
        (pts(|r| r.f64.p999), CYAN, "f64 99.9th percentile"),
    ];
    let x_hi = rows.iter().map(|r| r.distance).fold(10.0, f64::max) * 2.0;
    let axes =
        ("distance from the origin (scene units; 0 drawn at 1)", "error vs f64 reference (1/255 steps)");
    super::plot::log_log_svg(path, title, (0.5..x_hi, 0.005..300.0), axes, |chart| {
        for (data, colour, label) in series {
            chart
                .draw_series(LineSeries::new(data.clone(), colour.stroke_width(2)))
                .map_err(|e| e.to_string())?
                .label(label)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour));
            chart
                .draw_series(data.iter().map(|&p| Circle::new(p, 4, colour.filled())))
                .map_err(|e| e.to_string())?;
        }
        chart.configure_series_labels().border_style(BLACK).draw().map_err(|e| e.to_string())?;
        Ok(())
    })
}
