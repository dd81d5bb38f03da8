//! The ways a session hands out work, each a value whose next recording is a plain function of
//! its state — no device, so a test can check that every recording covers the image once.
//!
//! - [`Bands`]: the frame in bands of whole rows (the bands mode, and the conventional mode's
//!   plain schedule);
//! - [`Queue`]: the paper's tile queue, a frame in waves of workgroups taking chunks of tiles;
//! - [`Slices`]: the frameless mode's slices of a pixel order;
//! - progressive refinement: the sample index, its jitter and how it lands in the frame buffer
//!   ([`refinement_jitter`], [`frameless_sample`], [`resolve`]).

use super::order::{Dissolve, PixelOrder};
use super::schedule::{tile_grid, Schedule};
use crate::gpu::layout::{
    Launch, PixelSample, BUNDLE_SAMPLES_PER_PASS, FRAME_ACCUMULATE, FRAME_BLEND, FRAME_JITTER_PAIRS,
    FRAME_WRITE, LAVAPIPE_LOOP_LIMIT, MAX_CHUNK_TILES, ORDER_DISSOLVE, ORDER_TABLE, OUT_COMPACT, TILE_H,
    TILE_W, WHOLE_PASS,
};
use crate::gpu::recording::{Command, Dispatch, Recording};
use crate::scene::{Scene, ShadowMode};
use std::ops::Range;

/// Eye rays per dispatch of the bands, in whole rows: a 512² frame is one dispatch, larger
/// frames several bands (a progress mark after each). Every dispatch ends with a submit and
/// wait, and with one of lavapipe's threads idle until the other is done (docs/performance.md,
/// "One dispatch a frame").
pub const BAND_PIXELS: u32 = 1 << 18;

/// [`BAND_PIXELS`] on a GPU, 16 times larger: a GPU traces a band of 2^18 eye rays in about the
/// time its submit and wait cost the host, and one large dispatch fills it better
/// (docs/performance.md, "One dispatch a frame").
pub const GPU_BAND_PIXELS: u32 = 1 << 22;

/// Tiles a workgroup of the conventional queue traces before it exits (plus at most one
/// chunk): what lets a frame be split into waves that input can cancel between.
pub const TILE_BUDGET: u32 = 16;

/// A workgroup of the queue takes no further chunk once its busiest invocation, plus one more
/// chunk at the dearest tile it has seen, would pass this many loop iterations: half of
/// lavapipe's limit, leaving the other half as margin for a tile dearer than any before.
pub const QUEUE_LOOP_BUDGET: u32 = LAVAPIPE_LOOP_LIMIT / 2;

// render_queue's workgroup is one tile.
const _: () = assert!(TILE_W * TILE_H == 64);

/// The `Launch::pass_range` of each pass over a pixel: one, or a split bundle's (see
/// `BUNDLE_SAMPLES_PER_PASS`). Every mode traces these passes.
pub fn passes(scene: &Scene) -> Vec<[u32; 4]> {
    match scene.trace.shadows {
        ShadowMode::Bundle { samples, .. } if scene.lights.iter().any(|l| l.radius > 0.0) => (0..samples)
            .step_by(BUNDLE_SAMPLES_PER_PASS as usize)
            .map(|k0| {
                let end = k0 + BUNDLE_SAMPLES_PER_PASS;
                [k0, end, (k0 == 0) as u32, (end >= samples) as u32]
            })
            .collect(),
        _ => vec![WHOLE_PASS],
    }
}

/// The refinement jitter of sample `k`: (0, 0) for the first (pixel centres, as the bands),
/// then the R2 sequence (Roberts 2018) over the pixel, in [-0.5, 0.5)².
pub fn refinement_jitter(k: u32) -> [f32; 2] {
    if k == 0 {
        return [0.0, 0.0];
    }
    const A1: f64 = 0.754_877_666_246_692_8; // 1/φ₂, φ₂ the plastic number
    const A2: f64 = 0.569_840_290_998_053_3; // 1/φ₂²
    let f = |a: f64| ((0.5 + a * k as f64).fract() - 0.5) as f32;
    [f(A1), f(A2)]
}

/// Sample `k` of a conventional frame (or the bands): traced into the output buffer only, at
/// its refinement jitter; [`resolve`] puts a whole frame into the frame buffer.
pub fn frame_sample(k: u32) -> PixelSample {
    PixelSample { index: k, flags: 0, jitter: refinement_jitter(k), alpha: 0.0 }
}

