//! A binary bounding-volume hierarchy beside the grid: binned surface-area-heuristic build on
//! the CPU (Wald 2007, "On fast construction of SAH-based bounding volume hierarchies"),
//! flattened depth-first with the left child next to its parent, leaves of a few primitives.
//!
//! Built in f64 over the same primitive boxes the grid inserts by ([`Grid::for_each_bound`]);
//! the packing (`gpu::layout`) rounds every box outward to f32 with a margin, so the shader's
//! f32 slab test never loses a primitive to rounding.
//!
//! Each subtree occupies a contiguous run of nodes: node `i` with a subtree of `s` nodes has its
//! left child at `i + 1`, its right child at `i + 1 + s_left` and the first node after its
//! subtree (its *escape*) at `i + s`. The shader walks it either with a stack (visiting the
//! child nearer along the split axis first) or stackless by the escape links (a fixed order);
//! docs/performance.md, "Grid vs BVH", says which and why.

use super::grid::Grid;
use super::PrimRef;
use crate::scene::Scene;
use glam::DVec3;
use std::fmt;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// Primitives a leaf holds at most.
pub const MAX_LEAF: usize = 4;
/// Bins per axis of the SAH sweep.
pub const BINS: usize = 16;
/// SAH cost of visiting an inner node, relative to one primitive test.
pub const TRAVERSAL_COST: f64 = 1.0;
/// Depth a tree never exceeds: the shader's traversal stack has this many slots. Past
/// [`SAH_DEPTH`], nodes are split at the object median, which halves them at every level.
pub const MAX_DEPTH: usize = 64;
const SAH_DEPTH: usize = MAX_DEPTH - 34;
/// Below this many primitives a subtree is built on the calling thread.
const MIN_PRIMS_PER_THREAD: usize = 1 << 12;

/// What a node is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NodeKind {
    /// Children at `index + 1` and `right`; the node after the subtree at `escape`. `axis` is
    /// the axis the children were split along: the left child holds the lower centroids, or
    /// the higher ones where `swapped` ([`Bvh::ordered_towards`]).
    Inner { axis: u8, right: u32, escape: u32, swapped: bool },
    /// Primitives `refs[first..first + count]`.
    Leaf { first: u32, count: u32 },
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Node {
    pub lo: DVec3,
    pub hi: DVec3,
    pub kind: NodeKind,
}

/// How a build chooses its splits ([`Bvh::build_with`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Split {
    /// Binned SAH over all three axes (what [`Bvh::build`] uses).
    Sah,
    /// The object median along the largest centroid extent: the baseline the SAH is tested
    /// against.
    Median,
}

/// The flattened hierarchy.
#[derive(Clone, Debug, PartialEq)]
pub struct Bvh {
    /// Depth-first, left child next; the root is `nodes[0]`.
    pub nodes: Vec<Node>,
    /// The primitives, leaf by leaf.
    pub refs: Vec<PrimRef>,
}

/// What a build reads from a scene: every primitive's box, gathered ([`BvhInput::of`]) so that
/// the build itself needs no scene and can run on another thread (the viewer's background
/// build, `render::Session::new_interactive`).
pub struct BvhInput(Vec<Prim>);

impl BvhInput {
    /// The boxes of `scene`'s spheres, triangles and cones.
    pub fn of(scene: &Scene) -> BvhInput {
        let mut prims = Vec::with_capacity(scene.primitive_count());
        Grid::for_each_bound(scene, |r, lo, hi| prims.push(Prim { lo, hi, centre: (lo + hi) * 0.5, r }));
        BvhInput(prims)
    }

    /// [`Bvh::build`] of these boxes.
    pub fn build(self) -> Bvh {
        self.build_with_progress(&|_, _| {})
    }

    /// [`Bvh::build_with_progress`] of these boxes.
    pub fn build_with_progress(self, progress: &(dyn Fn(usize, usize) + Sync)) -> Bvh {
        self.build_reporting(Split::Sah, build_threads(), progress, &AtomicBool::new(false))
            .expect("a build nobody cancels ends")
    }

