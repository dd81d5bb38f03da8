//! Spline surfaces (PAPER.md §8, issue #45): rational B-spline (NURBS) patches of degree up to
//! [`MAX_DEGREE`] in u and v, Bezier patches their special case (clamped knots, one span). This
//! is what a scene holds and what every tracer evaluates: the point and its exact first and
//! second derivatives (the normal, and the curvature a designer reads), from the basis
//! functions' derivatives (de Boor–Cox, Piegl and Tiller's A2.3) and the quotient rule for the
//! weights. [`bezier`] cuts a patch into rational Bezier pieces, [`leaves`] cuts those into
//! the leaves the accelerators hold.

pub mod bezier;
pub mod leaves;
pub mod trim;

use glam::{DVec2, DVec3, DVec4};

/// Highest degree in u or in v.
pub const MAX_DEGREE: usize = 5;
/// Most control points along one parameter (a limit checked before anything is allocated).
pub const MAX_POINTS_A_SIDE: usize = 1 << 12;

/// A NURBS surface: `counts[0] × counts[1]` control points, u fastest, each `(x, y, z, w)` with
/// its weight `w > 0` (Euclidean, not premultiplied: what OBJ's `v x y z w` and STEP give), a
/// knot vector per parameter of `count + degree + 1` non-decreasing values.
#[derive(Clone, Debug, PartialEq)]
pub struct Patch {
    pub degree: [usize; 2],
    pub counts: [usize; 2],
    pub knots: [Vec<f64>; 2],
    pub points: Vec<DVec4>,
    pub material: u32,
    /// Trim loops, closed polygons in the parameter domain (`trim`): empty for the whole
    /// domain, else the part inside an odd number of them is surface.
    pub trim: Vec<Vec<DVec2>>,
}

/// The surface at `(u, v)`: its point and its partial derivatives up to the second.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint {
    pub p: DVec3,
    pub du: DVec3,
    pub dv: DVec3,
    pub duu: DVec3,
    pub duv: DVec3,
    pub dvv: DVec3,
}

impl SurfacePoint {
    /// The unit normal `du × dv`, or `None` where the surface is degenerate (a pole, a
    /// collapsed edge): the tracers then take a neighbour's.
    pub fn normal(&self) -> Option<DVec3> {
        let n = self.du.cross(self.dv);
        let scale = self.du.length() * self.dv.length();
        (n.length() > 1e-12 * scale && scale > 0.0).then(|| n.normalize())
    }

    /// Gaussian and mean curvature from the fundamental forms (the normal's side positive).
    pub fn curvature(&self) -> Option<(f64, f64)> {
        let n = self.normal()?;
        let (e, f, g) = (self.du.dot(self.du), self.du.dot(self.dv), self.dv.dot(self.dv));
        let (l, m, nn) = (self.duu.dot(n), self.duv.dot(n), self.dvv.dot(n));
        let det = e * g - f * f;
        Some(((l * nn - m * m) / det, (e * nn - 2.0 * f * m + g * l) / (2.0 * det)))
    }
}

impl Patch {
    /// A NURBS patch, checked: degrees 1 to [`MAX_DEGREE`], at least `degree + 1` points a
    /// side, `count + degree + 1` non-decreasing knots spanning a non-empty domain, positive
    /// finite weights, finite coordinates. Each error says which of those failed.
    pub fn new(
        degree: [usize; 2],
        counts: [usize; 2],
        knots: [Vec<f64>; 2],
        points: Vec<DVec4>,
        material: u32,
    ) -> Result<Patch, String> {
        let patch = Patch { degree, counts, knots, points, material, trim: vec![] };
        patch.check_net()?;
        Ok(patch)
    }

    /// [`Patch::new`]'s checks and a material below `materials`: what `Scene::validate` asks
    /// of a patch however it was made.
    pub fn check(&self, materials: usize) -> Result<(), String> {
        self.check_net()?;
        trim::check(&self.trim, self.domain())?;
        if self.material as usize >= materials {
            return Err(format!("material {} does not exist ({materials} materials)", self.material));
        }
        Ok(())
    }