/// Visit `visit` (since the last change) of a frameless pixel: written into the frame buffer,
/// replacing (the first visit), added (refinement), blended with weight `blend`, or as the
/// paper's jittered pairs (two of four sub-pixel positions per visit, blended with α = ½).
pub fn frameless_sample(visit: u32, blend: Option<f32>, jitter_pairs: bool) -> PixelSample {
    let refine = blend.is_none() && !jitter_pairs;
    let mut flags = FRAME_WRITE;
    if jitter_pairs {
        flags |= FRAME_JITTER_PAIRS | FRAME_BLEND;
    } else if blend.is_some() {
        flags |= FRAME_BLEND;
    } else if visit > 0 {
        flags |= FRAME_ACCUMULATE;
    }
    let alpha = if jitter_pairs { 0.5 } else { blend.unwrap_or(1.0) };
    let jitter = if refine { refinement_jitter(visit) } else { [0.0, 0.0] };
    PixelSample { index: visit, flags, jitter, alpha }
}

/// How sample `k` of a whole conventional frame lands in the frame buffer: the first replaces,
/// later ones add.
pub fn resolve_sample(k: u32) -> PixelSample {
    let flags = if k == 0 { FRAME_WRITE } else { FRAME_WRITE | FRAME_ACCUMULATE };
    PixelSample { index: k, flags, ..Default::default() }
}

/// A whole conventional frame of `pixels` pixels, sample `k`, into the frame buffer: one
/// dispatch per [`MAX_SLICE`] pixels (a dispatch has at most 65 535 workgroups).
pub fn resolve(pixels: u32, k: u32) -> Recording {
    let commands = (0..pixels)
        .step_by(MAX_SLICE as usize)
        .map(|first| {
            let launch = Launch::resolve(first, pixels, resolve_sample(k));
            let groups = [(pixels - first).min(MAX_SLICE as u32).div_ceil(64), 1, 1];
            Command::Dispatch(Dispatch { entry: "resolve_frame".into(), launch, groups })
        })
        .collect();
    Recording { commands }
}

/// Bands of whole rows of the eye-ray grid.
#[derive(Clone, Debug, PartialEq)]
pub struct Bands {
    /// Eye rays per row and column (one more than the pixels with corner rays).
    pub grid_size: [u32; 2],
    /// The `Launch::pass_range` of each pass over the image (one unless a bundle is split).
    pub passes: Vec<[u32; 4]>,
    /// Each band's rows of tiles dealt round-robin to this many device threads
    /// ([`Dispatch::dealt`]; 0 or 1: in order).
    pub deal: u32,
    /// Eye rays per band, in whole rows ([`BAND_PIXELS`], [`GPU_BAND_PIXELS`], or `u32::MAX`:
    /// one band).
    pub band_pixels: u32,
}

impl Bands {
    /// Sample `s` of the frame: bands of `band_pixels` eye rays, every pass of a band before the
    /// next, with a progress mark (rows done) after each band.
    pub fn recording(&self, s: PixelSample) -> Recording {
        self.recording_rows(s, 0..self.grid_size[1])
    }

    /// [`Bands::recording`] of the eye-ray rows `rows` alone, their output from vec4 0 on (a
    /// piece of a picture larger than the output buffer; progress marks count the whole grid's
    /// rows).
    pub fn recording_rows(&self, s: PixelSample, rows: Range<u32>) -> Recording {
        let [cols, all] = self.grid_size;
        let mut commands = Vec::new();
        let mut y = rows.start;
        while y < rows.end {
            let band = (self.band_pixels / cols.max(1)).max(1).min(rows.end - y);
            for &pass in &self.passes {
                let launch = Launch::bands([0, y, cols, band], pass, s);
                commands.push(Command::Dispatch(Dispatch::dealt(launch, self.deal)));
            }
            y += band;
            commands.push(Command::Progress { done: y, total: all });
        }
        Recording { commands }.at_base(rows.start * cols)
    }
}

/// Workgroups per wave for a frame of `tiles` tiles cut into about `waves` waves (each
/// workgroup traces up to [`TILE_BUDGET`] tiles; fewer where the loop budget stops it, and the
/// host then runs more waves until the queue is empty).
pub fn wave_groups(tiles: u32, waves: u32) -> u32 {
    tiles.div_ceil(waves.max(1)).div_ceil(TILE_BUDGET).max(1)
}

