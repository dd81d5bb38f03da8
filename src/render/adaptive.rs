//! The adaptive frameless order (`--order adaptive`), after Dayal, Woolley, Watson & Luebke,
//! *Adaptive Frameless Rendering* (EGSR 2005): slices go where the picture changes.
//!
//! The image is cut into blocks of 4×4 pixels (two of lavapipe's 8-lane SIMD groups each, in
//! Hilbert order inside the block; 8×8 blocks err about 5% more on the tuning scenes). Each
//! block keeps an estimate of how fast its pixels change (the mean difference, in display space,
//! between a pixel's new sample and its previous one, per pass of time between the two) and
//! what a pixel of it costs (its shader loop iterations), both from the slice's samples as they
//! come back. A slice of S positions takes the ⌈S/16⌉ blocks of highest priority
//! `((rate + FLOOR) × age)² / cost`, age the positions dealt since the block's last visit: the
//! change expected since then, squared as the RMS error counts it, per unit of cost (the pixels
//! that change under a moving camera are the dear ones — reflections, refractions, edges — so an
//! order that ignored cost would trace fewer of them per second than it assumes). A block whose
//! age would pass the revisit bound within the slice is dealt first (oldest first): every pixel
//! is traced again within [`AdaptiveOrder::bound`] positions, a stated number of passes.
//!
//! After a change (camera, scene, settings) the order deals adaptively until every block has
//! been dealt once since the change — every pixel then shows the new state, visit 0, as any
//! order's first pass leaves it — and then walks the Hilbert order pass after pass for the
//! refinement samples, as the Hilbert order does: at rest it converges to the same picture.

use super::fill::BlockFill;
use super::order::{hilbert_d2xy, PixelOrder};

/// Blocks are 4×4 pixels.
pub const BLOCK_SIDE: u32 = 4;
const BLOCK_PIXELS: u32 = BLOCK_SIDE * BLOCK_SIDE;

/// The revisit bound by default, in passes of the image: a pixel is traced again at the latest
/// three passes' positions after its last visit, so at least two thirds of the slices'
/// positions go where the estimates send them (2 passes err 4–8% more on the tuning scenes,
/// 5 passes 2–6% less, at a longer wait for the last pixel).
pub const DEFAULT_REVISIT_PASSES: u32 = 3;

/// Added to every rate (display-space change per pass): a block that did not change still ages
/// into the slices.
const FLOOR: f32 = 1.0 / 1024.0;

/// A block's estimate shared with its four neighbours at this weight: an edge moving out of a
/// block moves into the next one, which may not have changed yet.
const SPREAD: f32 = 0.5;

/// A pixel's cost beyond its loops (the eye ray, the write), in loop iterations.
const COST_BASE: f32 = 8.0;

/// The adaptive order's state over a `width`×`height` image.
#[derive(Clone, Debug)]
pub struct AdaptiveOrder {
    width: u32,
    blocks_x: u32,
    /// Every block's pixels (indices y·width + x), block after block, each in Hilbert order;
    /// block b's are `block_pixels[block_start[b]..block_start[b + 1]]`.
    block_pixels: Vec<u32>,
    block_start: Vec<u32>,
    /// The Hilbert order of a pass, for the refinement passes once every block is covered.
    base: Vec<u32>,
    estimate: Vec<f32>,
    /// What a pixel of the block cost at its last visit: its mean shader loop iterations, plus
    /// [`COST_BASE`].
    cost: Vec<f32>,
    /// `clock` when each block was last dealt, and the positions between its last two deals.
    dealt_at: Vec<u64>,
    interval: Vec<u64>,
    /// Positions dealt so far (starts at a pass, so that the first ages are a pass's).
    clock: u64,
    bound: u64,
    pass: u64,
    /// Blocks dealt since the last change: `covered[b] == generation`.
    covered: Vec<u32>,
    generation: u32,
    uncovered: usize,
    /// `clock` at the last change.
    changed_at: u64,
    /// Each pixel's last sample, in display space (√ of the clamped radiance).
    last: Vec<[f32; 3]>,
    /// Each block's mean difference between adjacent pixels of `last` (pairs whose first pixel
    /// is the block's), for the fill.
    gradient: Vec<f32>,
    /// The blocks and pixels of the last slice dealt.
    slice_blocks: Vec<u32>,
    slice: Vec<u32>,
    /// Work space of `deal`: (priority, block).
    ranked: Vec<(f32, u32)>,
    spread: Vec<f32>,
}

