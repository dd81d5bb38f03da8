//! A traced picture read back from the output buffer: the image, the ray counts, the eye rays
//! that hit (SPD reports these) and the shader's loop meter, decoded on all cores.

use crate::gpu::layout::{self, LAVAPIPE_LOOP_LIMIT};
use crate::gpu::RayCounts;
use crate::image::Image;
use std::mem::MaybeUninit;
use std::time::Duration;

/// A traced picture.
pub struct Picture {
    pub image: Image,
    pub rays: RayCounts,
    /// The most shader loop iterations any pixel needed in one pass (see `LAVAPIPE_LOOP_LIMIT`).
    pub max_loop_iterations: u32,
    /// Eye rays that hit something (SPD reports these); always counted, from the output's alpha.
    pub eye_hits: u64,
    /// Loop iterations per pixel and how busy lavapipe's SIMD lanes were ([`LoopMeter`]).
    pub loops: LoopMeter,
    /// The host's share of the frame after its dispatches: the output copied into readback
    /// memory, mapped, and decoded into the image.
    pub readback: Duration,
}

/// What the shader's loop meter says of a frame: the mean loop iterations per pixel, and the
/// lanes' occupancy: lavapipe runs [`SIMD_LANES`] invocations together (a 4x2-pixel block of a
/// [`layout::RENDER_TILE`] workgroup) and a block's loops run until its busiest lane is done,
/// so occupancy = Σ lane iterations / Σ blocks (lanes × the block's most). It is an upper
/// bound: the meter sums all of a pixel's loops, and each loop waits for its own slowest lane.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LoopMeter {
    pub mean: f64,
    pub occupancy: f64,
    /// The most iterations of any pixel.
    pub max: u32,
}

/// Invocations lavapipe runs in one SIMD group (256-bit vectors of 32-bit lanes).
pub const SIMD_LANES: u32 = 8;

impl LoopMeter {
    /// The meter of a `cols` x `rows` grid of per-pixel loop iterations (row-major,
    /// `iterations(i)` of pixel i, called once per pixel, block by block).
    pub fn of(iterations: impl FnMut(usize) -> u32, cols: u32, rows: u32) -> Self {
        MeterSums::of_rows(iterations, cols as usize, 0..rows as usize).meter(cols as u64 * rows as u64)
    }
}

impl LoopMeter {
    /// The meter of a picture whose rows are this meter's `cells` eye rays and then `below`'s
    /// `below_cells` (pieces of a picture traced one after another).
    pub fn stacked(self, cells: u64, below: LoopMeter, below_cells: u64) -> LoopMeter {
        let sum = |m: &LoopMeter, n: u64| m.mean * n as f64;
        let executed = |m: &LoopMeter, n: u64| if m.occupancy > 0.0 { sum(m, n) / m.occupancy } else { 0.0 };
        let (s, e) = (
            sum(&self, cells) + sum(&below, below_cells),
            executed(&self, cells) + executed(&below, below_cells),
        );
        LoopMeter {
            mean: s / (cells + below_cells).max(1) as f64,
            occupancy: if e > 0.0 { s / e } else { 1.0 },
            max: self.max.max(below.max),
        }
    }
}

/// What a [`LoopMeter`] is made of, over a band of whole block rows, so that bands can be
/// counted apart (on threads) and added.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct MeterSums {
    /// Lane iterations.
    sum: u64,
    /// Blocks' iterations × lanes.
    executed: u64,
    /// The most iterations of any pixel.
    max: u64,
}

impl MeterSums {
    /// A SIMD group's block: 4x2 pixels of a [`layout::RENDER_TILE`] workgroup.
    const BLOCK: [usize; 2] =
        [layout::RENDER_TILE[0] as usize, (SIMD_LANES / layout::RENDER_TILE[0]) as usize];

