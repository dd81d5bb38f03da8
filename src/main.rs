//! `irt`: the command-line front end. Library errors become messages and exit codes here; each
//! command lives in its own module under `cli/`.

mod cli;

use clap::Parser;

fn main() {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    if let Err(e) = cli::Cli::parse().command.run() {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}
