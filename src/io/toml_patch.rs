//! Spline patches in TOML: `[[patch]]` is one NURBS surface (docs/scene-format.md, "Patches";
//! docs/splines.md). What `irt convert` writes for the patches of an OBJ or STEP file, and what
//! a scene can hold inline:
//!
//! ```toml
//! [[patch]]
//! material = "paint"
//! degree = [3, 3]            # in u and v, 1 to 5 (one number: both)
//! counts = [4, 4]            # control points in u and v
//! points = [[0, 0, 0], [1, 0, 0.5, 0.8], ...]   # u fastest; [x, y, z] or [x, y, z, w]
//! knots_u = [0, 0, 0, 0, 1, 1, 1, 1]  # counts + degree + 1 each; default: clamped and
//! knots_v = [0, 0, 0, 0, 1, 1, 1, 1]  # uniform over [0, 1] (a Bezier patch at counts = degree + 1)
//! trim = [[[0.2, 0.2], [0.8, 0.2], [0.5, 0.8], [0.2, 0.2]]]  # optional: closed loops in (u, v)
//! ```
//!
//! `trim` loops are polygons in the patch's parameter domain, each closed (its last point its
//! first); the part inside an odd number of them is surface (`scene::patch::trim`).

use super::{err, Names, Res, Span};
use crate::scene::patch::{Patch, MAX_DEGREE, MAX_POINTS_A_SIDE};
use crate::scene::Scene;
use ::toml::Spanned;
use glam::{DVec2, DVec4};
use serde::Deserialize;

/// `[[patch]]` tables in one scene, at most (each is at least one Bezier piece).
pub const MAX_PATCHES: usize = 1 << 20;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct PatchDoc {
    material: Spanned<String>,
    degree: Spanned<DegreeDoc>,
    counts: Spanned<[usize; 2]>,
    points: Spanned<Vec<Vec<f64>>>,
    knots_u: Option<Spanned<Vec<f64>>>,
    knots_v: Option<Spanned<Vec<f64>>>,
    trim: Option<Spanned<Vec<Vec<[f64; 2]>>>>,
}

#[derive(Deserialize)]
#[serde(untagged, expecting = "a degree, or [degree in u, degree in v]")]
enum DegreeDoc {
    Both(usize),
    Each([usize; 2]),
}

/// Clamped uniform knots for `n` points of degree `p` over [0, 1].
fn uniform(n: usize, p: usize) -> Vec<f64> {
    let spans = n - p;
    (0..n + p + 1).map(|i| (i.saturating_sub(p).min(spans)) as f64 / spans as f64).collect()
}

