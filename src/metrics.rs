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
