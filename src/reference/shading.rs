//! The shading equations of docs/shading.md in f64, one function per name used there.
//!
//! Conventions: `n` is the unit shading normal already flipped to face the viewer, `e = -d`
//! points to the eye, `l` to the light, all unit. `inside` is true when the ray hit the back
//! side (the normal was flipped).

use crate::scene::MaterialKind;
use glam::DVec3;

/// `max(0, min(1, x))`: the docs clamp dot products at 0; cosines of unit vectors can exceed 1
/// by an ulp, which we also clip so that `1 - cos` never goes negative.
fn clamp01(x: f64) -> f64 {
    x.clamp(0.0, 1.0)
}

/// `x^n` with `0^0 = 1` (exponent 0 gives a constant highlight).
fn pow0(x: f64, n: f64) -> f64 {
    if n == 0.0 {
        1.0
    } else {
        x.powf(n)
    }
}

fn pow5(x: f64) -> f64 {
    let x2 = x * x;
    x2 * x2 * x
}

/// Schlick's approximation `r0 + (1 - r0)(1 - c)^5`, `c` clamped to [0, 1].
pub fn schlick(cos: f64, r0: f64) -> f64 {
    r0 + (1.0 - r0) * pow5(1.0 - clamp01(cos))
}

/// `((eta - 1)/(eta + 1))²`, the normal-incidence reflectance of an interface of index `eta`.
pub fn r0_from_eta(eta: f64) -> f64 {
    let r = (eta - 1.0) / (eta + 1.0);
    r * r
}

/// Fresnel reflectance of a dielectric interface of index `eta` (outside index 1).
///
/// Entering: `schlick(cos_i, r0)`. Leaving (`inside`): Schlick at the cosine of the transmitted
/// angle, `sqrt(1 - eta² (1 - cos_i²))`, or 1 on total internal reflection.
/// Decision: `cos_i` is clamped to [0, 1] first (dot products clamp at 0), so `cos_i = 0`
/// when leaving gives TIR for any `eta > 1`. `eta` is taken literally: for `eta < 1`, "inside"
/// still means the medium of index `eta`, never TIR there.
pub fn dielectric_reflectance(cos_i: f64, eta: f64, inside: bool) -> f64 {
    let r0 = r0_from_eta(eta);
    let c = clamp01(cos_i);
    if !inside {
        return schlick(c, r0);
    }
    let sin2_t = eta * eta * (1.0 - c * c);
    if sin2_t > 1.0 {
        return 1.0;
    }
    schlick((1.0 - sin2_t).sqrt(), r0)
}

/// Mirror direction `d - 2 (d·n) n`.
pub fn reflect(d: DVec3, n: DVec3) -> DVec3 {
    d - 2.0 * d.dot(n) * n
}

/// Refracted unit direction for `eta_ratio = n1/n2` (`n` facing against `d`), or `None` on
/// total internal reflection (`k < 0`; `k == 0` grazes and still refracts).
pub fn refract(d: DVec3, n: DVec3, eta_ratio: f64) -> Option<DVec3> {
    let c = -n.dot(d);
    let k = 1.0 - eta_ratio * eta_ratio * (1.0 - c * c);
    if k < 0.0 {
        return None;
    }
    Some((eta_ratio * d + (eta_ratio * c - k.sqrt()) * n).normalize())
}

/// The paper's two-colour ambient: `sky` when `n` is `up`, `ground` when it is `-up`,
/// their mean at right angles. `up` must be unit; `cos θ` is not clamped here.
pub fn ambient_intensity(n: DVec3, up: DVec3, sky: DVec3, ground: DVec3) -> DVec3 {
    let cos = n.dot(up);
    let half_sin = 0.5 * (1.0 - cos * cos).max(0.0).sqrt();
    if cos >= 0.0 {
        (1.0 - half_sin) * sky + half_sin * ground
    } else {
        half_sin * sky + (1.0 - half_sin) * ground
    }
}

/// The material's Fresnel reflectance `F` at this point, per channel.
fn fresnel(m: &MaterialKind, n: DVec3, e: DVec3, inside: bool) -> DVec3 {
    let ne = n.dot(e);
    match *m {
        MaterialKind::Diffuse { .. } => DVec3::ZERO,
        MaterialKind::Metal { color, .. } => {
            DVec3::new(schlick(ne, color.x), schlick(ne, color.y), schlick(ne, color.z))
        }
        MaterialKind::Dielectric { eta, .. } => DVec3::splat(dielectric_reflectance(ne, eta, inside)),
        MaterialKind::Polished { eta, .. } => DVec3::splat(schlick(ne, r0_from_eta(eta))),
    }
}

