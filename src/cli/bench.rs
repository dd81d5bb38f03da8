//! `irt bench`: accelerator build time, time to first frame, steady frame time and Mrays/s.

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
    /// Also time peers on the same scene and rays, in the same process, rounds interleaved,
    /// and report the ratio irt / peer for each (needs `--workload primary-shadow`). Several
    /// peers: `--peer native,embree`.
    #[arg(long, value_enum, value_delimiter = ',')]
    pub peer: Vec<Peer>,
    /// Threads for each peer (default: all cores).
    #[arg(long)]
    pub peer_threads: Option<usize>,
    /// Device path: wgpu (default) or ash (raw Vulkan; no --peer). See docs/backends.md.
    #[arg(long, value_enum, default_value_t = super::Backend::Wgpu)]
    pub backend: super::Backend,
    /// Also time this many tiny dispatches (one workgroup of a readback kernel, one item):
    /// dispatch + submit + wait, median reported: the per-dispatch overhead of the device path.
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub dispatch_overhead: u32,
    /// Time these accelerators against each other instead (e.g. `--accels grid,bvh`): one
    /// frame of each per round, rounds interleaved, medians; Mrays/s of each and its ratio to the
    /// first's, the build times, and what `--accel auto` picks for the scene.
    #[arg(long, value_name = "ACCELS", value_delimiter = ',')]
    pub accels: Vec<irt::accel::AccelChoice>,
    #[command(flatten)]
    pub device: DeviceArgs,
}

/// What one backend measured.
struct Measured {
    /// Opening the instance and device.
    open: Duration,
    first_frame: Duration,
    frame: Duration,
    rays: irt::gpu::RayCounts,
    grid: String,
    device: String,
    driver_info: String,
    cache_status: String,
    overhead: Option<Duration>,
}

/// What the ash measurement needs of [`BenchArgs`] (whose scene arguments are moved out).
struct BenchArgsOf<'a> {
    device: &'a DeviceArgs,
    frames: u32,
    dispatch_overhead: u32,
}

/// The readback kernel and input of the per-dispatch overhead: one Fresnel evaluation.
const TINY_ENTRY: &str = "k_fresnel";
const TINY_INPUT: [[f32; 4]; 1] = [[0.5, 0.04, 1.5, 0.0]];

/// Resident set now and at its peak, in MiB (lavapipe's device memory is host memory).
fn memory_mib() -> (u64, u64) {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    let field = |name: &str| {
        status
            .lines()
            .find(|l| l.starts_with(name))
            .and_then(|l| l.split_whitespace().nth(1))
            .and_then(|v| v.parse::<u64>().ok())
            .map_or(0, |kib| kib >> 10)
    };
    (field("VmRSS:"), field("VmHWM:"))
}

fn measure_ash(args: &BenchArgsOf, scene: &irt::scene::Scene, opts: RenderOptions) -> Result<Measured> {
    use irt::gpu::vk::{VkDispatcher, VkKernel, VkRenderer};
    let t = Instant::now();
    let ctx = super::open_vk_device(args.device)?;
    let open = t.elapsed();
    let t = Instant::now();
    let renderer = VkRenderer::new(&ctx, scene, opts)?;
    let first = renderer.render(&mut |_, _| {})?;
    let first_frame = t.elapsed();
    if first.image.non_finite() > 0 {
        bail!("the benchmark frame contains NaN/Inf values");
    }
    let counting = VkRenderer::new(&ctx, scene, RenderOptions { count_rays: true, ..opts })?;
    let rays = counting.render(&mut |_, _| {})?.rays;
    drop(counting);
    let frame = renderer.median_frame_time(args.frames)?;
    let overhead = if args.dispatch_overhead > 0 {
        let d = VkDispatcher::new(
            &ctx,
            &renderer.scene,
            irt::gpu::shaders::Kernel::Tests,
            irt::gpu::shaders::Variant::FULL,
            1,
            &TINY_INPUT,
        )?;
        Some(irt::gpu::backend::dispatch_overhead(&VkKernel(&d), TINY_ENTRY, args.dispatch_overhead)?)
    } else {
        None
    };
    Ok(Measured {
        open,
        first_frame,
        frame,
        rays,
        grid: renderer.accel.summary(),
        device: ctx.info.name.clone(),
        driver_info: ctx.info.driver_info.clone(),
        cache_status: "none (the ash path has no pipeline cache yet)".into(),
        overhead,
    })
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
    /// Embree 3's BVH and single-ray kernels, multithreaded, robust (watertight) scene (a build
    /// with `--features embree`).
    Embree,
    /// As `embree` with Embree's default scene flags: its fastest traversal, not watertight.
    EmbreeFast,
    /// As `embree` with 8-wide ray packets (`rtcIntersect8` / `rtcOccluded8`), eight pixels of a
    /// row at a time.
    EmbreePacket,
}