    /// [`BvhInput::build`], given up (`None`) soon after `cancel` is set: a background build
    /// whose scene was edited meanwhile stops instead of holding a core and the boxes' memory to
    /// its end (`render::Session`).
    pub fn build_unless(self, cancel: &AtomicBool) -> Option<Bvh> {
        self.build_reporting(Split::Sah, build_threads(), &|_, _| {}, cancel)
    }

    fn build_reporting(
        self,
        split: Split,
        threads: usize,
        progress: &(dyn Fn(usize, usize) + Sync),
        cancel: &AtomicBool,
    ) -> Option<Bvh> {
        let mut prims = self.0;
        if prims.is_empty() {
            // One empty leaf, so the shader's walk needs no special case.
            let kind = NodeKind::Leaf { first: 0, count: 0 };
            return Some(Bvh { nodes: vec![Node { lo: DVec3::ZERO, hi: DVec3::ZERO, kind }], refs: vec![] });
        }
        // At most 2n - 1 nodes.
        let mut nodes = Vec::with_capacity(2 * prims.len());
        let placed = Placed { done: AtomicUsize::new(0), total: prims.len(), report: progress, cancel };
        build_range(&mut nodes, &mut prims, 0, 0, split, threads.max(1), &placed);
        // A cancelled build's nodes are a partial tree: dropped, never returned.
        (!placed.cancelled()).then(|| Bvh { nodes, refs: prims.iter().map(|p| p.r).collect() })
    }
}

/// Threads a build may use: one a core.
fn build_threads() -> usize {
    std::thread::available_parallelism().map_or(1, |t| t.get())
}

/// A primitive as the builder sees it.
#[derive(Clone, Copy)]
struct Prim {
    lo: DVec3,
    hi: DVec3,
    centre: DVec3,
    r: PrimRef,
}

#[derive(Clone, Copy)]
struct Aabb {
    lo: DVec3,
    hi: DVec3,
}

impl Aabb {
    const EMPTY: Aabb = Aabb { lo: DVec3::splat(f64::INFINITY), hi: DVec3::splat(f64::NEG_INFINITY) };
    fn grow(&mut self, lo: DVec3, hi: DVec3) {
        self.lo = self.lo.min(lo);
        self.hi = self.hi.max(hi);
    }
    fn union(self, o: Aabb) -> Aabb {
        Aabb { lo: self.lo.min(o.lo), hi: self.hi.max(o.hi) }
    }
    /// Half the surface area (the SAH only needs ratios); 0 for an empty box.
    fn half_area(&self) -> f64 {
        let e = (self.hi - self.lo).max(DVec3::ZERO);
        if self.lo.x > self.hi.x {
            return 0.0;
        }
        e.x * e.y + e.y * e.z + e.z * e.x
    }
}

fn bounds(prims: &[Prim]) -> (Aabb, Aabb) {
    let (mut b, mut c) = (Aabb::EMPTY, Aabb::EMPTY);
    for p in prims {
        b.grow(p.lo, p.hi);
        c.grow(p.centre, p.centre);
    }
    (b, c)
}

/// Nodes under construction, depth-first.
type Nodes = Vec<Node>;

/// Counts the primitives placed in leaves and reports them about every hundredth; carries the
/// flag that gives the build up.
struct Placed<'a> {
    done: AtomicUsize,
    total: usize,
    report: &'a (dyn Fn(usize, usize) + Sync),
    cancel: &'a AtomicBool,
}

impl Placed<'_> {
    fn cancelled(&self) -> bool {
        self.cancel.load(Ordering::Relaxed)
    }

    /// Appends `leaf` (of `count` primitives) to `out` and counts them.
    fn leaf(&self, out: &mut Nodes, leaf: Node, count: usize) {
        out.push(leaf);
        let step = (self.total / 100).max(1);
        let before = self.done.fetch_add(count, Ordering::Relaxed);
        if before / step != (before + count) / step {
            (self.report)(before + count, self.total);
        }
    }
}

