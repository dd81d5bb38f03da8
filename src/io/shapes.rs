//! Generated meshes: quad, box and icosphere for scene files; a fractal terrain for large-model
//! tests. And the triangulation of the polygons that NFF, OBJ and PLY files describe.
//!
//! Every shape shares vertices between its triangles (closed shapes are watertight) and winds
//! triangles counter-clockwise seen from outside, because flat-shaded triangles take their
//! outside, and so which side is inside a dielectric, from the winding (docs/shading.md).

use crate::scene::Mesh;
use glam::{DVec2, DVec3};
use std::collections::HashMap;

/// Vertices of one polygon, at most. Ear clipping costs O(n²) per polygon, so this bounds the
/// time a single polygon can take; generators write far smaller polygons (SPD's gears: 144).
pub const MAX_POLYGON_VERTICES: usize = 4096;
/// Icosphere subdivision limit: level 6 is 81 920 triangles, already smooth at any resolution.
pub const MAX_ICOSPHERE_SUBDIVISIONS: u32 = 6;

/// Triangle mesh geometry without a material.
#[derive(Clone, Debug, PartialEq)]
pub struct Geometry {
    pub positions: Vec<DVec3>,
    pub normals: Option<Vec<DVec3>>,
    pub indices: Vec<[u32; 3]>,
}

impl Geometry {
    /// Scales each axis by `scale` (about the origin), then moves by `translate`. Normals follow
    /// the inverse scale so that they stay perpendicular to the surface. The identity changes
    /// nothing, not even the sign of a zero, so a written scene loads back bit for bit.
    pub fn transform(&mut self, scale: DVec3, translate: DVec3) {
        if scale == DVec3::ONE && translate == DVec3::ZERO {
            return;
        }
        for p in &mut self.positions {
            *p = *p * scale + translate;
        }
        for n in self.normals.iter_mut().flatten() {
            *n = (*n / scale).normalize_or_zero();
        }
    }

    pub fn into_mesh(self, material: u32) -> Mesh {
        Mesh { positions: self.positions, normals: self.normals, uvs: None, indices: self.indices, material }
    }
}

/// A quad in the plane `y = center.y`, `size[0]` along x and `size[1]` along z, facing +y.
pub fn quad(center: DVec3, size: [f64; 2]) -> Geometry {
    let (hx, hz) = (size[0] * 0.5, size[1] * 0.5);
    // Going -x-z → -x+z → +x+z winds counter-clockwise seen from +y: z × x = +y.
    let corner = |sx: f64, sz: f64| center + DVec3::new(sx * hx, 0.0, sz * hz);
    quad_corners([corner(-1.0, -1.0), corner(-1.0, 1.0), corner(1.0, 1.0), corner(1.0, -1.0)])
}

/// A quad through four corners in order; it faces the side from which they run counter-clockwise.
pub fn quad_corners(corners: [DVec3; 4]) -> Geometry {
    Geometry { positions: corners.to_vec(), normals: None, indices: vec![[0, 1, 2], [0, 2, 3]] }
}

/// The axis-aligned box from `min` to `max`: 8 shared corners, 12 triangles.
pub fn cuboid(min: DVec3, max: DVec3) -> Geometry {
    // Corner i has x from bit 0, y from bit 1, z from bit 2 (0 = min, 1 = max).
    let positions = (0..8)
        .map(|i| {
            let pick = |bit: u32, lo: f64, hi: f64| if i & (1 << bit) == 0 { lo } else { hi };
            DVec3::new(pick(0, min.x, max.x), pick(1, min.y, max.y), pick(2, min.z, max.z))
        })
        .collect();
    // Each face as a counter-clockwise loop seen from outside.
    const FACES: [[u32; 4]; 6] = [
        [0, 2, 3, 1], // -z
        [4, 5, 7, 6], // +z
        [0, 4, 6, 2], // -x
        [1, 3, 7, 5], // +x
        [0, 1, 5, 4], // -y
        [2, 6, 7, 3], // +y
    ];
    let indices = FACES.iter().flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]]).collect();
    Geometry { positions, normals: None, indices }
}

