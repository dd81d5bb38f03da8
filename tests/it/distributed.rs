//! `--mpi`: the job as a user starts it, `mpirun --oversubscribe -n 3 irt …` (Open MPI), against
//! the single-process picture, and the faults a cluster user meets: a rank killed, stopped,
//! panicking, of another build, without its device. Every job runs in a process group of its own
//! under a watchdog, and the test kills that group when it is done: nothing is left behind even
//! when a case fails.

use std::io::{BufRead, BufReader};
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use crate::viewer::{capture, decode, differing_pixels, headless, serial, window_id, TempDir, Xvfb};
use irt::render::{Mode, Settings};

const IRT: &str = env!("CARGO_BIN_EXE_irt");

fn dir() -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("distributed");
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A small picture: the cases are about who traced the pixels, not about the scene.
const SMALL: [&str; 2] = ["--size", "160x120"];

/// One application context of an MPMD job: the environment it adds and irt's arguments.
struct Ranks<'a> {
    n: u32,
    env: &'a [(&'a str, &'a str)],
    args: Vec<String>,
}

fn ranks<'a>(n: u32, args: &[&str]) -> Ranks<'a> {
    Ranks { n, env: &[], args: args.iter().map(|a| a.to_string()).collect() }
}

/// A running `mpirun`, its stderr lines arriving on a channel.
struct Job {
    child: Child,
    stderr: mpsc::Receiver<String>,
    seen: Vec<String>,
}

impl Job {
    fn start(contexts: &[Ranks]) -> Job {
        Job::start_in(Command::new("mpirun"), contexts)
    }

    /// The job from `cmd` (mpirun with an environment of its own: a display).
    fn start_in(cmd: Command, contexts: &[Ranks]) -> Job {
        Job::start_to(cmd, contexts, Stdio::null())
    }

