//! OBJ free-form surfaces (the OBJ specification's §"Free-form curve/surface attributes" and
//! "body statements") → [`Patch`]es: `cstype [rat] bezier|bspline`, `deg`, `surf s0 s1 t0 t1
//! v…`, `parm u|v …`, `end`, weights from `v x y z w`. A Bezier surface's `parm` values are its
//! segments' break points (each interior one a knot of multiplicity `deg`; without `parm`, one
//! segment); a B-spline's are its knot vector. Control points are listed u fastest.
//!
//! Trimming: `vp u v [w]` parameter vertices, `curv2 vp…` curves in a surface's parameter
//! space (the current `cstype` and `deg`, knots from their `parm u`, then `end`), and in a
//! `surf` body `trim`/`hole u0 u1 curv2 [u0 u1 curv2…]`: one loop each, of the curves' parts
//! joined end to end (`scene::patch::trim` keeps it as a polygon). A loop whose parts do not
//! join, or that does not close, is an error at its line; a `curv2` is defined before the
//! `surf` that uses it.
//!
//! What irt does not trace is refused in words, at its line, rather than drawn wrong: the basis
//! matrix, Cardinal and Taylor types, and a `surf` range narrower than its knots' domain. 3D
//! curves (`curv`), special curves and points (`scrv`, `sp`) and connectivity (`con`) have no
//! surface to trace and are skipped with a warning.

use super::{Line, Text};
use crate::io::LoadError;
use crate::scene::patch::trim::{self, Curve};
use crate::scene::patch::{Patch, MAX_DEGREE, MAX_POINTS_A_SIDE};
use glam::{DVec2, DVec3};

/// Every free-form statement, traced or refused here or skipped by the caller.
pub const STATEMENTS: &[&str] = &[
    "vp", "cstype", "deg", "bmat", "step", "curv", "curv2", "surf", "parm", "trim", "hole", "scrv", "sp",
    "end", "con",
];
/// Of those, the ones with no surface, skipped with a warning.
pub const SKIPPED: &[&str] = &["curv", "scrv", "sp", "con"];

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
    loops: Vec<TrimStatement>,
}

/// A `trim` or `hole` statement: each part's (u0, u1, curve index) and where it stands.
struct TrimStatement {
    parts: Vec<(f64, f64, usize)>,
    hole: bool,
    at: usize,
}

/// A `curv2` being read, until its `end`.
struct OpenCurve {
    keyword_at: usize,
    basis: Basis,
    rational: bool,
    degree: usize,
    points: Vec<u32>,
    parm: Option<(Vec<f64>, usize)>,
}

/// The free-form state of one OBJ file.
#[derive(Default)]
pub struct FreeForm {
    cstype: Option<(Basis, bool)>,
    deg: Option<[usize; 2]>,
    open: Option<Open>,
    open_curve: Option<OpenCurve>,
    /// `vp` lines: (u, v, w).
    params: Vec<DVec3>,
    /// `curv2` curves so far.
    curves: Vec<Curve>,
    /// Each patch with the material slot it was made under.
    pub patches: Vec<(Patch, usize)>,
}

