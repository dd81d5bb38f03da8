//! The native scene format, TOML; every key is documented in docs/scene-format.md.
//!
//! Parsing has two stages. serde (with `deny_unknown_fields`) turns the text into the `*Doc`
//! structs below, keeping each value's place in the file with [`Spanned`]; syntax and type
//! errors come out of it with a position. Then the `build` functions turn the documents into a
//! [`Scene`], checking what serde cannot (vector lengths, finiteness, material names, indices)
//! at the offending value, and [`Scene::validate`] checks the rest, reported at the table it
//! is about.

#[path = "toml_motion.rs"]
mod motion;
#[path = "toml_particles.rs"]
mod particles;
#[path = "toml_patch.rs"]
pub mod patch;
#[path = "toml_volume.rs"]
pub mod volume;

use super::shapes::{self, Geometry, MAX_ICOSPHERE_SUBDIVISIONS};
use super::{
    line_column, png, LoadError, MAX_CONES, MAX_MATERIALS, MAX_SPHERES, MAX_TRIANGLES, MAX_VERTICES,
};
use crate::scene::patch::Patch;
use crate::scene::{
    Ambient, Animated, Camera, Cone, Filter, Light, Material, MaterialKind, Mesh, Scene, ShadowMode,
    ShadowSetting, Sphere, Target, Texture, TraceSettings, Wrap, MAX_LIGHTS, MAX_TEXTURES,
    MAX_TEXTURE_PIXELS,
};
use ::toml::Spanned;
use glam::{DVec2, DVec3};
use serde::Deserialize;
use std::collections::HashMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

pub const DEFAULT_FOV_DEG: f64 = 45.0;
pub const DEFAULT_WIDTH: u32 = 640;
pub const DEFAULT_HEIGHT: u32 = 480;
pub const DEFAULT_ETA: f64 = 1.5;
pub const DEFAULT_METAL_EXPONENT: f64 = 64.0;
/// Glass and clear coats are smoother than metal: a tighter highlight.
pub const DEFAULT_COAT_EXPONENT: f64 = 128.0;
pub const DEFAULT_DIFFUSE_COLOR: f64 = 0.8;
pub const DEFAULT_METAL_COLOR: f64 = 0.9;
pub const DEFAULT_ICOSPHERE_SUBDIVISIONS: u32 = 2;
/// Largest texture file read. A PNG of the largest texture irt accepts ([`MAX_TEXTURE_PIXELS`])
/// stored without compression at 16 bits per channel is 8 bytes per pixel, 128 MiB, plus a
/// filter byte per row and chunk headers; this leaves room for that and no more.
pub const MAX_TEXTURE_FILE_BYTES: u64 = MAX_TEXTURE_PIXELS * 8 + (16 << 20);
pub const EMPTY_SCENE: &str =
    "scene has nothing to render: add a [[sphere]], [[mesh]], [[cone]], [[patch]], [[model]] or [[particles]]";

/// Parses and validates a scene; `origin` names the source in error messages, and texture
/// `file`s are found relative to its directory (for a `<built-in …>` origin: the current one).
pub fn parse_str(src: &str, origin: &str) -> Result<Scene, LoadError> {
    let located = |e: Located| match e.span {
        Some(span) => LoadError::at(origin, src, span.start, e.message),
        None => LoadError::new(origin, e.message),
    };
    let doc: Doc = ::toml::from_str(src)
        .map_err(|e| located(Located { span: e.span(), message: e.message().trim_end().to_string() }))?;
    let scene = build(&doc, src, origin).map_err(located)?;
    scene.validate().map_err(|e| located(Located { span: blame(&doc, &e.0), message: e.0 }))?;
    if scene.primitive_count() == 0 {
        return Err(LoadError::new(origin, EMPTY_SCENE));
    }
    Ok(scene)
}

// ---- The file as serde sees it -------------------------------------------------------------

type Span = Range<usize>;
/// A list of numbers (a point, colour or size) before its length is checked.
type Numbers = Spanned<Vec<f64>>;
type Number = Spanned<f64>;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Doc {
    background: Option<Numbers>,
    camera: Spanned<CameraDoc>,
    ambient: Option<Spanned<AmbientDoc>>,
    #[serde(default)]
    light: Vec<Spanned<LightDoc>>,
    trace: Option<Spanned<TraceDoc>>,
    #[serde(default)]
    texture: Vec<Spanned<TextureDoc>>,
    #[serde(default)]
    material: Vec<Spanned<MaterialDoc>>,
    #[serde(default)]
    sphere: Vec<Spanned<SphereDoc>>,
    #[serde(default)]
    mesh: Vec<Spanned<MeshDoc>>,
    #[serde(default)]
    cone: Vec<Spanned<ConeDoc>>,
    #[serde(default)]
    model: Vec<Spanned<ModelDoc>>,
    #[serde(default)]
    particles: Vec<Spanned<particles::ParticlesDoc>>,
    #[serde(default)]
    volume: Vec<Spanned<volume::VolumeDoc>>,
    #[serde(default)]
    patch: Vec<Spanned<patch::PatchDoc>>,
}

