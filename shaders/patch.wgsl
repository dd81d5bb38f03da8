// Spline patches traced directly (PAPER.md §8; issue #45): a leaf of a rational Bezier piece
// (src/gpu/layout/patch.rs has the records, src/scene/patch/leaves.rs the depth rule) met by
// Newton's method from the leaf's middle, on the ray written as two planes (Martin et al., JGT
// 2000). Its f64 twin finds the same hits by subdivision alone (src/reference/patch.rs).
// Everything here runs only where `HAS_PATCHES` lets `intersect_prim` call it.

// The pieces' degree: a constant in a specialised pipeline, so every loop below unrolls and
// spends none of lavapipe's loop budget; the uber-shader reads it from the frame uniform.
fn patch_degree() -> u32 {
    if PATCH_DEGREE == PATCH_ANY {
        return params.patches.z;
    }
    return PATCH_DEGREE;
}

// The Bernstein polynomials of degree n at t, and their derivatives.
struct Bernstein {
    b: array<f32, 6>,
    db: array<f32, 6>,
}

fn bernstein(n: u32, t: f32) -> Bernstein {
    let s = 1.0 - t;
    // Degree n - 1 first, raised one degree at a time in place (from the top down).
    var c = array<f32, 6>(1.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    for (var k = 1u; k < n; k++) {
        c[k] = t * c[k - 1u];
        for (var r = 1u; r < k; r++) {
            let i = k - r;
            c[i] = s * c[i] + t * c[i - 1u];
        }
        c[0] = s * c[0];
    }
    var out: Bernstein;
    for (var i = 0u; i <= n; i++) {
        let below = select(0.0, c[max(i, 1u) - 1u], i > 0u);
        let here = select(0.0, c[min(i, 5u)], i < n);
        out.b[i] = s * here + t * below;
        out.db[i] = f32(n) * (below - here);
    }
    return out;
}

// A piece's point at (u, v) (fractions of its spans) and its first derivatives.
struct PatchPoint {
    p: vec3f,
    du: vec3f,
    dv: vec3f,
}

fn patch_eval(points: u32, n: u32, uv: vec2f) -> PatchPoint {
    let bu = bernstein(n, uv.x);
    let bv = bernstein(n, uv.y);
    var a = vec4f(0.0);
    var au = vec4f(0.0);
    var av = vec4f(0.0);
    for (var j = 0u; j <= n; j++) {
        var row = vec4f(0.0);
        var row_u = vec4f(0.0);
        for (var i = 0u; i <= n; i++) {
            let h = ftexel(points + i + (n + 1u) * j);
            row += bu.b[i] * h;
            row_u += bu.db[i] * h;
        }
        a += bv.b[j] * row;
        au += bv.b[j] * row_u;
        av += bv.db[j] * row;
    }
    // S = a.xyz / a.w and the quotient rule.
    let p = a.xyz / a.w;
    return PatchPoint(p, (au.xyz - au.w * p) / a.w, (av.xyz - av.w * p) / a.w);
}

struct Leaf {
    piece: u32,
    // The leaf's square in its piece, grown by PATCH_OVERLAP of its side on every side.
    lo: vec2f,
    hi: vec2f,
}

fn load_leaf(i: u32) -> Leaf {
    let rec = texel(params.patches.x + i * LEAF_TEXELS);
    let cell = vec2u(rec.y & 0xffu, (rec.y >> 8u) & 0xffu);
    let side = vec2f(1.0) / vec2f(vec2u(1u << ((rec.y >> 16u) & 0xffu), 1u << (rec.y >> 24u)));
    let lo = vec2f(cell) * side;
    let grow = PATCH_OVERLAP * side;
    return Leaf(rec.x, max(lo - grow, vec2f(0.0)), min(lo + side + grow, vec2f(1.0)));
}

// The ray's nearest crossing with leaf `i` in (t_min, t_max): (t, u, v), (u, v) in fractions
// of the piece's spans, or t = MISS; w: the Newton steps taken. Newton from the leaf's middle on
// F(u, v) = (n1·(S - o), n2·(S - o)), n1 and n2 unit normals of two planes through the ray; a
// solve that does not converge in PATCH_NEWTON_STEPS (within the piece) misses here.
fn patch_newton(i: u32, o: vec3f, d: vec3f, t_min: f32, t_max_in: f32) -> vec4f {
    let leaf = load_leaf(i);
    let middle = 0.5 * (leaf.lo + leaf.hi);
    // A ray that leaves the surface here (a shadow, reflected or refracted ray) meets it again
    // within a hair of its origin if it leaves below the horizon. From the middle, Newton
    // meets another root of the piece or none at such grazing angles (20 of 300 such shadow
    // rays passed through); from the origin's own parameters it meets that one. So a leaf near
    // the origin is solved from there first, and the middle's solve looks only nearer.
    var t_max = t_max_in;
    var near = Solve(MISS, middle, 0u, false);
    let points = leaf.piece + PIECE_HEADER_TEXELS;
    let reach = bitcast<f32>(texel(leaf.piece).z) * vmax2(leaf.hi - leaf.lo);
    let s0 = patch_eval(points, patch_degree(), middle);
    if length(s0.p - o) < 2.0 * reach {
        near = patch_solve(leaf, o, d, t_min, t_max, patch_project(points, leaf, o, middle, s0));
        if near.t != MISS {
            t_max = near.t;
        }
    }
    let first = pick_nearer(patch_solve(leaf, o, d, t_min, t_max, middle), near);
    // A ray near the silhouette crosses a leaf twice. Met where the surface faces away from
    // it (the far crossing, for a ray from outside), the solve is tried once more from the
    // middle's mirror image about that root, on the near crossing's side; the nearer wins.
    if first.t == MISS || !first.away {
        return vec4f(first.t, first.uv, f32(first.steps + near.steps));
    }
    let start = clamp(leaf.lo + leaf.hi - first.uv, leaf.lo, leaf.hi);
    let second = patch_solve(leaf, o, d, t_min, first.t, start);
    let steps = f32(first.steps + second.steps + near.steps);
    if second.t != MISS {
        return vec4f(second.t, second.uv, steps);
    }
    return vec4f(first.t, first.uv, steps);
}

fn vmax2(v: vec2f) -> f32 {
    return max(v.x, v.y);
}

// `a` unless `b` is a nearer hit; `a`'s steps.
fn pick_nearer(a: Solve, b: Solve) -> Solve {
    if b.t != MISS && (a.t == MISS || b.t <= a.t) {
        return Solve(b.t, b.uv, a.steps, b.away);
    }
    return a;
}

// The parameters in `leaf` of the surface point nearest `x` (a point within about a leaf of
// the surface): Gauss-Newton on |S(u, v) - x|² from `start`, where S is `s`, three steps.
fn patch_project(points: u32, leaf: Leaf, x: vec3f, start: vec2f, s: PatchPoint) -> vec2f {
    var uv = start;
    var at = s;
    for (var k = 0u; k < 3u; k++) {
        let r = x - at.p;
        let a = mat2x2f(
            vec2f(dot(at.du, at.du), dot(at.du, at.dv)),
            vec2f(dot(at.du, at.dv), dot(at.dv, at.dv)),
        );
        let det = determinant(a);
        if !(abs(det) > 0.0) {
            break;
        }
        let b = vec2f(dot(at.du, r), dot(at.dv, r));
        uv = clamp(uv + vec2f(a[1].y * b.x - a[1].x * b.y, a[0].x * b.y - a[0].y * b.x) / det, leaf.lo, leaf.hi);
        at = patch_eval(points, patch_degree(), uv);
    }
    return uv;
}

struct Solve {
    t: f32,
    uv: vec2f,
    steps: u32,
    // The surface there faces away from the ray (du × dv · d > 0).
    away: bool,
}

fn patch_solve(leaf: Leaf, o: vec3f, d: vec3f, t_min: f32, t_max: f32, start: vec2f) -> Solve {
    let n = patch_degree();
    let head = texel(leaf.piece);
    let points = leaf.piece + PIECE_HEADER_TEXELS;
    let tol = PATCH_TOLERANCE * bitcast<f32>(head.z);
    let ad = abs(d);
    let n1 = normalize(select(vec3f(0.0, d.z, -d.y), vec3f(d.y, -d.x, 0.0), ad.x > ad.y && ad.x > ad.z));
    let n2 = normalize(cross(n1, d));
    var uv = start;
    var met = false;
    var q = vec3f(0.0);
    var facing = 0.0;
    var steps = 0u;
    for (var k = 0u; k < PATCH_NEWTON_STEPS; k++) {
        let s = patch_eval(points, n, uv);
        q = s.p - o;
        let f = vec2f(dot(n1, q), dot(n2, q));
        facing = dot(cross(s.du, s.dv), d);
        if max(abs(f.x), abs(f.y)) <= tol {
            met = true;
            break;
        }
        let j = mat2x2f(vec2f(dot(n1, s.du), dot(n2, s.du)), vec2f(dot(n1, s.dv), dot(n2, s.dv)));
        let det = determinant(j);
        steps += 1u;
        if !(abs(det) > 0.0) {
            // A pole (du or dv vanishes on a degenerate edge, where a clamped step can land)
            // or a ray along the surface: halfway back to the middle, and on.
            uv = 0.5 * (uv + 0.5 * (leaf.lo + leaf.hi));
            continue;
        }
        // A step goes at most a leaf's side in each parameter (a ray along the tangent plane
        // would throw it across the piece, into another sheet of the surface), and stays
        // within the piece: beyond it the polynomial is not the surface.
        let step = vec2f(j[1].y * f.x - j[1].x * f.y, j[0].x * f.y - j[0].y * f.x) / det;
        let side = leaf.hi - leaf.lo;
        uv = clamp(uv - clamp(step, -side, side), vec2f(0.0), vec2f(1.0));
    }
    // A root met outside the leaf is still the surface's (only a nearer one matters, and the
    // leaf that holds it is tested too: its box is entered before this root): kept, so that a
    // solve drawn to a pole's degenerate edge or just across a seam still counts.
    let t = dot(q, d) / dot(d, d);
    if met && t > t_min && t < t_max {
        return Solve(t, uv, steps, facing > 0.0);
    }
    return Solve(MISS, uv, steps, false);
}

fn intersect_patch(i: u32, o: vec3f, d: vec3f, t_min: f32, t_max: f32) -> vec3f {
    let h = patch_newton(i, o, d, t_min, t_max).xyz;
    if h.x == MISS || patch_kept(load_leaf(i).piece, h.yz) {
        return h;
    }
    return vec3f(MISS, h.yz);
}

// Whether the piece's point at `uv` (fractions of the piece's spans) is surface: inside an odd
// number of its patch's trim loops, by the crossings of a ray towards +u (the f64 twin:
// `scene::patch::trim::kept`); true for an untrimmed patch.
fn patch_kept(piece: u32, uv: vec2f) -> bool {
    let record = texel(piece).w;
    if record == 0u {
        return true;
    }
    let span = ftexel(piece + 1u);
    let p = vec2f(mix(span.x, span.y, uv.x), mix(span.z, span.w, uv.y));
    let edges = texel(record).x;
    var inside = false;
    for (var k = 0u; k < edges; k++) {
        let e = ftexel(record + 1u + k);
        if (e.y > p.y) != (e.w > p.y) && p.x < e.x + (p.y - e.y) * (e.z - e.x) / (e.w - e.y) {
            inside = !inside;
        }
    }
    return inside;
}

// The surface at a hit of leaf `i` at (u, v): the point (recomputed from the piece), the
// geometric normal du × dv (`unit_or` takes over at a pole), the material and the texture
// coordinates (the patch's own parameters, as fractions of its domain).
struct PatchSurface {
    p: vec3f,
    n: vec3f,
    material: u32,
    uv: vec2f,
    size: f32,
}

fn patch_surface(i: u32, uv: vec2f) -> PatchSurface {
    let leaf = load_leaf(i);
    let head = texel(leaf.piece);
    let s = patch_eval(leaf.piece + PIECE_HEADER_TEXELS, patch_degree(), uv);
    let span = ftexel(leaf.piece + 1u);
    let tex = vec2f(mix(span.x, span.y, uv.x), mix(span.z, span.w, uv.y));
    return PatchSurface(s.p, cross(s.du, s.dv), head.x, tex, bitcast<f32>(head.z));
}
