//! The argument groups the commands share, each declared once and flattened where it is used,
//! and the one scene loader every command goes through.
//!
//! | group | flags | flattened into |
//! |---|---|---|
//! | [`SceneArgs`] | SCENE, `--size`, `--shadows`, `--light-radius`, `--max-depth`, `--precision`, `--accel` | render, view, replay, bench, tradeoff, stability |
//! | [`DeviceArgs`] | `--adapter`, `--no-cache` | every command that opens a device |
//! | [`BackendArgs`] | `--backend` | render, replay, bench, tradeoff, stability (not view: its window is wgpu's) |
//! | [`ModeArgs`] | `--mode`, `--schedule`, `--workers`, `--order`, `--slice`, `--blend`, `--jitter-pairs` | render, view, replay |
//! | [`AshArgs`] | `--robust`, `--push-tile`, `--profile`, `--spirv-val` | bench |
//!
//! A command whose image size is not the scene camera's by default says so with
//! `#[command(mut_arg("size", ...))]` ([`fixed_size`]), so its `--help` shows its own default.

use anyhow::{anyhow, bail, Result};
use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
use clap::{Args, ValueEnum};
use irt::accel::AccelChoice;
use irt::gpu::device::Backend;
use irt::render::{Mode, PixelOrder, Schedule, Settings, DEFAULT_SLICE};
use irt::scene::{Scene, MAX_TRACE_DEPTH};
use std::path::{Path, PathBuf};

/// What `irt` reads as a scene: every extension of [`irt::io::FORMATS`] (a test keeps them equal).
pub const SCENE_FILES: &str = ".toml, .gltf, .glb, .nff, .obj, .ply";

/// The scene and what a command may override in it.
#[derive(Args, Clone, Debug)]
#[command(next_help_heading = "Scene")]
pub struct SceneArgs {
    /// Scene file (.toml, .gltf, .glb, .nff, .obj, .ply) or a volume file (.nrrd, .nhdr, .nii,
    /// .nii.gz, .vti: its isosurface, see --iso); the built-in default scene when omitted.
    #[arg(help_heading = None)]
    pub scene: Option<PathBuf>,
    /// Image size in pixels, WxH (default: the scene camera's): up to 16384 a side and 67108864
    /// pixels (64 Mpixel, e.g. 8192x8192). A picture larger than the device's frame buffers
    /// (lavapipe's: 8388608 pixels, about 2896x2896) is traced in pieces; the host holds the
    /// whole picture, about 30-40 bytes a pixel at peak (2.6 GB at the limit; docs/large-models.md).
    #[arg(long, value_name = "WxH", value_parser = parse_size, allow_hyphen_values = true)]
    pub size: Option<[u32; 2]>,
    /// Shadow mode (overrides the scene's [trace] shadows): soft (picks shell, a bundle or hard
    /// for the scene by a quick CPU pilot of each one's error and cost, and says which;
    /// docs/tradeoff.md), hard, bundle:K (K rays to a precomputed point set on the light, rotated
    /// per pixel; bundle:K:fixed unrotated), or shell (one ray through translucent shells;
    /// shell:FALLOFF:COMBINE with FALLOFF disc (default), smoothstep or linear and COMBINE min
    /// (default) or product). See docs/shadows.md.
    #[arg(long, value_name = "MODE")]
    pub shadows: Option<irt::scene::ShadowSetting>,
    /// Isovalues of every volume, comma-separated (overrides the scene's `iso`; a volume file
    /// alone is drawn halfway through its samples' range): e.g. --iso 80 or --iso 80,300. The
    /// i-th isosurface keeps the volume's i-th material (its last, past the ones it has).
    #[arg(long, value_name = "V[,V...]", value_delimiter = ',', allow_hyphen_values = true)]
    pub iso: Vec<f64>,
    /// How every volume is drawn (overrides the scene's `mode`): iso (its isosurfaces), mip
    /// (the greatest sample along each ray, in greys) or dvr (emission and absorption through
    /// the inferno map); the transfer window is the samples' range unless the scene gives one.
    /// See docs/volumes.md.
    #[arg(long, value_name = "iso|mip|dvr", value_parser = irt::scene::transfer::Look::parse)]
    pub volume_mode: Option<irt::scene::transfer::Look>,
    /// Radius of every light (overrides the scene; 0 is a point light, soft modes need > 0).
    #[arg(long, value_name = "R")]
    pub light_radius: Option<f64>,
    /// Maximum ray depth, the eye ray counting 1 (overrides the scene's [trace] max_depth).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=MAX_TRACE_DEPTH as i64))]
    pub max_depth: Option<u32>,
    /// Arithmetic of ray–primitive intersection and accelerator traversal: f32, or f64 (needs
    /// the device's SHADER_F64; lavapipe has it). See docs/stability.md.
    #[arg(long, value_enum, value_name = "BITS", default_value_t = Precision::F32)]
    pub precision: Precision,
    /// Accelerator: grid (the paper's uniform grid with macro-cells), bvh (a binned-SAH BVH
    /// walked without a stack, by escape links), bvh-stack (the same BVH walked with a stack,
    /// near child first; for measuring), or auto (the BVH; the grid only for scenes past 2^21
    /// primitives some of which move, where a BVH is rebuilt every frame; docs/performance.md,
    /// "Grid vs BVH").
    #[arg(long, value_name = "ACCEL", default_value_t = AccelChoice::default())]
    pub accel: AccelChoice,
}

