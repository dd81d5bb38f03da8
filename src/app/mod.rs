//! `irt view`: the interactive window. A thin layer over [`crate::render::Session`]: a winit
//! window with a wgpu surface on the same device, the session's frame buffer blitted to it
//! ([`blit`]), a camera controller ([`camera`], pure math), an egui HUD ([`hud`]) and the loop
//! ([`viewer`]). `--frames N --screenshot FILE` is its headless-like twin for scripts and tests.

pub mod blit;
pub mod camera;
pub mod edit;
pub mod hud;
pub mod viewer;

use crate::render::{Mode, ModeArgs, Settings};
use crate::scene::{Scene, ShadowMode};
use anyhow::Result;
use std::path::PathBuf;

/// Every key and mouse binding, as the HUD and `irt view --help` show it.
pub const KEYS: &[(&str, &str)] = &[
    ("left drag", "orbit around the focus point"),
    ("right drag", "look around (fly); Q/E move down/up while held"),
    ("W A S D", "fly forward / left / back / right"),
    ("E", "fly up"),
    ("wheel", "fly speed x1.25 per notch"),
    ("Shift / Ctrl", "move x4 faster / x0.25 finer"),
    ("F", "frame the scene (fit its bounding sphere)"),
    ("R", "reset to the scene's camera"),
    ("C", "print the camera as a TOML [camera] table on stdout"),
    ("M", "switch conventional / frameless"),
    ("1 2 3 4", "shadows hard / bundle:4 / bundle:16 / shell"),
    ("+ / -", "max ray depth up / down"),
    ("[ / ]", "resolution scale down / up (1, 1/2, 1/4)"),
    ("H", "HUD on / off"),
    ("P", "screenshot PNG (--screenshot FILE, else irt-YYYYmmdd-HHMMSS.png, UTC)"),
    ("left click", "select the object or light under the cursor (the HUD edits it)"),
    ("Shift+left drag", "move the selected light in the view plane (also: middle drag)"),
    ("PgUp / PgDn", "move the selected light farther / nearer"),
    ("L", "select the next light"),
    ("K", "selected object's material: next kind (diffuse, metal, dielectric, polished)"),
    ("T", "write the scene as TOML (--save FILE, else irt-scene-YYYYmmdd-HHMMSS.toml, UTC)"),
    ("Space", "play / pause (animated scenes)"),
    (", / .", "playback speed /2 / x2"),
    ("Esc, Q", "quit (Q quits unless the right button is held)"),
];

/// `irt view`'s one-line help.
pub const ABOUT: &str =
    "Open a window that traces the scene interactively (orbit, fly, live modes; H for the HUD)";

/// `irt view --help`'s description (the keys follow it).
pub const LONG_ABOUT: &str = "Open a window that traces the scene again and again as you move the camera.

