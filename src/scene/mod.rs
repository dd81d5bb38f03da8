//! What the user describes: camera, lights, ambient, materials and primitives.
//!
//! Everything here is f64 and format-agnostic. Loaders (`crate::io`) produce a [`Scene`],
//! [`Scene::validate`] rejects what no renderer could draw, and both the GPU path and the CPU
//! reference read it. Units are arbitrary; colours are linear RGB.

mod builtin;
pub mod colour_map;
mod motion;
pub mod particles;
pub mod patch;
mod shadows;
mod shells;
mod soft;
mod texture;
pub mod transfer;
pub mod volume;

pub use builtin::default_scene;
use glam::{DVec2, DVec3};
pub use motion::{
    euler_degrees, Animated, Channel, Interpolation, Keyable, Motion, Rotation, Stage, Target, Trs,
};
pub use shadows::{bundle_samples, pixel_hash, Combine, Falloff, ShadowMode, MAX_BUNDLE, SHADOW_MODE_SYNTAX};
pub use shells::{
    light_shells, scene_shells, shell_cell, shells_walk_grid, LightShells, ShellObject, ShellShape, Slabs,
    SHELL_CELL_GAIN, SHELL_CELL_LOAD, SHELL_CELL_RES_MAX, SHELL_CELL_RES_MIN, SHELL_DIRECT_TRIANGLES,
};
pub use soft::{choose_soft, pilot, Estimate, ShadowSetting, SoftChoice, SOFT_COST_BUDGET};
pub use texture::{Filter, Texture, Wrap, MAX_TEXTURES, MAX_TEXTURE_PIXELS, MAX_TOTAL_TEXTURE_PIXELS};

/// Largest image side we accept; larger is refused before anything is allocated.
pub const MAX_IMAGE_SIDE: u32 = 16384;
/// Largest pixel count (64 Mpixel, 1 GiB of f32 RGBA).
pub const MAX_PIXELS: u64 = 1 << 26;
/// Lights are summed per shading point; the GPU keeps them in a fixed uniform array.
pub const MAX_LIGHTS: usize = 16;
/// Recursion depth limit (eye ray = depth 1, as in SPD's rules); also the GPU ray stack size.
pub const MAX_TRACE_DEPTH: u32 = 8;

#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    pub camera: Camera,
    pub lights: Vec<Light>,
    pub ambient: Ambient,
    /// Radiance of rays that leave the scene.
    pub background: DVec3,
    pub materials: Vec<Material>,
    pub spheres: Vec<Sphere>,
    pub meshes: Vec<Mesh>,
    pub cones: Vec<Cone>,
    /// Base-colour textures, referred to by index from materials.
    pub textures: Vec<Texture>,
    pub trace: TraceSettings,
    /// Objects that move over time; the tracers render [`Scene::at`] a time (empty: a still).
    pub motions: Vec<Animated>,
    /// The particle files whose spheres are among `spheres` (what `irt convert` writes by
    /// reference and the HUD's colour bar shows).
    pub particles: Vec<particles::Particles>,
    /// Sampled volumes drawn as isosurfaces (PAPER.md §10), at most [`volume::MAX_VOLUMES`].
    pub volumes: Vec<volume::Volume>,
    /// Spline surfaces traced directly (PAPER.md §8): NURBS and Bezier patches.
    pub patches: Vec<patch::Patch>,
}

/// Pinhole camera. Rays go through pixel centres; `vfov_deg` is the full vertical angle
/// between the top and bottom image edges.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    pub eye: DVec3,
    pub look_at: DVec3,
    pub up: DVec3,
    pub vfov_deg: f64,
    pub width: u32,
    pub height: u32,
}

/// Orthonormal camera frame scaled to the image plane at distance 1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraBasis {
    /// Right, scaled by the half-width of the image plane.
    pub u: DVec3,
    /// Up, scaled by the half-height of the image plane.
    pub v: DVec3,
    /// Forward, unit length.
    pub w: DVec3,
}

impl Camera {
    pub fn basis(&self) -> CameraBasis {
        let w = (self.look_at - self.eye).normalize();
        let u = w.cross(self.up).normalize();
        let v = u.cross(w);
        let half_h = (self.vfov_deg.to_radians() * 0.5).tan();
        let half_w = half_h * self.width as f64 / self.height as f64;
        CameraBasis { u: u * half_w, v: v * half_h, w }
    }

