//! A BVH as the shaders read it: nodes with boxes rounded outward to f32, and the compact
//! one-texel nodes of the stackless walk, quantised to a lattice.

use super::*;
use crate::accel::bvh::NodeKind;
use crate::accel::Bvh;
use glam::DVec3;

/// The device's nodes of `bvh`, boxes relative to `origin`: each rounded outward to f32 and
/// grown by a margin (`BVH_MARGIN_ULPS`, `BVH_MARGIN_REL`), so that a ray the f32 slab test
/// misses misses the box in exact arithmetic too, with room for the primitives' own rounding.
/// A leaf's `a` is its reference texel: leaves in node order, one texel each.
pub fn bvh_nodes(bvh: &Bvh, origin: DVec3) -> Vec<BvhNode> {
    let mut leaf = 0u32;
    bvh.nodes
        .iter()
        .map(|n| {
            let (lo, hi) = node_box(n, origin);
            let (a, b) = match n.kind {
                NodeKind::Inner { axis, right, escape, .. } => {
                    (escape, BVH_INNER | (axis as u32) << BVH_AXIS_SHIFT | right)
                }
                NodeKind::Leaf { count, .. } => {
                    leaf += 1;
                    (leaf - 1, count)
                }
            };
            BvhNode { lo, a, hi, b }
        })
        .collect()
}

/// `n`'s box relative to `origin`, grown by the margin and rounded outward to f32.
fn node_box(n: &crate::accel::bvh::Node, origin: DVec3) -> ([f32; 3], [f32; 3]) {
    let down = |v: f64| {
        let f = v as f32;
        if (f as f64) > v {
            f.next_down()
        } else {
            f
        }
    };
    let up = |v: f64| {
        let f = v as f32;
        if (f as f64) < v {
            f.next_up()
        } else {
            f
        }
    };
    let (lo, hi) = (n.lo - origin, n.hi - origin);
    let magnitude = lo.abs().max(hi.abs()).max_element();
    let margin = BVH_MARGIN_ULPS * f32::EPSILON as f64 * magnitude + BVH_MARGIN_REL * (hi - lo).max_element();
    let (lo, hi) = (lo - margin, hi + margin);
    ([down(lo.x), down(lo.y), down(lo.z)], [up(hi.x), up(hi.y), up(hi.z)])
}

/// (first reference, count) of each leaf of `bvh`, in node order.
pub(super) fn bvh_leaves(bvh: &Bvh) -> impl Iterator<Item = (u32, u32)> + '_ {
    bvh.nodes.iter().filter_map(|n| match n.kind {
        NodeKind::Leaf { first, count } => Some((first, count)),
        NodeKind::Inner { .. } => None,
    })
}

/// The lattice a compact node's box coordinates are steps of, per axis: `base + q · step` for q
/// in 0..=[`BVH_QUANT_MAX`], covering every node's f32 box ([`bvh_nodes`]). The shader decodes
/// with `fma(q, step, base)` in f32 (`Params::accel_min` and `cell`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BvhLattice {
    pub base: [f32; 3],
    pub top: [f32; 3],
    pub step: [f32; 3],
}

impl BvhLattice {
    /// The lattice of `bvh`'s nodes packed relative to `origin`.
    pub fn of(bvh: &Bvh, origin: DVec3) -> Self {
        Self::of_nodes(&bvh_nodes(bvh, origin))
    }

    /// The lattice covering `nodes` (as [`bvh_nodes`] rounds them).
    pub fn of_nodes(nodes: &[BvhNode]) -> Self {
        let (mut base, mut top) = ([f32::MAX; 3], [f32::MIN; 3]);
        for n in nodes {
            let (lo, hi) = (n.lo, n.hi);
            for k in 0..3 {
                base[k] = base[k].min(lo[k]);
                top[k] = top[k].max(hi[k]);
            }
        }
        let mut step = [0f32; 3];
        for k in 0..3 {
            let mut s = ((top[k] as f64 - base[k] as f64) / BVH_QUANT_MAX as f64) as f32;
            while decoded(BVH_QUANT_MAX, s, base[k]).0 < top[k] {
                s = s.next_up();
            }
            step[k] = s;
        }
        BvhLattice { base, top, step }
    }
}

/// `a · b + c` rounded once. Without the FMA instruction in the build's target (the default
/// x86-64 target has none) `f32::mul_add` is a software routine of about a hundred cycles, most
/// of packing a BVH scene (docs/performance.md, "Quantising the nodes with the CPU's FMA"); the
/// CPU's own instruction, where it has one, gives the same bits.
fn fma(a: f32, b: f32, c: f32) -> f32 {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("fma") {
        #[target_feature(enable = "fma")]
        fn hardware(a: f32, b: f32, c: f32) -> f32 {
            a.mul_add(b, c)
        }
        // SAFETY: the CPU has FMA (detected just above).
        return unsafe { hardware(a, b, c) };
    }
    a.mul_add(b, c)
}

