//! The occluders of `shell` shadow mode as objects (docs/shadows.md, Shell objects): every sphere
//! and cone, and every mesh as one object whose penumbra comes from its contour edges as seen
//! from the light's centre. Input data built once per light on the host and shared by both
//! tracers (like the bundle's point set), not tracing code.

use super::Scene;
use glam::DVec3;
use std::collections::HashMap;

use crate::reference::bvh::Bvh;
use crate::reference::{cone_bounds, intersect_cone, intersect_sphere, intersect_triangle};

/// What a shell object is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ShellShape {
    /// Sphere `i` of the scene.
    Sphere(u32),
    /// Cone `i` of the scene.
    Cone(u32),
    /// A mesh: its triangles `[first, end)` in `Scene::triangles` order and its contour edges
    /// `[first, end)` in [`LightShells::edges`].
    Mesh { triangles: [u32; 2], edges: [u32; 2] },
}

/// One occluder with a bounding sphere (which a shadow segment must pass within the light's
/// radius of for the object's shell to matter).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShellObject {
    pub center: DVec3,
    pub radius: f64,
    /// A mesh's bounding box, `center ± half` (zero for spheres and cones): a segment that does
    /// not pass through it hits none of the mesh's triangles, so the GPU tests a small mesh's
    /// triangles only where it does (a floor under the light: never for the points above it).
    pub half: DVec3,
    pub shape: ShellShape,
}

/// The shell objects of a scene for one light.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LightShells {
    pub objects: Vec<ShellObject>,
    /// Contour edges of every mesh seen from the light's centre, as segments, in mesh order;
    /// those hidden from the light's centre by the scene are left out ([`light_shells`]).
    pub edges: Vec<[DVec3; 2]>,
    /// Cells per side of each face of the light buffer's cube ([`shell_cell`]): a power of two
    /// from [`SHELL_CELL_RES_MIN`] to [`SHELL_CELL_RES_MAX`], chosen per light.
    pub res: u32,
    /// A light buffer (Haines & Greenberg 1986): the directions from the light's centre cut into
    /// the cells of a cube (`res`² per face). Each cell lists the meshes (indices into
    /// `objects`) whose shell a shadow segment in that direction can reach. An object left out of
    /// a cell gives σ = 1 exactly to every segment in it, so skipping it changes no result: the
    /// lists are only a way to visit fewer objects.
    pub cells: Vec<Vec<u32>>,
    /// Per cell, the contour edges (indices into `edges`, in order, so grouped by mesh) that a
    /// shadow segment in that direction can pass within the light's radius of. An edge farther
    /// than that from the segment is beyond the shell's width `b < r`, where a mesh's σ is 0 or
    /// 1 unless a nearer edge is within its own (`reference::shadows::nearest_edge`), so leaving
    /// it out changes no result either.
    pub cell_edges: Vec<Vec<u32>>,
    /// The depth slabs that cut each cell's spheres and cones by the shadow segment's length.
    pub slabs: Slabs,
    /// Per cell and slab (`cell * slabs.count + slab`), the spheres and cones (indices into
    /// `objects`) whose shell a segment in that direction, of a length in that slab, can reach:
    /// the shell's width `b = r t / D` narrows towards the segment's origin, and an object
    /// wholly beyond the origin (farther from the light than the segment is long) has none
    /// ([`Slabs`]).
    pub slab_cells: Vec<Vec<u32>>,
}

/// Depth slabs of a light buffer (docs/shadows.md, "Light buffer"): slab 0 holds the shadow
/// segments of length at most `near`, slab `k` those in `(near ratioᵏ⁻¹, near ratioᵏ]`, the last
/// every longer one. A sphere or cone is listed in a slab for the width its shell can have there:
/// a segment of length `D` from `p` passes a point at distance `s` from the light's centre at
/// `t = D − s` from `p`, where the shell is `b = r t / D = r (1 − s / D)` wide; so an occluder
/// piece whose nearest point lies `s_min` from the light needs the light's radius grown only by
/// `r (1 − s_min / D_far)` (`D_far` the slab's longest segment), and none at all when
/// `s_min ≥ D_far` (it lies wholly beyond every segment's origin, where `t ≤ 0`). Small occluders
/// near the receiver (a sphereflake's, a tree's) thus drop out of the lists of the rays that
/// pass them at a distance their shells cannot reach.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Slabs {
    pub count: u32,
    pub near: f64,
    pub ratio: f64,
}

impl Default for Slabs {
    fn default() -> Self {
        Slabs { count: 1, near: 0.0, ratio: 2.0 }
    }
}

/// Depth slabs of a light buffer with spheres or cones ([`Slabs`]): the longest segment a
/// scene's shading points can cast reaches `ratio^(count - 2)` times the shortest slab's.
pub const SHELL_SLABS: u32 = 16;
/// The shortest slab ends at least this fraction of the way to the farthest occluder: nearer
/// segments are few (the light is inside the scene) and share one slab.
const SHELL_SLAB_NEAREST: f64 = 1.0 / 16.0;

