//! PLY files of points alone — a `vertex` element and no `face` — as particles: each point a
//! sphere, coloured by one of its fields through a colour map (docs/large-models.md,
//! "Particles"). What a simulation writes: `x y z`, perhaps a `radius`, and scalar fields.
//!
//! The body is read by the same cursors as meshes (every encoding, the same messages and
//! positions). A particle's colour is one of [`MAP_LEVELS`] materials, so a sphere needs no
//! record beyond its centre, radius and material index.

use super::{instances, skip, Body, Header, Kind, Slot, VALUES};
use crate::io::stage::Model;
use crate::io::toml::DEFAULT_DIFFUSE_COLOR;
use crate::io::{LoadError, MAX_PARTICLES};
use crate::scene::colour_map::{level, MAP_LEVELS};
use crate::scene::particles::{auto_radius, Legend, ParticleStyle, Particles, Radius};
use crate::scene::{Material, MaterialKind, Sphere};
use glam::DVec3;

/// Value slots of a point: its position, its radius and the field it is coloured by.
const RADIUS: usize = 3;
const FIELD: usize = 4;
const _: () = assert!(FIELD < VALUES);

/// The property a radius is read from when the style does not name one.
const RADIUS_NAMES: [&str; 2] = ["radius", "r"];

/// Reads the points of a PLY file whose header is `h` as spheres with their materials.
pub(super) fn read<B: Body>(h: &Header, body: &mut B, style: &ParticleStyle) -> Result<Model, LoadError> {
    let vertex = h.elements.iter().position(|e| e.name == "vertex").expect("checked by the caller");
    let e = &h.elements[vertex];
    if e.count > MAX_PARTICLES as u64 {
        return Err(
            h.error(e.count_at, format!("{} points; irt's limit is {MAX_PARTICLES} particles", e.count))
        );
    }
    let mut plan = vec![Slot::Skip; e.properties.len()];
    let scalar = |name: &str, role: &str| -> Result<Option<usize>, LoadError> {
        match e.property(&[name]) {
            None => Ok(None),
            Some((_, p)) if matches!(p.kind, Kind::List { .. }) => {
                Err(h.error(p.at, format!("vertex property `{name}` is a list; {role} is one number")))
            }
            Some((i, _)) => Ok(Some(i)),
        }
    };
    for (k, name) in ["x", "y", "z"].into_iter().enumerate() {
        let i = scalar(name, "a coordinate")?.ok_or_else(|| {
            h.error(e.at, format!("element vertex has no property `{name}`; irt needs x, y and z"))
        })?;
        plan[i] = Slot::Value { k, scale: 1.0 };
    }
    let fields: Vec<&str> = e
        .properties
        .iter()
        .filter(|p| matches!(p.kind, Kind::Scalar(_)) && !["x", "y", "z"].contains(&p.name.as_str()))
        .map(|p| p.name.as_str())
        .collect();
    let missing = |what: &str, name: &str| {
        let known = if fields.is_empty() { "none".to_string() } else { fields.join(", ") };
        h.error(e.at, format!("the points have no {what} `{name}`; their fields are {known}"))
    };
    let radius_property = match &style.radius {
        Radius::Field(name) => {
            Some((scalar(name, "a radius")?.ok_or_else(|| missing("radius field", name))?, name.clone()))
        }
        Radius::Auto => {
            let named = RADIUS_NAMES.iter().find(|n| fields.contains(n));
            named.map(|n| (e.property(&[n]).expect("listed").0, n.to_string()))
        }
        Radius::Value(_) => None,
    };
    if let Some((i, _)) = radius_property {
        plan[i] = Slot::Value { k: RADIUS, scale: 1.0 };
    }
    let field = match &style.field {
        Some(name) => Some((scalar(name, "a field")?.ok_or_else(|| missing("field", name))?, name.clone())),
        None => fields
            .iter()
            .find(|n| radius_property.as_ref().is_none_or(|(_, r)| r != *n))
            .map(|n| (e.property(&[n]).expect("listed").0, n.to_string())),
    };
    if let Some((i, name)) = &field {
        if plan[*i] != Slot::Skip {
            return Err(h.error(e.at, format!("`{name}` is the radius; colour by another field")));
        }
        plan[*i] = Slot::Value { k: FIELD, scale: 1.0 };
    }

    let left = (body.len() - body.position().min(body.len())) as u64;
    let n = e.count.min(left / e.min_size(h.encoding).max(1)) as usize;
    let mut spheres = Vec::with_capacity(n);
    let mut values = Vec::with_capacity(if field.is_some() { n } else { 0 });
    let fixed = match style.radius {
        Radius::Value(r) => r,
        _ => 0.0,
    };
    for (i, other) in h.elements.iter().enumerate() {
        if i != vertex {
            skip(body, other)?;
            continue;
        }
        instances(body, e, &plan, 0, |body, index, v, _| {
            let radius = if radius_property.is_some() { v[RADIUS] } else { fixed };
            if radius_property.is_some() && radius <= 0.0 {
                return Err(body.error(format!("the radius of point {index} is {radius}; a radius is > 0")));
            }
            spheres.push(Sphere { center: DVec3::new(v[0], v[1], v[2]), radius, material: 0 });
            if field.is_some() {
                values.push(v[FIELD]);
            }
            Ok(())
        })?;
    }
    body.finish()?;
    if spheres.is_empty() {
        return Err(h.error(e.count_at, "the file holds no points"));
    }
    if matches!(style.radius, Radius::Auto) && radius_property.is_none() {
        let (lo, hi) = spheres
            .iter()
            .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), s| (lo.min(s.center), hi.max(s.center)));
        let r = auto_radius(lo, hi, spheres.len());
        spheres.iter_mut().for_each(|s| s.radius = r);
    }

    let (materials, legend) = match field {
        None => (
            vec![Material::new(
                "particles",
                MaterialKind::Diffuse { color: DVec3::splat(DEFAULT_DIFFUSE_COLOR) },
            )],
            None,
        ),
        Some((_, name)) => {
            let [lo, hi] = style.range.unwrap_or_else(|| {
                values.iter().fold([f64::INFINITY, f64::NEG_INFINITY], |[lo, hi], v| [lo.min(*v), hi.max(*v)])
            });
            for (s, v) in spheres.iter_mut().zip(&values) {
                s.material = level(*v, lo, hi) as u32;
            }
            let levels = (0..MAP_LEVELS).map(|k| {
                let color = style.map.level_colour(k);
                Material::new(format!("{name} {} {k}", style.map.name()), MaterialKind::Diffuse { color })
            });
            (levels.collect(), Some(Legend { field: name, lo, hi, map: style.map }))
        }
    };
    let particles = Particles {
        file: h.origin.to_string(),
        style: style.clone(),
        scale: 1.0,
        rotate_deg: DVec3::ZERO,
        translate: DVec3::ZERO,
        spheres: 0..spheres.len(),
        materials: 0..materials.len(),
        legend,
    };
    Ok(Model { spheres, materials, particles: vec![particles], ..Default::default() })
}

