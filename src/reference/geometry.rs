//! Ray–primitive intersection in f64, written independently of the WGSL twins of the same name.

use glam::DVec3;

/// Nearest root `t` of `|o + t d - center| = radius` with `t_min < t < t_max`.
///
/// `d` need not be unit; `t` is in units of `d`. The discriminant is formed as
/// `r² - |oc - (oc·d̂)d̂|²` (the squared distance of closest approach, no cancellation between
/// two large squares) and the two roots without subtracting nearly equal numbers.
/// Decision: a tangent ray (discriminant exactly 0) hits, at its single (double) root.
pub fn intersect_sphere(
    o: DVec3,
    d: DVec3,
    center: DVec3,
    radius: f64,
    t_min: f64,
    t_max: f64,
) -> Option<f64> {
    let (len, dh) = unit_direction(d)?;
    let oc = o - center;
    let b = oc.dot(dh);
    let perp = oc - b * dh;
    let disc = radius * radius - perp.length_squared();
    if disc < 0.0 {
        return None;
    }
    // Roots along d̂: s² + 2 b s + c = 0, s = -b ± sqrt(disc).
    let sq = disc.sqrt();
    let q = -(b + sq.copysign(b));
    let (s0, s1) = if q == 0.0 {
        (0.0, 0.0)
    } else {
        let c = oc.length_squared() - radius * radius;
        let other = c / q;
        (q.min(other), q.max(other))
    };
    [s0 / len, s1 / len].into_iter().find(|&t| t > t_min && t < t_max)
}

/// Two-sided ray–triangle test (Möller–Trumbore). Returns `(t, b1, b2)`: the ray parameter (in
/// units of `d`) and the barycentric weights of `p1` and `p2`; the hit point is
/// `(1 - b1 - b2) p0 + b1 p1 + b2 p2`.
///
/// Decisions: points on edges and vertices hit (the barycentric tests are inclusive); a
/// triangle is degenerate, and never hit, when `|e1 × e2|² <= 1e-24 |e1|² |e2|²` (its angle's
/// sine is below 1e-12, the same relative threshold `Scene::validate` uses for the camera); a
/// ray parallel to the plane (determinant exactly 0) misses.
pub fn intersect_triangle(
    o: DVec3,
    d: DVec3,
    p0: DVec3,
    p1: DVec3,
    p2: DVec3,
    t_min: f64,
    t_max: f64,
) -> Option<(f64, f64, f64)> {
    let e1 = p1 - p0;
    let e2 = p2 - p0;
    let area2 = e1.cross(e2).length_squared();
    if area2 <= 1e-24 * e1.length_squared() * e2.length_squared() || area2 == 0.0 {
        return None;
    }
    let pvec = d.cross(e2);
    let det = e1.dot(pvec);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv = 1.0 / det;
    let tvec = o - p0;
    let b1 = tvec.dot(pvec) * inv;
    if !(0.0..=1.0).contains(&b1) {
        return None;
    }
    let qvec = tvec.cross(e1);
    let b2 = d.dot(qvec) * inv;
    if b2 < 0.0 || b1 + b2 > 1.0 {
        return None;
    }
    let t = e2.dot(qvec) * inv;
    (t > t_min && t < t_max).then_some((t, b1, b2))
}

/// Unit geometric normal `normalize((p1 - p0) × (p2 - p0))` (counter-clockwise winding faces it).
pub fn triangle_normal(p0: DVec3, p1: DVec3, p2: DVec3) -> DVec3 {
    (p1 - p0).cross(p2 - p0).normalize()
}