/// `b` with every chunk longer than `max` tiles cut into pieces of `max` (the last shorter).
pub fn cap_chunks(b: &[u32], max: u32) -> Vec<u32> {
    let mut out = vec![b[0]];
    for w in b.windows(2) {
        let mut t = w[0];
        while w[1] - t > max {
            t += max;
            out.push(t);
        }
        out.push(w[1]);
    }
    out
}

/// The conventional mode's tile queue over a frame: chunks of tiles taken through one atomic
/// counter from a boundary array in the work buffer, in waves of workgroups.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Queue {
    /// Chunks in the boundary array.
    pub chunks: u32,
    /// Tile columns of the frame.
    pub columns: u32,
    /// Workgroups per wave.
    pub wave_groups: u32,
}

impl Queue {
    /// A queue of the tiles `tiles` alone, one tile a chunk, one wave: how a distributed worker
    /// traces the chunk it was handed with the conventional frame's own entry point. Returns its
    /// boundary array too.
    pub fn of_tiles(tiles: Range<u32>, columns: u32) -> (Queue, Vec<u32>) {
        let b: Vec<u32> = (tiles.start..=tiles.end).collect();
        let chunks = tiles.len() as u32;
        (Queue { chunks, columns, wave_groups: chunks.max(1) }, b)
    }

    /// The queue of a `w`×`h` frame with `schedule`'s chunks for `workers` workers, cut into
    /// about `waves` waves; and its boundary array, what the work buffer holds.
    pub fn new(schedule: Schedule, workers: u32, [w, h]: [u32; 2], waves: u32) -> (Queue, Vec<u32>) {
        let [tx, ty] = tile_grid(w, h);
        let b = cap_chunks(&schedule.boundaries(tx * ty, workers), MAX_CHUNK_TILES);
        let queue =
            Queue { chunks: b.len() as u32 - 1, columns: tx, wave_groups: wave_groups(tx * ty, waves) };
        (queue, b)
    }

    /// One wave of pass `pass` of sample `s`, the queue restarted first when `restart`.
    pub fn wave(&self, pass: [u32; 4], s: PixelSample, restart: bool) -> Recording {
        let launch = Launch::queue(pass, s, self.chunks, TILE_BUDGET, self.columns, QUEUE_LOOP_BUDGET);
        let wave = Dispatch { entry: "render_queue".into(), launch, groups: [self.wave_groups, 1, 1] };
        let mut commands = Vec::with_capacity(2);
        if restart {
            commands.push(Command::ResetQueue);
        }
        commands.push(Command::Dispatch(wave));
        Recording { commands }
    }
}

/// The pixels of tiles `tiles` of a `width`×`height` frame whose tile grid has `columns`
/// columns, tile after tile, each tile's pixels row by row (clipped at the image's edges): the
/// order in which a distributed worker returns a chunk's pixels and the master places them.
pub fn chunk_pixels(tiles: Range<u32>, columns: u32, width: u32, height: u32) -> impl Iterator<Item = u32> {
    tiles.flat_map(move |t| {
        let (x0, y0) = ((t % columns.max(1)) * TILE_W, (t / columns.max(1)) * TILE_H);
        (y0..(y0 + TILE_H).min(height))
            .flat_map(move |y| (x0..(x0 + TILE_W).min(width)).map(move |x| y * width + x))
    })
}

/// The most positions a frameless slice holds: one dispatch of `render_slice`'s 64-wide
/// workgroups, of which a dispatch may have 65 535 (a longer piece is traced in parts).
pub const MAX_SLICE: u64 = 65535 * 64;

/// Frameless slices never straddle a pass of the order: positions `[first, first + len)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SliceSpan {
    pub first: u64,
    pub len: u64,
}

/// Where the frameless mode is in its pixel order.
#[derive(Clone, Debug, PartialEq)]
pub struct Slices {
    /// Positions in one pass of the order (≥ the pixel count for the dissolve).
    pub pass_len: u64,
    /// Where the next slice starts in the current pass.
    pub cursor: u64,
    /// Positions traced since the last change (a pixel's visit index since then is
    /// `since_change / pass_len`).
    pub since_change: u64,
    /// The dissolve, and its register's state at `cursor` (carried from slice to slice, so the
    /// host never jumps); `None` for a table order.
    pub dissolve: Option<(Dissolve, u32)>,
    /// Pixels of the image (dissolve values past it are skipped).
    pixels: u64,
}