/// A model file placed in the scene: its meshes and materials (or `material` for all of them),
/// scaled, rotated and moved.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ModelDoc {
    file: Spanned<String>,
    material: Option<Spanned<String>>,
    scale: Option<Spanned<Scale>>,
    rotate: Option<Numbers>,
    translate: Option<Numbers>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraDoc {
    eye: Numbers,
    look_at: Numbers,
    up: Option<Numbers>,
    fov: Option<Number>,
    width: Option<u32>,
    height: Option<u32>,
}

#[derive(Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct AmbientDoc {
    sky: Option<Numbers>,
    ground: Option<Numbers>,
    up: Option<Numbers>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LightDoc {
    position: Numbers,
    color: Option<Numbers>,
    intensity: Option<Number>,
    radius: Option<Number>,
    /// Stages of the object's motion, outermost first (toml_motion.rs).
    #[serde(default)]
    motion: Vec<Spanned<motion::StageDoc>>,
}

#[derive(Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct TraceDoc {
    max_depth: Option<u32>,
    weight_cutoff: Option<Number>,
    shadows: Option<Spanned<String>>,
}

/// A PNG image used as a base colour, and how it is sampled.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TextureDoc {
    name: Spanned<String>,
    file: Spanned<String>,
    wrap: Option<Spanned<WrapDoc>>,
    filter: Option<Spanned<String>>,
}

#[derive(Deserialize)]
#[serde(untagged, expecting = "a wrap mode (\"repeat\", \"clamp\" or \"mirror\") or a list [u mode, v mode]")]
enum WrapDoc {
    Both(String),
    Each(Vec<String>),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialDoc {
    name: Spanned<String>,
    #[serde(rename = "type")]
    kind: MaterialType,
    color: Option<Numbers>,
    exponent: Option<Number>,
    eta: Option<Number>,
    texture: Option<Spanned<String>>,
}

#[derive(Clone, Copy, Deserialize)]
#[serde(rename_all = "lowercase")]
enum MaterialType {
    Diffuse,
    Metal,
    Dielectric,
    Polished,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SphereDoc {
    center: Numbers,
    radius: Number,
    material: Spanned<String>,
    /// Stages of the object's motion, outermost first (toml_motion.rs).
    #[serde(default)]
    motion: Vec<Spanned<motion::StageDoc>>,
}

/// An open cone or cylinder: `radius` for a cylinder, or `base_radius` and `apex_radius`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ConeDoc {
    base: Numbers,
    apex: Numbers,
    radius: Option<Number>,
    base_radius: Option<Number>,
    apex_radius: Option<Number>,
    material: Spanned<String>,
    /// Stages of the object's motion, outermost first (toml_motion.rs).
    #[serde(default)]
    motion: Vec<Spanned<motion::StageDoc>>,
}

/// Inline geometry (`positions`, `indices`, `normals`) or a generated `shape` and its
/// parameters; which keys apply depends on the shape.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MeshDoc {
    material: Spanned<String>,
    shape: Option<Shape>,
    positions: Option<Spanned<Vec<Numbers>>>,
    indices: Option<Spanned<Vec<Spanned<Vec<i64>>>>>,
    normals: Option<Spanned<Vec<Numbers>>>,
    uvs: Option<Spanned<Vec<Numbers>>>,
    center: Option<Numbers>,
    size: Option<Numbers>,
    corners: Option<Spanned<Vec<Numbers>>>,
    min: Option<Numbers>,
    max: Option<Numbers>,
    radius: Option<Number>,
    subdivisions: Option<Spanned<u32>>,
    translate: Option<Numbers>,
    scale: Option<Spanned<Scale>>,
    /// Stages of the object's motion, outermost first (toml_motion.rs).
    #[serde(default)]
    motion: Vec<Spanned<motion::StageDoc>>,
}

#[derive(Clone, Copy, Deserialize)]
#[serde(rename_all = "lowercase")]
enum Shape {
    Quad,
    Box,
    Icosphere,
}

#[derive(Deserialize)]
#[serde(untagged, expecting = "a number or a list [sx, sy, sz]")]
enum Scale {
    Uniform(f64),
    Axes(Vec<f64>),
}

// ---- Errors and checked values -------------------------------------------------------------

/// An error at a place in the file (`None`: the file as a whole).
struct Located {
    span: Option<Span>,
    message: String,
}

type Res<T> = Result<T, Located>;

fn located(span: Span, message: impl Into<String>) -> Located {
    Located { span: Some(span), message: message.into() }
}

fn err<T>(span: Span, message: impl Into<String>) -> Res<T> {
    Err(located(span, message))
}

/// Exactly `N` finite numbers. TOML has `nan` and `inf` literals, and a renderer fed one
/// produces black or NaN pixels far from the cause, so they stop here.
fn floats<const N: usize>(values: &[f64], span: Span, key: &str) -> Res<[f64; N]> {
    let Ok(array) = <[f64; N]>::try_from(values) else {
        return err(span, format!("`{key}` needs {N} numbers, found {}", values.len()));
    };
    match array.iter().find(|x| !x.is_finite()) {
        Some(x) => err(span, format!("`{key}` contains {x}; numbers must be finite")),
        None => Ok(array),
    }
}

