// Light visibility s in each shadow mode (docs/shadows.md). f64 twins: src/reference/shadows.rs.

// Pixel whose ray tree this invocation traces (bundles are rotated per pixel).
var<private> pixel_id: u32;
// Seed of the bundle's per-pixel rotation: the pixel id for the first sample, other values for
// the later samples of progressive refinement (fresh rotations average out).
var<private> bundle_seed: u32;

struct Frame {
    u: vec3f,
    v: vec3f,
}

// Branchless orthonormal basis around unit `n` (Duff et al. 2017): the light disc's axes, and
// where u = 0 lies around a cone's axis (`cone_uv`, texture.wgsl).
fn frame(n: vec3f) -> Frame {
    let sign = select(-1.0, 1.0, n.z >= 0.0);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    return Frame(vec3f(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x), vec3f(b, sign + n.y * n.y * a, -n.y));
}

// Shell transparency for tau in [0, 1]: 0 smoothstep, 1 linear, 2 disc.
fn falloff(f: u32, tau: f32) -> f32 {
    let t = clamp(tau, 0.0, 1.0);
    if f == 1u {
        return t;
    }
    if f == 2u {
        let x = 1.0 - 2.0 * t;
        return (acos(x) - x * sqrt(max(0.0, 1.0 - x * x))) / PI;
    }
    return t * t * (3.0 - 2.0 * t);
}

// Transparency of a sphere's shell for the segment o + t l, 0 < t < dist (the ray is known to
// miss the sphere itself), and the t of closest approach.
fn sphere_shell(f: u32, o: vec3f, l: vec3f, dist: f32, light_r: f32, center: vec3f, radius: f32) -> vec2f {
    let t = dot(center - o, l);
    if t <= 0.0 || t >= dist {
        return vec2f(1.0, t);
    }
    let d = length(center - (o + t * l));
    let b = light_r * t / dist;
    if b <= 0.0 || d >= radius + b {
        return vec2f(1.0, t);
    }
    return vec2f(falloff(f, (d - radius) / b), t);
}

// Distance between the segment o + t l, t in [0, len] (l unit), and the segment a b, and the t
// of the closest point (Ericson, Real-Time Collision Detection §5.1.9).
fn segment_distance(o: vec3f, l: vec3f, len: f32, a: vec3f, b: vec3f) -> vec2f {
    let e = b - a;
    let r = o - a;
    let ee = dot(e, e);
    let le = dot(l, e);
    let lr = dot(l, r);
    let er = dot(e, r);
    var t = 0.0;
    var s = 0.0;
    if ee <= 1.0e-37 {
        t = clamp(-lr, 0.0, len);
    } else {
        let denom = ee - le * le;
        if denom > 1.0e-12 * ee {
            t = clamp((le * er - ee * lr) / denom, 0.0, len);
        }
        s = (le * t + er) / ee;
        if s < 0.0 {
            s = 0.0;
            t = clamp(-lr, 0.0, len);
        } else if s > 1.0 {
            s = 1.0;
            t = clamp(le - lr, 0.0, len);
        }
    }
    return vec2f(length((o + t * l) - (a + s * e)), t);
}

// Transparency of a triangle's shell (points within b of its edges) and the t of closest approach.
fn triangle_shell(f: u32, o: vec3f, l: vec3f, dist: f32, light_r: f32, p0: vec3f, p1: vec3f, p2: vec3f) -> vec2f {
    // Cheap rejection: the segment passes farther from the triangle's bounding sphere than the
    // widest shell (b < light_r), so no edge is within b of it.
    let centre = (p0 + p1 + p2) / 3.0;
    let radius = sqrt(max(max(dot(p0 - centre, p0 - centre), dot(p1 - centre, p1 - centre)), dot(p2 - centre, p2 - centre)));
    let tc = clamp(dot(centre - o, l), 0.0, dist);
    if length(centre - (o + tc * l)) > radius + light_r {
        return vec2f(1.0, tc);
    }
    var best = segment_distance(o, l, dist, p0, p1);
    let e1 = segment_distance(o, l, dist, p1, p2);
    let e2 = segment_distance(o, l, dist, p2, p0);
    best = select(best, e1, e1.x < best.x);
    best = select(best, e2, e2.x < best.x);
    let t = best.y;
    if t <= 0.0 || t >= dist {
        return vec2f(1.0, t);
    }
    let b = light_r * t / dist;
    if b <= 0.0 || best.x >= b {
        return vec2f(1.0, t);
    }
    return vec2f(falloff(f, best.x / b), t);
}

// Transparency of a cone's shell and the t of closest approach to its axis segment. The gap is
// the distance from that ray point to the cone's solid cross-section disc at the axis point
// nearest to it: d - r(s) beside the cone, the distance to the end disc past its ends.
fn cone_shell(f: u32, o: vec3f, l: vec3f, dist: f32, light_r: f32, base: vec3f, r0: f32, axis: vec3f, r1: f32) -> vec2f {
    let t = segment_distance(o, l, dist, base, base + axis).y;
    if t <= 0.0 || t >= dist {
        return vec2f(1.0, t);
    }
    let b = light_r * t / dist;
    let x = o + t * l;
    let s = clamp(dot(x - base, axis) / dot(axis, axis), 0.0, 1.0);
    let v = x - (base + s * axis);
    let along = dot(v, normalize(axis));
    let across = sqrt(max(0.0, dot(v, v) - along * along));
    let out = max(0.0, across - mix(r0, r1, s));
    let gap = sqrt(along * along + out * out);
    if b <= 0.0 || gap >= b {
        return vec2f(1.0, t);
    }
    return vec2f(falloff(f, gap / b), t);
}

