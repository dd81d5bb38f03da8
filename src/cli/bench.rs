//! `irt bench`: accelerator build time, time to first frame, steady frame time and Mrays/s.

use super::args::{fixed_size, load_scene, AshArgs, BackendArgs, DeviceArgs, SceneArgs};
use super::open_device_with;
use anyhow::{bail, Result};
use clap::{Args, ValueEnum};
use irt::gpu::device::{Backend, Device};
use irt::gpu::layout::SIMD_LOOPS;
use irt::gpu::{CacheSetting, GpuError};
use irt::render::{Session, Settings};
use std::path::PathBuf;
use std::time::{Duration, Instant};

#[derive(Args)]
#[command(mut_arg("size", |a| fixed_size(a, "512x512", "one size for every scene, so that scenes compare")))]
pub struct BenchArgs {
    /// Timed frames after the first (median reported).
    #[arg(long, value_name = "N", default_value_t = 5)]
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
    /// reflection or refraction: `irt::lab::peer::primary_shadow`).
    #[arg(long, value_enum, default_value_t = Workload::Full)]
    pub workload: Workload,
    /// Also time peers on the same scene and rays, in the same process, rounds interleaved,
    /// and report the ratio irt / peer for each (needs `--workload primary-shadow`). Several
    /// peers: `--peer native,embree`.
    #[arg(long, value_enum, value_delimiter = ',')]
    pub peer: Vec<Peer>,
    /// Time these accelerators against each other instead (e.g. `--accels grid,bvh`): one
    /// frame of each per round, rounds interleaved, medians; Mrays/s of each and its ratio to the
    /// first's, the build times, and what `--accel auto` picks for the scene.
    #[arg(long, value_name = "ACCELS", value_delimiter = ',')]
    pub accels: Vec<irt::accel::AccelChoice>,
    /// Threads for each peer (default: all cores).
    #[arg(long)]
    pub peer_threads: Option<usize>,
    /// Also time this many tiny dispatches (one workgroup of a readback kernel, one item):
    /// dispatch + submit + wait, median reported: the per-dispatch overhead of the device path.
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub dispatch_overhead: u32,
    /// Also render one frame with SIMD counters (the device needs subgroup operations; lavapipe
    /// has them) and print, per loop (accelerator walk, candidate tests, ray tree, lights), the
    /// share of the lane slots its SIMD groups ran that did work: how much of an iteration's cost
    /// lanes that are done or masked pay. The timed frames run without the counters.
    #[arg(long, conflicts_with_all = ["peer", "markdown", "accels"])]
    pub simd: bool,
    #[command(flatten)]
    pub scene: SceneArgs,
    #[command(flatten)]
    pub backend: BackendArgs,
    #[command(flatten)]
    pub ash: AshArgs,
    #[command(flatten)]
    pub device: DeviceArgs,
}

/// What one backend measured.
struct Measured {
    /// Opening the instance and device.
    open: Duration,
    first_frame: Duration,
    frame: Duration,
    /// The median frame's host side after its dispatches ([`irt::gpu::Frame::readback`]).
    readback: Duration,
    rays: irt::gpu::RayCounts,
    grid: String,
    device: String,
    driver_info: String,
    cache_status: String,
    overhead: Option<Duration>,
    /// `--profile`: what the queries said of one frame.
    profile: Option<Profile>,
    /// `--simd`: the loops' counters of one frame, and the lanes in a SIMD group.
    simd: Option<([irt::gpu::SimdCount; SIMD_LOOPS.len()], u32)>,
}

/// The queries' view of one frame (`--profile`).
struct Profile {
    support: String,
    samples: Vec<irt::gpu::vk::DispatchSample>,
    /// Pixels (eye rays) x passes: what the invocations should add up to, less the
    /// workgroups' rounding up to 8x8.
    eye_rays_x_passes: u64,
}

