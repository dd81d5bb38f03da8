//! `irt replay PATH.toml [SCENE]`: a [`Source`] — a [`Session`], or the MPI master of
//! `--mpi` (src/dist/replay.rs) — run over a scripted camera path on a [`Clock`],
//! measured the way frameless rendering was judged (../PAPER §3; docs/interactive.md): pixel
//! age and input-to-screen latency at every present, and optionally the *dynamic error*
//! (Woolley et al. 2003, Dayal et al. 2005) — the RMS error of the displayed image against the
//! ideal image of the camera of that instant. "Ideal" here is irt's own single-sample render of
//! that camera (a fresh conventional frame of a second session with the same settings), so a
//! mode that keeps up shows zero error and the measure isolates what the interactive loop costs.
//!
//! # The loop: the window's host loop ([`super::host_loop`]) on clock time
//! - **Warm start**: one whole frame or pass of the path's first camera, on screen at t = 0
//!   (this also compiles the pipelines, so no mode pays for that).
//! - **Frameless**: each step takes the camera of the current time and traces one slice; the
//!   display presents after the step in which a refresh (1/`display_hz`) fell due.
//! - **Conventional**: a frame takes the camera of the time it starts (input is read between
//!   frames, as RTRT's master did) and is presented when its last wave is done; the display keeps
//!   showing the last presented frame at every refresh in between.
//! - **Inputs** are read at the display rate: one latency event per refresh instant t0 at which
//!   the path's camera differs from the previous refresh's. A pixel reflects the input when it
//!   was traced with a camera taken at t0 or later (see [`super::metrics`]).
//! - After the path's end the camera rests on its last key until every input has reached 100%
//!   of the screen.
//! - A step with nothing to do (refinement converged at rest) waits for the next refresh.

pub use super::camera_path::{CameraKey, CameraPath, MAX_PATH_FILE_BYTES};
use super::host_loop::{Cancel, HostLoop};
use super::metrics::{AgeStats, AgeTracker, Clock, LatencyStats, LatencyTracker, LATENCY_LEVELS};
use super::{Mode, Session, Settings, StepReport};
use crate::gpu::device::Device;
use crate::image::Image;
use crate::scene::{Camera, Scene};
use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Duration;

/// What a replay can fail with.
#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    #[error(transparent)]
    Render(#[from] crate::render::RenderError),
    #[error(transparent)]
    Gpu(#[from] crate::gpu::GpuError),
    #[error("the display rate must be a number of Hz > 0, not {0}")]
    DisplayRate(f64),
    #[error("the replay did not settle within {0:.0} s of clock time")]
    Unsettled(f64),
    #[error("{0}: {1}")]
    Io(String, std::io::Error),
    /// The MPI job failed (src/dist/replay.rs: the master ends the job with it).
    #[error("{0}")]
    Distributed(String),
}

/// A device path's error as a replay's.
fn gpu_err<E: Into<crate::gpu::GpuError>>(e: E) -> ReplayError {
    ReplayError::Gpu(e.into())
}

/// The display rate of a replay unless told: presents and input at 60 Hz of clock time.
pub const DEFAULT_DISPLAY_HZ: f64 = 60.0;

// ---- The replay ----------------------------------------------------------------------------

/// How a replay runs and what it records.
#[derive(Clone, Debug, PartialEq)]
pub struct ReplayOptions {
    pub clock: Clock,
    /// Display refreshes (and input reads) per second of clock time.
    pub display_hz: f64,
    /// Measure the dynamic error at every `error_every`-th refresh (0: never; each costs a whole
    /// single-sample render of that instant's camera).
    pub error_every: u32,
    /// Write every present as `DIR/frame_0000.png`, … (atomically).
    pub frames_dir: Option<PathBuf>,
    /// A progress bar on stderr.
    pub progress: bool,
}

impl Default for ReplayOptions {
    fn default() -> Self {
        ReplayOptions {
            clock: Clock::Real,
            display_hz: DEFAULT_DISPLAY_HZ,
            error_every: 0,
            frames_dir: None,
            progress: false,
        }
    }
}

/// The screen at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Clock time, seconds.
    pub t: f64,
    pub age: AgeStats,
    /// Dynamic error (display-space RMSE against the ideal image of the camera at `t`), where
    /// measured.
    pub error: Option<f64>,
}

