//! The commands and what they share: the argument groups and the scene loader ([`args`]),
//! device opening, output checks and the machine line of measurement tables.
//!
//! Adding a command: a module with its `Args` struct (flattening the groups of [`args`] it
//! takes) and `run(args) -> Result<()>`, and a variant of [`Command`] (with its arm in
//! [`Command::run`]).

pub mod args;
mod bench;
mod convert;
mod farm;
mod info;
mod mpi;
mod render;
mod replay;
mod sequence;
mod spd;
mod stability;
mod tradeoff;
mod view;

use anyhow::{bail, Result};
use args::DeviceArgs;
use clap::{Parser, Subcommand};
use irt::gpu::{AdapterChoice, CacheSetting, GpuContext};
use std::path::Path;

#[derive(Parser)]
#[command(
    name = "irt",
    version,
    about = "Interactive ray tracer on Vulkan compute (Parker et al., I3D 1999)",
    long_about = "irt traces scenes with WGSL compute shaders on any Vulkan device — by default \
Mesa's lavapipe, which runs Vulkan on the CPU. Without a SCENE it draws the built-in default \
scene.\n\nExamples:\n  irt view\n  irt view scenes/spd/balls_s2.nff --mode frameless\n  irt replay scenes/paths/orbit.toml --mode frameless\n  irt render --out default.png\n  irt render --out default.exr\n  irt render scenes/metal.toml --size 800x600 --out metal.png\n  irt render scenes/spd/balls_s4.nff --stats --spd-rules --out balls.png\n  irt render --shadows bundle:16 --out soft.png\n  irt render --shadows soft --light-radius 0.5 --out soft.png\n  mpirun -n 3 irt view scenes/spd/balls_s4.nff --mpi\n  irt render --tile 0/4 --out tiles/   (then: irt merge tiles/ --out picture.png)\n  irt tradeoff --out-dir tradeoff\n  irt bench\n  irt convert model.glb model.toml\n  irt spd balls --size 6 --out balls_s6.nff\n  irt info"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand)]
pub enum Command {
    // about and long help come from ViewArgs (a doc comment here would replace them).
    View(view::ViewArgs),
    /// Render a scene to a PNG or OpenEXR image (headless).
    Render(render::RenderArgs),
    /// Replay a camera path; measure latency, pixel age and dynamic error (docs/interactive.md).
    Replay(replay::ReplayArgs),
    /// Write any scene irt can load (TOML, glTF/GLB, NFF, OBJ, PLY) as a native TOML scene, losslessly.
    Convert(convert::ConvertArgs),
    /// Write Haines' sphereflake (balls) or Sierpinski tetrahedron (tetra) at any size, as NFF.
    Spd(spd::SpdArgs),
    /// Show the Vulkan adapters and the one irt would use.
    Info(info::InfoArgs),
    /// Measure accelerator build time, time to first frame and Mrays/s.
    Bench(bench::BenchArgs),
    /// Measure every shadow mode's time and error against the ground truth; table + plot.
    Tradeoff(tradeoff::TradeoffArgs),
    /// Measure the GPU's error against the f64 reference as the scene moves away from the origin.
    Stability(stability::StabilityArgs),
    /// Stitch the tiles of `irt render --tile I/N --out DIR` into one picture (a render farm's
    /// last step; refuses while a tile is missing).
    Merge(farm::MergeArgs),
}

impl Command {
    pub fn run(self) -> Result<()> {
        match self {
            Command::View(a) => view::run(a),
            Command::Render(a) => render::run(a),
            Command::Replay(a) => replay::run(a),
            Command::Convert(a) => convert::run(a),
            Command::Spd(a) => spd::run(a),
            Command::Info(a) => info::run(a),
            Command::Bench(a) => bench::run(a),
            Command::Tradeoff(a) => tradeoff::run(a),
            Command::Stability(a) => stability::run(a),
            Command::Merge(a) => farm::merge(a),
        }
    }
}

/// Opens the ash path's device on the adapter the arguments name, with `options` (no pipeline
/// cache: the ash path has none yet).
pub fn open_vk_device(
    args: &DeviceArgs,
    options: irt::gpu::vk::VkOptions,
) -> Result<irt::gpu::vk::VkContext> {
    let choice = AdapterChoice::from_arg_or_env(args.adapter.as_deref());
    if options.full_spirv_check && !irt::gpu::vk::spirv_val_available() {
        bail!("--spirv-val: spirv-val does not run here (install SPIRV-Tools, e.g. apt-get install spirv-tools, or set IRT_SPIRV_VAL)");
    }
    Ok(irt::gpu::vk::VkContext::with_options(&choice, options)?)
}

use irt::io::{report, LARGE_SCENE_PRIMITIVES};

/// A progress bar of `len` steps drawn by `template` (indicatif's), in the commands' one style.
pub fn bar(len: u64, template: &str) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(len);
    bar.set_style(
        indicatif::ProgressStyle::with_template(template).expect("valid template").progress_chars("=> "),
    );
    bar
}

/// A bar for [`irt::render::Session::with_progress`]: the accelerator build's primitives, then the
/// upload.
pub fn setup_bar(primitives: usize) -> indicatif::ProgressBar {
    if primitives < LARGE_SCENE_PRIMITIVES {
        return indicatif::ProgressBar::hidden();
    }
    let bar = bar(primitives as u64, "{spinner} {msg} [{bar:30}] {human_pos}/{human_len} {elapsed}");
    bar.set_message("building the accelerator");
    bar.enable_steady_tick(std::time::Duration::from_millis(120));
    bar
}

/// The progress callback that drives [`setup_bar`].
pub fn show_setup(bar: &indicatif::ProgressBar, stage: irt::render::SetupStage, done: u64, total: u64) {
    match stage {
        irt::render::SetupStage::Grid | irt::render::SetupStage::Bvh => {
            bar.set_message(if stage == irt::render::SetupStage::Grid {
                "building the grid"
            } else {
                "building the BVH"
            });
            bar.set_length(total);
            bar.set_position(done);
        }
        irt::render::SetupStage::Upload => bar.set_message("packing and uploading the scene"),
    }
}

/// Opens the device the arguments name, with the pipeline cache of `--no-cache`/`$IRT_CACHE_DIR`.
pub fn open_device(args: &DeviceArgs) -> Result<GpuContext> {
    open_device_with(args, &CacheSetting::from_flag_or_env(args.no_cache))
}

/// Opens the device the arguments name, with the pipeline cache `cache`.
pub fn open_device_with(args: &DeviceArgs, cache: &CacheSetting) -> Result<GpuContext> {
    Ok(GpuContext::with_cache(&AdapterChoice::from_arg_or_env(args.adapter.as_deref()), cache)?)
}

/// Fails early (before minutes of tracing) when a file could not be written at `out`.
pub fn check_output_path(out: &Path) -> Result<()> {
    let dir = out.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    if !dir.is_dir() {
        bail!("output directory '{}' does not exist", dir.display());
    }
    if out.is_dir() {
        bail!("output '{}' is a directory; give a file name", out.display());
    }
    Ok(())
}

/// This run's arguments after the subcommand, for tables that state their command.
pub fn command_args() -> String {
    std::env::args().skip(2).map(|a| format!(" {a}")).collect()
}

/// CPU model and core count, for tables that state the machine.
pub fn machine_line() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .map(|l| l.split(':').nth(1).unwrap_or("").trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    format!("{cpu}, {cores} cores")
}
