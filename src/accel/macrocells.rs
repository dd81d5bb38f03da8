//! A volume's min/max macrocell hierarchy (Parker et al.'s, PAPER.md §10): level 0 holds the
//! range (least and greatest sample) of each brick of `BRICK`³ cells, and each level above
//! groups `BRICK`³ of the level below. A ray walks the coarsest level and descends only into
//! macrocells whose range holds the isovalue, so a new isovalue rebuilds nothing and a walk
//! skips the empty space. This is the host's copy; the shader's walk (not written yet) is to
//! follow it and be checked against it by readback.

use crate::scene::volume::{cell_hit, Grid};
use glam::DVec3;

/// Cells (or macrocells) a macrocell spans along each axis.
pub const BRICK: u32 = 4;
/// Levels of macrocells above the cells (the paper used three).
pub const MAX_LEVELS: usize = 3;

/// One level: how many of its macrocells lie along each axis, how many grid cells each spans,
/// and their ranges, x fastest.
#[derive(Clone, Debug, PartialEq)]
pub struct Level {
    pub dims: [u32; 3],
    pub span: u32,
    pub ranges: Vec<[f32; 2]>,
}

impl Level {
    fn index(&self, [i, j, k]: [u32; 3]) -> usize {
        i as usize + self.dims[0] as usize * (j as usize + self.dims[1] as usize * k as usize)
    }

    /// Whether macrocell `c`'s range holds `iso`.
    pub fn holds(&self, c: [u32; 3], iso: f32) -> bool {
        let [lo, hi] = self.ranges[self.index(c)];
        lo <= iso && iso <= hi
    }
}

/// The hierarchy: `levels[0]` groups `BRICK`³ cells, each level above `BRICK`³ of the one
/// below, the last the coarsest. The cells' own ranges are not stored (8 bytes a cell would be
/// four times a 16-bit volume): the walk takes them from the samples as it reaches them.
#[derive(Clone, Debug, PartialEq)]
pub struct Macrocells {
    pub levels: Vec<Level>,
}

impl Macrocells {
    /// Builds the ranges bottom up: level 0 from the samples (a macrocell of cells `m B ..
    /// m B + B` spans samples `m B ..= m B + B`), then up to [`MAX_LEVELS`] levels in all,
    /// stopping once a level has a single macrocell.
    pub fn build(grid: &Grid) -> Macrocells {
        let cells = grid.cells();
        let dims = cells.map(|d| d.div_ceil(BRICK));
        let mut ranges = Vec::with_capacity(dims.iter().map(|&d| d as usize).product());
        for mk in 0..dims[2] {
            for mj in 0..dims[1] {
                for mi in 0..dims[0] {
                    let lo = [mi, mj, mk].map(|m| m * BRICK);
                    let hi: [u32; 3] = std::array::from_fn(|a| (lo[a] + BRICK).min(cells[a]));
                    let mut r = [f32::INFINITY, f32::NEG_INFINITY];
                    for k in lo[2]..=hi[2] {
                        for j in lo[1]..=hi[1] {
                            for i in lo[0]..=hi[0] {
                                let v = grid.at(i, j, k);
                                r = [r[0].min(v), r[1].max(v)];
                            }
                        }
                    }
                    ranges.push(r);
                }
            }
        }
        let mut levels = vec![Level { dims, span: BRICK, ranges }];
        while levels.len() < MAX_LEVELS && levels.last().is_some_and(|l| l.dims.iter().any(|&d| d > 1)) {
            let below = levels.last().expect("a level");
            let dims = below.dims.map(|d| d.div_ceil(BRICK));
            let mut ranges =
                vec![[f32::INFINITY, f32::NEG_INFINITY]; dims.iter().map(|&d| d as usize).product()];
            for k in 0..below.dims[2] {
                for j in 0..below.dims[1] {
                    for i in 0..below.dims[0] {
                        let [lo, hi] = below.ranges[below.index([i, j, k])];
                        let up = [i / BRICK, j / BRICK, k / BRICK];
                        let at = up[0] as usize
                            + dims[0] as usize * (up[1] as usize + dims[1] as usize * up[2] as usize);
                        ranges[at] = [ranges[at][0].min(lo), ranges[at][1].max(hi)];
                    }
                }
            }
            let span = below.span * BRICK;
            levels.push(Level { dims, span, ranges });
        }
        Macrocells { levels }
    }

    /// Walks the ray `origin + t dir` (t in `[t0, t1]`) through `grid`, calling `visit(cell, ta,
    /// tb)` for each cell, in order along the ray, that lies in a macrocell of every level whose
    /// range holds `iso` — every cell whose own range holds it among them. `visit` returns
    /// `true` to stop (a hit).
    pub fn walk(
        &self,
        grid: &Grid,
        origin: DVec3,
        dir: DVec3,
        [t0, t1]: [f64; 2],
        iso: f32,
        visit: &mut impl FnMut([u32; 3], f64, f64) -> bool,
    ) -> bool {
        let Some([t0, t1]) = clip(grid, origin, dir, [t0, t1]) else { return false };
        let top = self.levels.len() - 1;
        let all = [[0, 0, 0], self.levels[top].dims.map(|d| d - 1)];
        self.walk_level(top, all, grid, origin, dir, [t0, t1], iso, visit)
    }

