// Ray–primitive intersection. CPU twins: src/reference (same names).

// Nearest root of |o + t d - c| = r in (t_min, t_max), or MISS; `d` unit length, `a` a point on
// the sphere (its anchor: the point nearest the eye, computed in f64 on the host). Everything is
// measured from the anchor, g = o - a, with f = o - c = g + r n_a:
//   disc = r² - |f⊥|² = r² (n_a·d)² - 2r (g⊥·n_a) - |g⊥|²     (⊥: perpendicular to d)
//   t0 t1 = |f|² - r² = |g|² + 2r (n_a·g)
// so no term is a difference of two large numbers: for a small, distant sphere this is Ray
// Tracing Gems ch. 7's r² - |f⊥|², and for a sphere far larger than the view (a planet-sized
// ground) its numbers stay near the hit, where f32 centre-based forms lose metres.
// In `real` arithmetic: f32, or f64 in the f64 pipeline variant.
fn intersect_sphere_r(o: vec3r, d: vec3r, c: vec3r, r: real, a: vec3r, t_min: real, t_max: real) -> real {
    let na = (a - c) / r;
    let g = o - a;
    let gd = dot(g, d);
    let nd = dot(na, d);
    let gp = g - gd * d;
    let disc = r * r * nd * nd - 2.0 * r * dot(gp, na) - dot(gp, gp);
    if disc < 0.0 {
        return real(MISS);
    }
    let fd = gd + r * nd;
    let cc = dot(g, g) + 2.0 * r * dot(na, g);
    // Roots of t² + 2 fd t + cc = 0 without cancellation.
    let s = sqrt(disc);
    let q = -(fd + select(-s, s, fd >= 0.0));
    var t0 = select(cc / q, 0.0, q == 0.0);
    var t1 = q;
    if t0 > t1 {
        let tmp = t0;
        t0 = t1;
        t1 = tmp;
    }
    if t0 > t_min && t0 < t_max {
        return t0;
    }
    if t1 > t_min && t1 < t_max {
        return t1;
    }
    return real(MISS);
}

fn intersect_sphere(o: vec3f, d: vec3f, c: vec3f, r: f32, a: vec3f, t_min: f32, t_max: f32) -> f32 {
    return f32(intersect_sphere_r(vec3r(o), vec3r(d), vec3r(c), real(r), vec3r(a), real(t_min), real(t_max)));
}

// Watertight ray–triangle test (Woop, Benthin & Wald, JCGT 2013), two-sided. The vertices are
// moved into a ray-aligned frame (a permutation and a shear that make the ray the +z axis), where
// each edge's 2D edge function depends only on its two vertices: the triangles on both sides of a
// shared edge compute it from the same numbers with opposite signs, so a ray through the edge or
// a shared vertex hits at least one of them. Returns (t, b1, b2) with b1, b2 the barycentrics of
// p1 and p2, or t = MISS. Zero-area triangles never hit (det == 0).
// In `real` arithmetic: f32, or f64 in the f64 pipeline variant.
fn intersect_triangle_r(o: vec3r, d: vec3r, p0: vec3r, p1: vec3r, p2: vec3r, t_min: real, t_max: real) -> vec3r {
    let ad = abs(d);
    var kz = 2;
    if ad.x >= ad.y && ad.x >= ad.z {
        kz = 0;
    } else if ad.y >= ad.z {
        kz = 1;
    }
    var kx = (kz + 1) % 3;
    var ky = (kx + 1) % 3;
    // Keep the winding: swapping x and y when the ray points down its main axis.
    if d[kz] < 0.0 {
        let k = kx;
        kx = ky;
        ky = k;
    }
    let sz = 1.0 / d[kz];
    let sx = d[kx] * sz;
    let sy = d[ky] * sz;
    let a = p0 - o;
    let b = p1 - o;
    let c = p2 - o;
    let ax = a[kx] - sx * a[kz];
    let ay = a[ky] - sy * a[kz];
    let bx = b[kx] - sx * b[kz];
    let by = b[ky] - sy * b[kz];
    let cx = c[kx] - sx * c[kz];
    let cy = c[ky] - sy * c[kz];
    let u = cx * by - cy * bx;
    let v = ax * cy - ay * cx;
    let w = bx * ay - by * ax;
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return vec3r(real(MISS), 0.0, 0.0);
    }
    let det = u + v + w;
    if det == 0.0 {
        return vec3r(real(MISS), 0.0, 0.0);
    }
    let tt = sz * (u * a[kz] + v * b[kz] + w * c[kz]);
    let inv = 1.0 / det;
    let t = tt * inv;
    if t > t_min && t < t_max {
        return vec3r(t, v * inv, w * inv);
    }
    return vec3r(real(MISS), 0.0, 0.0);
}

fn intersect_triangle(o: vec3f, d: vec3f, p0: vec3f, p1: vec3f, p2: vec3f, t_min: f32, t_max: f32) -> vec3f {
    return vec3f(intersect_triangle_r(vec3r(o), vec3r(d), vec3r(p0), vec3r(p1), vec3r(p2), real(t_min), real(t_max)));
}

