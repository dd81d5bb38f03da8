// Light visibility s in each shadow mode (docs/shadows.md). f64 twins: src/reference/shadows.rs.

// Pixel whose ray tree this invocation traces (bundles are rotated per pixel).
var<private> pixel_id: u32;
// Seed of the bundle's per-pixel rotation: the pixel id for the first sample, other values for
// the later samples of progressive refinement (fresh rotations average out).
var<private> bundle_seed: u32;

struct Basis {
    u: vec3f,
    v: vec3f,
}

// Branchless orthonormal basis around unit `n` (Duff et al. 2017): the light disc's axes, and
// where u = 0 lies around a cone's axis (`cone_uv`, texture.wgsl).
fn basis(n: vec3f) -> Basis {
    let sign = select(-1.0, 1.0, n.z >= 0.0);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    return Basis(vec3f(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x), vec3f(b, sign + n.y * n.y * a, -n.y));
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

// σ of a shell whose occluder edge lies at signed distance x from the shadow ray (x > 0: the
// ray passes outside the occluder) where the light's cone has radius b: the penumbra straddles
// the hard shadow's edge, x from -b (σ = 0) to +b (σ = 1), τ = (1 + x/b)/2.
fn straddle(f: u32, x: f32, b: f32) -> f32 {
    return falloff(f, 0.5 + 0.5 * x / b);
}

// Transparency of a sphere's shell for the segment o + t l, 0 < t < dist, and the t of closest
// approach: opaque inside radius - b, clear outside radius + b.
fn sphere_shell(f: u32, o: vec3f, l: vec3f, dist: f32, light_r: f32, center: vec3f, radius: f32) -> vec2f {
    let t = dot(center - o, l);
    let b = light_r * t / dist;
    if t <= 0.0 || t >= dist || b <= 0.0 {
        return vec2f(1.0, t);
    }
    let d = length(center - (o + t * l));
    return vec2f(straddle(f, d - radius, b), t);
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

// σ from the distance and t of the nearest occluder edge (`d`, from `segment_distance`), on
// the occluder's side of it when `inside`. An edge at or behind the ray's origin (t = 0) has no
// penumbra there.
fn edge_shell(f: u32, inside: bool, d: vec2f, dist: f32, light_r: f32) -> f32 {
    let b = light_r * d.y / dist;
    if b <= 0.0 {
        return select(1.0, 0.0, inside);
    }
    return straddle(f, select(d.x, -d.x, inside), b);
}

// `d` = (distance, t) of an edge from `segment_distance`: its distance in units of the shell's
// width there (d / b, b = r t / D; BIG where b = 0), the key of `nearest_edge` (reference).
fn edge_reach(d: vec2f, dist: f32, light_r: f32) -> f32 {
    return select(BIG, d.x * dist / (light_r * d.y), d.y > 0.0);
}

// Transparency of a lone triangle's shell (a mesh of one triangle: its contour is its three
// edges) and the t of closest approach; `inside`: the segment hits the triangle.
fn triangle_shell(f: u32, o: vec3f, l: vec3f, dist: f32, light_r: f32, inside: bool, p0: vec3f, p1: vec3f, p2: vec3f) -> vec2f {
    var best = segment_distance(o, l, dist, p0, p1);
    let e1 = segment_distance(o, l, dist, p1, p2);
    let e2 = segment_distance(o, l, dist, p2, p0);
    best = select(best, e1, edge_reach(e1, dist, light_r) < edge_reach(best, dist, light_r));
    best = select(best, e2, edge_reach(e2, dist, light_r) < edge_reach(best, dist, light_r));
    return vec2f(edge_shell(f, inside, best, dist, light_r), best.y);
}

// Transparency of a mesh's shell from its contour edges (texels [first, end), two per edge:
// end points a, b) seen from the light, by the edge whose penumbra reaches the segment most
// (`nearest_edge`, reference); `inside`: the segment hits the mesh.
fn mesh_shell(f: u32, o: vec3f, l: vec3f, dist: f32, light_r: f32, inside: bool, first: u32, end: u32) -> f32 {
    var best = vec2f(BIG, 0.0);
    var key = BIG;
    for (var e = first; e < end; e += SHELL_EDGE_TEXELS) {
        loop_tick(LOOP_CANDIDATES);
        let d = segment_distance(o, l, dist, ftexel(e).xyz, ftexel(e + 1u).xyz);
        let k = edge_reach(d, dist, light_r);
        best = select(best, d, k < key);
        key = min(key, k);
    }
    return edge_shell(f, inside, best, dist, light_r);
}

// Transparency of a cone's shell and the t of closest approach to its axis segment. The signed
// distance is from that ray point to the edge of the cone's solid cross-section disc at the axis
// point nearest to it: d - r(s) beside the cone (negative inside it, where the nearer end is
// also an edge), the distance to the end disc past its ends.
fn cone_shell(f: u32, o: vec3f, l: vec3f, dist: f32, light_r: f32, base: vec3f, r0: f32, axis: vec3f, r1: f32) -> vec2f {
    let t = segment_distance(o, l, dist, base, base + axis).y;
    let b = light_r * t / dist;
    if t <= 0.0 || t >= dist || b <= 0.0 {
        return vec2f(1.0, t);
    }
    let x = o + t * l;
    let len = length(axis);
    let s_raw = dot(x - base, axis) / (len * len);
    let s = clamp(s_raw, 0.0, 1.0);
    let v = x - (base + s * axis);
    let along = dot(v, axis / len);
    let across = sqrt(max(0.0, dot(v, v) - along * along));
    let r = mix(r0, r1, s);
    let out = max(0.0, across - r);
    let gap = sqrt(along * along + out * out);
    let depth = min(r - across, min(s_raw, 1.0 - s_raw) * len);
    let inside = s_raw > 0.0 && s_raw < 1.0 && across < r;
    return vec2f(straddle(f, select(gap, -depth, inside), b), t);
}

// PCG hash (Jarzynski & Olano 2020); the same as `scene::pixel_hash`.
fn pixel_hash(i: u32) -> u32 {
    let state = i * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// Bundle point k on the unit disc, turned by the pixel's fixed angle when `rotate`.
fn bundle_point(k: u32, pixel: u32, rotate: bool) -> vec2f {
    let t = ftexel(params.accel_base.w + k / 2u);
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

// The light-buffer cell of direction `d` from the light's centre in a buffer of `n` cells per
// face side (`scene::shell_cell`): face by the largest axis (+x, -x, +y, -y, +z, -z), then
// row-major on the face.
fn shell_cell(d: vec3f, n: u32) -> u32 {
    let a = abs(d);
    var face = 4u + select(1u, 0u, d.z > 0.0);
    var uv = d.xy / a.z;
    if a.x >= a.y && a.x >= a.z {
        face = select(1u, 0u, d.x > 0.0);
        uv = d.yz / a.x;
    } else if a.y >= a.z {
        face = 2u + select(1u, 0u, d.y > 0.0);
        uv = d.xz / a.y;
    }
    let i = vec2u(clamp(vec2i((uv * 0.5 + 0.5) * f32(n)), vec2i(0), vec2i(i32(n) - 1)));
    return face * n * n + i.y * n + i.x;
}

// The depth slab of a shadow segment `dist` long (`scene::Slabs::of`); `slabs` is the section's
// `[count, near (f32), 1 / log2(ratio) (f32), 0]`.
fn shell_slab(dist: f32, slabs: vec4u) -> u32 {
    let near = bitcast<f32>(slabs.y);
    if slabs.x <= 1u || dist <= near {
        return 0u;
    }
    return u32(clamp(ceil(log2(dist / near) * bitcast<f32>(slabs.z)), 0.0, f32(slabs.x - 1u)));
}

// The part (entry, exit) of the segment o + t l, t in [lo, hi], inside the box c ± half; entry >
// exit where it misses (`ShellObject::crosses_box`). A zero component of l is taken as 1e-20
// (the same side of each slab, without 0 × inf).
fn segment_box(o: vec3f, l: vec3f, lo: f32, hi: f32, c: vec3f, half: vec3f) -> vec2f {
    let inv = 1.0 / select(l, vec3f(1.0e-20), l == vec3f(0.0));
    let t0 = (c - half - o) * inv;
    let t1 = (c + half - o) * inv;
    let near = min(t0, t1);
    let far = max(t0, t1);
    return vec2f(max(lo, max(near.x, max(near.y, near.z))), min(hi, min(far.x, min(far.y, far.z))));
}

// Object `at` of a light-buffer list (object indices, four per texel from `list`).
fn shell_listed(list: u32, at: u32) -> u32 {
    return texel(list + at / 4u)[at % 4u];
}

// `s` with one more object's σ combined in.
fn shell_combine(s: f32, sigma: f32, product: bool) -> f32 {
    return select(min(s, sigma), s * sigma, product);
}

// Single-sample soft shadow (docs/shadows.md, Shell objects): one ray towards the light's
// centre. Whether the segment passes through a mesh comes from its triangles, tested in the
// object loop for a small mesh and by a walk of the grid for a large one (spheres and cones need
// no test: their shells know from the distance alone); every shell object of this light
// (`section`: its first texel, see layout.rs) listed for the ray gives σ and `s` combines them,
// each object once (objects not listed give 1). The light-buffer cell of the ray's direction
// lists its meshes, each with the run of its contour edges that segments in the cell can come
// near; the cell's depth slab of the ray's length lists its spheres, then its cones. Each kind
// has a loop of its own: lavapipe runs the whole body of a loop at every iteration
// (LAVAPIPE.md), so one loop would pay for the mesh code at every sphere. Once `s` is 0 no
// object can raise it (min or product of σ ∈ [0, 1]): the loops stop there, all lanes' alike (a
// group's loop ends with its last lane).
fn shell_visibility(o: vec3f, c: vec3f, light_r: f32, gap: f32, section: u32) -> f32 {
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
    let head = texel(section);
    let list = head.z;
    // [first mesh, end, first slab texel, 0] and the slab's [first, first cone, end, 0].
    let cell = texel(head.y + shell_cell(-l, head.w));
    let slab = texel(cell.z + shell_slab(dist, texel(section + 1u)));
    let objects = section + SHELL_HEADER_TEXELS;
    // Only meshes of more than SHELL_DIRECT_TRIANGLES triangles use the walk's answer; the
    // variant compiles it out where there are none (`Variant::shell_walk`). A hit on one lies
    // inside its bounding sphere, so the walk covers only the part of the segment inside the
    // bounds of the large meshes listed in the cell (none: no walk).
    var hit_tri = NO_HIT;
    if HAS_TRIANGLES && SHELL_WALK {
        var lo = dist;
        var hi = 0.0;
        for (var j = cell.x; j < cell.y; j += 3u) {
            loop_tick(LOOP_CANDIDATES);
            let k = shell_listed(list, j);
            let rec = texel(objects + 1u + SHELL_OBJECT_TEXELS * k);
            let bound = ftexel(objects + SHELL_OBJECT_TEXELS * k);
            let tc = dot(bound.xyz - o, l);
            let v = bound.xyz - (o + tc * l);
            // Grown by 0.1% for the f32 rounding of the bound and of tc.
            let h2 = bound.w * bound.w * 1.002 - dot(v, v);
            if rec.y - prim_index(rec.x) > SHELL_DIRECT_TRIANGLES && h2 > 0.0 {
                let h = sqrt(h2);
                lo = min(lo, tc - h);
                hi = max(hi, tc + h);
            }
        }
        lo = max(lo, 0.0);
        hi = min(hi, dist - gap);
        if lo < hi {
            let h = accel_walk(o, l, lo, hi, true, true);
            if h.prim != NO_HIT {
                hit_tri = prim_index(h.prim);
            }
        }
    }
    if HAS_SPHERES {
        for (var j = slab.x; j < slab.y && s > 0.0; j++) {
            loop_tick(LOOP_CANDIDATES);
            let bound = ftexel(objects + SHELL_OBJECT_TEXELS * shell_listed(list, j));
            s = shell_combine(s, sphere_shell(f, o, l, dist, light_r, bound.xyz, bound.w).x, product);
        }
    }
    if HAS_CONES {
        for (var j = slab.y; j < slab.z && s > 0.0; j++) {
            loop_tick(LOOP_CANDIDATES);
            let rec = texel(objects + 1u + SHELL_OBJECT_TEXELS * shell_listed(list, j));
            let cn = load_cone(prim_index(rec.x));
            s = shell_combine(s, cone_shell(f, o, l, dist, light_r, cn.base, cn.r0, cn.axis, cn.r1).x, product);
        }
    }
    if HAS_TRIANGLES {
        for (var j = cell.x; j < cell.y && s > 0.0; j += 3u) {
            loop_tick(LOOP_CANDIDATES);
            let k = shell_listed(list, j);
            let bound = ftexel(objects + SHELL_OBJECT_TEXELS * k);
            let rec = texel(objects + 1u + SHELL_OBJECT_TEXELS * k);
            // Its shell lies within its bounding sphere grown by the light's radius, and a
            // segment through one of its triangles passes through its bounding box. A small
            // mesh's triangles are tested here where the segment crosses its box (a floor under
            // the light: never for the points above it), a large one's hit comes from the walk.
            let first = prim_index(rec.x);
            let direct = rec.y - first <= SHELL_DIRECT_TRIANGLES;
            var inside = !direct && hit_tri >= first && hit_tri < rec.y;
            let tc = clamp(dot(bound.xyz - o, l), 0.0, dist);
            let near = length(bound.xyz - (o + tc * l)) < bound.w + light_r;
            let span = segment_box(o, l, 0.0, dist - gap, bound.xyz, ftexel(objects + 2u + SHELL_OBJECT_TEXELS * k).xyz);
            for (var i = first; i < select(first, rec.y, direct && span.x <= span.y); i++) {
                loop_tick(LOOP_CANDIDATES);
                let tri = load_triangle(i);
                inside = inside || intersect_triangle(o, l, tri.p0, tri.p1, tri.p2, 0.0, dist - gap).x != MISS;
            }
            var sigma = 1.0;
            if inside || near {
                sigma = mesh_shell(f, o, l, dist, light_r, inside, shell_listed(list, j + 1u), shell_listed(list, j + 2u));
            }
            s = shell_combine(s, sigma, product);
        }
    }
    return s;
}

// s for `light` seen from the offset origin `o`; `l` is the unit direction to its centre. A
// bundle is split over passes (`launch.pass_range`): each returns its samples' share of s. Every other
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
    if !bundle && launch.pass_range.z == 0u {
        return 0.0;
    }
    if kind == 0u || r == 0.0 {
        ray_counts.w += 1u;
        let dist = length(c - o);
        return select(1.0, 0.0, occluded(o, l, dist - gap));
    }
    if kind == 1u {
        let fr = basis(normalize(c - o));
        let k = params.shadow.y;
        let rotate = params.shadow.z != 0u;
        var seen = 0.0;
        for (var i = launch.pass_range.x; i < min(k, launch.pass_range.y); i++) {
            loop_tick(LOOP_LIGHTS);
            let x = bundle_point(i, bundle_seed, rotate);
            seen += ray_visibility(o, c + r * (x.x * fr.u + x.y * fr.v), gap);
        }
        return seen / f32(k);
    }
    return shell_visibility(o, c, r, gap, bitcast<u32>(light.color.w));
}