    /// Unnormalised direction of the ray through image position (`px`, `py`) in pixels,
    /// (0, 0) the top-left corner of the image, (width, height) the bottom-right.
    pub fn direction(&self, b: &CameraBasis, px: f64, py: f64) -> DVec3 {
        let sx = 2.0 * px / self.width as f64 - 1.0;
        let sy = 1.0 - 2.0 * py / self.height as f64;
        b.w + sx * b.u + sy * b.v
    }
}

/// A spherical light; `radius == 0` is a point light. `color` is the intensity l_e per channel.
#[derive(Clone, Debug, PartialEq)]
pub struct Light {
    pub position: DVec3,
    pub color: DVec3,
    pub radius: f64,
}

/// The paper's two-colour ambient: `sky` (A) faces `up`, `ground` (B) faces away from it.
#[derive(Clone, Debug, PartialEq)]
pub struct Ambient {
    pub sky: DVec3,
    pub ground: DVec3,
    pub up: DVec3,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    pub kind: MaterialKind,
    /// Index into `Scene::textures`: the kind's colour is multiplied by this texture at the hit's
    /// texture coordinates (a dielectric has no colour to multiply). Spheres are mapped by
    /// longitude and latitude about +y, cones by the angle around and the position along their
    /// axis (docs/scene-format.md); a mesh without `uvs` reads the texture at (0, 0).
    pub texture: Option<u32>,
}

impl Material {
    /// An untextured material.
    pub fn new(name: impl Into<String>, kind: MaterialKind) -> Self {
        Material { name: name.into(), kind, texture: None }
    }
}

/// The paper's four materials (PAPER.md §4). Highlights use Blinn–Phong (n̂·ĥ)^N with the
/// Schlick reflectance k_s as k_h (see docs/shading.md).
#[derive(Clone, Debug, PartialEq)]
pub enum MaterialKind {
    /// k_d = `color`; no highlight, reflection or transmission.
    Diffuse { color: DVec3 },
    /// k_s = k_h = Schlick with R0 = `color` per channel.
    Metal { color: DVec3, exponent: f64 },
    /// Glass/water with index of refraction `eta`; k_s Schlick, k_t = 1 - k_s.
    Dielectric { eta: f64, exponent: f64 },
    /// Diffuse `color` under a clear coat of index `eta`.
    Polished { color: DVec3, eta: f64, exponent: f64 },
}

#[derive(Clone, Debug, PartialEq)]
pub struct Sphere {
    pub center: DVec3,
    pub radius: f64,
    pub material: u32,
}

/// An open cone (NFF's `c`): the lateral surface between the disc of `base_radius` around `base`
/// and the disc of `apex_radius` around `apex`, both perpendicular to the axis `base → apex`, with
/// no caps. Equal radii make a cylinder, different ones a truncated cone, a zero radius a pointed
/// cone.
#[derive(Clone, Debug, PartialEq)]
pub struct Cone {
    pub base: DVec3,
    pub base_radius: f64,
    pub apex: DVec3,
    pub apex_radius: f64,
    pub material: u32,
}

/// Indexed triangle mesh; `normals` and `uvs`, when present, have one element per position and
/// are interpolated across each triangle (normals for shading, uvs for textures).
#[derive(Clone, Debug, PartialEq)]
pub struct Mesh {
    pub positions: Vec<DVec3>,
    pub normals: Option<Vec<DVec3>>,
    /// Texture coordinates, one per position (see [`Texture`]).
    pub uvs: Option<Vec<DVec2>>,
    pub indices: Vec<[u32; 3]>,
    pub material: u32,
}

/// One triangle of a mesh, resolved to positions (the form the accelerator and tracers use).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Triangle {
    pub p: [DVec3; 3],
    pub n: Option<[DVec3; 3]>,
    pub uv: Option<[DVec2; 3]>,
    pub material: u32,
}

#[derive(Clone, Debug, PartialEq)]
pub struct TraceSettings {
    /// Maximum ray depth, eye ray = 1 (SPD's rule uses 5).
    pub max_depth: u32,
    /// A reflected/refracted ray is traced only if its weight (max channel) exceeds this.
    pub weight_cutoff: f64,
    /// How light visibility is found (docs/shadows.md).
    pub shadows: ShadowMode,
    /// The scene file asked for `soft`: the mode is to be picked for the scene as it will be
    /// traced, after any overrides (`ShadowSetting::Soft`, resolved by the command that loads
    /// the scene, with `ShadowSetting::resolve`); until then `shadows` is hard.
    pub soft: bool,
}

