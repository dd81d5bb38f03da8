//! The measurements of docs/interactive.md, as one run that writes every table (`*.md`) and plot
//! (`*.svg`) into a directory: conventional against frameless over a camera path at equal
//! rays/s, the conventional schedules, the frameless pixel orders, the frameless slice size and
//! progressive refinement. `scripts/interactive-table.sh` runs it (through
//! `irt-lab interactive`) with the machine header of `scripts/bench-lib.sh`.

use irt::gpu::{AdapterChoice, CacheSetting, GpuContext};
use irt::image::Image;
use irt::render::metrics::{AgeStats, Clock};
use irt::render::replay::{calibrate, replay, CameraPath, ReplayOptions, ReplayReport};
use irt::render::{Mode, PixelOrder, RenderError, Schedule, Session, Settings};
use irt::scene::Scene;
use plotters::prelude::*;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// A session kept for speed measurements interleaved with others (so that a load on the
/// machine that comes and goes hits every configuration alike): its camera moves along the path
/// on its own real clock, wrapping at the end; conventional frames take the camera when they
/// start.
pub struct SpeedRunner {
    session: Session,
    t: f64,
    conventional: bool,
    /// Wall time and pixels of the whole units so far.
    time: Duration,
    pixels: u64,
}

impl SpeedRunner {
    /// A session of `settings` on `scene`, warmed up (pipelines compiled) by one whole pass.
    pub fn new(ctx: &GpuContext, scene: &Scene, settings: &Settings) -> Result<Self, RenderError> {
        let mut session = Session::new(ctx, scene, Settings { max_samples: 1, ..settings.clone() })?;
        session.complete_pass(ctx);
        let conventional = matches!(settings.mode, Mode::Conventional { .. });
        Ok(SpeedRunner { session, t: 0.0, conventional, time: Duration::ZERO, pixels: 0 })
    }

    /// Traces whole units until at least `pixels` pixel values are written.
    pub fn run(&mut self, ctx: &GpuContext, path: &CameraPath, pixels: u64) {
        let [w, h] = self.session.size();
        let (mut done, mut frame, mut frame_start) = (0u64, Duration::ZERO, true);
        while done < pixels {
            if !self.conventional || frame_start {
                let c = path.camera_at(self.t % path.duration(), w, h);
                self.session.set_camera(ctx, &c);
            }
            let r = self.session.step(ctx);
            if r.idle {
                self.t += 1e-3;
                continue;
            }
            self.t += r.trace_time.as_secs_f64();
            frame += r.trace_time;
            frame_start = !self.conventional || r.frame_done;
            if frame_start {
                self.time += std::mem::take(&mut frame);
                self.pixels += r.pixels;
                done += r.pixels;
            }
        }
    }

    /// Wall seconds per pixel over all the units so far (the total, not a median: a stall
    /// of the machine costs short and long units alike).
    pub fn s_per_pixel(&self) -> f64 {
        self.time.as_secs_f64() / self.pixels.max(1) as f64
    }
}

/// `rounds` rounds, each running every runner for `pixels` pixel values in turn.
fn interleaved(ctx: &GpuContext, runners: &mut [SpeedRunner], path: &CameraPath, pixels: u64, rounds: u32) {
    for _ in 0..rounds {
        for r in runners.iter_mut() {
            r.run(ctx, path, pixels);
        }
    }
}

/// Rays of every kind per pixel of a headless frame of `scene`'s camera (for Mrays/s from
/// pixel updates/s).
pub fn rays_per_pixel(ctx: &GpuContext, scene: &Scene) -> Result<f64, RenderError> {
    let picture = Session::new(ctx, scene, Settings { count_rays: true, ..Settings::bands() })?
        .picture(ctx, &mut |_, _| {});
    Ok(picture.rays.total() as f64 / (scene.camera.width as f64 * scene.camera.height as f64))
}

