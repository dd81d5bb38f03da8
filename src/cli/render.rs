//! `irt render`: one frame of a scene, written to an image file.

use super::args::{load_scene, BackendArgs, DeviceArgs, ModeArgs, SceneArgs};
use super::{check_output_path, open_device};
use anyhow::{Context, Result};
use clap::Args;
use irt::gpu::device::{Backend, Device};
use irt::image::{Image, OutputFormat};
use irt::render::{Mode, Picture, Session, Settings};
use std::path::PathBuf;
use std::time::Instant;

#[derive(Args)]
pub struct RenderArgs {
    /// Output image, written atomically; the extension picks the format: .png (8-bit sRGB) or
    /// .exr (OpenEXR: linear radiance as 32-bit float RGB, values above 1 kept). With --frames,
    /// a pattern with the frame number as `%d` or zero-padded `%04d` (e.g. 'frame_%04d.png').
    #[arg(long, short, default_value = "irt.png")]
    pub out: PathBuf,
    /// Render an animated scene at this time, in seconds (motions hold their first and last
    /// keys outside their range; a still scene looks the same at every time).
    #[arg(long, value_name = "SECONDS", conflicts_with = "frames")]
    pub time: Option<f64>,
    /// Render frames A up to (not including) B of the animation as an image sequence, frame k at
    /// time k / --fps; the scene stays on the device and each frame updates what moved.
    #[arg(long, value_name = "A..B", value_parser = parse_frames)]
    pub frames: Option<std::ops::Range<u32>>,
    /// Frames per second of --frames.
    #[arg(long, default_value_t = 24.0, requires = "frames")]
    pub fps: f64,
    /// With --frames on the grid (--accel grid): rebuild the whole grid every frame instead of
    /// re-inserting only what moves (the same grid either way; for measuring what the update
    /// saves). A BVH is rebuilt whole whenever geometry moves, with or without it.
    #[arg(long, requires = "frames")]
    pub full_rebuild: bool,
    /// Print rays traced by kind (eye, reflection, refraction, shadow) and the eye rays that hit.
    #[arg(long)]
    pub stats: bool,
    /// SPD's testing rules, to compare --stats with the published ray counts: eye rays through
    /// the pixel corners ((W+1)x(H+1) rays, each pixel the mean of its corners), depth at most 5,
    /// a reflection ray at every reflective hit, hard shadows. See docs/nff.md.
    #[arg(long, conflicts_with_all = ["shadows", "max_depth", "mode"])]
    pub spd_rules: bool,
    #[command(flatten)]
    pub scene: SceneArgs,
    /// Without --mode the image is traced in bands of rows (the plain headless path); with it,
    /// one complete frame (conventional) or pass (frameless) of the interactive modes, which
    /// give the same picture bit for bit.
    #[command(flatten)]
    pub mode: ModeArgs,
    /// Samples per pixel, jittered and added up (conventional frames or frameless passes; with
    /// --mode only).
    #[arg(long, value_name = "N", default_value_t = 1, requires = "mode")]
    pub samples: u32,
    #[command(flatten)]
    pub backend: BackendArgs,
    #[command(flatten)]
    pub device: DeviceArgs,
    #[command(flatten)]
    pub mpi: super::mpi::MpiArgs,
    /// Render only tile I of N (I from 0: a band of whole rows, split evenly) into the directory
    /// --out, for a task of a render farm's job array (e.g. --tile $SLURM_ARRAY_TASK_ID/4);
    /// `irt merge DIR --out F` then writes the picture, the same bit for bit as without --tile.
    /// Written atomically; a tile already there is left alone. See examples/slurm.
    #[arg(long, value_name = "I/N", conflicts_with_all = ["mpi", "frames"])]
    pub tile: Option<irt::farm::TileSpec>,
}

pub fn run(args: RenderArgs) -> Result<()> {
    // Under mpirun every rank runs this command: the workers trace until rank 0 ends the job.
    let cluster = match args.mpi.mpi {
        true => match super::mpi::join(args.backend.backend, &args.device)? {
            Some(c) => Some(c),
            None => return Ok(()),
        },
        false => None,
    };
    let result = render(&args, cluster.as_ref());
    if let (Err(e), Some(cluster)) = (&result, &cluster) {
        // The workers wait for rank 0: an error here must end them too, never leave them waiting.
        cluster.abort(&format!("error: {e:#}"));
    }
    result
}