#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ErrorStats {
    pub mean: f64,
    pub max: f64,
    pub samples: usize,
}

/// Wall-clock measurements of a replay: the device's real speed whatever the clock, and not
/// repeatable.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WallTimes {
    /// All dispatches together.
    pub trace: Duration,
    /// The median over work units (frameless slices, conventional frames) of wall time per
    /// pixel: steadier than the total on a loaded machine, where another process stalls a
    /// dispatch now and then, but biased toward short units (a stall lands in few of many short
    /// slices and the median skips them, while every long frame takes its share), so modes are
    /// compared by the total.
    pub median_s_per_pixel: f64,
}

/// What a replay measured. Everything but `wall` is a function of the clock's times, so on a
/// virtual clock two runs give equal reports.
#[derive(Clone, Debug, PartialEq)]
pub struct ReplayReport {
    pub clock: Clock,
    pub size: [u32; 2],
    /// The path's duration; the means below are over presents and refreshes up to it.
    pub duration: f64,
    /// Each new picture: frameless, the presents at the display rate; conventional, each
    /// finished frame (the age of a frame at its present is its trace time).
    pub presents: Vec<Sample>,
    /// The display's refreshes up to `duration`: frameless, the presents; conventional, every
    /// refresh instant, showing the last presented frame (what a viewer sees).
    pub refreshes: Vec<Sample>,
    pub latency: LatencyStats,
    pub age_at_presents: AgeStats,
    pub age_at_refreshes: AgeStats,
    pub dynamic_error: Option<ErrorStats>,
    pub steps: u64,
    /// Conventional frames or frameless passes completed.
    pub frames: u64,
    /// Pixel values written (frameless positions that name pixels; conventional whole frames).
    pub pixels: u64,
    pub eye_rays: u64,
    /// Clock time at the end (the path plus the rest until every input reached the screen).
    pub clock_time: f64,
    pub wall: WallTimes,
}

impl ReplayReport {
    /// Pixel values written per second of all the dispatches' wall time.
    pub fn pixel_updates_per_s(&self) -> f64 {
        self.pixels as f64 / self.wall.trace.as_secs_f64().max(1e-12)
    }

    /// Pixel values written per second of dispatch wall time, from the median work unit (see
    /// [`WallTimes::median_s_per_pixel`]).
    pub fn median_pixel_updates_per_s(&self) -> f64 {
        1.0 / self.wall.median_s_per_pixel.max(1e-15)
    }

    /// The report without its wall times: what two runs on a virtual clock agree on.
    pub fn without_wall_times(&self) -> ReplayReport {
        ReplayReport { wall: WallTimes::default(), ..self.clone() }
    }
}

/// The ideal images: a second session (same scene upload, same settings, conventional, one
/// sample), rendering whole frames of any camera, and of the scene at any time.
struct Ideal<D: Device> {
    session: Session<D>,
    last: Option<(Camera, f64, Image)>,
}

impl<D: Device> Ideal<D> {
    fn new(ctx: &D, scene: &Scene, settings: &Settings) -> Result<Self, ReplayError> {
        let settings = Settings { mode: Mode::conventional(), max_samples: 1, ..settings.clone() };
        Ok(Ideal { session: Session::new(ctx, scene, settings)?, last: None })
    }

    fn image(&mut self, ctx: &D, camera: &Camera, t: f64) -> Result<&Image, ReplayError> {
        if self.last.as_ref().is_none_or(|(c, at, _)| c != camera || *at != t) {
            self.session.set_camera(ctx, camera);
            self.session.set_time(ctx, t)?;
            self.session.try_complete_pass(ctx).map_err(gpu_err)?;
            self.last = Some((camera.clone(), t, self.session.try_read_image(ctx).map_err(gpu_err)?));
        }
        Ok(&self.last.as_ref().expect("just rendered").2)
    }
}

// ---- What a replay drives ------------------------------------------------------------------

