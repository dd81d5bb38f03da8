//! Measurements of the interactive loop, as frameless rendering was judged (../PAPER §3:
//! Bishop et al. 1994 at equal compute; Woolley et al. 2003 and Dayal et al. 2005 by the error of
//! the *displayed* image): how old the pixels on screen are, how long an input takes to reach
//! the screen, on a [`Clock`] that is either the measured trace time or a fixed cost per pixel
//! (deterministic, so tests and side-by-side comparisons repeat exactly).
//!
//! Time is in seconds of clock time throughout. A pixel's *age* at a present is the present's
//! time minus the time of the camera its value was traced with: for a frameless slice the time
//! the slice started (when it took the newest camera), for a conventional frame the time the
//! frame started. A pixel *reflects* an input at t0 when it was traced with a camera taken at
//! t0 or later.

use super::StepReport;
use crate::ParseError;
use std::collections::VecDeque;
use std::fmt;
use std::str::FromStr;

/// What a unit of work costs in clock time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Clock {
    /// The measured wall time of the step's dispatches ([`StepReport::trace_time`]): what the
    /// device really did, not repeatable.
    Real,
    /// A fixed cost per traced eye ray ([`StepReport::eye_rays`]; a conventional frame is
    /// charged when it completes): deterministic, and the same for every mode, so modes compare
    /// at equal rays per second.
    Virtual { seconds_per_pixel: f64 },
}

impl Clock {
    /// The clock time `step` took.
    pub fn cost(&self, step: &StepReport) -> f64 {
        match *self {
            Clock::Real => step.trace_time.as_secs_f64(),
            Clock::Virtual { seconds_per_pixel } => step.eye_rays as f64 * seconds_per_pixel,
        }
    }
}

impl fmt::Display for Clock {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Clock::Real => write!(f, "real"),
            Clock::Virtual { seconds_per_pixel } => write!(f, "virtual:{}", seconds_per_pixel * 1e9),
        }
    }
}

/// `real` or `virtual:NS` (nanoseconds per traced pixel).
impl FromStr for Clock {
    type Err = ParseError;
    fn from_str(s: &str) -> Result<Self, ParseError> {
        match s.split_once(':') {
            None if s == "real" => Ok(Clock::Real),
            Some(("virtual", ns)) => match ns.parse::<f64>() {
                Ok(ns) if ns.is_finite() && ns > 0.0 => Ok(Clock::Virtual { seconds_per_pixel: ns / 1e9 }),
                _ => Err(ParseError::new(
                    "clock",
                    format!("`{s}`: expected a number of nanoseconds > 0 after `virtual:`"),
                )),
            },
            _ => Err(ParseError::unknown("clock", s, "real or virtual:NS (ns per traced pixel)")),
        }
    }
}

/// Ages of the pixels on screen at one instant, in seconds.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AgeStats {
    pub mean: f64,
    /// 90% of the pixels are at most this old.
    pub p90: f64,
    pub max: f64,
}

impl AgeStats {
    /// Over many instants: the mean of the means and of the p90s, the largest max (zero for
    /// none).
    pub fn summarise(all: &[AgeStats]) -> AgeStats {
        let n = all.len().max(1) as f64;
        AgeStats {
            mean: all.iter().map(|a| a.mean).sum::<f64>() / n,
            p90: all.iter().map(|a| a.p90).sum::<f64>() / n,
            max: all.iter().map(|a| a.max).fold(0.0, f64::max),
        }
    }
}

/// When each pixel on screen got its value, for ages and latency. The screen is `pass_len`
/// positions: a frameless pass visits every position once, so the newest `pass_len` positions'
/// slices are exactly what is on screen (each slice weighted by its positions; the dissolve's
/// positions past the image are spread evenly over it, so they weigh every slice alike). A
/// conventional frame replaces the whole screen at once.
///
/// An order that is not a fixed permutation (the adaptive one) revisits some pixels before
/// others: its tracker ([`AgeTracker::per_pixel`]) keeps each pixel's camera time instead.
#[derive(Clone, Debug, PartialEq)]
pub struct AgeTracker {
    pass_len: u64,
    /// (camera time, positions), oldest first; the oldest may be partly overwritten.
    slices: VecDeque<(f64, u64)>,
    total: u64,
    pixels: Option<PixelTimes>,
}

/// Each pixel's camera time, as an index into `times` (ascending), and how many pixels hold
/// each time.
#[derive(Clone, Debug, PartialEq)]
struct PixelTimes {
    of: Vec<u32>,
    times: Vec<f64>,
    count: Vec<u64>,
}

