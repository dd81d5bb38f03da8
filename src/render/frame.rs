//! A frame buffer on the host: the pixels of a picture's pieces (what MPI workers return, a farm
//! tile's, the pieces of a picture larger than the device's buffers), written as a device's
//! frame buffer would write them (shaders/trace.wgsl, `update_frame`): per pixel the sum of its samples and
//! their count, never cleared between frameless slices. The additions are the same f32 additions
//! in the same order, so a still picture refined over N samples is bit for bit what one process
//! shows.

use crate::gpu::layout::{PixelSample, FRAME_ACCUMULATE, FRAME_BLEND};
use crate::image::Image;

/// Per pixel: rgb the sum of its samples, a their count (0: never traced).
#[derive(Clone, Debug, PartialEq)]
pub struct HostFrame {
    pub width: u32,
    pub height: u32,
    pub sums: Vec<[f32; 4]>,
}

impl HostFrame {
    pub fn new(width: u32, height: u32) -> Self {
        HostFrame { width, height, sums: vec![[0.0; 4]; width as usize * height as usize] }
    }

    /// Sample `s` of pixel `i` (its radiance `c`), as its flags say: replace, add, or blend with
    /// weight `s.alpha` into the mean so far.
    pub fn update(&mut self, i: usize, c: [f32; 3], s: &PixelSample) {
        let old = self.sums[i];
        self.sums[i] = if s.flags & FRAME_ACCUMULATE != 0 {
            [old[0] + c[0], old[1] + c[1], old[2] + c[2], old[3] + 1.0]
        } else if s.flags & FRAME_BLEND != 0 && old[3] > 0.0 {
            // WGSL's mix(x, y, a) = x(1 - a) + ya, rounded as the shader's `update_frame` does.
            let a = s.alpha;
            let mix = |k: usize| (old[k] / old[3]) * (1.0 - a) + c[k] * a;
            [mix(0), mix(1), mix(2), 1.0]
        } else {
            [c[0], c[1], c[2], 1.0]
        };
    }

    /// Each pixel the mean of its samples (black where none yet), as a session reads its frame
    /// buffer.
    pub fn image(&self) -> Image {
        let pixels = self
            .sums
            .iter()
            .map(|p| if p[3] > 0.0 { [p[0] / p[3], p[1] / p[3], p[2] / p[3]] } else { [0.0; 3] })
            .collect();
        Image { width: self.width, height: self.height, pixels }
    }

    /// The raw sums and counts, as the window's blit reads a frame buffer.
    pub fn bytes(&self) -> &[u8] {
        bytemuck::cast_slice(&self.sums)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::layout::FRAME_WRITE;

    #[test]
    fn samples_replace_add_and_blend_as_the_shader_does() {
        let mut f = HostFrame::new(2, 1);
        let write = PixelSample { flags: FRAME_WRITE, ..Default::default() };
        let add = PixelSample { flags: FRAME_WRITE | FRAME_ACCUMULATE, ..Default::default() };
        f.update(0, [1.0, 2.0, 3.0], &write);
        f.update(0, [3.0, 2.0, 1.0], &add);
        assert_eq!(f.sums[0], [4.0, 4.0, 4.0, 2.0]);
        assert_eq!(f.image().pixels[0], [2.0, 2.0, 2.0]);
        assert_eq!(f.image().pixels[1], [0.0; 3], "never traced: black");
        let blend = PixelSample { flags: FRAME_WRITE | FRAME_BLEND, alpha: 0.5, ..Default::default() };
        f.update(0, [0.0, 0.0, 0.0], &blend);
        assert_eq!(f.sums[0], [1.0, 1.0, 1.0, 1.0]);
        f.update(1, [5.0, 5.0, 5.0], &blend);
        assert_eq!(f.sums[1], [5.0, 5.0, 5.0, 1.0], "a blend into nothing replaces");
    }
}
