//! The backend-neutral seam: what a frame dispatches, written once as a [`Recording`] (in the
//! manner of vello's), and the [`ComputeBackend`] each device path implements to run it — wgpu
//! ([`WgpuKernel`]) or raw Vulkan through `ash` ([`super::vk::VkKernel`]).
//!
//! A backend holds one compiled kernel bound to an uploaded scene and its buffers (the bindings of
//! shaders/types.wgsl); the recording says which entry points run over which tiles, in order.
//! Phase 1 of issue #12 expresses the headless bands and the readback kernels of the tests this
//! way; the interactive modes (tile queue, frameless slices) still call the wgpu dispatcher.

use super::dispatch::{Dispatcher, RayCounts};
use super::layout::Tile;
use super::GpuContext;
use std::convert::Infallible;
use std::time::{Duration, Instant};

/// One compute dispatch: `groups` workgroups of `entry`, with `tile` as its uniform.
#[derive(Clone, Debug, PartialEq)]
pub struct Dispatch {
    pub entry: String,
    pub tile: Tile,
    pub groups: [u32; 3],
}

impl Dispatch {
    /// `entry` over the invocations of `tile.rect` in 8x8 workgroups (the `render` entry point and
    /// the readback kernels).
    pub fn over_rect(entry: &str, tile: Tile) -> Self {
        let rect = tile.rect;
        Dispatch { entry: entry.to_string(), tile, groups: [rect[2].div_ceil(8), rect[3].div_ceil(8), 1] }
    }
}

/// What a recording asks of a backend, in order.
#[derive(Clone, Debug, PartialEq)]
pub enum Command {
    /// Zero the ray counters.
    ResetCounts,
    /// Run a dispatch and wait for it (each waits, so a progress mark after it is true).
    Dispatch(Dispatch),
    /// Report progress: `done` of `total` (rows, for the bands).
    Progress { done: u32, total: u32 },
}

/// A frame's work, independent of the device path.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Recording {
    pub commands: Vec<Command>,
}

impl Recording {
    /// The dispatches, in order.
    pub fn dispatches(&self) -> impl Iterator<Item = &Dispatch> {
        self.commands.iter().filter_map(|c| match c {
            Command::Dispatch(d) => Some(d),
            _ => None,
        })
    }
}

/// A compiled kernel bound to a scene, on some device path.
pub trait ComputeBackend {
    /// What fails on this path (`Infallible` for wgpu, whose errors surface as device loss).
    type Error: std::fmt::Display;
    /// Zeroes the ray counters.
    fn reset_counts(&self) -> Result<(), Self::Error>;
    /// Runs `d` and waits for it.
    fn dispatch(&self, d: &Dispatch) -> Result<(), Self::Error>;
    /// The output buffer and the ray counters.
    fn read_output(&self) -> Result<(Vec<[f32; 4]>, RayCounts), Self::Error>;

    /// Runs every command of `rec`, reporting its progress marks to `progress`.
    fn run(&self, rec: &Recording, progress: &mut dyn FnMut(u32, u32)) -> Result<(), Self::Error> {
        for c in &rec.commands {
            match c {
                Command::ResetCounts => self.reset_counts()?,
                Command::Dispatch(d) => self.dispatch(d)?,
                &Command::Progress { done, total } => progress(done, total),
            }
        }
        Ok(())
    }
}

/// The wgpu path: a [`Dispatcher`] and the context it was made on.
pub struct WgpuKernel<'a> {
    pub ctx: &'a GpuContext,
    pub dispatcher: &'a Dispatcher,
}

impl ComputeBackend for WgpuKernel<'_> {
    type Error = Infallible;
    fn reset_counts(&self) -> Result<(), Infallible> {
        self.dispatcher.reset_counts(self.ctx);
        Ok(())
    }
    fn dispatch(&self, d: &Dispatch) -> Result<(), Infallible> {
        self.dispatcher.run(self.ctx, &d.entry, d.tile, d.groups);
        Ok(())
    }
    fn read_output(&self) -> Result<(Vec<[f32; 4]>, RayCounts), Infallible> {
        Ok(self.dispatcher.read(self.ctx))
    }
}

/// The value of a result that cannot fail.
pub fn infallible<T>(r: Result<T, Infallible>) -> T {
    match r {
        Ok(v) => v,
        Err(never) => match never {},
    }
}

/// The readback kernels of the tests: `entry` over `items` invocations (one row), then the output.
pub fn readback_recording(entry: &str, items: u32) -> Recording {
    Recording { commands: vec![Command::Dispatch(Dispatch::over_rect(entry, Tile::whole([0, 0, items, 1])))] }
}

/// The median wall time of `samples` (at least 1) dispatches of one workgroup of `entry` over a
/// single item, after one untimed (which compiles the pipeline): what a dispatch costs the
/// path, submit and wait included, with next to no work in it.
pub fn dispatch_overhead<B: ComputeBackend>(
    backend: &B,
    entry: &str,
    samples: u32,
) -> Result<Duration, B::Error> {
    let d = Dispatch { entry: entry.to_string(), tile: Tile::whole([0, 0, 1, 1]), groups: [1, 1, 1] };
    backend.dispatch(&d)?;
    let mut times = Vec::with_capacity(samples.max(1) as usize);
    for _ in 0..samples.max(1) {
        let t = Instant::now();
        backend.dispatch(&d)?;
        times.push(t.elapsed());
    }
    times.sort();
    Ok(times[times.len() / 2])
}
