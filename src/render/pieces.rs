//! Pieces of a picture traced on their own and read back compactly: a chunk of a conventional
//! frame's tiles, a slice of the frameless order. What a distributed worker traces (`dist`):
//! the same entry points, samples and seeds as a whole frame, so a pixel is the same whichever
//! rank traced it.

use super::modes::{chunk_pixels, frame_sample, Queue, SliceSpan};
use super::schedule::tile_grid;
use super::session::{ModeState, Session};
use super::{Mode, RenderError, Schedule, Settings};
use crate::gpu::device::{BoundKernel, Device};
use crate::gpu::layout::TILE_H;
use std::ops::Range;

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
    /// must be in an interactive mode (conventional or frameless).
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
        let (queue, boundaries) = Queue::of_tiles(tiles.clone(), columns);
        // The rows of tiles the chunk covers, read as one range.
        let y0 = tiles.start / columns * TILE_H;
        let y1 = ((tiles.end - 1) / columns * TILE_H + TILE_H).min(h);
        let out = {
            let bound = self.bound(ctx);
            bound.write_work(&boundaries).map_err(Into::into)?;
            let sample = frame_sample(k);
            for &pass in &self.passes {
                bound.run(&queue.wave(pass, sample, true), &mut |_, _| {}).map_err(Into::into)?;
            }
            bound.read_output_range(y0 as u64 * w as u64, (y1 - y0) as u64 * w as u64).map_err(Into::into)?
        };
        let base = y0 * w;
        let picked = values(chunk_pixels(tiles, columns, w, h).map(|p| out[(p - base) as usize]));
        // The work buffer held the frame's schedule: the next frame of this session's own
        // writes it again.
        self.configure_mode(ctx)?;
        Ok(picked)
    }

    /// The positions `span` of the frameless order's pass at visit `visit` (its refinement
    /// jitter): their pixels in position order (the dissolve's positions past the image hold
    /// nothing). The session must be in the frameless mode with the order the positions belong
    /// to; its frame buffer is not written.
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
        let rec = slices.compact_recording(span, &self.passes, visit);
        let bound = self.bound(ctx);
        bound.run(&rec, &mut |_, _| {}).map_err(Into::into)?;
        let out = bound.read_output_range(0, span.len).map_err(Into::into)?;
        Ok(values(out.into_iter()))
    }
}