fn render(args: &RenderArgs, cluster: Option<&irt::dist::cluster::Cluster>) -> Result<()> {
    if let Some(spec) = args.tile {
        return super::farm::tile(args, spec);
    }
    // The output is checked first: a mistyped name should not wait for the scene to load.
    check_output_path(&args.out)?;
    let format = OutputFormat::from_path(&args.out).map_err(anyhow::Error::msg)?;
    let scene = scene_of(args)?;
    let mode = args.mode.mode()?;
    if let Some(frames) = args.frames.clone() {
        if cluster.is_some() {
            anyhow::bail!("--frames runs in one process: for an animation on many machines, give each task of a job array a frame range (examples/slurm/frames.sbatch)");
        }
        if args.stats {
            anyhow::bail!("--stats counts rays of one frame: drop --frames to use it");
        }
        return super::sequence::run(args, &scene, frames, mode);
    }
    if let Some(cluster) = cluster {
        return distributed(cluster, args, format, &scene, whole_settings(args, mode));
    }
    if let Some(mode) = mode {
        if args.stats {
            anyhow::bail!("--stats counts rays of the band renderer: drop --mode to use it");
        }
        let settings = Settings { max_samples: args.samples.max(1), ..one_picture(args, mode) };
        return match args.backend.backend {
            Backend::Wgpu => one_pass(&open_device(&args.device)?, args, format, &scene, settings),
            Backend::Ash => one_pass(
                &super::open_vk_device(&args.device, Default::default())?,
                args,
                format,
                &scene,
                settings,
            ),
        };
    }
    match args.backend.backend {
        Backend::Wgpu => bands(&open_device(&args.device)?, args, format, scene, "bands"),
        Backend::Ash => bands(
            &super::open_vk_device(&args.device, Default::default())?,
            args,
            format,
            scene,
            "bands, ash",
        ),
    }
}

/// The scene to render: loaded, with the SPD rules if asked, posed at --time.
pub fn scene_of(args: &RenderArgs) -> Result<irt::scene::Scene> {
    let mut scene = load_scene(&args.scene)?;
    if args.spd_rules {
        irt::io::nff::apply_spd_rules(&mut scene);
    }
    if let Some(t) = args.time {
        if !t.is_finite() {
            anyhow::bail!("--time {t}: give a finite number of seconds");
        }
        if !scene.is_animated() {
            log::info!("the scene has no motion: --time {t} renders it as it is");
        }
        scene = scene.at(t);
        scene.validate().map_err(|e| anyhow::anyhow!("at time {t} s: {}", e.0))?;
    }
    Ok(scene)
}

/// The settings of the whole picture when others trace its pieces (MPI workers, farm tiles):
/// the bands, or `mode` with --samples.
pub fn whole_settings(args: &RenderArgs, mode: Option<Mode>) -> Settings {
    Settings { mode: mode.unwrap_or(Mode::Bands), max_samples: args.samples, ..bands_settings(args) }
}

/// The bands on `ctx`'s path, with a bar for the setup and one for the tracing. The scene is
/// handed over to the session (a large model is not held twice).
fn bands<D: Device>(
    ctx: &D,
    args: &RenderArgs,
    format: OutputFormat,
    scene: irt::scene::Scene,
    how: &str,
) -> Result<()> {
    let settings = bands_settings(args);
    let (h, primitives) = (scene.camera.height, scene.primitive_count());
    let setup = super::setup_bar(primitives);
    let mut session = Session::with_progress(ctx, scene, settings, &|stage, done, total| {
        super::show_setup(&setup, stage, done, total)
    })?;
    setup.finish_and_clear();
    let t = session.setup_timings();
    super::report(
        primitives,
        format!(
            "set up in {:.2} s: {} {:.2} s ({} references), packing and upload {:.2} s ({} MiB on the device)",
            (t.accel_build + t.upload + t.pipeline).as_secs_f64(),
            match session.accel.kind() {
                irt::accel::AccelKind::Grid => "grid",
                irt::accel::AccelKind::Bvh(_) => "BVH",
            },
            t.accel_build.as_secs_f64(),
            session.accel.refs(),
            t.upload.as_secs_f64(),
            session.device_scene().bytes >> 20
        ),
    );
    let bar = tracing_bar(h);
    let how = if session.whole() { how.to_string() } else { format!("{how}{}", in_pieces(&session)) };
    let t = Instant::now();
    let frame = session.try_picture(ctx, &mut |done, _| bar.set_position(done as u64))?;
    let elapsed = t.elapsed();
    bar.finish_and_clear();
    write(args, format, &frame.image, session.scene(), elapsed, ctx.adapter_name(), &how)?;
    print_stats(args, &frame);
    Ok(())
}

/// The settings of a headless picture in `mode`: one sample, the scene arguments' precision and
/// accelerator (`--mode`, and each frame of `--frames`).
pub fn one_picture(args: &RenderArgs, mode: irt::render::Mode) -> Settings {
    Settings { mode, f64: args.scene.f64(), accel: args.scene.accel, max_samples: 1, ..Settings::default() }
}

