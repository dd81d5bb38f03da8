//! Each shader function, run through a readback kernel (shaders/tests.wgsl) on thousands of
//! generated inputs, against its f64 twin of the same name in `irt::reference`.
//!
//! Inputs are rounded to f32 before the f64 twin sees them, so the tolerances below measure the
//! shader's own f32 arithmetic; each is stated where it is used, with why.
use crate::common;

use crate::common::run_kernel;
use common::*;
use glam::DVec3;
use irt::accel::Grid;
use irt::gpu::{GpuContext, GpuScene};
use irt::reference as cpu;
use irt::scene::MaterialKind;

const N: usize = 4096;

struct Harness {
    ctx: GpuContext,
    scene: GpuScene,
}

impl Harness {
    fn new() -> Self {
        let ctx = gpu();
        let s = scene_of(vec![irt::scene::Sphere { center: DVec3::ZERO, radius: 1.0, material: 0 }], vec![]);
        let scene = crate::common::upload(&ctx, &s, &Grid::build(&s));
        Harness { ctx, scene }
    }
    fn run(&self, entry: &str, inputs: &[[f32; 4]], items: usize, out_per: u32) -> Vec<[f32; 4]> {
        run_kernel(&self.ctx, &self.scene, entry, inputs, items as u32, out_per)
    }
}

#[test]
fn ray_sphere() {
    let h = Harness::new();
    let mut rng = Rng::new(1);
    let mut cases = Vec::new();
    for i in 0..N {
        // Every tenth sphere is planet-sized, with rays starting just above its surface.
        let huge = i % 10 == 9;
        let c = if huge {
            f32_round(DVec3::new(0.0, -1e6, 0.0) + rng.vec(-10.0, 10.0))
        } else {
            f32_round(rng.vec(-10.0, 10.0))
        };
        let r = if huge { 1e6 } else { rng.range(0.05, 5.0) as f32 as f64 };
        // A third of the rays start inside the sphere; the rest aim near it (hits and misses).
        let o = if huge {
            f32_round(c + DVec3::new(rng.range(-5.0, 5.0), r + rng.range(0.01, 3.0), rng.range(-5.0, 5.0)))
        } else if i % 3 == 0 {
            f32_round(c + rng.unit() * r * rng.f() * 0.99)
        } else {
            f32_round(rng.vec(-20.0, 20.0))
        };
        let target = if huge {
            o + DVec3::new(rng.range(-4.0, 4.0), -rng.range(0.5, 3.0), rng.range(-4.0, 4.0))
        } else {
            c + rng.unit() * r * rng.range(0.0, 1.5)
        };
        let d = f32_round((target - o).normalize());
        let (t_min, t_max) =
            if i % 5 == 0 { (rng.range(0.0, 2.0), rng.range(2.0, 30.0)) } else { (0.0, 1e30) };
        cases.push((o, d, c, r, t_min as f32 as f64, t_max as f32 as f64));
    }
    let inputs: Vec<[f32; 4]> = cases
        .iter()
        .flat_map(|&(o, d, c, r, a, b)| {
            // The anchor as the renderer makes it: nearest the ray's origin here.
            let anchor = irt::gpu::layout::sphere_anchor(c, r, o);
            [v4(o, a), v4(d, b), v4(c, r), v4(anchor, 0.0)]
        })
        .collect();
    let out = h.run("k_sphere", &inputs, N, 1);
    let mut checked = 0;
    for (k, &(o, d, c, r, a, b)) in cases.iter().enumerate() {
        let want = cpu::intersect_sphere(o, d, c, r, a, b);
        let got = out[k][0] as f64;
        // Near-tangent rays (closest approach within 1e-4 r of the surface) and roots within
        // 1e-4 of t_min/t_max may be classified either way in f32.
        let oc = o - c;
        let closest = (oc - oc.dot(d) * d).length();
        // The numbers the root is computed from: distances from the anchor (and the radius for
        // a sphere smaller than them).
        let scale = if r > 1e3 { 10.0 * ((o - c).length() - r).abs().max(1.0) } else { oc.length() + r };
        let ambiguous = (closest - r).abs() < 1e-4 * scale
            || want.is_some_and(|t| (t - a).abs() < 1e-4 * scale || (t - b).abs() < 1e-4 * scale);
        if ambiguous {
            continue;
        }
        checked += 1;
        match want {
            None => assert_eq!(got, -1.0, "case {k}: GPU hit at {got}, reference misses"),
            // f32 has 6e-8 relative precision; the root's error grows with |o - c| + r through
            // the subtractions, so allow 1e-5 of that scale.
            Some(t) => assert!((got - t).abs() <= 1e-5 * scale, "case {k}: GPU t {got}, reference {t}"),
        }
    }
    assert!(checked > N * 9 / 10, "only {checked} unambiguous cases");
}

