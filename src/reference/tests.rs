//! Whole-tracer checks against values worked out by hand.

use super::*;
use crate::scene::{
    Ambient, Camera, Cone, Light, Material, MaterialKind, Mesh, Scene, Sphere, TraceSettings,
};
use glam::DVec3;

fn v(x: f64, y: f64, z: f64) -> DVec3 {
    DVec3::new(x, y, z)
}

fn close(a: DVec3, b: DVec3, tol: f64) -> bool {
    (a - b).abs().max_element() <= tol
}

/// A camera at `eye` looking at `look_at`, 4x4 pixels so position (2, 2) is the exact centre.
fn scene(eye: DVec3, look_at: DVec3, materials: Vec<MaterialKind>) -> Scene {
    Scene {
        camera: Camera { eye, look_at, up: v(0., 1., 0.), vfov_deg: 40.0, width: 4, height: 4 },
        lights: vec![],
        ambient: Ambient { sky: v(0.2, 0.3, 0.4), ground: v(0.1, 0.05, 0.0), up: v(0., 1., 0.) },
        background: v(0.7, 0.8, 0.9),
        materials: materials
            .into_iter()
            .enumerate()
            .map(|(i, kind)| Material { name: format!("m{i}"), kind, texture: None })
            .collect(),
        spheres: vec![],
        meshes: vec![],
        cones: vec![],
        textures: vec![],
        trace: TraceSettings::default(),
        motions: Vec::new(),
        particles: Vec::new(),
        volumes: Vec::new(),
        patches: Vec::new(),
    }
}

/// Square of half-side `h` centred at `c` in the plane spanned by `a` and `b`; its winding
/// faces `a × b`.
fn quad(c: DVec3, a: DVec3, b: DVec3, h: f64, material: u32) -> Mesh {
    Mesh {
        positions: vec![c - h * a - h * b, c + h * a - h * b, c + h * a + h * b, c - h * a + h * b],
        normals: None,
        uvs: None,
        indices: vec![[0, 1, 2], [0, 2, 3]],
        material,
    }
}

fn centre(r: &Reference) -> (DVec3, Stats) {
    let mut st = Stats::default();
    let c = &r.scene.camera;
    let l = r.trace_pixel(c.width as f64 / 2.0, c.height as f64 / 2.0, &mut st);
    (l, st)
}

#[test]
fn diffuse_sphere_lit_head_on() {
    let kd = v(0.5, 0.6, 0.7);
    let mut s = scene(v(0., 0., 5.), DVec3::ZERO, vec![MaterialKind::Diffuse { color: kd }]);
    s.spheres.push(Sphere { center: DVec3::ZERO, radius: 1.0, material: 0 });
    let le = v(0.9, 0.8, 0.3);
    s.lights.push(Light { position: v(0., 0., 10.), color: le, radius: 0.0 });
    s.validate().unwrap();
    let (l, st) = centre(&Reference::new(&s));
    // n = (0, 0, 1) is perpendicular to up: I_a = (A + B)/2; n·l = 1.
    let ia = (s.ambient.sky + s.ambient.ground) / 2.0;
    assert!(close(l, kd * (ia + le), 1e-12), "{l}");
    assert_eq!(st, Stats { eye: 1, reflection: 0, refraction: 0, shadow: 1 });
    // The free function agrees.
    assert_eq!(trace_pixel(&s, 2.0, 2.0), l);
    // A corner pixel misses and sees the background.
    assert_eq!(trace_pixel(&s, 0.5, 0.5), s.background);
}

