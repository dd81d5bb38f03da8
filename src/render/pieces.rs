//! Pieces of a picture traced on their own and read back compactly: a chunk of a conventional
//! frame's tiles, a slice of the frameless order, a band of the bands' rows. What a distributed
//! worker traces (`dist`), what a farm tile is made of (`farm`), and how a picture larger than
//! the device's buffers is traced in one process (each buffer holds at most
//! `session::buffer_rays` eye rays: 8 388 608 on lavapipe, whose storage bindings stop at 128
//! MiB). The same entry points, samples and seeds as a whole frame, so a pixel is the same
//! whoever traced it, and in whichever piece.

use super::frame::HostFrame;
use super::modes::{
    chunk_pixels, frame_sample, frameless_sample, resolve_sample, Queue, SliceSpan, MAX_SLICE,
};
use super::order::order_pixels;
use super::picture::{OutputGrid, Picture};
use super::schedule::tile_grid;
use super::session::{ModeState, Session};
use super::{Mode, RenderError, Schedule, Settings};
use crate::gpu::device::{BoundKernel, Device};
use crate::gpu::layout::{RENDER_TILE, TILE_H};
use crate::image::Image;
use std::ops::Range;

/// The most tiles of the conventional queue one dispatch of a piece traces: a workgroup a
/// tile, well inside the 65 535 workgroups a dispatch may have, and a progress step.
pub const PIECE_TILES: u32 = 4096;

/// The settings a picture's pieces are traced with, or what cannot be split (for the message
/// "… cannot be split: drop it"): the bands' one picture is traced as the tiles of one
/// conventional frame (the same picture, bit for bit: sample 0 at the pixel centres); the SPD
/// rules' corner rays and the ray counters have no pieces.
pub fn split_settings(settings: Settings) -> Result<Settings, &'static str> {
    if settings.corner_rays {
        return Err("SPD's corner rays (--spd-rules)");
    }
    if settings.count_rays || settings.simd_stats {
        return Err("counting rays (--stats)");
    }
    Ok(match settings.mode {
        Mode::Bands => Settings {
            mode: Mode::Conventional { schedule: Schedule::default(), workers: 0 },
            max_samples: 1,
            ..settings
        },
        _ => settings,
    })
}

/// A piece's pixels (rgb, in the piece's order) and the most loop iterations any of them ran.
pub type PieceValues = (Vec<[f32; 3]>, u32);

fn values(out: impl Iterator<Item = [f32; 4]>) -> PieceValues {
    let mut most = 0u32;
    let v = out
        .map(|p| {
            most = most.max(p[3] as u32 >> 1);
            [p[0], p[1], p[2]]
        })
        .collect();
    (v, most)
}

impl<D: Device> Session<D> {
    /// Tiles `tiles` of the conventional frame at sample `k` (its refinement jitter), through the
    /// conventional mode's tile queue: their pixels in `modes::chunk_pixels` order. The session
    /// must be in an interactive mode (conventional or frameless). Any range of the frame's
    /// tiles: it is traced [`PIECE_TILES`] at a time, each into the output buffer from its
    /// first row on, so the picture may be larger than the buffers.
    pub fn try_trace_tiles(
        &mut self,
        ctx: &D,
        tiles: Range<u32>,
        k: u32,
    ) -> Result<PieceValues, RenderError> {
        if self.settings.mode == super::Mode::Bands {
            return Err(RenderError::Mode(
                "tiles are traced by the conventional mode's queue, not the bands",
            ));
        }
        let [w, h] = self.size();
        let [columns, ty] = tile_grid(w, h);
        if tiles.is_empty() || tiles.end > columns * ty {
            return Err(RenderError::Mode("those tiles are not in the frame"));
        }
        // Rows of tiles a piece may cover: its rows' pixels fit the output buffer.
        let tile_rows = (self.buffer_rays() / (TILE_H as u64 * w as u64)).max(1) as u32;
        let (mut values, mut most) = (Vec::new(), 0);
        let mut first = tiles.start;
        while first < tiles.end {
            let row_end = (first / columns + tile_rows) * columns;
            let end = tiles.end.min(first + PIECE_TILES).min(row_end);
            let (v, m) = self.trace_tile_piece(ctx, first..end, k)?;
            values.extend(v);
            most = most.max(m);
            first = end;
        }
        Ok((values, most))
    }

