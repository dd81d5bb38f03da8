//! Live edits in the window, as pure functions the viewer and the HUD call (and the tests call
//! directly): picking (a light's projection near the cursor, else one ray of the f64 reference),
//! what a selection names, the material kinds, moving a light in the view plane, and the
//! playback clock of an animated scene.

use crate::reference::{Geometry, Primitive, Reference};
use crate::scene::{Camera, MaterialKind, Scene, TraceSettings};
use glam::DVec3;
use std::path::Path;
use std::time::SystemTime;

/// A click within this many window pixels of a light's projection selects the light.
pub const LIGHT_PICK_RADIUS: f64 = 12.0;
/// A left press and release that moved at most this many pixels is a click, not a drag.
pub const CLICK_SLOP: f64 = 3.0;

/// What the user selected: a light, or the primitive a click hit (its material is what the HUD
/// edits).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Selection {
    Light(usize),
    Object(Primitive),
}

impl Selection {
    /// `light 0`, `sphere 2`, `cone 1`, `mesh 0 (triangle 17)`.
    pub fn name(&self) -> String {
        match *self {
            Selection::Light(i) => format!("light {i}"),
            Selection::Object(Primitive::Sphere(i)) => format!("sphere {i}"),
            Selection::Object(Primitive::Cone(i)) => format!("cone {i}"),
            Selection::Object(Primitive::Volume(i)) => format!("volume {i}"),
            Selection::Object(Primitive::Patch(i)) => format!("patch {i}"),
            Selection::Object(Primitive::Triangle { mesh, triangle }) => {
                format!("mesh {mesh} (triangle {triangle})")
            }
        }
    }

    /// The name and, for an object, its material as a user reads it (what `selected:` prints).
    pub fn describe(&self, scene: &Scene) -> String {
        match *self {
            Selection::Light(_) => self.name(),
            Selection::Object(p) => match object_material(scene, p) {
                Some(m) => format!(
                    "{} material {m} '{}' ({})",
                    self.name(),
                    scene.materials[m as usize].name,
                    kind_name(&scene.materials[m as usize].kind)
                ),
                None => self.name(),
            },
        }
    }
}

/// The material index of a primitive (`None` when the scene has no such primitive).
pub fn object_material(scene: &Scene, p: Primitive) -> Option<u32> {
    match p {
        Primitive::Sphere(i) => scene.spheres.get(i).map(|s| s.material),
        Primitive::Cone(i) => scene.cones.get(i).map(|c| c.material),
        Primitive::Triangle { mesh, .. } => scene.meshes.get(mesh).map(|m| m.material),
        // Its first isosurface's (the one a material edit changes).
        Primitive::Volume(i) => scene.volumes.get(i).and_then(|v| v.isos.first()).map(|iso| iso.material),
        Primitive::Patch(i) => scene.patches.get(i).map(|p| p.material),
    }
}

/// How many spheres, cones, meshes and patches use material `m` (an edit of it changes them
/// all).
pub fn material_users(scene: &Scene, m: u32) -> usize {
    scene.spheres.iter().filter(|s| s.material == m).count()
        + scene.cones.iter().filter(|c| c.material == m).count()
        + scene.meshes.iter().filter(|x| x.material == m).count()
        + scene.patches.iter().filter(|x| x.material == m).count()
}

/// A window position (physical pixels from the top-left, as the cursor reports it) as an image
/// position of the render, which is `render` pixels stretched over `window`: the pixel's
/// centre, in the render's pixel units.
pub fn render_position(cursor: [f64; 2], window: [u32; 2], render: [u32; 2]) -> [f64; 2] {
    [
        (cursor[0].floor() + 0.5) * render[0] as f64 / window[0].max(1) as f64,
        (cursor[1].floor() + 0.5) * render[1] as f64 / window[1].max(1) as f64,
    ]
}