/// Nearest `t` with `t_min < t < t_max` where `o + t d` meets the open cone (no caps) between
/// the disc of radius `base_radius` around `base` and the disc of radius `apex_radius` around
/// `apex` (a cylinder when the radii are equal). `t` is in units of `d`.
///
/// With `a` the unit axis, `k` the radius's slope along it and `q(t)` the ray's offset from the
/// axis, the surface is `|q(t)|² = r(s(t))²`, a quadratic in `t`. Both roots are tried, nearer
/// first, and a root counts only where its axial position `s` lies on the cone (`0 <= s <= h`,
/// inclusive), so a ray entering through an open end hits the inside. Precision:
/// - the ray is first moved to its closest approach to the axis midpoint, so the coefficients
///   stay small when it starts far away (as for spheres);
/// - the discriminant is formed as `|r₀ q_d − k (d·a) q_o|² − |q_o × q_d|²` (Lagrange's
///   identity), a difference of geometric squares instead of two large products;
/// - the roots are taken without cancellation, and the quadratic coefficient may vanish (a ray
///   parallel to a cylinder's axis or to a cone's generating line): then the one linear root is
///   the answer, or none.
#[allow(clippy::too_many_arguments)]
pub fn intersect_cone(
    o: DVec3,
    d: DVec3,
    base: DVec3,
    base_radius: f64,
    apex: DVec3,
    apex_radius: f64,
    t_min: f64,
    t_max: f64,
) -> Option<f64> {
    let (len, dh) = unit_direction(d)?;
    let axis = apex - base;
    let h = axis.length();
    let a = axis / h;
    let k = (apex_radius - base_radius) / h;
    let tc = (base + 0.5 * axis - o).dot(dh);
    let co = o + tc * dh - base;
    let (s0, da) = (co.dot(a), dh.dot(a));
    let (qo, qd) = (co - s0 * a, dh - da * a);
    let ro = base_radius + k * s0;
    let qa = qd.length_squared() - k * k * da * da;
    let qb = qo.dot(qd) - k * ro * da;
    let qc = qo.length_squared() - ro * ro;
    let disc = (ro * qd - k * da * qo).length_squared() - qo.cross(qd).length_squared();
    if disc < 0.0 {
        return None;
    }
    // Roots of qa s² + 2 qb s + qc = 0 along d̂ from the shifted origin.
    let q = -(qb + disc.sqrt().copysign(qb));
    let (r0, r1) = if q != 0.0 {
        (qc / q, if qa != 0.0 { q / qa } else { f64::NAN })
    } else if qa != 0.0 {
        (0.0, 0.0)
    } else {
        return None;
    };
    let (lo, hi) = if r1.is_nan() { (r0, r0) } else { (r0.min(r1), r0.max(r1)) };
    [lo, hi].into_iter().find_map(|s| {
        let along = s0 + s * da;
        let t = (tc + s) / len;
        ((0.0..=h).contains(&along) && t > t_min && t < t_max).then_some(t)
    })
}

/// Unit outward normal of the cone of [`intersect_cone`] at the surface point `p`: the
/// direction away from the axis tilted by the radius's slope. At a pointed tip, where the
/// direction away from the axis is undefined, it is the axis direction out of the tip.
pub fn cone_normal(p: DVec3, base: DVec3, base_radius: f64, apex: DVec3, apex_radius: f64) -> DVec3 {
    let axis = apex - base;
    let h = axis.length();
    let a = axis / h;
    let k = (apex_radius - base_radius) / h;
    let v = p - base;
    let away = (v - v.dot(a) * a).normalize_or_zero();
    (away - k * a).normalize()
}

/// Axis-aligned bounds of the cone: the union of the bounds of its two end discs (a disc of
/// radius `r` with unit normal `a` reaches `r sqrt(1 - a_i²)` along axis `i`).
pub fn cone_bounds(base: DVec3, base_radius: f64, apex: DVec3, apex_radius: f64) -> (DVec3, DVec3) {
    let a = (apex - base).normalize();
    let reach = (DVec3::ONE - a * a).max(DVec3::ZERO).map(f64::sqrt);
    let (e0, e1) = (reach * base_radius, reach * apex_radius);
    ((base - e0).min(apex - e1), (base + e0).max(apex + e1))
}

/// The length of a ray direction and the unit direction, `None` for a zero or non-finite one:
/// the quadrics measure `t` along the unit direction and scale it back.
fn unit_direction(d: DVec3) -> Option<(f64, DVec3)> {
    let len = d.length();
    (len > 0.0 && len.is_finite()).then(|| (len, d / len))
}