impl FreeForm {
    /// What a `surf` or `curv2` statement (`keyword`) starts from: the basis, whether it is
    /// rational, and the degrees; an error if a `surf` is open (`hint` says what to do).
    fn begin(&self, text: &Text, keyword: &str, hint: &str) -> Result<(Basis, bool, [usize; 2]), LoadError> {
        if let Some(open) = &self.open {
            return Err(text.error(
                keyword,
                format!("a `{keyword}` inside the `surf` begun on line {} ({hint})", open.line),
            ));
        }
        let Some((basis, rational)) = self.cstype else {
            return Err(
                text.error(keyword, format!("`{keyword}` before any `cstype`: say bezier or bspline first"))
            );
        };
        let Some(degree) = self.deg else {
            return Err(text.error(keyword, format!("`{keyword}` before any `deg`: give the degrees first")));
        };
        Ok((basis, rational, degree))
    }

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
            "surf" | "curv2" if self.open_curve.is_some() => {
                return Err(text.error(line.keyword, "inside a `curv2` (each ends with `end`)"));
            }
            "vp" => {
                let n = text.numbers(line, "u, and v and an optional weight w", 2, 3)?;
                self.params.push(DVec3::new(n[0], n[1], n.get(2).copied().unwrap_or(1.0)));
            }
            "curv2" => {
                let (basis, rational, degree) = self.begin(text, line.keyword, "define it before")?;
                if words.len() < 2 {
                    return Err(text.error(line.keyword, "`curv2` takes its control points (`vp` indices)"));
                }
                let mut points = Vec::with_capacity(words.len());
                for w in &words {
                    points.push(super::index_in(text, w, w, "parameter vertex", "`vp`", self.params.len())?);
                }
                let keyword_at = text.offset(line.keyword);
                self.open_curve =
                    Some(OpenCurve { keyword_at, basis, rational, degree: degree[0], points, parm: None });
            }
            "trim" | "hole" => {
                let Some(open) = &mut self.open else {
                    return Err(
                        text.error(line.keyword, format!("`{}` outside a `surf` … `end` body", line.keyword))
                    );
                };
                if words.is_empty() || !words.len().is_multiple_of(3) {
                    return Err(text.error(
                        line.keyword,
                        format!("`{}` takes u0 u1 curv2 for each part of its loop", line.keyword),
                    ));
                }
                let mut parts = Vec::with_capacity(words.len() / 3);
                for w in words.chunks(3) {
                    let u0 = text.number(w[0], "a trim curve's start parameter")?;
                    let u1 = text.number(w[1], "a trim curve's end parameter")?;
                    let k = super::index_in(text, w[2], w[2], "curv2", "`curv2` … `end`", self.curves.len())?;
                    parts.push((u0, u1, k as usize));
                }
                open.loops.push(TrimStatement {
                    parts,
                    hole: line.keyword == "hole",
                    at: text.offset(line.keyword),
                });
            }
            "surf" => {
                let (basis, rational, degree) = self.begin(text, line.keyword, "each ends with `end`")?;
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
                    loops: vec![],
                });
            }
            "parm" if self.open_curve.is_some() => {
                let open = self.open_curve.as_mut().expect("a curv2 is open");
                if words.first() != Some(&"u") {
                    return Err(text.error(at(0), "a `curv2`'s `parm` is `parm u` and its values"));
                }
                let mut values = Vec::with_capacity(words.len() - 1);
                for w in &words[1..] {
                    values.push(text.number(w, "a `parm` value")?);
                }
                open.parm = Some((values, text.offset(line.keyword)));
            }
            "end" if self.open_curve.is_some() => {
                let open = self.open_curve.take().expect("a curv2 is open");
                let here = |m: String| LoadError::at(text.origin, text.src, open.keyword_at, m);
                let (knots, count) =
                    knots_of(text, open.basis, open.degree, "u", &open.parm, [0.0, 1.0], &here)?;
                if open.points.len() != count {
                    return Err(here(format!(
                        "this `curv2` lists {} control points; degree {} with these `parm` values needs {count}",
                        open.points.len(),
                        open.degree
                    )));
                }
                let points = open
                    .points
                    .iter()
                    .map(|&i| {
                        let q = self.params[i as usize];
                        DVec3::new(q.x, q.y, if open.rational { q.z } else { 1.0 })
                    })
                    .collect();
                let curve = Curve::new(open.degree, knots, points)
                    .map_err(|why| here(format!("this curve: {why}")))?;
                self.curves.push(curve);
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
                let mut patch = make(text, &open, positions, weights)?;
                patch.trim = loops(text, &open, &self.curves, patch.domain())?;
                self.patches.push((patch, open.slot));
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

    /// At the end of the file: a `surf` or `curv2` without its `end` is an error.
    pub fn finish(&self, text: &Text) -> Result<(), LoadError> {
        if let Some(open) = &self.open_curve {
            return Err(LoadError::at(
                text.origin,
                text.src,
                open.keyword_at,
                "this `curv2` has no `end`: the file ends inside it",
            ));
        }
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

/// The knots (and control point count) of a Bezier or B-spline of degree `p` in parameter
/// `name` from its `parm` values (a Bezier's break points, `range` without them; a B-spline's
/// knots), errors at the `parm` line where there is one, else by `here`.
fn knots_of(
    text: &Text,
    basis: Basis,
    p: usize,
    name: &str,
    parm: &Option<(Vec<f64>, usize)>,
    range: [f64; 2],
    here: &dyn Fn(String) -> LoadError,
) -> Result<(Vec<f64>, usize), LoadError> {
    let (values, parm_at) = match parm {
        Some((v, at)) => (v.clone(), Some(*at)),
        None if basis == Basis::Bezier => (range.to_vec(), None),
        None => return Err(here(format!("this B-spline has no `parm {name}` (its knots)"))),
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
    match basis {
        Basis::Bezier => {
            if values.len() < 2 {
                return Err(at_parm(format!("`parm {name}` of a Bezier needs at least 2 values")));
            }
            let segments = values.len() - 1;
            let mut k = vec![values[0]; p + 1];
            for &b in &values[1..segments] {
                k.extend(std::iter::repeat_n(b, p));
            }
            k.extend(std::iter::repeat_n(values[segments], p + 1));
            Ok((k, p * segments + 1))
        }
        Basis::BSpline => {
            if values.len() < 2 * (p + 1) {
                return Err(at_parm(format!(
                    "`parm {name}` has {} knots; degree {p} needs at least {}",
                    values.len(),
                    2 * (p + 1)
                )));
            }
            let n = values.len() - p - 1;
            Ok((values, n))
        }
    }
}

/// A surface's `trim` and `hole` loops as polygons in its `domain`: each part flattened
/// (`trim::TOLERANCE` of the domain), the parts joined end to end, the loop closed; holes with
/// no outer loop get the domain's boundary as theirs. Errors at the loop's statement.
fn loops(
    text: &Text,
    open: &Open,
    curves: &[Curve],
    domain: [[f64; 2]; 2],
) -> Result<Vec<Vec<DVec2>>, LoadError> {
    let size = (domain[0][1] - domain[0][0]).max(domain[1][1] - domain[1][0]);
    let join = 1e-6 * size;
    let mut out: Vec<Vec<DVec2>> = vec![];
    let mut edges = 0;
    for TrimStatement { parts, at, .. } in &open.loops {
        let here = |m: String| LoadError::at(text.origin, text.src, *at, m);
        let mut l: Vec<DVec2> = vec![];
        for (k, &(u0, u1, c)) in parts.iter().enumerate() {
            let budget = trim::MAX_EDGES.saturating_sub(edges + l.len()) + 1;
            let piece = curves[c]
                .flatten([u0, u1], trim::TOLERANCE * size, budget)
                .map_err(|why| here(format!("part {} (curv2 {}): {why}", k + 1, c + 1)))?;
            if let Some(&last) = l.last() {
                if (last - piece[0]).length() > join {
                    return Err(here(format!(
                        "an open trim loop: part {k} ends at ({}, {}) but part {} (curv2 {}) starts at ({}, {})",
                        last.x,
                        last.y,
                        k + 1,
                        c + 1,
                        piece[0].x,
                        piece[0].y
                    )));
                }
                l.pop();
            }
            l.extend(piece);
        }
        let (first, last) = (l[0], l[l.len() - 1]);
        if (first - last).length() > join {
            return Err(here(format!(
                "an open trim loop: it starts at ({}, {}) and ends at ({}, {})",
                first.x, first.y, last.x, last.y
            )));
        }
        *l.last_mut().expect("a loop has points") = first;
        edges += l.len() - 1;
        out.push(l);
    }
    if !out.is_empty() && open.loops.iter().all(|l| l.hole) {
        out.push(trim::boundary(domain));
    }
    trim::check(&out, domain).map_err(|why| {
        LoadError::at(text.origin, text.src, open.keyword_at, format!("this surface: {why}"))
    })?;
    Ok(out)
}

/// The patch an `end` closes.
fn make(text: &Text, open: &Open, positions: &[DVec3], weights: &[f64]) -> Result<Patch, LoadError> {
    let here = |message: String| LoadError::at(text.origin, text.src, open.keyword_at, message);
    let mut knots: [Vec<f64>; 2] = [vec![], vec![]];
    let mut counts = [0; 2];
    for a in 0..2 {
        let name = ["u", "v"][a];
        let parm_at = open.parm[a].as_ref().map(|p| p.1);
        let at_parm = |m: String| match parm_at {
            Some(at) => LoadError::at(text.origin, text.src, at, m),
            None => here(m),
        };
        (knots[a], counts[a]) =
            knots_of(text, open.basis, open.degree[a], name, &open.parm[a], open.range[a], &here)?;
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

    /// A unit square trimmed to an inner square by four line curves, with a circular hole (a
    /// rational quadratic `curv2`): the loops are polygons in (u, v) that keep what they bound.
    const TRIMMED: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n\
        vp 0.1 0.1\nvp 0.9 0.1\nvp 0.9 0.9\nvp 0.1 0.9\n\
        vp 0.75 0.5 1\nvp 0.75 0.75 0.7071067811865476\nvp 0.5 0.75 1\nvp 0.25 0.75 0.7071067811865476\n\
        vp 0.25 0.5 1\nvp 0.25 0.25 0.7071067811865476\nvp 0.5 0.25 1\nvp 0.75 0.25 0.7071067811865476\n\
        cstype bspline\ndeg 1\n\
        curv2 1 2\nparm u 0 0 1 1\nend\ncurv2 2 3\nparm u 0 0 1 1\nend\n\
        curv2 3 4\nparm u 0 0 1 1\nend\ncurv2 4 1\nparm u 0 0 1 1\nend\n\
        cstype rat bspline\ndeg 2\n\
        curv2 5 6 7 8 9 10 11 12 5\nparm u 0 0 0 0.25 0.25 0.5 0.5 0.75 0.75 1 1 1\nend\n\
        cstype bezier\ndeg 1 1\nsurf 0 1 0 1 1 2 3 4\n\
        trim 0 1 1 0 1 2 0 1 3 0 1 4\nhole 0 1 5\nend\n";

    #[test]
    fn a_trimmed_surface_with_a_hole_loads_as_loops() {
        let m = parse_model(TRIMMED.as_bytes(), "t.obj").unwrap();
        let p = &m.patches[0];
        assert_eq!(p.trim.len(), 2);
        // The outer loop: the four corners, closed.
        assert_eq!(p.trim[0].len(), 5);
        assert!(p.trim[1].len() > 50, "{} points on the circle", p.trim[1].len());
        for (u, v, kept) in
            [(0.5, 0.5, false), (0.5, 0.2, true), (0.15, 0.85, true), (0.05, 0.5, false), (0.8, 0.8, true)]
        {
            assert_eq!(p.kept(u, v), kept, "({u}, {v})");
        }
        // A hole alone: the surface's boundary is its outer loop.
        let hole_only = TRIMMED.replace("trim 0 1 1 0 1 2 0 1 3 0 1 4\n", "");
        let m = parse_model(hole_only.as_bytes(), "t.obj").unwrap();
        assert!(m.patches[0].kept(0.05, 0.5) && !m.patches[0].kept(0.5, 0.5));
    }

    #[test]
    fn malformed_trims_fail_at_their_line() {
        // Parts out of order: 1 then 3 do not join.
        let bad = TRIMMED.replace("trim 0 1 1 0 1 2 0 1 3 0 1 4", "trim 0 1 1 0 1 3 0 1 2 0 1 4");
        let line = TRIMMED.lines().position(|l| l.starts_with("trim")).unwrap() + 1;
        fails(&bad, line, &["open trim loop", "curv2 3"]);
        // Three sides only: the loop does not close.
        let bad = TRIMMED.replace("trim 0 1 1 0 1 2 0 1 3 0 1 4", "trim 0 1 1 0 1 2 0 1 3");
        fails(&bad, line, &["open trim loop", "starts at"]);
        fails(&TRIMMED.replace("hole 0 1 5", "hole 0 1 9"), line + 1, &["curv2 index 9", "out of range"]);
        fails(&TRIMMED.replace("hole 0 1 5", "hole 0 2 5"), line + 1, &["not a part of the curve's domain"]);
        fails(&TRIMMED.replace("hole 0 1 5", "hole 0 1"), line + 1, &["u0 u1 curv2"]);
        let curve = TRIMMED.lines().position(|l| l.starts_with("curv2")).unwrap() + 1;
        fails(&TRIMMED.replace("curv2 1 2\n", "curv2 1 99\n"), curve, &["parameter vertex index 99"]);
        fails(
            &TRIMMED.replace("curv2 1 2\nparm u 0 0 1 1\n", "curv2 1 2\nparm u 0 0 1\n"),
            curve + 1,
            &["needs at least 4"],
        );
        let cut = TRIMMED.find("curv2 2 3").unwrap();
        fails(&TRIMMED[..cut].replace("end\n", ""), curve, &["`curv2` has no `end`"]);
        fails("vp 0.5\n", 1, &["u, and v"]);
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
        fails(
            &format!("{NET}cstype bezier\ndeg 1 1\nsurf 0 1 0 1 1 2 3 4\ntrim 0 1 1\n"),
            8,
            &["curv2 index 1", "out of range"],
        );
        fails(&format!("{NET}end\n"), 5, &["without a `surf`"]);
    }
}