impl Slabs {
    /// Slabs spanning the distances `[nearest, farthest]` from the light of the scene's
    /// occluders; one slab (no cut) where there are none.
    fn spanning(nearest: f64, farthest: f64) -> Self {
        let near = nearest.max(farthest * SHELL_SLAB_NEAREST);
        if !(near > 0.0 && farthest.is_finite()) {
            return Slabs::default();
        }
        let ratio = (farthest / near).powf(1.0 / (SHELL_SLABS - 2) as f64).max(1.0 + 1e-3);
        Slabs { count: SHELL_SLABS, near, ratio }
    }

    /// `1 / log2(ratio)`, as the shader gets it.
    pub fn inv_log2_ratio(&self) -> f64 {
        1.0 / self.ratio.log2()
    }

    /// The slab of a shadow segment `dist` long; the shader's `shell_slab` is the same formula.
    pub fn of(&self, dist: f64) -> u32 {
        if self.count <= 1 || dist <= self.near {
            return 0;
        }
        ((dist / self.near).log2() * self.inv_log2_ratio()).ceil().clamp(0.0, (self.count - 1) as f64) as u32
    }

    /// The longest segment slab `k` holds, grown by 10⁻³ for the f32 rounding of the GPU's
    /// slab; unbounded for the last.
    fn far(&self, k: u32) -> f64 {
        if k + 1 >= self.count {
            return f64::INFINITY;
        }
        self.near * self.ratio.powi(k as i32) * (1.0 + 1e-3)
    }

    /// `piece` (centre, radius) grown by as much of the light's radius `r` as a shell can have
    /// in slab `k` (seen from `light`), or `None` where it lies beyond every segment's origin.
    fn grown(&self, k: u32, light: DVec3, (q, radius): (DVec3, f64), r: f64) -> Option<(DVec3, f64)> {
        let far = self.far(k);
        let s_min = (q.distance(light) - radius - r).max(0.0);
        if s_min >= far {
            return None;
        }
        let reach = if far.is_finite() { r * (1.0 - s_min / far) } else { r };
        Some((q, radius + reach))
    }
}

impl ShellObject {
    /// Whether the segment `p + t l`, `t ∈ [0, len]`, passes through the object's bounding box
    /// (a mesh's; the shader's `segment_box` is the same test, its box grown for f32 rounding).
    pub fn crosses_box(&self, p: DVec3, l: DVec3, len: f64) -> bool {
        let (mut a, mut b) = (0.0f64, len);
        for k in 0..3 {
            let (lo, hi) = (self.center[k] - self.half[k] - p[k], self.center[k] + self.half[k] - p[k]);
            if l[k] == 0.0 {
                if lo > 0.0 || hi < 0.0 {
                    return false;
                }
                continue;
            }
            let (t0, t1) = (lo / l[k], hi / l[k]);
            (a, b) = (a.max(t0.min(t1)), b.min(t0.max(t1)));
        }
        a <= b
    }
}

/// Fewest and most cells per side of a light buffer's face ([`light_shells`] picks per light).
pub const SHELL_CELL_RES_MIN: u32 = 16;
pub const SHELL_CELL_RES_MAX: u32 = 128;

/// The light buffer's resolution is the coarsest whose mean list a listed entry shares its cell
/// with (Σ n² / Σ n over the cells' objects and edges) is at most this, or else the one a finer
/// resolution no longer shortens by [`SHELL_CELL_GAIN`]: a shadow ray visits the list of its
/// cell, and rays gather where the occluders are (docs/shadows.md, "What a shell ray costs").
pub const SHELL_CELL_LOAD: f64 = 4.0;
/// See [`SHELL_CELL_LOAD`]: a doubling that shortens the lists by less (occluders larger than
/// the cells, listed in all of them anyway) is not worth four times the cells. The load
/// understates what a doubling saves the rays: on SPD balls_s3, 64 to 128 cells a side shortens
/// it to 0.79 and the spheres a pilot frame's shell rays visit to 0.58 (0.75 kept 64).
pub const SHELL_CELL_GAIN: f64 = 0.85;
/// Most list entries (objects and edges, over all cells) of one light's buffer.
const SHELL_CELL_ENTRIES: usize = 1 << 22;

/// A mesh of at most this many triangles is tested triangle by triangle in the GPU's shell
/// object loop to tell whether a shadow ray is inside it; a larger one by a grid walk of the part
/// of the segment inside its bounding sphere. Measured (docs/shadows.md, Shell objects): the two
/// are even at 12 triangles and the walk is faster from 20 on, while a floor quad's bound holds
/// the whole scene, so walking it costs the whole segment. The reference asks the same question
/// of every mesh (does the segment hit one of its triangles).
pub const SHELL_DIRECT_TRIANGLES: u32 = 16;

/// Whether a shell shadow ray in `scene` must walk the grid to find the mesh it is inside of:
/// some mesh has more than [`SHELL_DIRECT_TRIANGLES`] triangles (every mesh is a shell object of
/// every light).
pub fn shells_walk_grid(scene: &Scene) -> bool {
    scene.meshes.iter().any(|m| m.indices.len() > SHELL_DIRECT_TRIANGLES as usize)
}