/// Pixels that reached the screen in a step, and the clock time of the camera they were traced
/// with.
#[derive(Clone, Debug, PartialEq)]
pub enum Landed {
    /// Frameless: `positions` of the pixel order (a pass is [`Source::pass_len`] of them).
    Slice { t: f64, positions: u64 },
    /// Frameless in an order that is not a fixed permutation (adaptive): the pixels.
    Pixels { t: f64, pixels: Vec<u32> },
    /// Conventional: a whole frame.
    Frame { t: f64 },
}

/// What a replay runs: one [`Session`] on a device ([`LocalSource`]), or the master of MPI ranks
/// (src/dist/replay.rs). The replay's loop, clock and measures are the same for both.
pub trait Source {
    /// Positions of a frameless pass, or the pixels of a conventional frame.
    fn pass_len(&self) -> u64;
    /// Slices land as [`Landed::Pixels`] (the order is not a fixed permutation).
    fn per_pixel(&self) -> bool {
        false
    }
    /// The whole picture of the first camera, on screen at t = 0.
    fn warm_start(&mut self) -> Result<(), ReplayError>;
    /// Takes `camera` and the objects of time `time` (None: a still scene), read at clock time
    /// `t`; returns the host time spent moving objects.
    fn take_state(&mut self, camera: &Camera, time: Option<f64>, t: f64) -> Result<Duration, ReplayError>;
    /// One step of work; what reached the screen in it goes into `landed`.
    fn step(&mut self, landed: &mut Vec<Landed>) -> Result<StepReport, ReplayError>;
    /// The picture on screen.
    fn image(&mut self) -> Result<Image, ReplayError>;
    /// The ideal image of `camera` and the scene at time `t` (for the dynamic error).
    fn ideal(&mut self, camera: &Camera, t: f64) -> Result<Image, ReplayError>;
    /// The device that traces, in words.
    fn device(&self) -> String;
}

/// A replay on one [`Session`] on `ctx`.
pub struct LocalSource<'a, D: Device> {
    ctx: &'a D,
    session: Session<D>,
    ideal: Option<Ideal<D>>,
    conventional: bool,
    /// Clock time of the camera the session holds.
    t_state: f64,
}

impl<'a, D: Device> LocalSource<'a, D> {
    /// `scene` (with its first camera) on `ctx`; an ideal session too when errors are measured.
    pub fn new(ctx: &'a D, scene: &Scene, settings: &Settings, ideal: bool) -> Result<Self, ReplayError> {
        // Both sessions upload positions relative to the first camera's eye, so a frame of the
        // same camera is the same bit for bit in each.
        let session = Session::new(ctx, scene, settings.clone())?;
        let ideal = if ideal { Some(Ideal::new(ctx, scene, settings)?) } else { None };
        let conventional = matches!(settings.mode, Mode::Conventional { .. });
        Ok(LocalSource { ctx, session, ideal, conventional, t_state: 0.0 })
    }
}

impl<D: Device> Source for LocalSource<'_, D> {
    fn pass_len(&self) -> u64 {
        if self.conventional {
            let [w, h] = self.session.size();
            w as u64 * h as u64
        } else {
            self.session.pass_len()
        }
    }

    fn per_pixel(&self) -> bool {
        self.session.last_slice_pixels().is_some()
    }

    fn warm_start(&mut self) -> Result<(), ReplayError> {
        self.session.try_complete_pass(self.ctx).map_err(gpu_err)?;
        Ok(())
    }

    fn take_state(&mut self, camera: &Camera, time: Option<f64>, t: f64) -> Result<Duration, ReplayError> {
        self.t_state = t;
        self.session.set_camera(self.ctx, camera);
        match time {
            Some(time) => Ok(self.session.set_time(self.ctx, time)?.total()),
            None => Ok(Duration::ZERO),
        }
    }

    fn step(&mut self, landed: &mut Vec<Landed>) -> Result<StepReport, ReplayError> {
        let step = self.session.try_step(self.ctx).map_err(gpu_err)?;
        if step.idle {
            return Ok(step);
        }
        if self.conventional {
            if step.frame_done {
                landed.push(Landed::Frame { t: self.t_state });
            }
        } else {
            let slice = step.slice.expect("frameless steps report their slice");
            landed.push(match self.session.last_slice_pixels() {
                Some(pixels) => Landed::Pixels { t: self.t_state, pixels: pixels.to_vec() },
                None => Landed::Slice { t: self.t_state, positions: slice.len },
            });
        }
        Ok(step)
    }

    fn image(&mut self) -> Result<Image, ReplayError> {
        self.session.try_read_shown(self.ctx).map_err(gpu_err)
    }

    fn ideal(&mut self, camera: &Camera, t: f64) -> Result<Image, ReplayError> {
        let ideal = self.ideal.as_mut().expect("error_every > 0 made the ideal session");
        Ok(ideal.image(self.ctx, camera, t)?.clone())
    }

    fn device(&self) -> String {
        format!("{} ({})", self.ctx.adapter_name(), self.ctx.adapter_driver())
    }
}

