//! Uniform grid over the scene with a coarser macro-cell occupancy level, flattened to CSR arrays.
//!
//! Built once on the CPU in f64 and walked by the shader in f32. Two things make that safe:
//! primitives are inserted into every cell they overlap *grown by a margin* that covers f32
//! rounding of the grid's planes and the shader's cell arithmetic, and the grid box is padded
//! so that nothing lies exactly on its boundary (flat scenes get a real thickness).

use crate::scene::Scene;
use glam::DVec3;
use std::fmt;

/// What kind of primitive a [`PrimRef`] points at (its top two bits).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum PrimKind {
    Sphere = 0,
    Triangle = 1,
    Cone = 2,
    /// A volume's isosurfaces: its macrocells are the leaf's inside (`shaders/volume.wgsl`).
    Volume = 3,
    /// A leaf of a spline patch (`scene::patch::leaves`): solved by Newton (`shaders/patch.wgsl`).
    Patch = 4,
}

/// A primitive reference as stored in the grid: kind in bits 29..32, index into that kind's
/// array (`Scene::spheres`, `Scene::triangles()`, `Scene::cones`, `Scene::volumes`, the patches'
/// leaves) in bits 0..29. All ones is the shader's "no hit", kind 7, which no primitive has.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(transparent)]
pub struct PrimRef(pub u32);

impl PrimRef {
    pub const INDEX_BITS: u32 = 29;
    pub const KIND_SHIFT: u32 = 29;
    pub const MAX_INDEX: u32 = (1 << Self::INDEX_BITS) - 1;
    pub fn new(kind: PrimKind, index: u32) -> Self {
        assert!(index <= Self::MAX_INDEX);
        PrimRef(((kind as u32) << Self::KIND_SHIFT) | index)
    }
    pub fn kind(self) -> PrimKind {
        match self.0 >> Self::KIND_SHIFT {
            0 => PrimKind::Sphere,
            1 => PrimKind::Triangle,
            2 => PrimKind::Cone,
            3 => PrimKind::Volume,
            _ => PrimKind::Patch,
        }
    }
    pub fn index(self) -> u32 {
        self.0 & Self::MAX_INDEX
    }
}

/// Target cells per primitive. The classic heuristic (Cleary & Wyvill; Wald et al. 2006) sizes
/// cells so the grid has λN cells, cubic in shape: res_a = extent_a · ∛(λN / V). Larger λ means
/// fewer intersection tests per ray but more DDA steps and memory; macro-cells make the empty
/// cells that a large λ creates cheap to skip. 16 takes the large gain on a small object over a
/// large floor (SPD balls) for a few per cent on tiny scenes; finer grids gain little more
/// (docs/performance.md, "The accelerator").
pub const CELLS_PER_PRIMITIVE: f64 = 16.0;
/// Cells per axis, at most.
pub const MAX_RES: u32 = 512;
/// Total cells, at most (8 Mi cells: 32 MiB of ranges).
pub const MAX_CELLS: u64 = 1 << 23;
/// Fine cells per macro-cell side.
pub const MACRO_FACTOR: u32 = 4;
/// The grid box is padded by this fraction of its largest extent on every side.
const PAD_REL: f64 = 1e-3;
/// Insertion margin as a fraction of the cell size: a primitive within this distance of a cell
/// is listed in it, which absorbs the shader's f32 rounding of cell boundaries.
const MARGIN_CELL_REL: f64 = 1e-3;
/// ... and as a multiple of the f32 spacing at the scene's coordinate magnitude, for scenes far
/// from the origin where f32 ulps, not cell sizes, dominate.
const MARGIN_ULPS: f64 = 8.0;

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
    /// Per cell, in increasing primitive order (spheres, triangles, cones): the build is
    /// deterministic.
    pub prim_refs: Vec<PrimRef>,
    /// `ceil(res / MACRO_FACTOR)` per axis.
    pub macro_res: [u32; 3],
    /// One bit per macro-cell (same linear order as cells), set when any of its cells is non-empty.
    pub macro_bits: Vec<u32>,
}

/// An axis-aligned box.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Aabb {
    lo: DVec3,
    hi: DVec3,
}

impl Aabb {
    const EMPTY: Aabb = Aabb { lo: DVec3::splat(f64::INFINITY), hi: DVec3::splat(f64::NEG_INFINITY) };

    fn union(self, o: Aabb) -> Aabb {
        Aabb { lo: self.lo.min(o.lo), hi: self.hi.max(o.hi) }
    }
    fn of_points(p: &[DVec3]) -> Aabb {
        p.iter().fold(Aabb::EMPTY, |b, &q| b.union(Aabb { lo: q, hi: q }))
    }
    fn is_empty(&self) -> bool {
        self.lo.x > self.hi.x
    }
}

/// A primitive as the builder sees it: its bounds and an exact overlap test against a box.
enum Shape {
    Sphere {
        center: DVec3,
        radius: f64,
    },
    Triangle([DVec3; 3]),
    Cone {
        base: DVec3,
        r0: f64,
        apex: DVec3,
        r1: f64,
    },
    /// A volume, by its world box.
    Box(Aabb),
}

impl Shape {
    fn bounds(&self) -> Aabb {
        match *self {
            Shape::Sphere { center, radius } => Aabb { lo: center - radius, hi: center + radius },
            Shape::Triangle(p) => Aabb::of_points(&p),
            Shape::Cone { base, r0, apex, r1 } => {
                // Each end disc reaches r sqrt(1 - a_i²) along axis i.
                let a = (apex - base).normalize();
                let reach = (DVec3::ONE - a * a).max(DVec3::ZERO).map(f64::sqrt);
                Aabb { lo: base - reach * r0, hi: base + reach * r0 }
                    .union(Aabb { lo: apex - reach * r1, hi: apex + reach * r1 })
            }
            Shape::Box(b) => b,
        }
    }

    /// Whether the shape overlaps the box.
    fn overlaps(&self, b: &Aabb) -> bool {
        match *self {
            // Distance from the centre to the nearest point of the box.
            Shape::Sphere { center, radius } => {
                center.clamp(b.lo, b.hi).distance_squared(center) <= radius * radius
            }
            Shape::Triangle(p) => triangle_overlaps_box(p, b),
            Shape::Cone { base, r0, apex, r1 } => cone_overlaps_box(base, r0, apex, r1, b),
            Shape::Box(v) => v.lo.cmple(b.hi).all() && b.lo.cmple(v.hi).all(),
        }
    }
}

