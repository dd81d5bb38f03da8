//! `irt view`: the interactive window. A thin layer over [`crate::render::Session`]: a winit
//! window with a wgpu surface on the same device ([`present`]), the session's frame buffer
//! blitted to it ([`blit`]), a camera controller ([`camera`], pure math), mouse and keys
//! ([`input`], one table of keys: [`keys`]), an egui HUD ([`hud`]) and the loop ([`viewer`],
//! whose policy is [`crate::render::host_loop`]). `--frames N --screenshot FILE` is its headless-like twin for scripts and tests.
//! It runs with plain [`ViewOptions`]; `irt view`'s arguments are read in src/cli/view.rs.

pub mod blit;
pub mod camera;
mod colour_bar;
mod display;
pub mod edit;
pub mod hud;
pub mod input;
pub mod keys;
pub mod present;
pub mod scale;
pub mod source;
pub mod viewer;
pub mod volume_panel;

use crate::render::{Mode, Settings};
use crate::scene::Scene;
use anyhow::Result;
use std::path::PathBuf;

/// `irt view`'s one-line help.
pub const ABOUT: &str =
    "Open a window that traces the scene interactively (orbit, fly, live modes; H for the HUD)";

/// `irt view --help`'s description (the keys follow it).
pub const LONG_ABOUT: &str = "Open a window that traces the scene again and again as you move the camera.

The picture refines while the camera rests (jittered samples add up, up to --max-samples). Two ways \
of handing out the work (the paper's, see docs): conventional (tiles from a queue; the frame is \
shown when it is whole) and frameless (slices of pixels in a fixed order, each traced with the newest \
camera, shown continuously). A compact status in the top-left corner shows the rate, the mode and the \
device; the HUD panel (H, or a click on the status) shows where the time goes and switches modes, \
shadows, depth and resolution live. The window opens at about 1280x720 within the screen, with the \
scene camera's aspect (--size sets it).

Frameless slices adapt to the device: S is chosen slice by slice so that one slice takes a \
quarter of a display refresh, or three presents where presenting takes longer (lavapipe's software \
present), so that presenting never takes over (--slice fixes S). Conventional frames time the plain dispatch \
against the tile queue over their first frames and keep the faster (--schedule fixes it).

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

/// What the window runs with: `irt view`'s arguments without the command line (src/cli/view.rs
/// builds them), beside the scene it shows.
#[derive(Clone, Debug)]
pub struct ViewOptions {
    /// The window's size in pixels (`--size`); `None`: about 1280×720 within the screen, with
    /// the scene camera's aspect ([`present::default_window_size`]).
    pub size: Option<[u32; 2]>,
    /// Resolution divisor of the render against the window: 1, 2 or 4.
    pub scale: u32,
    /// Start with the HUD hidden.
    pub no_hud: bool,
    /// The adaptive order's pixels not yet traced since a change are shown as traced, not
    /// filled from fresher neighbours (`render::fill`).
    pub no_fill: bool,
    /// Show this many pictures (each after at least one step), write the screenshot and exit.
    pub frames: Option<u32>,
    /// Where P (and `frames`) writes the PNG; otherwise irt-YYYYmmdd-HHMMSS.png (UTC).
    pub screenshot: Option<PathBuf>,
    /// Where T writes the edited scene as TOML; otherwise irt-scene-YYYYmmdd-HHMMSS.toml (UTC).
    pub save: Option<PathBuf>,
    /// Animated scenes: the scene time to start at, in seconds.
    pub time: f64,
    /// Animated scenes: start paused.
    pub paused: bool,
    /// The Vulkan adapter ([`crate::gpu::AdapterChoice::from_arg_or_env`]).
    pub adapter: Option<String>,
    /// No on-disk pipeline cache ([`crate::gpu::CacheSetting::from_flag_or_env`]).
    pub no_cache: bool,
    /// The scene's name in the window's title and messages.
    pub scene_name: String,
    /// What `soft` shadows picked for the scene, and the line that says why (shown in the panel
    /// while that mode is in use).
    pub soft_pick: Option<(crate::scene::ShadowMode, String)>,
    /// The session's settings at the start; their mode is one of the two below.
    pub settings: Settings,
    /// `--slice` was given: frameless S stays as given instead of following the slice-time
    /// controller ([`crate::render::adapt::Adaptation`]).
    pub fixed_slice: bool,
    /// `--schedule` was given: conventional frames use it instead of the faster of the plain
    /// dispatch and the queue, as the first frames measure them.
    pub fixed_schedule: bool,
    /// The modes M switches between (frameless with its `present_every`).
    pub frameless: Mode,
    pub conventional: Mode,
}

/// `irt view`: runs the window on `scene` until it is closed (or `options.frames` are shown).
pub fn run(options: ViewOptions, scene: Scene) -> Result<()> {
    viewer::run(options, scene, None)
}

/// `irt view --mpi` on rank 0: the window, with the pixels traced by the job's workers
/// ([`source::Distributed`]); closing it ends their work.
pub fn run_distributed(
    options: ViewOptions,
    scene: Scene,
    cluster: &crate::dist::cluster::Cluster,
    deadlines: crate::dist::master::Deadlines,
) -> Result<()> {
    viewer::run(options, scene, Some((cluster, deadlines)))
}
