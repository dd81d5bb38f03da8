// BVH traversal (src/accel/bvh.rs builds the tree, src/gpu/layout.rs packs it: `BvhNode`).
// Nodes are depth-first, the left child next to its parent; an inner node's `a` is its escape
// (the first node after its subtree), `b` its axis and right child; a leaf's `a` is its texel
// of primitive references, `b` their count. Both walks test one node's box per loop iteration, so a
// lavapipe iteration (which every lane pays for, taken branch or not) is one box test plus the
// masked leaf loop.

fn load_bvh_node(i: u32) -> BvhNode {
    let at = params.accel_base.x + i * BVH_NODE_TEXELS;
    let a = texel(at);
    let b = texel(at + 1u);
    return BvhNode(bitcast<vec3f>(a.xyz), a.w, bitcast<vec3f>(b.xyz), b.w);
}

// Whether o + t d meets the node's box for some t in [t_min, t_max] (slab test in `real`). The
// box's far distance is grown by 1 + 2γ₃ (Ize, "Robust BVH ray traversal", JCGT 2013), so the
// test's own rounding never loses a box; the packing grew the boxes for everything else.
// Its min and max are compares and selects: the distances are never NaN (`bvh_inv_dir` keeps
// 1/d finite), and WGSL's min/max keep NaN semantics that cost lavapipe a third instruction each.
fn bvh_box(n: BvhNode, o: vec3r, inv_d: vec3r, t_min: real, t_max: real) -> bool {
    let t0 = (vec3r(n.lo) - o) * inv_d;
    let t1 = (vec3r(n.hi) - o) * inv_d;
    let swap = t1 < t0;
    let lo = select(t0, t1, swap);
    let hi = select(t1, t0, swap);
    let near = max_r(max_r(lo.x, lo.y), max_r(lo.z, t_min));
    let far = min_r(min_r(hi.x, hi.y), hi.z) * real(1.0000004);
    return near <= min_r(far, t_max);
}

fn min_r(a: real, b: real) -> real {
    return select(b, a, a < b);
}

fn max_r(a: real, b: real) -> real {
    return select(b, a, a > b);
}

// 1 / d per axis, a zero (or tiny) component replaced by 1 / 1e-30 of the same sign: the slabs
// of that axis then give ±huge distances on the right sides, never a NaN.
fn bvh_inv_dir(d: vec3f) -> vec3r {
    let tiny = abs(d) < vec3f(1.0e-30);
    let safe = select(d, select(vec3f(1.0e-30), vec3f(-1.0e-30), d < vec3f(0.0)), tiny);
    return vec3r(1.0) / vec3r(safe);
}

// A leaf's primitives against the ray: `count` (at most 4) references in the one texel
// `refs_texel`; `best` updated; true when `any_hit` and one was hit.
fn bvh_leaf(refs_texel: u32, count: u32, o: vec3f, d: vec3f, t_min: f32, any_hit: bool, triangles_only: bool, best: ptr<function, Hit>) -> bool {
    let refs = texel(params.accel_base.y + refs_texel);
    for (var k = 0u; k < count; k++) {
        loop_tick(LOOP_CANDIDATES);
        let r = refs[k];
        if triangles_only && prim_kind(r) != PRIM_TRIANGLE {
            continue;
        }
        let h = intersect_prim(r, o, d, t_min, (*best).t);
        if h.x != MISS {
            *best = Hit(h.x, r, h.y, h.z);
            if any_hit {
                return true;
            }
        }
    }
    return false;
}

// Nearest hit in (t_min, t_max) (`any_hit`: the first found; `triangles_only`: for shell
// shadows, as `grid_walk`), with a stack of node indices: at an inner node the child on the
// ray's near side of the split axis is visited first and the other pushed; a popped node's box
// is tested against the nearest hit so far. The stack is a private array indexed at run time,
// a per-lane scatter/gather on lavapipe; the tree is at most BVH_STACK deep (accel::bvh).
fn bvh_walk_stack(o: vec3f, d: vec3f, t_min: f32, t_max: f32, any_hit: bool, triangles_only: bool) -> Hit {
    var best = Hit(t_max, NO_HIT, 0.0, 0.0);
    let or = vec3r(o);
    let inv_d = bvh_inv_dir(d);
    let negative = d < vec3f(0.0);
    var stack: array<u32, BVH_STACK>;
    var sp = 0u;
    var i = 0u;
    loop {
        loop_tick(LOOP_WALK);
        let n = load_bvh_node(i);
        var next = NO_HIT;
        if bvh_box(n, or, inv_d, real(t_min), real(best.t)) {
            if (n.b & BVH_INNER) != 0u {
                let axis = (n.b >> BVH_AXIS_SHIFT) & 3u;
                let right = n.b & BVH_CHILD_MASK;
                // The left child holds the lower centroids: it is the near one unless the ray
                // runs towards lower coordinates on the split axis.
                let flip = select(select(negative.x, negative.y, axis == 1u), negative.z, axis == 2u);
                next = select(i + 1u, right, flip);
                stack[sp] = select(right, i + 1u, flip);
                sp += 1u;
            } else if bvh_leaf(n.a, n.b, o, d, t_min, any_hit, triangles_only, &best) {
                return best;
            }
        }
        if next == NO_HIT {
            if sp == 0u {
                break;
            }
            sp -= 1u;
            next = stack[sp];
        }
        i = next;
    }
    return best;
}

// Compact node texel `q` decoded: its box `base + q * step` (as the host's quantise_node
// rounded it, fused or not), `a` its link word.
fn bvh_qnode(q: vec4u, base: vec3f, step: vec3f) -> BvhNode {
    let lo = fma(vec3f(vec3u(q.x & 0xffffu, q.x >> 16u, q.y & 0xffffu)), step, base);
    let hi = fma(vec3f(vec3u(q.y >> 16u, q.z & 0xffffu, q.z >> 16u)), step, base);
    return BvhNode(lo, q.w, hi, 0u);
}

// The same without a stack, over compact nodes (one texel: the box in 16-bit steps of the
// lattice `params.accel_min + q * params.cell`, then the link word; layout.rs,
// quantise_node): the nodes in their depth-first order, a missed inner node's subtree skipped by
// its escape link. One fetch, a decode and a slab test per iteration; children come in a fixed
// order, so a closest-hit ray cannot visit the near side first.
fn bvh_walk_stackless(o: vec3f, d: vec3f, t_min: f32, t_max: f32, any_hit: bool, triangles_only: bool) -> Hit {
    var best = Hit(t_max, NO_HIT, 0.0, 0.0);
    let or = vec3r(o);
    let inv_d = bvh_inv_dir(d);
    // Hoisted by hand: lavapipe moves nothing out of loops.
    let count = params.accel_base.z;
    let nodes = params.accel_base.x;
    let base = params.accel_min.xyz;
    let step = params.cell.xyz;
    var i = 0u;
    loop {
        loop_tick(LOOP_WALK);
        let n = bvh_qnode(texel(nodes + i), base, step);
        let hit = bvh_box(n, or, inv_d, real(t_min), real(best.t));
        let inner = (n.a & BVH_INNER) != 0u;
        let link = n.a & ~BVH_INNER;
        if hit && !inner && bvh_leaf(link & ((1u << BVH_COUNT_SHIFT) - 1u), link >> BVH_COUNT_SHIFT, o, d, t_min, any_hit, triangles_only, &best) {
            return best;
        }
        i = select(i + 1u, link, inner && !hit);
        if i >= count {
            break;
        }
    }
    return best;
}
