//! A native multithreaded tracer of irt's own structure, for the primary-shadow workload: the
//! same flattened grid ([`Grid`]: `cell_start`, `prim_refs`, macro-cell bits), the same 3D DDA,
//! the same f32 arithmetic and positions relative to the eye, run as plain Rust on every core.
//! It answers "what does the Vulkan-compute path cost or gain against native code of the same
//! algorithm?", so it is deliberately not faster or cleverer than the shader (no SIMD packets, no
//! BVH). It is not the oracle: `crate::reference` (f64, its own BVH) stays that.
//!
//! Traces spheres, triangles (mesh vertex normals included) and open cones.
//! Only the work [`super::primary_shadow`] leaves: eye rays at pixel centres, one hard-shadow ray
//! per light facing the hit, diffuse Lambert shading, no ambient, background on a miss.

use super::PeerError;
use crate::accel::bvh::NodeKind;
use crate::accel::{Bvh, Grid, PrimKind, PrimRef};
use crate::gpu::layout::{sphere_anchor, RAY_OFFSET_REL};
use crate::image::Image;
use crate::scene::{MaterialKind, Scene, ShadowMode};
use glam::{DVec3, IVec3, Vec3};
use std::sync::Mutex;

/// "No limit" for ray parameters, as the shader's.
const BIG: f32 = 3.0e38;

/// Rays one render traced, counted as the GPU counts them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PeerRays {
    pub eye: u64,
    pub shadow: u64,
}

impl PeerRays {
    pub fn total(&self) -> u64 {
        self.eye + self.shadow
    }
}

pub struct PeerFrame {
    pub image: Image,
    pub rays: PeerRays,
}

pub(super) struct SphereF {
    pub(super) center: Vec3,
    pub(super) radius: f32,
    /// The point of the sphere nearest the eye: the intersection is measured from it.
    anchor: Vec3,
    color: Vec3,
}

pub(super) struct TriangleF {
    pub(super) p: [Vec3; 3],
    n: Option<[Vec3; 3]>,
    color: Vec3,
}

pub(super) struct ConeF {
    pub(super) base: Vec3,
    pub(super) r0: f32,
    /// `apex - base`.
    pub(super) axis: Vec3,
    pub(super) r1: f32,
    color: Vec3,
}

struct LightF {
    position: Vec3,
    color: Vec3,
}

/// The grid in f32, relative to the eye, as the shader reads it.
struct GridF {
    min: Vec3,
    max: Vec3,
    cell: Vec3,
    inv_cell: Vec3,
    res: IVec3,
    macro_res: [u32; 2],
    cell_start: Vec<u32>,
    prim_refs: Vec<PrimRef>,
    macro_bits: Vec<u32>,
}

/// What every peer shares: the camera, lights and primitives in f32 relative to the eye, and
/// the shading of the workload. A peer brings only the ray casting ([`Caster`]), so two peers
/// that find the same hits produce the same image and count the same rays.
pub(super) struct Shade {
    width: u32,
    height: u32,
    cam: [Vec3; 3],
    background: Vec3,
    lights: Vec<LightF>,
    pub(super) spheres: Vec<SphereF>,
    pub(super) triangles: Vec<TriangleF>,
    pub(super) cones: Vec<ConeF>,
}

/// The ray casting a peer brings to [`Shade::render`]: nearest hit and any hit in (0, t_max).
/// `Ctx` is per-thread state (Embree's intersection context; nothing for the native walk).
pub(super) trait Caster: Sync {
    type Ctx;
    fn context(&self) -> Self::Ctx;
    fn nearest(&self, ctx: &mut Self::Ctx, o: Vec3, d: Vec3, t_max: f32) -> Option<Hit>;
    fn occluded(&self, ctx: &mut Self::Ctx, o: Vec3, d: Vec3, t_max: f32) -> bool;
}

