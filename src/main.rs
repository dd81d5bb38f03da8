//! `irt`: the command-line front end. Library errors become messages and exit codes here.

use anyhow::{bail, Context, Result};
use clap::{Args, Parser, Subcommand};
use irt::gpu::{AdapterChoice, CacheSetting, GpuContext, RenderOptions, Renderer};
use irt::scene::Scene;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

#[derive(Parser)]
#[command(
    name = "irt",
    version,
    about = "Interactive ray tracer on Vulkan compute (Parker et al., I3D 1999)",
    long_about = "irt traces scenes with WGSL compute shaders on any Vulkan device — by default \
Mesa's lavapipe, which runs Vulkan on the CPU. Without a SCENE it draws the built-in default \
scene.\n\nExamples:\n  irt render --out default.png\n  irt render scenes/metal.toml --width 800 --height 600 --out metal.png\n  irt render scenes/spd/balls_s4.nff --stats --spd-rules --out balls.png\n  irt render --shadows bundle:16 --out soft.png\n  irt tradeoff --out-dir tradeoff\n  irt bench\n  irt convert model.glb model.toml\n  irt info"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene to a PNG (headless).
    Render(RenderArgs),
    /// Show the Vulkan adapters and the one irt would use.
    Info(DeviceArgs),
    /// Measure grid build, time to first frame and Mrays/s.
    Bench(BenchArgs),
    /// Measure every shadow mode's time and error against the ground truth; table + plot.
    Tradeoff(TradeoffArgs),
    /// Measure the GPU's error against the f64 reference as the scene moves away from the origin.
    Stability(StabilityArgs),
    /// Write any scene irt can load (TOML, glTF) as a native TOML scene, losslessly.
    Convert(ConvertArgs),
    // about and long help come from ViewArgs (a doc comment here would replace them).
    View(irt::app::ViewArgs),
}

#[derive(Args)]
struct ConvertArgs {
    /// Scene to read (.toml, .gltf, .glb).
    input: PathBuf,
    /// TOML file to write (atomically); loading it gives back exactly the scene irt read. Each
    /// texture is written beside it as OUTPUT-STEM.<index>[.<name>].png (replacing such files).
    output: PathBuf,
}

#[derive(Args)]
struct DeviceArgs {
    /// Vulkan adapter: "lavapipe" (default), "gpu" (best hardware GPU), or part of a device name.
    /// Also read from $IRT_ADAPTER.
    #[arg(long, value_name = "NAME")]
    adapter: Option<String>,
    /// Do not read or write the on-disk pipeline cache (also: IRT_CACHE_DIR=off). By default
    /// compiled pipelines are kept in $IRT_CACHE_DIR, else $XDG_CACHE_HOME/irt, else ~/.cache/irt.
    #[arg(long)]
    no_cache: bool,
}

#[derive(Args)]
struct SceneArgs {
    /// Scene file (.toml, .gltf, .glb, .nff); the built-in default scene when omitted.
    scene: Option<PathBuf>,
    /// Image width in pixels (overrides the scene's camera).
    #[arg(long, allow_negative_numbers = true)]
    width: Option<u32>,
    /// Image height in pixels (overrides the scene's camera).
    #[arg(long, allow_negative_numbers = true)]
    height: Option<u32>,
    /// Shadow mode (overrides the scene's [trace] shadows): hard, bundle:K (K rays to a
    /// precomputed point set on the light, rotated per pixel; bundle:K:fixed unrotated), or shell
    /// (one ray through translucent shells; shell:FALLOFF:COMBINE with FALLOFF linear (default),
    /// smoothstep or disc and COMBINE min (default) or product). See docs/shadows.md.
    #[arg(long, value_name = "MODE")]
    shadows: Option<irt::scene::ShadowMode>,
    /// Radius of every light (overrides the scene; 0 is a point light, soft modes need > 0).
    #[arg(long, value_name = "R")]
    light_radius: Option<f64>,
    /// Arithmetic of ray–primitive intersection and grid traversal: f32, or f64 (needs the
    /// device's SHADER_F64; lavapipe has it). See docs/stability.md.
    #[arg(long, value_name = "BITS", default_value = "f32", value_parser = ["f32", "f64"])]
    precision: String,
}