/// The lowest and highest value the device may compute for `fma(q, step, base)` in f32: fused
/// (one rounding) or not (two), whichever its compiler emits.
fn decoded(q: u32, step: f32, base: f32) -> (f32, f32) {
    let fused = fma(q as f32, step, base);
    let split = q as f32 * step + base;
    (fused.min(split), fused.max(split))
}

/// The compact texel of `n` ([`BVH_QNODE_TEXELS`]): its box's lower corner rounded down and
/// upper corner rounded up to `lattice` steps, so the decoded box holds the f32 box however the
/// device rounds the decode; the link word from `n`'s escape or leaf texel and count.
pub fn quantise_node(n: &BvhNode, lattice: &BvhLattice) -> [u32; 4] {
    let mut q = [0u32; 6];
    for k in 0..3 {
        let (base, step) = (lattice.base[k], lattice.step[k]);
        let steps = |v: f32| if step > 0.0 { (v as f64 - base as f64) / step as f64 } else { 0.0 };
        let clamp = |v: f64| v.clamp(0.0, BVH_QUANT_MAX as f64) as u32;
        let mut lo = clamp(steps(n.lo[k]).floor());
        while lo > 0 && decoded(lo, step, base).1 > n.lo[k] {
            lo -= 1;
        }
        let mut hi = clamp(steps(n.hi[k]).ceil());
        while hi < BVH_QUANT_MAX && decoded(hi, step, base).0 < n.hi[k] {
            hi += 1;
        }
        q[k] = lo;
        q[3 + k] = hi;
    }
    let link = if n.b & BVH_INNER != 0 { BVH_INNER | n.a } else { n.b << BVH_COUNT_SHIFT | n.a };
    [q[0] | q[1] << 16, q[2] | q[3] << 16, q[4] | q[5] << 16, link]
}

/// The box the device decodes from a compact texel `t` (the f32 fma, fused), for tests.
pub fn decode_qnode(t: [u32; 4], lattice: &BvhLattice) -> ([f32; 3], [f32; 3]) {
    let q = [t[0] & 0xffff, t[0] >> 16, t[1] & 0xffff, t[1] >> 16, t[2] & 0xffff, t[2] >> 16];
    let at = |k: usize, v: u32| (v as f32).mul_add(lattice.step[k], lattice.base[k]);
    ([at(0, q[0]), at(1, q[1]), at(2, q[2])], [at(0, q[3]), at(1, q[4]), at(2, q[5])])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::Bvh;
    use crate::scene::{default_scene, Scene};

    /// Every compact node's decoded box holds its f32 box, whether the device fuses the decode's
    /// multiply-add or not, and is at most two steps looser on each side; the link words say
    /// what the two-texel nodes say. Scenes: near the origin, far from it (1e5), and flat (a
    /// mesh in a plane: zero extent on one axis).
    #[test]
    fn compact_nodes_hold_their_boxes() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
        let mut scenes = vec![default_scene()];
        for name in ["mesh.toml", "cones.toml", "spd/balls_s2.nff", "spd/tetra_s4.nff"] {
            scenes.push(crate::io::load(&dir.join(name)).expect("scene loads"));
        }
        let flat = crate::scene::Mesh {
            positions: (0..64).map(|i| DVec3::new((i % 8) as f64, 0.0, (i / 8) as f64 * 0.37)).collect(),
            normals: None,
            uvs: None,
            indices: (0..49).filter(|i| i % 8 != 7).map(|i| [i, i + 1, i + 8]).collect(),
            material: 0,
        };
        let mut plane = default_scene();
        plane.spheres.clear();
        plane.meshes = vec![flat];
        scenes.push(plane);
        let origins = |s: &Scene| [s.camera.eye, s.camera.eye + DVec3::splat(1e5), DVec3::ZERO];
        for scene in &scenes {
            let bvh = Bvh::build(scene);
            for origin in origins(scene) {
                let lattice = BvhLattice::of(&bvh, origin);
                for (i, n) in bvh_nodes(&bvh, origin).iter().enumerate() {
                    let t = quantise_node(n, &lattice);
                    let q = [t[0] & 0xffff, t[0] >> 16, t[1] & 0xffff, t[1] >> 16, t[2] & 0xffff, t[2] >> 16];
                    for k in 0..3 {
                        let (base, step) = (lattice.base[k], lattice.step[k]);
                        let (lo, hi) = (decoded(q[k], step, base), decoded(q[3 + k], step, base));
                        assert!(
                            lo.1 <= n.lo[k] && hi.0 >= n.hi[k],
                            "node {i} axis {k}: {lo:?} {hi:?} vs {n:?}"
                        );
                        let step = step as f64;
                        assert!(
                            (n.lo[k] - lo.0) as f64 <= 2.0 * step && (hi.1 - n.hi[k]) as f64 <= 2.0 * step
                        );
                    }
                    if n.b & BVH_INNER != 0 {
                        assert_eq!(t[3], BVH_INNER | n.a, "node {i}: escape");
                    } else {
                        assert_eq!(
                            (t[3] >> BVH_COUNT_SHIFT, t[3] & ((1 << BVH_COUNT_SHIFT) - 1)),
                            (n.b, n.a)
                        );
                    }
                }
            }
        }
    }
}
