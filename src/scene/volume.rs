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
    /// The smallest and largest sample, found once (a scan of 1 GiB takes half a second; the
    /// window's isovalue keys ask for it on every press).
    range: (f32, f32),
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
        let range = (0..voxels.len()).fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), i| {
            let v = voxels.get(i);
            (lo.min(v), hi.max(v))
        });
        Ok(Grid { dims, spacing, origin, voxels, range })
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
        self.range
    }
}

/// Volumes a scene may hold: the shader keeps their isovalues in its frame uniform, so a new
/// isovalue is a new uniform, not a new scene texture.
pub const MAX_VOLUMES: usize = 4;
/// Isosurfaces one volume may draw at once.
pub const MAX_ISOS: usize = 4;

/// How a volume's samples and macrocells lie in the scene texture: a device matter (lavapipe's
/// caches and a GPU's differ), so a scene may say, and the default is what docs/volumes.md
/// measured best here. Pictures are the same whatever the layout: the macrocells only skip
/// what is certainly empty, and a brick only moves samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Layout {
    /// Edge of the bricks the samples are stored in, a power of two: 1 stores them x fastest,
    /// then y, then z; 4 stores 4x4x4 bricks, each one contiguous.
    pub brick: u32,
    /// Macrocell levels the walk uses, 0 to `accel::macrocells::MAX_LEVELS`.
    pub levels: u32,
}

/// Largest brick edge (a 16-bit brick of 16³ is 8 KiB).
pub const MAX_BRICK: u32 = 16;

impl Default for Layout {
    fn default() -> Layout {
        Layout { brick: 8, levels: crate::accel::macrocells::MAX_LEVELS as u32 }
    }
}

impl Layout {
    /// Checks the fields, in words.
    pub fn check(self) -> Result<Layout, String> {
        if !self.brick.is_power_of_two() || self.brick > MAX_BRICK {
            return Err(format!("brick {} is not a power of two from 1 to {MAX_BRICK}", self.brick));
        }
        let max = crate::accel::macrocells::MAX_LEVELS as u32;
        if self.levels > max {
            return Err(format!("macrocell_levels {} is more than {max}", self.levels));
        }
        Ok(self)
    }
}

/// One isosurface of a volume: the sample value it is drawn at and its material.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Iso {
    pub value: f64,
    pub material: u32,
}

/// A volume placed in a scene: its samples (shared, never copied by a clone of the scene),
/// where they go and the isosurfaces drawn from them. The isosurfaces are surfaces like any
/// other: they cast and take shadows and show in mirrors and through glass.
#[derive(Clone, Debug)]
pub struct Volume {
    pub grid: std::sync::Arc<Grid>,
    /// World from the grid's own coordinates (those of [`Grid::origin`] and
    /// [`Grid::spacing`]): the file's placement, then the scene's scale, rotation and move.
    pub transform: glam::DAffine3,
    pub isos: Vec<Iso>,
    /// How it is drawn: its isosurfaces (`isos`), or MIP or DVR through `transfer`. The
    /// isovalues stay when another look is chosen, so the window can switch back.
    pub look: super::transfer::Look,
    pub transfer: super::transfer::Transfer,
    /// How the device holds it ([`Layout`]).
    pub layout: Layout,
    /// Where the file came from (what `irt convert` writes back), if it came from one.
    pub file: Option<std::path::PathBuf>,
}

/// Equal when placed and drawn alike over equal samples; shared samples (every clone of a
/// scene, every edit in the window) are equal without comparing a gigabyte sample by sample.
impl PartialEq for Volume {
    fn eq(&self, o: &Volume) -> bool {
        (std::sync::Arc::ptr_eq(&self.grid, &o.grid) || self.grid == o.grid)
            && self.transform == o.transform
            && self.isos == o.isos
            && self.look == o.look
            && self.transfer == o.transfer
            && self.layout == o.layout
            && self.file == o.file
    }
}

