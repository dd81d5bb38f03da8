//! The viewer's camera controller: pure math over [`Camera`], no window, unit-tested.
//!
//! Two ways to move, sharing one state (an eye, a focus point and the world's up):
//! - **orbit** (left drag): the eye circles the focus point at a fixed distance;
//! - **fly** (right drag to look, W/A/S/D/Q/E to move): the eye turns in place and moves; the
//!   focus point moves with it, at the same distance in front of the eye.
//!
//! The world's up is the scene camera's `up`: the view never rolls, and the pitch stays
//! [`MAX_PITCH_DEG`] short of straight up or down. Until the first move the controller hands back
//! the scene's camera exactly (so the first picture equals a headless render).

use crate::scene::{Camera, Scene};
use glam::DVec3;
use std::fmt::Write as _;

/// The pitch never comes closer than this to ±90° (the view direction would be parallel to up).
pub const MAX_PITCH_DEG: f64 = 89.0;
/// Radians the view turns per pixel of mouse drag.
pub const TURN_PER_PIXEL: f64 = 0.005;
/// Fly speed at speed factor 1: this fraction of the scene's bounding radius per second.
pub const SPEED_PER_RADIUS: f64 = 0.5;
/// One wheel notch multiplies (or divides) the fly speed by this.
pub const WHEEL_STEP: f64 = 1.25;

/// A bounding sphere.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    pub center: DVec3,
    pub radius: f64,
}

/// An axis-aligned box (min, max).
pub type Box3 = (DVec3, DVec3);

fn union(a: Option<Box3>, b: Box3) -> Option<Box3> {
    Some(match a {
        Some((lo, hi)) => (lo.min(b.0), hi.max(b.1)),
        None => b,
    })
}

/// The boxes of the scene's objects: each sphere, each mesh (the used vertices) and each cone
/// (a sphere around each rim covers it).
pub fn object_boxes(scene: &Scene) -> Vec<Box3> {
    let mut boxes = Vec::new();
    for s in &scene.spheres {
        boxes.push((s.center - DVec3::splat(s.radius), s.center + DVec3::splat(s.radius)));
    }
    for m in &scene.meshes {
        let b =
            m.indices.iter().flatten().map(|&i| m.positions[i as usize]).fold(None, |b, p| union(b, (p, p)));
        boxes.extend(b);
    }
    for c in &scene.cones {
        let r0 = DVec3::splat(c.base_radius);
        let r1 = DVec3::splat(c.apex_radius);
        boxes.push(((c.base - r0).min(c.apex - r1), (c.base + r0).max(c.apex + r1)));
    }
    boxes
}

/// The box around every primitive of `scene`; `None` for a scene without primitives.
pub fn scene_box(scene: &Scene) -> Option<Box3> {
    object_boxes(scene).into_iter().fold(None, union)
}

/// A flat box (thinner than 1/1000 of its size along one axis): a ground plane or a wall.
fn is_flat((lo, hi): Box3) -> bool {
    let e = hi - lo;
    e.min_element() <= 1e-3 * e.max_element()
}

/// What `F` frames and the fly speed is scaled to: the sphere around the scene's objects,
/// leaving out a flat object (a ground plane) more than twice as large as all the others
/// together, which would otherwise shrink the objects on it to a few pixels. A unit sphere
/// around the camera's focus for an empty scene.
pub fn scene_bounds(scene: &Scene) -> Bounds {
    let boxes = object_boxes(scene);
    let size = |(lo, hi): Box3| (hi - lo).max_element();
    let solid = boxes.iter().copied().filter(|&b| !is_flat(b)).fold(None, union);
    let kept = boxes
        .iter()
        .copied()
        .filter(|&b| match solid {
            Some(s) => !is_flat(b) || size(b) <= 2.0 * size(s),
            None => true,
        })
        .fold(None, union);
    match kept {
        Some((lo, hi)) => {
            let radius = 0.5 * (hi - lo).length();
            Bounds { center: 0.5 * (lo + hi), radius: if radius > 0.0 { radius } else { 1.0 } }
        }
        None => Bounds { center: scene.camera.look_at, radius: 1.0 },
    }
}

/// Keys held for flying: each axis -1, 0 or +1 (forward, right, up).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FlyInput {
    pub forward: f64,
    pub right: f64,
    pub up: f64,
}

impl FlyInput {
    pub fn is_zero(&self) -> bool {
        self.forward == 0.0 && self.right == 0.0 && self.up == 0.0
    }
}