/// Progressive refinement at rest: the display-space RMSE of the picture after each of
/// `counts` samples per pixel against the same session's picture after `reference` samples.
pub fn refinement_errors(
    ctx: &GpuContext,
    scene: &Scene,
    counts: &[u32],
    reference: u32,
) -> Result<Vec<(u32, f64)>, RenderError> {
    let settings = Settings { mode: Mode::conventional(), max_samples: reference, ..Settings::default() };
    let mut s = Session::new(ctx, scene, settings)?;
    let mut pictures: Vec<(u32, Image)> = Vec::new();
    while !s.converged() {
        s.complete_pass(ctx);
        if counts.contains(&s.samples()) {
            pictures.push((s.samples(), s.read_image(ctx)));
        }
    }
    let reference = s.read_image(ctx);
    Ok(pictures.iter().map(|(n, p)| (*n, irt::metrics::rmse(p, &reference))).collect())
}

/// `irt-lab interactive`: the study's arguments.
#[derive(clap::Args, Clone, Debug)]
pub struct StudyArgs {
    /// Where the tables (*.md) and plots (*.svg) go (created if missing).
    #[arg(long, default_value = "docs/interactive")]
    pub out_dir: PathBuf,
    /// The line that heads every table (scripts/bench-lib.sh's machine_header: machine, date,
    /// command).
    #[arg(long, default_value = "")]
    pub header: String,
    /// Dynamic error at every K-th display refresh (6 per second at 60 Hz).
    #[arg(long, default_value_t = 10, value_name = "K")]
    pub error_every: u32,
    /// Timed frames per schedule (their mean, the schedules taking turns) and per calibration of the
    /// virtual clock (their median).
    #[arg(long, default_value_t = 5)]
    pub frames: u32,
    /// Tiny images and few frames: a smoke test of the whole study in seconds (numbers
    /// meaningless).
    #[arg(long)]
    pub quick: bool,
    /// Run only these parts (repeatable): modes, schedules, orders, slices, refinement.
    #[arg(long, value_name = "PART", value_parser = PARTS)]
    pub only: Vec<String>,
    /// Vulkan adapter: "lavapipe" (default), "gpu", or part of a device name (also $IRT_ADAPTER).
    #[arg(long, value_name = "NAME")]
    pub adapter: Option<String>,
}

/// The parts of the study, each one table (`PART.md`).
pub const PARTS: [&str; 5] = ["modes", "schedules", "orders", "slices", "refinement"];

struct Case {
    name: &'static str,
    scene: Scene,
    path: CameraPath,
}

fn case(name: &'static str, scene: Option<&str>, path: &str) -> anyhow::Result<Case> {
    let scene = match scene {
        Some(p) => irt::io::load(Path::new(p))?,
        None => irt::scene::default_scene(),
    };
    Ok(Case { name, scene, path: CameraPath::load(Path::new(path))? })
}

fn sized(scene: &Scene, path: &CameraPath, [w, h]: [u32; 2]) -> Scene {
    let mut s = scene.clone();
    s.camera = path.camera_at(0.0, w, h);
    s
}

fn ms(s: f64) -> String {
    if s < 0.01 {
        format!("{:.1}", s * 1e3)
    } else {
        format!("{:.0}", s * 1e3)
    }
}

fn ages(a: &AgeStats) -> String {
    format!("{} / {} / {}", ms(a.mean), ms(a.p90), ms(a.max))
}

fn latency(r: &ReplayReport) -> String {
    let l = &r.latency.mean;
    format!("{} / {} / {} / {}", ms(l[0]), ms(l[1]), ms(l[2]), ms(l[3]))
}

fn error(r: &ReplayReport) -> String {
    r.dynamic_error.map_or("–".into(), |e| format!("{:.4} ({:.4})", e.mean, e.max))
}

fn frameless_with(order: PixelOrder, slice: u32) -> Mode {
    Mode::Frameless { order, slice, present_every: 0, blend: None, jitter_pairs: false }
}

/// Rounds of every interleaved speed measurement.
const SPEED_ROUNDS: u32 = 3;

fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "unknown".into())
}

