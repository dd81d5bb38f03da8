//! `irt tradeoff`: every shadow mode's time and error against an f64 ground truth; table + plot.

use super::args::{fixed_size, load_scene, BackendArgs, DeviceArgs, SceneArgs};
use super::{command_args, machine_line, open_device};
use anyhow::{bail, Context, Result};
use clap::Args;
use irt::gpu::device::{Backend, Device};
use irt::render::Settings;
use std::path::PathBuf;
use std::time::Instant;

#[derive(Args)]
#[command(mut_arg("size", |a| fixed_size(
    a,
    "320x240",
    "small: the f64 ground truth traces STRATA² shadow rays per light and shading point on the CPU",
)))]
// Every shadow mode is measured (--modes chooses): --shadows is refused, and not offered.
#[command(mut_arg("shadows", |a| a.hide(true)))]
pub struct TradeoffArgs {
    /// Where table.md and plot.svg go (created if missing).
    #[arg(long, default_value = "tradeoff")]
    pub out_dir: PathBuf,
    /// Ground truth: STRATA² stratified shadow rays per light and shading point (32 → 1024,
    /// about 30 s on 2 cores for the default scene; docs/tradeoff.md uses 64 → 4096).
    #[arg(long, default_value_t = 32)]
    pub strata: u32,
    /// Timed frames per mode, in rounds that time every mode once in turn (median reported).
    #[arg(long, default_value_t = 5)]
    pub frames: u32,
    /// Only these modes, comma-separated (e.g. `hard,shell`), for quick timing; every mode of
    /// docs/tradeoff.md when omitted. `hard` is added first if missing (the `× hard` column);
    /// `soft` is the mode `--shadows soft` picks for the scene, its row labelled with the pick.
    #[arg(long, value_delimiter = ',', value_name = "MODE,...")]
    pub modes: Vec<irt::scene::ShadowSetting>,
    #[command(flatten)]
    pub scene: SceneArgs,
    #[command(flatten)]
    pub backend: BackendArgs,
    #[command(flatten)]
    pub device: DeviceArgs,
}

pub fn run(args: TradeoffArgs) -> Result<()> {
    let scene_args = args.scene;
    if scene_args.shadows.is_some() {
        bail!("--shadows: irt tradeoff measures every shadow mode; choose them with --modes");
    }
    let scene = load_scene(&scene_args)?;
    let base = Settings { f64: scene_args.f64(), accel: scene_args.accel, ..Settings::bands() };
    if scene.lights.iter().all(|l| l.radius == 0.0) {
        bail!("every light is a point light (radius 0): soft shadows equal hard ones; give the lights a radius (--light-radius R)");
    }
    if !(1..=256).contains(&args.strata) {
        bail!("--strata {} must be between 1 and 256", args.strata);
    }
    std::fs::create_dir_all(&args.out_dir).with_context(|| format!("creating {}", args.out_dir.display()))?;
    let name = scene_args.name_or("default scene");
    let (w, h) = (scene.camera.width, scene.camera.height);
    eprintln!(
        "ground truth: {w}x{h}, {} shadow rays per light and shading point, f64 on the CPU...",
        args.strata * args.strata
    );
    let t = Instant::now();
    let truth = irt::reference::Reference::new(&scene).with_ground_truth(args.strata).render().0;
    let truth = irt::image::Image {
        width: truth.width,
        height: truth.height,
        pixels: truth.pixels.iter().map(|p| [p.x as f32, p.y as f32, p.z as f32]).collect(),
    };
    eprintln!("ground truth took {:.1} s", t.elapsed().as_secs_f64());
    truth.save_png(&args.out_dir.join("ground-truth.png"))?;
    // Each mode and, for `soft`, its row's label.
    let mut modes: Vec<(irt::scene::ShadowMode, Option<String>)> = if args.modes.is_empty() {
        irt::lab::tradeoff::modes().into_iter().map(|m| (m, None)).collect()
    } else {
        args.modes
            .iter()
            .map(|m| {
                let (mode, soft) = m.resolve(&scene);
                (mode, soft.map(|_| format!("soft → {mode}")))
            })
            .collect()
    };
    if !modes.iter().any(|(m, label)| *m == irt::scene::ShadowMode::Hard && label.is_none()) {
        modes.insert(0, (irt::scene::ShadowMode::Hard, None));
    }
    let labels: Vec<Option<String>> = modes.iter().map(|(_, l)| l.clone()).collect();
    let modes: Vec<irt::scene::ShadowMode> = modes.into_iter().map(|(m, _)| m).collect();
    // The machine is shared: its load (1-minute average at the start of the timing and at the
    // end) says how far the absolute times can be trusted; the ratios hold either way.
    let load = || {
        std::fs::read_to_string("/proc/loadavg").ok().and_then(|s| s.split(' ').next().map(str::to_string))
    };
    let load_start = load();
    let (rows, device) = match args.backend.backend {
        Backend::Wgpu => measure(&open_device(&args.device)?, &scene, &base, &modes, &truth, args.frames)?,
        Backend::Ash => measure(
            &super::open_vk_device(&args.device, Default::default())?,
            &scene,
            &base,
            &modes,
            &truth,
            args.frames,
        )?,
    };
    let rows: Vec<irt::lab::tradeoff::Row> = rows
        .into_iter()
        .zip(labels)
        .map(|(r, l)| irt::lab::tradeoff::Row { label: l.unwrap_or(r.label.clone()), ..r })
        .collect();
    let header = format!(
        "Scene: {name}, {w}x{h}, light radius {}; device: {}; ground truth {}² stratified rays (f64 CPU); {}, load {} → {}; {} interleaved rounds; command: `irt tradeoff{}`\n\n",
        scene.lights.iter().map(|l| l.radius.to_string()).collect::<Vec<_>>().join(", "),
        device,
        args.strata,
        machine_line(),
        load_start.unwrap_or_else(|| "?".into()),
        load().unwrap_or_else(|| "?".into()),
        args.frames,
        command_args(),
    );
    let table = header + &irt::lab::tradeoff::markdown_table(&rows);
    print!("{table}");
    irt::image::write_atomic(&args.out_dir.join("table.md"), table.as_bytes())?;
    irt::lab::tradeoff::write_images(&rows, &truth, &args.out_dir)?;
    irt::lab::tradeoff::plot_svg(
        &rows,
        &format!("shadow modes on {name}: error vs time"),
        &args.out_dir.join("plot.svg"),
    )
    .map_err(anyhow::Error::msg)?;
    eprintln!(
        "wrote {}/table.md, plot.svg, ground-truth.png, MODE.png, MODE-error.png",
        args.out_dir.display()
    );
    Ok(())
}

/// Every mode on `ctx`'s path, with a spinner; and the adapter's name.
fn measure<D: Device>(
    ctx: &D,
    scene: &irt::scene::Scene,
    base: &Settings,
    modes: &[irt::scene::ShadowMode],
    truth: &irt::image::Image,
    frames: u32,
) -> Result<(Vec<irt::lab::tradeoff::Row>, String)> {
    let bar = indicatif::ProgressBar::new_spinner();
    let rows = irt::lab::tradeoff::measure_all(ctx, scene, base, modes, truth, frames, &mut |m| {
        bar.set_message(m.to_string());
        bar.tick();
    })
    .map_err(anyhow::Error::msg)?;
    bar.finish_and_clear();
    Ok((rows, ctx.adapter_name().to_string()))
}