/// Conservative separating-axis test of the solid truncated cone (the convex hull of its two end
/// discs, so a superset of the open surface) against a box. Axes tried: the box's three face
/// normals (the cone's tight bounds), the cone's axis, and the axis crossed with the box's edge
/// directions and diagonals (seven directions around the axis). A body with a curved side can
/// also be separated along other axes, so this may list a cone in a cell it misses near a
/// corner of the cell (never farther than √3 times its larger radius from the axis), never the
/// other way round.
fn cone_overlaps_box(base: DVec3, r0: f64, apex: DVec3, r1: f64, b: &Aabb) -> bool {
    let c = (b.lo + b.hi) * 0.5;
    let h = (b.hi - b.lo) * 0.5;
    let a = (apex - base).normalize();
    let separated = |u: DVec3| {
        // Support of a disc (centre e, radius r, normal a) along u: e·u ± r |u - (u·a) a|.
        let spread = (u - u.dot(a) * a).length();
        let (e0, e1) = ((base - c).dot(u), (apex - c).dot(u));
        let lo = (e0 - r0 * spread).min(e1 - r1 * spread);
        let hi = (e0 + r0 * spread).max(e1 + r1 * spread);
        let r = h.dot(u.abs());
        lo > r || hi < -r
    };
    let axes = [DVec3::X, DVec3::Y, DVec3::Z];
    let diagonals = [
        DVec3::new(1.0, 1.0, 1.0),
        DVec3::new(-1.0, 1.0, 1.0),
        DVec3::new(1.0, -1.0, 1.0),
        DVec3::new(1.0, 1.0, -1.0),
    ];
    !(axes.into_iter().any(separated)
        || separated(a)
        || axes.into_iter().chain(diagonals).any(|e| separated(a.cross(e))))
}

/// Separating-axis test of a triangle against a box (Akenine-Möller 2001): the box's three
/// face normals, the triangle's normal and the nine edge × axis cross products. Exact in
/// exact arithmetic; callers pass a box grown by a margin that dominates f64 rounding.
fn triangle_overlaps_box(p: [DVec3; 3], b: &Aabb) -> bool {
    let c = (b.lo + b.hi) * 0.5;
    let h = (b.hi - b.lo) * 0.5;
    let v = p.map(|q| q - c);
    let separated = |axis: DVec3| {
        let r = h.dot(axis.abs());
        let (a, b2, c2) = (v[0].dot(axis), v[1].dot(axis), v[2].dot(axis));
        a.min(b2).min(c2) > r || a.max(b2).max(c2) < -r
    };
    if [DVec3::X, DVec3::Y, DVec3::Z].into_iter().any(separated) {
        return false;
    }
    let e = [v[1] - v[0], v[2] - v[1], v[0] - v[2]];
    // A degenerate triangle has a zero normal; a zero axis separates nothing, so the test
    // falls back to the remaining axes (conservative, as a zero-area triangle is never hit).
    if separated(e[0].cross(e[1])) {
        return false;
    }
    !e.iter().any(|&ei| [DVec3::X, DVec3::Y, DVec3::Z].into_iter().any(|a| separated(ei.cross(a))))
}

/// Summary of a built grid, for logs and `irt bench`.
#[derive(Clone, Debug, PartialEq)]
pub struct GridStats {
    pub res: [u32; 3],
    pub cells: usize,
    pub empty_cells: usize,
    pub prims: usize,
    pub refs: usize,
    pub max_refs_per_cell: u32,
    pub macro_res: [u32; 3],
    pub macro_occupied: usize,
    /// Bytes of cell ranges, references and macro bits as stored (before packing).
    pub bytes: usize,
}

impl fmt::Display for GridStats {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        let [x, y, z] = self.res;
        let [mx, my, mz] = self.macro_res;
        let macros = (mx * my * mz) as f64;
        write!(
            f,
            "{x}x{y}x{z} cells ({:.0}% empty), {} refs for {} primitives ({:.2} per primitive, \
             at most {} in a cell), macro-cells {mx}x{my}x{mz} ({:.0}% occupied), {:.1} MiB",
            100.0 * self.empty_cells as f64 / self.cells as f64,
            self.refs,
            self.prims,
            self.refs as f64 / self.prims.max(1) as f64,
            self.max_refs_per_cell,
            100.0 * self.macro_occupied as f64 / macros,
            self.bytes as f64 / (1024.0 * 1024.0)
        )
    }
}

/// Primitives inserted into the grid between progress reports.
const PROGRESS_STEP: usize = 1 << 16;
/// Below this many primitives per core, a second build thread costs more than it saves.
const MIN_PRIMS_PER_THREAD: usize = 1 << 15;

/// The scene's primitives by one index (spheres, then every mesh's triangles, then cones), each
/// made into a [`Shape`] when asked: a list of shapes would cost ~90 bytes per primitive, which
/// for a large mesh is more than the mesh itself.
struct Prims<'a> {
    scene: &'a Scene,
    /// The patches' leaves (after the volumes in the global order).
    leaves: crate::scene::patch::leaves::Leaves,
    /// Index of each mesh's first triangle among all triangles, and the total at the end.
    mesh_start: Vec<usize>,
}

impl<'a> Prims<'a> {
    fn new(scene: &'a Scene) -> Self {
        let mut mesh_start = vec![0];
        for m in &scene.meshes {
            mesh_start.push(mesh_start.last().unwrap() + m.indices.len());
        }
        Prims { scene, leaves: crate::scene::patch::leaves::Leaves::build(&scene.patches), mesh_start }
    }

    fn len(&self) -> usize {
        self.scene.spheres.len()
            + self.mesh_start.last().unwrap()
            + self.scene.cones.len()
            + self.scene.volumes.len()
            + self.leaves.leaves.len()
    }

    fn bounds(&self, ranges: &[std::ops::Range<usize>]) -> Aabb {
        let mut b = Aabb::EMPTY;
        for r in ranges {
            self.for_each(r.clone(), |_, shape| b = b.union(shape.bounds()));
        }
        b
    }

