//! A patch as rational Bezier pieces: knot insertion (Boehm's, one knot at a time) until every
//! span is one piece, then de Casteljau splits of a piece at any parameter and degree elevation.
//! With positive weights a piece lies in the convex hull of its control points, so a piece's
//! box is exact, not sampled: what the leaves' boxes (`leaves`) and the f64 twin's subdivision
//! (`reference::patch`) both stand on. Tied to the evaluator (`Patch::eval`, de Boor–Cox) by
//! the tests below: the pieces are the patch.

use super::Patch;
use glam::{DVec3, DVec4};

/// A rational Bezier piece: `(p + 1) × (q + 1)` homogeneous points `(w x, w y, w z, w)`, u
/// fastest, over the parameter box `domain` of its patch.
#[derive(Clone, Debug, PartialEq)]
pub struct Piece {
    pub degree: [usize; 2],
    pub points: Vec<DVec4>,
    pub domain: [[f64; 2]; 2],
}

impl Piece {
    /// Homogeneous control point `(i, j)`.
    pub fn at(&self, i: usize, j: usize) -> DVec4 {
        self.points[i + (self.degree[0] + 1) * j]
    }

    /// Euclidean control point `(i, j)`.
    pub fn point(&self, i: usize, j: usize) -> DVec3 {
        let h = self.at(i, j);
        h.truncate() / h.w
    }

    /// The box of the Euclidean control points, which holds the piece.
    pub fn bounds(&self) -> (DVec3, DVec3) {
        self.points.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), h| {
            let p = h.truncate() / h.w;
            (lo.min(p), hi.max(p))
        })
    }

    /// Halves at the middle of parameter `a` (0: u, 1: v).
    pub fn split(&self, a: usize) -> [Piece; 2] {
        self.split_at(a, 0.5)
    }

    /// The two pieces either side of fraction `s` (0 to 1) of parameter `a`'s span.
    pub fn split_at(&self, a: usize, s: f64) -> [Piece; 2] {
        let [p, q] = self.degree;
        let (n, m) = if a == 0 { (p, q) } else { (q, p) };
        let mut halves = [self.points.clone(), self.points.clone()];
        let mut row = Vec::with_capacity(n + 1);
        for line in 0..=m {
            let index = |k: usize| if a == 0 { k + (p + 1) * line } else { line + (p + 1) * k };
            row.clear();
            row.extend((0..=n).map(|k| self.points[index(k)]));
            for r in 0..=n {
                halves[0][index(r)] = row[0];
                halves[1][index(n - r)] = row[n - r];
                for k in 0..n - r {
                    row[k] = row[k] * (1.0 - s) + row[k + 1] * s;
                }
            }
        }
        let [t0, t1] = self.domain[a];
        let mid = if s == 0.5 { 0.5 * (t0 + t1) } else { t0 + s * (t1 - t0) };
        let mut d = [self.domain, self.domain];
        d[0][a][1] = mid;
        d[1][a][0] = mid;
        let [h0, h1] = halves;
        [
            Piece { degree: self.degree, points: h0, domain: d[0] },
            Piece { degree: self.degree, points: h1, domain: d[1] },
        ]
    }

    /// The part of the piece over fractions `[[u0, u1], [v0, v1]]` (each within 0 to 1) of its
    /// spans.
    pub fn sub(&self, range: [[f64; 2]; 2]) -> Piece {
        let mut piece = self.clone();
        for (a, [lo, hi]) in range.into_iter().enumerate() {
            if hi < 1.0 {
                let [left, _] = piece.split_at(a, hi);
                piece = left;
            }
            if lo > 0.0 {
                let [_, right] = piece.split_at(a, lo / hi);
                piece = right;
            }
        }
        piece
    }

    /// The same surface at degree `to` in both parameters (each at least the piece's own):
    /// repeated degree elevation, Q_i = i/(n+1) P_(i-1) + (1 - i/(n+1)) P_i, exact.
    pub fn elevated(&self, to: usize) -> Piece {
        let mut piece = self.clone();
        for a in 0..2 {
            while piece.degree[a] < to {
                let [p, q] = piece.degree;
                let (n, m) = if a == 0 { (p, q) } else { (q, p) };
                let mut degree = piece.degree;
                degree[a] += 1;
                let mut points = vec![DVec4::ZERO; (degree[0] + 1) * (degree[1] + 1)];
                for line in 0..=m {
                    let old =
                        |k: usize| piece.points[if a == 0 { k + (p + 1) * line } else { line + (p + 1) * k }];
                    for i in 0..=n + 1 {
                        let f = i as f64 / (n + 1) as f64;
                        let below = if i > 0 { old(i - 1) * f } else { DVec4::ZERO };
                        let here = if i <= n { old(i) * (1.0 - f) } else { DVec4::ZERO };
                        let at = if a == 0 { i + (degree[0] + 1) * line } else { line + (degree[0] + 1) * i };
                        points[at] = below + here;
                    }
                }
                piece = Piece { degree, points, domain: piece.domain };
            }
        }
        piece
    }
}

