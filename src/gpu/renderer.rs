//! Headless rendering: a scene in, a linear radiance image (and ray counts) out.

use super::backend::{infallible, Command, ComputeBackend, Device, Dispatch, Recording};
use super::dispatch::{ModeBuffers, RayCounts};
use super::layout::{self, PackedScene, Params, Tile, BUNDLE_SAMPLES_PER_PASS, LAVAPIPE_LOOP_LIMIT};
use super::shaders::{Kernel, Variant};
use super::GpuContext;
use crate::accel::{Accel, AccelChoice, AccelKind};
use crate::image::Image;
use crate::scene::{Scene, ShadowMode};
use std::mem::MaybeUninit;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// Eye rays per dispatch of the band renderer, in whole rows: a 512² frame is one dispatch,
/// larger frames several bands (a progress mark after each). Every dispatch ends with a submit
/// and wait, and with one of lavapipe's threads idle until the other is done: 16 bands of 32
/// rows cost 5–32% of a 512² frame against one (docs/performance.md, "One dispatch a frame").
pub const BAND_PIXELS: u32 = 1 << 18;

/// [`BAND_PIXELS`] on a GPU, 16 times larger: a GPU traces a band of 2^18 eye rays in about the
/// time its submit and wait cost the host (an H200: 0.061 ms of device time, 0.058 ms of host
/// overhead), and one large dispatch fills it better (a 2048² frame as one dispatch: 0.86 ms of
/// device time against 2.1 ms as 16 bands; docs/performance.md, "On a GPU").
pub const GPU_BAND_PIXELS: u32 = 1 << 22;

#[derive(Clone, Copy, Debug, Default)]
pub struct RenderOptions {
    /// Count rays by kind (four atomics per pixel; off for timing runs).
    pub count_rays: bool,
    /// Count each loop's SIMD efficiency (`Variant::simd_stats`; a measuring run: the device
    /// needs subgroup operations, and the counters cost time).
    pub simd_stats: bool,
    /// Compile the full uber-shader instead of the variant specialised to the scene.
    pub uber_shader: bool,
    /// Trace eye rays through the pixel corners, a (width+1)x(height+1) grid, as SPD's testing
    /// rules ask, instead of through the centres; each pixel is the mean of its four corners.
    pub corner_rays: bool,
    /// Intersect and traverse in f64 (the device must have SHADER_F64; docs/stability.md).
    pub f64: bool,
    /// Make the scene texture layered past this many rows, fewer than the device's largest
    /// texture side (tests trace the layered path with small scenes; 0: always layered);
    /// `None`: the device's.
    pub max_scene_rows: Option<u32>,
    /// The accelerator: the grid, a BVH, or chosen per scene (`--accel`).
    pub accel: AccelChoice,
    /// Deal each band's rows of tiles to this many device threads (0 or 1: in order); `None`: the device's
    /// (`backend::dealing_threads`).
    pub deal: Option<u32>,
}

/// How long each stage of setting up took.
#[derive(Clone, Copy, Debug, Default)]
pub struct SetupTimings {
    pub grid_build: Duration,
    pub upload: Duration,
    /// Shader module + pipeline creation (lavapipe compiles at first dispatch, which is in the
    /// first frame's time).
    pub pipeline: Duration,
}

/// The `Tile::pass_range` of each pass over a pixel: one, or a split bundle's (see
/// `BUNDLE_SAMPLES_PER_PASS`). Every renderer of the crate traces these passes.
pub fn passes(scene: &Scene) -> Vec<[u32; 4]> {
    match scene.trace.shadows {
        ShadowMode::Bundle { samples, .. } if scene.lights.iter().any(|l| l.radius > 0.0) => (0..samples)
            .step_by(BUNDLE_SAMPLES_PER_PASS as usize)
            .map(|k0| {
                let end = k0 + BUNDLE_SAMPLES_PER_PASS;
                [k0, end, (k0 == 0) as u32, (end >= samples) as u32]
            })
            .collect(),
        _ => vec![Tile::whole([0; 4]).pass_range],
    }
}

/// The headless band renderer on a device path (wgpu's [`GpuContext`] by default, or ash's
/// `vk::VkContext`): one scene, one compiled kernel, the bands of [`Bands::recording`].
pub struct Renderer<D: Device = GpuContext> {
    pub accel: Accel,
    pub gpu_scene: D::Scene,
    dispatcher: D::Kernel,
    bands: Bands,
    pub variant: Variant,
    pub timings: SetupTimings,
    /// Whether the pipeline cache was saved after this renderer's first frame.
    cache_saved: AtomicBool,
}

