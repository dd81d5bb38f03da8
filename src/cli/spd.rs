//! `irt spd`: one of Haines' scalable Standard Procedural Databases at any size, as NFF.

use super::args::choices;
use super::check_output_path;
use anyhow::{Context, Result};
use clap::Args;
use irt::io::spd::Generator;
use std::path::PathBuf;

#[derive(Args)]
#[command(after_help = "Examples:\n  irt spd balls --size 6 --out balls_s6.nff   # 597 871 spheres\n  \
irt spd tetra --size 10 --out tetra_s10.nff # 1 048 576 triangles\n  \
irt spd balls --size 7 --out balls_s7.nff   # 5 380 840 spheres, 228 MB\n  irt bench balls_s6.nff --peer native-bvh\n\n\
Sizes 1, 2 and 4 of balls and 4 of tetra are the files in scenes/spd/, byte for byte.")]
pub struct SpdArgs {
    /// Which database.
    #[arg(value_name = "GENERATOR", value_parser = choices(GENERATORS))]
    pub generator: Generator,
    /// SPD's size factor (-s): balls 1-7, tetra 1-11.
    #[arg(long, short, default_value_t = 4)]
    pub size: u32,
    /// NFF file to write (atomically).
    #[arg(long, short)]
    pub out: PathBuf,
}

/// The databases.
const GENERATORS: &[(&str, Generator, &str)] = &[
    (
        "balls",
        Generator::Balls,
        "Sphereflake: a sphere with nine children, recursively; (9^(size+1) - 1) / 8 spheres on a floor",
    ),
    ("tetra", Generator::Tetra, "Sierpinski tetrahedron: 4^size triangles"),
];

pub fn run(args: SpdArgs) -> Result<()> {
    check_output_path(&args.out)?;
    let nff = args.generator.nff(args.size).map_err(anyhow::Error::msg)?;
    irt::image::write_atomic(&args.out, nff.as_bytes())
        .with_context(|| format!("writing {}", args.out.display()))?;
    let unit = if args.generator == Generator::Balls { "spheres" } else { "triangles" };
    let n = args.generator.primitives(args.size).unwrap_or(0);
    eprintln!("wrote {} ({n} {unit}, {} bytes)", args.out.display(), nff.len());
    Ok(())
}
