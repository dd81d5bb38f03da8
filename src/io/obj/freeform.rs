//! OBJ free-form surfaces (the OBJ specification's §"Free-form curve/surface attributes" and
//! "body statements") → [`Patch`]es: `cstype [rat] bezier|bspline`, `deg`, `surf s0 s1 t0 t1
//! v…`, `parm u|v …`, `end`, weights from `v x y z w`. A Bezier surface's `parm` values are its
//! segments' break points (each interior one a knot of multiplicity `deg`; without `parm`, one
//! segment); a B-spline's are its knot vector. Control points are listed u fastest.
//!
//! What irt does not trace is refused in words, at its line, rather than drawn wrong: the basis
//! matrix, Cardinal and Taylor types, and a `surf` range narrower than its knots' domain.
//! Trimming (`trim`, `hole`, `curv2`, `vp`) is not traced yet, so a trimmed surface is refused
//! too: an untrimmed CAD face shows the wrong surface. 3D curves (`curv`), special points and
//! connectivity (`sp`, `con`) have no surface to trace and are skipped with a warning.

use super::{Line, Text};
use crate::io::LoadError;
use crate::scene::patch::{Patch, MAX_DEGREE, MAX_POINTS_A_SIDE};
use glam::DVec3;

/// Every free-form statement, traced or refused here or skipped by the caller.
pub const STATEMENTS: &[&str] = &[
    "vp", "cstype", "deg", "bmat", "step", "curv", "curv2", "surf", "parm", "trim", "hole", "scrv", "sp",
    "end", "con",
];
/// Of those, the ones with no surface, skipped with a warning.
pub const SKIPPED: &[&str] = &["curv", "sp", "con"];

#[derive(Clone, Copy, Debug, PartialEq)]
enum Basis {
    Bezier,
    BSpline,
}

/// A `surf` being read: its line, control points (0-based) and slot, until its `end`.
struct Open {
    line: usize,
    keyword_at: usize,
    basis: Basis,
    rational: bool,
    degree: [usize; 2],
    range: [[f64; 2]; 2],
    points: Vec<u32>,
    parm: [Option<(Vec<f64>, usize)>; 2],
    slot: usize,
}

/// The free-form state of one OBJ file.
#[derive(Default)]
pub struct FreeForm {
    cstype: Option<(Basis, bool)>,
    deg: Option<[usize; 2]>,
    open: Option<Open>,
    /// Each patch with the material slot it was made under.
    pub patches: Vec<(Patch, usize)>,
}