#[cfg(test)]
mod tests {
    use super::*;

    const INF: f64 = f64::INFINITY;

    fn v(x: f64, y: f64, z: f64) -> DVec3 {
        DVec3::new(x, y, z)
    }

    #[test]
    fn sphere_from_outside_hits_near_side() {
        let t = intersect_sphere(v(0., 0., -5.), v(0., 0., 1.), DVec3::ZERO, 1.0, 0.0, INF);
        assert_eq!(t, Some(4.0));
        // Non-unit direction: t is in units of d.
        let t = intersect_sphere(v(0., 0., -5.), v(0., 0., 2.), DVec3::ZERO, 1.0, 0.0, INF);
        assert_eq!(t, Some(2.0));
        // Off-axis: closest approach 0.6 => half chord 0.8.
        let t = intersect_sphere(v(0.6, 0., -5.), v(0., 0., 1.), DVec3::ZERO, 1.0, 0.0, INF).unwrap();
        assert!((t - 4.2).abs() < 1e-14, "{t}");
        // t_max before the sphere, or sphere behind the origin: miss.
        assert_eq!(intersect_sphere(v(0., 0., -5.), v(0., 0., 1.), DVec3::ZERO, 1.0, 0.0, 3.9), None);
        assert_eq!(intersect_sphere(v(0., 0., 5.), v(0., 0., 1.), DVec3::ZERO, 1.0, 0.0, INF), None);
        // t_min past the near root gives the far root.
        let t = intersect_sphere(v(0., 0., -5.), v(0., 0., 1.), DVec3::ZERO, 1.0, 4.5, INF);
        assert_eq!(t, Some(6.0));
    }

    #[test]
    fn sphere_from_inside_hits_far_side() {
        let c = v(1., 2., 3.);
        let t = intersect_sphere(c, v(0., 1., 0.), c, 2.0, 0.0, INF);
        assert_eq!(t, Some(2.0));
        let t = intersect_sphere(c + v(0., 0.5, 0.), v(0., -1., 0.), c, 2.0, 0.0, INF);
        assert_eq!(t, Some(2.5));
    }

    #[test]
    fn sphere_miss_and_tangent() {
        assert_eq!(intersect_sphere(v(0., 2., -5.), v(0., 0., 1.), DVec3::ZERO, 1.0, 0.0, INF), None);
        // Exactly tangent: closest approach equals the radius; grazes at x = 0.
        let t = intersect_sphere(v(-5., 1., 0.), v(1., 0., 0.), DVec3::ZERO, 1.0, 0.0, INF);
        assert_eq!(t, Some(5.0));
        // A hair outside: miss.
        let t = intersect_sphere(v(-5., 1. + 1e-9, 0.), v(1., 0., 0.), DVec3::ZERO, 1.0, 0.0, INF);
        assert_eq!(t, None);
    }

    #[test]
    fn sphere_far_from_origin_is_accurate() {
        // A small sphere far away: the naive b² - c discriminant loses everything here.
        let c = v(1e6, 1e6, 1e6);
        let o = c - v(0., 0., 10.);
        let t = intersect_sphere(o, v(0., 0., 1.), c, 1e-3, 0.0, INF).unwrap();
        assert!((t - (10.0 - 1e-3)).abs() < 1e-9, "{t}");
        // An offset ray leaving the surface does not re-hit it.
        let p = c + v(0., 0., -1e-3);
        let eps = 1e-9 * 1e6;
        let t = intersect_sphere(p + v(0., 0., -eps), v(0., 0., -1.), c, 1e-3, 0.0, INF);
        assert_eq!(t, None);
    }

    const P0: DVec3 = DVec3::new(0., 0., 0.);
    const P1: DVec3 = DVec3::new(1., 0., 0.);
    const P2: DVec3 = DVec3::new(0., 1., 0.);