    /// Calls `f` with each primitive of `range` in order. Triangles are reached by walking the
    /// meshes from the one holding the range's first, not by a search per triangle.
    fn for_each(&self, range: std::ops::Range<usize>, mut f: impl FnMut(PrimRef, Shape)) {
        let s = self.scene;
        let (spheres, triangles) = (s.spheres.len(), *self.mesh_start.last().unwrap());
        for i in range.start.min(spheres)..range.end.min(spheres) {
            let sp = &s.spheres[i];
            f(
                PrimRef::new(PrimKind::Sphere, i as u32),
                Shape::Sphere { center: sp.center, radius: sp.radius },
            );
        }
        let (t0, t1) = (
            range.start.clamp(spheres, spheres + triangles) - spheres,
            range.end.clamp(spheres, spheres + triangles) - spheres,
        );
        if t0 < t1 {
            let mut m = self.mesh_start.partition_point(|&start| start <= t0) - 1;
            for t in t0..t1 {
                while t >= self.mesh_start[m + 1] {
                    m += 1;
                }
                let mesh = &s.meshes[m];
                let p = mesh.indices[t - self.mesh_start[m]].map(|v| mesh.positions[v as usize]);
                f(PrimRef::new(PrimKind::Triangle, t as u32), Shape::Triangle(p));
            }
        }
        let first_cone = spheres + triangles;
        let first_volume = first_cone + s.cones.len();
        for i in range.start.clamp(first_cone, first_volume)..range.end.clamp(first_cone, first_volume) {
            let k = i - first_cone;
            let c = &s.cones[k];
            let shape = Shape::Cone { base: c.base, r0: c.base_radius, apex: c.apex, r1: c.apex_radius };
            f(PrimRef::new(PrimKind::Cone, k as u32), shape);
        }
        let first_leaf = first_volume + s.volumes.len();
        for i in range.start.clamp(first_volume, first_leaf)..range.end.clamp(first_volume, first_leaf) {
            let v = i - first_volume;
            let (lo, hi) = s.volumes[v].world_bounds();
            f(PrimRef::new(PrimKind::Volume, v as u32), Shape::Box(Aabb { lo, hi }));
        }
        for i in range.start.max(first_leaf)..range.end.max(first_leaf) {
            let leaf = &self.leaves.leaves[i - first_leaf];
            f(
                PrimRef::new(PrimKind::Patch, (i - first_leaf) as u32),
                Shape::Box(Aabb { lo: leaf.lo, hi: leaf.hi }),
            );
        }
    }
}

impl Grid {
    /// Builds the grid for every sphere, mesh triangle and cone of `scene` (which must be valid).
    /// The grid does not depend on the shadow mode: `shell` mode keeps its shells in a list of
    /// objects of its own (docs/shadows.md, Shell objects), not in the cells.
    pub fn build(scene: &Scene) -> Grid {
        Self::build_with_progress(scene, &|_, _| {})
    }

    /// [`Grid::build`], calling `progress(done, total)` as primitives are inserted (from any of
    /// the build threads). Primitives are split into contiguous ranges, one per core, each
    /// thread listing its (cell, ref) pairs; the counting sort then reads the ranges in order,
    /// so the cells list their primitives in the same order whatever the thread count.
    pub fn build_with_progress(scene: &Scene, progress: &(dyn Fn(usize, usize) + Sync)) -> Grid {
        let n = Prims::new(scene).len();
        let threads =
            std::thread::available_parallelism().map_or(1, |t| t.get()).min(n.div_ceil(MIN_PRIMS_PER_THREAD));
        Self::build_on(scene, threads.max(1), progress)
    }

    fn build_on(scene: &Scene, threads: usize, progress: &(dyn Fn(usize, usize) + Sync)) -> Grid {
        let prims = Prims::new(scene);
        let n = prims.len();
        let frame = Lattice::fit(prims.bounds(std::slice::from_ref(&(0..n))), n);
        Self::build_framed(&prims, frame, threads, progress)
    }

    /// [`Grid::build`] in a frame chosen by the caller (which must hold every primitive): what
    /// a moving scene keeps from frame to frame so that [`Grid::update`] can reuse the cells.
    pub fn build_in(scene: &Scene, frame: Lattice) -> Grid {
        let prims = Prims::new(scene);
        let threads = std::thread::available_parallelism()
            .map_or(1, |t| t.get())
            .min(prims.len().div_ceil(MIN_PRIMS_PER_THREAD))
            .max(1);
        Self::build_framed(&prims, frame, threads, &|_, _| {})
    }