#[derive(Clone, Debug)]
pub struct CameraController {
    /// The scene's camera: what `reset` returns to and what the first picture shows.
    home: Camera,
    eye: DVec3,
    focus: DVec3,
    /// The scene camera's `up` as given (written back unchanged).
    up: DVec3,
    /// `up`, unit length: the axis of yaw.
    world_up: DVec3,
    vfov_deg: f64,
    bounds: Bounds,
    /// Wheel factor on the fly speed (1 at start).
    pub speed_factor: f64,
}

impl CameraController {
    pub fn new(home: &Camera, bounds: Bounds) -> Self {
        let world_up = if home.up.length_squared() > 0.0 { home.up.normalize() } else { DVec3::Y };
        CameraController {
            home: home.clone(),
            eye: home.eye,
            focus: home.look_at,
            up: home.up,
            world_up,
            vfov_deg: home.vfov_deg,
            bounds,
            speed_factor: 1.0,
        }
    }

    pub fn bounds(&self) -> Bounds {
        self.bounds
    }

    pub fn eye(&self) -> DVec3 {
        self.eye
    }

    pub fn focus(&self) -> DVec3 {
        self.focus
    }

    /// The camera to trace, `width`×`height` (the session ignores the size; it matters for `C`).
    pub fn camera(&self, width: u32, height: u32) -> Camera {
        Camera { eye: self.eye, look_at: self.focus, up: self.up, vfov_deg: self.vfov_deg, width, height }
    }

    /// Back to the scene's camera (and speed factor 1).
    pub fn reset(&mut self) {
        *self = CameraController::new(&self.home.clone(), self.bounds);
    }

    /// Distance from the eye to the focus point.
    pub fn distance(&self) -> f64 {
        (self.focus - self.eye).length()
    }

    /// Unit view direction.
    pub fn forward(&self) -> DVec3 {
        (self.focus - self.eye).normalize_or(-DVec3::Z)
    }

    /// Unit right vector (horizontal: perpendicular to the world's up).
    pub fn right(&self) -> DVec3 {
        let r = self.forward().cross(self.world_up);
        if r.length_squared() > 1e-12 {
            r.normalize()
        } else {
            self.world_up.any_orthonormal_vector()
        }
    }

    /// (yaw, pitch) of the view direction in radians; pitch 0 is horizontal.
    fn angles(&self) -> (f64, f64) {
        let (e1, e2) = self.horizontal_frame();
        let d = self.forward();
        let pitch = d.dot(self.world_up).clamp(-1.0, 1.0).asin();
        let yaw = d.dot(e2).atan2(d.dot(e1));
        (yaw, pitch)
    }

    /// A fixed orthonormal pair spanning the plane perpendicular to the world's up.
    fn horizontal_frame(&self) -> (DVec3, DVec3) {
        let e1 = self.world_up.any_orthonormal_vector();
        (e1, self.world_up.cross(e1))
    }

    fn direction(&self, yaw: f64, pitch: f64) -> DVec3 {
        let (e1, e2) = self.horizontal_frame();
        let max = MAX_PITCH_DEG.to_radians();
        let pitch = pitch.clamp(-max, max);
        pitch.cos() * (yaw.cos() * e1 + yaw.sin() * e2) + pitch.sin() * self.world_up
    }

    /// The view direction turned by a drag of (`dx`, `dy`) pixels (right and down positive):
    /// dragging right turns the view right, dragging down tilts it down.
    fn turned(&self, dx: f64, dy: f64) -> DVec3 {
        let (yaw, pitch) = self.angles();
        // Yaw grows from e1 towards e2 = up × e1, which is to the left: turning right is -yaw.
        self.direction(yaw - dx * TURN_PER_PIXEL, pitch - dy * TURN_PER_PIXEL)
    }

    /// Left drag: the eye circles the focus point (distance kept); dragging right moves the eye
    /// left around it, as if the scene were turned with the mouse.
    pub fn orbit(&mut self, dx: f64, dy: f64) {
        if dx == 0.0 && dy == 0.0 {
            return;
        }
        let d = self.distance();
        // The view turns the way the mouse goes while the eye swings the other way round.
        let dir = self.turned(dx, dy);
        self.eye = self.focus - dir * d;
    }

    /// Right drag: the view turns in place (the focus point moves, distance kept).
    pub fn look(&mut self, dx: f64, dy: f64) {
        if dx == 0.0 && dy == 0.0 {
            return;
        }
        let d = self.distance();
        let dir = self.turned(dx, dy);
        self.focus = self.eye + dir * d;
    }