fn numbers<const N: usize>(v: &Numbers, key: &str) -> Res<[f64; N]> {
    floats(v.get_ref(), v.span(), key)
}

fn vec3(v: &Numbers, key: &str) -> Res<DVec3> {
    numbers::<3>(v, key).map(DVec3::from_array)
}

fn vec3_or(v: &Option<Numbers>, key: &str, default: DVec3) -> Res<DVec3> {
    v.as_ref().map_or(Ok(default), |v| vec3(v, key))
}

fn number(v: &Number, key: &str) -> Res<f64> {
    floats::<1>(&[*v.get_ref()], v.span(), key).map(|[x]| x)
}

fn number_or(v: &Option<Number>, key: &str, default: f64) -> Res<f64> {
    v.as_ref().map_or(Ok(default), |v| number(v, key))
}

fn positive(v: &Number, key: &str) -> Res<f64> {
    let x = number(v, key)?;
    if x > 0.0 {
        Ok(x)
    } else {
        err(v.span(), format!("`{key}` must be greater than 0, not {x}"))
    }
}

/// A key a table cannot do without (`what` names the table), reported at the table.
fn required<'a, T>(v: &'a Option<T>, key: &str, what: &str, table: &Span) -> Res<&'a T> {
    v.as_ref().ok_or_else(|| located(table.clone(), format!("{what} needs `{key}`")))
}

fn span_of<T>(v: &Option<Spanned<T>>) -> Option<Span> {
    v.as_ref().map(Spanned::span)
}

/// Rejects keys that `what` does not take. Ignoring them would hide a misunderstanding (an
/// `eta` on a diffuse material does nothing), so the message lists the keys that do apply.
fn only_keys(given: &[(&str, Option<Span>)], allowed: &[&str], what: &str) -> Res<()> {
    let stray = given.iter().find(|(key, span)| span.is_some() && !allowed.contains(key));
    match stray {
        Some((key, Some(span))) => {
            let takes = allowed.iter().map(|k| format!("`{k}`")).collect::<Vec<_>>().join(", ");
            err(span.clone(), format!("`{key}` does not apply to {what}; it takes {takes}"))
        }
        _ => Ok(()),
    }
}

/// Refuses more than `max` tables of one kind, pointing at the first one too many.
fn at_most<T>(tables: &[Spanned<T>], max: usize, what: &str) -> Res<()> {
    match tables.get(max) {
        Some(extra) => err(extra.span(), format!("too many {what}: at most {max} are supported")),
        None => Ok(()),
    }
}

// ---- Building the scene --------------------------------------------------------------------

fn build(doc: &Doc, src: &str, origin: &str) -> Res<Scene> {
    let (textures, texture_names) = textures(&doc.texture, src, origin)?;
    let (materials, names) = materials(&doc.material, src, &texture_names)?;
    let mut scene = Scene {
        camera: camera(doc.camera.get_ref())?,
        lights: lights(&doc.light)?,
        ambient: ambient(doc.ambient.as_ref().map_or(&AmbientDoc::default(), Spanned::get_ref))?,
        background: vec3_or(&doc.background, "background", DVec3::ZERO)?,
        spheres: spheres(&doc.sphere, &names)?,
        meshes: meshes(&doc.mesh, &names)?,
        cones: cones(&doc.cone, &names)?,
        materials,
        textures,
        trace: trace(doc.trace.as_ref().map_or(&TraceDoc::default(), Spanned::get_ref))?,
        motions: Vec::new(),
        particles: Vec::new(),
        volumes: Vec::new(),
        patches: Vec::new(),
    };
    scene.motions = motions(doc)?;
    for m in &doc.model {
        place_model(&mut scene, m.get_ref(), &m.span(), origin, &names)?;
    }
    for p in &doc.particles {
        particles::place(&mut scene, p.get_ref(), &p.span(), origin)?;
    }
    for v in &doc.volume {
        volume::place(&mut scene, v.get_ref(), &v.span(), origin, &names)?;
    }
    patch::place(&mut scene, &doc.patch, &names)?;
    Ok(scene)
}

/// Every object's `motion`, with the object it moves.
fn motions(doc: &Doc) -> Res<Vec<Animated>> {
    let mut out = Vec::new();
    let mut add = |target: Target, stages: &[Spanned<motion::StageDoc>], round: bool| -> Res<()> {
        if !stages.is_empty() {
            out.push(Animated { target, motion: motion::motion(stages, round)? });
        }
        Ok(())
    };
    for (i, l) in doc.light.iter().enumerate() {
        add(Target::Light(i as u32), &l.get_ref().motion, false)?;
    }
    for (i, s) in doc.sphere.iter().enumerate() {
        add(Target::Sphere(i as u32), &s.get_ref().motion, true)?;
    }
    for (i, c) in doc.cone.iter().enumerate() {
        add(Target::Cone(i as u32), &c.get_ref().motion, true)?;
    }
    for (i, m) in doc.mesh.iter().enumerate() {
        add(Target::Mesh(i as u32), &m.get_ref().motion, false)?;
    }
    Ok(out)
}

