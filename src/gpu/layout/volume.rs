//! Volumes in the scene texture (`shaders/volume.wgsl` decodes the same): per volume a record,
//! its samples in the file's own type, and its min/max macrocell levels
//! (`accel::macrocells`). The isovalues are not here but in [`super::Params::iso`], so a new
//! isovalue is a new uniform and nothing is packed again.
//!
//! - record ([`VOLUME_TEXELS`]): three rows of the affine map from (origin-relative) world to
//!   grid index coordinates, `[a00, a01, a02, b0]` ..., then `[nx, ny, nz, sample type]`
//!   ([`sample_code`]), `[first sample texel, isovalues, levels, 0]`, `[first texel of level 0,
//!   1, 2, 0]`, `[material of isovalue 0, 1, 2, 3]`, `[transfer window lo, hi (f32), first
//!   texel of its table, 0]`;
//! - samples: in bricks of `B`³ ([`brick`]: `Layout::brick` unless padding costs too much; `B` = 1 is the file's own order), bricks x
//!   fastest, then y, then z, and inside a brick the same; the last bricks padded with zeros;
//!   packed `32 / bits` to a word little end first, four words a texel (16 bytes of samples,
//!   whatever their type). Record texel 4's `w` is log2 `B`;
//! - each level's ranges, x fastest: `[lo0, hi0, lo1, hi1]` (f32), two macrocells a texel;
//! - the transfer function's table ([`TRANSFER_ENTRIES`] texels of linear RGB and opacity, f32).
//!
//! The looks (iso, MIP, DVR) are in [`super::Params::volume`] too, so the window switches them
//! without packing anything.

use crate::accel::macrocells::{Macrocells, MAX_LEVELS};
use crate::scene::transfer::TRANSFER_ENTRIES;
use crate::scene::volume::{Layout, Volume, Voxels, MAX_ISOS, MAX_VOLUMES};
use crate::scene::Scene;
use glam::DVec3;

pub const VOLUME_TEXELS: u32 = 8;
/// Macrocells a texel of a level's ranges.
pub const RANGES_PER_TEXEL: u32 = 2;
const _: () = assert!(MAX_LEVELS <= 3 && MAX_ISOS == 4);

/// The shader's code for a sample type, and log2 of samples per texel.
pub fn sample_code(v: &Voxels) -> (u32, u32) {
    match v {
        Voxels::U8(_) => (0, 4),
        Voxels::U16(_) => (1, 3),
        Voxels::I16(_) => (2, 3),
        Voxels::F32(_) => (3, 2),
    }
}

/// Texels the volumes of `scene` take, and their macrocells (built here, once).
pub fn volume_texels(scene: &Scene) -> (usize, Vec<Macrocells>) {
    let cells: Vec<Macrocells> = scene.volumes.iter().map(|v| Macrocells::build(&v.grid)).collect();
    let n = scene
        .volumes
        .iter()
        .zip(&cells)
        .map(|(v, m)| {
            let samples = stored_samples(v.grid.dims, brick(v)).div_ceil(1 << sample_code(&v.grid.voxels).1);
            let ranges: usize =
                levels(m, v.layout).iter().map(|l| l.ranges.len().div_ceil(RANGES_PER_TEXEL as usize)).sum();
            VOLUME_TEXELS as usize + samples + ranges + TRANSFER_ENTRIES
        })
        .sum();
    (n, cells)
}