#[test]
fn ray_triangle() {
    let h = Harness::new();
    let mut rng = Rng::new(2);
    let mut cases = Vec::new();
    for i in 0..N {
        let p = [f32_round(rng.vec(-5.0, 5.0)), f32_round(rng.vec(-5.0, 5.0)), f32_round(rng.vec(-5.0, 5.0))];
        let tri = if i % 50 == 0 { [p[0], p[1], p[0] * 0.5 + p[1] * 0.5] } else { p }; // some degenerate
        let o = f32_round(rng.vec(-10.0, 10.0));
        let (b1, b2) = (rng.range(-0.3, 1.1), rng.range(-0.3, 1.1));
        let target = tri[0] + b1 * (tri[1] - tri[0]) + b2 * (tri[2] - tri[0]);
        let d = f32_round((target - o).normalize());
        cases.push((o, d, tri));
    }
    let inputs: Vec<[f32; 4]> = cases
        .iter()
        .flat_map(|&(o, d, t)| [v4(o, 0.0), v4(d, 1e30), v4(t[0], 0.0), v4(t[1], 0.0), v4(t[2], 0.0)])
        .collect();
    let out = h.run("k_triangle", &inputs, N, 1);
    let mut checked = 0;
    for (k, &(o, d, t)) in cases.iter().enumerate() {
        let want = cpu::intersect_triangle(o, d, t[0], t[1], t[2], 0.0, 1e30);
        let got = out[k];
        // Rays within 1e-4 (barycentric) of an edge, or nearly parallel to the plane, or
        // degenerate triangles may be classified either way in f32 (watertightness is tested
        // separately on closed meshes).
        let n = (t[1] - t[0]).cross(t[2] - t[0]);
        if n.length() < 1e-6 || n.normalize().dot(d).abs() < 1e-3 {
            continue;
        }
        let (u, v) = plane_barycentrics(o, d, t);
        if u.abs() < 1e-4 || v.abs() < 1e-4 || (1.0 - u - v).abs() < 1e-4 {
            continue;
        }
        checked += 1;
        match want {
            None => assert_eq!(got[0], -1.0, "case {k}: GPU hit {got:?}, reference misses"),
            Some((tw, u, v)) => {
                let scale = (o - t[0]).length() + 10.0;
                assert!((got[0] as f64 - tw).abs() <= 1e-5 * scale, "case {k}: t {} vs {tw}", got[0]);
                assert!(
                    (got[1] as f64 - u).abs() < 1e-4 && (got[2] as f64 - v).abs() < 1e-4,
                    "case {k}: barycentrics {got:?} vs ({u}, {v})"
                );
            }
        }
    }
    assert!(checked > N * 3 / 4, "only {checked} unambiguous cases");
}

