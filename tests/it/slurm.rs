//! The render-farm templates on a real Slurm: a single-node cluster (munge, slurmctld, slurmd)
//! started by the test in a folder of its own, on ports nothing else uses, and stopped when the
//! test ends (pass or fail). examples/slurm/submit.sh queues the tile array and the merge after
//! it exactly as a user would; the picture must be `irt render`'s file byte for byte, and a
//! failing array must cancel the merge instead of leaving it pending forever.
//!
//! Needs slurm-wlm and munge (scripts/setup.sh installs them); facts about running them without
//! systemd are in ../shared/DISTRIBUTED.md.

use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

const IRT: &str = env!("CARGO_BIN_EXE_irt");
const SUBMIT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/slurm/submit.sh");

/// A port no one listens on now (the kernel's pick; free again once the listener is dropped).
fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port()
}

fn run(cmd: &mut Command) -> String {
    let out = cmd.output().unwrap_or_else(|e| panic!("{cmd:?}: {e}"));
    assert!(
        out.status.success(),
        "{cmd:?}: {}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn is_root() -> bool {
    run(Command::new("id").arg("-u")).trim() == "0"
}

/// A single-node Slurm whose daemons run in the foreground as the test's children.
struct Slurm {
    dir: PathBuf,
    conf: PathBuf,
    daemons: Vec<Child>,
}

impl Slurm {
    fn start(name: &str) -> Slurm {
        for tool in ["munged", "slurmctld", "slurmd", "sbatch"] {
            let found = Command::new("sh").args(["-c", &format!("command -v {tool}")]).output().unwrap();
            assert!(
                found.status.success(),
                "{tool} is not installed: run scripts/setup.sh (slurm-wlm, munge)"
            );
        }
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("slurm").join(name);
        let _ = std::fs::remove_dir_all(&dir);
        for sub in ["munge", "state", "spool", "log", "work"] {
            std::fs::create_dir_all(dir.join(sub)).unwrap();
        }
        let mut slurm = Slurm { conf: dir.join("slurm.conf"), dir, daemons: Vec::new() };
        slurm.start_munge();
        let d = slurm.dir.display();
        let user = if is_root() {
            "root".to_string()
        } else {
            run(Command::new("id").arg("-un")).trim().to_string()
        };
        let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
        let conf = format!(
            "ClusterName=irttest\nSlurmctldHost=localhost\nSlurmctldPort={}\nSlurmdPort={}\n\
             AuthType=auth/munge\nCredType=cred/munge\nAuthInfo=socket={d}/munge/munge.sock\n\
             SlurmUser={user}\nSlurmdUser={user}\nProctrackType=proctrack/linuxproc\nTaskPlugin=task/none\n\
             SelectType=select/cons_tres\nSelectTypeParameters=CR_CPU\n\
             AccountingStorageType=accounting_storage/none\nJobCompType=jobcomp/none\n\
             JobAcctGatherType=jobacct_gather/none\nMailProg=/bin/true\nMpiDefault=none\n\
             StateSaveLocation={d}/state\nSlurmdSpoolDir={d}/spool\n\
             SlurmctldLogFile={d}/log/slurmctld.log\nSlurmdLogFile={d}/log/slurmd.log\n\
             SlurmctldPidFile={d}/slurmctld.pid\nSlurmdPidFile={d}/slurmd.pid\n\
             SchedulerParameters=batch_sched_delay=0,sched_min_interval=0\nReturnToService=2\n\
             NodeName=localhost NodeAddr=127.0.0.1 CPUs={cpus} RealMemory=1000 State=UNKNOWN\n\
             PartitionName=irttest Nodes=localhost Default=YES MaxTime=INFINITE State=UP\n",
            free_port(),
            free_port(),
        );
        std::fs::write(&slurm.conf, conf).unwrap();
        let ctld = Command::new("slurmctld")
            .args(["-D", "-i", "-f"])
            .arg(&slurm.conf)
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        slurm.daemons.push(ctld);
        let slurmd = Command::new("slurmd")
            .args(["-D", "-N", "localhost", "-f"])
            .arg(&slurm.conf)
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        slurm.daemons.push(slurmd);
        // The node is idle within a second or so of the daemons' start.
        let t = Instant::now();
        loop {
            let out = slurm.cmd("sinfo").args(["-h", "-o", "%T"]).output().unwrap();
            if String::from_utf8_lossy(&out.stdout).trim() == "idle" {
                return slurm;
            }
            assert!(
                t.elapsed() < Duration::from_secs(30),
                "Slurm's node is not idle after 30 s: see {}/log",
                slurm.dir.display()
            );
            std::thread::sleep(Duration::from_millis(200));
        }
    }

    /// munged with a fresh key; as root it runs as the munge user, as munge insists.
    fn start_munge(&mut self) {
        let m = self.dir.join("munge");
        let key = self.dir.join("munge.key");
        run(Command::new("sh").args([
            "-c",
            &format!("head -c 1024 /dev/urandom > '{}' && chmod 400 '{}'", key.display(), key.display()),
        ]));
        let mut cmd = if is_root() {
            for p in [&m, &key] {
                run(Command::new("chown").arg("munge").arg(p));
            }
            run(Command::new("chmod").arg("755").arg(&m));
            let mut c = Command::new("runuser");
            c.args(["-u", "munge", "--", "munged"]);
            c
        } else {
            Command::new("munged")
        };
        cmd.arg("-F")
            .arg(format!("--socket={}/munge.sock", m.display()))
            .arg(format!("--key-file={}", key.display()))
            .arg(format!("--log-file={}/munged.log", m.display()))
            .arg(format!("--pid-file={}/munged.pid", m.display()))
            .arg(format!("--seed-file={}/munged.seed", m.display()))
            .stderr(Stdio::null());
        self.daemons.push(cmd.spawn().unwrap());
        let sock = m.join("munge.sock");
        let t = Instant::now();
        while !sock.exists() {
            assert!(
                t.elapsed() < Duration::from_secs(10),
                "munged did not start: see {}/munged.log",
                m.display()
            );
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    /// A Slurm command against this cluster.
    fn cmd(&self, program: &str) -> Command {
        let mut c = Command::new(program);
        c.env("SLURM_CONF", &self.conf).env("IRT", IRT).current_dir(self.dir.join("work"));
        c
    }

    /// The state of job `id` ("COMPLETED", "PENDING", …).
    fn state(&self, id: &str) -> String {
        let out = run(self.cmd("scontrol").args(["show", "job", id]));
        out.split_whitespace().find_map(|w| w.strip_prefix("JobState=")).unwrap_or("").to_string()
    }

    /// Waits until job `id` has ended and returns its final state.
    fn wait(&self, id: &str, limit: Duration) -> String {
        let t = Instant::now();
        loop {
            let s = self.state(id);
            if !matches!(s.as_str(), "PENDING" | "RUNNING" | "CONFIGURING" | "COMPLETING" | "") {
                return s;
            }
            assert!(t.elapsed() < limit, "job {id} still {s} after {limit:?}");
            std::thread::sleep(Duration::from_millis(200));
        }
    }
}

impl Drop for Slurm {
    fn drop(&mut self) {
        let _ = self.cmd("scancel").args(["--user", run(Command::new("id").arg("-un")).trim()]).output();
        // slurmd, slurmctld, then munged: SIGTERM is their way to stop.
        for d in self.daemons.iter_mut().rev() {
            let _ = Command::new("kill").arg(d.id().to_string()).status();
            let t = Instant::now();
            while d.try_wait().ok().flatten().is_none() && t.elapsed() < Duration::from_secs(5) {
                std::thread::sleep(Duration::from_millis(50));
            }
            let _ = d.kill();
            let _ = d.wait();
        }
    }
}

/// The job ids submit.sh printed: "tiles: job T (array …), merge: job M -> OUT".
fn job_ids(printed: &str) -> (String, String) {
    let ids: Vec<&str> = printed
        .split("job ")
        .skip(1)
        .map(|s| s.split(|c: char| !c.is_ascii_digit()).next().unwrap())
        .collect();
    assert_eq!(ids.len(), 2, "{printed}");
    (ids[0].to_string(), ids[1].to_string())
}

#[test]
fn a_slurm_array_of_tiles_and_its_merge_make_the_render() {
    let slurm = Slurm::start("array");
    let work = slurm.dir.join("work");
    let args = ["--size", "120x90", "--mode", "conventional", "--samples", "2"];
    let printed = run(slurm.cmd(SUBMIT).args(["", "merged.png", "4"]).args(args));
    let (tiles, merge) = job_ids(&printed);
    assert_eq!(slurm.wait(&merge, Duration::from_secs(120)), "COMPLETED", "{printed}");
    assert_eq!(slurm.state(&format!("{tiles}_0")), "COMPLETED");
    let whole = work.join("whole.png");
    run(Command::new(IRT).arg("render").args(args).arg("--out").arg(&whole));
    assert!(
        std::fs::read(&whole).unwrap() == std::fs::read(work.join("merged.png")).unwrap(),
        "the merge differs from the render"
    );
    // Four tiles, each said so in its task's log.
    let logs = std::fs::read_dir(&work).unwrap().filter_map(|e| {
        let name = e.ok()?.file_name().into_string().ok()?;
        name.starts_with("irt-tiles-").then_some(name)
    });
    assert_eq!(logs.count(), 4);

    // A failing array: the merge is cancelled, not left pending, and writes nothing.
    let printed = run(slurm.cmd(SUBMIT).args(["", "broken.png", "2", "--size", "0x0"]));
    let (tiles, merge) = job_ids(&printed);
    assert_eq!(slurm.wait(&format!("{tiles}_1"), Duration::from_secs(60)), "FAILED");
    assert_eq!(slurm.wait(&merge, Duration::from_secs(60)), "CANCELLED");
    assert!(!work.join("broken.png").exists());
}

#[test]
fn the_kubernetes_job_s_tile_count_matches_its_completions() {
    // Not run on a cluster here: the manifest's one invariant, that `--tile I/N` names the
    // job's completion count, is what a user edits by hand.
    let text =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/k8s/tiles-job.yaml")).unwrap();
    let field = |key: &str| -> u32 {
        let line =
            text.lines().find(|l| l.trim_start().starts_with(key)).unwrap_or_else(|| panic!("no {key}"));
        line.split(':').nth(1).unwrap().trim().parse().unwrap()
    };
    let tile =
        text.split("$JOB_COMPLETION_INDEX/").nth(1).expect("the index comes from $JOB_COMPLETION_INDEX");
    let n: u32 = tile.split('"').next().unwrap().parse().unwrap();
    assert_eq!(n, field("completions:"));
    assert!(field("parallelism:") <= n);
    assert!(text.contains("completionMode: Indexed"));
}
