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

// The first s in [0, 1] where the interpolant along a -> b equals iso, or MISS. The cubic comes
// from four of its values (Newton's form on 0, 1/3, 2/3, 1); its extrema split [0, 1] into
// monotone pieces (Marmitt et al. 2004), and the first piece that crosses iso is bisected.
// Lavapipe runs every branch and loop for all lanes, so the pieces are a fixed three and the
// bisection a fixed 24 steps (f32's mantissa).
fn cell_hit(c0: vec4f, c1: vec4f, a: vec3f, b: vec3f, iso: f32) -> f32 {
    let e = b - a;
    let v0 = trilinear(c0, c1, a) - iso;
    let v1 = trilinear(c0, c1, a + e * (1.0 / 3.0)) - iso;
    let v2 = trilinear(c0, c1, a + e * (2.0 / 3.0)) - iso;
    let v3 = trilinear(c0, c1, b) - iso;
    let d1 = 3.0 * (v1 - v0);
    let d2 = 4.5 * (v2 - 2.0 * v1 + v0);
    let d3 = 4.5 * (v3 - 3.0 * v2 + 3.0 * v1 - v0);
    let c = vec4f(v0, d1 - d2 / 3.0 + d3 * (2.0 / 9.0), d2 - d3, d3);
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
