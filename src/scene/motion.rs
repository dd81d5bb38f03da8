//! Rigid motion over time: keyframed translation, rotation and scale, one implementation of
//! interpolation for every source (TOML keyframes, glTF animations) and every consumer (the
//! GPU path, the f64 reference, the viewer's playback): both tracers render [`Scene::at`].
//!
//! A [`Motion`] is a chain of [`Stage`]s, outermost first, as a glTF node path from the root to
//! the node holding the mesh: a point `p` of the object as written goes to
//! `stages[0](t) · stages[1](t) · … · p`. Times before the first key hold the first value,
//! times after the last hold the last (glTF's rule), so every time is valid.

use super::{InvalidScene, Scene};
use glam::{DAffine3, DMat3, DQuat, DVec3, EulerRot};
use std::borrow::Cow;

/// How values between two keys are found (glTF's three samplers).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interpolation {
    /// The earlier key's value until the next key.
    Step,
    /// Straight line (vectors) or shortest great arc (quaternions, slerp).
    Linear,
    /// Cubic Hermite with a tangent in and out of every key (glTF's CUBICSPLINE).
    CubicSpline,
}

impl Interpolation {
    pub const NAMES: [(&'static str, Interpolation); 3] = [
        ("step", Interpolation::Step),
        ("linear", Interpolation::Linear),
        ("cubic", Interpolation::CubicSpline),
    ];

    pub fn name(self) -> &'static str {
        Self::NAMES.iter().find(|(_, i)| *i == self).map_or("linear", |(n, _)| n)
    }
}

/// A value that can be keyed.
pub trait Keyable: Copy + PartialEq + std::fmt::Debug {
    fn linear(a: Self, b: Self, s: f64) -> Self;
    fn scaled_sum(terms: [(f64, Self); 4]) -> Self;
    /// What a cubic's raw result becomes (quaternions are normalised).
    fn finish(self) -> Self {
        self
    }
    fn is_finite(&self) -> bool;
}

impl Keyable for DVec3 {
    fn linear(a: Self, b: Self, s: f64) -> Self {
        a.lerp(b, s)
    }
    fn scaled_sum(t: [(f64, Self); 4]) -> Self {
        t.iter().map(|(k, v)| *k * *v).sum()
    }
    fn is_finite(&self) -> bool {
        DVec3::is_finite(*self)
    }
}

impl Keyable for DQuat {
    fn linear(a: Self, b: Self, s: f64) -> Self {
        a.slerp(b, s)
    }
    fn scaled_sum(t: [(f64, Self); 4]) -> Self {
        t.iter().fold(DQuat::from_xyzw(0.0, 0.0, 0.0, 0.0), |acc, (k, v)| acc + *v * *k)
    }
    fn finish(self) -> Self {
        self.normalize()
    }
    fn is_finite(&self) -> bool {
        DQuat::is_finite(*self)
    }
}

/// Keys of one property. For [`Interpolation::CubicSpline`] `values` holds three per key, as
/// glTF stores them: in-tangent, value, out-tangent (tangents per second).
#[derive(Clone, Debug, PartialEq)]
pub struct Channel<T> {
    pub interpolation: Interpolation,
    pub times: Vec<f64>,
    pub values: Vec<T>,
}

impl<T: Keyable> Channel<T> {
    /// A cubic channel through `values` with Catmull–Rom tangents (one-sided at the ends):
    /// what TOML's `cubic` means, so it runs through the same Hermite code as glTF's splines.
    pub fn catmull_rom(times: Vec<f64>, values: &[T]) -> Self {
        let n = values.len();
        let mut out = Vec::with_capacity(3 * n);
        for i in 0..n {
            let (a, b) = (i.saturating_sub(1), (i + 1).min(n - 1));
            let dt = times[b] - times[a];
            let tangent = if n < 2 || dt <= 0.0 {
                T::scaled_sum([(0.0, values[i]); 4])
            } else {
                T::scaled_sum([
                    (1.0 / dt, values[b]),
                    (-1.0 / dt, values[a]),
                    (0.0, values[i]),
                    (0.0, values[i]),
                ])
            };
            out.extend([tangent, values[i], tangent]);
        }
        Channel { interpolation: Interpolation::CubicSpline, times, values: out }
    }

