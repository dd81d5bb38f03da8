//! f64 twins of the shadow modes in docs/shadows.md, and the ground truth they are judged by.

use crate::scene::{pixel_hash, Falloff};
use glam::{DVec2, DVec3};
use std::f64::consts::PI;

/// Branchless orthonormal basis around unit `n` (Duff et al. 2017): the light disc's axes, and
/// where u = 0 lies around a cone's axis (`cone_uv`).
pub fn basis(n: DVec3) -> (DVec3, DVec3) {
    let sign = if n.z >= 0.0 { 1.0 } else { -1.0 };
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (DVec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x), DVec3::new(b, sign + n.y * n.y * a, -n.y))
}

/// Shell transparency for `tau` in [0, 1] (clamped outside).
pub fn falloff(f: Falloff, tau: f64) -> f64 {
    let t = tau.clamp(0.0, 1.0);
    match f {
        Falloff::Smoothstep => t * t * (3.0 - 2.0 * t),
        Falloff::Linear => t,
        Falloff::Disc => {
            let x = 1.0 - 2.0 * t;
            (x.acos() - x * (1.0 - x * x).max(0.0).sqrt()) / PI
        }
    }
}

/// σ of a shell whose occluder edge lies at signed distance `x` from the shadow ray (`x > 0`:
/// the ray passes outside the occluder) where the light's cone has radius `b`: the penumbra
/// straddles the hard shadow's edge, `x` from `-b` (σ = 0) to `+b` (σ = 1).
pub fn straddle(f: Falloff, x: f64, b: f64) -> f64 {
    falloff(f, 0.5 + 0.5 * x / b)
}

/// Transparency of a sphere's shell for the shadow ray `p + t l`, `0 < t < dist`, towards a
/// light of radius `light_r`: 0 inside `radius - b`, 1 outside `radius + b`, with
/// `b = light_r t / dist` at the closest approach `t`.
pub fn sphere_shell(
    f: Falloff,
    p: DVec3,
    l: DVec3,
    dist: f64,
    light_r: f64,
    center: DVec3,
    radius: f64,
) -> f64 {
    let t = (center - p).dot(l);
    let b = light_r * t / dist;
    if t <= 0.0 || t >= dist || b <= 0.0 {
        return 1.0;
    }
    let d = (center - (p + t * l)).length();
    straddle(f, d - radius, b)
}

/// σ from the distance and `t` of the nearest occluder edge (`d`, as `segment_distance` gives
/// it), on the occluder's side of it when `inside`.
pub fn edge_shell(f: Falloff, inside: bool, (d, t): (f64, f64), dist: f64, light_r: f64) -> f64 {
    let b = light_r * t / dist;
    if b <= 0.0 {
        return if inside { 0.0 } else { 1.0 };
    }
    straddle(f, if inside { -d } else { d }, b)
}

/// Of `edges`, the one whose penumbra reaches the segment `p + t l`, `t ∈ [0, dist]`, the most:
/// the least distance in units of the shell's width at its closest point (`d / b`, `b = r t /
/// D`), as `(d, t)`. σ depends on `d / b` alone, so two edges tied on it give the same σ, and an
/// edge beyond its own width changes nothing while another is within its own. The plain nearest
/// edge would take a near one where the cone is thin over a farther one that casts the
/// penumbra (docs/shadows.md, Shell objects).
pub fn nearest_edge(
    p: DVec3,
    l: DVec3,
    dist: f64,
    light_r: f64,
    edges: impl IntoIterator<Item = [DVec3; 2]>,
) -> (f64, f64) {
    let (mut best, mut key) = ((f64::INFINITY, 0.0), f64::INFINITY);
    for [a, b] in edges {
        let e = segment_distance(p, l, dist, a, b);
        let k = if e.1 > 0.0 { e.0 * dist / (light_r * e.1) } else { f64::INFINITY };
        if k < key {
            (best, key) = (e, k);
        }
    }
    best
}

/// Transparency of a lone triangle's shell (a mesh of one triangle: its contour is its three
/// edges); `inside`: the segment hits it.
pub fn triangle_shell(
    f: Falloff,
    p: DVec3,
    l: DVec3,
    dist: f64,
    light_r: f64,
    inside: bool,
    tri: [DVec3; 3],
) -> f64 {
    let edges = [[tri[0], tri[1]], [tri[1], tri[2]], [tri[2], tri[0]]];
    edge_shell(f, inside, nearest_edge(p, l, dist, light_r, edges), dist, light_r)
}