    /// The job from `cmd`, its standard output to `stdout`.
    fn start_to(mut cmd: Command, contexts: &[Ranks], stdout: Stdio) -> Job {
        cmd.arg("--oversubscribe");
        for (i, c) in contexts.iter().enumerate() {
            if i > 0 {
                cmd.arg(":");
            }
            cmd.args(["-n", &c.n.to_string()]);
            if !c.env.is_empty() {
                cmd.arg("env");
                cmd.args(c.env.iter().map(|(k, v)| format!("{k}={v}")));
            }
            cmd.arg(IRT).args(&c.args);
        }
        // Root in CI containers: Open MPI refuses root without these.
        cmd.env("OMPI_ALLOW_RUN_AS_ROOT", "1").env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1");
        // Two workers on a 2-core machine: one lavapipe thread each.
        cmd.env("LP_NUM_THREADS", "1");
        cmd.stdout(stdout).stderr(Stdio::piped()).process_group(0);
        let mut child = cmd.spawn().expect("mpirun runs (scripts/setup.sh installs Open MPI)");
        let (tx, rx) = mpsc::channel();
        let err = child.stderr.take().unwrap();
        std::thread::spawn(move || {
            for line in BufReader::new(err).lines().map_while(Result::ok) {
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        Job { child, stderr: rx, seen: Vec::new() }
    }

    /// Waits for a stderr line containing `needle`, at most `limit`.
    fn wait_for_line(&mut self, needle: &str, limit: Duration) -> bool {
        let end = Instant::now() + limit;
        loop {
            let left = end.saturating_duration_since(Instant::now());
            match self.stderr.recv_timeout(left) {
                Ok(line) => {
                    let hit = line.contains(needle);
                    self.seen.push(line);
                    if hit {
                        return true;
                    }
                }
                Err(_) => return false,
            }
        }
    }

    /// The exit status, or `None` if the job was still running after `limit` (then it is killed).
    fn wait(&mut self, limit: Duration) -> Option<ExitStatus> {
        let end = Instant::now() + limit;
        while Instant::now() < end {
            if let Some(status) = self.child.try_wait().unwrap() {
                return Some(status);
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        None
    }

    /// Everything the job wrote on stderr so far.
    fn stderr(&mut self) -> String {
        // The reader thread ends with the pipe; what it has sent is all there is.
        while let Ok(line) = self.stderr.recv_timeout(Duration::from_millis(200)) {
            self.seen.push(line);
        }
        self.seen.join("\n")
    }

    /// The pid of MPI rank `rank`: a child of mpirun that Open MPI told its rank.
    fn rank_pid(&self, rank: u32) -> Option<u32> {
        let parent = self.child.id();
        std::fs::read_dir("/proc").ok()?.flatten().find_map(|e| {
            let pid: u32 = e.file_name().to_str()?.parse().ok()?;
            let stat = std::fs::read_to_string(e.path().join("stat")).ok()?;
            // pid (comm) state ppid …: the command may hold spaces, the last ')' ends it.
            let ppid: u32 = stat[stat.rfind(')')? + 2..].split(' ').nth(1)?.parse().ok()?;
            let env = std::fs::read(e.path().join("environ")).ok()?;
            let want = format!("OMPI_COMM_WORLD_RANK={rank}");
            let is_rank = env.split(|&b| b == 0).any(|v| v == want.as_bytes());
            (ppid == parent && is_rank).then_some(pid)
        })
    }

    /// The processes still in the job's group.
    fn left_behind(&self) -> Vec<u32> {
        let group = self.child.id();
        let Ok(entries) = std::fs::read_dir("/proc") else { return Vec::new() };
        entries
            .flatten()
            .filter_map(|e| {
                let pid: u32 = e.file_name().to_str()?.parse().ok()?;
                let stat = std::fs::read_to_string(e.path().join("stat")).ok()?;
                let mut fields = stat[stat.rfind(')')? + 2..].split(' ');
                let state = fields.next()?;
                let pgrp: u32 = fields.nth(1)?.parse().ok()?;
                // A zombie is dead already, only not reaped.
                (pgrp == group && state != "Z").then_some(pid)
            })
            .collect()
    }
}

impl Drop for Job {
    fn drop(&mut self) {
        // The whole group, stopped ones too, whatever the test saw.
        let group = format!("-{}", self.child.id());
        let _ = Command::new("kill").args(["-KILL", "--", &group]).stderr(Stdio::null()).status();
        let _ = self.child.wait();
    }
}

fn signal(pid: u32, sig: &str) {
    assert!(Command::new("kill").args([sig, &pid.to_string()]).status().unwrap().success());
}

/// Renders `args` in one process and as an MPI job of a master and two workers; both files
/// must be the same bytes.
fn assert_same_as_one_process(name: &str, args: &[&str]) {
    assert_same_as_one_process_at(name, args, &SMALL);
}

/// [`assert_same_as_one_process`] at `size` (`["--size", "WxH"]`).
fn assert_same_as_one_process_at(name: &str, args: &[&str], size: &[&str]) {
    assert_same_with_workers(name, args, size, &[]);
}

/// [`assert_same_as_one_process_at`], the second worker with the environment `env`; gives what
/// the job wrote on stderr.
fn assert_same_with_workers(name: &str, args: &[&str], size: &[&str], env: &[(&str, &str)]) -> String {
    let one = dir().join(format!("{name}-one.png"));
    let mpi = dir().join(format!("{name}-mpi.png"));
    let out = Command::new(IRT).arg("render").args(args).args(size).arg("--out").arg(&one).output().unwrap();
    assert!(out.status.success(), "{name}: {}", String::from_utf8_lossy(&out.stderr));
    let mut job_args = vec!["render", "--mpi", "--out", mpi.to_str().unwrap()];
    job_args.extend(args);
    job_args.extend(size);
    let mut job = match env.is_empty() {
        true => Job::start(&[ranks(3, &job_args)]),
        false => Job::start(&[ranks(2, &job_args), Ranks { env, ..ranks(1, &job_args) }]),
    };
    let status = job.wait(Duration::from_secs(240));
    let err = job.stderr();
    assert!(status.is_some_and(|s| s.success()), "{name}: {status:?}\n{err}");
    assert!(std::fs::read(&one).unwrap() == std::fs::read(&mpi).unwrap(), "{name}: the MPI picture differs");
    assert!(job.left_behind().is_empty(), "{name}: processes left: {:?}", job.left_behind());
    err
}

/// A particle file is not in the scene message: a worker that sees rank 0's file reads it
/// there; one that cannot is sent it in parts. Either way the picture is one process's.
#[test]
fn particle_files_are_read_where_workers_see_them_and_sent_where_not() {
    let plate = irt::io::stress_plate::plate(20_000);
    let mut bytes = Vec::new();
    irt::io::ply::write_points(&plate, irt::io::ply::Encoding::BinaryLittleEndian, &mut bytes).unwrap();
    let file = dir().join("plate.ply");
    std::fs::write(&file, &bytes).unwrap();
    let args = [file.to_str().unwrap(), "--mode", "conventional"];
    let err = assert_same_with_workers("particles-read", &args, &SMALL, &[]);
    assert!(err.contains("every worker read its 1 file(s) itself"), "{err}");
    assert!(!err.contains("sent it the file"), "{err}");
    let unseen = [("IRT_FAULT", "unseen-files")];
    let err = assert_same_with_workers("particles-sent", &args, &SMALL, &unseen);
    let mb = format!("sent it the file ({:.1} MB in", bytes.len() as f64 / 1e6);
    assert!(err.contains("rank 2 cannot read") && err.contains(&mb), "{err}");
    assert!(!err.contains("rank 1 cannot read"), "rank 1 sees the file: {err}");
    // The file goes in parts of 64 MiB; this one is a single part, the unit tests split one.
    assert!(err.contains(&format!("{:.1} MB of files sent", bytes.len() as f64 / 1e6)), "{err}");
}

/// A volume's file travels as a particle file does (read where a worker sees it, else sent);
/// the picture, an isosurface or a MIP, is one process's. A detached NRRD header, whose data
/// file would not travel with it, is refused in words before any rank traces.
#[test]
fn volume_files_are_read_or_sent_and_the_picture_is_one_process_s() {
    let volume = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/volumes/mni152_t1.nii.gz");
    let args = [volume, "--iso", "90", "--mode", "conventional"];
    let err = assert_same_with_workers("volume-read", &args, &SMALL, &[]);
    assert!(err.contains("every worker read its 1 file(s) itself"), "{err}");
    let args = [volume, "--volume-mode", "mip", "--mode", "frameless", "--samples", "2"];
    let err = assert_same_with_workers("volume-sent", &args, &SMALL, &[("IRT_FAULT", "unseen-files")]);
    assert!(err.contains("rank 2 cannot read") && err.contains("sent it the file"), "{err}");
    let nhdr = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/volumes/sphere_gzip.nhdr");
    let out = dir().join("nhdr.png");
    let mut job = Job::start(&[ranks(3, &["render", "--mpi", nhdr, "--out", out.to_str().unwrap()])]);
    let status = job.wait(Duration::from_secs(120));
    let err = job.stderr();
    assert!(status.is_some_and(|s| !s.success()), "{status:?}\n{err}");
    assert!(err.contains("detached NRRD header"), "{err}");
    assert!(!out.exists(), "no picture from a refused job");
}

#[test]
fn the_picture_is_one_process_s_bit_for_bit() {
    // The bands' one picture, traced as the tiles of a conventional frame.
    assert_same_as_one_process("bands", &[]);
    // Progressive samples accumulate on rank 0 keyed by sample, whichever rank traced them;
    // bundle shadows rotate their points by sample.
    assert_same_as_one_process(
        "conventional",
        &["--mode", "conventional", "--samples", "3", "--shadows", "bundle:8"],
    );
    // Frameless blends each visit into the pixel: applied in the order they were handed out.
    assert_same_as_one_process(
        "frameless",
        &["--mode", "frameless", "--samples", "2", "--shadows", "bundle:8"],
    );
    // The paper's jitter pairs (two sub-pixel positions a visit, the workers trace both) and a
    // blend, applied on rank 0 as the shader's mix rounds it.
    assert_same_as_one_process(
        "frameless-jitter-blend",
        &["--mode", "frameless", "--samples", "2", "--jitter-pairs", "--order", "dissolve"],
    );
    assert_same_as_one_process(
        "frameless-blend",
        &["--mode", "frameless", "--samples", "3", "--blend", "0.3"],
    );
    // An animated scene posed at a time by every rank.
    let animated = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/animated.toml");
    assert_same_as_one_process(
        "animated",
        &[animated, "--time", "0.7", "--mode", "frameless", "--samples", "2"],
    );
}

/// Newell's teapot as Bezier patches: the OBJ's free-form surfaces reach the workers inside the
/// scene message (as `[[patch]]`), and their tiles give one process's picture.
#[test]
fn patches_across_ranks_are_one_process_s_picture() {
    let teapot = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/teapot-patches.obj");
    assert_same_as_one_process("patches", &[teapot, "--mode", "conventional", "--shadows", "bundle:8"]);
}

#[test]
fn a_picture_past_the_device_s_buffers_is_one_process_s_bit_for_bit() {
    // 4096×2304 is more than lavapipe's 128 MiB bindings hold: one process traces it in pieces,
    // the workers their tiles of it (each of which fits).
    let big = ["--size", "4096x2304"];
    assert_same_as_one_process_at("big-bands", &[], &big);
    assert_same_as_one_process_at("big-conventional", &["--mode", "conventional"], &big);
    assert_same_as_one_process_at("big-frameless", &["--mode", "frameless"], &big);
}

#[test]
fn a_worker_whose_device_fails_names_itself_and_ends_the_job() {
    // A lost device mid-job (after the worker's first dispatch), and an allocation the device
    // refuses while the worker sets the scene up.
    for (fault, words) in [
        ("device-lost", ["irt rank 1", "the device was lost"]),
        ("device-alloc", ["rank 1 could not set the scene up", "the device refused irt's work"]),
    ] {
        let out = dir().join(format!("{fault}.png"));
        let mut job = with_fault(&out, 1, fault);
        let err = assert_fails_loudly(&mut job, Duration::from_secs(120), &words);
        assert!(
            !err.contains("panicked") && !err.contains(".rs:"),
            "{fault}: a panic or a source path:\n{err}"
        );
        assert!(!out.exists(), "{fault}: a picture was written");
    }
}

/// A job that must fail: it ends non-zero within `limit`, its stderr says `words`, and nothing
/// of it is left running.
fn assert_fails_loudly(job: &mut Job, limit: Duration, words: &[&str]) -> String {
    let start = Instant::now();
    let status = job.wait(limit);
    let err = job.stderr();
    assert!(status.is_some(), "still running after {limit:?}:\n{err}");
    assert!(!status.unwrap().success(), "exited 0:\n{err}");
    for w in words {
        assert!(err.contains(w), "stderr lacks {w:?}:\n{err}");
    }
    // mpirun's children end with it; give the kernel a moment to reap them.
    let end = Instant::now() + Duration::from_secs(5);
    while !job.left_behind().is_empty() && Instant::now() < end {
        std::thread::sleep(Duration::from_millis(50));
    }
    assert!(job.left_behind().is_empty(), "processes left: {:?}", job.left_behind());
    eprintln!("ended in {:.1} s", start.elapsed().as_secs_f64());
    err
}

/// Never ends by itself: the fault has time to happen mid-job.
fn endless(out: &Path) -> Vec<String> {
    let mut a: Vec<String> =
        ["render", "--mpi", "--mode", "frameless", "--samples", "1000000", "--deadline", "3"]
            .iter()
            .map(|s| s.to_string())
            .collect();
    a.extend(SMALL.iter().map(|s| s.to_string()));
    a.extend(["--out".to_string(), out.to_str().unwrap().to_string()]);
    a
}

/// An [`endless`] job of `healthy` ranks and one more, last, with `IRT_FAULT=fault`.
fn with_fault(out: &Path, healthy: u32, fault: &str) -> Job {
    let args = endless(out);
    let args: Vec<&str> = args.iter().map(|s| s.as_str()).collect();
    let env = [("IRT_FAULT", fault)];
    Job::start(&[ranks(healthy, &args), Ranks { n: 1, env: &env, args: ranks(1, &args).args }])
}

/// An [`endless`] job of three ranks, once rank 0 says it is tracing.
fn tracing(out: &Path) -> Job {
    let args = endless(out);
    let args: Vec<&str> = args.iter().map(|s| s.as_str()).collect();
    let mut job = Job::start(&[ranks(3, &args)]);
    assert!(
        job.wait_for_line("tracing", Duration::from_secs(120)),
        "the job never started:\n{}",
        job.stderr()
    );
    job
}

#[test]
fn a_worker_that_stops_answering_is_named_after_the_deadline() {
    let out = dir().join("stopped.png");
    let mut job = tracing(&out);
    let pid = job.rank_pid(1).expect("rank 1 runs");
    signal(pid, "-STOP");
    // The deadline is 3 s a piece; the rest is Open MPI ending the ranks.
    assert_fails_loudly(&mut job, Duration::from_secs(30), &["rank 1 said nothing for", "tracing positions"]);
    assert!(!out.exists(), "a failed job wrote its picture");
}

#[test]
fn a_killed_worker_ends_the_job() {
    let out = dir().join("killed.png");
    let mut job = tracing(&out);
    let pid = job.rank_pid(2).expect("rank 2 runs");
    signal(pid, "-KILL");
    // Open MPI names the rank and the signal.
    assert_fails_loudly(&mut job, Duration::from_secs(30), &["rank 2", "signal 9"]);
    assert!(!out.exists());
}

#[test]
fn a_panicking_worker_ends_the_job_with_its_message() {
    let mut job = with_fault(&dir().join("panic.png"), 1, "panic");
    assert_fails_loudly(&mut job, Duration::from_secs(120), &["irt rank 1: panicked at", "IRT_FAULT=panic"]);
}

#[test]
fn ranks_of_another_build_refuse_to_start() {
    let mut job = with_fault(&dir().join("version.png"), 2, "version");
    assert_fails_loudly(
        &mut job,
        Duration::from_secs(120),
        &["rank 2 runs irt", "start every rank from the same irt build"],
    );
}

#[test]
fn a_worker_without_its_device_says_so_before_the_first_frame() {
    let out = dir().join("device.png");
    let args = endless(&out);
    let mut theirs = args.clone();
    theirs.extend(["--adapter".to_string(), "no-such-device".to_string()]);
    let args: Vec<&str> = args.iter().map(|s| s.as_str()).collect();
    let theirs: Vec<&str> = theirs.iter().map(|s| s.as_str()).collect();
    let mut job = Job::start(&[ranks(1, &args), ranks(1, &theirs)]);
    assert_fails_loudly(
        &mut job,
        Duration::from_secs(120),
        &["rank 1 could not open a device", "no-such-device"],
    );
}

/// `irt replay --mpi`: the path replayed with two workers tracing prints what a local replay
/// prints, and every input reaches the whole screen within a sane latency.
#[test]
fn replay_across_ranks_measures_latency_and_pixel_age() {
    let out = dir().join("replay.txt");
    let file = std::fs::File::create(&out).unwrap();
    let csv = dir().join("replay.csv");
    let args =
        ["replay", "scenes/paths/orbit.toml", "--mpi", "--size", "96x72", "--csv", csv.to_str().unwrap()];
    let mut job = Job::start_to(Command::new("mpirun"), &[ranks(3, &args)], Stdio::from(file));
    let status = job.wait(Duration::from_secs(60));
    let stderr = job.stderr();
    assert!(status.is_some_and(|s| s.success()), "{status:?}\n{stderr}");
    let text = std::fs::read_to_string(&out).unwrap();
    for head in [
        "replay     scenes/paths/orbit.toml",
        "device     2 MPI workers on",
        "clock      real",
        "latency    (mean / max of",
        "pixel age  at presents",
        "pixel age  at refreshes",
    ] {
        assert!(text.contains(head), "no `{head}` in\n{text}");
    }
    // Every input of the 3 s path reached 100% of the screen (else the replay would not end),
    // within a sane time: the worst "100%" latency is finite and under the path's own 3 s. This
    // bound catches an input that is lost or waits for the path to end; it is not a speed
    // target (that lives in docs/distributed.md). On CI's 2 cores, 3 ranks share them and the
    // worst input reached 1018 ms once while the mean was 200 ms, so a 1 s bound was a timing
    // test in disguise.
    let latency = text.lines().find(|l| l.starts_with("latency")).unwrap();
    let worst = latency.rsplit("100% ").next().unwrap();
    let max_ms: f64 = worst.split(" / ").nth(1).unwrap().trim_end_matches(" ms").parse().unwrap();
    assert!(max_ms.is_finite() && max_ms > 0.0 && max_ms < 3000.0, "{latency}");
    let inputs: u32 = latency.split("of ").nth(1).unwrap().split(' ').next().unwrap().parse().unwrap();
    assert!(inputs > 100, "{latency}");
    // Pixel ages at the presents are in the CSV, each finite and under the path's 3 s (the same
    // reason as above).
    let ages = std::fs::read_to_string(&csv).unwrap();
    let presents: Vec<f64> = ages
        .lines()
        .filter(|l| l.starts_with("present,"))
        .map(|l| l.split(',').nth(4).unwrap().parse().unwrap())
        .collect();
    assert!(presents.len() > 100 && presents.iter().all(|a| a.is_finite() && *a < 3.0), "{ages}");
}

#[test]
fn one_rank_is_told_how_to_launch() {
    let mut job = Job::start(&[ranks(1, &["render", "--mpi", "--out", "/nonexistent/x.png"])]);
    assert_fails_loudly(&mut job, Duration::from_secs(60), &["mpirun -n 3 irt render --mpi", "at least 2"]);
}

#[test]
fn a_scene_rank_0_cannot_load_ends_every_rank() {
    // The workers wait for rank 0's scene: rank 0's error must end them, not leave the job
    // waiting in MPI_Finalize.
    let out = dir().join("noscene.png");
    let mut job =
        Job::start(&[ranks(3, &["render", "no-such-scene.nff", "--mpi", "--out", out.to_str().unwrap()])]);
    assert_fails_loudly(&mut job, Duration::from_secs(60), &["irt rank 0: error", "no-such-scene.nff"]);
    let mut job =
        Job::start(&[ranks(3, &["render", "--mpi", "--frames", "0..2", "--out", out.to_str().unwrap()])]);
    assert_fails_loudly(&mut job, Duration::from_secs(60), &["irt rank 0: error", "job array"]);
}

/// Presses P in the window of `x` until the screenshot `shot` is there and the same as the one
/// before it a second earlier, within `limit` (the picture converged: --max-samples 1); it.
fn settled(x: &Xvfb, job: &mut Job, shot: &Path, limit: Duration) -> Vec<u8> {
    let deadline = Instant::now() + limit;
    let mut last: Option<Vec<u8>> = None;
    loop {
        let _ = std::fs::remove_file(shot);
        x.xdotool(&["key", "p"], Duration::from_secs(10));
        while !shot.exists() {
            assert!(job.child.try_wait().unwrap().is_none(), "the job ended:\n{}", job.stderr());
            assert!(Instant::now() < deadline, "no screenshot within {limit:?}:\n{}", job.stderr());
            std::thread::sleep(Duration::from_millis(50));
        }
        let (_, _, img) = decode(shot);
        if img.iter().any(|&c| c > 0) && last.as_ref() == Some(&img) {
            return img;
        }
        last = Some(img);
        assert!(Instant::now() < deadline, "the picture did not settle within {limit:?}");
        std::thread::sleep(Duration::from_millis(1000));
    }
}

/// A pixel of `scene` over a sphere and that sphere's material, as the viewer picks.
fn sphere_pixel(scene: &irt::scene::Scene) -> (u32, u32, usize) {
    use irt::app::edit::{Picker, Selection};
    use irt::reference::Primitive;
    let [w, h] = [scene.camera.width, scene.camera.height];
    let mut picker = Picker::default();
    (0..h)
        .step_by(4)
        .flat_map(|y| (0..w).step_by(4).map(move |x| (x, y)))
        .find_map(|(x, y)| match picker.pick(scene, [x as f64, y as f64], [w, h]) {
            Some(Selection::Object(Primitive::Sphere(i))) => Some((x, y, scene.spheres[i].material as usize)),
            _ => None,
        })
        .expect("the default scene shows a sphere")
}

/// `scene` traced in one process, one pass, as sRGB bytes.
fn headless_of(scene: &irt::scene::Scene, settings: Settings) -> Vec<u8> {
    let ctx = crate::common::gpu();
    let mut s = irt::render::Session::new(&ctx, scene, settings).unwrap();
    s.complete_pass(&ctx);
    s.read_image(&ctx).to_srgb8()
}

/// `mpirun -n 3 irt view --mpi` under Xvfb, as a user meets it: rank 0's window shows what the
/// two workers traced — the settled picture is the single-process one bit for bit, in both
/// modes, and it is what the window shows — a live edit reaches the workers (the picture becomes
/// the edited scene's, bit for bit), a drag changes it, and Escape ends every rank with status 0
/// and nothing left behind.
#[test]
fn the_window_across_ranks_shows_the_workers_picture_and_escape_ends_the_job() {
    let _serial = serial();
    let x = Xvfb::start();
    let dir = TempDir::new("mpi-view");
    let shot = dir.join("shot.png");
    let cases = [
        ("conventional", Settings { mode: Mode::conventional(), max_samples: 1, ..Settings::default() }),
        ("frameless", Settings { mode: Mode::frameless(), max_samples: 1, ..Settings::default() }),
    ];
    for (mode, settings) in cases {
        let args = [
            "view",
            "--mpi",
            "--size",
            "160x120",
            "--mode",
            mode,
            "--max-samples",
            "1",
            "--no-hud",
            "--screenshot",
            shot.to_str().unwrap(),
        ];
        let mut job = Job::start_in(x.command("mpirun"), &[ranks(3, &args)]);
        let wid = window_id(&x);
        crate::viewer::focus(&x, &wid);
        let before = settled(&x, &mut job, &shot, Duration::from_secs(120));
        let want = headless(settings.clone(), 160, 120, 1);
        let diff = differing_pixels(&before, &want);
        assert_eq!(diff, 0, "{mode}: {diff} pixels differ from the single-process picture");
        // What the window shows is that picture (the master's host frame, uploaded for the
        // blit): within the rounding of the surface's sRGB encoding.
        let on_screen = capture(&x, &wid, &dir.join("screen.png"));
        let off = before.iter().zip(&on_screen).map(|(a, b)| a.abs_diff(*b)).max();
        assert!(
            on_screen.len() == before.len() && off <= Some(2),
            "{mode}: the window shows another picture ({off:?})"
        );
        if mode == "conventional" {
            // A live edit: the workers set the edited scene up, and show it as one process would.
            let scene = irt::scene::Scene {
                camera: irt::scene::Camera { width: 160, height: 120, ..irt::scene::default_scene().camera },
                ..irt::scene::default_scene()
            };
            let (px, py, m) = sphere_pixel(&scene);
            x.xdotool(
                &["mousemove", "--window", &wid, &px.to_string(), &py.to_string()],
                Duration::from_secs(10),
            );
            x.xdotool(&["click", "1"], Duration::from_secs(10));
            x.xdotool(&["key", "k"], Duration::from_secs(10));
            let mut edited = scene.clone();
            edited.materials[m].kind = irt::app::edit::next_kind(&scene.materials[m].kind);
            let want = headless_of(&edited, settings.clone());
            let deadline = Instant::now() + Duration::from_secs(120);
            loop {
                let got = settled(&x, &mut job, &shot, Duration::from_secs(120));
                if got == want {
                    break;
                }
                assert!(
                    Instant::now() < deadline,
                    "the edit of material {m} never showed as one process shows it"
                );
            }

            x.xdotool(&["mousemove", "--window", &wid, "80", "60"], Duration::from_secs(10));
            x.xdotool(&["mousedown", "1"], Duration::from_secs(10));
            for dx in [10, 20, 30, 40] {
                let to = (80 + dx).to_string();
                x.xdotool(&["mousemove", "--window", &wid, &to, "62"], Duration::from_secs(10));
                std::thread::sleep(Duration::from_millis(30));
            }
            x.xdotool(&["mouseup", "1"], Duration::from_secs(10));
            let after = settled(&x, &mut job, &shot, Duration::from_secs(120));
            let diff = differing_pixels(&want, &after);
            assert!(diff > 160 * 120 / 20, "{mode}: only {diff} pixels changed after a drag");
        }
        x.xdotool(&["key", "Escape"], Duration::from_secs(10));
        let status = job.wait(Duration::from_secs(30));
        let err = job.stderr();
        assert!(status.is_some_and(|s| s.success()), "{mode}: Escape gave {status:?}:\n{err}");
        assert!(!err.contains("panicked"), "{mode}: {err}");
        assert!(job.left_behind().is_empty(), "{mode}: processes left: {:?}", job.left_behind());
    }
}

/// Without a display rank 0 says so in words (no path inside winit's sources) and the whole job
/// ends non-zero at once: no worker is left waiting for a window that never opens.
#[test]
fn view_without_a_display_ends_the_job_in_words() {
    let mut cmd = Command::new("mpirun");
    cmd.env_remove("DISPLAY").env_remove("WAYLAND_DISPLAY").env_remove("WAYLAND_SOCKET");
    let mut job = Job::start_in(cmd, &[ranks(3, &["view", "--mpi", "--size", "160x120"])]);
    let status = job.wait(Duration::from_secs(60));
    let err = job.stderr();
    assert!(status.is_some_and(|s| !s.success()), "{status:?}\n{err}");
    assert!(err.contains("irt rank 0: error: cannot open a window: neither"), "{err}");
    assert!(!err.contains(".cargo") && !err.contains(".rs:"), "a source path in the message:\n{err}");
    assert!(job.left_behind().is_empty(), "processes left: {:?}", job.left_behind());
}

/// A worker that stops answering while the window refines (frameless, never converging) is
/// named by rank 0 after --deadline, and the whole job ends non-zero: the window's loop is the
/// master's loop.
#[test]
fn a_stopped_worker_ends_the_window_job_with_its_rank_named() {
    let _serial = serial();
    let x = Xvfb::start();
    let args = [
        "view",
        "--mpi",
        "--size",
        "160x120",
        "--mode",
        "frameless",
        "--max-samples",
        "0",
        "--no-hud",
        "--deadline",
        "3",
    ];
    let mut job = Job::start_in(x.command("mpirun"), &[ranks(3, &args)]);
    assert!(
        job.wait_for_line("tracing", Duration::from_secs(120)),
        "the job never started:\n{}",
        job.stderr()
    );
    window_id(&x);
    let pid = job.rank_pid(2).expect("rank 2 runs");
    signal(pid, "-STOP");
    assert_fails_loudly(&mut job, Duration::from_secs(30), &["rank 2 said nothing for", "tracing positions"]);
}
