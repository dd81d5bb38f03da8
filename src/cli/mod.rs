//! The commands and what they share: scene and device arguments, scene loading, device opening,
//! output checks and the machine line of measurement tables.
//!
//! Adding a command: a module with its `Args` struct and `run(args) -> Result<()>`, and a
//! variant of [`Command`] (with its arm in [`Command::run`]).

mod bench;
mod convert;
mod info;
mod mpi;
mod render;
mod sequence;
mod spd;
mod stability;
mod tradeoff;

use anyhow::{bail, Result};
use clap::{Args, Parser, Subcommand};
use irt::gpu::{AdapterChoice, CacheSetting, GpuContext};
use irt::scene::Scene;
use std::path::{Path, PathBuf};

#[derive(Parser)]
#[command(
    name = "irt",
    version,
    about = "Interactive ray tracer on Vulkan compute (Parker et al., I3D 1999)",
    long_about = "irt traces scenes with WGSL compute shaders on any Vulkan device — by default \
Mesa's lavapipe, which runs Vulkan on the CPU. Without a SCENE it draws the built-in default \
scene.\n\nExamples:\n  irt view\n  irt view scenes/spd/balls_s2.nff --mode frameless\n  irt replay scenes/paths/orbit.toml --mode frameless\n  irt render --out default.png\n  irt render --out default.exr\n  irt render scenes/metal.toml --width 800 --height 600 --out metal.png\n  irt render scenes/spd/balls_s4.nff --stats --spd-rules --out balls.png\n  irt render --shadows bundle:16 --out soft.png\n  irt tradeoff --out-dir tradeoff\n  irt bench\n  irt convert model.glb model.toml\n  irt spd balls --size 6 --out balls_s6.nff\n  irt info"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand)]
pub enum Command {
    /// Render a scene to a PNG or OpenEXR image (headless).
    Render(render::RenderArgs),
    /// Show the Vulkan adapters and the one irt would use.
    Info(info::InfoArgs),
    /// Measure grid build, time to first frame and Mrays/s.
    Bench(bench::BenchArgs),
    /// Measure every shadow mode's time and error against the ground truth; table + plot.
    Tradeoff(tradeoff::TradeoffArgs),
    /// Measure the GPU's error against the f64 reference as the scene moves away from the origin.
    Stability(stability::StabilityArgs),
    /// Write any scene irt can load (TOML, glTF) as a native TOML scene, losslessly.
    Convert(convert::ConvertArgs),
    /// Write Haines' sphereflake (balls) or Sierpinski tetrahedron (tetra) at any size, as NFF.
    Spd(spd::SpdArgs),
    // about and long help come from ViewArgs (a doc comment here would replace them).
    View(irt::app::ViewArgs),
    /// Replay a camera path; measure latency, pixel age and dynamic error (docs/interactive.md).
    Replay(irt::render::replay::ReplayArgs),
}

impl Command {
    pub fn run(self) -> Result<()> {
        match self {
            Command::Render(a) => render::run(a),
            Command::Info(a) => info::run(a),
            Command::Bench(a) => bench::run(a),
            Command::Tradeoff(a) => tradeoff::run(a),
            Command::Stability(a) => stability::run(a),
            Command::Convert(a) => convert::run(a),
            Command::Spd(a) => spd::run(a),
            Command::View(a) => irt::app::run(a),
            Command::Replay(a) => irt::render::replay::run(a),
        }
    }
}

#[derive(Args)]
pub struct DeviceArgs {
    /// Vulkan adapter: "lavapipe" (default), "gpu" (best hardware GPU), or part of a device name.
    /// Also read from $IRT_ADAPTER.
    #[arg(long, value_name = "NAME")]
    pub adapter: Option<String>,
    /// Do not read or write the on-disk pipeline cache (also: IRT_CACHE_DIR=off). By default
    /// compiled pipelines are kept in $IRT_CACHE_DIR, else $XDG_CACHE_HOME/irt, else ~/.cache/irt.
    #[arg(long)]
    pub no_cache: bool,
}

pub use irt::gpu::device::Backend;

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum OnOff {
    #[default]
    On,
    Off,
}

/// The ash path's raw-Vulkan levers (docs/backends.md, "Raw-Vulkan levers"); `--backend ash`.
#[derive(Args, Clone, Debug, Default)]
pub struct AshArgs {
    /// Robustness: on (default; the device's robust buffer and image access, naga's index
    /// checks) or off (neither: out-of-bounds accesses are undefined; the kernels make none).
    #[arg(long, value_enum, default_value_t = OnOff::On)]
    pub robust: OnOff,
    /// The tile in push constants instead of a uniform buffer written before each dispatch.
    #[arg(long)]
    pub push_tile: bool,
    /// Timestamps around every dispatch and its compute-shader invocations (pipeline
    /// statistics): device time against host wall time per dispatch, invocations per frame.
    #[arg(long)]
    pub profile: bool,
    /// Also validate every pipeline's SPIR-V with spirv-val (SPIRV-Tools) before the driver sees
    /// it; the structural check and naga's read-back always run.
    #[arg(long)]
    pub spirv_val: bool,
}

