//! Regenerates the tables and plots of docs/interactive.md (`irt::render::study`): run it from
//! the repository root, as `scripts/interactive-table.sh` does:
//!
//!     cargo run --release --example interactive -- --out-dir docs/interactive
use clap::Parser;

#[derive(Parser)]
#[command(
    args_override_self = true,
    about = "The measurements of docs/interactive.md: conventional vs frameless, schedules, orders, slice size, refinement"
)]
struct Cli {
    #[command(flatten)]
    study: irt::render::study::StudyArgs,
}

fn main() -> anyhow::Result<()> {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    irt::render::study::run(Cli::parse().study)
}