    /// Checks what sampling relies on: keys, matching counts, finite strictly increasing
    /// times, finite values. `what` names the channel in the message.
    pub fn validate(&self, what: &str) -> Result<(), InvalidScene> {
        let per_key = if self.interpolation == Interpolation::CubicSpline { 3 } else { 1 };
        if self.times.is_empty() {
            return Err(InvalidScene(format!("{what} has no keys")));
        }
        if self.values.len() != per_key * self.times.len() {
            return Err(InvalidScene(format!(
                "{what} has {} times but {} values ({} {} needs {per_key} per key)",
                self.times.len(),
                self.values.len(),
                self.interpolation.name(),
                if per_key == 3 { "spline" } else { "channel" }
            )));
        }
        if let Some(i) = self.times.iter().position(|t| !t.is_finite()) {
            return Err(InvalidScene(format!("{what}: key {i}'s time {} is not finite", self.times[i])));
        }
        if let Some(i) = self.times.windows(2).position(|w| w[1] <= w[0]) {
            return Err(InvalidScene(format!(
                "{what}: key {} at time {} does not come after key {i} at {}: times must increase",
                i + 1,
                self.times[i + 1],
                self.times[i]
            )));
        }
        if let Some(i) = self.values.iter().position(|v| !v.is_finite()) {
            return Err(InvalidScene(format!(
                "{what}: value {} ({:?}) is not finite",
                i / per_key,
                self.values[i]
            )));
        }
        Ok(())
    }

    /// The value at time `t` (clamped to the first and last keys).
    pub fn sample(&self, t: f64) -> T {
        let cubic = self.interpolation == Interpolation::CubicSpline;
        let value = |i: usize| if cubic { self.values[3 * i + 1] } else { self.values[i] };
        let last = self.times.len() - 1;
        // NaN compares false: it holds the first key, as times before it do.
        if t.is_nan() || t <= self.times[0] {
            return value(0);
        }
        if t >= self.times[last] {
            return value(last);
        }
        // The key interval holding t: times[i] <= t < times[i + 1].
        let i = self.times.partition_point(|&k| k <= t) - 1;
        let (t0, t1) = (self.times[i], self.times[i + 1]);
        let s = (t - t0) / (t1 - t0);
        match self.interpolation {
            Interpolation::Step => value(i),
            Interpolation::Linear => T::linear(value(i), value(i + 1), s),
            Interpolation::CubicSpline => {
                let dt = t1 - t0;
                let (s2, s3) = (s * s, s * s * s);
                let out_tangent = self.values[3 * i + 2];
                let in_tangent = self.values[3 * (i + 1)];
                T::scaled_sum([
                    (2.0 * s3 - 3.0 * s2 + 1.0, value(i)),
                    ((s3 - 2.0 * s2 + s) * dt, out_tangent),
                    (-2.0 * s3 + 3.0 * s2, value(i + 1)),
                    ((s3 - s2) * dt, in_tangent),
                ])
                .finish()
            }
        }
    }

    /// The keys' values (without a cubic's tangents).
    pub fn key_values(&self) -> impl Iterator<Item = &T> {
        let cubic = self.interpolation == Interpolation::CubicSpline;
        self.values.iter().skip(cubic as usize).step_by(if cubic { 3 } else { 1 })
    }

    /// The last key's time.
    pub fn end(&self) -> f64 {
        self.times.last().copied().unwrap_or(0.0)
    }
}

/// A rotation channel: Euler angles in degrees (x, then y, then z, as `[[model]] rotate`;
/// interpolated as angles, so 0 → 360 is a full turn) or quaternions (glTF; slerp).
#[derive(Clone, Debug, PartialEq)]
pub enum Rotation {
    EulerDegrees(Channel<DVec3>),
    Quaternion(Channel<DQuat>),
}

impl Rotation {
    fn sample(&self, t: f64) -> DQuat {
        match self {
            Rotation::EulerDegrees(c) => euler_degrees(c.sample(t)),
            Rotation::Quaternion(c) => c.sample(t).normalize(),
        }
    }
}

/// The rotation of `[[model]] rotate` and of TOML keys: about x, then y, then z, in degrees.
pub fn euler_degrees(d: DVec3) -> DQuat {
    let r = d * (std::f64::consts::PI / 180.0);
    // Extrinsic x → y → z is R = Rz · Ry · Rx.
    DQuat::from_euler(EulerRot::ZYX, r.z, r.y, r.x)
}

