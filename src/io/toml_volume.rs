//! Volumes in TOML: `[[volume]]` places a volume file (NRRD, NIfTI, VTK ImageData) and draws
//! its isosurfaces (docs/scene-format.md, "Volumes"; docs/volumes.md):
//!
//! ```toml
//! [[volume]]
//! file = "head.nii.gz"    # relative to the scene file
//! iso = 80                # one isovalue, drawn with `material`
//! material = "skin"       # default: a pale diffuse one
//! # or several, each with its own material:
//! # iso = [{ value = 80, material = "skin" }, { value = 300, material = "bone" }]
//! mode = "iso"            # isosurfaces; "mip" (maximum intensity) or "dvr" (emission and
//!                         # absorption) map samples through a transfer function:
//! colormap = "greys"      # mip: greys, dvr: inferno (docs/scene-format.md lists the maps)
//! window = [40, 120]      # the samples the map spans (default: their whole range)
//! opacity = 0.1           # at the window's top (dvr: per cell; default mip 1, dvr 0.1)
//! scale = 1.0             # a number or [sx, sy, sz], then rotate (degrees), then translate
//! # or, instead of those three, the placement as three rows [a, b, c, t] (what irt convert
//! # writes): matrix = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0]]
//! brick = 8               # how the device stores the samples (1: as the file; 2 to 16: in
//! macrocell_levels = 3    # bricks of that edge) and the macrocell levels the walk uses (0
//!                         # to 3); pictures are the same, speed is not (docs/volumes.md)
//! ```

use super::{err, located, scene_relative, vec3_or, Names, Numbers, Res, Scale, Span};
use crate::io::stage::rotation;
use crate::io::MAX_MATERIALS;
use crate::scene::colour_map::ColourMap;
use crate::scene::transfer::{Look, Transfer};
use crate::scene::volume::{Iso, Layout, Volume, MAX_ISOS, MAX_VOLUMES};
use crate::scene::{Material, MaterialKind, Scene};
use ::toml::Spanned;
use glam::{DAffine3, DMat3, DVec3};
use serde::Deserialize;
use std::sync::Arc;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct VolumeDoc {
    file: Spanned<String>,
    iso: Option<Spanned<IsoDoc>>,
    material: Option<Spanned<String>>,
    mode: Option<Spanned<String>>,
    colormap: Option<Spanned<String>>,
    window: Option<Spanned<[f64; 2]>>,
    opacity: Option<Spanned<f64>>,
    scale: Option<Spanned<Scale>>,
    rotate: Option<Numbers>,
    translate: Option<Numbers>,
    matrix: Option<Spanned<[[f64; 4]; 3]>>,
    brick: Option<Spanned<u32>>,
    macrocell_levels: Option<Spanned<u32>>,
}

