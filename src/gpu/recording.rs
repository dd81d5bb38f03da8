//! A frame's work, written once and independent of the device path (in the manner of vello's
//! `Recording`): a list of [`Command`]s that a [`BoundKernel`] runs in order. The render modes
//! (`render::modes`) build their recordings as plain functions of their state; the readback
//! kernels of the tests are recordings too.

use super::device::BoundKernel;
use super::layout::{Launch, RENDER_TILE};
use std::time::{Duration, Instant};

/// One compute dispatch: `groups` workgroups of `entry`, with `launch` as its uniform.
#[derive(Clone, Debug, PartialEq)]
pub struct Dispatch {
    pub entry: String,
    pub launch: Launch,
    pub groups: [u32; 3],
}

impl Dispatch {
    /// The readback kernel `entry` (shaders/tests.wgsl) over `items` items, in workgroups of 64.
    pub fn readback(entry: &str, items: u32) -> Self {
        let launch = Launch::whole([0, 0, items, 1]);
        Dispatch { entry: entry.to_string(), launch, groups: [items.div_ceil(64), 1, 1] }
    }

    /// The `render` entry point over `launch.rect` with its rows of tiles ([`RENDER_TILE`])
    /// dealt round-robin to `threads` workers (see shaders/trace.wgsl): lavapipe splits a
    /// dispatch's workgroups into one contiguous run per thread (x fastest, z slowest), so
    /// workgroup (x, y, z) traces tile (x, y · threads + z) and the z-th thread takes every
    /// `threads`-th row of tiles over the whole rect. Multiplies only: lavapipe has no vector
    /// integer divide (docs/performance.md, "Dealing rows of tiles without a divide").
    /// `threads` ≤ 1: the tiles in order.
    pub fn dealt(launch: Launch, threads: u32) -> Self {
        let [tw, th] = RENDER_TILE;
        let (nx, ny) = (launch.rect[2].div_ceil(tw), launch.rect[3].div_ceil(th));
        let n = threads.max(1);
        let launch = Launch { work: [n, 0, 0, 0], ..launch };
        Dispatch { entry: "render".into(), launch, groups: [nx, ny.div_ceil(n), n] }
    }
}

/// What a recording asks of a backend, in order.
#[derive(Clone, Debug, PartialEq)]
pub enum Command {
    /// Zero the ray counters.
    ResetCounts,
    /// Restart the conventional mode's tile queue (its counter to 0).
    ResetQueue,
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

    /// This recording with every dispatch's output written from eye ray `base` on
    /// ([`Launch::at_base`]): a piece of a picture larger than the output buffer.
    pub fn at_base(mut self, base: u32) -> Recording {
        for c in &mut self.commands {
            if let Command::Dispatch(d) = c {
                d.launch = d.launch.at_base(base);
            }
        }
        self
    }

    /// The readback kernels of the tests: `entry` over `items` items.
    pub fn readback(entry: &str, items: u32) -> Recording {
        Recording { commands: vec![Command::Dispatch(Dispatch::readback(entry, items))] }
    }
}

/// The median wall time of `samples` (at least 1) dispatches of one workgroup of `entry` over a
/// single item, after one untimed (which compiles the pipeline): what a dispatch costs the
/// path, submit and wait included, with next to no work in it.
pub fn dispatch_overhead<B: BoundKernel>(
    backend: &B,
    entry: &str,
    samples: u32,
) -> Result<Duration, B::Error> {
    let d = Dispatch { entry: entry.to_string(), launch: Launch::whole([0, 0, 1, 1]), groups: [1, 1, 1] };
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The shader's dealing (shaders/trace.wgsl, `render`) reaches every tile exactly once, and
    /// each thread's contiguous run of workgroups (lavapipe's split of the linear workgroup
    /// index) spreads over the rect: every n-th row of tiles.
    #[test]
    fn dealt_tiles_cover_the_rect_once() {
        let [tw, th] = RENDER_TILE;
        for (w, h) in [(512, 32), (131, 67), (8, 8), (1, 1), (1000, 16), (512, 512)] {
            for threads in [0, 1, 2, 3, 4, 7, 16] {
                let d = Dispatch::dealt(Launch::whole([0, 0, w, h]), threads);
                let n = d.launch.work[0];
                let (nx, ny) = (w.div_ceil(tw), h.div_ceil(th));
                assert_eq!((n, d.groups[0], d.groups[2]), (threads.max(1), nx, threads.max(1)));
                let [gx, gy, gz] = d.groups;
                let run = (gx * gy * gz / n) as usize;
                let mut seen = vec![0u32; (nx * ny) as usize];
                let mut runs = vec![Vec::new(); n as usize];
                for g in 0..gx * gy * gz {
                    let (x, y, z) = (g % gx, g / gx % gy, g / (gx * gy));
                    let row = y * n + z;
                    if row < ny {
                        seen[(row * nx + x) as usize] += 1;
                        runs[g as usize / run].push(row);
                    }
                }
                assert!(seen.iter().all(|&c| c == 1), "{w}x{h}, {threads} threads: {seen:?}");
                // Thread k's rows: k, k + n, … to near the last row.
                for (k, rows) in runs.iter().enumerate() {
                    assert!(rows.iter().all(|&r| r % n == k as u32), "{w}x{h}, {threads}: {runs:?}");
                    if ny >= 2 * n {
                        assert!(rows.last().unwrap() + n >= ny, "{w}x{h}, {threads}: {runs:?}");
                    }
                }
            }
        }
    }
}
