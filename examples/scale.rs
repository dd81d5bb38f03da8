//! One row of the large-model scale table (docs/large-models.md; scripts/scale-table.sh runs it
//! per size, each in a fresh process): loads a model file, sets it up on the device and renders
//! it at 512², timing each stage, then prints a Markdown row with the peak resident memory.
//! On lavapipe the "device" is this process, so the peak counts the host's copy of the scene
//! and the device's together.
//!
//!     cargo run --release --example scale -- MODEL.ply
use irt::gpu::{GpuContext, RenderOptions, Renderer};
use std::time::Instant;

fn peak_mib() -> f64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    let kib = status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.split_whitespace().next()?.parse::<f64>().ok());
    kib.unwrap_or(f64::NAN) / 1024.0
}

fn main() -> anyhow::Result<()> {
    let path = std::env::args().nth(1).ok_or_else(|| anyhow::anyhow!("usage: scale MODEL"))?;
    let start = Instant::now();
    let mut scene = irt::io::load(std::path::Path::new(&path))?;
    let load = start.elapsed();
    (scene.camera.width, scene.camera.height) = (512, 512);
    let triangles = scene.triangle_count();
    let loaded_mib = peak_mib();
    let ctx = GpuContext::new(&irt::gpu::AdapterChoice::from_arg_or_env(None))?;
    // The table is the grid's (its columns say so); `--accel auto` builds a BVH for these since
    // 2026-12-04, measured apart in docs/large-models.md, "Which accelerator".
    let opts = RenderOptions { accel: irt::accel::AccelChoice::Grid, ..Default::default() };
    let renderer = Renderer::new(&ctx, &scene, opts).map_err(anyhow::Error::msg)?;
    let t = Instant::now();
    renderer.render(&ctx, &mut |_, _| {});
    let first = t.elapsed();
    let total = start.elapsed();
    let frame = renderer.median_frame_time(&ctx, 3);
    let peak = peak_mib();
    let device_mib = renderer.gpu_scene.bytes as f64 / (1 << 20) as f64;
    let ms = |d: std::time::Duration| d.as_secs_f64() * 1e3;
    println!(
        "| {:.2}M | {:.0} | {:.0} | {:.0} | {:.0} | {:.0} | {:.1} | {:.0} | {:.0} | {:.0} | {:.0} |",
        triangles as f64 / 1e6,
        ms(load),
        ms(renderer.timings.grid_build),
        ms(renderer.timings.upload),
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
