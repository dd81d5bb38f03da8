//! Watertight triangles: no ray slips through a shared edge or vertex of a closed mesh. Rays
//! start inside closed meshes (a box, a subdivided icosphere, both far from the origin too) and
//! aim at vertices, at points on edges and at random directions; every one must hit.
use crate::common;

use crate::common::run_kernel;
use common::{gpu, v4, Rng};
use glam::DVec3;
use irt::io::shapes;

fn leaks(ctx: &irt::gpu::GpuContext, mesh: shapes::Geometry, inside: DVec3, seed: u64) -> (usize, usize) {
    let mut s = common::scene_of(vec![], vec![]);
    let targets: Vec<DVec3> = {
        let m = mesh.clone().into_mesh(0);
        let mut t: Vec<DVec3> = m.positions.clone();
        // Midpoints and other points along every edge: where two triangles meet.
        for tri in &m.indices {
            for k in 0..3 {
                let (a, b) = (m.positions[tri[k] as usize], m.positions[tri[(k + 1) % 3] as usize]);
                t.extend([0.5, 0.25, 1.0 / 3.0].map(|f| a + (b - a) * f));
            }
        }
        t
    };
    s.meshes = vec![mesh.into_mesh(0)];
    let gs = crate::common::upload(ctx, &s, &irt::accel::Grid::build(&s));
    let mut rng = Rng::new(seed);
    let mut rays: Vec<(DVec3, DVec3)> = targets.iter().map(|&t| (inside, (t - inside).normalize())).collect();
    rays.extend((0..2000).map(|_| (inside, rng.unit())));
    // The f32 ray the GPU traces: round origin and direction first so both sides agree.
    let inputs: Vec<[f32; 4]> = rays.iter().flat_map(|&(o, d)| [v4(o, 0.0), v4(d, 1e30)]).collect();
    let out = run_kernel(ctx, &gs, "k_trace", &inputs, rays.len() as u32, 1);
    (out.iter().filter(|h| h[1].to_bits() == u32::MAX).count(), rays.len())
}

#[test]
fn no_ray_from_inside_a_closed_mesh_escapes() {
    let ctx = gpu();
    let mut failures = vec![];
    for (name, offset) in [("origin", DVec3::ZERO), ("far", DVec3::new(1e4, -3e4, 2e4))] {
        let cases = [
            ("box", shapes::cuboid(offset - DVec3::new(1.0, 0.7, 1.3), offset + DVec3::new(0.9, 1.1, 0.6))),
            ("icosphere", shapes::icosphere(offset, 1.0, 4)),
        ];
        for (shape, mesh) in cases {
            let inside = offset + DVec3::new(0.1, -0.05, 0.02);
            let (escaped, total) = leaks(&ctx, mesh, inside, 3);
            println!("{shape} at {name}: {escaped} of {total} rays escaped");
            if escaped > 0 {
                failures.push(format!("{shape} at {name}: {escaped} of {total} rays slipped through"));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:?}");
}