/// Runs the whole study; see the module documentation.
pub fn run(args: StudyArgs) -> anyhow::Result<()> {
    use anyhow::Context;
    let t_start = Instant::now();
    let load_start = load_average();
    std::fs::create_dir_all(&args.out_dir).with_context(|| format!("creating {}", args.out_dir.display()))?;
    let ctx = GpuContext::with_cache(
        &AdapterChoice::from_arg_or_env(args.adapter.as_deref()),
        &CacheSetting::from_flag_or_env(false),
    )?;
    let device = format!("{} ({})", ctx.info.name, ctx.info.driver_info);
    let default = case("default", None, "scenes/paths/orbit.toml")?;
    let balls = case("balls_s2", Some("scenes/spd/balls_s2.nff"), "scenes/paths/balls.toml")?;
    let q = args.quick;
    let sizes: &[[u32; 2]] = if q { &[[64, 48]] } else { &[[512, 512], [1280, 720]] };
    let small = if q { [64, 48] } else { [512, 512] };
    let frames = if q { 1 } else { args.frames };
    let bar = indicatif::ProgressBar::new_spinner();
    bar.enable_steady_tick(Duration::from_millis(200));
    let say = |m: String| bar.set_message(format!("[{:.0} s] {m}", t_start.elapsed().as_secs_f64()));
    // Each table states the load it was measured under: the machine is shared, and its other
    // work moves every real-clock number.
    let part_start = std::cell::Cell::new((Instant::now(), String::new()));
    let head = |what: &str| {
        part_start.set((Instant::now(), load_average()));
        let mut h = String::new();
        if !args.header.is_empty() {
            let _ = writeln!(h, "{}\n", args.header);
        }
        let _ = writeln!(h, "Device: {device}. {what}\n");
        h
    };
    let write = |name: &str, text: &str| -> anyhow::Result<()> {
        let (t0, load0) = part_start.replace((Instant::now(), String::new()));
        let text = format!(
            "{text}\nMeasured in {:.0} s; load average (1, 5, 15 min) {load0} before, {} after.\n",
            t0.elapsed().as_secs_f64(),
            load_average()
        );
        let p = args.out_dir.join(name);
        irt::image::write_atomic(&p, text.as_bytes()).with_context(|| format!("writing {}", p.display()))
    };
    let settings = Settings { max_samples: 1, ..Settings::default() };
    let part = |name: &str| args.only.is_empty() || args.only.iter().any(|p| p == name);

    // ---- Conventional against frameless, equal rays/s --------------------------------------
    let mut timeline: Vec<(String, ReplayReport)> = Vec::new();
    let mut hilbert_512: Option<ReplayReport> = None;
    let mut clock_512 = None;
    if part("modes") {
        let mut t = head(&format!(
            "Each mode replays the scene's camera path (scenes/paths/) on a virtual clock charging every traced \
             pixel the ns of the first column (measured from conventional frames of the path's first camera): \
             equal rays/s. Presents and input at 60 Hz of that clock; no refinement (1 sample); dynamic error at \
             every {}th refresh. Real speed: pixel values written per second of dispatch wall time over \
             {SPEED_ROUNDS} rounds that alternate the two modes (two frames or passes each, the camera moving along \
             the path); Mrays/s = that × the rays per pixel of a counted headless frame.",
            args.error_every
        ));
        t += "| scene | size | mode | ns/pixel (clock) | Mpixel updates/s (real) | Mrays/s (real) | presents/s | latency ms: first / 50% / 90% / 100% | age at presents ms: mean / p90 / max | age at refreshes ms: mean / p90 / max | dynamic error RMSE: mean (max) |\n|---|---|---|---|---|---|---|---|---|---|---|\n";
        for c in [&default, &balls] {
            for &size in sizes {
                let scene = sized(&c.scene, &c.path, size);
                let n = size[0] as u64 * size[1] as u64;
                say(format!("{} {}x{}: calibrating", c.name, size[0], size[1]));
                let spp = calibrate(&ctx, &scene, &settings, frames).map_err(anyhow::Error::msg)?;
                let rpp = rays_per_pixel(&ctx, &scene).map_err(anyhow::Error::msg)?;
                let clock = Clock::Virtual { seconds_per_pixel: spp };
                let modes = [Mode::conventional(), Mode::frameless()];
                say(format!("{} {}x{}: speed", c.name, size[0], size[1]));
                let mut runners = modes
                    .iter()
                    .map(|&mode| SpeedRunner::new(&ctx, &scene, &Settings { mode, ..settings.clone() }))
                    .collect::<Result<Vec<_>, _>>()
                    .map_err(anyhow::Error::msg)?;
                interleaved(&ctx, &mut runners, &c.path, 2 * n, SPEED_ROUNDS);
                for (mode, runner) in modes.into_iter().zip(&runners) {
                    say(format!("{} {}x{}: {mode}", c.name, size[0], size[1]));
                    let opts =
                        ReplayOptions { clock, error_every: args.error_every, ..ReplayOptions::default() };
                    let r = replay(&ctx, &scene, &Settings { mode, ..settings.clone() }, &c.path, &opts)
                        .map_err(anyhow::Error::msg)?;
                    let rate = 1.0 / runner.s_per_pixel();
                    let _ = writeln!(
                        t,
                        "| {} | {}x{} | {mode} | {:.0} | {:.3} | {:.2} | {:.1} | {} | {} | {} | {} |",
                        c.name,
                        size[0],
                        size[1],
                        spp * 1e9,
                        rate / 1e6,
                        rate * rpp / 1e6,
                        r.presents.len() as f64 / r.duration,
                        latency(&r),
                        ages(&r.age_at_presents),
                        ages(&r.age_at_refreshes),
                        error(&r)
                    );
                    if c.name == "default" && size == small {
                        clock_512 = Some(clock);
                        if matches!(mode, Mode::Frameless { .. }) {
                            hilbert_512 = Some(r.clone());
                        }
                        timeline.push((mode.to_string(), r));
                    }
                }
            }
        }
        write("modes.md", &t)?;
        let title = "default scene, orbit path: displayed vs ideal image";
        plot_timeline(&timeline, title, &args.out_dir.join("modes-error.svg"))?;
    }

    // ---- Conventional schedules -------------------------------------------------------------
    if part("schedules") {
        let threads = match irt::gpu::device::dealing_threads(&ctx) {
            0 => "a GPU, no thread count of its own".to_string(),
            n => format!("lavapipe runs {n} threads"),
        };
        let mut t = head(&format!(
            "Conventional frame time: the mean of {frames} frames per configuration, the configurations taking \
             turns frame by frame (so a passing load hits all alike), the camera moving along the path; P = the \
             workers the schedule is built for ({threads})."
        ));
        let ps = [2u32, 8, 32];
        t += "| scene | size | schedule | frame ms, P = 2 | P = 8 | P = 32 |\n|---|---|---|---|---|---|\n";
        for c in [&default, &balls] {
            let scene = sized(&c.scene, &c.path, small);
            let n = small[0] as u64 * small[1] as u64;
            say(format!("{}: schedules", c.name));
            let configs: Vec<(Schedule, u32)> =
                Schedule::ALL.iter().flat_map(|&s| ps.iter().map(move |&p| (s, p))).collect();
            let mut runners = configs
                .iter()
                .map(|&(schedule, workers)| {
                    let mode = Mode::Conventional { schedule, workers };
                    SpeedRunner::new(&ctx, &scene, &Settings { mode, ..settings.clone() })
                })
                .collect::<Result<Vec<_>, _>>()
                .map_err(anyhow::Error::msg)?;
            interleaved(&ctx, &mut runners, &c.path, n, frames);
            for (i, schedule) in Schedule::ALL.iter().enumerate() {
                let cells: Vec<String> = runners[i * ps.len()..(i + 1) * ps.len()]
                    .iter()
                    .map(|r| ms(r.s_per_pixel() * n as f64))
                    .collect();
                let _ = writeln!(
                    t,
                    "| {} | {}x{} | {schedule} | {} |",
                    c.name,
                    small[0],
                    small[1],
                    cells.join(" | ")
                );
            }
        }
        write("schedules.md", &t)?;
    }

    // ---- Frameless pixel orders -------------------------------------------------------------
    let scene = sized(&default.scene, &default.path, small);
    let n_small = small[0] as u64 * small[1] as u64;
    if part("orders") {
        let clock = match clock_512 {
            Some(c) => c,
            None => Clock::Virtual {
                seconds_per_pixel: calibrate(&ctx, &scene, &settings, frames).map_err(anyhow::Error::msg)?,
            },
        };
        let mut t = head(&format!(
            "The default scene at {}x{} over scenes/paths/orbit.toml, S = {}, on the virtual clock of the modes \
             table (equal cost per pixel); real speed as in the modes table ({SPEED_ROUNDS} rounds alternating the \
             orders). The last row is the default order with 4×4-pixel chunks instead of RTRT's 2×2 at this size.",
            small[0],
            small[1],
            irt::render::DEFAULT_SLICE
        ));
        t += "| order | Mpixel updates/s (real) | latency ms: first / 50% / 90% / 100% | age at presents ms: mean / p90 / max | dynamic error RMSE: mean (max) |\n|---|---|---|---|---|\n";
        let orders: Vec<PixelOrder> = PixelOrder::ALL
            .into_iter()
            .chain([
                PixelOrder::Hilbert { chunk: 16, procs: 16 },
                PixelOrder::Hilbert { chunk: 4, procs: 16 },
            ])
            .collect();
        say("orders: speed".into());
        let mut runners = orders
            .iter()
            .map(|&o| {
                SpeedRunner::new(
                    &ctx,
                    &scene,
                    &Settings { mode: frameless_with(o, irt::render::DEFAULT_SLICE), ..settings.clone() },
                )
            })
            .collect::<Result<Vec<_>, _>>()
            .map_err(anyhow::Error::msg)?;
        interleaved(&ctx, &mut runners, &default.path, 2 * n_small, SPEED_ROUNDS);
        for (order, runner) in orders.into_iter().zip(&runners) {
            let r = match (&hilbert_512, order == PixelOrder::default()) {
                (Some(r), true) => r.clone(),
                _ => {
                    say(format!("order {order}"));
                    let opts =
                        ReplayOptions { clock, error_every: args.error_every, ..ReplayOptions::default() };
                    let mode = frameless_with(order, irt::render::DEFAULT_SLICE);
                    replay(&ctx, &scene, &Settings { mode, ..settings.clone() }, &default.path, &opts)
                        .map_err(anyhow::Error::msg)?
                }
            };
            let _ = writeln!(
                t,
                "| {order} | {:.3} | {} | {} | {} |",
                1e-6 / runner.s_per_pixel(),
                latency(&r),
                ages(&r.age_at_presents),
                error(&r)
            );
        }
        write("orders.md", &t)?;
    }

    // ---- Slice size -------------------------------------------------------------------------
    if part("slices") {
        let slices: &[u32] = if q { &[256, 1024] } else { &[256, 1024, 4096, 16384, 65536, 262144] };
        let mut t = head(&format!(
            "The default scene at {}x{} over scenes/paths/orbit.toml, Hilbert order, replayed on the real clock \
             (each slice's measured dispatch time, so per-dispatch overhead counts; presents at 60 Hz or after the \
             slice in flight): {SPEED_ROUNDS} rounds alternating the sizes, each row the round with the median 90% \
             latency. Speed: the median of the rounds' pixels per second of dispatch time.",
            small[0], small[1]
        ));
        t += "| S | slices per pass | Mpixel updates/s (real) | pass ms | presents/s | latency ms: first / 50% / 90% / 100% | age at presents ms: mean / p90 / max |\n|---|---|---|---|---|---|---|\n";
        let mut runs: Vec<Vec<ReplayReport>> = vec![Vec::new(); slices.len()];
        for round in 0..SPEED_ROUNDS {
            for (i, &s) in slices.iter().enumerate() {
                say(format!("slice {s}, round {}", round + 1));
                let mode = frameless_with(PixelOrder::default(), s);
                let r = replay(
                    &ctx,
                    &scene,
                    &Settings { mode, ..settings.clone() },
                    &default.path,
                    &ReplayOptions::default(),
                )
                .map_err(anyhow::Error::msg)?;
                runs[i].push(r);
            }
        }
        let mut curve = Vec::new();
        for (&s, mut rs) in slices.iter().zip(runs) {
            let mut rates: Vec<f64> = rs.iter().map(|r| r.pixel_updates_per_s()).collect();
            rates.sort_by(f64::total_cmp);
            let rate = rates[rates.len() / 2];
            rs.sort_by(|a, b| a.latency.mean[2].total_cmp(&b.latency.mean[2]));
            let r = rs.swap_remove(rs.len() / 2);
            let _ = writeln!(
                t,
                "| {s} | {:.0} | {:.3} | {:.0} | {:.1} | {} | {} |",
                (n_small as f64 / s as f64).ceil(),
                rate / 1e6,
                n_small as f64 / rate * 1e3,
                r.presents.len() as f64 / r.duration,
                latency(&r),
                ages(&r.age_at_presents)
            );
            curve.push((s, r));
        }
        write("slices.md", &t)?;
        plot_slices(&curve, &args.out_dir.join("slices.svg"))?;
    }

    // ---- Progressive refinement -------------------------------------------------------------
    if part("refinement") {
        let (size, counts, reference): ([u32; 2], &[u32], u32) =
            if q { ([32, 24], &[1, 2, 4], 16) } else { ([256, 256], &[1, 2, 4, 8, 16, 32, 64], 256) };
        let mut t = head(&format!(
        "The camera at rest on the path's first key, {}x{}: conventional frames with the refinement jitter (R2 \
         sequence), display-space RMSE after n samples per pixel against the same session after {reference} (which \
         contains those n: the error against the limit is larger by about 1/(1 − n/{reference})).",
        size[0], size[1]
    ));
        t += "| samples | default RMSE | balls_s2 RMSE |\n|---|---|---|\n";
        let mut series = Vec::new();
        for c in [&default, &balls] {
            say(format!("refinement {}", c.name));
            let e = refinement_errors(&ctx, &sized(&c.scene, &c.path, size), counts, reference)
                .map_err(anyhow::Error::msg)?;
            series.push((c.name, e));
        }
        for (i, n) in counts.iter().enumerate() {
            let _ = writeln!(t, "| {n} | {:.5} | {:.5} |", series[0].1[i].1, series[1].1[i].1);
        }
        write("refinement.md", &t)?;
        plot_refinement(&series, reference, &args.out_dir.join("refinement.svg"))?;
    }
    bar.finish_and_clear();
    eprintln!(
        "the study took {:.0} s; load average (1, 5, 15 min) {load_start} at its start, {} at its end",
        t_start.elapsed().as_secs_f64(),
        load_average()
    );
    eprintln!("wrote the tables (*.md) and plots (*.svg) into {}", args.out_dir.display());
    Ok(())
}

