//! `irt replay PATH.toml [SCENE]`: a camera path replayed on a clock and measured
//! ([`irt::render::replay`]: latency, pixel age, dynamic error).

use super::args::{load_scene, BackendArgs, DeviceArgs, ModeArgs, SceneArgs};
use super::{open_device, open_vk_device};
use anyhow::{anyhow, Result};
use clap::Args;
use irt::dist::master::Master;
use irt::dist::replay::MasterSource;
use irt::gpu::device::{Backend, Device};
use irt::render::metrics::Clock;
use irt::render::replay::{
    calibrate, first_camera, replay, replay_on, samples_csv, summary, CameraPath, ReplayOptions, Source,
    DEFAULT_DISPLAY_HZ,
};
use irt::render::Settings;
use irt::scene::Scene;
use std::path::PathBuf;
use std::str::FromStr;
use std::time::Instant;

/// `--clock`: `real`, `virtual` (calibrated: ns per pixel of a conventional frame measured
/// first) or `virtual:NS`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ClockArg {
    Calibrated,
    Given(Clock),
}

impl FromStr for ClockArg {
    type Err = anyhow::Error;
    fn from_str(s: &str) -> Result<Self> {
        if s == "virtual" {
            Ok(ClockArg::Calibrated)
        } else {
            s.parse().map(ClockArg::Given).map_err(|e| anyhow!("{e}, or virtual (calibrated)"))
        }
    }
}

#[derive(Args, Clone, Debug)]
pub struct ReplayArgs {
    /// Camera path: a TOML file of [[key]] tables (t, eye, look_at, optional up and fov, as in a
    /// scene's [camera]); see scenes/paths/orbit.toml.
    pub path: PathBuf,
    /// Clock: real (measured dispatch time), virtual (a fixed cost per traced pixel, calibrated
    /// from a conventional frame first: modes compare at equal rays/s, and runs repeat exactly)
    /// or virtual:NS (NS nanoseconds per pixel).
    #[arg(long, default_value = "virtual", value_name = "CLOCK")]
    pub clock: ClockArg,
    /// Display refreshes and input reads per second of clock time.
    #[arg(long, default_value_t = DEFAULT_DISPLAY_HZ, value_name = "HZ")]
    pub rate: f64,
    /// Refinement stops after this many samples per pixel (1: none, so a picture that keeps up
    /// with the camera has zero dynamic error).
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub max_samples: u32,
    /// Measure the dynamic error at every K-th refresh (0: not at all; each costs a whole frame).
    #[arg(long, default_value_t = 0, value_name = "K")]
    pub error_every: u32,
    /// Write every present as DIR/frame_0000.png, …
    #[arg(long, value_name = "DIR")]
    pub frames: Option<PathBuf>,
    /// Write every present and refresh (time, ages, error) as CSV.
    #[arg(long, value_name = "FILE")]
    pub csv: Option<PathBuf>,
    #[command(flatten)]
    pub scene: SceneArgs,
    /// The dispatch mode (frameless unless --mode says otherwise) and its parameters, as
    /// `irt render` and `irt view` spell them.
    #[command(flatten)]
    pub mode: ModeArgs,
    #[command(flatten)]
    pub backend: BackendArgs,
    #[command(flatten)]
    pub device: DeviceArgs,
    /// With --mpi the clock is the wall time of rank 0's turns (the round trip to the workers is
    /// part of what is measured), and --error-every is refused (rank 0 has no device).
    #[command(flatten)]
    pub mpi: super::mpi::MpiArgs,
}

impl ReplayArgs {
    /// The settings the arguments describe.
    pub fn settings(&self) -> Result<Settings> {
        Ok(Settings {
            mode: self.mode.mode_or_frameless()?,
            max_samples: self.max_samples,
            f64: self.scene.f64(),
            accel: self.scene.accel,
            ..Settings::default()
        })
    }
}

/// Runs `irt replay`: loads the path and scene, replays, prints what was measured.
pub fn run(args: ReplayArgs) -> Result<()> {
    if args.mpi.mpi {
        // Under mpirun every rank runs this command: the workers trace until rank 0 ends the job.
        let Some(cluster) = super::mpi::join(args.backend.backend, &args.device)? else { return Ok(()) };
        let result = distributed(&cluster, &args);
        if let Err(e) = &result {
            // The workers wait for rank 0: an error here must end them too.
            cluster.abort(&format!("error: {e:#}"));
        }
        return result;
    }
    let path = CameraPath::load(&args.path)?;
    let scene = load_scene(&args.scene)?;
    let settings = args.settings()?;
    match args.backend.backend {
        Backend::Wgpu => run_on(&open_device(&args.device)?, &args, &path, &scene, &settings),
        Backend::Ash => {
            run_on(&open_vk_device(&args.device, Default::default())?, &args, &path, &scene, &settings)
        }
    }
}

/// `irt replay` on `ctx`'s device path.
fn run_on<D: Device>(
    ctx: &D,
    args: &ReplayArgs,
    path: &CameraPath,
    scene: &Scene,
    settings: &Settings,
) -> Result<()> {
    let clock = match args.clock {
        ClockArg::Given(c) => c,
        ClockArg::Calibrated => {
            let mut s = scene.clone();
            s.camera = path.camera_at(0.0, scene.camera.width, scene.camera.height);
            let spp = calibrate(ctx, &s, settings, 3)?;
            Clock::Virtual { seconds_per_pixel: spp }
        }
    };
    let opts = ReplayOptions {
        clock,
        display_hz: args.rate,
        error_every: args.error_every,
        frames_dir: args.frames.clone(),
        progress: true,
    };
    let t = Instant::now();
    let report = replay(ctx, scene, settings, path, &opts)?;
    let device = format!("{} ({})", ctx.adapter_name(), ctx.adapter_driver());
    print_report(args, &report, settings, path, &device, t)
}

