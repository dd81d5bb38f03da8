//! Shared by the criterion benches (docs/performance.md, *Benches*): the short default
//! configuration, the scenes, the ray-kind workloads, and a summary table printed at the end of
//! a run (median per-frame time and Mrays/s of every bench, ratios where a bench asks).
#![allow(dead_code)]

use criterion::{BenchmarkGroup, Criterion, SamplingMode, Throughput};
use glam::DVec3;
use irt::gpu::GpuContext;
use irt::render::{Session, Settings};
use irt::scene::{Material, MaterialKind, Scene};
use std::cell::RefCell;
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// Seconds of measurement per bench: `IRT_BENCH_SECS` (default 2, so that `cargo bench`
/// finishes in minutes on two cores; 10 or more for numbers to quote).
pub fn measurement_secs() -> f64 {
    std::env::var("IRT_BENCH_SECS").ok().and_then(|s| s.parse().ok()).unwrap_or(2.0)
}

/// Samples per bench: `IRT_BENCH_SAMPLES` (default and criterion's minimum: 10).
pub fn samples() -> usize {
    std::env::var("IRT_BENCH_SAMPLES").ok().and_then(|s| s.parse().ok()).unwrap_or(10).max(10)
}

/// The configuration every bench starts from (command-line flags such as `--sample-size` or
/// `--measurement-time` still override it).
pub fn config() -> Criterion {
    Criterion::default()
        .sample_size(samples())
        .measurement_time(Duration::from_secs_f64(measurement_secs()))
        .warm_up_time(Duration::from_millis(500))
        .without_plots()
}

/// Whether this is a real run (`cargo bench` passes `--bench`), not criterion's test mode
/// (`cargo test --benches`, `--all-targets`), which runs every bench once: there the benches
/// keep only their smallest case, so that building and checking them stays quick.
pub fn full_run() -> bool {
    std::env::args().any(|a| a == "--bench")
}

/// `all` in a real run, its first element in test mode.
pub fn cases<T: Clone>(all: &[T]) -> Vec<T> {
    if full_run() {
        all.to_vec()
    } else {
        all[..1].to_vec()
    }
}

pub fn gpu() -> GpuContext {
    GpuContext::new(&irt::gpu::AdapterChoice::from_arg_or_env(None))
        .expect("a Vulkan device (lavapipe: scripts/setup.sh)")
}

/// A scene shipped in `scenes/` (`"default"`: the built-in default scene) at `side`².
pub fn scene(name: &str, side: u32) -> Scene {
    let mut s = if name == "default" {
        irt::scene::default_scene()
    } else {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name);
        irt::io::load(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
    };
    (s.camera.width, s.camera.height) = (side, side);
    s
}

/// The vertices per side of a [`terrain`](irt::io::shapes::terrain) with at least `triangles`
/// triangles (it has `2 (side − 1)²`).
pub fn terrain_side(triangles: usize) -> u32 {
    ((triangles as f64 / 2.0).sqrt().ceil() as u32) + 1
}

/// A fractal terrain of at least `triangles` triangles with vertex normals, one diffuse
/// material and the staged headlight, seen from above at an angle so that the mesh fills most of
/// the image (as tests/large_mesh.rs), at `side`².
pub fn terrain_scene(triangles: usize, side: u32) -> Scene {
    let diffuse = MaterialKind::Diffuse { color: DVec3::splat(0.8) };
    let model = irt::io::stage::Model {
        meshes: vec![irt::io::shapes::terrain(terrain_side(triangles), 11, true).into_mesh(0)],
        materials: vec![Material::new("terrain", diffuse)],
        textures: vec![],
        motions: vec![],
        ..Default::default()
    };
    let mut s = irt::io::stage::stage(model);
    s.camera.eye = DVec3::new(0.6, 0.9, 1.3);
    s.camera.look_at = DVec3::new(0.0, 0.0, 0.1);
    (s.camera.width, s.camera.height) = (side, side);
    s
}