/// A rendered frame.
pub struct Frame {
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

/// Output vec4s each thread of [`Bands::frame`] decodes at least. On 2 cores, the decode alone
/// (medians): 2048² 32–38 ms on one thread, 22–26 on two; 512² 0.55 ms, 0.41–0.45 on two
/// (within a frame on lavapipe nothing measurable either way). On an H200's 16-core host a 512²
/// frame on four threads took 1.0–1.4 ms against 1.7–2.2 on one (docs/performance.md, "On a
/// GPU").
const DECODE_PER_THREAD: usize = 1 << 16;

/// The cores [`Bands::frame`] may decode on, asked once (on Linux std reads the cgroup's CPU
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

/// What [`Renderer::with_progress`] reports: the stage, and how far it is (`done` of `total`).
pub type SetupProgress<'a> = &'a (dyn Fn(SetupStage, u64, u64) + Sync);

/// The stages of setting up a scene on the device that take long for large scenes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SetupStage {
    /// Inserting primitives into the grid (`done` of `total` primitives).
    Grid,
    /// Building the BVH (`done` of `total` primitives placed in leaves).
    Bvh,
    /// Packing and uploading the scene texture (reported once, `0` of `1`).
    Upload,
}

/// What the band renderer traces, whichever backend runs it: the image size, the eye-ray grid
/// and the passes over each pixel.
#[derive(Clone, Debug)]
pub struct Bands {
    pub width: u32,
    pub height: u32,
    /// Eye rays per row and column (one more than the pixels with `corner_rays`).
    pub grid_size: [u32; 2],
    /// The `Tile::pass` of each pass over the image (one unless a bundle is split).
    pub passes: Vec<[u32; 4]>,
    /// Each band's rows of tiles dealt round-robin to this many device threads
    /// ([`Dispatch::dealt`]; 0 or 1: in order).
    pub deal: u32,
    /// Eye rays per band, in whole rows ([`BAND_PIXELS`], or [`GPU_BAND_PIXELS`] on a GPU).
    pub band_pixels: u32,
}

impl Bands {
    /// Output vec4s: one per eye ray.
    pub fn out_len(&self) -> u64 {
        self.grid_size[0] as u64 * self.grid_size[1] as u64
    }

    /// A frame: the counters zeroed, then bands of `band_pixels` eye rays, every pass of a band
    /// before the next, with a progress mark (rows done) after each band.
    pub fn recording(&self) -> Recording {
        let [cols, rows] = self.grid_size;
        let mut commands = vec![Command::ResetCounts];
        let mut y = 0;
        while y < rows {
            let band = (self.band_pixels / cols.max(1)).max(1).min(rows - y);
            for &pass in &self.passes {
                let tile = Tile { rect: [0, y, cols, band], pass_range: pass, ..Tile::default() };
                commands.push(Command::Dispatch(Dispatch::dealt(tile, self.deal)));
            }
            y += band;
            commands.push(Command::Progress { done: y, total: rows });
        }
        Recording { commands }
    }

    /// Runs a frame on `backend` and reads it back.
    pub fn render<B: ComputeBackend>(
        &self,
        backend: &B,
        progress: &mut dyn FnMut(u32, u32),
    ) -> Result<Frame, B::Error> {
        backend.run(&self.recording(), progress)?;
        let t = Instant::now();
        let mut frame = backend.read_output_with(|out, rays| self.frame(out, rays))?;
        frame.readback = t.elapsed();
        Ok(frame)
    }

    /// The frame of the output buffer `out`, in one pass over it: the host side of a frame is
    /// bound by reading the output (16 bytes an eye ray; separate passes for the hits, the meter
    /// and the pixels took 2.7 ms a 512² frame on the Intel machine, this one pass 1.9), and on a
    /// GPU the host side is most of a frame, so bands of rows are decoded on all cores
    /// (docs/performance.md, "On a GPU").
    pub fn frame(&self, out: &[[f32; 4]], rays: RayCounts) -> Frame {
        let threads = (out.len() / DECODE_PER_THREAD).clamp(1, decode_cores());
        self.frame_on(out, rays, threads)
    }

