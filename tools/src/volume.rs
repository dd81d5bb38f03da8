//! Volumes at scale (docs/volumes.md): `write` makes a synthetic body the shape of the Visible
//! Woman (an elliptic trunk, a skin, fat, muscle and two leg bones, in 16-bit CT-like numbers)
//! as a raw NRRD, streamed slice by slice; `stats` loads a volume file and builds its
//! macrocells, and says what each took and how many cells an isovalue keeps.
//!
//!     target/release/irt-lab volume write /tmp/woman.nrrd 512 512 1734
//!     target/release/irt-lab volume stats /tmp/woman.nrrd 1200
//!
//! `sweep` renders a volume file at 512² on the default device for each sample brick edge, each
//! macrocell depth and each look (the tables of docs/volumes.md), and then the isovalues one
//! after another in one session, each a uniform-only edit:
//!
//!     target/release/irt-lab volume sweep tests/data/mni152_t1.nii.gz \
//!         bricks=1,2,4,8 levels=0,1,2,3 looks=iso,mip,dvr isos=40,80,150,250 frames=5 rounds=3
use irt::accel::macrocells::Macrocells;
use std::io::Write;
use std::time::Instant;

pub fn run(args: &[String]) -> anyhow::Result<()> {
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    match args[..] {
        ["write", path, nx, ny, nz] => write(path, [nx.parse()?, ny.parse()?, nz.parse()?]),
        ["stats", path, ref isos @ ..] => {
            let isos = isos.iter().map(|s| s.parse::<f32>()).collect::<Result<Vec<_>, _>>()?;
            stats(path, &isos)
        }
        ["sweep", path, ref opts @ ..] => sweep(path, opts),
        _ => anyhow::bail!(
            "usage: irt-lab volume write PATH NX NY NZ | irt-lab volume stats PATH [ISO ...] | \
             irt-lab volume sweep PATH [bricks=1,4] [levels=0,3] [looks=iso,mip,dvr] [isos=A,B] [frames=N] [rounds=N] [size=N]"
        ),
    }
}

/// The body's value at `(x, y, z)` in [-1, 1]² × [0, 1]: air 0, skin 1100, fat 900, muscle
/// 1050, bone 1800 (CT numbers offset by 1024 into uint16).
fn body(x: f64, y: f64, z: f64) -> u16 {
    // The trunk narrows towards the feet and splits into two legs below z = 0.45.
    let legs = z < 0.45;
    let (cx, w) =
        if legs { (if x < 0.0 { -0.3 } else { 0.3 }, 0.22 + 0.2 * z) } else { (0.0, 0.75 - 0.15 * z) };
    let r = (((x - cx) / w).powi(2) + (y / (0.6 * w / 0.75)).powi(2)).sqrt();
    let bone = ((x - cx).powi(2) + y * y).sqrt() < 0.05 && legs;
    match r {
        _ if bone => 1800,
        r if r < 0.80 => 1050,
        r if r < 0.95 => 900,
        r if r < 1.0 => 1100,
        _ => 0,
    }
}

fn write(path: &str, [nx, ny, nz]: [usize; 3]) -> anyhow::Result<()> {
    let start = Instant::now();
    let part = format!("{path}.part");
    let mut out = std::io::BufWriter::with_capacity(1 << 22, std::fs::File::create(&part)?);
    write!(
        out,
        "NRRD0004\n# irt-lab volume write: a synthetic body\ntype: uint16\ndimension: 3\nsizes: {nx} {ny} {nz}\n\
         endian: little\nencoding: raw\nspacings: 0.33 0.33 1.0\n\n"
    )?;
    let mut slice = Vec::with_capacity(nx * ny * 2);
    for k in 0..nz {
        slice.clear();
        for j in 0..ny {
            for i in 0..nx {
                let v = body(
                    2.0 * i as f64 / nx as f64 - 1.0,
                    2.0 * j as f64 / ny as f64 - 1.0,
                    k as f64 / nz as f64,
                );
                slice.extend_from_slice(&v.to_le_bytes());
            }
        }
        out.write_all(&slice)?;
    }
    out.into_inner()?.sync_all()?;
    std::fs::rename(&part, path)?;
    let mb = std::fs::metadata(path)?.len() as f64 / 1e6;
    println!("wrote {path}: {nx}x{ny}x{nz} uint16, {mb:.0} MB in {:.1} s", start.elapsed().as_secs_f64());
    Ok(())
}

fn stats(path: &str, isos: &[f32]) -> anyhow::Result<()> {
    let t = Instant::now();
    let grid = irt::io::volume::load(std::path::Path::new(path))?;
    let load = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let m = Macrocells::build(&grid);
    let build = t.elapsed().as_secs_f64();
    let [x, y, z] = grid.dims;
    let mb = (grid.voxels.len() * grid.voxels.sample_bytes()) as f64 / 1e6;
    let (lo, hi) = grid.range();
    println!("{path}: {x}x{y}x{z} {} ({mb:.0} MB), values {lo}..{hi}", grid.voxels.type_name());
    println!("  load {load:.2} s; macrocells {build:.2} s, {} levels:", m.levels.len());
    for (n, l) in m.levels.iter().enumerate() {
        let [a, b, c] = l.dims;
        let kb = (l.ranges.len() * 8) as f64 / 1e3;
        println!("    level {n}: {a}x{b}x{c} of {} cell(s) a side, {kb:.0} kB", l.span);
    }
    for &iso in isos {
        let shares: Vec<String> = m
            .levels
            .iter()
            .map(|l| {
                let held = l.ranges.iter().filter(|[lo, hi]| *lo <= iso && iso <= *hi).count();
                format!("{:.2}%", 100.0 * held as f64 / l.ranges.len() as f64)
            })
            .collect();
        println!("  iso {iso}: share of each level's cells that hold it: {}", shares.join(", "));
    }
    let hwm = std::fs::read_to_string("/proc/self/status")?
        .lines()
        .find(|l| l.starts_with("VmHWM"))
        .map(|l| l.split_whitespace().nth(1).unwrap_or("?").to_string())
        .unwrap_or_default();
    println!("  peak resident {} MiB", hwm.parse::<u64>().map_or(0, |k| k / 1024));
    Ok(())
}