impl AgeTracker {
    /// A screen of `pass_len` positions, all written with the camera of time `t0`.
    pub fn new(pass_len: u64, t0: f64) -> Self {
        let pass_len = pass_len.max(1);
        AgeTracker { pass_len, slices: VecDeque::from([(t0, pass_len)]), total: pass_len, pixels: None }
    }

    /// A screen of `pixels` pixels followed pixel by pixel ([`AgeTracker::record_pixels`]), all
    /// written with the camera of time `t0`.
    pub fn per_pixel(pixels: u64, t0: f64) -> Self {
        let times = PixelTimes { of: vec![0; pixels as usize], times: vec![t0], count: vec![pixels] };
        AgeTracker { pixels: Some(times), ..AgeTracker::new(pixels, t0) }
    }

    /// Pixels (indices) traced with the camera of time `t` (not earlier than any recorded
    /// before), on a [`AgeTracker::per_pixel`] screen.
    pub fn record_pixels(&mut self, t: f64, pixels: &[u32]) {
        let p = self.pixels.as_mut().expect("record_pixels is for a per-pixel screen");
        if p.times.last() != Some(&t) {
            p.times.push(t);
            p.count.push(0);
        }
        let now = p.times.len() as u32 - 1;
        for &i in pixels {
            let old = std::mem::replace(&mut p.of[i as usize], now);
            p.count[old as usize] -= 1;
            p.count[now as usize] += 1;
        }
    }

    pub fn pass_len(&self) -> u64 {
        self.pass_len
    }

    /// Follows pixels ([`AgeTracker::per_pixel`]) rather than positions.
    pub fn is_per_pixel(&self) -> bool {
        self.pixels.is_some()
    }

    /// A frameless slice of `positions` traced with the camera of time `t` (not earlier than
    /// any recorded before).
    pub fn record_slice(&mut self, t: f64, positions: u64) {
        let positions = positions.min(self.pass_len);
        if positions == 0 {
            return;
        }
        match self.slices.back_mut() {
            Some(last) if last.0 == t => last.1 += positions,
            _ => self.slices.push_back((t, positions)),
        }
        self.total += positions;
        while let Some(&(_, oldest)) = self.slices.front() {
            if self.total - oldest < self.pass_len {
                break;
            }
            self.slices.pop_front();
            self.total -= oldest;
        }
    }

    /// A conventional frame whose tracing started (with its camera) at `t_start`, now whole on
    /// screen.
    pub fn record_frame(&mut self, t_start: f64) {
        if let Some(p) = &mut self.pixels {
            *p = PixelTimes { of: vec![0; p.of.len()], times: vec![t_start], count: vec![p.of.len() as u64] };
        }
        self.slices.clear();
        self.slices.push_back((t_start, self.pass_len));
        self.total = self.pass_len;
    }

    /// (camera time, positions on screen), oldest first; the positions sum to `pass_len`.
    fn on_screen(&self) -> Box<dyn Iterator<Item = (f64, u64)> + '_> {
        if let Some(p) = &self.pixels {
            return Box::new(p.times.iter().zip(&p.count).filter(|c| *c.1 > 0).map(|(&t, &n)| (t, n)));
        }
        let hidden = self.total - self.pass_len;
        Box::new(
            self.slices.iter().enumerate().map(move |(i, &(t, n))| (t, if i == 0 { n - hidden } else { n })),
        )
    }

    /// The ages of the screen at time `now`.
    pub fn stats(&self, now: f64) -> AgeStats {
        let n = self.pass_len as f64;
        let mut ages: Vec<(f64, u64)> = self.on_screen().map(|(t, k)| (now - t, k)).collect();
        ages.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mean = ages.iter().map(|&(a, k)| a * k as f64).sum::<f64>() / n;
        // The youngest 90% (rounded up) of the positions.
        let want = (self.pass_len * 9).div_ceil(10);
        let mut seen = 0;
        let mut p90 = 0.0;
        for &(a, k) in &ages {
            seen += k;
            p90 = a;
            if seen >= want {
                break;
            }
        }
        AgeStats { mean, p90, max: ages.last().map_or(0.0, |a| a.0) }
    }

    /// Positions on screen traced with a camera of time `t0` or later.
    pub fn positions_since(&self, t0: f64) -> u64 {
        self.on_screen().filter(|&(t, _)| t >= t0).map(|(_, k)| k).sum()
    }

    /// The share of the screen that reflects an input at `t0`.
    pub fn fraction_since(&self, t0: f64) -> f64 {
        self.positions_since(t0) as f64 / self.pass_len as f64
    }
}

/// The latency levels: the first pixel, then 50%, 90% and 100% of the screen.
pub const LATENCY_LEVELS: [&str; 4] = ["first pixel", "50%", "90%", "100%"];