/// The face of direction `d` (by its largest axis: +x, −x, +y, −y, +z, −z) and its coordinates
/// on that face, in [−1, 1].
fn face_of(d: DVec3) -> (u32, f64, f64) {
    let a = d.abs();
    if a.x >= a.y && a.x >= a.z {
        (if d.x > 0.0 { 0 } else { 1 }, d.y / a.x, d.z / a.x)
    } else if a.y >= a.z {
        (if d.y > 0.0 { 2 } else { 3 }, d.x / a.y, d.z / a.y)
    } else {
        (if d.z > 0.0 { 4 } else { 5 }, d.x / a.z, d.y / a.z)
    }
}

/// The light-buffer cell of direction `d` (from the light's centre, not necessarily unit) in a
/// buffer of `res` cells per face side: face by the largest axis (+x, −x, +y, −y, +z, −z), then
/// row-major on the face. The shader's `shell_cell` is the same formula.
pub fn shell_cell(d: DVec3, res: u32) -> u32 {
    let (face, u, v) = face_of(d);
    let at = |w: f64| (((w * 0.5 + 0.5) * res as f64) as i64).clamp(0, res as i64 - 1) as u32;
    face * res * res + at(v) * res + at(u)
}

/// Centre direction (unit) and angular radius (the largest angle to a corner) of the cell
/// `(iu, iv)` of face `face` cut into `n` × `n` cells.
fn cell_cone(face: u32, n: u32, iu: u32, iv: u32) -> (DVec3, f64) {
    let dir = |u: f64, v: f64| -> DVec3 {
        let w = [-1.0, 1.0][face.is_multiple_of(2) as usize];
        match face / 2 {
            0 => DVec3::new(w, u, v),
            1 => DVec3::new(u, w, v),
            _ => DVec3::new(u, v, w),
        }
        .normalize()
    };
    let side = |i: u32| -1.0 + 2.0 * i as f64 / n as f64;
    let centre = dir(side(iu) + 1.0 / n as f64, side(iv) + 1.0 / n as f64);
    let corners = [(iu, iv), (iu + 1, iv), (iu, iv + 1), (iu + 1, iv + 1)];
    let beta = corners.iter().map(|&(a, b)| centre.angle_between(dir(side(a), side(b)))).fold(0.0, f64::max);
    (centre, beta)
}

/// Spheres `(centre, radius)` covering the segment `a b` thickened by `radius`: at most 16, each
/// at most about twice `radius` long, so a long thin cylinder or edge is listed only in the
/// cells along it, not in every cell its bounding sphere reaches.
pub(super) fn capsule(a: DVec3, b: DVec3, radius: f64) -> Vec<(DVec3, f64)> {
    let len = a.distance(b);
    let m = if radius > 0.0 { (len / (2.0 * radius)).ceil().clamp(1.0, 16.0) as u32 } else { 16 };
    (0..m).map(|i| (a.lerp(b, (i as f64 + 0.5) / m as f64), len / (2.0 * m as f64) + radius)).collect()
}

/// Calls `found` with every cell of a `res`-per-side buffer around `light` whose cone of
/// directions comes within the angle one of `pieces` subtends (plus 10⁻³ rad for f32 rounding of
/// the direction on the GPU), found by descending from whole faces through quarters.
pub(super) fn cover(light: DVec3, pieces: &[(DVec3, f64)], res: u32, found: &mut impl FnMut(u32)) {
    let caps: Vec<Option<(DVec3, f64)>> = pieces
        .iter()
        .map(|&(q, r)| {
            let to = q - light;
            let dist = to.length();
            (dist > r).then(|| (to / dist, (r / dist).asin()))
        })
        .collect();
    if caps.iter().any(Option::is_none) {
        (0..6 * res * res).for_each(found);
        return;
    }
    fn visit(
        caps: &[Option<(DVec3, f64)>],
        cell: (u32, u32, u32, u32),
        res: u32,
        found: &mut impl FnMut(u32),
    ) {
        let (face, n, iu, iv) = cell;
        let (centre, beta) = cell_cone(face, n, iu, iv);
        if !caps.iter().flatten().any(|&(w, alpha)| w.angle_between(centre) <= alpha + beta + 1e-3) {
            return;
        }
        if n == res {
            found(face * res * res + iv * res + iu);
            return;
        }
        for (du, dv) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
            visit(caps, (face, 2 * n, 2 * iu + du, 2 * iv + dv), res, found);
        }
    }
    for face in 0..6 {
        visit(&caps, (face, 1, 0, 0), res, found);
    }
}

/// Every primitive of a scene, to ask whether a point is hidden from the light's centre (and,
/// for `--shadows soft`, what a hard shadow ray costs, [`shell_cost`]).
pub(super) struct Occluders<'a> {
    scene: &'a Scene,
    triangles: Vec<[DVec3; 3]>,
    bvh: Bvh,
}

