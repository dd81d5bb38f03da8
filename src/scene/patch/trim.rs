//! Trimming (issue #45): which part of a patch's parameter domain is surface. CAD systems
//! deliver a face as a surface and loops of 2D curves in its parameter space: an outer boundary
//! and holes (OBJ's `trim` and `hole` of `curv2`s, STEP's face bounds). irt keeps each loop as a
//! closed polygon in the patch's (u, v), the curves flattened to [`TOLERANCE`] of the domain,
//! and decides a hit by the even-odd rule over all of a patch's loops (Martin et al., JGT 2000,
//! test the point against the loops after the hit; they keep monotone curve pieces, irt the
//! polygon, whose chord error is bounded instead). Outer loops and holes need no flag: a hole
//! lies inside its outer loop, so the point is inside one more loop. A patch with holes and no
//! outer loop gets its domain's boundary as one (OBJ: the surface's own boundary then bounds it).
//!
//! [`kept`] is what the f64 twin asks; `shaders/patch.wgsl`'s `patch_kept` is its GPU twin, over
//! the same edges (`gpu::layout::patch`).

use glam::{DVec2, DVec3};

/// A trim curve's chord error, at most, as a fraction of the larger side of the patch's
/// parameter domain (a 64-edge circle of a quarter of the domain is 3e-4 off; this makes it
/// about 200 edges: under a thousandth of a pixel where the patch spans 1000 pixels).
pub const TOLERANCE: f64 = 1e-5;
/// Edges of all of one patch's loops, at most: each hit tests every one (a limit checked before
/// a curve is flattened further, and by `Patch::check`).
pub const MAX_EDGES: usize = 4096;

/// A 2D rational B-spline curve in a patch's parameter space: degree, knots, control points
/// `(u, v, w)` with weights `w > 0`.
#[derive(Clone, Debug, PartialEq)]
pub struct Curve {
    pub degree: usize,
    pub knots: Vec<f64>,
    pub points: Vec<DVec3>,
}

impl Curve {
    /// Checked: degree 1 to `MAX_DEGREE`, `points + degree + 1` non-decreasing finite knots over
    /// a non-empty domain, finite points with positive weights.
    pub fn new(degree: usize, knots: Vec<f64>, points: Vec<DVec3>) -> Result<Curve, String> {
        let n = points.len();
        if degree == 0 || degree > super::MAX_DEGREE {
            return Err(format!(
                "degree {degree}: irt takes trim curves of degree 1 to {}",
                super::MAX_DEGREE
            ));
        }
        if n <= degree {
            return Err(format!("{n} control points: degree {degree} needs at least {}", degree + 1));
        }
        if knots.len() != n + degree + 1 {
            return Err(format!(
                "{} knots: {n} points of degree {degree} need {}",
                knots.len(),
                n + degree + 1
            ));
        }
        if let Some(i) = knots.windows(2).position(|w| w[1].partial_cmp(&w[0]).is_none_or(|o| o.is_lt())) {
            return Err(format!(
                "knots decrease (or are not numbers) at {}: {} then {}",
                i + 1,
                knots[i],
                knots[i + 1]
            ));
        }
        if knots[degree] >= knots[n] {
            return Err(format!("knots span an empty domain ({} to {})", knots[degree], knots[n]));
        }
        if let Some(i) = points.iter().position(|q| !q.is_finite() || q.z <= 0.0) {
            return Err(format!("control point {i} ({}) needs finite values and a weight > 0", points[i]));
        }
        Ok(Curve { degree, knots, points })
    }

    /// The parameter domain `[t0, t1]`.
    pub fn domain(&self) -> [f64; 2] {
        [self.knots[self.degree], self.knots[self.points.len()]]
    }

    /// The point at `t` (clamped into the domain), by de Boor on the homogeneous points.
    pub fn at(&self, t: f64) -> DVec2 {
        let (p, n) = (self.degree, self.points.len());
        let [t0, t1] = self.domain();
        let t = t.clamp(t0, t1);
        let k = &self.knots;
        let span = if t >= k[n] {
            (p..n).rev().find(|&s| k[s] < k[s + 1]).expect("a non-empty span")
        } else {
            (p..n).find(|&s| t < k[s + 1]).expect("t within the domain")
        };
        let mut d: Vec<DVec3> = (0..=p)
            .map(|j| {
                let q = self.points[span - p + j];
                DVec3::new(q.x * q.z, q.y * q.z, q.z)
            })
            .collect();
        for r in 1..=p {
            for j in (r..=p).rev() {
                let i = span - p + j;
                let den = k[i + p + 1 - r] - k[i];
                let a = if den > 0.0 { (t - k[i]) / den } else { 0.0 };
                d[j] = d[j - 1] * (1.0 - a) + d[j] * a;
            }
        }
        DVec2::new(d[p].x / d[p].z, d[p].y / d[p].z)
    }