/// Transparency of a mesh's shell from its contour `edges` seen from the light ([`nearest_edge`]);
/// `inside`: the segment hits the mesh.
pub fn mesh_shell(
    f: Falloff,
    p: DVec3,
    l: DVec3,
    dist: f64,
    light_r: f64,
    inside: bool,
    edges: &[[DVec3; 2]],
) -> f64 {
    edge_shell(f, inside, nearest_edge(p, l, dist, light_r, edges.iter().copied()), dist, light_r)
}

/// Transparency of a cone's shell (docs/shadows.md, Cone). From the closest approach of the
/// shadow segment to the cone's axis segment (ray point `p + t l`, axis point at fraction `s`),
/// the signed distance to the edge of the cone's solid cross-section disc at `s` (radius
/// `r(s)`): `d - r(s)` beside the cone, the distance to the end disc past its ends, and inside
/// the cone minus the depth to the nearer of its side and its ends.
#[allow(clippy::too_many_arguments)]
pub fn cone_shell(
    f: Falloff,
    p: DVec3,
    l: DVec3,
    dist: f64,
    light_r: f64,
    base: DVec3,
    base_radius: f64,
    apex: DVec3,
    apex_radius: f64,
) -> f64 {
    let (_, t) = segment_distance(p, l, dist, base, apex);
    let b = light_r * t / dist;
    if t <= 0.0 || t >= dist || b <= 0.0 {
        return 1.0;
    }
    straddle(f, cone_edge(p + t * l, base, base_radius, apex, apex_radius), b)
}

/// Signed distance from `x` to the edge of the cone's cross-section disc at `x`'s axial position
/// (negative inside the solid cone).
fn cone_edge(x: DVec3, base: DVec3, base_radius: f64, apex: DVec3, apex_radius: f64) -> f64 {
    let axis = apex - base;
    let len = axis.length();
    let s_raw = (x - base).dot(axis) / (len * len);
    let s = s_raw.clamp(0.0, 1.0);
    let v = x - (base + s * axis);
    let along = v.dot(axis / len);
    let across = (v.length_squared() - along * along).max(0.0).sqrt();
    let r = base_radius + s * (apex_radius - base_radius);
    if s_raw > 0.0 && s_raw < 1.0 && across < r {
        return -(r - across).min(s_raw.min(1.0 - s_raw) * len);
    }
    (along * along + (across - r).max(0.0).powi(2)).sqrt()
}

/// Distance between the segment `p + t l`, `t ∈ [0, len]` (`l` unit) and the segment `a b`,
/// with the `t` of the closest point (Ericson, Real-Time Collision Detection §5.1.9).
pub fn segment_distance(p: DVec3, l: DVec3, len: f64, a: DVec3, b: DVec3) -> (f64, f64) {
    let e = b - a;
    let r = p - a;
    let ee = e.dot(e);
    let le = l.dot(e);
    let lr = l.dot(r);
    let er = e.dot(r);
    // t along the ray, s along the edge; first the unconstrained solution, then clamping.
    let (t, s) = if ee <= f64::MIN_POSITIVE {
        ((-lr).clamp(0.0, len), 0.0)
    } else {
        let denom = ee - le * le; // |l|² |e|² − (l·e)², |l| = 1
        let mut t = if denom > 1e-12 * ee { ((le * er - ee * lr) / denom).clamp(0.0, len) } else { 0.0 };
        let mut s = (le * t + er) / ee;
        if s < 0.0 {
            s = 0.0;
            t = (-lr).clamp(0.0, len);
        } else if s > 1.0 {
            s = 1.0;
            t = (le - lr).clamp(0.0, len);
        }
        (t, s)
    };
    (((p + t * l) - (a + s * e)).length(), t)
}

/// The `k`-th bundle point rotated for pixel `pixel` (`rotate`), as an offset on the unit disc.
pub fn bundle_point(sample: [f64; 2], pixel: u32, rotate: bool) -> DVec2 {
    let s = DVec2::from(sample);
    if !rotate {
        return s;
    }
    let angle = 2.0 * PI * (pixel_hash(pixel) as f64 / 4294967296.0);
    DVec2::from_angle(angle).rotate(s)
}

