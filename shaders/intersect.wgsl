// Ray–primitive intersection. CPU twins: src/reference (same names).

// Nearest root of |o + t d - c| = r in (t_min, t_max), or MISS. `d` must be unit length.
// The discriminant is r² - |oc - (oc·d) d|² (Ray Tracing Gems, ch. 7), which keeps its
// precision when the sphere is small and far away, unlike b² - c.
fn intersect_sphere(o: vec3f, d: vec3f, c: vec3f, r: f32, t_min: f32, t_max: f32) -> f32 {
    let f = o - c;
    let b = -dot(f, d);
    let q = f + b * d;
    let disc = r * r - dot(q, q);
    if disc < 0.0 {
        return MISS;
    }
    // Roots without cancellation: t0 * t1 = |f|² - r².
    let s = select(-1.0, 1.0, b >= 0.0);
    let qq = b + s * sqrt(disc);
    let cc = dot(f, f) - r * r;
    var t0 = select(cc / qq, 0.0, qq == 0.0);
    var t1 = qq;
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
    return MISS;
}

// Möller–Trumbore, two-sided. Returns (t, b1, b2) with b1, b2 the barycentrics of p1 and p2,
// or t = MISS. Zero-area triangles never hit (det == 0).
fn intersect_triangle(o: vec3f, d: vec3f, p0: vec3f, p1: vec3f, p2: vec3f, t_min: f32, t_max: f32) -> vec3f {
    let e1 = p1 - p0;
    let e2 = p2 - p0;
    let pv = cross(d, e2);
    let det = dot(e1, pv);
    if det == 0.0 {
        return vec3f(MISS, 0.0, 0.0);
    }
    let inv = 1.0 / det;
    let tv = o - p0;
    let b1 = dot(tv, pv) * inv;
    if b1 < 0.0 || b1 > 1.0 {
        return vec3f(MISS, 0.0, 0.0);
    }
    let qv = cross(tv, e1);
    let b2 = dot(d, qv) * inv;
    if b2 < 0.0 || b1 + b2 > 1.0 {
        return vec3f(MISS, 0.0, 0.0);
    }
    let t = dot(e2, qv) * inv;
    if t > t_min && t < t_max {
        return vec3f(t, b1, b2);
    }
    return vec3f(MISS, 0.0, 0.0);
}

// Nearest t in (t_min, t_max) where o + t d meets the open cone (no caps) from `base` (radius r0)
// to `base + axis` (radius r1), or MISS. `d` must be unit length. The method of the f64 twin:
// the origin first moved to the ray's closest approach to the axis midpoint (small coefficients
// for distant origins), the discriminant by Lagrange's identity |r q_d - k (d·a) q_o|² -
// |q_o × q_d|² (no difference of large products), both roots without cancellation, nearer
// first, each kept only where its axial position lies on the cone. A vanishing quadratic term
// (ray parallel to a cylinder's axis or to a cone's generating line) leaves the linear root.
fn intersect_cone(o: vec3f, d: vec3f, base: vec3f, r0: f32, axis: vec3f, r1: f32, t_min: f32, t_max: f32) -> f32 {
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
        return MISS;
    }
    let q = -(qb + select(-1.0, 1.0, qb >= 0.0) * sqrt(disc));
    var lo = 0.0;
    var hi = 0.0;
    if q != 0.0 {
        let ra = qc / q;
        let rb = select(ra, q / qa, qa != 0.0);
        lo = min(ra, rb);
        hi = max(ra, rb);
    } else if qa == 0.0 {
        return MISS;
    }
    let s_lo = s0 + lo * da;
    if s_lo >= 0.0 && s_lo <= h && tc + lo > t_min && tc + lo < t_max {
        return tc + lo;
    }
    let s_hi = s0 + hi * da;
    if s_hi >= 0.0 && s_hi <= h && tc + hi > t_min && tc + hi < t_max {
        return tc + hi;
    }
    return MISS;
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

// Primitive reference `r` (kind in the top bits): (t, b1, b2) or t = MISS.
fn intersect_prim(r: u32, o: vec3f, d: vec3f, t_min: f32, t_max: f32) -> vec3f {
    let i = prim_index(r);
    if HAS_SPHERES && prim_kind(r) == PRIM_SPHERE {
        let s = load_sphere(i);
        return vec3f(intersect_sphere(o, d, s.xyz, s.w, t_min, t_max), 0.0, 0.0);
    }
    if HAS_TRIANGLES && prim_kind(r) == PRIM_TRIANGLE {
        let tri = load_triangle(i);
        return intersect_triangle(o, d, tri.p0, tri.p1, tri.p2, t_min, t_max);
    }
    if HAS_CONES && prim_kind(r) == PRIM_CONE {
        let c = load_cone(i);
        return vec3f(intersect_cone(o, d, c.base, c.r0, c.axis, c.r1, t_min, t_max), 0.0, 0.0);
    }
    return vec3f(MISS, 0.0, 0.0);
}