/// One complete frame (conventional) or pass (frameless) of an interactive mode, on `ctx`'s path.
fn one_pass<D: Device>(
    ctx: &D,
    args: &RenderArgs,
    format: OutputFormat,
    scene: &irt::scene::Scene,
    settings: Settings,
) -> Result<()> {
    let mode = settings.mode;
    let mut session = Session::new(ctx, scene, settings)?;
    let pieces = if session.whole() { String::new() } else { in_pieces(&session) };
    let bar = super::bar(0, "{spinner} tracing {pos}/{len} pixels [{bar:30}] {elapsed_precise}");
    let t = Instant::now();
    let image = session.try_render_image(ctx, &mut |done, total| {
        bar.set_length(total);
        bar.set_position(done);
    })?;
    let elapsed = t.elapsed();
    bar.finish_and_clear();
    let how = match args.backend.backend {
        Backend::Wgpu => format!("{mode}{pieces}"),
        Backend::Ash => format!("{mode}{pieces}, ash"),
    };
    write(args, format, &image, scene, elapsed, ctx.adapter_name(), &how)
}

/// How a picture larger than the device's buffers was traced, for the report line.
fn in_pieces<D: Device>(session: &Session<D>) -> String {
    format!(", in pieces of at most {} pixels (the device's largest storage binding)", session.buffer_rays())
}

fn bands_settings(args: &RenderArgs) -> Settings {
    Settings {
        mode: Mode::Bands,
        count_rays: args.stats,
        corner_rays: args.spd_rules,
        ..one_picture(args, Mode::Bands)
    }
}

/// The picture traced by the workers of an MPI job; rank 0 writes it.
fn distributed(
    cluster: &irt::dist::cluster::Cluster,
    args: &RenderArgs,
    format: OutputFormat,
    scene: &irt::scene::Scene,
    settings: Settings,
) -> Result<()> {
    let deadlines = args.mpi.deadlines()?;
    let how = format!("{} over MPI", settings.mode);
    let bar =
        super::bar(0, "{spinner} tracing {pos}/{len} pixels on the workers [{bar:30}] {elapsed_precise}");
    let t = Instant::now();
    let r = irt::dist::master::render(cluster, scene, settings, deadlines, &mut |done, total| {
        bar.set_length(total);
        bar.set_position(done);
    })
    .unwrap_or_else(|e| cluster.abort(&e.to_string()));
    bar.finish_and_clear();
    let elapsed = t.elapsed();
    let kib = |b: u64| b.div_ceil(1024);
    irt::dist::cluster::say(
        0,
        &format!(
            "traced in {:.3} s after {:.3} s of setup, leading on {:.0}% of a core; sent {} KiB in {} messages, received {} KiB in {}",
            r.trace.as_secs_f64(),
            r.setup.as_secs_f64(),
            100.0 * r.cpu.as_secs_f64() / r.trace.as_secs_f64().max(1e-9),
            kib(r.traffic.sent),
            r.traffic.messages_sent,
            kib(r.traffic.received),
            r.traffic.messages_received
        ),
    );
    let how = format!("{how}, {} workers", r.workers);
    write(args, format, &r.image, scene, elapsed, &r.devices, &how)
}

fn tracing_bar(rows: u32) -> indicatif::ProgressBar {
    super::bar(rows as u64, "{spinner} tracing {pos}/{len} rows [{bar:30}] {elapsed_precise}")
}

fn print_stats(args: &RenderArgs, frame: &Picture) {
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
            "shader loop iterations: at most {} per pixel and pass (lavapipe's limit is {}), \
             {:.1} per pixel on average; SIMD lanes busy at most {:.0}% of their loop iterations",
            frame.max_loop_iterations,
            irt::gpu::layout::LAVAPIPE_LOOP_LIMIT,
            frame.loops.mean,
            frame.loops.occupancy * 100.0
        );
    }
}

/// `A..B` (B excluded), the frames of `--frames`.
fn parse_frames(s: &str) -> Result<std::ops::Range<u32>, String> {
    let (a, b) = s.split_once("..").ok_or_else(|| format!("'{s}' is not A..B (e.g. 0..96)"))?;
    let number =
        |x: &str| x.trim().parse::<u32>().map_err(|_| format!("'{x}' in '{s}' is not a frame number"));
    let (a, b) = (number(a)?, number(b)?);
    if b <= a {
        return Err(format!("'{s}' has no frames: B must be greater than A (B is not included)"));
    }
    Ok(a..b)
}

pub(super) fn write(
    args: &RenderArgs,
    format: OutputFormat,
    image: &Image,
    scene: &irt::scene::Scene,
    elapsed: std::time::Duration,
    device: &str,
    how: &str,
) -> Result<()> {
    let (w, h) = (image.width, image.height);
    // Never expected (the extreme-scene suite checks it), but never silently written either.
    let bad = image.non_finite();
    if bad > 0 {
        let written = match format {
            OutputFormat::Png => "written black or clamped",
            OutputFormat::Exr => "written as they are",
        };
        log::warn!("{bad} pixel channels are NaN or infinite ({written})");
    }
    image.save_as(&args.out, format).with_context(|| format!("writing {}", args.out.display()))?;
    eprintln!(
        "wrote {} ({w}x{h}, {} primitives, {how}, {:.2} s on {})",
        args.out.display(),
        scene.primitive_count(),
        elapsed.as_secs_f64(),
        device
    );
    Ok(())
}