/// A sphere approximated by a subdivided icosahedron, with the exact sphere normals per vertex.
/// `subdivisions` is clamped to [`MAX_ICOSPHERE_SUBDIVISIONS`].
pub fn icosphere(center: DVec3, radius: f64, subdivisions: u32) -> Geometry {
    let (mut unit, mut indices) = icosahedron();
    for _ in 0..subdivisions.min(MAX_ICOSPHERE_SUBDIVISIONS) {
        indices = subdivide(&mut unit, &indices);
    }
    let positions = unit.iter().map(|&n| center + radius * n).collect();
    Geometry { positions, normals: Some(unit), indices }
}

/// The regular icosahedron on the unit sphere, faces wound outward.
fn icosahedron() -> (Vec<DVec3>, Vec<[u32; 3]>) {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    #[rustfmt::skip]
    let corners = [
        [-1.0, t, 0.0], [1.0, t, 0.0], [-1.0, -t, 0.0], [1.0, -t, 0.0],
        [0.0, -1.0, t], [0.0, 1.0, t], [0.0, -1.0, -t], [0.0, 1.0, -t],
        [t, 0.0, -1.0], [t, 0.0, 1.0], [-t, 0.0, -1.0], [-t, 0.0, 1.0],
    ];
    #[rustfmt::skip]
    let faces = vec![
        [0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11],
        [1, 5, 9], [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8],
        [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9],
        [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1],
    ];
    (corners.iter().map(|&c| DVec3::from_array(c).normalize()).collect(), faces)
}

/// Splits every triangle into four, adding one vertex (on the unit sphere) per edge. Edge
/// midpoints are shared through a map so that neighbouring triangles keep sharing vertices.
fn subdivide(vertices: &mut Vec<DVec3>, triangles: &[[u32; 3]]) -> Vec<[u32; 3]> {
    let mut midpoints: HashMap<(u32, u32), u32> = HashMap::new();
    let mut midpoint = |a: u32, b: u32| {
        *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
            vertices.push((vertices[a as usize] + vertices[b as usize]).normalize());
            vertices.len() as u32 - 1
        })
    };
    let mut out = Vec::with_capacity(triangles.len() * 4);
    for &[a, b, c] in triangles {
        let (ab, bc, ca) = (midpoint(a, b), midpoint(b, c), midpoint(c, a));
        out.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
    }
    out
}

/// A fractal terrain over the square |x|, |z| ≤ 1: `side` × `side` vertices on a regular grid,
/// heights from a few octaves of value noise (at most about ±0.25), `2 (side − 1)²` triangles
/// facing +y, with smooth vertex normals when `normals`. The same `seed` gives the same mesh.
/// Large-model tests and the scale study use it: any triangle count, a real depth range, and
/// triangles as small and numerous as a scan's.
pub fn terrain(side: u32, seed: u64, normals: bool) -> Geometry {
    let n = side.max(2) as usize;
    let step = 2.0 / (n - 1) as f64;
    let height = |x: f64, z: f64| -> f64 {
        let (mut sum, mut amp, mut freq) = (0.0, 0.25, 2.0);
        for octave in 0..6u64 {
            sum += amp * value_noise(x * freq, z * freq, seed.wrapping_add(octave));
            amp *= 0.5;
            freq *= 2.0;
        }
        sum
    };
    let positions: Vec<DVec3> = (0..n * n)
        .map(|i| {
            let (x, z) = (-1.0 + (i % n) as f64 * step, -1.0 + (i / n) as f64 * step);
            DVec3::new(x, height(x, z), z)
        })
        .collect();
    let normals = normals.then(|| {
        (0..n * n)
            .map(|i| {
                let (c, r) = (i % n, i / n);
                let at = |c: usize, r: usize| positions[r * n + c];
                // Central differences, one-sided at the border.
                let dx = at((c + 1).min(n - 1), r) - at(c.saturating_sub(1), r);
                let dz = at(c, (r + 1).min(n - 1)) - at(c, r.saturating_sub(1));
                dz.cross(dx).normalize_or(DVec3::Y)
            })
            .collect()
    });
    let mut indices = Vec::with_capacity(2 * (n - 1) * (n - 1));
    for r in 0..n - 1 {
        for c in 0..n - 1 {
            let v = |c: usize, r: usize| (r * n + c) as u32;
            // Counter-clockwise seen from +y (z × x = +y), as `quad`.
            indices.push([v(c, r), v(c, r + 1), v(c + 1, r + 1)]);
            indices.push([v(c, r), v(c + 1, r + 1), v(c + 1, r)]);
        }
    }
    Geometry { positions, normals, indices }
}

