//! Eric Haines' Neutral File Format (NFF), the format of the Standard Procedural Databases (SPD).
//! docs/nff.md says what each command becomes in a [`Scene`].
//!
//! The parser is token-based, not line-based: SPD writes a cone (`c`) on one line where the
//! format's description uses three, and nothing in the format depends on line breaks. A command
//! is a word and its arguments are numbers, so an optional argument (a light's colour) is
//! recognised by being a number; `#` starts a comment that runs to the end of the line.
//! Every count is checked against its limit before anything is allocated for it.

use super::shapes::{triangulate, MAX_POLYGON_VERTICES};
use super::{LoadError, MAX_CONES, MAX_MATERIALS, MAX_SPHERES, MAX_TRIANGLES, MAX_VERTICES};
use crate::scene::{
    Ambient, Camera, Cone, Light, Material, MaterialKind, Mesh, Scene, ShadowMode, Sphere, TraceSettings,
    MAX_IMAGE_SIDE, MAX_LIGHTS,
};
use glam::DVec3;
use std::collections::HashMap;

/// Above this Kd/Ks ratio a reflective opaque surface keeps its diffuse part (polished);
/// below it, it is a mirror-like metal (docs/nff.md).
pub const METAL_KD_OVER_KS: f64 = 0.1;
/// Largest Ks turned into a clear coat: `eta` grows without bound as Ks approaches 1.
pub const MAX_COAT_KS: f64 = 0.98;
pub const COMMANDS: &str = "v, b, l, f, c, s, p, pp";
/// Bytes an NFF file may have: what the largest scene irt takes needs as text. NFF is parsed
/// command by command into the scene, with no document tree in between, so unlike TOML it may
/// be as large as its counts allow: a triangle (`p 3` and three vertex lines) takes about 100
/// bytes, a sphere about 42 (SPD's balls at size 7, 5.4M spheres, is 228 MB).
pub const MAX_FILE_BYTES: u64 = MAX_TRIANGLES as u64 * 128;

/// Parses and validates an NFF scene; `origin` names the source in error messages.
pub fn parse_str(src: &str, origin: &str) -> Result<Scene, LoadError> {
    let mut p = Parser::new(src, origin);
    p.run()?;
    p.finish()
}

/// SPD's testing rules (PAPER.md §7) as far as they are trace settings: ray depth at most 5
/// (the eye ray is depth 1), a reflection ray at every reflective hit however small its weight
/// (no weight cut-off), point lights with hard shadows. The renderer's part, eye rays through
/// the pixel corners, is `gpu::RenderOptions::corner_rays`.
pub fn apply_spd_rules(scene: &mut Scene) {
    scene.trace = TraceSettings { max_depth: 5, weight_cutoff: 0.0, shadows: ShadowMode::Hard, soft: false };
    scene.lights.iter_mut().for_each(|l| l.radius = 0.0);
}

/// The vertical field of view (image edge to edge, irt's convention) for NFF's `angle`, which
/// spans the centres of the top and bottom pixel rows of an image `height` pixels high: their
/// distance is `height - 1` pixels, the edges' `height`.
pub fn vfov_from_nff_angle(angle_deg: f64, height: u32) -> f64 {
    if height <= 1 {
        return angle_deg;
    }
    let h = height as f64;
    2.0 * ((angle_deg.to_radians() * 0.5).tan() * h / (h - 1.0)).atan().to_degrees()
}

/// The material an `f` line describes (docs/nff.md has the table and the reasons):
/// transmissive → dielectric; no specular part → diffuse; a specular part with a diffuse part
/// under a tenth of it → metal; both → polished, its coat as reflective as Ks at normal incidence.
pub fn material_kind(rgb: DVec3, kd: f64, ks: f64, shine: f64, t: f64, ior: f64) -> MaterialKind {
    if t > 0.0 {
        MaterialKind::Dielectric { eta: ior, exponent: shine }
    } else if ks == 0.0 {
        MaterialKind::Diffuse { color: kd * rgb }
    } else if kd < METAL_KD_OVER_KS * ks {
        MaterialKind::Metal { color: ks * rgb, exponent: shine }
    } else {
        MaterialKind::Polished { color: kd * rgb, eta: coat_eta(ks), exponent: shine }
    }
}