/// One link of a motion chain.
#[derive(Clone, Debug, PartialEq)]
pub enum Stage {
    /// A fixed transform (a glTF node without channels, a pivot).
    Fixed(DAffine3),
    /// `T · R · S`, each property keyed or held at its rest value (build it with
    /// [`Stage::keyed`]).
    Keyed {
        translation: Option<Channel<DVec3>>,
        rotation: Option<Rotation>,
        scale: Option<Channel<DVec3>>,
        rest: Trs,
    },
}

/// Translation, rotation and scale.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Trs {
    pub translation: DVec3,
    pub rotation: DQuat,
    pub scale: DVec3,
}

impl Default for Trs {
    fn default() -> Self {
        Trs { translation: DVec3::ZERO, rotation: DQuat::IDENTITY, scale: DVec3::ONE }
    }
}

impl Stage {
    /// A keyed stage; a keyed property's rest value is never used, so it is set to the
    /// identity's (stages that move alike compare equal, and the TOML writer, which writes a
    /// property as keys or as a held value, gives them back exactly).
    pub fn keyed(
        translation: Option<Channel<DVec3>>,
        rotation: Option<Rotation>,
        scale: Option<Channel<DVec3>>,
        rest: Trs,
    ) -> Stage {
        let identity = Trs::default();
        let rest = Trs {
            translation: if translation.is_some() { identity.translation } else { rest.translation },
            rotation: if rotation.is_some() { identity.rotation } else { rest.rotation },
            scale: if scale.is_some() { identity.scale } else { rest.scale },
        };
        Stage::Keyed { translation, rotation, scale, rest }
    }

    pub fn at(&self, t: f64) -> DAffine3 {
        match self {
            Stage::Fixed(m) => *m,
            Stage::Keyed { translation, rotation, scale, rest } => DAffine3::from_scale_rotation_translation(
                scale.as_ref().map_or(rest.scale, |c| c.sample(t)),
                rotation.as_ref().map_or(rest.rotation.normalize(), |r| r.sample(t)),
                translation.as_ref().map_or(rest.translation, |c| c.sample(t)),
            ),
        }
    }

    fn end(&self) -> f64 {
        match self {
            Stage::Fixed(_) => 0.0,
            Stage::Keyed { translation, rotation, scale, .. } => {
                let r = match rotation {
                    Some(Rotation::EulerDegrees(c)) => c.end(),
                    Some(Rotation::Quaternion(c)) => c.end(),
                    None => 0.0,
                };
                translation
                    .as_ref()
                    .map_or(0.0, Channel::end)
                    .max(r)
                    .max(scale.as_ref().map_or(0.0, Channel::end))
            }
        }
    }

    fn validate(&self, what: &str) -> Result<(), InvalidScene> {
        match self {
            Stage::Fixed(m) => {
                if !(m.matrix3.is_finite() && m.translation.is_finite()) {
                    return Err(InvalidScene(format!("{what}: a fixed transform is not finite")));
                }
                Ok(())
            }
            Stage::Keyed { translation, rotation, scale, rest } => {
                if let Some(c) = translation {
                    c.validate(&format!("{what}: translation"))?;
                }
                match rotation {
                    Some(Rotation::EulerDegrees(c)) => c.validate(&format!("{what}: rotation"))?,
                    Some(Rotation::Quaternion(c)) => {
                        c.validate(&format!("{what}: rotation"))?;
                        // A spline's tangents may be zero (the usual ones); its keys may not.
                        let per_key = if c.interpolation == Interpolation::CubicSpline { 3 } else { 1 };
                        let mut keys = c.values.iter().skip(per_key / 2).step_by(per_key);
                        if let Some(i) = keys.position(|q| q.length_squared() == 0.0) {
                            return Err(InvalidScene(format!(
                                "{what}: rotation value {i} is the zero quaternion"
                            )));
                        }
                    }
                    None => {}
                }
                if let Some(c) = scale {
                    c.validate(&format!("{what}: scale"))?;
                }
                if !(rest.translation.is_finite() && rest.rotation.is_finite() && rest.scale.is_finite()) {
                    return Err(InvalidScene(format!("{what}: the rest transform is not finite")));
                }
                Ok(())
            }
        }
    }