    /// Fly speed in scene units per second for the current wheel factor and `modifier`
    /// (4 with Shift, 0.25 with Ctrl, else 1).
    pub fn speed(&self, modifier: f64) -> f64 {
        self.bounds.radius * SPEED_PER_RADIUS * self.speed_factor * modifier
    }

    /// Moves eye and focus by `input` for `dt` seconds at `speed(modifier)`: forward along the
    /// view direction, right horizontally, up along the world's up.
    pub fn fly(&mut self, input: FlyInput, dt: f64, modifier: f64) {
        if input.is_zero() || dt <= 0.0 {
            return;
        }
        let step = self.speed(modifier) * dt;
        let delta =
            (input.forward * self.forward() + input.right * self.right() + input.up * self.world_up) * step;
        self.eye += delta;
        self.focus += delta;
    }

    /// Wheel: `notches` up speed up, down slow down (within a factor 10⁴ either way).
    pub fn wheel(&mut self, notches: f64) {
        self.speed_factor = (self.speed_factor * WHEEL_STEP.powf(notches)).clamp(1e-4, 1e4);
    }

    /// `F`: keeps the view direction and puts the scene's bounding sphere in view, filling the
    /// smaller of the two fields of view of an image of `aspect` = width / height; the focus
    /// point becomes the sphere's centre.
    pub fn frame(&mut self, aspect: f64) {
        let half_v = (self.vfov_deg.to_radians() * 0.5).clamp(1e-6, 1.5);
        let half_h = (half_v.tan() * aspect.max(1e-6)).atan();
        let half = half_v.min(half_h);
        let d = self.bounds.radius / half.sin();
        let dir = self.forward();
        self.focus = self.bounds.center;
        self.eye = self.focus - dir * d;
    }
}

/// `value` as a TOML float that parses back to the same f64 (Rust's shortest round-trip form,
/// which is valid TOML for every finite value).
fn toml_float(value: f64) -> String {
    let s = format!("{value:?}");
    if s.contains(['.', 'e', 'E']) || s.contains("inf") || s.contains("NaN") {
        s
    } else {
        s + ".0"
    }
}

fn toml_vec3(v: DVec3) -> String {
    format!("[{}, {}, {}]", toml_float(v.x), toml_float(v.y), toml_float(v.z))
}

