//! What a model file lacks: OBJ, PLY and many glTF files carry geometry and materials but no
//! camera and no lights. [`stage`] gives such a [`Model`] the stage irt renders it on
//! (docs/formats.md, "Staging a model"): a camera that frames its bounding sphere, a light above
//! and to the right of the eye, the two-colour ambient and a neutral background.

use crate::scene::particles::Particles;
use crate::scene::{
    Ambient, Animated, Camera, Light, Material, Mesh, Scene, Sphere, Stage, Target, Texture, TraceSettings,
};
use glam::{DAffine3, DMat3, DVec3};

/// Geometry and materials without a stage: what a model loader returns and what a TOML scene's
/// `[[model]]` places. Each mesh's `material` indexes `materials`; each material's `texture`
/// indexes `textures`; `motions` animate meshes (a glTF file's animations; other formats have
/// none), their targets indexing `meshes`. A particle file's model has spheres instead of
/// meshes, and `particles` says what file they came from (`Particles::spheres` and `materials`
/// index this model's lists until it is placed).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Model {
    pub meshes: Vec<Mesh>,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    pub motions: Vec<Animated>,
    pub spheres: Vec<Sphere>,
    pub particles: Vec<Particles>,
    /// Sampled volumes (a volume file staged alone, or `[[volume]]`).
    pub volumes: Vec<crate::scene::volume::Volume>,
    /// Spline patches (OBJ free-form surfaces, STEP faces, `[[patch]]`).
    pub patches: Vec<crate::scene::patch::Patch>,
}

impl Model {
    /// Places the model: each axis scaled by `scale`, then rotated by `rotate_deg` (degrees about
    /// x, then y, then z), then moved by `translate`. Normals follow the inverse scale and the
    /// rotation, so they stay perpendicular to the surface. The identity changes nothing.
    /// Animated meshes stay in their own coordinates: the placement becomes their motion's
    /// outermost stage.
    pub fn transform(&mut self, scale: DVec3, rotate_deg: DVec3, translate: DVec3) {
        if scale == DVec3::ONE && rotate_deg == DVec3::ZERO && translate == DVec3::ZERO {
            return;
        }
        let r = rotation(rotate_deg);
        let placement = DAffine3::from_mat3_translation(r * DMat3::from_diagonal(scale), translate);
        let mut moving = vec![false; self.meshes.len()];
        for a in &mut self.motions {
            if let Some(m) = match a.target {
                Target::Mesh(i) => moving.get_mut(i as usize),
                _ => None,
            } {
                *m = true;
            }
            a.motion.stages.insert(0, Stage::Fixed(placement));
        }
        // Spheres stay round: they scale by the largest factor (TOML's `[[particles]]` takes
        // one factor, so there they are all the same).
        let radius_scale = scale.abs().max_element();
        for s in &mut self.spheres {
            s.center = r * (s.center * scale) + translate;
            s.radius *= radius_scale;
        }
        for p in &mut self.particles {
            p.scale *= radius_scale;
            p.rotate_deg = rotate_deg;
            p.translate = translate;
        }
        for v in &mut self.volumes {
            v.transform = placement * v.transform;
        }
        // A NURBS surface is affine invariant: its control points move, its weights stay.
        for patch in &mut self.patches {
            for q in &mut patch.points {
                *q = placement.transform_point3(q.truncate()).extend(q.w);
            }
        }
        for (mesh, _) in self.meshes.iter_mut().zip(moving).filter(|(_, moving)| !moving) {
            for p in &mut mesh.positions {
                *p = r * (*p * scale) + translate;
            }
            for n in mesh.normals.iter_mut().flatten() {
                *n = (r * (*n / scale)).normalize_or_zero();
            }
        }
    }
}

/// Rotation by `deg.x` degrees about x, then `deg.y` about y, then `deg.z` about z.
pub fn rotation(deg: DVec3) -> DMat3 {
    let r = deg * (std::f64::consts::PI / 180.0);
    DMat3::from_rotation_z(r.z) * DMat3::from_rotation_y(r.y) * DMat3::from_rotation_x(r.x)
}

/// Two-colour ambient of a staged model: a cool sky (A) above, a warm dark ground (B) below.
pub const DEFAULT_AMBIENT_SKY: DVec3 = DVec3::new(0.16, 0.17, 0.2);
pub const DEFAULT_AMBIENT_GROUND: DVec3 = DVec3::new(0.06, 0.055, 0.05);
pub const DEFAULT_BACKGROUND: DVec3 = DVec3::new(0.32, 0.36, 0.42);