    fn check_net(&self) -> Result<(), String> {
        let Patch { degree, counts, knots, points, .. } = self;
        for a in 0..2 {
            let name = ["u", "v"][a];
            let (p, n) = (degree[a], counts[a]);
            if p == 0 || p > MAX_DEGREE {
                return Err(format!("degree {p} in {name}: irt traces degrees 1 to {MAX_DEGREE}"));
            }
            if n <= p || n > MAX_POINTS_A_SIDE {
                return Err(format!(
                    "{n} control points in {name}: degree {p} needs {} to {MAX_POINTS_A_SIDE}",
                    p + 1
                ));
            }
            let k = &knots[a];
            if k.len() != n + p + 1 {
                return Err(format!(
                    "{} knots in {name}: {n} points of degree {p} need {}",
                    k.len(),
                    n + p + 1
                ));
            }
            if let Some(i) = k.iter().position(|x| !x.is_finite()) {
                return Err(format!("knot {i} in {name} is {}", k[i]));
            }
            if let Some(i) = k.windows(2).position(|w| w[1] < w[0]) {
                return Err(format!("knots in {name} decrease at {}: {} then {}", i + 1, k[i], k[i + 1]));
            }
            if k[p] >= k[n] {
                return Err(format!("knots in {name} span an empty domain ({} to {})", k[p], k[n]));
            }
        }
        if points.len() != counts[0] * counts[1] {
            return Err(format!("{} control points for a {} x {} net", points.len(), counts[0], counts[1]));
        }
        if let Some(i) = points.iter().position(|q| !q.is_finite() || q.w <= 0.0) {
            return Err(format!(
                "control point {i} ({}) needs finite coordinates and a weight > 0",
                points[i]
            ));
        }
        Ok(())
    }

    /// A Bezier patch of degree `degree` (one span, knots clamped to [0, 1]), points u fastest.
    pub fn bezier(degree: [usize; 2], points: Vec<DVec4>, material: u32) -> Result<Patch, String> {
        let knots = degree.map(|p| [vec![0.0; p + 1], vec![1.0; p + 1]].concat());
        Patch::new(degree, degree.map(|p| p + 1), knots, points, material)
    }

    /// The sphere about `center` as one rational biquadratic NURBS: 9 x 5 points, the
    /// standard construction (circles of weights 1 and √½ at the corners), u around the z axis
    /// and v from the south pole to the north.
    pub fn sphere(center: DVec3, radius: f64, material: u32) -> Patch {
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let circle = [
            (1.0, 0.0, 1.0),
            (1.0, 1.0, h),
            (0.0, 1.0, 1.0),
            (-1.0, 1.0, h),
            (-1.0, 0.0, 1.0),
            (-1.0, -1.0, h),
            (0.0, -1.0, 1.0),
            (1.0, -1.0, h),
            (1.0, 0.0, 1.0),
        ];
        let meridian = [(0.0, -1.0, 1.0), (1.0, -1.0, h), (1.0, 0.0, 1.0), (1.0, 1.0, h), (0.0, 1.0, 1.0)];
        let mut points = Vec::with_capacity(45);
        for &(r, z, wv) in &meridian {
            for &(x, y, wu) in &circle {
                points.push((center + DVec3::new(r * x, r * y, z) * radius).extend(wu * wv));
            }
        }
        let ku = vec![0.0, 0.0, 0.0, 0.25, 0.25, 0.5, 0.5, 0.75, 0.75, 1.0, 1.0, 1.0];
        let kv = vec![0.0, 0.0, 0.0, 0.5, 0.5, 1.0, 1.0, 1.0];
        Patch::new([2, 2], [9, 5], [ku, kv], points, material).expect("a valid net")
    }

    /// Whether `(u, v)` is surface: within the trim loops, if any ([`trim::kept`]).
    pub fn kept(&self, u: f64, v: f64) -> bool {
        trim::kept(&self.trim, u, v)
    }

    /// The parameter domain `[[u0, u1], [v0, v1]]`.
    pub fn domain(&self) -> [[f64; 2]; 2] {
        std::array::from_fn(|a| [self.knots[a][self.degree[a]], self.knots[a][self.counts[a]]])
    }

    /// The point and its derivatives at `(u, v)`, clamped into the domain.
    pub fn eval(&self, u: f64, v: f64) -> SurfacePoint {
        let d = self.domain();
        let (u, v) = (u.clamp(d[0][0], d[0][1]), v.clamp(d[1][0], d[1][1]));
        let (su, bu) = basis_ders(&self.knots[0], self.degree[0], self.counts[0], u);
        let (sv, bv) = basis_ders(&self.knots[1], self.degree[1], self.counts[1], v);
        // Homogeneous sums: a[k][l] = ∂^(k+l)/∂u^k ∂v^l of Σ N_i N_j w P (xyz) and Σ N_i N_j w.
        let mut a = [[DVec4::ZERO; 3]; 3];
        for (j, nv) in bv.iter().enumerate() {
            for (i, nu) in bu.iter().enumerate() {
                let q = self.points[(su - self.degree[0] + i) + self.counts[0] * (sv - self.degree[1] + j)];
                let h = DVec4::new(q.x * q.w, q.y * q.w, q.z * q.w, q.w);
                for k in 0..3 {
                    for l in 0..3 - k {
                        a[k][l] += h * (nu[k] * nv[l]);
                    }
                }
            }
        }
        // S = A / w and its derivatives by the quotient rule.
        let w = |k: usize, l: usize| a[k][l].w;
        let xyz = |k: usize, l: usize| a[k][l].truncate();
        let p = xyz(0, 0) / w(0, 0);
        let du = (xyz(1, 0) - w(1, 0) * p) / w(0, 0);
        let dv = (xyz(0, 1) - w(0, 1) * p) / w(0, 0);
        let duu = (xyz(2, 0) - 2.0 * w(1, 0) * du - w(2, 0) * p) / w(0, 0);
        let dvv = (xyz(0, 2) - 2.0 * w(0, 1) * dv - w(0, 2) * p) / w(0, 0);
        let duv = (xyz(1, 1) - w(1, 0) * dv - w(0, 1) * du - w(1, 1) * p) / w(0, 0);
        SurfacePoint { p, du, dv, duu, duv, dvv }
    }
}