#[derive(Args)]
struct RenderArgs {
    #[command(flatten)]
    scene: SceneArgs,
    /// Output PNG (8-bit sRGB), written atomically.
    #[arg(long, short, default_value = "irt.png")]
    out: PathBuf,
    /// Print rays traced by kind (eye, reflection, refraction, shadow) and the eye rays that hit.
    #[arg(long)]
    stats: bool,
    /// SPD's testing rules, to compare --stats with the published ray counts: eye rays through
    /// the pixel corners ((W+1)x(H+1) rays, each pixel the mean of its corners), depth at most 5,
    /// a reflection ray at every reflective hit, hard shadows. See docs/nff.md.
    #[arg(long, conflicts_with = "shadows")]
    spd_rules: bool,
    #[command(flatten)]
    device: DeviceArgs,
}

#[derive(Args)]
struct TradeoffArgs {
    #[command(flatten)]
    scene: SceneArgs,
    /// Where table.md and plot.svg go (created if missing).
    #[arg(long, default_value = "tradeoff")]
    out_dir: PathBuf,
    /// Ground truth: STRATA² stratified shadow rays per light and shading point (32 → 1024,
    /// about 30 s on 2 cores for the default scene; docs/tradeoff.md uses 64 → 4096).
    #[arg(long, default_value_t = 32)]
    strata: u32,
    /// Timed frames per mode (median reported).
    #[arg(long, default_value_t = 3)]
    frames: u32,
    #[command(flatten)]
    device: DeviceArgs,
}

#[derive(Args)]
struct StabilityArgs {
    #[command(flatten)]
    scene: SceneArgs,
    /// Where table.md and plot.svg go (created if missing).
    #[arg(long, default_value = "stability")]
    out_dir: PathBuf,
    #[command(flatten)]
    device: DeviceArgs,
}

#[derive(Args)]
struct BenchArgs {
    #[command(flatten)]
    scene: SceneArgs,
    /// Timed frames after the first (median reported).
    #[arg(long, default_value_t = 5)]
    frames: u32,
    /// Start with an empty Mesa shader cache and an empty irt pipeline cache, to measure a cold
    /// time to first frame.
    #[arg(long)]
    cold: bool,
    /// Start with an empty Mesa shader cache but irt's pipeline cache as found: what irt's own
    /// cache brings on its own.
    #[arg(long, conflicts_with = "cold")]
    cold_mesa_only: bool,
    /// Print one Markdown table row (for the README's performance table).
    #[arg(long)]
    markdown: bool,
    /// Time the uber-pipeline (every primitive type and shadow mode compiled in) instead of the
    /// pipeline specialised to the scene.
    #[arg(long)]
    uber: bool,
    #[command(flatten)]
    device: DeviceArgs,
}