/// A generated cone: cylinders, pointed and truncated cones, near-cylinders, thin needles and
/// nearly flat rings, anywhere in a 20-unit box. Returned as the GPU sees it (f32 base, axis and
/// radii) with the f64 apex `base + axis`.
fn random_cone(rng: &mut Rng, i: usize) -> (DVec3, f64, DVec3, f64) {
    let base = f32_round(rng.vec(-10.0, 10.0));
    let r = rng.range(0.05, 3.0);
    let h = match i % 7 {
        5 => r * rng.range(0.01, 0.1),   // nearly flat: a wide ring
        6 => r * rng.range(20.0, 100.0), // a needle
        _ => rng.range(0.1, 8.0),
    };
    let axis = f32_round(rng.unit() * h);
    let (r0, r1) = match i % 5 {
        0 => (r, r),
        1 => (r, 0.0),
        2 => (0.0, r),
        3 => (r, r * (1.0 + 1e-5)),
        _ => (r, rng.range(0.0, 3.0)),
    };
    (base, r0 as f32 as f64, base + axis, r1 as f32 as f64)
}

#[test]
fn ray_cone() {
    let h = Harness::new();
    let mut rng = Rng::new(7);
    let mut cases = Vec::new();
    for i in 0..N {
        let (base, r0, apex, r1) = random_cone(&mut rng, i);
        let axis = apex - base;
        let (u, w) = axis.normalize().any_orthonormal_pair();
        // Aim at a point near the surface, a little past the ends too; a third of the rays start
        // inside the cone's hull, some run parallel to the axis or to a generating line.
        let s = rng.range(-0.2, 1.2);
        let phi = rng.range(0.0, std::f64::consts::TAU);
        let radial = phi.cos() * u + phi.sin() * w;
        let r = r0 + s.clamp(0.0, 1.0) * (r1 - r0);
        let target = base + s * axis + radial * r * rng.range(0.0, 1.5);
        let o = match i % 3 {
            0 => f32_round(base + rng.f() * axis + radial * r * rng.f() * 0.9),
            _ => f32_round(target + rng.unit() * rng.range(1.0, 20.0)),
        };
        let mut d = (target - o).normalize();
        if i % 31 == 0 {
            d = axis.normalize();
        } else if i % 31 == 1 {
            d = (axis + (r0 - r1) * radial).normalize();
        }
        let d = f32_round(d);
        let (t_min, t_max) =
            if i % 5 == 0 { (rng.range(0.0, 2.0), rng.range(2.0, 30.0)) } else { (0.0, 1e30) };
        cases.push((o, d, base, r0, apex, r1, t_min as f32 as f64, t_max as f32 as f64));
    }
    let inputs: Vec<[f32; 4]> = cases
        .iter()
        .flat_map(|&(o, d, b, r0, a, r1, t0, t1)| [v4(o, t0), v4(d, t1), v4(b, r0), v4(a - b, r1)])
        .collect();
    let out = h.run("k_cone", &inputs, N, 1);
    let (mut checked, mut hits, mut worst) = (0, 0, 0.0f64);
    for (k, &(o, d, b, r0, a, r1, t0, t1)) in cases.iter().enumerate() {
        let want = cpu::intersect_cone(o, d, b, r0, a, r1, t0, t1);
        let got = out[k][0] as f64;
        // f32 cannot tell apart cones that differ by a few ulps of the scene's scale, so a case
        // is ambiguous when the f64 answer changes between the cone grown and shrunk by
        // 1e-4 of that scale (radii and ends): grazing rays, rays past a rim or along a
        // generating line. Elsewhere the same perturbation bounds the sensitivity of t.
        let scale = (o - (a + b) * 0.5).length() + (a - b).length() + r0.max(r1);
        let delta = 1e-4 * scale;
        let e = (a - b).normalize() * delta;
        let grown = cpu::intersect_cone(o, d, b - e, r0 + delta, a + e, r1 + delta, t0, t1);
        let shrunk =
            cpu::intersect_cone(o, d, b + e, (r0 - delta).max(0.0), a - e, (r1 - delta).max(0.0), t0, t1);
        let near_limit = want.is_some_and(|t| (t - t0).abs() < 1e-4 * scale || (t - t1).abs() < 1e-4 * scale);
        let (Some(tg), Some(ts)) = (grown, shrunk) else {
            if grown.is_some() != shrunk.is_some() || near_limit || (a - b).length() < 2.0 * delta {
                continue;
            }
            checked += 1;
            assert_eq!(got, -1.0, "case {k}: GPU hit at {got}, reference misses");
            continue;
        };
        if near_limit {
            continue;
        }
        checked += 1;
        let Some(t) = want else {
            // Hit by both neighbours but not by the cone itself: it lies between them.
            continue;
        };
        hits += 1;
        let tol = 1e-5 * scale + (tg - ts).abs();
        worst = worst.max((got - t).abs() / scale);
        assert!((got - t).abs() <= tol, "case {k}: GPU t {got}, reference {t} (tolerance {tol})");
        // The normal there: f32 error of the hit point over the local radius moves it.
        let p = o + t * d;
        let n = cpu::cone_normal(p, b, r0, a, r1);
        let sp = ((p - b).dot(a - b) / (a - b).length_squared()).clamp(0.0, 1.0);
        let local_r = r0 + sp * (r1 - r0);
        if local_r > 1e-2 * scale {
            let tol = 1e-3 + 1e-5 * scale / local_r;
            let got_n = DVec3::new(out[k][1] as f64, out[k][2] as f64, out[k][3] as f64);
            assert!((got_n - n).length() < tol, "case {k}: normal {got_n} vs {n}");
        }
    }
    println!("ray_cone: {checked} unambiguous cases, {hits} hits, worst t error {worst:e} of the scale");
    assert!(checked > N * 4 / 5, "only {checked} unambiguous cases");
    assert!(hits > N / 4, "only {hits} hits");
}