/// [`Caster`] for packets of eight rays; `active[i]` false: lane `i` is no ray.
#[cfg(feature = "embree")]
pub(super) trait Caster8: Sync {
    type Ctx;
    fn context(&self) -> Self::Ctx;
    fn nearest8(
        &self,
        ctx: &mut Self::Ctx,
        o: &[Vec3; 8],
        d: &[Vec3; 8],
        t_max: &[f32; 8],
        active: &[bool; 8],
    ) -> [Option<Hit>; 8];
    fn occluded8(
        &self,
        ctx: &mut Self::Ctx,
        o: &[Vec3; 8],
        d: &[Vec3; 8],
        t_max: &[f32; 8],
        active: &[bool; 8],
    ) -> [bool; 8];
}

/// The shadow ray from `sf` to `light` (origin, unit direction, t_max, n·l), or None where the
/// surface faces away from the light (SPD's rule, as irt: no ray then).
fn shadow_ray(sf: &Surface, light: &LightF) -> Option<(Vec3, Vec3, f32, f32)> {
    let l = (light.position - sf.p).normalize();
    let nl = sf.n.dot(l);
    if nl <= 0.0 {
        return None;
    }
    let so = offset_origin(sf, l);
    let ends = so.abs().max(light.position.abs());
    let gap = RAY_OFFSET_REL * ends.max_element();
    let dist = (light.position - so).length();
    Some((so, l, dist - gap, nl))
}

/// The scene and its accelerator prepared once; [`NativePeer::render`] traces a frame.
pub struct NativePeer {
    shade: Shade,
    accel: AccelF,
}

/// What the native peer walks: irt's grid, or irt's BVH.
enum AccelF {
    Grid(GridF),
    Bvh(BvhF),
}

/// irt's BVH in f32 relative to the eye, in its depth-first order: each node's box as the
/// device's two-texel nodes hold it (`layout::bvh_nodes`: rounded outward, with the margin), an
/// inner node's escape, a leaf's references.
struct BvhF {
    nodes: Vec<BvhNodeF>,
    refs: Vec<PrimRef>,
}

struct BvhNodeF {
    lo: Vec3,
    hi: Vec3,
    /// Inner: the escape (the node after the subtree). Leaf: its first reference.
    link: u32,
    /// Inner: `u32::MAX`. Leaf: how many references.
    count: u32,
}

fn f(v: DVec3) -> Vec3 {
    v.as_vec3()
}

impl Shade {
    /// `scene` must be the primary-shadow workload (see [`super::primary_shadow`]); anything the
    /// peers do not trace is an error, not a silent difference. `who` names the peer in errors.
    pub(super) fn new(scene: &Scene, peer: &'static str) -> Result<Self, PeerError> {
        if scene.trace.max_depth != 1 || scene.trace.shadows != ShadowMode::Hard {
            return Err(PeerError::NotTheWorkload { peer });
        }
        if !scene.volumes.is_empty() || !scene.patches.is_empty() {
            return Err(PeerError::Volumes { peer });
        }
        let eye = scene.camera.eye;
        let color = |m: u32| match scene.materials[m as usize].kind {
            MaterialKind::Diffuse { color } => Ok(f(color)),
            _ => Err(PeerError::NotDiffuse { peer }),
        };
        let spheres = scene
            .spheres
            .iter()
            .map(|s| {
                Ok(SphereF {
                    center: f(s.center - eye),
                    radius: s.radius as f32,
                    anchor: f(sphere_anchor(s.center, s.radius, eye) - eye),
                    color: color(s.material)?,
                })
            })
            .collect::<Result<_, PeerError>>()?;
        let triangles = scene
            .triangles()
            .map(|t| {
                Ok(TriangleF {
                    p: t.p.map(|p| f(p - eye)),
                    n: t.n.map(|n| n.map(f)),
                    color: color(t.material)?,
                })
            })
            .collect::<Result<_, PeerError>>()?;
        let cones = scene
            .cones
            .iter()
            .map(|c| {
                Ok(ConeF {
                    base: f(c.base - eye),
                    r0: c.base_radius as f32,
                    axis: f(c.apex - c.base),
                    r1: c.apex_radius as f32,
                    color: color(c.material)?,
                })
            })
            .collect::<Result<_, PeerError>>()?;
        let b = scene.camera.basis();
        Ok(Shade {
            width: scene.camera.width,
            height: scene.camera.height,
            cam: [f(b.u), f(b.v), f(b.w)],
            background: f(scene.background),
            lights: scene
                .lights
                .iter()
                .map(|l| LightF { position: f(l.position - eye), color: f(l.color) })
                .collect(),
            spheres,
            triangles,
            cones,
        })
    }

