//! The occluders of `shell` shadow mode as objects (docs/shadows.md, Shell objects): every sphere
//! and cone, and every mesh as one object whose penumbra comes from its contour edges as seen
//! from the light's centre. Input data built once per light on the host and shared by both
//! tracers (like the bundle's point set), not tracing code.

use super::Scene;
use glam::DVec3;
use std::collections::HashMap;

/// A position welded by its exact value.
type Key = [u64; 3];

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
    pub shape: ShellShape,
}

/// The shell objects of a scene for one light.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LightShells {
    pub objects: Vec<ShellObject>,
    /// Contour edges of every mesh seen from the light's centre, as segments.
    pub edges: Vec<[DVec3; 2]>,
    /// A light buffer (Haines & Greenberg 1986): the directions from the light's centre cut into
    /// the cells of a cube ([`shell_cell`], `SHELL_CELL_RES`² per face), each listing the objects
    /// (indices into `objects`) whose shell a shadow segment in that direction can reach. An
    /// object left out of a cell gives σ = 1 exactly to every segment in it, so skipping it
    /// changes no result: the list is only a way to visit fewer objects.
    pub cells: Vec<Vec<u32>>,
}

/// Cells per side of each face of the light buffer's cube.
pub const SHELL_CELL_RES: u32 = 16;

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

/// The light-buffer cell of direction `d` (from the light's centre, not necessarily unit):
/// face by the largest axis (+x, −x, +y, −y, +z, −z), then row-major on the face. The shader's
/// `shell_cell` is the same formula.
pub fn shell_cell(d: DVec3) -> u32 {
    let a = d.abs();
    let (face, u, v) = if a.x >= a.y && a.x >= a.z {
        (if d.x > 0.0 { 0 } else { 1 }, d.y / a.x, d.z / a.x)
    } else if a.y >= a.z {
        (if d.y > 0.0 { 2 } else { 3 }, d.x / a.y, d.z / a.y)
    } else {
        (if d.z > 0.0 { 4 } else { 5 }, d.x / a.z, d.y / a.z)
    };
    let n = SHELL_CELL_RES;
    let at = |w: f64| (((w * 0.5 + 0.5) * n as f64) as i64).clamp(0, n as i64 - 1) as u32;
    face * n * n + at(v) * n + at(u)
}

