//! The recursive f64 tracer: brute force over every primitive, hard shadows, recursion per
//! docs/shading.md. Slow by design; it is the oracle, not the renderer.

use super::bvh::{Bvh, PrimId};
use super::geometry::{
    cone_bounds, cone_normal, intersect_cone, intersect_sphere, intersect_triangle, triangle_normal,
};
use super::shading::{ambient_intensity, reflect, reflectance, refract, shade_ambient, shade_light};
use super::shadows::{basis, bundle_point, cone_shell, mesh_shell, sphere_shell, stratified_disc};
use super::texture::{cone_uv, material_at, sphere_uv};
use crate::scene::{
    bundle_samples, light_shells, scene_shells, CameraBasis, Combine, Light, LightShells, MaterialKind,
    Scene, ShadowMode, ShellShape, Triangle,
};
use glam::{DVec2, DVec3};
use std::cell::Cell;
use std::ops::AddAssign;

/// Ray offset relative to the hit point's magnitude: ~4500 f64 ulps (1e-9 moved contact shadows visibly at 1e6).
pub const RAY_OFFSET_REL: f64 = 1e-12;

/// Rays traced, by kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Stats {
    pub eye: u64,
    pub reflection: u64,
    pub refraction: u64,
    pub shadow: u64,
}

impl AddAssign for Stats {
    fn add_assign(&mut self, o: Stats) {
        self.eye += o.eye;
        self.reflection += o.reflection;
        self.refraction += o.refraction;
        self.shadow += o.shadow;
    }
}

/// Linear radiance, row-major, `y = 0` the top row.
#[derive(Clone, Debug, PartialEq)]
pub struct RadianceImage {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<DVec3>,
}

impl RadianceImage {
    pub fn get(&self, x: u32, y: u32) -> DVec3 {
        self.pixels[y as usize * self.width as usize + x as usize]
    }
}

/// What a ray hit, resolved for shading.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceHit {
    pub t: f64,
    pub p: DVec3,
    /// Geometric normal, flipped to face the ray (`n_g · d <= 0`).
    pub n_g: DVec3,
    /// Shading normal, flipped with `n_g` and never on the other side of it.
    pub n: DVec3,
    /// The ray hit the back side (the normals were flipped).
    pub inside: bool,
    pub material: u32,
    /// Magnitude of the numbers `p` was computed from (origin and distance along the ray, the
    /// sphere's centre and radius or the triangle's vertices): its rounding error is relative
    /// to this, so ray offsets are too.
    pub scale: f64,
    /// Texture coordinates: interpolated on triangles ((0, 0) on a mesh without them), `sphere_uv`
    /// and `cone_uv` on spheres and cones.
    pub uv: DVec2,
}

/// Which primitive a ray hit, by its index in the scene's lists: sphere `i`, cone `i`, or
/// triangle `triangle` of mesh `mesh` (the viewer's picking names it so).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Primitive {
    Sphere(usize),
    Triangle { mesh: usize, triangle: usize },
    Cone(usize),
    Volume(usize),
    Patch(usize),
}

/// The parts of a [`Reference`] that depend on the primitives alone (resolved triangles and the
/// BVH): kept by a caller that asks rays of scenes whose geometry does not change, so that a
/// big mesh's BVH is built once ([`Reference::into_geometry`], [`Reference::with_geometry`]).
pub struct Geometry {
    triangles: Vec<Triangle>,
    bvh: Option<Bvh>,
}

#[derive(Clone, Copy)]
enum Prim {
    Sphere(usize),
    Triangle {
        index: usize,
        b1: f64,
        b2: f64,
    },
    Cone(usize),
    /// Volume `index`'s isosurface, with the outward normal found with the hit (world units).
    Volume {
        index: usize,
        iso: usize,
        n: DVec3,
    },
    /// Patch `index` at its parameters `(u, v)`.
    Patch {
        index: usize,
        u: f64,
        v: f64,
    },
}

