//! Writes a synthetic CT volume of the Visible Woman's shape and size (512x512x1734 uint16,
//! 0.33 x 0.33 x 1 mm: 0.85 GiB of samples) as a raw NRRD, for the scale check in
//! docs/volumes.md: a body of soft tissue (1000) around a spine, ribs, a skull and two femurs
//! (bone, 2000), in air (0). Nothing is downloaded; the file is written slice by slice (little
//! memory) and renamed into place once whole.
//!
//!     cargo run --release --example synthetic_volume -- /tmp/woman.nrrd [NX NY NZ]

use std::io::{BufWriter, Write};

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let out = args.next().unwrap_or_else(|| "woman.nrrd".into());
    let dims: Vec<u32> = args.map(|a| a.parse()).collect::<Result<_, _>>()?;
    let [nx, ny, nz] = match dims[..] {
        [] => [512, 512, 1734],
        [x, y, z] => [x, y, z],
        _ => anyhow::bail!("give NX NY NZ or nothing"),
    };
    let tmp = format!("{out}.partial");
    let mut w = BufWriter::with_capacity(1 << 22, std::fs::File::create(&tmp)?);
    // Spacing chosen so the body keeps its proportions at any size: 169 mm across, 1734 mm tall.
    let (sx, sz) = (169.0 / nx as f64, 1734.0 / nz as f64);
    write!(
        w,
        "NRRD0004\n# irt examples/synthetic_volume.rs: a synthetic body of the Visible Woman's size\ntype: uint16\ndimension: 3\nsizes: {nx} {ny} {nz}\nspacings: {sx} {sx} {sz}\nencoding: raw\nendian: little\n\n"
    )?;
    let mut slice = vec![0u16; nx as usize * ny as usize];
    let mut bytes = Vec::with_capacity(slice.len() * 2);
    for k in 0..nz {
        // Height from the feet, 0..1.
        let h = k as f64 / (nz - 1) as f64;
        for j in 0..ny {
            for i in 0..nx {
                // Centred coordinates in mm.
                let x = (i as f64 + 0.5) * sx - 84.5;
                let y = (j as f64 + 0.5) * sx - 84.5;
                slice[(i + nx * j) as usize] = body(x, y, h);
            }
        }
        bytes.clear();
        bytes.extend(slice.iter().flat_map(|v| v.to_le_bytes()));
        w.write_all(&bytes)?;
        if k % 200 == 0 {
            eprintln!("slice {k} of {nz}");
        }
    }
    w.into_inner()?.sync_all()?;
    std::fs::rename(&tmp, &out)?;
    eprintln!(
        "wrote {out}: {nx}x{ny}x{nz} uint16 ({:.2} GiB)",
        (nx as f64 * ny as f64 * nz as f64 * 2.0) / (1u64 << 30) as f64
    );
    Ok(())
}

/// The sample at (x, y) mm across, height fraction h: 0 air, ~1000 tissue, ~2000 bone, with a
/// gentle ramp at each boundary so the field is smooth enough to shade.
fn body(x: f64, y: f64, h: f64) -> u16 {
    let ramp = |d: f64| (0.5 - d / 2.0).clamp(0.0, 1.0); // d: signed distance in mm, inside < 0
    let ellipse = |cx: f64, cy: f64, a: f64, b: f64| {
        let r = ((x - cx) / a).hypot((y - cy) / b);
        (r - 1.0) * a.min(b)
    };
    let (tissue, bone) = if h < 0.47 {
        // Legs, tapering to the feet; a femur in each.
        let a = 18.0 + 40.0 * h;
        let leg = ellipse(-30.0, 0.0, a, a * 0.9).min(ellipse(30.0, 0.0, a, a * 0.9));
        let femur = ellipse(-30.0, 0.0, 9.0, 9.0).min(ellipse(30.0, 0.0, 9.0, 9.0));
        (leg, femur)
    } else if h < 0.86 {
        // Torso: a spine behind, ribs as a shell in the upper half.
        let torso = ellipse(0.0, 0.0, 78.0, 52.0);
        let spine = ellipse(0.0, 35.0, 10.0, 10.0);
        let ribs = if h > 0.68 { (ellipse(0.0, 0.0, 70.0, 45.0)).abs() - 3.0 } else { f64::INFINITY };
        (torso, spine.min(ribs))
    } else if h < 0.89 {
        (ellipse(0.0, 5.0, 28.0, 28.0), ellipse(0.0, 15.0, 8.0, 8.0))
    } else {
        // Head: a skull shell.
        let r = 70.0 * (1.0 - ((h - 0.945) / 0.055).powi(2)).max(0.0).sqrt();
        let head = ellipse(0.0, 0.0, r.max(0.1), (r * 0.85).max(0.1));
        (head, head.abs() - 4.0 - 6.0 * 0.0f64.max(-head.signum()))
    };
    (1000.0 * ramp(tissue) + 1000.0 * ramp(bone)).round() as u16
}
