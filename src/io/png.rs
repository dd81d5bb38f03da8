//! Texture images: PNG in (glTF images, TOML `[[texture]]` files) and out (`irt convert`).

use crate::scene::{MAX_TEXTURE_PIXELS, MAX_TOTAL_TEXTURE_PIXELS};

/// A decoded image: width, height, sRGB-encoded RGBA texels (row 0 at the top).
pub type Rgba8 = (u32, u32, Vec<[u8; 4]>);

/// Why a PNG could not be written ([`encode`]), a texture file's header read ([`read_header`]) or
/// one more texture added to a scene ([`PixelBudget::take`]).
#[derive(Debug, thiserror::Error)]
pub enum PngError {
    #[error("cannot encode a {width}x{height} PNG: {error}")]
    Encode { width: u32, height: u32, error: image::ImageError },
    #[error("'{}': cannot read the texture file: {error}", .path.display())]
    Read { path: std::path::PathBuf, error: std::io::Error },
    #[error(
        "the textures up to this one have {pixels} pixels together; a scene's textures may have at \
         most {MAX_TOTAL_TEXTURE_PIXELS}"
    )]
    TooManyPixels { pixels: u64 },
}

/// Why an image cannot be used.
#[derive(Debug)]
pub enum Unusable {
    /// Bad input: an error.
    Refused(String),
    /// Not a PNG: glTF may use JPEG, which irt does not decode (a warning there).
    NotPng(String),
}

/// Decodes a PNG after checking its size in the header (the first chunk, IHDR, PNG §11.2.2),
/// so a huge declared image is refused before anything is allocated. `what` names the image in
/// messages.
pub fn decode(bytes: &[u8], what: &str) -> Result<Rgba8, Unusable> {
    use image::{ImageFormat, ImageReader, Limits};
    use std::io::Cursor;
    let (w, h) = checked_size(bytes, what)?;
    let mut reader = ImageReader::with_format(Cursor::new(bytes), ImageFormat::Png);
    let mut limits = Limits::default();
    limits.max_image_width = Some(w);
    limits.max_image_height = Some(h);
    limits.max_alloc = Some(MAX_TEXTURE_PIXELS * 16);
    reader.limits(limits);
    let image =
        reader.decode().map_err(|e| Unusable::Refused(format!("{what}: cannot decode the PNG: {e}")))?;
    // 16-bit and grey images are brought to 8-bit RGBA the way the image crate does (no
    // dithering): what irt samples is 8-bit sRGB.
    let texels = image.to_rgba8().into_raw().chunks_exact(4).map(|p| [p[0], p[1], p[2], p[3]]).collect();
    Ok((w, h, texels))
}

/// Encodes RGBA texels as a PNG (lossless: decoding gives the same texels back).
pub fn encode(width: u32, height: u32, texels: &[[u8; 4]]) -> Result<Vec<u8>, PngError> {
    use image::{ExtendedColorType, ImageEncoder};
    let mut out = Vec::new();
    image::codecs::png::PngEncoder::new(&mut out)
        .write_image(texels.as_flattened(), width, height, ExtendedColorType::Rgba8)
        .map_err(|error| PngError::Encode { width, height, error })?;
    Ok(out)
}

/// The width and height a PNG declares in its IHDR header (its first [`HEADER_BYTES`]),
/// within [`MAX_TEXTURE_PIXELS`]: what [`decode`] checks before decoding, and what a loader
/// checks first to add up a scene's textures ([`PixelBudget`]) before it decodes any of them.
pub fn checked_size(bytes: &[u8], what: &str) -> Result<(u32, u32), Unusable> {
    if !bytes.starts_with(PNG_SIGNATURE) {
        return Err(Unusable::NotPng(format!("{what} is not a PNG; irt decodes PNG textures only")));
    }
    let word = |at: usize| bytes.get(at..at + 4).map(|b| u32::from_be_bytes(b.try_into().unwrap()));
    let (Some(b"IHDR"), Some(w), Some(h)) = (bytes.get(12..16), word(16), word(20)) else {
        return Err(Unusable::Refused(format!("{what}: the PNG does not start with its IHDR header")));
    };
    if w == 0 || h == 0 || w as u64 * h as u64 > MAX_TEXTURE_PIXELS {
        return Err(Unusable::Refused(format!(
            "{what} is {w}x{h} pixels; irt reads textures of 1 to {MAX_TEXTURE_PIXELS} pixels"
        )));
    }
    Ok((w, h))
}

/// The pixels of a scene's textures so far, refused past [`MAX_TOTAL_TEXTURE_PIXELS`]: loaders
/// add each image's declared size before decoding it, so many images that compress well (a
/// solid 4096² image is a few KiB of PNG) cannot add up to gigabytes decoded.
#[derive(Default)]
pub struct PixelBudget(u64);

impl PixelBudget {
    pub fn take(&mut self, width: u32, height: u32) -> Result<(), PngError> {
        self.0 += width as u64 * height as u64;
        if self.0 > MAX_TOTAL_TEXTURE_PIXELS {
            return Err(PngError::TooManyPixels { pixels: self.0 });
        }
        Ok(())
    }
}

/// The first bytes of a PNG file, up to its declared size (fewer if the file is shorter), so
/// that a file can be refused by its header before it is read whole.
pub fn read_header(path: &std::path::Path) -> Result<Vec<u8>, PngError> {
    use std::io::Read;
    let cannot = |error| PngError::Read { path: path.to_path_buf(), error };
    let mut header = Vec::with_capacity(HEADER_BYTES);
    let file = std::fs::File::open(path).map_err(cannot)?;
    file.take(HEADER_BYTES as u64).read_to_end(&mut header).map_err(cannot)?;
    Ok(header)
}

/// The bytes every PNG file starts with (PNG §5.2); the IHDR size follows up to byte 24.
pub const PNG_SIGNATURE: &[u8] = b"\x89PNG\r\n\x1a\n";
/// Bytes of a PNG up to the end of the image size in its IHDR header.
pub const HEADER_BYTES: usize = 24;