/// A scene prepared for tracing: camera basis, resolved triangles and unit ambient `up`.
pub struct Reference<'a> {
    pub scene: &'a Scene,
    basis: CameraBasis,
    triangles: Vec<Triangle>,
    up: DVec3,
    /// `None`: scan every primitive (the plain oracle the BVH is tested against).
    bvh: Option<Bvh>,
    /// `Some(n)`: soft shadows integrated over an `n × n` stratified disc instead of the scene's
    /// shadow mode (the ground truth of docs/shadows.md).
    ground_truth: Option<u32>,
    bundle: Vec<[f64; 2]>,
    /// Shell mode: each light's shell objects (`scene::light_shells`).
    shells: Vec<LightShells>,
    /// Each volume's transfer table (`Transfer::table`), made once rather than per ray.
    transfer_tables: Vec<Vec<[f32; 4]>>,
}

impl<'a> Reference<'a> {
    /// Prepares `scene` with a BVH over its primitives.
    pub fn new(scene: &'a Scene) -> Self {
        let mut r = Self::brute_force(scene);
        let spheres = scene.spheres.iter().map(|s| {
            let r = DVec3::splat(s.radius);
            (s.center - r, s.center + r)
        });
        let tris =
            r.triangles.iter().map(|t| (t.p[0].min(t.p[1]).min(t.p[2]), t.p[0].max(t.p[1]).max(t.p[2])));
        let cones = scene.cones.iter().map(|c| cone_bounds(c.base, c.base_radius, c.apex, c.apex_radius));
        let volumes = scene.volumes.iter().map(|v| v.world_bounds());
        let patches = scene.patches.iter().map(patch_bounds);
        r.bvh = Some(Bvh::build(
            &spheres.chain(tris).chain(cones).chain(volumes).chain(patches).collect::<Vec<_>>(),
        ));
        r
    }

    /// The triangles and BVH, to prepare another scene with the same primitives again
    /// ([`Reference::with_geometry`]) without building them anew.
    pub fn into_geometry(self) -> Geometry {
        Geometry { triangles: self.triangles, bvh: self.bvh }
    }

    /// Prepares `scene` with `geometry` from [`Reference::into_geometry`] of a scene with the
    /// same spheres, meshes and cones (the caller checks; other primitives give wrong hits).
    pub fn with_geometry(scene: &'a Scene, geometry: Geometry) -> Self {
        let mut r = Self::prepare(scene, geometry.triangles);
        r.bvh = geometry.bvh;
        r
    }

    /// Prepares `scene` to be traced by testing every primitive for every ray.
    ///
    /// `scene` must be a still: an animated scene is traced at a time, `scene.at(t)` (the
    /// free functions below take time 0, as the GPU renderers do).
    pub fn brute_force(scene: &'a Scene) -> Self {
        Self::prepare(scene, scene.triangles().collect())
    }

    /// [`Reference::new`] for a scene in shell mode whose shells (`scene::scene_shells`) are
    /// already built.
    pub fn with_shells(scene: &'a Scene, shells: Vec<LightShells>) -> Self {
        let mut hard = scene.clone();
        hard.trace.shadows = ShadowMode::Hard;
        let geometry = Reference::new(&hard).into_geometry();
        let mut r = Self::prepare_with(scene, geometry.triangles, Some(shells));
        r.bvh = geometry.bvh;
        r
    }

    fn prepare(scene: &'a Scene, triangles: Vec<Triangle>) -> Self {
        Self::prepare_with(scene, triangles, None)
    }

    fn prepare_with(scene: &'a Scene, triangles: Vec<Triangle>, shells: Option<Vec<LightShells>>) -> Self {
        assert!(!scene.is_animated(), "trace an animated scene at a time: Reference::new(&scene.at(t))");
        Reference {
            scene,
            basis: scene.camera.basis(),
            triangles,
            // docs/shading.md wants a unit `up`; the scene only guarantees non-zero.
            up: scene.ambient.up.normalize(),
            bvh: None,
            ground_truth: None,
            bundle: match scene.trace.shadows {
                ShadowMode::Bundle { samples, .. } => bundle_samples(samples),
                _ => Vec::new(),
            },
            shells: match (scene.trace.shadows, shells) {
                (ShadowMode::Shell { .. }, Some(shells)) => shells,
                (ShadowMode::Shell { .. }, None) => scene_shells(scene),
                _ => Vec::new(),
            },
            transfer_tables: scene.volumes.iter().map(|v| v.transfer.table()).collect(),
        }
    }

    /// Traces soft shadows as the ground truth does: `strata²` stratified rays per light.
    pub fn with_ground_truth(mut self, strata: u32) -> Self {
        self.ground_truth = Some(strata.max(1));
        self
    }

