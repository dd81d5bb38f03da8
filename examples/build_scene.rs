//! Build a scene in code — a glass sphere over a floor, lit by a spherical light — trace it with
//! soft shadows, and check it against the independent f64 reference tracer.
//!
//!     cargo run --release --example build_scene -- build_scene.png

use glam::DVec3;
use irt::gpu::{AdapterChoice, GpuContext};
use irt::io::shapes;
use irt::render::{Session, Settings};
use irt::scene::{Ambient, Camera, Light, Material, MaterialKind, Scene, ShadowMode, Sphere, TraceSettings};

fn main() -> anyhow::Result<()> {
    let out = std::env::args().nth(1).unwrap_or_else(|| "build_scene.png".into());
    let material = |name: &str, kind| Material { name: name.into(), kind, texture: None };
    let scene = Scene {
        camera: Camera {
            eye: DVec3::new(0.0, 1.5, 5.0),
            look_at: DVec3::new(0.0, 0.6, 0.0),
            up: DVec3::Y,
            vfov_deg: 40.0,
            width: 480,
            height: 320,
        },
        // A spherical light of radius 0.4: soft shadows in the bundle and shell modes.
        lights: vec![Light { position: DVec3::new(2.0, 4.0, 3.0), color: DVec3::splat(0.9), radius: 0.4 }],
        ambient: Ambient { sky: DVec3::new(0.25, 0.3, 0.4), ground: DVec3::splat(0.1), up: DVec3::Y },
        background: DVec3::new(0.5, 0.6, 0.8),
        materials: vec![
            material("floor", MaterialKind::Diffuse { color: DVec3::new(0.7, 0.65, 0.6) }),
            material("glass", MaterialKind::Dielectric { eta: 1.5, exponent: 200.0 }),
            material("copper", MaterialKind::Metal { color: DVec3::new(0.95, 0.64, 0.54), exponent: 80.0 }),
        ],
        spheres: vec![
            Sphere { center: DVec3::new(-0.6, 0.6, 0.0), radius: 0.6, material: 1 },
            Sphere { center: DVec3::new(0.8, 0.4, -0.5), radius: 0.4, material: 2 },
        ],
        // Meshes come from the same generators the scene files use.
        meshes: vec![shapes::quad(DVec3::ZERO, [8.0, 8.0]).into_mesh(0)],
        cones: vec![],
        textures: vec![],
        trace: TraceSettings {
            shadows: ShadowMode::Bundle { samples: 16, rotate: true },
            ..Default::default()
        },
        motions: vec![],
        particles: Vec::new(),
        volumes: Vec::new(),
        patches: Vec::new(),
    };
    // Limits and consistency (indices, materials, finite numbers), in words a user can act on.
    scene.validate().map_err(|e| anyhow::anyhow!(e.0))?;

    let ctx = GpuContext::new(&AdapterChoice::from_arg_or_env(None))?;
    let mut session = Session::new(&ctx, &scene, Settings::bands())?;
    let gpu = session.picture(&ctx, &mut |_, _| {}).image;
    gpu.save_png(std::path::Path::new(&out))?;

    // The f64 CPU tracer of the same equations: what every GPU result is checked against.
    let cpu = irt::reference::render(&scene);
    let cpu = irt::image::Image {
        width: cpu.width,
        height: cpu.height,
        pixels: cpu.pixels.iter().map(|p| [p.x as f32, p.y as f32, p.z as f32]).collect(),
    };
    println!("wrote {out}; GPU against the f64 reference: {}", irt::metrics::compare(&gpu, &cpu));
    Ok(())
}
