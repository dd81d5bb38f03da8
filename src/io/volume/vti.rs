//! VTK ImageData (`.vti`, XML) through the `vtkio` crate: ascii and base64 binary data are
//! tested here; appended and zlib-compressed data are read as vtkio reads them. The point-data
//! array named `Scalars`, else the first, must hold one component a point; it is placed on the
//! image's extent, origin and spacing.

use super::{aligned_grid, voxel_count};
use crate::io::LoadError;
use crate::scene::volume::{Grid, Voxels};
use glam::DVec3;
use std::path::Path;
use vtkio::model::{Attribute, DataSet, IOBuffer, Piece};

/// vtkio reads a whole file into its model: files past this are refused before it does (the
/// largest volume irt takes, as float32, and its XML around it).
const MAX_FILE_BYTES: u64 = super::MAX_VOXELS * 4 + (1 << 20);

pub fn load(path: &Path) -> Result<Grid, LoadError> {
    let shown = path.display().to_string();
    let fail = |m: String| LoadError::new(&shown, m);
    let size = std::fs::metadata(path).map_err(|e| fail(e.to_string()))?.len();
    if size > MAX_FILE_BYTES {
        return Err(fail(format!("{size} bytes; .vti files are limited to {MAX_FILE_BYTES}")));
    }
    // vtkio 0.7.0-rc1 panics on some malformed files (the loader fuzzer found an index out of
    // bounds in its XML reader): a panic there is a bad file, said as one.
    let imported = std::panic::catch_unwind(|| vtkio::Vtk::import(path))
        .map_err(|_| fail("not a VTK file irt can read: vtkio failed on it (its message is above)".into()))?;
    let vtk = imported.map_err(|e| fail(format!("not a VTK file irt can read: {e}")))?;
    let DataSet::ImageData { extent, origin, spacing, pieces, .. } = vtk.data else {
        return Err(fail("a VTK file of another data set: irt reads ImageData (.vti) volumes".into()));
    };
    // An extent may start past 0: its first sample is that many spacings from the origin.
    let first = match &extent {
        vtkio::model::Extent::Ranges(r) => r.clone().map(|r| *r.start() as f64),
        vtkio::model::Extent::Dims(_) => [0.0; 3],
    };
    let dims = extent.into_dims();
    voxel_count(dims.map(u64::from)).map_err(&fail)?;
    let [piece] = &pieces[..] else {
        return Err(fail(format!("{} pieces: irt reads an ImageData of one piece", pieces.len())));
    };
    let Piece::Inline(piece) = piece else {
        return Err(fail("a piece in another file: irt reads serial .vti files".into()));
    };
    let arrays: Vec<_> = piece
        .data
        .point
        .iter()
        .filter_map(|a| match a {
            Attribute::DataArray(d) => Some(d),
            Attribute::Field { .. } => None,
        })
        .collect();
    // vtkio drops an array whose length does not fit the extent: such a file has no array here.
    let points = dims.iter().map(|&d| d as usize).product::<usize>();
    let [x, y, z] = dims;
    let array = arrays
        .iter()
        .find(|a| a.name == "Scalars")
        .or(arrays.first())
        .filter(|a| a.data.len() == points)
        .ok_or_else(|| {
            fail(format!(
                "no point-data array of {x}x{y}x{z} = {points} values: irt reads one sample per point"
            ))
        })?;
    if array.elem.num_comp() != 1 {
        let m = format!(
            "array `{}` has {} components: irt reads scalar volumes",
            array.name,
            array.elem.num_comp()
        );
        return Err(fail(m));
    }
    let voxels = match array.data.clone() {
        IOBuffer::U8(v) => Voxels::U8(v),
        IOBuffer::I8(v) => Voxels::I16(v.into_iter().map(i16::from).collect()),
        IOBuffer::U16(v) => Voxels::U16(v),
        IOBuffer::I16(v) => Voxels::I16(v),
        IOBuffer::U32(v) => Voxels::F32(v.into_iter().map(|x| x as f32).collect()),
        IOBuffer::I32(v) => Voxels::F32(v.into_iter().map(|x| x as f32).collect()),
        IOBuffer::F32(v) => Voxels::F32(v),
        IOBuffer::F64(v) => Voxels::F32(v.into_iter().map(|x| x as f32).collect()),
        _ => return Err(fail(format!("array `{}` holds a type irt does not read", array.name))),
    };
    let s = spacing.map(|x| x as f64);
    let dirs = [DVec3::X * s[0], DVec3::Y * s[1], DVec3::Z * s[2]];
    let origin =
        DVec3::from_array(origin.map(|x| x as f64)) + DVec3::from_array(first) * DVec3::from_array(s);
    aligned_grid(dims, dirs, origin, voxels).map_err(|m| fail(format!("array `{}`: {m}", array.name)))
}