    /// One frame on `threads` threads (rows handed out one at a time, so a slow region does not
    /// leave the other threads idle).
    pub(super) fn render<C: Caster>(&self, caster: &C, threads: usize) -> PeerFrame {
        self.rows_on(
            threads,
            || caster.context(),
            |ctx, y, row, shadow| {
                for (x, px) in row.iter_mut().enumerate() {
                    *px = self.pixel(caster, ctx, x as u32, y, shadow).to_array();
                }
            },
        )
    }

    /// The frame, its rows dealt to `threads` workers one at a time; each worker makes its
    /// caster context with `context` and fills a row with `row(ctx, y, pixels, shadow_rays)`.
    fn rows_on<X>(
        &self,
        threads: usize,
        context: impl Fn() -> X + Sync,
        row: impl Fn(&mut X, u32, &mut [[f32; 3]], &mut u64) + Sync,
    ) -> PeerFrame {
        let (w, h) = (self.width as usize, self.height as usize);
        let mut pixels = vec![[0.0f32; 3]; w * h];
        let rows = Mutex::new(pixels.chunks_mut(w).enumerate());
        let shadow = std::thread::scope(|s| {
            let workers: Vec<_> = (0..threads.max(1))
                .map(|_| {
                    s.spawn(|| {
                        let mut shadow = 0u64;
                        let mut ctx = context();
                        loop {
                            let next = rows.lock().expect("no worker panics holding the lock").next();
                            let Some((y, pixels)) = next else { break };
                            row(&mut ctx, y as u32, pixels, &mut shadow);
                        }
                        shadow
                    })
                })
                .collect();
            workers.into_iter().map(|t| t.join().expect("peer worker")).sum()
        });
        let image = Image { width: self.width, height: self.height, pixels };
        PeerFrame { image, rays: PeerRays { eye: (w * h) as u64, shadow } }
    }

    fn pixel<C: Caster>(&self, caster: &C, ctx: &mut C::Ctx, x: u32, y: u32, shadow_rays: &mut u64) -> Vec3 {
        let d = self.eye_dir(x, y);
        let o = Vec3::ZERO;
        let Some(hit) = caster.nearest(ctx, o, d, BIG) else { return self.background };
        let sf = self.surface(hit, o, d);
        let mut c = Vec3::ZERO;
        for light in &self.lights {
            let Some((so, l, t_max, nl)) = shadow_ray(&sf, light) else { continue };
            *shadow_rays += 1;
            if !caster.occluded(ctx, so, l, t_max) {
                c += sf.color * light.color * nl;
            }
        }
        c
    }

    /// The eye ray through the centre of pixel (x, y), from the eye (the origin).
    fn eye_dir(&self, x: u32, y: u32) -> Vec3 {
        let [u, v, w] = self.cam;
        let sx = 2.0 * (x as f32 + 0.5) / self.width as f32 - 1.0;
        let sy = 1.0 - 2.0 * (y as f32 + 0.5) / self.height as f32;
        (w + sx * u + sy * v).normalize()
    }

    /// As [`Shade::render`], eight pixels of a row at a time through a packet caster: the same
    /// rays and per-ray arithmetic, so the image and counts are those of the single-ray path
    /// wherever the packet kernel finds the same hits.
    #[cfg(feature = "embree")]
    pub(super) fn render8<C: Caster8>(&self, caster: &C, threads: usize) -> PeerFrame {
        self.rows_on(
            threads,
            || caster.context(),
            |ctx, y, row, shadow| {
                for (i, px) in row.chunks_mut(8).enumerate() {
                    self.pixels8(caster, ctx, 8 * i as u32, y, px, shadow);
                }
            },
        )
    }