impl Volume {
    /// `grid` placed by `transform`, drawn as its isosurfaces `isos`, with the default transfer
    /// function over its samples' range for when MIP or DVR is chosen.
    pub fn new(
        grid: std::sync::Arc<Grid>,
        transform: glam::DAffine3,
        isos: Vec<Iso>,
        file: Option<std::path::PathBuf>,
    ) -> Volume {
        let transfer = super::transfer::Transfer::default_for(super::transfer::Look::Iso, grid.range());
        Volume {
            grid,
            transform,
            isos,
            look: super::transfer::Look::Iso,
            transfer,
            layout: Layout::default(),
            file,
        }
    }

    /// Draws it with `look`, and the look's default transfer function over the samples' range.
    pub fn with_look(mut self, look: super::transfer::Look) -> Volume {
        self.look = look;
        self.transfer = super::transfer::Transfer::default_for(look, self.grid.range());
        self
    }

    /// Switches it to `look` (the window's key, `--volume-mode`): the look's default colour map
    /// and opacity over the window it had. Nothing changes when it has that look already.
    pub fn switch_look(&mut self, look: super::transfer::Look) {
        if self.look != look {
            let window = self.transfer.window;
            self.look = look;
            self.transfer = super::transfer::Transfer {
                window,
                ..super::transfer::Transfer::default_for(look, self.grid.range())
            };
        }
    }

    /// Grid index coordinates (sample (i, j, k) at (i, j, k)) from world coordinates: what the
    /// tracers move a ray into before walking the cells. Affine, so a ray's `t` is kept.
    pub fn index_from_world(&self) -> glam::DAffine3 {
        let g = &self.grid;
        glam::DAffine3::from_scale(g.spacing.recip())
            * glam::DAffine3::from_translation(-g.origin)
            * self.transform.inverse()
    }

