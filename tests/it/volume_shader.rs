//! The volume shader's pieces one at a time, by readback (shaders/tests.wgsl): the samples as
//! each brick layout stores them, decoded; and the macrocell walk alone against the host's
//! `Macrocells::iso_hit`, in every layout.

use crate::common::{gpu, run_kernel, scene_of, upload};
use glam::{DAffine3, DVec3};
use irt::accel::macrocells::Macrocells;
use irt::accel::Grid as Accel;
use irt::scene::volume::{Grid, Iso, Layout, Volume, Voxels};
use irt::scene::Scene;
use std::sync::Arc;

/// `grid` alone in a scene, placed where its header puts it, as isosurface `iso`, in `layout`.
fn scene_with(grid: &Arc<Grid>, iso: f64, layout: Layout) -> Scene {
    let mut s = scene_of(vec![], vec![]);
    let mut v = Volume::new(grid.clone(), DAffine3::IDENTITY, vec![Iso { value: iso, material: 0 }], None);
    v.layout = layout.check().expect("a valid layout");
    s.volumes.push(v);
    s
}

fn lcg(seed: &mut u64) -> f64 {
    *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    (*seed >> 11) as f64 / (1u64 << 53) as f64
}

/// Every sample of a volume whose sides are no multiple of any brick (but y's of 2) comes back
/// exact, for each sample type and each brick edge: the padding, the bricks' order and the
/// samples' order inside a brick all checked. The sides are just under multiples of 16, so
/// padding stays under a quarter and every brick edge asked for is the one stored.
#[test]
fn every_brick_layout_reads_back_every_sample_of_every_type() {
    let ctx = gpu();
    let dims = [63u32, 62, 47];
    let n = dims.iter().product::<u32>() as usize;
    let mut seed = 3u64;
    let mut r = || lcg(&mut seed);
    let types = [
        Voxels::U8((0..n).map(|_| (r() * 255.0) as u8).collect()),
        Voxels::U16((0..n).map(|_| (r() * 65535.0) as u16).collect()),
        Voxels::I16((0..n).map(|_| (r() * 65535.0 - 32768.0) as i16).collect()),
        Voxels::F32((0..n).map(|_| (r() * 2e4 - 1e4) as f32).collect()),
    ];
    let at: Vec<[f32; 4]> = (0..dims[2])
        .flat_map(|k| (0..dims[1]).flat_map(move |j| (0..dims[0]).map(move |i| [i, j, k])))
        .map(|c| [f32::from_bits(c[0]), f32::from_bits(c[1]), f32::from_bits(c[2]), 0.0])
        .collect();
    for voxels in types {
        let grid = Arc::new(Grid::new(dims, DVec3::ONE, DVec3::ZERO, voxels).expect("grid"));
        for brick in [1, 2, 4, 8, 16] {
            let s = scene_with(&grid, 0.5, Layout { brick, levels: 3 });
            assert_eq!(irt::gpu::layout::volume::brick(&s.volumes[0]), brick, "the brick stored");
            let out =
                run_kernel(&ctx, &upload(&ctx, &s, &Accel::build(&s)), "k_volume_sample", &at, n as u32, 1);
            for (c, got) in at.iter().zip(&out) {
                let [i, j, k] = [0, 1, 2].map(|a| c[a].to_bits());
                let name = grid.voxels.type_name();
                assert_eq!(got[0], grid.at(i, j, k), "{name}, brick {brick}: sample ({i}, {j}, {k})");
            }
        }
    }
}