struct Replayer<'a, S: Source> {
    source: &'a mut S,
    path: &'a CameraPath,
    opts: &'a ReplayOptions,
    size: [u32; 2],
    /// The scene's motions end here (0: a still scene).
    motion_end: f64,
    screen: AgeTracker,
    latency: LatencyTracker,
    end: f64,
    period: f64,
    /// The next input instant to read (index k: time k · period).
    next_input: u64,
    refresh_count: u64,
    presents: Vec<Sample>,
    refreshes: Vec<Sample>,
    /// Conventional: the presented frame (kept only to measure the error between presents).
    held: Option<Image>,
    frames_written: u64,
}

impl<S: Source> Replayer<'_, S> {
    fn camera(&self, t: f64) -> Camera {
        self.path.camera_at(t, self.size[0], self.size[1])
    }

    /// Reads the inputs up to `t`: one event per refresh instant at which the camera changed.
    fn read_inputs(&mut self, t: f64) {
        loop {
            // k / rate rather than k · period: the instants land exactly on key times.
            let at = |k: u64| k as f64 / self.opts.display_hz;
            let t0 = at(self.next_input);
            if t0 > t || t0 > self.end {
                return;
            }
            // While objects move, every refresh instant is an input (the scene changed).
            let moving = t0 > 0.0 && t0 <= self.motion_end;
            if self.next_input > 0 && (moving || self.camera(t0) != self.camera(at(self.next_input - 1))) {
                self.latency.input(t0);
            }
            self.next_input += 1;
        }
    }

    /// Every input up to the path's end has been read and has reached the whole screen.
    fn settled(&self) -> bool {
        self.next_input as f64 / self.opts.display_hz > self.end && self.latency.pending() == 0
    }

    /// Whether the refresh being counted now measures the dynamic error.
    fn error_due(&mut self, t: f64) -> bool {
        let k = self.refresh_count;
        self.refresh_count += 1;
        t <= self.end && self.opts.error_every > 0 && k.is_multiple_of(self.opts.error_every as u64)
    }

    fn error_of(&mut self, shown: &Image, t: f64) -> Result<f64, ReplayError> {
        let camera = self.camera(t);
        Ok(crate::metrics::rmse(shown, &self.source.ideal(&camera, t)?))
    }

    /// Takes the camera and (in an animated scene) the objects of time `t`; returns the host
    /// time spent moving them.
    fn take_state(&mut self, t: f64) -> Result<Duration, ReplayError> {
        let c = self.camera(t);
        let time = (self.motion_end > 0.0).then_some(t);
        self.source.take_state(&c, time, t)
    }

    /// What reached the screen in a step.
    fn record(&mut self, landed: &[Landed]) {
        for l in landed {
            match *l {
                Landed::Slice { t, positions } => self.screen.record_slice(t, positions),
                Landed::Pixels { t, ref pixels } => self.screen.record_pixels(t, pixels),
                Landed::Frame { t } => self.screen.record_frame(t),
            }
        }
    }

    /// A new picture at `t`.
    fn present(&mut self, t: f64) -> Result<(), ReplayError> {
        self.read_inputs(t);
        self.latency.present(t, &self.screen);
        let age = self.screen.stats(t);
        if t <= self.end {
            self.presents.push(Sample { t, age, error: None });
        }
        if let Some(dir) = &self.opts.frames_dir {
            let file = dir.join(format!("frame_{:04}.png", self.frames_written));
            self.source
                .image()?
                .save_png(&file)
                .map_err(|e| ReplayError::Io(format!("writing {}", file.display()), e))?;
            self.frames_written += 1;
        }
        Ok(())
    }

    /// Frameless: a present is a refresh.
    fn present_frameless(&mut self, t: f64) -> Result<(), ReplayError> {
        self.present(t)?;
        if t <= self.end {
            let error = if self.error_due(t) {
                let shown = self.source.image()?;
                Some(self.error_of(&shown, t)?)
            } else {
                None
            };
            self.refreshes.push(Sample { t, age: self.screen.stats(t), error });
        }
        Ok(())
    }

    /// Conventional: a refresh at `t` shows the frame presented last.
    fn refresh_conventional(&mut self, t: f64) -> Result<(), ReplayError> {
        self.read_inputs(t);
        if t > self.end {
            return Ok(());
        }
        let error = if self.error_due(t) {
            let shown = self.held.take().expect("the presented frame is kept while errors are measured");
            let e = self.error_of(&shown, t);
            self.held = Some(shown);
            Some(e?)
        } else {
            None
        };
        self.refreshes.push(Sample { t, age: self.screen.stats(t), error });
        Ok(())
    }
}

