//! The one way a frame is traced: a [`Session`] holds a scene on a device and traces it in one of
//! the [`Mode`]s, for the window, the headless commands and the measurements alike.
//!
//! - **Bands** ([`Mode::Bands`]): one picture in bands of whole rows into the output buffer, with
//!   ray counts and the loop meter ([`Picture`]): what `irt render` and the benchmarks trace.
//! - **Conventional** ([`Mode::Conventional`], the paper's §3): 32×2-pixel tiles from a queue; a
//!   schedule ([`Schedule`]) is a host-built boundary array that workgroups walk with one atomic
//!   counter. The frame is shown whole.
//! - **Frameless** ([`Mode::Frameless`]): a fixed permutation of the pixels ([`PixelOrder`]),
//!   traced in slices of S pixels per dispatch, each with the newest camera; the frame buffer is
//!   never cleared and is shown continuously.
//!
//! Conventional and frameless refine progressively while the camera rests: later samples are
//! jittered and added up (the frame buffer holds sums and counts). Each mode's recordings are
//! plain functions of its state ([`modes`]); animation ([`animation`]) and the background BVH
//! ([`background`]) live beside the session.

pub mod adapt;
pub mod adaptive;
pub mod animation;
pub mod background;
pub mod camera_path;
pub mod fill;
pub mod frame;
pub mod host_loop;
pub mod metrics;
pub mod modes;
pub mod order;
pub mod picture;
pub mod pieces;
mod readout;
pub mod replay;
pub mod schedule;
pub mod session;
mod steps;
pub mod updates;

pub use background::Adoption;
pub use host_loop::{Cancel, HostLoop, FRAME_BUDGET};
pub use modes::SliceSpan;
pub use order::PixelOrder;
pub use picture::{LoopMeter, Picture};
pub use schedule::Schedule;
pub use session::{Session, SetupProgress, SetupStage, SetupTimings, StepReport};
pub use updates::UpdateReport;

use crate::gpu::shaders::Variant;
use crate::gpu::GpuError;
use crate::scene::{Scene, ShadowMode};
use std::fmt;
use std::str::FromStr;

/// Frameless slice size by default: a few ms of lavapipe's work at 512² on two cores, inside a
/// 60 Hz refresh (docs/interactive.md, "Slice size"). A much faster device wants larger slices.
pub const DEFAULT_SLICE: u32 = 16384;

/// What setting up or changing a session can fail with.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error("{0}")]
    Scene(String),
    #[error("at time {time} s: {message}")]
    SceneAt { time: f64, message: String },
    #[error(transparent)]
    Order(#[from] modes::TooManyPixels),
    #[error("starting the BVH build thread: {0}")]
    Thread(std::io::Error),
    #[error("the BVH built in the background is lost: {0}")]
    BvhBuild(&'static str),
    #[error("{0}")]
    Mode(&'static str),
}

impl From<crate::scene::InvalidScene> for RenderError {
    fn from(e: crate::scene::InvalidScene) -> Self {
        RenderError::Scene(e.0)
    }
}

/// How work is handed out.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Mode {
    /// One picture in bands of whole rows, into the output buffer only (no frame buffer, one
    /// sample; an animated scene at time 0): the headless renderer's.
    Bands,
    /// Tiles from a queue, the frame shown whole. `workers`: the P the schedule is built for
    /// (0 = the device's default, [`Schedule::default_workers`]).
    Conventional { schedule: Schedule, workers: u32 },
    /// Slices of `slice` positions of `order` per dispatch; `present_every` slices per present
    /// (0: at the display's rate). `blend`: new samples weighted α into the old value (the
    /// paper's option, off = replace); `jitter_pairs`: two of four sub-pixel positions per
    /// visit (blended with α = ½). Either turns progressive refinement off.
    Frameless { order: PixelOrder, slice: u32, present_every: u32, blend: Option<f32>, jitter_pairs: bool },
}

impl Mode {
    pub fn conventional() -> Mode {
        Mode::Conventional { schedule: Schedule::default(), workers: 0 }
    }

    pub fn frameless() -> Mode {
        Mode::Frameless {
            order: PixelOrder::default(),
            slice: DEFAULT_SLICE,
            present_every: 0,
            blend: None,
            jitter_pairs: false,
        }
    }

    pub fn name(&self) -> &'static str {
        match self {
            Mode::Bands => "bands",
            Mode::Conventional { .. } => "conventional",
            Mode::Frameless { .. } => "frameless",
        }
    }
}