fn main() {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(a) => render(a),
        Command::Info(a) => info(a),
        Command::Bench(a) => bench(a),
        Command::Tradeoff(a) => tradeoff(a),
        Command::Stability(a) => stability(a),
        Command::Convert(a) => convert(a),
        Command::View(a) => irt::app::run(a),
    };
    if let Err(e) = result {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

fn load_scene(args: &SceneArgs) -> Result<Scene> {
    let mut scene = match &args.scene {
        Some(path) => irt::io::load(path)?,
        None => irt::scene::default_scene(),
    };
    if let Some(w) = args.width {
        scene.camera.width = w;
    }
    if let Some(h) = args.height {
        scene.camera.height = h;
    }
    if let Some(m) = args.shadows {
        scene.trace.shadows = m;
    }
    if let Some(r) = args.light_radius {
        scene.lights.iter_mut().for_each(|l| l.radius = r);
    }
    let origin = args.scene.as_deref().map_or("default scene".into(), |p| p.display().to_string());
    scene.validate().with_context(|| format!("{origin} cannot be rendered"))?;
    if scene.primitive_count() == 0 {
        bail!("{origin} has no primitives: nothing to render");
    }
    Ok(scene)
}

fn open_device(args: &DeviceArgs) -> Result<GpuContext> {
    open_device_with(args, &CacheSetting::from_flag_or_env(args.no_cache))
}

fn open_device_with(args: &DeviceArgs, cache: &CacheSetting) -> Result<GpuContext> {
    Ok(GpuContext::with_cache(&AdapterChoice::from_arg_or_env(args.adapter.as_deref()), cache)?)
}

fn render(args: RenderArgs) -> Result<()> {
    let mut scene = load_scene(&args.scene)?;
    if args.spd_rules {
        irt::io::nff::apply_spd_rules(&mut scene);
    }
    check_output_path(&args.out)?;
    let ctx = open_device(&args.device)?;
    let (w, h) = (scene.camera.width, scene.camera.height);
    let opts = RenderOptions {
        count_rays: args.stats,
        corner_rays: args.spd_rules,
        f64: args.scene.precision == "f64",
        ..Default::default()
    };
    let renderer = Renderer::new(&ctx, &scene, opts).map_err(anyhow::Error::msg)?;
    let bar = indicatif::ProgressBar::new(h as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{spinner} tracing {pos}/{len} rows [{bar:30}] {elapsed_precise}",
        )
        .expect("valid template")
        .progress_chars("=> "),
    );
    let t = Instant::now();
    let frame = renderer.render(&ctx, &mut |done, _| bar.set_position(done as u64));
    let elapsed = t.elapsed();
    bar.finish_and_clear();
    // Never expected (the extreme-scene suite checks it), but never silently written either.
    let bad = frame.image.non_finite();
    if bad > 0 {
        log::warn!("{bad} pixel channels are NaN or infinite (written black or clamped)");
    }
    frame.image.save_png(&args.out).with_context(|| format!("writing {}", args.out.display()))?;
    eprintln!(
        "wrote {} ({w}x{h}, {} primitives, {:.2} s on {})",
        args.out.display(),
        scene.primitive_count(),
        elapsed.as_secs_f64(),
        ctx.info.name
    );
    if args.stats {
        let r = frame.rays;
        println!(
            "rays: eye {} ({} hit)  reflection {}  refraction {}  shadow {}  total {}",
            r.eye,
            frame.eye_hits,
            r.reflection,
            r.refraction,
            r.shadow,
            r.total()
        );
        println!(
            "shader loop iterations: at most {} per pixel and pass (lavapipe's limit is {})",
            frame.max_loop_iterations,
            irt::gpu::layout::LAVAPIPE_LOOP_LIMIT
        );
    }
    Ok(())
}

fn convert(args: ConvertArgs) -> Result<()> {
    if !args.output.extension().is_some_and(|e| e.eq_ignore_ascii_case("toml")) {
        bail!("output '{}' must be a .toml file: irt writes its native TOML format", args.output.display());
    }
    check_output_path(&args.output)?;
    let scene = irt::io::load(&args.input)?;
    let stem = args.output.file_stem().map_or("scene".into(), |s| s.to_string_lossy());
    let files = irt::io::toml_write::to_files(&scene, &stem).map_err(anyhow::Error::msg)?;
    if files.toml.len() as u64 > irt::io::MAX_SCENE_FILE_BYTES {
        bail!(
            "the TOML would be {} bytes, above the {}-byte limit irt loads; keep the scene in its own format",
            files.toml.len(),
            irt::io::MAX_SCENE_FILE_BYTES
        );
    }
    // Textures first: the TOML, written last, never refers to a file that is not there yet.
    let dir = args.output.parent().unwrap_or(Path::new(""));
    for (name, png) in &files.textures {
        let path = dir.join(name);
        irt::image::write_atomic(&path, png).with_context(|| format!("writing {}", path.display()))?;
        eprintln!("wrote {}", path.display());
    }
    irt::image::write_atomic(&args.output, files.toml.as_bytes())
        .with_context(|| format!("writing {}", args.output.display()))?;
    eprintln!(
        "wrote {} ({} materials, {} textures, {} spheres, {} triangles, {} lights)",
        args.output.display(),
        scene.materials.len(),
        scene.textures.len(),
        scene.spheres.len(),
        scene.triangle_count(),
        scene.lights.len()
    );
    Ok(())
}

/// Fails early (before minutes of tracing) when the PNG could not be written.
fn check_output_path(out: &Path) -> Result<()> {
    let dir = out.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    if !dir.is_dir() {
        bail!("output directory '{}' does not exist", dir.display());
    }
    if out.is_dir() {
        bail!("output '{}' is a directory; give a .png file name", out.display());
    }
    Ok(())
}