impl Default for TraceSettings {
    fn default() -> Self {
        TraceSettings { max_depth: 5, weight_cutoff: 1.0 / 512.0, shadows: ShadowMode::Hard, soft: false }
    }
}

/// A scene that cannot be rendered, with what is wrong in words a user can act on.
#[derive(Debug, thiserror::Error, PartialEq)]
#[error("{0}")]
pub struct InvalidScene(pub String);

impl Scene {
    pub fn triangle_count(&self) -> usize {
        self.meshes.iter().map(|m| m.indices.len()).sum()
    }

    pub fn primitive_count(&self) -> usize {
        self.spheres.len()
            + self.triangle_count()
            + self.cones.len()
            + self.volumes.len()
            + self.patches.len()
    }

    /// All mesh triangles in mesh order; triangle `i` here is triangle `i` everywhere.
    pub fn triangles(&self) -> impl Iterator<Item = Triangle> + '_ {
        self.meshes.iter().flat_map(|m| {
            m.indices.iter().map(move |t| Triangle {
                p: t.map(|i| m.positions[i as usize]),
                n: m.normals.as_ref().map(|n| t.map(|i| n[i as usize])),
                uv: m.uvs.as_ref().map(|uv| t.map(|i| uv[i as usize])),
                material: m.material,
            })
        })
    }

    /// The same scene scaled by `scale` about the origin, then moved by `offset`: every position,
    /// radius and camera point (light intensities and the ambient are unchanged, so a valid
    /// scene renders the same picture). The stability suite's way of making extreme scenes.
    pub fn transformed(&self, scale: f64, offset: DVec3) -> Scene {
        let p = |v: DVec3| v * scale + offset;
        let mut s = self.clone();
        s.camera.eye = p(s.camera.eye);
        s.camera.look_at = p(s.camera.look_at);
        for l in &mut s.lights {
            l.position = p(l.position);
            l.radius *= scale;
        }
        for sp in &mut s.spheres {
            sp.center = p(sp.center);
            sp.radius *= scale;
        }
        for m in &mut s.meshes {
            m.positions.iter_mut().for_each(|v| *v = p(*v));
        }
        for c in &mut s.cones {
            (c.base, c.apex) = (p(c.base), p(c.apex));
            c.base_radius *= scale;
            c.apex_radius *= scale;
        }
        s
    }

    /// Checks everything a loader might let through: finite numbers, positive sizes, indices in
    /// range, image size within limits. Loaders call it; so does anyone building a Scene by hand.
    pub fn validate(&self) -> Result<(), InvalidScene> {
        let bad = |msg: String| Err(InvalidScene(msg));
        let c = &self.camera;
        if c.width == 0 || c.height == 0 {
            return bad(format!("camera resolution {}x{} must be at least 1x1", c.width, c.height));
        }
        if c.width > MAX_IMAGE_SIDE || c.height > MAX_IMAGE_SIDE {
            return bad(format!(
                "camera resolution {}x{} exceeds the limit of {MAX_IMAGE_SIDE} per side",
                c.width, c.height
            ));
        }
        if c.width as u64 * c.height as u64 > MAX_PIXELS {
            return bad(format!("camera resolution {}x{} exceeds {MAX_PIXELS} pixels", c.width, c.height));
        }
        finite3("camera.eye", c.eye)?;
        finite3("camera.look_at", c.look_at)?;
        finite3("camera.up", c.up)?;
        if !(c.vfov_deg.is_finite() && c.vfov_deg > 0.0 && c.vfov_deg < 180.0) {
            return bad(format!("camera.fov {} must be between 0 and 180 degrees", c.vfov_deg));
        }
        let w = c.look_at - c.eye;
        if w.length_squared() == 0.0 {
            return bad("camera.look_at equals camera.eye: the view direction is undefined".into());
        }
        if w.cross(c.up).length_squared() <= 1e-24 * w.length_squared() * c.up.length_squared() {
            return bad("camera.up is zero or parallel to the view direction".into());
        }
        if self.lights.len() > MAX_LIGHTS {
            return bad(format!("{} lights given; at most {MAX_LIGHTS} are supported", self.lights.len()));
        }
        if self.volumes.len() > volume::MAX_VOLUMES {
            return bad(format!(
                "{} volumes given; at most {} are supported",
                self.volumes.len(),
                volume::MAX_VOLUMES
            ));
        }
        for (i, v) in self.volumes.iter().enumerate() {
            v.check(self.materials.len()).or_else(|why| bad(format!("volume {i}: {why}")))?;
        }
        for (i, p) in self.patches.iter().enumerate() {
            p.check(self.materials.len()).or_else(|why| bad(format!("patch {i}: {why}")))?;
        }
        if let Err(why) = patch::leaves::check_size(&self.patches) {
            return bad(why);
        }
        for (i, l) in self.lights.iter().enumerate() {
            finite3(format_args!("light {i} position"), l.position)?;
            nonneg3(format_args!("light {i} color"), l.color)?;
            if !(l.radius.is_finite() && l.radius >= 0.0) {
                return bad(format!("light {i} radius {} must be finite and >= 0", l.radius));
            }
        }
        nonneg3("ambient.sky", self.ambient.sky)?;
        nonneg3("ambient.ground", self.ambient.ground)?;
        finite3("ambient.up", self.ambient.up)?;
        if self.ambient.up.length_squared() == 0.0 {
            return bad("ambient.up must not be the zero vector".into());
        }
        nonneg3("background", self.background)?;
        self.validate_textures()?;
        for m in &self.materials {
            m.validate()?;
            if let Some(t) = m.texture.filter(|&t| t as usize >= self.textures.len()) {
                return bad(format!(
                    "material '{}' uses texture index {t} but only {} exist",
                    m.name,
                    self.textures.len()
                ));
            }
        }
        let nmat = self.materials.len() as u32;
        for (i, s) in self.spheres.iter().enumerate() {
            finite3(format_args!("sphere {i} center"), s.center)?;
            if !(s.radius.is_finite() && s.radius > 0.0) {
                return bad(format!("sphere {i} radius {} must be finite and > 0", s.radius));
            }
            if s.material >= nmat {
                return bad(format!("sphere {i} uses material index {} but only {nmat} exist", s.material));
            }
        }
        for (i, m) in self.meshes.iter().enumerate() {
            if m.material >= nmat {
                return bad(format!("mesh {i} uses material index {} but only {nmat} exist", m.material));
            }
            for (j, p) in m.positions.iter().enumerate() {
                finite3(format_args!("mesh {i} vertex {j}"), *p)?;
            }
            if let Some(n) = &m.normals {
                if n.len() != m.positions.len() {
                    return bad(format!(
                        "mesh {i} has {} normals for {} vertices",
                        n.len(),
                        m.positions.len()
                    ));
                }
                for (j, v) in n.iter().enumerate() {
                    finite3(format_args!("mesh {i} normal {j}"), *v)?;
                }
            }
            if let Some(uv) = &m.uvs {
                if uv.len() != m.positions.len() {
                    return bad(format!("mesh {i} has {} uvs for {} vertices", uv.len(), m.positions.len()));
                }
                if let Some(j) = uv.iter().position(|v| !v.is_finite()) {
                    return bad(format!("mesh {i} uv {j} ({}, {}) is not finite", uv[j].x, uv[j].y));
                }
            }
            let nv = m.positions.len() as u32;
            for (j, t) in m.indices.iter().enumerate() {
                if let Some(k) = t.iter().find(|&&k| k >= nv) {
                    return bad(format!("mesh {i} triangle {j} refers to vertex {k} but only {nv} exist"));
                }
            }
        }
        for (i, c) in self.cones.iter().enumerate() {
            finite3(format_args!("cone {i} base"), c.base)?;
            finite3(format_args!("cone {i} apex"), c.apex)?;
            let (r0, r1) = (c.base_radius, c.apex_radius);
            if !(r0.is_finite() && r1.is_finite() && r0 >= 0.0 && r1 >= 0.0 && r0.max(r1) > 0.0) {
                return bad(format!("cone {i} radii {r0} and {r1} must be finite, >= 0 and not both 0"));
            }
            // The intersection divides by the height and by nothing else that can vanish.
            let h = c.apex.distance(c.base);
            if !(h > 0.0 && ((r1 - r0) / h).is_finite()) {
                return bad(format!("cone {i} has its base and apex at the same point: no axis"));
            }
            if c.material >= nmat {
                return bad(format!("cone {i} uses material index {} but only {nmat} exist", c.material));
            }
        }
        let t = &self.trace;
        if t.max_depth == 0 || t.max_depth > MAX_TRACE_DEPTH {
            return bad(format!("trace.max_depth {} must be between 1 and {MAX_TRACE_DEPTH}", t.max_depth));
        }
        if !(t.weight_cutoff.is_finite() && (0.0..1.0).contains(&t.weight_cutoff)) {
            return bad(format!("trace.weight_cutoff {} must be in [0, 1)", t.weight_cutoff));
        }
        self.validate_motions()
    }
}