/// A curve's Bezier pieces (their points) and each one's parameter span.
type Pieces1 = (Vec<Vec<DVec4>>, Vec<[f64; 2]>);

/// Inserts knots into one B-spline curve (homogeneous points) until every knot value in its
/// domain has multiplicity at least `p`, and returns its Bezier pieces' points (`p + 1` each)
/// with each piece's parameter span. Unclamped ends are handled alike: the domain's ends are
/// knots to fill up too.
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

/// How many Bezier pieces the patch has: its non-empty spans in u times those in v (known
/// before any is made, for the limits).
pub fn piece_count(patch: &Patch) -> usize {
    let spans = |a: usize| {
        let k = &patch.knots[a];
        (patch.degree[a]..patch.counts[a]).filter(|&s| k[s] < k[s + 1]).count()
    };
    spans(0) * spans(1)
}

/// The patch's rational Bezier pieces, u fastest.
pub fn pieces(patch: &Patch) -> Vec<Piece> {
    let [p, q] = patch.degree;
    let [nu, nv] = patch.counts;
    let h: Vec<DVec4> = patch.points.iter().map(|c| (c.truncate() * c.w).extend(c.w)).collect();
    // Rows in u, then the resulting columns in v.
    let rows: Vec<Pieces1> =
        (0..nv).map(|j| curve_to_bezier(&patch.knots[0], p, &h[nu * j..nu * (j + 1)])).collect();
    let uspans = rows[0].1.clone();
    let mut by_u = Vec::new();
    for pu in 0..uspans.len() {
        let mut columns = Vec::new();
        let mut vspans = Vec::new();
        for i in 0..=p {
            let column: Vec<DVec4> = rows.iter().map(|r| r.0[pu][i]).collect();
            let (c, s) = curve_to_bezier(&patch.knots[1], q, &column);
            columns.push(c);
            vspans = s;
        }
        by_u.push((columns, vspans));
    }
    let mut out = Vec::new();
    let vcount = by_u[0].1.len();
    for pv in 0..vcount {
        for (pu, us) in uspans.iter().enumerate() {
            let (columns, vspans) = &by_u[pu];
            let mut points = vec![DVec4::ZERO; (p + 1) * (q + 1)];
            for (i, column) in columns.iter().enumerate() {
                for j in 0..=q {
                    points[i + (p + 1) * j] = column[pv][j];
                }
            }
            out.push(Piece { degree: patch.degree, points, domain: [*us, vspans[pv]] });
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lcg(seed: &mut u64) -> f64 {
        *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (*seed >> 11) as f64 / (1u64 << 53) as f64
    }

    /// A quintic by cubic B-spline with random weights, interior knots single and double, and
    /// unclamped ends.
    pub(crate) fn quintic() -> Patch {
        let mut seed = 9u64;
        let (nu, nv) = (9, 6);
        let points = (0..nu * nv)
            .map(|_| DVec4::new(lcg(&mut seed), lcg(&mut seed), lcg(&mut seed), 0.5 + lcg(&mut seed)))
            .collect();
        let ku = vec![-0.5, -0.4, -0.2, -0.1, -0.05, 0.0, 0.3, 0.5, 0.5, 1.0, 1.1, 1.2, 1.3, 1.4, 1.5];
        let kv = vec![0.0, 0.0, 0.0, 0.0, 0.4, 0.7, 1.0, 1.0, 1.0, 1.0];
        Patch::new([5, 3], [nu, nv], [ku, kv], points, 0).unwrap()
    }

    fn euclid(h: DVec4) -> DVec3 {
        h.truncate() / h.w
    }

    /// Knot insertion and halving keep the surface: every piece's corners, and the corner its
    /// halves share (its middle), are the patch's points there; the count is known up front.
    #[test]
    fn the_bezier_pieces_are_the_patch() {
        for (s, count) in [(Patch::sphere(DVec3::ZERO, 1.0, 0), 8), (quintic(), 9)] {
            let ps = pieces(&s);
            assert_eq!((ps.len(), piece_count(&s)), (count, count));
            for p in &ps {
                let [[u0, u1], [v0, v1]] = p.domain;
                let [n, m] = p.degree;
                let quarter = &p.split(0)[0].split(1)[0];
                let mid = s.eval(0.5 * (u0 + u1), 0.5 * (v0 + v1)).p;
                assert!((quarter.point(n, m) - mid).length() < 1e-12, "the middle of {:?}", p.domain);
                for (i, j, u, v) in [(0, 0, u0, v0), (n, 0, u1, v0), (0, m, u0, v1), (n, m, u1, v1)] {
                    assert!((p.point(i, j) - s.eval(u, v).p).length() < 1e-12, "({u}, {v})");
                }
            }
        }
    }

    /// A sub-piece and an elevated piece are the same surface: their corners and the middles of
    /// their edges (de Casteljau halves) are the patch's points there.
    #[test]
    fn sub_pieces_and_elevated_pieces_keep_the_surface() {
        let s = quintic();
        for p in pieces(&s) {
            let [[u0, u1], [v0, v1]] = p.domain;
            let at = |fu: f64, fv: f64| s.eval(u0 + fu * (u1 - u0), v0 + fv * (v1 - v0)).p;
            let range = [[0.2, 0.65], [0.1, 0.3]];
            for piece in [p.sub(range), p.elevated(5).sub(range), p.sub([[0.0, 1.0], [0.5, 1.0]])] {
                let [[a0, a1], [b0, b1]] = piece.domain;
                let frac = |t: f64, a: usize| (t - p.domain[a][0]) / (p.domain[a][1] - p.domain[a][0]);
                let [n, m] = piece.degree;
                for (i, j, fu, fv) in [(0, 0, a0, b0), (n, 0, a1, b0), (0, m, a0, b1), (n, m, a1, b1)] {
                    let want = at(frac(fu, 0), frac(fv, 1));
                    assert!((piece.point(i, j) - want).length() < 1e-11, "{:?}", piece.domain);
                }
                let mid = piece.split(0)[0].split(1)[0].point(n, m);
                let want = at(frac(0.5 * (a0 + a1), 0), frac(0.5 * (b0 + b1), 1));
                assert!((mid - want).length() < 1e-11, "the middle of {:?}", piece.domain);
            }
            let e = p.elevated(6);
            assert_eq!(e.degree, [6, 6]);
            let mid = e.split(0)[0].split(1)[0].point(6, 6);
            assert!((mid - at(0.5, 0.5)).length() < 1e-11);
            assert!((euclid(e.points[0]) - euclid(p.points[0])).length() < 1e-12);
        }
    }
}