fn info(args: DeviceArgs) -> Result<()> {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
    desc.backends = wgpu::Backends::VULKAN;
    let instance = wgpu::Instance::new(desc);
    let adapters = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::VULKAN));
    println!("Vulkan adapters:");
    for a in &adapters {
        let i = a.get_info();
        println!("  {} ({:?}, driver {} {})", i.name, i.device_type, i.driver, i.driver_info);
    }
    let ctx = open_device(&args)?;
    let i = &ctx.info;
    println!("irt uses: {} — driver {} {}", i.name, i.driver, i.driver_info);
    let f = ctx.adapter.features();
    println!(
        "  features: SHADER_F64 {}  TIMESTAMP_QUERY {}  PIPELINE_CACHE {}",
        f.contains(wgpu::Features::SHADER_F64),
        f.contains(wgpu::Features::TIMESTAMP_QUERY),
        f.contains(wgpu::Features::PIPELINE_CACHE)
    );
    let l = ctx.device.limits();
    println!(
        "  limits: 2D texture {}  storage binding {} MiB  workgroups/dim {}",
        l.max_texture_dimension_2d,
        l.max_storage_buffer_binding_size >> 20,
        l.max_compute_workgroups_per_dimension
    );
    println!("  pipeline cache: {}", ctx.cache_status);
    Ok(())
}

fn median(mut v: Vec<Duration>) -> Duration {
    v.sort();
    v[v.len() / 2]
}