/// Where `p` shows in `camera`'s image (pixels from the top-left, the inverse of
/// [`Camera::direction`]), if it is in front of the camera.
pub fn project(camera: &Camera, p: DVec3) -> Option<[f64; 2]> {
    let b = camera.basis();
    let d = p - camera.eye;
    let z = d.dot(b.w);
    if z.is_nan() || z <= 0.0 {
        return None;
    }
    let sx = d.dot(b.u) / (b.u.length_squared() * z);
    let sy = d.dot(b.v) / (b.v.length_squared() * z);
    Some([(sx + 1.0) * 0.5 * camera.width as f64, (1.0 - sy) * 0.5 * camera.height as f64])
}

/// The light whose projection is nearest to the window position `cursor`, within
/// [`LIGHT_PICK_RADIUS`] window pixels. `scene.camera` is the render's (its size the render's).
pub fn pick_light(scene: &Scene, cursor: [f64; 2], window: [u32; 2]) -> Option<usize> {
    let cam = &scene.camera;
    let to_window = |q: [f64; 2]| {
        [q[0] * window[0] as f64 / cam.width as f64, q[1] * window[1] as f64 / cam.height as f64]
    };
    let c = [cursor[0].floor() + 0.5, cursor[1].floor() + 0.5];
    scene
        .lights
        .iter()
        .enumerate()
        .filter_map(|(i, l)| {
            let q = to_window(project(cam, l.position)?);
            let d = ((q[0] - c[0]).powi(2) + (q[1] - c[1]).powi(2)).sqrt();
            (d <= LIGHT_PICK_RADIUS).then_some((d, i))
        })
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, i)| i)
}

/// Picking with the f64 reference: the BVH over the primitives is kept until they change, so
/// that a click on a big mesh does not build one each time.
#[derive(Default)]
pub struct Picker {
    /// The primitives the BVH was built over (no lights, materials or textures: a ray query
    /// needs none).
    scene: Option<Scene>,
    geometry: Option<Geometry>,
    /// BVH builds so far.
    pub builds: u32,
}

impl Picker {
    /// What shows at window position `cursor`: the nearest light within [`LIGHT_PICK_RADIUS`]
    /// pixels of it, else the primitive the eye ray through that pixel hits first, else `None`
    /// (the background). `scene` is a still whose camera is the render's (the session's scene).
    pub fn pick(&mut self, scene: &Scene, cursor: [f64; 2], window: [u32; 2]) -> Option<Selection> {
        if let Some(i) = pick_light(scene, cursor, window) {
            return Some(Selection::Light(i));
        }
        self.pick_object(scene, cursor, window).map(Selection::Object)
    }

    /// The primitive under window position `cursor` (lights ignored).
    pub fn pick_object(&mut self, scene: &Scene, cursor: [f64; 2], window: [u32; 2]) -> Option<Primitive> {
        let same = self.scene.as_ref().is_some_and(|s| {
            s.spheres == scene.spheres && s.cones == scene.cones && s.meshes == scene.meshes
        });
        if !same || self.geometry.is_none() {
            let copy = Scene {
                camera: scene.camera.clone(),
                lights: Vec::new(),
                ambient: scene.ambient.clone(),
                background: scene.background,
                materials: Vec::new(),
                spheres: scene.spheres.clone(),
                meshes: scene.meshes.clone(),
                cones: scene.cones.clone(),
                textures: Vec::new(),
                trace: TraceSettings::default(),
                motions: Vec::new(),
                particles: Vec::new(),
                volumes: Vec::new(),
                patches: Vec::new(),
            };
            self.geometry = Some(Reference::new(&copy).into_geometry());
            self.scene = Some(copy);
            self.builds += 1;
        }
        let cam = &scene.camera;
        let [px, py] = render_position(cursor, window, [cam.width, cam.height]);
        let d = cam.direction(&cam.basis(), px, py).normalize();
        let prims = self.scene.as_ref().expect("built above");
        let r = Reference::with_geometry(prims, self.geometry.take().expect("built above"));
        let hit = r.intersect_primitive(cam.eye, d, f64::INFINITY);
        self.geometry = Some(r.into_geometry());
        hit.map(|(p, _)| p)
    }
}

