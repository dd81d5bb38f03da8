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

/// The xyz of a kernel's vec4 output (or input) as f64.
pub fn d3(v: [f32; 4]) -> DVec3 {
    DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64)
}

/// The f64 value of what the GPU actually sees (inputs rounded to f32 first), so tests compare
/// the functions and not the rounding of their inputs.
pub fn f32_round(v: DVec3) -> DVec3 {
    DVec3::new(v.x as f32 as f64, v.y as f32 as f64, v.z as f32 as f64)
}

/// The device the GPU tests run on: lavapipe, or the adapter `$IRT_ADAPTER` names (`gpu` for
/// the best hardware GPU), so the same per-pixel checks against the reference can be run on a GPU.
pub fn adapter() -> irt::gpu::AdapterChoice {
    irt::gpu::AdapterChoice::from_arg_or_env(None)
}

pub fn gpu() -> irt::gpu::GpuContext {
    irt::gpu::GpuContext::new(&adapter())
        .expect("lavapipe is installed (scripts/setup.sh), or $IRT_ADAPTER names a device")
}

pub fn material(name: &str, kind: MaterialKind) -> Material {
    Material { name: name.into(), kind, texture: None }
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
        vec![Mesh { positions, normals: None, uvs: None, indices, material: 0 }]
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
        cones: vec![],
        textures: vec![],
        trace: TraceSettings::default(),
        motions: Vec::new(),
        particles: Vec::new(),
        volumes: Vec::new(),
        patches: Vec::new(),
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

/// The scene traced on the GPU (its own shadow mode, the specialised pipeline). Every test render
/// also checks that no pixel came near lavapipe's loop-iteration limit (a quarter of it: the
/// count is per pixel, the limit per group of SIMD lanes), past which its results are wrong.
pub fn render_gpu(ctx: &irt::gpu::GpuContext, scene: &Scene) -> irt::image::Image {
    render_gpu_with(ctx, scene, irt::render::Settings::bands())
}

/// [`render_gpu`] with `opts` (another accelerator, f64, ...).
pub fn render_gpu_with(
    ctx: &irt::gpu::GpuContext,
    scene: &Scene,
    opts: irt::render::Settings,
) -> irt::image::Image {
    let mut r = irt::render::Session::new(ctx, scene, opts).expect("renderer");
    let frame = r.picture(ctx, &mut |_, _| {});
    let limit = irt::gpu::layout::LAVAPIPE_LOOP_LIMIT;
    assert!(
        frame.max_loop_iterations < limit / 4,
        "{} loop iterations in a pixel",
        frame.max_loop_iterations
    );
    frame.image
}

pub fn to_image(r: &irt::reference::RadianceImage) -> irt::image::Image {
    irt::image::Image {
        width: r.width,
        height: r.height,
        pixels: r.pixels.iter().map(|p| [p.x as f32, p.y as f32, p.z as f32]).collect(),
    }
}

/// The scene traced by the f64 CPU reference (the oracle).
pub fn reference_image(scene: &Scene) -> irt::image::Image {
    to_image(&irt::reference::render(scene))
}

/// GPU image against the reference, per pixel. Metric: per-channel absolute error in display
/// space (clamped, sRGB-encoded, [0, 1]; 1/255 is one output level), see `irt::metrics`.
/// Tolerances, and why:
/// - `p999` (99.9th percentile) ≤ 2/255: away from discontinuities f32 and f64 agree to far below
///   one output level; the worst 0.1% are where they legitimately decide differently.
/// - `bad_pixels` (pixels off by more than 2/255) ≤ 0.25%: a pixel-centre ray that passes within
///   f32 rounding of a silhouette, a shadow boundary or a critical angle may be decided
///   differently by the two tracers, and then the pixel differs by up to the full contrast of
///   that edge. Such pixels are isolated and rare; a real bug (wrong normal, wrong Fresnel, a
///   missed grid cell) changes whole regions and blows both bounds.
/// - no NaN or infinity anywhere.
///
/// On failure the GPU, reference and diff images are written to target/golden/.
pub fn assert_matches_reference(name: &str, gpu: &irt::image::Image, reference: &irt::image::Image) {
    const P999: f64 = 2.0 / 255.0;
    const BAD_PIXELS: f64 = 0.0025;
    let diff = irt::metrics::compare(gpu, reference);
    println!("{name}: {diff}");
    if diff.p999 <= P999 && diff.bad_pixels <= BAD_PIXELS && diff.non_finite == 0 {
        return;
    }
    let dir = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target/golden");
    std::fs::create_dir_all(&dir).unwrap();
    gpu.save_png(&dir.join(format!("{name}-gpu.png"))).unwrap();
    reference.save_png(&dir.join(format!("{name}-ref.png"))).unwrap();
    irt::metrics::diff_image(gpu, reference, 8.0).save_png(&dir.join(format!("{name}-diff.png"))).unwrap();
    panic!("{name}: GPU differs from the reference: {diff}\n(images in {})", dir.display());
}

/// A file of the Khronos glTF samples, vendored under tests/data/scenes with their licences so
/// that a fresh clone tests them too (the SPD scenes live in scenes/spd); `$IRT_SHARED_DIR/scenes`
/// overrides.
pub fn shared_scene(relative: &str) -> std::path::PathBuf {
    let scenes = match std::env::var_os("IRT_SHARED_DIR") {
        Some(dir) => std::path::PathBuf::from(dir).join("scenes"),
        None => std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/scenes"),
    };
    scenes.join(relative)
}

/// 1-based line and column of the last occurrence of `needle` in `src` (tests append the bad
/// value last, so the needle can be as short as the value).
pub fn position_of(src: &str, needle: &str) -> (usize, usize) {
    let at = src.rfind(needle).unwrap_or_else(|| panic!("'{needle}' not in the source"));
    let line_start = src[..at].rfind('\n').map_or(0, |i| i + 1);
    (src[..at].matches('\n').count() + 1, src[line_start..at].chars().count() + 1)
}

/// Asserts that parsing `src` (named `origin`) failed at the start of the last `at`, with a
/// message containing every one of `words`; returns the error.
pub fn assert_fails_at(
    result: Result<Scene, irt::io::LoadError>,
    src: &str,
    origin: &str,
    at: &str,
    words: &[&str],
) -> irt::io::LoadError {
    let e = result.expect_err("the scene should be rejected");
    let (line, column) = position_of(src, at);
    assert_eq!((e.line, e.column), (Some(line), Some(column)), "wrong position for: {e}");
    assert_eq!(e.path, origin);
    assert!(e.to_string().starts_with(&format!("{origin}:{line}:{column}: ")), "{e}");
    for w in words {
        assert!(e.message.contains(w), "message lacks '{w}': {e}");
    }
    e
}

/// Every number in a JSON document, as a JSON pointer (the glTF mutation tests edit them).
pub fn number_pointers(v: &serde_json::Value, at: String, out: &mut Vec<String>) {
    use serde_json::Value;
    match v {
        Value::Number(_) => out.push(at),
        Value::Array(a) => {
            a.iter().enumerate().for_each(|(i, x)| number_pointers(x, format!("{at}/{i}"), out))
        }
        Value::Object(o) => o.iter().for_each(|(k, x)| number_pointers(x, format!("{at}/{k}"), out)),
        _ => {}
    }
}

/// One shader function over a batch of inputs on the wgpu path (`irt::gpu::readback::run_kernel`).
pub fn run_kernel(
    ctx: &irt::gpu::GpuContext,
    scene: &irt::gpu::GpuScene,
    entry: &str,
    inputs: &[[f32; 4]],
    items: u32,
    out_per_item: u32,
) -> Vec<[f32; 4]> {
    irt::gpu::readback::run_kernel(ctx, scene, entry, inputs, items, out_per_item).expect("readback kernel")
}

/// `scene` and its grid uploaded in world coordinates (the readback kernels' rays are in world
/// space).
pub fn upload(ctx: &irt::gpu::GpuContext, scene: &Scene, grid: &irt::accel::Grid) -> irt::gpu::GpuScene {
    irt::gpu::readback::upload_at(ctx, scene, grid, glam::DVec3::ZERO).expect("upload")
}
