//! Sampled volumes (PAPER.md §10): a regular grid of scalar samples, as NRRD, NIfTI and VTK
//! ImageData files hold them. Sample `(i, j, k)` sits at `origin + (i, j, k) * spacing`; between
//! samples the field is the trilinear interpolant, whose level sets are the isosurfaces RTRT
//! traced and whose gradient is their normal.

use glam::DVec3;

/// The samples, in the type the file stores them (a 1 GiB 16-bit volume stays 1 GiB), x fastest,
/// then y, then z.
#[derive(Clone, Debug, PartialEq)]
pub enum Voxels {
    U8(Vec<u8>),
    U16(Vec<u16>),
    I16(Vec<i16>),
    F32(Vec<f32>),
}

impl Voxels {
    pub fn len(&self) -> usize {
        match self {
            Voxels::U8(v) => v.len(),
            Voxels::U16(v) => v.len(),
            Voxels::I16(v) => v.len(),
            Voxels::F32(v) => v.len(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Sample `i` as a float (exact for every stored type but f32's own).
    pub fn get(&self, i: usize) -> f32 {
        match self {
            Voxels::U8(v) => v[i] as f32,
            Voxels::U16(v) => v[i] as f32,
            Voxels::I16(v) => v[i] as f32,
            Voxels::F32(v) => v[i],
        }
    }

    /// The name a user knows the type by.
    pub fn type_name(&self) -> &'static str {
        match self {
            Voxels::U8(_) => "uint8",
            Voxels::U16(_) => "uint16",
            Voxels::I16(_) => "int16",
            Voxels::F32(_) => "float32",
        }
    }

    /// Bytes a sample takes.
    pub fn sample_bytes(&self) -> usize {
        match self {
            Voxels::U8(_) => 1,
            Voxels::U16(_) | Voxels::I16(_) => 2,
            Voxels::F32(_) => 4,
        }
    }
}

/// A volume's samples on their grid.
#[derive(Clone, Debug, PartialEq)]
pub struct Grid {
    /// Samples along x, y and z (each at least 2: a cell needs two samples a side).
    pub dims: [u32; 3],
    /// World distance between neighbouring samples, per axis (each above 0).
    pub spacing: DVec3,
    /// Where sample (0, 0, 0) sits.
    pub origin: DVec3,
    pub voxels: Voxels,
}

impl Grid {
    /// A grid, checked: the sample count matches `dims`, each side has two samples or more,
    /// spacings are finite and positive, the origin is finite, and no sample is NaN.
    pub fn new(dims: [u32; 3], spacing: DVec3, origin: DVec3, voxels: Voxels) -> Result<Grid, String> {
        if let Some(d) = dims.iter().find(|&&d| d < 2) {
            return Err(format!("a side of {d} sample(s): a volume needs at least 2 a side ({dims:?})"));
        }
        let n = dims.iter().map(|&d| d as u64).product::<u64>();
        if voxels.len() as u64 != n {
            return Err(format!("{} samples for {}x{}x{} = {n}", voxels.len(), dims[0], dims[1], dims[2]));
        }
        if !(spacing.is_finite() && spacing.min_element() > 0.0) {
            return Err(format!("spacing {spacing}: give three finite distances above 0"));
        }
        if !origin.is_finite() {
            return Err(format!("origin {origin} is not finite"));
        }
        if let Voxels::F32(v) = &voxels {
            if let Some(i) = v.iter().position(|x| !x.is_finite()) {
                return Err(format!("sample {i} is {}: a volume's samples must be finite", v[i]));
            }
        }
        Ok(Grid { dims, spacing, origin, voxels })
    }

    /// Sample `(i, j, k)`.
    pub fn at(&self, i: u32, j: u32, k: u32) -> f32 {
        let [nx, ny, _] = self.dims;
        self.voxels.get(i as usize + nx as usize * (j as usize + ny as usize * k as usize))
    }

    /// Cells along each axis (one fewer than samples).
    pub fn cells(&self) -> [u32; 3] {
        self.dims.map(|d| d - 1)
    }

    /// The world box the samples span.
    pub fn bounds(&self) -> (DVec3, DVec3) {
        let [nx, ny, nz] = self.cells();
        (self.origin, self.origin + DVec3::new(nx as f64, ny as f64, nz as f64) * self.spacing)
    }

    /// The eight samples of cell `(i, j, k)`, corner `c` at bit 0 = +x, bit 1 = +y, bit 2 = +z.
    pub fn corners(&self, [i, j, k]: [u32; 3]) -> [f64; 8] {
        std::array::from_fn(|c| {
            self.at(i + (c & 1) as u32, j + (c >> 1 & 1) as u32, k + (c >> 2) as u32) as f64
        })
    }

    /// The smallest and largest sample.
    pub fn range(&self) -> (f32, f32) {
        (0..self.voxels.len()).fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), i| {
            let v = self.voxels.get(i);
            (lo.min(v), hi.max(v))
        })
    }
}

/// The trilinear interpolant of a cell's corners ([`Grid::corners`]) at `(u, v, w)` in [0, 1]³.
pub fn trilinear(c: &[f64; 8], [u, v, w]: [f64; 3]) -> f64 {
    let lerp = |a: f64, b: f64, t: f64| a + (b - a) * t;
    let x00 = lerp(c[0], c[1], u);
    let x10 = lerp(c[2], c[3], u);
    let x01 = lerp(c[4], c[5], u);
    let x11 = lerp(c[6], c[7], u);
    lerp(lerp(x00, x10, v), lerp(x01, x11, v), w)
}

/// The gradient of [`trilinear`] with respect to `(u, v, w)` (divide by the spacing for world
/// units).
pub fn trilinear_gradient(c: &[f64; 8], [u, v, w]: [f64; 3]) -> DVec3 {
    let lerp = |a: f64, b: f64, t: f64| a + (b - a) * t;
    let du = lerp(lerp(c[1] - c[0], c[3] - c[2], v), lerp(c[5] - c[4], c[7] - c[6], v), w);
    let dv = lerp(lerp(c[2] - c[0], c[3] - c[1], u), lerp(c[6] - c[4], c[7] - c[5], u), w);
    let dw = lerp(lerp(c[4] - c[0], c[5] - c[1], u), lerp(c[6] - c[2], c[7] - c[3], u), v);
    DVec3::new(du, dv, dw)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp() -> Grid {
        // f = x + 10 y + 100 z on a 3x2x2 grid of spacing (1, 2, 4).
        let v = (0..12).map(|n| (n % 3 + 10 * (n / 3 % 2) + 100 * (n / 6)) as f32).collect();
        Grid::new([3, 2, 2], DVec3::new(1.0, 2.0, 4.0), DVec3::ZERO, Voxels::F32(v)).unwrap()
    }

    #[test]
    fn samples_sit_x_fastest_and_the_interpolant_is_exact_on_a_linear_field() {
        let g = ramp();
        assert_eq!(g.at(2, 1, 1), 112.0);
        assert_eq!(g.bounds(), (DVec3::ZERO, DVec3::new(2.0, 2.0, 4.0)));
        assert_eq!(g.range(), (0.0, 112.0));
        let c = g.corners([1, 0, 0]);
        assert_eq!(trilinear(&c, [0.5, 0.25, 0.75]), 1.5 + 2.5 + 75.0);
        assert_eq!(trilinear_gradient(&c, [0.3, 0.6, 0.1]), DVec3::new(1.0, 10.0, 100.0));
    }

    #[test]
    fn a_bad_grid_is_refused_in_words() {
        let e = Grid::new([2, 2, 2], DVec3::ONE, DVec3::ZERO, Voxels::U8(vec![0; 7])).unwrap_err();
        assert!(e.contains("7 samples for 2x2x2 = 8"), "{e}");
        let e = Grid::new([1, 2, 2], DVec3::ONE, DVec3::ZERO, Voxels::U8(vec![0; 4])).unwrap_err();
        assert!(e.contains("at least 2 a side"), "{e}");
        let e =
            Grid::new([2, 2, 2], DVec3::new(1.0, 0.0, 1.0), DVec3::ZERO, Voxels::U8(vec![0; 8])).unwrap_err();
        assert!(e.contains("above 0"), "{e}");
        let mut v = vec![0.0f32; 8];
        v[5] = f32::NAN;
        let e = Grid::new([2, 2, 2], DVec3::ONE, DVec3::ZERO, Voxels::F32(v)).unwrap_err();
        assert!(e.contains("sample 5 is NaN"), "{e}");
    }
}