/// Loads a `[[model]]`'s file (relative to the scene file) and adds its meshes, with its own
/// materials and textures appended to the scene's (named `file:material`), or all with the
/// scene's `material`.
fn place_model(scene: &mut Scene, m: &ModelDoc, table: &Span, origin: &str, names: &Names) -> Res<()> {
    // The table's own values first: a typo should not wait for a large model to load.
    let rotate = vec3_or(&m.rotate, "rotate", DVec3::ZERO)?;
    if !rotate.is_finite() {
        return err(span_of(&m.rotate).unwrap_or(table.clone()), "`rotate` must be finite");
    }
    let (scale, translate) = (scale(&m.scale)?, vec3_or(&m.translate, "translate", DVec3::ZERO)?);
    let material = m.material.as_ref().map(|name| names.resolve(name)).transpose()?;
    let path = scene_relative(origin, &m.file);
    let mut model = super::load_model(&path).map_err(|e| located(m.file.span(), format!("model: {e}")))?;
    if !model.spheres.is_empty() {
        // Its spheres would be dropped here: particles have their own table and style.
        return err(m.file.span(), "model: a PLY file of points is particles: place it with [[particles]]");
    }
    model.transform(scale, rotate, translate);
    let triangles = scene.triangle_count() + model.meshes.iter().map(|m| m.indices.len()).sum::<usize>();
    let vertices = scene.meshes.iter().chain(&model.meshes).map(|m| m.positions.len()).sum::<usize>();
    if triangles > MAX_TRIANGLES || vertices > MAX_VERTICES {
        return err(
            table.clone(),
            format!("with this model the scene exceeds {MAX_TRIANGLES} triangles or {MAX_VERTICES} vertices"),
        );
    }
    // An animated model's motions follow its meshes to their indices in the scene.
    let mesh_base = scene.meshes.len() as u32;
    scene.motions.extend(model.motions.into_iter().map(|a| crate::scene::Animated {
        target: match a.target {
            crate::scene::Target::Mesh(i) => crate::scene::Target::Mesh(i + mesh_base),
            other => other,
        },
        ..a
    }));
    if let Some(material) = material {
        scene.meshes.extend(model.meshes.into_iter().map(|mesh| Mesh { material, ..mesh }));
        scene.patches.extend(model.patches.into_iter().map(|p| Patch { material, ..p }));
        return Ok(());
    }
    let (material_base, texture_base) = (scene.materials.len() as u32, scene.textures.len() as u32);
    if scene.materials.len() + model.materials.len() > MAX_MATERIALS
        || scene.textures.len() + model.textures.len() > MAX_TEXTURES
    {
        return err(table.clone(), "with this model the scene has too many materials or textures");
    }
    let stem = Path::new(m.file.get_ref())
        .file_name()
        .map_or(m.file.get_ref().clone(), |f| f.to_string_lossy().into());
    scene.materials.extend(model.materials.into_iter().map(|mat| Material {
        name: format!("{stem}:{}", mat.name),
        texture: mat.texture.map(|t| t + texture_base),
        ..mat
    }));
    scene.textures.extend(model.textures);
    scene.meshes.extend(
        model.meshes.into_iter().map(|mesh| Mesh { material: mesh.material + material_base, ..mesh }),
    );
    scene
        .patches
        .extend(model.patches.into_iter().map(|p| Patch { material: p.material + material_base, ..p }));
    Ok(())
}

fn camera(c: &CameraDoc) -> Res<Camera> {
    Ok(Camera {
        eye: vec3(&c.eye, "eye")?,
        look_at: vec3(&c.look_at, "look_at")?,
        up: vec3_or(&c.up, "up", DVec3::Y)?,
        vfov_deg: number_or(&c.fov, "fov", DEFAULT_FOV_DEG)?,
        width: c.width.unwrap_or(DEFAULT_WIDTH),
        height: c.height.unwrap_or(DEFAULT_HEIGHT),
    })
}

fn lights(docs: &[Spanned<LightDoc>]) -> Res<Vec<Light>> {
    at_most(docs, MAX_LIGHTS, "[[light]] tables")?;
    let light = |l: &LightDoc| {
        let color = vec3_or(&l.color, "color", DVec3::ONE)?;
        Ok(Light {
            position: vec3(&l.position, "position")?,
            color: color * number_or(&l.intensity, "intensity", 1.0)?,
            radius: number_or(&l.radius, "radius", 0.0)?,
        })
    };
    docs.iter().map(|l| light(l.get_ref())).collect()
}

fn ambient(a: &AmbientDoc) -> Res<Ambient> {
    Ok(Ambient {
        sky: vec3_or(&a.sky, "sky", DVec3::ZERO)?,
        ground: vec3_or(&a.ground, "ground", DVec3::ZERO)?,
        up: vec3_or(&a.up, "up", DVec3::Y)?,
    })
}

