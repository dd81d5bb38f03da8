//! The occluders of `shell` shadow mode as objects (docs/shadows.md, Shell objects): every sphere
//! and cone, and every mesh as one object whose penumbra comes from its contour edges as seen
//! from the light's centre. Input data built once per light on the host and shared by both
//! tracers (like the bundle's point set), not tracing code.

use super::Scene;
use glam::DVec3;
use std::collections::HashMap;

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
}

/// Builds the shell objects of `scene` for a light centred at `light`: spheres, then cones, then
/// meshes (each with its contour edges). A mesh edge is a contour edge when it borders one
/// triangle only, or two (or more) that do not all face the same way from `light`; positions
/// are welded by their exact value, so quads written as separate triangles still share edges.
pub fn light_shells(scene: &Scene, light: DVec3) -> LightShells {
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
        let key = |v: DVec3| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
        // Edge (by its two welded end points, in order) -> (facing of each triangle using it).
        let mut edges: HashMap<([u64; 3], [u64; 3]), (DVec3, DVec3, Vec<bool>)> = HashMap::new();
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
        let sh = light_shells(&s, DVec3::new(5.0, 6.0, 7.0));
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
        assert_eq!(light_shells(&s, DVec3::new(5.0, 6.0, 7.0)).edges.len(), 3);
    }
}
