//! Base-colour textures: the shader's sampling (shaders/texture.wgsl) against its f64 twin
//! (`irt::reference::sample_texture`) through readback, texture coordinates at hits, and whole
//! textured scenes against the reference.
use crate::common;

use crate::common::run_kernel;
use common::*;
use glam::{DVec2, DVec3};
use irt::accel::Grid;
use irt::reference as cpu;
use irt::scene::{Filter, Material, MaterialKind, Mesh, Scene, Texture, Wrap};

/// Random textures covering every wrap/filter pair, odd and even sizes, 1-texel sides.
fn random_textures(rng: &mut Rng) -> Vec<Texture> {
    let sizes = [(1, 1), (1, 5), (7, 1), (2, 2), (3, 5), (16, 9), (64, 33)];
    let wraps = [Wrap::Repeat, Wrap::Clamp, Wrap::Mirror];
    let mut out = Vec::new();
    for (k, &(w, h)) in sizes.iter().enumerate() {
        for (j, filter) in [Filter::Nearest, Filter::Linear].into_iter().enumerate() {
            let texels = (0..w * h).map(|_| std::array::from_fn(|_| rng.below(256) as u8)).collect();
            let wrap = [wraps[(k + j) % 3], wraps[(k + 2 * j + 1) % 3]];
            out.push(Texture { name: format!("t{k}{j}"), width: w, height: h, texels, wrap, filter });
        }
    }
    out
}

fn textured_scene(textures: Vec<Texture>) -> Scene {
    let mut s = scene_of(vec![irt::scene::Sphere { center: DVec3::ZERO, radius: 1.0, material: 0 }], vec![]);
    s.materials = (0..textures.len())
        .map(|i| Material {
            texture: Some(i as u32),
            ..Material::new(format!("m{i}"), MaterialKind::Diffuse { color: DVec3::ONE })
        })
        .collect();
    s.textures = textures;
    s
}

#[test]
fn sample_texture_matches_its_twin() {
    let mut rng = Rng::new(7);
    let scene = textured_scene(random_textures(&mut rng));
    let ctx = gpu();
    let gpu_scene = crate::common::upload(&ctx, &scene, &Grid::build(&scene));
    let mut inputs = Vec::new();
    for i in 0..8192 {
        let t = i % scene.textures.len();
        // Mostly inside [0, 1], some a few periods out on either side, some far out.
        let span = [1.0, 4.0, 1e3][rng.below(3)];
        let uv = DVec2::new(rng.range(-span, span), rng.range(-span, span));
        inputs.push([uv.x as f32, uv.y as f32, t as f32, 0.0]);
    }
    // Exact texel edges and centres, where rounding decides between neighbours.
    for t in 0..scene.textures.len() {
        let (w, h) = (scene.textures[t].width as f32, scene.textures[t].height as f32);
        for (a, b) in
            [(0.0, 0.0), (1.0, 1.0), (-1.0, 2.0), (0.5 / w, 0.5 / h), (1.0 / w, 3.0 / h), (-0.0, 1.5)]
        {
            inputs.push([a, b, t as f32, 0.0]);
        }
    }
    let out = run_kernel(&ctx, &gpu_scene, "k_texture", &inputs, inputs.len() as u32, 1);
    let mut worst: f64 = 0.0;
    let mut flipped = 0;
    for (inp, o) in inputs.iter().zip(&out) {
        let tex = &scene.textures[inp[2] as usize];
        let uv = DVec2::new(inp[0] as f64, inp[1] as f64);
        let want = cpu::sample_texture(tex, uv);
        let got = d3(*o);
        let err = (got - want).abs().max_element();
        // Tolerance: the shader folds u into a period and scales it in f32; an error of a few
        // ulps of u·size moves the bilinear weights by ~1e-7·size per unit of contrast, and the
        // f32 pow in the sRGB decode is good to ~1e-6 relative. 1e-4 leaves a wide margin below
        // one output level (1/255 ≈ 4e-3) yet catches any wrong texel, weight or wrap.
        if err > 1e-4 {
            // A nearest-filtered coordinate within f32 rounding of a texel edge may pick the
            // neighbour: allowed only where the f64 coordinate is that close to an edge.
            let near_edge = [(uv.x, tex.width), (uv.y, tex.height)].iter().any(|&(u, n)| {
                let x = u * n as f64;
                (x - x.round()).abs() <= 4.0 * f32::EPSILON as f64 * x.abs().max(1.0)
            });
            assert!(
                tex.filter == Filter::Nearest && near_edge,
                "texture {} ({:?}) at {uv}: shader {got}, twin {want}",
                tex.name,
                tex
            );
            flipped += 1;
        }
        worst = worst.max(if err > 1e-4 { 0.0 } else { err });
    }
    println!("worst error {worst:.2e}, {flipped} nearest-filter ties decided differently");
    assert!(flipped <= inputs.len() / 200, "{flipped} ties");
}

