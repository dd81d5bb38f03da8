//! The adaptive order's reconstruction (Dayal et al.'s filter, simplified): what the screen shows
//! of a pixel that has not been traced since the last change is a blend of it and its fresher
//! neighbours, each sample weighted by the inverse of its expected squared error.
//!
//! A sample's expected error is predicted per 4×4 block of the adaptive order
//! ([`super::adaptive::AdaptiveOrder::fill_blocks`]): `missed`, the change its block is expected
//! to have missed (the block's rate times the time from its last visit to the change, 0 for a
//! block traced since), and, for a neighbour `d` pixels away, `gradient · d` (the block's mean
//! difference between adjacent pixels). So a pixel traced since the change is shown as it is
//! (at rest the picture is the frame buffer's, bit for bit), an edge keeps its stale sample where
//! the neighbours differ more than it has moved, and a block that moved takes its fresher
//! neighbours' colours. The weights work in the display space the rates are measured in.
//!
//! One rule, two places: [`fill`] here (the replay's measurements and the reference) and the
//! window's blit shader (`app::blit`), tied by a test that draws the blit offscreen.

use crate::image::Image;

/// Neighbours up to this many pixels away in x and y (a 5×5 window). On the tuning scenes at
/// 512² a radius of 2 erred as 4 and 9% less than 7; 2 is also the cheapest.
pub const FILL_RADIUS: i32 = 2;

/// The error every sample has (display space): the floor of the weights. 0.03 erred 1–9% more
/// on the tuning scenes.
pub const FILL_EPS: f32 = 1.0 / 256.0;

/// What the fill knows of a block, as the blit shader reads it (`vec2<f32>`): the change it
/// missed and its gradient, in display space.
pub type BlockFill = [f32; 2];

/// `image` (linear radiance, the frame buffer's means) as the screen shows it, given each
/// block's [`BlockFill`] (`blocks_x` blocks of `block_side` pixels a row).
pub fn fill(image: &Image, block_side: u32, blocks_x: u32, blocks: &[BlockFill]) -> Image {
    let (w, h) = (image.width as i32, image.height as i32);
    let block = |x: i32, y: i32| ((y as u32 / block_side) * blocks_x + x as u32 / block_side) as usize;
    let mut out = image.clone();
    for y in 0..h {
        for x in 0..w {
            let [missed, g] = blocks[block(x, y)];
            if missed <= 0.0 {
                continue;
            }
            let (mut sum, mut weights) = ([0.0f32; 3], 0.0f32);
            for dy in -FILL_RADIUS..=FILL_RADIUS {
                for dx in -FILL_RADIUS..=FILL_RADIUS {
                    let (qx, qy) = (x + dx, y + dy);
                    if qx < 0 || qy < 0 || qx >= w || qy >= h {
                        continue;
                    }
                    let e = blocks[block(qx, qy)][0];
                    let d2 = (dx * dx + dy * dy) as f32;
                    let wt = 1.0 / (FILL_EPS * FILL_EPS + e * e + g * g * d2);
                    let c = image.pixels[(qy * w + qx) as usize];
                    for k in 0..3 {
                        sum[k] += wt * c[k];
                    }
                    weights += wt;
                }
            }
            out.pixels[(y * w + x) as usize] = sum.map(|s| s / weights);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn picture(w: u32, h: u32, f: impl Fn(u32, u32) -> f32) -> Image {
        let pixels = (0..w * h).map(|i| [f(i % w, i / w); 3]).collect();
        Image { width: w, height: h, pixels }
    }

    #[test]
    fn blocks_traced_since_the_change_are_shown_as_they_are() {
        let img = picture(8, 8, |x, y| ((x * 7 + y * 3) % 5) as f32 / 4.0);
        assert_eq!(fill(&img, 4, 2, &[[0.0, 0.5]; 4]), img);
    }

    #[test]
    fn a_stale_block_takes_its_fresh_neighbours_colour_and_keeps_its_own_where_they_differ() {
        // Left block stale (missed 0.5) and dark; right block fresh and bright.
        let img = picture(8, 4, |x, _| if x < 4 { 0.0 } else { 1.0 });
        let out = fill(&img, 4, 2, &[[0.5, 0.0], [0.0, 0.0]]);
        // Next to the fresh block: mostly the fresh colour; the far side, too few fresh samples
        // within reach to move it.
        assert!(out.pixels[3][0] > 0.99, "{:?}", out.pixels[3]);
        assert_eq!(out.pixels[0][0], 0.0);
        assert_eq!(out.pixels[4..8], img.pixels[4..8], "the fresh block is untouched");
        // A steep gradient (an edge or texture) keeps the stale sample.
        let out = fill(&img, 4, 2, &[[0.05, 1.0], [0.0, 0.0]]);
        assert!(out.pixels[3][0] < 0.01, "{:?}", out.pixels[3]);
    }
}