impl AdaptiveOrder {
    /// The order over a `width`×`height` image, every pixel revisited within `revisit_passes`
    /// passes' positions (at least 1). Ages start as a Hilbert pass leaves them (the picture
    /// the order starts from is a whole pass), estimates high (unknown).
    pub fn new(width: u32, height: u32, revisit_passes: u32) -> AdaptiveOrder {
        let (bx, by) = (width.div_ceil(BLOCK_SIDE), height.div_ceil(BLOCK_SIDE));
        let blocks = (bx * by) as usize;
        let mut block_pixels = Vec::with_capacity(width as usize * height as usize);
        let mut block_start = Vec::with_capacity(blocks + 1);
        for b in 0..bx * by {
            block_start.push(block_pixels.len() as u32);
            let (x0, y0) = ((b % bx) * BLOCK_SIDE, (b / bx) * BLOCK_SIDE);
            for d in 0..BLOCK_PIXELS as u64 {
                let (dx, dy) = hilbert_d2xy(BLOCK_SIDE, d);
                let (x, y) = (x0 + dx, y0 + dy);
                if x < width && y < height {
                    block_pixels.push(y * width + x);
                }
            }
        }
        block_start.push(block_pixels.len() as u32);
        let base = PixelOrder::default().table(width, height).expect("the Hilbert order has a table");
        let pass = base.len() as u64;
        // A block was last dealt where the Hilbert pass traced its last pixel (as
        // `traced_in_order` counts).
        let mut dealt_at = vec![0u64; blocks];
        for (pos, &p) in base.iter().enumerate() {
            let b = ((p / width) / BLOCK_SIDE * bx + (p % width) / BLOCK_SIDE) as usize;
            dealt_at[b] = dealt_at[b].max(pos as u64);
        }
        AdaptiveOrder {
            width,
            blocks_x: bx,
            block_pixels,
            block_start,
            base,
            estimate: vec![1.0; blocks],
            cost: vec![COST_BASE; blocks],
            interval: vec![pass; blocks],
            dealt_at,
            clock: pass,
            bound: pass * revisit_passes.max(1) as u64,
            pass,
            covered: vec![0; blocks],
            generation: 1,
            uncovered: blocks,
            changed_at: 0,
            last: vec![[0.0; 3]; width as usize * height as usize],
            gradient: vec![0.0; blocks],
            slice_blocks: Vec::new(),
            slice: Vec::new(),
            ranked: Vec::with_capacity(blocks),
            spread: vec![0.0; blocks],
        }
    }

    /// Every pixel is traced again within this many positions of its last visit.
    pub fn bound(&self) -> u64 {
        self.bound
    }

    /// The Hilbert order the refinement passes walk.
    pub fn base(&self) -> &[u32] {
        &self.base
    }

    /// A change: every block is to be dealt again before the refinement passes.
    pub fn restart(&mut self) {
        self.generation = self.generation.wrapping_add(1).max(1);
        self.uncovered = self.estimate.len();
        self.changed_at = self.clock;
    }

    /// Some block has not been dealt since the last change: slices are dealt adaptively.
    pub fn covering(&self) -> bool {
        self.uncovered > 0
    }