/// The offset that moves a point at `p` by (`dx`, `dy`) window pixels (right, down) in the view
/// plane through it: its projection follows the cursor.
pub fn view_offset(camera: &Camera, window: [u32; 2], p: DVec3, dx: f64, dy: f64) -> DVec3 {
    let b = camera.basis();
    // The depth in front of the camera; for a point far off the view direction (out of view,
    // beside or behind the camera, where the projection cannot follow the cursor), at least
    // half its distance, so that it still moves.
    let z = (p - camera.eye).dot(b.w).max(0.5 * (p - camera.eye).length()).max(1e-9);
    z * (2.0 * dx / window[0].max(1) as f64 * b.u - 2.0 * dy / window[1].max(1) as f64 * b.v)
}

/// The offset that moves a point at `p` `steps` tenths of its distance away from the camera
/// (negative: nearer), along the view direction.
pub fn depth_offset(camera: &Camera, p: DVec3, steps: f64) -> DVec3 {
    let b = camera.basis();
    let dist = (p - camera.eye).length().max(1e-3);
    b.w * dist * 0.1 * steps
}

/// The material kinds, in the order the HUD lists them (and K cycles).
pub const KINDS: [&str; 4] = ["diffuse", "metal", "dielectric", "polished"];

pub fn kind_name(k: &MaterialKind) -> &'static str {
    match k {
        MaterialKind::Diffuse { .. } => KINDS[0],
        MaterialKind::Metal { .. } => KINDS[1],
        MaterialKind::Dielectric { .. } => KINDS[2],
        MaterialKind::Polished { .. } => KINDS[3],
    }
}

/// (colour, eta, exponent) of a kind, with the values a kind lacks filled in (grey 0.8, 1.5,
/// 50): what a switch to another kind keeps.
pub fn kind_params(k: &MaterialKind) -> (DVec3, f64, f64) {
    let (grey, eta, exponent) = (DVec3::splat(0.8), 1.5, 50.0);
    match *k {
        MaterialKind::Diffuse { color } => (color, eta, exponent),
        MaterialKind::Metal { color, exponent } => (color, eta, exponent),
        MaterialKind::Dielectric { eta, exponent } => (grey, eta, exponent),
        MaterialKind::Polished { color, eta, exponent } => (color, eta, exponent),
    }
}

/// A kind named `name` (one of [`KINDS`]) from the parameters, clamped to what a scene accepts:
/// colour channels in [0, 1], eta at least 0.01, exponent at least 0 (non-finite values become
/// the defaults of [`kind_params`]).
pub fn make_kind(name: &str, color: DVec3, eta: f64, exponent: f64) -> MaterialKind {
    let fix = |x: f64, default: f64| if x.is_finite() { x } else { default };
    let color =
        DVec3::new(fix(color.x, 0.8), fix(color.y, 0.8), fix(color.z, 0.8)).clamp(DVec3::ZERO, DVec3::ONE);
    let eta = fix(eta, 1.5).max(0.01);
    let exponent = fix(exponent, 50.0).max(0.0);
    match name {
        "metal" => MaterialKind::Metal { color, exponent },
        "dielectric" => MaterialKind::Dielectric { eta, exponent },
        "polished" => MaterialKind::Polished { color, eta, exponent },
        _ => MaterialKind::Diffuse { color },
    }
}

/// `k` as the next kind of [`KINDS`] (what K does), keeping colour, eta and exponent.
pub fn next_kind(k: &MaterialKind) -> MaterialKind {
    let i = KINDS.iter().position(|&n| n == kind_name(k)).unwrap_or(0);
    let (c, eta, n) = kind_params(k);
    make_kind(KINDS[(i + 1) % KINDS.len()], c, eta, n)
}