/// Smoothly interpolated lattice noise in [-1, 1] (a hash per integer lattice point).
fn value_noise(x: f64, z: f64, seed: u64) -> f64 {
    let lattice = |i: i64, j: i64| -> f64 {
        let mut h = (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
            ^ (j as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F)
            ^ seed;
        h ^= h >> 31;
        h = h.wrapping_mul(0xBF58_476D_1CE4_E5B9);
        h ^= h >> 29;
        (h >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    };
    let (i, j) = (x.floor(), z.floor());
    let (fx, fz) = (x - i, z - j);
    let s = |t: f64| t * t * (3.0 - 2.0 * t);
    let (i, j) = (i as i64, j as i64);
    let a = lattice(i, j) + s(fx) * (lattice(i + 1, j) - lattice(i, j));
    let b = lattice(i, j + 1) + s(fx) * (lattice(i + 1, j + 1) - lattice(i, j + 1));
    a + s(fz) * (b - a)
}

/// Triangles covering the polygon `p` (vertices in order, convex or concave, any winding), as
/// index triples wound like the polygon; none for a polygon without area.
///
/// Ear clipping in the polygon's plane: Newell's normal (right for concave and slightly
/// non-planar polygons, unlike the first three vertices) gives the plane and the winding; an ear
/// is a convex corner whose triangle holds no other remaining vertex. Vertices that make no turn
/// (collinear, or a spike back along the same line) are dropped without a triangle, so no
/// zero-area triangle is made. A simple polygon always has an ear; one that is not simple (it
/// crosses itself) can run out of them, and then the rest is cut corner by corner without the
/// ear test, so the loop always ends, after O(n²) work at most for such polygons.
pub fn triangulate(p: &[DVec3]) -> Vec<[usize; 3]> {
    let n = p.len();
    if n < 3 {
        return Vec::new();
    }
    let mut normal = DVec3::ZERO;
    for i in 0..n {
        let (a, b) = (p[i], p[(i + 1) % n]);
        normal += DVec3::new((a.y - b.y) * (a.z + b.z), (a.z - b.z) * (a.x + b.x), (a.x - b.x) * (a.y + b.y));
    }
    let Some(normal) = normal.try_normalize() else { return Vec::new() };
    // (u, v, normal) right-handed: the polygon runs counter-clockwise in (u, v).
    let u = normal.any_orthonormal_vector();
    let v = normal.cross(u);
    let q: Vec<DVec2> = p.iter().map(|&x| DVec2::new((x - p[0]).dot(u), (x - p[0]).dot(v))).collect();
    let extent = q.iter().fold(0.0f64, |m, x| m.max(x.abs().max_element()));
    // Twice a triangle's area below this is no turn at all.
    let eps = 1e-12 * extent * extent;
    let turn = |a: usize, b: usize, c: usize| (q[b] - q[a]).perp_dot(q[c] - q[b]);
    let mut prev: Vec<usize> = (0..n).map(|i| (i + n - 1) % n).collect();
    let mut next: Vec<usize> = (0..n).map(|i| (i + 1) % n).collect();
    let is_ear = |a: usize, b: usize, c: usize, next: &[usize]| {
        let mut k = next[c];
        while k != a {
            let x = q[k];
            // Repeated vertices (a polygon touching itself) do not block an ear at their copy.
            let repeat = x == q[a] || x == q[b] || x == q[c];
            let inside = (q[b] - q[a]).perp_dot(x - q[a]) >= -eps
                && (q[c] - q[b]).perp_dot(x - q[b]) >= -eps
                && (q[a] - q[c]).perp_dot(x - q[c]) >= -eps;
            if inside && !repeat {
                return false;
            }
            k = next[k];
        }
        true
    };
    let mut out = Vec::with_capacity(n - 2);
    let (mut left, mut i, mut misses, mut simple) = (n, 0, 0, true);
    while left > 3 {
        let (a, c) = (prev[i], next[i]);
        let t = turn(a, i, c);
        simple &= misses < left;
        let cut = if t.abs() <= eps {
            true
        } else if t > 0.0 && (!simple || is_ear(a, i, c, &next)) {
            out.push([a, i, c]);
            true
        } else {
            !simple
        };
        if cut {
            next[a] = c;
            prev[c] = a;
            left -= 1;
            misses = 0;
            i = a;
        } else {
            misses += 1;
            i = c;
        }
    }
    let (a, c) = (prev[i], next[i]);
    if turn(a, i, c) > eps {
        out.push([a, i, c]);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashSet;

    /// Directed edges of all triangles; in a consistently wound mesh none repeats.
    fn directed_edges(g: &Geometry) -> Vec<(u32, u32)> {
        g.indices.iter().flat_map(|&[a, b, c]| [(a, b), (b, c), (c, a)]).collect()
    }

    /// Closed and consistently wound: every directed edge appears once and so does its reverse.
    fn assert_watertight(g: &Geometry) {
        let edges = directed_edges(g);
        let set: HashSet<_> = edges.iter().copied().collect();
        assert_eq!(set.len(), edges.len(), "a directed edge repeats: inconsistent winding");
        for &(a, b) in &edges {
            assert!(set.contains(&(b, a)), "edge {a}-{b} has no neighbour: not watertight");
        }
    }

    fn face_normal(g: &Geometry, t: [u32; 3]) -> DVec3 {
        let [a, b, c] = t.map(|i| g.positions[i as usize]);
        (b - a).cross(c - a)
    }

    /// Six times the enclosed volume; positive when a closed mesh is wound outward.
    fn signed_volume6(g: &Geometry) -> f64 {
        g.indices
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| g.positions[i as usize]);
                a.dot(b.cross(c))
            })
            .sum()
    }

    #[test]
    fn box_is_watertight_outward_and_has_the_right_volume() {
        let (min, max) = (DVec3::new(-1.0, 0.5, 2.0), DVec3::new(2.0, 1.5, 4.0));
        let g = cuboid(min, max);
        assert_eq!((g.positions.len(), g.indices.len()), (8, 12));
        assert_watertight(&g);
        assert!((signed_volume6(&g) / 6.0 - 3.0 * 1.0 * 2.0).abs() < 1e-12);
        let centre = (min + max) * 0.5;
        for &t in &g.indices {
            let to_face = g.positions[t[0] as usize] - centre;
            assert!(face_normal(&g, t).dot(to_face) > 0.0, "triangle {t:?} faces inward");
        }
    }

    #[test]
    fn icosphere_is_watertight_outward_with_unit_normals_at_every_level() {
        let centre = DVec3::new(1.0, -2.0, 3.0);
        for level in 0..=3 {
            let g = icosphere(centre, 2.0, level);
            let faces = 20 * 4usize.pow(level);
            assert_eq!(g.indices.len(), faces);
            assert_eq!(g.positions.len(), faces / 2 + 2, "Euler: V = F/2 + 2 when shared");
            assert_watertight(&g);
            assert!(signed_volume6(&g) > 0.0);
            let normals = g.normals.as_ref().unwrap();
            for (p, n) in g.positions.iter().zip(normals) {
                assert!((n.length() - 1.0).abs() < 1e-12);
                assert!(((*p - centre) / 2.0 - *n).length() < 1e-12, "normal is radial");
            }
            for &t in &g.indices {
                let mid = t.iter().map(|&i| g.positions[i as usize]).sum::<DVec3>() / 3.0 - centre;
                assert!(face_normal(&g, t).dot(mid) > 0.0, "triangle {t:?} faces inward");
            }
        }
    }

    #[test]
    fn icosphere_subdivisions_are_capped() {
        let g = icosphere(DVec3::ZERO, 1.0, 100);
        assert_eq!(g.indices.len(), 20 * 4usize.pow(MAX_ICOSPHERE_SUBDIVISIONS));
    }

    #[test]
    fn quad_faces_up_with_shared_vertices_and_the_given_size() {
        let g = quad(DVec3::new(1.0, 2.0, 3.0), [4.0, 6.0]);
        assert_eq!((g.positions.len(), g.indices.len()), (4, 2));
        let edges = directed_edges(&g);
        assert_eq!(edges.iter().collect::<HashSet<_>>().len(), edges.len(), "consistent winding");
        let mut area = 0.0;
        for &t in &g.indices {
            let n = face_normal(&g, t);
            assert!(n.x == 0.0 && n.z == 0.0 && n.y > 0.0, "faces +y: {n}");
            area += n.length() / 2.0;
        }
        assert_eq!(area, 24.0);
        assert!(g.positions.iter().all(|p| p.y == 2.0));
    }

    #[test]
    fn transform_scales_then_translates_and_keeps_normals_perpendicular() {
        let mut g = icosphere(DVec3::ZERO, 1.0, 1);
        let scale = DVec3::new(2.0, 1.0, 0.5);
        g.transform(scale, DVec3::new(0.0, 5.0, 0.0));
        let normals = g.normals.as_ref().unwrap();
        for (p, n) in g.positions.iter().zip(normals) {
            // The scaled sphere is the ellipsoid (x/2)² + (y-5)² + (2z)² = 1; its gradient is
            // the normal direction.
            let q = *p - DVec3::new(0.0, 5.0, 0.0);
            let grad = (q / (scale * scale)).normalize();
            assert!((grad - *n).length() < 1e-12);
        }
    }

    #[test]
    fn terrain_has_the_triangles_it_promises_facing_up() {
        let g = terrain(20, 3, true);
        assert_eq!(g.indices.len(), 2 * 19 * 19);
        assert_eq!(g, terrain(20, 3, true), "same seed, same mesh");
        assert_ne!(g.positions, terrain(20, 4, true).positions);
        for t in &g.indices {
            let p = t.map(|i| g.positions[i as usize]);
            assert!((p[1] - p[0]).cross(p[2] - p[0]).y > 0.0, "winding faces +y");
        }
        assert!(g.normals.unwrap().iter().all(|n| n.y > 0.0 && (n.length() - 1.0).abs() < 1e-12));
        assert!(g.positions.iter().all(|p| p.y.abs() < 0.5));
    }

    /// Twice the area of the polygon (Newell) and the sum of twice the triangles' areas, each
    /// triangle's measured along the polygon's normal (negative if wound the other way).
    fn areas(p: &[DVec3], tris: &[[usize; 3]]) -> (f64, f64) {
        let mut normal = DVec3::ZERO;
        for i in 0..p.len() {
            normal += p[i].cross(p[(i + 1) % p.len()]);
        }
        let unit = normal.normalize();
        let sum = tris.iter().map(|t| (p[t[1]] - p[t[0]]).cross(p[t[2]] - p[t[0]]).dot(unit)).sum();
        (normal.length(), sum)
    }

    /// Every triangle wound like the polygon and, together, exactly its area: ears lie inside
    /// the polygon, so this means they cover it without overlap.
    fn assert_covers(p: &[DVec3], tris: &[[usize; 3]]) {
        let (area, sum) = areas(p, tris);
        let unit = {
            let mut n = DVec3::ZERO;
            for i in 0..p.len() {
                n += p[i].cross(p[(i + 1) % p.len()]);
            }
            n.normalize()
        };
        for t in tris {
            assert!((p[t[1]] - p[t[0]]).cross(p[t[2]] - p[t[0]]).dot(unit) > 0.0, "{t:?} wound backwards");
        }
        assert!((area - sum).abs() <= 1e-9 * area, "triangles cover {sum}, the polygon {area}");
    }

    fn xy(points: &[(f64, f64)]) -> Vec<DVec3> {
        points.iter().map(|&(x, y)| DVec3::new(x, y, 0.0)).collect()
    }

    #[test]
    fn convex_and_concave_polygons() {
        let square = xy(&[(0., 0.), (1., 0.), (1., 1.), (0., 1.)]);
        assert_eq!(triangulate(&square).len(), 2);
        assert_covers(&square, &triangulate(&square));
        // Clockwise: the triangles follow the polygon's winding.
        let cw: Vec<DVec3> = square.iter().rev().copied().collect();
        assert_covers(&cw, &triangulate(&cw));
        let l_shape = xy(&[(0., 0.), (2., 0.), (2., 1.), (1., 1.), (1., 2.), (0., 2.)]);
        assert_eq!(triangulate(&l_shape).len(), 4);
        assert_covers(&l_shape, &triangulate(&l_shape));
        // A comb: the fan from vertex 0 would cover the gaps between the teeth.
        let mut comb = vec![(0.0, 0.0), (9.0, 0.0)];
        for k in (0..5).rev() {
            let x = 2.0 * k as f64;
            comb.extend([(x + 1.0, 3.0), (x + 1.0, 1.0), (x, 1.0), (x, 3.0)]);
        }
        comb.pop();
        comb.pop();
        comb.pop();
        let comb = xy(&comb);
        assert_covers(&comb, &triangulate(&comb));
    }

    #[test]
    fn tilted_star_shaped_and_gear_polygons() {
        // Random star-shaped polygons in a tilted plane, far from the origin.
        let (u, v) = (DVec3::new(1.0, 2.0, 0.5).normalize(), DVec3::new(-2.0, 1.0, 0.3));
        let v = (v - v.dot(u) * u).normalize();
        let mut seed = 1u64;
        let mut rnd = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for n in [3, 5, 17, 144, 1000] {
            let p: Vec<DVec3> = (0..n)
                .map(|k| {
                    let a = std::f64::consts::TAU * k as f64 / n as f64;
                    let r = 0.2 + rnd();
                    DVec3::splat(100.0) + r * (a.cos() * u + a.sin() * v)
                })
                .collect();
            let tris = triangulate(&p);
            assert_eq!(tris.len(), n - 2);
            assert_covers(&p, &tris);
        }
        // A gear face from SPD's gears: 144 vertices, teeth and gaps.
        let gear: Vec<DVec3> = (0..144)
            .map(|k| {
                let a = std::f64::consts::TAU * (k / 4) as f64 / 36.0 + [0.0, 0.05, 0.08, 0.13][k % 4];
                let r = [1.0, 1.0, 0.9, 0.9][k % 4];
                DVec3::new(r * a.cos(), r * a.sin(), 1.0)
            })
            .collect();
        let tris = triangulate(&gear);
        assert_eq!(tris.len(), 142);
        assert_covers(&gear, &tris);
    }

    #[test]
    fn collinear_and_degenerate_vertices() {
        // A square with a vertex in the middle of an edge: no zero-area triangle (each is wound
        // forwards, so has area).
        let p = xy(&[(0., 0.), (0.5, 0.), (1., 0.), (1., 1.), (0., 1.)]);
        assert_covers(&p, &triangulate(&p));
        let p = xy(&[(0., 0.), (0.25, 0.), (0.5, 0.), (0.75, 0.), (1., 0.), (0.5, 1.)]);
        assert_covers(&p, &triangulate(&p));
        // All on a line, or repeated points: nothing to draw.
        assert!(triangulate(&xy(&[(0., 0.), (1., 0.), (2., 0.)])).is_empty());
        assert!(triangulate(&xy(&[(1., 1.), (1., 1.), (1., 1.), (1., 1.)])).is_empty());
        // A repeated vertex (a polygon touching itself at a point) still triangulates.
        let p = xy(&[(0., 0.), (2., 0.), (2., 2.), (1., 1.), (0., 2.), (1., 1.)]);
        let (area, sum) = areas(&p, &triangulate(&p));
        assert!((area - sum).abs() < 1e-9, "{area} vs {sum}");
    }

    #[test]
    fn self_intersecting_polygons_end() {
        // A bow tie has no valid triangulation; the loop must still end with n - 2 at most.
        let p = xy(&[(0., 0.), (1., 1.), (1., 0.), (0., 1.)]);
        assert!(triangulate(&p).len() <= 2);
        let n = MAX_POLYGON_VERTICES;
        let star: Vec<DVec3> = (0..n)
            .map(|k| {
                let a = std::f64::consts::TAU * (k * (n / 2 - 1)) as f64 / n as f64;
                DVec3::new(a.cos(), a.sin(), 0.0)
            })
            .collect();
        let t = std::time::Instant::now();
        assert!(triangulate(&star).len() <= n - 2);
        assert!(t.elapsed().as_secs_f64() < 5.0, "{:?}", t.elapsed());
    }

    /// A thin spiral is the classic slow case of ear clipping (most corners are not ears); at
    /// the vertex limit it must still take well under a second.
    #[test]
    fn a_spiral_at_the_vertex_limit_is_fast() {
        let half = MAX_POLYGON_VERTICES / 2;
        let arm = |k: usize, r: f64| {
            let a = 6.0 * std::f64::consts::TAU * k as f64 / half as f64;
            let r = r + 0.5 * k as f64 / half as f64;
            DVec3::new(r * a.cos(), r * a.sin(), 0.0)
        };
        let mut p: Vec<DVec3> = (0..half).map(|k| arm(k, 0.1)).collect();
        p.extend((0..half).rev().map(|k| arm(k, 0.12)));
        let t = std::time::Instant::now();
        let tris = triangulate(&p);
        println!("spiral of {} vertices: {:?}", p.len(), t.elapsed());
        assert_covers(&p, &tris);
        assert!(t.elapsed().as_secs_f64() < 1.0, "{:?}", t.elapsed());
    }
}