    /// Radiance through image position (`px`, `py`) in pixels; `(x + 0.5, y + 0.5)` is the
    /// centre of pixel (x, y).
    pub fn trace_pixel(&self, px: f64, py: f64, stats: &mut Stats) -> DVec3 {
        let cam = &self.scene.camera;
        let d = cam.direction(&self.basis, px, py).normalize();
        stats.eye += 1;
        let pixel = px.floor().max(0.0) as u32 + py.floor().max(0.0) as u32 * cam.width;
        self.trace_from(cam.eye, d, 1, DVec3::ONE, pixel, stats)
    }

    /// Nearest hit with `0 < t < t_max`; `d` unit. The winner is the smallest `t`, and on an
    /// exact tie the lowest primitive index (spheres, then triangles, then cones, each in scene
    /// order).
    pub fn intersect(&self, o: DVec3, d: DVec3, t_max: f64) -> Option<SurfaceHit> {
        self.intersect_primitive(o, d, t_max).map(|(_, hit)| hit)
    }

    /// [`Reference::intersect`], and which primitive the hit is on.
    pub fn intersect_primitive(&self, o: DVec3, d: DVec3, t_max: f64) -> Option<(Primitive, SurfaceHit)> {
        let best: Cell<Option<(f64, PrimId, Prim)>> = Cell::new(None);
        let consider = |id: PrimId| {
            if let Some((t, prim)) = self.hit_prim(id, o, d) {
                let better = match best.get() {
                    None => t < t_max,
                    Some((bt, bid, _)) => t < bt || (t == bt && id < bid),
                };
                if better {
                    best.set(Some((t, id, prim)));
                }
            }
        };
        match &self.bvh {
            Some(bvh) => {
                let bound = || best.get().map_or(t_max, |b| b.0);
                bvh.traverse(o, d, bound, |id| {
                    consider(id);
                    false
                });
            }
            None => (0..self.prim_count()).for_each(consider),
        }
        best.get().map(|(t, _, prim)| (self.primitive(prim), self.resolve(o, d, t, prim)))
    }

    fn primitive(&self, prim: Prim) -> Primitive {
        match prim {
            Prim::Sphere(i) => Primitive::Sphere(i),
            Prim::Cone(i) => Primitive::Cone(i),
            Prim::Volume { index, .. } => Primitive::Volume(index),
            Prim::Patch { index, .. } => Primitive::Patch(index),
            Prim::Triangle { index, .. } => {
                let mut first = 0;
                for (mesh, m) in self.scene.meshes.iter().enumerate() {
                    if index < first + m.indices.len() {
                        return Primitive::Triangle { mesh, triangle: index - first };
                    }
                    first += m.indices.len();
                }
                unreachable!("triangle {index} is in no mesh")
            }
        }
    }

    /// Whether anything blocks the segment `o + t d`, `0 < t < t_max` (`d` unit).
    pub fn occluded(&self, o: DVec3, d: DVec3, t_max: f64) -> bool {
        let blocks = |id: PrimId| self.hit_prim(id, o, d).is_some_and(|(t, _)| t < t_max);
        match &self.bvh {
            Some(bvh) => {
                let mut hit = false;
                bvh.traverse(
                    o,
                    d,
                    || t_max,
                    |id| {
                        hit = blocks(id);
                        hit
                    },
                );
                hit
            }
            None => (0..self.prim_count()).any(blocks),
        }
    }

    fn prim_count(&self) -> PrimId {
        (self.scene.spheres.len()
            + self.triangles.len()
            + self.scene.cones.len()
            + self.scene.volumes.len()
            + self.scene.patches.len()) as PrimId
    }