/// A light's colour as the HUD shows it: a hue in [0, 1]³ (its largest channel 1) times an
/// intensity (the largest channel).
pub fn split_light_color(c: DVec3) -> (DVec3, f64) {
    let i = c.max_element();
    if i > 0.0 && i.is_finite() {
        (c / i, i)
    } else {
        (DVec3::ONE, 0.0)
    }
}

/// Speeds of the playback clock: halved / doubled by `,` / `.`, within these.
pub const MIN_SPEED: f64 = 1.0 / 64.0;
pub const MAX_SPEED: f64 = 64.0;

/// The playback clock of an animated scene: scene time advances by wall time × speed while
/// playing and loops from `duration` back to 0.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Playback {
    pub time: f64,
    pub duration: f64,
    pub speed: f64,
    pub playing: bool,
}

impl Playback {
    pub fn new(duration: f64, start: f64, paused: bool) -> Playback {
        let mut p = Playback { time: 0.0, duration: duration.max(0.0), speed: 1.0, playing: !paused };
        p.seek(start);
        p
    }

    /// Moves to time `t`, clamped to [0, duration].
    pub fn seek(&mut self, t: f64) {
        self.time = if t.is_finite() { t.clamp(0.0, self.duration) } else { 0.0 };
    }

    /// Advances by `wall` seconds of wall time while playing (looping past the end); whether
    /// the time changed.
    pub fn advance(&mut self, wall: f64) -> bool {
        if !self.playing || self.duration <= 0.0 || wall.is_nan() || wall <= 0.0 {
            return false;
        }
        let old = self.time;
        let t = self.time + wall * self.speed;
        self.time = if t >= self.duration { t.rem_euclid(self.duration) } else { t };
        self.time != old
    }

    /// Speed ×`factor`, within [`MIN_SPEED`], [`MAX_SPEED`].
    pub fn scale_speed(&mut self, factor: f64) {
        self.speed = (self.speed * factor).clamp(MIN_SPEED, MAX_SPEED);
    }
}

/// `irt-YYYYmmdd-HHMMSS.png` for now (UTC).
pub fn screenshot_name(t: SystemTime) -> String {
    format!("irt-{}.png", utc_stamp(t))
}

/// `irt-scene-YYYYmmdd-HHMMSS.toml` for now (UTC): where T writes the scene without --save.
pub fn scene_file_name(t: SystemTime) -> String {
    format!("irt-scene-{}.toml", utc_stamp(t))
}

/// Writes `scene` as the native TOML (`io::toml_write`, what `irt convert` writes) to `path`,
/// atomically, its textures beside it first (the TOML never names a file not yet there).
pub fn write_scene(scene: &Scene, path: &Path) -> Result<(), String> {
    let stem = path.file_stem().map_or("scene".into(), |s| s.to_string_lossy().into_owned());
    let files = crate::io::toml_write::to_files(scene, &stem)?;
    if files.toml.len() as u64 > crate::io::MAX_SCENE_FILE_BYTES {
        return Err(format!(
            "the TOML would be {} bytes, above the {}-byte limit irt loads: not written",
            files.toml.len(),
            crate::io::MAX_SCENE_FILE_BYTES
        ));
    }
    let dir = path.parent().unwrap_or(Path::new(""));
    for (name, png) in &files.textures {
        let p = dir.join(name);
        crate::image::write_atomic(&p, png).map_err(|e| format!("writing {}: {e}", p.display()))?;
    }
    crate::image::write_atomic(path, files.toml.as_bytes())
        .map_err(|e| format!("writing {}: {e}", path.display()))
}