impl FreeForm {
    /// One free-form statement. `positions` and `weights` are the `v` lines so far (a weight
    /// of 1 where a line has none); `slot` is the current material's (given with `surf`).
    pub fn statement(
        &mut self,
        text: &Text,
        line: &Line,
        positions: &[DVec3],
        weights: &[f64],
        slot: Option<usize>,
    ) -> Result<(), LoadError> {
        let words: Vec<&str> = super::args(line.rest).collect();
        let at = |i: usize| words.get(i).copied().unwrap_or(line.keyword);
        match line.keyword {
            "cstype" => {
                let (rational, kind) = match words.as_slice() {
                    ["rat", kind] => (true, *kind),
                    [kind] => (false, *kind),
                    _ => {
                        return Err(
                            text.error(line.keyword, "`cstype` takes [rat] and a type: bezier or bspline")
                        )
                    }
                };
                let basis = match kind {
                    "bezier" => Basis::Bezier,
                    "bspline" => Basis::BSpline,
                    "bmatrix" | "cardinal" | "taylor" => {
                        return Err(text.error(
                            at(words.len() - 1),
                            format!(
                                "`cstype {kind}`: irt traces bezier and bspline surfaces (rational or not)"
                            ),
                        ))
                    }
                    _ => {
                        return Err(text.error(
                            at(words.len() - 1),
                            format!("unknown curve and surface type `{kind}`: expected bezier or bspline"),
                        ))
                    }
                };
                self.cstype = Some((basis, rational));
            }
            "deg" => {
                if words.is_empty() || words.len() > 2 {
                    return Err(text.error(line.keyword, "`deg` takes a degree in u and one in v"));
                }
                let mut d = [0; 2];
                for (k, w) in words.iter().enumerate() {
                    d[k] = match w.parse::<usize>() {
                        Ok(n) if (1..=MAX_DEGREE).contains(&n) => n,
                        _ => {
                            return Err(
                                text.error(w, format!("degree `{w}`: irt traces degrees 1 to {MAX_DEGREE}"))
                            )
                        }
                    };
                }
                if words.len() == 1 {
                    d[1] = d[0];
                }
                self.deg = Some(d);
            }
            "surf" => {
                if let Some(open) = &self.open {
                    return Err(text.error(
                        line.keyword,
                        format!("a `surf` inside the one begun on line {} (each ends with `end`)", open.line),
                    ));
                }
                let Some((basis, rational)) = self.cstype else {
                    return Err(
                        text.error(line.keyword, "`surf` before any `cstype`: say bezier or bspline first")
                    );
                };
                let Some(degree) = self.deg else {
                    return Err(text.error(line.keyword, "`surf` before any `deg`: give the degrees first"));
                };
                if words.len() < 5 {
                    return Err(text.error(line.keyword, "`surf` takes s0 s1 t0 t1 and its control points"));
                }
                let mut range = [[0.0; 2]; 2];
                for k in 0..4 {
                    range[k / 2][k % 2] = text.number(words[k], "a `surf` parameter bound")?;
                }
                let most = MAX_POINTS_A_SIDE * MAX_POINTS_A_SIDE;
                if words.len() - 4 > most {
                    return Err(text.error(words[4 + most], format!("more than {most} control points")));
                }
                let mut points = Vec::with_capacity(words.len() - 4);
                for w in &words[4..] {
                    let v = w.split('/').next().unwrap_or(w);
                    points.push(super::vertex_index(text, v, w, positions.len())?);
                }
                let slot = slot.expect("the caller gives a surf its slot");
                let keyword_at = text.offset(line.keyword);
                self.open = Some(Open {
                    line: line.number,
                    keyword_at,
                    basis,
                    rational,
                    degree,
                    range,
                    points,
                    parm: [None, None],
                    slot,
                });
            }
            "parm" => {
                let Some(open) = &mut self.open else {
                    return Err(text.error(line.keyword, "`parm` outside a `surf` … `end` body"));
                };
                let a = match words.first() {
                    Some(&"u") => 0,
                    Some(&"v") => 1,
                    _ => return Err(text.error(at(0), "`parm` takes u or v, then its values")),
                };
                let mut values = Vec::with_capacity(words.len() - 1);
                for w in &words[1..] {
                    values.push(text.number(w, "a `parm` value")?);
                }
                open.parm[a] = Some((values, text.offset(line.keyword)));
            }
            "end" => {
                let Some(open) = self.open.take() else {
                    return Err(text.error(line.keyword, "`end` without a `surf` before it"));
                };
                let patch = make(text, &open, positions, weights)?;
                self.patches.push((patch, open.slot));
            }
            "trim" | "hole" | "scrv" | "curv2" | "vp" => {
                return Err(text.error(
                    line.keyword,
                    format!(
                        "`{}`: trimmed surfaces are not traced yet (issue #45); drawing this one untrimmed \
                         would show the wrong surface",
                        line.keyword
                    ),
                ))
            }
            "bmat" | "step" => {
                return Err(text.error(
                    line.keyword,
                    format!("`{}` belongs to the basis-matrix types, which irt does not trace", line.keyword),
                ))
            }
            _ => unreachable!("the caller passes free-form statements only"),
        }
        Ok(())
    }

    /// At the end of the file: a `surf` without its `end` is an error.
    pub fn finish(&self, text: &Text) -> Result<(), LoadError> {
        match &self.open {
            Some(open) => Err(LoadError::at(
                text.origin,
                text.src,
                open.keyword_at,
                "this `surf` has no `end`: the file ends inside it",
            )),
            None => Ok(()),
        }
    }
}