fn bench(args: BenchArgs) -> Result<()> {
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
    let mut scene_args = args.scene;
    scene_args.width = scene_args.width.or(Some(512));
    scene_args.height = scene_args.height.or(Some(512));
    let scene = load_scene(&scene_args)?;
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
    let f64 = scene_args.precision == "f64";
    let opts = RenderOptions { uber_shader: args.uber, f64, ..Default::default() };
    let renderer = Renderer::new(&ctx, &scene, opts).map_err(anyhow::Error::msg)?;
    let first = renderer.render(&ctx, &mut |_, _| {});
    let first_frame = t.elapsed();
    if first.image.non_finite() > 0 {
        bail!("the benchmark frame contains NaN/Inf values");
    }
    let frame = renderer.median_frame_time(&ctx, args.frames);
    // Ray counts come from a separate counting pipeline so the timed one carries no atomics.
    let counting = Renderer::new(&ctx, &scene, RenderOptions { count_rays: true, f64, ..Default::default() })
        .map_err(anyhow::Error::msg)?;
    let rays = counting.render(&ctx, &mut |_, _| {}).rays;
    let mrays = rays.total() as f64 / frame.as_secs_f64() / 1e6;
    let stats = renderer.grid.stats();
    let (w, h) = (scene.camera.width, scene.camera.height);
    let mut name = scene_args.scene.as_deref().map_or("default".into(), |p| p.display().to_string());
    if args.uber {
        name += " (uber)";
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

fn tradeoff(args: TradeoffArgs) -> Result<()> {
    let mut scene_args = args.scene;
    // Half the default scene's size unless told: the f64 ground truth traces `strata²` rays per
    // shading point on the CPU.
    if scene_args.width.is_none() && scene_args.height.is_none() {
        scene_args.width = Some(320);
        scene_args.height = Some(240);
    }
    let scene = load_scene(&scene_args)?;
    if scene.lights.iter().all(|l| l.radius == 0.0) {
        bail!("every light is a point light (radius 0): soft shadows equal hard ones; give the lights a radius (--light-radius R)");
    }
    if !(1..=256).contains(&args.strata) {
        bail!("--strata {} must be between 1 and 256", args.strata);
    }
    std::fs::create_dir_all(&args.out_dir).with_context(|| format!("creating {}", args.out_dir.display()))?;
    let ctx = open_device(&args.device)?;
    let name = scene_args.scene.as_deref().map_or("default scene".into(), |p| p.display().to_string());
    let (w, h) = (scene.camera.width, scene.camera.height);
    eprintln!(
        "ground truth: {w}x{h}, {} shadow rays per light and shading point, f64 on the CPU...",
        args.strata * args.strata
    );
    let t = Instant::now();
    let truth = irt::reference::Reference::new(&scene).with_ground_truth(args.strata).render().0;
    let truth = irt::image::Image {
        width: truth.width,
        height: truth.height,
        pixels: truth.pixels.iter().map(|p| [p.x as f32, p.y as f32, p.z as f32]).collect(),
    };
    eprintln!("ground truth took {:.1} s", t.elapsed().as_secs_f64());
    truth.save_png(&args.out_dir.join("ground-truth.png"))?;
    let modes = irt::tradeoff::modes();
    let bar = indicatif::ProgressBar::new(modes.len() as u64);
    let mut rows = Vec::new();
    for mode in modes {
        bar.set_message(mode.to_string());
        rows.push(
            irt::tradeoff::measure(&ctx, &scene, mode, &truth, args.frames).map_err(anyhow::Error::msg)?,
        );
        bar.inc(1);
    }
    bar.finish_and_clear();
    let header = format!(
        "Scene: {name}, {w}x{h}, light radius {}; device: {}; ground truth {}² stratified rays (f64 CPU); {}; command: `irt tradeoff{}`\n\n",
        scene.lights.iter().map(|l| l.radius.to_string()).collect::<Vec<_>>().join(", "),
        ctx.info.name,
        args.strata,
        machine_line(),
        command_args(),
    );
    let table = header + &irt::tradeoff::markdown_table(&rows);
    print!("{table}");
    irt::image::write_atomic(&args.out_dir.join("table.md"), table.as_bytes())?;
    irt::tradeoff::plot_svg(
        &rows,
        &format!("shadow modes on {name}: error vs time"),
        &args.out_dir.join("plot.svg"),
    )
    .map_err(anyhow::Error::msg)?;
    eprintln!("wrote {}/table.md, plot.svg, ground-truth.png", args.out_dir.display());
    Ok(())
}

/// This run's arguments after the subcommand, for tables that state their command.
fn command_args() -> String {
    std::env::args().skip(2).map(|a| format!(" {a}")).collect()
}

/// CPU model and core count, for tables that state the machine.
fn machine_line() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .map(|l| l.split(':').nth(1).unwrap_or("").trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    format!("{cpu}, {cores} cores")
}

/// A directory removed when dropped.
struct TempDir(PathBuf);

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn stability(args: StabilityArgs) -> Result<()> {
    let mut scene_args = args.scene;
    // The f64 reference renders every distance: keep it small unless told.
    if scene_args.width.is_none() && scene_args.height.is_none() {
        scene_args.width = Some(160);
        scene_args.height = Some(120);
    }
    let scene = load_scene(&scene_args)?;
    std::fs::create_dir_all(&args.out_dir).with_context(|| format!("creating {}", args.out_dir.display()))?;
    let ctx = open_device(&args.device)?;
    let bar = indicatif::ProgressBar::new(irt::stability::DISTANCES.len() as u64);
    let mut rows = Vec::new();
    for d in irt::stability::DISTANCES {
        bar.set_message(format!("{d:e}"));
        rows.push(irt::stability::measure(&ctx, &scene, d).map_err(anyhow::Error::msg)?);
        bar.inc(1);
    }
    bar.finish_and_clear();
    let name = scene_args.scene.as_deref().map_or("default scene".into(), |p| p.display().to_string());
    let (w, h) = (scene.camera.width, scene.camera.height);
    let table = format!(
        "Scene: {name}, {w}x{h}, moved along (1, 0.8, -0.6); device: {}; {}; command: `irt stability{}`\n\n{}",
        ctx.info.name,
        machine_line(),
        command_args(),
        irt::stability::markdown_table(&rows)
    );
    print!("{table}");
    irt::image::write_atomic(&args.out_dir.join("table.md"), table.as_bytes())?;
    irt::stability::plot_svg(
        &rows,
        &format!("GPU (f32, f64) vs f64 reference: {name}"),
        &args.out_dir.join("plot.svg"),
    )
    .map_err(anyhow::Error::msg)?;
    eprintln!("wrote {}/table.md and plot.svg", args.out_dir.display());
    Ok(())
}