fn trace(t: &TraceDoc) -> Res<TraceSettings> {
    let default = TraceSettings::default();
    let setting = match &t.shadows {
        None => ShadowSetting::Mode(default.shadows),
        Some(s) => s.get_ref().parse().or_else(|e: crate::ParseError| err(s.span(), e.to_string()))?,
    };
    let (shadows, soft) = match setting {
        ShadowSetting::Mode(m) => (m, false),
        // Picked once the scene is whole and its overrides applied (`ShadowSetting::resolve`,
        // by the command that loads it).
        ShadowSetting::Soft => (ShadowMode::Hard, true),
    };
    Ok(TraceSettings {
        max_depth: t.max_depth.unwrap_or(default.max_depth),
        weight_cutoff: number_or(&t.weight_cutoff, "weight_cutoff", default.weight_cutoff)?,
        shadows,
        soft,
    })
}

/// Names of one kind of table (`what`: "material", "texture") → index, and where each was
/// defined.
struct Names<'a> {
    what: &'static str,
    map: HashMap<&'a str, (u32, Span)>,
}

impl<'a> Names<'a> {
    fn new(what: &'static str) -> Self {
        Names { what, map: HashMap::new() }
    }

    /// Adds the next table's `name`, refusing one already taken.
    fn define(&mut self, name: &'a Spanned<String>, src: &str) -> Res<u32> {
        let (what, text) = (self.what, name.get_ref());
        if let Some((_, first)) = self.map.get(text.as_str()) {
            let line = line_column(src, first.start).0;
            return err(name.span(), format!("{what} '{text}' is already defined on line {line}"));
        }
        let index = self.map.len() as u32;
        self.map.insert(text, (index, name.span()));
        Ok(index)
    }

    fn resolve(&self, name: &Spanned<String>) -> Res<u32> {
        match self.map.get(name.get_ref().as_str()) {
            Some((index, _)) => Ok(*index),
            None => err(name.span(), self.unknown(name.get_ref())),
        }
    }

    fn unknown(&self, name: &str) -> String {
        let what = self.what;
        if self.map.is_empty() {
            return format!("unknown {what} '{name}': the file defines no [[{what}]]");
        }
        let mut known: Vec<_> = self.map.iter().map(|(n, (i, _))| (*i, *n)).collect();
        known.sort_unstable();
        const SHOWN: usize = 10;
        let mut list = known.iter().take(SHOWN).map(|(_, n)| format!("'{n}'")).collect::<Vec<_>>().join(", ");
        if known.len() > SHOWN {
            list += &format!(" and {} more", known.len() - SHOWN);
        }
        format!("unknown {what} '{name}' ({what}s defined: {list})")
    }
}

fn materials<'a>(
    docs: &'a [Spanned<MaterialDoc>],
    src: &str,
    textures: &Names,
) -> Res<(Vec<Material>, Names<'a>)> {
    at_most(docs, MAX_MATERIALS, "[[material]] tables")?;
    let mut names = Names::new("material");
    let mut out = Vec::with_capacity(docs.len());
    for doc in docs {
        let m = doc.get_ref();
        names.define(&m.name, src)?;
        let texture =
            match (&m.texture, m.kind) {
                (None, _) => None,
                (Some(t), MaterialType::Dielectric) => return err(
                    t.span(),
                    "a dielectric material has no colour to texture; `texture` applies to diffuse, metal \
                     and polished materials",
                ),
                (Some(t), _) => Some(textures.resolve(t)?),
            };
        let material = Material { name: m.name.get_ref().clone(), texture, kind: material_kind(m)? };
        // Range checks (colour in [0, 1], eta > 0) are the scene model's; report them here
        // because here we still know which table they belong to.
        material.validate().map_err(|e| located(doc.span(), e.0))?;
        out.push(material);
    }
    Ok((out, names))
}

/// Reads and decodes every texture's PNG. The headers come first: a file that is not a PNG, an
/// image too big on its own, and a scene whose images together exceed
/// [`crate::scene::MAX_TOTAL_TEXTURE_PIXELS`] are refused before any file is read whole or decoded.
fn textures<'a>(docs: &'a [Spanned<TextureDoc>], src: &str, origin: &str) -> Res<(Vec<Texture>, Names<'a>)> {
    at_most(docs, MAX_TEXTURES, "[[texture]] tables")?;
    let mut names = Names::new("texture");
    let mut settings = Vec::with_capacity(docs.len());
    for doc in docs {
        let t = doc.get_ref();
        names.define(&t.name, src)?;
        settings.push((scene_relative(origin, &t.file), wrap(&t.wrap)?, filter(&t.filter)?));
    }
    let mut budget = png::PixelBudget::default();
    for (t, (path, ..)) in docs.iter().zip(&settings) {
        let file = &t.get_ref().file;
        let header = png::read_header(path).map_err(|e| located(file.span(), e.to_string()))?;
        let (w, h) = png::checked_size(&header, &texture_what(path)).map_err(|e| match e {
            png::Unusable::Refused(m) | png::Unusable::NotPng(m) => located(file.span(), m),
        })?;
        budget.take(w, h).map_err(|e| located(file.span(), e.to_string()))?;
    }
    let mut out = Vec::with_capacity(docs.len());
    for (t, (path, wrap, filter)) in docs.iter().zip(settings) {
        let t = t.get_ref();
        let what = texture_what(&path);
        let bytes = super::read_limited(&path, MAX_TEXTURE_FILE_BYTES, "texture file")
            .map_err(|m| located(t.file.span(), format!("'{}': {m}", path.display())))?;
        let (width, height, texels) = png::decode(&bytes, &what).map_err(|e| match e {
            png::Unusable::Refused(m) | png::Unusable::NotPng(m) => located(t.file.span(), m),
        })?;
        out.push(Texture { name: t.name.get_ref().clone(), width, height, texels, wrap, filter });
    }
    Ok((out, names))
}