    /// The first `t` where the ray meets the isosurface `iso`: the walk, and in each cell it
    /// visits [`cell_hit`] on the segment the ray spends in it.
    pub fn iso_hit(&self, grid: &Grid, origin: DVec3, dir: DVec3, span: [f64; 2], iso: f32) -> Option<f64> {
        let mut hit = None;
        self.walk(grid, origin, dir, span, iso, &mut |c, ta, tb| {
            let corner = DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64);
            let local = |t: f64| {
                ((origin + dir * t - grid.origin) / grid.spacing - corner).clamp(DVec3::ZERO, DVec3::ONE)
            };
            let s = cell_hit(&grid.corners(c), local(ta), local(tb), iso as f64);
            hit = s.map(|s| ta + (tb - ta) * s);
            hit.is_some()
        });
        hit
    }

    #[allow(clippy::too_many_arguments)]
    fn walk_level(
        &self,
        level: usize,
        within: [[u32; 3]; 2],
        grid: &Grid,
        origin: DVec3,
        dir: DVec3,
        span: [f64; 2],
        iso: f32,
        visit: &mut impl FnMut([u32; 3], f64, f64) -> bool,
    ) -> bool {
        let l = &self.levels[level];
        let size = grid.spacing * l.span as f64;
        dda(grid.origin, size, within, origin, dir, span, &mut |c, ta, tb| {
            if !l.holds(c, iso) {
                return false;
            }
            // The children of `c` on the level below (the cells, under level 0), clamped to
            // that level's extent.
            let below = if level == 0 { grid.cells() } else { self.levels[level - 1].dims };
            let lo = c.map(|x| x * BRICK);
            let hi = std::array::from_fn(|a| (lo[a] + BRICK - 1).min(below[a] - 1));
            if level > 0 {
                return self.walk_level(level - 1, [lo, hi], grid, origin, dir, [ta, tb], iso, visit);
            }
            dda(grid.origin, grid.spacing, [lo, hi], origin, dir, [ta, tb], &mut |cell, ca, cb| {
                let corners = grid.corners(cell);
                let (lo, hi) = corners
                    .iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
                lo <= iso as f64 && iso as f64 <= hi && visit(cell, ca, cb)
            })
        })
    }
}

/// The part of `[t0, t1]` where the ray is inside the grid's bounds.
pub fn clip(grid: &Grid, origin: DVec3, dir: DVec3, [t0, t1]: [f64; 2]) -> Option<[f64; 2]> {
    let (lo, hi) = grid.bounds();
    let inv = dir.recip();
    let a = (lo - origin) * inv;
    let b = (hi - origin) * inv;
    let near = a.min(b);
    let far = a.max(b);
    // An axis the ray is parallel to gives NaN only when it starts on a slab face: treat as in.
    let near = [near.x, near.y, near.z].into_iter().filter(|x| !x.is_nan()).fold(t0, f64::max);
    let far = [far.x, far.y, far.z].into_iter().filter(|x| !x.is_nan()).fold(t1, f64::min);
    (near <= far).then_some([near, far])
}