    /// The sums of `rows` (starting on a block row) of a grid `cols` wide.
    fn of_rows(mut iterations: impl FnMut(usize) -> u32, cols: usize, rows: std::ops::Range<usize>) -> Self {
        let [bw, bh] = Self::BLOCK;
        let mut m = MeterSums::default();
        for by in rows.clone().step_by(bh) {
            for bx in (0..cols).step_by(bw) {
                let mut most = 0u64;
                for y in by..(by + bh).min(rows.end) {
                    for x in bx..(bx + bw).min(cols) {
                        let n = iterations(y * cols + x) as u64;
                        m.sum += n;
                        most = most.max(n);
                    }
                }
                m.executed += most * SIMD_LANES as u64;
                m.max = m.max.max(most);
            }
        }
        m
    }

    fn add(self, o: Self) -> Self {
        MeterSums { sum: self.sum + o.sum, executed: self.executed + o.executed, max: self.max.max(o.max) }
    }

    /// The meter of these sums over `cells` pixels.
    fn meter(self, cells: u64) -> LoopMeter {
        LoopMeter {
            mean: self.sum as f64 / cells.max(1) as f64,
            occupancy: if self.executed == 0 { 1.0 } else { self.sum as f64 / self.executed as f64 },
            max: self.max as u32,
        }
    }
}

/// Output vec4s each thread of [`OutputGrid::picture`] decodes at least: below that a thread's
/// start costs more than it saves (docs/performance.md, "Large frames decode on all cores").
const DECODE_PER_THREAD: usize = 1 << 16;

/// The cores [`OutputGrid::picture`] may decode on, asked once (on Linux std reads the cgroup's CPU
/// quota for it).
fn decode_cores() -> usize {
    static CORES: std::sync::OnceLock<usize> = std::sync::OnceLock::new();
    *CORES.get_or_init(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
}

/// `f(k, chunk)` on each `chunk` of `data` of `len` items (the k-th), the results in order: the
/// first chunk on this thread, each other on a scoped thread of its own.
fn on_threads<U: Send, T: Send>(
    data: &mut [U],
    len: usize,
    f: impl Fn(usize, &mut [U]) -> T + Sync,
) -> Vec<T> {
    let f = &f;
    let (first, rest) = data.split_at_mut(len.min(data.len()));
    std::thread::scope(|s| {
        let workers: Vec<_> =
            rest.chunks_mut(len.max(1)).enumerate().map(|(k, c)| s.spawn(move || f(k + 1, c))).collect();
        let mut out = vec![f(0, first)];
        out.extend(workers.into_iter().map(|w| w.join().unwrap_or_else(|e| std::panic::resume_unwind(e))));
        out
    })
}

/// How a picture's output buffer is laid out: the image size and the eye-ray grid (one more
/// column and row than the pixels with `Settings::corner_rays`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OutputGrid {
    pub width: u32,
    pub height: u32,
    /// Eye rays per row and column.
    pub grid_size: [u32; 2],
}

impl OutputGrid {
    /// The picture of the output buffer `out`, in one pass over it: the host side of a frame is
    /// bound by reading the output (16 bytes an eye ray), and on a GPU the host side is most of a
    /// frame, so bands of rows are decoded on all cores.
    pub fn picture(&self, out: &[[f32; 4]], rays: RayCounts) -> Picture {
        let threads = (out.len() / DECODE_PER_THREAD).clamp(1, decode_cores());
        self.picture_on(out, rays, threads)
    }