/// Moves every index of `nodes` (a subtree) by `by` nodes.
fn shift(nodes: &mut [Node], by: u32) {
    for n in nodes {
        if let NodeKind::Inner { right, escape, .. } = &mut n.kind {
            *right += by;
            *escape += by;
        }
    }
}

/// Summary of a built BVH, for logs and `irt bench`.
#[derive(Clone, Debug, PartialEq)]
pub struct BvhStats {
    pub nodes: usize,
    pub leaves: usize,
    pub prims: usize,
    pub depth: usize,
    /// SAH cost relative to one primitive test per ray through the root box ([`Bvh::sah_cost`]).
    pub sah: f64,
    /// Bytes as packed for the device (nodes and references).
    pub bytes: usize,
}

impl fmt::Display for BvhStats {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        write!(
            f,
            "BVH {} nodes, {} leaves ({:.2} primitives per leaf), depth {}, SAH cost {:.1}, {:.1} MiB",
            self.nodes,
            self.leaves,
            self.prims as f64 / self.leaves.max(1) as f64,
            self.depth,
            self.sah,
            self.bytes as f64 / (1024.0 * 1024.0)
        )
    }
}

impl Bvh {
    /// The binned-SAH hierarchy over every sphere, triangle and cone of `scene`, on all cores.
    pub fn build(scene: &Scene) -> Bvh {
        BvhInput::of(scene).build()
    }

    /// [`Bvh::build`], calling `progress(done, total)` as primitives are placed in leaves (from
    /// any of the building threads, about every hundredth of them).
    pub fn build_with_progress(scene: &Scene, progress: &(dyn Fn(usize, usize) + Sync)) -> Bvh {
        BvhInput::of(scene).build_with_progress(progress)
    }

    /// [`Bvh::build`] with the split rule and the number of threads given: the tree is the same
    /// for every thread count (subtrees are built independently and joined in order).
    pub fn build_with(scene: &Scene, split: Split, threads: usize) -> Bvh {
        BvhInput::of(scene)
            .build_reporting(split, threads, &|_, _| {}, &AtomicBool::new(false))
            .expect("a build nobody cancels ends")
    }

    /// Expected cost of a ray through the root box by the surface-area heuristic, in units of
    /// one primitive test: each node is visited with the probability that its box is hit given
    /// the root's is (the ratio of their areas), inner nodes at [`TRAVERSAL_COST`], leaves at
    /// one test per primitive.
    pub fn sah_cost(&self) -> f64 {
        let area = |n: &Node| Aabb { lo: n.lo, hi: n.hi }.half_area();
        let root = area(&self.nodes[0]);
        if root <= 0.0 {
            return 0.0;
        }
        self.nodes
            .iter()
            .map(|n| {
                area(n) / root
                    * match n.kind {
                        NodeKind::Inner { .. } => TRAVERSAL_COST,
                        NodeKind::Leaf { count, .. } => count as f64,
                    }
            })
            .sum()
    }

    /// The same tree flattened again with, at every inner node, the child nearer `eye` first
    /// (its box nearer, or if both boxes are as near, e.g. both hold the eye, its centre; ties
    /// in the builder's order): the
    /// stackless walk visits children in their stored order, so eye rays from `eye` meet the
    /// near side of each split first and cut the far side's boxes by the hit found (docs/
    /// performance.md, "Eye-ordered BVH"). Leaves and references are renumbered in the new
    /// order; boxes and leaves are unchanged.
    pub fn ordered_towards(&self, eye: DVec3) -> Bvh {
        let mut out =
            Bvh { nodes: Vec::with_capacity(self.nodes.len()), refs: Vec::with_capacity(self.refs.len()) };
        self.emit_ordered(0, eye, &mut out);
        out
    }