/// Ambient term: `k_d ⊙ I_a` (diffuse), `k_d ⊙ I_a (1 - F)` (polished), 0 otherwise.
pub fn shade_ambient(m: &MaterialKind, n: DVec3, e: DVec3, ia: DVec3, inside: bool) -> DVec3 {
    match *m {
        MaterialKind::Diffuse { color } => color * ia,
        MaterialKind::Polished { color, .. } => color * ia * (1.0 - fresnel(m, n, e, inside).x),
        MaterialKind::Metal { .. } | MaterialKind::Dielectric { .. } => DVec3::ZERO,
    }
}

/// Contribution of one unshadowed light of colour `l_e` in direction `l`; 0 when `n·l <= 0`.
/// Highlights are Blinn–Phong `F l_e (n·h)^N`, `h = normalize(l + e)`.
/// Decision: if `l + e` is the zero vector (only possible with shading normals), `n·h = 0`.
pub fn shade_light(m: &MaterialKind, n: DVec3, e: DVec3, l: DVec3, l_e: DVec3, inside: bool) -> DVec3 {
    let nl = n.dot(l);
    if nl <= 0.0 {
        return DVec3::ZERO;
    }
    let nl = clamp01(nl);
    let highlight = |exponent: f64| {
        let h = (l + e).normalize_or_zero();
        pow0(n.dot(h).max(0.0), exponent) * fresnel(m, n, e, inside) * l_e
    };
    match *m {
        MaterialKind::Diffuse { color } => color * l_e * nl,
        MaterialKind::Metal { exponent, .. } | MaterialKind::Dielectric { exponent, .. } => {
            highlight(exponent)
        }
        MaterialKind::Polished { color, exponent, .. } => {
            let ne = clamp01(n.dot(e));
            let base = (1.0 - pow5(1.0 - ne)) * (1.0 - pow5(1.0 - nl));
            color * l_e * base + highlight(exponent)
        }
    }
}