const NO_EMBREE: &str =
    "this irt was built without Embree: cargo build --release --features embree (needs libembree-dev)";

fn make_peer(
    peer: Peer,
    scene: &irt::scene::Scene,
    grid: &irt::accel::Grid,
) -> Result<Box<dyn irt::peer::Peer>> {
    Ok(match peer {
        Peer::Native => {
            Box::new(irt::peer::native::NativePeer::new(scene, grid).map_err(anyhow::Error::msg)?)
        }
        #[cfg(feature = "embree")]
        Peer::Embree | Peer::EmbreeFast | Peer::EmbreePacket => Box::new(
            irt::peer::embree::EmbreePeer::with_options(
                scene,
                peer != Peer::EmbreeFast,
                peer == Peer::EmbreePacket,
            )
            .map_err(anyhow::Error::msg)?,
        ),
        #[cfg(not(feature = "embree"))]
        Peer::Embree | Peer::EmbreeFast | Peer::EmbreePacket => bail!(NO_EMBREE),
    })
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
    if !args.peer.is_empty() && args.workload != Workload::PrimaryShadow {
        bail!("--peer traces only the peer-comparable work: add --workload primary-shadow");
    }
    if args.peer.iter().any(|&p| p != Peer::Native) && !cfg!(feature = "embree") {
        bail!(NO_EMBREE);
    }
    let mut scene_args = args.scene;
    scene_args.width = scene_args.width.or(Some(512));
    scene_args.height = scene_args.height.or(Some(512));
    let mut scene = load_scene(&scene_args)?;
    if args.workload == Workload::PrimaryShadow {
        scene = irt::peer::primary_shadow(&scene);
    }
    if !args.accels.is_empty() {
        if args.backend == super::Backend::Ash || !args.peer.is_empty() {
            bail!("--accels runs on the wgpu path without peers: drop --backend ash and --peer");
        }
        let ctx = open_device_with(&args.device, &cache)?;
        let opts = RenderOptions { uber_shader: args.uber, f64: scene_args.f64(), ..Default::default() };
        let name = scene_args.name_or("default");
        return accel_rounds(&name, &scene, &ctx, opts, &args.accels, args.frames, args.markdown);
    }
    let builds: Vec<Duration> = (0..5)
        .map(|_| {
            let t = Instant::now();
            std::hint::black_box(irt::accel::Accel::choose(&scene, scene_args.accel, &|_, _| {}));
            t.elapsed()
        })
        .collect();
    let grid_build = median(builds);
    let f64 = scene_args.f64();
    let opts = RenderOptions { uber_shader: args.uber, f64, accel: scene_args.accel, ..Default::default() };
    let measured = if args.backend == super::Backend::Ash {
        if !args.peer.is_empty() {
            bail!("--peer runs on the wgpu path: drop --backend ash");
        }
        measure_ash(
            &BenchArgsOf {
                device: &args.device,
                frames: args.frames,
                dispatch_overhead: args.dispatch_overhead,
            },
            &scene,
            opts,
        )?
    } else {
        let t = Instant::now();
        let ctx = open_device_with(&args.device, &cache)?;
        let open = t.elapsed();

        // Time to first frame: pipeline creation + the first dispatch (where lavapipe compiles).
        let t = Instant::now();
        let renderer = Renderer::new(&ctx, &scene, opts).map_err(anyhow::Error::msg)?;
        let first = renderer.render(&ctx, &mut |_, _| {});
        let first_frame = t.elapsed();
        if first.image.non_finite() > 0 {
            bail!("the benchmark frame contains NaN/Inf values");
        }
        // Ray counts come from a separate counting pipeline so the timed one carries no atomics.
        let counting = Renderer::new(&ctx, &scene, RenderOptions { count_rays: true, ..opts })
            .map_err(anyhow::Error::msg)?;
        let rays = counting.render(&ctx, &mut |_, _| {}).rays;
        if !args.peer.is_empty() {
            // The native peer walks irt's grid whichever accelerator the GPU traces.
            let peer_grid = renderer.accel.grid().cloned().unwrap_or_else(|| irt::accel::Grid::build(&scene));
            let peers =
                args.peer.iter().map(|&p| make_peer(p, &scene, &peer_grid)).collect::<Result<Vec<_>>>()?;
            let name = scene_args.name_or("default");
            return peer_rounds(
                &name,
                &scene,
                &renderer,
                &ctx,
                rays.total(),
                &peers,
                args.frames,
                args.peer_threads,
                args.markdown,
            );
        }
        let frame = renderer.median_frame_time(&ctx, args.frames);
        let overhead = (args.dispatch_overhead > 0).then(|| {
            let d = irt::gpu::Dispatcher::new(
                &ctx,
                &renderer.gpu_scene,
                irt::gpu::shaders::Kernel::Tests,
                irt::gpu::shaders::Variant::FULL,
                TINY_ENTRY,
                1,
                &TINY_INPUT,
            );
            let kernel = irt::gpu::backend::WgpuKernel { ctx: &ctx, dispatcher: &d };
            irt::gpu::backend::infallible(irt::gpu::backend::dispatch_overhead(
                &kernel,
                TINY_ENTRY,
                args.dispatch_overhead,
            ))
        });
        Measured {
            open,
            first_frame,
            frame,
            rays,
            grid: renderer.accel.summary(),
            device: ctx.info.name.clone(),
            driver_info: ctx.info.driver_info.clone(),
            cache_status: ctx.cache_status.clone(),
            overhead,
        }
    };
    let Measured { open, first_frame, frame, rays, grid: stats, device, driver_info, cache_status, overhead } =
        measured;
    let mrays = rays.total() as f64 / frame.as_secs_f64() / 1e6;
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
            device
        );
    } else {
        println!("scene            {name} ({w}x{h}, {} primitives)", scene.primitive_count());
        println!("device           {device} ({driver_info}), {:?} backend", args.backend);
        println!("accelerator      {stats}");
        println!(
            "build            {:.2} ms (median of 5; --accel {})",
            grid_build.as_secs_f64() * 1e3,
            scene_args.accel
        );
        println!("device open      {:.1} ms (instance, adapter choice, device)", open.as_secs_f64() * 1e3);
        println!(
            "first frame      {:.0} ms (pipeline creation + first dispatch; Mesa shader cache {})",
            first_frame.as_secs_f64() * 1e3,
            if args.cold || args.cold_mesa_only { "empty at start" } else { "as found" }
        );
        println!("pipeline cache   {cache_status}");
        println!("frame            {:.1} ms (median of {})", frame.as_secs_f64() * 1e3, args.frames.max(1));
        if let Some(o) = overhead {
            println!(
                "dispatch         {:.1} µs (1 workgroup of {TINY_ENTRY}: dispatch + submit + wait, median of {})",
                o.as_secs_f64() * 1e6,
                args.dispatch_overhead
            );
        }
        let (rss, peak) = memory_mib();
        println!("memory           {rss} MiB resident, {peak} MiB at peak (process)");
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

/// irt and each peer on the same scene and rays, `frames` rounds interleaved (one irt frame, then
/// one frame of each peer) so that load from other processes falls on all alike; medians.
/// Markdown row: irt ms, each peer's ms, irt Mrays/s, each peer's Mrays/s, each ratio irt / peer.
#[allow(clippy::too_many_arguments)]
fn peer_rounds(
    name: &str,
    scene: &irt::scene::Scene,
    renderer: &Renderer,
    ctx: &irt::gpu::GpuContext,
    irt_rays: u64,
    peers: &[Box<dyn irt::peer::Peer>],
    frames: u32,
    threads: Option<usize>,
    markdown: bool,
) -> Result<()> {
    let threads = threads.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    // The first frame also warms the peers' caches, as irt's first frame did.
    let peer_rays: Vec<u64> = peers.iter().map(|p| p.render(threads).rays.total()).collect();
    let mut irt_t = Vec::new();
    let mut peer_t = vec![Vec::new(); peers.len()];
    for _ in 0..frames.max(1) {
        let t = Instant::now();
        renderer.render(ctx, &mut |_, _| {});
        irt_t.push(t.elapsed());
        for (p, times) in peers.iter().zip(&mut peer_t) {
            let t = Instant::now();
            std::hint::black_box(p.render(threads));
            times.push(t.elapsed());
        }
    }
    let irt_t = median(irt_t);
    let peer_t: Vec<Duration> = peer_t.into_iter().map(median).collect();
    let mrays = |rays: u64, t: Duration| rays as f64 / t.as_secs_f64() / 1e6;
    let irt_m = mrays(irt_rays, irt_t);
    let peer_m: Vec<f64> = peer_rays.iter().zip(&peer_t).map(|(&r, &t)| mrays(r, t)).collect();
    let (w, h) = (scene.camera.width, scene.camera.height);
    let ms = |t: &Duration| format!("{:.1}", t.as_secs_f64() * 1e3);
    if markdown {
        let cells: Vec<String> = std::iter::once(ms(&irt_t))
            .chain(peer_t.iter().map(ms))
            .chain(std::iter::once(format!("{irt_m:.2}")))
            .chain(peer_m.iter().map(|m| format!("{m:.2}")))
            .chain(peer_m.iter().map(|m| format!("{:.2}", irt_m / m)))
            .collect();
        println!(
            "| {name} | {w}x{h} | {} | {} | {} |",
            scene.primitive_count(),
            cells.join(" | "),
            ctx.info.name
        );
    } else {
        println!("scene            {name} ({w}x{h}, {} primitives), primary-shadow", scene.primitive_count());
        println!("device           {} ({})", ctx.info.name, ctx.info.driver_info);
        let counts: Vec<String> =
            peers.iter().zip(&peer_rays).map(|(p, r)| format!("{} {r}", p.name())).collect();
        println!("rays/frame        irt {irt_rays}, {}", counts.join(", "));
        println!("irt               {} ms  {irt_m:.2} Mrays/s", ms(&irt_t));
        for (i, p) in peers.iter().enumerate() {
            println!(
                "{:<17} {} ms  {:.2} Mrays/s ({threads} threads)",
                format!("{} peer", p.name()),
                ms(&peer_t[i]),
                peer_m[i],
            );
        }
        for (i, p) in peers.iter().enumerate() {
            println!(
                "{:<17} {:.2} (throughput; median of {} interleaved rounds)",
                format!("irt / {}", p.name()),
                irt_m / peer_m[i],
                frames.max(1)
            );
        }
    }
    Ok(())
}

/// `irt bench --accels`: every accelerator of `accels` on `scene`, one frame of each per round
/// (rounds interleaved, so load on the machine falls on all of them), medians of `frames` rounds.
fn accel_rounds(
    name: &str,
    scene: &irt::scene::Scene,
    ctx: &irt::gpu::GpuContext,
    opts: RenderOptions,
    accels: &[irt::accel::AccelChoice],
    frames: u32,
    markdown: bool,
) -> Result<()> {
    use irt::accel::{Accel, AccelChoice};
    let mut renderers = Vec::new();
    let mut rays = Vec::new();
    let mut builds = Vec::new();
    for &accel in accels {
        let kind = accel.resolve(scene);
        let times: Vec<Duration> = (0..3)
            .map(|_| {
                let t = Instant::now();
                std::hint::black_box(Accel::build(scene, kind, &|_, _| {}));
                t.elapsed()
            })
            .collect();
        builds.push(median(times));
        let r = Renderer::new(ctx, scene, RenderOptions { accel, ..opts }).map_err(anyhow::Error::msg)?;
        // The first frame compiles (lavapipe compiles at the first dispatch).
        if r.render(ctx, &mut |_, _| {}).image.non_finite() > 0 {
            bail!("the {accel} frame contains NaN/Inf values");
        }
        let counting = Renderer::new(ctx, scene, RenderOptions { accel, count_rays: true, ..opts })
            .map_err(anyhow::Error::msg)?;
        rays.push(counting.render(ctx, &mut |_, _| {}).rays.total());
        renderers.push(r);
    }
    let mut times = vec![Vec::new(); renderers.len()];
    for _ in 0..frames.max(1) {
        for (r, t) in renderers.iter().zip(&mut times) {
            let t0 = Instant::now();
            r.render(ctx, &mut |_, _| {});
            t.push(t0.elapsed());
        }
    }
    let mrays: Vec<f64> =
        times.into_iter().zip(&rays).map(|(t, &n)| n as f64 / median(t).as_secs_f64() / 1e6).collect();
    let auto = match AccelChoice::Auto.resolve(scene) {
        irt::accel::AccelKind::Grid => "grid",
        irt::accel::AccelKind::Bvh(_) => "bvh",
    };
    let (w, h) = (scene.camera.width, scene.camera.height);
    if markdown {
        let cells: Vec<String> = builds
            .iter()
            .map(|b| format!("{:.1}", b.as_secs_f64() * 1e3))
            .chain(mrays.iter().map(|m| format!("{m:.2}")))
            .chain(mrays[1..].iter().map(|m| format!("{:.2}", m / mrays[0])))
            .collect();
        println!(
            "| {name} | {w}x{h} | {} | {} | {} | {auto} | {} |",
            scene.primitive_count(),
            rays[0],
            cells.join(" | "),
            ctx.info.name
        );
    } else {
        println!("scene            {name} ({w}x{h}, {} primitives)", scene.primitive_count());
        println!("device           {} ({})", ctx.info.name, ctx.info.driver_info);
        for (i, (&accel, r)) in accels.iter().zip(&renderers).enumerate() {
            println!(
                "{:<16} {:.2} Mrays/s ({:.2}x {}), {} rays/frame, build {:.1} ms: {}",
                accel.to_string(),
                mrays[i],
                mrays[i] / mrays[0],
                accels[0],
                rays[i],
                builds[i].as_secs_f64() * 1e3,
                r.accel.summary()
            );
        }
        println!("auto picks       {auto}");
    }
    if rays.iter().any(|&r| r != rays[0]) {
        log::warn!("the accelerators traced different ray counts {rays:?}: their images differ");
    }
    Ok(())
}