/// `--precision`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum Precision {
    #[default]
    F32,
    F64,
}

impl SceneArgs {
    /// Whether `--precision f64` was asked for.
    pub fn f64(&self) -> bool {
        self.precision == Precision::F64
    }

    /// The scene's name in messages and tables: its path, else `default`.
    pub fn name_or(&self, default: &str) -> String {
        self.scene.as_deref().map_or(default.into(), |p| p.display().to_string())
    }
}

/// `--size` of a command whose default size is not the scene camera's: `default`, and `why`.
pub fn fixed_size(arg: clap::Arg, default: &'static str, why: &str) -> clap::Arg {
    arg.default_value(default).help(format!("Image size in pixels, WxH ({why})"))
}

/// The scene the arguments name (or the built-in default scene), with their size and overrides
/// applied, validated and non-empty: what every command traces.
pub fn load_scene(args: &SceneArgs) -> Result<Scene> {
    Ok(load_scene_and_pick(args)?.0)
}

/// [`load_scene`], and what `soft` shadows picked for it (the command line's or the scene
/// file's), for the window to show.
pub fn load_scene_and_pick(args: &SceneArgs) -> Result<(Scene, Option<irt::scene::SoftChoice>)> {
    if let Some(path) = &args.scene {
        not_a_directory(path)?;
    }
    let mut scene = irt::io::load_or_default(args.scene.as_deref())?;
    if let Some([w, h]) = args.size {
        scene.camera.width = w;
        scene.camera.height = h;
    }
    let overrides =
        Settings { light_radius: args.light_radius, max_depth: args.max_depth, ..Settings::default() };
    overrides.apply_to(&mut scene);
    set_isos(&mut scene, &args.iso)?;
    if let Some(look) = args.volume_mode {
        set_looks(&mut scene, look)?;
    }
    // After the size and the lights' radius: `soft` weighs the modes on the scene as it is traced.
    // The command line's choice, else the scene file's `shadows = "soft"`.
    let setting = args.shadows.or(scene.trace.soft.then_some(irt::scene::ShadowSetting::Soft));
    let mut pick = None;
    if let Some(setting) = setting {
        let (mode, choice) = setting.resolve(&scene);
        scene.trace.shadows = mode;
        scene.trace.soft = false;
        if let Some(c) = &choice {
            eprintln!("shadows: {c}");
        }
        pick = choice;
    }
    irt::io::check_renderable(&scene, &args.name_or("default scene")).map_err(anyhow::Error::msg)?;
    Ok((scene, pick))
}

/// `--iso`: every volume's isovalues replaced by `isos` (nothing when empty).
pub fn set_isos(scene: &mut Scene, isos: &[f64]) -> Result<()> {
    if isos.is_empty() {
        return Ok(());
    }
    if scene.volumes.is_empty() {
        bail!("--iso: the scene has no volume (give a .nrrd, .nhdr, .nii, .nii.gz or .vti file, or a [[volume]])");
    }
    let max = irt::scene::volume::MAX_ISOS;
    if isos.len() > max || isos.iter().any(|v| !v.is_finite()) {
        bail!("--iso: give 1 to {max} finite isovalues");
    }
    for v in &mut scene.volumes {
        let materials: Vec<u32> = v.isos.iter().map(|i| i.material).collect();
        v.isos = isos
            .iter()
            .enumerate()
            .map(|(k, &value)| irt::scene::volume::Iso {
                value,
                material: materials[k.min(materials.len() - 1)],
            })
            .collect();
    }
    Ok(())
}

/// `--volume-mode`: every volume drawn with `look`. A volume that changes look gets the look's
/// default colour map and opacity, and keeps its window (the scene's, or the samples' range).
pub fn set_looks(scene: &mut Scene, look: irt::scene::transfer::Look) -> Result<()> {
    if scene.volumes.is_empty() {
        bail!("--volume-mode: the scene has no volume (give a .nrrd, .nhdr, .nii, .nii.gz or .vti file, or a [[volume]])");
    }
    scene.volumes.iter_mut().for_each(|v| v.switch_look(look));
    Ok(())
}

