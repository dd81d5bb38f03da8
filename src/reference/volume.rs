//! The f64 twin of a volume's ray queries, written apart from the macrocell walk and the cell's
//! cubic (`accel::macrocells`, `scene::volume::cell_hit`): the interpolant sampled densely along
//! the ray through the whole volume, a sign change bisected; MIP as the largest sample; DVR
//! integrated on the shader's lattice of samples to the end (no early stop).

use crate::scene::transfer::{step_opacity, Transfer, DVR_STEP};
use crate::scene::volume::{trilinear, trilinear_gradient, Grid};
use glam::DVec3;

/// Samples per cell along the ray: a crossing pair closer than a 64th of a cell is not seen.
pub const SAMPLES_PER_CELL: f64 = 64.0;

/// The part of `[t0, t1]` inside the volume's box, by the slabs one axis at a time (its own,
/// not the walk's `accel::macrocells::clip`: the twin shares no code with what it checks).
fn clip(grid: &Grid, origin: DVec3, dir: DVec3, [mut t0, mut t1]: [f64; 2]) -> Option<[f64; 2]> {
    let (lo, hi) = grid.bounds();
    for a in 0..3 {
        if dir[a] == 0.0 {
            if origin[a] < lo[a] || origin[a] > hi[a] {
                return None;
            }
            continue;
        }
        let (near, far) = ((lo[a] - origin[a]) / dir[a], (hi[a] - origin[a]) / dir[a]);
        t0 = t0.max(near.min(far));
        t1 = t1.min(near.max(far));
    }
    (t0 <= t1).then_some([t0, t1])
}

/// The interpolated value at world point `p`, `None` outside the volume.
pub fn value_at(grid: &Grid, p: DVec3) -> Option<f64> {
    let (cell, uvw) = locate(grid, p)?;
    Some(trilinear(&grid.corners(cell), uvw))
}

/// The cell holding `p` and `p`'s coordinates in it.
fn locate(grid: &Grid, p: DVec3) -> Option<([u32; 3], [f64; 3])> {
    let x = (p - grid.origin) / grid.spacing;
    let cells = grid.cells();
    let mut cell = [0u32; 3];
    let mut uvw = [0.0; 3];
    for a in 0..3 {
        // A point the clip put on a face may round a hair outside it: still on the face.
        let slack = 1e-9 * cells[a] as f64;
        if !(x[a] >= -slack && x[a] <= cells[a] as f64 + slack) {
            return None;
        }
        let x = x[a].clamp(0.0, cells[a] as f64);
        let c = (x.floor() as u32).min(cells[a] - 1);
        cell[a] = c;
        uvw[a] = x - c as f64;
    }
    Some((cell, uvw))
}

/// The interpolant's gradient at `p` in world units (`None` outside).
pub fn gradient_at(grid: &Grid, p: DVec3) -> Option<DVec3> {
    let (cell, uvw) = locate(grid, p)?;
    Some(trilinear_gradient(&grid.corners(cell), uvw) / grid.spacing)
}

/// The first `t` in `[t0, t1]` where the ray `origin + t dir` meets the isosurface `iso`, with
/// the surface's unit normal there (along the gradient: towards larger values).
pub fn iso_hit(grid: &Grid, origin: DVec3, dir: DVec3, span: [f64; 2], iso: f64) -> Option<(f64, DVec3)> {
    let [ta, tb] = clip(grid, origin, dir, span)?;
    let step = grid.spacing.min_element() / SAMPLES_PER_CELL / dir.length();
    let f = |t: f64| value_at(grid, origin + dir * t).map(|v| v - iso);
    let n = ((tb - ta) / step).ceil().max(1.0) as usize;
    let mut prev = (ta, f(ta)?);
    if prev.1 == 0.0 {
        return normal(grid, origin + dir * ta).map(|nrm| (ta, nrm));
    }
    for i in 1..=n {
        let t = (ta + (tb - ta) * i as f64 / n as f64).min(tb);
        let Some(v) = f(t) else { continue };
        if v == 0.0 || v.signum() != prev.1.signum() {
            let (mut lo, mut hi) = (prev.0, t);
            for _ in 0..64 {
                let mid = 0.5 * (lo + hi);
                match f(mid) {
                    Some(m) if m.signum() == prev.1.signum() && m != 0.0 => lo = mid,
                    _ => hi = mid,
                }
            }
            let t = 0.5 * (lo + hi);
            return normal(grid, origin + dir * t).map(|nrm| (t, nrm));
        }
        prev = (t, v);
    }
    None
}

fn normal(grid: &Grid, p: DVec3) -> Option<DVec3> {
    gradient_at(grid, p).map(|g| g.normalize_or_zero())
}

/// The largest interpolated value along the ray in `[t0, t1]` (maximum-intensity projection),
/// `None` where the ray misses the volume.
pub fn mip(grid: &Grid, origin: DVec3, dir: DVec3, span: [f64; 2]) -> Option<f64> {
    let [ta, tb] = clip(grid, origin, dir, span)?;
    let step = grid.spacing.min_element() / SAMPLES_PER_CELL / dir.length();
    let n = ((tb - ta) / step).ceil().max(1.0) as usize;
    (0..=n)
        .filter_map(|i| value_at(grid, origin + dir * (ta + (tb - ta) * i as f64 / n as f64)))
        .reduce(f64::max)
}

/// Where the ray enters the volume's box (the greatest near slab distance, not clipped).
pub fn entry(grid: &Grid, origin: DVec3, dir: DVec3) -> f64 {
    let (lo, hi) = grid.bounds();
    (0..3)
        .map(|a| {
            let (p, q) = ((lo[a] - origin[a]) / dir[a], (hi[a] - origin[a]) / dir[a]);
            if p.is_nan() || q.is_nan() {
                f64::NEG_INFINITY
            } else {
                p.min(q)
            }
        })
        .fold(f64::NEG_INFINITY, f64::max)
}

/// Emission and absorption along the ray in `[t0, t1]` through `transfer` (its `table`): the
/// light emitted towards the origin and the share of the light behind that gets through.
/// Samples sit every [`DVR_STEP`] cells (in index units) from where the ray enters the box, at
/// the middles of the steps, as the shader's do; the integral runs to the end.
pub fn dvr(
    grid: &Grid,
    transfer: &Transfer,
    table: &[[f32; 4]],
    origin: DVec3,
    dir: DVec3,
    span: [f64; 2],
) -> (DVec3, f64) {
    let Some([ta, tb]) = clip(grid, origin, dir, span) else { return (DVec3::ZERO, 1.0) };
    let dt = DVR_STEP / (dir / grid.spacing).length();
    let (mut c, mut through) = (DVec3::ZERO, 1.0);
    let mut k = 0.0;
    while ta + (k + 0.5) * dt < tb {
        if let Some(v) = value_at(grid, origin + dir * (ta + (k + 0.5) * dt)) {
            let f = transfer.lookup(table, v);
            let a = step_opacity(f[3]);
            c += through * a * DVec3::new(f[0], f[1], f[2]);
            through *= 1.0 - a;
        }
        k += 1.0;
    }
    (c, through)
}
