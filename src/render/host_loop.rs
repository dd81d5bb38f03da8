//! The host loop's policy: when a new camera is taken, when a conventional frame in flight is
//! cancelled or finished first, and when a picture is presented. One policy, driven by the
//! caller's clock in seconds: the window runs it on wall time (src/app/viewer.rs), `irt replay`
//! on a real or virtual [`super::metrics::Clock`] (src/render/replay.rs), so what replay
//! measures is what the window does.
//!
//! - **Frameless**: every step traces with the newest camera; a picture is presented after the
//!   step in which a display refresh fell due (refreshes every `period` seconds from t = 0), or
//!   after exactly `present_every` slices when that is set. At least one slice per present.
//! - **Conventional** (and bands): a picture is presented when its frame is whole. A new
//!   camera is taken between frames; during a frame, [`Cancel`] says whether it cancels it.

use super::StepReport;
use std::time::Duration;

/// The window's display interval: frameless presents about this often.
pub const FRAME_BUDGET: Duration = Duration::from_millis(16);

/// What a new camera does to a conventional frame in flight.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Cancel {
    /// It cancels the frame if at most one wave of it is traced and no frame was cancelled
    /// since the last present; otherwise the frame is finished first. A sporadic move so shows
    /// up to a frame sooner, while a continuous drag (on a CPU device input comes faster than
    /// waves) cannot cancel every frame and freeze the screen: a picture comes at least every
    /// frame time plus one wave. The window's rule.
    FirstWave,
    /// Never: a frame takes the camera of the time it starts (RTRT's master read input between
    /// frames). What `irt replay` measures conventional frames with.
    Never,
}

/// The policy's state: the refresh grid, the frame in flight, the slices since the last
/// present.
#[derive(Clone, Debug)]
pub struct HostLoop {
    period: f64,
    present_every: u32,
    cancel: Cancel,
    next_refresh: f64,
    slices: u32,
    waves: u32,
    cancelled: bool,
}

impl HostLoop {
    /// Refreshes every `period` seconds of the caller's clock; frameless presents after exactly
    /// `present_every` slices instead when it is above 0.
    pub fn new(period: f64, present_every: u32, cancel: Cancel) -> Self {
        HostLoop {
            period,
            present_every,
            cancel,
            next_refresh: period,
            slices: 0,
            waves: 0,
            cancelled: false,
        }
    }

    /// Frameless: present after exactly this many slices (0: at the refreshes).
    pub fn set_present_every(&mut self, n: u32) {
        self.present_every = n;
    }

    /// The display's next refresh instant.
    pub fn next_refresh(&self) -> f64 {
        self.next_refresh
    }

    /// The refresh at [`Self::next_refresh`] is counted; the next one is a period later.
    pub fn refreshed(&mut self) {
        self.next_refresh += self.period;
    }

    /// Conventional: whether a frame is in flight (some of its waves traced).
    pub fn in_frame(&self) -> bool {
        self.waves > 0
    }

    /// Conventional: waves traced of the frame in flight.
    pub fn waves(&self) -> u32 {
        self.waves
    }

    /// Whether the session takes a new camera (or time) now. `conventional`: the mode hands out
    /// whole frames; `changed`: the input differs from what the session traces. Frameless:
    /// always. Conventional: between frames; during one, as [`Cancel`] says — taking it cancels
    /// the frame in flight (the session restarts it), which this records.
    pub fn take_input(&mut self, conventional: bool, changed: bool) -> bool {
        if !conventional || self.waves == 0 {
            return true;
        }
        let cancel = changed
            && match self.cancel {
                Cancel::FirstWave => self.waves <= 1 && !self.cancelled,
                Cancel::Never => false,
            };
        if cancel {
            self.cancelled = true;
            self.waves = 0;
        }
        cancel
    }

    /// The frame in flight was restarted (new settings, size, scene or time): its waves so far
    /// count for nothing.
    pub fn restart(&mut self) {
        self.waves = 0;
    }

