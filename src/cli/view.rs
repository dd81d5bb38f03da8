//! `irt view`: the interactive window ([`irt::app`]), its arguments turned into the library's
//! [`ViewOptions`].

use super::args::{load_scene_and_pick, DeviceArgs, ModeArgs, SceneArgs};
use anyhow::{bail, Result};
use clap::Args;
use irt::app::{keys, ViewOptions, ABOUT, LONG_ABOUT};
use irt::dist::cluster::Cluster;
use irt::dist::master::Deadlines;
use irt::render::{Mode, Settings};
use std::path::PathBuf;

#[derive(Args, Clone, Debug)]
#[command(
    about = ABOUT,
    long_about = LONG_ABOUT,
    after_long_help = keys::help(),
    mut_arg("size", |a| a.help("Window size in pixels, WxH (default: about 1280x720 within the screen, with the scene camera's aspect)"))
)]
pub struct ViewArgs {
    /// Frameless: present after exactly N slices (0: as many slices as fit in one display
    /// interval, ~16 ms, at least one).
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub present_every: u32,
    /// Refinement stops after this many samples per pixel (0: never); the window then waits.
    #[arg(long, value_name = "N", default_value_t = 64)]
    pub max_samples: u32,
    /// Resolution scale of the render against the window: 1, 1/2 or 1/4.
    #[arg(long, value_name = "SCALE", default_value = "1", value_parser = parse_scale)]
    pub scale: u32,
    /// Start with the HUD hidden (H shows it).
    #[arg(long)]
    pub no_hud: bool,
    /// With --order adaptive: show pixels not yet traced since a change as they were traced,
    /// rather than blended with fresher neighbours. The blend costs the window's present about
    /// 5x on lavapipe (docs/adaptive.md), time the CPU then does not trace.
    #[arg(long)]
    pub no_fill: bool,
    /// Show N pictures (each after at least one step), write the screenshot and exit 0.
    #[arg(long, value_name = "N")]
    pub frames: Option<u32>,
    /// Where P (and --frames) writes the PNG, atomically; otherwise irt-YYYYmmdd-HHMMSS.png (UTC)
    /// in the current directory.
    #[arg(long, value_name = "FILE")]
    pub screenshot: Option<PathBuf>,
    /// Where T (and the HUD's save button) writes the edited scene as TOML, atomically, with its
    /// textures beside it; otherwise irt-scene-YYYYmmdd-HHMMSS.toml (UTC) in the current directory.
    #[arg(long, value_name = "FILE")]
    pub save: Option<PathBuf>,
    /// Animated scenes: the scene time to start at, in seconds (a still ignores it).
    #[arg(long, value_name = "T", default_value_t = 0.0)]
    pub time: f64,
    /// Animated scenes: start paused (Space plays).
    #[arg(long)]
    pub paused: bool,
    #[command(flatten)]
    pub scene: SceneArgs,
    /// The dispatch mode (frameless unless --mode says otherwise; M switches in the window)
    /// and its parameters, as `irt render` spells them.
    #[command(flatten)]
    pub mode: ModeArgs,
    #[command(flatten)]
    pub device: DeviceArgs,
    /// `mpirun -n N irt view --mpi`: rank 0 opens the window, ranks 1..N-1 trace.
    #[command(flatten)]
    pub mpi: super::mpi::MpiArgs,
}

/// `1`, `1/2` or `1/4` (also `0.5`, `0.25`) as the divisor 1, 2 or 4.
pub fn parse_scale(s: &str) -> Result<u32> {
    match s.trim() {
        "1" | "1/1" | "1.0" => Ok(1),
        "1/2" | "0.5" => Ok(2),
        "1/4" | "0.25" => Ok(4),
        _ => bail!("scale `{s}`: expected 1, 1/2 or 1/4"),
    }
}

/// `irt view`: runs the window until it is closed (or `--frames` are shown).
pub fn run(args: ViewArgs) -> Result<()> {
    if !args.mpi.mpi {
        return window(args, None);
    }
    // Under mpirun every rank runs this command: the workers trace until rank 0 ends the job.
    let Some(cluster) = super::mpi::join(irt::gpu::device::Backend::Wgpu, &args.device)? else {
        return Ok(());
    };
    // Rank 0: whatever fails here (no display, a bad scene, a dead worker) ends every rank.
    let deadlines = args.mpi.deadlines().unwrap_or_else(|e| cluster.abort(&format!("{e:#}")));
    window(args, Some((&cluster, deadlines))).unwrap_or_else(|e| cluster.abort(&format!("error: {e:#}")));
    Ok(())
}

/// The window, on this process's device or (`cluster`) with the job's workers tracing.
fn window(args: ViewArgs, cluster: Option<(&Cluster, Deadlines)>) -> Result<()> {
    let (scene, pick) = load_scene_and_pick(&args.scene)?;
    let frameless = args.mode.frameless(args.present_every);
    let conventional = args.mode.conventional();
    let mode = match args.mode.mode()? {
        Some(Mode::Conventional { .. }) => conventional,
        _ => frameless,
    };
    let settings = Settings {
        mode,
        max_samples: args.max_samples,
        f64: args.scene.f64(),
        accel: args.scene.accel,
        ..Settings::default()
    };
    let options = ViewOptions {
        size: args.scene.size,
        scale: args.scale,
        no_hud: args.no_hud,
        no_fill: args.no_fill,
        frames: args.frames,
        screenshot: args.screenshot,
        save: args.save,
        time: args.time,
        paused: args.paused,
        adapter: args.device.adapter,
        no_cache: args.device.no_cache,
        scene_name: args.scene.name_or("default scene"),
        soft_pick: pick.map(|c| (c.mode, format!("soft picked {}: {}", c.mode, c.why))),
        settings,
        fixed_slice: args.mode.slice.is_some(),
        fixed_schedule: args.mode.schedule.is_some(),
        frameless,
        conventional,
    };
    match cluster {
        Some((cluster, deadlines)) => irt::app::run_distributed(options, scene, cluster, deadlines),
        None => irt::app::run(options, scene),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scales_parse() {
        assert_eq!(parse_scale("1/2").unwrap(), 2);
        assert_eq!(parse_scale("0.25").unwrap(), 4);
        assert!(parse_scale("1/3").is_err());
    }
}