/// Points with named scalar fields, all `float`: what [`write`] writes (the stress plate,
/// `io::stress_plate`; the tests' hand-made files).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PointTable {
    pub positions: Vec<[f32; 3]>,
    /// Each field's name and one value per position.
    pub fields: Vec<(String, Vec<f32>)>,
}

/// Writes `points` as a PLY file of one `vertex` element: `float x y z`, then each field.
pub fn write(
    points: &PointTable,
    encoding: super::Encoding,
    out: impl std::io::Write,
) -> std::io::Result<()> {
    use super::Encoding::*;
    use std::io::Write;
    let mut w = std::io::BufWriter::with_capacity(1 << 20, out);
    writeln!(w, "ply\nformat {} 1.0\ncomment written by irt", encoding.name())?;
    writeln!(w, "element vertex {}", points.positions.len())?;
    for name in ["x", "y", "z"].into_iter().chain(points.fields.iter().map(|(n, _)| n.as_str())) {
        writeln!(w, "property float {name}")?;
    }
    writeln!(w, "end_header")?;
    for (i, p) in points.positions.iter().enumerate() {
        let values = p.iter().copied().chain(points.fields.iter().map(|(_, v)| v[i]));
        for (k, x) in values.enumerate() {
            match encoding {
                Ascii => write!(w, "{}{x}", if k == 0 { "" } else { " " })?,
                BinaryLittleEndian => w.write_all(&x.to_le_bytes())?,
                BinaryBigEndian => w.write_all(&x.to_be_bytes())?,
            }
        }
        if encoding == Ascii {
            writeln!(w)?;
        }
    }
    w.flush()
}