/// A texture file as messages name it.
fn texture_what(path: &Path) -> String {
    format!("texture file '{}'", path.display())
}

/// A texture's or model's `file`, relative to the directory of the scene file `origin`.
fn scene_relative(origin: &str, file: &Spanned<String>) -> PathBuf {
    Path::new(origin).parent().unwrap_or(Path::new("")).join(file.get_ref())
}

/// A word from `names` (the modes of a wrap or filter), or an error listing them.
fn mode<T: Copy>(word: &str, names: &[(&str, T)], key: &str, span: Span) -> Res<T> {
    match names.iter().find(|(n, _)| *n == word) {
        Some((_, mode)) => Ok(*mode),
        None => {
            let known = names.iter().map(|(n, _)| format!("\"{n}\"")).collect::<Vec<_>>().join(", ");
            err(span, format!("unknown `{key}` \"{word}\"; expected one of {known}"))
        }
    }
}

fn wrap(w: &Option<Spanned<WrapDoc>>) -> Res<[Wrap; 2]> {
    let Some(w) = w else { return Ok([Wrap::default(); 2]) };
    let one = |word: &str| mode(word, &Wrap::NAMES, "wrap", w.span());
    match w.get_ref() {
        WrapDoc::Both(word) => Ok([one(word)?; 2]),
        WrapDoc::Each(words) => match words.as_slice() {
            [u, v] => Ok([one(u)?, one(v)?]),
            _ => err(w.span(), format!("`wrap` needs 2 modes [u, v] as a list, found {}", words.len())),
        },
    }
}

fn filter(f: &Option<Spanned<String>>) -> Res<Filter> {
    f.as_ref().map_or(Ok(Filter::default()), |f| mode(f.get_ref(), &Filter::NAMES, "filter", f.span()))
}

fn material_kind(m: &MaterialDoc) -> Res<MaterialKind> {
    let (what, allowed): (&str, &[&str]) = match m.kind {
        MaterialType::Diffuse => ("a diffuse material", &["color"]),
        MaterialType::Metal => ("a metal material", &["color", "exponent"]),
        MaterialType::Dielectric => ("a dielectric material", &["eta", "exponent"]),
        MaterialType::Polished => ("a polished material", &["color", "eta", "exponent"]),
    };
    let given = [("color", span_of(&m.color)), ("exponent", span_of(&m.exponent)), ("eta", span_of(&m.eta))];
    only_keys(&given, allowed, what)?;
    let color = |default| vec3_or(&m.color, "color", DVec3::splat(default));
    let exponent = |default| number_or(&m.exponent, "exponent", default);
    let eta = || number_or(&m.eta, "eta", DEFAULT_ETA);
    Ok(match m.kind {
        MaterialType::Diffuse => MaterialKind::Diffuse { color: color(DEFAULT_DIFFUSE_COLOR)? },
        MaterialType::Metal => MaterialKind::Metal {
            color: color(DEFAULT_METAL_COLOR)?,
            exponent: exponent(DEFAULT_METAL_EXPONENT)?,
        },
        MaterialType::Dielectric => {
            MaterialKind::Dielectric { eta: eta()?, exponent: exponent(DEFAULT_COAT_EXPONENT)? }
        }
        MaterialType::Polished => MaterialKind::Polished {
            color: color(DEFAULT_DIFFUSE_COLOR)?,
            eta: eta()?,
            exponent: exponent(DEFAULT_COAT_EXPONENT)?,
        },
    })
}

fn spheres(docs: &[Spanned<SphereDoc>], names: &Names) -> Res<Vec<Sphere>> {
    at_most(docs, MAX_SPHERES, "[[sphere]] tables")?;
    let sphere = |s: &SphereDoc| {
        Ok(Sphere {
            center: vec3(&s.center, "center")?,
            radius: positive(&s.radius, "radius")?,
            material: names.resolve(&s.material)?,
        })
    };
    docs.iter().map(|s| sphere(s.get_ref())).collect()
}

fn cones(docs: &[Spanned<ConeDoc>], names: &Names) -> Res<Vec<Cone>> {
    at_most(docs, MAX_CONES, "[[cone]] tables")?;
    let cone = |c: &ConeDoc, table: &Span| {
        let radius = |v: &Number, key| {
            let r = number(v, key)?;
            if r >= 0.0 {
                Ok(r)
            } else {
                err(v.span(), format!("`{key}` must be at least 0, not {r}"))
            }
        };
        let (base_radius, apex_radius) = match (&c.radius, &c.base_radius, &c.apex_radius) {
            (Some(r), None, None) => (radius(r, "radius")?, radius(r, "radius")?),
            (None, Some(b), Some(a)) => (radius(b, "base_radius")?, radius(a, "apex_radius")?),
            (Some(r), _, _) => {
                return err(
                    r.span(),
                    "a cone takes either `radius` (a cylinder) or `base_radius` and `apex_radius`",
                )
            }
            _ => {
                return err(
                    table.clone(),
                    "a cone needs `radius` (a cylinder) or `base_radius` and `apex_radius`",
                )
            }
        };
        Ok(Cone {
            base: vec3(&c.base, "base")?,
            base_radius,
            apex: vec3(&c.apex, "apex")?,
            apex_radius,
            material: names.resolve(&c.material)?,
        })
    };
    docs.iter().map(|c| cone(c.get_ref(), &c.span())).collect()
}

