//! Modes that fit the device they run on (docs/interactive.md, "Adapting to the device").
//!
//! - [`SliceControl`]: frameless rendering's slice size S, chosen slice by slice so that one
//!   slice's trace takes a set share of a display refresh. A fast GPU then traces as many pixels
//!   per refresh as it can and still presents at the display rate; lavapipe keeps slices short
//!   enough for its latency. The default S of lavapipe (`DEFAULT_SLICE`) is where it starts.
//! - [`ScheduleProbe`]: conventional frames' dispatch, the plain one or the tile queue, chosen by
//!   what the first frames cost on this device: the queue balances lavapipe's threads, a GPU's
//!   own scheduler makes it pure overhead.
//!
//! Both are plain state over measured durations (host time or timestamps), tested on a virtual
//! clock with cost models of a fast and a slow device.

use super::schedule::Schedule;
use super::{Mode, StepReport};
use std::time::Duration;

/// Frameless: the share of a refresh one slice should take by default. A quarter leaves room for
/// the present and for input between slices, and makes the present's deadline miss by at most a
/// quarter of a refresh when a slice runs long.
pub const SLICE_SHARE: f64 = 0.25;

/// Slice sizes are multiples of this (the Hilbert order's default chunk of 8×8 pixels).
pub const SLICE_QUANTUM: u32 = 64;

/// The slice size S of frameless rendering, fitted to a time per slice.
///
/// Slice time is close to affine in S, `t(S) = o + p·S` (a dispatch's floor `o`, a pixel's cost
/// `p`). The update `S ← S · target / t(S)` has its fixed point at `t(S) = target` and, for
/// `o < target`, moves towards it monotonically (the map's slope there is `o / target < 1`):
/// it settles without overshooting, so it cannot oscillate. Each step is limited to a factor
/// [`SliceControl::MAX_STEP`] so one outlier (a page fault, a compositor hiccup) moves S little,
/// and the measured time is smoothed in the log domain for the same reason.
#[derive(Clone, Debug)]
pub struct SliceControl {
    target: Duration,
    min: u32,
    max: u32,
    slice: u32,
    /// Smoothed log of (measured time / target) per unit of S, i.e. the log of the time a slice
    /// of the current S would take over the target; `None` before the first measurement.
    smoothed: Option<f64>,
}

impl SliceControl {
    /// Largest factor by which one measurement may change S.
    pub const MAX_STEP: f64 = 4.0;
    /// Weight of the newest measurement in the smoothed slice cost.
    const WEIGHT: f64 = 0.5;

    /// Slices of `start` pixels at first, aiming at `share` of `refresh`, never below `min` nor
    /// above `max` (the image's pixels: one slice a whole pass).
    pub fn new(refresh: Duration, share: f64, start: u32, min: u32, max: u32) -> SliceControl {
        let min = min.max(1).min(max.max(1));
        let max = max.max(min);
        SliceControl {
            target: refresh.mul_f64(share.clamp(0.01, 1.0)),
            min,
            max,
            slice: start.clamp(min, max),
            smoothed: None,
        }
    }

    /// The slice size to trace next.
    pub fn slice(&self) -> u32 {
        self.slice
    }

    /// The time one slice is aimed at.
    pub fn target(&self) -> Duration {
        self.target
    }

    /// Slices aim at `target` from now on (the smoothed cost is rescaled to it).
    pub fn set_target(&mut self, target: Duration) {
        let target = target.max(Duration::from_micros(1));
        if let Some(s) = &mut self.smoothed {
            *s += (self.target.as_secs_f64() / target.as_secs_f64()).ln();
        }
        self.target = target;
    }

    /// The largest S becomes `max` (the image was resized); S is kept within it.
    pub fn set_max(&mut self, max: u32) {
        self.max = max.max(self.min);
        let slice = self.slice.min(self.max);
        // The smoothed cost is of a slice of the current S: carried over to the new S.
        if let Some(s) = &mut self.smoothed {
            *s += (slice as f64 / self.slice as f64).ln();
        }
        self.slice = slice;
    }