/// Appends the volumes' records (all first, so record `i` is at `base + i VOLUME_TEXELS`), then
/// each one's samples and levels; returns `base`.
pub fn push_volumes(t: &mut Vec<[u32; 4]>, scene: &Scene, cells: &[Macrocells], origin: DVec3) -> u32 {
    let base = t.len() as u32;
    let records = t.len();
    t.resize(records + VOLUME_TEXELS as usize * scene.volumes.len(), [0; 4]);
    for (i, (v, m)) in scene.volumes.iter().zip(cells).enumerate() {
        let samples = t.len() as u32;
        push_samples(t, &v.grid.voxels, v.grid.dims, brick(v));
        let used = levels(m, v.layout);
        let mut bases = [0u32; 4];
        for (l, level) in used.iter().enumerate() {
            bases[l] = t.len() as u32;
            for pair in level.ranges.chunks(RANGES_PER_TEXEL as usize) {
                let mut texel = [0u32; 4];
                for (k, r) in pair.iter().enumerate() {
                    texel[2 * k] = r[0].to_bits();
                    texel[2 * k + 1] = r[1].to_bits();
                }
                t.push(texel);
            }
        }
        let table = t.len() as u32;
        t.extend(v.transfer.table().iter().map(|e| e.map(f32::to_bits)));
        let rec = &mut t[records + i * VOLUME_TEXELS as usize..][..VOLUME_TEXELS as usize];
        record(rec, v, samples, used.len() as u32, bases, origin);
        let [lo, hi] = v.transfer.window.map(|x| (x as f32).to_bits());
        rec[7] = [lo, hi, table, 0];
    }
    base
}

fn record(rec: &mut [[u32; 4]], v: &Volume, samples: u32, levels: u32, bases: [u32; 4], origin: DVec3) {
    // Index coordinates of an origin-relative point q: A (q + origin) + b.
    let m = v.index_from_world();
    let b = m.translation + m.matrix3 * origin;
    for r in 0..3 {
        let row = m.matrix3.row(r);
        rec[r] = [row.x, row.y, row.z, b[r]].map(|x| (x as f32).to_bits());
    }
    let [nx, ny, nz] = v.grid.dims;
    rec[3] = [nx, ny, nz, sample_code(&v.grid.voxels).0];
    rec[4] = [samples, v.isos.len() as u32, levels, brick(v).trailing_zeros()];
    rec[5] = [bases[0], bases[1], bases[2], 0];
    let mut materials = [0u32; 4];
    for (k, iso) in v.isos.iter().enumerate() {
        materials[k] = iso.material;
    }
    rec[6] = materials;
}

/// The macrocell levels `layout` keeps: the finest ones (the walk descends from the last kept).
fn levels(m: &Macrocells, layout: Layout) -> &[crate::accel::macrocells::Level] {
    &m.levels[..m.levels.len().min(layout.levels as usize)]
}

/// Samples stored for a grid of `dims` in bricks of `brick`: whole bricks.
pub fn stored_samples(dims: [u32; 3], brick: u32) -> usize {
    dims.iter().map(|&d| d.div_ceil(brick) as usize * brick as usize).product()
}

/// The brick edge volume `v` is stored in: its layout's, halved while padding to whole bricks
/// would add more than a quarter to its samples (a thin slab in bricks of 8 would take 4 times
/// its size; the shader's u32 sample index stays in range too). Pictures are the same in any.
pub fn brick(v: &Volume) -> u32 {
    let n = v.grid.voxels.len();
    let mut b = v.layout.brick;
    while b > 1 && stored_samples(v.grid.dims, b) > n + n / 4 {
        b /= 2;
    }
    b
}

/// The samples in the order [`Layout::brick`] stores them, as words.
fn push_samples(t: &mut Vec<[u32; 4]>, v: &Voxels, dims: [u32; 3], brick: u32) {
    match v {
        Voxels::U8(s) => pack(t, s, dims, brick, 8, |&x| x as u32),
        Voxels::U16(s) => pack(t, s, dims, brick, 16, |&x| x as u32),
        Voxels::I16(s) => pack(t, s, dims, brick, 16, |&x| x as u16 as u32),
        Voxels::F32(s) => pack(t, s, dims, brick, 32, |x| x.to_bits()),
    }
}