    /// [`Bands::frame`] decoded in `threads` bands of rows.
    fn frame_on(&self, out: &[[f32; 4]], rays: RayCounts, threads: usize) -> Frame {
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
        // Not zeroed first: every pixel is written once (a 512² image's zeroing was 2% of an
        // all-miss frame's time on lavapipe, and more of a GPU frame's host side).
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
        Frame {
            image: Image { width: self.width, height: self.height, pixels },
            rays,
            max_loop_iterations,
            eye_hits,
            loops,
            readback: Duration::ZERO,
        }
    }
}

/// A scene made ready for the band renderer on any backend: its grid, packed texture and frame
/// constants, the variant to compile and the bands to trace.
pub struct Prepared {
    pub accel: Accel,
    pub packed: PackedScene,
    pub params: Params,
    pub variant: Variant,
    pub bands: Bands,
    pub grid_build: Duration,
}

/// Builds the accelerator `opts.accel` resolves to (reporting its progress), packs the scene relative to the eye and picks the variant:
/// everything of a band renderer's setup that no device is needed for.
pub fn prepare(scene: &Scene, opts: RenderOptions, progress: SetupProgress) -> Prepared {
    // An animated scene renders at time 0 here; `irt render --time` passes `scene.at(t)`.
    let scene = &*scene.posed(0.0);
    let t0 = Instant::now();
    let kind = opts.accel.resolve(scene);
    let stage = match kind {
        AccelKind::Grid => SetupStage::Grid,
        AccelKind::Bvh(_) => SetupStage::Bvh,
    };
    let accel = Accel::build(scene, kind, &|done, total| progress(stage, done as u64, total as u64));
    let grid_build = t0.elapsed();
    progress(SetupStage::Upload, 0, 1);
    let (width, height) = (scene.camera.width, scene.camera.height);
    // Positions relative to the eye: f32 precision follows distance from the viewer.
    let packed = layout::pack_scene(scene, &accel, scene.camera.eye);
    let mut params = layout::params(scene, &accel, &packed, scene.camera.eye);
    params.eye_grid = layout::eye_grid(width, height, opts.corner_rays);
    let grid_size = [params.eye_grid[0], params.eye_grid[1]];
    let variant = if opts.uber_shader {
        Variant { count_rays: opts.count_rays, f64: opts.f64, simd_stats: opts.simd_stats, ..Variant::FULL }
    } else {
        Variant { f64: opts.f64, simd_stats: opts.simd_stats, ..Variant::for_scene(scene, opts.count_rays) }
    };
    let bands = Bands { width, height, grid_size, passes: passes(scene), deal: 0, band_pixels: BAND_PIXELS };
    Prepared { accel, packed, params, variant, bands, grid_build }
}

impl<D: Device> Renderer<D> {
    pub fn new(ctx: &D, scene: &Scene, opts: RenderOptions) -> Result<Self, String> {
        Self::with_progress(ctx, scene, opts, &|_, _, _| {})
    }

    /// [`Renderer::new`], reporting the grid build and the upload as they go.
    pub fn with_progress(
        ctx: &D,
        scene: &Scene,
        opts: RenderOptions,
        progress: SetupProgress,
    ) -> Result<Self, String> {
        let t1 = Instant::now();
        let Prepared { accel, packed, params, variant, mut bands, grid_build } =
            prepare(scene, opts, progress);
        bands.deal = opts.deal.unwrap_or_else(|| super::backend::dealing_threads(ctx));
        bands.band_pixels = if ctx.is_cpu() { BAND_PIXELS } else { GPU_BAND_PIXELS };
        let gpu_scene = ctx.upload(packed, params, opts.max_scene_rows, 0)?;
        let t2 = Instant::now();
        let dispatcher =
            ctx.compile(&gpu_scene, Kernel::Render, variant, bands.out_len(), &[], ModeBuffers::default())?;
        let variant = D::variant(&dispatcher);
        let timings = SetupTimings { grid_build, upload: t2 - t1 - grid_build, pipeline: t2.elapsed() };
        Ok(Renderer {
            accel,
            gpu_scene,
            dispatcher,
            bands,
            variant,
            timings,
            cache_saved: AtomicBool::new(false),
        })
    }

    /// The bound kernel, as a backend (for measuring single dispatches).
    pub fn kernel<'a>(&'a self, ctx: &'a D) -> D::Bound<'a> {
        ctx.bind(&self.dispatcher)
    }

    /// The bands this renderer traces.
    pub fn bands(&self) -> &Bands {
        &self.bands
    }