    fn build_framed(
        prims: &Prims,
        frame: Lattice,
        threads: usize,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Grid {
        let n = prims.len();
        let lists = frame.insert(prims, std::slice::from_ref(&(0..n)), threads, progress);
        let cells = frame.cells();
        let pairs = lists.iter().flatten();
        let mut cell_start = vec![0u32; cells + 1];
        for &(c, _) in pairs.clone() {
            cell_start[c as usize + 1] += 1;
        }
        for c in 0..cells {
            cell_start[c + 1] += cell_start[c];
        }
        let mut fill = cell_start.clone();
        let mut prim_refs = vec![PrimRef(0); cell_start[cells] as usize];
        for &(c, r) in pairs {
            prim_refs[fill[c as usize] as usize] = r;
            fill[c as usize] += 1;
        }
        frame.grid(cell_start, prim_refs)
    }

    /// Where this grid lies and how it is cut.
    pub fn lattice(&self) -> Lattice {
        Lattice { min: self.min, max: self.max, res: self.res }
    }

    /// The grid of `scene` in this grid's frame, reusing the cells of every primitive outside
    /// `moving` (ranges of primitive indices: spheres, then all triangles, then cones; sorted,
    /// disjoint): only the moving primitives are inserted again. Equal to
    /// `Grid::build_in(scene, self.lattice())` (a cell lists its primitives in index order either
    /// way) provided the other primitives are where they were when this grid was built and
    /// every primitive lies in the frame.
    pub fn update(&self, scene: &Scene, moving: &[std::ops::Range<usize>]) -> Grid {
        let prims = Prims::new(scene);
        let frame = self.lattice();
        let threads = std::thread::available_parallelism().map_or(1, |t| t.get());
        let total: usize = moving.iter().map(|r| r.len()).sum();
        let threads = threads.min(total.div_ceil(MIN_PRIMS_PER_THREAD)).max(1);
        let fresh: Vec<(u32, PrimRef)> =
            frame.insert(&prims, moving, threads, &|_, _| {}).into_iter().flatten().collect();
        let cells = frame.cells();
        // The fresh pairs by cell (stable: each cell's in primitive order).
        let mut fresh_start = vec![0u32; cells + 1];
        for &(c, _) in &fresh {
            fresh_start[c as usize + 1] += 1;
        }
        for c in 0..cells {
            fresh_start[c + 1] += fresh_start[c];
        }
        let mut fill = fresh_start.clone();
        let mut fresh_refs = vec![PrimRef(0); fresh.len()];
        for &(c, r) in &fresh {
            fresh_refs[fill[c as usize] as usize] = r;
            fill[c as usize] += 1;
        }
        let (spheres, triangles) = (scene.spheres.len(), *prims.mesh_start.last().unwrap());
        let global = |r: PrimRef| match r.kind() {
            PrimKind::Sphere => r.index() as usize,
            PrimKind::Triangle => spheres + r.index() as usize,
            PrimKind::Cone => spheres + triangles + r.index() as usize,
            PrimKind::Volume => spheres + triangles + scene.cones.len() + r.index() as usize,
            PrimKind::Patch => {
                spheres + triangles + scene.cones.len() + scene.volumes.len() + r.index() as usize
            }
        };
        let is_moving = |r: PrimRef| {
            let g = global(r);
            let i = moving.partition_point(|m| m.end <= g);
            i < moving.len() && moving[i].contains(&g)
        };
        // Each cell: its kept references merged with its fresh ones. A reference's value orders
        // as its primitive index does (kind in the top bits, kinds in index order).
        let mut cell_start = Vec::with_capacity(cells + 1);
        let mut prim_refs = Vec::with_capacity(self.prim_refs.len() + fresh_refs.len());
        cell_start.push(0u32);
        for c in 0..cells {
            let old = &self.prim_refs[self.cell_start[c] as usize..self.cell_start[c + 1] as usize];
            let new = &fresh_refs[fresh_start[c] as usize..fresh_start[c + 1] as usize];
            let mut kept = old.iter().copied().filter(|&r| !is_moving(r)).peekable();
            let mut new = new.iter().copied().peekable();
            loop {
                let take_new = match (kept.peek(), new.peek()) {
                    (Some(k), Some(n)) => n.0 < k.0,
                    (None, Some(_)) => true,
                    (Some(_), None) => false,
                    (None, None) => break,
                };
                prim_refs.push(if take_new { new.next() } else { kept.next() }.expect("peeked"));
            }
            cell_start.push(prim_refs.len() as u32);
        }
        frame.grid(cell_start, prim_refs)
    }

    /// The primitives that `scene`'s motions move (sphere, cone and mesh targets; lights are
    /// no primitives), as sorted, disjoint ranges of indices as in [`Grid::update`].
    pub fn moving_prims(scene: &Scene) -> Vec<std::ops::Range<usize>> {
        use crate::scene::Target;
        let prims = Prims::new(scene);
        let (spheres, triangles) = (scene.spheres.len(), *prims.mesh_start.last().unwrap());
        let mut ranges: Vec<std::ops::Range<usize>> = scene
            .motions
            .iter()
            .filter_map(|a| match a.target {
                Target::Sphere(i) => Some(i as usize..i as usize + 1),
                Target::Mesh(m) => {
                    let m = m as usize;
                    Some(spheres + prims.mesh_start[m]..spheres + prims.mesh_start[m + 1])
                }
                Target::Cone(k) => {
                    Some(spheres + triangles + k as usize..spheres + triangles + k as usize + 1)
                }
                Target::Light(_) => None,
            })
            .filter(|r| !r.is_empty())
            .collect();
        ranges.sort_by_key(|r| r.start);
        let mut merged: Vec<std::ops::Range<usize>> = Vec::new();
        for r in ranges {
            match merged.last_mut() {
                Some(last) if r.start <= last.end => last.end = last.end.max(r.end),
                _ => merged.push(r),
            }
        }
        merged
    }

    /// Calls `f(reference, lo, hi)` with the bounds of every primitive of `scene` in index order
    /// (spheres, triangles, cones): the boxes the grid inserts by, which the BVH
    /// (`accel::bvh`) is built over too.
    pub fn for_each_bound(scene: &Scene, mut f: impl FnMut(PrimRef, DVec3, DVec3)) {
        let prims = Prims::new(scene);
        prims.for_each(0..prims.len(), |r, shape| {
            let b = shape.bounds();
            f(r, b.lo, b.hi)
        });
    }

    /// The bounds of primitives `ranges` of `scene` (indices as in [`Grid::update`]); `None`
    /// when there are none.
    pub fn bounds_of(scene: &Scene, ranges: &[std::ops::Range<usize>]) -> Option<(DVec3, DVec3)> {
        let b = Prims::new(scene).bounds(ranges);
        (!b.is_empty()).then_some((b.lo, b.hi))
    }

    pub fn cell_count(&self) -> usize {
        self.cell_start.len() - 1
    }

    /// The references of cell `(x, y, z)`.
    pub fn cell(&self, x: u32, y: u32, z: u32) -> &[PrimRef] {
        let c = (x + self.res[0] * (y + self.res[1] * z)) as usize;
        &self.prim_refs[self.cell_start[c] as usize..self.cell_start[c + 1] as usize]
    }

    /// Whether macro-cell `(mx, my, mz)` has its occupancy bit set.
    pub fn macro_occupied(&self, mx: u32, my: u32, mz: u32) -> bool {
        let m = mx + self.macro_res[0] * (my + self.macro_res[1] * mz);
        self.macro_bits[(m / 32) as usize] & (1 << (m % 32)) != 0
    }

    pub fn stats(&self) -> GridStats {
        let counts = self.cell_start.windows(2).map(|w| w[1] - w[0]);
        let mut prims: Vec<u32> = self.prim_refs.iter().map(|r| r.0).collect();
        prims.sort_unstable();
        prims.dedup();
        GridStats {
            res: self.res,
            cells: self.cell_count(),
            empty_cells: counts.clone().filter(|&n| n == 0).count(),
            prims: prims.len(),
            refs: self.prim_refs.len(),
            max_refs_per_cell: counts.max().unwrap_or(0),
            macro_res: self.macro_res,
            macro_occupied: self.macro_bits.iter().map(|b| b.count_ones() as usize).sum(),
            bytes: 4 * (self.cell_start.len() + self.prim_refs.len() + self.macro_bits.len()),
        }
    }
}

/// Where a grid lies and how it is cut into cells.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lattice {
    pub min: DVec3,
    pub max: DVec3,
    pub res: [u32; 3],
}

impl Lattice {
    /// The frame [`Grid::build`] gives `n` primitives whose bounds are `lo`..`hi`.
    pub fn around(lo: DVec3, hi: DVec3, n: usize) -> Lattice {
        Self::fit(Aabb { lo, hi }, n)
    }

    fn fit(bounds: Aabb, n: usize) -> Lattice {
        let (min, max) = padded(bounds);
        Lattice { min, max, res: resolution(max - min, n) }
    }

    /// Whether the box `lo`..`hi` lies inside the frame.
    pub fn holds(&self, lo: DVec3, hi: DVec3) -> bool {
        lo.cmpge(self.min).all() && hi.cmple(self.max).all()
    }