    /// [`Session::try_trace_tiles`] of tiles whose rows fit the output buffer.
    fn trace_tile_piece(&mut self, ctx: &D, tiles: Range<u32>, k: u32) -> Result<PieceValues, RenderError> {
        let [w, h] = self.size();
        let [columns, _] = tile_grid(w, h);
        let (queue, boundaries) = Queue::of_tiles(tiles.clone(), columns);
        // The rows of tiles the chunk covers, traced into the output from its first row on.
        let y0 = tiles.start / columns * TILE_H;
        let y1 = ((tiles.end - 1) / columns * TILE_H + TILE_H).min(h);
        let base = y0 * w;
        // The work buffer holds the chunk's boundaries now: the mode's own work goes back
        // before its next step.
        self.work_resident = false;
        let out = {
            let bound = self.bound(ctx);
            bound.write_work(&boundaries).map_err(Into::into)?;
            let sample = frame_sample(k);
            for &pass in &self.passes {
                bound
                    .run(&queue.wave(pass, sample, true).at_base(base), &mut |_, _| {})
                    .map_err(Into::into)?;
            }
            bound.read_output_range(0, (y1 - y0) as u64 * w as u64).map_err(Into::into)?
        };
        Ok(values(chunk_pixels(tiles, columns, w, h).map(|p| out[(p - base) as usize])))
    }

    /// The positions `span` of the frameless order's pass at visit `visit` (its refinement
    /// jitter): their pixels in position order (the dissolve's positions past the image hold
    /// nothing). The session must be in the frameless mode with the order the positions belong
    /// to; its frame buffer is not written. A span longer than the output buffer is traced in
    /// parts; a table order whose table is not in the work buffer (a picture larger than the
    /// buffers) has each part's positions written there first.
    pub fn try_trace_slice(
        &mut self,
        ctx: &D,
        span: SliceSpan,
        visit: u32,
    ) -> Result<PieceValues, RenderError> {
        let ModeState::Slices(slices) = &self.state else {
            return Err(RenderError::Mode("a slice is traced by the frameless mode"));
        };
        if span.len == 0 || span.first + span.len > slices.pass_len {
            return Err(RenderError::Mode("that slice is not in the pass"));
        }
        let (mut values, mut most) = (Vec::with_capacity(span.len as usize), 0);
        let mut first = span.first;
        while first < span.first + span.len {
            let len = (span.first + span.len - first).min(self.buffer_rays()).min(MAX_SLICE);
            let (v, m) = self.trace_slice_part(ctx, SliceSpan { first, len }, visit)?;
            values.extend(v);
            most = most.max(m);
            first += len;
        }
        Ok((values, most))
    }

    /// [`Session::try_trace_slice`] of a span no longer than the output buffer.
    fn trace_slice_part(&mut self, ctx: &D, span: SliceSpan, visit: u32) -> Result<PieceValues, RenderError> {
        let ModeState::Slices(slices) = &self.state else { unreachable!("checked by try_trace_slice") };
        let table_part = slices.has_table() && !self.work_resident;
        let table_at = if table_part { 0 } else { span.first };
        let Mode::Frameless { blend, jitter_pairs, .. } = self.settings.mode else {
            unreachable!("slices are the frameless mode's")
        };
        let sample = frameless_sample(visit, blend, jitter_pairs);
        let rec = slices.compact_recording(span, &self.passes, sample, table_at);
        let bound = self.bound(ctx);
        if table_part {
            let part = &self.mode_work[span.first as usize..(span.first + span.len) as usize];
            bound.write_work(part).map_err(Into::into)?;
        }
        bound.run(&rec, &mut |_, _| {}).map_err(Into::into)?;
        let out = bound.read_output_range(0, span.len).map_err(Into::into)?;
        Ok(values(out.into_iter()))
    }

    /// The bands' picture in pieces of whole eye-ray rows, each traced into the output buffer
    /// and read back before the next (ray counters zeroed by the caller): what
    /// [`Session::try_picture`] does with a picture larger than the buffers. With corner rays
    /// consecutive pieces share their boundary row of corners.
    pub(super) fn picture_in_pieces(
        &mut self,
        ctx: &D,
        band_pixels: u32,
        progress: &mut dyn FnMut(u32, u32),
    ) -> Result<Picture, D::Error> {
        let grid = self.output_grid();
        let [cols, _] = grid.grid_size;
        let extra = grid.grid_size[1] - grid.height;
        let bands = self.bands(band_pixels);
        // Eye rows a piece holds, in whole rows of the bands' tiles where there is room.
        let fit = (self.buffer_rays() / cols as u64) as u32;
        let tile = RENDER_TILE[1];
        let eye_rows = if fit > tile + extra { (fit - extra) / tile * tile + extra } else { fit };
        let step = eye_rows - extra;
        let sample = super::modes::frame_sample(self.samples);
        let mut picture: Option<(Picture, u64)> = None;
        let mut y = 0;
        while y < grid.height {
            let y1 = (y + step).min(grid.height);
            let rows = y..y1 + extra;
            self.run(ctx, &bands.recording_rows(sample, rows.clone()), progress)?;
            let cells = rows.len() as u64 * cols as u64;
            let piece_grid =
                OutputGrid { width: grid.width, height: y1 - y, grid_size: [cols, rows.len() as u32] };
            let t = std::time::Instant::now();
            let mut piece =
                self.bound(ctx).read_output_with(cells, |out, rays| piece_grid.picture(out, rays))?;
            piece.readback = t.elapsed();
            picture = Some(match picture {
                None => (piece, cells),
                Some((above, n)) => (above.stacked(n, piece, cells), n + cells),
            });
            y = y1;
        }
        self.samples += 1;
        let (picture, _) = picture.expect("a picture has at least one row");
        self.max_loop_iterations = picture.max_loop_iterations;
        Ok(picture)
    }