    /// Pixels x0.. x0 + px.len() (at most 8) of row y.
    #[cfg(feature = "embree")]
    fn pixels8<C: Caster8>(
        &self,
        caster: &C,
        ctx: &mut C::Ctx,
        x0: u32,
        y: u32,
        px: &mut [[f32; 3]],
        shadow_rays: &mut u64,
    ) {
        let n = px.len();
        let mut d = [Vec3::Z; 8];
        let mut active = [false; 8];
        for i in 0..n {
            d[i] = self.eye_dir(x0 + i as u32, y);
            active[i] = true;
        }
        let hits = caster.nearest8(ctx, &[Vec3::ZERO; 8], &d, &[BIG; 8], &active);
        let sf: [Option<Surface>; 8] =
            std::array::from_fn(|i| hits[i].map(|h| self.surface(h, Vec3::ZERO, d[i])));
        let mut c = [Vec3::ZERO; 8];
        for light in &self.lights {
            let (mut so, mut l, mut t_max, mut nl) =
                ([Vec3::ZERO; 8], [Vec3::Z; 8], [0.0f32; 8], [0.0f32; 8]);
            let mut active = [false; 8];
            for i in 0..n {
                if let Some((o, dir, t, k)) = sf[i].as_ref().and_then(|sf| shadow_ray(sf, light)) {
                    (so[i], l[i], t_max[i], nl[i], active[i]) = (o, dir, t, k, true);
                    *shadow_rays += 1;
                }
            }
            if !active.contains(&true) {
                continue;
            }
            let blocked = caster.occluded8(ctx, &so, &l, &t_max, &active);
            for i in 0..n {
                if active[i] && !blocked[i] {
                    let sf = sf[i].as_ref().expect("an active shadow ray has a surface");
                    c[i] += sf.color * light.color * nl[i];
                }
            }
        }
        for i in 0..n {
            px[i] = if hits[i].is_some() { c[i] } else { self.background }.to_array();
        }
    }

    /// The hit point, its normals (facing the ray) and colour. The point is recomputed from the
    /// primitive where that uses smaller numbers than the ray, so `offset_origin`'s error model holds.
    fn surface(&self, h: Hit, o: Vec3, d: Vec3) -> Surface {
        let ray_p = o + d * h.t;
        let (p, scale, mut ng, mut n, color);
        match h.prim.kind() {
            PrimKind::Triangle => {
                let t = &self.triangles[h.prim.index() as usize];
                let [p0, p1, p2] = t.p;
                let (b1, b2) = h.b;
                p = p0 + b1 * (p1 - p0) + b2 * (p2 - p0);
                scale = p0.abs().max(p1.abs()).max(p2.abs()).max_element();
                ng = unit_or((p1 - p0).cross(p2 - p0), -d);
                n = ng;
                if let Some([n0, n1, n2]) = t.n {
                    let nv = (1.0 - b1 - b2) * n0 + b1 * n1 + b2 * n2;
                    if nv.dot(nv) > 0.0 {
                        n = nv.normalize();
                        if ng.dot(n) < 0.0 {
                            ng = -ng;
                        }
                    }
                }
                color = t.color;
            }
            PrimKind::Volume | PrimKind::Patch => {
                unreachable!("the native peer refuses scenes with volumes and patches")
            }
            PrimKind::Cone => {
                let c = &self.cones[h.prim.index() as usize];
                ng = unit_or(cone_normal(ray_p, c), -d);
                n = ng;
                // The point stays the ray's: its error is relative to the ray's numbers.
                (p, scale) = (ray_p, o.abs().max_element() + h.t);
                color = c.color;
            }
            PrimKind::Sphere => {
                let s = &self.spheres[h.prim.index() as usize];
                ng = unit_or(ray_p - s.center, -d);
                n = ng;
                let sphere_scale = s.center.abs().max_element() + s.radius;
                let ray_scale = o.abs().max_element() + h.t;
                (p, scale) = if sphere_scale <= ray_scale {
                    (s.center + s.radius * ng, sphere_scale)
                } else {
                    (ray_p, ray_scale)
                };
                color = s.color;
            }
        }
        if ng.dot(d) > 0.0 {
            ng = -ng;
            n = -n;
        }
        if n.dot(ng) < 0.0 {
            n = ng;
        }
        Surface { p, ng, n, scale, color }
    }
}