    /// [`OutputGrid::picture`] decoded in `threads` bands of rows.
    fn picture_on(&self, out: &[[f32; 4]], rays: RayCounts, threads: usize) -> Picture {
        let cols = self.grid_size[0] as usize;
        let rows = out.len() / cols.max(1);
        let (w, h) = (self.width as usize, self.height as usize);
        let direct = cols == w;
        // Alpha: 2 × loop iterations + eye hit (trace.wgsl). Rows `r` of the output (starting
        // on a block row), their pixels into `px` where the output is the image.
        let decode = |r: std::ops::Range<usize>, px: &mut [MaybeUninit<[f32; 3]>]| {
            let band = &out[r.start * cols..r.end * cols];
            let mut hits = 0u64;
            let sums = MeterSums::of_rows(
                |i| {
                    let p = &band[i];
                    let meter = p[3] as u32;
                    hits += (meter & 1) as u64;
                    if direct {
                        px[i].write([p[0], p[1], p[2]]);
                    }
                    meter >> 1
                },
                cols,
                0..r.len(),
            );
            (sums, hits)
        };
        // Not zeroed first: every pixel is written once, and zeroing is a measurable share of a
        // cheap frame's host side (docs/performance.md, "The frame and the host side").
        let n = if direct { rows * cols } else { 0 };
        let mut pixels: Vec<[f32; 3]> = Vec::with_capacity(n);
        let band = rows.div_ceil(threads.max(1)).next_multiple_of(MeterSums::BLOCK[1]);
        let parts = if direct {
            let px = &mut pixels.spare_capacity_mut()[..n];
            on_threads(px, band * cols, |k, px| decode(k * band..((k + 1) * band).min(rows), px))
        } else {
            vec![decode(0..rows, &mut [])]
        };
        // SAFETY: the bands are the rows 0..rows, each decoded over the pixels of its rows, and
        // `MeterSums::of_rows` visits every index of its rows once, so all `n` are initialised.
        unsafe { pixels.set_len(n) };
        let (sums, eye_hits) =
            parts.into_iter().fold((MeterSums::default(), 0), |(m, n), (pm, pn)| (m.add(pm), n + pn));
        let loops = sums.meter((cols * rows) as u64);
        let max_loop_iterations = loops.max;
        if max_loop_iterations > LAVAPIPE_LOOP_LIMIT / 2 {
            log::warn!(
                "a pixel ran {max_loop_iterations} shader loop iterations; lavapipe stops loops after \
                 {LAVAPIPE_LOOP_LIMIT} per invocation group, so parts of this image may be wrong"
            );
        }
        if !direct {
            let at = |x: usize, y: usize| out[y * cols + x];
            pixels = (0..w * h)
                .map(|i| {
                    let (x, y) = (i % w, i / w);
                    let c = [at(x, y), at(x + 1, y), at(x, y + 1), at(x + 1, y + 1)];
                    [0, 1, 2].map(|k| c.iter().map(|p| p[k]).sum::<f32>() * 0.25)
                })
                .collect();
        }
        Picture {
            image: Image { width: self.width, height: self.height, pixels },
            rays,
            max_loop_iterations,
            eye_hits,
            loops,
            readback: Duration::ZERO,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two 4x2 blocks of an 8x2 grid whose pixel i ran i iterations: 0..3 and 8..11 (sum 44, the
    /// block runs 11), 4..7 and 12..15 (sum 76, runs 15).
    #[test]
    fn loop_meter_counts_blocks_by_their_busiest_lane() {
        let m = LoopMeter::of(|i| i as u32, 8, 2);
        assert_eq!(m, LoopMeter { mean: 120.0 / 16.0, occupancy: 120.0 / (8.0 * 26.0), max: 15 });
    }

    /// A picture decoded in bands on threads is the picture of one pass: pixels, eye hits and loop
    /// meter, on 333 rows (the last band short, its last block row half) and 1 to 4 bands.
    #[test]
    fn a_frame_decoded_in_bands_equals_one_pass() {
        let (w, h) = (1000u32, 333u32);
        let out: Vec<[f32; 4]> = (0..w * h)
            .map(|i| {
                let iterations = (i.wrapping_mul(7919) >> 3) % 97;
                [i as f32, (i % 5) as f32, 0.5, (2 * iterations + (i % 3 == 0) as u32) as f32]
            })
            .collect();
        let grid = OutputGrid { width: w, height: h, grid_size: [w, h] };
        let meter = LoopMeter::of(|i| out[i][3] as u32 >> 1, w, h);
        let hits = out.iter().filter(|p| p[3] as u32 & 1 == 1).count() as u64;
        let pixels: Vec<[f32; 3]> = out.iter().map(|p| [p[0], p[1], p[2]]).collect();
        for threads in 1..=4 {
            let f = grid.picture_on(&out, RayCounts::default(), threads);
            assert_eq!(
                (f.loops, f.max_loop_iterations, f.eye_hits),
                (meter, meter.max, hits),
                "{threads} bands"
            );
            assert!(f.image.pixels == pixels, "{threads} bands: pixels");
        }
    }
}
