//! Whole-tracer checks against values worked out by hand.

use super::*;
use crate::scene::{
    Ambient, Camera, Light, Material, MaterialKind, Mesh, Scene, Sphere, TraceSettings,
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
        camera: Camera {
            eye,
            look_at,
            up: v(0., 1., 0.),
            vfov_deg: 40.0,
            width: 4,
            height: 4,
        },
        lights: vec![],
        ambient: Ambient {
            sky: v(0.2, 0.3, 0.4),
            ground: v(0.1, 0.05, 0.0),
            up: v(0., 1., 0.),
        },
        background: v(0.7, 0.8, 0.9),
        materials: materials
            .into_iter()
            .enumerate()
            .map(|(i, kind)| Material {
                name: format!("m{i}"),
                kind,
            })
            .collect(),
        spheres: vec![],
        meshes: vec![],
        trace: TraceSettings::default(),
    }
}

/// Square of half-side `h` centred at `c` in the plane spanned by `a` and `b`; its winding
/// faces `a × b`.
fn quad(c: DVec3, a: DVec3, b: DVec3, h: f64, material: u32) -> Mesh {
    Mesh {
        positions: vec![
            c - h * a - h * b,
            c + h * a - h * b,
            c + h * a + h * b,
            c - h * a + h * b,
        ],
        normals: None,
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
    let mut s = scene(
        v(0., 0., 5.),
        DVec3::ZERO,
        vec![MaterialKind::Diffuse { color: kd }],
    );
    s.spheres.push(Sphere {
        center: DVec3::ZERO,
        radius: 1.0,
        material: 0,
    });
    let le = v(0.9, 0.8, 0.3);
    s.lights.push(Light {
        position: v(0., 0., 10.),
        color: le,
        radius: 0.0,
    });
    s.validate().unwrap();
    let (l, st) = centre(&Reference::new(&s));
    // n = (0, 0, 1) is perpendicular to up: I_a = (A + B)/2; n·l = 1.
    let ia = (s.ambient.sky + s.ambient.ground) / 2.0;
    assert!(close(l, kd * (ia + le), 1e-12), "{l}");
    assert_eq!(
        st,
        Stats {
            eye: 1,
            reflection: 0,
            refraction: 0,
            shadow: 1
        }
    );
    // The free function agrees.
    assert_eq!(trace_pixel(&s, 2.0, 2.0), l);
    // A corner pixel misses and sees the background.
    assert_eq!(trace_pixel(&s, 0.5, 0.5), s.background);
}

#[test]
fn mirror_reflects_the_wall_behind_the_camera() {
    let kd = v(0.3, 0.6, 0.9);
    let mirror = MaterialKind::Metal {
        color: DVec3::ONE,
        exponent: 20.0,
    };
    let mut s = scene(
        v(0., 0., 0.),
        v(0., 0., -1.),
        vec![MaterialKind::Diffuse { color: kd }, mirror],
    );
    // Mirror at z = -5 facing +z, diffuse wall at z = +5 facing -z (behind the eye).
    s.meshes
        .push(quad(v(0., 0., -5.), v(1., 0., 0.), v(0., 1., 0.), 10.0, 1));
    s.meshes
        .push(quad(v(0., 0., 5.), v(0., 1., 0.), v(1., 0., 0.), 10.0, 0));
    let le = v(1.0, 0.5, 0.25);
    s.lights.push(Light {
        position: v(0., 3., 0.),
        color: le,
        radius: 0.0,
    });
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
    assert_eq!(
        st,
        Stats {
            eye: 1,
            reflection: 1,
            refraction: 0,
            shadow: 2
        }
    );

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
    let mut s = scene(
        v(3., 1., 0.),
        DVec3::ZERO,
        vec![MaterialKind::Diffuse { color: kd }],
    );
    s.meshes
        .push(quad(DVec3::ZERO, v(0., 0., 1.), v(1., 0., 0.), 10.0, 0));
    let le = v(1., 1., 1.);
    s.lights.push(Light {
        position: v(0., 10., 0.),
        color: le,
        radius: 0.0,
    });
    s.validate().unwrap();
    // Unshadowed first: floor normal = up, I_a = A, n·l = 1.
    let (lit, st) = centre(&Reference::new(&s));
    assert!(close(lit, kd * (s.ambient.sky + le), 1e-12), "{lit}");
    assert_eq!(st.shadow, 1);
    s.spheres.push(Sphere {
        center: v(0., 5., 0.),
        radius: 1.0,
        material: 0,
    });
    let (dark, st) = centre(&Reference::new(&s));
    assert!(close(dark, kd * s.ambient.sky, 1e-12), "{dark}");
    assert_eq!(
        st,
        Stats {
            eye: 1,
            reflection: 0,
            refraction: 0,
            shadow: 1
        }
    );
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
    let glass = MaterialKind::Dielectric {
        eta: 1.5,
        exponent: 0.0,
    };
    let mut s = scene(v(0., 0., 5.), DVec3::ZERO, vec![glass]);
    s.spheres.push(Sphere {
        center: DVec3::ZERO,
        radius: 1.0,
        material: 0,
    });
    let bg = s.background;
    // Depth 2: front reflection sees the background; the back hit has no children.
    s.trace.max_depth = 2;
    let (l, st) = centre(&Reference::new(&s));
    assert!(close(l, 0.04 * bg, 1e-12), "{l}");
    assert_eq!(
        st,
        Stats {
            eye: 1,
            reflection: 1,
            refraction: 1,
            shadow: 0
        }
    );
    // Depth 3: the back hit refracts out (0.96) and reflects back into the front (dark).
    s.trace.max_depth = 3;
    let (l, st) = centre(&Reference::new(&s));
    assert!(close(l, (0.04 + 0.96 * 0.96) * bg, 1e-12), "{l}");
    assert_eq!(
        st,
        Stats {
            eye: 1,
            reflection: 2,
            refraction: 2,
            shadow: 0
        }
    );
    // eta = 1: no reflection weight at normal incidence (cut off), straight through.
    s.materials[0].kind = MaterialKind::Dielectric {
        eta: 1.0,
        exponent: 0.0,
    };
    let (l, st) = centre(&Reference::new(&s));
    assert!(close(l, bg, 1e-12), "{l}");
    assert_eq!(
        st,
        Stats {
            eye: 1,
            reflection: 0,
            refraction: 2,
            shadow: 0
        }
    );
}

#[test]
fn interpolated_normals_shade_and_flip() {
    // A floor quad whose vertex normals all tilt 60° from the geometric normal towards +x.
    let kd = v(1., 1., 1.);
    let mut s = scene(
        v(0., 3., 0.001),
        DVec3::ZERO,
        vec![MaterialKind::Diffuse { color: kd }],
    );
    let mut q = quad(DVec3::ZERO, v(0., 0., 1.), v(1., 0., 0.), 10.0, 0);
    let th = 60f64.to_radians();
    q.normals = Some(vec![v(th.sin(), th.cos(), 0.); 4]);
    s.meshes.push(q);
    s.lights.push(Light {
        position: v(0., 10., 0.),
        color: v(1., 1., 1.),
        radius: 0.0,
    });
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
        vec![MaterialKind::Polished {
            color: v(0.5, 0.5, 0.5),
            eta: 1.5,
            exponent: 30.0,
        }],
    );
    s.camera.width = 7;
    s.camera.height = 5;
    s.spheres.push(Sphere {
        center: DVec3::ZERO,
        radius: 1.5,
        material: 0,
    });
    s.lights.push(Light {
        position: v(2., 3., 4.),
        color: v(1., 1., 1.),
        radius: 0.0,
    });
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