impl NativePeer {
    /// `scene` must be the primary-shadow workload (see [`super::primary_shadow`]) and `grid` its
    /// grid; anything the peer does not trace is an error, not a silent difference.
    pub fn new(scene: &Scene, grid: &Grid) -> Result<Self, PeerError> {
        let shade = Shade::new(scene, "native")?;
        let eye = scene.camera.eye;
        let res = grid.res;
        Ok(NativePeer {
            shade,
            accel: AccelF::Grid(GridF {
                min: f(grid.min - eye),
                max: f(grid.max - eye),
                cell: f(grid.cell_size),
                inv_cell: f(grid.cell_size.recip()),
                res: IVec3::new(res[0] as i32, res[1] as i32, res[2] as i32),
                macro_res: [grid.macro_res[0], grid.macro_res[1]],
                cell_start: grid.cell_start.clone(),
                prim_refs: grid.prim_refs.clone(),
                macro_bits: grid.macro_bits.clone(),
            }),
        })
    }

    /// The same peer over irt's BVH (`--peer native-bvh`): the device's default accelerator,
    /// walked as its shader does (stackless, by escape links, children in their stored order:
    /// give it the device's tree, `accel::bvh_for(scene, BvhWalk::Stackless)`).
    pub fn with_bvh(scene: &Scene, bvh: &Bvh) -> Result<Self, PeerError> {
        let shade = Shade::new(scene, "native-bvh")?;
        let boxes = crate::gpu::layout::bvh_nodes(bvh, scene.camera.eye);
        let nodes = bvh
            .nodes
            .iter()
            .zip(boxes)
            .map(|(n, b)| {
                let (link, count) = match n.kind {
                    NodeKind::Inner { escape, .. } => (escape, u32::MAX),
                    NodeKind::Leaf { first, count } => (first, count),
                };
                BvhNodeF { lo: Vec3::from(b.lo), hi: Vec3::from(b.hi), link, count }
            })
            .collect();
        Ok(NativePeer { shade, accel: AccelF::Bvh(BvhF { nodes, refs: bvh.refs.clone() }) })
    }

