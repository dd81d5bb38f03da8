//! The extreme-scene suite (issue: numerical stability): every case is traced by the GPU and by
//! the f64 reference and must agree within the golden tolerance (`common::assert_matches_reference`,
//! which also rejects any NaN or infinity), and every GPU pixel must encode to a value in [0, 1].
use crate::common;

use common::*;
use glam::DVec3;
use irt::io::shapes;
use irt::scene::*;

fn check(name: &str, scene: Scene) {
    scene.validate().unwrap_or_else(|e| panic!("{name}: {e}"));
    let ctx = gpu();
    let img = render_gpu(&ctx, &scene);
    assert!(
        img.pixels.iter().flatten().all(|c| c.is_finite() && *c >= 0.0),
        "{name}: negative or non-finite radiance"
    );
    assert_matches_reference(name, &img, &reference_image(&scene));
}

/// The default scene, small.
fn small_default() -> Scene {
    let mut s = default_scene();
    s.camera.width = 80;
    s.camera.height = 60;
    s
}

/// Three spheres of every material on a ground quad, under one light, with a small ambient.
fn materials_scene() -> Scene {
    let g = 20.0;
    let mut s = scene_of(
        vec![
            Sphere { center: DVec3::new(-1.2, 0.5, 0.0), radius: 0.5, material: 1 },
            Sphere { center: DVec3::new(0.0, 0.5, 0.3), radius: 0.5, material: 2 },
            Sphere { center: DVec3::new(1.2, 0.5, 0.0), radius: 0.5, material: 3 },
        ],
        vec![
            [DVec3::new(-g, 0.0, -g), DVec3::new(-g, 0.0, g), DVec3::new(g, 0.0, g)],
            [DVec3::new(-g, 0.0, -g), DVec3::new(g, 0.0, g), DVec3::new(g, 0.0, -g)],
        ],
    );
    s.materials.extend([
        material("metal", MaterialKind::Metal { color: DVec3::new(0.9, 0.8, 0.6), exponent: 50.0 }),
        material("glass", MaterialKind::Dielectric { eta: 1.5, exponent: 100.0 }),
        material(
            "polished",
            MaterialKind::Polished { color: DVec3::new(0.2, 0.3, 0.8), eta: 1.5, exponent: 80.0 },
        ),
    ]);
    s.camera = Camera {
        eye: DVec3::new(0.0, 1.5, 4.5),
        look_at: DVec3::new(0.0, 0.4, 0.0),
        up: DVec3::Y,
        vfov_deg: 45.0,
        width: 64,
        height: 48,
    };
    s.lights = vec![Light { position: DVec3::new(3.0, 6.0, 4.0), color: DVec3::splat(0.8), radius: 0.0 }];
    s.ambient =
        Ambient { sky: DVec3::new(0.2, 0.25, 0.3), ground: DVec3::new(0.1, 0.08, 0.05), up: DVec3::Y };
    s.background = DVec3::new(0.3, 0.4, 0.6);
    s
}

#[test]
fn default_scene_far_from_the_origin() {
    for d in [1e3, 1e5, 1e6, 1e7] {
        check(&format!("default at {d:e}"), small_default().transformed(1.0, irt::lab::stability::offset(d)));
    }
}

#[test]
fn default_scene_tiny_and_huge() {
    for scale in [1e-4, 1e4] {
        check(&format!("default scaled {scale:e}"), small_default().transformed(scale, DVec3::ZERO));
    }
}

#[test]
fn huge_ground_sphere_under_small_objects() {
    let mut s = materials_scene();
    s.meshes.clear();
    s.spheres.push(Sphere { center: DVec3::new(0.0, -1e6, 0.0), radius: 1e6, material: 0 });
    check("ground sphere r=1e6", s);
}

#[test]
fn grazing_view_along_a_large_triangle() {
    let mut s = materials_scene();
    s.camera.eye = DVec3::new(0.0, 1e-3, 6.0);
    s.camera.look_at = DVec3::new(0.0, 0.3, 0.0);
    check("grazing", s);
}

#[test]
fn axis_parallel_rays_through_cell_boundaries() {
    // Odd sizes put the centre pixel's ray exactly on the view axis, (0, 0, -1) with ±0s, and the
    // eye on the grid's cell planes through x = 0 and y = 0.5.
    let mut s = materials_scene();
    s.camera = Camera {
        eye: DVec3::new(0.0, 0.5, 6.0),
        look_at: DVec3::new(0.0, 0.5, 0.0),
        up: DVec3::Y,
        vfov_deg: 30.0,
        width: 65,
        height: 49,
    };
    check("axis-parallel", s);
}

#[test]
fn camera_inside_a_sphere_and_inside_glass() {
    let mut s = materials_scene();
    s.spheres.push(Sphere { center: DVec3::new(0.0, 1.5, 4.5), radius: 0.4, material: 2 });
    check("inside glass", s);
    let mut s = materials_scene();
    s.spheres.push(Sphere { center: DVec3::new(0.0, 1.5, 4.5), radius: 30.0, material: 0 });
    s.lights[0].position = DVec3::new(1.0, 4.0, 2.0);
    check("inside a sphere", s);
}

