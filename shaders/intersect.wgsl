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
    return vec3f(MISS, 0.0, 0.0);
}