    /// Which accelerator it walks, for tables ("native" walks the grid).
    pub fn name(&self) -> &'static str {
        match self.accel {
            AccelF::Grid(_) => "native",
            AccelF::Bvh(_) => "native-bvh",
        }
    }

    /// One frame on `threads` threads (rows handed out one at a time, so a slow region does not
    /// leave the other threads idle).
    pub fn render(&self, threads: usize) -> PeerFrame {
        self.shade.render(self, threads)
    }

    /// The nearest hit in (t_min, t_max), or with `any` the first found.
    fn walk(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32, any: bool) -> Option<Hit> {
        match &self.accel {
            AccelF::Grid(g) => self.walk_grid(g, o, d, t_min, t_max, any),
            AccelF::Bvh(b) => self.walk_bvh(b, o, d, t_min, t_max, any),
        }
    }

    /// The shader's stackless BVH walk (shaders/bvh.wgsl): nodes in depth-first order, a missed
    /// inner node's subtree skipped by its escape, the slab test's far distance grown by
    /// 1 + 2γ₃ as there, 1/d of a zero component replaced by ±1e30.
    fn walk_bvh(&self, b: &BvhF, o: Vec3, d: Vec3, t_min: f32, t_max: f32, any: bool) -> Option<Hit> {
        let tiny = d.abs().cmplt(Vec3::splat(1e-30));
        let safe =
            Vec3::select(tiny, Vec3::select(d.cmplt(Vec3::ZERO), Vec3::splat(-1e-30), Vec3::splat(1e-30)), d);
        let inv_d = safe.recip();
        let mut best: Option<Hit> = None;
        let mut best_t = t_max;
        let mut i = 0usize;
        while i < b.nodes.len() {
            let n = &b.nodes[i];
            let t0 = (n.lo - o) * inv_d;
            let t1 = (n.hi - o) * inv_d;
            let near = t0.min(t1).max_element().max(t_min);
            let far = t0.max(t1).min_element() * 1.000_000_4;
            let hit = near <= far.min(best_t);
            if n.count == u32::MAX {
                i = if hit { i + 1 } else { n.link as usize };
                continue;
            }
            if hit {
                for &r in &b.refs[n.link as usize..(n.link + n.count) as usize] {
                    if let Some(h) = self.intersect(r, o, d, t_min, best_t) {
                        best_t = h.t;
                        best = Some(h);
                        if any {
                            return best;
                        }
                    }
                }
            }
            i += 1;
        }
        best
    }

    /// Amanatides & Woo over the grid, skipping empty macro-cells. A hit beyond the current
    /// cell stays a candidate until the walk reaches its cell (primitives span cells; no
    /// mailbox).
    fn walk_grid(&self, g: &GridF, o: Vec3, d: Vec3, t_min: f32, t_max: f32, any: bool) -> Option<Hit> {
        let moving = d.cmpne(Vec3::ZERO);
        let inv_d = Vec3::select(moving, d.recip(), Vec3::ZERO);
        if (!moving & (o.cmplt(g.min) | o.cmpgt(g.max))).any() {
            return None;
        }
        let ta = (g.min - o) * inv_d;
        let tb = (g.max - o) * inv_d;
        let t_lo = Vec3::select(moving, ta.min(tb), Vec3::splat(-BIG));
        let t_hi = Vec3::select(moving, ta.max(tb), Vec3::splat(BIG));
        let t0 = t_min.max(t_lo.max_element());
        let t1 = t_max.min(t_hi.min_element());
        if t0 > t1 {
            return None;
        }
        let positive = d.cmpgt(Vec3::ZERO);
        let p = o + d * t0;
        let mut cell = ((p - g.min) * g.inv_cell).floor().as_ivec3().clamp(IVec3::ZERO, g.res - 1);
        let step = IVec3::select(positive, IVec3::ONE, IVec3::NEG_ONE);
        let out = IVec3::select(positive, g.res, IVec3::NEG_ONE);
        let boundary = g.min + (cell + IVec3::select(positive, IVec3::ONE, IVec3::ZERO)).as_vec3() * g.cell;
        let mut t_next = Vec3::select(moving, (boundary - o) * inv_d, Vec3::splat(BIG));
        let t_delta = Vec3::select(moving, g.cell * inv_d.abs(), Vec3::splat(BIG));
        let mut best: Option<Hit> = None;
        let mut best_t = t_max;
        loop {
            if g.macro_occupied(cell) {
                let c = (cell.x + g.res.x * (cell.y + g.res.y * cell.z)) as usize;
                let refs = &g.prim_refs[g.cell_start[c] as usize..g.cell_start[c + 1] as usize];
                for &r in refs {
                    if let Some(h) = self.intersect(r, o, d, t_min, best_t) {
                        best_t = h.t;
                        best = Some(h);
                        if any {
                            return best;
                        }
                    }
                }
                if best.is_some() && best_t <= t_next.min_element() {
                    return best;
                }
            }
            // Step along the axis whose boundary comes first (ties: x, then y).
            if t_next.min_element() >= t1 {
                return best;
            }
            let axis = if t_next.x <= t_next.y && t_next.x <= t_next.z {
                0
            } else if t_next.y <= t_next.z {
                1
            } else {
                2
            };
            cell[axis] += step[axis];
            t_next[axis] += t_delta[axis];
            if cell[axis] == out[axis] {
                return best;
            }
        }
    }

    fn intersect(&self, r: PrimRef, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Option<Hit> {
        let i = r.index() as usize;
        match r.kind() {
            PrimKind::Sphere => {
                let s = &self.shade.spheres[i];
                sphere_t(o, d, s, t_min, t_max).map(|t| Hit { t, prim: r, b: (0.0, 0.0) })
            }
            PrimKind::Triangle => triangle_t(o, d, &self.shade.triangles[i].p, t_min, t_max)
                .map(|(t, b1, b2)| Hit { t, prim: r, b: (b1, b2) }),
            PrimKind::Cone => {
                cone_t(o, d, &self.shade.cones[i], t_min, t_max).map(|t| Hit { t, prim: r, b: (0.0, 0.0) })
            }
            // `new` refuses scenes with volumes and patches.
            PrimKind::Volume | PrimKind::Patch => None,
        }
    }
}

