//! Linear radiance images, written atomically as 8-bit sRGB PNG or as linear float OpenEXR
//! (the format chosen by the file name: [`OutputFormat::from_path`], [`Image::save`]).

use std::io::Write;
use std::path::{Path, PathBuf};

/// An output file name that names no format irt writes ([`OutputFormat::from_path`]).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum FormatError {
    #[error(
        "output '{}' has no extension to choose the image format by; irt writes {}",
        .path.display(),
        OutputFormat::supported()
    )]
    NoExtension { path: PathBuf },
    #[error(
        "output '{}': unsupported image format .{extension}; irt writes {}",
        .path.display(),
        OutputFormat::supported()
    )]
    Unsupported { path: PathBuf, extension: String },
}

/// The image file formats irt writes, chosen by the file name's extension (case-insensitive).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OutputFormat {
    /// `.png`: 8-bit sRGB, clamped to [0, 1] for display ([`Image::to_srgb8`]).
    Png,
    /// `.exr`: OpenEXR, linear radiance as RGB 32-bit floats exactly as traced (values above 1
    /// kept), losslessly compressed (RLE): what compositing and HDR tools want.
    Exr,
}

impl OutputFormat {
    /// Every format irt writes, in the order messages list them.
    pub const ALL: [OutputFormat; 2] = [OutputFormat::Png, OutputFormat::Exr];

    /// The format `path`'s extension names (`.png` or `.exr`, in any case); an error naming the
    /// extension and the supported ones otherwise, to be reported before any work is done.
    pub fn from_path(path: &Path) -> Result<OutputFormat, FormatError> {
        let Some(ext) = path.extension().filter(|e| !e.is_empty()) else {
            return Err(FormatError::NoExtension { path: path.to_path_buf() });
        };
        Self::ALL.into_iter().find(|f| ext.eq_ignore_ascii_case(f.extension())).ok_or_else(|| {
            FormatError::Unsupported {
                path: path.to_path_buf(),
                extension: ext.to_string_lossy().into_owned(),
            }
        })
    }

    /// Every format as messages list them: ".png (8-bit sRGB) or .exr (…)".
    fn supported() -> String {
        let list: Vec<String> =
            Self::ALL.iter().map(|f| format!(".{} ({})", f.extension(), f.what())).collect();
        list.join(" or ")
    }

    /// The file name extension, without the dot.
    pub fn extension(self) -> &'static str {
        match self {
            OutputFormat::Png => "png",
            OutputFormat::Exr => "exr",
        }
    }

    /// What the format holds, in words.
    pub fn what(self) -> &'static str {
        match self {
            OutputFormat::Png => "8-bit sRGB",
            OutputFormat::Exr => "OpenEXR, linear float RGB",
        }
    }
}

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

    /// Writes the image in the format `path`'s extension names ([`OutputFormat::from_path`];
    /// an `InvalidInput` error for any other), atomically: to a temporary file beside `path`,
    /// then renamed over it, so a crash never leaves a half-written image.
    pub fn save(&self, path: &Path) -> std::io::Result<()> {
        let format = OutputFormat::from_path(path)
            .map_err(|e| std::io::Error::new(std::io::ErrorKind::InvalidInput, e))?;
        self.save_as(path, format)
    }

    /// Writes the image atomically in `format`, whatever `path`'s extension.
    pub fn save_as(&self, path: &Path, format: OutputFormat) -> std::io::Result<()> {
        write_atomic(path, &self.encode(format)?)
    }

    /// Writes a PNG atomically (see [`Image::save`]), whatever `path`'s extension.
    pub fn save_png(&self, path: &Path) -> std::io::Result<()> {
        self.save_as(path, OutputFormat::Png)
    }

    /// The bytes of the image file in `format`.
    pub fn encode(&self, format: OutputFormat) -> std::io::Result<Vec<u8>> {
        use image::ImageEncoder;
        match format {
            OutputFormat::Png => encode_png(self.width, self.height, &self.to_srgb8()),
            OutputFormat::Exr => {
                let mut buf = std::io::Cursor::new(Vec::new());
                image::codecs::openexr::OpenExrEncoder::new(&mut buf)
                    .write_image(
                        bytemuck::cast_slice(self.pixels.as_slice()),
                        self.width,
                        self.height,
                        image::ExtendedColorType::Rgb32F,
                    )
                    .map_err(std::io::Error::other)?;
                Ok(buf.into_inner())
            }
        }
    }
}