/// What a frame traces.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// Eye rays only: the primary-shadow workload (depth 1, diffuse) without lights, shaded by
    /// the scene's ambient alone, so no shadow ray is cast.
    Eye,
    /// `irt::lab::peer::primary_shadow`: eye rays and one hard-shadow ray per light facing each hit.
    EyeShadow,
    /// The scene's own settings (depth, shadows, materials).
    Full,
}

impl Kind {
    pub const ALL: [Kind; 3] = [Kind::Eye, Kind::EyeShadow, Kind::Full];

    pub fn name(self) -> &'static str {
        match self {
            Kind::Eye => "eye",
            Kind::EyeShadow => "eye+shadow",
            Kind::Full => "full",
        }
    }

    pub fn apply(self, scene: &Scene) -> Scene {
        match self {
            Kind::Eye => {
                let mut s = irt::lab::peer::primary_shadow(scene);
                s.lights.clear();
                s.ambient = scene.ambient.clone();
                s
            }
            Kind::EyeShadow => irt::lab::peer::primary_shadow(scene),
            Kind::Full => scene.clone(),
        }
    }
}

/// A session of the bands past its first picture (lavapipe compiles at the first dispatch), and
/// the rays one of its pictures traces, counted by a separate counting pipeline (as `irt bench`
/// does: the timed pipeline carries no atomics).
pub struct Traced {
    pub session: RefCell<Session>,
    pub rays: u64,
    pub primitives: usize,
}

impl Traced {
    /// One more picture (what the benches time).
    pub fn render(&self, ctx: &GpuContext) {
        self.session.borrow_mut().picture(ctx, &mut |_, _| {});
    }
}

pub fn traced(ctx: &GpuContext, scene: &Scene) -> Traced {
    traced_with(ctx, scene, Settings::bands())
}

/// [`traced`] with `settings` (another accelerator).
pub fn traced_with(ctx: &GpuContext, scene: &Scene, settings: Settings) -> Traced {
    let mut session = Session::new(ctx, scene, settings.clone()).expect("session");
    let first = session.picture(ctx, &mut |_, _| {});
    assert_eq!(first.image.non_finite(), 0, "the bench frame has NaN/Inf values");
    let counting = Settings { count_rays: true, ..settings };
    let rays = Session::new(ctx, scene, counting)
        .expect("counting session")
        .picture(ctx, &mut |_, _| {})
        .rays
        .total();
    Traced { session: RefCell::new(session), rays, primitives: scene.primitive_count() }
}

/// One row of the summary: every timed iteration's duration (warm-up included: all are steady
/// frames, the first frame having been rendered in setup).
struct Row {
    id: String,
    rays: u64,
    primitives: usize,
    times: Vec<Duration>,
}

static ROWS: Mutex<Vec<Row>> = Mutex::new(Vec::new());
static RATIOS: Mutex<Vec<(String, String, String)>> = Mutex::new(Vec::new());

/// Benches `frame` (one call = one frame of `rays` rays) as `group/id`, with criterion's
/// throughput in rays, and keeps each iteration's time for the summary.
pub fn bench_frames(
    g: &mut BenchmarkGroup<'_, criterion::measurement::WallTime>,
    id: &str,
    rays: u64,
    primitives: usize,
    mut frame: impl FnMut(),
) {
    let full_id = format!("{}/{id}", g_name(g));
    g.throughput(Throughput::Elements(rays));
    g.bench_function(id, |b| {
        b.iter_custom(|iters| {
            let mut total = Duration::ZERO;
            let mut times = Vec::with_capacity(iters as usize);
            for _ in 0..iters {
                let t = Instant::now();
                frame();
                let e = t.elapsed();
                times.push(e);
                total += e;
            }
            record(&full_id, rays, primitives, times);
            total
        })
    });
}

