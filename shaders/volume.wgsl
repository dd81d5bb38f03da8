// Volumes (PAPER.md §10): a volume's record and samples in the scene texture (src/gpu/layout/
// volume.rs), the walk of its min/max macrocells (twin: `accel::macrocells::Macrocells::walk`)
// and the isosurface of the trilinear interpolant inside one cell (twin: `scene::volume::
// cell_hit`, f64). Everything here runs only where `HAS_VOLUMES` lets `intersect_prim` call it.

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

// The cubic c's extrema in [0, 1], sorted (1 where it has fewer): the roots of c.y + 2 c.z s
// + 3 c.w s², each clamped into [0, 1].
fn cubic_extrema(c: vec4f) -> vec2f {
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
    return vec2f(s1, s2);
}

// The greatest value of the interpolant along a -> b (MIP): at an end or an extremum.
fn segment_max(c0: vec4f, c1: vec4f, a: vec3f, b: vec3f) -> f32 {
    let c = cell_cubic(c0, c1, a, b, 0.0);
    let x = cubic_extrema(c);
    return max(max(cubic_at(c, 0.0), cubic_at(c, 1.0)), max(cubic_at(c, x.x), cubic_at(c, x.y)));
}

// The first s in [0, 1] where the interpolant along a -> b equals iso, or MISS. The cubic comes
// from four of its values (Newton's form on 0, 1/3, 2/3, 1); its extrema split [0, 1] into
// monotone pieces (Marmitt et al. 2004), and the first piece that crosses iso is bisected.
// Lavapipe runs every branch and loop for all lanes, so the pieces are a fixed three and the
// bisection a fixed 24 steps (f32's mantissa).
fn cell_hit(c0: vec4f, c1: vec4f, a: vec3f, b: vec3f, iso: f32) -> f32 {
    let c = cell_cubic(c0, c1, a, b, iso);
    let x = cubic_extrema(c);
    let s1 = x.x;
    let s2 = x.y;
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

struct VolumeRec {
    m0: vec4f,
    m1: vec4f,
    m2: vec4f,
    dims: vec3u,
    kind: u32,
    samples: u32,
    isos: u32,
    levels: u32,
    // log2 of the bricks' edge (0: the file's order).
    brick: u32,
    level_base: vec3u,
    materials: vec4u,
    // The transfer function: the samples its table spans, and the table's first texel.
    window: vec2f,
    table: u32,
}

fn load_volume(v: u32) -> VolumeRec {
    let b = params.volume.x + v * VOLUME_TEXELS;
    let d = texel(b + 3u);
    let r = texel(b + 4u);
    let w = texel(b + 7u);
    return VolumeRec(ftexel(b), ftexel(b + 1u), ftexel(b + 2u), d.xyz, d.w, r.x, r.y, r.z, r.w, texel(b + 5u).xyz, texel(b + 6u), bitcast<vec2f>(w.xy), w.z);
}

// Volume v's look (`LOOK_*`), from the frame uniform: the window switches it live.
fn volume_look(v: u32) -> u32 {
    return (params.volume.z >> (2u * v)) & 3u;
}

// The transfer function at sample value x: linear RGB and opacity, linear between the table's
// entries, transparent below the window (twin: `Transfer::lookup`).
fn transfer_at(vol: VolumeRec, x: f32) -> vec4f {
    let s = (x - vol.window.x) / (vol.window.y - vol.window.x);
    let f = clamp(s, 0.0, 1.0) * f32(TRANSFER_ENTRIES - 1u);
    let i = min(u32(f), TRANSFER_ENTRIES - 2u);
    let e = mix(ftexel(vol.table + i), ftexel(vol.table + i + 1u), f - f32(i));
    return select(e, vec4f(e.rgb, 0.0), s <= 0.0);
}

// Grid index coordinates of the (origin-relative) world point p, and of a direction.
fn volume_point(vol: VolumeRec, p: vec3f) -> vec3f {
    return vec3f(dot(vol.m0.xyz, p) + vol.m0.w, dot(vol.m1.xyz, p) + vol.m1.w, dot(vol.m2.xyz, p) + vol.m2.w);
}

fn volume_dir(vol: VolumeRec, d: vec3f) -> vec3f {
    return vec3f(dot(vol.m0.xyz, d), dot(vol.m1.xyz, d), dot(vol.m2.xyz, d));
}

// Sample c, decoded from its type (`layout::volume::sample_code`: 0 u8, 1 u16, 2 i16, 3 f32).
// Bricks of 2^b a side lie x fastest, and the samples in each the same (b = 0 is one order for
// all: bricks of one sample).
fn volume_sample(vol: VolumeRec, c: vec3u) -> f32 {
    let b = vol.brick;
    let bricks = (vol.dims + vec3u((1u << b) - 1u)) >> vec3u(b);
    let o = c >> vec3u(b);
    let l = c - (o << vec3u(b));
    let i = ((o.x + bricks.x * (o.y + bricks.y * o.z)) << (3u * b)) + (l.x + ((l.y + (l.z << b)) << b));
    let shift = select(select(3u, 2u, vol.kind == 3u), 4u, vol.kind == 0u);
    let t = texel(vol.samples + (i >> shift));
    let w = t[(i >> (shift - 2u)) & 3u];
    let sub = i & ((1u << (shift - 2u)) - 1u);
    if vol.kind == 3u {
        return bitcast<f32>(w);
    }
    if vol.kind == 0u {
        return f32((w >> (8u * sub)) & 0xffu);
    }
    let h = (w >> (16u * sub)) & 0xffffu;
    if vol.kind == 2u {
        return f32(bitcast<i32>(h << 16u) >> 16u);
    }
    return f32(h);
}

// Cell c's corners as `trilinear` takes them: corners 0..3 (z = 0), then 4..7.
fn volume_corners(vol: VolumeRec, c: vec3u, z: u32) -> vec4f {
    let k = c + vec3u(0u, 0u, z);
    return vec4f(
        volume_sample(vol, k),
        volume_sample(vol, k + vec3u(1u, 0u, 0u)),
        volume_sample(vol, k + vec3u(0u, 1u, 0u)),
        volume_sample(vol, k + vec3u(1u, 1u, 0u))
    );
}

// The range of macrocell m of level l (spanning 4^(l+1) cells a side).
fn volume_range(vol: VolumeRec, l: u32, m: vec3u) -> vec2f {
    let s = 2u * (l + 1u);
    let dims = (vol.dims - 1u + vec3u((1u << s) - 1u)) >> vec3u(s);
    let i = m.x + dims.x * (m.y + dims.y * m.z);
    let t = ftexel(vol.level_base[l] + (i >> 1u));
    return select(t.xy, t.zw, (i & 1u) == 1u);
}

// Whether [lo, hi] holds one of volume v's isovalues.
fn volume_holds(r: vec2f, iso: vec4f, n: u32) -> bool {
    let inside = vec4<bool>(r.x <= iso.x && iso.x <= r.y, r.x <= iso.y && iso.y <= r.y, r.x <= iso.z && iso.z <= r.y, r.x <= iso.w && iso.w <= r.y);
    let used = vec4<bool>(n > 0u, n > 1u, n > 2u, n > 3u);
    return any(inside & used);
}

// Whether a walk in `look` may pass over a box of samples in [r.x, r.y] without looking in:
// it holds no isovalue (iso), cannot raise the greatest value found, acc.x (MIP), or is
// transparent (DVR: all of it at or below the transfer window).
fn volume_skips(r: vec2f, look: u32, iso: vec4f, n: u32, acc: vec4f, vol: VolumeRec) -> bool {
    if look == LOOK_ISO {
        return !volume_holds(r, iso, n);
    }
    if look == LOOK_MIP {
        return r.y <= acc.x;
    }
    return r.y <= vol.window.x;
}

// The first crossing of volume v's isosurfaces in (t_min, t_max): (t, which isovalue), t = MISS
// when there is none.
fn volume_hit(v: u32, o: vec3f, d: vec3f, t_min: f32, t_max: f32) -> vec2f {
    if volume_look(v) != LOOK_ISO {
        return vec2f(MISS, 0.0);
    }
    return volume_walk(v, o, d, t_min, t_max, LOOK_ISO).xy;
}

// Walks volume v along o + t d, t in (t_min, t_max), for its look. Iso: (the first crossing's t
// or MISS, which isovalue, 0, 0). MIP: (the greatest value, 0, 0, 1 if the ray met the volume,
// else 0). DVR: (the colour emitted towards o, premultiplied; the transmittance), samples every
// DVR_STEP cells from where the ray enters the box, stopped below DVR_EARLY_OUT.
//
// The ray moves into index coordinates (t is kept) and walks the cells; at each cell the
// coarsest macrocell holding it that `volume_skips` is passed over whole (its exit found from
// its faces, the next cell from the exit axis, so the walk always moves on), else the cell is
// looked into. No stack: a skip restarts the descent from the top, which costs a range load a
// level on lavapipe, where a stack indexed at run time costs more (../shared/LAVAPIPE.md).
fn volume_walk(v: u32, o: vec3f, d: vec3f, t_min: f32, t_max: f32, look: u32) -> vec4f {
    let vol = load_volume(v);
    let iso = params.iso[v];
    let q = volume_point(vol, o);
    let e0 = volume_dir(vol, d);
    let e = select(e0, vec3f(1e-30), e0 == vec3f(0.0));
    let inv = 1.0 / e;
    let cells = vol.dims - 1u;
    let slabs = volume_slabs(vol, q, inv);
    let t0 = max(t_min, slabs.x);
    let t1 = min(t_max, slabs.y);
    var acc = select(vec4f(MISS, 0.0, 0.0, 0.0), vec4f(0.0, 0.0, 0.0, 1.0), look == LOOK_DVR);
    if look == LOOK_MIP {
        acc = vec4f(-3.0e38, 0.0, 0.0, 0.0);
    }
    if !(t0 < t1) {
        return acc;
    }
    if look == LOOK_MIP {
        acc.w = 1.0;
    }
    // DVR's samples: t0 + (k + 1/2) dt.
    let dt = DVR_STEP / length(e0);
    let step = vec3i(select(vec3i(-1), vec3i(1), e > vec3f(0.0)));
    let last = vec3i(cells) - 1;
    var cell = clamp(vec3i(floor(q + e * t0)), vec3i(0), last);
    var t = t0;
    let bound = cells.x + cells.y + cells.z + 3u;
    for (var n = 0u; n < bound; n++) {
        loop_iters += 1u;
        if any(cell < vec3i(0)) || any(cell > last) || t >= t1 {
            break;
        }
        // The coarsest level whose macrocell here may be passed over: its span's shift, or 0.
        var skip = 0u;
        for (var l = vol.levels; l > 0u; l--) {
            let s = 2u * l;
            if volume_skips(volume_range(vol, l - 1u, vec3u(cell) >> vec3u(s)), look, iso, vol.isos, acc, vol) {
                skip = s;
                break;
            }
        }
        let lo = (cell >> vec3u(skip)) << vec3u(skip);
        let hi = min(lo + vec3i((1 << skip) - 1), last);
        let faces = vec3f(select(lo, hi + 1, step > vec3i(0)));
        let tf = (faces - q) * inv;
        let t_exit = min(min(tf.x, tf.y), tf.z);
        if skip == 0u {
            let c = vec3u(cell);
            let c0 = volume_corners(vol, c, 0u);
            let c1 = volume_corners(vol, c, 1u);
            let r = vec2f(min(min(c0, c1).x, min(min(c0, c1).y, min(min(c0, c1).z, min(c0, c1).w))), max(max(c0, c1).x, max(max(c0, c1).y, max(max(c0, c1).z, max(c0, c1).w))));
            if !volume_skips(r, look, iso, vol.isos, acc, vol) {
                let tb = min(t_exit, t1);
                let a = clamp(q + e * t - vec3f(c), vec3f(0.0), vec3f(1.0));
                let b = clamp(q + e * tb - vec3f(c), vec3f(0.0), vec3f(1.0));
                if look == LOOK_ISO {
                    var best = MISS;
                    var which = 0u;
                    for (var k = 0u; k < vol.isos; k++) {
                        let s = cell_hit(c0, c1, a, b, iso[k]);
                        if s != MISS {
                            let th = t + (tb - t) * s;
                            if th > t_min && (best == MISS || th < best) {
                                best = th;
                                which = k;
                            }
                        }
                    }
                    if best != MISS {
                        return vec4f(best, f32(which), 0.0, 0.0);
                    }
                } else if look == LOOK_MIP {
                    acc.x = max(acc.x, segment_max(c0, c1, a, b));
                } else {
                    // The samples in [t, tb): at most DVR_CELL_SAMPLES of them (a cell's
                    // diagonal is √3 cells), the same k's a neighbouring cell would count.
                    let k0 = ceil((t - t0) / dt - 0.5);
                    let k1 = ceil((tb - t0) / dt - 0.5);
                    for (var j = 0u; j < DVR_CELL_SAMPLES; j++) {
                        let k = k0 + f32(j);
                        if k < k1 {
                            let p = clamp(q + e * (t0 + (k + 0.5) * dt) - vec3f(c), vec3f(0.0), vec3f(1.0));
                            let f = transfer_at(vol, trilinear(c0, c1, p));
                            let alpha = 1.0 - pow(1.0 - f.a, DVR_STEP);
                            acc = vec4f(acc.rgb + (acc.w * alpha) * f.rgb, acc.w * (1.0 - alpha));
                        }
                    }
                    if acc.w < DVR_EARLY_OUT {
                        return acc;
                    }
                }
            }
        }
        // On to the cell beyond the exit face; the other axes stay within the box left.
        let p = floor(q + e * t_exit);
        var next = clamp(vec3i(p), lo, hi);
        if tf.x <= tf.y && tf.x <= tf.z {
            next.x = select(lo.x - 1, hi.x + 1, step.x > 0);
        } else if tf.y <= tf.z {
            next.y = select(lo.y - 1, hi.y + 1, step.y > 0);
        } else {
            next.z = select(lo.z - 1, hi.z + 1, step.z > 0);
        }
        cell = next;
        t = max(t, t_exit);
    }
    return acc;
}

// What the volumes drawn by MIP or DVR do to o + t d up to t_max: (what they emit towards o,
// what share of the light from behind them gets through), so that the ray brings back
// emitted + share × what lies behind. Each volume goes over the ones behind it, in the order
// the ray enters their boxes (twin: `reference::trace`'s `through_volumes`).
fn through_volumes(o: vec3f, d: vec3f, t_max: f32) -> vec4f {
    var acc = vec4f(0.0, 0.0, 0.0, 1.0);
    var done = 0u;
    for (var n = 0u; n < params.volume.y; n++) {
        loop_iters += 1u;
        // The farthest volume not composited yet.
        var far = NO_HIT;
        var far_t = -3.0e38;
        for (var v = 0u; v < params.volume.y; v++) {
            if volume_look(v) != LOOK_ISO && ((done >> v) & 1u) == 0u {
                let te = volume_entry(v, o, d);
                if te >= far_t {
                    far = v;
                    far_t = te;
                }
            }
        }
        if far == NO_HIT {
            break;
        }
        done |= 1u << far;
        let look = volume_look(far);
        var r = volume_walk(far, o, d, 0.0, t_max, look);
        if look == LOOK_MIP {
            let f = transfer_at(load_volume(far), r.x);
            let a = select(0.0, f.a, r.w > 0.0);
            r = vec4f(a * f.rgb, 1.0 - a);
        }
        acc = vec4f(r.rgb + r.w * acc.rgb, r.w * acc.w);
    }
    return acc;
}

// The ray's distances (index point q, inverse index direction inv) to where it enters and
// leaves the volume's box of cells, unclipped.
fn volume_slabs(vol: VolumeRec, q: vec3f, inv: vec3f) -> vec2f {
    let fa = -q * inv;
    let fb = (vec3f(vol.dims - 1u) - q) * inv;
    let near = min(fa, fb);
    let far = max(fa, fb);
    return vec2f(max(max(near.x, near.y), near.z), min(min(far.x, far.y), far.z));
}

// Where o + t d enters volume v's box (the walk clips for itself).
fn volume_entry(v: u32, o: vec3f, d: vec3f) -> f32 {
    let vol = load_volume(v);
    let e0 = volume_dir(vol, d);
    return volume_slabs(vol, volume_point(vol, o), 1.0 / select(e0, vec3f(1e-30), e0 == vec3f(0.0))).x;
}

// The outward normal (towards smaller values: the solid is where the samples exceed the
// isovalue) at the world point p of volume v, from the interpolant's gradient.
fn volume_normal(v: u32, p: vec3f) -> vec3f {
    let vol = load_volume(v);
    let x = volume_point(vol, p);
    let c = vec3u(clamp(vec3i(floor(x)), vec3i(0), vec3i(vol.dims - 2u)));
    let u = clamp(x - vec3f(c), vec3f(0.0), vec3f(1.0));
    let c0 = volume_corners(vol, c, 0u);
    let c1 = volume_corners(vol, c, 1u);
    // d/du, d/dv, d/dw of the trilinear interpolant.
    let y0 = mix(c0, c1, u.z);
    let du = mix(y0.y - y0.x, y0.w - y0.z, u.y);
    let dv = mix(y0.z - y0.x, y0.w - y0.y, u.x);
    let x0 = mix(c0.xz, c0.yw, u.x);
    let x1 = mix(c1.xz, c1.yw, u.x);
    let dw = mix(x1.x - x0.x, x1.y - x0.y, u.y);
    let g = vec3f(du, dv, dw);
    return -(vol.m0.xyz * g.x + vol.m1.xyz * g.y + vol.m2.xyz * g.z);
}