fn meshes(docs: &[Spanned<MeshDoc>], names: &Names) -> Res<Vec<Mesh>> {
    let (mut triangles, mut vertices) = (0, 0);
    let mut out = Vec::with_capacity(docs.len());
    for doc in docs {
        let mesh = mesh(doc.get_ref(), &doc.span(), names)?;
        triangles += mesh.indices.len();
        vertices += mesh.positions.len();
        if triangles > MAX_TRIANGLES || vertices > MAX_VERTICES {
            return err(
                doc.span(),
                format!(
                    "the meshes exceed the limit of {MAX_TRIANGLES} triangles or {MAX_VERTICES} vertices \
                     in total"
                ),
            );
        }
        out.push(mesh);
    }
    Ok(out)
}

fn mesh(m: &MeshDoc, table: &Span, names: &Names) -> Res<Mesh> {
    let material = names.resolve(&m.material)?;
    let (what, allowed): (&str, &[&str]) = match m.shape {
        None => ("an inline mesh (no `shape`)", &["positions", "indices", "normals", "uvs"]),
        Some(Shape::Quad) => ("a quad", &["center", "size", "corners", "uvs"]),
        Some(Shape::Box) => ("a box", &["min", "max"]),
        Some(Shape::Icosphere) => ("an icosphere", &["center", "radius", "subdivisions"]),
    };
    #[rustfmt::skip]
    let given = [
        ("positions", span_of(&m.positions)), ("indices", span_of(&m.indices)), ("normals", span_of(&m.normals)),
        ("uvs", span_of(&m.uvs)),
        ("center", span_of(&m.center)), ("size", span_of(&m.size)), ("corners", span_of(&m.corners)),
        ("min", span_of(&m.min)), ("max", span_of(&m.max)), ("radius", span_of(&m.radius)),
        ("subdivisions", span_of(&m.subdivisions)),
    ];
    only_keys(&given, allowed, what)?;
    let mut geometry = match m.shape {
        None => inline(m, what, table)?,
        Some(Shape::Quad) => quad(m, table)?,
        Some(Shape::Box) => cuboid(m, what, table)?,
        Some(Shape::Icosphere) => icosphere(m, what, table)?,
    };
    let vertices = match m.shape {
        None => "`positions` has",
        _ => "a quad has",
    };
    let uvs = m.uvs.as_ref().map(|u| uvs(u, geometry.positions.len(), vertices)).transpose()?;
    geometry.transform(scale(&m.scale)?, vec3_or(&m.translate, "translate", DVec3::ZERO)?);
    // Texture coordinates belong to the vertices and are not moved by `scale` and `translate`.
    Ok(Mesh { uvs, ..geometry.into_mesh(material) })
}

/// One texture coordinate `[u, v]` per vertex (`vertices`: "`positions` has", "a quad has").
fn uvs(u: &Spanned<Vec<Numbers>>, vertex_count: usize, vertices: &str) -> Res<Vec<DVec2>> {
    if u.get_ref().len() != vertex_count {
        let count = u.get_ref().len();
        return err(
            u.span(),
            format!("`uvs` has {count} entries but {vertices} {vertex_count} vertices; give one [u, v] per vertex"),
        );
    }
    u.get_ref().iter().map(|v| numbers::<2>(v, "uvs").map(DVec2::from_array)).collect()
}

fn inline(m: &MeshDoc, what: &str, table: &Span) -> Res<Geometry> {
    let positions = required(&m.positions, "positions", what, table)?;
    let positions: Vec<DVec3> =
        positions.get_ref().iter().map(|p| vec3(p, "positions")).collect::<Res<_>>()?;
    let indices = required(&m.indices, "indices", what, table)?;
    let indices = indices.get_ref().iter().map(|t| triangle(t, positions.len())).collect::<Res<_>>()?;
    let normals = m.normals.as_ref().map(|n| normals(n, positions.len())).transpose()?;
    Ok(Geometry { positions, normals, indices })
}

fn triangle(t: &Spanned<Vec<i64>>, vertex_count: usize) -> Res<[u32; 3]> {
    let Ok(corners) = <[i64; 3]>::try_from(t.get_ref().as_slice()) else {
        return err(t.span(), format!("a triangle needs 3 vertex indices, found {}", t.get_ref().len()));
    };
    let index = |k: i64| {
        u32::try_from(k).ok().filter(|&k| (k as usize) < vertex_count).ok_or_else(|| {
            let message = format!(
                "vertex index {k} is out of range: `positions` has {vertex_count} vertices, numbered from 0"
            );
            located(t.span(), message)
        })
    };
    Ok([index(corners[0])?, index(corners[1])?, index(corners[2])?])
}