/// Input-to-screen latency over many inputs, in seconds: per level of [`LATENCY_LEVELS`], the
/// time from an input until the first present at which that much of the screen reflects it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LatencyStats {
    pub mean: [f64; 4],
    pub max: [f64; 4],
    /// Inputs measured (every one reached 100%).
    pub inputs: usize,
    /// Inputs still short of 100% when the measurement ended (not in the means).
    pub unfinished: usize,
}

/// Inputs (camera changes) waiting to reach the screen, and the latencies of those that have.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LatencyTracker {
    pending: Vec<(f64, [Option<f64>; 4])>,
    done: Vec<[f64; 4]>,
}

impl LatencyTracker {
    /// An input at time `t0` (before any present it is checked against).
    pub fn input(&mut self, t0: f64) {
        self.pending.push((t0, [None; 4]));
    }

    /// A present at `now` showing `screen`: every pending input takes the levels it reached.
    pub fn present(&mut self, now: f64, screen: &AgeTracker) {
        let n = screen.pass_len();
        let need = [1, n.div_ceil(2), (n * 9).div_ceil(10), n];
        for (t0, reached) in &mut self.pending {
            let k = screen.positions_since(*t0);
            for (r, &need) in reached.iter_mut().zip(&need) {
                if r.is_none() && k >= need {
                    *r = Some(now - *t0);
                }
            }
        }
        let done = &mut self.done;
        self.pending.retain(|(_, r)| match r {
            [Some(a), Some(b), Some(c), Some(d)] => {
                done.push([*a, *b, *c, *d]);
                false
            }
            _ => true,
        });
    }

    /// Inputs not yet wholly on screen.
    pub fn pending(&self) -> usize {
        self.pending.len()
    }

    /// Each finished input's latencies, in input order.
    pub fn latencies(&self) -> &[[f64; 4]] {
        &self.done
    }