const COLOURS: [RGBColor; 5] = [BLACK, RED, BLUE, GREEN, MAGENTA];

pub fn plot_timeline(runs: &[(String, ReplayReport)], title: &str, path: &Path) -> Result<(), anyhow::Error> {
    let pts: Vec<Vec<(f64, f64)>> = runs
        .iter()
        .map(|(_, r)| r.refreshes.iter().filter_map(|s| s.error.map(|e| (s.t, e))).collect())
        .collect();
    let top = pts.iter().flatten().map(|p| p.1).fold(1e-3, f64::max) * 1.1;
    let end = runs.iter().map(|(_, r)| r.duration).fold(0.0, f64::max);
    let axes = ("clock time (s)", "dynamic error: RMSE of the displayed image (display space)");
    irt::lab::plot::linear_svg(path, title, (0.0..end, 0.0..top), axes, |chart| {
        for (i, ((name, _), p)) in runs.iter().zip(&pts).enumerate() {
            let c = COLOURS[i % COLOURS.len()];
            chart
                .draw_series(LineSeries::new(p.iter().copied(), c.stroke_width(2)))
                .map_err(|e| e.to_string())?
                .label(name.clone())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2)));
        }
        chart.configure_series_labels().background_style(WHITE).border_style(BLACK).draw()?;
        Ok(())
    })
    .map_err(anyhow::Error::from)
}

