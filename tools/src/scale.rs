//! One row of the large-model scale table (docs/large-models.md; scripts/scale-table.sh runs it
//! per size, each in a fresh process): loads a model file, sets it up on the device and renders
//! it at 512², timing each stage, then prints a Markdown row with the peak resident memory.
//! On lavapipe the "device" is this process, so the peak counts the host's copy of the scene
//! and the device's together.
//!
//!     cargo run --release -p irt-tools -- scale MODEL.ply
use irt::gpu::GpuContext;
use irt::render::{Session, Settings};
use std::time::Instant;

fn peak_mib() -> f64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    let kib = status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.split_whitespace().next()?.parse::<f64>().ok());
    kib.unwrap_or(f64::NAN) / 1024.0
}

pub fn run(args: &[String]) -> anyhow::Result<()> {
    let path = args.first().ok_or_else(|| anyhow::anyhow!("usage: irt-lab scale MODEL"))?;
    let start = Instant::now();
    let mut scene = irt::io::load(std::path::Path::new(&path))?;
    let load = start.elapsed();
    (scene.camera.width, scene.camera.height) = (512, 512);
    let triangles = scene.triangle_count();
    let loaded_mib = peak_mib();
    let ctx = GpuContext::new(&irt::gpu::AdapterChoice::from_arg_or_env(None))?;
    // The table is the grid's (its columns say so); `--accel auto` builds a BVH for these since
    // 2026-12-04, measured apart in docs/large-models.md, "Which accelerator".
    let settings = Settings { accel: irt::accel::AccelChoice::Grid, ..Settings::bands() };
    let mut session = Session::new(&ctx, &scene, settings)?;
    let t = Instant::now();
    session.picture(&ctx, &mut |_, _| {});
    let first = t.elapsed();
    let total = start.elapsed();
    let (frame, _) = session.try_median_picture_times(&ctx, 3)?;
    let peak = peak_mib();
    let device_mib = session.device_scene().bytes as f64 / (1 << 20) as f64;
    let ms = |d: std::time::Duration| d.as_secs_f64() * 1e3;
    println!(
        "| {:.2}M | {:.0} | {:.0} | {:.0} | {:.0} | {:.0} | {:.1} | {:.0} | {:.0} | {:.0} | {:.0} |",
        triangles as f64 / 1e6,
        ms(load),
        ms(session.setup_timings().accel_build),
        ms(session.setup_timings().upload),
        ms(first),
        ms(frame),
        total.as_secs_f64(),
        loaded_mib,
        device_mib,
        peak,
        peak * (1 << 20) as f64 / triangles as f64,
    );
    Ok(())
}