    /// Nearest hit of primitive `id` with `t > 0` (no upper bound: the nearest root does not
    /// depend on it, so callers compare `t` themselves).
    fn hit_prim(&self, id: PrimId, o: DVec3, d: DVec3) -> Option<(f64, Prim)> {
        let ns = self.scene.spheres.len();
        let id = id as usize;
        if id < ns {
            let s = &self.scene.spheres[id];
            intersect_sphere(o, d, s.center, s.radius, 0.0, f64::INFINITY).map(|t| (t, Prim::Sphere(id)))
        } else if id < ns + self.triangles.len() {
            let index = id - ns;
            let [p0, p1, p2] = self.triangles[index].p;
            intersect_triangle(o, d, p0, p1, p2, 0.0, f64::INFINITY)
                .map(|(t, b1, b2)| (t, Prim::Triangle { index, b1, b2 }))
        } else if id >= ns + self.triangles.len() + self.scene.cones.len() + self.scene.volumes.len() {
            let index = id - ns - self.triangles.len() - self.scene.cones.len() - self.scene.volumes.len();
            let patch = &self.scene.patches[index];
            let (lo, hi) = patch_bounds(patch);
            super::patch::hit(patch, o, d, [0.0, f64::INFINITY], PATCH_TOLERANCE * (hi - lo).length())
                .map(|(t, u, v)| (t, Prim::Patch { index, u, v }))
        } else if id >= ns + self.triangles.len() + self.scene.cones.len() {
            let index = id - ns - self.triangles.len() - self.scene.cones.len();
            volume_hit(&self.scene.volumes[index], o, d)
                .map(|(t, iso, n)| (t, Prim::Volume { index, iso, n }))
        } else {
            let index = id - ns - self.triangles.len();
            let c = &self.scene.cones[index];
            intersect_cone(o, d, c.base, c.base_radius, c.apex, c.apex_radius, 0.0, f64::INFINITY)
                .map(|t| (t, Prim::Cone(index)))
        }
    }

    fn resolve(&self, o: DVec3, d: DVec3, t: f64, prim: Prim) -> SurfaceHit {
        let p = o + t * d;
        let mut scale = o.abs().max_element() + t * d.length();
        let mut uv = DVec2::ZERO;
        let (n_g, n, material) = match prim {
            Prim::Sphere(i) => {
                let s = &self.scene.spheres[i];
                scale = scale.max(s.center.abs().max_element() + s.radius);
                // (p - c)/r, normalised so rounding in p cannot leave it off unit length.
                let n = (p - s.center).normalize();
                uv = sphere_uv(n);
                (n, n, s.material)
            }
            Prim::Triangle { index, b1, b2 } => {
                let tri = &self.triangles[index];
                if let Some([a, b, c]) = tri.uv {
                    uv = (1.0 - b1 - b2) * a + b1 * b + b2 * c;
                }
                scale = tri.p.iter().fold(scale, |m, v| m.max(v.abs().max_element()));
                let n_g = triangle_normal(tri.p[0], tri.p[1], tri.p[2]);
                let n = match tri.n {
                    Some([n0, n1, n2]) => {
                        let n = ((1.0 - b1 - b2) * n0 + b1 * n1 + b2 * n2).normalize_or_zero();
                        if n == DVec3::ZERO {
                            n_g
                        } else {
                            n
                        }
                    }
                    None => n_g,
                };
                // Vertex normals say which side is outside, whatever the winding
                // (docs/shading.md, Notation): turn n_g to their side before the flip below.
                let n_g = if n.dot(n_g) < 0.0 { -n_g } else { n_g };
                (n_g, n, tri.material)
            }
            Prim::Cone(i) => {
                let c = &self.scene.cones[i];
                let n = cone_normal(p, c.base, c.base_radius, c.apex, c.apex_radius);
                uv = cone_uv(p, c.base, c.apex);
                (n, n, c.material)
            }
            Prim::Volume { index, iso, n } => (n, n, self.scene.volumes[index].isos[iso].material),
            Prim::Patch { index, u, v } => {
                let patch = &self.scene.patches[index];
                scale = patch.points.iter().fold(scale, |m, q| m.max(q.truncate().abs().max_element()));
                let [[u0, u1], [v0, v1]] = patch.domain();
                uv = DVec2::new((u - u0) / (u1 - u0), (v - v0) / (v1 - v0));
                // At a pole the surface has no normal: the ray's own, as the shader does.
                let n = patch.eval(u, v).normal().unwrap_or(-d.normalize());
                (n, n, patch.material)
            }
        };
        // Decision: flip when n_g·d > 0; at exactly 0 (grazing) the normal is kept.
        let inside = n_g.dot(d) > 0.0;
        let (n_g, mut n) = if inside { (-n_g, -n) } else { (n_g, n) };
        // Decision: "n on the other side of n_g" means n·n_g < 0 (n points into the surface the
        // viewer sees); such an n is replaced by n_g.
        if n.dot(n_g) < 0.0 {
            n = n_g;
        }
        SurfaceHit { t, p, n_g, n, inside, material, scale, uv }
    }

