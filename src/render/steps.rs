//! One unit of work of each mode, on a [`Session`]: the bands' frame, a wave of the conventional
//! tile queue, a frameless slice (the adaptive order's too), each a recording of `render::modes`
//! run on the session's device path.

use super::modes::{self, Queue, SliceSpan};
use super::session::{ModeState, Session, StepReport};
use super::Mode;
use crate::gpu::device::{BoundKernel, Device};
use crate::gpu::layout::OUT_COMPACT;
use crate::gpu::recording::Recording;
use std::time::{Duration, Instant};

impl<D: Device> Session<D> {
    /// One unit of work: the bands' frame, a wave of the conventional frame, or one frameless
    /// slice.
    pub fn try_step(&mut self, ctx: &D) -> Result<StepReport, D::Error> {
        if self.converged() {
            return Ok(StepReport { idle: true, camera_version: self.camera_version, ..Default::default() });
        }
        if !self.whole() {
            return Err(self.too_large().into());
        }
        self.restore_work(ctx)?;
        if self.samples > 0 {
            self.reorder(ctx, true);
        }
        let report = match self.state.clone() {
            ModeState::Bands { band_pixels } => self.step_bands(ctx, band_pixels, &mut |_, _| {}),
            ModeState::Queue { queue, in_flight } => self.step_queue(ctx, queue, in_flight),
            ModeState::Slices(_) => self.step_frameless(ctx),
        }?;
        self.first_traced(ctx);
        Ok(report)
    }

    /// Drivers that compile at the first dispatch (lavapipe) fill a pipeline cache only after
    /// the first frame: it is saved then, once.
    pub(super) fn first_traced(&mut self, ctx: &D) {
        if !self.compiled {
            self.compiled = true;
            ctx.pipelines_compiled();
        }
    }

    /// Runs steps until the current frame or frameless pass is complete (or refinement
    /// converged): one whole picture, what the headless commands write.
    pub fn try_complete_pass(&mut self, ctx: &D) -> Result<Duration, D::Error> {
        let mut t = Duration::ZERO;
        loop {
            let r = self.try_step(ctx)?;
            t += r.trace_time;
            if r.frame_done || r.idle {
                return Ok(t);
            }
        }
    }

    /// Runs `rec` on the session's kernel.
    pub(super) fn run(
        &self,
        ctx: &D,
        rec: &Recording,
        progress: &mut dyn FnMut(u32, u32),
    ) -> Result<(), D::Error> {
        self.bound(ctx).run(rec, progress)
    }

    /// A frame in bands of rows: the bands mode's picture, or the conventional plain schedule's
    /// frame (then resolved into the frame buffer).
    pub(super) fn step_bands(
        &mut self,
        ctx: &D,
        band_pixels: u32,
        progress: &mut dyn FnMut(u32, u32),
    ) -> Result<StepReport, D::Error> {
        let k = self.samples;
        let bands = self.bands(band_pixels);
        let t0 = Instant::now();
        self.run(ctx, &bands.recording(modes::frame_sample(k)), progress)?;
        if self.settings.mode != Mode::Bands {
            return self.finish_frame(ctx, t0.elapsed());
        }
        self.samples += 1;
        let [cols, rows] = bands.grid_size;
        Ok(StepReport {
            pixels: self.pixels(),
            eye_rays: cols as u64 * rows as u64,
            trace_time: t0.elapsed(),
            frame_done: true,
            camera_version: self.camera_version,
            ..Default::default()
        })
    }

    /// A wave of the conventional tile queue.
    fn step_queue(&mut self, ctx: &D, queue: Queue, in_flight: bool) -> Result<StepReport, D::Error> {
        let k = self.samples;
        let sample = modes::frame_sample(k);
        let split = self.passes.len() > 1;
        let t0 = Instant::now();
        let mut done = true;
        for &pass in &self.passes {
            let mut restart = split || !in_flight;
            loop {
                // One wave; the queue's counter carries over between waves. A split bundle's
                // passes each walk the whole queue here (waves would interleave passes).
                self.run(ctx, &queue.wave(pass, sample, restart), &mut |_, _| {})?;
                done = self.bound(ctx).read_queue()? >= queue.chunks;
                if done || !split {
                    break;
                }
                restart = false;
            }
        }
        self.state = ModeState::Queue { queue, in_flight: !done };
        if done {
            return self.finish_frame(ctx, t0.elapsed());
        }
        Ok(StepReport { trace_time: t0.elapsed(), camera_version: self.camera_version, ..Default::default() })
    }