    /// The scales this stage holds at its keys (or at rest), for the similarity check. (A cubic
    /// can overshoot between keys; a sphere stays round under any uniform scale.)
    fn scales(&self) -> Vec<DVec3> {
        match self {
            Stage::Fixed(m) => vec![DVec3::new(
                m.matrix3.x_axis.length(),
                m.matrix3.y_axis.length(),
                m.matrix3.z_axis.length(),
            )],
            Stage::Keyed { scale: Some(c), .. } => c.key_values().copied().collect(),
            Stage::Keyed { rest, .. } => vec![rest.scale],
        }
    }
}

/// Where a point of an object goes over time.
#[derive(Clone, Debug, PartialEq)]
pub struct Motion {
    pub stages: Vec<Stage>,
}

impl Motion {
    /// The object-to-world transform at time `t`.
    pub fn at(&self, t: f64) -> DAffine3 {
        self.stages.iter().fold(DAffine3::IDENTITY, |m, s| m * s.at(t))
    }

    /// The last key's time over all stages (0 for a motion without keys).
    pub fn end(&self) -> f64 {
        self.stages.iter().map(Stage::end).fold(0.0, f64::max)
    }
}

/// What a motion moves: an index into the scene's lists.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Target {
    Sphere(u32),
    Cone(u32),
    Mesh(u32),
    Light(u32),
}

impl std::fmt::Display for Target {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Target::Sphere(i) => write!(f, "sphere {i}"),
            Target::Cone(i) => write!(f, "cone {i}"),
            Target::Mesh(i) => write!(f, "mesh {i}"),
            Target::Light(i) => write!(f, "light {i}"),
        }
    }
}

/// One animated object.
#[derive(Clone, Debug, PartialEq)]
pub struct Animated {
    pub target: Target,
    pub motion: Motion,
}

/// Largest relative difference between a sphere's or cone's scale factors: they stay round
/// only under a similarity.
const UNIFORM_SCALE_TOLERANCE: f64 = 1e-9;

impl Scene {
    /// Whether anything moves.
    pub fn is_animated(&self) -> bool {
        !self.motions.is_empty()
    }

    /// The time of the last key of any motion (seconds); 0 for a static scene.
    pub fn duration(&self) -> f64 {
        self.motions.iter().map(|a| a.motion.end()).fold(0.0, f64::max)
    }

    /// The scene at time `t`: every animated object moved by its motion, and no motions left
    /// (a still the tracers render). Objects are written in their own coordinates; an
    /// unanimated scene is returned unchanged.
    pub fn at(&self, t: f64) -> Scene {
        let mut s = Scene { motions: Vec::new(), ..self.clone() };
        for a in &self.motions {
            let m = a.motion.at(t);
            // Spheres and cones are checked to move by similarities: any axis gives the scale.
            let k = m.matrix3.x_axis.length();
            match a.target {
                Target::Sphere(i) => {
                    let sp = &mut s.spheres[i as usize];
                    sp.center = m.transform_point3(sp.center);
                    sp.radius *= k;
                }
                Target::Cone(i) => {
                    let c = &mut s.cones[i as usize];
                    (c.base, c.apex) = (m.transform_point3(c.base), m.transform_point3(c.apex));
                    c.base_radius *= k;
                    c.apex_radius *= k;
                }
                Target::Light(i) => {
                    let l = &mut s.lights[i as usize];
                    l.position = m.transform_point3(l.position);
                }
                Target::Mesh(i) => {
                    let mesh = &mut s.meshes[i as usize];
                    mesh.positions.iter_mut().for_each(|p| *p = m.transform_point3(*p));
                    // A mirroring pose turns the winding inside out; swapping two corners turns
                    // it back, as the loaders do when they bake a mirroring transform.
                    if m.matrix3.determinant() < 0.0 {
                        mesh.indices.iter_mut().for_each(|t| t.swap(1, 2));
                    }
                    if let Some(n) = &mut mesh.normals {
                        let nm: DMat3 = m.matrix3.inverse().transpose();
                        n.iter_mut().for_each(|v| *v = (nm * *v).normalize_or_zero());
                    }
                }
            }
        }
        s
    }