    #[test]
    fn triangle_hit_both_sides() {
        let down = v(0., 0., -1.);
        let h = intersect_triangle(v(0.25, 0.5, 2.), down, P0, P1, P2, 0.0, INF);
        assert_eq!(h, Some((2.0, 0.25, 0.5)));
        // Back side (two-sided) and non-unit direction.
        let h = intersect_triangle(v(0.25, 0.5, -2.), v(0., 0., 4.), P0, P1, P2, 0.0, INF);
        assert_eq!(h, Some((0.5, 0.25, 0.5)));
        // Out of [t_min, t_max]: miss.
        assert_eq!(intersect_triangle(v(0.25, 0.5, 2.), down, P0, P1, P2, 0.0, 2.0), None);
        assert_eq!(intersect_triangle(v(0.25, 0.5, 2.), down, P0, P1, P2, 2.0, INF), None);
        // Oblique ray: hit point matches the barycentrics.
        let o = v(-1., -2., 3.);
        let target = v(0.2, 0.3, 0.);
        let (t, b1, b2) = intersect_triangle(o, target - o, P0, P1, P2, 0.0, INF).unwrap();
        assert!((t - 1.0).abs() < 1e-15 && (b1 - 0.2).abs() < 1e-15 && (b2 - 0.3).abs() < 1e-15);
    }

    #[test]
    fn triangle_miss_edge_and_vertex() {
        let down = v(0., 0., -1.);
        assert_eq!(intersect_triangle(v(0.6, 0.6, 1.), down, P0, P1, P2, 0.0, INF), None);
        assert_eq!(intersect_triangle(v(-0.1, 0.5, 1.), down, P0, P1, P2, 0.0, INF), None);
        // On an edge and at a vertex: inclusive.
        assert_eq!(intersect_triangle(v(0.5, 0., 1.), down, P0, P1, P2, 0.0, INF), Some((1.0, 0.5, 0.0)));
        assert_eq!(intersect_triangle(v(0.5, 0.5, 1.), down, P0, P1, P2, 0.0, INF), Some((1.0, 0.5, 0.5)));
        assert_eq!(intersect_triangle(v(0., 1., 1.), down, P0, P1, P2, 0.0, INF), Some((1.0, 0.0, 1.0)));
        // Parallel to the plane: miss.
        assert_eq!(intersect_triangle(v(0.2, 0.2, 0.), v(1., 0., 0.), P0, P1, P2, 0.0, INF), None);
    }

    #[test]
    fn degenerate_triangles_never_hit() {
        let down = v(0., 0., -1.);
        let collinear = v(2., 0., 0.);
        assert_eq!(intersect_triangle(v(0.5, 0., 1.), down, P0, P1, collinear, 0.0, INF), None);
        assert_eq!(intersect_triangle(v(0., 0., 1.), down, P0, P0, P0, 0.0, INF), None);
        // A ray along the degenerate triangle's line misses too.
        assert_eq!(intersect_triangle(v(-1., 0., 0.), v(1., 0., 0.), P0, P1, collinear, 0.0, INF), None);
        assert_eq!(triangle_normal(P0, P1, P2), v(0., 0., 1.));
    }