/// `(k_s, k_t)`: weights of the reflected (per channel) and refracted radiance.
pub fn reflectance(m: &MaterialKind, n: DVec3, e: DVec3, inside: bool) -> (DVec3, f64) {
    let f = fresnel(m, n, e, inside);
    match m {
        MaterialKind::Dielectric { .. } => (f, 1.0 - f.x),
        _ => (f, 0.0),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: f64, y: f64, z: f64) -> DVec3 {
        DVec3::new(x, y, z)
    }

    fn close(a: DVec3, b: DVec3, tol: f64) -> bool {
        (a - b).abs().max_element() <= tol
    }

    #[test]
    fn schlick_at_normal_and_grazing() {
        assert_eq!(schlick(1.0, 0.04), 0.04); // 0 degrees
        assert_eq!(schlick(0.0, 0.04), 1.0); // 90 degrees
        assert_eq!(schlick(-0.5, 0.04), 1.0); // clamped
        assert!((schlick(0.5, 0.04) - (0.04 + 0.96 / 32.0)).abs() < 1e-15);
        assert!((r0_from_eta(1.5) - 0.04).abs() < 1e-15);
    }

    #[test]
    fn dielectric_reflectance_entering_leaving_and_tir() {
        let eta = 1.5;
        assert!((dielectric_reflectance(1.0, eta, false) - 0.04).abs() < 1e-15);
        assert!((dielectric_reflectance(1.0, eta, true) - 0.04).abs() < 1e-15);
        // Symmetric across the interface: entering at θ_i equals leaving at the refracted θ_t.
        let theta_i = 50f64.to_radians();
        let sin_t = theta_i.sin() / eta;
        let cos_t = (1.0 - sin_t * sin_t).sqrt();
        let a = dielectric_reflectance(theta_i.cos(), eta, false);
        let b = dielectric_reflectance(cos_t, eta, true);
        assert!((a - b).abs() < 1e-14, "{a} {b}");
        // Just beyond the critical angle inside: total internal reflection.
        let crit = (1.0 / eta).asin();
        assert_eq!(dielectric_reflectance((crit + 1e-6).cos(), eta, true), 1.0);
        assert!(dielectric_reflectance((crit - 1e-6).cos(), eta, true) < 1.0);
    }

    #[test]
    fn refract_obeys_snell_and_tir() {
        let n = v(0., 1., 0.);
        for deg in [0.0f64, 10.0, 30.0, 60.0, 89.0] {
            let th = deg.to_radians();
            let d = v(th.sin(), -th.cos(), 0.);
            let t = refract(d, n, 1.0 / 1.5).unwrap();
            assert!((t.length() - 1.0).abs() < 1e-15);
            assert!(t.y < 0.0, "goes through");
            assert!(t.z == 0.0, "stays in the plane of incidence");
            // sin θ_i / sin θ_t = n2/n1.
            let sin_t = t.x;
            assert!((th.sin() - 1.5 * sin_t).abs() < 1e-15, "{deg}: {sin_t}");
        }
        // Leaving glass (eta_ratio 1.5): refracts just below the critical angle, TIR just above.
        let crit = (1.0f64 / 1.5).asin();
        let dir = |th: f64| v(th.sin(), -th.cos(), 0.);
        let t = refract(dir(crit - 1e-6), n, 1.5).unwrap();
        assert!(t.x > 0.999, "near grazing: {t}");
        assert_eq!(refract(dir(crit + 1e-6), n, 1.5), None);
        // Mirror.
        assert_eq!(reflect(v(1., -1., 0.), n), v(1., 1., 0.));
    }

    #[test]
    fn ambient_blends_sky_and_ground() {
        let up = v(0., 1., 0.);
        let a = v(0.2, 0.4, 0.8);
        let b = v(0.6, 0.3, 0.0);
        assert_eq!(ambient_intensity(up, up, a, b), a);
        assert!(close(ambient_intensity(v(1., 0., 0.), up, a, b), (a + b) / 2.0, 1e-15));
        assert_eq!(ambient_intensity(-up, up, a, b), b);
        // θ = 45°: sin θ / 2 = √2/4 of the far colour.
        let s = 2f64.sqrt() / 4.0;
        let n45 = v(1., 1., 0.).normalize();
        assert!(close(ambient_intensity(n45, up, a, b), (1.0 - s) * a + s * b, 1e-15));
        assert!(close(ambient_intensity(v(1., -1., 0.).normalize(), up, a, b), s * a + (1.0 - s) * b, 1e-15));
    }

    #[test]
    fn material_terms_follow_the_table() {
        let n = v(0., 0., 1.);
        let e = n;
        let th = 60f64.to_radians();
        let l = v(th.sin(), 0., th.cos());
        let le = v(1., 2., 3.);
        let kd = v(0.5, 0.25, 1.0);
        let ia = v(0.1, 0.2, 0.3);
        let diffuse = MaterialKind::Diffuse { color: kd };
        assert!(close(shade_light(&diffuse, n, e, l, le, false), kd * le * 0.5, 1e-15));
        assert_eq!(shade_ambient(&diffuse, n, e, ia, false), kd * ia);
        assert_eq!(reflectance(&diffuse, n, e, false), (DVec3::ZERO, 0.0));
        // Facing away from the light: nothing, whatever the material.
        let away = v(0., 0., -1.);
        let metal = MaterialKind::Metal { color: v(0.9, 0.5, 0.1), exponent: 10.0 };
        for m in [&diffuse, &metal] {
            assert_eq!(shade_light(m, n, e, away, le, false), DVec3::ZERO);
            assert_eq!(shade_light(m, n, e, v(1., 0., 0.), le, false), DVec3::ZERO);
        }
        // Metal at normal incidence: F = colour; highlight (n·h)^N with h at 30°.
        let (ks, kt) = reflectance(&metal, n, e, false);
        assert!(close(ks, v(0.9, 0.5, 0.1), 1e-15) && kt == 0.0);
        let nh = 30f64.to_radians().cos();
        assert!(close(shade_light(&metal, n, e, l, le, false), ks * le * nh.powf(10.0), 1e-14));
        assert_eq!(shade_ambient(&metal, n, e, ia, false), DVec3::ZERO);
        // Exponent 0: 0^0 = 1 style constant highlight.
        let flat = MaterialKind::Metal { color: DVec3::ONE, exponent: 0.0 };
        assert!(close(shade_light(&flat, n, e, l, le, false), le, 1e-15));
        // Dielectric: F and 1 - F.
        let glass = MaterialKind::Dielectric { eta: 1.5, exponent: 0.0 };
        let (ks, kt) = reflectance(&glass, n, e, false);
        assert!(close(ks, DVec3::splat(0.04), 1e-15) && (kt - 0.96).abs() < 1e-15);
        // Polished at normal incidence to the eye: base (1 - 0)(1 - 0.5^5), F = 0.04.
        let pol = MaterialKind::Polished { color: kd, eta: 1.5, exponent: 1.0 };
        let want = kd * le * (1.0 - 0.5f64.powi(5)) + 0.04 * le * nh;
        assert!(close(shade_light(&pol, n, e, l, le, false), want, 1e-14));
        assert!(close(shade_ambient(&pol, n, e, ia, false), kd * ia * 0.96, 1e-15));
        let (ks, kt) = reflectance(&pol, n, e, false);
        assert!(close(ks, DVec3::splat(0.04), 1e-15) && kt == 0.0);
    }
}