    fn cells(&self) -> usize {
        self.res.iter().map(|&r| r as usize).product()
    }

    fn cell_size(&self) -> DVec3 {
        (self.max - self.min) / DVec3::new(self.res[0] as f64, self.res[1] as f64, self.res[2] as f64)
    }

    /// The (cell, reference) pairs of the primitives of `ranges`, in primitive order, on
    /// `threads` threads (each a contiguous share of the primitives, so the order does not
    /// depend on the count).
    fn insert(
        &self,
        prims: &Prims,
        ranges: &[std::ops::Range<usize>],
        threads: usize,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Vec<Vec<(u32, PrimRef)>> {
        let (min, max, res) = (self.min, self.max, self.res);
        let cell_size = self.cell_size();
        let magnitude = min.abs().max(max.abs()).max_element();
        let margin =
            (cell_size * MARGIN_CELL_REL).max(DVec3::splat(magnitude * MARGIN_ULPS * f32::EPSILON as f64));
        let n: usize = ranges.iter().map(|r| r.len()).sum();
        let cell_of = |p: DVec3| {
            let c = ((p - min) / cell_size).floor();
            [0, 1, 2].map(|a| (c[a].max(0.0) as u32).min(res[a] - 1))
        };
        let done = std::sync::atomic::AtomicUsize::new(0);
        // The k-th to (k + len)-th primitives of `ranges` together.
        let share = |from: usize, len: usize| -> Vec<std::ops::Range<usize>> {
            let mut out = Vec::new();
            let (mut skip, mut left) = (from, len);
            for r in ranges {
                if left == 0 {
                    break;
                }
                if skip >= r.len() {
                    skip -= r.len();
                    continue;
                }
                let start = r.start + skip;
                let end = (start + left).min(r.end);
                out.push(start..end);
                left -= end - start;
                skip = 0;
            }
            out
        };
        let insert = |parts: Vec<std::ops::Range<usize>>| {
            let mut pairs: Vec<(u32, PrimRef)> = Vec::new();
            let mut k = 0;
            for range in parts {
                prims.for_each(range, |r, shape| {
                    let b = shape.bounds();
                    let (lo, hi) = (cell_of(b.lo - margin), cell_of(b.hi + margin));
                    for z in lo[2]..=hi[2] {
                        for y in lo[1]..=hi[1] {
                            for x in lo[0]..=hi[0] {
                                let c_lo = min + DVec3::new(x as f64, y as f64, z as f64) * cell_size;
                                let cell = Aabb { lo: c_lo - margin, hi: c_lo + cell_size + margin };
                                let c = x + res[0] * (y + res[1] * z);
                                if shape.overlaps(&cell) {
                                    pairs.push((c, r));
                                }
                            }
                        }
                    }
                    k += 1;
                    if k % PROGRESS_STEP == 0 {
                        let d = done.fetch_add(PROGRESS_STEP, std::sync::atomic::Ordering::Relaxed);
                        progress(d + PROGRESS_STEP, n);
                    }
                });
            }
            pairs
        };
        let chunk = n.div_ceil(threads.max(1)).max(1);
        let lists = if threads <= 1 {
            vec![insert(share(0, n))]
        } else {
            std::thread::scope(|s| {
                let handles: Vec<_> = (0..threads)
                    .map(|t| {
                        let part = share(t * chunk, chunk.min(n.saturating_sub(t * chunk)));
                        s.spawn(|| insert(part))
                    })
                    .collect();
                handles.into_iter().map(|h| h.join().expect("grid build thread")).collect()
            })
        };
        progress(n, n);
        lists
    }

    /// The grid of these CSR arrays, with its macro-cell bits.
    fn grid(&self, cell_start: Vec<u32>, prim_refs: Vec<PrimRef>) -> Grid {
        let res = self.res;
        let macro_res = res.map(|r| r.div_ceil(MACRO_FACTOR));
        let macro_count = macro_res.iter().map(|&r| r as usize).product::<usize>();
        let mut macro_bits = vec![0u32; macro_count.div_ceil(32)];
        for z in 0..res[2] {
            for y in 0..res[1] {
                for x in 0..res[0] {
                    let c = (x + res[0] * (y + res[1] * z)) as usize;
                    if cell_start[c + 1] > cell_start[c] {
                        let [mx, my, mz] = [x, y, z].map(|v| v / MACRO_FACTOR);
                        let m = mx + macro_res[0] * (my + macro_res[1] * mz);
                        macro_bits[(m / 32) as usize] |= 1 << (m % 32);
                    }
                }
            }
        }
        Grid {
            min: self.min,
            max: self.max,
            res,
            cell_size: self.cell_size(),
            cell_start,
            prim_refs,
            macro_res,
            macro_bits,
        }
    }
}

/// The scene bounds grown so that no primitive touches the boundary and no axis is flat. An
/// empty scene gets a unit box around the origin.
fn padded(b: Aabb) -> (DVec3, DVec3) {
    if b.is_empty() {
        return (DVec3::splat(-0.5), DVec3::splat(0.5));
    }
    let extent = (b.hi - b.lo).max_element();
    let magnitude = b.lo.abs().max(b.hi.abs()).max_element();
    // Relative to the extent for ordinary scenes; relative to the magnitude when the scene is
    // tiny compared with its distance from the origin (f32 could not tell its planes apart);
    // and never zero (a single degenerate triangle at the origin).
    let pad = (extent * PAD_REL).max(magnitude * 1e-5).max(f64::MIN_POSITIVE.sqrt());
    (b.lo - pad, b.hi + pad)
}

/// Cells per axis for `n` primitives in a box of size `extent` (see [`CELLS_PER_PRIMITIVE`]).
fn resolution(extent: DVec3, n: usize) -> [u32; 3] {
    if n == 0 {
        return [1, 1, 1];
    }
    let volume = extent.x * extent.y * extent.z;
    let mut density = (CELLS_PER_PRIMITIVE * n as f64 / volume).cbrt();
    loop {
        let res = [0, 1, 2].map(|a| ((extent[a] * density).ceil().clamp(1.0, MAX_RES as f64)) as u32);
        if res.iter().map(|&r| r as u64).product::<u64>() <= MAX_CELLS {
            return res;
        }
        density *= 0.95;
    }
}

#[cfg(test)]
pub(in crate::accel) mod tests {
    use super::*;
    use crate::scene::{Ambient, Camera, Cone, Material, MaterialKind, Mesh, Sphere, TraceSettings};