fn prim_shell(r: u32, f: u32, o: vec3f, l: vec3f, dist: f32, light_r: f32) -> vec2f {
    let i = prim_index(r);
    if HAS_SPHERES && prim_kind(r) == PRIM_SPHERE {
        let s = load_sphere(i);
        return sphere_shell(f, o, l, dist, light_r, s.xyz, s.w);
    }
    if HAS_CONES && prim_kind(r) == PRIM_CONE {
        let c = load_cone(i);
        return cone_shell(f, o, l, dist, light_r, c.base, c.r0, c.axis, c.r1);
    }
    let tri = load_triangle(i);
    return triangle_shell(f, o, l, dist, light_r, tri.p0, tri.p1, tri.p2);
}

// PCG hash (Jarzynski & Olano 2020); the same as `scene::pixel_hash`.
fn pixel_hash(i: u32) -> u32 {
    let state = i * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// Bundle point k on the unit disc, turned by the pixel's fixed angle when `rotate`.
fn bundle_point(k: u32, pixel: u32, rotate: bool) -> vec2f {
    let t = ftexel(params.grid_base.w + k / 2u);
    let x = select(t.xy, t.zw, (k & 1u) == 1u);
    if !rotate {
        return x;
    }
    let a = f32(pixel_hash(pixel)) * (TAU / 4294967296.0);
    let c = cos(a);
    let s = sin(a);
    return vec2f(c * x.x - s * x.y, s * x.x + c * x.y);
}

fn shadow_kind() -> u32 {
    if SHADOW_MODE == 3u {
        return params.shadow.x;
    }
    return SHADOW_MODE;
}

// Visibility along one ray from `o` towards the point `q`, stopping `gap` short of it.
fn ray_visibility(o: vec3f, q: vec3f, gap: f32) -> f32 {
    let v = q - o;
    let len = length(v);
    ray_counts.w += 1u;
    if len <= gap || !occluded(o, v / len, len - gap) {
        return 1.0;
    }
    return 0.0;
}

// Single-sample soft shadow: one walk towards the light's centre through the shells. A shell is
// counted in the cell whose t-range holds its closest approach, so `product` sees it once.
fn shell_visibility(o: vec3f, c: vec3f, light_r: f32, gap: f32) -> f32 {
    let to = c - o;
    let dist = length(to);
    ray_counts.w += 1u;
    if dist <= gap {
        return 1.0;
    }
    let l = to / dist;
    let f = params.shadow.w & 0xffu;
    let product = (params.shadow.w >> 8u) == 1u;
    var s = 1.0;
    var st: Dda;
    if !dda_init(o, l, 0.0, dist, &st) {
        return 1.0;
    }
    var t_cell = st.t_enter;
    var macro_id = NO_HIT;
    var macro_full = false;
    loop {
        loop_iters += 1u;
        let m = macro_linear(st.cell);
        if m != macro_id {
            macro_id = m;
            macro_full = macro_occupied(m);
        }
        let t_exit = dda_cell_exit(&st);
        if macro_full {
            let range = cell_range(cell_linear(st.cell));
            for (var k = 0u; k < range.y; k++) {
                loop_iters += 1u;
                let r = prim_ref(range.x + k);
                // A shell-only reference cannot be hit here; where the segment does hit that
                // primitive, the cell holding the hit lists it as a full reference.
                if (r & PRIM_SHELL_ONLY) == 0u && intersect_prim(r, o, l, 0.0, dist - gap).x != MISS {
                    return 0.0;
                }
                let sh = prim_shell(r, f, o, l, dist, light_r);
                if product {
                    if real(sh.y) >= t_cell && real(sh.y) < t_exit {
                        s *= sh.x;
                    }
                } else {
                    s = min(s, sh.x);
                }
            }
        }
        t_cell = t_exit;
        if !dda_step(&st) {
            break;
        }
    }
    return s;
}

// s for `light` seen from the offset origin `o`; `l` is the unit direction to its centre. A
// bundle is split over passes (`tile.pass`): each returns its samples' share of s. Every other
// mode belongs wholly to the first pass.
fn light_visibility(o: vec3f, l: vec3f, light: Light) -> f32 {
    let c = light.position_radius.xyz;
    let r = light.position_radius.w;
    // Stop short of the light by a relative margin of the segment's end points' magnitudes
    // (positions are camera-relative, so this follows the scene's own scale).
    let ends = max(abs(o), abs(c));
    let gap = params.trace.y * max(max(ends.x, ends.y), ends.z);
    let kind = shadow_kind();
    let bundle = kind == 1u && r != 0.0;
    if !bundle && tile.pass_range.z == 0u {
        return 0.0;
    }
    if kind == 0u || r == 0.0 {
        ray_counts.w += 1u;
        let dist = length(c - o);
        return select(1.0, 0.0, occluded(o, l, dist - gap));
    }
    if kind == 1u {
        let fr = frame(normalize(c - o));
        let k = params.shadow.y;
        let rotate = params.shadow.z != 0u;
        var seen = 0.0;
        for (var i = tile.pass_range.x; i < min(k, tile.pass_range.y); i++) {
            loop_iters += 1u;
            let x = bundle_point(i, bundle_seed, rotate);
            seen += ray_visibility(o, c + r * (x.x * fr.u + x.y * fr.v), gap);
        }
        return seen / f32(k);
    }
    return shell_visibility(o, c, r, gap);
}