/// `YYYYmmdd-HHMMSS` (UTC).
fn utc_stamp(t: SystemTime) -> String {
    let secs = t.duration_since(SystemTime::UNIX_EPOCH).map_or(0, |d| d.as_secs()) as i64;
    let (days, rem) = (secs.div_euclid(86_400), secs.rem_euclid(86_400));
    // Civil date from days since 1970-01-01 (Howard Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + (month <= 2) as i64;
    format!("{year:04}{month:02}{day:02}-{:02}{:02}{:02}", rem / 3600, rem / 60 % 60, rem % 60)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{default_scene, Material, Sphere};

    /// A camera at the origin looking down -z at a sphere, with a light to the right.
    fn scene() -> Scene {
        let mut s = default_scene();
        s.camera = Camera {
            eye: DVec3::ZERO,
            look_at: DVec3::new(0.0, 0.0, -1.0),
            up: DVec3::Y,
            vfov_deg: 60.0,
            width: 100,
            height: 80,
        };
        s.materials = vec![Material::new("a", MaterialKind::Diffuse { color: DVec3::splat(0.5) })];
        s.spheres = vec![Sphere { center: DVec3::new(0.0, 0.0, -5.0), radius: 1.0, material: 0 }];
        s.meshes.clear();
        s.cones.clear();
        s.motions.clear();
        s.lights.truncate(1);
        s.lights[0].position = DVec3::new(2.0, 0.0, -5.0);
        s
    }

    #[test]
    fn picking_agrees_with_the_reference() {
        let s = scene();
        let mut p = Picker::default();
        // The window is twice the render: its centre is over the sphere.
        let window = [200, 160];
        assert_eq!(p.pick(&s, [100.0, 80.0], window), Some(Selection::Object(Primitive::Sphere(0))));
        // The reference's own eye ray through that render pixel hits the sphere too.
        let r = Reference::new(&s);
        let [px, py] = render_position([100.0, 80.0], window, [100, 80]);
        let d = s.camera.direction(&s.camera.basis(), px, py).normalize();
        assert!(r.intersect(s.camera.eye, d, f64::INFINITY).is_some());
        // A corner shows the background.
        assert_eq!(p.pick(&s, [2.0, 2.0], window), None);
        // The light's projection, and a click 8 window pixels off it, select the light; 20
        // pixels off, the background.
        let q = project(&s.camera, s.lights[0].position).unwrap();
        let (lx, ly) = (q[0] * 2.0, q[1] * 2.0);
        assert_eq!(p.pick(&s, [lx, ly], window), Some(Selection::Light(0)));
        assert_eq!(p.pick(&s, [lx + 8.0, ly], window), Some(Selection::Light(0)));
        assert_eq!(p.pick(&s, [lx + 20.0, ly], window), None);
        // One BVH for all of these; a moved sphere builds another.
        assert_eq!(p.builds, 1);
        let mut moved = s.clone();
        moved.spheres[0].center.x += 10.0;
        assert_eq!(p.pick(&moved, [100.0, 80.0], window), None);
        assert_eq!(p.builds, 2);
    }

    #[test]
    fn triangles_name_their_mesh() {
        let mut s = scene();
        s.spheres.clear();
        let quad = |z: f64| crate::scene::Mesh {
            positions: vec![
                DVec3::new(-1.0, -1.0, z),
                DVec3::new(1.0, -1.0, z),
                DVec3::new(1.0, 1.0, z),
                DVec3::new(-1.0, 1.0, z),
            ],
            normals: None,
            uvs: None,
            indices: vec![[0, 1, 2], [0, 2, 3]],
            material: 0,
        };
        // Mesh 1 is nearer: the centre ray hits it.
        s.meshes = vec![quad(-6.0), quad(-4.0)];
        let got = Picker::default().pick_object(&s, [50.0, 40.0], [100, 80]);
        assert!(matches!(got, Some(Primitive::Triangle { mesh: 1, .. })), "{got:?}");
    }

    #[test]
    fn projection_inverts_the_eye_ray() {
        let s = scene();
        let b = s.camera.basis();
        let d = s.camera.direction(&b, 30.5, 20.5);
        let q = project(&s.camera, s.camera.eye + 3.0 * d).unwrap();
        assert!((q[0] - 30.5).abs() < 1e-9 && (q[1] - 20.5).abs() < 1e-9, "{q:?}");
        assert_eq!(project(&s.camera, DVec3::new(0.0, 0.0, 1.0)), None);
    }

    #[test]
    fn a_view_drag_follows_the_cursor_and_returns_exactly() {
        let s = scene();
        let window = [200, 160];
        let p = s.lights[0].position;
        let q0 = project(&s.camera, p).unwrap();
        let moved = p + view_offset(&s.camera, window, p, 20.0, -10.0);
        let q1 = project(&s.camera, moved).unwrap();
        // 20 window pixels right and 10 up are 10 and 5 render pixels.
        assert!((q1[0] - q0[0] - 10.0).abs() < 1e-9 && (q1[1] - q0[1] + 5.0).abs() < 1e-9);
        assert_eq!(p + view_offset(&s.camera, window, p, 0.0, 0.0), p);
        let far = p + depth_offset(&s.camera, p, 1.0);
        assert!(far.z < p.z);
    }

    #[test]
    fn kinds_keep_their_parameters_and_clamp() {
        let m = MaterialKind::Polished { color: DVec3::new(0.1, 0.2, 0.3), eta: 1.7, exponent: 20.0 };
        let d = next_kind(&m);
        assert_eq!(d, MaterialKind::Diffuse { color: DVec3::new(0.1, 0.2, 0.3) });
        let metal = next_kind(&d);
        assert_eq!(metal, MaterialKind::Metal { color: DVec3::new(0.1, 0.2, 0.3), exponent: 50.0 });
        assert_eq!(kind_name(&next_kind(&metal)), "dielectric");
        assert_eq!(
            make_kind("polished", DVec3::new(2.0, -1.0, f64::NAN), -3.0, f64::INFINITY),
            MaterialKind::Polished { color: DVec3::new(1.0, 0.0, 0.8), eta: 0.01, exponent: 50.0 }
        );
        for k in KINDS {
            let m = Material::new("m", make_kind(k, DVec3::splat(7.0), 0.0, -1.0));
            assert!(m.validate().is_ok(), "{k}");
        }
        assert_eq!(split_light_color(DVec3::new(2.0, 1.0, 0.0)), (DVec3::new(1.0, 0.5, 0.0), 2.0));
        assert_eq!(split_light_color(DVec3::ZERO), (DVec3::ONE, 0.0));
    }

    #[test]
    fn the_playback_clock_loops_and_clamps() {
        let mut p = Playback::new(2.0, 5.0, false);
        assert_eq!(p.time, 2.0);
        p.seek(0.5);
        assert!(p.advance(1.0));
        assert_eq!(p.time, 1.5);
        p.scale_speed(2.0);
        assert!(p.advance(0.5));
        // 1.5 + 0.5 * 2 = 2.5: past the end by 0.5.
        assert_eq!(p.time, 0.5);
        p.playing = false;
        assert!(!p.advance(1.0));
        assert_eq!(p.time, 0.5);
        let mut still = Playback::new(0.0, 1.0, false);
        assert!(!still.advance(1.0));
        assert_eq!(still.time, 0.0);
        for _ in 0..20 {
            p.scale_speed(2.0);
        }
        assert_eq!(p.speed, MAX_SPEED);
        assert!(!Playback::new(1.0, 0.3, true).playing);
    }

    #[test]
    fn screenshot_names_are_utc_timestamps() {
        let t = SystemTime::UNIX_EPOCH + std::time::Duration::from_secs(951_782_400 + 3 * 3600 + 4 * 60 + 5);
        assert_eq!(screenshot_name(t), "irt-20000229-030405.png");
        assert_eq!(screenshot_name(SystemTime::UNIX_EPOCH), "irt-19700101-000000.png");
        assert_eq!(scene_file_name(t), "irt-scene-20000229-030405.toml");
    }
}