/// The camera as a `[camera]` table of a scene file (the keys of scenes/default.toml), exact:
/// loading it gives back `camera` bit for bit.
pub fn camera_toml(camera: &Camera) -> String {
    let mut s = String::from("[camera]\n");
    let _ = writeln!(s, "eye = {}", toml_vec3(camera.eye));
    let _ = writeln!(s, "look_at = {}", toml_vec3(camera.look_at));
    let _ = writeln!(s, "up = {}", toml_vec3(camera.up));
    let _ = writeln!(s, "fov = {}", toml_float(camera.vfov_deg));
    let _ = writeln!(s, "width = {}", camera.width);
    let _ = writeln!(s, "height = {}", camera.height);
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn home() -> Camera {
        Camera {
            eye: DVec3::new(0.0, 2.0, 7.8),
            look_at: DVec3::new(0.0, 0.75, -0.3),
            up: DVec3::Y,
            vfov_deg: 40.0,
            width: 640,
            height: 480,
        }
    }

    fn bounds() -> Bounds {
        Bounds { center: DVec3::new(1.0, 0.5, -2.0), radius: 3.0 }
    }

    fn close(a: DVec3, b: DVec3, tol: f64) -> bool {
        (a - b).length() <= tol
    }

    #[test]
    fn untouched_controller_gives_the_scene_camera_exactly() {
        let c = CameraController::new(&home(), bounds());
        assert_eq!(c.camera(640, 480), home());
    }

    #[test]
    fn orbit_keeps_the_distance_to_the_focus_and_the_focus() {
        let mut c = CameraController::new(&home(), bounds());
        let (d0, f0, e0) = (c.distance(), c.focus(), c.eye());
        for (dx, dy) in [(40.0, 0.0), (0.0, 25.0), (-300.0, 90.0), (10.0, -1000.0)] {
            c.orbit(dx, dy);
            assert!((c.distance() - d0).abs() < 1e-9 * d0, "distance {} vs {d0}", c.distance());
            assert_eq!(c.focus(), f0);
        }
        assert!(!close(c.eye(), e0, 1e-3), "the eye moved");
        // Dragging right moves the eye to the left of where it looked from (scene turns right).
        let mut c = CameraController::new(&home(), bounds());
        let right = c.right();
        c.orbit(50.0, 0.0);
        assert!((c.eye() - e0).dot(right) < 0.0);
    }

    #[test]
    fn pitch_is_clamped_and_up_never_changes() {
        let mut c = CameraController::new(&home(), bounds());
        c.orbit(0.0, 1e6);
        let cam = c.camera(640, 480);
        assert_eq!(cam.up, DVec3::Y);
        let pitch = c.forward().dot(DVec3::Y).asin().to_degrees().abs();
        assert!((pitch - MAX_PITCH_DEG).abs() < 1e-6, "pitch {pitch}");
        c.look(0.0, -1e6);
        let pitch = c.forward().dot(DVec3::Y).asin().to_degrees().abs();
        assert!((pitch - MAX_PITCH_DEG).abs() < 1e-6, "pitch {pitch}");
        // No roll: the right vector stays horizontal.
        assert!(c.right().dot(DVec3::Y).abs() < 1e-12);
    }

    #[test]
    fn look_turns_in_place() {
        let mut c = CameraController::new(&home(), bounds());
        let (e0, d0, f0) = (c.eye(), c.distance(), c.forward());
        c.look(30.0, 0.0);
        assert_eq!(c.eye(), e0);
        assert!((c.distance() - d0).abs() < 1e-9);
        // Dragging right turns the view right.
        assert!(c.forward().dot(CameraController::new(&home(), bounds()).right()) > 0.0);
        let flat = |v: DVec3| DVec3::new(v.x, 0.0, v.z).normalize();
        let yaw_delta = flat(c.forward()).dot(flat(f0)).acos();
        assert!((yaw_delta - 30.0 * TURN_PER_PIXEL).abs() < 1e-9, "turned {yaw_delta}");
        assert!((c.forward().y - f0.y).abs() < 1e-12, "pitch kept");
    }

    #[test]
    fn fly_moves_along_the_view_direction() {
        let mut c = CameraController::new(&home(), bounds());
        let (e0, f0, dir) = (c.eye(), c.focus(), c.forward());
        c.fly(FlyInput { forward: 1.0, ..Default::default() }, 2.0, 1.0);
        let expected = e0 + dir * (2.0 * c.speed(1.0));
        assert!(close(c.eye(), expected, 1e-12), "{} vs {expected}", c.eye());
        assert!(close(c.focus() - c.eye(), f0 - e0, 1e-12), "focus moves along");
        assert_eq!(c.speed(1.0), 3.0 * SPEED_PER_RADIUS);
        // Shift (x4) goes four times as far; strafing right is perpendicular to the view.
        let mut f = CameraController::new(&home(), bounds());
        f.fly(FlyInput { forward: 1.0, ..Default::default() }, 2.0, 4.0);
        assert!(((f.eye() - e0).length() - 4.0 * (c.eye() - e0).length()).abs() < 1e-9);
        let mut s = CameraController::new(&home(), bounds());
        s.fly(FlyInput { right: 1.0, ..Default::default() }, 1.0, 1.0);
        assert!((s.eye() - e0).dot(dir).abs() < 1e-12);
        assert!((s.eye() - e0).dot(DVec3::new(1.0, 0.0, 0.0)) > 0.0, "right is +x here");
        let mut u = CameraController::new(&home(), bounds());
        u.fly(FlyInput { up: 1.0, ..Default::default() }, 1.0, 1.0);
        assert!(close(u.eye() - e0, DVec3::Y * u.speed(1.0), 1e-12));
    }

    #[test]
    fn wheel_scales_the_speed() {
        let mut c = CameraController::new(&home(), bounds());
        let v = c.speed(1.0);
        c.wheel(2.0);
        assert!((c.speed(1.0) - v * WHEEL_STEP * WHEEL_STEP).abs() < 1e-12);
        c.wheel(-2.0);
        assert!((c.speed(1.0) - v).abs() < 1e-12);
    }

    /// Every corner of the bounds' box projects inside the image after `F`, and the sphere's
    /// centre is at the image centre.
    #[test]
    fn frame_puts_the_bounding_sphere_in_view() {
        for aspect in [640.0 / 480.0, 0.5, 2.5] {
            let mut c = CameraController::new(&home(), bounds());
            c.orbit(123.0, -40.0);
            let dir = c.forward();
            c.frame(aspect);
            assert!(close(c.forward(), dir, 1e-12), "direction kept");
            assert_eq!(c.focus(), bounds().center);
            let (w, h) = ((480.0 * aspect) as u32, 480);
            let cam = c.camera(w, h);
            let basis = cam.basis();
            // The sphere's silhouette: points on it perpendicular to the view at its centre, and
            // the tangent cone (what `F` fits) holds the whole sphere.
            let to_center = bounds().center - cam.eye;
            let dist = to_center.length();
            let half_v = (cam.vfov_deg.to_radians() / 2.0).tan();
            let half_h = half_v * w as f64 / h as f64;
            let half_angle = (bounds().radius / dist).asin();
            let need = half_angle.tan();
            assert!(need <= half_v * (1.0 + 1e-9) && need <= half_h * (1.0 + 1e-9));
            assert!((need - half_v.min(half_h)).abs() < 1e-9, "fills the smaller field");
            assert!(close(basis.w, to_center / dist, 1e-12));
        }
    }

    #[test]
    fn reset_returns_to_the_scene_camera() {
        let mut c = CameraController::new(&home(), bounds());
        c.orbit(10.0, 10.0);
        c.fly(FlyInput { forward: 1.0, right: 1.0, up: -1.0 }, 0.3, 4.0);
        c.wheel(3.0);
        c.reset();
        assert_eq!(c.camera(640, 480), home());
        assert_eq!(c.speed_factor, 1.0);
    }

    #[test]
    fn scene_bounds_cover_every_primitive() {
        let scene = crate::scene::default_scene();
        let (lo, hi) = scene_box(&scene).unwrap();
        for s in &scene.spheres {
            assert!((s.center - DVec3::splat(s.radius)).cmpge(lo).all());
            assert!((s.center + DVec3::splat(s.radius)).cmple(hi).all());
        }
        for t in scene.triangles() {
            for p in t.p {
                assert!(p.cmpge(lo).all() && p.cmple(hi).all());
            }
        }
        let b = scene_bounds(&scene);
        assert!(b.radius > 0.0 && b.radius.is_finite());
    }

    /// The default scene's ground quad is left out of what `F` frames (the objects on it are
    /// not), unless it is alone.
    #[test]
    fn a_large_ground_plane_is_not_framed() {
        let mut scene = crate::scene::default_scene();
        let whole = scene_box(&scene).unwrap();
        let b = scene_bounds(&scene);
        assert!(b.radius < 0.5 * (whole.1 - whole.0).length() / 2.0, "{b:?} vs {whole:?}");
        for s in &scene.spheres {
            assert!((s.center - b.center).length() + s.radius <= b.radius * (1.0 + 1e-12));
        }
        scene.spheres.clear();
        scene.cones.clear();
        let ground: Vec<_> = scene.meshes.iter().filter(|m| is_flat(object_boxes_of(m))).cloned().collect();
        assert!(!ground.is_empty(), "the default scene has a ground quad");
        scene.meshes = ground;
        let g = scene_bounds(&scene);
        let gb = scene_box(&scene).unwrap();
        assert!((g.radius - 0.5 * (gb.1 - gb.0).length()).abs() < 1e-12, "alone, the ground is framed");
    }

    fn object_boxes_of(m: &crate::scene::Mesh) -> Box3 {
        let scene = Scene {
            meshes: vec![m.clone()],
            spheres: vec![],
            cones: vec![],
            ..crate::scene::default_scene()
        };
        scene_box(&scene).unwrap()
    }

    /// What `C` prints loads back, through the project's TOML loader, to the same camera.
    #[test]
    fn camera_toml_parses_back_to_the_same_camera() {
        let mut c = CameraController::new(&home(), bounds());
        c.orbit(37.0, -11.0);
        c.fly(FlyInput { forward: 1.0, right: -1.0, up: 0.0 }, 0.137, 0.25);
        for cam in [
            c.camera(321, 123),
            home(),
            Camera { vfov_deg: 1e-3, eye: DVec3::new(1e-17, 2.5, 3e6 + 0.1), ..home() },
        ] {
            let text = camera_toml(&cam);
            let doc = format!(
                "{text}\n[[material]]\nname = \"m\"\ntype = \"diffuse\"\ncolor = [0.5, 0.5, 0.5]\n\n\
                 [[sphere]]\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\nmaterial = \"m\"\n"
            );
            let scene =
                crate::io::toml::parse_str(&doc, "camera_toml test").unwrap_or_else(|e| panic!("{e}\n{doc}"));
            assert_eq!(scene.camera, cam, "{text}");
        }
    }
}
