//! Image error metrics, measured in display space: each channel clamped, sRGB-encoded, in [0, 1]
//! (what a viewer sees, and the unit of the 8-bit output: 1/255 is one output level).

use crate::image::{display, Image};

/// Per-channel absolute error statistics of one image against a reference.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageDiff {
    pub max: f64,
    /// 99th and 99.9th percentile of the per-channel error.
    pub p99: f64,
    pub p999: f64,
    pub rmse: f64,
    /// Fraction of pixels with some channel off by more than 2/255 (two output levels).
    pub bad_pixels: f64,
    /// Channels that were NaN or infinite in the tested image.
    pub non_finite: usize,
}

impl std::fmt::Display for ImageDiff {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "max {:.4} ({:.1}/255)  p99 {:.4}  p99.9 {:.4} ({:.1}/255)  rmse {:.5}  pixels >2/255: {:.3}%  non-finite: {}",
            self.max,
            self.max * 255.0,
            self.p99,
            self.p999,
            self.p999 * 255.0,
            self.rmse,
            self.bad_pixels * 100.0,
            self.non_finite
        )
    }
}

/// Compares `test` against `reference` (same size) channel by channel in display space.
pub fn compare(test: &Image, reference: &Image) -> ImageDiff {
    assert_eq!((test.width, test.height), (reference.width, reference.height), "image sizes differ");
    let mut errs = Vec::with_capacity(test.pixels.len() * 3);
    let mut bad = 0usize;
    for (a, b) in test.pixels.iter().zip(&reference.pixels) {
        let mut worst: f64 = 0.0;
        for c in 0..3 {
            let e = (display(a[c] as f64) - display(b[c] as f64)).abs();
            worst = worst.max(e);
            errs.push(e);
        }
        if worst > 2.0 / 255.0 {
            bad += 1;
        }
    }
    let n = errs.len().max(1);
    let rmse = (errs.iter().map(|e| e * e).sum::<f64>() / n as f64).sqrt();
    errs.sort_by(f64::total_cmp);
    let pct = |p: f64| errs.get(((n as f64 * p) as usize).min(n - 1)).copied().unwrap_or(0.0);
    ImageDiff {
        max: errs.last().copied().unwrap_or(0.0),
        p99: pct(0.99),
        p999: pct(0.999),
        rmse,
        bad_pixels: bad as f64 / test.pixels.len().max(1) as f64,
        non_finite: test.non_finite(),
    }
}

/// The root-mean-square channel error of `test` against `reference` in display space: the
/// `rmse` of [`compare`] without its percentiles (no sort), for measurements that compare many
/// images (the dynamic error of `irt replay`).
pub fn rmse(test: &Image, reference: &Image) -> f64 {
    assert_eq!((test.width, test.height), (reference.width, reference.height), "image sizes differ");
    let sum: f64 = test
        .pixels
        .iter()
        .zip(&reference.pixels)
        .flat_map(|(a, b)| (0..3).map(move |c| (display(a[c] as f64) - display(b[c] as f64)).powi(2)))
        .sum();
    (sum / (test.pixels.len() * 3).max(1) as f64).sqrt()
}

/// A visualisation of where two images differ: error ×`gain` in red over a dimmed copy of `b`.
pub fn diff_image(a: &Image, b: &Image, gain: f32) -> Image {
    let pixels = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .map(|(p, q)| {
            let e = (0..3)
                .map(|c| (display(p[c] as f64) - display(q[c] as f64)).abs() as f32)
                .fold(0.0, f32::max);
            let base = (q[0] + q[1] + q[2]) / 3.0 * 0.25;
            [base + e * gain, base, base]
        })
        .collect();
    Image { width: a.width, height: a.height, pixels }
}

/// Mean structural similarity (Wang et al. 2004) of the display-space luma of `test` against
/// `reference`: 11×11 Gaussian windows (σ = 1.5), the paper's constants. 1 is identical; the
/// perceptual metric of `irt tradeoff`, which rewards smooth penumbrae over noisy ones at equal
/// RMSE.
pub fn ssim(test: &Image, reference: &Image) -> f64 {
    assert_eq!((test.width, test.height), (reference.width, reference.height), "image sizes differ");
    let (w, h) = (test.width as usize, test.height as usize);
    let luma = |img: &Image| -> Vec<f64> {
        img.pixels
            .iter()
            .map(|p| {
                0.2126 * display(p[0] as f64) + 0.7152 * display(p[1] as f64) + 0.0722 * display(p[2] as f64)
            })
            .collect()
    };
    let (x, y) = (luma(test), luma(reference));
    const R: isize = 5;
    let g: Vec<f64> = (-R..=R).map(|i| (-(i * i) as f64 / (2.0 * 1.5 * 1.5)).exp()).collect();
    let (c1, c2) = (0.01f64.powi(2), 0.03f64.powi(2));
    let (mut total, mut count) = (0.0, 0usize);
    // Windows wholly inside the image (or the whole image when it is smaller than a window).
    let range = |n: usize| if n > 2 * R as usize { R as usize..n - R as usize } else { n / 2..n / 2 + 1 };
    for cy in range(h) {
        for cx in range(w) {
            let (mut sw, mut mx, mut my, mut xx, mut yy, mut xy) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
            for dy in -R..=R {
                for dx in -R..=R {
                    let (px, py) = (cx as isize + dx, cy as isize + dy);
                    if px < 0 || py < 0 || px >= w as isize || py >= h as isize {
                        continue;
                    }
                    let k = py as usize * w + px as usize;
                    let wt = g[(dx + R) as usize] * g[(dy + R) as usize];
                    sw += wt;
                    mx += wt * x[k];
                    my += wt * y[k];
                    xx += wt * x[k] * x[k];
                    yy += wt * y[k] * y[k];
                    xy += wt * x[k] * y[k];
                }
            }
            let (mx, my) = (mx / sw, my / sw);
            let (vx, vy, cov) = (xx / sw - mx * mx, yy / sw - my * my, xy / sw - mx * my);
            total += ((2.0 * mx * my + c1) * (2.0 * cov + c2)) / ((mx * mx + my * my + c1) * (vx + vy + c2));
            count += 1;
        }
    }
    total / count.max(1) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    fn noise(w: u32, h: u32, amp: f32, seed: u32) -> Image {
        let mut s = seed;
        let pixels = (0..w * h)
            .map(|i| {
                s = s.wrapping_mul(1664525).wrapping_add(1013904223);
                let v = 0.3 + 0.2 * ((i % w) as f32 / w as f32) + amp * ((s >> 8) as f32 / 16777216.0 - 0.5);
                [v, v, v]
            })
            .collect();
        Image { width: w, height: h, pixels }
    }

    #[test]
    fn rmse_is_the_rmse_of_compare() {
        let (a, b) = (noise(40, 30, 0.1, 4), noise(40, 30, 0.1, 5));
        assert!((rmse(&a, &b) - compare(&a, &b).rmse).abs() < 1e-12);
        assert_eq!(rmse(&a, &a), 0.0);
    }

    #[test]
    fn ssim_is_one_for_equal_images_and_falls_with_noise() {
        let a = noise(40, 30, 0.0, 1);
        assert!((ssim(&a, &a) - 1.0).abs() < 1e-12);
        let (s1, s2) = (ssim(&noise(40, 30, 0.05, 2), &a), ssim(&noise(40, 30, 0.2, 3), &a));
        assert!(s1 < 1.0 && s2 < s1, "{s1} {s2}");
    }
}