/// Packs `samples` (x fastest) brick by brick, `bits` to a sample, low bits first. A brick's
/// rows are runs of the file's own rows, so this copies runs, not single samples.
fn pack<T: Copy + Default>(
    t: &mut Vec<[u32; 4]>,
    samples: &[T],
    [nx, ny, nz]: [u32; 3],
    brick: u32,
    bits: u32,
    word: impl Fn(&T) -> u32,
) {
    let per_texel = (128 / bits) as usize;
    let per_word = 32 / bits as usize;
    let mut texel = [0u32; 4];
    let mut k = 0;
    let mut put = |x: &T| {
        let w = k / per_word;
        texel[w] |= word(x) << (bits as usize * (k % per_word));
        k += 1;
        if k == per_texel {
            t.push(texel);
            texel = [0; 4];
            k = 0;
        }
    };
    let (nx, ny, nz, b) = (nx as usize, ny as usize, nz as usize, brick as usize);
    if b == 1 {
        samples.iter().for_each(&mut put);
    } else {
        let pad = T::default();
        for bz in (0..nz).step_by(b) {
            for by in (0..ny).step_by(b) {
                for bx in (0..nx).step_by(b) {
                    for z in bz..bz + b {
                        for y in by..by + b {
                            if z < nz && y < ny {
                                let row = &samples[nx * (y + ny * z)..][..nx];
                                let run = &row[bx..(bx + b).min(nx)];
                                run.iter().for_each(&mut put);
                                (run.len()..b).for_each(|_| put(&pad));
                            } else {
                                (0..b).for_each(|_| put(&pad));
                            }
                        }
                    }
                }
            }
        }
    }
    if k > 0 {
        t.push(texel);
    }
}

/// The looks of `scene`'s volumes as the frame uniform holds them: two bits each
/// (`Look::code`), volume 0 lowest.
pub fn look_bits(scene: &Scene) -> u32 {
    const _: () = assert!(MAX_VOLUMES <= 16);
    scene.volumes.iter().enumerate().fold(0, |bits, (i, v)| bits | v.look.code() << (2 * i))
}

/// The isovalues of `scene`'s volumes as the frame uniform holds them.
pub fn iso_values(scene: &Scene) -> [[f32; 4]; MAX_VOLUMES] {
    let mut iso = [[0.0; 4]; MAX_VOLUMES];
    for (v, out) in scene.volumes.iter().zip(&mut iso) {
        for (k, i) in v.isos.iter().enumerate() {
            out[k] = i.value as f32;
        }
    }
    iso
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::volume::{Grid, Iso};
    use std::sync::Arc;

    fn volume(dims: [u32; 3], brick: u32) -> Volume {
        let n = dims.iter().product::<u32>() as usize;
        let grid = Grid::new(dims, DVec3::ONE, DVec3::ZERO, Voxels::U8(vec![0; n])).expect("grid");
        let iso = vec![Iso { value: 0.5, material: 0 }];
        let mut v = Volume::new(Arc::new(grid), glam::DAffine3::IDENTITY, iso, None);
        v.layout = Layout { brick, levels: 3 };
        v
    }

    #[test]
    fn padding_to_whole_bricks_never_adds_more_than_a_quarter() {
        // The MRI template's shape keeps bricks of 8 (6% padding); a thin slab and a 9³ cube
        // fall back to smaller bricks rather than take 4 and 5.6 times their samples.
        assert_eq!(brick(&volume([197, 233, 189], 8)), 8);
        assert_eq!(brick(&volume([512, 512, 2], 8)), 2);
        assert_eq!(brick(&volume([9, 9, 9], 8)), 1);
        assert_eq!(brick(&volume([64, 64, 64], 16)), 16);
        for dims in [[2, 2, 1000], [17, 3, 40], [100, 101, 102], [5, 300, 7]] {
            for b in [1, 2, 4, 8, 16] {
                let v = volume(dims, b);
                let n = v.grid.voxels.len();
                assert!(stored_samples(dims, brick(&v)) <= n + n / 4, "{dims:?} in bricks of {b}");
            }
        }
    }
}
