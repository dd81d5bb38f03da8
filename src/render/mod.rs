//! What a frame dispatches, independent of the window: the paper's two ways of handing out work
//! (../PAPER §3) over one device-resident scene ([`Session`]).
//!
//! - **Conventional** ([`Mode::Conventional`]): 32×2-pixel tiles from a queue; a schedule
//!   ([`Schedule`]) is a host-built boundary array that workgroups walk with one atomic counter.
//!   The frame is shown whole.
//! - **Frameless** ([`Mode::Frameless`]): a fixed permutation of the pixels ([`PixelOrder`]),
//!   traced in slices of S pixels per dispatch, each with the newest camera; the frame buffer is
//!   never cleared and is shown continuously.
//!
//! Both refine progressively while the camera rests: later samples are jittered and added up
//! (the frame buffer holds sums and counts).

pub mod args;
pub mod metrics;
pub mod order;
pub mod replay;
pub mod schedule;
pub mod session;
pub mod study;

pub use args::ModeArgs;
pub use order::PixelOrder;
pub use schedule::Schedule;
pub use session::{Session, StepReport, UpdateReport};

use crate::scene::{Scene, ShadowMode};
use std::fmt;
use std::str::FromStr;

/// Frameless slice size by default (docs/interactive.md, slice table): on a quiet 2-core machine
/// with 8×8 Hilbert chunks a slice of 16384 pixels takes about 6 ms at 512² on the default scene,
/// inside a 60 Hz refresh (presents stay at the display's rate), and traced 28% more pixels per
/// second than 4096 with a quarter of the dispatches; 256–1024 lose a third or more to
/// per-dispatch overhead, and from 65536 a slice outlasts a refresh. S should stay a few ms of
/// the device's work: a much faster device wants larger slices.
pub const DEFAULT_SLICE: u32 = 16384;

/// How work is handed out.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Mode {
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
            Mode::Conventional { .. } => "conventional",
            Mode::Frameless { .. } => "frameless",
        }
    }
}

impl fmt::Display for Mode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Mode::Conventional { schedule, workers: 0 } => write!(f, "conventional ({schedule})"),
            Mode::Conventional { schedule, workers } => write!(f, "conventional ({schedule}, P = {workers})"),
            Mode::Frameless { order, slice, .. } => write!(f, "frameless ({order}, S = {slice})"),
        }
    }
}

/// `conventional` or `frameless` (defaults for the rest).
impl FromStr for Mode {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "conventional" => Ok(Mode::conventional()),
            "frameless" => Ok(Mode::frameless()),
            _ => Err(format!("unknown mode `{s}`: expected conventional or frameless")),
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
        }
    }
}

impl Settings {
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