impl Slices {
    /// The slices of `order` over a `w`×`h` image, and what the work buffer holds for it (the
    /// order's table, or the dissolve's jump matrices).
    pub fn new(order: PixelOrder, [w, h]: [u32; 2]) -> Result<(Slices, Vec<u32>), TooManyPixels> {
        let pixels = w as u64 * h as u64;
        let (dissolve, work) = match order {
            PixelOrder::Dissolve => {
                if !Dissolve::fits(pixels) {
                    return Err(TooManyPixels { width: w, height: h });
                }
                let d = Dissolve::new(pixels);
                let jumps = d.jumps();
                (Some((d, 1)), jumps)
            }
            // The host writes each slice's pixels (`render::adaptive`).
            PixelOrder::Adaptive { .. } => (None, Vec::new()),
            _ => (None, order.table(w, h).expect("table orders have tables")),
        };
        let slices = Slices { pass_len: order.pass_len(w, h), cursor: 0, since_change: 0, dissolve, pixels };
        Ok((slices, work))
    }

    /// The visit of the pixels the next slice traces, since the last change.
    pub fn visit(&self) -> u32 {
        (self.since_change / self.pass_len) as u32
    }

    /// The next slice of at most `slice` positions: it ends at the end of the pass and where
    /// this visit since the change ends, so that all its pixels share one sample index.
    pub fn next_span(&self, slice: u32) -> SliceSpan {
        let to_visit_end = self.pass_len - self.since_change % self.pass_len;
        let len = (slice.max(1) as u64).min(MAX_SLICE).min(self.pass_len - self.cursor).min(to_visit_end);
        SliceSpan { first: self.cursor, len }
    }

    /// The dispatches of `span`, one per pass, of sample `s`.
    pub fn recording(&self, span: SliceSpan, passes: &[[u32; 4]], s: PixelSample) -> Recording {
        let state = self.dissolve.as_ref().map_or(0, |(_, state)| *state);
        self.recording_from(span, passes, s, state)
    }

    /// [`Slices::recording`] of any span of the pass (the dissolve's register worked out for
    /// its first position), its output compact (`OUT_COMPACT`: position i of the span in output
    /// vec4 i) and no frame buffer written: what a distributed worker traces and returns. A
    /// table order's positions are read from the work buffer at `table_at` (the span's own
    /// first position where the whole table is there, 0 where only the span's part is).
    /// `sample` ([`frameless_sample`]) says where in the pixel the rays go: its jitter, or the
    /// jitter pairs' two positions; how it lands in a frame is the caller's.
    pub fn compact_recording(
        &self,
        span: SliceSpan,
        passes: &[[u32; 4]],
        sample: PixelSample,
        table_at: u64,
    ) -> Recording {
        let state = self.dissolve.as_ref().map_or(0, |(d, _)| d.state_at(span.first));
        let s = PixelSample { flags: OUT_COMPACT | (sample.flags & FRAME_JITTER_PAIRS), ..sample };
        self.recording_from(SliceSpan { first: table_at, ..span }, passes, s, state)
    }

    /// Whether the order reads its positions from a table (else the dissolve's register).
    pub fn has_table(&self) -> bool {
        self.dissolve.is_none()
    }

    fn recording_from(&self, span: SliceSpan, passes: &[[u32; 4]], s: PixelSample, state: u32) -> Recording {
        let (kind, bits) = match &self.dissolve {
            Some((d, _)) => (ORDER_DISSOLVE, d.bits),
            None => (ORDER_TABLE, 0),
        };
        let commands = passes
            .iter()
            .map(|&pass| {
                let launch = Launch::slice(pass, s, span.first as u32, span.len as u32, kind, bits, state);
                let groups = [(span.len as u32).div_ceil(64), 1, 1];
                Command::Dispatch(Dispatch { entry: "render_slice".into(), launch, groups })
            })
            .collect();
        Recording { commands }
    }

    /// Moves past `span` (traced): returns the positions in it that name pixels, whether it
    /// finished a pass of the order, and whether it finished a visit since the last change.
    pub fn advance(&mut self, span: SliceSpan) -> (u64, bool, bool) {
        self.cursor += span.len;
        self.since_change += span.len;
        let pass_done = self.cursor == self.pass_len;
        if pass_done {
            self.cursor = 0;
        }
        let visit_done = self.since_change.is_multiple_of(self.pass_len);
        let pixels = match &mut self.dissolve {
            // Values past the image are skipped: count the positions that name pixels, and step
            // the register to the next slice's first state.
            Some((d, state)) => {
                let mut n = 0;
                for _ in 0..span.len {
                    n += (*state as u64 <= self.pixels) as u64;
                    *state = d.step(*state);
                }
                n
            }
            None => span.len,
        };
        (pixels, pass_done, visit_done)
    }