impl Caster for NativePeer {
    type Ctx = ();
    fn context(&self) {}
    fn nearest(&self, _: &mut (), o: Vec3, d: Vec3, t_max: f32) -> Option<Hit> {
        self.walk(o, d, 0.0, t_max, false)
    }
    fn occluded(&self, _: &mut (), o: Vec3, d: Vec3, t_max: f32) -> bool {
        self.walk(o, d, 0.0, t_max, true).is_some()
    }
}

impl GridF {
    fn macro_occupied(&self, cell: IVec3) -> bool {
        let m = cell.as_uvec3() / crate::accel::grid::MACRO_FACTOR;
        let i = m.x + self.macro_res[0] * (m.y + self.macro_res[1] * m.z);
        self.macro_bits[(i / 32) as usize] & (1 << (i % 32)) != 0
    }
}

#[derive(Clone, Copy)]
pub(super) struct Hit {
    pub(super) t: f32,
    pub(super) prim: PrimRef,
    /// Barycentrics of p1 and p2 (triangles).
    pub(super) b: (f32, f32),
}

pub(super) struct Surface {
    p: Vec3,
    ng: Vec3,
    n: Vec3,
    /// Magnitude of the numbers `p` came from.
    scale: f32,
    color: Vec3,
}

/// `v` normalised, or `fallback` when it cannot be (never a NaN normal).
fn unit_or(v: Vec3, fallback: Vec3) -> Vec3 {
    let len2 = v.dot(v);
    if len2.is_nan() || len2 <= 1.0e-30 || len2 > 1.0e30 {
        let m = v.abs().max_element();
        return if m > 0.0 && m < 3.0e38 { (v / m).normalize() } else { fallback };
    }
    v * len2.sqrt().recip()
}

/// `sf.p` moved off the surface to the side `dir` leaves on: 256 ulps per coordinate along the
/// normal, or 2^-15 of the point's scale where a coordinate is small next to it (Wächter &
/// Binder, Ray Tracing Gems ch. 6; docs/shading.md, "Ray origins").
fn offset_origin(sf: &Surface, dir: Vec3) -> Vec3 {
    let n = if dir.dot(sf.ng) > 0.0 { sf.ng } else { -sf.ng };
    let ulps = |p: f32, n: f32| {
        let k = (256.0 * n) as i32;
        f32::from_bits((p.to_bits() as i32).wrapping_add(if p < 0.0 { -k } else { k }) as u32)
    };
    let small = sf.scale / 32.0;
    let by_scale = sf.p + (sf.scale / 32768.0) * n;
    let pick = |a: usize| if sf.p[a].abs() < small { by_scale[a] } else { ulps(sf.p[a], n[a]) };
    Vec3::new(pick(0), pick(1), pick(2))
}

/// Nearest root of |o + t d - c| = r in (t_min, t_max), `d` unit length, measured from the
/// anchor `a` so no term is a difference of two large numbers (see intersect.wgsl for the
/// derivation): disc = r²(n_a·d)² - 2r(g⊥·n_a) - |g⊥|², t0·t1 = |g|² + 2r(n_a·g), g = o - a.
fn sphere_t(o: Vec3, d: Vec3, s: &SphereF, t_min: f32, t_max: f32) -> Option<f32> {
    let r = s.radius;
    let na = (s.anchor - s.center) / r;
    let g = o - s.anchor;
    let gd = g.dot(d);
    let nd = na.dot(d);
    let gp = g - gd * d;
    let disc = r * r * nd * nd - 2.0 * r * gp.dot(na) - gp.dot(gp);
    if disc < 0.0 {
        return None;
    }
    let fd = gd + r * nd;
    let cc = g.dot(g) + 2.0 * r * na.dot(g);
    let sq = disc.sqrt();
    let q = -(fd + if fd >= 0.0 { sq } else { -sq });
    let a = if q == 0.0 { 0.0 } else { cc / q };
    let (t0, t1) = if a > q { (q, a) } else { (a, q) };
    [t0, t1].into_iter().find(|&t| t > t_min && t < t_max)
}

