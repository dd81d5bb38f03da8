//! A plain median-split bounding-volume hierarchy, only to make the oracle usable on SPD-sized
//! scenes. It is a pure speed-up: traversal visits every box the ray could touch (boxes are
//! padded, tests inclusive) and picks the winner by the same rule as the brute-force scan
//! (smallest `t`, then lowest primitive index), so results are identical; a test checks that.

use glam::DVec3;

/// Primitive `i` of the tracer: spheres first (`0..spheres`), then triangles.
pub type PrimId = u32;

#[derive(Clone, Copy, Debug)]
struct Node {
    lo: DVec3,
    hi: DVec3,
    /// Leaf: first index into `Bvh::prims`; interior: index of the second child (the first
    /// child is the next node).
    index: u32,
    /// Leaf: number of primitives (> 0); interior: 0.
    count: u32,
}

pub struct Bvh {
    nodes: Vec<Node>,
    prims: Vec<PrimId>,
}

const LEAF_SIZE: usize = 4;

impl Bvh {
    /// `boxes[i]` bounds primitive `i`.
    pub fn build(boxes: &[(DVec3, DVec3)]) -> Bvh {
        let mut items: Vec<(PrimId, DVec3, DVec3)> = boxes
            .iter()
            .enumerate()
            .map(|(i, &(lo, hi))| {
                // Pad so rounding in the slab test can never reject a hit the exact primitive
                // test accepts (flat boxes of axis-aligned triangles, tangent rays).
                let pad = 1e-7 * lo.abs().max(hi.abs()).max_element().max(1.0);
                (i as PrimId, lo - DVec3::splat(pad), hi + DVec3::splat(pad))
            })
            .collect();
        let mut bvh = Bvh { nodes: Vec::new(), prims: Vec::with_capacity(items.len()) };
        if !items.is_empty() {
            bvh.build_node(&mut items);
        }
        bvh
    }

    fn build_node(&mut self, items: &mut [(PrimId, DVec3, DVec3)]) -> usize {
        let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        let (mut clo, mut chi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        for &(_, a, b) in items.iter() {
            lo = lo.min(a);
            hi = hi.max(b);
            let c = 0.5 * (a + b);
            clo = clo.min(c);
            chi = chi.max(c);
        }
        let me = self.nodes.len();
        self.nodes.push(Node { lo, hi, index: 0, count: 0 });
        let extent = chi - clo;
        if items.len() <= LEAF_SIZE || extent.max_element() <= 0.0 {
            self.nodes[me].index = self.prims.len() as u32;
            self.nodes[me].count = items.len() as u32;
            self.prims.extend(items.iter().map(|it| it.0));
            return me;
        }
        let axis = if extent.x >= extent.y && extent.x >= extent.z {
            0
        } else if extent.y >= extent.z {
            1
        } else {
            2
        };
        let mid = items.len() / 2;
        items.select_nth_unstable_by(mid, |a, b| {
            let ca = a.1[axis] + a.2[axis];
            let cb = b.1[axis] + b.2[axis];
            ca.total_cmp(&cb)
        });
        let (left, right) = items.split_at_mut(mid);
        self.build_node(left);
        let second = self.build_node(right);
        self.nodes[me].index = second as u32;
        me
    }

    /// Slab test of the box against `o + t d`, `0 <= t <= t_max`, inclusive.
    fn box_hit(n: &Node, o: DVec3, inv: DVec3, t_max: f64) -> bool {
        let (mut t0, mut t1) = (0.0f64, t_max);
        for a in 0..3 {
            if inv[a].is_infinite() {
                // Ray parallel to this slab: inside it or not at all.
                if o[a] < n.lo[a] || o[a] > n.hi[a] {
                    return false;
                }
                continue;
            }
            let ta = (n.lo[a] - o[a]) * inv[a];
            let tb = (n.hi[a] - o[a]) * inv[a];
            t0 = t0.max(ta.min(tb));
            t1 = t1.min(ta.max(tb));
            if t0 > t1 {
                return false;
            }
        }
        true
    }

    /// Calls `visit(prim)` for every primitive whose box the ray reaches before `t_max()`
    /// (re-read at each box, so the caller can shrink it); stops when `visit` returns true.
    pub fn traverse(
        &self,
        o: DVec3,
        d: DVec3,
        mut t_max: impl FnMut() -> f64,
        mut visit: impl FnMut(PrimId) -> bool,
    ) {
        if self.nodes.is_empty() {
            return;
        }
        let inv = DVec3::ONE / d;
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            let n = &self.nodes[i];
            if !Self::box_hit(n, o, inv, t_max()) {
                continue;
            }
            if n.count > 0 {
                let first = n.index as usize;
                for &p in &self.prims[first..first + n.count as usize] {
                    if visit(p) {
                        return;
                    }
                }
            } else {
                stack.push(n.index as usize);
                stack.push(i + 1);
            }
        }
    }
}