impl<'a> Occluders<'a> {
    pub(super) fn new(scene: &'a Scene) -> Self {
        let triangles: Vec<[DVec3; 3]> = scene.triangles().map(|t| t.p).collect();
        let spheres = scene.spheres.iter().map(|s| (s.center - s.radius, s.center + s.radius));
        let tris = triangles.iter().map(|p| (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2])));
        let cones = scene.cones.iter().map(|c| cone_bounds(c.base, c.base_radius, c.apex, c.apex_radius));
        let bvh = Bvh::build(&spheres.chain(tris).chain(cones).collect::<Vec<_>>());
        Occluders { scene, triangles, bvh }
    }

    /// The nearest hit on `o + t d`, `0 < t < t_max` (`d` unit) when `any` is false, the first
    /// found when it is; and the BVH nodes plus primitives the walk visited.
    pub(super) fn walk(&self, o: DVec3, d: DVec3, t_max: f64, any: bool) -> (Option<f64>, usize) {
        let (ns, nt) = (self.scene.spheres.len(), self.triangles.len());
        let best = std::cell::Cell::new(t_max);
        let mut found = None;
        let visits = std::cell::Cell::new(0usize);
        self.bvh.traverse(
            o,
            d,
            || {
                visits.set(visits.get() + 1);
                best.get()
            },
            |id| {
                visits.set(visits.get() + 1);
                let id = id as usize;
                let t_max = best.get();
                let t = if id < ns {
                    let s = &self.scene.spheres[id];
                    intersect_sphere(o, d, s.center, s.radius, 0.0, t_max)
                } else if id < ns + nt {
                    let [a, b, c] = self.triangles[id - ns];
                    intersect_triangle(o, d, a, b, c, 0.0, t_max).map(|h| h.0)
                } else {
                    let c = &self.scene.cones[id - ns - nt];
                    intersect_cone(o, d, c.base, c.base_radius, c.apex, c.apex_radius, 0.0, t_max)
                };
                if let Some(t) = t.filter(|&t| t < t_max) {
                    best.set(t);
                    found = Some(t);
                    return any;
                }
                false
            },
        );
        (found, visits.get())
    }

    /// Whether anything lies on the segment `o + t d`, `0 < t < t_max` (`d` unit).
    fn blocked(&self, o: DVec3, d: DVec3, t_max: f64) -> bool {
        self.walk(o, d, t_max, true).0.is_some()
    }
}

/// Each position's representative: the first position within `1e-6` of the mesh's extent of it.
/// A tessellated surface whose patches were written separately (SPD's teapot) repeats a seam's
/// vertices with different last digits; welded only by exact value, every seam was a contour
/// edge, a line of light across the inside of the mesh's shadow (docs/shadows.md).
fn weld(positions: &[DVec3]) -> Vec<u32> {
    let (lo, hi) =
        positions.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &p| (lo.min(p), hi.max(p)));
    let tol = 1e-6 * (hi - lo).max_element();
    if tol.is_nan() || tol <= 0.0 {
        return (0..positions.len() as u32).collect();
    }
    let key = |p: DVec3| ((p - lo) / tol).floor().as_i64vec3();
    let mut grid: HashMap<glam::I64Vec3, Vec<u32>> = HashMap::new();
    let mut rep = Vec::with_capacity(positions.len());
    for (i, &p) in positions.iter().enumerate() {
        let k = key(p);
        let mut found = None;
        'search: for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    for &j in grid.get(&(k + glam::I64Vec3::new(dx, dy, dz))).into_iter().flatten() {
                        if positions[j as usize].distance(p) <= tol {
                            found = Some(j);
                            break 'search;
                        }
                    }
                }
            }
        }
        let r = found.unwrap_or(i as u32);
        if found.is_none() {
            grid.entry(k).or_default().push(i as u32);
        }
        rep.push(r);
    }
    rep
}

/// The contour edges of mesh `m` seen from `light`: an edge (by its welded end points) is one
/// when it borders one triangle only, or two (or more) that do not all face the same way from
/// `light`.
fn contour_edges(m: &crate::scene::Mesh, light: DVec3) -> Vec<[DVec3; 2]> {
    let rep = weld(&m.positions);
    // Edge (welded end points, in order) -> the facing of each triangle using it.
    let mut edges: HashMap<(u32, u32), Vec<bool>> = HashMap::new();
    let mut order = vec![];
    for t in &m.indices {
        let p = t.map(|i| m.positions[i as usize]);
        let n = (p[1] - p[0]).cross(p[2] - p[0]);
        if n == DVec3::ZERO {
            continue;
        }
        let facing = n.dot(light - p[0]) > 0.0;
        let w = t.map(|i| rep[i as usize]);
        for k in 0..3 {
            let (a, b) = (w[k], w[(k + 1) % 3]);
            if a == b {
                continue;
            }
            let id = (a.min(b), a.max(b));
            edges
                .entry(id)
                .or_insert_with(|| {
                    order.push(id);
                    vec![]
                })
                .push(facing);
        }
    }
    order
        .into_iter()
        .filter(|id| {
            let f = &edges[id];
            f.len() == 1 || f.iter().any(|&x| x != f[0])
        })
        .map(|(a, b)| [m.positions[a as usize], m.positions[b as usize]])
        .collect()
}