    pub(in crate::accel) struct Rng(pub(in crate::accel) u64);
    impl Rng {
        pub(in crate::accel) fn f(&mut self) -> f64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }
        pub(in crate::accel) fn vec(&mut self, lo: f64, hi: f64) -> DVec3 {
            DVec3::new(self.f(), self.f(), self.f()) * (hi - lo) + lo
        }
    }

    pub(in crate::accel) fn scene(spheres: Vec<Sphere>, tris: Vec<[DVec3; 3]>) -> Scene {
        Scene {
            camera: Camera {
                eye: DVec3::Z,
                look_at: DVec3::ZERO,
                up: DVec3::Y,
                vfov_deg: 45.0,
                width: 4,
                height: 4,
            },
            lights: vec![],
            ambient: Ambient { sky: DVec3::ONE, ground: DVec3::ZERO, up: DVec3::Y },
            background: DVec3::ZERO,
            materials: vec![Material {
                name: "m".into(),
                texture: None,
                kind: MaterialKind::Diffuse { color: DVec3::ONE },
            }],
            spheres,
            meshes: vec![Mesh {
                positions: tris.iter().flatten().copied().collect(),
                normals: None,
                uvs: None,
                indices: (0..tris.len() as u32).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect(),
                material: 0,
            }],
            cones: vec![],
            textures: vec![],
            trace: TraceSettings::default(),
            motions: Vec::new(),
            particles: Vec::new(),
            volumes: Vec::new(),
            patches: Vec::new(),
        }
    }

    #[test]
    fn the_grid_does_not_depend_on_the_thread_count() {
        let mut s = random_scene(7, 900, 10.0, DVec3::ZERO);
        // Several meshes, one empty, so ranges start inside and between them.
        let mesh = s.meshes[0].clone();
        s.meshes.push(Mesh { indices: vec![], ..mesh.clone() });
        s.meshes.push(mesh);
        let one = Grid::build_on(&s, 1, &|_, _| {});
        for threads in [2, 3, 7] {
            assert!(Grid::build_on(&s, threads, &|_, _| {}) == one, "{threads} threads");
        }
        assert!(one.prim_refs.len() > 900);
    }

    /// Moving some spheres, triangles and cones and updating gives the grid a full build in the
    /// same frame gives, reference for reference (on one and on several threads).
    #[test]
    fn an_update_equals_a_build_in_the_same_frame() {
        let s = random_scene(11, 1200, 10.0, DVec3::ZERO);
        let (spheres, tris) = (s.spheres.len(), s.triangle_count());
        let grid = Grid::build(&s);
        // Spheres 3..10, triangles 50..70 and the last cones move (global indices).
        let n = spheres + tris + s.cones.len();
        let moving = vec![3..10, spheres + 50..spheres + 70, n - 5..n];
        let mut moved = s.clone();
        // Towards the origin, inside the scene's box, so that the frame still holds them.
        let pull = |p: DVec3| p * 0.8;
        moved.spheres[3..10].iter_mut().for_each(|sp| sp.center = pull(sp.center));
        let m = &mut moved.meshes[0];
        for t in 50..70 {
            for v in m.indices[t] {
                m.positions[v as usize] = pull(m.positions[v as usize]);
            }
        }
        let k = moved.cones.len();
        moved.cones[k - 5..].iter_mut().for_each(|c| (c.base, c.apex) = (pull(c.base), pull(c.apex)));
        let (lo, hi) = Grid::bounds_of(&moved, std::slice::from_ref(&(0..n))).unwrap();
        assert!(grid.lattice().holds(lo, hi), "the moved scene stays in the frame");
        let updated = grid.update(&moved, &moving);
        let full = Grid::build_in(&moved, grid.lattice());
        assert!(updated == full, "update = build in the frame");
        assert!(updated != grid, "something moved");
        // And back: the original grid.
        assert!(updated.update(&s, &moving) == grid);
    }

    pub(in crate::accel) fn random_scene(seed: u64, n: usize, extent: f64, offset: DVec3) -> Scene {
        let mut rng = Rng(seed.wrapping_mul(0x9E3779B97F4A7C15) | 1);
        let (mut spheres, mut tris, mut cones) = (vec![], vec![], vec![]);
        for i in 0..n {
            let c = offset + rng.vec(-extent, extent);
            let size = extent * 0.05 * (0.1 + 4.0 * rng.f() * rng.f());
            if i % 3 == 0 {
                spheres.push(Sphere { center: c, radius: size, material: 0 });
            } else if i % 6 == 1 {
                cones.push(random_cone(&mut rng, c, size));
            } else {
                tris.push([c + rng.vec(-size, size), c + rng.vec(-size, size), c + rng.vec(-size, size)]);
            }
        }
        let mut s = scene(spheres, tris);
        s.cones = cones;
        s
    }

    /// A cone around `c` of about `size`: cylinders, truncated and pointed cones, thin and fat.
    fn random_cone(rng: &mut Rng, c: DVec3, size: f64) -> Cone {
        let axis = rng.vec(-size, size) * 2.0;
        let (r0, r1) = match rng.f() {
            x if x < 0.3 => (size * 0.3, size * 0.3),
            x if x < 0.6 => (size * 0.5 * rng.f(), 0.0),
            _ => (size * 0.5 * rng.f(), size * 0.5 * rng.f()),
        };
        Cone {
            base: c - axis * 0.5,
            base_radius: r0.max(1e-3 * size),
            apex: c + axis * 0.5,
            apex_radius: r1,
            material: 0,
        }
    }

    /// A point of the cone's surface: fraction `s` along the axis, angle `phi` around it.
    fn cone_point(c: &Cone, s: f64, phi: f64) -> DVec3 {
        let axis = c.apex - c.base;
        let (u, w) = axis.normalize().any_orthonormal_pair();
        let r = c.base_radius + s * (c.apex_radius - c.base_radius);
        c.base + s * axis + r * (phi.cos() * u + phi.sin() * w)
    }

    /// Distance from the segment `a b` to the box (convex in the segment parameter: ternary
    /// search, to 1e-12 of the segment).
    fn segment_box_distance(a: DVec3, b: DVec3, lo: DVec3, hi: DVec3) -> f64 {
        let f = |s: f64| {
            let p = a + s * (b - a);
            p.clamp(lo, hi).distance(p)
        };
        let (mut x, mut y) = (0.0, 1.0);
        for _ in 0..100 {
            let (m1, m2) = (x + (y - x) / 3.0, y - (y - x) / 3.0);
            if f(m1) <= f(m2) {
                y = m2;
            } else {
                x = m1;
            }
        }
        f(0.5 * (x + y))
    }