    /// The first visit since the change was traced some other way (the adaptive order's dealt
    /// slices): the next slice starts the second visit's pass.
    pub fn first_visit_done(&mut self) {
        self.since_change = self.pass_len;
        self.cursor = 0;
    }

    /// A change (camera, scene, settings): the visits count again from here.
    pub fn restart(&mut self) {
        self.since_change = 0;
    }
}

/// The dissolve's register has 26 bits.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("the dissolve order handles at most 2^26 - 1 pixels; {width}x{height} has more")]
pub struct TooManyPixels {
    pub width: u32,
    pub height: u32,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::layout::RENDER_TILE;

    /// Each pixel's count of dispatches that cover it, over `rec` (the `render` entry point's
    /// dealt tiles, as the shader deals them).
    fn bands_coverage(rec: &Recording, [w, h]: [u32; 2], pass: [u32; 4]) -> Vec<u32> {
        let mut seen = vec![0u32; (w * h) as usize];
        let [tw, th] = RENDER_TILE;
        for d in rec.dispatches().filter(|d| d.launch.pass_range == pass) {
            let [x0, y0, rw, rh] = d.launch.rect;
            let n = d.launch.work[0];
            let [gx, gy, gz] = d.groups;
            for g in 0..gx * gy * gz {
                let (x, y, z) = (g % gx, g / gx % gy, g / (gx * gy));
                let (tile_x, tile_y) = (x, y * n + z);
                for ly in 0..th {
                    for lx in 0..tw {
                        let (px, py) = (tile_x * tw + lx, tile_y * th + ly);
                        if px < rw && py < rh {
                            seen[((y0 + py) * w + x0 + px) as usize] += 1;
                        }
                    }
                }
            }
        }
        seen
    }

    /// The bands cover every pixel once per pass, in whole rows of at most `band_pixels` eye
    /// rays, each band followed by a progress mark: 16 bands for a 2048² frame on lavapipe, one
    /// on a GPU; split bundles trace every pass of a band before the next band.
    #[test]
    fn bands_cover_the_image_once_per_pass() {
        let split = vec![[0, 16, 1, 0], [16, 32, 0, 1]];
        for (size, band_pixels, count, passes) in [
            ([2048, 2048], BAND_PIXELS, 16, vec![WHOLE_PASS]),
            ([2048, 2048], GPU_BAND_PIXELS, 1, vec![WHOLE_PASS]),
            ([1000, 1000], BAND_PIXELS, 4, vec![WHOLE_PASS]),
            ([131, 67], BAND_PIXELS, 1, split.clone()),
            ([640, 480], u32::MAX, 1, split),
        ] {
            let bands = Bands { grid_size: size, passes: passes.clone(), deal: 2, band_pixels };
            let rec = bands.recording(frame_sample(0));
            for &pass in &passes {
                let seen = bands_coverage(&rec, size, pass);
                assert!(seen.iter().all(|&c| c == 1), "{size:?}, {band_pixels}: {pass:?}");
            }
            let mut next = 0;
            for d in rec.dispatches().step_by(passes.len()) {
                let [x, y, w, h] = d.launch.rect;
                assert_eq!((x, y, w), (0, next, size[0]));
                assert!(h as u64 * size[0] as u64 <= (band_pixels as u64).max(size[0] as u64));
                next += h;
            }
            assert_eq!(next, size[1]);
            let marks = rec.commands.iter().filter(|c| matches!(c, Command::Progress { .. })).count();
            assert_eq!((marks, rec.dispatches().count()), (count, count * passes.len()), "{size:?}");
        }
    }