    /// [`Scene::at`] without a copy when nothing moves: what every renderer calls first.
    pub fn posed(&self, t: f64) -> Cow<'_, Scene> {
        if self.is_animated() {
            Cow::Owned(self.at(t))
        } else {
            Cow::Borrowed(self)
        }
    }

    /// Checks the motions: targets that exist, valid channels, spheres and cones scaled alike
    /// on every axis, transforms that stay invertible.
    pub fn validate_motions(&self) -> Result<(), InvalidScene> {
        for a in &self.motions {
            let (index, count) = match a.target {
                Target::Sphere(i) => (i, self.spheres.len()),
                Target::Cone(i) => (i, self.cones.len()),
                Target::Mesh(i) => (i, self.meshes.len()),
                Target::Light(i) => (i, self.lights.len()),
            };
            let who = format!("{} motion", a.target);
            if index as usize >= count {
                return Err(InvalidScene(format!("{who}: there is no such object ({count} exist)")));
            }
            for s in &a.motion.stages {
                s.validate(&who)?;
                for v in s.scales() {
                    if v.abs().min_element() == 0.0 {
                        return Err(InvalidScene(format!("{who}: a scale of 0 flattens the object")));
                    }
                    let round = matches!(a.target, Target::Sphere(_) | Target::Cone(_));
                    let a_ = v.abs();
                    if round
                        && a_.max_element() - a_.min_element() > UNIFORM_SCALE_TOLERANCE * a_.max_element()
                    {
                        return Err(InvalidScene(format!(
                            "{who}: scale ({}, {}, {}) differs between axes; spheres and cones scale alike on all",
                            v.x, v.y, v.z
                        )));
                    }
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn linear(times: &[f64], values: &[DVec3]) -> Channel<DVec3> {
        Channel { interpolation: Interpolation::Linear, times: times.to_vec(), values: values.to_vec() }
    }

    #[test]
    fn linear_step_and_clamping() {
        let c = linear(&[1.0, 3.0], &[DVec3::ZERO, DVec3::new(2.0, 4.0, -2.0)]);
        assert_eq!(c.sample(2.0), DVec3::new(1.0, 2.0, -1.0));
        assert_eq!(c.sample(-5.0), DVec3::ZERO, "before the first key: the first value");
        assert_eq!(c.sample(9.0), DVec3::new(2.0, 4.0, -2.0), "after the last: the last");
        assert_eq!(c.sample(f64::NAN), DVec3::ZERO, "NaN time holds the first key");
        let s = Channel { interpolation: Interpolation::Step, ..c.clone() };
        assert_eq!(s.sample(2.999), DVec3::ZERO);
        assert_eq!(s.sample(3.0), DVec3::new(2.0, 4.0, -2.0));
    }

    #[test]
    fn cubic_passes_through_keys_with_its_tangents() {
        let times = vec![0.0, 1.0, 3.0];
        let v = [DVec3::ZERO, DVec3::X, DVec3::new(5.0, 0.0, 0.0)];
        let c = Channel::catmull_rom(times, &v);
        for (t, want) in [(0.0, v[0]), (1.0, v[1]), (3.0, v[2])] {
            assert!((c.sample(t) - want).length() < 1e-12, "at {t}");
        }
        // The slope at a key is its tangent: central difference across key 1 ≈ (5 - 0) / 3.
        let h = 1e-6;
        let slope = (c.sample(1.0 + h) - c.sample(1.0 - h)).x / (2.0 * h);
        assert!((slope - 5.0 / 3.0).abs() < 1e-4, "slope {slope}");
        // Linear data stays linear under Catmull–Rom with even spacing.
        let even = Channel::catmull_rom(vec![0.0, 1.0, 2.0], &[DVec3::ZERO, DVec3::X, 2.0 * DVec3::X]);
        assert!((even.sample(0.25).x - 0.25).abs() < 1e-12);
        assert!((even.sample(1.5).x - 1.5).abs() < 1e-12);
    }

    #[test]
    fn quaternions_slerp_and_euler_turns_fully() {
        let c = Channel {
            interpolation: Interpolation::Linear,
            times: vec![0.0, 1.0],
            values: vec![DQuat::IDENTITY, DQuat::from_rotation_y(std::f64::consts::FRAC_PI_2)],
        };
        let half = c.sample(0.5);
        assert!(half.angle_between(DQuat::from_rotation_y(std::f64::consts::FRAC_PI_4)) < 1e-12);
        // Euler keys 0 → 360 about y: a quarter of the way is 90 degrees, not identity.
        let e = Rotation::EulerDegrees(linear(&[0.0, 4.0], &[DVec3::ZERO, DVec3::new(0.0, 360.0, 0.0)]));
        let q = e.sample(1.0);
        assert!((q * DVec3::X - DVec3::NEG_Z).length() < 1e-12, "{:?}", q * DVec3::X);
    }

    #[test]
    fn euler_order_is_x_then_y_then_z() {
        let q = euler_degrees(DVec3::new(90.0, 90.0, 0.0));
        // x first takes +y to +z, then y takes +z to +x.
        assert!((q * DVec3::Y - DVec3::X).length() < 1e-12, "{:?}", q * DVec3::Y);
    }

    #[test]
    fn validation_names_what_is_wrong() {
        let c = linear(&[0.0, 0.0], &[DVec3::ZERO, DVec3::X]);
        assert!(c.validate("t").unwrap_err().to_string().contains("times must increase"));
        let c = linear(&[0.0, 1.0], &[DVec3::ZERO]);
        assert!(c.validate("t").unwrap_err().to_string().contains("2 times but 1 values"));
        let c = linear(&[0.0, f64::INFINITY], &[DVec3::ZERO, DVec3::X]);
        assert!(c.validate("t").unwrap_err().to_string().contains("not finite"));
        let c = linear(&[0.0, 1.0], &[DVec3::ZERO, DVec3::splat(f64::NAN)]);
        assert!(c.validate("t").unwrap_err().to_string().contains("value 1"));
        let c: Channel<DVec3> = linear(&[], &[]);
        assert!(c.validate("t").unwrap_err().to_string().contains("no keys"));
    }

    #[test]
    fn spline_tangents_are_not_scales_and_mirroring_poses_keep_the_winding() {
        use crate::scene::Mesh;
        let mut scene = crate::scene::default_scene();
        scene.meshes.push(Mesh {
            positions: vec![DVec3::ZERO, DVec3::X, DVec3::Y],
            normals: None,
            uvs: None,
            indices: vec![[0, 1, 2]],
            material: 0,
        });
        let i = scene.meshes.len() as u32 - 1;
        // Zero tangents (the usual ones) around keys of scale 1 and -1 on x: a mirror at t = 1.
        let (one, flip) = (DVec3::ONE, DVec3::new(-1.0, 1.0, 1.0));
        let scale = Channel {
            interpolation: Interpolation::CubicSpline,
            times: vec![0.0, 1.0],
            values: vec![DVec3::ZERO, one, DVec3::ZERO, DVec3::ZERO, flip, DVec3::ZERO],
        };
        let stage =
            Stage::Keyed { translation: None, rotation: None, scale: Some(scale), rest: Trs::default() };
        scene.motions = vec![Animated { target: Target::Mesh(i), motion: Motion { stages: vec![stage] } }];
        scene.validate_motions().expect("tangents of 0 are no scale of 0");
        let m = |t: f64| scene.at(t).meshes[i as usize].clone();
        assert_eq!(m(0.0).indices, vec![[0, 1, 2]]);
        let mirrored = m(1.0);
        assert_eq!(mirrored.indices, vec![[0, 2, 1]]);
        // Still counter-clockwise seen from +z, as before the mirror.
        let p = mirrored.indices[0].map(|k| mirrored.positions[k as usize]);
        assert!((p[1] - p[0]).cross(p[2] - p[0]).z > 0.0);
    }

    #[test]
    fn chains_compose_outermost_first() {
        let m = Motion {
            stages: vec![
                Stage::Fixed(DAffine3::from_translation(DVec3::X)),
                Stage::Keyed {
                    translation: None,
                    rotation: None,
                    scale: Some(linear(&[0.0, 1.0], &[DVec3::ONE, DVec3::splat(3.0)])),
                    rest: Trs::default(),
                },
            ],
        };
        // Scaled by 2 at t = 0.5, then moved by +x.
        assert_eq!(m.at(0.5).transform_point3(DVec3::Y), DVec3::new(1.0, 2.0, 0.0));
        assert_eq!(m.end(), 1.0);
    }
}