/// Direction from the model's centre to the eye of the framing camera: in front (+z), a little
/// to the right and above, with +y up (the convention of glTF, and of most OBJ and PLY files).
/// An open model is seen from its open side instead ([`framing_direction`]).
pub const FRAMING_DIRECTION: DVec3 = DVec3::new(0.5, 0.45, 1.0);

/// The net area-weighted normal of a model, as a fraction of its area, from which it counts as
/// open to one side: 0 for a closed mesh, 1 for a flat one; 0.15 for the Cornell box (open at
/// −z), 0.02 for the Stanford bunny's holes in its base.
pub const OPEN_SIDE_FRACTION: f64 = 0.1;

/// Radius of the staging light as a fraction of the model's bounding radius (soft shadow modes
/// use it; hard shadows treat it as a point).
pub const STAGE_LIGHT_RADIUS: f64 = 0.05;

/// `model` on the default stage: [`framing_camera`] and [`headlight`].
pub fn stage(model: Model) -> Scene {
    stage_with(model, None, vec![])
}

/// `model` with the given camera (else [`framing_camera`]) and lights (if none,
/// [`headlight`]), the default ambient and background.
pub fn stage_with(mut model: Model, camera: Option<Camera>, mut lights: Vec<Light>) -> Scene {
    // Spheres, volumes and patches are framed by the corners of their boxes (a patch's: its
    // control points'), a mesh of points without triangles.
    let proxy = !model.spheres.is_empty() || !model.volumes.is_empty() || !model.patches.is_empty();
    if proxy {
        let mut corners = sphere_box_corners(&model.spheres);
        if model.spheres.is_empty() {
            corners.positions.clear();
        }
        for v in &model.volumes {
            let (lo, hi) = v.world_bounds();
            corners.positions.extend([lo, hi]);
        }
        for p in &model.patches {
            corners.positions.extend(p.points.iter().map(|q| q.truncate()));
        }
        model.meshes.push(corners);
    }
    let (center, radius) = bounds(&model.meshes);
    let camera = camera.unwrap_or_else(|| framing_camera(&model.meshes));
    if proxy {
        model.meshes.pop();
    }
    if lights.is_empty() {
        lights.push(headlight(&camera, center, radius));
    }
    Scene {
        camera,
        lights,
        ambient: Ambient { sky: DEFAULT_AMBIENT_SKY, ground: DEFAULT_AMBIENT_GROUND, up: DVec3::Y },
        background: DEFAULT_BACKGROUND,
        materials: model.materials,
        spheres: model.spheres,
        cones: vec![],
        meshes: model.meshes,
        textures: model.textures,
        trace: TraceSettings::default(),
        motions: model.motions,
        particles: model.particles,
        volumes: model.volumes,
        patches: model.patches,
    }
}

/// The eight corners of the box around `spheres`, as the positions of a mesh with no triangles.
fn sphere_box_corners(spheres: &[Sphere]) -> Mesh {
    let (lo, hi) = spheres.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), s| {
        (lo.min(s.center - s.radius), hi.max(s.center + s.radius))
    });
    let positions =
        (0..8).map(|i| DVec3::new([lo.x, hi.x][i & 1], [lo.y, hi.y][i >> 1 & 1], [lo.z, hi.z][i >> 2 & 1]));
    Mesh { positions: positions.collect(), normals: None, uvs: None, indices: vec![], material: 0 }
}

/// Centre and radius of the box around every vertex ([`bounding_box`]).
pub fn bounds(meshes: &[Mesh]) -> (DVec3, f64) {
    let (lo, hi) = bounding_box(meshes);
    let radius = 0.5 * (hi - lo).length();
    (0.5 * (lo + hi), if radius > 0.0 && radius.is_finite() { radius } else { 1.0 })
}

/// Corners of the box around every vertex (the unit box about the origin for no vertices).
pub fn bounding_box(meshes: &[Mesh]) -> (DVec3, DVec3) {
    let points = meshes.iter().flat_map(|m| &m.positions);
    let (lo, hi) =
        points.fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
    if lo.is_finite() && hi.is_finite() {
        (lo, hi)
    } else {
        (DVec3::splat(-0.5), DVec3::splat(0.5))
    }
}

/// Fraction of the half field of view (each way) that the framed box may fill.
const FRAMING_FILL: f64 = 0.9;