/// A unit quad in the z = 0 plane, uv (0,0) at its top-left (-1, 1) corner and (2, 3) at the
/// bottom-right, so that the texture repeats across it.
fn quad_mesh(material: u32) -> Mesh {
    Mesh {
        positions: vec![
            DVec3::new(-1.0, 1.0, 0.0),
            DVec3::new(1.0, 1.0, 0.0),
            DVec3::new(1.0, -1.0, 0.0),
            DVec3::new(-1.0, -1.0, 0.0),
        ],
        normals: None,
        uvs: Some(vec![
            DVec2::new(0.0, 0.0),
            DVec2::new(2.0, 0.0),
            DVec2::new(2.0, 3.0),
            DVec2::new(0.0, 3.0),
        ]),
        indices: vec![[0, 1, 2], [0, 2, 3]],
        material,
    }
}

#[test]
fn texture_coordinates_at_hits_match_the_reference() {
    let mut s = textured_scene(random_textures(&mut Rng::new(3)));
    s.spheres.clear();
    s.meshes.push(quad_mesh(0));
    let ctx = gpu();
    let gpu_scene = crate::common::upload(&ctx, &s, &Grid::build(&s));
    let reference = cpu::Reference::new(&s);
    let mut rng = Rng::new(11);
    let mut inputs = Vec::new();
    for _ in 0..4096 {
        let o = DVec3::new(rng.range(-2.0, 2.0), rng.range(-2.0, 2.0), rng.range(0.5, 4.0));
        let target = DVec3::new(rng.range(-1.2, 1.2), rng.range(-1.2, 1.2), 0.0);
        inputs.push(v4(o, 0.0));
        inputs.push(v4((target - o).normalize(), 0.0));
    }
    let out = run_kernel(&ctx, &gpu_scene, "k_surface_uv", &inputs, 4096, 1);
    let mut hits = 0;
    for (k, o) in out.iter().enumerate() {
        let (ray_o, ray_d) = (d3(inputs[2 * k]), d3(inputs[2 * k + 1]).normalize());
        let Some(h) = reference.intersect(ray_o, ray_d, f64::INFINITY) else {
            assert!(o[0] == 0.0 || on_edge(ray_o, ray_d), "ray {k}: GPU hit, reference missed");
            continue;
        };
        if o[0] == 0.0 {
            assert!(on_edge(ray_o, ray_d), "ray {k}: reference hit, GPU missed");
            continue;
        }
        hits += 1;
        // Barycentrics in f32 are good to ~1e-6 of the quad; uv spans 3 units across it.
        let err = (DVec2::new(o[1] as f64, o[2] as f64) - h.uv).abs().max_element();
        assert!(err < 1e-5, "ray {k}: uv {:?} vs {}", &o[1..3], h.uv);
    }
    assert!(hits > 2500, "only {hits} hits");
}

/// Whether the ray passes within f32 rounding of the quad's outline.
fn on_edge(o: DVec3, d: DVec3) -> bool {
    let p = o + d * (-o.z / d.z);
    (p.x.abs() - 1.0).abs() < 1e-5 || (p.y.abs() - 1.0).abs() < 1e-5
}

/// Whether two u coordinates agree within `tol`, counting 0 and 1 as the same (the seam).
fn same_u(a: f64, b: f64, tol: f64) -> bool {
    let d = (a - b).abs();
    d.min(1.0 - d) < tol
}