/// `irt replay --mpi` on rank 0: the replay's loop on the master, the workers tracing.
fn distributed(cluster: &irt::dist::cluster::Cluster, args: &ReplayArgs) -> Result<()> {
    if args.error_every > 0 {
        anyhow::bail!(
            "--error-every renders ideal frames on rank 0, which has no device with --mpi: drop one of them"
        );
    }
    if let ClockArg::Given(c) = args.clock {
        anyhow::bail!("--clock {c} with --mpi: the clock is the wall time of rank 0's turns (drop --clock)");
    }
    let path = CameraPath::load(&args.path)?;
    let scene = first_camera(&load_scene(&args.scene)?, &path);
    let settings = args.settings()?;
    let mut master = Master::start(cluster, &scene, settings.clone(), args.mpi.deadlines()?)?;
    let opts = ReplayOptions {
        clock: Clock::Real,
        display_hz: args.rate,
        error_every: 0,
        frames_dir: args.frames.clone(),
        progress: true,
    };
    let t = Instant::now();
    let mut source = MasterSource::new(&mut master);
    let result = replay_on(&mut source, &scene, &settings.mode, &path, &opts);
    let (failure, device) = (source.failure.take(), source.device());
    if let Some(e) = failure {
        // A silent or failed rank: named, and the whole job ends.
        master.abort(&e);
    }
    let report = result?;
    master.finish();
    print_report(args, &report, &settings, &path, &device, t)
}

/// The summary on stdout, the time taken, and the CSV when asked for.
fn print_report(
    args: &ReplayArgs,
    report: &irt::render::replay::ReplayReport,
    settings: &Settings,
    path: &CameraPath,
    device: &str,
    t: Instant,
) -> Result<()> {
    let scene_name = args.scene.name_or("default scene");
    print!("{}", summary(report, &settings.mode, &format!("{} on {scene_name}", path.origin), device));
    eprintln!("(took {:.1} s)", t.elapsed().as_secs_f64());
    if let Some(csv) = &args.csv {
        irt::image::write_atomic(csv, samples_csv(report).as_bytes())?;
        eprintln!("wrote {}", csv.display());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::{CommandFactory, Parser};
    use irt::render::{Mode, PixelOrder, Schedule};

    #[derive(clap::Parser)]
    struct Cli {
        #[command(flatten)]
        args: ReplayArgs,
    }

    fn parse(line: &str) -> Result<ReplayArgs, clap::Error> {
        Cli::try_parse_from(line.split_whitespace()).map(|c| c.args)
    }

    #[test]
    fn clock_arguments_parse() {
        assert_eq!("virtual".parse::<ClockArg>().unwrap(), ClockArg::Calibrated);
        assert_eq!("real".parse::<ClockArg>().unwrap(), ClockArg::Given(Clock::Real));
        assert!("fast".parse::<ClockArg>().unwrap_err().to_string().contains("virtual (calibrated)"));
    }

    #[test]
    fn replay_arguments_parse_into_settings() {
        Cli::command().debug_assert();
        let a = parse(
            "replay p.toml s.nff --mode conventional --schedule guided --workers 8 --clock virtual:300",
        )
        .unwrap();
        assert_eq!(a.path, PathBuf::from("p.toml"));
        assert_eq!(a.scene.scene.as_deref(), Some(std::path::Path::new("s.nff")));
        assert_eq!(a.clock, ClockArg::Given(Clock::Virtual { seconds_per_pixel: 300e-9 }));
        let s = a.settings().unwrap();
        assert_eq!(s.mode, Mode::Conventional { schedule: Schedule::Guided, workers: 8 });
        assert_eq!(s.max_samples, 1);
        let f = parse("replay p.toml --order dissolve --slice 1000").unwrap().settings().unwrap();
        assert!(
            matches!(f.mode, Mode::Frameless { order: PixelOrder::Dissolve, slice: 1000, .. }),
            "{:?}",
            f.mode
        );
        let bad = parse("replay p.toml --slice 0").unwrap().settings().unwrap_err();
        assert!(bad.to_string().contains("--slice 0"), "{bad}");
        assert!(parse("replay p.toml --clock fast").is_err());
        assert!(parse("replay p.toml --mode sideways").is_err());
        let sized = parse("replay p.toml --size 16x8 --precision f64 --accel grid").unwrap();
        assert_eq!(sized.scene.size, Some([16, 8]));
        let s = sized.settings().unwrap();
        assert!(s.f64 && s.accel == irt::accel::AccelChoice::Grid, "{s:?}");
        let m = parse("replay p.toml --mpi --deadline 5").unwrap();
        assert!(m.mpi.mpi && m.mpi.deadline == 5.0);
        assert!(parse("replay p.toml --deadline 5").is_err(), "--deadline needs --mpi");
    }

    /// The path is read (and a bad one reported by file, line and column) before any device
    /// is opened.
    #[test]
    fn bad_path_files_are_reported_by_file_and_line() {
        let dir = std::env::temp_dir().join(format!("irt-replay-args-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("bad.toml");
        std::fs::write(&file, "[[key]]\nt = 0\neye = [0, 2, 7.8]\nlook_at = [0, 0.75, -0.3]\n\n[[key]]\nt = 1\neye = [0, 2, 7.8]\nlook_at = [0, 0.75]\n").unwrap();
        let line = format!("replay {} --size 16x16 --clock real --no-cache", file.display());
        let err = format!("{:#}", run(parse(&line).unwrap()).unwrap_err());
        let want = format!("{}:9:11: `look_at` needs 3 numbers, found 2", file.display());
        assert!(err.starts_with(&want), "got {err}\nwant {want}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