/// One normal per vertex, made unit length (the scene model's contract). A normal that already
/// is, to rounding, is kept as written: normalising again could change its last bits, and a
/// scene written by `irt convert` must load back bit for bit.
fn normals(n: &Spanned<Vec<Numbers>>, vertex_count: usize) -> Res<Vec<DVec3>> {
    if n.get_ref().len() != vertex_count {
        let count = n.get_ref().len();
        return err(
            n.span(),
            format!("`normals` has {count} entries but `positions` has {vertex_count}; give one per vertex"),
        );
    }
    let unit = |v: &Numbers| {
        let n = vec3(v, "normals")?;
        super::unit_normal(n).ok_or_else(|| located(v.span(), "a normal must not be zero"))
    };
    n.get_ref().iter().map(unit).collect()
}

fn quad(m: &MeshDoc, table: &Span) -> Res<Geometry> {
    let Some(corners) = &m.corners else {
        let what = "a quad without `corners`";
        let center = vec3(required(&m.center, "center", what, table)?, "center")?;
        let size = required(&m.size, "size", what, table)?;
        let [sx, sz] = numbers::<2>(size, "size")?;
        if !(sx > 0.0 && sz > 0.0) {
            return err(size.span(), "`size` = [x extent, z extent] must be greater than 0");
        }
        return Ok(shapes::quad(center, [sx, sz]));
    };
    if let Some(extra) = m.center.as_ref().or(m.size.as_ref()) {
        return err(extra.span(), "a quad takes either `corners` or `center` and `size`, not both");
    }
    let points: Vec<DVec3> = corners.get_ref().iter().map(|c| vec3(c, "corners")).collect::<Res<_>>()?;
    let Ok(points) = <[DVec3; 4]>::try_from(points) else {
        return err(corners.span(), format!("`corners` needs 4 points, found {}", corners.get_ref().len()));
    };
    Ok(shapes::quad_corners(points))
}

fn cuboid(m: &MeshDoc, what: &str, table: &Span) -> Res<Geometry> {
    let min = vec3(required(&m.min, "min", what, table)?, "min")?;
    let max_doc = required(&m.max, "max", what, table)?;
    let max = vec3(max_doc, "max")?;
    if !max.cmpgt(min).all() {
        return err(max_doc.span(), "`max` must be greater than `min` on every axis");
    }
    Ok(shapes::cuboid(min, max))
}

fn icosphere(m: &MeshDoc, what: &str, table: &Span) -> Res<Geometry> {
    let center = vec3(required(&m.center, "center", what, table)?, "center")?;
    let radius = positive(required(&m.radius, "radius", what, table)?, "radius")?;
    let subdivisions = match &m.subdivisions {
        None => DEFAULT_ICOSPHERE_SUBDIVISIONS,
        Some(s) if *s.get_ref() > MAX_ICOSPHERE_SUBDIVISIONS => {
            return err(s.span(), format!("`subdivisions` must be at most {MAX_ICOSPHERE_SUBDIVISIONS}"));
        }
        Some(s) => *s.get_ref(),
    };
    Ok(shapes::icosphere(center, radius, subdivisions))
}

/// Per-axis scale, positive: zero flattens a mesh and a negative scale mirrors it, which would
/// turn its winding, and so its outside, inside out.
fn scale(s: &Option<Spanned<Scale>>) -> Res<DVec3> {
    let Some(s) = s else { return Ok(DVec3::ONE) };
    let values = match s.get_ref() {
        Scale::Uniform(x) => vec![*x; 3],
        Scale::Axes(axes) => axes.clone(),
    };
    let scale = DVec3::from_array(floats::<3>(&values, s.span(), "scale")?);
    if scale.min_element() > 0.0 {
        Ok(scale)
    } else {
        err(s.span(), "`scale` must be greater than 0 (mirroring would turn the mesh inside out)")
    }
}

/// The table a [`Scene::validate`] message is about. Those messages start with the item they
/// concern ("camera.fov …", "light 2 color …", "sphere 0 radius …"), which maps back to a table.
fn blame(doc: &Doc, message: &str) -> Option<Span> {
    let mut words = message.split([' ', '.']);
    let head = words.next()?;
    match head {
        "camera" => Some(doc.camera.span()),
        "ambient" => doc.ambient.as_ref().map(Spanned::span),
        "background" => span_of(&doc.background),
        "trace" => doc.trace.as_ref().map(Spanned::span),
        "light" => nth_span(&doc.light, words.next()),
        "sphere" => nth_span(&doc.sphere, words.next()),
        "mesh" => nth_span(&doc.mesh, words.next()),
        "cone" => nth_span(&doc.cone, words.next()),
        _ => None,
    }
}

/// The span of table number `index` (a decimal word), if there is one.
fn nth_span<T>(tables: &[Spanned<T>], index: Option<&str>) -> Option<Span> {
    tables.get(index?.parse::<usize>().ok()?).map(Spanned::span)
}
