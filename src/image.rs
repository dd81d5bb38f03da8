//! Linear radiance images and their 8-bit sRGB encoding, written atomically.

use std::io::Write;
use std::path::Path;

/// Linear RGB radiance, row-major, top row first.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<[f32; 3]>,
}

/// The sRGB transfer function of a linear value in [0, 1].
pub fn linear_to_srgb(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// The inverse: linear value of an sRGB-encoded one in [0, 1] (texels are stored encoded).
pub fn srgb_to_linear(x: f64) -> f64 {
    if x <= 0.04045 {
        x / 12.92
    } else {
        ((x + 0.055) / 1.055).powf(2.4)
    }
}

/// Display value of a linear channel: clamped, sRGB-encoded, in [0, 1]. NaN maps to 0 here;
/// the renderer's tests make sure none is ever produced.
pub fn display(x: f64) -> f64 {
    if x.is_nan() {
        0.0
    } else {
        linear_to_srgb(x)
    }
}

impl Image {
    pub fn new(width: u32, height: u32) -> Self {
        Image { width, height, pixels: vec![[0.0; 3]; width as usize * height as usize] }
    }

    pub fn get(&self, x: u32, y: u32) -> [f32; 3] {
        self.pixels[(y * self.width + x) as usize]
    }

    /// Count of channels that are NaN or infinite.
    pub fn non_finite(&self) -> usize {
        self.pixels.iter().flatten().filter(|c| !c.is_finite()).count()
    }

    /// 8-bit sRGB, RGB interleaved.
    pub fn to_srgb8(&self) -> Vec<u8> {
        self.pixels.iter().flatten().map(|&c| (display(c as f64) * 255.0).round() as u8).collect()
    }

    /// Writes a PNG atomically: to a temporary file beside `path`, then renamed over it, so a
    /// crash never leaves a half-written image.
    pub fn save_png(&self, path: &Path) -> std::io::Result<()> {
        write_png_atomic(path, self.width, self.height, &self.to_srgb8())
    }
}

/// Encodes 8-bit RGB as PNG and writes it with [`write_atomic`].
pub fn write_png_atomic(path: &Path, width: u32, height: u32, rgb: &[u8]) -> std::io::Result<()> {
    use image::ImageEncoder;
    let mut buf = Vec::new();
    image::codecs::png::PngEncoder::new(&mut buf)
        .write_image(rgb, width, height, image::ExtendedColorType::Rgb8)
        .map_err(std::io::Error::other)?;
    write_atomic(path, &buf)
}

/// Writes `bytes` to a temporary file beside `path`, then renames it over `path`: readers see
/// the old file or the whole new one, never a half-written one.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let name = path.file_name().ok_or_else(|| {
        std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            format!("'{}' is not a file path", path.display()),
        )
    })?;
    let tmp = dir.join(format!(".{}.{}.tmp", name.to_string_lossy(), std::process::id()));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_transfer_functions_are_inverses() {
        for i in 0..=1000 {
            let x = i as f64 / 1000.0;
            assert!((srgb_to_linear(linear_to_srgb(x)) - x).abs() < 1e-12, "{x}");
            assert!((linear_to_srgb(srgb_to_linear(x)) - x).abs() < 1e-12, "{x}");
        }
        // The standard's fixed points: 8-bit 128 is 0.2158605 linear.
        assert!((srgb_to_linear(128.0 / 255.0) - 0.215_860_5).abs() < 1e-7);
    }
}