/// `key=a,b,c` from `opts`, or `default`.
fn list<T>(opts: &[&str], key: &str, default: &[T]) -> anyhow::Result<Vec<T>>
where
    T: Clone + std::str::FromStr,
    T::Err: std::fmt::Display,
{
    let Some(v) = opts.iter().find_map(|o| o.strip_prefix(key)?.strip_prefix('=')) else {
        return Ok(default.to_vec());
    };
    v.split(',').map(|x| x.parse::<T>().map_err(|e| anyhow::anyhow!("{key}={x}: {e}"))).collect()
}

fn sweep(path: &str, opts: &[&str]) -> anyhow::Result<()> {
    use irt::render::{Session, Settings};
    use irt::scene::transfer::Look;
    use irt::scene::volume::Layout;
    if let Some(bad) = opts.iter().find(|o| {
        !["bricks=", "levels=", "looks=", "isos=", "frames=", "size=", "rounds="]
            .iter()
            .any(|k| o.starts_with(k))
    }) {
        anyhow::bail!("unknown option {bad}");
    }
    let bricks: Vec<u32> = list(opts, "bricks", &[1, 2, 4, 8])?;
    let levels: Vec<u32> = list(opts, "levels", &[0, 1, 2, 3])?;
    let looks: Vec<String> = list(opts, "looks", &["iso".to_string(), "mip".into(), "dvr".into()])?;
    let looks =
        looks.iter().map(|l| Look::parse(l).map_err(anyhow::Error::msg)).collect::<Result<Vec<_>, _>>()?;
    let isos: Vec<f64> = list(opts, "isos", &[])?;
    let frames = list(opts, "frames", &[5u32])?[0];
    let size = list(opts, "size", &[512u32])?[0];
    let rounds = list(opts, "rounds", &[1usize])?[0].max(1);

    let mut scene = irt::io::load(std::path::Path::new(path))?;
    (scene.camera.width, scene.camera.height) = (size, size);
    let ctx = irt::gpu::GpuContext::new(&irt::gpu::AdapterChoice::from_arg_or_env(None))?;
    let iso0 = scene.volumes[0].isos[0].value;
    println!(
        "{path} at {size}x{size} on {} ({}), iso {iso0}; medians of {frames} frames, {rounds} round(s)",
        ctx.info.name, ctx.info.driver_info
    );
    // Rounds over every configuration in turn, so that load from other processes falls on all
    // alike; each row is the median over rounds of each round's median frame.
    // (look, brick, levels, set-up s and frame ms of each round, most pixels unlike).
    type Row = (String, u32, u32, Vec<f64>, Vec<f64>, usize);
    let mut rows: Vec<Row> = Vec::new();
    for round in 0..rounds {
        let mut at = 0;
        for &look in &looks {
            let mut first: Option<Vec<[f32; 3]>> = None;
            for &brick in &bricks {
                for &lv in &levels {
                    let mut s = scene.clone();
                    s.volumes[0].switch_look(look);
                    s.volumes[0].layout = Layout { brick, levels: lv }.check().map_err(anyhow::Error::msg)?;
                    let t = Instant::now();
                    let mut session = Session::new(&ctx, &s, Settings::bands())?;
                    let setup = t.elapsed().as_secs_f64();
                    let pixels = session.try_picture(&ctx, &mut |_, _| {})?.image.pixels;
                    let (frame, _) = session.try_median_picture_times(&ctx, frames)?;
                    let reference = first.get_or_insert_with(|| pixels.clone());
                    let unlike = reference.iter().zip(&pixels).filter(|(a, b)| a != b).count();
                    if round == 0 {
                        rows.push((format!("{look:?}").to_lowercase(), brick, lv, vec![], vec![], 0));
                    }
                    let row = &mut rows[at];
                    row.3.push(setup);
                    row.4.push(frame.as_secs_f64() * 1e3);
                    row.5 = row.5.max(unlike);
                    at += 1;
                }
            }
        }
    }
    let median = |v: &[f64]| {
        let mut v = v.to_vec();
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    println!(
        "\n| look | brick | macrocell levels | set-up s | frame ms | pixels unlike the look's first row |"
    );
    println!("| --- | --- | --- | --- | --- | --- |");
    for (look, brick, lv, setup, frame, unlike) in &rows {
        println!("| {look} | {brick} | {lv} | {:.2} | {:.1} | {unlike} |", median(setup), median(frame));
    }
    if !isos.is_empty() {
        let mut session = Session::new(&ctx, &scene, Settings::bands())?;
        println!("\n| isovalue | edit ms | uniform only | frame ms |");
        println!("| --- | --- | --- | --- |");
        for &iso in &isos {
            let mut s = scene.clone();
            s.volumes[0].isos[0].value = iso;
            let report = session.set_scene(&ctx, &s)?;
            let (frame, _) = session.try_median_picture_times(&ctx, frames)?;
            println!(
                "| {iso} | {:.2} | {} | {:.1} |",
                report.total().as_secs_f64() * 1e3,
                report.uniform_only,
                frame.as_secs_f64() * 1e3
            );
        }
    }
    Ok(())
}