fn plot_slices(curve: &[(u32, ReplayReport)], path: &Path) -> Result<(), anyhow::Error> {
    let lines: Vec<(&str, Vec<(f64, f64)>)> = vec![
        (
            "latency to the first pixel",
            curve.iter().map(|(s, r)| (*s as f64, r.latency.mean[0] * 1e3)).collect(),
        ),
        ("latency to 90%", curve.iter().map(|(s, r)| (*s as f64, r.latency.mean[2] * 1e3)).collect()),
        (
            "mean pixel age at presents",
            curve.iter().map(|(s, r)| (*s as f64, r.age_at_presents.mean * 1e3)).collect(),
        ),
    ];
    let ys: Vec<f64> = lines.iter().flat_map(|l| l.1.iter().map(|p| p.1)).collect();
    let (lo, hi) = (ys.iter().copied().fold(f64::INFINITY, f64::min), ys.iter().copied().fold(0.0, f64::max));
    let xs = (curve[0].0 as f64 / 1.5)..(curve[curve.len() - 1].0 as f64 * 1.5);
    let axes = ("slice size S (positions, log)", "ms (log; real clock)");
    irt::lab::plot::log_log_svg(
        path,
        "frameless slice size: latency and age",
        (xs, (lo / 1.5)..(hi * 1.5)),
        axes,
        |chart| {
            for (i, (name, p)) in lines.iter().enumerate() {
                let c = COLOURS[i % COLOURS.len()];
                chart
                    .draw_series(LineSeries::new(p.iter().copied(), c.stroke_width(2)))
                    .map_err(|e| e.to_string())?
                    .label(*name)
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2)));
                chart
                    .draw_series(p.iter().map(|&q| Circle::new(q, 4, c.filled())))
                    .map_err(|e| e.to_string())?;
            }
            chart.configure_series_labels().background_style(WHITE).border_style(BLACK).draw()?;
            Ok(())
        },
    )
    .map_err(anyhow::Error::from)
}