    /// Radiance arriving at `o` from direction `d` (unit) for a ray of the given depth and
    /// weight (eye ray: depth 1, weight 1).
    pub fn trace(&self, o: DVec3, d: DVec3, depth: u32, weight: DVec3, stats: &mut Stats) -> DVec3 {
        self.trace_from(o, d, depth, weight, 0, stats)
    }

    /// [`Self::trace`] for the ray tree of pixel `pixel` (bundles are rotated per pixel).
    fn trace_from(
        &self,
        o: DVec3,
        d: DVec3,
        depth: u32,
        weight: DVec3,
        pixel: u32,
        stats: &mut Stats,
    ) -> DVec3 {
        let hit = self.intersect(o, d, f64::INFINITY);
        // The volumes drawn by MIP or DVR in front of the hit: what they emit, and the share of
        // the light from behind (the hit's and every ray it spawns) they let through.
        let (fog, veil) = self.through_volumes(o, d, hit.as_ref().map_or(f64::INFINITY, |h| h.t));
        let Some(hit) = hit else {
            return fog + veil * self.scene.background;
        };
        let weight = weight * veil;
        let m = &material_at(self.scene, hit.material, hit.uv);
        let (p, n, n_g, inside) = (hit.p, hit.n, hit.n_g, hit.inside);
        let e = -d;
        let eps = RAY_OFFSET_REL * hit.scale.max(1.0);
        // Move p along n_g to the side a new ray in direction `dir` leaves on.
        // Decision: a direction exactly in the tangent plane leaves on the n_g (viewer) side.
        let origin = |dir: DVec3| {
            if n_g.dot(dir) >= 0.0 {
                p + eps * n_g
            } else {
                p - eps * n_g
            }
        };

        let amb = &self.scene.ambient;
        let ia = ambient_intensity(n, self.up, amb.sky, amb.ground);
        let mut radiance = shade_ambient(m, n, e, ia, inside);

        for light in &self.scene.lights {
            let to_light = light.position - p;
            let dist = to_light.length();
            // Decision: a light exactly at p has no direction; it contributes nothing.
            if dist == 0.0 {
                continue;
            }
            let l = to_light / dist;
            if n.dot(l) <= 0.0 {
                continue; // faces away: no light, no shadow ray
            }
            let s = self.visibility(origin(l), light, eps, pixel, stats);
            if s > 0.0 {
                radiance += s * shade_light(m, n, e, l, light.color, inside);
            }
        }

        if depth < self.scene.trace.max_depth {
            let cutoff = self.scene.trace.weight_cutoff;
            let (ks, kt) = reflectance(m, n, e, inside);
            let wr = weight * ks;
            if wr.max_element() > cutoff {
                let r = reflect(d, n).normalize();
                stats.reflection += 1;
                radiance += ks * self.trace_from(origin(r), r, depth + 1, wr, pixel, stats);
            }
            let wt = weight * kt;
            if wt.max_element() > cutoff {
                if let MaterialKind::Dielectric { eta, .. } = *m {
                    let eta_ratio = if inside { eta } else { 1.0 / eta };
                    // Decision: refract() failing where dielectric_reflectance did not report
                    // TIR (possible only for eta < 1 entering) drops the k_t share, as the doc's
                    // "none on total internal reflection" says.
                    if let Some(t) = refract(d, n, eta_ratio) {
                        stats.refraction += 1;
                        radiance += kt * self.trace_from(origin(t), t, depth + 1, wt, pixel, stats);
                    }
                }
            }
        }
        fog + veil * radiance
    }