/// Runs `settings`' mode over `path` on `scene` (its camera's width and height; the rest of its
/// camera is the path's) and measures it; see the module documentation.
pub fn replay<D: Device>(
    ctx: &D,
    scene: &Scene,
    settings: &Settings,
    path: &CameraPath,
    opts: &ReplayOptions,
) -> Result<ReplayReport, ReplayError> {
    check_options(opts)?;
    let scene = first_camera(scene, path);
    let mut source = LocalSource::new(ctx, &scene, settings, opts.error_every > 0)?;
    replay_on(&mut source, &scene, &settings.mode, path, opts)
}

/// The display rate is a rate.
pub fn check_options(opts: &ReplayOptions) -> Result<(), ReplayError> {
    if !(opts.display_hz.is_finite() && opts.display_hz > 0.0) {
        return Err(ReplayError::DisplayRate(opts.display_hz));
    }
    Ok(())
}

/// `scene` with the path's first camera (its own width and height).
pub fn first_camera(scene: &Scene, path: &CameraPath) -> Scene {
    let mut scene = scene.clone();
    scene.camera = path.camera_at(0.0, scene.camera.width, scene.camera.height);
    scene
}

/// The replay's loop on `source`, which holds `scene` (posed at the path's first camera) in
/// `mode`; see the module documentation.
pub fn replay_on<S: Source>(
    source: &mut S,
    scene: &Scene,
    mode: &Mode,
    path: &CameraPath,
    opts: &ReplayOptions,
) -> Result<ReplayReport, ReplayError> {
    check_options(opts)?;
    let size = [scene.camera.width, scene.camera.height];
    if let Some(dir) = &opts.frames_dir {
        std::fs::create_dir_all(dir)
            .map_err(|e| ReplayError::Io(format!("creating {}", dir.display()), e))?;
    }
    let conventional = matches!(mode, Mode::Conventional { .. });
    let mut r = Replayer {
        screen: if source.per_pixel() {
            AgeTracker::per_pixel(source.pass_len(), 0.0)
        } else {
            AgeTracker::new(source.pass_len(), 0.0)
        },
        source,
        path,
        opts,
        size,
        motion_end: scene.duration(),
        latency: LatencyTracker::default(),
        // An animated scene plays to its end even if the camera rests sooner.
        end: path.duration().max(scene.duration()),
        period: 1.0 / opts.display_hz,
        next_input: 0,
        refresh_count: 0,
        presents: Vec::new(),
        refreshes: Vec::new(),
        held: None,
        frames_written: 0,
    };
    // Warm start: the first camera's picture is on screen at t = 0.
    r.source.warm_start()?;
    if opts.error_every > 0 && conventional {
        r.held = Some(r.source.image()?);
    }
    let bar = if opts.progress {
        let bar = indicatif::ProgressBar::new((r.end * 1000.0).ceil() as u64);
        bar.set_style(
            indicatif::ProgressStyle::with_template(
                "{spinner} replaying {pos}/{len} ms of clock time [{bar:30}] {elapsed_precise}",
            )
            .expect("valid template")
            .progress_chars("=> "),
        );
        bar
    } else {
        indicatif::ProgressBar::hidden()
    };
    let limit = r.end * 20.0 + 120.0;
    // The window's policy on clock time; frames take the camera of the time they start.
    let mut host = HostLoop::new(r.period, 0, Cancel::Never);
    let mut now = 0.0f64;
    let (mut steps, mut frames, mut pixels_done, mut eye_rays) = (0u64, 0u64, 0u64, 0u64);
    let mut trace_wall = Duration::ZERO;
    // (pixels, wall time) of each slice or frame, and the waves of the frame in flight.
    let mut units: Vec<(u64, Duration)> = Vec::new();
    let mut frame_wall = Duration::ZERO;
    let mut landed = Vec::new();
    loop {
        if now > limit {
            return Err(ReplayError::Unsettled(limit));
        }
        let mut update = Duration::ZERO;
        if host.take_input(conventional, true) {
            update = r.take_state(now)?;
        }
        landed.clear();
        let step = r.source.step(&mut landed)?;
        if step.idle {
            // Converged at rest: nothing to trace until the next refresh.
            host.stepped(now, conventional, &step);
            if r.settled() {
                break;
            }
            now = now.max(host.next_refresh());
            if conventional {
                r.refresh_conventional(now)?;
            } else {
                r.present_frameless(now)?;
            }
            host.presented(now);
            continue;
        }
        steps += 1;
        // A real clock also pays for moving the objects (the host's work before the step).
        now += opts.clock.cost(&step) + if opts.clock == Clock::Real { update.as_secs_f64() } else { 0.0 };
        trace_wall += step.trace_time;
        frame_wall += step.trace_time;
        if !conventional || step.frame_done {
            units.push((step.pixels, std::mem::take(&mut frame_wall)));
        }
        pixels_done += step.pixels;
        eye_rays += step.eye_rays;
        frames += step.frame_done as u64;
        bar.set_position((now.min(r.end) * 1000.0) as u64);
        let present = host.stepped(now, conventional, &step);
        if conventional {
            // Refreshes while this wave ran showed the frame presented before.
            while host.next_refresh() < now {
                r.refresh_conventional(host.next_refresh())?;
                host.refreshed();
            }
            r.record(&landed);
            if present {
                r.present(now)?;
                if opts.error_every > 0 {
                    r.held = Some(r.source.image()?);
                }
            }
        } else {
            r.record(&landed);
            if present {
                r.present_frameless(now)?;
                host.presented(now);
            }
        }
        if !host.in_frame() && r.settled() {
            break;
        }
    }
    bar.finish_and_clear();
    let errors: Vec<f64> = r.refreshes.iter().filter_map(|s| s.error).collect();
    let dynamic_error = (!errors.is_empty()).then(|| ErrorStats {
        mean: errors.iter().sum::<f64>() / errors.len() as f64,
        max: errors.iter().copied().fold(0.0, f64::max),
        samples: errors.len(),
    });
    let ages = |s: &[Sample]| AgeStats::summarise(&s.iter().map(|s| s.age).collect::<Vec<_>>());
    Ok(ReplayReport {
        clock: opts.clock,
        size,
        duration: r.end,
        age_at_presents: ages(&r.presents),
        age_at_refreshes: ages(&r.refreshes),
        latency: r.latency.stats(),
        presents: r.presents,
        refreshes: r.refreshes,
        dynamic_error,
        steps,
        frames,
        pixels: pixels_done,
        eye_rays,
        clock_time: now,
        wall: WallTimes { trace: trace_wall, median_s_per_pixel: median_per_pixel(&units) },
    })
}