/// Whether the light's centre sees none of edge `e`: the segments from it to three points along
/// the edge are all blocked short of the edge. Such an edge lies inside the shadow of what hides
/// it, where its shell would light a line inside the umbra (a lid's rim under the lid, a fold
/// behind the body): it is no edge of the shadow.
fn hidden(occluders: &Occluders, light: DVec3, e: [DVec3; 2]) -> bool {
    [1.0 / 6.0, 0.5, 5.0 / 6.0].iter().all(|&s| {
        let to = e[0].lerp(e[1], s) - light;
        let dist = to.length();
        dist > 0.0 && occluders.blocked(light, to / dist, dist * (1.0 - 1e-6))
    })
}

/// [`light_shells`] for every light of `scene`, sharing the work that does not depend on the
/// light.
pub fn scene_shells(scene: &Scene) -> Vec<LightShells> {
    let occluders = Occluders::new(scene);
    scene.lights.iter().map(|l| shells_for(scene, &occluders, l.position, l.radius)).collect()
}

/// Builds the shell objects of `scene` for a light centred at `light`: spheres, then cones, then
/// meshes (each with its contour edges, [`contour_edges`], less those the light's centre cannot
/// see, [`hidden`]). Every position is welded within 10⁻⁶ of its mesh's extent.
///
/// `light_radius` bounds every shell's width (`b = r t / D < r`): the light buffer lists an
/// object in every cell within the angle its bounding sphere (a cone's or an edge's capsule)
/// grown by it subtends, plus the cell's own angular radius and 10⁻³ rad for f32 rounding of the
/// direction on the GPU. Its resolution is the coarsest at which the lists are short
/// ([`SHELL_CELL_LOAD`]) or stop shortening ([`SHELL_CELL_GAIN`]).
pub fn light_shells(scene: &Scene, light: DVec3, light_radius: f64) -> LightShells {
    shells_for(scene, &Occluders::new(scene), light, light_radius)
}

/// One resolution's lists ([`LightShells`]' fields), their load ([`SHELL_CELL_LOAD`]) and
/// their entries.
struct Buffer {
    cells: Vec<Vec<u32>>,
    cell_edges: Vec<Vec<u32>>,
    slab_cells: Vec<Vec<u32>>,
    load: f64,
    stored: usize,
}