    fn cell_containing(g: &Grid, p: DVec3) -> [u32; 3] {
        let c = ((p - g.min) / g.cell_size).floor();
        [0, 1, 2].map(|a| c[a].clamp(0.0, (g.res[a] - 1) as f64) as u32)
    }

    /// Points on each primitive's surface (sampled densely) lie in cells that list it.
    fn assert_complete(g: &Grid, s: &Scene, rng: &mut Rng) {
        let check = |r: PrimRef, p: DVec3| {
            assert!(p.cmpgt(g.min).all() && p.cmplt(g.max).all(), "{p} outside the grid box");
            let [x, y, z] = cell_containing(g, p);
            assert!(g.cell(x, y, z).contains(&r), "{r:?} missing from cell {x},{y},{z} at {p}");
            let f = MACRO_FACTOR;
            assert!(g.macro_occupied(x / f, y / f, z / f));
        };
        for (i, sp) in s.spheres.iter().enumerate() {
            for _ in 0..200 {
                let d = (rng.vec(-1.0, 1.0)).normalize_or(DVec3::X);
                check(PrimRef::new(PrimKind::Sphere, i as u32), sp.center + d * sp.radius);
            }
        }
        for (i, t) in s.triangles().enumerate() {
            for _ in 0..200 {
                let (mut u, mut v) = (rng.f(), rng.f());
                if u + v > 1.0 {
                    (u, v) = (1.0 - u, 1.0 - v);
                }
                let p = t.p[0] + u * (t.p[1] - t.p[0]) + v * (t.p[2] - t.p[0]);
                check(PrimRef::new(PrimKind::Triangle, i as u32), p);
            }
        }
        for (i, c) in s.cones.iter().enumerate() {
            for _ in 0..200 {
                check(PrimRef::new(PrimKind::Cone, i as u32), cone_point(c, rng.f(), rng.f() * 7.0));
            }
        }
    }

    #[test]
    fn every_surface_point_is_in_a_cell_that_lists_its_primitive() {
        let mut rng = Rng(7);
        for (seed, n, extent, offset) in [
            (1, 1, 1.0, DVec3::ZERO),
            (2, 50, 1.0, DVec3::ZERO),
            (3, 500, 10.0, DVec3::ZERO),
            (4, 300, 1e-3, DVec3::ZERO),
            (5, 300, 1.0, DVec3::splat(1e4)),
        ] {
            let s = random_scene(seed, n, extent, offset);
            let g = Grid::build(&s);
            assert_complete(&g, &s, &mut rng);
        }
    }

    /// A primitive is listed only in cells it comes within the margin of: overlap is decided
    /// exactly (spheres: distance to the box; triangles: clipping the triangle to the box, an
    /// independent method from the SAT used by the builder).
    #[test]
    fn cells_list_only_primitives_that_touch_them() {
        let s = random_scene(9, 400, 5.0, DVec3::ZERO);
        let g = Grid::build(&s);
        let tris: Vec<_> = s.triangles().collect();
        let slack = g.cell_size * 2e-3;
        for z in 0..g.res[2] {
            for y in 0..g.res[1] {
                for x in 0..g.res[0] {
                    let lo = g.min + DVec3::new(x as f64, y as f64, z as f64) * g.cell_size - slack;
                    let hi = lo + g.cell_size + 2.0 * slack;
                    for r in g.cell(x, y, z) {
                        let touches = match r.kind() {
                            PrimKind::Sphere => {
                                let sp = &s.spheres[r.index() as usize];
                                sp.center.clamp(lo, hi).distance(sp.center) <= sp.radius
                            }
                            PrimKind::Triangle => {
                                !clip(tris[r.index() as usize].p.to_vec(), lo, hi).is_empty()
                            }
                            // Conservative, so only bounded (see `cone_overlaps_box`).
                            PrimKind::Cone => {
                                let c = &s.cones[r.index() as usize];
                                segment_box_distance(c.base, c.apex, lo, hi)
                                    <= 3f64.sqrt() * c.base_radius.max(c.apex_radius)
                            }
                            PrimKind::Volume => {
                                let (vlo, vhi) = s.volumes[r.index() as usize].world_bounds();
                                vlo.cmple(hi).all() && lo.cmple(vhi).all()
                            }
                            PrimKind::Patch => unreachable!("this scene holds no patches"),
                        };
                        assert!(touches, "{r:?} listed in cell {x},{y},{z} it does not touch");
                    }
                }
            }
        }
    }

    /// Sutherland–Hodgman: the part of a convex polygon inside the box.
    fn clip(mut poly: Vec<DVec3>, lo: DVec3, hi: DVec3) -> Vec<DVec3> {
        for a in 0..3 {
            for (bound, keep_below) in [(lo[a], false), (hi[a], true)] {
                let inside = |p: DVec3| if keep_below { p[a] <= bound } else { p[a] >= bound };
                let mut out = vec![];
                for i in 0..poly.len() {
                    let (p, q) = (poly[i], poly[(i + 1) % poly.len()]);
                    if inside(p) {
                        out.push(p);
                    }
                    if inside(p) != inside(q) {
                        let t = (bound - p[a]) / (q[a] - p[a]);
                        out.push(p + t * (q - p));
                    }
                }
                poly = out;
                if poly.is_empty() {
                    return poly;
                }
            }
        }
        poly
    }

    #[test]
    fn csr_and_macro_bits_are_consistent_and_deterministic() {
        let s = random_scene(3, 300, 2.0, DVec3::ZERO);
        let g = Grid::build(&s);
        assert_eq!(g, Grid::build(&s));
        assert!(g.cell_start.windows(2).all(|w| w[0] <= w[1]));
        assert_eq!(*g.cell_start.last().unwrap() as usize, g.prim_refs.len());
        for c in 0..g.cell_count() {
            let refs = &g.prim_refs[g.cell_start[c] as usize..g.cell_start[c + 1] as usize];
            assert!(refs.windows(2).all(|w| w[0] < w[1]), "refs sorted and unique");
        }
        let f = MACRO_FACTOR;
        for mz in 0..g.macro_res[2] {
            for my in 0..g.macro_res[1] {
                for mx in 0..g.macro_res[0] {
                    let mut any = false;
                    for z in mz * f..((mz + 1) * f).min(g.res[2]) {
                        for y in my * f..((my + 1) * f).min(g.res[1]) {
                            for x in mx * f..((mx + 1) * f).min(g.res[0]) {
                                any |= !g.cell(x, y, z).is_empty();
                            }
                        }
                    }
                    assert_eq!(g.macro_occupied(mx, my, mz), any, "macro-cell {mx},{my},{mz}");
                }
            }
        }
        let st = g.stats();
        assert_eq!(st.prims, s.primitive_count());
        assert!(st.to_string().contains("cells"));
    }