#[test]
fn sphere_and_cone_coordinates_match_the_reference() {
    let mut s = textured_scene(random_textures(&mut Rng::new(5)));
    s.spheres = vec![irt::scene::Sphere { center: DVec3::new(0.3, -0.2, 0.1), radius: 1.0, material: 0 }];
    // A slanted truncated cone away from the sphere, and a cylinder along +y (a.z = 0: the seam
    // of the frame construction's sign choice).
    s.cones = vec![
        irt::scene::Cone {
            base: DVec3::new(3.0, -1.0, 0.5),
            base_radius: 0.8,
            apex: DVec3::new(3.6, 1.0, -0.2),
            apex_radius: 0.3,
            material: 1,
        },
        irt::scene::Cone {
            base: DVec3::new(-3.0, -1.0, 0.0),
            base_radius: 0.6,
            apex: DVec3::new(-3.0, 1.2, 0.0),
            apex_radius: 0.6,
            material: 2,
        },
    ];
    let ctx = gpu();
    let gpu_scene = crate::common::upload(&ctx, &s, &Grid::build(&s));
    let reference = cpu::Reference::new(&s);
    let mut rng = Rng::new(13);
    let targets = [DVec3::new(0.3, -0.2, 0.1), DVec3::new(3.3, 0.0, 0.15), DVec3::new(-3.0, 0.1, 0.0)];
    let mut inputs = Vec::new();
    for i in 0..6144 {
        let o = rng.unit() * 8.0;
        let target = targets[i % 3] + rng.vec(-0.9, 0.9);
        inputs.push(v4(o, 0.0));
        inputs.push(v4((target - o).normalize(), 0.0));
    }
    let out = run_kernel(&ctx, &gpu_scene, "k_surface_uv", &inputs, (inputs.len() / 2) as u32, 1);
    let (mut checked, mut sphere_hits, mut cone_hits) = (0, 0, 0);
    for (k, o) in out.iter().enumerate() {
        let (ray_o, ray_d) = (d3(inputs[2 * k]), d3(inputs[2 * k + 1]).normalize());
        let Some(h) = reference.intersect(ray_o, ray_d, f64::INFINITY) else { continue };
        if o[0] == 0.0 {
            continue; // a silhouette graze decided the other way; the golden tests cover those
        }
        // Where the angle around the axis is ill-conditioned (at a pole or on the axis) u may
        // differ arbitrarily; skip points within 1% of the radius of it.
        let (axis_point, axis, radius) = if h.material == 0 {
            sphere_hits += 1;
            (s.spheres[0].center, DVec3::Y, 1.0)
        } else {
            cone_hits += 1;
            let c = &s.cones[h.material as usize - 1];
            (c.base, (c.apex - c.base).normalize(), c.base_radius.min(c.apex_radius))
        };
        let q = h.p - axis_point;
        if (q - q.dot(axis) * axis).length() < 0.01 * radius {
            continue;
        }
        checked += 1;
        // f32 hit points are good to ~1e-7 of the scene's size, and lavapipe's atan2/acos to a few
        // ulps: 1e-4 (a tenth of a texel of a 1024-wide texture) is far above both and far
        // below any mistake in the convention.
        let (u, v) = (o[1] as f64, o[2] as f64);
        assert!(same_u(u, h.uv.x, 1e-4) && (v - h.uv.y).abs() < 1e-4, "ray {k}: uv ({u}, {v}) vs {}", h.uv);
    }
    println!("{checked} hits compared ({sphere_hits} sphere, {cone_hits} cone)");
    assert!(sphere_hits > 1000 && cone_hits > 1000 && checked > 3000, "{sphere_hits}/{cone_hits}/{checked}");
}

#[test]
fn sphere_and_cone_coordinates_follow_the_convention() {
    use cpu::{cone_uv, sphere_uv};
    // Sphere: the +y pole is v = 0 (the image's top row), the equator v = 1/2, -y v = 1; going
    // round +y, u covers [0, 1] once.
    assert!((sphere_uv(DVec3::Y).y).abs() < 1e-12 && (sphere_uv(-DVec3::Y).y - 1.0).abs() < 1e-12);
    assert!((sphere_uv(DVec3::X).y - 0.5).abs() < 1e-12);
    let us: Vec<f64> = (0..8)
        .map(|i| {
            let a = i as f64 * std::f64::consts::TAU / 8.0;
            sphere_uv(DVec3::new(a.cos(), 0.0, a.sin())).x
        })
        .collect();
    let steps: Vec<f64> = us.windows(2).map(|w| (w[1] - w[0]).rem_euclid(1.0)).collect();
    assert!(
        steps.iter().all(|&d| (d - 0.125).abs() < 1e-12) || steps.iter().all(|&d| (d - 0.875).abs() < 1e-12),
        "{us:?}"
    );
    // Cone: v = 1 at the base, 0 at the apex, linear in between.
    let (base, apex) = (DVec3::new(1.0, 2.0, 3.0), DVec3::new(1.0, 2.0, 5.0));
    assert!((cone_uv(base + DVec3::X, base, apex).y - 1.0).abs() < 1e-12);
    assert!((cone_uv(apex + DVec3::X, base, apex).y).abs() < 1e-12);
    assert!((cone_uv(base + DVec3::new(0.0, 0.5, 0.5), base, apex).y - 0.75).abs() < 1e-12);
}