/// Fails with a message that says so when `path`, given as a scene, is a directory (the loader
/// would only see an unknown extension).
pub fn not_a_directory(path: &Path) -> Result<()> {
    if path.is_dir() {
        bail!("'{}' is a directory; give a scene file ({SCENE_FILES})", path.display());
    }
    Ok(())
}

/// `WxH`, e.g. `640x480` (the scene's validation bounds each side).
pub fn parse_size(s: &str) -> Result<[u32; 2]> {
    let bad = || anyhow!("size `{s}`: expected WxH, e.g. 640x480");
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    let w: u32 = w.trim().parse().map_err(|_| bad())?;
    let h: u32 = h.trim().parse().map_err(|_| bad())?;
    Ok([w, h])
}

/// The device a command opens.
#[derive(Args, Clone, Debug)]
#[command(next_help_heading = "Device")]
pub struct DeviceArgs {
    /// Vulkan adapter: "lavapipe" (default), "gpu" (the first hardware GPU), or part of a device
    /// name. Also read from $IRT_ADAPTER.
    #[arg(long, value_name = "NAME")]
    pub adapter: Option<String>,
    /// Do not read or write the on-disk pipeline cache (also: IRT_CACHE_DIR=off). By default
    /// compiled pipelines are kept in $IRT_CACHE_DIR, else $XDG_CACHE_HOME/irt, else ~/.cache/irt
    /// (the wgpu path's; the ash path has none yet).
    #[arg(long)]
    pub no_cache: bool,
}

/// The device path of the commands that have both.
#[derive(Args, Clone, Copy, Debug)]
#[command(next_help_heading = "Device")]
pub struct BackendArgs {
    /// Device path: wgpu, or ash (raw Vulkan: the same shaders, modes and pictures). See
    /// docs/backends.md.
    #[arg(long, value_name = "PATH", default_value = "wgpu", value_parser = choices(BACKENDS))]
    pub backend: Backend,
}

/// `--backend`'s values.
const BACKENDS: &[(&str, Backend, &str)] = &[
    ("wgpu", Backend::Wgpu, "wgpu (Vulkan only), the window's path too"),
    ("ash", Backend::Ash, "raw Vulkan through ash: the same SPIR-V, adapter, modes and pictures"),
];

/// A value parser for one of a library type's values (the library has no clap), by name:
/// `(name, value, help)`; `--help` lists the names with their help.
pub fn choices<T: Copy + Send + Sync + 'static>(
    table: &'static [(&'static str, T, &'static str)],
) -> impl TypedValueParser<Value = T> {
    PossibleValuesParser::new(table.iter().map(|&(name, _, help)| PossibleValue::new(name).help(help)))
        .map(move |s| table.iter().find(|&&(name, ..)| name == s).expect("clap checked the name").1)
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum OnOff {
    #[default]
    On,
    Off,
}

/// The ash path's raw-Vulkan levers (docs/backends.md, "Raw-Vulkan levers"); `--backend ash`.
#[derive(Args, Clone, Debug, Default)]
#[command(next_help_heading = "Raw-Vulkan levers (--backend ash)")]
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

/// The command-line spelling of a [`Mode`], shared by `irt render`, `irt view` and `irt replay`.
#[derive(Args, Clone, Debug)]
#[command(next_help_heading = "Dispatch mode")]
pub struct ModeArgs {
    /// How work is handed out: conventional (32x2-pixel tiles from a queue, the frame shown
    /// whole) or frameless (a fixed pixel order traced in slices, each with the newest camera).
    /// Without it `irt render` traces bands of rows, `irt view` and `irt replay` run frameless.
    #[arg(long, value_enum, value_name = "MODE")]
    pub mode: Option<ModeName>,
    /// Conventional: chunk sizes of the tile queue: rtrt[:ROUNDS] (RTRT's shrinking chunks,
    /// default 40 rounds), guided, factoring, fixed[:TILES], or plain (no queue: one dispatch,
    /// split statically between the device's threads). Default rtrt:40; `irt view` then keeps
    /// rtrt:40 or plain, whichever its first frames find faster on the device.
    #[arg(long, value_name = "SCHEDULE")]
    pub schedule: Option<Schedule>,
    /// Conventional: the workers P the schedule is built for (0: the device's, its thread
    /// count on lavapipe).
    #[arg(long, value_name = "P", default_value_t = 0)]
    pub workers: u32,
    /// Frameless: pixel order: hilbert[:CHUNK[:PROCS]] (the paper's; CHUNK a power of 4,
    /// default 64 = 8x8 blocks, PROCS 16), adaptive[:PASSES] (slices go where the picture
    /// changes, every pixel revisited within PASSES passes, default 3, pixels not yet traced
    /// since a change shown blended with fresher neighbours; one process only; see
    /// docs/adaptive.md), random, or dissolve (an LFSR, no table).
    #[arg(long, value_name = "ORDER", default_value_t = PixelOrder::default())]
    pub order: PixelOrder,
    /// Frameless: pixels per slice (one dispatch each, each with the newest camera; at most
    /// 4194240, 65535 workgroups of 64). Default 16384; `irt view` then adapts S so that a slice takes a quarter of a display refresh (or
    /// three presents, where a present takes longer).
    #[arg(long, value_name = "S")]
    pub slice: Option<u32>,
    /// Frameless: blend new samples into the old with weight ALPHA (the paper's option;
    /// replaces progressive refinement).
    #[arg(long, value_name = "ALPHA")]
    pub blend: Option<f32>,
    /// Frameless: trace two of four sub-pixel positions per visit (the paper's jitter; blended
    /// with alpha 1/2, replaces progressive refinement).
    #[arg(long)]
    pub jitter_pairs: bool,
}

/// `--mode`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ModeName {
    Conventional,
    Frameless,
}

