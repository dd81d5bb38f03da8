//! Reading what a session traced: the picture with its counts (whole, or in pieces where the
//! device's buffers hold less), the frame buffer's image, the raw output for bit-for-bit
//! comparisons, and the adaptive order's fill of what the screen shows.

use super::fill::{self, BlockFill};
use super::picture::Picture;
use super::session::{ModeState, Session, StepReport};
use super::Mode;
use crate::gpu::device::{BoundKernel, Device};
use crate::gpu::layout::LAVAPIPE_LOOP_LIMIT;
use crate::gpu::{GpuContext, GpuError};
use crate::image::Image;
use std::time::{Duration, Instant};

impl<D: Device> Session<D> {
    /// Whether refinement has reached its sample limit (nothing left to trace); the bands trace
    /// one sample.
    pub fn converged(&self) -> bool {
        let max = if self.settings.mode == Mode::Bands { 1 } else { self.settings.max_samples };
        max > 0 && self.samples >= max
    }

    /// Traces the first sample of the current camera again, whole (the current mode's frame or
    /// pass, ray counters zeroed first), and reads it from the output buffer: the picture with
    /// its ray counts and loop meter. `progress(rows done, rows)` after each band of the bands.
    pub fn try_picture(&mut self, ctx: &D, progress: &mut dyn FnMut(u32, u32)) -> Result<Picture, D::Error> {
        self.restart();
        if let Some(a) = &mut self.adaptive {
            // One whole pass in the Hilbert order: the picture, as any order's first pass.
            a.cover_in_order();
        }
        self.bound(ctx).reset_counts()?;
        match self.state.clone() {
            ModeState::Bands { band_pixels } if !self.whole() && self.settings.mode == Mode::Bands => {
                let picture = self.picture_in_pieces(ctx, band_pixels, progress)?;
                self.first_traced(ctx);
                return Ok(picture);
            }
            _ if !self.whole() => return Err(self.too_large().into()),
            ModeState::Bands { band_pixels } => {
                self.step_bands(ctx, band_pixels, progress)?;
            }
            _ => {
                self.try_complete_pass(ctx)?;
            }
        }
        self.first_traced(ctx);
        self.try_read_picture(ctx)
    }

    /// The picture in the output buffer now (see [`Session::try_picture`]).
    pub fn try_read_picture(&mut self, ctx: &D) -> Result<Picture, D::Error> {
        let t = Instant::now();
        let grid = self.output_grid();
        if !self.whole() {
            return Err(self.too_large().into());
        }
        let rays = grid.grid_size[0] as u64 * grid.grid_size[1] as u64;
        let mut picture = self.bound(ctx).read_output_with(rays, |out, counts| grid.picture(out, counts))?;
        picture.readback = t.elapsed();
        self.max_loop_iterations = picture.max_loop_iterations;
        Ok(picture)
    }

    /// The median wall time of `frames` (at least 1) pictures, and the median of their
    /// readbacks: what the measurement commands report. Call after a first picture, which
    /// carries lavapipe's shader compile.
    pub fn try_median_picture_times(
        &mut self,
        ctx: &D,
        frames: u32,
    ) -> Result<(Duration, Duration), D::Error> {
        let (mut times, mut readbacks) = (Vec::new(), Vec::new());
        for _ in 0..frames.max(1) {
            let t = Instant::now();
            let picture = self.try_picture(ctx, &mut |_, _| {})?;
            times.push(t.elapsed());
            readbacks.push(picture.readback);
        }
        let median = |mut v: Vec<Duration>| {
            v.sort();
            v[v.len() / 2]
        };
        Ok((median(times), median(readbacks)))
    }

    /// The pixels the last frameless slice traced, where the order is not a fixed permutation
    /// (adaptive): for measures that follow pixels rather than positions.
    pub fn last_slice_pixels(&self) -> Option<&[u32]> {
        self.adaptive.as_ref().map(|a| a.last_traced())
    }

    /// Brings the adaptive order's fill of what the screen shows ([`fill`]) up to date: see
    /// [`Self::fill`].
    pub fn update_fill(&mut self) {
        let stale = match &mut self.adaptive {
            Some(a) => a.fill_blocks(&mut self.fill),
            None => false,
        };
        if !stale {
            self.fill.clear();
        }
    }