/// Point `(i, j)` of an `n × n` jittered stratification of the unit disc (Shirley–Chiu's
/// concentric map of the square), the ground truth's sample set.
pub fn stratified_disc(i: u32, j: u32, n: u32) -> DVec2 {
    let jitter = |k: u32| pixel_hash(k) as f64 / 4294967296.0;
    let u = (i as f64 + jitter(i * n + j)) / n as f64;
    let v = (j as f64 + jitter(n * n + i * n + j)) / n as f64;
    let (a, b) = (2.0 * u - 1.0, 2.0 * v - 1.0);
    if a == 0.0 && b == 0.0 {
        return DVec2::ZERO;
    }
    let (r, phi) = if a * a > b * b { (a, PI / 4.0 * (b / a)) } else { (b, PI / 2.0 - PI / 4.0 * (a / b)) };
    DVec2::new(r * phi.cos(), r * phi.sin())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A shadow ray from the origin up to a light 10 away (radius 1): an edge 0.05 beside it at
    /// height 0.1, where the shell is 0.01 wide, and one 0.3 beside it at height 5, where it is
    /// 0.5 wide. The first is nearer but its penumbra does not reach the ray; the second's does,
    /// and is the one that shadows it.
    #[test]
    fn the_edge_whose_penumbra_reaches_furthest_is_taken() {
        let (p, l, dist, r) = (DVec3::ZERO, DVec3::Y, 10.0, 1.0);
        let low = [DVec3::new(0.05, 0.1, -1.0), DVec3::new(0.05, 0.1, 1.0)];
        let high = [DVec3::new(0.3, 5.0, -1.0), DVec3::new(0.3, 5.0, 1.0)];
        let (d, t) = nearest_edge(p, l, dist, r, [low, high]);
        assert!((d - 0.3).abs() < 1e-12 && (t - 5.0).abs() < 1e-12, "({d}, {t})");
        let sigma = mesh_shell(Falloff::Disc, p, l, dist, r, false, &[low, high]);
        assert!(sigma > 0.6 && sigma < 0.9, "σ {sigma}: the high edge's partial shadow");
        // Nearest by distance alone it would have been the low edge: fully lit.
        assert_eq!(
            edge_shell(Falloff::Disc, false, segment_distance(p, l, dist, low[0], low[1]), dist, r),
            1.0
        );
    }

    #[test]
    fn frame_is_orthonormal() {
        for n in [
            DVec3::X,
            DVec3::NEG_Z,
            DVec3::new(0.3, -0.5, 0.8).normalize(),
            DVec3::new(1e-9, 0.0, -1.0).normalize(),
        ] {
            let (u, v) = basis(n);
            for (a, b) in [(u, v), (u, n), (v, n)] {
                assert!(a.dot(b).abs() < 1e-12);
            }
            assert!((u.length() - 1.0).abs() < 1e-12 && (v.length() - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn falloffs_rise_from_zero_to_one() {
        for f in Falloff::ALL {
            assert_eq!(falloff(f, 0.0), 0.0);
            assert!((falloff(f, 1.0) - 1.0).abs() < 1e-12);
            let mut last = 0.0;
            for k in 1..=100 {
                let s = falloff(f, k as f64 / 100.0);
                assert!(s >= last, "{f:?} not monotone");
                last = s;
            }
        }
        assert!((falloff(Falloff::Disc, 0.5) - 0.5).abs() < 1e-12);
    }

    #[test]
    fn segment_distance_matches_sampling() {
        let p = DVec3::new(0.1, -0.2, 0.3);
        let l = DVec3::new(1.0, 0.4, -0.2).normalize();
        for (a, b) in [
            (DVec3::new(1.0, 1.0, 0.0), DVec3::new(1.5, -1.0, 0.5)),
            (DVec3::new(-2.0, 0.0, 0.0), DVec3::new(-1.0, 0.1, 0.0)),
            (DVec3::new(0.5, 0.5, 0.5), DVec3::new(0.5, 0.5, 0.5)),
            (p + 2.0 * l + DVec3::Y, p + 3.0 * l + DVec3::Y),
        ] {
            let (d, t) = segment_distance(p, l, 4.0, a, b);
            let mut best = f64::INFINITY;
            for i in 0..=400 {
                for j in 0..=400 {
                    let q = p + l * (4.0 * i as f64 / 400.0);
                    let r = a + (b - a) * (j as f64 / 400.0);
                    best = best.min(q.distance(r));
                }
            }
            assert!(d <= best + 1e-12 && d > best - 0.02, "{d} vs sampled {best}");
            assert!(((p + t * l) - a).length() >= d - 1e-9);
        }
    }

    #[test]
    fn stratified_disc_stays_inside_and_fills_it() {
        let n = 16;
        let pts: Vec<DVec2> = (0..n).flat_map(|i| (0..n).map(move |j| stratified_disc(i, j, n))).collect();
        assert!(pts.iter().all(|p| p.length() <= 1.0));
        let mean = pts.iter().copied().sum::<DVec2>() / pts.len() as f64;
        assert!(mean.length() < 0.02, "{mean}");
        let inner = pts.iter().filter(|p| p.length() < 0.5f64.sqrt()).count();
        assert!((118..=138).contains(&inner), "{inner}");
    }
}
