//! Particles in TOML: `[[particles]]` places a PLY file of points as spheres coloured by a field
//! (docs/scene-format.md, "Particles"):
//!
//! ```toml
//! [[particles]]
//! file = "plate.ply"      # relative to the scene file
//! radius = 0.002          # or the name of the field that holds it; default: the file's
//!                         # `radius`, else a third of the points' mean spacing
//! field = "von_mises"     # default: the file's first field
//! map = "viridis"         # scene::colour_map::COLOUR_MAPS
//! range = [0.0, 3.0]      # the values at the map's ends; default: the field's own
//! scale = 1.0             # one factor (spheres stay round), then rotate, then translate
//! ```

use super::{err, floats, located, number, scene_relative, vec3_or, Number, Numbers, Res, Span};
use crate::io::{ply, read_limited, MAX_MATERIALS, MAX_PARTICLES};
use crate::scene::colour_map::ColourMap;
use crate::scene::particles::{ParticleStyle, Radius};
use crate::scene::Scene;
use ::toml::Spanned;
use glam::DVec3;
use serde::Deserialize;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct ParticlesDoc {
    file: Spanned<String>,
    radius: Option<Spanned<RadiusDoc>>,
    field: Option<Spanned<String>>,
    map: Option<Spanned<String>>,
    range: Option<Numbers>,
    scale: Option<Number>,
    rotate: Option<Numbers>,
    translate: Option<Numbers>,
}

#[derive(Deserialize)]
#[serde(untagged, expecting = "a number, or the name of the field that holds each radius")]
enum RadiusDoc {
    Value(f64),
    Field(String),
}

/// The style a table asks for, checked before its file is read.
fn style(p: &ParticlesDoc) -> Res<ParticleStyle> {
    let radius = match p.radius.as_ref().map(|r| (r.get_ref(), r.span())) {
        None => Radius::Auto,
        Some((RadiusDoc::Value(r), span)) if !(r.is_finite() && *r > 0.0) => {
            return err(span, format!("`radius` is {r}; a radius is a finite number > 0"))
        }
        Some((RadiusDoc::Value(r), _)) => Radius::Value(*r),
        Some((RadiusDoc::Field(f), _)) => Radius::Field(f.clone()),
    };
    let map = match &p.map {
        None => ColourMap::default(),
        Some(m) => ColourMap::parse(m.get_ref()).map_err(|e| located(m.span(), e))?,
    };
    let range = match &p.range {
        None => None,
        Some(r) => {
            let [lo, hi] = floats::<2>(r.get_ref(), r.span(), "range")?;
            if lo >= hi {
                return err(r.span(), format!("`range` [{lo}, {hi}] must rise: [low, high]"));
            }
            Some([lo, hi])
        }
    };
    Ok(ParticleStyle { radius, field: p.field.as_ref().map(|f| f.get_ref().clone()), map, range })
}

/// Reads a `[[particles]]` table's file and adds its spheres and colour levels to `scene`.
pub(super) fn place(scene: &mut Scene, p: &ParticlesDoc, table: &Span, origin: &str) -> Res<()> {
    let style = style(p)?;
    let scale = p.scale.as_ref().map_or(Ok(1.0), |s| number(s, "scale"))?;
    if scale <= 0.0 {
        return err(p.scale.as_ref().map_or(table.clone(), Spanned::span), "`scale` must be > 0");
    }
    let (rotate, translate) =
        (vec3_or(&p.rotate, "rotate", DVec3::ZERO)?, vec3_or(&p.translate, "translate", DVec3::ZERO)?);
    let path = scene_relative(origin, &p.file);
    let name = path.display().to_string();
    let at_file = |e: String| located(p.file.span(), format!("particles: {e}"));
    if !path.extension().is_some_and(|e| e.eq_ignore_ascii_case("ply")) {
        return Err(at_file(format!("{name}: particles are read from PLY files of points (.ply)")));
    }
    let bytes = read_limited(&path, ply::MAX_FILE_BYTES, "particle file")
        .map_err(|e| at_file(format!("{name}: {e}")))?;
    let mut model = ply::parse_particles(&bytes, &name, &style).map_err(|e| at_file(e.to_string()))?;
    drop(bytes);
    model.transform(DVec3::splat(scale), rotate, translate);
    if scene.spheres.len() + model.spheres.len() > MAX_PARTICLES {
        return err(
            table.clone(),
            format!("with these particles the scene has more than {MAX_PARTICLES} spheres"),
        );
    }
    if scene.materials.len() + model.materials.len() > MAX_MATERIALS {
        return err(table.clone(), "with these particles the scene has too many materials");
    }
    let (sphere_base, material_base) = (scene.spheres.len(), scene.materials.len());
    // The levels are named after the file, as a [[model]]'s materials are.
    let stem = path.file_name().map_or(name.clone(), |f| f.to_string_lossy().into());
    scene.materials.extend(
        model
            .materials
            .into_iter()
            .map(|m| crate::scene::Material { name: format!("{stem}:{}", m.name), ..m }),
    );
    scene.spheres.extend(
        model
            .spheres
            .into_iter()
            .map(|s| crate::scene::Sphere { material: s.material + material_base as u32, ..s }),
    );
    for mut record in model.particles {
        record.spheres = record.spheres.start + sphere_base..record.spheres.end + sphere_base;
        record.materials = record.materials.start + material_base..record.materials.end + material_base;
        scene.particles.push(record);
    }
    Ok(())
}
