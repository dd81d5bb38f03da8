//! `irt stability`: the GPU's error against the f64 reference as the scene moves away from the
//! origin; table + plot.

use super::args::{fixed_size, load_scene, BackendArgs, DeviceArgs, SceneArgs};
use super::{command_args, machine_line, open_device};
use anyhow::{bail, Context, Result};
use clap::Args;
use irt::gpu::device::{Backend, Device};
use irt::render::Settings;
use std::path::PathBuf;

#[derive(Args)]
#[command(mut_arg("size", |a| fixed_size(a, "160x120", "small: the f64 reference renders every distance")))]
// f32 and f64 are measured side by side: --precision is refused, and not offered.
#[command(mut_arg("precision", |a| a.hide(true)))]
pub struct StabilityArgs {
    /// Where table.md and plot.svg go (created if missing).
    #[arg(long, default_value = "stability")]
    pub out_dir: PathBuf,
    #[command(flatten)]
    pub scene: SceneArgs,
    #[command(flatten)]
    pub backend: BackendArgs,
    #[command(flatten)]
    pub device: DeviceArgs,
}

pub fn run(args: StabilityArgs) -> Result<()> {
    let scene_args = args.scene;
    if scene_args.f64() {
        bail!("--precision: irt stability measures f32 and f64 side by side; drop it");
    }
    let scene = load_scene(&scene_args)?;
    let base = Settings { accel: scene_args.accel, ..Settings::bands() };
    std::fs::create_dir_all(&args.out_dir).with_context(|| format!("creating {}", args.out_dir.display()))?;
    let (rows, device) = match args.backend.backend {
        Backend::Wgpu => measure(&open_device(&args.device)?, &scene, &base)?,
        Backend::Ash => measure(&super::open_vk_device(&args.device, Default::default())?, &scene, &base)?,
    };
    let name = scene_args.name_or("default scene");
    let (w, h) = (scene.camera.width, scene.camera.height);
    let table = format!(
        "Scene: {name}, {w}x{h}, moved along (1, 0.8, -0.6); device: {}; {}; command: `irt stability{}`\n\n{}",
        device,
        machine_line(),
        command_args(),
        irt::lab::stability::markdown_table(&rows)
    );
    print!("{table}");
    irt::image::write_atomic(&args.out_dir.join("table.md"), table.as_bytes())?;
    irt::lab::stability::plot_svg(
        &rows,
        &format!("GPU (f32, f64) vs f64 reference: {name}"),
        &args.out_dir.join("plot.svg"),
    )
    .map_err(anyhow::Error::msg)?;
    eprintln!("wrote {}/table.md and plot.svg", args.out_dir.display());
    Ok(())
}

/// Every distance on `ctx`'s path, with a bar; and the adapter's name.
fn measure<D: Device>(
    ctx: &D,
    scene: &irt::scene::Scene,
    base: &Settings,
) -> Result<(Vec<irt::lab::stability::Row>, String)> {
    let bar = indicatif::ProgressBar::new(irt::lab::stability::DISTANCES.len() as u64);
    let mut rows = Vec::new();
    for d in irt::lab::stability::DISTANCES {
        bar.set_message(format!("{d:e}"));
        rows.push(irt::lab::stability::measure(ctx, scene, base, d).map_err(anyhow::Error::msg)?);
        bar.inc(1);
    }
    bar.finish_and_clear();
    Ok((rows, ctx.adapter_name().to_string()))
}