#[test]
fn highlight_exponents_from_1_to_1e4() {
    for n in [1.0, 10.0, 100.0, 1e3, 1e4] {
        let mut s = materials_scene();
        s.materials[1].kind = MaterialKind::Metal { color: DVec3::new(0.9, 0.8, 0.6), exponent: n };
        s.materials[3].kind =
            MaterialKind::Polished { color: DVec3::new(0.2, 0.3, 0.8), eta: 1.5, exponent: n };
        check(&format!("exponent {n}"), s);
    }
}

#[test]
fn ambient_at_exactly_0_half_pi_and_pi() {
    // Faces whose normals are exactly up, sideways and down: a box seen from below and beside.
    let mut s = scene_of(vec![], vec![]);
    s.meshes = vec![shapes::cuboid(DVec3::new(-1.0, -1.0, -1.0), DVec3::new(1.0, 1.0, 1.0)).into_mesh(0)];
    s.lights.clear();
    s.ambient = Ambient { sky: DVec3::new(0.9, 0.2, 0.1), ground: DVec3::new(0.1, 0.3, 0.9), up: DVec3::Y };
    for eye in [DVec3::new(2.5, -3.0, 3.5), DVec3::new(2.5, 3.0, 3.5)] {
        s.camera.eye = eye;
        s.camera.look_at = DVec3::ZERO;
        s.camera.width = 48;
        s.camera.height = 48;
        check(&format!("ambient box from {eye}"), s.clone());
    }
}

#[test]
fn degenerate_geometry_is_skipped_not_propagated() {
    let mut s = materials_scene();
    let p = DVec3::new(0.3, 1.2, 0.5);
    // A zero-area triangle, one with coincident vertices, and a smooth mesh whose vertex normals
    // include a zero vector (its interpolated normal falls back to the face normal).
    let mut ico = shapes::icosphere(DVec3::new(0.0, 1.4, -1.0), 0.4, 1);
    if let Some(n) = ico.normals.as_mut() {
        n[0] = DVec3::ZERO;
    }
    s.meshes.push(Mesh {
        positions: vec![p, p, p, p, p + DVec3::X, p + 2.0 * DVec3::X],
        normals: None,
        uvs: None,
        indices: vec![[0, 1, 2], [3, 4, 5]],
        material: 1,
    });
    s.meshes.push(ico.into_mesh(3));
    check("degenerate", s);
}

#[test]
fn empty_scene_one_primitive_and_everything_in_one_cell() {
    let mut s = materials_scene();
    s.spheres.clear();
    s.meshes.clear();
    check("empty", s.clone());
    s.spheres.push(Sphere { center: DVec3::new(0.0, 0.5, 0.0), radius: 0.5, material: 2 });
    check("one primitive", s.clone());
    // Many spheres within a hair of each other and one far away: the grid's cells are huge
    // next to the cluster, which lands in a single cell.
    let mut rng = Rng::new(4);
    s.spheres = (0..60)
        .map(|_| Sphere {
            center: DVec3::new(0.0, 0.5, 0.0) + rng.vec(-0.3, 0.3),
            radius: 0.05 + 0.1 * rng.f(),
            material: (rng.below(3) + 1) as u32,
        })
        .collect();
    s.spheres.push(Sphere { center: DVec3::new(400.0, 300.0, -500.0), radius: 1.0, material: 0 });
    let grid = irt::accel::Grid::build(&s);
    let busiest = grid.cell_start.windows(2).map(|w| w[1] - w[0]).max().unwrap();
    assert!(busiest >= 50, "the cluster is spread over cells ({busiest} at most in one)");
    check("one cell", s);
}

#[test]
fn dielectric_around_the_critical_angle() {
    // The eye inside a large glass sphere (eta 1.5, critical angle 41.8°), looking at its wall
    // obliquely: the image spans incidence angles from near 0° to about 65° (30° at its centre),
    // so a band of pixels sits at the critical angle, where reflectance jumps to 1 (total
    // internal reflection).
    let mut s = materials_scene();
    s.spheres.push(Sphere { center: DVec3::new(0.0, 0.5, 0.0), radius: 5.0, material: 2 });
    s.camera.eye = DVec3::new(-1.5, 0.8, 2.0);
    s.camera.look_at = DVec3::new(3.0, 0.8, 4.5);
    s.camera.vfov_deg = 60.0;
    check("critical angle", s);
}

#[test]
fn f64_pipeline_matches_the_reference() {
    // The f64 variant (intersection and traversal in f64) on the default scene, near the origin
    // and 1e7 away.
    let ctx = gpu();
    for d in [0.0, 1e7] {
        let s = small_default().transformed(1.0, irt::lab::stability::offset(d));
        let opts = irt::render::Settings { f64: true, ..irt::render::Settings::bands() };
        let img = irt::render::Session::new(&ctx, &s, opts)
            .expect("f64 renderer")
            .picture(&ctx, &mut |_, _| {})
            .image;
        assert_matches_reference(&format!("f64 default at {d:e}"), &img, &reference_image(&s));
    }
}
