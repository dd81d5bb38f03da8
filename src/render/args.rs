//! The command-line spelling of a [`Mode`], shared by `irt render`, `irt view` and `irt replay`.

use super::{Mode, PixelOrder, Schedule, DEFAULT_SLICE};
use clap::Args;

#[derive(Args, Clone, Debug)]
pub struct ModeArgs {
    /// How work is handed out: conventional (32x2-pixel tiles from a queue, the frame shown
    /// whole) or frameless (a fixed pixel order traced in slices, each with the newest camera).
    /// Without it `irt render` traces bands of rows and `irt view` starts frameless.
    #[arg(long, value_name = "MODE", value_parser = ["conventional", "frameless"])]
    pub mode: Option<String>,
    /// Conventional: chunk sizes of the tile queue: rtrt[:ROUNDS] (RTRT's shrinking chunks,
    /// default 40 rounds), guided, factoring, fixed[:TILES], or plain (no queue: one dispatch,
    /// split statically between the device's threads).
    #[arg(long, value_name = "SCHEDULE", default_value_t = Schedule::default())]
    pub schedule: Schedule,
    /// Conventional: the workers P the schedule is built for (0: the device's, its thread
    /// count on lavapipe).
    #[arg(long, value_name = "P", default_value_t = 0)]
    pub workers: u32,
    /// Frameless: pixel order: hilbert[:CHUNK[:PROCS]] (the paper's; CHUNK a power of 4,
    /// default 64 = 8x8 blocks, PROCS 16), random, or dissolve (an LFSR, no table).
    #[arg(long, value_name = "ORDER", default_value_t = PixelOrder::default())]
    pub order: PixelOrder,
    /// Frameless: pixels per slice (one dispatch each, each with the newest camera).
    #[arg(long, value_name = "S", default_value_t = DEFAULT_SLICE)]
    pub slice: u32,
    /// Frameless: blend new samples into the old with weight ALPHA (the paper's option;
    /// replaces progressive refinement).
    #[arg(long, value_name = "ALPHA")]
    pub blend: Option<f32>,
    /// Frameless: trace two of four sub-pixel positions per visit (the paper's jitter; blended
    /// with alpha 1/2, replaces progressive refinement).
    #[arg(long)]
    pub jitter_pairs: bool,
}

impl ModeArgs {
    /// The mode asked for, or `None` when `--mode` was not given.
    pub fn mode(&self) -> Result<Option<Mode>, String> {
        if let Some(a) = self.blend {
            if !(a > 0.0 && a <= 1.0) {
                return Err(format!("--blend {a}: expected a weight in (0, 1]"));
            }
        }
        if self.slice == 0 {
            return Err("--slice 0: a slice holds at least one pixel".into());
        }
        Ok(self.mode.as_deref().map(|m| match m {
            "conventional" => Mode::Conventional { schedule: self.schedule, workers: self.workers },
            _ => Mode::Frameless {
                order: self.order,
                slice: self.slice,
                present_every: 0,
                blend: self.blend,
                jitter_pairs: self.jitter_pairs,
            },
        }))
    }
}
