//! The measurements of docs/distributed.md: `irt render --mpi` against one process, as whole
//! commands (mpirun and all), interleaved round by round so that a drift of the machine's speed
//! touches every configuration alike; medians. Then the farm: N tiles + merge against one render.
//!
//!     cargo run --release -p irt-tools -- distributed [SCENE] [--size WxH] [--samples N]
//!         [--workers 1,2] [--rounds R] [--out-dir docs/distributed]
//!
//! Each worker rank gets LP_NUM_THREADS=1 (one core each); one process runs at 1 thread and at
//! every core. Times are the commands' own: the trace after setup (the workers' devices open and
//! their scene built; a single process's pipelines compiled), so the comparison is of tracing
//! and the traffic, not of process start. The irt binary is the one beside this harness.

use anyhow::{anyhow, bail, Context, Result};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

struct Options {
    scene: Option<String>,
    size: String,
    samples: u32,
    workers: Vec<u32>,
    rounds: usize,
    out_dir: PathBuf,
}

fn parse(args: &[String]) -> Result<Options> {
    let mut o = Options {
        scene: None,
        size: "512x512".into(),
        samples: 8,
        workers: vec![1, 2],
        rounds: 3,
        out_dir: "docs/distributed".into(),
    };
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = || it.next().cloned().ok_or_else(|| anyhow!("{a} needs a value"));
        match a.as_str() {
            "--size" => o.size = value()?,
            "--samples" => o.samples = value()?.parse()?,
            "--rounds" => o.rounds = value()?.parse()?,
            "--out-dir" => o.out_dir = value()?.into(),
            "--workers" => o.workers = value()?.split(',').map(str::parse).collect::<Result<_, _>>()?,
            s if s.starts_with("--") => bail!("unknown option {s}"),
            s => o.scene = Some(s.into()),
        }
    }
    Ok(o)
}

fn irt() -> Result<PathBuf> {
    let exe = std::env::current_exe()?;
    let irt = exe.parent().context("the harness's folder")?.join("irt");
    if !irt.exists() {
        bail!("{} is not built: cargo build --release", irt.display());
    }
    Ok(irt)
}

/// What one run printed: trace seconds and rank 0's traffic during the trace (bytes).
#[derive(Clone, Copy, Default)]
struct Run {
    trace: f64,
    sent: f64,
    received: f64,
    messages: f64,
    /// Rank 0's CPU time over the trace's wall time, in percent of a core.
    lead: f64,
}

/// The number before `unit` in `line`, after `after`.
fn number_before(line: &str, after: &str, unit: &str) -> Option<f64> {
    let rest = &line[line.find(after)? + after.len()..];
    let end = rest.find(unit)?;
    rest[..end].trim().rsplit(' ').next()?.parse().ok()
}