    /// The world box around the volume's (transformed) box.
    pub fn world_bounds(&self) -> (DVec3, DVec3) {
        let (lo, hi) = self.grid.bounds();
        (0..8).fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(a, b), c| {
            let p = DVec3::new(
                if c & 1 == 0 { lo.x } else { hi.x },
                if c & 2 == 0 { lo.y } else { hi.y },
                if c & 4 == 0 { lo.z } else { hi.z },
            );
            let w = self.transform.transform_point3(p);
            (a.min(w), b.max(w))
        })
    }

    /// Why the volume cannot be drawn, if it cannot (`materials`: how many the scene has).
    pub fn check(&self, materials: usize) -> Result<(), String> {
        if self.isos.is_empty() || self.isos.len() > MAX_ISOS {
            return Err(format!("{} isovalues: give 1 to {MAX_ISOS}", self.isos.len()));
        }
        for iso in &self.isos {
            if !iso.value.is_finite() {
                return Err(format!("isovalue {} is not finite", iso.value));
            }
            if iso.material as usize >= materials {
                return Err(format!("isovalue {} names material {} of {materials}", iso.value, iso.material));
            }
        }
        self.transfer.check()?;
        let det = self.transform.matrix3.determinant();
        if !(det.is_finite() && det.abs() > 1e-300 && self.transform.translation.is_finite()) {
            return Err("its transform is not invertible (a scale of 0?)".into());
        }
        Ok(())
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

/// The first `s` in `[0, 1]` where the trilinear interpolant of `corners` along the segment from
/// `a` to `b` (cell coordinates, each in [0, 1]³) equals `iso`. Along a line the interpolant is
/// a cubic in `s`; it is split at its extrema into monotone pieces (Marmitt et al. 2004) and
/// the first piece that crosses `iso` is bisected. What the shader's cell test computes, in f64.
pub fn cell_hit(corners: &[f64; 8], a: DVec3, b: DVec3, iso: f64) -> Option<f64> {
    let f = |s: f64| trilinear(corners, (a + (b - a) * s).to_array()) - iso;
    // The cubic from four of its values (exact: the interpolant is a cubic along a line).
    let cubic = Cubic::through([f(0.0), f(1.0 / 3.0), f(2.0 / 3.0), f(1.0)]);
    let mut cuts = vec![0.0];
    cuts.extend(cubic.extrema().into_iter().filter(|&s| s > 0.0 && s < 1.0));
    cuts.push(1.0);
    cuts.sort_by(f64::total_cmp);
    for w in cuts.windows(2) {
        let (mut lo, mut hi) = (w[0], w[1]);
        let (flo, fhi) = (cubic.at(lo), cubic.at(hi));
        if flo == 0.0 {
            return Some(lo);
        }
        if flo.signum() == fhi.signum() {
            continue;
        }
        for _ in 0..64 {
            let mid = 0.5 * (lo + hi);
            if cubic.at(mid).signum() == flo.signum() {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        return Some(0.5 * (lo + hi));
    }
    None
}

/// A cubic `c[0] + c[1] s + c[2] s² + c[3] s³`.
struct Cubic([f64; 4]);

impl Cubic {
    /// The cubic through `(0, v0)`, `(1/3, v1)`, `(2/3, v2)`, `(1, v3)`.
    fn through([v0, v1, v2, v3]: [f64; 4]) -> Cubic {
        // Newton's divided differences on the nodes 0, 1/3, 2/3, 1, expanded.
        let d1 = 3.0 * (v1 - v0);
        let d2 = 4.5 * (v2 - 2.0 * v1 + v0);
        let d3 = 4.5 * (v3 - 3.0 * v2 + 3.0 * v1 - v0);
        // v0 + d1 s + d2 s (s - 1/3) + d3 s (s - 1/3) (s - 2/3)
        Cubic([v0, d1 - d2 / 3.0 + d3 * 2.0 / 9.0, d2 - d3, d3])
    }

    fn at(&self, s: f64) -> f64 {
        let [a, b, c, d] = self.0;
        a + s * (b + s * (c + s * d))
    }

    /// The real roots of the derivative `b + 2c s + 3d s²`.
    fn extrema(&self) -> Vec<f64> {
        let [_, b, c, d] = self.0;
        let (qa, qb, qc) = (3.0 * d, 2.0 * c, b);
        if qa.abs() < 1e-300 {
            return if qb != 0.0 { vec![-qc / qb] } else { vec![] };
        }
        let disc = qb * qb - 4.0 * qa * qc;
        if disc < 0.0 {
            return vec![];
        }
        let r = disc.sqrt();
        // The stable pair: no cancellation between -qb and ±r.
        let q = -0.5 * (qb + qb.signum() * r);
        let mut out = vec![q / qa];
        if q != 0.0 {
            out.push(qc / q);
        }
        out
    }
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

    /// Against dense sampling of random cells along random segments: the same first crossing
    /// wherever the sampling sees one (a crossing pair closer than its step it cannot see).
    #[test]
    fn the_cell_hit_is_dense_sampling_s_first_crossing() {
        let mut seed = 3u64;
        let mut next = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut hits = 0;
        for case in 0..2000 {
            let c: [f64; 8] = std::array::from_fn(|_| next() * 10.0);
            let a = DVec3::new(next(), next(), next());
            let b = DVec3::new(next(), next(), next());
            let iso = 2.0 + next() * 6.0;
            let f = |s: f64| trilinear(&c, (a + (b - a) * s).to_array()) - iso;
            let n = 20_000;
            let sampled =
                (0..n).find(|&i| f(i as f64 / n as f64).signum() != f((i + 1) as f64 / n as f64).signum());
            let got = cell_hit(&c, a, b, iso);
            match (sampled, got) {
                (Some(i), Some(s)) => {
                    assert!(
                        (s - i as f64 / n as f64).abs() <= 1.0 / n as f64 + 1e-12,
                        "case {case}: {s} against {i}/{n}"
                    );
                    assert!(f(s).abs() < 1e-9, "case {case}: f({s}) = {}", f(s));
                    hits += 1;
                }
                (None, None) => {}
                // A double crossing inside one step: the cubic sees it, the sampling does not.
                (None, Some(s)) => assert!(f(s).abs() < 1e-9, "case {case}"),
                (Some(i), None) => {
                    panic!("case {case}: sampling crosses at {i}/{n}, the cell test sees none")
                }
            }
        }
        assert!(hits > 300, "the cases cross ({hits})");
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