/// The median of the units' seconds per pixel (units without pixels left out).
fn median_per_pixel(units: &[(u64, Duration)]) -> f64 {
    let mut v: Vec<f64> =
        units.iter().filter(|u| u.0 > 0).map(|(n, t)| t.as_secs_f64() / *n as f64).collect();
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(0.0)
}

/// Seconds per pixel of `settings`' shadows and depth on `scene` as a conventional frame (the
/// default schedule) takes them on `ctx`: the median of `frames` frames after one untimed one.
/// What a virtual clock charges to compare modes at the device's real rate.
pub fn calibrate<D: Device>(
    ctx: &D,
    scene: &Scene,
    settings: &Settings,
    frames: u32,
) -> Result<f64, ReplayError> {
    let settings = Settings { mode: Mode::conventional(), max_samples: 0, ..settings.clone() };
    let mut s = Session::new(ctx, scene, settings)?;
    s.try_complete_pass(ctx).map_err(gpu_err)?;
    let mut times: Vec<Duration> =
        (0..frames.max(1)).map(|_| s.try_complete_pass(ctx)).collect::<Result<_, _>>().map_err(gpu_err)?;
    times.sort();
    let [w, h] = s.size();
    Ok(times[times.len() / 2].as_secs_f64() / (w as f64 * h as f64))
}