    #[test]
    fn cylinder_hits_outside_and_inside() {
        let (b, a) = (v(0., 0., -1.), v(0., 0., 1.));
        // Across the axis: the near wall at x = -1, then from inside the far wall.
        let t = intersect_cone(v(-5., 0., 0.), v(1., 0., 0.), b, 1.0, a, 1.0, 0.0, INF).unwrap();
        assert!((t - 4.0).abs() < 1e-14, "{t}");
        let t = intersect_cone(v(0., 0., 0.), v(1., 0., 0.), b, 1.0, a, 1.0, 0.0, INF).unwrap();
        assert!((t - 1.0).abs() < 1e-14, "{t}");
        // Off-centre chord: closest approach 0.6 => half chord 0.8.
        let t = intersect_cone(v(-5., 0.6, 0.3), v(2., 0., 0.), b, 1.0, a, 1.0, 0.0, INF).unwrap();
        assert!((t - 4.2 / 2.0).abs() < 1e-14, "{t}");
        assert_eq!(intersect_cone(v(-5., 1.1, 0.), v(1., 0., 0.), b, 1.0, a, 1.0, 0.0, INF), None);
        // Open ends: a ray down the axis never meets the wall; one entering the open end at an
        // angle hits the inside.
        assert_eq!(intersect_cone(v(0., 0., -5.), v(0., 0., 1.), b, 1.0, a, 1.0, 0.0, INF), None);
        let d = v(1., 0., 2.);
        let t = intersect_cone(v(0., 0., -2.), d, b, 1.0, a, 1.0, 0.0, INF).unwrap();
        assert!((v(0., 0., -2.) + t * d - v(1., 0., 0.)).length() < 1e-14, "{t}");
        // Past the ends: missed.
        assert_eq!(intersect_cone(v(-5., 0., 1.5), v(1., 0., 0.), b, 1.0, a, 1.0, 0.0, INF), None);
        // The far root when t_min is past the near one.
        let t = intersect_cone(v(-5., 0., 0.), v(1., 0., 0.), b, 1.0, a, 1.0, 4.5, INF).unwrap();
        assert!((t - 6.0).abs() < 1e-14, "{t}");
    }

    #[test]
    fn cone_hits_and_normals() {
        // Radius 1 at z = 0 narrowing to a point at z = 1: a 45° cone.
        let (b, a) = (DVec3::ZERO, v(0., 0., 1.));
        let t = intersect_cone(v(-5., 0., 0.5), v(1., 0., 0.), b, 1.0, a, 0.0, 0.0, INF).unwrap();
        assert!((t - 4.5).abs() < 1e-14, "{t}");
        let n = cone_normal(v(-0.5, 0., 0.5), b, 1.0, a, 0.0);
        assert!((n - v(-1., 0., 1.).normalize()).length() < 1e-14, "{n}");
        // Truncated: radius 1 to 0.5. Rays parallel to a generating line (quadratic term 0):
        // one just inside that line never meets the wall; one from the axis meets the
        // opposite wall at its single (linear) root.
        let d = v(-0.5, 0., 1.);
        assert_eq!(intersect_cone(v(0.9, 0., 0.), d, b, 1.0, a, 0.5, 0.0, INF), None);
        let t = intersect_cone(v(-0.5, 0., 0.), d, b, 1.0, a, 0.5, 0.0, INF).unwrap();
        assert!((t - 0.5).abs() < 1e-12, "{t}");
        // The pointed tip's normal is the axis.
        assert_eq!(cone_normal(a, b, 1.0, a, 0.0), a);
        // The same cone described from the other end gives the same hits.
        let (o, d) = (v(0.3, -4., 0.2), v(0., 1., 0.05));
        let t1 = intersect_cone(o, d, b, 1.0, a, 0.5, 0.0, INF).unwrap();
        let t2 = intersect_cone(o, d, a, 0.5, b, 1.0, 0.0, INF).unwrap();
        assert!((t1 - t2).abs() < 1e-12);
    }

    #[test]
    fn cone_bounds_are_tight() {
        let (lo, hi) = cone_bounds(v(0., 0., 0.), 1.0, v(0., 0., 2.), 0.5);
        assert_eq!((lo, hi), (v(-1., -1., 0.), v(1., 1., 2.)));
        let (b, a) = (v(1., 2., 3.), v(2., 3., 3.5));
        let (lo, hi) = cone_bounds(b, 0.3, a, 0.2);
        let ax = (a - b).normalize();
        let (u, w) = (ax.any_orthonormal_pair().0, ax.any_orthonormal_pair().1);
        let (mut plo, mut phi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        for i in 0..3600 {
            let phase = i as f64 / 3600.0 * std::f64::consts::TAU;
            for (c, r) in [(b, 0.3), (a, 0.2)] {
                let p = c + r * (phase.cos() * u + phase.sin() * w);
                plo = plo.min(p);
                phi = phi.max(p);
            }
        }
        assert!((plo - lo).abs().max_element() < 1e-6 && (phi - hi).abs().max_element() < 1e-6);
    }
}