    /// After a step that ended at `now`: whether a picture is presented now.
    pub fn stepped(&mut self, now: f64, conventional: bool, r: &StepReport) -> bool {
        if r.idle {
            self.waves = 0;
            return false;
        }
        if conventional {
            self.waves = if r.frame_done { 0 } else { self.waves + 1 };
            return r.frame_done;
        }
        self.slices += 1;
        if self.present_every > 0 {
            self.slices >= self.present_every
        } else {
            now >= self.next_refresh
        }
    }

    /// A picture was presented at `now`: the refreshes up to it are spent.
    pub fn presented(&mut self, now: f64) {
        self.cancelled = false;
        self.slices = 0;
        while self.next_refresh <= now {
            self.next_refresh += self.period;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn step(frame_done: bool) -> StepReport {
        StepReport { frame_done, pixels: 1, eye_rays: 1, ..Default::default() }
    }

    /// Frameless on a virtual clock (in milliseconds, exact in f64): slices of 3 ms against a
    /// 16 ms refresh present after the step that crosses each refresh.
    #[test]
    fn frameless_presents_at_the_refreshes() {
        let mut h = HostLoop::new(16.0, 0, Cancel::FirstWave);
        let mut presents = Vec::new();
        let mut now = 0.0;
        for _ in 0..40 {
            now += 3.0;
            if h.stepped(now, false, &step(false)) {
                presents.push(now);
                h.presented(now);
            }
        }
        assert_eq!(presents, [18.0, 33.0, 48.0, 66.0, 81.0, 96.0, 114.0]);
        // A slow slice (40 ms) presents after every slice, and the grid skips the refreshes
        // it missed.
        now += 40.0;
        assert!(h.stepped(now, false, &step(false)));
        h.presented(now);
        assert_eq!(h.next_refresh(), 176.0);
    }

    #[test]
    fn present_every_counts_slices() {
        let mut h = HostLoop::new(0.016, 3, Cancel::FirstWave);
        let shown: Vec<bool> = (0..6).map(|i| h.stepped(i as f64, false, &step(false))).collect();
        assert_eq!(shown, [false, false, true, true, true, true]);
        h.presented(6.0);
        assert!(!h.stepped(7.0, false, &step(false)));
    }

    /// The window's rule: a move cancels a frame at its first wave, once per present; later it
    /// waits for the frame to finish. Replay's rule never cancels.
    #[test]
    fn conventional_frames_cancel_once_per_present_at_most() {
        let mut h = HostLoop::new(0.016, 0, Cancel::FirstWave);
        assert!(h.take_input(true, true), "between frames the camera is taken");
        assert!(!h.stepped(0.01, true, &step(false)));
        assert!(!h.take_input(true, false), "no change, nothing taken");
        assert!(h.take_input(true, true), "one wave in: cancelled");
        assert!(!h.in_frame());
        assert!(!h.stepped(0.02, true, &step(false)));
        assert!(!h.take_input(true, true), "a frame was cancelled since the last present: held");
        assert!(!h.stepped(0.03, true, &step(false)));
        assert!(h.stepped(0.04, true, &step(true)));
        h.presented(0.04);
        assert!(h.take_input(true, true));
        assert!(!h.stepped(0.05, true, &step(false)));
        assert!(h.take_input(true, true), "after a present a first-wave frame cancels again");
        assert!(!h.stepped(0.06, true, &step(false)));
        assert!(!h.stepped(0.07, true, &step(false)));
        assert!(!h.take_input(true, true), "two waves in: held");

        let mut r = HostLoop::new(0.016, 0, Cancel::Never);
        assert!(!r.stepped(0.01, true, &step(false)));
        assert!(!r.take_input(true, true));
        assert!(r.take_input(false, true), "frameless always takes the camera");
    }

    #[test]
    fn idle_steps_end_the_frame_and_present_nothing() {
        let mut h = HostLoop::new(0.016, 0, Cancel::FirstWave);
        assert!(!h.stepped(0.01, true, &step(false)));
        assert!(h.in_frame());
        assert!(!h.stepped(1.0, true, &StepReport { idle: true, ..Default::default() }));
        assert!(!h.in_frame());
    }
}