    /// A slice of `pixels` took `took`: the size of the next.
    pub fn observe(&mut self, pixels: u32, took: Duration) -> u32 {
        if pixels == 0 || took.is_zero() {
            return self.slice;
        }
        // The measured slice's time, scaled to the current S (for S changed since it started),
        // over the target, in the log domain.
        let ratio = took.as_secs_f64() / self.target.as_secs_f64() * self.slice as f64 / pixels as f64;
        let sample = ratio.ln();
        let s = match self.smoothed {
            None => sample,
            Some(old) => old + Self::WEIGHT * (sample - old),
        };
        let step = (-s).clamp(-Self::MAX_STEP.ln(), Self::MAX_STEP.ln()).exp();
        let next = (self.slice as f64 * step).round();
        let quantised = ((next / SLICE_QUANTUM as f64).round() as u64 * SLICE_QUANTUM as u64).max(1);
        let next = (quantised.min(u32::MAX as u64) as u32).clamp(self.min, self.max);
        // What was smoothed is a cost at the old S: carry it over to the new S.
        self.smoothed = Some(s + (next as f64 / self.slice as f64).ln());
        self.slice = next;
        next
    }
}

/// Frames each schedule is timed for before the choice.
pub const PROBE_FRAMES: usize = 2;

/// The tile queue is kept only when it beats the plain dispatch by this factor: the plain
/// dispatch is the simpler (one dispatch, no atomic counter), and a tie is noise.
pub const QUEUE_MARGIN: f64 = 0.95;

/// Conventional frames: which dispatch suits this device, by timing the first frames with each
/// (alternately, so that a drift of the machine's speed touches both), then keeping the faster.
#[derive(Clone, Debug)]
pub struct ScheduleProbe {
    queue: Schedule,
    plain: Vec<Duration>,
    queued: Vec<Duration>,
    chosen: Option<Schedule>,
}

impl ScheduleProbe {
    /// A probe between the plain dispatch and `queue` (the queue's own schedule, e.g. RTRT's).
    pub fn new(queue: Schedule) -> ScheduleProbe {
        ScheduleProbe { queue, plain: Vec::new(), queued: Vec::new(), chosen: None }
    }

    /// The schedule of the next frame: alternately the two while probing, then the choice.
    pub fn next(&self) -> Schedule {
        self.chosen.unwrap_or(if self.plain.len() <= self.queued.len() {
            Schedule::Plain
        } else {
            self.queue
        })
    }

    /// The choice, once made.
    pub fn chosen(&self) -> Option<Schedule> {
        self.chosen
    }

    /// The queue's schedule, which the plain dispatch is timed against.
    pub fn queue(&self) -> Schedule {
        self.queue
    }

    /// The best frame time of the plain dispatch and of the queue, once both were timed.
    pub fn best(&self) -> Option<(Duration, Duration)> {
        Some((*self.plain.iter().min()?, *self.queued.iter().min()?))
    }

    /// A frame traced with `schedule` took `took` (a frame cancelled part-way is not reported).
    pub fn observe(&mut self, schedule: Schedule, took: Duration) {
        if self.chosen.is_some() {
            return;
        }
        match schedule {
            Schedule::Plain => self.plain.push(took),
            _ => self.queued.push(took),
        }
        if self.plain.len() >= PROBE_FRAMES && self.queued.len() >= PROBE_FRAMES {
            let best = |v: &[Duration]| v.iter().min().copied().unwrap_or_default().as_secs_f64();
            // The best of each: the first frames carry one-off costs (caches, page faults).
            let queue_wins = best(&self.queued) < QUEUE_MARGIN * best(&self.plain);
            self.chosen = Some(if queue_wins { self.queue } else { Schedule::Plain });
        }
    }
}

/// Frameless in the window: presents may take at most this share of the loop's time. Where a
/// present costs more than a refresh (lavapipe's software present of a large window: about 20 ms),
/// slices of a quarter of a refresh would leave the loop presenting most of the time; slices then
/// take three times a present instead ([`Adaptation::presented`]).
pub const PRESENT_SHARE: f64 = 0.25;

/// Presents whose cost is remembered; the cheapest is the present's cost (a present is never
/// faster than it, and the first ones carry one-off uploads).
const PRESENTS_KEPT: usize = 8;

