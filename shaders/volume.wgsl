// Volumes (PAPER.md §10): the isosurface of the trilinear interpolant inside one cell. Twin of
// `scene::volume::cell_hit` (f64). Compiled only into programs that trace volumes (for now the
// readback kernels: the walk and the volume's data on the device come next).

// The trilinear interpolant of corners c0 (bit 0 = +x, bit 1 = +y, bit 2 = +z) at p in [0, 1]³.
fn trilinear(c0: vec4f, c1: vec4f, p: vec3f) -> f32 {
    // c0 = corners 0..3 (z = 0), c1 = corners 4..7 (z = 1).
    let y0 = mix(c0.xz, c0.yw, p.x); // (z0,y0), (z0,y1) along x
    let y1 = mix(c1.xz, c1.yw, p.x);
    return mix(mix(y0.x, y0.y, p.y), mix(y1.x, y1.y, p.y), p.z);
}

// The cubic c.x + c.y s + c.z s² + c.w s³ at s.
fn cubic_at(c: vec4f, s: f32) -> f32 {
    return c.x + s * (c.y + s * (c.z + s * c.w));
}

// The cubic along a -> b, less iso, from four of its values (Newton's form on 0, 1/3, 2/3, 1).
fn cell_cubic(c0: vec4f, c1: vec4f, a: vec3f, b: vec3f, iso: f32) -> vec4f {
    let e = b - a;
    let v0 = trilinear(c0, c1, a) - iso;
    let v1 = trilinear(c0, c1, a + e * (1.0 / 3.0)) - iso;
    let v2 = trilinear(c0, c1, a + e * (2.0 / 3.0)) - iso;
    let v3 = trilinear(c0, c1, b) - iso;
    let d1 = 3.0 * (v1 - v0);
    let d2 = 4.5 * (v2 - 2.0 * v1 + v0);
    let d3 = 4.5 * (v3 - 3.0 * v2 + 3.0 * v1 - v0);
    return vec4f(v0, d1 - d2 / 3.0 + d3 * (2.0 / 9.0), d2 - d3, d3);
}

// The first s in [0, 1] where the interpolant along a -> b equals iso, or MISS. The cubic comes
// from four of its values (Newton's form on 0, 1/3, 2/3, 1); its extrema split [0, 1] into
// monotone pieces (Marmitt et al. 2004), and the first piece that crosses iso is bisected.
// Lavapipe runs every branch and loop for all lanes, so the pieces are a fixed three and the
// bisection a fixed 24 steps (f32's mantissa).
fn cell_hit(c0: vec4f, c1: vec4f, a: vec3f, b: vec3f, iso: f32) -> f32 {
    let c = cell_cubic(c0, c1, a, b, iso);
    // Extrema: roots of c.y + 2 c.z s + 3 c.w s², sorted, each clamped into [0, 1].
    var s1 = 1.0;
    var s2 = 1.0;
    let qa = 3.0 * c.w;
    let qb = 2.0 * c.z;
    let disc = qb * qb - 4.0 * qa * c.y;
    if abs(qa) > 1e-30 && disc >= 0.0 {
        let q = -0.5 * (qb + select(-1.0, 1.0, qb >= 0.0) * sqrt(disc));
        let r1 = q / qa;
        let r2 = select(1.0, c.y / q, q != 0.0);
        s1 = clamp(min(r1, r2), 0.0, 1.0);
        s2 = clamp(max(r1, r2), 0.0, 1.0);
    } else if abs(qa) <= 1e-30 && qb != 0.0 {
        s1 = clamp(-c.y / qb, 0.0, 1.0);
    }
    let cuts = array<f32, 4>(0.0, s1, s2, 1.0);
    var lo = 1.0;
    var hi = 1.0;
    var flo = 0.0;
    var found = false;
    for (var k = 0u; k < 3u; k++) {
        let f0 = cubic_at(c, cuts[k]);
        let f1 = cubic_at(c, cuts[k + 1u]);
        let crosses = f0 == 0.0 || sign(f0) != sign(f1);
        if !found && crosses {
            found = true;
            lo = cuts[k];
            hi = cuts[k + 1u];
            flo = f0;
        }
    }
    if !found {
        return MISS;
    }
    if flo == 0.0 {
        return lo;
    }
    for (var k = 0u; k < 24u; k++) {
        let mid = 0.5 * (lo + hi);
        let same = sign(cubic_at(c, mid)) == sign(flo);
        lo = select(lo, mid, same);
        hi = select(mid, hi, same);
    }
    return 0.5 * (lo + hi);
}

// The same crossing by the closed form (Cardano, or the trigonometric form for three real
// roots): the alternative to cell_hit that the readback test measures against it in f32
// (docs/volumes.md). Not used to trace.
fn cell_hit_closed_form(c0: vec4f, c1: vec4f, a: vec3f, b: vec3f, iso: f32) -> f32 {
    let c = cell_cubic(c0, c1, a, b, iso);
    let scale = max(max(abs(c.x), abs(c.y)), max(abs(c.z), abs(c.w)));
    var roots = array<f32, 3>(2.0, 2.0, 2.0);
    // Nearly quadratic: dividing by a small c.w loses f32's digits. Of the thresholds 1e-6 to
    // 1e-1 of the largest coefficient, 1e-3 gave the smallest worst error (docs/volumes.md).
    if abs(c.w) <= 1e-3 * scale {
        if abs(c.z) <= 1e-6 * scale {
            roots[0] = select(2.0, -c.x / c.y, c.y != 0.0);
        } else {
            let disc = c.y * c.y - 4.0 * c.z * c.x;
            if disc >= 0.0 {
                let q = -0.5 * (c.y + select(-1.0, 1.0, c.y >= 0.0) * sqrt(disc));
                roots[0] = q / c.z;
                roots[1] = select(2.0, c.x / q, q != 0.0);
            }
        }
    } else {
        let p3 = c.z / c.w;
        let p2 = c.y / c.w;
        let p1 = c.x / c.w;
        let p = p2 - p3 * p3 / 3.0;
        let q = 2.0 * p3 * p3 * p3 / 27.0 - p3 * p2 / 3.0 + p1;
        let disc = q * q / 4.0 + p * p * p / 27.0;
        let shift = -p3 / 3.0;
        if disc > 0.0 {
            let r = sqrt(disc);
            let u = -0.5 * q + r;
            let v = -0.5 * q - r;
            roots[0] = sign(u) * pow(abs(u), 1.0 / 3.0) + sign(v) * pow(abs(v), 1.0 / 3.0) + shift;
        } else {
            let m = 2.0 * sqrt(max(-p / 3.0, 0.0));
            let arg = select(0.0, clamp(3.0 * q / (p * m), -1.0, 1.0), p != 0.0);
            let phi = acos(arg) / 3.0;
            for (var k = 0u; k < 3u; k++) {
                roots[k] = m * cos(phi - 2.0943951 * f32(k)) + shift;
            }
        }
    }
    var first = MISS;
    for (var k = 0u; k < 3u; k++) {
        let r = roots[k];
        if r >= 0.0 && r <= 1.0 && (first == MISS || r < first) {
            first = r;
        }
    }
    return first;
}