    /// The pixels of the next slice of about `slice` positions (whole blocks, at least one).
    pub fn deal(&mut self, slice: u32) -> &[u32] {
        let blocks = self.estimate.len();
        let want = (slice.max(1).div_ceil(BLOCK_PIXELS) as usize).min(blocks);
        let horizon = self.clock + (want as u64) * BLOCK_PIXELS as u64;
        self.spread_estimates();
        self.ranked.clear();
        for b in 0..blocks {
            let age = self.clock - self.dealt_at[b];
            // Past the bound within this slice: first, oldest first (ages ≤ a few 2^24 are
            // exact in f32 to well within a block).
            let p = if horizon - self.dealt_at[b] >= self.bound {
                f32::MAX / 2.0 + age as f32
            } else {
                // The change expected since its last visit, squared (the error is an RMS), per
                // unit of cost.
                let x = (self.spread[b] + FLOOR) * (age as f32 / self.pass as f32);
                x * x / self.cost[b]
            };
            self.ranked.push((p, b as u32));
        }
        if want < blocks {
            self.ranked.select_nth_unstable_by(want, |a, b| b.0.total_cmp(&a.0));
        }
        self.slice_blocks.clear();
        self.slice.clear();
        for &(_, b) in &self.ranked[..want] {
            self.slice_blocks.push(b);
        }
        // Dealt in image order: neighbouring blocks in neighbouring workgroups.
        self.slice_blocks.sort_unstable();
        for &b in &self.slice_blocks {
            let b = b as usize;
            let r = self.block_start[b] as usize..self.block_start[b + 1] as usize;
            self.slice.extend_from_slice(&self.block_pixels[r]);
            if self.covered[b] != self.generation {
                self.covered[b] = self.generation;
                self.uncovered -= 1;
            }
        }
        for &b in &self.slice_blocks {
            self.interval[b as usize] = self.clock - self.dealt_at[b as usize];
            self.dealt_at[b as usize] = self.clock;
        }
        self.clock += self.slice.len() as u64;
        &self.slice
    }

    /// A pass walks the Hilbert order instead: the next change deals from what it left.
    pub fn cover_in_order(&mut self) {
        self.uncovered = 0;
    }

    /// Positions `first..first + len` of the Hilbert order were traced: their blocks were dealt
    /// now. Returns their pixels.
    pub fn traced_in_order(&mut self, first: u64, len: u64) -> &[u32] {
        self.slice.clear();
        self.slice_blocks.clear();
        self.slice.extend_from_slice(&self.base[first as usize..(first + len) as usize]);
        for (i, &p) in self.slice.iter().enumerate() {
            let b = ((p / self.width) / BLOCK_SIDE * self.blocks_x + (p % self.width) / BLOCK_SIDE) as usize;
            self.dealt_at[b] = self.clock + i as u64;
        }
        self.clock += len;
        &self.slice
    }

    /// The pixels of the last slice, dealt or traced in order.
    pub fn last_traced(&self) -> &[u32] {
        &self.slice
    }

    /// The last slice's samples came back (radiance, one per pixel of [`Self::slice`], in its
    /// order): each block's estimate becomes the mean change of its pixels.
    pub fn learn(&mut self, samples: &[[f32; 4]]) {
        let mut at = 0;
        for &b in &self.slice_blocks {
            let b = b as usize;
            let n = (self.block_start[b + 1] - self.block_start[b]) as usize;
            let (mut sum, mut iters) = (0.0f32, 0.0f32);
            for (&p, s) in self.block_pixels[self.block_start[b] as usize..][..n].iter().zip(&samples[at..]) {
                let new = [shown(s[0]), shown(s[1]), shown(s[2])];
                let old = &mut self.last[p as usize];
                sum += (0..3).map(|c| (new[c] - old[c]).abs()).sum::<f32>() / 3.0;
                *old = new;
                // Alpha is 2 × the loop iterations + whether the eye ray hit.
                iters += (s[3] / 2.0).floor();
            }
            // Per pass: a block seen again soon changed little because little time passed.
            self.estimate[b] = sum / n.max(1) as f32 * self.pass as f32 / self.interval[b].max(1) as f32;
            self.cost[b] = iters / n.max(1) as f32 + COST_BASE;
            at += n;
        }
        // A block's gradient counts pairs reaching into its right and lower neighbours.
        let bx = self.blocks_x;
        for i in 0..self.slice_blocks.len() {
            let b = self.slice_blocks[i];
            self.update_gradient(b);
            if !b.is_multiple_of(bx) {
                self.update_gradient(b - 1);
            }
            if b >= bx {
                self.update_gradient(b - bx);
            }
        }
    }

    fn update_gradient(&mut self, b: u32) {
        let w = self.width as usize;
        let h = self.last.len() / w;
        let shown = |i: usize| self.last[i].iter().sum::<f32>() / 3.0;
        let (mut sum, mut pairs) = (0.0f32, 0u32);
        let r = self.block_start[b as usize] as usize..self.block_start[b as usize + 1] as usize;
        for &p in &self.block_pixels[r] {
            let (p, x, y) = (p as usize, p as usize % w, p as usize / w);
            if x + 1 < w {
                sum += (shown(p) - shown(p + 1)).abs();
                pairs += 1;
            }
            if y + 1 < h {
                sum += (shown(p) - shown(p + w)).abs();
                pairs += 1;
            }
        }
        self.gradient[b as usize] = sum / pairs.max(1) as f32;
    }