    /// The whole picture as the session's mode makes it, refined to `Settings::max_samples`
    /// (one sample for the bands): what `irt render` writes. A picture that fits the buffers is
    /// traced as the mode traces a frame; a larger one in pieces — the bands in bands of rows,
    /// the conventional frame as tiles of its queue, the frameless pass as slices of its order
    /// — into a frame on the host, the same picture bit for bit. Traced anew on every call.
    /// `progress(done, total)` counts eye rays.
    pub fn try_render_image(
        &mut self,
        ctx: &D,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<Image, RenderError> {
        let [w, h] = self.size();
        let pixels = w as u64 * h as u64;
        if self.settings.mode == Mode::Bands {
            let cols = self.output_grid().grid_size[0] as u64;
            let picture = self
                .try_picture(ctx, &mut |rows, _| progress(rows as u64 * cols, pixels))
                .map_err(Into::into)?;
            return Ok(picture.image);
        }
        // From the first sample, whatever the session traced before (a picture again is traced
        // again, not read).
        self.restart();
        let samples = self.settings.max_samples.max(1);
        let total = pixels * samples as u64;
        if self.whole() {
            let mut passes = 0u64;
            while !self.converged() {
                self.try_complete_pass(ctx).map_err(Into::into)?;
                passes += 1;
                progress((passes * pixels).min(total), total);
            }
            return Ok(self.try_read_image(ctx).map_err(Into::into)?);
        }
        let mut frame = HostFrame::new(w, h);
        let mut done = 0;
        match self.settings.mode {
            Mode::Frameless { blend, jitter_pairs, .. } => {
                let ModeState::Slices(slices) = &self.state else { unreachable!("a frameless state") };
                let (pass, table) = (slices.pass_len, slices.has_table());
                for visit in 0..samples {
                    let s = frameless_sample(visit, blend, jitter_pairs);
                    let mut first = 0;
                    while first < pass {
                        let len = (pass - first).min(self.buffer_rays()).min(MAX_SLICE);
                        let (values, _) = self.try_trace_slice(ctx, SliceSpan { first, len }, visit)?;
                        let order = table.then_some(&self.mode_work[..]);
                        for (p, v) in order_pixels(order, first, len, pixels).zip(&values) {
                            if let Some(p) = p {
                                frame.update(p as usize, *v, &s);
                                done += 1;
                            }
                        }
                        progress(done, total);
                        first += len;
                    }
                }
            }
            _ => {
                for k in 0..samples {
                    self.trace_rows_as_tiles(ctx, 0..h, k, &mut frame, &mut |n| {
                        done += n;
                        progress(done, total);
                    })?;
                }
            }
        }
        self.samples = samples;
        Ok(frame.image())
    }

    /// Sample `k` of the picture's rows `rows` (whole rows of tiles) as tiles of the
    /// conventional queue, [`PIECE_TILES`] at a time, into `frame` (which holds those rows) as
    /// a whole frame's resolve writes them. `traced(n)` after each piece of `n` pixels.
    pub fn trace_rows_as_tiles(
        &mut self,
        ctx: &D,
        rows: Range<u32>,
        k: u32,
        frame: &mut HostFrame,
        traced: &mut dyn FnMut(u64),
    ) -> Result<(), RenderError> {
        let [w, h] = self.size();
        let [columns, _] = tile_grid(w, h);
        let tiles = rows.start / TILE_H * columns..rows.end.div_ceil(TILE_H) * columns;
        let base = rows.start * w;
        let s = resolve_sample(k);
        let mut first = tiles.start;
        while first < tiles.end {
            let end = (first + PIECE_TILES).min(tiles.end);
            let (values, _) = self.try_trace_tiles(ctx, first..end, k)?;
            for (p, v) in chunk_pixels(first..end, columns, w, h).zip(&values) {
                frame.update((p - base) as usize, *v, &s);
            }
            traced(values.len() as u64);
            first = end;
        }
        Ok(())
    }
}

impl Picture {
    /// This picture (`cells` eye rays) with `below` (`below_cells`) under it: the rows of a
    /// picture traced in pieces. Ray counters are the last piece's (they count from the first),
    /// eye hits add up, and the loop meter is the meter of both.
    pub(super) fn stacked(mut self, cells: u64, below: Picture, below_cells: u64) -> Picture {
        self.image.height += below.image.height;
        self.image.pixels.extend(below.image.pixels);
        self.rays = below.rays;
        self.eye_hits += below.eye_hits;
        self.loops = self.loops.stacked(cells, below.loops, below_cells);
        self.max_loop_iterations = self.max_loop_iterations.max(below.max_loop_iterations);
        self.readback += below.readback;
        self
    }
}