The picture refines while the camera rests (jittered samples add up, up to --max-samples). Two ways \
of handing out the work (the paper's, see docs): conventional (tiles from a queue; the frame is \
shown when it is whole) and frameless (slices of pixels in a fixed order, each traced with the newest \
camera, shown continuously). The HUD (H) shows where the time goes and switches modes, shadows, depth \
and resolution live.

On lavapipe (Vulkan on the CPU, the default device) expect a few frames per second at full size; \
`[` lowers the resolution, and \"lower resolution while moving\" in the HUD halves it during motion.

Live edits: a click selects the object or light under the cursor (L and the HUD's list select \
lights too). The HUD edits a light's position, colour, intensity and radius (Shift+left or middle \
drag moves it in the view plane, PgUp/PgDn in depth) or the material of the picked object (kind, \
colour, eta, exponent; K switches the kind; every object using that material changes). T writes \
the edited scene as TOML with the current camera (--save FILE). Animated scenes play: Space, `,` \
and `.` for the speed, a time slider in the HUD; --time T and --paused set the start.

Scripted use: `irt view --frames N --screenshot FILE` shows N pictures, writes the last one as a PNG \
and exits 0. With one sample (--max-samples 1, or --mode conventional --frames 1) the PNG equals \
`irt render` at the same size bit for bit.

Examples:
  irt view
  irt view scenes/spd/balls_s2.nff --mode conventional --size 800x600
  irt view --shadows bundle:16 --scale 1/2
  irt view --frames 3 --screenshot shot.png --size 256x192";

fn keys_help() -> String {
    let mut s = String::from("Keys and mouse:\n");
    for (k, what) in KEYS {
        s += &format!("  {k:<16}{what}\n");
    }
    s
}

#[derive(clap::Args, Clone, Debug)]
#[command(about = ABOUT, long_about = LONG_ABOUT, after_long_help = keys_help())]
pub struct ViewArgs {
    /// Scene file (.toml, .gltf, .glb, .nff); the built-in default scene when omitted.
    pub scene: Option<PathBuf>,
    /// Window size in pixels, WxH (default: the scene camera's size, at least 320x240).
    #[arg(long, value_name = "WxH", value_parser = parse_size)]
    pub size: Option<[u32; 2]>,
    /// The dispatch mode (frameless unless --mode says otherwise; M switches in the window)
    /// and its parameters, as `irt render` spells them.
    #[command(flatten)]
    pub mode: ModeArgs,
    /// Frameless: present after exactly N slices (0: as many slices as fit in one display
    /// interval, ~16 ms, at least one).
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub present_every: u32,
    /// Shadow mode (overrides the scene's): hard, bundle:K, shell (see `irt render --help`).
    #[arg(long, value_name = "MODE")]
    pub shadows: Option<ShadowMode>,
    /// Maximum ray depth (overrides the scene's; eye ray = 1).
    #[arg(long, value_name = "N")]
    pub max_depth: Option<u32>,
    /// Accelerator: grid, bvh, bvh-stack or auto (see `irt render --help`).
    #[arg(long, value_name = "ACCEL", default_value_t = crate::accel::AccelChoice::default())]
    pub accel: crate::accel::AccelChoice,
    /// Refinement stops after this many samples per pixel (0: never); the window then waits.
    #[arg(long, value_name = "N", default_value_t = 64)]
    pub max_samples: u32,
    /// Resolution scale of the render against the window: 1, 1/2 or 1/4.
    #[arg(long, value_name = "SCALE", default_value = "1", value_parser = parse_scale)]
    pub scale: u32,
    /// Start with the HUD hidden (H shows it).
    #[arg(long)]
    pub no_hud: bool,
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
    /// Vulkan adapter: "lavapipe" (default), "gpu" (best hardware GPU), or part of a device
    /// name. Also read from $IRT_ADAPTER.
    #[arg(long, value_name = "NAME")]
    pub adapter: Option<String>,
    /// Do not read or write the on-disk pipeline cache (also: IRT_CACHE_DIR=off).
    #[arg(long)]
    pub no_cache: bool,
}

/// `WxH` with both at least 1.
pub fn parse_size(s: &str) -> Result<[u32; 2], String> {
    let bad = || format!("size `{s}`: expected WxH, e.g. 640x480");
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    let w: u32 = w.trim().parse().map_err(|_| bad())?;
    let h: u32 = h.trim().parse().map_err(|_| bad())?;
    if w == 0 || h == 0 || w > crate::scene::MAX_IMAGE_SIDE || h > crate::scene::MAX_IMAGE_SIDE {
        return Err(format!("size `{s}`: each side must be 1 to {}", crate::scene::MAX_IMAGE_SIDE));
    }
    Ok([w, h])
}

/// `1`, `1/2` or `1/4` (also `0.5`, `0.25`) as the divisor 1, 2 or 4.
pub fn parse_scale(s: &str) -> Result<u32, String> {
    match s.trim() {
        "1" | "1/1" | "1.0" => Ok(1),
        "1/2" | "0.5" => Ok(2),
        "1/4" | "0.25" => Ok(4),
        _ => Err(format!("scale `{s}`: expected 1, 1/2 or 1/4")),
    }
}

impl ViewArgs {
    /// The frameless mode with `--order`, `--slice`, `--blend`, `--jitter-pairs` and
    /// `--present-every` applied (what M switches to).
    pub fn frameless(&self) -> Mode {
        Mode::Frameless {
            order: self.mode.order,
            slice: self.mode.slice.max(1),
            present_every: self.present_every,
            blend: self.mode.blend,
            jitter_pairs: self.mode.jitter_pairs,
        }
    }

    /// The conventional mode with `--schedule` and `--workers` applied.
    pub fn conventional(&self) -> Mode {
        Mode::Conventional { schedule: self.mode.schedule, workers: self.mode.workers }
    }

    /// The session settings these arguments ask for.
    pub fn settings(&self) -> Settings {
        let mode = match self.mode.mode.as_deref() {
            Some("conventional") => self.conventional(),
            _ => self.frameless(),
        };
        Settings {
            mode,
            shadows: self.shadows,
            max_depth: self.max_depth,
            max_samples: self.max_samples,
            accel: self.accel,
            ..Settings::default()
        }
    }

    /// The scene (file or built-in), checked as `irt render` checks it.
    pub fn load_scene(&self) -> Result<Scene> {
        let scene = crate::io::load_or_default(self.scene.as_deref())?;
        self.mode.mode().map_err(anyhow::Error::msg)?;
        let mut checked = scene.clone();
        self.settings().apply_to(&mut checked);
        crate::io::check_renderable(&checked, &self.scene_name()).map_err(anyhow::Error::msg)?;
        Ok(scene)
    }

    /// The window's size: `--size`, else the scene camera's (at least 320×240).
    pub fn window_size(&self, scene: &Scene) -> [u32; 2] {
        self.size.unwrap_or([scene.camera.width.max(320), scene.camera.height.max(240)])
    }

    /// The name the window's title shows.
    pub fn scene_name(&self) -> String {
        self.scene.as_deref().map_or("default scene".into(), |p| p.display().to_string())
    }
}

/// `irt view`: runs the window until it is closed (or `--frames` are shown).
pub fn run(args: ViewArgs) -> Result<()> {
    viewer::run(args)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_and_scales_parse() {
        assert_eq!(parse_size("256x192"), Ok([256, 192]));
        assert_eq!(parse_size("1X1"), Ok([1, 1]));
        assert!(parse_size("0x10").is_err());
        assert!(parse_size("640").is_err());
        assert!(parse_size("axb").is_err());
        assert_eq!(parse_scale("1/2"), Ok(2));
        assert_eq!(parse_scale("0.25"), Ok(4));
        assert!(parse_scale("1/3").is_err());
    }
}
