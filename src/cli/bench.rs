//! `irt bench`: grid build time, time to first frame, steady frame time and Mrays/s.

use super::{load_scene, open_device_with, DeviceArgs, SceneArgs};
use anyhow::{bail, Result};
use clap::{Args, ValueEnum};
use irt::gpu::{CacheSetting, RenderOptions, Renderer};
use std::path::PathBuf;
use std::time::{Duration, Instant};

#[derive(Args)]
pub struct BenchArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
    /// Timed frames after the first (median reported).
    #[arg(long, default_value_t = 5)]
    pub frames: u32,
    /// Start with an empty Mesa shader cache and an empty irt pipeline cache, to measure a cold
    /// time to first frame.
    #[arg(long)]
    pub cold: bool,
    /// Start with an empty Mesa shader cache but irt's pipeline cache as found: what irt's own
    /// cache brings on its own.
    #[arg(long, conflicts_with = "cold")]
    pub cold_mesa_only: bool,
    /// Print one Markdown table row (for the README's performance table).
    #[arg(long)]
    pub markdown: bool,
    /// Time the uber-pipeline (every primitive type and shadow mode compiled in) instead of the
    /// pipeline specialised to the scene.
    #[arg(long)]
    pub uber: bool,
    /// What to trace: the scene as given, or the peer-comparable work (eye rays at pixel centres,
    /// one hard-shadow ray per light facing each hit, diffuse Lambert shading, no ambient, no
    /// reflection or refraction: `irt::peer::primary_shadow`).
    #[arg(long, value_enum, default_value_t = Workload::Full)]
    pub workload: Workload,
    /// Also time a peer on the same scene and rays, in the same process, rounds interleaved,
    /// and report the ratio irt / peer (needs `--workload primary-shadow`).
    #[arg(long, value_enum)]
    pub peer: Option<Peer>,
    /// Threads for the native peer (default: all cores).
    #[arg(long)]
    pub peer_threads: Option<usize>,
    #[command(flatten)]
    pub device: DeviceArgs,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Workload {
    Full,
    PrimaryShadow,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Peer {
    /// irt's own algorithm (grid, 3D DDA, f32) as multithreaded Rust on the CPU.
    Native,
}

fn median(mut v: Vec<Duration>) -> Duration {
    v.sort();
    v[v.len() / 2]
}

/// A directory removed when dropped.
struct TempDir(PathBuf);

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

pub fn run(args: BenchArgs) -> Result<()> {
    // Cold: Mesa's on-disk shader cache starts empty (a fresh directory), so the first frame pays
    // the full shader compile and later frames are served from the cache as usual. (Disabling the
    // cache instead makes lavapipe recompile on every dispatch, which measures nothing useful.)
    let _cold_cache = if args.cold || args.cold_mesa_only {
        let dir = std::env::temp_dir().join(format!("irt-cold-cache-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("mesa"))?;
        // Read by Mesa when the device is created, which happens below.
        std::env::set_var("MESA_SHADER_CACHE_DIR", dir.join("mesa"));
        Some(TempDir(dir))
    } else {
        None
    };
    let cache = match &_cold_cache {
        // An empty directory: the pipeline cache starts empty and is written there.
        Some(dir) if args.cold && !args.device.no_cache => CacheSetting::Dir(dir.0.join("irt")),
        _ => CacheSetting::from_flag_or_env(args.device.no_cache),
    };
    if args.peer.is_some() && args.workload != Workload::PrimaryShadow {
        bail!("--peer traces only the peer-comparable work: add --workload primary-shadow");
    }
    let mut scene_args = args.scene;
    scene_args.width = scene_args.width.or(Some(512));
    scene_args.height = scene_args.height.or(Some(512));
    let mut scene = load_scene(&scene_args)?;
    if args.workload == Workload::PrimaryShadow {
        scene = irt::peer::primary_shadow(&scene);
    }
    let ctx = open_device_with(&args.device, &cache)?;
    let builds: Vec<Duration> = (0..5)
        .map(|_| {
            let t = Instant::now();
            std::hint::black_box(irt::accel::Grid::build(&scene));
            t.elapsed()
        })
        .collect();
    let grid_build = median(builds);

    // Time to first frame: pipeline creation + the first dispatch (where lavapipe compiles).
    let t = Instant::now();
    let f64 = scene_args.f64();
    let opts = RenderOptions { uber_shader: args.uber, f64, ..Default::default() };
    let renderer = Renderer::new(&ctx, &scene, opts).map_err(anyhow::Error::msg)?;
    let first = renderer.render(&ctx, &mut |_, _| {});
    let first_frame = t.elapsed();
    if first.image.non_finite() > 0 {
        bail!("the benchmark frame contains NaN/Inf values");
    }
    // Ray counts come from a separate counting pipeline so the timed one carries no atomics.
    let counting = Renderer::new(&ctx, &scene, RenderOptions { count_rays: true, f64, ..Default::default() })
        .map_err(anyhow::Error::msg)?;
    let rays = counting.render(&ctx, &mut |_, _| {}).rays;
    if let Some(Peer::Native) = args.peer {
        let name = scene_args.name_or("default");
        return peer_native(
            &name,
            &scene,
            &renderer,
            &ctx,
            rays.total(),
            args.frames,
            args.peer_threads,
            args.markdown,
        );
    }
    let frame = renderer.median_frame_time(&ctx, args.frames);
    let mrays = rays.total() as f64 / frame.as_secs_f64() / 1e6;
    let stats = renderer.grid.stats();
    let (w, h) = (scene.camera.width, scene.camera.height);
    let mut name = scene_args.name_or("default");
    if args.uber {
        name += " (uber)";
    }
    if args.workload == Workload::PrimaryShadow {
        name += " (primary-shadow)";
    }
    if args.markdown {
        println!(
            "| {name} | {w}x{h} | {} | {:.1} | {:.0} | {:.0} | {:.2} | {} |",
            scene.primitive_count(),
            grid_build.as_secs_f64() * 1e3,
            first_frame.as_secs_f64() * 1e3,
            frame.as_secs_f64() * 1e3,
            mrays,
            ctx.info.name
        );
    } else {
        println!("scene            {name} ({w}x{h}, {} primitives)", scene.primitive_count());
        println!("device           {} ({})", ctx.info.name, ctx.info.driver_info);
        println!("grid             {stats}");
        println!("grid build       {:.2} ms (median of 5)", grid_build.as_secs_f64() * 1e3);
        println!(
            "first frame      {:.0} ms (pipeline creation + first dispatch; Mesa shader cache {})",
            first_frame.as_secs_f64() * 1e3,
            if args.cold || args.cold_mesa_only { "empty at start" } else { "as found" }
        );
        println!("pipeline cache   {}", ctx.cache_status);
        println!("frame            {:.1} ms (median of {})", frame.as_secs_f64() * 1e3, args.frames.max(1));
        println!(
            "rays/frame       {} (eye {}, reflection {}, refraction {}, shadow {})",
            rays.total(),
            rays.eye,
            rays.reflection,
            rays.refraction,
            rays.shadow
        );
        println!("throughput       {mrays:.2} Mrays/s");
    }
    Ok(())
}

/// irt and the native peer on the same scene and rays, `frames` rounds interleaved (one irt
/// frame, one peer frame) so that load from other processes falls on both alike; medians.
#[allow(clippy::too_many_arguments)]
fn peer_native(
    name: &str,
    scene: &irt::scene::Scene,
    renderer: &Renderer,
    ctx: &irt::gpu::GpuContext,
    irt_rays: u64,
    frames: u32,
    threads: Option<usize>,
    markdown: bool,
) -> Result<()> {
    use irt::peer::native::NativePeer;
    let threads = threads.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let peer = NativePeer::new(scene, &renderer.grid).map_err(anyhow::Error::msg)?;
    let peer_rays = peer.render(threads).rays.total(); // also warms its caches, as irt's first frame did
    let (mut irt_t, mut peer_t) = (Vec::new(), Vec::new());
    for _ in 0..frames.max(1) {
        let t = Instant::now();
        renderer.render(ctx, &mut |_, _| {});
        irt_t.push(t.elapsed());
        let t = Instant::now();
        std::hint::black_box(peer.render(threads));
        peer_t.push(t.elapsed());
    }
    let (irt_t, peer_t) = (median(irt_t), median(peer_t));
    let irt_m = irt_rays as f64 / irt_t.as_secs_f64() / 1e6;
    let peer_m = peer_rays as f64 / peer_t.as_secs_f64() / 1e6;
    let (w, h) = (scene.camera.width, scene.camera.height);
    if markdown {
        println!(
            "| {name} | {w}x{h} | {} | {:.1} | {:.1} | {irt_m:.2} | {peer_m:.2} | {:.2} | {} |",
            scene.primitive_count(),
            irt_t.as_secs_f64() * 1e3,
            peer_t.as_secs_f64() * 1e3,
            irt_m / peer_m,
            ctx.info.name
        );
    } else {
        println!("scene            {name} ({w}x{h}, {} primitives), primary-shadow", scene.primitive_count());
        println!("device           {} ({})", ctx.info.name, ctx.info.driver_info);
        println!("rays/frame       irt {irt_rays}, native {peer_rays}");
        println!("irt              {:.1} ms  {irt_m:.2} Mrays/s", irt_t.as_secs_f64() * 1e3);
        println!(
            "native peer      {:.1} ms  {peer_m:.2} Mrays/s ({threads} threads)",
            peer_t.as_secs_f64() * 1e3
        );
        println!(
            "irt / native     {:.2} (throughput; median of {} interleaved rounds)",
            irt_m / peer_m,
            frames.max(1)
        );
    }
    Ok(())
}