    /// The curve from `t0` to `t1` (either way round) as a polyline whose chords are within
    /// `tolerance` of the curve, both end points included: each knot span is cut into 2^k equal
    /// parts, k the least that puts every part's middle within `tolerance` of its chord. Err
    /// where that takes more than `budget` points.
    pub fn flatten(&self, [t0, t1]: [f64; 2], tolerance: f64, budget: usize) -> Result<Vec<DVec2>, String> {
        let (lo, hi) = (t0.min(t1), t0.max(t1));
        let [d0, d1] = self.domain();
        if lo < d0 - 1e-12 * (d1 - d0)
            || hi > d1 + 1e-12 * (d1 - d0)
            || hi.partial_cmp(&lo) != Some(std::cmp::Ordering::Greater)
        {
            return Err(format!("the range {t0} to {t1} is not a part of the curve's domain {d0} to {d1}"));
        }
        let mut breaks = vec![lo];
        breaks.extend(self.knots.iter().copied().filter(|&k| k > lo && k < hi));
        breaks.push(hi);
        breaks.dedup();
        let mut out = vec![self.at(lo)];
        for w in breaks.windows(2) {
            let (a, b) = (w[0], w[1]);
            let mut parts = 1usize;
            loop {
                let at = |i: usize| a + (b - a) * i as f64 / parts as f64;
                let flat = (0..parts).all(|i| {
                    let (p, q, m) = (self.at(at(i)), self.at(at(i + 1)), self.at(0.5 * (at(i) + at(i + 1))));
                    distance_to_segment(m, p, q) <= tolerance
                        && distance_to_segment(self.at(at(i) + 0.25 * (b - a) / parts as f64), p, q)
                            <= tolerance
                });
                if flat {
                    out.extend((1..=parts).map(|i| self.at(at(i))));
                    break;
                }
                parts *= 2;
                if out.len() + parts > budget {
                    return Err(format!(
                        "flattening it to {tolerance:e} of the domain takes more than {budget} edges"
                    ));
                }
            }
        }
        if t1 < t0 {
            out.reverse();
        }
        Ok(out)
    }
}

fn distance_to_segment(m: DVec2, p: DVec2, q: DVec2) -> f64 {
    let e = q - p;
    let s =
        if e.length_squared() > 0.0 { ((m - p).dot(e) / e.length_squared()).clamp(0.0, 1.0) } else { 0.0 };
    (m - (p + e * s)).length()
}

/// The loops' edges, at most, and each loop closed (its last point its first), at least three
/// edges, finite and within the patch's `domain` (to its tolerance): what `Patch::check` asks.
pub fn check(loops: &[Vec<DVec2>], domain: [[f64; 2]; 2]) -> Result<(), String> {
    let edges: usize = loops.iter().map(|l| l.len().saturating_sub(1)).sum();
    if edges > MAX_EDGES {
        return Err(format!("its trim loops have {edges} edges; irt's limit is {MAX_EDGES} a patch"));
    }
    let size = (domain[0][1] - domain[0][0]).max(domain[1][1] - domain[1][0]);
    let slack = 1e-9 * size;
    for (k, l) in loops.iter().enumerate() {
        if l.len() < 4 {
            return Err(format!(
                "trim loop {k} has {} points; a loop needs at least 3 and its first again",
                l.len()
            ));
        }
        if let Some(i) = l.iter().position(|p| {
            !p.is_finite()
                || p.x < domain[0][0] - slack
                || p.x > domain[0][1] + slack
                || p.y < domain[1][0] - slack
                || p.y > domain[1][1] + slack
        }) {
            return Err(format!(
                "trim loop {k}'s point {i} ({}) is outside the patch's domain {:?} x {:?}",
                l[i], domain[0], domain[1]
            ));
        }
        let (first, last) = (l[0], l[l.len() - 1]);
        if (first - last).length() > slack {
            return Err(format!("trim loop {k} is open: it starts at {first} and ends at {last}"));
        }
    }
    Ok(())
}

/// Whether `(u, v)` is kept by `loops` (no loops: the whole domain): inside an odd number of
/// them, counted by the crossings of a ray towards +u.
pub fn kept(loops: &[Vec<DVec2>], u: f64, v: f64) -> bool {
    if loops.is_empty() {
        return true;
    }
    let mut inside = false;
    for l in loops {
        for e in l.windows(2) {
            let (a, b) = (e[0], e[1]);
            if (a.y > v) != (b.y > v) && u < a.x + (v - a.y) * (b.x - a.x) / (b.y - a.y) {
                inside = !inside;
            }
        }
    }
    inside
}

