//! Uniform grid over the scene with a coarser macro-cell occupancy level, flattened to CSR arrays.
use crate::scene::Scene;
use glam::DVec3;

/// What kind of primitive a [`PrimRef`] points at (its top two bits).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum PrimKind {
    Sphere = 0,
    Triangle = 1,
}

/// A primitive reference as stored in the grid: kind in bits 30..32, index into that kind's
/// array (`Scene::spheres`, `Scene::triangles()`) in bits 0..30.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(transparent)]
pub struct PrimRef(pub u32);

impl PrimRef {
    pub const INDEX_BITS: u32 = 30;
    pub const MAX_INDEX: u32 = (1 << Self::INDEX_BITS) - 1;
    pub fn new(kind: PrimKind, index: u32) -> Self {
        assert!(index <= Self::MAX_INDEX);
        PrimRef(((kind as u32) << Self::INDEX_BITS) | index)
    }
    pub fn kind(self) -> PrimKind {
        match self.0 >> Self::INDEX_BITS {
            0 => PrimKind::Sphere,
            _ => PrimKind::Triangle,
        }
    }
    pub fn index(self) -> u32 {
        self.0 & Self::MAX_INDEX
    }
}

/// The flattened grid. Cell `(x, y, z)` has linear index `x + res[0] * (y + res[1] * z)`; its
/// primitives are `prim_refs[cell_start[c] as usize..cell_start[c + 1] as usize]`.
#[derive(Clone, Debug, PartialEq)]
pub struct Grid {
    pub min: DVec3,
    pub max: DVec3,
    pub res: [u32; 3],
    /// `(max - min) / res` per axis.
    pub cell_size: DVec3,
    /// `cell_count + 1` entries, CSR offsets into `prim_refs`.
    pub cell_start: Vec<u32>,
    pub prim_refs: Vec<PrimRef>,
    /// Fine cells per macro-cell side.
    pub macro_factor: u32,
    /// `ceil(res / macro_factor)` per axis.
    pub macro_res: [u32; 3],
    /// One bit per macro-cell (same linear order as cells), set when any of its cells is non-empty.
    pub macro_bits: Vec<u32>,
}

impl Grid {
    pub fn build(scene: &Scene) -> Grid {
        // TEMPORARY STUB (uncommitted): one cell with everything.
        let mut lo = DVec3::splat(f64::MAX);
        let mut hi = DVec3::splat(-f64::MAX);
        let mut refs = vec![];
        for (i, s) in scene.spheres.iter().enumerate() {
            lo = lo.min(s.center - s.radius);
            hi = hi.max(s.center + s.radius);
            refs.push(PrimRef::new(PrimKind::Sphere, i as u32));
        }
        for (i, t) in scene.triangles().enumerate() {
            for p in t.p {
                lo = lo.min(p);
                hi = hi.max(p);
            }
            refs.push(PrimRef::new(PrimKind::Triangle, i as u32));
        }
        let pad = (hi - lo).max_element() * 1e-3 + 1e-3;
        lo -= pad;
        hi += pad;
        Grid {
            min: lo,
            max: hi,
            res: [1, 1, 1],
            cell_size: hi - lo,
            cell_start: vec![0, refs.len() as u32],
            prim_refs: refs,
            macro_factor: 4,
            macro_res: [1, 1, 1],
            macro_bits: vec![1],
        }
    }
    pub fn stats(&self) -> String {
        "stub".into()
    }
}