fn shells_for(scene: &Scene, occluders: &Occluders, light: DVec3, light_radius: f64) -> LightShells {
    let mut out = LightShells::default();
    // Each object's pieces: spheres and cones ungrown (each depth slab grows them by what it
    // needs), then meshes grown by the light's whole radius, one list per cell for every slab.
    let mut pieces: Vec<Vec<(DVec3, f64)>> = vec![];
    for (i, s) in scene.spheres.iter().enumerate() {
        out.objects.push(ShellObject {
            center: s.center,
            radius: s.radius,
            half: DVec3::ZERO,
            shape: ShellShape::Sphere(i as u32),
        });
        pieces.push(vec![(s.center, s.radius)]);
    }
    for (i, c) in scene.cones.iter().enumerate() {
        let center = (c.base + c.apex) / 2.0;
        let widest = c.base_radius.max(c.apex_radius);
        let radius = (c.apex - c.base).length() / 2.0 + widest;
        out.objects.push(ShellObject {
            center,
            radius,
            half: DVec3::ZERO,
            shape: ShellShape::Cone(i as u32),
        });
        pieces.push(capsule(c.base, c.apex, widest));
    }
    let solids = pieces.len();
    let mut first = 0u32;
    for m in &scene.meshes {
        let end = first + m.indices.len() as u32;
        let edge_first = out.edges.len() as u32;
        out.edges.extend(contour_edges(m, light).into_iter().filter(|&e| !hidden(occluders, light, e)));
        let (lo, hi) = m
            .positions
            .iter()
            .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &p| (lo.min(p), hi.max(p)));
        let center = if m.positions.is_empty() { DVec3::ZERO } else { (lo + hi) / 2.0 };
        let radius = m.positions.iter().map(|p| p.distance(center)).fold(0.0, f64::max);
        let shape = ShellShape::Mesh { triangles: [first, end], edges: [edge_first, out.edges.len() as u32] };
        if end > first {
            let half = if m.positions.is_empty() { DVec3::ZERO } else { (hi - lo) / 2.0 };
            out.objects.push(ShellObject { center, radius, half, shape });
            pieces.push(vec![(center, radius + light_radius)]);
        }
        first = end;
    }
    let edge_pieces: Vec<Vec<(DVec3, f64)>> =
        out.edges.iter().map(|e| capsule(e[0], e[1], light_radius)).collect();
    // The slabs span from the nearest sphere or cone (no shorter segment lists any) to the
    // farthest shading point, which lies on some object.
    let reach = |o: &ShellObject| {
        let d = o.center.distance(light);
        ((d - o.radius).max(0.0), d + o.radius)
    };
    let nearest = out.objects[..solids].iter().map(|o| reach(o).0).fold(f64::INFINITY, f64::min);
    let farthest = out.objects.iter().map(|o| reach(o).1).fold(0.0, f64::max);
    let slabs = if solids > 0 { Slabs::spanning(nearest, farthest) } else { Slabs::default() };
    let build = |res: u32| -> Buffer {
        let cells = 6 * res as usize * res as usize;
        let n_slabs = slabs.count as usize;
        let mut b = Buffer {
            cells: vec![vec![]; cells],
            cell_edges: vec![vec![]; cells],
            slab_cells: vec![vec![]; cells * n_slabs],
            load: 0.0,
            stored: 0,
        };
        for (k, p) in pieces.iter().enumerate().skip(solids) {
            cover(light, p, res, &mut |c| b.cells[c as usize].push(k as u32));
        }
        for (k, p) in edge_pieces.iter().enumerate() {
            cover(light, p, res, &mut |c| b.cell_edges[c as usize].push(k as u32));
        }
        for (k, p) in pieces.iter().enumerate().take(solids) {
            for slab in 0..slabs.count {
                let grown: Vec<(DVec3, f64)> =
                    p.iter().filter_map(|&q| slabs.grown(slab, light, q, light_radius)).collect();
                if !grown.is_empty() {
                    let at = |c: u32| c as usize * n_slabs + slab as usize;
                    cover(light, &grown, res, &mut |c| b.slab_cells[at(c)].push(k as u32));
                }
            }
        }
        // A ray visits its cell's meshes and edges and its slab's spheres and cones; each part's
        // load is taken on its own (a floor's few long edges in every cell would hide a crowd of
        // small spheres in a few).
        let load = |n: &mut dyn Iterator<Item = f64>| {
            let (sum, squares) = n.fold((0.0, 0.0), |(s, q), n| (s + n, q + n * n));
            squares / f64::max(sum, 1.0)
        };
        let meshes = load(&mut (0..cells).map(|c| (b.cells[c].len() + b.cell_edges[c].len()) as f64));
        b.load = meshes.max(load(&mut b.slab_cells.iter().map(|l| l.len() as f64)));
        b.stored = b.cells.iter().chain(&b.cell_edges).chain(&b.slab_cells).map(Vec::len).sum();
        b
    };
    // Finer buffers are tried up to the finest, not only while each doubling pays: a scene
    // small and far from its light sits in one coarse cell until the cells are smaller than it
    // (SPD tree's lights are 50 away from a tree 3 across: 16 and 32 cells a side list it whole).
    let (mut res, mut best) = (SHELL_CELL_RES_MIN, build(SHELL_CELL_RES_MIN));
    let mut finer_res = res;
    while best.load > SHELL_CELL_LOAD && finer_res < SHELL_CELL_RES_MAX {
        finer_res *= 2;
        let finer = build(finer_res);
        if finer.stored > SHELL_CELL_ENTRIES {
            break;
        }
        if finer.load <= SHELL_CELL_GAIN * best.load {
            (res, best) = (finer_res, finer);
        }
    }
    out.res = res;
    out.slabs = slabs;
    (out.cells, out.cell_edges, out.slab_cells) = (best.cells, best.cell_edges, best.slab_cells);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{default_scene, Mesh};

    /// A closed box seen from a light above a corner: its contour is six edges (a hexagon);
    /// the other six border two faces that face the same way.
    #[test]
    fn a_box_has_a_six_edge_contour() {
        let mut s = default_scene();
        s.spheres.clear();
        s.cones.clear();
        let p: Vec<DVec3> =
            (0..8).map(|i| DVec3::new((i & 1) as f64, (i >> 1 & 1) as f64, (i >> 2) as f64)).collect();
        // Faces wound outward, as quads of two triangles.
        let quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
        let indices = quads.iter().flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]).collect();
        s.meshes = vec![Mesh { positions: p, normals: None, uvs: None, indices, material: 0 }];
        let sh = light_shells(&s, DVec3::new(5.0, 6.0, 7.0), 0.5);
        assert_eq!(sh.objects.len(), 1);
        assert_eq!(sh.edges.len(), 6, "{:?}", sh.edges);
        // None of the contour edges touches the vertex nearest the light or the one farthest.
        for e in &sh.edges {
            for v in e {
                assert!(*v != DVec3::ONE && *v != DVec3::ZERO, "{e:?}");
            }
        }
        // A lone triangle's contour is its three edges.
        s.meshes[0].indices.truncate(1);
        assert_eq!(light_shells(&s, DVec3::new(5.0, 6.0, 7.0), 0.5).edges.len(), 3);
    }

    /// The light buffer lists a sphere in the cell of every direction whose ray from the light
    /// passes within its radius plus the light's (there its shell may matter) and, for a small
    /// far sphere, in few cells; directions map to the cell whose cone holds them.
    #[test]
    fn the_light_buffer_lists_every_object_where_its_shell_can_reach() {
        use crate::scene::Sphere;
        let mut s = default_scene();
        s.meshes.clear();
        s.cones.clear();
        s.spheres = vec![Sphere { center: DVec3::new(3.0, -4.0, 5.0), radius: 0.3, material: 0 }];
        let (light, r) = (DVec3::new(0.5, 0.2, -0.1), 0.4);
        let sh = light_shells(&s, light, r);
        // One object: the lists are as short as they get at the coarsest resolution.
        assert_eq!(sh.res, SHELL_CELL_RES_MIN);
        let listed =
            sh.slab_cells.chunks(sh.slabs.count as usize).filter(|c| c.iter().any(|l| !l.is_empty())).count();
        // Its grown cap (5.4°) plus a cell's radius (up to ~5°) covers about 15 of the 1536
        // cells (measured: 15); everywhere would be a broken buffer.
        assert!(listed <= 20, "a small far sphere in {listed} cells");
        for res in [SHELL_CELL_RES_MIN, 64] {
            let mut cells = vec![false; 6 * res as usize * res as usize];
            let to = s.spheres[0].center - light;
            cover(light, &[(s.spheres[0].center, 0.3 + r)], res, &mut |c| cells[c as usize] = true);
            let mut checked = 0;
            for i in 0..20_000 {
                // Directions spread over the sphere (a Fibonacci lattice).
                let z = 1.0 - 2.0 * (i as f64 + 0.5) / 20_000.0;
                let phi = i as f64 * std::f64::consts::PI * (3.0 - 5f64.sqrt());
                let d = DVec3::new((1.0 - z * z).sqrt() * phi.cos(), (1.0 - z * z).sqrt() * phi.sin(), z);
                let c = shell_cell(d, res);
                let (face, n) = (c / (res * res), res);
                let (centre, beta) = cell_cone(face, n, c % n, c / n % n);
                assert!(centre.angle_between(d) <= beta + 1e-12, "direction {d} outside its cell {c}");
                let t = to.dot(d);
                if t > 0.0 && (to - t * d).length() < 0.3 + r {
                    assert!(
                        cells[c as usize],
                        "res {res}: direction {d} near the sphere, cell {c} not listed"
                    );
                    checked += 1;
                }
            }
            assert!(checked > 20, "only {checked} directions near the sphere");
            if res == SHELL_CELL_RES_MIN {
                // The last depth slab lists with the light's whole radius.
                let n = sh.slabs.count as usize;
                let want: Vec<bool> = sh.slab_cells.chunks(n).map(|c| c[n - 1] == vec![0]).collect();
                assert_eq!(cells, want, "cover() and light_shells() list the same cells");
            }
        }
    }

    /// Every sphere and cone whose shell a shadow segment reaches (σ < 1 by the reference's own
    /// functions) is listed in the segment's cell and depth slab; and a cluster of small
    /// occluders, shadowing points among and below them, is listed far less often than with the
    /// light's whole radius (the last slab's lists, as the buffer was without slabs).
    #[test]
    fn the_depth_slabs_list_every_shell_a_segment_reaches() {
        use crate::reference::shadows::{cone_shell, sphere_shell};
        use crate::scene::{Cone, Falloff, Sphere};
        let mut s = default_scene();
        s.meshes.clear();
        // A hash-spread cluster 2 across at height 1..3, and two thin branches.
        let h = |i: u32, k: u32| (crate::scene::pixel_hash(i * 3 + k) as f64 / u32::MAX as f64) * 2.0 - 1.0;
        s.spheres = (0..300)
            .map(|i| Sphere {
                center: DVec3::new(h(i, 0), 2.0 + h(i, 1), h(i, 2)),
                radius: 0.05,
                material: 0,
            })
            .collect();
        s.cones = vec![
            Cone {
                base: DVec3::ZERO,
                base_radius: 0.08,
                apex: DVec3::new(0.3, 2.0, 0.1),
                apex_radius: 0.03,
                material: 0,
            },
            Cone {
                base: DVec3::new(0.3, 2.0, 0.1),
                base_radius: 0.03,
                apex: DVec3::new(-0.8, 2.9, 0.5),
                apex_radius: 0.02,
                material: 0,
            },
        ];
        let (light, r) = (DVec3::new(3.0, 12.0, 4.0), 0.5);
        let sh = light_shells(&s, light, r);
        assert_eq!(sh.slabs.count, SHELL_SLABS);
        let n = sh.slabs.count as usize;
        let (mut listed, mut unsliced, mut reached) = (0usize, 0usize, 0usize);
        for i in 0..4000u32 {
            // Points among the cluster and on the ground below it.
            let y = if i % 2 == 0 { 0.0 } else { 2.0 + h(i, 4) };
            let p = DVec3::new(1.5 * h(i, 5), y, 1.5 * h(i, 6));
            let dist = p.distance(light);
            let l = (light - p) / dist;
            let cell = shell_cell(-l, sh.res) as usize;
            let list = &sh.slab_cells[cell * n + sh.slabs.of(dist) as usize];
            (listed, unsliced) = (listed + list.len(), unsliced + sh.slab_cells[cell * n + n - 1].len());
            for (k, o) in sh.objects.iter().enumerate() {
                let sigma = match o.shape {
                    ShellShape::Sphere(j) => {
                        let b = &s.spheres[j as usize];
                        sphere_shell(Falloff::Disc, p, l, dist, r, b.center, b.radius)
                    }
                    ShellShape::Cone(j) => {
                        let c = &s.cones[j as usize];
                        cone_shell(Falloff::Disc, p, l, dist, r, c.base, c.base_radius, c.apex, c.apex_radius)
                    }
                    ShellShape::Mesh { .. } => continue,
                };
                if sigma < 1.0 {
                    reached += 1;
                    assert!(
                        list.contains(&(k as u32)),
                        "segment from {p}: object {k} (σ {sigma}) not listed"
                    );
                }
            }
        }
        assert!(reached > 1000, "only {reached} shells reached");
        // Measured: 0.46 (30.4 listed a segment against 66.2 unsliced, of which 1.3 reach it: the
        // rest are in the cell's cone of directions, not near the segment itself).
        let ratio = listed as f64 / unsliced as f64;
        assert!(ratio < 0.6, "the slabs list {ratio:.2} of the unsliced lists");
    }

    /// A long thin cylinder is listed along its length only (its capsule's pieces), far fewer
    /// cells than its bounding sphere reaches; and every direction passing within its radius
    /// plus the light's is listed.
    #[test]
    fn a_thin_cylinder_is_listed_along_its_axis() {
        let (light, r) = (DVec3::new(0.0, 10.0, 0.0), 0.05);
        let (a, b, rad) = (DVec3::new(-4.0, 0.0, -4.0), DVec3::new(4.0, 0.0, 4.0), 0.05);
        let res = 64;
        let count = |pieces: &[(DVec3, f64)]| {
            let mut cells = vec![false; 6 * res * res];
            cover(light, pieces, res as u32, &mut |c| cells[c as usize] = true);
            cells
        };
        let along = count(&capsule(a, b, rad + r));
        let sphere = count(&[((a + b) / 2.0, a.distance(b) / 2.0 + rad + r)]);
        let (n_along, n_sphere) =
            (along.iter().filter(|&&x| x).count(), sphere.iter().filter(|&&x| x).count());
        assert!(n_along * 8 < n_sphere, "capsule in {n_along} cells, bounding sphere in {n_sphere}");
        for i in 0..=1000 {
            let q = a.lerp(b, i as f64 / 1000.0) + DVec3::new(0.07, 0.0, -0.02);
            assert!(
                along[shell_cell(q - light, res as u32) as usize],
                "point {q} beside the axis not listed"
            );
        }
    }

    /// Positions repeated with different last digits (patches written separately) weld, so the
    /// seam between two quads is no contour edge; an edge the light's centre cannot see (under a
    /// lid) is left out.
    #[test]
    fn seams_weld_and_hidden_edges_are_left_out() {
        let mut s = default_scene();
        s.spheres.clear();
        s.cones.clear();
        let e = 1e-9;
        // Two unit quads side by side at y = 0, the second's copy of the shared edge nudged.
        let p = vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(1.0, 0.0, 1.0),
            DVec3::new(0.0, 0.0, 1.0),
            DVec3::new(1.0 + e, 0.0, 0.0),
            DVec3::new(2.0, 0.0, 0.0),
            DVec3::new(2.0, 0.0, 1.0),
            DVec3::new(1.0 - e, 0.0, 1.0),
        ];
        let indices = vec![[0, 2, 1], [0, 3, 2], [4, 6, 5], [4, 7, 6]];
        s.meshes = vec![Mesh { positions: p, normals: None, uvs: None, indices, material: 0 }];
        let light = DVec3::new(0.5, 5.0, 0.5);
        let sh = light_shells(&s, light, 0.2);
        assert_eq!(sh.edges.len(), 6, "the outline of the 2x1 rectangle: {:?}", sh.edges);
        // A lid: a larger quad above; the rectangle's outline is hidden from the light now.
        let lid = [
            DVec3::new(-1.0, 1.0, -1.0),
            DVec3::new(3.0, 1.0, -1.0),
            DVec3::new(3.0, 1.0, 2.0),
            DVec3::new(-1.0, 1.0, 2.0),
        ];
        s.meshes.push(Mesh {
            positions: lid.to_vec(),
            normals: None,
            uvs: None,
            indices: vec![[0, 2, 1], [0, 3, 2]],
            material: 0,
        });
        let sh = light_shells(&s, light, 0.2);
        assert_eq!(sh.edges.len(), 4, "only the lid's outline: {:?}", sh.edges);
        assert!(sh.edges.iter().flatten().all(|v| v.y == 1.0));
    }
}