/// The domain's boundary as a loop (counter-clockwise), for holes with no outer loop.
pub fn boundary(domain: [[f64; 2]; 2]) -> Vec<DVec2> {
    let [[u0, u1], [v0, v1]] = domain;
    [(u0, v0), (u1, v0), (u1, v1), (u0, v1), (u0, v0)].map(|(u, v)| DVec2::new(u, v)).to_vec()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit circle as a rational quadratic B-spline (9 points, the standard construction).
    fn circle(c: DVec2, r: f64) -> Curve {
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let pts = [
            (1., 0., 1.),
            (1., 1., h),
            (0., 1., 1.),
            (-1., 1., h),
            (-1., 0., 1.),
            (-1., -1., h),
            (0., -1., 1.),
            (1., -1., h),
            (1., 0., 1.),
        ];
        let points = pts.iter().map(|&(x, y, w)| DVec3::new(c.x + r * x, c.y + r * y, w)).collect();
        let knots = vec![0., 0., 0., 0.25, 0.25, 0.5, 0.5, 0.75, 0.75, 1., 1., 1.];
        Curve::new(2, knots, points).unwrap()
    }

    /// The circle's points lie on it, and its polyline keeps within the tolerance of it,
    /// closes, and decides inside and outside as the circle does.
    #[test]
    fn a_flattened_circle_is_the_circle_to_the_tolerance() {
        let (c, r) = (DVec2::new(0.5, 0.4), 0.25);
        let curve = circle(c, r);
        for k in 0..=40 {
            let p = curve.at(k as f64 / 40.0);
            assert!(((p - c).length() - r).abs() < 1e-12, "{p}");
        }
        let l = curve.flatten([0.0, 1.0], TOLERANCE, MAX_EDGES).unwrap();
        assert!((l[0] - l[l.len() - 1]).length() < 1e-12);
        for e in l.windows(2) {
            let m = 0.5 * (e[0] + e[1]);
            assert!(r - (m - c).length() <= TOLERANCE * 1.01, "chord error {}", r - (m - c).length());
        }
        println!("{} edges", l.len() - 1);
        assert!(l.len() < 1000, "{} points", l.len());
        check(std::slice::from_ref(&l), [[0.0, 1.0], [0.0, 1.0]]).unwrap();
        let loops = vec![boundary([[0.0, 1.0], [0.0, 1.0]]), l.clone()];
        let mut seed = 3u64;
        for _ in 0..2000 {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            let (u, v) = (
                (seed >> 40) as f64 / (1u64 << 24) as f64,
                (seed >> 16 & 0xffffff) as f64 / (1u64 << 24) as f64,
            );
            let d = (DVec2::new(u, v) - c).length();
            if (d - r).abs() > 2.0 * TOLERANCE {
                assert_eq!(kept(&loops, u, v), d > r, "({u}, {v}) at {d} from the centre");
            }
        }
        // Reversed, the same points the other way round.
        let back = curve.flatten([1.0, 0.0], TOLERANCE, MAX_EDGES).unwrap();
        assert!(back.iter().rev().zip(&l).all(|(a, b)| (*a - *b).length() < 1e-12));
    }

    #[test]
    fn bad_loops_and_curves_are_refused_in_words() {
        let d = [[0.0, 1.0], [0.0, 1.0]];
        let open =
            vec![DVec2::new(0.1, 0.1), DVec2::new(0.9, 0.1), DVec2::new(0.9, 0.9), DVec2::new(0.1, 0.8)];
        assert!(check(&[open], d).unwrap_err().contains("open"));
        let out =
            vec![DVec2::new(0.1, 0.1), DVec2::new(1.9, 0.1), DVec2::new(0.9, 0.9), DVec2::new(0.1, 0.1)];
        assert!(check(&[out], d).unwrap_err().contains("outside the patch's domain"));
        assert!(check(&[vec![DVec2::ZERO; 3]], d).unwrap_err().contains("at least 3"));
        let line = |k: Vec<f64>| Curve::new(1, k, vec![DVec3::new(0., 0., 1.), DVec3::new(1., 0., 1.)]);
        assert!(line(vec![0., 1., 0., 1.]).unwrap_err().contains("decrease"));
        assert!(line(vec![0., 1., 1.]).unwrap_err().contains("knots"));
        let c = line(vec![0., 0., 1., 1.]).unwrap();
        assert!(c.flatten([0.0, 2.0], TOLERANCE, 10).unwrap_err().contains("not a part"));
        assert!(circle(DVec2::splat(0.5), 0.25)
            .flatten([0.0, 1.0], 1e-9, 100)
            .unwrap_err()
            .contains("more than 100"));
    }
}