// ---- What `irt replay` prints --------------------------------------------------------------

fn ms(s: f64) -> String {
    format!("{:.1} ms", s * 1e3)
}

/// What `irt replay` prints.
/// `device`: what traced, in words ([`Source::device`]).
pub fn summary(r: &ReplayReport, mode: &Mode, what: &str, device: &str) -> String {
    let mut out = String::new();
    let [w, h] = r.size;
    let _ = writeln!(out, "replay     {what}, {w}x{h}, {mode}");
    let _ = writeln!(out, "device     {device}");
    let clock = match r.clock {
        Clock::Real => "real (measured dispatch time)".to_string(),
        Clock::Virtual { seconds_per_pixel } => {
            format!("virtual, {:.1} ns per traced pixel", seconds_per_pixel * 1e9)
        }
    };
    let _ = writeln!(out, "clock      {clock}; path {:.2} s, run to {:.2} s", r.duration, r.clock_time);
    let _ = writeln!(
        out,
        "work       {} steps, {} frames/passes, {} presents, {} refreshes",
        r.steps,
        r.frames,
        r.presents.len(),
        r.refreshes.len()
    );
    let _ = writeln!(
        out,
        "speed      {:.3} M pixel updates/s over {:.2} s of dispatches (real; {:.3} in the median slice or frame)",
        r.pixel_updates_per_s() / 1e6,
        r.wall.trace.as_secs_f64(),
        r.median_pixel_updates_per_s() / 1e6
    );
    let l = &r.latency;
    let levels: Vec<String> =
        (0..4).map(|i| format!("{} {} / {}", LATENCY_LEVELS[i], ms(l.mean[i]), ms(l.max[i]))).collect();
    let _ = writeln!(out, "latency    (mean / max of {} inputs) {}", l.inputs, levels.join(", "));
    for (name, a) in [("at presents", &r.age_at_presents), ("at refreshes", &r.age_at_refreshes)] {
        let _ = writeln!(out, "pixel age  {name}: mean {}, p90 {}, max {}", ms(a.mean), ms(a.p90), ms(a.max));
    }
    if let Some(e) = &r.dynamic_error {
        let _ = writeln!(
            out,
            "dyn. error RMSE (display space) mean {:.4}, max {:.4} over {} refreshes",
            e.mean, e.max, e.samples
        );
    }
    out
}

/// Every present and refresh as CSV: `kind,t,age_mean,age_p90,age_max,error`.
pub fn samples_csv(r: &ReplayReport) -> String {
    let mut out = String::from("kind,t,age_mean,age_p90,age_max,error\n");
    for (kind, list) in [("present", &r.presents), ("refresh", &r.refreshes)] {
        for s in list {
            let e = s.error.map_or(String::new(), |e| format!("{e:.6}"));
            let _ =
                writeln!(out, "{kind},{:.6},{:.6},{:.6},{:.6},{e}", s.t, s.age.mean, s.age.p90, s.age.max);
        }
    }
    out
}