impl ModeArgs {
    /// The mode asked for, or `None` when `--mode` was not given; the frameless parameters are
    /// checked either way.
    pub fn mode(&self) -> Result<Option<Mode>> {
        if let Some(a) = self.blend {
            if !(a > 0.0 && a <= 1.0) {
                bail!("--blend {a}: expected a weight in (0, 1]");
            }
        }
        match self.slice {
            Some(0) => bail!("--slice 0: a slice holds at least one pixel"),
            Some(s) if s as u64 > irt::render::modes::MAX_SLICE => bail!(
                "--slice {s}: a slice is one dispatch of at most 65535 workgroups of 64 pixels, so S is at most {}",
                irt::render::modes::MAX_SLICE
            ),
            _ => {}
        }
        Ok(self.mode.map(|m| match m {
            ModeName::Conventional => self.conventional(),
            ModeName::Frameless => self.frameless(0),
        }))
    }

    /// `--mode`, else frameless (what the window and the replay start in).
    pub fn mode_or_frameless(&self) -> Result<Mode> {
        Ok(self.mode()?.unwrap_or_else(|| self.frameless(0)))
    }

    /// The frameless mode with `--order`, `--slice`, `--blend` and `--jitter-pairs`, presenting
    /// after `present_every` slices (0: by the display's interval).
    pub fn frameless(&self, present_every: u32) -> Mode {
        Mode::Frameless {
            order: self.order,
            slice: self.slice.unwrap_or(DEFAULT_SLICE),
            present_every,
            blend: self.blend,
            jitter_pairs: self.jitter_pairs,
        }
    }

    /// The conventional mode with `--schedule` and `--workers`.
    pub fn conventional(&self) -> Mode {
        Mode::Conventional { schedule: self.schedule.unwrap_or_default(), workers: self.workers }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse() {
        assert_eq!(parse_size("256x192").unwrap(), [256, 192]);
        assert_eq!(parse_size("1X1").unwrap(), [1, 1]);
        assert_eq!(parse_size("0x10").unwrap(), [0, 10], "the scene's validation refuses it");
        for bad in ["640", "axb", "-3x4", "640x"] {
            assert!(parse_size(bad).unwrap_err().to_string().contains("expected WxH"), "{bad}");
        }
    }

    #[test]
    fn the_scene_help_names_every_format() {
        let listed: Vec<String> =
            irt::io::FORMATS.iter().flat_map(|f| f.extensions.iter().map(|e| format!(".{e}"))).collect();
        assert_eq!(SCENE_FILES, listed.join(", "));
        let command = SceneArgs::augment_args(clap::Command::new("t"));
        let scene = command.get_arguments().find(|a| a.get_id() == "scene").unwrap();
        assert!(scene.get_help().unwrap().to_string().contains(SCENE_FILES));
    }

    #[test]
    fn the_size_help_states_the_limits() {
        let command = SceneArgs::augment_args(clap::Command::new("t"));
        let size = command.get_arguments().find(|a| a.get_id() == "size").unwrap();
        let help = size.get_long_help().or(size.get_help()).unwrap().to_string();
        let side = irt::scene::MAX_IMAGE_SIDE;
        assert!(help.contains(&format!("up to {side} a side")), "{help}");
        assert!(help.contains(&irt::scene::MAX_PIXELS.to_string()), "{help}");
        let root = (irt::scene::MAX_PIXELS as f64).sqrt() as u32;
        assert!(help.contains(&format!("{root}x{root}")), "{help}");
    }

    #[test]
    fn a_directory_is_not_a_scene() {
        let dir = std::env::temp_dir();
        let e = not_a_directory(&dir).unwrap_err().to_string();
        assert!(e.contains("is a directory") && e.contains(".ply"), "{e}");
        assert!(not_a_directory(Path::new("no/such/file.toml")).is_ok());
    }
}
