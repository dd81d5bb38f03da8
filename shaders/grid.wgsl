// Grid traversal: a 3D DDA (Amanatides & Woo) over the uniform grid, skipping the cell loads of
// empty macro-cells. The walker state is a struct so the test kernels step the very same code.

struct Dda {
    cell: vec3i,
    step: vec3i,
    // Cell index per axis at which the ray has left the grid.
    out: vec3i,
    // Ray parameter at which the ray crosses the next cell boundary, per axis.
    t_next: vec3r,
    t_delta: vec3r,
    // The ray segment clipped to the grid box.
    t_enter: real,
    t_leave: real,
}

// Sets up the walk of o + t d, t in [t_min, t_max]; returns false if the segment misses the grid.
// Direction components may be exactly ±0: such an axis is never stepped. Computed in `real`
// (f32, or f64 in the f64 pipeline variant).
fn dda_init(o_in: vec3f, d_in: vec3f, t_min_in: f32, t_max_in: f32, s: ptr<function, Dda>) -> bool {
    let o = vec3r(o_in);
    let d = vec3r(d_in);
    let t_min = real(t_min_in);
    let t_max = real(t_max_in);
    let gmin = vec3r(params.accel_min.xyz);
    let gmax = vec3r(params.accel_max.xyz);
    let res = vec3i(params.cells.xyz);
    let moving = d_in != vec3f(0.0);
    let inv_d = select(vec3r(0.0), 1.0 / d, moving);
    let ta = (gmin - o) * inv_d;
    let tb = (gmax - o) * inv_d;
    let t_lo = select(vec3r(real(-BIG)), min(ta, tb), moving);
    let t_hi = select(vec3r(real(BIG)), max(ta, tb), moving);
    if any(!moving & ((o < gmin) | (o > gmax))) {
        return false;
    }
    let t0 = max(t_min, max(max(t_lo.x, t_lo.y), t_lo.z));
    let t1 = min(t_max, min(min(t_hi.x, t_hi.y), t_hi.z));
    if t0 > t1 {
        return false;
    }
    let p = o + d * t0;
    let cell = clamp(vec3i(floor((p - gmin) * vec3r(params.inv_cell.xyz))), vec3i(0), res - 1);
    let positive = d_in > vec3f(0.0);
    let boundary = gmin + vec3r(cell + select(vec3i(0), vec3i(1), positive)) * vec3r(params.cell.xyz);
    (*s).cell = cell;
    (*s).step = select(vec3i(-1), vec3i(1), positive);
    (*s).out = select(vec3i(-1), res, positive);
    (*s).t_next = select(vec3r(real(BIG)), (boundary - o) * inv_d, moving);
    (*s).t_delta = select(vec3r(real(BIG)), vec3r(params.cell.xyz) * abs(inv_d), moving);
    (*s).t_enter = t0;
    (*s).t_leave = t1;
    return true;
}

// Ray parameter at which the walk leaves the current cell.
fn dda_cell_exit(s: ptr<function, Dda>) -> real {
    let t = (*s).t_next;
    return min(min(t.x, t.y), t.z);
}

// Moves to the next cell along the ray; false once the ray has left the grid or its segment.
fn dda_step(s: ptr<function, Dda>) -> bool {
    let t = (*s).t_next;
    if min(min(t.x, t.y), t.z) >= (*s).t_leave {
        return false;
    }
    var axis = 2;
    if t.x <= t.y && t.x <= t.z {
        axis = 0;
    } else if t.y <= t.z {
        axis = 1;
    }
    (*s).cell[axis] += (*s).step[axis];
    (*s).t_next[axis] += (*s).t_delta[axis];
    return (*s).cell[axis] != (*s).out[axis];
}

fn cell_linear(c: vec3i) -> u32 {
    let res = params.cells;
    return u32(c.x) + res.x * (u32(c.y) + res.y * u32(c.z));
}

// The macro factor is a constant (accel::grid::MACRO_FACTOR), not a run-time value: lavapipe has
// no vector integer divide, so a divisor known only at run time costs eight scalar divides per
// axis and SIMD group on every step of the walk (docs/performance.md, "The walk's loop on
// lavapipe").
fn macro_linear(c: vec3i) -> u32 {
    let m = vec3u(c) / MACRO_FACTOR;
    return m.x + params.macro_res.x * (m.y + params.macro_res.y * m.z);
}

// Nearest hit in (t_min, t_max) (`any_hit`: the first found, for shadow rays; `triangles_only`:
// spheres and cones are passed by, for shell shadows, which decide those by their shells).
// A hit is only final once it lies within the current cell's t-range; a hit further on is kept
// as a candidate, so primitives spanning several cells need no mailbox.
fn grid_walk(o: vec3f, d: vec3f, t_min: f32, t_max: f32, any_hit: bool, triangles_only: bool) -> Hit {
    var best = Hit(t_max, NO_HIT, 0.0, 0.0);
    var s: Dda;
    if !dda_init(o, d, t_min, t_max, &s) {
        return best;
    }
    var macro_id = NO_HIT;
    var macro_full = false;
    loop {
        loop_tick(LOOP_WALK);
        let m = macro_linear(s.cell);
        if m != macro_id {
            macro_id = m;
            macro_full = macro_occupied(m);
        }
        if macro_full {
            let range = cell_range(cell_linear(s.cell));
            for (var k = 0u; k < range.y; k++) {
                loop_tick(LOOP_CANDIDATES);
                let r = prim_ref(range.x + k);
                if triangles_only && prim_kind(r) != PRIM_TRIANGLE {
                    continue;
                }
                let h = intersect_prim(r, o, d, t_min, best.t);
                if h.x != MISS {
                    best = Hit(h.x, r, h.y, h.z);
                    if any_hit {
                        return best;
                    }
                }
            }
            if best.prim != NO_HIT && real(best.t) <= dda_cell_exit(&s) {
                return best;
            }
        }
        if !dda_step(&s) {
            break;
        }
    }
    return best;
}