#[test]
fn schlick_and_dielectric_reflectance() {
    let h = Harness::new();
    let mut rng = Rng::new(3);
    let mut cases: Vec<[f64; 4]> = (0..N)
        .map(|i| [rng.f(), rng.f(), rng.range(1.0, 2.5), (i % 2) as f64].map(|x| x as f32 as f64))
        .collect();
    // The ends: normal and grazing incidence, and exactly the critical angle of eta = 1.5.
    cases.extend([[1.0, 0.04, 1.5, 0.0], [0.0, 0.04, 1.5, 0.0], [1.0, 0.0, 1.5, 1.0], [0.0, 0.5, 1.5, 1.0]]);
    let crit = (1.0f64 - 1.0 / (1.5 * 1.5)).sqrt() as f32 as f64;
    cases.push([crit, 0.04, 1.5, 1.0]);
    let inputs: Vec<[f32; 4]> = cases.iter().map(|c| c.map(|x| x as f32)).collect();
    let out = h.run("k_fresnel", &inputs, cases.len(), 1);
    for (k, c) in cases.iter().enumerate() {
        let s = cpu::schlick(c[0], c[1]);
        assert!((out[k][0] as f64 - s).abs() < 1e-6, "schlick{c:?}: {} vs {s}", out[k][0]);
        let inside = c[3] != 0.0;
        let sin2_t = c[2] * c[2] * (1.0 - c[0] * c[0]);
        // At the critical angle sqrt(1 - sin²t) has unbounded slope: skip the 1e-5 band.
        if inside && (sin2_t - 1.0).abs() < 1e-5 {
            continue;
        }
        let f = cpu::dielectric_reflectance(c[0], c[2], inside);
        // sqrt(1 - sin²t) amplifies f32 rounding near the critical angle: 1e-4 absolute.
        assert!((out[k][1] as f64 - f).abs() < 1e-4, "dielectric{c:?}: {} vs {f}", out[k][1]);
    }
    // Values with known answers: normal incidence on glass is R0 = 0.04; grazing is 1.
    assert!((out[N][0] - 0.04).abs() < 1e-7);
    assert!((out[N + 1][0] - 1.0).abs() < 1e-7);
}