/// Amanatides and Woo's walk over the boxes of size `size` from `base` with indices in
/// `within` (inclusive), along the ray within `[ta, tb]` (inside those boxes' union): `f(box,
/// enter, leave)` for each in order, until it returns `true`.
fn dda(
    base: DVec3,
    size: DVec3,
    within: [[u32; 3]; 2],
    origin: DVec3,
    dir: DVec3,
    [ta, tb]: [f64; 2],
    f: &mut impl FnMut([u32; 3], f64, f64) -> bool,
) -> bool {
    // The box holding the point just inside the span: a point on a face belongs to either side.
    let start = origin + dir * (ta + (tb - ta) * 1e-9);
    let mut cell = [0i64; 3];
    let mut step = [0i64; 3];
    let mut next = [f64::INFINITY; 3];
    let mut delta = [f64::INFINITY; 3];
    for a in 0..3 {
        let x = ((start[a] - base[a]) / size[a]).floor() as i64;
        cell[a] = x.clamp(within[0][a] as i64, within[1][a] as i64);
        if dir[a] > 0.0 {
            step[a] = 1;
            next[a] = (base[a] + (cell[a] + 1) as f64 * size[a] - origin[a]) / dir[a];
            delta[a] = size[a] / dir[a];
        } else if dir[a] < 0.0 {
            step[a] = -1;
            next[a] = (base[a] + cell[a] as f64 * size[a] - origin[a]) / dir[a];
            delta[a] = -size[a] / dir[a];
        }
    }
    let mut t = ta;
    loop {
        let a = (0..3).min_by(|&x, &y| next[x].total_cmp(&next[y])).expect("three axes");
        let leave = next[a].min(tb);
        if f(cell.map(|c| c as u32), t, leave) {
            return true;
        }
        if next[a] >= tb {
            return false;
        }
        t = next[a];
        cell[a] += step[a];
        next[a] += delta[a];
        if cell[a] < within[0][a] as i64 || cell[a] > within[1][a] as i64 {
            return false;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::volume::Voxels;

    /// A small deterministic generator, so that a failure names its case.
    fn lcg(seed: &mut u64) -> f64 {
        *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (*seed >> 11) as f64 / (1u64 << 53) as f64
    }

    fn random_grid(seed: &mut u64) -> Grid {
        let dims =
            [2 + (lcg(seed) * 14.0) as u32, 2 + (lcg(seed) * 11.0) as u32, 2 + (lcg(seed) * 9.0) as u32];
        let n = dims.iter().product::<u32>() as usize;
        // Smooth-ish values with some flat regions, so whole macrocells miss an isovalue.
        let v = (0..n).map(|_| if lcg(seed) < 0.6 { 10 } else { (lcg(seed) * 255.0) as u8 }).collect();
        let spacing = DVec3::new(0.5 + lcg(seed), 0.5 + lcg(seed), 0.5 + lcg(seed));
        Grid::new(dims, spacing, DVec3::new(-1.0, 0.5, 2.0), Voxels::U8(v)).unwrap()
    }

    /// Every cell the ray crosses whose range holds the isovalue, by walking every cell.
    fn brute(grid: &Grid, origin: DVec3, dir: DVec3, iso: f32) -> Vec<[u32; 3]> {
        let mut out = Vec::new();
        if let Some(span) = clip(grid, origin, dir, [0.0, f64::INFINITY]) {
            let all = [[0, 0, 0], grid.cells().map(|d| d - 1)];
            dda(grid.origin, grid.spacing, all, origin, dir, span, &mut |c, _, _| {
                let v = grid.corners(c);
                if v.iter().any(|&x| x <= iso as f64) && v.iter().any(|&x| x >= iso as f64) {
                    out.push(c);
                }
                false
            });
        }
        out
    }

    /// Exhaustive over many small random volumes and rays: the walk visits exactly the cells
    /// the brute force finds, in the same order, at every isovalue.
    #[test]
    fn the_walk_skips_no_cell_that_holds_the_isovalue() {
        let mut seed = 7u64;
        let mut visited = 0;
        for case in 0..300 {
            let grid = random_grid(&mut seed);
            let m = Macrocells::build(&grid);
            assert!(!m.levels.is_empty(), "case {case}");
            let (lo, hi) = grid.bounds();
            for _ in 0..20 {
                let inside = lo + (hi - lo) * DVec3::new(lcg(&mut seed), lcg(&mut seed), lcg(&mut seed));
                let dir =
                    DVec3::new(lcg(&mut seed) - 0.5, lcg(&mut seed) - 0.5, lcg(&mut seed) - 0.5).normalize();
                let origin = inside - dir * 40.0;
                let iso = (lcg(&mut seed) * 255.0) as f32;
                let want = brute(&grid, origin, dir, iso);
                let mut got = Vec::new();
                m.walk(&grid, origin, dir, [0.0, f64::INFINITY], iso, &mut |c, ta, tb| {
                    assert!(ta <= tb, "case {case}: the span {ta}..{tb} runs backwards");
                    got.push(c);
                    false
                });
                assert_eq!(got, want, "case {case}: iso {iso}, grid {:?}", grid.dims);
                visited += got.len();
            }
        }
        assert!(visited > 10_000, "the cases visit cells ({visited})");
    }

    #[test]
    fn levels_group_bricks_and_hold_their_samples_ranges() {
        let v: Vec<u8> = (0..34 * 9 * 3).map(|n| (n % 34) as u8).collect();
        let g = Grid::new([34, 9, 3], DVec3::ONE, DVec3::ZERO, Voxels::U8(v)).unwrap();
        let m = Macrocells::build(&g);
        let dims: Vec<_> = m.levels.iter().map(|l| (l.dims, l.span)).collect();
        assert_eq!(dims, [([9, 2, 1], 4), ([3, 1, 1], 16), ([1, 1, 1], 64)]);
        // Cells 4..8 along x span samples 4..=8; the last macrocell, cells 32..33, samples 32..=33.
        assert_eq!(m.levels[0].ranges[1], [4.0, 8.0]);
        assert_eq!(m.levels[0].ranges[8], [32.0, 33.0]);
        assert_eq!(m.levels[1].ranges[0], [0.0, 16.0]);
        assert_eq!(m.levels[2].ranges[0], [0.0, 33.0]);
    }
}
