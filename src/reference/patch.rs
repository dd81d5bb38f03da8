//! The f64 twin of a spline patch's ray query (issue #45), by subdivision to a tolerance and
//! nothing else: the patch's rational Bezier pieces (`scene::patch::bezier`, tied to the
//! evaluator by its tests) are split in halves nearest box first, and a piece whose box is under
//! the tolerance is met as the two triangles of its corners. The bounds are exact, not sampled:
//! with positive weights a rational Bezier piece lies in the convex hull of its control points.
//! No Newton step and no evaluation of the surface: it shares nothing with the shader's solve,
//! which it is to check.

use crate::scene::patch::bezier::{pieces, Piece};
use crate::scene::patch::Patch;
use glam::DVec3;

/// Where `o + t d` (`inv` = 1 / d) enters the box, `t >= 0`, if it does. An axis the ray runs
/// parallel to is a containment test (0 × ∞ would be NaN for a ray in a face's plane).
fn slab(o: DVec3, inv: DVec3, (lo, hi): (DVec3, DVec3)) -> Option<f64> {
    let (mut near, mut far) = (0.0f64, f64::INFINITY);
    for a in 0..3 {
        if inv[a].is_infinite() {
            if o[a] < lo[a] || o[a] > hi[a] {
                return None;
            }
            continue;
        }
        let (t0, t1) = ((lo[a] - o[a]) * inv[a], (hi[a] - o[a]) * inv[a]);
        near = near.max(t0.min(t1));
        far = far.min(t0.max(t1));
    }
    (near <= far).then_some(near)
}

fn triangle(o: DVec3, d: DVec3, [a, b, c]: [DVec3; 3]) -> Option<(f64, f64, f64)> {
    let (e1, e2) = (b - a, c - a);
    let pv = d.cross(e2);
    let det = e1.dot(pv);
    if det.abs() < 1e-300 {
        return None;
    }
    let s = o - a;
    let u = s.dot(pv) / det;
    let qv = s.cross(e1);
    let v = d.dot(qv) / det;
    let t = e2.dot(qv) / det;
    // Slack of a thousandth of a triangle already under the tolerance: the halves of two
    // neighbouring pieces need not meet at the same points along their seam, and a ray aimed
    // at the seam must not slip through the sliver between their chords.
    const SLACK: f64 = 1e-3;
    (u >= -SLACK && v >= -SLACK && u + v <= 1.0 + SLACK).then_some((t, u, v))
}

/// The nearest hit of `o + t d` with the patch in `(t_min, t_max)`, within its trim loops:
/// `(t, u, v)`, found to `tolerance` (a world length: a piece is met as flat once its box's diagonal is under it).
pub fn hit(
    patch: &Patch,
    o: DVec3,
    d: DVec3,
    [t_min, t_max]: [f64; 2],
    tolerance: f64,
) -> Option<(f64, f64, f64)> {
    let inv = d.recip();
    let mut stack: Vec<(f64, Piece)> =
        pieces(patch).into_iter().filter_map(|p| slab(o, inv, p.bounds()).map(|t| (t, p))).collect();
    let mut best: Option<(f64, f64, f64)> = None;
    while let Some(i) = (0..stack.len()).min_by(|&a, &b| stack[a].0.total_cmp(&stack[b].0)) {
        let (entry, piece) = stack.swap_remove(i);
        if entry > best.map_or(t_max, |b| b.0) {
            break;
        }
        let (lo, hi) = piece.bounds();
        if (hi - lo).length() < tolerance {
            let [p, q] = piece.degree;
            let c = |i: usize, j: usize| piece.at(i, j).truncate() / piece.at(i, j).w;
            let corners = [c(0, 0), c(p, 0), c(p, q), c(0, q)];
            let [[u0, u1], [v0, v1]] = piece.domain;
            for (tri, uv) in [
                ([corners[0], corners[1], corners[2]], [(u0, v0), (u1, v0), (u1, v1)]),
                ([corners[0], corners[2], corners[3]], [(u0, v0), (u1, v1), (u0, v1)]),
            ] {
                if let Some((t, a, b)) = triangle(o, d, tri) {
                    if t > t_min && t < best.map_or(t_max, |b| b.0) {
                        let u = uv[0].0 + a * (uv[1].0 - uv[0].0) + b * (uv[2].0 - uv[0].0);
                        let v = uv[0].1 + a * (uv[1].1 - uv[0].1) + b * (uv[2].1 - uv[0].1);
                        // Trimmed away: not surface, and a farther crossing may be.
                        if patch.kept(u, v) {
                            best = Some((t, u, v));
                        }
                    }
                }
            }
            continue;
        }
        // Split along the longer parameter side in world terms (the wider control polygon).
        let [p, q] = piece.degree;
        let c = |i: usize, j: usize| piece.at(i, j).truncate() / piece.at(i, j).w;
        let along_u = (c(p, 0) - c(0, 0)).length() + (c(p, q) - c(0, q)).length();
        let along_v = (c(0, q) - c(0, 0)).length() + (c(p, q) - c(p, 0)).length();
        for half in piece.split(if along_u >= along_v { 0 } else { 1 }) {
            if let Some(t) = slab(o, inv, half.bounds()) {
                if t <= best.map_or(t_max, |b| b.0) {
                    stack.push((t, half));
                }
            }
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lcg(seed: &mut u64) -> f64 {
        *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (*seed >> 11) as f64 / (1u64 << 53) as f64
    }

    /// The unit sphere: its knots have interior doubles, so knot insertion is exercised (4 x 2
    /// pieces).
    fn sphere() -> Patch {
        Patch::sphere(DVec3::ZERO, 1.0, 0)
    }

    /// Rays at the NURBS sphere hit where irt's analytic sphere is hit, to the tolerance, and
    /// miss where it is missed; the (u, v) found evaluates to the hit point.
    #[test]
    fn the_nurbs_sphere_is_hit_where_the_analytic_sphere_is() {
        let s = sphere();
        let tol = 1e-4;
        let mut seed = 4u64;
        let (mut hits, mut edge) = (0, 0);
        for case in 0..300 {
            let o = DVec3::new(lcg(&mut seed) - 0.5, lcg(&mut seed) - 0.5, lcg(&mut seed) - 0.5).normalize()
                * 5.0;
            let aim = DVec3::new(lcg(&mut seed) - 0.5, lcg(&mut seed) - 0.5, lcg(&mut seed) - 0.5) * 2.4;
            let d = (aim - o).normalize();
            let want = crate::reference::intersect_sphere(o, d, DVec3::ZERO, 1.0, 0.0, f64::INFINITY);
            let got = hit(&s, o, d, [0.0, f64::INFINITY], tol);
            let rim = (o.cross(d).length() - 1.0).abs();
            match (want, got) {
                (Some(t), Some((g, u, v))) => {
                    assert!(
                        (t - g).abs() < 2.0 * tol / d.dot(-(o + d * t)).abs().max(1e-3),
                        "case {case}: t {g} against {t}"
                    );
                    assert!(
                        (s.eval(u, v).p - (o + d * g)).length() < 4.0 * tol,
                        "case {case}: (u, v) = ({u}, {v})"
                    );
                    hits += 1;
                }
                (None, None) => {}
                // Within the tolerance of the silhouette, either answer is right.
                _ if rim < 2.0 * tol => edge += 1,
                (w, g) => panic!("case {case}: sphere {w:?}, patch {g:?}, {rim} from the rim"),
            }
        }
        println!("{hits} hits, {edge} within the tolerance of the rim");
        assert!(hits > 100, "{hits} hits");
        assert!(edge < 3, "{edge} at the rim");
    }
}