    /// The queue's boundary array cuts the frame's tiles into chunks of at most
    /// `MAX_CHUNK_TILES` that cover every tile once, for every schedule; a wave restarts the
    /// queue only when asked, and its workgroups with their budget can take the whole frame in
    /// about the waves asked for.
    #[test]
    fn the_queue_covers_every_tile_once() {
        for size in [[640, 480], [1280, 720], [33, 17], [1, 1]] {
            for schedule in Schedule::ALL {
                for workers in [1, 2, 16, 256] {
                    let (q, b) = Queue::new(schedule, workers, size, 4);
                    let [tx, ty] = tile_grid(size[0], size[1]);
                    assert_eq!((b[0], *b.last().unwrap(), q.chunks as usize), (0, tx * ty, b.len() - 1));
                    assert!(b.windows(2).all(|w| w[0] < w[1] && w[1] - w[0] <= MAX_CHUNK_TILES));
                    assert!(q.wave_groups * TILE_BUDGET * 4 >= tx * ty, "{size:?} {schedule}");
                    let first = q.wave(WHOLE_PASS, frame_sample(0), true);
                    assert_eq!(first.commands[0], Command::ResetQueue);
                    let later = q.wave(WHOLE_PASS, frame_sample(0), false);
                    assert_eq!(later.dispatches().count(), 1);
                    assert!(!later.commands.contains(&Command::ResetQueue));
                }
            }
        }
    }

    /// A pass of frameless slices covers every position of the order once, and the positions
    /// name every pixel once (a table order is a permutation; the dissolve skips values past
    /// the image), whatever the slice size; the visit counts passes since the last change.
    #[test]
    fn frameless_slices_cover_every_pixel_once_a_pass() {
        for size in [[64, 48], [37, 11], [1, 1]] {
            let pixels = (size[0] * size[1]) as usize;
            for order in [PixelOrder::default(), PixelOrder::Random, PixelOrder::Dissolve] {
                for slice in [1, 7, 1000, 1 << 20] {
                    let (mut s, work) = Slices::new(order, size).expect("fits");
                    let mut seen = vec![0u32; pixels];
                    let mut positions = 0;
                    let mut named = 0;
                    loop {
                        let span = s.next_span(slice);
                        assert_eq!(span.first, s.cursor);
                        let rec = s.recording(span, &[WHOLE_PASS], frameless_sample(0, None, false));
                        assert_eq!(rec.dispatches().count(), 1);
                        if let Some((d, state)) = &s.dissolve {
                            let mut v = *state;
                            for _ in 0..span.len {
                                if (v as usize) <= pixels {
                                    seen[v as usize - 1] += 1;
                                }
                                v = d.step(v);
                            }
                        } else {
                            for p in &work[span.first as usize..(span.first + span.len) as usize] {
                                seen[*p as usize] += 1;
                            }
                        }
                        positions += span.len;
                        let (n, pass_done, visit_done) = s.advance(span);
                        named += n;
                        if pass_done {
                            assert!(visit_done);
                            break;
                        }
                    }
                    assert_eq!(positions, s.pass_len, "{order} {size:?} S={slice}");
                    assert_eq!(named as usize, pixels, "{order} {size:?} S={slice}");
                    assert!(seen.iter().all(|&c| c == 1), "{order} {size:?} S={slice}");
                    assert_eq!(s.visit(), 1);
                    s.restart();
                    assert_eq!(s.visit(), 0);
                }
            }
        }
    }

    /// The frame-buffer flags of each way a sample lands: a conventional frame writes only the
    /// output (the resolve writes the frame buffer: replacing, then adding); frameless visits
    /// replace, then add, or blend.
    #[test]
    fn samples_land_as_each_mode_says() {
        assert_eq!(frame_sample(0), PixelSample::default());
        assert_eq!(frame_sample(3).jitter, refinement_jitter(3));
        let flags = |r: Recording| r.dispatches().next().unwrap().launch.sample[1];
        assert_eq!(flags(resolve(100, 0)), FRAME_WRITE);
        // A frame past one dispatch's workgroups resolves in several, covering it once.
        let big = resolve(3 * MAX_SLICE as u32 + 5, 0);
        let starts: Vec<u32> = big.dispatches().map(|d| d.launch.work[1]).collect();
        assert_eq!(starts, [0, 1, 2, 3].map(|i| i * MAX_SLICE as u32));
        assert!(big.dispatches().all(|d| d.groups[0] <= 65535));
        assert_eq!(flags(resolve(100, 1)), FRAME_WRITE | FRAME_ACCUMULATE);
        assert_eq!(frameless_sample(0, None, false).flags, FRAME_WRITE);
        assert_eq!(frameless_sample(2, None, false).flags, FRAME_WRITE | FRAME_ACCUMULATE);
        assert_eq!(frameless_sample(2, Some(0.3), false).alpha, 0.3);
        assert_eq!(frameless_sample(5, None, true).flags, FRAME_WRITE | FRAME_JITTER_PAIRS | FRAME_BLEND);
        assert_eq!(frameless_sample(5, None, true).jitter, [0.0, 0.0]);
    }
}