/// The patch an `end` closes.
fn make(text: &Text, open: &Open, positions: &[DVec3], weights: &[f64]) -> Result<Patch, LoadError> {
    let here = |message: String| LoadError::at(text.origin, text.src, open.keyword_at, message);
    let mut knots: [Vec<f64>; 2] = [vec![], vec![]];
    let mut counts = [0; 2];
    for a in 0..2 {
        let p = open.degree[a];
        let name = ["u", "v"][a];
        let (values, parm_at) = match &open.parm[a] {
            Some((v, at)) => (v.clone(), Some(*at)),
            None if open.basis == Basis::Bezier => (open.range[a].to_vec(), None),
            None => return Err(here(format!("this B-spline `surf` has no `parm {name}` (its knots)"))),
        };
        let at_parm = |m: String| match parm_at {
            Some(at) => LoadError::at(text.origin, text.src, at, m),
            None => here(m),
        };
        if let Some(i) = values.windows(2).position(|w| w[1] < w[0]) {
            return Err(at_parm(format!(
                "`parm {name}` values decrease at {}: {} then {}",
                i + 1,
                values[i],
                values[i + 1]
            )));
        }
        match open.basis {
            Basis::Bezier => {
                if values.len() < 2 {
                    return Err(at_parm(format!(
                        "`parm {name}` of a Bezier surface needs at least 2 values"
                    )));
                }
                let segments = values.len() - 1;
                counts[a] = p * segments + 1;
                let mut k = vec![values[0]; p + 1];
                for &b in &values[1..segments] {
                    k.extend(std::iter::repeat_n(b, p));
                }
                k.extend(std::iter::repeat_n(values[segments], p + 1));
                knots[a] = k;
            }
            Basis::BSpline => {
                if values.len() < 2 * (p + 1) {
                    return Err(at_parm(format!(
                        "`parm {name}` has {} knots; degree {p} needs at least {}",
                        values.len(),
                        2 * (p + 1)
                    )));
                }
                counts[a] = values.len() - p - 1;
                knots[a] = values;
            }
        }
        if counts[a] > MAX_POINTS_A_SIDE {
            return Err(at_parm(format!(
                "{} control points in {name}; irt's limit is {MAX_POINTS_A_SIDE}",
                counts[a]
            )));
        }
    }
    let want = counts[0] * counts[1];
    if open.points.len() != want {
        return Err(here(format!(
            "this `surf` lists {} control points; degree {} x {} with these `parm` values needs {} x {} = {want}",
            open.points.len(),
            open.degree[0],
            open.degree[1],
            counts[0],
            counts[1]
        )));
    }
    for a in 0..2 {
        let (p, k) = (open.degree[a], &knots[a]);
        let domain = [k[p], k[counts[a]]];
        if open.range[a] != domain {
            return Err(here(format!(
                "this `surf` uses {} to {} in {} of a knot domain {} to {}: irt traces a surface's whole domain",
                open.range[a][0],
                open.range[a][1],
                ["u", "v"][a],
                domain[0],
                domain[1]
            )));
        }
    }
    let points = open
        .points
        .iter()
        .map(|&i| {
            let w = if open.rational { weights.get(i as usize).copied().unwrap_or(1.0) } else { 1.0 };
            positions[i as usize].extend(w)
        })
        .collect();
    Patch::new(open.degree, counts, knots, points, 0).map_err(|why| here(format!("this surface: {why}")))
}

#[cfg(test)]
mod tests {
    use crate::io::obj::parse_model;

    const NET: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0.5 2\n";

    fn fails(src: &str, line: usize, words: &[&str]) {
        let e = parse_model(src.as_bytes(), "t.obj").err().unwrap_or_else(|| panic!("accepted: {src}"));
        assert_eq!(e.line, Some(line), "{e}");
        for w in words {
            assert!(e.message.contains(w), "'{w}' not in: {e}");
        }
    }

    /// A bilinear rational Bezier surface: its weights come from `v x y z w`, the current
    /// material is its, and the line continuation joins its `surf`.
    #[test]
    fn a_rational_bezier_surface_loads() {
        let src = format!(
            "{NET}cstype rat bezier\ndeg 1 1\nsurf 0 1 0 1 1 2 \\\n 3 4\nparm u 0 1\nparm v 0 1\nend\n"
        );
        let m = parse_model(src.as_bytes(), "t.obj").unwrap();
        assert_eq!(m.patches.len(), 1);
        let p = &m.patches[0];
        assert_eq!((p.degree, p.counts), ([1, 1], [2, 2]));
        assert_eq!(p.points[3].w, 2.0);
        assert_eq!(p.points[0].w, 1.0);
    }

    /// Each malformed surface fails in words at its line.
    #[test]
    fn malformed_surfaces_fail_at_their_line() {
        let body = "surf 0 1 0 1 1 2 3 4\nparm u 0 1\nparm v 0 1\nend\n";
        fails(&format!("{NET}deg 1 1\n{body}"), 6, &["cstype"]);
        fails(&format!("{NET}cstype bezier\n{body}"), 6, &["deg"]);
        fails(&format!("{NET}cstype taylor\n"), 5, &["bezier and bspline"]);
        fails(&format!("{NET}cstype bezier\ndeg 6\n"), 6, &["degrees 1 to 5"]);
        fails(&format!("{NET}cstype bezier\ndeg 1 1\nsurf 0 1 0 1 1 2 3 9\n"), 7, &["out of range"]);
        fails(
            &format!("{NET}cstype bezier\ndeg 1 1\nsurf 0 1 0 1 1 2 3\nend\n"),
            7,
            &["3 control points", "2 x 2"],
        );
        fails(
            &format!("{NET}cstype bspline\ndeg 1 1\nsurf 0 1 0 1 1 2 3 4\nparm u 0 0 1 1\nend\n"),
            7,
            &["parm v"],
        );
        fails(
            &format!(
                "{NET}cstype bspline\ndeg 1 1\nsurf 0 1 0 1 1 2 3 4\nparm u 0 1 0 1\nparm v 0 0 1 1\nend\n"
            ),
            8,
            &["decrease"],
        );
        fails(&format!("{NET}cstype bezier\ndeg 1 1\nsurf 0 1 0 1 1 2 3 4\n"), 7, &["no `end`"]);
        fails(&format!("{NET}cstype bezier\ndeg 1 1\nsurf 0 1 0 1 1 2 3 4\ntrim 0 1 1\n"), 8, &["trimmed"]);
        fails(&format!("{NET}end\n"), 5, &["without a `surf`"]);
    }
}