    fn emit_ordered(&self, i: usize, eye: DVec3, out: &mut Bvh) {
        let n = self.nodes[i];
        match n.kind {
            NodeKind::Leaf { first, count } => {
                let at = out.refs.len() as u32;
                out.refs.extend_from_slice(&self.refs[first as usize..(first + count) as usize]);
                out.nodes.push(Node { kind: NodeKind::Leaf { first: at, count }, ..n });
            }
            NodeKind::Inner { axis, right, swapped, .. } => {
                let key = |c: &Node| {
                    let nearest = eye.clamp(c.lo, c.hi);
                    (eye.distance_squared(nearest), eye.distance_squared((c.lo + c.hi) * 0.5))
                };
                let (l, r) = (i + 1, right as usize);
                // Ties keep the builder's order, so the result depends on the eye alone, not on
                // the order the tree came in.
                let (kl, kr) = (key(&self.nodes[l]), key(&self.nodes[r]));
                let swap = kr < kl || (kr == kl && swapped);
                let (first, second) = if swap { (r, l) } else { (l, r) };
                let at = out.nodes.len();
                out.nodes.push(n);
                self.emit_ordered(first, eye, out);
                let right = out.nodes.len() as u32;
                self.emit_ordered(second, eye, out);
                let escape = out.nodes.len() as u32;
                out.nodes[at].kind = NodeKind::Inner { axis, right, escape, swapped: swapped != swap };
            }
        }
    }

    /// The depth of the deepest leaf (the root alone: 1).
    pub fn depth(&self) -> usize {
        fn depth_at(b: &Bvh, i: usize) -> usize {
            match b.nodes[i].kind {
                NodeKind::Leaf { .. } => 1,
                NodeKind::Inner { right, .. } => 1 + depth_at(b, i + 1).max(depth_at(b, right as usize)),
            }
        }
        depth_at(self, 0)
    }

    pub fn stats(&self) -> BvhStats {
        let leaves = self.nodes.iter().filter(|n| matches!(n.kind, NodeKind::Leaf { .. })).count();
        BvhStats {
            nodes: self.nodes.len(),
            leaves,
            prims: self.refs.len(),
            depth: self.depth(),
            sah: self.sah_cost(),
            bytes: 32 * self.nodes.len() + 4 * self.refs.len(),
        }
    }
}

/// Appends the subtree over `prims` (reordered in place), whose first primitive is
/// `refs[first]`, at `depth`, to `out`: depth-first, its root at `out.len()`, indices absolute.
/// `threads` threads may build it. Written in place rather than returned and concatenated: the
/// concatenation copied every node once per level above it (a tenth of a 3M-triangle build).
fn build_range(
    out: &mut Nodes,
    prims: &mut [Prim],
    first: u32,
    depth: usize,
    split: Split,
    threads: usize,
    placed: &Placed,
) {
    if placed.cancelled() {
        // Checked at every node: each thread stops once the node it is binning is done.
        return;
    }
    let (b, c) = bounds(prims);
    let n = prims.len();
    let leaf = Node { lo: b.lo, hi: b.hi, kind: NodeKind::Leaf { first, count: n as u32 } };
    if n == 1 {
        return placed.leaf(out, leaf, n);
    }
    let extent = c.hi - c.lo;
    let mut chosen = None;
    if split == Split::Sah && depth < SAH_DEPTH {
        if let Some((axis, cost, bin)) = sah_split(prims, &b, &c) {
            if n <= MAX_LEAF && cost >= n as f64 {
                return placed.leaf(out, leaf, n);
            }
            // Bins are cut at centroid coordinates; partition by the same bin function.
            let (lo, k) = (c.lo[axis], bin_scale(extent)[axis]);
            let mid = partition(prims, |p| bin_of(p.centre[axis], lo, k) <= bin);
            if mid > 0 && mid < n {
                chosen = Some((axis, mid));
            }
        }
    }
    let (axis, mid) = match chosen {
        Some(c) => c,
        None if n <= MAX_LEAF => return placed.leaf(out, leaf, n),
        None => {
            // The object median along the largest centroid extent (ties by reference, so the
            // result does not depend on the order the primitives came in).
            let axis = extent.max_position();
            let key = |p: &Prim| (p.centre[axis], p.r.0);
            prims
                .select_nth_unstable_by(n / 2, |a, b| key(a).partial_cmp(&key(b)).expect("finite centroids"));
            (axis, n / 2)
        }
    };
    let at = out.len();
    out.push(leaf); // replaced below, once the children's indices are known
    let (left, right) = prims.split_at_mut(mid);
    let right_at = if threads > 1 && n >= 2 * MIN_PRIMS_PER_THREAD {
        let (lt, rt) = (threads / 2, threads - threads / 2);
        // The right subtree on its own thread into its own nodes (from index 0), moved after
        // the left one.
        let mut r = std::thread::scope(|s| {
            let h = s.spawn(|| {
                let mut r = Vec::with_capacity(2 * right.len());
                build_range(&mut r, right, first + mid as u32, depth + 1, split, rt, placed);
                r
            });
            build_range(out, left, first, depth + 1, split, lt, placed);
            h.join().expect("BVH build thread")
        });
        let right_at = out.len() as u32;
        shift(&mut r, right_at);
        out.append(&mut r);
        right_at
    } else {
        build_range(out, left, first, depth + 1, split, 1, placed);
        let right_at = out.len() as u32;
        build_range(out, right, first + mid as u32, depth + 1, split, 1, placed);
        right_at
    };
    let escape = out.len() as u32;
    out[at] = Node {
        lo: b.lo,
        hi: b.hi,
        kind: NodeKind::Inner { axis: axis as u8, right: right_at, escape, swapped: false },
    };
}