fn plot_refinement(
    series: &[(&str, Vec<(u32, f64)>)],
    reference: u32,
    path: &Path,
) -> Result<(), anyhow::Error> {
    let ys: Vec<f64> = series.iter().flat_map(|s| s.1.iter().map(|p| p.1.max(1e-6))).collect();
    let (lo, hi) = (ys.iter().copied().fold(f64::INFINITY, f64::min), ys.iter().copied().fold(0.0, f64::max));
    let n_max = series.iter().flat_map(|s| s.1.iter().map(|p| p.0)).max().unwrap_or(1) as f64;
    let axes = ("samples per pixel (log)", "RMSE vs the reference (display space, log)");
    let title = format!("progressive refinement: error against {reference} samples");
    irt::lab::plot::log_log_svg(path, &title, (0.7..n_max * 1.4, (lo / 1.5)..(hi * 1.5)), axes, |chart| {
        for (i, (name, p)) in series.iter().enumerate() {
            let c = COLOURS[i % COLOURS.len()];
            let p: Vec<(f64, f64)> = p.iter().map(|&(n, e)| (n as f64, e.max(1e-6))).collect();
            chart
                .draw_series(LineSeries::new(p.iter().copied(), c.stroke_width(2)))
                .map_err(|e| e.to_string())?
                .label(*name)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2)));
            chart.draw_series(p.iter().map(|&q| Circle::new(q, 4, c.filled()))).map_err(|e| e.to_string())?;
        }
        chart.configure_series_labels().background_style(WHITE).border_style(BLACK).draw()?;
        Ok(())
    })
    .map_err(anyhow::Error::from)
}

#[cfg(test)]
mod tests {
    #[derive(clap::Parser)]
    struct StudyCli {
        #[command(flatten)]
        args: super::StudyArgs,
    }

    #[test]
    fn study_arguments_parse() {
        use clap::{CommandFactory, Parser};
        StudyCli::command().debug_assert();
        let a = StudyCli::try_parse_from(["study", "--only", "slices", "--only", "modes", "--quick"])
            .unwrap()
            .args;
        assert_eq!(a.only, ["slices", "modes"]);
        assert!(StudyCli::try_parse_from(["study", "--only", "everything"]).is_err());
    }
}