/// A camera that looks at the centre of the meshes' bounding box from [`FRAMING_DIRECTION`],
/// as close as it can while every corner of the box lies within [`FRAMING_FILL`] of the field
/// of view (vertical and horizontal), and never inside the box's bounding sphere. Fitting the
/// corners rather than the sphere frames flat and long models as tightly as round ones.
pub fn framing_camera(meshes: &[Mesh]) -> Camera {
    use super::toml::{DEFAULT_FOV_DEG, DEFAULT_HEIGHT, DEFAULT_WIDTH};
    let (lo, hi) = bounding_box(meshes);
    let (center, radius) = bounds(meshes);
    let mut camera = Camera {
        eye: center + framing_direction(meshes),
        look_at: center,
        up: DVec3::Y,
        vfov_deg: DEFAULT_FOV_DEG,
        width: DEFAULT_WIDTH,
        height: DEFAULT_HEIGHT,
    };
    // The basis's u and v are the image plane's half extents at distance 1.
    let b = camera.basis();
    let (tan_x, tan_y) = (b.u.length() * FRAMING_FILL, b.v.length() * FRAMING_FILL);
    let (right, up) = (b.u.normalize(), b.v.normalize());
    let mut distance = 1.05 * radius;
    for i in 0..8 {
        let corner =
            DVec3::new([lo.x, hi.x][i & 1], [lo.y, hi.y][i >> 1 & 1], [lo.z, hi.z][i >> 2 & 1]) - center;
        // At eye distance d the corner is d + c·w in front of the eye.
        let ahead = corner.dot(b.w);
        distance =
            distance.max(corner.dot(right).abs() / tan_x - ahead).max(corner.dot(up).abs() / tan_y - ahead);
    }
    camera.eye = center - b.w * distance;
    camera
}

/// Where the framing camera looks from: [`FRAMING_DIRECTION`], unless the triangles' net
/// area-weighted normal (their windings' sum, which cancels on a closed mesh) reaches
/// [`OPEN_SIDE_FRACTION`] of their area: then the model is open to that side — a box without
/// its front wall, a single sheet — and is seen from there (the same offsets turned about y, or
/// from above or below).
pub fn framing_direction(meshes: &[Mesh]) -> DVec3 {
    let (mut net, mut area) = (DVec3::ZERO, 0.0);
    for m in meshes {
        for t in &m.indices {
            let p = t.map(|i| m.positions[i as usize]);
            let twice = (p[1] - p[0]).cross(p[2] - p[0]);
            net += twice;
            area += twice.length();
        }
    }
    let d = FRAMING_DIRECTION;
    // Also the default when the sums are not finite (NaN fails every comparison).
    let open = area > 0.0 && net.length() >= OPEN_SIDE_FRACTION * area;
    if !open {
        return d.normalize();
    }
    let a = net.abs();
    let dir = if a.y >= a.x && a.y >= a.z {
        DVec3::new(d.x, d.z * net.y.signum(), d.y)
    } else if a.x >= a.z {
        DVec3::new(d.z * net.x.signum(), d.y, -d.x * net.x.signum())
    } else {
        DVec3::new(d.x * net.z.signum(), d.y, d.z * net.z.signum())
    };
    dir.normalize()
}

/// The light of a scene without lights: white, above and to the right of the eye, so that what
/// the camera sees is lit and shadows fall behind and below it.
/// Poses at which [`swept_meshes`] frames an animation (its two ends included).
pub const FRAMING_POSES: u32 = 9;
/// Above this many vertices over all poses, an animation is framed on its pose at time 0 alone.
const MAX_FRAMING_VERTICES: usize = 1 << 22;

/// The meshes of `scene` at [`FRAMING_POSES`] times over its animation, one after another: what
/// a stage frames so that nothing moves out of view (only for bounds and directions; a still
/// scene gives its meshes once).
pub fn swept_meshes(scene: &Scene) -> Vec<Mesh> {
    let vertices: usize = scene.meshes.iter().map(|m| m.positions.len()).sum();
    let poses = if vertices * FRAMING_POSES as usize > MAX_FRAMING_VERTICES { 1 } else { FRAMING_POSES };
    let end = scene.duration();
    (0..poses).flat_map(|k| scene.at(end * k as f64 / (FRAMING_POSES - 1) as f64).meshes).collect()
}

pub fn headlight(camera: &Camera, center: DVec3, radius: f64) -> Light {
    let b = camera.basis();
    let reach = (center - camera.eye).length().max(radius);
    let offset = (b.u.normalize() + b.v.normalize()) * (0.5 * reach);
    Light { position: camera.eye + offset, color: DVec3::ONE, radius: STAGE_LIGHT_RADIUS * radius }
}