/// The index of a clear coat that reflects `ks` at normal incidence: Schlick's
/// R0 = ((eta - 1)/(eta + 1))² = Ks  ⇔  eta = (1 + √Ks)/(1 - √Ks), Ks capped at [`MAX_COAT_KS`].
pub fn coat_eta(ks: f64) -> f64 {
    let r = ks.clamp(0.0, MAX_COAT_KS).sqrt();
    (1.0 + r) / (1.0 - r)
}

#[derive(Clone, Copy)]
struct Token<'a> {
    text: &'a str,
    /// Byte offset in the source.
    at: usize,
}

struct Lexer<'a> {
    src: &'a str,
    pos: usize,
}

impl<'a> Lexer<'a> {
    fn next(&mut self) -> Option<Token<'a>> {
        let bytes = self.src.as_bytes();
        loop {
            while self.pos < bytes.len() && bytes[self.pos].is_ascii_whitespace() {
                self.pos += 1;
            }
            if self.pos < bytes.len() && bytes[self.pos] == b'#' {
                while self.pos < bytes.len() && bytes[self.pos] != b'\n' {
                    self.pos += 1;
                }
                continue;
            }
            break;
        }
        if self.pos >= bytes.len() {
            return None;
        }
        let at = self.pos;
        while self.pos < bytes.len() && !bytes[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        Some(Token { text: &self.src[at..self.pos], at })
    }

    fn peek(&self) -> Option<Token<'a>> {
        Lexer { src: self.src, pos: self.pos }.next()
    }
}

fn is_number(t: &Token) -> bool {
    t.text.parse::<f64>().is_ok()
}

/// Where each scene item came from, so that errors found after parsing point at it.
#[derive(Default)]
struct Places {
    viewpoint: Option<usize>,
    background: Option<usize>,
    lights: Vec<usize>,
}

struct Parser<'a> {
    src: &'a str,
    origin: &'a str,
    lex: Lexer<'a>,
    places: Places,
    camera: Option<Camera>,
    up: DVec3,
    background: DVec3,
    /// Light positions and colours as given (`None`: no colour, SPD's default intensity).
    lights: Vec<(DVec3, Option<DVec3>)>,
    materials: Vec<Material>,
    /// The numbers of each distinct `f` line → material index.
    material_index: HashMap<[u64; 8], u32>,
    /// The material of what follows, once an `f` has been seen.
    current: Option<u32>,
    spheres: Vec<Sphere>,
    cones: Vec<Cone>,
    meshes: Vec<Mesh>,
    /// (material, has vertex normals) → index into `meshes`.
    mesh_of: HashMap<(u32, bool), usize>,
    vertices: usize,
    triangles: usize,
    degenerate_polygons: usize,
}

impl<'a> Parser<'a> {
    fn new(src: &'a str, origin: &'a str) -> Self {
        Parser {
            src,
            origin,
            lex: Lexer { src, pos: 0 },
            places: Places::default(),
            camera: None,
            up: DVec3::Z,
            background: DVec3::ZERO,
            lights: Vec::new(),
            materials: Vec::new(),
            material_index: HashMap::new(),
            current: None,
            spheres: Vec::new(),
            cones: Vec::new(),
            meshes: Vec::new(),
            mesh_of: HashMap::new(),
            vertices: 0,
            triangles: 0,
            degenerate_polygons: 0,
        }
    }

    fn error(&self, at: usize, message: impl Into<String>) -> LoadError {
        LoadError::at(self.origin, self.src, at, message)
    }

    fn line_of(&self, at: usize) -> usize {
        super::line_column(self.src, at).0
    }