fn print_profile(p: &Profile) {
    let n = p.samples.len();
    println!("queries          {}", p.support);
    if n == 0 {
        return;
    }
    let med = |mut v: Vec<Duration>| {
        v.sort();
        v[v.len() / 2].as_secs_f64() * 1e3
    };
    let host = med(p.samples.iter().map(|s| s.host).collect());
    let host_sum: Duration = p.samples.iter().map(|s| s.host).sum();
    if p.samples.iter().all(|s| s.device.is_some()) {
        let device = med(p.samples.iter().filter_map(|s| s.device).collect());
        let device_sum: Duration = p.samples.iter().filter_map(|s| s.device).sum();
        let gap = med(p.samples.iter().filter_map(|s| s.device.map(|d| s.host.saturating_sub(d))).collect());
        println!(
            "per dispatch     device {device:.3} ms, host wall {host:.3} ms, host - device {:.1} µs (medians of {n}, one frame)",
            gap * 1e3
        );
        println!(
            "frame            device {:.1} ms of host wall {:.1} ms in its {n} dispatches",
            device_sum.as_secs_f64() * 1e3,
            host_sum.as_secs_f64() * 1e3
        );
    } else {
        println!("per dispatch     host wall {host:.3} ms (median of {n}); no timestamps");
    }
    if p.samples.iter().all(|s| s.invocations.is_some()) {
        let inv: u64 = p.samples.iter().filter_map(|s| s.invocations).sum();
        let groups: u64 = p.samples.iter().map(|s| s.groups.iter().map(|&g| g as u64).product::<u64>()).sum();
        println!(
            "invocations      {inv} per frame (workgroups x 64: {}; eye rays x passes: {})",
            groups * 64,
            p.eye_rays_x_passes
        );
    }
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

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Workload {
    Full,
    PrimaryShadow,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Peer {
    /// irt's own algorithm (grid, 3D DDA, f32) as multithreaded Rust on the CPU.
    Native,
    /// The same over irt's BVH, walked as the shader walks it (stackless, escape links): the
    /// like-for-like peer of irt's default accelerator.
    NativeBvh,
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
) -> Result<Box<dyn irt::lab::peer::Peer>> {
    Ok(match peer {
        Peer::Native => {
            Box::new(irt::lab::peer::native::NativePeer::new(scene, grid).map_err(anyhow::Error::msg)?)
        }
        Peer::NativeBvh => {
            // The device's tree, as its stackless walk gets it (ordered towards the eye).
            let bvh = irt::accel::bvh_for(scene, irt::accel::BvhWalk::Stackless);
            Box::new(irt::lab::peer::native::NativePeer::with_bvh(scene, &bvh).map_err(anyhow::Error::msg)?)
        }
        #[cfg(feature = "embree")]
        Peer::Embree | Peer::EmbreeFast | Peer::EmbreePacket => Box::new(
            irt::lab::peer::embree::EmbreePeer::with_options(
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
    if args.peer.iter().any(|&p| !matches!(p, Peer::Native | Peer::NativeBvh)) && !cfg!(feature = "embree") {
        bail!(NO_EMBREE);
    }
    let scene_args = args.scene;
    let mut scene = load_scene(&scene_args)?;
    if args.workload == Workload::PrimaryShadow {
        scene = irt::lab::peer::primary_shadow(&scene);
    }
    if !args.accels.is_empty() {
        if !args.peer.is_empty() {
            bail!("--accels times irt's accelerators against each other: drop --peer");
        }
        let opts = Settings { uber_shader: args.uber, f64: scene_args.f64(), ..Settings::bands() };
        let name = scene_args.name_or("default");
        let (accels, frames, markdown) = (&args.accels, args.frames, args.markdown);
        return match args.backend.backend {
            Backend::Wgpu => accel_rounds(
                &name,
                &scene,
                &open_device_with(&args.device, &cache)?,
                opts,
                accels,
                frames,
                markdown,
            ),
            Backend::Ash => {
                let ctx = super::open_vk_device(&args.device, args.ash.options())?;
                accel_rounds(&name, &scene, &ctx, opts, accels, frames, markdown)
            }
        };
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
    let opts = Settings { uber_shader: args.uber, f64, accel: scene_args.accel, ..Settings::bands() };
    if args.backend.backend != Backend::Ash && args.ash.any() {
        bail!(
            "--robust, --push-tile, --profile and --spirv-val are levers of the ash path: add --backend ash"
        );
    }
    let job = Job {
        name: scene_args.name_or("default"),
        scene: &scene,
        opts,
        peers: &args.peer,
        peer_threads: args.peer_threads,
        frames: args.frames,
        dispatch_overhead: args.dispatch_overhead,
        markdown: args.markdown,
        simd: args.simd,
    };
    let t = Instant::now();
    let measured = match args.backend.backend {
        Backend::Wgpu => {
            let ctx = open_device_with(&args.device, &cache)?;
            job.on(&ctx, t.elapsed(), &ctx.cache_status)?
        }
        Backend::Ash => {
            let ctx = super::open_vk_device(&args.device, args.ash.options())?;
            let measured = job.on(&ctx, t.elapsed(), "none (the ash path has no pipeline cache yet)")?;
            match measured {
                // One more frame with the queries' samples taken alone.
                Some(m) if args.ash.profile => Some(Measured { profile: Some(profile(&ctx, &job)?), ..m }),
                m => m,
            }
        }
    };
    // The peer rounds printed their own table.
    let Some(measured) = measured else { return Ok(()) };
    let Measured {
        open,
        first_frame,
        frame,
        readback,
        rays,
        grid: stats,
        device,
        driver_info,
        cache_status,
        overhead,
        profile,
        simd,
    } = measured;
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
        println!("device           {device} ({driver_info}), {:?} backend", args.backend.backend);
        println!("accelerator      {stats}");
        println!(
            "build            {:.2} ms (median of 5; --accel {})",
            grid_build.as_secs_f64() * 1e3,
            scene_args.accel
        );
        println!("device open      {:.1} ms (instance, adapter choice, device)", open.as_secs_f64() * 1e3);
        // --cold empties Mesa's shader cache; another driver's (NVIDIA's) stays as found.
        let shader_cache = if !driver_info.contains("Mesa") {
            "the driver's shader cache as found"
        } else if args.cold || args.cold_mesa_only {
            "Mesa shader cache empty at start"
        } else {
            "Mesa shader cache as found"
        };
        println!(
            "first frame      {:.0} ms (pipeline creation + first dispatch; {shader_cache})",
            first_frame.as_secs_f64() * 1e3,
        );
        println!("pipeline cache   {cache_status}");
        println!(
            "frame            {:.1} ms (median of {}{})",
            frame.as_secs_f64() * 1e3,
            args.frames.max(1),
            if profile.is_some() { "; queries on" } else { "" }
        );
        println!(
            "readback         {:.2} ms of it (output mapped and decoded into the image on the host, median)",
            readback.as_secs_f64() * 1e3
        );
        if args.backend.backend == Backend::Ash {
            let o = args.ash.options();
            println!(
                "ash levers       robust {}, tile in {}, spirv-val {}",
                if o.robust { "on" } else { "off (no device robustness, no naga bounds checks)" },
                if o.push_tile { "push constants" } else { "a uniform buffer" },
                if o.full_spirv_check { "on" } else { "off" }
            );
        }
        if let Some(p) = &profile {
            print_profile(p);
        }
        if let Some((loops, size)) = &simd {
            print_simd(loops, *size, w as u64 * h as u64);
        }
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

/// One measurement, whichever device path runs it.
struct Job<'a> {
    name: String,
    scene: &'a irt::scene::Scene,
    opts: Settings,
    peers: &'a [Peer],
    peer_threads: Option<usize>,
    frames: u32,
    dispatch_overhead: u32,
    markdown: bool,
    simd: bool,
}

impl Job<'_> {
    /// Measures on `ctx` (opened in `open`); `None` when the peer rounds ran instead (they print
    /// their own report).
    fn on<D: Device>(&self, ctx: &D, open: Duration, cache_status: &str) -> Result<Option<Measured>> {
        let (scene, opts) = (self.scene, &self.opts);
        // Time to first frame: pipeline creation + the first dispatch (where lavapipe compiles).
        let t = Instant::now();
        let mut session = Session::new(ctx, scene, opts.clone())?;
        let first = session.try_picture(ctx, &mut |_, _| {})?;
        let first_frame = t.elapsed();
        if first.image.non_finite() > 0 {
            bail!("the benchmark frame contains NaN/Inf values");
        }
        // Ray counts come from a separate counting pipeline so the timed one carries no atomics.
        let counting = Settings { count_rays: true, ..opts.clone() };
        let rays = Session::new(ctx, scene, counting)?.try_picture(ctx, &mut |_, _| {})?.rays;
        let simd = if self.simd {
            let size = ctx
                .subgroup_size()
                .ok_or_else(|| GpuError::NoSubgroups { adapter: ctx.adapter_name().to_string() })?;
            let counting = Settings { simd_stats: true, ..opts.clone() };
            Some((Session::new(ctx, scene, counting)?.try_picture(ctx, &mut |_, _| {})?.rays.simd, size))
        } else {
            None
        };
        if !self.peers.is_empty() {
            // The native peer walks irt's grid whichever accelerator the device traces.
            let peer_grid = session.accel.grid().cloned().unwrap_or_else(|| irt::accel::Grid::build(scene));
            let peers =
                self.peers.iter().map(|&p| make_peer(p, scene, &peer_grid)).collect::<Result<Vec<_>>>()?;
            peer_rounds(
                &self.name,
                scene,
                &mut session,
                ctx,
                rays.total(),
                &peers,
                self.frames,
                self.peer_threads,
                self.markdown,
            )?;
            return Ok(None);
        }
        let (frame, readback) = session.try_median_picture_times(ctx, self.frames)?;
        let overhead = if self.dispatch_overhead > 0 {
            use irt::gpu::device::KernelSpec;
            let d = ctx.compile(session.device_scene(), KernelSpec::tests(&TINY_INPUT, 1))?;
            let overhead =
                irt::gpu::recording::dispatch_overhead(&ctx.bind(&d), TINY_ENTRY, self.dispatch_overhead)?;
            Some(overhead)
        } else {
            None
        };
        Ok(Some(Measured {
            open,
            first_frame,
            frame,
            readback,
            rays,
            grid: session.accel.summary(),
            device: ctx.adapter_name().to_string(),
            driver_info: ctx.adapter_driver().to_string(),
            cache_status: cache_status.to_string(),
            overhead,
            profile: None,
            simd,
        }))
    }
}

/// `--profile` on the ash path: the timestamps and invocation counts of one more frame.
fn profile(ctx: &irt::gpu::vk::VkContext, job: &Job) -> Result<Profile> {
    let mut session = Session::new(ctx, job.scene, job.opts.clone())?;
    session.try_picture(ctx, &mut |_, _| {})?;
    ctx.take_samples();
    session.try_picture(ctx, &mut |_, _| {})?;
    let passes = irt::render::modes::passes(job.scene).len() as u64;
    let (w, h) = (job.scene.camera.width as u64, job.scene.camera.height as u64);
    Ok(Profile {
        support: ctx.query_support().describe(),
        samples: ctx.take_samples(),
        eye_rays_x_passes: w * h * passes,
    })
}

/// irt and each peer on the same scene and rays, `frames` rounds interleaved (one irt frame, then
/// one frame of each peer) so that load from other processes falls on all alike; medians.
/// Markdown row: irt ms, each peer's ms, irt Mrays/s, each peer's Mrays/s, each ratio irt / peer.
/// The pause before each timed frame of [`peer_rounds`]: the peers' worker threads (Embree's
/// TBB pool, rayon's) spin for a while after their frame, and lavapipe's threads, started right
/// after, would share the cores with them (irt's frame read 1.5-1.8x longer that way). Each
/// contender is timed on a machine the previous one has left.
const SETTLE: Duration = Duration::from_millis(40);

#[allow(clippy::too_many_arguments)]
fn peer_rounds<D: Device>(
    name: &str,
    scene: &irt::scene::Scene,
    session: &mut Session<D>,
    ctx: &D,
    irt_rays: u64,
    peers: &[Box<dyn irt::lab::peer::Peer>],
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
        std::thread::sleep(SETTLE);
        let t = Instant::now();
        session.try_picture(ctx, &mut |_, _| {})?;
        irt_t.push(t.elapsed());
        for (p, times) in peers.iter().zip(&mut peer_t) {
            std::thread::sleep(SETTLE);
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
            ctx.adapter_name()
        );
    } else {
        println!("scene            {name} ({w}x{h}, {} primitives), primary-shadow", scene.primitive_count());
        println!("device           {} ({})", ctx.adapter_name(), ctx.adapter_driver());
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
fn accel_rounds<D: Device>(
    name: &str,
    scene: &irt::scene::Scene,
    ctx: &D,
    opts: Settings,
    accels: &[irt::accel::AccelChoice],
    frames: u32,
    markdown: bool,
) -> Result<()> {
    use irt::accel::{Accel, AccelChoice};
    let mut sessions = Vec::new();
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
        let mut s = Session::new(ctx, scene, Settings { accel, ..opts.clone() })?;
        // The first frame compiles (lavapipe compiles at the first dispatch).
        if s.try_picture(ctx, &mut |_, _| {})?.image.non_finite() > 0 {
            bail!("the {accel} frame contains NaN/Inf values");
        }
        let mut counter = Session::new(ctx, scene, Settings { accel, count_rays: true, ..opts.clone() })?;
        rays.push(counter.try_picture(ctx, &mut |_, _| {})?.rays.total());
        sessions.push(s);
    }
    let mut times = vec![Vec::new(); sessions.len()];
    for _ in 0..frames.max(1) {
        for (s, t) in sessions.iter_mut().zip(&mut times) {
            let t0 = Instant::now();
            s.try_picture(ctx, &mut |_, _| {})?;
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
            ctx.adapter_name()
        );
    } else {
        println!("scene            {name} ({w}x{h}, {} primitives)", scene.primitive_count());
        println!("device           {} ({})", ctx.adapter_name(), ctx.adapter_driver());
        for (i, (&accel, r)) in accels.iter().zip(&sessions).enumerate() {
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

/// `--simd`: per loop, the share of the lane slots run that did work, and the slots a pixel paid.
fn print_simd(loops: &[irt::gpu::SimdCount; SIMD_LOOPS.len()], size: u32, pixels: u64) {
    println!("SIMD efficiency  active lanes / lanes run, per loop ({size}-lane groups; slots run per pixel)");
    for (name, c) in SIMD_LOOPS.iter().zip(loops) {
        match c.efficiency(size) {
            Some(e) => println!(
                "  {name:<14} {:5.1}%  ({:.1} slots, {:.1} of them active)",
                100.0 * e,
                (c.group_iterations * size as u64) as f64 / pixels as f64,
                c.lane_iterations as f64 / pixels as f64
            ),
            None => println!("  {name:<14}     -   (not run)"),
        }
    }
}