    pub fn stats(&self) -> LatencyStats {
        let n = self.done.len().max(1) as f64;
        let mut s =
            LatencyStats { inputs: self.done.len(), unfinished: self.pending.len(), ..Default::default() };
        for l in &self.done {
            for (i, &x) in l.iter().enumerate() {
                s.mean[i] += x / n;
                s.max[i] = s.max[i].max(x);
            }
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A frameless run on the virtual clock: N positions, slices of S, each slice costing
    /// S × `c`, a present after every slice; a camera change at t = 0 (the first slice takes it).
    fn frameless_run(n: u64, s: u64, c: f64, slices: u64) -> (AgeTracker, LatencyTracker, Vec<AgeStats>) {
        let clock = Clock::Virtual { seconds_per_pixel: c };
        let mut screen = AgeTracker::new(n, -1.0);
        let mut latency = LatencyTracker::default();
        latency.input(0.0);
        let mut now = 0.0;
        let mut ages = Vec::new();
        let mut done = 0;
        for _ in 0..slices {
            let len = s.min(n - done % n);
            let report = StepReport { pixels: len, eye_rays: len, ..Default::default() };
            let t_camera = now;
            now += clock.cost(&report);
            screen.record_slice(t_camera, len);
            done += len;
            latency.present(now, &screen);
            ages.push(screen.stats(now));
        }
        (screen, latency, ages)
    }

    #[test]
    fn a_camera_change_reaches_the_screen_slice_by_slice() {
        // N = 1000 positions, S = 64 (not a divisor), 1 µs per pixel: a slice is 64 µs.
        let (n, s, c) = (1000u64, 64u64, 1e-6);
        let slice = s as f64 * c;
        let (_, latency, _) = frameless_run(n, s, c, 40);
        let l = latency.latencies();
        assert_eq!(l.len(), 1, "the change is wholly on screen after a pass");
        let slices = |k: u64| k as f64 * slice;
        assert!((l[0][0] - slices(1)).abs() < 1e-12, "first pixel after one slice: {:?}", l[0]);
        assert!((l[0][1] - slices((n / 2).div_ceil(s))).abs() < 1e-12, "50%: {:?}", l[0]);
        assert!((l[0][2] - slices((9 * n).div_ceil(10).div_ceil(s))).abs() < 1e-12, "90%: {:?}", l[0]);
        assert_eq!((9 * n).div_ceil(10).div_ceil(s), 15, "⌈0.9N/S⌉ slices");
        // 100%: 15 slices of 64 = 960, then a 40-position slice ends the pass.
        assert!((l[0][3] - (15.0 * slice + 40.0 * c)).abs() < 1e-12, "100%: {:?}", l[0]);
        let st = latency.stats();
        assert_eq!((st.inputs, st.unfinished), (1, 0));
    }

    #[test]
    fn frameless_ages_are_spread_over_a_pass() {
        // N = 4096, S = 64: 64 slices a pass. After a few passes, at a present right after a
        // slice, the screen holds one slice of each age 1…64 slice times: uniform, mean ≈ half a
        // pass, p90 ≈ 0.9 pass, max = one pass.
        let (n, s, c) = (4096u64, 64u64, 1e-6);
        let (slice, pass) = (s as f64 * c, n as f64 * c);
        let (screen, _, ages) = frameless_run(n, s, c, 64 * 3 + 17);
        let a = *ages.last().unwrap();
        assert!((a.mean - (pass / 2.0 + slice / 2.0)).abs() < 1e-12, "{a:?}");
        assert!((a.max - pass).abs() < 1e-12, "{a:?}");
        // 90% of 4096 = 3687 positions: the youngest ⌈3687/64⌉ = 58 slices.
        assert!((a.p90 - 58.0 * slice).abs() < 1e-12, "{a:?}");
        assert_eq!(screen.positions_since(f64::NEG_INFINITY), n);
        // Every present after the first pass looks the same.
        for b in &ages[64..] {
            assert!((b.mean - a.mean).abs() < 1e-9 && (b.max - a.max).abs() < 1e-9, "{b:?}");
        }
    }

    #[test]
    fn conventional_age_is_the_frame_time() {
        // Frames of 0.1 s back to back: at each present every pixel is one frame old.
        let mut screen = AgeTracker::new(640 * 480, 0.0);
        let mut latency = LatencyTracker::default();
        let frame = 0.1;
        // An input at 0.05, mid-frame: the frame in flight (started at 0) does not show it, the
        // next one (0.1 → 0.2) does, all at once.
        latency.input(0.05);
        for k in 0..5 {
            let start = k as f64 * frame;
            screen.record_frame(start);
            let now = start + frame;
            latency.present(now, &screen);
            let a = screen.stats(now);
            assert!((a.mean - frame).abs() < 1e-12 && a.p90 == a.mean && a.max == a.mean, "{a:?}");
            // Between presents the frame on screen keeps ageing.
            assert!((screen.stats(now + 0.05).mean - 0.15).abs() < 1e-12);
        }
        let l = latency.latencies()[0];
        for level in l {
            assert!((level - 0.15).abs() < 1e-12, "all levels together, 1.5 frames: {l:?}");
        }
    }

    #[test]
    fn a_partly_overwritten_slice_counts_what_is_left() {
        let mut t = AgeTracker::new(10, 0.0);
        t.record_slice(1.0, 4);
        assert_eq!(t.positions_since(0.0), 10);
        assert_eq!(t.positions_since(0.5), 4);
        t.record_slice(2.0, 4);
        t.record_slice(3.0, 4);
        // On screen: 2 of the slice at 1.0, 4 + 4 newer.
        assert_eq!(t.positions_since(1.0), 10);
        assert_eq!(t.positions_since(2.0), 8);
        let a = t.stats(3.0);
        assert!((a.mean - (2.0 * 2.0 + 4.0 * 1.0) / 10.0).abs() < 1e-12, "{a:?}");
        assert_eq!((a.p90, a.max), (2.0, 2.0));
        // A slice longer than the screen replaces it all.
        t.record_slice(4.0, 25);
        assert_eq!(t.stats(4.0), AgeStats::default());
    }

    /// Per pixel: a pixel traced twice counts once, at its newest time; pixels never traced
    /// keep the start's.
    #[test]
    fn per_pixel_ages_follow_each_pixel() {
        let mut a = AgeTracker::per_pixel(4, 0.0);
        a.record_pixels(1.0, &[0, 1]);
        a.record_pixels(2.0, &[1, 1]);
        assert_eq!(a.positions_since(1.0), 2);
        assert_eq!(a.positions_since(2.0), 1);
        assert_eq!(a.fraction_since(0.0), 1.0);
        let s = a.stats(3.0);
        assert_eq!((s.mean, s.max), ((2.0 + 1.0 + 3.0 + 3.0) / 4.0, 3.0));
        a.record_frame(2.5);
        assert_eq!(a.positions_since(2.5), 4);
    }

    #[test]
    fn clocks_parse_and_cost() {
        assert_eq!("real".parse::<Clock>().unwrap(), Clock::Real);
        let v: Clock = "virtual:250".parse().unwrap();
        let r = StepReport {
            eye_rays: 4000,
            trace_time: std::time::Duration::from_millis(3),
            ..Default::default()
        };
        assert!((v.cost(&r) - 1e-3).abs() < 1e-15);
        assert!((Clock::Real.cost(&r) - 3e-3).abs() < 1e-15);
        assert!("virtual:0".parse::<Clock>().is_err());
        assert!("virtual".parse::<Clock>().unwrap_err().to_string().contains("virtual:NS"));
    }
}
