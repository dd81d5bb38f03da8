//! Pixel age in frameless mode: how long ago the values on screen were traced.
//!
//! Every position of the pixel order is visited once a pass, so the last pass worth of slices
//! (`Session::pass_len` positions) covers every pixel exactly once, and each of those pixels was
//! last updated when its slice ran. The age distribution at time `now` is therefore the slices'
//! ages weighted by their position counts. [`age_stats`] computes it from any list of
//! (count, time) pairs (also usable offline, with simulated times); [`SliceAges`] keeps the last
//! pass worth of them as the viewer runs.

use std::collections::VecDeque;

/// Age statistics over the pixels, in the unit of the times given (seconds in the viewer).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AgeStats {
    /// Mean age, weighted by pixels.
    pub mean: f64,
    /// 90th percentile: 90% of the pixels are at most this old.
    pub p90: f64,
    /// Pixels the statistics cover.
    pub pixels: u64,
}

/// Weighted mean and 90th percentile of `now - time` over `slices` of (pixels, time at which
/// they were traced), in any order; `None` when no pixel is covered. Ages below zero (a time
/// after `now`) count as zero.
pub fn age_stats(slices: &[(u64, f64)], now: f64) -> Option<AgeStats> {
    let pixels: u64 = slices.iter().map(|s| s.0).sum();
    if pixels == 0 {
        return None;
    }
    let mut ages: Vec<(f64, u64)> =
        slices.iter().filter(|s| s.0 > 0).map(|&(n, t)| ((now - t).max(0.0), n)).collect();
    let mean = ages.iter().map(|&(a, n)| a * n as f64).sum::<f64>() / pixels as f64;
    ages.sort_by(|a, b| a.0.total_cmp(&b.0));
    // The smallest age with at least 90% of the pixels at or below it.
    let want = (pixels as f64 * 0.9).ceil() as u64;
    let mut seen = 0;
    let mut p90 = ages.last().map_or(0.0, |a| a.0);
    for &(a, n) in &ages {
        seen += n;
        if seen >= want {
            p90 = a;
            break;
        }
    }
    Some(AgeStats { mean, p90, pixels })
}

/// The slices of the last `window` positions (one pass) and when each ran, oldest first; the
/// oldest is trimmed so that the counts add up to at most `window`.
#[derive(Clone, Debug, Default)]
pub struct SliceAges {
    ring: VecDeque<(u64, f64)>,
    total: u64,
    window: u64,
}

impl SliceAges {
    pub fn new(window: u64) -> Self {
        SliceAges { ring: VecDeque::new(), total: 0, window }
    }

    /// Forgets everything and covers `window` positions from now on (a new render size or order).
    pub fn reset(&mut self, window: u64) {
        *self = SliceAges::new(window);
    }

    pub fn window(&self) -> u64 {
        self.window
    }

    /// A slice of `count` positions traced at `time`.
    pub fn push(&mut self, count: u64, time: f64) {
        if count == 0 || self.window == 0 {
            return;
        }
        let count = count.min(self.window);
        self.ring.push_back((count, time));
        self.total += count;
        while self.total > self.window {
            let excess = self.total - self.window;
            let front = self.ring.front_mut().expect("total > 0 means an entry");
            if front.0 <= excess {
                self.total -= front.0;
                self.ring.pop_front();
            } else {
                front.0 -= excess;
                self.total -= excess;
            }
        }
    }

    /// Positions covered (at most one pass).
    pub fn covered(&self) -> u64 {
        self.total
    }

    /// [`age_stats`] of the slices held, at `now`.
    pub fn stats(&mut self, now: f64) -> Option<AgeStats> {
        age_stats(self.ring.make_contiguous(), now)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_slices_give_the_expected_mean_and_p90() {
        // Ten slices of 100 pixels traced at t = 0..9; now = 10: ages 1..10.
        let slices: Vec<(u64, f64)> = (0..10).map(|i| (100, i as f64)).collect();
        let s = age_stats(&slices, 10.0).unwrap();
        assert!((s.mean - 5.5).abs() < 1e-12);
        assert_eq!(s.p90, 9.0);
        assert_eq!(s.pixels, 1000);
    }

    #[test]
    fn weights_count() {
        // 900 pixels 1 s old and 100 pixels 11 s old: mean 2, p90 1 (exactly 90% are ≤ 1 s).
        let s = age_stats(&[(100, 0.0), (900, 10.0)], 11.0).unwrap();
        assert!((s.mean - 2.0).abs() < 1e-12);
        assert_eq!(s.p90, 1.0);
        // One pixel more on the old side moves the percentile there.
        let s = age_stats(&[(101, 0.0), (899, 10.0)], 11.0).unwrap();
        assert_eq!(s.p90, 11.0);
        assert_eq!(age_stats(&[], 1.0), None);
        assert_eq!(age_stats(&[(0, 1.0)], 1.0), None);
    }

    #[test]
    fn the_ring_keeps_one_pass() {
        let mut r = SliceAges::new(1000);
        for i in 0..25 {
            r.push(100, i as f64);
        }
        assert_eq!(r.covered(), 1000);
        // The last ten slices (t = 15..24), now = 25: ages 1..10.
        let s = r.stats(25.0).unwrap();
        assert!((s.mean - 5.5).abs() < 1e-12, "{s:?}");
        assert_eq!(s.p90, 9.0);
        // A slice straddling the window is trimmed: 1000 positions still.
        r.push(250, 25.0);
        assert_eq!(r.covered(), 1000);
        let s = r.stats(25.0).unwrap();
        // 250 at age 0, then 100 each at ages 1..7, and 50 at age 8 (the trimmed one).
        let mean = (100.0 * (1..=7).sum::<i32>() as f64 + 50.0 * 8.0) / 1000.0;
        assert!((s.mean - mean).abs() < 1e-12, "{} vs {mean}", s.mean);
        r.reset(10);
        assert_eq!(r.stats(0.0), None);
        r.push(1000, 1.0);
        assert_eq!(r.covered(), 10);
    }
}