/// Watertight two-sided ray–triangle test (Woop, Benthin & Wald 2013): (t, b1, b2).
fn triangle_t(o: Vec3, d: Vec3, p: &[Vec3; 3], t_min: f32, t_max: f32) -> Option<(f32, f32, f32)> {
    let ad = d.abs();
    let kz = if ad.x >= ad.y && ad.x >= ad.z {
        0
    } else if ad.y >= ad.z {
        1
    } else {
        2
    };
    let (mut kx, mut ky) = ((kz + 1) % 3, (kz + 2) % 3);
    if d[kz] < 0.0 {
        std::mem::swap(&mut kx, &mut ky);
    }
    let sz = 1.0 / d[kz];
    let (sx, sy) = (d[kx] * sz, d[ky] * sz);
    let [a, b, c] = p.map(|q| q - o);
    let shear = |v: Vec3| (v[kx] - sx * v[kz], v[ky] - sy * v[kz]);
    let ((ax, ay), (bx, by), (cx, cy)) = (shear(a), shear(b), shear(c));
    let u = cx * by - cy * bx;
    let v = ax * cy - ay * cx;
    let w = bx * ay - by * ax;
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return None;
    }
    let det = u + v + w;
    if det == 0.0 {
        return None;
    }
    let inv = 1.0 / det;
    let t = sz * (u * a[kz] + v * b[kz] + w * c[kz]) * inv;
    (t > t_min && t < t_max).then_some((t, v * inv, w * inv))
}

/// Nearest t in (t_min, t_max) on the open cone (no caps), `d` unit length. As in
/// intersect.wgsl: the origin moved to the ray's closest approach to the axis midpoint (small
/// coefficients for distant origins), the discriminant by Lagrange's identity (no difference of
/// large products), both roots without cancellation, each kept only where it lies on the cone.
pub(super) fn cone_t(o: Vec3, d: Vec3, c: &ConeF, t_min: f32, t_max: f32) -> Option<f32> {
    let h = c.axis.length();
    let a = c.axis / h;
    let k = (c.r1 - c.r0) / h;
    let tc = (c.base + 0.5 * c.axis - o).dot(d);
    let co = o + tc * d - c.base;
    let s0 = co.dot(a);
    let da = d.dot(a);
    let qo = co - s0 * a;
    let qd = d - da * a;
    let ro = c.r0 + k * s0;
    let qa = qd.dot(qd) - k * k * da * da;
    let qb = qo.dot(qd) - k * ro * da;
    let qc = qo.dot(qo) - ro * ro;
    let w = ro * qd - k * da * qo;
    let x = qo.cross(qd);
    let disc = w.dot(w) - x.dot(x);
    if disc < 0.0 {
        return None;
    }
    let sign = if qb >= 0.0 { 1.0 } else { -1.0 };
    let q = -(qb + sign * disc.sqrt());
    let (lo, hi) = if q != 0.0 {
        let ra = qc / q;
        let rb = if qa != 0.0 { q / qa } else { ra };
        (ra.min(rb), ra.max(rb))
    } else if qa == 0.0 {
        return None;
    } else {
        (0.0, 0.0)
    };
    [lo, hi]
        .into_iter()
        .find(|&r| {
            let s = s0 + r * da;
            s >= 0.0 && s <= h && tc + r > t_min && tc + r < t_max
        })
        .map(|r| tc + r)
}

/// Outward normal of the cone at surface point `p`: away from the axis, tilted by the slope.
pub(super) fn cone_normal(p: Vec3, c: &ConeF) -> Vec3 {
    let h = c.axis.length();
    let a = c.axis / h;
    let v = p - c.base;
    let away = v - v.dot(a) * a;
    let len = away.length();
    let u = if len > 0.0 { away / len } else { Vec3::ZERO };
    (u - ((c.r1 - c.r0) / h) * a).normalize()
}
