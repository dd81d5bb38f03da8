//! `irt tradeoff`: what each shadow mode costs and how wrong it is, measured side by side in one
//! run against the CPU ground truth (docs/shadows.md).

use crate::gpu::device::Device;
use crate::image::Image;
use crate::metrics::{compare, ssim};
use crate::render::{RenderError, Session, Settings};
use crate::scene::{Combine, Falloff, Scene, ShadowMode};
use plotters::prelude::*;
use std::path::Path;
use std::time::{Duration, Instant};

/// One mode's measurements.
#[derive(Clone, Debug)]
pub struct Row {
    pub mode: ShadowMode,
    /// How the table names it: the mode, or what `soft` picked (`soft → shell:disc:min`).
    pub label: String,
    /// Median frame time (specialised pipeline, warm; modes interleaved, see [`measure_all`]).
    pub frame: Duration,
    pub mrays: f64,
    pub shadow_rays_per_pixel: f64,
    /// Display-space error against the ground truth.
    pub rmse: f64,
    pub max: f64,
    pub ssim: f64,
    /// The mode's picture (the first frame).
    pub image: Image,
}

/// The modes compared: hard, every shell variant, bundles of 4 to 256 (rotated) and one fixed.
pub fn modes() -> Vec<ShadowMode> {
    let mut v = vec![ShadowMode::Hard];
    for falloff in Falloff::ALL {
        for combine in [Combine::Min, Combine::Product] {
            v.push(ShadowMode::Shell { falloff, combine });
        }
    }
    for samples in [4, 16, 64, 256] {
        v.push(ShadowMode::Bundle { samples, rotate: true });
    }
    v.push(ShadowMode::Bundle { samples: 16, rotate: false });
    v
}

/// Renders `scene` in every mode of `modes` (with `base`'s other settings: the bands, the
/// precision and accelerator asked for) and compares each with `truth`; times them
/// interleaved: `frames` rounds, each timing one warm frame of every mode in turn, and each
/// mode's median. On a shared, loaded machine the load then falls on all modes alike, so the
/// ratios to hard shadows hold within one run even where absolute times drift.
pub fn measure_all<D: Device>(
    ctx: &D,
    scene: &Scene,
    base: &Settings,
    modes: &[ShadowMode],
    truth: &Image,
    frames: u32,
    progress: &mut dyn FnMut(&str),
) -> Result<Vec<Row>, RenderError> {
    let mut prepared = vec![];
    let counting = Settings { count_rays: true, ..base.clone() };
    for &mode in modes {
        progress(&format!("{mode}: first frame"));
        let mut s = scene.clone();
        s.trace.shadows = mode;
        let mut session = Session::new(ctx, &s, base.clone())?;
        let image = session.try_picture(ctx, &mut |_, _| {}).map_err(Into::into)?.image;
        let rays = Session::new(ctx, &s, counting.clone())?
            .try_picture(ctx, &mut |_, _| {})
            .map_err(Into::into)?
            .rays;
        prepared.push((mode, session, image, rays));
    }
    let mut times: Vec<Vec<Duration>> = vec![vec![]; prepared.len()];
    for round in 0..frames.max(1) {
        for (k, (mode, session, _, _)) in prepared.iter_mut().enumerate() {
            progress(&format!("round {}/{}: {mode}", round + 1, frames.max(1)));
            let t = Instant::now();
            session.try_picture(ctx, &mut |_, _| {}).map_err(Into::into)?;
            times[k].push(t.elapsed());
        }
    }
    let pixels = (scene.camera.width * scene.camera.height) as f64;
    Ok(prepared
        .into_iter()
        .zip(times)
        .map(|((mode, _, image, rays), mut t)| {
            t.sort();
            let frame = t[t.len() / 2];
            let diff = compare(&image, truth);
            Row {
                mode,
                label: mode.to_string(),
                frame,
                mrays: rays.total() as f64 / frame.as_secs_f64() / 1e6,
                shadow_rays_per_pixel: rays.shadow as f64 / pixels,
                rmse: diff.rmse,
                max: diff.max,
                ssim: ssim(&image, truth),
                image,
            }
        })
        .collect())
}

/// Writes each row's picture as `<mode>.png` and where it differs from `truth` as
/// `<mode>-error.png` (the display-space error ×8 in red over a dimmed truth), into `dir`: where
/// a mode's error comes from, beside hard shadows'.
pub fn write_images(rows: &[Row], truth: &Image, dir: &Path) -> std::io::Result<()> {
    for r in rows {
        let name = r.label.replace(" → ", "-").replace(':', "-");
        r.image.save_png(&dir.join(format!("{name}.png")))?;
        crate::metrics::diff_image(&r.image, truth, 8.0).save_png(&dir.join(format!("{name}-error.png")))?;
    }
    Ok(())
}

/// The rows as a Markdown table, with each mode's time relative to hard shadows.
pub fn markdown_table(rows: &[Row]) -> String {
    let hard = rows.iter().find(|r| r.label == "hard").map(|r| r.frame.as_secs_f64());
    let mut s = String::from(
        "| mode | frame ms | × hard | Mrays/s | shadow rays/pixel | RMSE | max error | SSIM |\n\
         |---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        let rel = hard.map_or("–".into(), |h| format!("{:.2}", r.frame.as_secs_f64() / h));
        s += &format!(
            "| {} | {:.1} | {rel} | {:.2} | {:.2} | {:.5} | {:.3} | {:.4} |\n",
            r.label,
            r.frame.as_secs_f64() * 1e3,
            r.mrays,
            r.shadow_rays_per_pixel,
            r.rmse,
            r.max,
            r.ssim
        );
    }
    s
}

/// Error (RMSE) against frame time, log–log, one labelled point per mode, as SVG.
pub fn plot_svg(rows: &[Row], title: &str, path: &Path) -> Result<(), super::plot::PlotError> {
    let ms: Vec<f64> = rows.iter().map(|r| r.frame.as_secs_f64() * 1e3).collect();
    let rmse: Vec<f64> = rows.iter().map(|r| r.rmse.max(1e-6)).collect();
    let span = |v: &[f64]| {
        let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = v.iter().copied().fold(0.0, f64::max);
        (lo / 1.5)..(hi * 1.5)
    };
    let colour = |m: &ShadowMode| match m {
        ShadowMode::Hard => BLACK,
        ShadowMode::Shell { .. } => RED,
        ShadowMode::Bundle { .. } => BLUE,
    };
    let axes = ("frame time (ms, log)", "RMSE vs ground truth (display space, log)");
    super::plot::log_log_svg(path, title, (span(&ms), span(&rmse)), axes, |chart| {
        chart
            .draw_series(rows.iter().zip(ms.iter().zip(&rmse)).map(|(r, (&x, &y))| {
                EmptyElement::at((x, y))
                    + Circle::new((0, 0), 4, colour(&r.mode).filled())
                    + Text::new(r.label.clone(), (6, -12), ("sans-serif", 12))
            }))
            .map_err(|e| e.to_string())?;
        Ok(())
    })
}
