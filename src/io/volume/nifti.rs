//! NIfTI-1 (`.nii`, `.nii.gz`) through the `nifti` crate: its header first (checked before the
//! voxels are read), then the voxels. Placement from the sform when it is set, else the qform's
//! quaternion, else the voxel sizes alone; `scl_slope`/`scl_inter` applied when they scale.

use super::{aligned_grid, voxel_count};
use crate::io::scalar::Scalar;
use crate::io::LoadError;
use crate::scene::volume::{Grid, Voxels};
use glam::{DMat3, DQuat, DVec3};
use nifti::{NiftiHeader, NiftiObject, NiftiType, ReaderOptions};
use std::path::Path;

pub fn load(path: &Path) -> Result<Grid, LoadError> {
    let shown = path.display().to_string();
    let fail = |m: String| LoadError::new(&shown, m);
    let h = NiftiHeader::from_file(path).map_err(|e| fail(format!("not a NIfTI-1 file: {e}")))?;
    let rank = h.dim[0] as usize;
    let extra = h.dim.get(4..=rank.max(3)).unwrap_or(&[]);
    if !(3..=7).contains(&rank) || extra.iter().any(|&d| d > 1) {
        return Err(fail(format!(
            "dim {:?}: irt reads 3-dimensional scalar volumes (one time point)",
            h.dim
        )));
    }
    let dims = [h.dim[1], h.dim[2], h.dim[3]].map(u64::from);
    let sample = match h.data_type() {
        Ok(NiftiType::Uint8) => Scalar::U8,
        Ok(NiftiType::Int8) => Scalar::I8,
        Ok(NiftiType::Int16) => Scalar::I16,
        Ok(NiftiType::Uint16) => Scalar::U16,
        Ok(NiftiType::Int32) => Scalar::I32,
        Ok(NiftiType::Uint32) => Scalar::U32,
        Ok(NiftiType::Float32) => Scalar::F32,
        Ok(NiftiType::Float64) => Scalar::F64,
        Ok(t) => {
            return Err(fail(format!(
                "datatype {t:?}: irt reads 8-, 16- and 32-bit integers, float32 and float64"
            )))
        }
        Err(_) => return Err(fail(format!("datatype {} is not one of NIfTI-1's", h.datatype))),
    };
    // The crate reserves the voxels the header promises: refused first if the file cannot hold
    // them (raw: from its length; gzip: deflate's largest ratio).
    let want = voxel_count(dims).map_err(&fail)? * sample.size() as u64;
    let size = std::fs::metadata(path).map_err(|e| fail(e.to_string()))?.len();
    let gz = shown.to_ascii_lowercase().ends_with(".gz");
    let holds = if gz {
        size.saturating_mul(super::DEFLATE_MAX_RATIO as u64)
    } else {
        size.saturating_sub(h.vox_offset as u64)
    };
    if want > holds {
        return Err(fail(format!(
            "the file holds {holds} bytes of voxels, its header promises {want}: it is truncated"
        )));
    }
    let directions = placement(&h);
    let obj = ReaderOptions::new().read_file(path).map_err(|e| {
        fail(match e {
            nifti::NiftiError::IncompatibleLength(got, want) => {
                format!("the file holds {got} bytes of voxels, its header promises {want}: it is truncated")
            }
            e => format!("reading its voxels: {e}"),
        })
    })?;
    let big = h.endianness == nifti::Endianness::Big;
    let mut voxels = sample.decode_voxels(obj.into_volume().raw_data(), big);
    // A slope of 0 or NaN means no scaling (the standard and nibabel agree); an offset that is
    // not finite is none.
    let slope = h.scl_slope as f64;
    let inter = if h.scl_inter.is_finite() { h.scl_inter as f64 } else { 0.0 };
    if slope.is_finite() && slope != 0.0 && (slope, inter) != (1.0, 0.0) {
        let n = voxels.len();
        voxels = Voxels::F32((0..n).map(|i| (voxels.get(i) as f64 * slope + inter) as f32).collect());
    }
    let (dirs, origin) = directions.map_err(&fail)?;
    aligned_grid(dims.map(|d| d as u32), dirs, origin, voxels).map_err(fail)
}

/// The world step along each voxel axis, and where voxel (0, 0, 0) is: NIfTI's method 3 (sform),
/// else method 2 (qform), else method 1 (pixdim only).
fn placement(h: &NiftiHeader) -> Result<([DVec3; 3], DVec3), String> {
    let p = |i: usize| h.pixdim[i] as f64;
    if h.sform_code > 0 {
        let row = |r: [f32; 4]| r.map(|x| x as f64);
        let [x, y, z] = [row(h.srow_x), row(h.srow_y), row(h.srow_z)];
        let col = |c: usize| DVec3::new(x[c], y[c], z[c]);
        return Ok(([col(0), col(1), col(2)], DVec3::new(x[3], y[3], z[3])));
    }
    let spacing = DVec3::new(p(1), p(2), p(3));
    if !(spacing.is_finite() && spacing.min_element() > 0.0) {
        return Err(format!("voxel sizes (pixdim) {spacing}: give three above 0"));
    }
    if h.qform_code > 0 {
        let (b, c, d) = (h.quatern_b as f64, h.quatern_c as f64, h.quatern_d as f64);
        let a = (1.0 - (b * b + c * c + d * d)).max(0.0).sqrt();
        let r = DMat3::from_quat(DQuat::from_xyzw(b, c, d, a));
        // qfac (pixdim[0]) of -1 flips the third axis.
        let qfac = if p(0) < 0.0 { -1.0 } else { 1.0 };
        let offset = DVec3::new(h.quatern_x as f64, h.quatern_y as f64, h.quatern_z as f64);
        let dirs = [r.x_axis * spacing.x, r.y_axis * spacing.y, r.z_axis * spacing.z * qfac];
        return Ok((dirs, offset));
    }
    Ok(([DVec3::X * spacing.x, DVec3::Y * spacing.y, DVec3::Z * spacing.z], DVec3::ZERO))
}
