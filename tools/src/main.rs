//! `irt-lab`: the timing harnesses behind irt's measurement docs, one subcommand each. They use
//! the library as any caller does (a `render::Session`, a device path); none is part of it.
//!
//!     cargo run --release -p irt-tools -- <HARNESS> [ARGS...]

mod adaptive;
mod backends;
mod deal;
mod dispatch_floor;
mod distributed;
mod particles;
mod pieces;
mod ply_speed;
mod scale;
mod study;
mod vklevers;
mod volume;

use clap::Parser;

/// (name, what it measures, the harness)
type Harness = (&'static str, &'static str, fn(&[String]) -> anyhow::Result<()>);

const HARNESSES: [Harness; 12] = [
    (
        "adaptive",
        "the adaptive frameless order against Hilbert on camera paths: dynamic error, latency, age (docs/adaptive.md)",
        adaptive::run,
    ),
    (
        "backends",
        "wgpu against ash: device open, first frame, frame, tiny dispatch, slices (docs/backends.md)",
        backends::run,
    ),
    (
        "distributed",
        "render --mpi against one process, and tiles + merge against one render (docs/distributed.md)",
        distributed::run_all,
    ),
    ("deal", "bands' tiles dealt to lavapipe's threads against in order (docs/performance.md)", deal::run),
    (
        "dispatch-floor",
        "an empty and a one-write 512² dispatch: the floor under a frame",
        dispatch_floor::run,
    ),
    ("interactive", "the interactive modes' study: tables and plots of docs/interactive.md", interactive),
    ("particles", "write the stress plate's nodes as a PLY file of particles (docs/large-models.md)", particles::run),
    ("pieces", "a picture traced whole against in 4 and 16 pieces, each mode (docs/large-models.md)", pieces::run),
    ("ply-speed", "the PLY reader's speed: write a terrain, read it back (docs/ply.md)", ply_speed::run),
    ("scale", "one row of the large-model scale table (docs/large-models.md)", scale::run),
    ("vklevers", "the ash path's raw-Vulkan levers against the default (docs/backends.md)", vklevers::run),
    ("volume", "write a synthetic 16-bit body as NRRD; load a volume and build its macrocells (docs/volumes.md)", volume::run),
];

#[derive(Parser)]
#[command(
    args_override_self = true,
    about = "The measurements of docs/interactive.md: conventional vs frameless, schedules, orders, slice size, refinement"
)]
struct Study {
    #[command(flatten)]
    study: study::StudyArgs,
}

fn interactive(args: &[String]) -> anyhow::Result<()> {
    let argv = std::iter::once("irt-lab interactive".to_string()).chain(args.iter().cloned());
    study::run(Study::parse_from(argv).study)
}

fn main() {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = || {
        let list: Vec<String> = HARNESSES.iter().map(|(n, what, _)| format!("  {n:<15} {what}")).collect();
        format!("usage: irt-lab <HARNESS> [ARGS...]\n\nharnesses:\n{}", list.join("\n"))
    };
    let Some(name) = args.first() else {
        eprintln!("{}", usage());
        std::process::exit(2);
    };
    let Some((_, _, run)) = HARNESSES.iter().find(|(n, ..)| n == name) else {
        eprintln!("error: no harness '{name}'\n\n{}", usage());
        std::process::exit(2);
    };
    if let Err(e) = run(&args[1..]) {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}