    /// What the fill ([`super::fill`]) needs of every block, into `out`: the change it missed
    /// (its rate, spread as the slices are dealt, times the passes from its last visit to the
    /// last change) and its gradient. Returns whether any block missed a change (otherwise the
    /// fill changes nothing).
    pub fn fill_blocks(&mut self, out: &mut Vec<BlockFill>) -> bool {
        self.spread_estimates();
        out.clear();
        let mut stale = false;
        for b in 0..self.estimate.len() {
            let passes = self.changed_at.saturating_sub(self.dealt_at[b]) as f32 / self.pass as f32;
            let missed = self.spread[b] * passes;
            stale |= missed > 0.0;
            out.push([missed, self.gradient[b]]);
        }
        stale
    }

    /// Blocks a row (of [`BLOCK_SIDE`] pixels).
    pub fn blocks_x(&self) -> u32 {
        self.blocks_x
    }

    /// `spread[b]` = the larger of b's estimate and [`SPREAD`] × its 4-neighbours' largest.
    fn spread_estimates(&mut self) {
        let bx = self.blocks_x as usize;
        let by = self.estimate.len() / bx.max(1);
        for y in 0..by {
            for x in 0..bx {
                let e = |x: usize, y: usize| self.estimate[y * bx + x];
                let mut n = 0.0f32;
                if x > 0 {
                    n = n.max(e(x - 1, y));
                }
                if x + 1 < bx {
                    n = n.max(e(x + 1, y));
                }
                if y > 0 {
                    n = n.max(e(x, y - 1));
                }
                if y + 1 < by {
                    n = n.max(e(x, y + 1));
                }
                self.spread[y * bx + x] = e(x, y).max(SPREAD * n);
            }
        }
    }
}