/// The window's use of both: what it adapts while it runs, and what the user fixed (`--slice`,
/// `--schedule`). Frameless: S follows a [`SliceControl`] fed each slice's measured trace time.
/// Conventional: the first frames alternate the plain dispatch and the queue
/// ([`ScheduleProbe`]), timed whole (the trace time of all their steps), and the faster is kept.
/// The caller applies [`Adaptation::slice`] before each frameless step and
/// [`Adaptation::schedule`] between conventional frames; neither restarts the picture.
#[derive(Clone, Debug)]
pub struct Adaptation {
    /// `None`: S is fixed (given, or the mode is not the window's to change).
    control: Option<SliceControl>,
    /// `None`: the schedule is fixed.
    probe: Option<ScheduleProbe>,
    /// Conventional: the frame in flight (its camera version, schedule and trace time so far).
    frame: Option<(u64, Schedule, Duration)>,
    /// Pixels of the first frame timed: later frames' times are scaled to it, so that a resize
    /// during the probe does not decide it.
    probe_pixels: u64,
    /// The slice target a refresh gives ([`SLICE_SHARE`] of it), and the last presents' costs.
    refresh_target: Duration,
    presents: std::collections::VecDeque<Duration>,
}

impl Adaptation {
    /// Adapts S from `start` (aiming at [`SLICE_SHARE`] of `refresh`) unless `fixed_slice`, and
    /// probes the plain dispatch against `queue` unless `fixed_schedule`.
    pub fn new(
        refresh: Duration,
        start: u32,
        queue: Schedule,
        fixed_slice: bool,
        fixed_schedule: bool,
    ) -> Adaptation {
        let control =
            (!fixed_slice).then(|| SliceControl::new(refresh, SLICE_SHARE, start, SLICE_QUANTUM, u32::MAX));
        // Probing plain against plain would decide nothing.
        let probe = (!fixed_schedule && queue != Schedule::Plain).then(|| ScheduleProbe::new(queue));
        let refresh_target = refresh.mul_f64(SLICE_SHARE);
        Adaptation {
            control,
            probe,
            frame: None,
            probe_pixels: 0,
            refresh_target,
            presents: Default::default(),
        }
    }

    /// Nothing adapts (the MPI master's slicing is its own).
    pub fn fixed() -> Adaptation {
        Adaptation::new(Duration::from_millis(16), 1, Schedule::Plain, true, true)
    }

    /// A present (blit, HUD and the surface's present) took `took`: slices aim at the larger
    /// of [`SLICE_SHARE`] of a refresh and what keeps presents within [`PRESENT_SHARE`] of the
    /// loop's time (one slice per present, as when a present outlasts a refresh).
    pub fn presented(&mut self, took: Duration) {
        let Some(c) = &mut self.control else { return };
        if self.presents.len() == PRESENTS_KEPT {
            self.presents.pop_front();
        }
        self.presents.push_back(took);
        let present = self.presents.iter().min().copied().unwrap_or_default();
        let floor = present.mul_f64((1.0 - PRESENT_SHARE) / PRESENT_SHARE);
        let target = self.refresh_target.max(floor);
        // Small drifts of the present's cost are noise: the target moves by 10% or more.
        let ratio = target.as_secs_f64() / c.target().as_secs_f64();
        if !(0.9..=1.1).contains(&ratio) {
            c.set_target(target);
        }
    }

    /// Frameless: the slice size the next step should trace, when S adapts.
    pub fn slice(&self) -> Option<u32> {
        self.control.as_ref().map(SliceControl::slice)
    }

    /// Conventional: the schedule the next frame should use, when the schedule adapts.
    pub fn schedule(&self) -> Option<Schedule> {
        self.probe.as_ref().map(ScheduleProbe::next)
    }

    /// A step of `mode` ran; `pass_len`: positions in one frameless pass (the largest S).
    pub fn stepped(&mut self, mode: &Mode, pass_len: u64, r: &StepReport) {
        if r.idle {
            self.frame = None;
            return;
        }
        match *mode {
            Mode::Frameless { .. } => {
                if let (Some(c), Some(span)) = (&mut self.control, r.slice) {
                    c.set_max(pass_len.clamp(1, u32::MAX as u64) as u32);
                    c.observe(span.len.min(u32::MAX as u64) as u32, r.trace_time);
                }
            }
            Mode::Conventional { schedule, .. } => {
                let Some(probe) = &mut self.probe else { return };
                // A frame restarted (a new camera, size or settings) counts from its new start.
                let t = match self.frame {
                    Some((v, s, t)) if v == r.camera_version && s == schedule => t + r.trace_time,
                    _ => r.trace_time,
                };
                self.frame = Some((r.camera_version, schedule, t));
                if r.frame_done {
                    self.frame = None;
                    if self.probe_pixels == 0 {
                        self.probe_pixels = r.pixels.max(1);
                    }
                    let scaled = t.mul_f64(self.probe_pixels as f64 / r.pixels.max(1) as f64);
                    probe.observe(schedule, scaled);
                }
            }
            Mode::Bands => {}
        }
    }

