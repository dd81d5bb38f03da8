//! What needs a fresh process per measurement (docs/performance.md, *Benches*): each iteration
//! runs `irt bench` (the binary of this build) on the default scene at 512² and hands criterion
//! the time that process reports, not the process's wall time.
//! - `lp_threads/N`: steady frame time with `LP_NUM_THREADS=N` (lavapipe reads it when the
//!   Vulkan instance is created, so it cannot change within a process), throughput in rays;
//! - `first_frame/…`: pipeline creation + first frame, cold (fresh empty Mesa shader cache
//!   directory, irt's pipeline cache off: `IRT_CACHE_DIR=off irt bench --cold-mesa-only`),
//!   Mesa cold with irt's cache warm (`--cold-mesa-only`), and warm (both caches filled by an
//!   earlier run). Mesa's cache is emptied by pointing it at a fresh directory, as `irt bench
//!   --cold` does, not disabled: `MESA_SHADER_CACHE_DISABLE` makes lavapipe recompile at every
//!   dispatch, which measures nothing useful.
//!
//!     cargo bench --bench process
mod common;

use common::cases;
use criterion::{Criterion, Throughput};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

/// What one `irt bench` run printed.
struct Report {
    first_frame: Duration,
    frame: Duration,
    rays: u64,
}

/// The number after `label` on the line that starts with it (`first frame      954 ms`).
fn field(out: &str, label: &str) -> f64 {
    out.lines()
        .find_map(|l| l.strip_prefix(label))
        .and_then(|rest| rest.split_whitespace().next()?.parse().ok())
        .unwrap_or_else(|| panic!("no `{label}` in irt bench's output:\n{out}"))
}

fn irt_bench(args: &[&str], env: &[(&str, &Path)], threads: Option<u32>) -> Report {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_irt"));
    cmd.arg("bench").args(args);
    for (k, v) in env {
        cmd.env(k, v);
    }
    if let Some(n) = threads {
        cmd.env("LP_NUM_THREADS", n.to_string());
    }
    let out = cmd.output().expect("run irt bench");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "irt bench {args:?} failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let ms = |label| Duration::from_secs_f64(field(&stdout, label) / 1e3);
    Report { first_frame: ms("first frame"), frame: ms("frame "), rays: field(&stdout, "rays/frame") as u64 }
}

fn default_primitives() -> usize {
    irt::scene::default_scene().primitive_count()
}

/// A directory removed when dropped.
struct TempDir(PathBuf);

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn lp_threads(c: &mut Criterion) {
    let mut g = common::group(c, "lp_threads");
    for n in cases(&[1u32, 2]) {
        let id = format!("default_512/{n}");
        if !common::wanted(&format!("lp_threads/{id}")) {
            continue;
        }
        let rays = irt_bench(&["--frames", "1"], &[], Some(n)).rays;
        g.throughput(Throughput::Elements(rays));
        g.bench_function(&id, |b| {
            b.iter_custom(|iters| {
                // One process per sample: the median of its frames, as `iters` frames.
                let frames = iters.max(3).to_string();
                let frame = irt_bench(&["--frames", &frames], &[], Some(n)).frame;
                common::record(&format!("lp_threads/{id}"), rays, default_primitives(), vec![frame]);
                frame * iters as u32
            })
        });
    }
    g.finish();
}

/// A first-frame variant: name, `irt bench` flags, environment.
type Variant<'a> = (&'a str, &'a [&'a str], &'a [(&'a str, &'a Path)]);

fn first_frame(c: &mut Criterion) {
    let dir = TempDir(std::env::temp_dir().join(format!("irt-bench-process-{}", std::process::id())));
    let (mesa, irt) = (dir.0.join("mesa"), dir.0.join("irt"));
    std::fs::create_dir_all(&mesa).expect("temp dir");
    let off = PathBuf::from("off");
    let warm_env = [("MESA_SHADER_CACHE_DIR", mesa.as_path()), ("IRT_CACHE_DIR", irt.as_path())];
    let variants: [Variant; 3] = [
        ("cold", &["--cold-mesa-only"], &[("IRT_CACHE_DIR", off.as_path())]),
        ("cold_mesa_warm_irt", &["--cold-mesa-only"], &[("IRT_CACHE_DIR", irt.as_path())]),
        ("warm", &[], &warm_env),
    ];
    // Fills both caches of the warm variants.
    irt_bench(&["--frames", "1"], &warm_env, None);
    let mut g = common::group(c, "first_frame");
    for (name, args, env) in cases(&variants) {
        let id = format!("default_512/{name}");
        if !common::wanted(&format!("first_frame/{id}")) {
            continue;
        }
        let args: Vec<&str> = ["--frames", "1"].iter().chain(args).copied().collect();
        g.bench_function(&id, |b| {
            b.iter_custom(|iters| {
                let times: Vec<Duration> =
                    (0..iters).map(|_| irt_bench(&args, env, None).first_frame).collect();
                let total = times.iter().sum();
                common::record(&format!("first_frame/{id}"), 0, default_primitives(), times);
                total
            })
        });
    }
    g.finish();
}

fn main() {
    // A process takes seconds: warm up with one, and let criterion take one per sample.
    let mut c = common::config()
        .warm_up_time(Duration::from_millis(1))
        .measurement_time(Duration::from_secs_f64(common::measurement_secs().min(1.0)))
        .configure_from_args();
    lp_threads(&mut c);
    first_frame(&mut c);
    c.final_summary();
    common::print_summary();
}