// Nearest t in (t_min, t_max) where o + t d meets the open cone (no caps) from `base` (radius r0)
// to `base + axis` (radius r1), or MISS. `d` must be unit length. The method of the f64 twin:
// the origin first moved to the ray's closest approach to the axis midpoint (small coefficients
// for distant origins), the discriminant by Lagrange's identity |r q_d - k (d·a) q_o|² -
// |q_o × q_d|² (no difference of large products), both roots without cancellation, nearer
// first, each kept only where its axial position lies on the cone. A vanishing quadratic term
// (ray parallel to a cylinder's axis or to a cone's generating line) leaves the linear root.
// In `real` arithmetic: f32, or f64 in the f64 pipeline variant.
fn intersect_cone_r(o: vec3r, d: vec3r, base: vec3r, r0: real, axis: vec3r, r1: real, t_min: real, t_max: real) -> real {
    let h = length(axis);
    let a = axis / h;
    let k = (r1 - r0) / h;
    let tc = dot(base + 0.5 * axis - o, d);
    let co = o + tc * d - base;
    let s0 = dot(co, a);
    let da = dot(d, a);
    let qo = co - s0 * a;
    let qd = d - da * a;
    let ro = r0 + k * s0;
    let qa = dot(qd, qd) - k * k * da * da;
    let qb = dot(qo, qd) - k * ro * da;
    let qc = dot(qo, qo) - ro * ro;
    let w = ro * qd - k * da * qo;
    let x = cross(qo, qd);
    let disc = dot(w, w) - dot(x, x);
    if disc < 0.0 {
        return real(MISS);
    }
    let q = -(qb + select(real(-1.0), real(1.0), qb >= 0.0) * sqrt(disc));
    var lo = real(0.0);
    var hi = real(0.0);
    if q != 0.0 {
        let ra = qc / q;
        let rb = select(ra, q / qa, qa != 0.0);
        lo = min(ra, rb);
        hi = max(ra, rb);
    } else if qa == 0.0 {
        return real(MISS);
    }
    let s_lo = s0 + lo * da;
    if s_lo >= 0.0 && s_lo <= h && tc + lo > t_min && tc + lo < t_max {
        return tc + lo;
    }
    let s_hi = s0 + hi * da;
    if s_hi >= 0.0 && s_hi <= h && tc + hi > t_min && tc + hi < t_max {
        return tc + hi;
    }
    return real(MISS);
}

fn intersect_cone(o: vec3f, d: vec3f, base: vec3f, r0: f32, axis: vec3f, r1: f32, t_min: f32, t_max: f32) -> f32 {
    return f32(intersect_cone_r(vec3r(o), vec3r(d), vec3r(base), real(r0), vec3r(axis), real(r1), real(t_min), real(t_max)));
}

// Unit outward normal of that cone at the surface point p: away from the axis, tilted by the
// radius's slope; along the axis at a pointed tip.
fn cone_normal(p: vec3f, base: vec3f, r0: f32, axis: vec3f, r1: f32) -> vec3f {
    let h = length(axis);
    let a = axis / h;
    let v = p - base;
    let away = v - dot(v, a) * a;
    let len = length(away);
    let u = select(vec3f(0.0), away / len, len > 0.0);
    return normalize(u - ((r1 - r0) / h) * a);
}

// A ray's hit: distance, primitive reference (NO_HIT: none), barycentrics b1, b2 on triangles
// (on a patch, its piece's (u, v)).
struct Hit {
    t: f32,
    prim: u32,
    b1: f32,
    b2: f32,
}

// Primitive reference `r` (kind in the top bits): (t, b1, b2) or t = MISS.
fn intersect_prim(r: u32, o: vec3f, d: vec3f, t_min: f32, t_max: f32) -> vec3f {
    let i = prim_index(r);
    if HAS_SPHERES && prim_kind(r) == PRIM_SPHERE {
        let s = load_sphere(i);
        return vec3f(intersect_sphere(o, d, s.xyz, s.w, sphere_anchor(i), t_min, t_max), 0.0, 0.0);
    }
    if HAS_TRIANGLES && prim_kind(r) == PRIM_TRIANGLE {
        let tri = load_triangle(i);
        return intersect_triangle(o, d, tri.p0, tri.p1, tri.p2, t_min, t_max);
    }
    if HAS_CONES && prim_kind(r) == PRIM_CONE {
        let c = load_cone(i);
        return vec3f(intersect_cone(o, d, c.base, c.r0, c.axis, c.r1, t_min, t_max), 0.0, 0.0);
    }
    if HAS_VOLUMES && prim_kind(r) == PRIM_VOLUME {
        // b1: which of the volume's isovalues was met.
        let h = volume_hit(i, o, d, t_min, t_max);
        return vec3f(h.x, h.y, 0.0);
    }
    if HAS_PATCHES && prim_kind(r) == PRIM_PATCH {
        // b1, b2: the hit's (u, v) in its piece.
        return intersect_patch(i, o, d, t_min, t_max);
    }
    return vec3f(MISS, 0.0, 0.0);
}