    /// What the volumes drawn by MIP or DVR do to the ray `o + t d`, `t` in `[0, t_max]`: (the
    /// light they emit towards `o`, the share of the light from behind them that gets through),
    /// each volume over those behind it in the order the ray enters their boxes.
    fn through_volumes(&self, o: DVec3, d: DVec3, t_max: f64) -> (DVec3, f64) {
        use crate::scene::transfer::Look;
        let mut seen: Vec<(f64, DVec3, f64)> = Vec::new();
        for (v, table) in
            self.scene.volumes.iter().zip(&self.transfer_tables).filter(|(v, _)| v.look != Look::Iso)
        {
            let inv = v.transform.inverse();
            let (og, dg) = (inv.transform_point3(o), inv.transform_vector3(d));
            let entry = super::volume::entry(&v.grid, og, dg);
            let (emit, through) = match v.look {
                Look::Mip => match super::volume::mip(&v.grid, og, dg, [0.0, t_max]) {
                    Some(m) => {
                        let f = v.transfer.lookup(table, m);
                        (DVec3::new(f[0], f[1], f[2]) * f[3], 1.0 - f[3])
                    }
                    None => (DVec3::ZERO, 1.0),
                },
                _ => super::volume::dvr(&v.grid, &v.transfer, table, og, dg, [0.0, t_max]),
            };
            seen.push((entry, emit, through));
        }
        // Farthest first, as the shader composites them.
        seen.sort_by(|a, b| b.0.total_cmp(&a.0));
        seen.iter().fold((DVec3::ZERO, 1.0), |(e, t), &(_, emit, through)| (emit + through * e, through * t))
    }

    /// Visibility `s` of `light` from the offset origin `so` (docs/shadows.md).
    pub fn visibility(&self, so: DVec3, light: &Light, eps: f64, pixel: u32, stats: &mut Stats) -> f64 {
        let c = light.position;
        let dist = (c - so).length();
        // Decision: a light within eps of the offset origin is unblocked.
        let ray_to = |q: DVec3, stats: &mut Stats| {
            stats.shadow += 1;
            let v = q - so;
            let len = v.length();
            if len <= eps || !self.occluded(so, v / len, len - eps) {
                1.0
            } else {
                0.0
            }
        };
        if dist <= eps || light.radius == 0.0 {
            return ray_to(c, stats);
        }
        let l = (c - so) / dist;
        let (u, v) = basis(l);
        let on_disc = |x: glam::DVec2| c + light.radius * (x.x * u + x.y * v);
        if let Some(n) = self.ground_truth {
            let total: f64 =
                (0..n * n).map(|k| ray_to(on_disc(stratified_disc(k / n, k % n, n)), stats)).sum();
            return total / (n * n) as f64;
        }
        match self.scene.trace.shadows {
            ShadowMode::Hard => ray_to(c, stats),
            ShadowMode::Bundle { rotate, .. } => {
                let total: f64 =
                    self.bundle.iter().map(|&x| ray_to(on_disc(bundle_point(x, pixel, rotate)), stats)).sum();
                total / self.bundle.len() as f64
            }
            ShadowMode::Shell { falloff, combine } => {
                stats.shadow += 1;
                let owned;
                let shells = match self.scene.lights.iter().position(|x| x == light) {
                    Some(i) if i < self.shells.len() => &self.shells[i],
                    _ => {
                        owned = light_shells(self.scene, light.position, light.radius);
                        &owned
                    }
                };
                let hit = self.triangles_hit(so, l, dist - eps);
                let r = light.radius;
                let sigmas = shells.objects.iter().map(|o| match o.shape {
                    ShellShape::Sphere(i) => {
                        let s = &self.scene.spheres[i as usize];
                        sphere_shell(falloff, so, l, dist, r, s.center, s.radius)
                    }
                    ShellShape::Cone(i) => {
                        let c = &self.scene.cones[i as usize];
                        cone_shell(falloff, so, l, dist, r, c.base, c.base_radius, c.apex, c.apex_radius)
                    }
                    ShellShape::Mesh { triangles: [first, end], edges: [e0, e1] } => {
                        let inside = hit.iter().any(|t| (first..end).contains(t));
                        let tc = (o.center - so).dot(l).clamp(0.0, dist);
                        if inside || (o.center - (so + tc * l)).length() < o.radius + r {
                            mesh_shell(
                                falloff,
                                so,
                                l,
                                dist,
                                r,
                                inside,
                                &shells.edges[e0 as usize..e1 as usize],
                            )
                        } else {
                            1.0
                        }
                    }
                });
                match combine {
                    Combine::Min => sigmas.fold(1.0, f64::min),
                    Combine::Product => sigmas.product(),
                }
            }
        }
    }

