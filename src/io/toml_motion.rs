//! Motion in TOML: `[[sphere.motion]]` (also cones, meshes, lights) is one stage of an object's
//! motion chain (`scene::motion`), outermost first; docs/scene-format.md "Motion" has the keys.
//! A property is keyed, `{ times = [...], values = [...], interpolation = "linear" }`, or held
//! at one value; `pivot` turns and scales about a point; `matrix` is a fixed transform.
//!
//! A property's channel goes through serde as one untagged value, which keeps no positions
//! inside it: errors in a channel are reported at the property, naming the key.

use super::{err, floats, mode, numbers, Numbers, Res, Span};
use crate::scene::{euler_degrees, Channel, Interpolation, Motion, Rotation, Stage, Trs};
use ::toml::Spanned;
use glam::{DAffine3, DMat3, DQuat, DVec3};
use serde::Deserialize;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct StageDoc {
    pivot: Option<Numbers>,
    matrix: Option<Spanned<Vec<Numbers>>>,
    translate: Option<Spanned<PropertyDoc>>,
    rotate: Option<Spanned<PropertyDoc>>,
    quaternion: Option<Spanned<PropertyDoc>>,
    scale: Option<Spanned<PropertyDoc>>,
}

#[derive(Deserialize)]
#[serde(
    untagged,
    expecting = "a value, or keys: { times = [...], values = [...], interpolation = \"step\", \"linear\" or \"cubic\" }"
)]
enum PropertyDoc {
    Number(f64),
    Value(Vec<f64>),
    Keys(ChannelDoc),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ChannelDoc {
    times: Vec<f64>,
    values: Vec<ValueDoc>,
    interpolation: Option<String>,
    /// Cubic only: the tangent into and out of each key (per second); Catmull–Rom without.
    in_tangents: Option<Vec<ValueDoc>>,
    out_tangents: Option<Vec<ValueDoc>>,
}

#[derive(Clone, Deserialize)]
#[serde(untagged)]
enum ValueDoc {
    Number(f64),
    List(Vec<f64>),
}

/// The motion of one object from its `motion` stages. `round`: a sphere or cone, which only
/// scales alike on every axis.
pub(super) fn motion(stages: &[Spanned<StageDoc>], round: bool) -> Res<Motion> {
    let mut out = Vec::new();
    for s in stages {
        stage(s.get_ref(), &s.span(), round, &mut out)?;
    }
    Ok(Motion { stages: out })
}

fn stage(d: &StageDoc, table: &Span, round: bool, out: &mut Vec<Stage>) -> Res<()> {
    if let Some(m) = &d.matrix {
        let others =
            [span(&d.pivot), span(&d.translate), span(&d.rotate), span(&d.quaternion), span(&d.scale)];
        if let Some(s) = others.into_iter().flatten().next() {
            return err(
                s,
                "a stage with `matrix` is fixed: it takes no other key (give another [[...motion]])",
            );
        }
        out.push(Stage::Fixed(matrix(m, round)?));
        return Ok(());
    }
    if let (Some(_), Some(q)) = (&d.rotate, &d.quaternion) {
        return err(q.span(), "give `rotate` (degrees) or `quaternion`, not both");
    }
    let mut rest = Trs::default();
    let translation = match &d.translate {
        Some(p) => property::<3, _>(p, "translate", &mut rest.translation, DVec3::from_array)?,
        None => None,
    };
    let mut euler = DVec3::ZERO;
    let rotation = match (&d.rotate, &d.quaternion) {
        (Some(p), _) => {
            let c = property::<3, _>(p, "rotate", &mut euler, DVec3::from_array)?;
            rest.rotation = euler_degrees(euler);
            c.map(Rotation::EulerDegrees)
        }
        (None, Some(p)) => {
            let c = property::<4, _>(p, "quaternion", &mut rest.rotation, DQuat::from_array)?;
            let zero = rest.rotation.length_squared() == 0.0
                || c.as_ref().is_some_and(|c| c.values.iter().any(|q| q.length_squared() == 0.0));
            if zero {
                return err(p.span(), "`quaternion` must not be [0, 0, 0, 0]: it names no rotation");
            }
            c.map(Rotation::Quaternion)
        }
        (None, None) => None,
    };
    let scale = match &d.scale {
        Some(p) => {
            let c = property::<3, _>(p, "scale", &mut rest.scale, DVec3::from_array)?;
            let values = c.as_ref().map_or(vec![rest.scale], |c| c.key_values().copied().collect());
            for v in values {
                if v.min_element() <= 0.0 {
                    return err(
                        p.span(),
                        "`scale` must be greater than 0 (mirroring turns objects inside out)",
                    );
                }
                if round && (v.x != v.y || v.y != v.z) {
                    return err(
                        p.span(),
                        "spheres and cones scale alike on every axis: give one number per key",
                    );
                }
            }
            c
        }
        None => None,
    };
    if translation.is_none() && rotation.is_none() && scale.is_none() && rest == Trs::default() {
        return err(
            table.clone(),
            "a motion stage needs `translate`, `rotate`, `quaternion`, `scale` or `matrix`",
        );
    }
    let keyed = Stage::keyed(translation, rotation, scale, rest);
    match &d.pivot {
        Some(p) => {
            let p = DVec3::from_array(numbers::<3>(p, "pivot")?);
            out.extend([
                Stage::Fixed(DAffine3::from_translation(p)),
                keyed,
                Stage::Fixed(DAffine3::from_translation(-p)),
            ]);
        }
        None => out.push(keyed),
    }
    Ok(())
}

fn span<T>(v: &Option<Spanned<T>>) -> Option<Span> {
    v.as_ref().map(Spanned::span)
}

/// A 3x4 `matrix`: three rows `[m0, m1, m2, translation]`.
fn matrix(m: &Spanned<Vec<Numbers>>, round: bool) -> Res<DAffine3> {
    if m.get_ref().len() != 3 {
        return err(
            m.span(),
            format!("`matrix` needs 3 rows of 4 numbers, found {} rows", m.get_ref().len()),
        );
    }
    let rows: Vec<[f64; 4]> = m.get_ref().iter().map(|r| numbers::<4>(r, "matrix")).collect::<Res<_>>()?;
    let linear = DMat3::from_cols_array_2d(&[
        [rows[0][0], rows[1][0], rows[2][0]],
        [rows[0][1], rows[1][1], rows[2][1]],
        [rows[0][2], rows[1][2], rows[2][2]],
    ]);
    let det = linear.determinant();
    if !(det.is_finite() && det.abs() > 1e-300) {
        return err(m.span(), "`matrix` is singular: it flattens the object");
    }
    if round {
        let k = [linear.x_axis, linear.y_axis, linear.z_axis].map(|a| a.length());
        let (lo, hi) = (k[0].min(k[1]).min(k[2]), k[0].max(k[1]).max(k[2]));
        let ortho = linear.x_axis.dot(linear.y_axis).abs()
            + linear.y_axis.dot(linear.z_axis).abs()
            + linear.z_axis.dot(linear.x_axis).abs();
        if hi - lo > 1e-9 * hi || ortho > 1e-9 * hi * hi {
            return err(
                m.span(),
                "a sphere's or cone's `matrix` may only turn, move and scale alike on every axis",
            );
        }
    }
    Ok(DAffine3 { matrix3: linear, translation: DVec3::new(rows[0][3], rows[1][3], rows[2][3]) })
}

/// A property: a held value (written to `rest`) or a channel of keys (returned). `N` numbers a
/// value; a single number is every component (a uniform `scale`).
fn property<const N: usize, T: crate::scene::Keyable>(
    p: &Spanned<PropertyDoc>,
    key: &str,
    rest: &mut T,
    make: impl Fn([f64; N]) -> T,
) -> Res<Option<Channel<T>>> {
    let at = p.span();
    let value = |v: &ValueDoc, what: &str| -> Res<T> {
        let list = match v {
            ValueDoc::Number(x) if N == 3 && key == "scale" => vec![*x; 3],
            ValueDoc::Number(x) => vec![*x],
            ValueDoc::List(l) => l.clone(),
        };
        floats::<N>(&list, at.clone(), what).map(&make)
    };
    let c = match p.get_ref() {
        PropertyDoc::Number(x) => {
            *rest = value(&ValueDoc::Number(*x), key)?;
            return Ok(None);
        }
        PropertyDoc::Value(l) => {
            *rest = value(&ValueDoc::List(l.clone()), key)?;
            return Ok(None);
        }
        PropertyDoc::Keys(c) => c,
    };
    let interpolation = match &c.interpolation {
        Some(word) => mode(word, &Interpolation::NAMES, &format!("{key}.interpolation"), at.clone())?,
        None => Interpolation::Linear,
    };
    if c.times.len() != c.values.len() {
        return err(
            at,
            format!("`{key}` has {} times but {} values: one value per key", c.times.len(), c.values.len()),
        );
    }
    let values: Vec<T> = c.values.iter().map(|v| value(v, &format!("{key}.values"))).collect::<Res<_>>()?;
    let channel = match (interpolation, &c.in_tangents, &c.out_tangents) {
        (Interpolation::CubicSpline, None, None) => Channel::catmull_rom(c.times.clone(), &values),
        (Interpolation::CubicSpline, Some(i), Some(o)) => {
            if i.len() != values.len() || o.len() != values.len() {
                return err(
                    at,
                    format!("`{key}` needs one in- and one out-tangent per key ({})", values.len()),
                );
            }
            let mut v = Vec::with_capacity(3 * values.len());
            for k in 0..values.len() {
                v.extend([
                    value(&i[k], &format!("{key}.in_tangents"))?,
                    values[k],
                    value(&o[k], &format!("{key}.out_tangents"))?,
                ]);
            }
            Channel { interpolation, times: c.times.clone(), values: v }
        }
        (Interpolation::CubicSpline, _, _) => {
            return err(at, format!("`{key}` gives `in_tangents` or `out_tangents`: give both, or neither"))
        }
        (_, None, None) => Channel { interpolation, times: c.times.clone(), values },
        _ => return err(at, format!("`{key}`: tangents apply only to \"cubic\" interpolation")),
    };
    channel.validate(&format!("`{key}`")).map_err(|e| super::located(at, e.0))?;
    Ok(Some(channel))
}