    /// A conventional frame is whole: into the frame buffer (a first sample replaces, later
    /// ones add).
    fn finish_frame(&mut self, ctx: &D, trace_time: Duration) -> Result<StepReport, D::Error> {
        let k = self.samples;
        let t1 = Instant::now();
        self.run(ctx, &modes::resolve(self.pixels() as u32, k), &mut |_, _| {})?;
        self.samples += 1;
        let pixels = self.pixels();
        Ok(StepReport {
            pixels,
            eye_rays: pixels,
            trace_time: trace_time + t1.elapsed(),
            frame_done: true,
            camera_version: self.camera_version,
            ..Default::default()
        })
    }

    /// One frameless slice.
    fn step_frameless(&mut self, ctx: &D) -> Result<StepReport, D::Error> {
        let Mode::Frameless { slice, blend, jitter_pairs, .. } = self.settings.mode else {
            unreachable!("a frameless state has a frameless mode")
        };
        if self.adaptive.is_some() {
            return self.step_adaptive(ctx, slice, blend, jitter_pairs);
        }
        let ModeState::Slices(slices) = &self.state else { unreachable!("step_frameless is for slices") };
        let span = slices.next_span(slice);
        let sample = modes::frameless_sample(slices.visit(), blend, jitter_pairs);
        let rec = slices.recording(span, &self.passes, sample);
        let t0 = Instant::now();
        self.run(ctx, &rec, &mut |_, _| {})?;
        let trace_time = t0.elapsed();
        let ModeState::Slices(slices) = &mut self.state else { unreachable!() };
        let (pixels, pass_done, visit_done) = slices.advance(span);
        if visit_done {
            self.samples += 1;
        }
        Ok(StepReport {
            pixels,
            eye_rays: pixels * if jitter_pairs { 2 } else { 1 },
            trace_time,
            frame_done: pass_done,
            slice: Some(span),
            camera_version: self.camera_version,
            idle: false,
        })
    }

    /// A slice of the adaptive order (`render::adaptive`): dealt by its estimates until every
    /// block has been dealt since the change (each slice's samples read back to update them),
    /// then the Hilbert order's passes for refinement. Either way the host writes the slice's
    /// pixels at the start of the work buffer.
    fn step_adaptive(
        &mut self,
        ctx: &D,
        slice: u32,
        blend: Option<f32>,
        jitter_pairs: bool,
    ) -> Result<StepReport, D::Error> {
        let ModeState::Slices(slices) = &mut self.state else { unreachable!("adaptive is frameless") };
        let a = self.adaptive.as_mut().expect("step_adaptive is for the adaptive order");
        let covering = a.covering();
        let span = (!covering).then(|| slices.next_span(slice));
        let pixels = match span {
            None => a.deal(slice),
            Some(span) => a.traced_in_order(span.first, span.len),
        };
        let len = pixels.len() as u64;
        let mut sample = modes::frameless_sample(slices.visit(), blend, jitter_pairs);
        if covering {
            sample.flags |= OUT_COMPACT;
        }
        let at = SliceSpan { first: 0, len };
        let rec = slices.recording(at, &self.passes, sample);
        let bound = ctx.bind(&self.kernel);
        bound.write_work(pixels)?;
        let t0 = Instant::now();
        bound.run(&rec, &mut |_, _| {})?;
        let trace_time = t0.elapsed();
        let (frame_done, visit_done) = match span {
            None => {
                a.learn(&bound.read_output_range(0, len)?);
                let done = !a.covering();
                if done {
                    // Every pixel shows the change: the refinement passes follow.
                    slices.first_visit_done();
                }
                (done, done)
            }
            Some(span) => {
                let (_, pass_done, visit_done) = slices.advance(span);
                (pass_done, visit_done)
            }
        };
        if visit_done {
            self.samples += 1;
        }
        Ok(StepReport {
            pixels: len,
            eye_rays: len * if jitter_pairs { 2 } else { 1 },
            trace_time,
            frame_done,
            slice: Some(at),
            camera_version: self.camera_version,
            idle: false,
        })
    }
}