    /// The HUD's words for how `mode`'s slice size or schedule came about.
    pub fn describe(&self, mode: &Mode) -> String {
        match *mode {
            Mode::Frameless { slice, .. } => match &self.control {
                Some(c) => format!(
                    "S = {slice} pixels a slice (adapting: {:.1} ms a slice)",
                    c.target().as_secs_f64() * 1e3
                ),
                None => format!("S = {slice} pixels a slice (fixed)"),
            },
            Mode::Conventional { schedule, .. } => match &self.probe {
                None => format!("schedule {schedule} (fixed)"),
                Some(p) => match (p.chosen(), p.best()) {
                    (Some(_), Some((plain, queue))) => format!(
                        "schedule {schedule} (chosen: plain {:.1} ms, {} {:.1} ms a frame)",
                        plain.as_secs_f64() * 1e3,
                        p.queue(),
                        queue.as_secs_f64() * 1e3
                    ),
                    _ => format!("schedule {schedule} (timing plain against {})", p.queue()),
                },
            },
            Mode::Bands => "bands".into(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A device's slice time: a dispatch floor and a cost per pixel, with ±`noise` deterministic
    /// jitter.
    struct Device {
        floor: f64,
        per_pixel: f64,
        noise: f64,
        seed: u64,
    }

    impl Device {
        fn slice(&mut self, pixels: u32) -> Duration {
            self.seed = self.seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            let u = (self.seed >> 11) as f64 / (1u64 << 53) as f64; // [0, 1)
            let t = (self.floor + self.per_pixel * pixels as f64) * (1.0 + self.noise * (2.0 * u - 1.0));
            Duration::from_secs_f64(t)
        }
    }

    const REFRESH: Duration = Duration::from_nanos(16_666_667);
    const HD: u32 = 1280 * 720;

    /// A fast GPU (2 ns a pixel, 50 µs a dispatch) and lavapipe on two cores (700 ns, 200 µs).
    fn fast() -> Device {
        Device { floor: 50e-6, per_pixel: 2e-9, noise: 0.05, seed: 1 }
    }
    fn slow() -> Device {
        Device { floor: 200e-6, per_pixel: 700e-9, noise: 0.05, seed: 2 }
    }

    /// Runs a frameless host loop on virtual time for `seconds`: a slice starts while the time
    /// to the next refresh holds the target with 10% to spare, then the present waits for that
    /// refresh (FIFO). Returns (S per slice, refreshes missed: presents after their refresh).
    fn run(device: &mut Device, control: &mut SliceControl, seconds: f64) -> (Vec<u32>, usize) {
        let refresh = REFRESH.as_secs_f64();
        let (mut now, mut vsync) = (0.0, refresh);
        let (mut sizes, mut missed) = (Vec::new(), 0);
        while now < seconds {
            while vsync - now >= 1.1 * control.target().as_secs_f64() {
                let s = control.slice();
                let took = device.slice(s);
                control.observe(s, took);
                sizes.push(s);
                now += took.as_secs_f64();
            }
            if now > vsync {
                missed += 1;
            }
            now = now.max(vsync);
            while vsync <= now {
                vsync += refresh;
            }
        }
        (sizes, missed)
    }

    #[test]
    fn a_slow_device_settles_on_the_share_of_a_refresh_without_oscillating() {
        let mut device = slow();
        let mut c = SliceControl::new(REFRESH, SLICE_SHARE, 16_384, SLICE_QUANTUM, HD);
        let (sizes, missed) = run(&mut device, &mut c, 5.0);
        // The fixed point: 200 µs + 700 ns · S = 4.17 ms, S ≈ 5,650.
        let ideal = (REFRESH.as_secs_f64() * SLICE_SHARE - 200e-6) / 700e-9;
        // Settled within 6 slices (starting 3x too large), to within the noise (±5%) and then some.
        for (i, &s) in sizes.iter().enumerate().skip(6) {
            assert!((s as f64 / ideal - 1.0).abs() < 0.12, "slice {i}: S = {s}, ideal {ideal:.0}");
        }
        // No oscillation: after settling, S never swings by more than 10% from one slice to the next.
        for w in sizes[6..].windows(2) {
            assert!((w[1] as f64 / w[0] as f64 - 1.0).abs() < 0.10, "{w:?}");
        }
        // Presents at the display rate: a refresh missed only while S was still too large.
        assert!(missed <= 3, "{missed} refreshes missed of 300");
    }

    #[test]
    fn a_fast_device_traces_whole_passes_and_keeps_the_display_rate() {
        let mut device = fast();
        let mut c = SliceControl::new(REFRESH, SLICE_SHARE, 16_384, SLICE_QUANTUM, HD);
        let (sizes, missed) = run(&mut device, &mut c, 2.0);
        // 50 µs + 2 ns · 921,600 = 1.9 ms < 4.17 ms: the whole image per slice, reached within 5
        // slices by steps of at most 4x from 16,384 (16 K → 64 K → 256 K → 922 K).
        assert!(sizes[5..].iter().all(|&s| s == HD), "{:?}", &sizes[..8]);
        // Several whole passes a refresh (slices of 1.9 ms while 12.5 ms are left): with the
        // lavapipe default S = 16,384 a refresh would hold 16,384 · (12.5 ms / 83 µs) ≈ 2.5 M.
        let per_refresh = sizes[5..].iter().map(|&s| s as f64).sum::<f64>() / 2.0 / 60.0;
        assert!(per_refresh > 5.0 * HD as f64, "{per_refresh} pixels a refresh");
        assert_eq!(missed, 0, "refreshes missed");
    }

    #[test]
    fn a_slow_device_at_4k_settles_below_the_image_and_an_outlier_moves_s_little() {
        let mut device = slow();
        let mut c = SliceControl::new(REFRESH, SLICE_SHARE, 16_384, SLICE_QUANTUM, 3840 * 2160);
        for _ in 0..20 {
            let s = c.slice();
            c.observe(s, device.slice(s));
        }
        let settled = c.slice();
        // One slice 20x slower than it should be (a page fault storm): S drops by at most the
        // smoothing's share of it, not to the floor.
        c.observe(settled, device.slice(settled) * 20);
        assert!(
            c.slice() as f64 > settled as f64 / SliceControl::MAX_STEP - 1.0,
            "{} after {settled}",
            c.slice()
        );
        for _ in 0..10 {
            let s = c.slice();
            c.observe(s, device.slice(s));
        }
        assert!((c.slice() as f64 / settled as f64 - 1.0).abs() < 0.12, "{} vs {settled}", c.slice());
    }

    #[test]
    fn slices_stay_within_their_bounds() {
        let mut c = SliceControl::new(REFRESH, SLICE_SHARE, 10, 256, 1000);
        assert_eq!(c.slice(), 256);
        c.observe(256, Duration::from_secs(10));
        assert_eq!(c.slice(), 256);
        c.observe(256, Duration::from_nanos(1));
        assert_eq!(c.slice(), 1000);
        c.observe(0, Duration::ZERO);
        assert_eq!(c.slice(), 1000);
    }

    /// Frame times of the plain dispatch and the queue on a device (the probe sees them in turn).
    fn probe(plain: f64, queue: f64) -> Schedule {
        let rtrt = Schedule::default();
        let mut p = ScheduleProbe::new(rtrt);
        let mut frames = 0;
        while p.chosen().is_none() {
            let s = p.next();
            // The first frame of each carries a one-off cost.
            let first = if frames < 2 { 3.0 } else { 1.0 };
            p.observe(s, Duration::from_secs_f64(first * if s == Schedule::Plain { plain } else { queue }));
            frames += 1;
            assert!(frames <= 2 * PROBE_FRAMES, "probing never ends");
        }
        assert_eq!(p.next(), p.chosen().unwrap());
        p.chosen().unwrap()
    }

    #[test]
    fn the_probe_keeps_the_queue_on_lavapipe_and_the_plain_dispatch_on_a_gpu() {
        // H200 at 512² (docs/interactive.md, "On a GPU"): plain 0.4 ms, the queue 2.3–3.3 ms.
        assert_eq!(probe(0.4e-3, 2.3e-3), Schedule::Plain);
        // Lavapipe, 2 threads, 512² (docs/interactive.md, the schedule table): the default
        // scene's queue 96–115 ms against plain 102–114 — the queue, by its best frames; balls_s2's
        // 207–223 against plain 172–176 — plain, whose halves are balanced already.
        assert_eq!(probe(114e-3, 96e-3), Schedule::default());
        assert_eq!(probe(173e-3, 223e-3), Schedule::Plain);
        // A tie keeps the simpler plain dispatch.
        assert_eq!(probe(100e-3, 98e-3), Schedule::Plain);
    }

    /// A conventional frame of `waves` steps, `frame` long in all, at camera version `version`.
    fn frame_steps(waves: u32, frame: Duration, pixels: u64, version: u64) -> Vec<StepReport> {
        (1..=waves)
            .map(|i| StepReport {
                pixels: if i == waves { pixels } else { 0 },
                trace_time: frame / waves,
                frame_done: i == waves,
                camera_version: version,
                ..Default::default()
            })
            .collect()
    }

    /// Runs the window's conventional loop on frame times `plain` and `queue` (seconds): each
    /// frame takes the schedule the adaptation asks for. Returns the schedule after 8 frames.
    fn window_probe(plain: f64, queue: f64) -> (Schedule, Adaptation) {
        let mut a = Adaptation::new(REFRESH, 16_384, Schedule::default(), false, false);
        let mut mode = Mode::conventional();
        // A frame cancelled after two of its waves by a camera move: not counted.
        for r in &frame_steps(4, Duration::from_millis(1), 512 * 512, 1)[..2] {
            a.stepped(&mode, 512 * 512, r);
        }
        for _ in 0..8 {
            let schedule = a.schedule().expect("the schedule adapts");
            mode = Mode::Conventional { schedule, workers: 0 };
            let t = if schedule == Schedule::Plain { plain } else { queue };
            for r in frame_steps(4, Duration::from_secs_f64(t), 512 * 512, 2) {
                a.stepped(&mode, 512 * 512, &r);
            }
        }
        (a.schedule().unwrap(), a)
    }

    #[test]
    fn the_window_keeps_the_faster_schedule_timed_over_whole_frames() {
        // H200 at 512²: the plain dispatch; lavapipe on the default scene: the queue.
        let (gpu, a) = window_probe(0.4e-3, 2.3e-3);
        assert_eq!(gpu, Schedule::Plain);
        // Whole frames were timed (4 waves each), not the cancelled frame's 1 ms.
        assert_eq!(
            a.probe.as_ref().unwrap().best(),
            Some((Duration::from_micros(400), Duration::from_micros(2300)))
        );
        let mode = Mode::Conventional { schedule: Schedule::Plain, workers: 0 };
        assert_eq!(a.describe(&mode), "schedule plain (chosen: plain 0.4 ms, rtrt:40 2.3 ms a frame)");
        assert_eq!(window_probe(114e-3, 96e-3).0, Schedule::default());
        // Given on the command line, or the MPI master's: nothing is probed.
        let fixed = Adaptation::new(REFRESH, 16_384, Schedule::default(), false, true);
        assert_eq!(fixed.schedule(), None);
        assert_eq!(fixed.describe(&Mode::conventional()), "schedule rtrt:40 (fixed)");
        assert_eq!(Adaptation::fixed().schedule(), None);
        // A probe of plain against plain decides nothing: not run.
        assert_eq!(Adaptation::new(REFRESH, 16_384, Schedule::Plain, false, false).schedule(), None);
    }

    /// The window's frameless loop: S as the adaptation says before each step, the step's
    /// measured trace time back into it, on the two cost models; the image shrinks half-way.
    #[test]
    fn the_window_s_slices_settle_on_both_devices_and_follow_a_resize() {
        for (mut device, ideal) in
            [(slow(), (REFRESH.as_secs_f64() * SLICE_SHARE - 200e-6) / 700e-9), (fast(), HD as f64)]
        {
            let mut a = Adaptation::new(REFRESH, 16_384, Schedule::default(), false, false);
            let mut mode = Mode::frameless();
            let mut pass = HD as u64;
            for i in 0..40 {
                if i == 20 {
                    // Resized to 640×360: S at most the new image.
                    pass = 640 * 360;
                }
                let s = a.slice().expect("S adapts");
                if let Mode::Frameless { slice, .. } = &mut mode {
                    *slice = s;
                }
                let len = (s as u64).min(pass);
                let r = StepReport {
                    pixels: len,
                    trace_time: device.slice(len as u32),
                    slice: Some(crate::render::SliceSpan { first: 0, len }),
                    ..Default::default()
                };
                a.stepped(&mode, pass, &r);
                let s = a.slice().unwrap() as f64;
                let want = ideal.min(pass as f64);
                if (8..20).contains(&i) || i >= 28 {
                    assert!((s / want - 1.0).abs() < 0.12, "step {i}: S = {s}, ideal {want:.0}");
                }
                assert!(s <= pass as f64, "step {i}: S = {s} over the image's {pass}");
            }
            assert!(a.describe(&mode).contains("(adapting: 4.2 ms a slice)"), "{}", a.describe(&mode));
        }
        let fixed = Adaptation::new(REFRESH, 1000, Schedule::default(), true, false);
        assert_eq!(fixed.slice(), None);
        assert_eq!(fixed.describe(&Mode::frameless()), "S = 16384 pixels a slice (fixed)");
    }

    /// The window's frameless loop with its presents: the host loop's rule (present after the
    /// step in which a refresh fell due) on a virtual clock, each present costing `present`.
    /// Returns (the tracing share of the last second, presents in it, S at the end).
    fn window_loop(device: &mut Device, present: Duration, feed_presents: bool) -> (f64, u32, u32) {
        use crate::render::{Cancel, HostLoop};
        let mut a = Adaptation::new(REFRESH, 16_384, Schedule::default(), false, false);
        let mut host = HostLoop::new(REFRESH.as_secs_f64(), 0, Cancel::FirstWave);
        let (mut now, mut traced, mut presents) = (0.0, 0.0, 0);
        while now < 4.0 {
            let s = a.slice().unwrap();
            let took = device.slice(s);
            let r = StepReport {
                pixels: s as u64,
                trace_time: took,
                slice: Some(crate::render::SliceSpan { first: 0, len: s as u64 }),
                ..Default::default()
            };
            a.stepped(&Mode::frameless(), HD as u64, &r);
            now += took.as_secs_f64();
            if now > 3.0 {
                traced += took.as_secs_f64();
            }
            if host.stepped(now, false, &r) {
                now += present.as_secs_f64();
                if feed_presents {
                    a.presented(present);
                }
                host.presented(now);
                presents += (now > 3.0) as u32;
            }
        }
        // The last second or so: from 3 s to the end of the step or present that crossed 4 s.
        let span = now - 3.0;
        (traced / span, (presents as f64 / span).round() as u32, a.slice().unwrap())
    }

    /// Lavapipe's software present (20 ms at 1280×720) is longer than a refresh: slices of a
    /// quarter of a refresh would leave the loop presenting most of the time (tracing ~40%); the
    /// slices grow to three presents, and tracing takes about three quarters of the time. A fast
    /// device's cheap present (0.3 ms) leaves the refresh's target as it was.
    #[test]
    fn an_expensive_present_makes_slices_long_enough_to_keep_tracing() {
        let (share, presents, s) = window_loop(&mut slow(), Duration::from_millis(20), true);
        eprintln!("slow, 20 ms presents: tracing {:.1}%, {presents} presents/s, S = {s}", share * 100.0);
        assert!(share > 0.7, "tracing {:.0}% of the time", share * 100.0);
        // The slice's time: 60 ms, at 200 µs + 700 ns a pixel.
        let ideal = (0.060 - 200e-6) / 700e-9;
        assert!((s as f64 / ideal - 1.0).abs() < 0.12, "S = {s}, ideal {ideal:.0}");
        assert!((10..=14).contains(&presents), "{presents} presents a second");
        // Without the present's floor (the refresh's target only) the same loop traces a fraction.
        let (share, p, s) = window_loop(&mut slow(), Duration::from_millis(20), false);
        eprintln!("without the floor: tracing {:.1}%, {p} presents/s, S = {s}", share * 100.0);
        assert!(share < 0.5, "tracing {:.0}% of the time without the floor", share * 100.0);
        let (_, presents, s) = window_loop(&mut fast(), Duration::from_micros(300), true);
        assert_eq!(s, HD, "the fast device traces whole passes");
        assert!(presents >= 55, "{presents} presents a second");
        let mut a = Adaptation::new(REFRESH, 16_384, Schedule::default(), false, false);
        a.presented(Duration::from_micros(300));
        assert_eq!(a.control.as_ref().unwrap().target(), REFRESH.mul_f64(SLICE_SHARE));
        // The first presents' one-off cost does not stay: the cheapest of the last 8 counts.
        a.presented(Duration::from_millis(200));
        for _ in 0..8 {
            a.presented(Duration::from_millis(20));
        }
        assert_eq!(a.control.as_ref().unwrap().target(), Duration::from_millis(60));
    }
}