    #[test]
    fn resolution_follows_primitive_count_and_shape() {
        // Cubic scene: about CELLS_PER_PRIMITIVE cells per primitive, same on every axis.
        let s = random_scene(4, 1000, 1.0, DVec3::ZERO);
        let g = Grid::build(&s);
        let cells = g.cell_count() as f64;
        assert!((0.5..4.0).contains(&(cells / (CELLS_PER_PRIMITIVE * 1000.0))), "{:?}", g.res);
        // A flat scene (a ground made of two triangles): thin but not zero thickness, one cell
        // deep; the long axes still get cells.
        let ground =
            [DVec3::new(-10.0, 0.0, -10.0), DVec3::new(10.0, 0.0, -10.0), DVec3::new(10.0, 0.0, 10.0)];
        let g = Grid::build(&scene(vec![], vec![ground]));
        assert!(g.max.y > g.min.y && g.res[1] == 1 && g.res[0] > 1 && g.res[2] > 1, "{:?}", g.res);
        // Caps hold for very many primitives in a long thin box.
        let mut s = random_scene(5, 10, 1.0, DVec3::ZERO);
        s.spheres = (0..200_000)
            .map(|i| Sphere { center: DVec3::new(i as f64, 0.0, 0.0), radius: 0.4, material: 0 })
            .collect();
        let g = Grid::build(&s);
        assert!(g.res.iter().all(|&r| r <= MAX_RES));
        assert!(g.cell_count() as u64 <= MAX_CELLS);
    }

    /// Shell mode's grid is hard mode's: no shell references crowd the cells near a mesh
    /// (they made shell walks visit every triangle of a mesh from every nearby cell).
    #[test]
    fn the_grid_does_not_depend_on_the_shadow_mode() {
        use crate::scene::{Light, ShadowMode};
        let mut s = scene(vec![Sphere { center: DVec3::ZERO, radius: 0.5, material: 0 }], vec![]);
        s.lights = vec![Light { position: DVec3::splat(9.0), color: DVec3::ONE, radius: 1.0 }];
        s.spheres.extend((0..200).map(|i| Sphere {
            center: DVec3::new(-4.0 + 0.04 * i as f64, 4.0, 4.0),
            radius: 0.01,
            material: 0,
        }));
        let hard = Grid::build(&s);
        s.trace.shadows = ShadowMode::Shell { falloff: Default::default(), combine: Default::default() };
        let shell = Grid::build(&s);
        assert!(hard.prim_refs == shell.prim_refs && hard.cell_start == shell.cell_start);
    }

    #[test]
    fn empty_and_degenerate_scenes_build() {
        let g = Grid::build(&scene(vec![], vec![]));
        assert_eq!(g.res, [1, 1, 1]);
        assert!(g.prim_refs.is_empty());
        // A zero-area triangle at a point: listed in the cell holding the point.
        let p = DVec3::new(1.0, 2.0, 3.0);
        let g = Grid::build(&scene(vec![], vec![[p, p, p]]));
        assert!(g.min.cmplt(p).all() && g.max.cmpgt(p).all());
        let [x, y, z] = cell_containing(&g, p);
        assert_eq!(g.cell(x, y, z), [PrimRef::new(PrimKind::Triangle, 0)]);
    }

    /// The cone–box test never misses a box that holds a point of the solid cone, never claims a
    /// box farther than √3 times the larger radius from the axis, and is tighter than the bounds.
    #[test]
    fn cone_box_test_is_conservative_and_tight() {
        let mut rng = Rng(33);
        let (lo, hi) = (DVec3::ZERO, DVec3::ONE);
        let (mut overlaps, mut in_bounds, mut loose) = (0, 0, 0);
        for _ in 0..20_000 {
            let (centre, size) = (rng.vec(-0.5, 1.5), rng.f() * 0.8 + 0.05);
            let c = random_cone(&mut rng, centre, size);
            let shape = Shape::Cone { base: c.base, r0: c.base_radius, apex: c.apex, r1: c.apex_radius };
            let hit = shape.overlaps(&Aabb { lo, hi });
            let solid = (0..200).any(|_| {
                let p = cone_point(&c, rng.f(), rng.f() * 7.0);
                let axis_point =
                    c.base + (p - c.base).dot((c.apex - c.base).normalize()) * (c.apex - c.base).normalize();
                let q = axis_point + (p - axis_point) * rng.f();
                q.cmpge(lo).all() && q.cmple(hi).all()
            });
            assert!(hit || !solid, "{c:?} has points in the box but the test says no");
            let reach = 3f64.sqrt() * c.base_radius.max(c.apex_radius);
            if segment_box_distance(c.base, c.apex, lo, hi) > reach + 1e-9 {
                assert!(!hit, "{c:?} is far from the box but the test says yes");
            }
            // Boxes the test lists though 200 samples of the solid miss them (the sampling misses
            // some real overlaps too, so this over-counts the looseness).
            if hit && !solid {
                loose += 1;
            }
            let b = shape.bounds();
            in_bounds += (b.lo.cmple(hi).all() && b.hi.cmpge(lo).all()) as usize;
            overlaps += hit as usize;
        }
        println!("{overlaps} overlaps ({loose} without a sampled point), {in_bounds} in bounds");
        assert!(overlaps > 2000 && overlaps < in_bounds && loose * 5 < overlaps);
    }

    #[test]
    fn sat_agrees_with_clipping() {
        let mut rng = Rng(21);
        let (lo, hi) = (DVec3::ZERO, DVec3::ONE);
        let mut hits = 0;
        for _ in 0..20_000 {
            let c = rng.vec(-0.5, 1.5);
            let t = [c + rng.vec(-0.6, 0.6), c + rng.vec(-0.6, 0.6), c + rng.vec(-0.6, 0.6)];
            let sat = triangle_overlaps_box(t, &Aabb { lo, hi });
            // Clipping against slightly smaller / larger boxes brackets the exact answer.
            let eps = DVec3::splat(1e-9);
            if !clip(t.to_vec(), lo + eps, hi - eps).is_empty() {
                assert!(sat, "{t:?} overlaps the box but SAT says no");
            }
            if clip(t.to_vec(), lo - eps, hi + eps).is_empty() {
                assert!(!sat, "{t:?} misses the box but SAT says yes");
            }
            hits += sat as usize;
        }
        assert!(hits > 2000 && hits < 18_000, "{hits}");
    }
}