#[test]
fn refraction_reflection_and_total_internal_reflection() {
    let h = Harness::new();
    let mut rng = Rng::new(4);
    let mut cases = Vec::new();
    for _ in 0..N {
        let n = f32_round(rng.unit());
        let mut d = rng.unit();
        if d.dot(n) > 0.0 {
            d = -d;
        }
        cases.push((f32_round(d), n, rng.range(0.4, 2.5) as f32 as f64));
    }
    let inputs: Vec<[f32; 4]> = cases.iter().flat_map(|&(d, n, e)| [v4(d, 0.0), v4(n, e)]).collect();
    let out = h.run("k_refract", &inputs, N, 2);
    let (mut tir, mut through) = (0, 0);
    for (k, &(d, n, eta)) in cases.iter().enumerate() {
        let r = cpu::reflect(d, n);
        assert!((d3(out[2 * k + 1]) - r).length() < 1e-5, "reflect case {k}");
        let c = -n.dot(d);
        let kk = 1.0 - eta * eta * (1.0 - c * c);
        if kk.abs() < 1e-5 {
            continue; // grazing the critical angle
        }
        match cpu::refract(d, n, eta) {
            None => {
                tir += 1;
                assert_eq!(out[2 * k][3], 0.0, "case {k}: GPU refracts, reference has TIR");
            }
            Some(t) => {
                through += 1;
                assert_eq!(out[2 * k][3], 1.0, "case {k}: GPU has TIR, reference refracts");
                // Snell's law holds for the reference; the GPU direction agrees to 1e-4 (the
                // sqrt(k) term amplifies f32 error as k -> 0).
                assert!((d3(out[2 * k]) - t).length() < 1e-4, "case {k}: {:?} vs {t}", out[2 * k]);
            }
        }
    }
    assert!(tir > 100 && through > 100, "both branches exercised: tir {tir}, through {through}");
}

#[test]
fn two_colour_ambient() {
    let h = Harness::new();
    let mut rng = Rng::new(5);
    let up = DVec3::Y;
    let (sky, ground) = (DVec3::new(0.2, 0.4, 0.9), DVec3::new(0.5, 0.3, 0.1));
    // θ exactly 0, π/2 and π first, then random normals and random up vectors.
    let mut cases =
        vec![(DVec3::Y, up, sky, ground), (DVec3::X, up, sky, ground), (-DVec3::Y, up, sky, ground)];
    for _ in 0..N {
        cases.push((
            f32_round(rng.unit()),
            f32_round(rng.unit()),
            f32_round(rng.vec(0.0, 1.0)),
            f32_round(rng.vec(0.0, 1.0)),
        ));
    }
    let inputs: Vec<[f32; 4]> =
        cases.iter().flat_map(|&(n, u, a, b)| [v4(n, 0.0), v4(u, 0.0), v4(a, 0.0), v4(b, 0.0)]).collect();
    let out = h.run("k_ambient", &inputs, cases.len(), 1);
    assert!((d3(out[0]) - sky).length() < 1e-6, "θ = 0 gives A");
    assert!((d3(out[1]) - (sky + ground) / 2.0).length() < 1e-6, "θ = π/2 gives (A+B)/2");
    assert!((d3(out[2]) - ground).length() < 1e-6, "θ = π gives B");
    for (k, &(n, u, a, b)) in cases.iter().enumerate() {
        let want = cpu::ambient_intensity(n, u, a, b);
        // sin θ = sqrt(1 - cos²θ) loses precision near θ = 0 (slope unbounded): 1e-3 there.
        let tol = if n.dot(u).abs() > 0.9999 { 1e-3 } else { 1e-5 };
        assert!((d3(out[k]) - want).length() < tol, "case {k}: {:?} vs {want}", out[k]);
    }
}

