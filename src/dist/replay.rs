//! `irt replay PATH --mpi`: the replay's loop (src/render/replay.rs) on rank 0, with the pixels
//! traced by the worker ranks. A step is one [`Master::pump`]; its pieces reach the screen with
//! the state version they were traced with, which maps back to the clock time that state was
//! read at, so pixel age and latency are measured as in one process.
//!
//! The clock is the wall time of the pumps (a real clock): the round trip to the workers, the
//! pieces in flight and rank 0's own work are all part of what the path measures. A virtual
//! clock charges traced pixels and would hide exactly that.

use super::master::{Master, MasterError};
use crate::image::Image;
use crate::render::replay::{Landed, ReplayError, Source};
use crate::render::{Settings, StepReport};
use crate::scene::Camera;
use std::collections::BTreeMap;
use std::time::{Duration, Instant};

/// The longest a step waits for pixels: short against a display refresh, so that presents fall
/// close to their instants when nothing comes back.
const PUMP_WAIT: Duration = Duration::from_millis(2);

/// A replay's [`Source`] on the master of a job.
pub struct MasterSource<'m, 'c> {
    master: &'m mut Master<'c>,
    settings: Settings,
    /// The clock time each state version was read at (pieces still on their way may carry an
    /// older one).
    read_at: BTreeMap<u64, f64>,
    /// Set when the master failed: the caller ends the job with it.
    pub failure: Option<MasterError>,
}

impl<'m, 'c> MasterSource<'m, 'c> {
    /// `master` already started with the scene posed at the path's first camera.
    pub fn new(master: &'m mut Master<'c>) -> Self {
        // The settings as the master split them for the ranks: every state sent keeps them.
        let settings = master.settings().clone();
        let read_at = BTreeMap::from([(master.version(), 0.0)]);
        MasterSource { master, settings, read_at, failure: None }
    }

    fn fail(&mut self, e: MasterError) -> ReplayError {
        let words = e.to_string();
        self.failure = Some(e);
        ReplayError::Distributed(words)
    }

    /// The clock time of state `version`: when it was read, or the newest before it.
    fn time_of(&self, version: u64) -> f64 {
        self.read_at.range(..=version).next_back().map_or(0.0, |(_, &t)| t)
    }
}

impl Source for MasterSource<'_, '_> {
    fn pass_len(&self) -> u64 {
        self.master.pass_len()
    }

    fn warm_start(&mut self) -> Result<(), ReplayError> {
        // The first camera's whole picture: a pass of positions or a frame back (or every
        // sample the settings ask for).
        let (mut covered, whole) = (0, self.master.pass_len());
        while covered < whole && !self.master.done() {
            let (_, applied) =
                self.master.pump_applied(Duration::from_millis(50)).map_err(|e| self.fail(e))?;
            covered += applied.iter().map(|a| if a.frame { whole } else { a.positions }).sum::<u64>();
        }
        Ok(())
    }

    fn take_state(&mut self, camera: &Camera, time: Option<f64>, t: f64) -> Result<Duration, ReplayError> {
        let start = Instant::now();
        let before = self.master.version();
        self.master.set_state(camera, &self.settings, time.unwrap_or(0.0)).map_err(|e| self.fail(e))?;
        if self.master.version() != before {
            self.read_at.insert(self.master.version(), t);
        }
        // Sending the state is the host's work before the step.
        Ok(start.elapsed())
    }

    fn step(&mut self, landed: &mut Vec<Landed>) -> Result<StepReport, ReplayError> {
        let (mut report, applied) = self.master.pump_applied(PUMP_WAIT).map_err(|e| self.fail(e))?;
        // The pump that brings the last piece back also finds the master done: it is a step
        // with pixels (the next one is idle), as a session's last slice is.
        report.idle &= applied.is_empty();
        for a in applied {
            let t = self.time_of(a.state);
            landed.push(match a.frame {
                true => Landed::Frame { t },
                false => Landed::Slice { t, positions: a.positions },
            });
        }
        Ok(report)
    }

    fn image(&mut self) -> Result<Image, ReplayError> {
        Ok(self.master.frame().image())
    }

    fn ideal(&mut self, _camera: &Camera, _t: f64) -> Result<Image, ReplayError> {
        Err(ReplayError::Distributed(
            "the dynamic error needs a device on rank 0: drop --error-every with --mpi".into(),
        ))
    }

    fn device(&self) -> String {
        format!("{} MPI workers on {}", self.master.workers(), self.master.device_summary())
    }
}