#[test]
fn mirror_reflects_the_wall_behind_the_camera() {
    let kd = v(0.3, 0.6, 0.9);
    let mirror = MaterialKind::Metal { color: DVec3::ONE, exponent: 20.0 };
    let mut s = scene(v(0., 0., 0.), v(0., 0., -1.), vec![MaterialKind::Diffuse { color: kd }, mirror]);
    // Mirror at z = -5 facing +z, diffuse wall at z = +5 facing -z (behind the eye).
    s.meshes.push(quad(v(0., 0., -5.), v(1., 0., 0.), v(0., 1., 0.), 10.0, 1));
    s.meshes.push(quad(v(0., 0., 5.), v(0., 1., 0.), v(1., 0., 0.), 10.0, 0));
    let le = v(1.0, 0.5, 0.25);
    s.lights.push(Light { position: v(0., 3., 0.), color: le, radius: 0.0 });
    s.validate().unwrap();
    let r = Reference::new(&s);
    let (l, st) = centre(&r);
    // Wall at (0, 0, 5): n = (0, 0, -1), l = (0, 3, -5)/√34, I_a = (A + B)/2.
    let ia = (s.ambient.sky + s.ambient.ground) / 2.0;
    let wall = kd * (ia + le * (5.0 / 34f64.sqrt()));
    // Mirror (F = 1 at any angle): highlight with n·h = cos(half the angle between l and e).
    let nh = ((3.0f64 / 5.0).atan() / 2.0).cos();
    let want = le * nh.powf(20.0) + wall;
    assert!(close(l, want, 1e-12), "{l} vs {want}");
    assert_eq!(st, Stats { eye: 1, reflection: 1, refraction: 0, shadow: 2 });

    // Depth 1: no reflection ray, only the highlight.
    let mut s1 = s.clone();
    s1.trace.max_depth = 1;
    let (l, st) = centre(&Reference::new(&s1));
    assert!(close(l, le * nh.powf(20.0), 1e-12), "{l}");
    assert_eq!(st.reflection, 0);
}

#[test]
fn shadowed_point_gets_only_ambient() {
    let kd = v(0.8, 0.7, 0.6);
    // Look straight down at the floor point (0, 0, 0); light above; a sphere between them.
    let mut s = scene(v(3., 1., 0.), DVec3::ZERO, vec![MaterialKind::Diffuse { color: kd }]);
    s.meshes.push(quad(DVec3::ZERO, v(0., 0., 1.), v(1., 0., 0.), 10.0, 0));
    let le = v(1., 1., 1.);
    s.lights.push(Light { position: v(0., 10., 0.), color: le, radius: 0.0 });
    s.validate().unwrap();
    // Unshadowed first: floor normal = up, I_a = A, n·l = 1.
    let (lit, st) = centre(&Reference::new(&s));
    assert!(close(lit, kd * (s.ambient.sky + le), 1e-12), "{lit}");
    assert_eq!(st.shadow, 1);
    s.spheres.push(Sphere { center: v(0., 5., 0.), radius: 1.0, material: 0 });
    let (dark, st) = centre(&Reference::new(&s));
    assert!(close(dark, kd * s.ambient.sky, 1e-12), "{dark}");
    assert_eq!(st, Stats { eye: 1, reflection: 0, refraction: 0, shadow: 1 });
    // Light under the floor: n·l < 0, no light and no shadow ray.
    s.spheres.clear();
    s.lights[0].position = v(0., -10., 0.);
    let (under, st) = centre(&Reference::new(&s));
    assert!(close(under, kd * s.ambient.sky, 1e-12), "{under}");
    assert_eq!(st.shadow, 0);
}

#[test]
fn glass_sphere_at_normal_incidence() {
    // Centre pixel through a glass ball: F = 0.04 at both interfaces, the rays stay on axis.
    let glass = MaterialKind::Dielectric { eta: 1.5, exponent: 0.0 };
    let mut s = scene(v(0., 0., 5.), DVec3::ZERO, vec![glass]);
    s.spheres.push(Sphere { center: DVec3::ZERO, radius: 1.0, material: 0 });
    let bg = s.background;
    // Depth 2: front reflection sees the background; the back hit has no children.
    s.trace.max_depth = 2;
    let (l, st) = centre(&Reference::new(&s));
    assert!(close(l, 0.04 * bg, 1e-12), "{l}");
    assert_eq!(st, Stats { eye: 1, reflection: 1, refraction: 1, shadow: 0 });
    // Depth 3: the back hit refracts out (0.96) and reflects back into the front (dark).
    s.trace.max_depth = 3;
    let (l, st) = centre(&Reference::new(&s));
    assert!(close(l, (0.04 + 0.96 * 0.96) * bg, 1e-12), "{l}");
    assert_eq!(st, Stats { eye: 1, reflection: 2, refraction: 2, shadow: 0 });
    // eta = 1: no reflection weight at normal incidence (cut off), straight through.
    s.materials[0].kind = MaterialKind::Dielectric { eta: 1.0, exponent: 0.0 };
    let (l, st) = centre(&Reference::new(&s));
    assert!(close(l, bg, 1e-12), "{l}");
    assert_eq!(st, Stats { eye: 1, reflection: 0, refraction: 2, shadow: 0 });
}

