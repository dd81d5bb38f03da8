//! The particle model of docs/large-models.md, "Particles": writes the stress plate
//! (`irt::io::stress_plate`, about N nodes with `von_mises` and `sigma_xx`) as a binary PLY file
//! of points (little-endian unless `be` or `ascii` follows), to render with `irt render FILE`.
//!
//!     target/release/irt-lab particles write /tmp/plate-35M.ply 35000000
use irt::io::ply::{write_points, Encoding};
use std::time::Instant;

pub fn run(args: &[String]) -> anyhow::Result<()> {
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let ["write", path, nodes, ref options @ ..] = args[..] else {
        anyhow::bail!("usage: irt-lab particles write PATH NODES [le|be|ascii]");
    };
    let encoding = match options {
        [] | ["le"] => Encoding::BinaryLittleEndian,
        ["be"] => Encoding::BinaryBigEndian,
        ["ascii"] => Encoding::Ascii,
        _ => anyhow::bail!("the option is an encoding: le, be or ascii"),
    };
    let start = Instant::now();
    let plate = irt::io::stress_plate::plate(nodes.parse()?);
    // Written beside and renamed, so that a stopped run leaves no half file.
    let part = format!("{path}.part");
    write_points(&plate, encoding, std::fs::File::create(&part)?)?;
    std::fs::rename(&part, path)?;
    println!(
        "wrote {path}: {} particles, {:.1} MB in {:.1} s",
        plate.positions.len(),
        std::fs::metadata(path)?.len() as f64 / 1e6,
        start.elapsed().as_secs_f64()
    );
    Ok(())
}