impl AshArgs {
    pub fn options(&self) -> irt::gpu::vk::VkOptions {
        let robust = self.robust == OnOff::On;
        irt::gpu::vk::VkOptions {
            robust,
            index_checks: robust,
            push_tile: self.push_tile,
            full_spirv_check: self.spirv_val,
            profile: self.profile,
            ..Default::default()
        }
    }

    /// Whether any lever differs from the default (each needs `--backend ash`).
    pub fn any(&self) -> bool {
        self.options() != irt::gpu::vk::VkOptions::default()
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

#[derive(Args)]
pub struct SceneArgs {
    /// Scene file (.toml, .gltf, .glb, .nff, .obj, .ply); the built-in default scene when omitted.
    pub scene: Option<PathBuf>,
    /// Image width in pixels (overrides the scene's camera).
    #[arg(long, allow_negative_numbers = true)]
    pub width: Option<u32>,
    /// Image height in pixels (overrides the scene's camera).
    #[arg(long, allow_negative_numbers = true)]
    pub height: Option<u32>,
    /// Shadow mode (overrides the scene's [trace] shadows): soft (picks shell or bundle:2 for
    /// the scene by what a shell ray would visit, and says which; docs/tradeoff.md), hard,
    /// bundle:K (K rays to a precomputed point set on the light, rotated per pixel; bundle:K:fixed
    /// unrotated), or shell (one ray through translucent shells; shell:FALLOFF:COMBINE with
    /// FALLOFF disc (default), smoothstep or linear and COMBINE min (default) or product). See
    /// docs/shadows.md.
    #[arg(long, value_name = "MODE")]
    pub shadows: Option<irt::scene::ShadowSetting>,
    /// Radius of every light (overrides the scene; 0 is a point light, soft modes need > 0).
    #[arg(long, value_name = "R")]
    pub light_radius: Option<f64>,
    /// Arithmetic of ray–primitive intersection and grid traversal: f32, or f64 (needs the
    /// device's SHADER_F64; lavapipe has it). See docs/stability.md.
    #[arg(long, value_name = "BITS", default_value = "f32", value_parser = ["f32", "f64"])]
    pub precision: String,
    /// Accelerator: grid (the paper's uniform grid with macro-cells), bvh (a binned-SAH BVH
    /// walked without a stack, by escape links), bvh-stack (the same BVH walked with a stack,
    /// near child first; for measuring), or auto (the BVH; the grid only for scenes past 2^21
    /// primitives some of which move, where a BVH is rebuilt every frame; docs/performance.md,
    /// "Grid vs BVH").
    #[arg(long, value_name = "ACCEL", default_value_t = irt::accel::AccelChoice::default())]
    pub accel: irt::accel::AccelChoice,
}

impl SceneArgs {
    /// Whether `--precision f64` was asked for.
    pub fn f64(&self) -> bool {
        self.precision == "f64"
    }

    /// The scene's name in messages and tables: its path, else `default`.
    pub fn name_or(&self, default: &str) -> String {
        self.scene.as_deref().map_or(default.into(), |p| p.display().to_string())
    }
}

/// The scene the arguments name (or the default scene), with their overrides applied, validated
/// and non-empty.
pub fn load_scene(args: &SceneArgs) -> Result<Scene> {
    let mut scene = irt::io::load_or_default(args.scene.as_deref())?;
    if let Some(w) = args.width {
        scene.camera.width = w;
    }
    if let Some(h) = args.height {
        scene.camera.height = h;
    }
    if let Some(r) = args.light_radius {
        scene.lights.iter_mut().for_each(|l| l.radius = r);
    }
    if let Some(m) = args.shadows {
        let (mode, soft) = m.resolve(&scene);
        scene.trace.shadows = mode;
        if let Some(c) = soft {
            eprintln!("shadows: {c}");
        }
    }
    irt::io::check_renderable(&scene, &args.name_or("default scene")).map_err(anyhow::Error::msg)?;
    Ok(scene)
}

use irt::io::{report, LARGE_SCENE_PRIMITIVES};

/// A bar for [`irt::gpu::Renderer::with_progress`]: the grid build's primitives, then the upload.
pub fn setup_bar(primitives: usize) -> indicatif::ProgressBar {
    if primitives < LARGE_SCENE_PRIMITIVES {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new(primitives as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{spinner} {msg} [{bar:30}] {human_pos}/{human_len} {elapsed}",
        )
        .expect("valid template")
        .progress_chars("=> "),
    );
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