/// A radiance as the display roughly shows it: clamped, gamma 2 (cheap; only compared).
fn shown(x: f32) -> f32 {
    if x.is_nan() {
        0.0
    } else {
        x.clamp(0.0, 1.0).sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Runs the order over `slices` slices of `s` positions with a picture that changes where
    /// `changes(pixel, slice)` says; returns each pixel's largest gap between visits (positions)
    /// and its visit count.
    fn run(
        w: u32,
        h: u32,
        s: u32,
        slices: u32,
        changes: impl Fn(u32, u32) -> bool,
    ) -> (AdaptiveOrder, Vec<u64>, Vec<u32>) {
        let mut a = AdaptiveOrder::new(w, h, DEFAULT_REVISIT_PASSES);
        let n = (w * h) as usize;
        let mut last = vec![0u64; n];
        let mut gap = vec![0u64; n];
        let mut visits = vec![0u32; n];
        let mut pos = 0u64;
        for k in 0..slices {
            let px = a.deal(s).to_vec();
            for &p in &px {
                let p = p as usize;
                gap[p] = gap[p].max(pos - last[p]);
                last[p] = pos;
                visits[p] += 1;
            }
            pos += px.len() as u64;
            let samples: Vec<[f32; 4]> =
                px.iter().map(|&p| if changes(p, k) { [(k % 2) as f32; 4] } else { [0.25; 4] }).collect();
            a.learn(&samples);
        }
        for p in 0..n {
            gap[p] = gap[p].max(pos - last[p]);
        }
        (a, gap, visits)
    }

    /// Every pixel of every block belongs to exactly one block.
    #[test]
    fn blocks_partition_the_image() {
        for (w, h) in [(64, 64), (37, 19), (1280, 720)] {
            let a = AdaptiveOrder::new(w, h, 2);
            let mut seen = vec![0u8; (w * h) as usize];
            for &p in &a.block_pixels {
                seen[p as usize] += 1;
            }
            assert!(seen.iter().all(|&c| c == 1), "{w}x{h}");
        }
    }

    /// A quarter of the picture changes at every visit, the rest never: the changing blocks get
    /// most of the slices, yet no pixel waits longer than the bound (from its last visit, or
    /// from the start's Hilbert pass).
    #[test]
    fn change_draws_slices_and_the_bound_holds() {
        let (w, h) = (128u32, 96u32);
        let n = (w * h) as u64;
        let moving = |p: u32| (p % w) < w / 2 && (p / w) < h / 2;
        let (a, gap, visits) = run(w, h, 1024, 200, |p, _| moving(p));
        let bound = a.bound() + n; // the first visit also waits for the start's pass
        let worst = gap.iter().copied().max().unwrap();
        assert!(worst <= bound, "a pixel waited {worst} positions, bound {bound}");
        let (mut hot, mut cold) = (0u64, 0u64);
        for p in 0..n as u32 {
            if moving(p) {
                hot += visits[p as usize] as u64;
            } else {
                cold += visits[p as usize] as u64;
            }
        }
        // The still pixels get about what the bound demands (one visit per two passes; 200
        // slices are 16.7 passes; the blocks bordering the changing quarter share its estimate
        // at half weight and get more), the changing quarter the rest: per pixel over 3x as many.
        let (hot_pp, cold_pp) = (hot as f64 / (n / 4) as f64, cold as f64 / (3 * n / 4) as f64);
        let passes = 200.0 * 1024.0 / n as f64;
        assert!(
            cold_pp <= passes / DEFAULT_REVISIT_PASSES as f64 + 2.5,
            "still pixels {cold_pp:.1} visits each"
        );
        assert!(hot_pp > 3.0 * cold_pp, "changing pixels {hot_pp:.1} visits each, still ones {cold_pp:.1}");
    }

    /// Nothing changes: the bound and the floor deal the blocks round, every pixel about once
    /// per pass, none past the bound.
    #[test]
    fn a_still_picture_is_dealt_round() {
        let (w, h) = (96u32, 64u32);
        let n = (w * h) as u64;
        let (a, gap, visits) = run(w, h, 512, 120, |_, _| false);
        assert!(gap.iter().all(|&g| g <= a.bound() + n));
        let (lo, hi) = (visits.iter().min().unwrap(), visits.iter().max().unwrap());
        assert!(*lo >= 5 && hi - lo <= 3, "visits per pixel from {lo} to {hi} over 10 passes");
    }

    /// The fill's view: nothing missed before any change; after one, the blocks dealt since
    /// missed nothing and the others their rate's worth; a block's gradient follows its samples.
    #[test]
    fn the_fill_sees_which_blocks_missed_the_change() {
        let mut a = AdaptiveOrder::new(16, 16, DEFAULT_REVISIT_PASSES);
        let mut out = Vec::new();
        assert!(!a.fill_blocks(&mut out), "at the start nothing changed");
        assert_eq!(out.len(), 16);
        a.restart();
        let dealt: Vec<u32> = a.deal(32).to_vec();
        // A vertical stripe pattern: adjacent pixels differ by 1 in x, not in y.
        let samples: Vec<[f32; 4]> =
            dealt.iter().map(|&p| [((p % 16) % 2) as f32; 3]).map(|c| [c[0], c[1], c[2], 2.0]).collect();
        a.learn(&samples);
        assert!(a.fill_blocks(&mut out));
        let fresh: Vec<usize> = a.slice_blocks.iter().map(|&b| b as usize).collect();
        assert_eq!(fresh.len(), 2);
        for (b, f) in out.iter().enumerate() {
            if fresh.contains(&b) {
                assert_eq!(f[0], 0.0, "block {b} was traced since the change");
                // Half of its pairs (the horizontal ones) differ by 1, those reaching into an
                // unsampled neighbour by 1 or 0: between a quarter and three quarters.
                assert!(f[1] > 0.25 && f[1] < 0.75, "block {b}'s gradient {}", f[1]);
            } else {
                assert!(f[0] > 0.0, "block {b} missed the change");
            }
        }
    }

    /// Coverage after a change: `covering` until every block has been dealt once since.
    #[test]
    fn coverage_counts_every_block_since_the_change() {
        let (w, h) = (64u32, 64u32);
        let mut a = AdaptiveOrder::new(w, h, 2);
        let mut seen = vec![false; (w * h) as usize];
        a.restart();
        let mut slices = 0;
        while a.covering() {
            for &p in a.deal(700) {
                seen[p as usize] = true;
            }
            slices += 1;
            assert!(slices < 1000);
        }
        assert!(seen.iter().all(|&s| s), "covered without dealing every pixel");
    }
}