fn random_material(rng: &mut Rng, kind: usize) -> MaterialKind {
    let color = f32_round(rng.vec(0.0, 1.0));
    let exponent = [0.0, 1.0, 10.0, 100.0, 1000.0][rng.below(5)];
    let eta = rng.range(1.05, 2.5) as f32 as f64;
    match kind {
        0 => MaterialKind::Diffuse { color },
        1 => MaterialKind::Metal { color, exponent },
        2 => MaterialKind::Dielectric { eta, exponent },
        _ => MaterialKind::Polished { color, eta, exponent },
    }
}

#[test]
fn each_material_shading() {
    let h = Harness::new();
    let mut rng = Rng::new(6);
    let mut cases = Vec::new();
    for i in 0..N {
        let m = random_material(&mut rng, i % 4);
        let n = f32_round(rng.unit());
        let mut e = rng.unit();
        if e.dot(n) < 0.0 {
            e = -e;
        }
        let l = f32_round(rng.unit());
        cases.push((
            m,
            n,
            f32_round(e),
            l,
            f32_round(rng.vec(0.0, 2.0)),
            f32_round(rng.vec(0.0, 1.0)),
            i % 8 == 3,
        ));
    }
    let inputs: Vec<[f32; 4]> = cases
        .iter()
        .flat_map(|(m, n, e, l, le, ia, inside)| {
            let code = irt::gpu::layout::material_code(m) as f64;
            let (color, eta, exponent) = match *m {
                MaterialKind::Diffuse { color } => (color, 1.0, 0.0),
                MaterialKind::Metal { color, exponent } => (color, 1.0, exponent),
                MaterialKind::Dielectric { eta, exponent } => (DVec3::ONE, eta, exponent),
                MaterialKind::Polished { color, eta, exponent } => (color, eta, exponent),
            };
            [
                v4(color, code),
                [eta as f32, exponent as f32, *inside as u8 as f32, 0.0],
                v4(*n, 0.0),
                v4(*e, 0.0),
                v4(*l, 0.0),
                v4(*le, 0.0),
                v4(*ia, 0.0),
            ]
        })
        .collect();
    let out = h.run("k_shade", &inputs, N, 3);
    for (k, (m, n, e, l, le, ia, inside)) in cases.iter().enumerate() {
        let exponent = match m {
            MaterialKind::Metal { exponent, .. }
            | MaterialKind::Dielectric { exponent, .. }
            | MaterialKind::Polished { exponent, .. } => *exponent,
            MaterialKind::Diffuse { .. } => 0.0,
        };
        // (n·h)^N multiplies the f32 relative error of n·h (~1e-7) by N; the dielectric's
        // exit-side cos_t has unbounded slope at the critical angle.
        let tol = |want: DVec3| 1e-5 + 1e-6 * (exponent + 10.0) * want.length();
        let sin2_t = match m {
            MaterialKind::Dielectric { eta, .. } => eta * eta * (1.0 - n.dot(*e).powi(2)),
            _ => 0.0,
        };
        if *inside && (sin2_t - 1.0).abs() < 1e-4 {
            continue;
        }
        // n·l = 0 is where the light term switches on; skip the f32 rounding band around it.
        if n.dot(*l).abs() < 1e-6 {
            continue;
        }
        let amb = cpu::shade_ambient(m, *n, *e, *ia, *inside);
        assert!(
            (d3(out[3 * k]) - amb).length()
                <= tol(amb) + 1e-4 * (matches!(m, MaterialKind::Dielectric { .. }) as u8 as f64),
            "case {k} {m:?}: ambient {:?} vs {amb}",
            out[3 * k]
        );
        let light = cpu::shade_light(m, *n, *e, *l, *le, *inside);
        assert!(
            (d3(out[3 * k + 1]) - light).length() <= tol(light) + 1e-4,
            "case {k} {m:?}: light {:?} vs {light}",
            out[3 * k + 1]
        );
        let (ks, kt) = cpu::reflectance(m, *n, *e, *inside);
        assert!(
            (d3(out[3 * k + 2]) - ks).length() < 1e-4,
            "case {k} {m:?}: k_s {:?} vs {ks}",
            out[3 * k + 2]
        );
        assert!(
            (out[3 * k + 2][3] as f64 - kt).abs() < 1e-4,
            "case {k} {m:?}: k_t {} vs {kt}",
            out[3 * k + 2][3]
        );
    }
}