/// Centre direction (unit) and angular radius (the largest angle to a corner) of cell `c`.
fn cell_cone(c: u32) -> (DVec3, f64) {
    let n = SHELL_CELL_RES;
    let (face, iv, iu) = (c / (n * n), c / n % n, c % n);
    let dir = |u: f64, v: f64| -> DVec3 {
        let w = [-1.0, 1.0][(face % 2 == 0) as usize];
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

/// Builds the shell objects of `scene` for a light centred at `light`: spheres, then cones, then
/// meshes (each with its contour edges). A mesh edge is a contour edge when it borders one
/// triangle only, or two (or more) that do not all face the same way from `light`; positions
/// are welded by their exact value, so quads written as separate triangles still share edges.
///
/// `light_radius` bounds every shell's width (`b = r t / D < r`): the light buffer lists an
/// object in every cell within the angle its bounding sphere grown by it subtends, plus the
/// cell's own angular radius and 10⁻³ rad for f32 rounding of the direction on the GPU.
pub fn light_shells(scene: &Scene, light: DVec3, light_radius: f64) -> LightShells {
    let mut out = LightShells::default();
    for (i, s) in scene.spheres.iter().enumerate() {
        out.objects.push(ShellObject {
            center: s.center,
            radius: s.radius,
            shape: ShellShape::Sphere(i as u32),
        });
    }
    for (i, c) in scene.cones.iter().enumerate() {
        let center = (c.base + c.apex) / 2.0;
        let radius = (c.apex - c.base).length() / 2.0 + c.base_radius.max(c.apex_radius);
        out.objects.push(ShellObject { center, radius, shape: ShellShape::Cone(i as u32) });
    }
    let mut first = 0u32;
    for m in &scene.meshes {
        let end = first + m.indices.len() as u32;
        let edge_first = out.edges.len() as u32;
        let key = |v: DVec3| -> Key { [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()] };
        // Edge (by its two welded end points, in order) -> its end points as first seen and the
        // facing of each triangle using it.
        let mut edges: HashMap<(Key, Key), (DVec3, DVec3, Vec<bool>)> = HashMap::new();
        let mut order = vec![];
        for t in &m.indices {
            let p = t.map(|i| m.positions[i as usize]);
            let n = (p[1] - p[0]).cross(p[2] - p[0]);
            if n == DVec3::ZERO {
                continue;
            }
            let facing = n.dot(light - p[0]) > 0.0;
            for k in 0..3 {
                let (a, b) = (p[k], p[(k + 1) % 3]);
                let (ka, kb) = (key(a), key(b));
                let id = if ka <= kb { (ka, kb) } else { (kb, ka) };
                let e = edges.entry(id).or_insert_with(|| {
                    order.push(id);
                    (a, b, vec![])
                });
                e.2.push(facing);
            }
        }
        for id in order {
            let (a, b, facings) = &edges[&id];
            if facings.len() == 1 || facings.iter().any(|&f| f != facings[0]) {
                out.edges.push([*a, *b]);
            }
        }
        let (lo, hi) = m
            .positions
            .iter()
            .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &p| (lo.min(p), hi.max(p)));
        let center = if m.positions.is_empty() { DVec3::ZERO } else { (lo + hi) / 2.0 };
        let radius = m.positions.iter().map(|p| p.distance(center)).fold(0.0, f64::max);
        let shape = ShellShape::Mesh { triangles: [first, end], edges: [edge_first, out.edges.len() as u32] };
        if end > first {
            out.objects.push(ShellObject { center, radius, shape });
        }
        first = end;
    }
    let cones: Vec<(DVec3, f64)> = (0..6 * SHELL_CELL_RES * SHELL_CELL_RES).map(cell_cone).collect();
    out.cells = vec![vec![]; cones.len()];
    for (k, o) in out.objects.iter().enumerate() {
        let to = o.center - light;
        let reach = o.radius + light_radius;
        let everywhere = to.length() <= reach;
        let (omega, alpha) =
            if everywhere { (DVec3::Z, 0.0) } else { (to.normalize(), (reach / to.length()).asin()) };
        for (cell, &(centre, beta)) in out.cells.iter_mut().zip(&cones) {
            if everywhere || omega.angle_between(centre) <= alpha + beta + 1e-3 {
                cell.push(k as u32);
            }
        }
    }
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
        let listed = sh.cells.iter().filter(|c| !c.is_empty()).count();
        // Its grown cap (5.4°) plus a cell's radius (up to ~5°) covers about 15 of the 1536
        // cells (measured: 15); everywhere would be a broken buffer.
        assert!(listed <= 20, "a small far sphere in {listed} cells");
        let mut checked = 0;
        for i in 0..20_000 {
            // Directions spread over the sphere (a Fibonacci lattice).
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / 20_000.0;
            let phi = i as f64 * std::f64::consts::PI * (3.0 - 5f64.sqrt());
            let d = DVec3::new((1.0 - z * z).sqrt() * phi.cos(), (1.0 - z * z).sqrt() * phi.sin(), z);
            let c = shell_cell(d);
            let (centre, beta) = cell_cone(c);
            assert!(centre.angle_between(d) <= beta + 1e-12, "direction {d} outside its cell {c}");
            let to = s.spheres[0].center - light;
            let t = to.dot(d);
            if t > 0.0 && (to - t * d).length() < 0.3 + r {
                assert_eq!(sh.cells[c as usize], vec![0], "direction {d} near the sphere, cell {c}");
                checked += 1;
            }
        }
        assert!(checked > 20, "only {checked} directions near the sphere");
    }
}