fn run(cmd: &mut Command) -> Result<String> {
    let out = cmd.output().with_context(|| format!("{cmd:?}"))?;
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    if !out.status.success() {
        bail!("{cmd:?} failed:\n{err}");
    }
    Ok(err)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// A configuration of the table: `None` workers is one process with `threads` threads.
#[derive(Clone, Copy)]
struct Config {
    mode: &'static str,
    workers: Option<u32>,
    threads: usize,
}

impl Config {
    fn label(&self) -> String {
        match self.workers {
            None => {
                format!("one process, {} thread{}", self.threads, if self.threads == 1 { "" } else { "s" })
            }
            Some(w) => format!("--mpi, {w} worker{} x 1 thread", if w == 1 { "" } else { "s" }),
        }
    }

    fn run(&self, o: &Options, irt: &Path, out: &Path) -> Result<Run> {
        let mut args: Vec<String> = o.scene.iter().cloned().collect();
        args.extend(
            ["--mode", self.mode, "--size", &o.size, "--samples", &o.samples.to_string()].map(String::from),
        );
        args.extend(["--out".to_string(), out.display().to_string()]);
        match self.workers {
            None => {
                let err = run(Command::new(irt)
                    .arg("render")
                    .args(&args)
                    .env("LP_NUM_THREADS", self.threads.to_string()))?;
                let line = err.lines().find(|l| l.starts_with("wrote")).context("no `wrote` line")?;
                // "… , T s on DEVICE)": the passes after the session's setup.
                let trace = number_before(line, ", ", " s on").context(line.to_string())?;
                Ok(Run { trace, ..Run::default() })
            }
            Some(w) => {
                let err = run(Command::new("mpirun")
                    .args(["--oversubscribe", "-n", &(w + 1).to_string(), "-x", "LP_NUM_THREADS=1"])
                    .arg(irt)
                    .args(["render", "--mpi"])
                    .args(&args)
                    .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
                    .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1"))?;
                let line = err.lines().find(|l| l.contains("traced in")).context("no `traced in` line")?;
                let kib = |after: &str| number_before(line, after, " KiB").map(|k| k * 1024.0);
                Ok(Run {
                    trace: number_before(line, "traced in", " s").context(line.to_string())?,
                    sent: kib("sent").unwrap_or(f64::NAN),
                    received: kib("received").unwrap_or(f64::NAN),
                    messages: number_before(line, "KiB in", " messages").unwrap_or(f64::NAN),
                    lead: number_before(line, "leading on", "%").unwrap_or(f64::NAN),
                })
            }
        }
    }
}

pub fn run_all(args: &[String]) -> Result<()> {
    let o = parse(args)?;
    let irt = irt()?;
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let (w, h) = o.size.split_once('x').context("--size WxH")?;
    let pixels = w.parse::<f64>()? * h.parse::<f64>()? * o.samples as f64;
    std::fs::create_dir_all(&o.out_dir)?;
    let tmp = std::env::temp_dir().join(format!("irt-distributed-{}", std::process::id()));
    std::fs::create_dir_all(&tmp)?;

    let mut configs = Vec::new();
    for mode in ["conventional", "frameless"] {
        configs.push(Config { mode, workers: None, threads: 1 });
        if cores > 1 {
            configs.push(Config { mode, workers: None, threads: cores });
        }
        for &w in &o.workers {
            configs.push(Config { mode, workers: Some(w), threads: 1 });
        }
    }
    let mut runs: Vec<Vec<Run>> = vec![Vec::new(); configs.len()];
    for round in 0..o.rounds {
        for (i, c) in configs.iter().enumerate() {
            eprintln!("round {}/{}: {} {}", round + 1, o.rounds, c.mode, c.label());
            runs[i].push(c.run(&o, &irt, &tmp.join("out.png"))?);
        }
    }

    let scene = o.scene.clone().unwrap_or_else(|| "the default scene".into());
    let mut table = String::new();
    writeln!(
        table,
        "Scene: {scene}, {} pixels, {} samples a pixel; {} rounds interleaved, medians.",
        o.size, o.samples, o.rounds
    )?;
    writeln!(table, "Speed-up against one process at 1 thread of the same mode; efficiency = speed-up / workers (or threads).\n")?;
    writeln!(table, "| mode | configuration | trace (s) | frame (ms) | pixel updates/s (M) | speed-up | efficiency | rank 0 sent / received per frame (KiB) | messages per frame | rank 0 busy |")?;
    writeln!(table, "|---|---|---|---|---|---|---|---|---|---|")?;
    let mut points: Vec<(&str, f64, f64)> = Vec::new();
    for (c, r) in configs.iter().zip(&runs) {
        let trace = median(r.iter().map(|x| x.trace).collect());
        let base = configs
            .iter()
            .zip(&runs)
            .find(|(b, _)| b.mode == c.mode && b.workers.is_none() && b.threads == 1);
        let base = median(base.unwrap().1.iter().map(|x| x.trace).collect());
        let speedup = base / trace;
        let units = c.workers.map_or(c.threads as f64, f64::from);
        let per_frame = |f: fn(&Run) -> f64| median(r.iter().map(f).collect()) / o.samples as f64;
        let traffic = match c.workers {
            Some(_) => format!(
                "{:.0} / {:.0} | {:.0} | {:.0}%",
                per_frame(|x| x.sent) / 1024.0,
                per_frame(|x| x.received) / 1024.0,
                per_frame(|x| x.messages),
                median(r.iter().map(|x| x.lead).collect())
            ),
            None => "— | — | —".into(),
        };
        writeln!(
            table,
            "| {} | {} | {:.3} | {:.1} | {:.2} | {:.2} | {:.0}% | {traffic} |",
            c.mode,
            c.label(),
            trace,
            trace * 1000.0 / o.samples as f64,
            pixels / trace / 1e6,
            speedup,
            100.0 * speedup / units
        )?;
        if let Some(w) = c.workers {
            points.push((c.mode, w as f64, speedup));
        }
    }

    // The farm: N tiles in turn (each a process on every core) + the merge, against one render.
    writeln!(table, "\nThe farm's way: `irt render --tile I/N` per task, one after another on all {cores} cores, then `irt merge`, against one `irt render` (the bands), whole commands:\n")?;
    writeln!(table, "| tiles N | one render (s) | N tiles (s) | merge (s) | tiles + merge / one render |")?;
    writeln!(table, "|---|---|---|---|---|")?;
    let scene_args: Vec<String> =
        o.scene.iter().cloned().chain(["--size".to_string(), o.size.clone()]).collect();
    for n in [2u32, 4, 8] {
        let (mut one, mut tiles, mut merge) = (Vec::new(), Vec::new(), Vec::new());
        for _ in 0..o.rounds {
            let t = Instant::now();
            run(Command::new(&irt).arg("render").args(&scene_args).arg("--out").arg(tmp.join("one.png")))?;
            one.push(t.elapsed().as_secs_f64());
            let dir = tmp.join(format!("tiles-{n}"));
            let _ = std::fs::remove_dir_all(&dir);
            let t = Instant::now();
            for i in 0..n {
                run(Command::new(&irt)
                    .arg("render")
                    .args(&scene_args)
                    .args(["--tile", &format!("{i}/{n}"), "--out"])
                    .arg(&dir))?;
            }
            tiles.push(t.elapsed().as_secs_f64());
            let t = Instant::now();
            run(Command::new(&irt).arg("merge").arg(&dir).arg("--out").arg(tmp.join("merged.png")))?;
            merge.push(t.elapsed().as_secs_f64());
        }
        let (one, tiles, merge) = (median(one), median(tiles), median(merge));
        writeln!(table, "| {n} | {one:.2} | {tiles:.2} | {merge:.2} | {:.2} |", (tiles + merge) / one)?;
    }
    let _ = std::fs::remove_dir_all(&tmp);

    print!("{table}");
    std::fs::write(o.out_dir.join("table.md"), &table)?;
    let max_w = o.workers.iter().copied().max().unwrap_or(1) as f64;
    let path = o.out_dir.join("speedup.svg");
    irt::lab::plot::linear_svg(
        &path,
        &format!("irt --mpi: speed-up over worker ranks ({scene}, {})", o.size),
        (0.0..max_w + 0.5, 0.0..max_w + 0.5),
        ("worker ranks (1 lavapipe thread each)", "speed-up against one process, 1 thread"),
        |chart| {
            use plotters::prelude::*;
            chart
                .draw_series(LineSeries::new([(0.0, 0.0), (max_w, max_w)], BLACK.mix(0.3)))?
                .label("ideal")
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.mix(0.3)));
            for (mode, colour) in [("conventional", &BLUE), ("frameless", &RED)] {
                let pts: Vec<(f64, f64)> =
                    points.iter().filter(|p| p.0 == mode).map(|p| (p.1, p.2)).collect();
                chart.draw_series(LineSeries::new(pts.clone(), colour.stroke_width(2)))?.label(mode).legend(
                    move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2)),
                );
                chart.draw_series(pts.iter().map(|&p| Circle::new(p, 4, colour.filled())))?;
            }
            chart.configure_series_labels().background_style(WHITE).border_style(BLACK).draw()?;
            Ok(())
        },
    )?;
    eprintln!("wrote {} and {}", o.out_dir.join("table.md").display(), path.display());
    Ok(())
}