    /// The triangles (indices into `Scene::triangles`) that the segment `o + t d`,
    /// `0 < t < t_max`, passes through: which meshes a shell shadow ray is inside of.
    fn triangles_hit(&self, o: DVec3, d: DVec3, t_max: f64) -> Vec<PrimId> {
        let ns = self.scene.spheres.len() as PrimId;
        let nt = self.triangles.len() as PrimId;
        let mut hit = vec![];
        let mut visit = |id: PrimId| {
            if id >= ns && id < ns + nt && self.hit_prim(id, o, d).is_some_and(|(t, _)| t < t_max) {
                hit.push(id - ns);
            }
            false
        };
        match &self.bvh {
            Some(bvh) => bvh.traverse(o, d, || t_max, &mut visit),
            None => (0..self.prim_count()).for_each(|id| {
                visit(id);
            }),
        }
        hit
    }

    /// Every pixel at its centre, rows shared round-robin over the available cores.
    pub fn render(&self) -> (RadianceImage, Stats) {
        let (w, h) = (self.scene.camera.width, self.scene.camera.height);
        let mut pixels = vec![DVec3::ZERO; w as usize * h as usize];
        if pixels.is_empty() {
            let image = RadianceImage { width: w, height: h, pixels };
            return (image, Stats::default());
        }
        let threads = std::thread::available_parallelism().map_or(1, |n| n.get()).min(h as usize).max(1);
        let mut buckets: Vec<Vec<(usize, &mut [DVec3])>> = (0..threads).map(|_| Vec::new()).collect();
        for (y, row) in pixels.chunks_mut(w as usize).enumerate() {
            buckets[y % threads].push((y, row));
        }
        let mut stats = Stats::default();
        std::thread::scope(|s| {
            let handles: Vec<_> = buckets
                .into_iter()
                .map(|rows| {
                    s.spawn(move || {
                        let mut st = Stats::default();
                        for (y, row) in rows {
                            for (x, px) in row.iter_mut().enumerate() {
                                *px = self.trace_pixel(x as f64 + 0.5, y as f64 + 0.5, &mut st);
                            }
                        }
                        st
                    })
                })
                .collect();
            for h in handles {
                stats += h.join().expect("reference render thread panicked");
            }
        });
        (RadianceImage { width: w, height: h, pixels }, stats)
    }
}

/// Radiance through image position (`px`, `py`) in pixels (pixel centre: `x + 0.5, y + 0.5`).
/// Builds a [`Reference`] per call; keep one for many pixels.
pub fn trace_pixel(scene: &Scene, px: f64, py: f64) -> DVec3 {
    Reference::new(&scene.posed(0.0)).trace_pixel(px, py, &mut Stats::default())
}

/// The whole image at pixel centres.
pub fn render(scene: &Scene) -> RadianceImage {
    Reference::new(&scene.posed(0.0)).render().0
}

/// The whole image at pixel centres and the rays it took.
pub fn render_with_stats(scene: &Scene) -> (RadianceImage, Stats) {
    Reference::new(&scene.posed(0.0)).render()
}

/// The nearest crossing with `t > 0` of any of `v`'s isosurfaces: (t, which isovalue, outward
/// The twin finds a patch's hits to this fraction of its box's diagonal: far below a pixel and
/// the shader's f32 Newton, so that the pictures' differences are the shader's.
pub const PATCH_TOLERANCE: f64 = 1e-7;

/// A patch's box: its control points'.
fn patch_bounds(patch: &crate::scene::patch::Patch) -> (DVec3, DVec3) {
    patch.points.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), q| {
        (lo.min(q.truncate()), hi.max(q.truncate()))
    })
}

/// unit normal in world units). The ray moves into the grid's own coordinates (an affine map
/// keeps `t`), where [`super::volume::iso_hit`] samples it densely; the normal comes back by the
/// inverse transpose and points to smaller values (the solid is above the isovalue).
fn volume_hit(v: &crate::scene::volume::Volume, o: DVec3, d: DVec3) -> Option<(f64, usize, DVec3)> {
    if v.look != crate::scene::transfer::Look::Iso {
        return None;
    }
    let inv = v.transform.inverse();
    let (og, dg) = (inv.transform_point3(o), inv.transform_vector3(d));
    let normal_map = inv.matrix3.transpose();
    v.isos
        .iter()
        .enumerate()
        .filter_map(|(k, iso)| {
            super::volume::iso_hit(&v.grid, og, dg, [0.0, f64::INFINITY], iso.value)
                .filter(|&(t, _)| t > 0.0)
                .map(|(t, n)| (t, k, (normal_map * -n).try_normalize().unwrap_or(-d.normalize())))
        })
        .min_by(|a, b| a.0.total_cmp(&b.0))
}