#[test]
fn interpolated_normals_shade_and_flip() {
    // A floor quad whose vertex normals all tilt 60° from the geometric normal towards +x.
    let kd = v(1., 1., 1.);
    let mut s = scene(v(0., 3., 0.001), DVec3::ZERO, vec![MaterialKind::Diffuse { color: kd }]);
    let mut q = quad(DVec3::ZERO, v(0., 0., 1.), v(1., 0., 0.), 10.0, 0);
    let th = 60f64.to_radians();
    q.normals = Some(vec![v(th.sin(), th.cos(), 0.); 4]);
    s.meshes.push(q);
    s.lights.push(Light { position: v(0., 10., 0.), color: v(1., 1., 1.), radius: 0.0 });
    s.ambient.sky = DVec3::ZERO;
    s.ambient.ground = DVec3::ZERO;
    let (l, _) = centre(&Reference::new(&s));
    let nl = v(th.sin(), th.cos(), 0.).dot(v(0., 10., 0.).normalize() * 1.0);
    assert!((l.x - nl).abs() < 1e-6, "{l} vs {nl}");
    // Seen from below, n and n_g flip together: the light above now faces away.
    s.camera.eye = v(0., -3., 0.001);
    let (l, st) = centre(&Reference::new(&s));
    assert_eq!(l, DVec3::ZERO);
    assert_eq!(st.shadow, 0);
}

#[test]
fn render_matches_trace_pixel_and_counts_rays() {
    let mut s = scene(
        v(0., 0., 5.),
        DVec3::ZERO,
        vec![MaterialKind::Polished { color: v(0.5, 0.5, 0.5), eta: 1.5, exponent: 30.0 }],
    );
    s.camera.width = 7;
    s.camera.height = 5;
    s.spheres.push(Sphere { center: DVec3::ZERO, radius: 1.5, material: 0 });
    s.lights.push(Light { position: v(2., 3., 4.), color: v(1., 1., 1.), radius: 0.0 });
    let (img, st) = render_with_stats(&s);
    assert_eq!((img.width, img.height, img.pixels.len()), (7, 5, 35));
    let r = Reference::new(&s);
    let mut want = Stats::default();
    for y in 0..5 {
        for x in 0..7 {
            let l = r.trace_pixel(x as f64 + 0.5, y as f64 + 0.5, &mut want);
            assert_eq!(img.get(x, y), l, "pixel {x},{y}");
        }
    }
    assert_eq!(st, want);
    assert_eq!(st.eye, 35);
    assert!(st.reflection > 0 && st.shadow > 0);
    assert_eq!(render(&s), img);
}

/// xorshift64*: deterministic test inputs without a dependency.
struct Rng(u64);

impl Rng {
    fn f(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.f()
    }
    fn vec(&mut self, a: f64, b: f64) -> DVec3 {
        v(self.range(a, b), self.range(a, b), self.range(a, b))
    }
}