/// The knot span holding `t` (the last non-empty one at the domain's end) and the `p + 1`
/// basis functions there with their first and second derivatives: `out[i][k]` is the k-th
/// derivative of N_{span - p + i}.
fn basis_ders(knots: &[f64], p: usize, n: usize, t: f64) -> (usize, Vec<[f64; 3]>) {
    let span = if t >= knots[n] {
        (p..n).rev().find(|&s| knots[s] < knots[s + 1]).expect("a non-empty span")
    } else {
        (p..n).find(|&s| t < knots[s + 1]).expect("t within the domain")
    };
    // ndu[j][r]: basis functions of degree j (upper triangle) and knot differences (lower).
    let mut ndu = vec![vec![0.0; p + 1]; p + 1];
    ndu[0][0] = 1.0;
    let (mut left, mut right) = (vec![0.0; p + 1], vec![0.0; p + 1]);
    for j in 1..=p {
        left[j] = t - knots[span + 1 - j];
        right[j] = knots[span + j] - t;
        let mut saved = 0.0;
        for r in 0..j {
            ndu[j][r] = right[r + 1] + left[j - r];
            let temp = ndu[r][j - 1] / ndu[j][r];
            ndu[r][j] = saved + right[r + 1] * temp;
            saved = left[j - r] * temp;
        }
        ndu[j][j] = saved;
    }
    let mut out = vec![[0.0; 3]; p + 1];
    for (r, o) in out.iter_mut().enumerate() {
        o[0] = ndu[r][p];
        // Derivatives k = 1, 2 from the lower degrees' functions (A2.3's recurrence).
        let mut a = [[0.0; 3]; 2];
        a[0][0] = 1.0;
        let (mut s1, mut s2) = (0, 1);
        for k in 1..=2.min(p) {
            let mut d = 0.0;
            let rk = r as isize - k as isize;
            let pk = p - k;
            if rk >= 0 {
                a[s2][0] = a[s1][0] / ndu[pk + 1][rk as usize];
                d = a[s2][0] * ndu[rk as usize][pk];
            }
            let j1 = if rk >= -1 { 1 } else { (-rk) as usize };
            let j2 = if r as isize - 1 <= pk as isize { k - 1 } else { p - r };
            for j in j1..=j2 {
                let at = (rk + j as isize) as usize;
                a[s2][j] = (a[s1][j] - a[s1][j - 1]) / ndu[pk + 1][at];
                d += a[s2][j] * ndu[at][pk];
            }
            if r <= pk {
                a[s2][k] = -a[s1][k - 1] / ndu[pk + 1][r];
                d += a[s2][k] * ndu[r][pk];
            }
            o[k] = d;
            std::mem::swap(&mut s1, &mut s2);
        }
        // The recurrence gives the derivatives over p! / (p - k)!.
        o[1] *= p as f64;
        o[2] *= (p * p.saturating_sub(1)) as f64;
    }
    (span, out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_rational_sphere_is_the_unit_sphere_with_radial_normals_and_unit_curvature() {
        let s = Patch::sphere(DVec3::ZERO, 1.0, 0);
        for i in 0..=40 {
            for j in 1..40 {
                let (u, v) = (i as f64 / 40.0, j as f64 / 40.0);
                let e = s.eval(u, v);
                assert!((e.p.length() - 1.0).abs() < 1e-12, "({u}, {v}): {}", e.p);
                let n = e.normal().expect("regular away from the poles");
                assert!(n.dot(e.p).abs() > 1.0 - 1e-9, "({u}, {v}): normal {n} at {}", e.p);
                let (k, h) = e.curvature().unwrap();
                assert!((k - 1.0).abs() < 1e-7 && (h.abs() - 1.0).abs() < 1e-7, "({u}, {v}): K {k}, H {h}");
            }
        }
        // The poles: on the sphere, degenerate (du vanishes), and no NaN.
        for v in [0.0, 1.0] {
            let e = s.eval(0.3, v);
            assert!((e.p.length() - 1.0).abs() < 1e-12 && e.p.is_finite() && e.du.is_finite());
            assert!(e.normal().is_none(), "a pole has no normal of its own: {:?}", e.normal());
        }
    }

    #[test]
    fn derivatives_match_finite_differences_on_a_quintic_bspline() {
        // Degree 5 by 3, interior knots of every multiplicity short of a break, random weights.
        let mut seed = 9u64;
        let mut r = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let (nu, nv) = (9, 6);
        let points = (0..nu * nv).map(|_| DVec4::new(r(), r(), r(), 0.5 + r())).collect();
        let ku = vec![0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.3, 0.5, 0.5, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0];
        let kv = vec![0.0, 0.0, 0.0, 0.0, 0.4, 0.7, 1.0, 1.0, 1.0, 1.0];
        let s = Patch::new([5, 3], [nu, nv], [ku, kv], points, 0).unwrap();
        let h = 1e-5;
        for (u, v) in [(0.1, 0.2), (0.35, 0.55), (0.6, 0.9), (0.95, 0.05)] {
            let e = s.eval(u, v);
            let fd = |f: &dyn Fn(f64, f64) -> DVec3, du: f64, dv: f64| {
                (f(u + du * h, v + dv * h) - f(u - du * h, v - dv * h)) / (2.0 * h)
            };
            let p = |u: f64, v: f64| s.eval(u, v).p;
            let pu = |u: f64, v: f64| s.eval(u, v).du;
            let pv = |u: f64, v: f64| s.eval(u, v).dv;
            let close = |a: DVec3, b: DVec3| (a - b).length() <= 1e-5 * (1.0 + b.length());
            assert!(close(e.du, fd(&p, 1.0, 0.0)), "du at ({u}, {v}): {} against {}", e.du, fd(&p, 1.0, 0.0));
            assert!(close(e.dv, fd(&p, 0.0, 1.0)), "dv at ({u}, {v})");
            assert!(
                close(e.duu, fd(&pu, 1.0, 0.0)),
                "duu at ({u}, {v}): {} against {}",
                e.duu,
                fd(&pu, 1.0, 0.0)
            );
            assert!(close(e.dvv, fd(&pv, 0.0, 1.0)), "dvv at ({u}, {v})");
            assert!(close(e.duv, fd(&pu, 0.0, 1.0)), "duv at ({u}, {v})");
        }
    }

    #[test]
    fn a_bezier_patch_passes_through_its_corners() {
        let points =
            (0..16).map(|i| DVec4::new((i % 4) as f64, (i / 4) as f64, ((i * 7) % 5) as f64, 1.0)).collect();
        let b = Patch::bezier([3, 3], points, 0).unwrap();
        for (u, v, i) in [(0.0, 0.0, 0), (1.0, 0.0, 3), (0.0, 1.0, 12), (1.0, 1.0, 15)] {
            assert!((b.eval(u, v).p - b.points[i].truncate()).length() < 1e-12);
        }
    }

    #[test]
    fn malformed_patches_fail_in_words() {
        let net = |n: usize| vec![DVec4::new(0.0, 0.0, 0.0, 1.0); n];
        let k = |v: &[f64]| v.to_vec();
        let cases: [(Result<Patch, String>, &str); 7] = [
            (Patch::bezier([6, 3], net(28), 0), "degree 6 in u: irt traces degrees 1 to 5"),
            (Patch::bezier([3, 3], net(15), 0), "15 control points for a 4 x 4 net"),
            (
                Patch::new([2, 1], [3, 2], [k(&[0., 0., 0., 1., 1.]), k(&[0., 0., 1., 1.])], net(6), 0),
                "5 knots in u: 3 points of degree 2 need 6",
            ),
            (
                Patch::new([2, 1], [3, 2], [k(&[0., 0., 0., 1., 0.5, 1.]), k(&[0., 0., 1., 1.])], net(6), 0),
                "knots in u decrease at 4: 1 then 0.5",
            ),
            (
                Patch::new([2, 1], [2, 2], [k(&[0., 0., 0., 1., 1.]), k(&[0., 0., 1., 1.])], net(4), 0),
                "2 control points in u: degree 2 needs 3",
            ),
            (
                Patch::new([1, 1], [2, 2], [k(&[0., 0., 0., 0.]), k(&[0., 0., 1., 1.])], net(4), 0),
                "knots in u span an empty domain",
            ),
            (Patch::bezier([1, 1], vec![DVec4::new(0.0, 0.0, 0.0, 0.0); 4], 0), "control point 0 ("),
        ];
        for (got, words) in cases {
            let e = got.expect_err(words);
            assert!(e.contains(words), "'{e}' lacks '{words}'");
        }
    }
}
