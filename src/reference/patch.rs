//! The f64 twin of a spline patch's ray query (issue #45), by subdivision to a tolerance and
//! nothing else: the patch is cut into its rational Bezier pieces (knot insertion), each piece
//! is split in halves (de Casteljau, in homogeneous coordinates) nearest box first, and a piece
//! whose box is under the tolerance is met as the two triangles of its corners. The bounds are
//! exact, not sampled: with positive weights a rational Bezier piece lies in the convex hull of
//! its projected control points. It shares no code with `scene::patch`'s evaluation or with the
//! shader's Newton solve, which it is to check.

use crate::scene::patch::Patch;
use glam::{DVec3, DVec4};

/// A rational Bezier piece: `(p + 1) × (q + 1)` homogeneous points `(w x, w y, w z, w)`, u
/// fastest, over the parameter box `domain`.
#[derive(Clone, Debug)]
struct Piece {
    degree: [usize; 2],
    points: Vec<DVec4>,
    domain: [[f64; 2]; 2],
}

impl Piece {
    fn at(&self, i: usize, j: usize) -> DVec4 {
        self.points[i + (self.degree[0] + 1) * j]
    }

    fn bounds(&self) -> (DVec3, DVec3) {
        self.points.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), h| {
            let p = h.truncate() / h.w;
            (lo.min(p), hi.max(p))
        })
    }

    /// Halves at the middle of parameter `a` (0: u, 1: v).
    fn split(&self, a: usize) -> [Piece; 2] {
        let [p, q] = self.degree;
        let (n, m) = if a == 0 { (p, q) } else { (q, p) };
        let mut halves = [self.points.clone(), self.points.clone()];
        for line in 0..=m {
            let index = |k: usize| if a == 0 { k + (p + 1) * line } else { line + (p + 1) * k };
            let mut row: Vec<DVec4> = (0..=n).map(|k| self.points[index(k)]).collect();
            for r in 0..=n {
                halves[0][index(r)] = row[0];
                halves[1][index(n - r)] = row[n - r];
                for k in 0..n - r {
                    row[k] = (row[k] + row[k + 1]) * 0.5;
                }
            }
        }
        let mid = 0.5 * (self.domain[a][0] + self.domain[a][1]);
        let mut d = [self.domain, self.domain];
        d[0][a][1] = mid;
        d[1][a][0] = mid;
        let [h0, h1] = halves;
        [
            Piece { degree: self.degree, points: h0, domain: d[0] },
            Piece { degree: self.degree, points: h1, domain: d[1] },
        ]
    }
}

/// A curve's Bezier pieces (their points) and each one's parameter span.
type Pieces1 = (Vec<Vec<DVec4>>, Vec<[f64; 2]>);

/// Inserts knots into one B-spline curve (homogeneous points) until every knot value in its
/// domain has multiplicity at least `p`, and returns its Bezier pieces' points (`p + 1` each)
/// with each piece's parameter span (Boehm's insertion, one knot at a time). Unclamped ends
/// are handled alike: the domain's ends are knots to fill up too.
fn curve_to_bezier(knots: &[f64], p: usize, points: &[DVec4]) -> Pieces1 {
    let (mut k, mut pts) = (knots.to_vec(), points.to_vec());
    let (lo, hi) = (knots[p], knots[points.len()]);
    let mut values: Vec<f64> = knots.iter().copied().filter(|&t| lo <= t && t <= hi).collect();
    values.dedup();
    for t in values {
        while k.iter().filter(|&&x| x == t).count() < p {
            // The last span s of the domain with k[s] <= t (t <= k[s + 1]; at the domain's top
            // end, the last span); the new points replace P[s - p + 1 ..= s].
            let s = (p..pts.len()).rfind(|&s| k[s] <= t).expect("t within the domain");
            let next = (0..=pts.len())
                .map(|j| {
                    if j + p <= s {
                        pts[j]
                    } else if j > s {
                        pts[j - 1]
                    } else {
                        let a = (t - k[j]) / (k[j + p] - k[j]);
                        pts[j - 1] * (1.0 - a) + pts[j] * a
                    }
                })
                .collect();
            k.insert(s + 1, t);
            pts = next;
        }
    }
    // Each non-empty span s of the domain is now a Bezier piece: points s - p ..= s.
    let (mut pieces, mut spans) = (Vec::new(), Vec::new());
    for s in p..pts.len() {
        if k[s] < k[s + 1] {
            pieces.push(pts[s - p..=s].to_vec());
            spans.push([k[s], k[s + 1]]);
        }
    }
    (pieces, spans)
}