#[derive(Deserialize)]
#[serde(untagged, expecting = "a number, or a list of { value = V, material = \"name\" }")]
enum IsoDoc {
    Value(f64),
    Levels(Vec<LevelDoc>),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LevelDoc {
    value: f64,
    // Not `Spanned`: an untagged enum's fields are buffered, which loses their places; an
    // unknown name is reported at the `iso` list.
    material: Option<String>,
}

/// The material a volume's isosurface gets when none is named: bone-white, diffuse.
pub const DEFAULT_VOLUME_COLOUR: DVec3 = DVec3::new(0.85, 0.8, 0.72);

/// The index of the scene's default volume material, added on first use.
pub fn default_material(scene: &mut Scene) -> u32 {
    if let Some(i) = scene.materials.iter().position(|m| m.name == "volume") {
        return i as u32;
    }
    scene.materials.push(Material::new("volume", MaterialKind::Diffuse { color: DEFAULT_VOLUME_COLOUR }));
    scene.materials.len() as u32 - 1
}

/// The isovalue a volume is drawn at when none is given: halfway through its samples' range.
pub fn default_iso(grid: &crate::scene::volume::Grid) -> f64 {
    let (lo, hi) = grid.range();
    0.5 * (lo as f64 + hi as f64)
}

/// Reads a `[[volume]]` table's file and adds the volume to `scene`.
pub(super) fn place(scene: &mut Scene, v: &VolumeDoc, table: &Span, origin: &str, names: &Names) -> Res<()> {
    if scene.volumes.len() >= MAX_VOLUMES {
        return err(table.clone(), format!("a scene holds at most {MAX_VOLUMES} volumes"));
    }
    let look = match &v.mode {
        Some(m) => Look::parse(m.get_ref()).map_err(|e| located(m.span(), e))?,
        None => Look::Iso,
    };
    let map = v
        .colormap
        .as_ref()
        .map(|m| ColourMap::parse(m.get_ref()).map_err(|e| located(m.span(), e)))
        .transpose()?;
    let rotate = vec3_or(&v.rotate, "rotate", DVec3::ZERO)?;
    let translate = vec3_or(&v.translate, "translate", DVec3::ZERO)?;
    let scale = super::scale(&v.scale)?;
    if !(rotate.is_finite() && translate.is_finite()) {
        return err(table.clone(), "`rotate` and `translate` must be finite");
    }
    let material = v.material.as_ref().map(|m| names.resolve(m)).transpose()?;
    // The levels, by name, before the file is read: a typo should not wait for 1 GiB.
    let levels: Vec<(Option<f64>, Option<u32>)> = match v.iso.as_ref().map(|i| (i.get_ref(), i.span())) {
        None => vec![(None, material)],
        Some((IsoDoc::Value(x), span)) => {
            if !x.is_finite() {
                return err(span, format!("`iso` {x} is not finite"));
            }
            vec![(Some(*x), material)]
        }
        Some((IsoDoc::Levels(ls), span)) => {
            if ls.is_empty() || ls.len() > MAX_ISOS {
                return err(span, format!("{} isovalues: give 1 to {MAX_ISOS}", ls.len()));
            }
            let mut out = Vec::new();
            for l in ls {
                if !l.value.is_finite() {
                    return err(span.clone(), format!("isovalue {} is not finite", l.value));
                }
                let m = match &l.material {
                    None => material,
                    Some(name) => match names.map.get(name.as_str()) {
                        Some((index, _)) => Some(*index),
                        None => return err(span.clone(), names.unknown(name)),
                    },
                };
                out.push((Some(l.value), m));
            }
            out
        }
    };
    let path = scene_relative(origin, &v.file);
    let grid = crate::io::volume::load(&path).map_err(|e| located(v.file.span(), format!("volume: {e}")))?;
    let needs_default = levels.iter().any(|(_, m)| m.is_none());
    if needs_default && scene.materials.len() >= MAX_MATERIALS {
        return err(table.clone(), "the scene has too many materials for the volume's default one");
    }
    let fallback = if needs_default { default_material(scene) } else { 0 };
    let isos = levels
        .into_iter()
        .map(|(value, m)| Iso {
            value: value.unwrap_or_else(|| default_iso(&grid)),
            material: m.unwrap_or(fallback),
        })
        .collect();
    let transform = match &v.matrix {
        None => DAffine3::from_mat3_translation(rotation(rotate) * DMat3::from_diagonal(scale), translate),
        Some(m) if v.scale.is_none() && v.rotate.is_none() && v.translate.is_none() => {
            let r = m.get_ref();
            let a = DAffine3::from_cols_array(&[
                r[0][0], r[1][0], r[2][0], r[0][1], r[1][1], r[2][1], r[0][2], r[1][2], r[2][2], r[0][3],
                r[1][3], r[2][3],
            ]);
            let det = a.matrix3.determinant();
            if !(a.is_finite() && det.abs() > 1e-300) {
                return err(m.span(), "`matrix` must be finite and invertible");
            }
            a
        }
        Some(m) => return err(m.span(), "give `matrix` or `scale`/`rotate`/`translate`, not both"),
    };
    let mut volume = Volume::new(Arc::new(grid), transform, isos, Some(path)).with_look(look);
    volume.transfer = transfer(volume.transfer, map, v.window.as_ref(), v.opacity.as_ref(), table)?;
    let layout = Layout {
        brick: v.brick.as_ref().map_or(volume.layout.brick, |b| *b.get_ref()),
        levels: v.macrocell_levels.as_ref().map_or(volume.layout.levels, |l| *l.get_ref()),
    };
    volume.layout = layout.check().or_else(|e| {
        let span = if e.starts_with("brick") { v.brick.as_ref() } else { v.macrocell_levels.as_ref() };
        err(span.map_or(table.clone(), |s| s.span()), e)
    })?;
    scene.volumes.push(volume);
    Ok(())
}

/// The look's default transfer function with what the table gives instead.
fn transfer(
    default: Transfer,
    map: Option<ColourMap>,
    window: Option<&Spanned<[f64; 2]>>,
    opacity: Option<&Spanned<f64>>,
    table: &Span,
) -> Res<Transfer> {
    let t = Transfer {
        map: map.unwrap_or(default.map),
        window: window.map_or(default.window, |w| *w.get_ref()),
        opacity: opacity.map_or(default.opacity, |o| *o.get_ref()),
    };
    if let Err(e) = t.check() {
        let span =
            if e.starts_with("opacity") { opacity.map(|o| o.span()) } else { window.map(|w| w.span()) };
        // No span: the samples' own range is one value, so a window must be given.
        return err(span.unwrap_or(table.clone()), e);
    }
    Ok(t)
}

/// A `[[volume]]` table that loads back as `v` with its file named `file`: the isovalues with
/// their materials (by the names `material` gives), the look and transfer function, the
/// placement as its `matrix`.
pub fn write(out: &mut String, v: &Volume, file: &str, material: &dyn Fn(u32) -> String) {
    use std::fmt::Write as _;
    let q = |s: &str| toml::Value::String(s.into()).to_string();
    let _ = write!(out, "\n[[volume]]\nfile = {}\niso = [", q(file));
    for (k, iso) in v.isos.iter().enumerate() {
        let sep = if k > 0 { ", " } else { "" };
        let _ = write!(out, "{sep}{{ value = {:?}, material = {} }}", iso.value, q(&material(iso.material)));
    }
    let t = &v.transfer;
    let _ = write!(
        out,
        "]\nmode = {}\ncolormap = {}\nwindow = [{:?}, {:?}]\nopacity = {:?}\nmatrix = [",
        q(v.look.name()),
        q(t.map.name()),
        t.window[0],
        t.window[1],
        t.opacity
    );
    let (m, tr) = (v.transform.matrix3, v.transform.translation);
    for r in 0..3 {
        let row = m.row(r);
        let sep = if r > 0 { ", " } else { "" };
        let _ = write!(out, "{sep}[{:?}, {:?}, {:?}, {:?}]", row.x, row.y, row.z, tr[r]);
    }
    let _ = writeln!(out, "]\nbrick = {}\nmacrocell_levels = {}", v.layout.brick, v.layout.levels);
}
