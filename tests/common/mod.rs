//! Shared test helpers: a seeded RNG, GPU setup, and small scene builders.
#![allow(dead_code)]

use glam::DVec3;
use irt::scene::*;

/// xorshift64*: deterministic, dependency-free, good enough to spread test inputs.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    /// Uniform in [0, 1).
    pub fn f(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.f()
    }
    pub fn vec(&mut self, lo: f64, hi: f64) -> DVec3 {
        DVec3::new(self.range(lo, hi), self.range(lo, hi), self.range(lo, hi))
    }
    pub fn unit(&mut self) -> DVec3 {
        loop {
            let v = self.vec(-1.0, 1.0);
            let l = v.length_squared();
            if l > 1e-4 && l <= 1.0 {
                return v / l.sqrt();
            }
        }
    }
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
}

/// The f32 vec4 the kernels read, from f64 values.
pub fn v4(v: DVec3, w: f64) -> [f32; 4] {
    [v.x as f32, v.y as f32, v.z as f32, w as f32]
}

/// The f64 value of what the GPU actually sees (inputs rounded to f32 first), so tests compare
/// the functions and not the rounding of their inputs.
pub fn f32_round(v: DVec3) -> DVec3 {
    DVec3::new(v.x as f32 as f64, v.y as f32 as f64, v.z as f32 as f64)
}

pub fn gpu() -> irt::gpu::GpuContext {
    irt::gpu::GpuContext::new(&irt::gpu::AdapterChoice::Lavapipe)
        .expect("lavapipe is installed (scripts/setup.sh)")
}

pub fn material(name: &str, kind: MaterialKind) -> Material {
    Material { name: name.into(), kind }
}

/// A scene of the given spheres and triangles (one diffuse material), camera looking at them.
pub fn scene_of(spheres: Vec<Sphere>, triangles: Vec<[DVec3; 3]>) -> Scene {
    let mut positions = Vec::new();
    let mut indices = Vec::new();
    for t in &triangles {
        let b = positions.len() as u32;
        positions.extend_from_slice(t);
        indices.push([b, b + 1, b + 2]);
    }
    let meshes = if triangles.is_empty() {
        vec![]
    } else {
        vec![Mesh { positions, normals: None, indices, material: 0 }]
    };
    Scene {
        camera: Camera {
            eye: DVec3::new(0.0, 0.0, 10.0),
            look_at: DVec3::ZERO,
            up: DVec3::Y,
            vfov_deg: 40.0,
            width: 8,
            height: 8,
        },
        lights: vec![],
        ambient: Ambient { sky: DVec3::ONE, ground: DVec3::ZERO, up: DVec3::Y },
        background: DVec3::ZERO,
        materials: vec![material("grey", MaterialKind::Diffuse { color: DVec3::splat(0.5) })],
        spheres,
        meshes,
        trace: TraceSettings::default(),
    }
}

/// Barycentrics (of p1, p2) where the ray meets the triangle's plane, inside or not.
pub fn plane_barycentrics(o: DVec3, d: DVec3, t: [DVec3; 3]) -> (f64, f64) {
    let (e1, e2) = (t[1] - t[0], t[2] - t[0]);
    let n = e1.cross(e2);
    let p = o + d * ((t[0] - o).dot(n) / d.dot(n)) - t[0];
    let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (p1, p2) = (p.dot(e1), p.dot(e2));
    let den = d11 * d22 - d12 * d12;
    ((d22 * p1 - d12 * p2) / den, (d11 * p2 - d12 * p1) / den)
}