fn encode_png(width: u32, height: u32, rgb: &[u8]) -> std::io::Result<Vec<u8>> {
    use image::ImageEncoder;
    let mut buf = Vec::new();
    image::codecs::png::PngEncoder::new(&mut buf)
        .write_image(rgb, width, height, image::ExtendedColorType::Rgb8)
        .map_err(std::io::Error::other)?;
    Ok(buf)
}

/// Encodes 8-bit RGB as PNG and writes it with [`write_atomic`].
pub fn write_png_atomic(path: &Path, width: u32, height: u32, rgb: &[u8]) -> std::io::Result<()> {
    write_atomic(path, &encode_png(width, height, rgb)?)
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

    #[test]
    fn output_format_follows_the_extension_in_any_case() {
        for (name, format) in [
            ("a.png", OutputFormat::Png),
            ("dir/b.PNG", OutputFormat::Png),
            ("c.Png", OutputFormat::Png),
            ("d.exr", OutputFormat::Exr),
            ("e.EXR", OutputFormat::Exr),
            ("f.jpg.exr", OutputFormat::Exr),
        ] {
            assert_eq!(OutputFormat::from_path(Path::new(name)), Ok(format), "{name}");
        }
        let e = OutputFormat::from_path(Path::new("x.jpg")).unwrap_err().to_string();
        for word in ["x.jpg", "unsupported image format .jpg", ".png", ".exr"] {
            assert!(e.contains(word), "{e}");
        }
        for name in ["x", "dir.png/x", "x."] {
            let e = OutputFormat::from_path(Path::new(name)).unwrap_err().to_string();
            assert!(e.contains(".png") && e.contains(".exr"), "{name}: {e}");
        }
    }

    /// An image whose channels cover what a render holds and more: zero, subnormal, tiny, the
    /// sRGB knee, exactly 1, above 1 (HDR), huge, negative, infinite and NaN; wider and taller than one
    /// 64x64 EXR tile.
    fn varied_image() -> Image {
        let special = [
            0.0,
            1e-40,
            1e-30,
            0.003_130_8,
            0.5,
            1.0,
            1.0 + f32::EPSILON,
            3.75,
            1e6,
            f32::MAX,
            -2.5,
            f32::INFINITY,
            f32::NAN,
        ];
        let mut img = Image::new(67, 70);
        for (i, p) in img.pixels.iter_mut().enumerate() {
            let k = i as u32;
            *p = [
                special[i % special.len()],
                f32::from_bits(0x3f80_0000 ^ k.wrapping_mul(2_654_435_761) >> 9),
                i as f32 / 7.0,
            ];
        }
        img
    }

    #[test]
    fn exr_keeps_linear_radiance_bit_for_bit() {
        use image::ImageDecoder;
        let img = varied_image();
        let bytes = img.encode(OutputFormat::Exr).unwrap();
        let decoder = image::codecs::openexr::OpenExrDecoder::new(std::io::Cursor::new(bytes)).unwrap();
        assert_eq!(decoder.dimensions(), (img.width, img.height));
        assert_eq!(decoder.color_type(), image::ColorType::Rgb32F);
        let mut raw = vec![0u8; decoder.total_bytes() as usize];
        decoder.read_image(&mut raw).unwrap();
        let back: Vec<[f32; 3]> = bytemuck::pod_collect_to_vec(&raw);
        assert_eq!(back.len(), img.pixels.len());
        for (i, (a, b)) in img.pixels.iter().zip(&back).enumerate() {
            assert_eq!(a.map(f32::to_bits), b.map(f32::to_bits), "pixel {i}: {a:?} read back as {b:?}");
        }
    }

    #[test]
    fn png_is_the_srgb8_encoding() {
        let img = varied_image();
        let bytes = img.encode(OutputFormat::Png).unwrap();
        let back = image::load_from_memory_with_format(&bytes, image::ImageFormat::Png).unwrap().to_rgb8();
        assert_eq!(back.dimensions(), (img.width, img.height));
        assert_eq!(back.into_raw(), img.to_srgb8());
    }
}