/// Adds durations measured elsewhere (another process's report) to the summary row `id`.
pub fn record(id: &str, rays: u64, primitives: usize, times: Vec<Duration>) {
    let mut rows = ROWS.lock().unwrap();
    match rows.iter_mut().find(|r| r.id == id) {
        Some(r) => r.times.extend(times),
        None => rows.push(Row { id: id.to_string(), rays, primitives, times }),
    }
}

/// Asks the summary for the throughput ratio of two rows (`numerator / denominator`).
pub fn ratio(label: &str, numerator: &str, denominator: &str) {
    RATIOS.lock().unwrap().push((label.into(), numerator.into(), denominator.into()));
}

// criterion's group name is not public; the benches name groups through this.
thread_local! {
    static GROUP: std::cell::RefCell<String> = const { std::cell::RefCell::new(String::new()) };
}

/// A benchmark group with flat sampling (the same iteration count in every sample): what
/// criterion advises for routines that take tens of milliseconds and more, as a frame does.
pub fn group<'a>(c: &'a mut Criterion, name: &str) -> BenchmarkGroup<'a, criterion::measurement::WallTime> {
    GROUP.with(|g| *g.borrow_mut() = name.to_string());
    let mut g = c.benchmark_group(name);
    g.sampling_mode(SamplingMode::Flat);
    g
}

fn g_name(_: &BenchmarkGroup<'_, criterion::measurement::WallTime>) -> String {
    GROUP.with(|g| g.borrow().clone())
}

fn median(v: &[Duration]) -> Duration {
    let mut v = v.to_vec();
    v.sort();
    v[v.len() / 2]
}

fn mrays(r: &Row) -> f64 {
    r.rays as f64 / median(&r.times).as_secs_f64() / 1e6
}

/// Prints the summary as a Markdown table (to stdout, after criterion's own report).
pub fn print_summary() {
    let rows = ROWS.lock().unwrap();
    if rows.is_empty() {
        return;
    }
    println!("\n| bench | primitives | rays/frame | median ms | Mrays/s | n |");
    println!("|---|---|---|---|---|---|");
    for r in rows.iter() {
        let ms = median(&r.times).as_secs_f64() * 1e3;
        let m = if r.rays > 0 { format!("{:.2}", mrays(r)) } else { "–".into() };
        println!("| {} | {} | {} | {ms:.1} | {m} | {} |", r.id, r.primitives, r.rays, r.times.len());
    }
    for (label, a, b) in RATIOS.lock().unwrap().iter() {
        let find = |id: &str| rows.iter().find(|r| r.id == *id);
        if let (Some(a), Some(b)) = (find(a), find(b)) {
            println!(
                "\n{label}: {:.2} ({:.2} / {:.2} Mrays/s, medians)",
                mrays(a) / mrays(b),
                mrays(a),
                mrays(b)
            );
        }
    }
}

/// Criterion's filter (the first free argument), if any.
fn filter() -> Option<String> {
    const VALUED: &[&str] = &[
        "--save-baseline",
        "-s",
        "--baseline",
        "-b",
        "--load-baseline",
        "--baseline-lenient",
        "--sample-size",
        "--warm-up-time",
        "--measurement-time",
        "--nresamples",
        "--noise-threshold",
        "--confidence-level",
        "--significance-level",
        "--profile-time",
        "--output-format",
        "--color",
        "-c",
        "--plotting-backend",
        "--format",
    ];
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut i = 0;
    while i < args.len() {
        if VALUED.contains(&args[i].as_str()) {
            i += 2;
        } else if args[i].starts_with('-') {
            i += 1;
        } else {
            return Some(args[i].clone());
        }
    }
    None
}

/// Whether the bench `id` (`group/…`) may pass criterion's filter, so that its setup (grid,
/// upload, shader compile) is worth doing. A filter with regex characters always passes here
/// and criterion decides.
pub fn wanted(id: &str) -> bool {
    match filter() {
        None => true,
        Some(f) if f.chars().any(|c| "^$.*+?()[]{}|\\".contains(c)) => true,
        Some(f) => id.contains(&f),
    }
}
