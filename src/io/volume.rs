//! Volume files: NRRD (`.nrrd`, `.nhdr` with its detached data), NIfTI-1 (`.nii`, `.nii.gz`)
//! and VTK ImageData (`.vti`), each read into a [`Grid`]. A grid's axes are the world's: a file
//! whose axes run backwards (a NIfTI in radiological order, a NRRD's negative direction) is
//! flipped to run forwards, and an oblique grid is refused (`[[volume]]`'s `rotate` places it).
//! Sizes are checked against [`MAX_VOXELS`] and the file's own length before anything is
//! allocated.

mod nifti;
mod nrrd;
mod vti;

use super::scalar::Scalar;
use super::LoadError;
use crate::scene::volume::{Grid, Voxels};
use glam::DVec3;
use std::path::Path;

/// Samples a volume may hold: 2^31, past the paper's 1 GB Visible Woman (512x512x1734, 16-bit:
/// 454M samples) with room; 8 GiB of host memory at float32.
pub const MAX_VOXELS: u64 = 1 << 31;

/// The most bytes deflate can make of one (a stream of 258-byte matches): a header that promises
/// more than this times the compressed size is refused before anything is allocated.
pub(super) const DEFLATE_MAX_RATIO: usize = 1032;

/// The extensions a volume file has (`.nii.gz` as its last two).
pub const EXTENSIONS: &[&str] = &["nrrd", "nhdr", "nii", "nii.gz", "vti"];

/// Whether `path` names a volume file by its extension.
pub fn is_volume(path: &Path) -> bool {
    extension(path).is_some()
}

fn extension(path: &Path) -> Option<&'static str> {
    let name = path.file_name()?.to_str()?.to_ascii_lowercase();
    EXTENSIONS.iter().copied().filter(|e| name.ends_with(&format!(".{e}"))).max_by_key(|e| e.len())
}

/// The grid of the volume file at `path`.
pub fn load(path: &Path) -> Result<Grid, LoadError> {
    let shown = path.display().to_string();
    match extension(path) {
        Some("nrrd" | "nhdr") => nrrd::load(path),
        Some("nii" | "nii.gz") => nifti::load(path),
        Some("vti") => vti::load(path),
        _ => Err(LoadError::new(&shown, format!("not a volume file (known: .{})", EXTENSIONS.join(", .")))),
    }
}

/// The sample count of `dims`, refused past [`MAX_VOXELS`] or below two samples a side.
fn voxel_count(dims: [u64; 3]) -> Result<u64, String> {
    if let Some(d) = dims.iter().find(|&&d| d < 2) {
        return Err(format!("a side of {d} sample(s): a volume needs at least 2 a side"));
    }
    let n = dims.iter().try_fold(1u64, |n, &d| n.checked_mul(d)).unwrap_or(u64::MAX);
    if n > MAX_VOXELS {
        let [x, y, z] = dims;
        return Err(format!("{x}x{y}x{z} = {n} samples; volumes are limited to {MAX_VOXELS}"));
    }
    Ok(n)
}

impl Scalar {
    /// `bytes` (exactly `n` samples of this type, in `big`-endian order or not) as voxels:
    /// 8- and 16-bit kept as they are (int8 widened to int16), the rest as float32.
    fn decode_voxels(self, bytes: &[u8], big: bool) -> Voxels {
        macro_rules! each {
            ($t:ty, $n:literal) => {
                bytes.chunks_exact($n).map(|c| {
                    let a: [u8; $n] = c.try_into().expect("chunk");
                    if big {
                        <$t>::from_be_bytes(a)
                    } else {
                        <$t>::from_le_bytes(a)
                    }
                })
            };
        }
        match self {
            Scalar::U8 => Voxels::U8(bytes.to_vec()),
            Scalar::I8 => Voxels::I16(bytes.iter().map(|&b| b as i8 as i16).collect()),
            Scalar::U16 => Voxels::U16(each!(u16, 2).collect()),
            Scalar::I16 => Voxels::I16(each!(i16, 2).collect()),
            Scalar::I32 => Voxels::F32(each!(i32, 4).map(|v| v as f32).collect()),
            Scalar::U32 => Voxels::F32(each!(u32, 4).map(|v| v as f32).collect()),
            Scalar::F32 => Voxels::F32(each!(f32, 4).collect()),
            Scalar::F64 => Voxels::F32(each!(f64, 8).map(|v| v as f32).collect()),
        }
    }
}

