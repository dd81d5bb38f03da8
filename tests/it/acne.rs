//! Self-intersection: secondary rays start from robustly offset points, so a convex object lit
//! from outside never shadows itself, at any scale or distance from the origin where its shape
//! is representable in f32. Every lit hit (n_g·l > 0) must have s = 1: acne fraction exactly 0.
use crate::common;

use crate::common::run_kernel;
use common::{f32_round, gpu, v4, Rng};
use glam::DVec3;
use irt::io::shapes;
use irt::scene::{Light, Sphere};

/// Lit hits that came out shadowed, out of lit hits, for eye rays aimed at random points of a
/// convex object of size `scale` centred at `at`.
fn acne(ctx: &irt::gpu::GpuContext, at: DVec3, scale: f64, mesh: bool, seed: u64) -> (usize, usize) {
    let mut s = if mesh {
        let mut sc = common::scene_of(vec![], vec![]);
        sc.meshes = vec![shapes::icosphere(at, scale, 3).into_mesh(0)];
        sc.meshes[0].normals = None; // flat faces: the geometric normal is what is shaded
        sc
    } else {
        common::scene_of(vec![Sphere { center: at, radius: scale, material: 0 }], vec![])
    };
    s.lights = vec![Light {
        position: at + DVec3::new(3.0, 5.0, 2.0) * 10.0 * scale,
        color: DVec3::ONE,
        radius: 0.0,
    }];
    let gs = crate::common::upload(ctx, &s, &irt::accel::Grid::build(&s));
    let mut rng = Rng::new(seed);
    let eye = at + DVec3::new(1.0, 2.0, 6.0) * scale;
    let rays: Vec<(DVec3, DVec3)> = (0..4000)
        .map(|_| {
            let target = at + rng.unit() * scale * 0.99;
            (f32_round(eye), f32_round((target - eye).normalize()))
        })
        .collect();
    let inputs: Vec<[f32; 4]> = rays.iter().flat_map(|&(o, d)| [v4(o, 0.0), v4(d, 0.0)]).collect();
    let out = run_kernel(ctx, &gs, "k_acne", &inputs, rays.len() as u32, 1);
    let lit: Vec<_> = out.iter().filter(|h| h[0] == 1.0 && h[1] > 0.0).collect();
    (lit.iter().filter(|h| h[2] < 1.0).count(), lit.len())
}

#[test]
fn convex_objects_never_shadow_themselves() {
    let ctx = gpu();
    let mut failures = vec![];
    for scale in [1e-4f64, 1e-2, 1.0, 1e2, 1e4] {
        for distance in [0.0, 1e3, 1e5, 1e6, 1e7] {
            let at = DVec3::new(1.0, -0.6, 0.8).normalize() * distance * scale.max(1.0);
            // A mesh's flat faces only stay convex while f32 resolves its vertices well: the
            // spacing of f32 at `at` must be far below the size of a face.
            let spacing = (at.abs().max_element() as f32).max(f32::MIN_POSITIVE).to_bits();
            let ulp = f32::from_bits(spacing + 1) as f64 - f32::from_bits(spacing) as f64;
            for mesh in [false, true] {
                // Where f32 cannot even place an eye a few sizes away from the object (its
                // spacing above 1/1000 of the size), or cannot keep a mesh's faces convex (its
                // spacing above 1e-4 of the size), there is no convex object to test.
                if ulp > scale * if mesh { 1e-4 } else { 1e-3 } {
                    continue;
                }
                let (bad, lit) = acne(&ctx, at, scale, mesh, 9);
                let what = if mesh { "icosphere" } else { "sphere" };
                println!("{what} size {scale:e} at {:e}: {bad} of {lit} lit hits self-shadowed", at.length());
                if bad > 0 || lit < 1000 {
                    failures.push(format!("{what} size {scale:e} at {:e}: {bad} of {lit}", at.length()));
                }
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}