    /// The fill as last updated: each block's missed change and gradient, and the blocks a
    /// row. `None` for the other orders, and where every block has been traced since the last
    /// change (the fill would change nothing).
    pub fn fill(&self) -> Option<(&[BlockFill], u32)> {
        let a = self.adaptive.as_ref()?;
        (!self.fill.is_empty()).then_some((&self.fill[..], a.blocks_x()))
    }

    /// What the screen shows: the frame buffer's image ([`Self::try_read_image`]), filled where
    /// the adaptive order says ([`fill`]); what the window's blit draws.
    pub fn try_read_shown(&mut self, ctx: &D) -> Result<Image, D::Error> {
        let image = self.try_read_image(ctx)?;
        self.update_fill();
        Ok(self.filled(image))
    }

    /// `image` (the frame buffer's) filled as [`Self::fill`] says, as last updated.
    pub fn filled(&self, image: Image) -> Image {
        match self.fill() {
            Some((blocks, blocks_x)) => fill::fill(&image, super::adaptive::BLOCK_SIDE, blocks_x, blocks),
            None => image,
        }
    }

    /// What is on screen: the frame buffer as an image (each pixel the mean of its samples); in
    /// the bands mode, the picture in the output buffer.
    pub fn try_read_image(&mut self, ctx: &D) -> Result<Image, D::Error> {
        if !self.whole() {
            return Err(self.too_large().into());
        }
        if self.settings.mode == Mode::Bands {
            return Ok(self.try_read_picture(ctx)?.image);
        }
        let [w, h] = self.size();
        let f = self.bound(ctx).read_frame()?;
        let pixels = f[..(w * h) as usize]
            .iter()
            .map(|p| if p[3] > 0.0 { [p[0] / p[3], p[1] / p[3], p[2] / p[3]] } else { [0.0; 3] })
            .collect();
        Ok(Image { width: w, height: h, pixels })
    }

    /// The raw output buffer of the last traced pixels (rgb radiance, alpha 2 × loop
    /// iterations + eye hit), one vec4 an eye ray, for tests that compare modes bit for bit.
    pub fn try_read_output(&mut self, ctx: &D) -> Result<Vec<[f32; 4]>, D::Error> {
        if !self.whole() {
            return Err(self.too_large().into());
        }
        let [cols, rows] = self.output_grid().grid_size;
        let (out, _) = self.bound(ctx).read_output()?;
        let out = out[..(cols * rows) as usize].to_vec();
        self.max_loop_iterations = out.iter().map(|p| p[3] as u32 >> 1).max().unwrap_or(0);
        if self.max_loop_iterations > LAVAPIPE_LOOP_LIMIT / 2 {
            log::warn!(
                "an invocation ran {} shader loop iterations; lavapipe stops loops after {LAVAPIPE_LOOP_LIMIT}",
                self.max_loop_iterations
            );
        }
        Ok(out)
    }
}

/// The wgpu path's plain forms, for tests and examples: a device failure panics with its words
/// (the commands use the `try_` forms and report it).
impl Session<GpuContext> {
    /// [`Session::try_step`].
    pub fn step(&mut self, ctx: &GpuContext) -> StepReport {
        ok(self.try_step(ctx))
    }

    /// [`Session::try_complete_pass`].
    pub fn complete_pass(&mut self, ctx: &GpuContext) -> Duration {
        ok(self.try_complete_pass(ctx))
    }

    /// [`Session::try_picture`].
    pub fn picture(&mut self, ctx: &GpuContext, progress: &mut dyn FnMut(u32, u32)) -> Picture {
        ok(self.try_picture(ctx, progress))
    }

    /// [`Session::try_read_image`].
    pub fn read_image(&mut self, ctx: &GpuContext) -> Image {
        ok(self.try_read_image(ctx))
    }

    /// [`Session::try_read_output`].
    pub fn read_output(&mut self, ctx: &GpuContext) -> Vec<[f32; 4]> {
        ok(self.try_read_output(ctx))
    }

    /// The frame buffer the window blits: `size()[0] × size()[1]` vec4s, row-major, rgb the sum
    /// of a pixel's samples and a their count (0: never traced).
    pub fn frame_buffer(&self) -> &wgpu::Buffer {
        self.kernel.frame_buffer()
    }
}

/// The value of a wgpu call, or a panic with the device's failure in words.
fn ok<T>(r: Result<T, GpuError>) -> T {
    r.unwrap_or_else(|e| panic!("{e}"))
}