/// Random spheres, triangles and cones plus an axis-aligned floor grid (flat boxes, shared edges).
fn random_scene(rng: &mut Rng) -> Scene {
    let mats = vec![
        MaterialKind::Diffuse { color: v(0.8, 0.5, 0.3) },
        MaterialKind::Metal { color: v(0.9, 0.9, 0.6), exponent: 50.0 },
        MaterialKind::Dielectric { eta: 1.5, exponent: 100.0 },
        MaterialKind::Polished { color: v(0.2, 0.6, 0.9), eta: 1.4, exponent: 20.0 },
    ];
    let mut s = scene(v(0., 4., 12.), v(0., 0., 0.), mats);
    s.camera.width = 24;
    s.camera.height = 18;
    s.lights.push(Light { position: v(5., 10., 5.), color: v(0.8, 0.8, 0.8), radius: 0.0 });
    s.lights.push(Light { position: v(-6., 4., 8.), color: v(0.3, 0.4, 0.5), radius: 0.0 });
    for i in 0..40 {
        let c = rng.vec(-4.0, 4.0).max(v(-4., 0.2, -4.));
        s.spheres.push(Sphere { center: c, radius: rng.range(0.1, 0.8), material: i % 4 });
    }
    let mut soup = Mesh { positions: vec![], normals: Some(vec![]), uvs: None, indices: vec![], material: 0 };
    for i in 0..60u32 {
        let c = rng.vec(-4.0, 4.0);
        for _ in 0..3 {
            soup.positions.push(c + rng.vec(-1.0, 1.0));
            soup.normals.as_mut().unwrap().push(rng.vec(-1.0, 1.0).normalize());
        }
        soup.indices.push([3 * i, 3 * i + 1, 3 * i + 2]);
    }
    soup.material = 3;
    s.meshes.push(soup);
    for i in 0..20 {
        let c = rng.vec(-4.0, 4.0);
        let axis = rng.vec(-1.5, 1.5);
        let r0 = rng.range(0.05, 0.6);
        // Cylinders, truncated and pointed cones.
        let r1 = [r0, rng.range(0.05, 0.6), 0.0][i % 3];
        s.cones.push(Cone {
            base: c - axis,
            base_radius: r0,
            apex: c + axis,
            apex_radius: r1,
            material: i as u32 % 4,
        });
    }
    let mut floor = Mesh { positions: vec![], normals: None, uvs: None, indices: vec![], material: 0 };
    let n = 8u32;
    for j in 0..=n {
        for i in 0..=n {
            floor.positions.push(v(i as f64 - 4.0, 0.0, j as f64 - 4.0));
        }
    }
    for j in 0..n {
        for i in 0..n {
            let k = j * (n + 1) + i;
            floor.indices.push([k, k + n + 1, k + 1]);
            floor.indices.push([k + 1, k + n + 1, k + n + 2]);
        }
    }
    s.meshes.push(floor);
    s.validate().unwrap();
    s
}

#[test]
fn bvh_gives_exactly_the_brute_force_answers() {
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    for _ in 0..3 {
        let s = random_scene(&mut rng);
        let fast = Reference::new(&s);
        let slow = Reference::brute_force(&s);
        for k in 0..4000 {
            let o = rng.vec(-6.0, 6.0);
            // Some rays through floor-grid vertices and edges, the rest random.
            let target = if k % 3 == 0 {
                v((rng.range(-4., 4.) * 2.0).round() / 2.0, 0.0, (rng.range(-4., 4.)).round())
            } else {
                rng.vec(-5.0, 5.0)
            };
            let d = (target - o).normalize();
            let a = fast.intersect(o, d, f64::INFINITY);
            let b = slow.intersect(o, d, f64::INFINITY);
            match (a, b) {
                (None, None) => {}
                (Some(a), Some(b)) => {
                    assert_eq!((a.t, a.material, a.n, a.n_g), (b.t, b.material, b.n, b.n_g))
                }
                _ => panic!("ray {o} {d}: bvh {a:?} vs brute {b:?}"),
            }
            let t_max = rng.range(0.0, 12.0);
            assert_eq!(fast.occluded(o, d, t_max), slow.occluded(o, d, t_max));
        }
        let (img_fast, st_fast) = fast.render();
        let (img_slow, st_slow) = slow.render();
        assert_eq!(img_fast, img_slow);
        assert_eq!(st_fast, st_slow);
        assert!(st_fast.refraction > 0 && st_fast.reflection > 0 && st_fast.shadow > 0);
    }
}

#[test]
fn empty_scene_is_background() {
    let s = scene(v(0., 0., 5.), DVec3::ZERO, vec![]);
    let img = render(&s);
    assert!(img.pixels.iter().all(|&p| p == s.background));
}