    /// Median wall time of `frames` (at least 1) further renders: what the measurement commands
    /// report. Call after a first frame, which carries lavapipe's shader compile.
    pub fn try_median_frame_time(&self, ctx: &D, frames: u32) -> Result<Duration, D::Error> {
        Ok(self.try_median_frame_times(ctx, frames)?.0)
    }

    /// The median frame time of `frames` frames, and the median of their [`Frame::readback`].
    pub fn try_median_frame_times(&self, ctx: &D, frames: u32) -> Result<(Duration, Duration), D::Error> {
        let (mut times, mut readbacks) = (Vec::new(), Vec::new());
        for _ in 0..frames.max(1) {
            let t = Instant::now();
            let frame = self.try_render(ctx, &mut |_, _| {})?;
            times.push(t.elapsed());
            readbacks.push(frame.readback);
        }
        let median = |mut v: Vec<Duration>| {
            v.sort();
            v[v.len() / 2]
        };
        Ok((median(times), median(readbacks)))
    }

    /// Traces every eye ray, in bands ([`BAND_PIXELS`] eye rays; [`GPU_BAND_PIXELS`] on a GPU); `progress(rows_done, rows)` after
    /// each.
    pub fn try_render(&self, ctx: &D, progress: &mut dyn FnMut(u32, u32)) -> Result<Frame, D::Error> {
        let frame = self.bands.render(&self.kernel(ctx), progress)?;
        // Drivers that compile at the first dispatch (lavapipe) fill the cache only now.
        if !self.cache_saved.swap(true, Ordering::Relaxed) {
            ctx.pipelines_compiled();
        }
        Ok(frame)
    }
}

/// The wgpu path, whose dispatches cannot fail: the values without a `Result`.
impl Renderer<GpuContext> {
    /// [`Renderer::try_render`].
    pub fn render(&self, ctx: &GpuContext, progress: &mut dyn FnMut(u32, u32)) -> Frame {
        infallible(self.try_render(ctx, progress))
    }

    /// [`Renderer::try_median_frame_time`].
    pub fn median_frame_time(&self, ctx: &GpuContext, frames: u32) -> Duration {
        infallible(self.try_median_frame_time(ctx, frames))
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

    /// A frame's bands are whole rows of at most `band_pixels` eye rays, cover every row once
    /// in order, and end with a progress mark each: 16 bands for a 2048² frame on lavapipe, one
    /// on a GPU.
    #[test]
    fn bands_are_whole_rows_covering_the_frame() {
        for (side, band_pixels, count) in
            [(2048, BAND_PIXELS, 16), (2048, GPU_BAND_PIXELS, 1), (1000, BAND_PIXELS, 4)]
        {
            let bands = Bands {
                width: side,
                height: side,
                grid_size: [side, side],
                passes: vec![[0, u32::MAX, 1, 1]],
                deal: 2,
                band_pixels,
            };
            let rec = bands.recording();
            let mut next = 0;
            for d in rec.dispatches() {
                let [x, y, w, h] = d.tile.rect;
                assert_eq!((x, y, w), (0, next, side));
                assert!(h * side <= band_pixels.max(side), "{side}², band of {h} rows");
                next += h;
            }
            assert_eq!((next, rec.dispatches().count()), (side, count), "{side}², {band_pixels}");
            let marks = rec.commands.iter().filter(|c| matches!(c, Command::Progress { .. })).count();
            assert_eq!(marks, count);
        }
    }

    /// A frame decoded in bands on threads is the frame of one pass: pixels, eye hits and loop
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
        let bands = Bands {
            width: w,
            height: h,
            grid_size: [w, h],
            passes: vec![],
            deal: 0,
            band_pixels: BAND_PIXELS,
        };
        let meter = LoopMeter::of(|i| out[i][3] as u32 >> 1, w, h);
        let hits = out.iter().filter(|p| p[3] as u32 & 1 == 1).count() as u64;
        let pixels: Vec<[f32; 3]> = out.iter().map(|p| [p[0], p[1], p[2]]).collect();
        for threads in 1..=4 {
            let f = bands.frame_on(&out, RayCounts::default(), threads);
            assert_eq!(
                (f.loops, f.max_loop_iterations, f.eye_hits),
                (meter, meter.max, hits),
                "{threads} bands"
            );
            assert!(f.image.pixels == pixels, "{threads} bands: pixels");
        }
    }
}
