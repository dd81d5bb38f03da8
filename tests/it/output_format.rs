//! `Image::save`: the format follows the file name's extension, and an OpenEXR file holds the
//! image's linear values exactly.
use irt::image::{Image, OutputFormat};
use std::path::PathBuf;

fn tmp(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("output_format");
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// A small image with values a PNG cannot hold: above 1, below 1/255, negative.
fn hdr_image() -> Image {
    let mut img = Image::new(5, 3);
    for (i, p) in img.pixels.iter_mut().enumerate() {
        let x = i as f32;
        *p = [x * 0.37 + 1e-4, 1.0 + x * 3.1, 1e-3 / (x + 1.0) - 0.002 * (i % 2) as f32];
    }
    img
}

#[test]
fn exr_reads_back_bit_for_bit() {
    let img = hdr_image();
    let path = tmp("hdr.exr");
    img.save(&path).unwrap();
    let back = image::open(&path).unwrap();
    let image::DynamicImage::ImageRgb32F(back) = back else { panic!("not RGB f32: {:?}", back.color()) };
    assert_eq!(back.dimensions(), (img.width, img.height));
    for ((x, y, p), want) in back.enumerate_pixels().zip(&img.pixels) {
        assert_eq!(p.0.map(f32::to_bits), want.map(f32::to_bits), "pixel ({x}, {y})");
    }
}

#[test]
fn png_and_upper_case_extensions() {
    let img = hdr_image();
    for name in ["hdr.png", "HDR.PNG"] {
        let path = tmp(name);
        img.save(&path).unwrap();
        let back = image::open(&path).unwrap();
        assert!(matches!(back, image::DynamicImage::ImageRgb8(_)), "{name}: {:?}", back.color());
        assert_eq!(back.to_rgb8().into_raw(), img.to_srgb8(), "{name}");
    }
    assert_eq!(OutputFormat::from_path(&tmp("HDR.EXR")), Ok(OutputFormat::Exr));
}

#[test]
fn other_extensions_are_refused_and_nothing_is_written() {
    for name in ["hdr.jpg", "hdr.tiff", "hdr"] {
        let path = tmp(name);
        let _ = std::fs::remove_file(&path);
        let e = hdr_image().save(&path).unwrap_err();
        assert_eq!(e.kind(), std::io::ErrorKind::InvalidInput, "{name}");
        let msg = e.to_string();
        assert!(msg.contains(name) && msg.contains(".png") && msg.contains(".exr"), "{msg}");
        assert!(!path.exists(), "{name} was written");
    }
    // save_as writes the format it is given, whatever the name.
    let path = tmp("exr-by-request.img");
    hdr_image().save_as(&path, OutputFormat::Exr).unwrap();
    assert!(std::fs::read(&path).unwrap().starts_with(&[0x76, 0x2f, 0x31, 0x01]));
}