impl Scene {
    fn validate_textures(&self) -> Result<(), InvalidScene> {
        let bad = |msg: String| Err(InvalidScene(msg));
        if self.textures.len() > MAX_TEXTURES {
            return bad(format!(
                "{} textures given; at most {MAX_TEXTURES} are supported",
                self.textures.len()
            ));
        }
        let mut total = 0u64;
        for t in &self.textures {
            let pixels = t.width as u64 * t.height as u64;
            if pixels == 0 || pixels > MAX_TEXTURE_PIXELS {
                return bad(format!(
                    "texture '{}' is {}x{} texels; textures must have 1 to {MAX_TEXTURE_PIXELS}",
                    t.name, t.width, t.height
                ));
            }
            if t.texels.len() as u64 != pixels {
                return bad(format!(
                    "texture '{}' has {} texels for {}x{}",
                    t.name,
                    t.texels.len(),
                    t.width,
                    t.height
                ));
            }
            total += pixels;
        }
        if total > MAX_TOTAL_TEXTURE_PIXELS {
            return bad(format!(
                "the textures have {total} texels together; at most {MAX_TOTAL_TEXTURE_PIXELS} are supported"
            ));
        }
        Ok(())
    }
}

impl Material {
    pub fn validate(&self) -> Result<(), InvalidScene> {
        let who = format!("material '{}'", self.name);
        let exponent_ok = |n: f64| {
            if n.is_finite() && n >= 0.0 {
                Ok(())
            } else {
                Err(InvalidScene(format!("{who}: exponent {n} must be finite and >= 0")))
            }
        };
        let eta_ok = |eta: f64| {
            if eta.is_finite() && eta > 0.0 {
                Ok(())
            } else {
                Err(InvalidScene(format!("{who}: eta {eta} must be finite and > 0")))
            }
        };
        match &self.kind {
            MaterialKind::Diffuse { color } => unit3(&who, *color),
            MaterialKind::Metal { color, exponent } => {
                unit3(&who, *color)?;
                exponent_ok(*exponent)
            }
            MaterialKind::Dielectric { eta, exponent } => {
                eta_ok(*eta)?;
                exponent_ok(*exponent)
            }
            MaterialKind::Polished { color, eta, exponent } => {
                unit3(&who, *color)?;
                eta_ok(*eta)?;
                exponent_ok(*exponent)
            }
        }
    }
}

/// `what` is formatted only for the error: validation runs over every vertex of a large mesh.
fn finite3(what: impl std::fmt::Display, v: DVec3) -> Result<(), InvalidScene> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(InvalidScene(format!("{what} ({}, {}, {}) is not finite", v.x, v.y, v.z)))
    }
}

fn nonneg3(what: impl std::fmt::Display + Copy, v: DVec3) -> Result<(), InvalidScene> {
    finite3(what, v)?;
    if v.min_element() < 0.0 {
        return Err(InvalidScene(format!("{what} ({}, {}, {}) must not be negative", v.x, v.y, v.z)));
    }
    Ok(())
}

/// Reflectances are fractions: each channel in [0, 1].
fn unit3(who: &str, v: DVec3) -> Result<(), InvalidScene> {
    nonneg3(format_args!("{who}: color"), v)?;
    if v.max_element() > 1.0 {
        return Err(InvalidScene(format!(
            "{who}: color ({}, {}, {}) must be in [0, 1] per channel",
            v.x, v.y, v.z
        )));
    }
    Ok(())
}