/// A volume cell's isosurface along a segment (`cell_hit`, shaders/volume.wgsl) against its f64
/// twin `scene::volume::cell_hit` on random cells and segments. The closed form
/// (`cell_hit_closed_form`, Cardano) runs on the same cells as the measured alternative: its
/// errors against the same tolerance are counted and printed, not asserted (docs/volumes.md).
#[test]
fn cell_hit() {
    let h = Harness::new();
    let mut rng = Rng::new(9);
    let mut cases = Vec::new();
    for _ in 0..N {
        let c: [f64; 8] = std::array::from_fn(|_| rng.range(0.0, 10.0) as f32 as f64);
        let a = f32_round(rng.vec(0.0, 1.0));
        let b = f32_round(rng.vec(0.0, 1.0));
        cases.push((c, a, b, rng.range(2.0, 8.0) as f32 as f64));
    }
    let inputs: Vec<[f32; 4]> = cases
        .iter()
        .flat_map(|&(c, a, b, iso)| {
            let q = |i: usize| [c[i] as f32, c[i + 1] as f32, c[i + 2] as f32, c[i + 3] as f32];
            [q(0), q(4), v4(a, iso), v4(b, 0.0)]
        })
        .collect();
    let out = h.run("k_cell_hit", &inputs, N, 1);
    let (mut checked, mut hits) = (0, 0);
    // The closed form's cases outside the tolerance the kept method meets, and its worst error.
    let (mut closed_wrong, mut closed_worst) = (0, 0.0f64);
    for (k, &(c, a, b, iso)) in cases.iter().enumerate() {
        let f = |s: f64| irt::scene::volume::trilinear(&c, (a + (b - a) * s).to_array()) - iso;
        // f32 evaluates the cubic to about 1e-5 of the corners' scale (10): a segment that comes
        // within 1e-4 of iso without crossing, or starts or ends there, may be classified either
        // way, and a root where the cubic is nearly flat moves by that error over its slope.
        let near = (0..=1000).map(|i| f(i as f64 / 1000.0).abs()).fold(f64::INFINITY, f64::min);
        let want = irt::scene::volume::cell_hit(&c, a, b, iso);
        let got = out[k][0] as f64;
        let slope = want.map_or(0.0, |s| ((f((s + 1e-4).min(1.0)) - f((s - 1e-4).max(0.0))) / 2e-4).abs());
        let graze = want.is_none() && near < 1e-3 || f(0.0).abs() < 1e-3 || f(1.0).abs() < 1e-3;
        if graze || (want.is_some() && slope < 0.1) {
            continue;
        }
        checked += 1;
        let closed = out[k][1] as f64;
        match want {
            None => {
                assert_eq!(got, -1.0, "case {k}: GPU s {got}, the f64 twin misses");
                closed_wrong += usize::from(closed != -1.0);
            }
            Some(s) => {
                hits += 1;
                let tolerance = 1e-4 / slope + 1e-6;
                assert!((got - s).abs() <= tolerance, "case {k}: GPU s {got}, f64 {s} (slope {slope})");
                let err = if closed == -1.0 { 1.0 } else { (closed - s).abs() };
                closed_worst = closed_worst.max(err);
                closed_wrong += usize::from(err > tolerance);
            }
        }
    }
    assert!(checked > N * 9 / 10 && hits > N / 5, "{checked} unambiguous cases, {hits} hits");
    println!(
        "cell_hit in f32 on {checked} cells ({hits} crossing): the extrema split and bisection all \
         within tolerance; the closed form {closed_wrong} outside it, worst error {closed_worst:.2e}"
    );
}
