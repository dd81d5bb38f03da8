//! wgpu against ash on the same device, in one process, rounds interleaved (so load from other
//! processes falls on both alike): per-dispatch overhead and frame time, medians. The numbers of
//! docs/backends.md.
//!
//!     cargo run --release -p irt-tools -- backends [SCENE] [ROUNDS] [DISPATCHES_PER_ROUND]
//!
//! Then frameless slices of S = 1 K … 256 K pixels on both paths (`render::Session`, the same
//! code on each): the wall time per slice, dispatch + submit + wait included, and the pixels per
//! second it leaves.

use irt::gpu::device::{Device, KernelSpec};
use irt::gpu::recording::dispatch_overhead;
use irt::gpu::vk::VkContext;
use irt::gpu::{AdapterChoice, GpuContext};
use irt::render::{Session, Settings};
use std::time::{Duration, Instant};

fn median(mut v: Vec<Duration>) -> f64 {
    v.sort();
    v[v.len() / 2].as_secs_f64() * 1e3
}

pub fn run(args: &[String]) -> anyhow::Result<()> {
    let path = args.first().filter(|a| *a != "default").map(std::path::PathBuf::from);
    let rounds: usize = args.get(1).map_or(Ok(7), |a| a.parse())?;
    let per_round: u32 = args.get(2).map_or(Ok(200), |a| a.parse())?;
    let mut scene = irt::io::load_or_default(path.as_deref())?;
    (scene.camera.width, scene.camera.height) = (512, 512);
    let choice = AdapterChoice::from_arg_or_env(None);

    let t = Instant::now();
    let ctx = GpuContext::new(&choice)?;
    let open_w = t.elapsed();
    let t = Instant::now();
    let vk = VkContext::new(&choice)?;
    let open_a = t.elapsed();
    // The first instance of a process loads the Vulkan loader and driver; open wgpu again, now
    // warm like ash was, to compare like with like.
    let t = Instant::now();
    drop(GpuContext::new(&choice)?);
    let open_w_warm = t.elapsed();

    let t = Instant::now();
    let mut w = Session::new(&ctx, &scene, Settings::bands())?;
    let fw = w.picture(&ctx, &mut |_, _| {});
    let first_w = t.elapsed();
    let t = Instant::now();
    let mut a = Session::new(&vk, &scene, Settings::bands())?;
    let fa = a.try_picture(&vk, &mut |_, _| {})?;
    let first_a = t.elapsed();
    let same = fw.image.pixels.iter().flatten().map(|x| x.to_bits()).eq(fa
        .image
        .pixels
        .iter()
        .flatten()
        .map(|x| x.to_bits()));

    let input = [[0.5f32, 0.04, 1.5, 0.0]];
    let dw = ctx.compile(w.device_scene(), KernelSpec::tests(&input, 1))?;
    let da = vk.compile(a.device_scene(), KernelSpec::tests(&input, 1))?;
    let (kw, ka) = (ctx.bind(&dw), vk.bind(&da));
    let (mut frame_w, mut frame_a, mut disp_w, mut disp_a) = (vec![], vec![], vec![], vec![]);
    for _ in 0..rounds {
        let t = Instant::now();
        w.picture(&ctx, &mut |_, _| {});
        frame_w.push(t.elapsed());
        let t = Instant::now();
        a.try_picture(&vk, &mut |_, _| {})?;
        frame_a.push(t.elapsed());
        disp_w.push(dispatch_overhead(&kw, "k_fresnel", per_round)?);
        disp_a.push(dispatch_overhead(&ka, "k_fresnel", per_round)?);
    }
    println!(
        "scene {} at 512x512 on {} ({}); {rounds} rounds, {per_round} tiny dispatches each; images identical: {same}",
        path.as_deref().map_or("default".into(), |p| p.display().to_string()),
        ctx.info.name,
        ctx.info.driver_info
    );
    println!("| | wgpu | ash |");
    println!("| --- | --- | --- |");
    let ms = |d: Duration| d.as_secs_f64() * 1e3;
    println!("| device open, first in the process (ms) | {:.1} | |", ms(open_w));
    println!("| device open, loader and driver loaded (ms) | {:.1} | {:.1} |", ms(open_w_warm), ms(open_a));
    println!("| setup + first frame (ms) | {:.0} | {:.0} |", ms(first_w), ms(first_a));
    println!("| frame, median (ms) | {:.1} | {:.1} |", median(frame_w), median(frame_a));
    println!(
        "| tiny dispatch, median of medians (µs) | {:.1} | {:.1} |",
        median(disp_w) * 1e3,
        median(disp_a) * 1e3
    );
    slices(&ctx, &vk, &scene, rounds)
}

/// Frameless slices per size on both paths, rounds interleaved: each round traces one pass (the
/// whole image) on each path in slices of S pixels, after a warm-up pass.
fn slices(ctx: &GpuContext, vk: &VkContext, scene: &irt::scene::Scene, rounds: usize) -> anyhow::Result<()> {
    use irt::render::{Mode, PixelOrder};
    println!();
    println!("| slice S (pixels) | wgpu ms / slice | ash ms / slice | wgpu Mpixels/s | ash Mpixels/s | ash / wgpu time |");
    println!("| --- | --- | --- | --- | --- | --- |");
    for slice in [1024u32, 4096, 16384, 65536, 262144] {
        let mode = Mode::Frameless {
            order: PixelOrder::default(),
            slice,
            present_every: 0,
            blend: None,
            jitter_pairs: false,
        };
        // No sample limit: every pass traces the whole image again (jittered after the first).
        let settings = Settings { mode, max_samples: 0, ..Settings::default() };
        let mut w = Session::new(ctx, scene, settings.clone())?;
        let mut a = Session::new(vk, scene, settings)?;
        w.complete_pass(ctx);
        a.try_complete_pass(vk)?;
        let (mut tw, mut ta) = (vec![], vec![]);
        let slices_per_pass = w.pass_len().div_ceil(slice as u64) as u32;
        for _ in 0..rounds {
            let t = Instant::now();
            w.complete_pass(ctx);
            tw.push(t.elapsed() / slices_per_pass);
            let t = Instant::now();
            a.try_complete_pass(vk)?;
            ta.push(t.elapsed() / slices_per_pass);
        }
        let (mw, ma) = (median(tw), median(ta));
        let rate = |ms: f64| slice.min(w.pass_len() as u32) as f64 / (ms * 1e3);
        println!("| {slice} | {mw:.2} | {ma:.2} | {:.2} | {:.2} | {:.2} |", rate(mw), rate(ma), ma / mw);
    }
    Ok(())
}