/// The shader's walk (f32, stackless, descending from the top at each cell) finds the host
/// walk's first hit (f64, recursive) on a real MRI volume, in each layout. Tolerance: 2e-3 of
/// a voxel in t. Rays start 400 voxels out, where an f32 position is good to 3e-5 of a voxel,
/// and the cell's cubic is solved in f32 to about 1e-5 of the corners' scale over its slope;
/// where the slope along the ray is under 1% of the corners' range, the surface is grazed and
/// either may see a crossing pair the other does not: those rays, fewer than 1 in 100, are
/// counted apart. Every layout must give the same answers bit for bit: a brick only moves
/// samples, and the macrocells only skip cells that cannot hold the isovalue.
#[test]
fn the_shader_walk_finds_the_host_walk_s_hits_in_every_layout() {
    let ctx = gpu();
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/volumes/mni152_t1.nii.gz");
    let grid = Arc::new(irt::io::volume::load(&path).expect("MNI152"));
    let m = Macrocells::build(&grid);
    let (lo, hi) = grid.bounds();
    let voxel = grid.spacing.min_element();
    let mut seed = 7u64;
    let mut rays = Vec::new();
    for _ in 0..600 {
        let inside = lo + (hi - lo) * DVec3::new(lcg(&mut seed), lcg(&mut seed), lcg(&mut seed));
        let dir = DVec3::new(lcg(&mut seed) - 0.5, lcg(&mut seed) - 0.5, lcg(&mut seed) - 0.5).normalize();
        rays.push((inside - dir * 400.0 * voxel, dir));
    }
    let input: Vec<[f32; 4]> = rays
        .iter()
        .flat_map(|(o, d)| [o.as_vec3().extend(0.0).to_array(), d.as_vec3().extend(1e30).to_array()])
        .collect();
    let (mut hits, mut grazes) = (0, 0);
    for iso in [40.0f32, 80.0, 150.0] {
        let mut first: Option<Vec<[f32; 4]>> = None;
        for (brick, levels) in [(1, 3), (4, 3), (8, 3), (2, 2), (4, 1), (1, 0)] {
            let s = scene_with(&grid, iso as f64, Layout { brick, levels });
            let gpu = upload(&ctx, &s, &Accel::build(&s));
            let out = run_kernel(&ctx, &gpu, "k_volume_walk", &input, rays.len() as u32, 1);
            if let Some(f) = &first {
                let same = f.iter().zip(&out).filter(|(a, b)| a[0].to_bits() == b[0].to_bits()).count();
                assert_eq!(
                    same,
                    rays.len(),
                    "iso {iso}, brick {brick}, {levels} levels: rays unlike brick 1, 3 levels"
                );
                continue;
            }
            for (k, ((o, d), got)) in rays.iter().zip(&out).enumerate() {
                let host = m.iso_hit(&grid, *o, *d, [0.0, f64::INFINITY], iso);
                let got = (got[0] != -1.0).then_some(got[0] as f64);
                match (host, got) {
                    (Some(a), Some(b)) if (a - b).abs() <= 2e-3 * voxel => hits += 1,
                    (None, None) => {}
                    (h, g) => {
                        let t = h.or(g).expect("one hits");
                        let p = *o + *d * t;
                        let slope = (sample(&grid, p + *d * voxel * 0.01)
                            - sample(&grid, p - *d * voxel * 0.01))
                        .abs()
                            / 0.02;
                        let (a, b) = grid.range();
                        assert!(
                            slope < 0.01 * (b - a) as f64,
                            "iso {iso} ray {k}: host {h:?}, shader {g:?}, slope {slope} per voxel there"
                        );
                        grazes += 1;
                    }
                }
            }
            first = Some(out);
        }
    }
    let all = 3 * rays.len();
    assert!(hits > all / 3, "{hits} of {all} rays hit");
    assert!(grazes * 100 < all, "{grazes} grazes of {all}");
    println!("the shader walk: {hits} of {all} rays hit where the host's does, {grazes} grazes");
}

/// The trilinear interpolant of `grid` at world point `p` (0 outside).
fn sample(grid: &Grid, p: DVec3) -> f64 {
    let q = (p - grid.origin) / grid.spacing;
    let c = q.floor();
    let cells = grid.cells();
    if c.min_element() < 0.0 || (0..3).any(|a| c[a] >= cells[a] as f64) {
        return 0.0;
    }
    let cell = [c.x as u32, c.y as u32, c.z as u32];
    irt::scene::volume::trilinear(&grid.corners(cell), (q - c).to_array())
}