/// Adds the `[[patch]]` tables' surfaces to `scene`.
pub(super) fn place(scene: &mut Scene, docs: &[Spanned<PatchDoc>], names: &Names) -> Res<()> {
    if docs.len() > MAX_PATCHES {
        return err(docs[MAX_PATCHES].span(), format!("more than {MAX_PATCHES} [[patch]] tables"));
    }
    for doc in docs {
        let d = doc.get_ref();
        let degree = match *d.degree.get_ref() {
            DegreeDoc::Both(p) => [p, p],
            DegreeDoc::Each(pq) => pq,
        };
        if let Some(&p) = degree.iter().find(|&&p| p == 0 || p > MAX_DEGREE) {
            return err(d.degree.span(), format!("degree {p}: irt traces degrees 1 to {MAX_DEGREE}"));
        }
        let counts = *d.counts.get_ref();
        for a in 0..2 {
            if counts[a] <= degree[a] || counts[a] > MAX_POINTS_A_SIDE {
                return err(
                    d.counts.span(),
                    format!(
                        "{} control points in {}: degree {} needs {} to {MAX_POINTS_A_SIDE}",
                        counts[a],
                        ["u", "v"][a],
                        degree[a],
                        degree[a] + 1
                    ),
                );
            }
        }
        let points = d.points.get_ref();
        if points.len() != counts[0] * counts[1] {
            return err(
                d.points.span(),
                format!(
                    "{} points for {} x {} control points (u fastest)",
                    points.len(),
                    counts[0],
                    counts[1]
                ),
            );
        }
        let mut net = Vec::with_capacity(points.len());
        for (i, q) in points.iter().enumerate() {
            match q.as_slice() {
                [x, y, z] => net.push(DVec4::new(*x, *y, *z, 1.0)),
                [x, y, z, w] => net.push(DVec4::new(*x, *y, *z, *w)),
                _ => {
                    return err(
                        d.points.span(),
                        format!("point {i} has {} numbers: [x, y, z] or [x, y, z, w]", q.len()),
                    )
                }
            }
        }
        let knots = |k: &Option<Spanned<Vec<f64>>>, a: usize| {
            k.as_ref().map_or_else(|| uniform(counts[a], degree[a]), |k| k.get_ref().clone())
        };
        let material = names.resolve(&d.material)?;
        let patch = Patch::new(degree, counts, [knots(&d.knots_u, 0), knots(&d.knots_v, 1)], net, material);
        // Each check names its part: the knots' at the knots, the rest at the table.
        let at = |why: &str| -> Span {
            let knot = |k: &Option<Spanned<Vec<f64>>>| k.as_ref().map(|k| k.span());
            match (why.contains("knot"), why.contains(" in u"), why.contains(" in v")) {
                (true, true, _) => knot(&d.knots_u).unwrap_or(doc.span()),
                (true, _, true) => knot(&d.knots_v).unwrap_or(doc.span()),
                _ if why.contains("control point") => d.points.span(),
                _ => doc.span(),
            }
        };
        let mut patch = patch.or_else(|why| err(at(&why), format!("patch: {why}")))?;
        if let Some(trim) = &d.trim {
            patch.trim =
                trim.get_ref().iter().map(|l| l.iter().map(|&[u, v]| DVec2::new(u, v)).collect()).collect();
            if let Err(why) = crate::scene::patch::trim::check(&patch.trim, patch.domain()) {
                return err(trim.span(), format!("patch: {why}"));
            }
        }
        scene.patches.push(patch);
    }
    Ok(())
}

/// A `[[patch]]` table for `p`, every number as it is (`{:?}`: the shortest digits that read
/// back the same), so that a converted scene traces the same surface.
pub fn write(out: &mut String, p: &Patch, material: &str) {
    use std::fmt::Write as _;
    let q = toml::Value::String(material.into()).to_string();
    let list = |v: &[f64]| v.iter().map(|x| format!("{x:?}")).collect::<Vec<_>>().join(", ");
    let _ = write!(
        out,
        "\n[[patch]]\nmaterial = {q}\ndegree = [{}, {}]\ncounts = [{}, {}]\nknots_u = [{}]\nknots_v = [{}]\npoints = [\n",
        p.degree[0],
        p.degree[1],
        p.counts[0],
        p.counts[1],
        list(&p.knots[0]),
        list(&p.knots[1])
    );
    for c in &p.points {
        let xyz = format!("{:?}, {:?}, {:?}", c.x, c.y, c.z);
        let _ = if c.w == 1.0 { writeln!(out, "  [{xyz}],") } else { writeln!(out, "  [{xyz}, {:?}],", c.w) };
    }
    out.push_str("]\n");
    if !p.trim.is_empty() {
        out.push_str("trim = [\n");
        for l in &p.trim {
            let pts: Vec<String> = l.iter().map(|q| format!("[{:?}, {:?}]", q.x, q.y)).collect();
            let _ = writeln!(out, "  [{}],", pts.join(", "));
        }
        out.push_str("]\n");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_knots_are_clamped() {
        assert_eq!(uniform(4, 3), vec![0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0]);
        assert_eq!(uniform(5, 2), vec![0.0, 0.0, 0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0, 1.0, 1.0]);
    }
}