    fn token(&mut self, what: &str, cmd: Token) -> Result<Token<'a>, LoadError> {
        self.lex.next().ok_or_else(|| {
            let line = self.line_of(cmd.at);
            self.error(
                self.src.len(),
                format!("expected {what} for `{}` on line {line}, found the end of the file", cmd.text),
            )
        })
    }

    /// The next token as a finite number; `what` names it in messages.
    fn number(&mut self, what: &str, cmd: Token) -> Result<(f64, usize), LoadError> {
        let t = self.token(what, cmd)?;
        match t.text.parse::<f64>() {
            Ok(x) if x.is_finite() => Ok((x, t.at)),
            Ok(_) => Err(self.error(t.at, format!("{what} is `{}`; numbers must be finite", t.text))),
            Err(_) => Err(self
                .error(t.at, format!("expected {what} (a number) for `{}`, found `{}`", cmd.text, t.text))),
        }
    }

    /// A number in `[lo, hi]` (`hi` may be infinite).
    fn ranged(&mut self, what: &str, cmd: Token, lo: f64, hi: f64) -> Result<f64, LoadError> {
        let (x, at) = self.number(what, cmd)?;
        if x < lo || x > hi {
            let range = if hi.is_infinite() { format!("at least {lo}") } else { format!("{lo} to {hi}") };
            return Err(self.error(at, format!("{what} {x} is out of range: {range}")));
        }
        Ok(x)
    }

    fn vec3(&mut self, what: &str, cmd: Token) -> Result<DVec3, LoadError> {
        Ok(DVec3::new(self.number(what, cmd)?.0, self.number(what, cmd)?.0, self.number(what, cmd)?.0))
    }

    /// A colour: three numbers, each at least 0 (at most `max`).
    fn colour(&mut self, what: &str, cmd: Token, max: f64) -> Result<DVec3, LoadError> {
        let mut c = [0.0; 3];
        for x in &mut c {
            *x = self.ranged(what, cmd, 0.0, max)?;
        }
        Ok(DVec3::from_array(c))
    }

    /// A whole number in `[lo, hi]`.
    fn count(&mut self, what: &str, cmd: Token, lo: usize, hi: usize) -> Result<usize, LoadError> {
        let t = self.token(what, cmd)?;
        let bad = |m: String| Err(self.error(t.at, m));
        match t.text.parse::<f64>() {
            Err(_) => bad(format!("expected {what} (a whole number) for `{}`, found `{}`", cmd.text, t.text)),
            Ok(x) if x.fract() != 0.0 => bad(format!("{what} `{}` must be a whole number", t.text)),
            Ok(x) if !(x >= lo as f64 && x <= hi as f64) => {
                bad(format!("{what} {} is out of range: {lo} to {hi}", t.text))
            }
            Ok(x) => Ok(x as usize),
        }
    }

    fn keyword(&mut self, word: &str, cmd: Token) -> Result<(), LoadError> {
        let t = self.token(&format!("`{word}`"), cmd)?;
        if t.text == word {
            return Ok(());
        }
        Err(self.error(
            t.at,
            format!(
                "expected `{word}`, found `{}`: a viewpoint `v` is followed by from, at, up, angle, \
                 hither and resolution, in that order",
                t.text
            ),
        ))
    }

    /// Refuses a second `v` or `b`, naming the line of the first.
    fn once(&self, first: Option<usize>, cmd: Token) -> Result<(), LoadError> {
        match first {
            Some(at) => Err(self.error(
                cmd.at,
                format!("a second `{}`; the first is on line {}", cmd.text, self.line_of(at)),
            )),
            None => Ok(()),
        }
    }

    fn material_for(&self, cmd: Token) -> Result<u32, LoadError> {
        self.current.ok_or_else(|| {
            self.error(
                cmd.at,
                format!(
                    "`{}` comes before any surface `f`: NFF objects take the last `f` before them",
                    cmd.text
                ),
            )
        })
    }

    fn run(&mut self) -> Result<(), LoadError> {
        while let Some(cmd) = self.lex.next() {
            match cmd.text {
                "v" => self.viewpoint(cmd)?,
                "b" => {
                    self.once(self.places.background, cmd)?;
                    self.places.background = Some(cmd.at);
                    self.background = self.colour("background colour", cmd, f64::INFINITY)?;
                }
                "l" => self.light(cmd)?,
                "f" => self.surface(cmd)?,
                "s" => self.sphere(cmd)?,
                "c" => self.cone(cmd)?,
                "p" => self.polygon(cmd, false)?,
                "pp" => self.polygon(cmd, true)?,
                _ if is_number(&cmd) => {
                    return Err(self.error(
                        cmd.at,
                        format!("expected a command ({COMMANDS}), found the number `{}`: one number too many before it?", cmd.text),
                    ))
                }
                other => {
                    return Err(self.error(cmd.at, format!("unknown command `{other}`; NFF commands are {COMMANDS}")))
                }
            }
        }
        Ok(())
    }

    fn viewpoint(&mut self, cmd: Token) -> Result<(), LoadError> {
        self.once(self.places.viewpoint, cmd)?;
        self.places.viewpoint = Some(cmd.at);
        self.keyword("from", cmd)?;
        let eye = self.vec3("`from` coordinate", cmd)?;
        self.keyword("at", cmd)?;
        let look_at = self.vec3("`at` coordinate", cmd)?;
        self.keyword("up", cmd)?;
        let up = self.vec3("`up` coordinate", cmd)?;
        self.keyword("angle", cmd)?;
        let (angle, at) = self.number("`angle`", cmd)?;
        if !(angle > 0.0 && angle < 180.0) {
            return Err(self.error(at, format!("`angle` {angle} is out of range: between 0 and 180 degrees")));
        }
        self.keyword("hither", cmd)?;
        // irt has no near clipping plane; the value is checked and otherwise unused (docs/nff.md).
        self.ranged("`hither`", cmd, 0.0, f64::INFINITY)?;
        self.keyword("resolution", cmd)?;
        let side = MAX_IMAGE_SIDE as usize;
        let width = self.count("resolution width", cmd, 1, side)? as u32;
        let height = self.count("resolution height", cmd, 1, side)? as u32;
        self.up = up;
        let vfov_deg = vfov_from_nff_angle(angle, height);
        self.camera = Some(Camera { eye, look_at, up, vfov_deg, width, height });
        Ok(())
    }

    fn light(&mut self, cmd: Token) -> Result<(), LoadError> {
        if self.lights.len() == MAX_LIGHTS {
            return Err(self.error(cmd.at, format!("too many lights: at most {MAX_LIGHTS} are supported")));
        }
        let position = self.vec3("light position", cmd)?;
        let colour = match self.lex.peek() {
            Some(t) if is_number(&t) => Some(self.colour("light colour", cmd, f64::INFINITY)?),
            _ => None,
        };
        self.places.lights.push(cmd.at);
        self.lights.push((position, colour));
        Ok(())
    }

    fn surface(&mut self, cmd: Token) -> Result<(), LoadError> {
        let rgb = self.colour("surface colour", cmd, 1.0)?;
        let kd = self.ranged("Kd", cmd, 0.0, 1.0)?;
        let ks = self.ranged("Ks", cmd, 0.0, 1.0)?;
        let shine = self.ranged("Shine", cmd, 0.0, f64::INFINITY)?;
        let t = self.ranged("T", cmd, 0.0, 1.0)?;
        // SPD writes 0 for surfaces that transmit nothing; only a transmissive one needs it.
        let (ior, at) = self.number("index of refraction", cmd)?;
        if ior < 0.0 || (t > 0.0 && ior == 0.0) {
            return Err(self.error(
                at,
                format!("index of refraction {ior} is out of range: greater than 0 (or 0 when T is 0)"),
            ));
        }
        // Identical `f` lines (SPD repeats them) share one material.
        let key = [rgb.x, rgb.y, rgb.z, kd, ks, shine, t, ior].map(f64::to_bits);
        if let Some(&m) = self.material_index.get(&key) {
            self.current = Some(m);
            return Ok(());
        }
        if self.materials.len() == MAX_MATERIALS {
            return Err(self.error(cmd.at, format!("too many distinct surfaces: at most {MAX_MATERIALS}")));
        }
        let index = self.materials.len() as u32;
        let kind = material_kind(rgb, kd, ks, shine, t, ior);
        self.materials.push(Material { name: format!("f{}", index + 1), kind, texture: None });
        self.material_index.insert(key, index);
        self.current = Some(index);
        Ok(())
    }

    fn sphere(&mut self, cmd: Token) -> Result<(), LoadError> {
        let material = self.material_for(cmd)?;
        if self.spheres.len() == MAX_SPHERES {
            return Err(self.error(cmd.at, format!("too many spheres: at most {MAX_SPHERES}")));
        }
        let center = self.vec3("sphere centre", cmd)?;
        let (radius, at) = self.number("sphere radius", cmd)?;
        if radius <= 0.0 {
            return Err(self.error(at, format!("sphere radius {radius} is out of range: greater than 0")));
        }
        self.spheres.push(Sphere { center, radius, material });
        Ok(())
    }

    fn cone(&mut self, cmd: Token) -> Result<(), LoadError> {
        let material = self.material_for(cmd)?;
        if self.cones.len() == MAX_CONES {
            return Err(self.error(cmd.at, format!("too many cones: at most {MAX_CONES}")));
        }
        let base = self.vec3("cone base", cmd)?;
        let (r0, at0) = self.number("cone base radius", cmd)?;
        let apex = self.vec3("cone apex", cmd)?;
        let (r1, at1) = self.number("cone apex radius", cmd)?;
        // NFF: both radii negative means only the inside is meant to be seen. irt's surfaces
        // are seen from both sides, so that is the same cone.
        let (r0, r1) = if r0 < 0.0 && r1 < 0.0 { (-r0, -r1) } else { (r0, r1) };
        if r0 < 0.0 || r1 < 0.0 {
            let at = if r0 < 0.0 { at0 } else { at1 };
            return Err(self
                .error(at, "cone radii must both be at least 0, or both negative (NFF: seen from inside)"));
        }
        if r0 == 0.0 && r1 == 0.0 {
            return Err(self.error(cmd.at, "cone radii are both 0: the cone has no surface"));
        }
        let h = base.distance(apex);
        if !(h > 0.0 && ((r1 - r0) / h).is_finite()) {
            return Err(self.error(cmd.at, "cone base and apex are the same point: the cone has no axis"));
        }
        self.cones.push(Cone { base, base_radius: r0, apex, apex_radius: r1, material });
        Ok(())
    }

    fn polygon(&mut self, cmd: Token, with_normals: bool) -> Result<(), LoadError> {
        let material = self.material_for(cmd)?;
        let n = self.count("vertex count", cmd, 3, MAX_POLYGON_VERTICES)?;
        if self.vertices + n > MAX_VERTICES || self.triangles + n - 2 > MAX_TRIANGLES {
            return Err(self.error(
                cmd.at,
                format!("the polygons exceed the limit of {MAX_VERTICES} vertices or {MAX_TRIANGLES} triangles in total"),
            ));
        }
        let mut positions = Vec::with_capacity(n);
        let mut normals = Vec::with_capacity(if with_normals { n } else { 0 });
        for _ in 0..n {
            positions.push(self.vec3("polygon vertex coordinate", cmd)?);
            if with_normals {
                let at = self.lex.peek().map_or(self.src.len(), |t| t.at);
                let normal = self.vec3("vertex normal coordinate", cmd)?;
                normals.push(
                    normal
                        .try_normalize()
                        .ok_or_else(|| self.error(at, "a vertex normal must not be zero"))?,
                );
            }
        }
        let triangles = triangulate(&positions);
        if triangles.is_empty() {
            self.degenerate_polygons += 1;
            return Ok(());
        }
        let next = self.meshes.len();
        let m = *self.mesh_of.entry((material, with_normals)).or_insert(next);
        if m == next {
            let normals = with_normals.then(Vec::new);
            self.meshes.push(Mesh {
                positions: Vec::new(),
                normals,
                uvs: None,
                indices: Vec::new(),
                material,
            });
        }
        let mesh = &mut self.meshes[m];
        let first = mesh.positions.len() as u32;
        mesh.positions.extend(positions);
        if let Some(all) = &mut mesh.normals {
            all.extend(normals);
        }
        mesh.indices.extend(triangles.iter().map(|t| t.map(|i| first + i as u32)));
        self.vertices += n;
        self.triangles += triangles.len();
        Ok(())
    }

    fn finish(self) -> Result<Scene, LoadError> {
        let Some(camera) = self.camera else {
            return Err(LoadError::new(self.origin, "the file has no viewpoint: a `v` command is required"));
        };
        if self.degenerate_polygons > 0 {
            log::warn!("{}: skipped {} polygons without area", self.origin, self.degenerate_polygons);
        }
        // SPD's suggestion for lights without a colour: sqrt(n)/(2n) each, n lights in all.
        let n = self.lights.len() as f64;
        let default = DVec3::splat(n.sqrt() / (2.0 * n));
        let lights = self
            .lights
            .iter()
            .map(|&(position, colour)| Light { position, color: colour.unwrap_or(default), radius: 0.0 })
            .collect();
        let scene = Scene {
            camera,
            lights,
            // NFF has no ambient light; `up` is the camera's, should one be added.
            ambient: Ambient { sky: DVec3::ZERO, ground: DVec3::ZERO, up: self.up },
            background: self.background,
            materials: self.materials,
            spheres: self.spheres,
            meshes: self.meshes,
            cones: self.cones,
            textures: vec![],
            trace: TraceSettings::default(),
            motions: Vec::new(),
            particles: Vec::new(),
            volumes: Vec::new(),
            patches: Vec::new(),
        };
        // What is left to find is about the viewpoint (an `up` along the view, `at` on `from`,
        // too many pixels): point there.
        if let Err(e) = scene.validate() {
            let at = match e.0.split([' ', '.']).next() {
                Some("camera") => self.places.viewpoint,
                Some("ambient") => self.places.viewpoint,
                Some("light") => {
                    e.0.split(' ')
                        .nth(1)
                        .and_then(|i| i.parse::<usize>().ok())
                        .and_then(|i| self.places.lights.get(i).copied())
                }
                _ => None,
            };
            return Err(match at {
                Some(at) => LoadError::at(self.origin, self.src, at, e.0),
                None => LoadError::new(self.origin, e.0),
            });
        }
        if scene.primitive_count() == 0 {
            return Err(LoadError::new(
                self.origin,
                "the file has no objects: add spheres (`s`), cones (`c`) or polygons (`p`, `pp`)",
            ));
        }
        Ok(scene)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nff_angle_spans_pixel_centres() {
        // Two rows: the centres are half the image apart, so the edges are twice as far.
        let v = vfov_from_nff_angle(2.0 * 1f64.atan().to_degrees(), 2);
        assert!((v - 2.0 * 2f64.atan().to_degrees()).abs() < 1e-12, "{v}");
        assert_eq!(vfov_from_nff_angle(45.0, 1), 45.0);
        assert!(vfov_from_nff_angle(45.0, 512) > 45.0 && vfov_from_nff_angle(45.0, 512) < 45.1);
    }

    #[test]
    fn surfaces_map_to_materials() {
        let c = DVec3::new(1.0, 0.5, 0.25);
        assert_eq!(material_kind(c, 0.8, 0.0, 10.0, 0.0, 1.0), MaterialKind::Diffuse { color: 0.8 * c });
        assert_eq!(
            material_kind(c, 0.2, 0.1, 10.0, 0.8, 1.3),
            MaterialKind::Dielectric { eta: 1.3, exponent: 10.0 }
        );
        assert_eq!(
            material_kind(c, 0.05, 0.9, 20.0, 0.0, 1.0),
            MaterialKind::Metal { color: 0.9 * c, exponent: 20.0 }
        );
        let MaterialKind::Polished { color, eta, exponent } = material_kind(c, 0.5, 0.5, 3.0, 0.0, 1.0)
        else {
            panic!("polished")
        };
        assert_eq!((color, exponent), (0.5 * c, 3.0));
        let r0 = ((eta - 1.0) / (eta + 1.0)).powi(2);
        assert!((r0 - 0.5).abs() < 1e-12, "the coat reflects Ks at normal incidence: {r0}");
        let MaterialKind::Polished { eta, .. } = material_kind(c, 0.5, 1.0, 3.0, 0.0, 1.0) else { panic!() };
        assert!(eta.is_finite());
    }
}