impl fmt::Display for Mode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Mode::Bands => write!(f, "bands"),
            Mode::Conventional { schedule, workers: 0 } => write!(f, "conventional ({schedule})"),
            Mode::Conventional { schedule, workers } => write!(f, "conventional ({schedule}, P = {workers})"),
            Mode::Frameless { order, slice, .. } => write!(f, "frameless ({order}, S = {slice})"),
        }
    }
}

/// `bands`, `conventional` or `frameless` (defaults for the rest).
impl FromStr for Mode {
    type Err = crate::ParseError;
    fn from_str(s: &str) -> Result<Self, crate::ParseError> {
        match s {
            "bands" => Ok(Mode::Bands),
            "conventional" => Ok(Mode::conventional()),
            "frameless" => Ok(Mode::frameless()),
            _ => Err(crate::ParseError::unknown("mode", s, "bands, conventional or frameless")),
        }
    }
}

/// Everything a session's pictures depend on besides the scene and the camera.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    pub mode: Mode,
    /// Overrides the scene's `[trace] shadows`.
    pub shadows: Option<ShadowMode>,
    /// Overrides every light's radius.
    pub light_radius: Option<f64>,
    /// Overrides the scene's `[trace] max_depth`.
    pub max_depth: Option<u32>,
    /// Intersect and traverse in f64.
    pub f64: bool,
    /// Refinement stops after this many samples per pixel (0: never).
    pub max_samples: u32,
    /// Conventional: waves per frame (the frame can be cancelled between waves).
    pub waves: u32,
    /// The accelerator (`--accel`): the grid, a BVH, or chosen per scene.
    pub accel: crate::accel::AccelChoice,
    /// Count rays by kind (four atomics per pixel; `irt render --stats`): a measuring run.
    pub count_rays: bool,
    /// Count each loop's SIMD efficiency (`Variant::simd_stats`; the device needs subgroup
    /// operations; `irt bench --simd`): a measuring run.
    pub simd_stats: bool,
    /// Compile the full uber-shader instead of the variant specialised to the scene (`irt bench
    /// --uber`).
    pub uber_shader: bool,
    /// Bands: eye rays through the pixel corners, a (width+1)x(height+1) grid, each pixel the
    /// mean of its four corners (SPD's testing rules), instead of through the centres.
    pub corner_rays: bool,
    /// Make the scene texture layered past this many rows, fewer than the device's largest
    /// side (tests trace the layered path with small scenes); `None`: the device's.
    pub max_scene_rows: Option<u32>,
    /// Deal the bands' rows of tiles to this many device threads (0 or 1: in order); `None`: the
    /// device's (`gpu::device::dealing_threads`).
    pub deal: Option<u32>,
    /// Size the output, frame and work buffers for at most this many eye rays, fewer than the
    /// device's largest storage binding allows (tests trace a picture's pieces with small
    /// pictures; never below `session::MIN_BUFFER_RAYS`); `None`: the device's.
    pub max_buffer_rays: Option<u64>,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            mode: Mode::frameless(),
            shadows: None,
            light_radius: None,
            max_depth: None,
            f64: false,
            max_samples: 64,
            waves: 4,
            accel: Default::default(),
            count_rays: false,
            simd_stats: false,
            uber_shader: false,
            corner_rays: false,
            max_scene_rows: None,
            deal: None,
            max_buffer_rays: None,
        }
    }
}

impl Settings {
    /// One picture in the bands mode, the rest as by default.
    pub fn bands() -> Settings {
        Settings { mode: Mode::Bands, max_samples: 1, ..Settings::default() }
    }

    /// The shader variant these settings compile for `scene` (settings applied).
    pub fn variant(&self, scene: &Scene) -> Variant {
        let base = if self.uber_shader {
            Variant { count_rays: self.count_rays, ..Variant::FULL }
        } else {
            Variant::for_scene(scene, self.count_rays)
        };
        Variant { f64: self.f64, simd_stats: self.simd_stats, ..base }
    }

    /// Writes the overrides into `scene`.
    pub fn apply_to(&self, scene: &mut Scene) {
        if let Some(s) = self.shadows {
            scene.trace.shadows = s;
        }
        if let Some(r) = self.light_radius {
            for l in &mut scene.lights {
                l.radius = r;
            }
        }
        if let Some(d) = self.max_depth {
            scene.trace.max_depth = d.clamp(1, crate::scene::MAX_TRACE_DEPTH);
        }
    }
}