/// Moves the primitives for which `left` holds before the others (unstable), returning how
/// many there are. Deterministic: the same input gives the same order.
fn partition(prims: &mut [Prim], left: impl Fn(&Prim) -> bool) -> usize {
    let mut i = 0;
    let mut j = prims.len();
    while i < j {
        if left(&prims[i]) {
            i += 1;
        } else {
            j -= 1;
            prims.swap(i, j);
        }
    }
    i
}

/// Per axis, bins per unit of centroid coordinate across a centroid box of `extent`; 0 on a flat
/// axis, which puts everything in bin 0 (and [`sah_split`] skips).
fn bin_scale(extent: DVec3) -> DVec3 {
    DVec3::from_array(extent.to_array().map(|e| if e > 0.0 { BINS as f64 / e } else { 0.0 }))
}

/// The bin of centroid coordinate `x`, bins starting at `lo`, `k` of them per unit: the one
/// function the SAH sweep bins by and the partition splits by.
fn bin_of(x: f64, lo: f64, k: f64) -> usize {
    (((x - lo) * k) as usize).min(BINS - 1)
}

/// The cheapest binned split: (axis, SAH cost in primitive tests relative to this node, last
/// bin of the left side), or `None` when every axis puts all centroids in one bin. The three
/// axes are binned in one pass over the primitives (a pass per axis read them three times).
fn sah_split(prims: &[Prim], b: &Aabb, c: &Aabb) -> Option<(usize, f64, usize)> {
    let extent = c.hi - c.lo;
    let area = b.half_area();
    let k = bin_scale(extent);
    let mut boxes = [[Aabb::EMPTY; BINS]; 3];
    let mut counts = [[0usize; BINS]; 3];
    for p in prims {
        for axis in 0..3 {
            let i = bin_of(p.centre[axis], c.lo[axis], k[axis]);
            boxes[axis][i].grow(p.lo, p.hi);
            counts[axis][i] += 1;
        }
    }
    let mut best: Option<(usize, f64, usize)> = None;
    for axis in (0..3).filter(|&axis| extent[axis] > 0.0) {
        let (boxes, counts) = (&boxes[axis], &counts[axis]);
        // Right-to-left sweep: area and count of bins i.. for every i.
        let mut right_area = [0.0; BINS];
        let mut right_count = [0usize; BINS];
        let (mut acc, mut count) = (Aabb::EMPTY, 0);
        for i in (1..BINS).rev() {
            acc = acc.union(boxes[i]);
            count += counts[i];
            right_area[i] = acc.half_area();
            right_count[i] = count;
        }
        let (mut acc, mut count) = (Aabb::EMPTY, 0);
        for i in 0..BINS - 1 {
            acc = acc.union(boxes[i]);
            count += counts[i];
            let (nl, nr) = (count, right_count[i + 1]);
            if nl == 0 || nr == 0 {
                continue;
            }
            let cost = TRAVERSAL_COST
                + (acc.half_area() * nl as f64 + right_area[i + 1] * nr as f64) / area.max(1e-300);
            if best.is_none_or(|(_, c, _)| cost < c) {
                best = Some((axis, cost, i));
            }
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::super::grid::tests::{random_scene, scene, Rng};
    use super::*;
    use crate::scene::Sphere;

    fn contains(outer: &Node, lo: DVec3, hi: DVec3) -> bool {
        outer.lo.cmple(lo).all() && outer.hi.cmpge(hi).all()
    }

    /// Every primitive is in exactly one leaf, leaves tile `refs`, every box holds its children
    /// and its primitives, the links say what the layout promises.
    fn assert_well_formed(bvh: &Bvh, s: &Scene) {
        let mut bounds = vec![];
        Grid::for_each_bound(s, |r, lo, hi| bounds.push((r, lo, hi)));
        let mut seen = vec![0u32; bounds.len()];
        let index = |r: PrimRef| bounds.iter().position(|b| b.0 == r).expect("a scene primitive");
        let mut next_ref = 0u32;
        // Walks subtree `i`, returning its node count.
        fn walk(b: &Bvh, i: usize, depth: usize, f: &mut dyn FnMut(&Node, usize)) -> usize {
            f(&b.nodes[i], depth);
            match b.nodes[i].kind {
                NodeKind::Leaf { .. } => 1,
                NodeKind::Inner { right, escape, .. } => {
                    let n = &b.nodes[i];
                    let (l, r) = (&b.nodes[i + 1], &b.nodes[right as usize]);
                    assert!(
                        contains(n, l.lo, l.hi) && contains(n, r.lo, r.hi),
                        "node {i} holds its children"
                    );
                    let left = walk(b, i + 1, depth + 1, f);
                    assert_eq!(right as usize, i + 1 + left, "right child after the left subtree");
                    let right_n = walk(b, right as usize, depth + 1, f);
                    assert_eq!(escape as usize, i + 1 + left + right_n, "escape after the subtree");
                    1 + left + right_n
                }
            }
        }
        let total = walk(bvh, 0, 1, &mut |n, depth| {
            assert!(depth <= MAX_DEPTH);
            if let NodeKind::Leaf { first, count } = n.kind {
                assert_eq!(first, next_ref, "leaves in order over refs");
                assert!(count as usize <= MAX_LEAF.max(1) || bounds.is_empty());
                next_ref += count;
                for r in &bvh.refs[first as usize..(first + count) as usize] {
                    let k = index(*r);
                    seen[k] += 1;
                    assert!(contains(n, bounds[k].1, bounds[k].2), "leaf holds {r:?}");
                }
            }
        });
        assert_eq!(total, bvh.nodes.len());
        assert_eq!(next_ref as usize, bvh.refs.len());
        assert!(seen.iter().all(|&k| k == 1), "every primitive in exactly one leaf");
    }

    #[test]
    fn every_primitive_is_in_exactly_one_leaf_and_boxes_hold_their_children() {
        for (seed, n, extent, offset) in [
            (1, 1, 1.0, DVec3::ZERO),
            (2, 2, 1.0, DVec3::ZERO),
            (3, 50, 1.0, DVec3::ZERO),
            (4, 2000, 10.0, DVec3::ZERO),
            (5, 300, 1e-3, DVec3::splat(1e4)),
        ] {
            let s = random_scene(seed, n, extent, offset);
            for split in [Split::Sah, Split::Median] {
                assert_well_formed(&Bvh::build_with(&s, split, 2), &s);
            }
        }
        // Many primitives with the same centroid (concentric spheres): no split separates
        // them, the median does, and depth stays bounded.
        let same: Vec<Sphere> =
            (0..1000).map(|i| Sphere { center: DVec3::ZERO, radius: 1.0 + i as f64, material: 0 }).collect();
        let s = scene(same, vec![]);
        let b = Bvh::build(&s);
        assert_well_formed(&b, &s);
        assert!(b.depth() <= 12, "{}", b.depth());
        // No primitives: one empty leaf.
        let b = Bvh::build(&scene(vec![], vec![]));
        assert_eq!(b.nodes.len(), 1);
        assert!(b.refs.is_empty());
    }

    /// The squared distance from `eye` to `n`'s box (0 inside) and to its centre.
    fn nearness(n: &Node, eye: DVec3) -> (f64, f64) {
        (eye.distance_squared(eye.clamp(n.lo, n.hi)), eye.distance_squared((n.lo + n.hi) * 0.5))
    }

    /// The leaves as (box, sorted references), in a canonical order: what ordering must keep.
    fn leaves(b: &Bvh) -> Vec<(DVec3, DVec3, Vec<PrimRef>)> {
        let mut out: Vec<_> = b
            .nodes
            .iter()
            .filter_map(|n| match n.kind {
                NodeKind::Leaf { first, count } => {
                    let mut r = b.refs[first as usize..(first + count) as usize].to_vec();
                    r.sort_by_key(|p| p.0);
                    Some((n.lo, n.hi, r))
                }
                NodeKind::Inner { .. } => None,
            })
            .collect();
        out.sort_by(|a, b| {
            (a.2.first().map(|p| p.0), a.0.to_array())
                .partial_cmp(&(b.2.first().map(|p| p.0), b.0.to_array()))
                .unwrap()
        });
        out
    }

    /// Ordering towards an eye keeps the tree well formed with the same leaves, puts the child
    /// nearer the eye first at every inner node, marks the nodes whose children it swapped,
    /// and depends on the eye alone (ordering an ordered tree for another eye is ordering the
    /// builder's tree for it).
    #[test]
    fn ordering_towards_an_eye_puts_the_nearer_child_first_and_keeps_the_tree() {
        let s = random_scene(7, 3000, 10.0, DVec3::ZERO);
        let built = Bvh::build(&s);
        let eyes = [DVec3::new(30.0, 5.0, -20.0), DVec3::new(-30.0, -5.0, 20.0), DVec3::ZERO];
        for eye in eyes {
            let b = built.ordered_towards(eye);
            assert_well_formed(&b, &s);
            assert_eq!(b.nodes.len(), built.nodes.len());
            assert!(leaves(&b) == leaves(&built), "the same leaves");
            assert_eq!(b.depth(), built.depth());
            let mut swaps = 0;
            for (i, n) in b.nodes.iter().enumerate() {
                if let NodeKind::Inner { right, swapped, .. } = n.kind {
                    let (l, r) = (&b.nodes[i + 1], &b.nodes[right as usize]);
                    assert!(nearness(l, eye) <= nearness(r, eye), "node {i}: the nearer child first");
                    swaps += swapped as usize;
                }
            }
            let inner = b.nodes.iter().filter(|n| matches!(n.kind, NodeKind::Inner { .. })).count();
            assert!(swaps > 0 && swaps < inner, "{swaps} of {inner} swapped");
            for other in eyes {
                assert!(b.ordered_towards(other) == built.ordered_towards(other), "order {eye} then {other}");
            }
        }
    }

    #[test]
    fn the_tree_does_not_depend_on_the_thread_count() {
        let s = random_scene(6, 30_000, 5.0, DVec3::ZERO);
        let one = Bvh::build_with(&s, Split::Sah, 1);
        for threads in [2, 3, 8] {
            assert!(Bvh::build_with(&s, Split::Sah, threads) == one, "{threads} threads");
        }
        assert_well_formed(&one, &s);
    }

    /// The build reports every primitive placed, in about a hundred steps, from whichever
    /// thread places them, and reporting changes nothing in the tree.
    #[test]
    fn the_build_reports_its_progress() {
        let s = random_scene(6, 30_000, 5.0, DVec3::ZERO);
        let n = s.primitive_count();
        let no = AtomicBool::new(false);
        for threads in [1, 3] {
            let reports = std::sync::Mutex::new(Vec::new());
            let bvh = BvhInput::of(&s)
                .build_reporting(
                    Split::Sah,
                    threads,
                    &|done, total| reports.lock().unwrap().push((done, total)),
                    &no,
                )
                .unwrap();
            assert!(bvh == Bvh::build_with(&s, Split::Sah, threads));
            let reports = reports.into_inner().unwrap();
            assert!(reports.iter().all(|&(d, t)| t == n && d <= n), "{threads} threads");
            assert_eq!(reports.iter().map(|r| r.0).max(), Some(n), "{threads} threads");
            assert!((90..=101).contains(&reports.len()), "{} reports", reports.len());
        }
    }

    /// A build cancelled before it starts returns nothing; one cancelled at its first progress
    /// report (a hundredth of the primitives placed) stops placing them soon after, on one
    /// thread or several, and returns nothing either.
    #[test]
    fn a_cancelled_build_stops_and_returns_nothing() {
        let s = random_scene(6, 30_000, 5.0, DVec3::ZERO);
        let n = s.primitive_count();
        assert!(BvhInput::of(&s).build_unless(&AtomicBool::new(true)).is_none());
        for threads in [1, 3] {
            let cancel = AtomicBool::new(false);
            let most = AtomicUsize::new(0);
            let report = |done: usize, _| {
                cancel.store(true, Ordering::Relaxed);
                most.fetch_max(done, Ordering::Relaxed);
            };
            assert!(BvhInput::of(&s).build_reporting(Split::Sah, threads, &report, &cancel).is_none());
            // Each thread finishes at most the node it is in: a few leaves past the 1% report.
            let placed = most.into_inner();
            assert!(placed < n / 10, "{threads} threads: {placed} of {n} placed after the cancel");
        }
    }

    /// Clusters of small spheres far apart (a teapot-in-a-stadium in miniature): the SAH puts
    /// the empty space between clusters into no box, the median split cuts through clusters.
    #[test]
    fn sah_is_cheaper_than_the_median_split_on_a_clustered_scene() {
        let mut rng = Rng(11);
        let mut spheres = vec![];
        for k in 0..8 {
            let centre = rng.vec(-100.0, 100.0);
            let count = if k == 0 { 2000 } else { 50 };
            for _ in 0..count {
                spheres.push(Sphere { center: centre + rng.vec(-1.0, 1.0), radius: 0.05, material: 0 });
            }
        }
        // A large floor of two triangles under everything.
        let floor = [
            [
                DVec3::new(-200.0, -120.0, -200.0),
                DVec3::new(200.0, -120.0, -200.0),
                DVec3::new(200.0, -120.0, 200.0),
            ],
            [
                DVec3::new(-200.0, -120.0, -200.0),
                DVec3::new(200.0, -120.0, 200.0),
                DVec3::new(-200.0, -120.0, 200.0),
            ],
        ];
        let s = scene(spheres, floor.to_vec());
        let sah = Bvh::build_with(&s, Split::Sah, 2);
        let median = Bvh::build_with(&s, Split::Median, 2);
        println!("SAH {:.2}, median {:.2}", sah.sah_cost(), median.sah_cost());
        assert!(sah.sah_cost() < 0.8 * median.sah_cost(), "{} vs {}", sah.sah_cost(), median.sah_cost());
        assert_well_formed(&sah, &s);
    }
}