/// The patch's rational Bezier pieces.
fn pieces(patch: &Patch) -> Vec<Piece> {
    let [p, q] = patch.degree;
    let [nu, nv] = patch.counts;
    let h: Vec<DVec4> = patch.points.iter().map(|c| (c.truncate() * c.w).extend(c.w)).collect();
    // Rows in u, then the resulting columns in v.
    let rows: Vec<Pieces1> =
        (0..nv).map(|j| curve_to_bezier(&patch.knots[0], p, &h[nu * j..nu * (j + 1)])).collect();
    let uspans = rows[0].1.clone();
    let mut out = Vec::new();
    for (pu, us) in uspans.iter().enumerate() {
        let mut columns = Vec::new();
        let mut vspans = Vec::new();
        for i in 0..=p {
            let column: Vec<DVec4> = rows.iter().map(|r| r.0[pu][i]).collect();
            let (c, s) = curve_to_bezier(&patch.knots[1], q, &column);
            columns.push(c);
            vspans = s;
        }
        for (pv, vs) in vspans.iter().enumerate() {
            let mut points = vec![DVec4::ZERO; (p + 1) * (q + 1)];
            for (i, column) in columns.iter().enumerate() {
                for j in 0..=q {
                    points[i + (p + 1) * j] = column[pv][j];
                }
            }
            out.push(Piece { degree: patch.degree, points, domain: [*us, *vs] });
        }
    }
    out
}

fn slab(o: DVec3, inv: DVec3, (lo, hi): (DVec3, DVec3)) -> Option<f64> {
    let a = (lo - o) * inv;
    let b = (hi - o) * inv;
    let near = a.min(b).max_element();
    let far = a.max(b).min_element();
    (near <= far && far >= 0.0).then_some(near.max(0.0))
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
    (u >= 0.0 && v >= 0.0 && u + v <= 1.0).then_some((t, u, v))
}

/// The nearest hit of `o + t d` with the patch in `(t_min, t_max)`: `(t, u, v)`, found to
/// `tolerance` (a world length: a piece is met as flat once its box's diagonal is under it).
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
                        best = Some((t, u, v));
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

    /// A quintic by cubic B-spline with random weights, interior knots single and double, and
    /// unclamped ends.
    fn quintic() -> Patch {
        let mut seed = 9u64;
        let (nu, nv) = (9, 6);
        let points = (0..nu * nv)
            .map(|_| DVec4::new(lcg(&mut seed), lcg(&mut seed), lcg(&mut seed), 0.5 + lcg(&mut seed)))
            .collect();
        let ku = vec![-0.5, -0.4, -0.2, -0.1, -0.05, 0.0, 0.3, 0.5, 0.5, 1.0, 1.1, 1.2, 1.3, 1.4, 1.5];
        let kv = vec![0.0, 0.0, 0.0, 0.0, 0.4, 0.7, 1.0, 1.0, 1.0, 1.0];
        Patch::new([5, 3], [nu, nv], [ku, kv], points, 0).unwrap()
    }

    /// Knot insertion and halving keep the surface: every piece's corners, and the corner its
    /// halves share (its middle), are the patch's points there.
    #[test]
    fn the_bezier_pieces_are_the_patch() {
        for (s, count) in [(sphere(), 8), (quintic(), 9)] {
            let ps = pieces(&s);
            assert_eq!(ps.len(), count);
            for p in &ps {
                let [[u0, u1], [v0, v1]] = p.domain;
                let quarter = &p.split(0)[0].split(1)[0];
                let h = quarter.at(p.degree[0], p.degree[1]);
                let mid = s.eval(0.5 * (u0 + u1), 0.5 * (v0 + v1)).p;
                assert!((h.truncate() / h.w - mid).length() < 1e-12, "the middle of {:?}", p.domain);
                for (i, j, u, v) in [(0, 0, u0, v0), (p.degree[0], 0, u1, v0), (0, p.degree[1], u0, v1)] {
                    let h = p.at(i, j);
                    assert!((h.truncate() / h.w - s.eval(u, v).p).length() < 1e-12, "({u}, {v})");
                }
            }
        }
        let s = sphere();
        for p in &pieces(&s) {
            let [[u0, u1], [v0, v1]] = p.domain;
            for (i, j, u, v) in [(0, 0, u0, v0), (2, 0, u1, v0), (0, 2, u0, v1), (2, 2, u1, v1)] {
                let h = p.at(i, j);
                let got = h.truncate() / h.w;
                assert!((got - s.eval(u, v).p).length() < 1e-12, "({u}, {v}): {got}");
            }
        }
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