/// A grid from axis directions (each a world vector between neighbouring samples) rather than
/// spacings: axis-aligned ones only; an axis that runs backwards is flipped (its samples reversed
/// and the origin moved to its far end) so that every spacing is positive.
fn aligned_grid(
    dims: [u32; 3],
    directions: [DVec3; 3],
    mut origin: DVec3,
    mut voxels: Voxels,
) -> Result<Grid, String> {
    let mut spacing = DVec3::ZERO;
    for (a, d) in directions.iter().enumerate() {
        let along = d[a];
        let off = (0..3).filter(|&b| b != a).map(|b| d[b].abs()).fold(0.0, f64::max);
        if !(d.is_finite() && along != 0.0 && off <= 1e-6 * along.abs()) {
            return Err(format!(
                "axis {a} runs along {d}: irt reads grids whose axes are the world's x, y and z \
                 (place an oblique one with [[volume]]'s rotate)"
            ));
        }
        spacing[a] = along.abs();
        if along < 0.0 {
            origin[a] += along * (dims[a] - 1) as f64;
            flip(&mut voxels, dims, a);
        }
    }
    Grid::new(dims, spacing, origin, voxels)
}

/// Reverses the samples along `axis`.
fn flip(voxels: &mut Voxels, [nx, ny, nz]: [u32; 3], axis: usize) {
    fn go<T>(v: &mut [T], [nx, ny, nz]: [usize; 3], axis: usize) {
        let at = |i: usize, j: usize, k: usize| i + nx * (j + ny * k);
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    let (a, b) = match axis {
                        0 if i < nx / 2 => (at(i, j, k), at(nx - 1 - i, j, k)),
                        1 if j < ny / 2 => (at(i, j, k), at(i, ny - 1 - j, k)),
                        2 if k < nz / 2 => (at(i, j, k), at(i, j, nz - 1 - k)),
                        _ => continue,
                    };
                    v.swap(a, b);
                }
            }
        }
    }
    let dims = [nx as usize, ny as usize, nz as usize];
    match voxels {
        Voxels::U8(v) => go(v, dims, axis),
        Voxels::U16(v) => go(v, dims, axis),
        Voxels::I16(v) => go(v, dims, axis),
        Voxels::F32(v) => go(v, dims, axis),
    }
}

/// Inflates gzip `data` into exactly `want` bytes: a stream that ends early is truncated, one
/// that holds more is not the volume the header describes. Nothing past `want + 1` is inflated.
fn gunzip(data: &[u8], want: usize) -> Result<Vec<u8>, String> {
    use std::io::Read;
    if want > data.len().saturating_mul(DEFLATE_MAX_RATIO) {
        return Err(format!(
            "{} bytes of gzip data cannot hold the {want} bytes the header promises",
            data.len()
        ));
    }
    let mut out = Vec::with_capacity(want);
    let mut z = flate2::read::MultiGzDecoder::new(data).take(want as u64 + 1);
    z.read_to_end(&mut out).map_err(|e| format!("the gzip data does not inflate: {e}"))?;
    match out.len().cmp(&want) {
        std::cmp::Ordering::Less => Err(format!(
            "the gzip data holds {} bytes, the header promises {want}: it is truncated",
            out.len()
        )),
        std::cmp::Ordering::Greater => {
            Err(format!("the gzip data holds more than the {want} bytes the header promises"))
        }
        std::cmp::Ordering::Equal => Ok(out),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn extensions_pick_the_reader_and_nii_gz_is_one() {
        assert_eq!(extension(Path::new("/d/head.nii.gz")), Some("nii.gz"));
        assert_eq!(extension(Path::new("a.NRRD")), Some("nrrd"));
        assert_eq!(extension(Path::new("a.gz")), None);
        let e = load(Path::new("x.raw")).unwrap_err().to_string();
        assert!(e.contains("not a volume file"), "{e}");
    }

    #[test]
    fn a_backwards_axis_is_flipped_and_an_oblique_one_refused() {
        let v = Voxels::U8((0..8).collect());
        let dirs = [DVec3::new(-2.0, 0.0, 0.0), DVec3::Y, DVec3::Z];
        let g = aligned_grid([2, 2, 2], dirs, DVec3::new(10.0, 0.0, 0.0), v.clone()).unwrap();
        assert_eq!(g.origin, DVec3::new(8.0, 0.0, 0.0));
        assert_eq!(g.spacing, DVec3::new(2.0, 1.0, 1.0));
        // The sample at world x = 10 (file index 0) is now the last along x.
        assert_eq!((g.at(1, 0, 0), g.at(0, 0, 0), g.at(1, 1, 1)), (0.0, 1.0, 6.0));
        let oblique = [DVec3::new(1.0, 0.5, 0.0), DVec3::Y, DVec3::Z];
        let e = aligned_grid([2, 2, 2], oblique, DVec3::ZERO, v).unwrap_err();
        assert!(e.contains("axis 0 runs along"), "{e}");
    }

    #[test]
    fn limits_are_checked_from_the_sizes() {
        assert!(voxel_count([2048, 2048, 1024]).unwrap_err().contains("limited to"));
        assert!(voxel_count([u64::MAX, 2, 2]).is_err());
        assert_eq!(voxel_count([2, 3, 4]), Ok(24));
    }
}
