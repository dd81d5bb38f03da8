//! What tracing a picture in pieces costs (docs/large-models.md, "Large pictures"): a picture
//! that fits the device's frame buffers, rendered whole and with the buffers capped so that it
//! is traced in 4 and 16 pieces, in each mode, side by side in one process (median of 3). A
//! device whose bindings are larger than lavapipe's 128 MiB traces whole what lavapipe must
//! split; this is the price of the split where a device cannot.
//!
//!     cargo run --release -p irt-tools -- pieces [WxH]
use irt::gpu::GpuContext;
use irt::render::session::MIN_BUFFER_RAYS;
use irt::render::{Mode, Session, Settings};
use std::time::{Duration, Instant};

pub fn run(args: &[String]) -> anyhow::Result<()> {
    let [w, h] = match args.first() {
        Some(s) => {
            let (a, b) = s.split_once('x').ok_or_else(|| anyhow::anyhow!("usage: irt-lab pieces [WxH]"))?;
            [a.parse()?, b.parse()?]
        }
        None => [2048u32, 2048],
    };
    let ctx = GpuContext::new(&irt::gpu::AdapterChoice::from_arg_or_env(None))?;
    let mut scene = irt::scene::default_scene();
    (scene.camera.width, scene.camera.height) = (w, h);
    let pixels = w as u64 * h as u64;
    println!("default scene at {w}x{h} on {}; median of 3 renders each", ctx.info.name);
    println!("| mode | whole s | 4 pieces s | ratio | 16 pieces s | ratio |");
    println!("|---|---|---|---|---|---|");
    for (name, mode) in
        [("bands", Mode::Bands), ("conventional", Mode::conventional()), ("frameless", Mode::frameless())]
    {
        let time = |cap: Option<u64>| -> anyhow::Result<f64> {
            let settings = Settings { mode, max_samples: 1, max_buffer_rays: cap, ..Settings::default() };
            let mut s = Session::new(&ctx, &scene, settings)?;
            anyhow::ensure!(cap.is_some() != s.whole(), "{name}: {cap:?} did not give the split asked for");
            s.try_render_image(&ctx, &mut |_, _| {})?; // the first carries the compile
            let mut times: Vec<Duration> = (0..3)
                .map(|_| {
                    let t = Instant::now();
                    s.try_render_image(&ctx, &mut |_, _| {}).map(|_| t.elapsed())
                })
                .collect::<Result<_, _>>()?;
            times.sort();
            Ok(times[1].as_secs_f64())
        };
        let whole = time(None)?;
        let four = time(Some((pixels / 4).max(MIN_BUFFER_RAYS)))?;
        let sixteen = time(Some((pixels / 16).max(MIN_BUFFER_RAYS)))?;
        println!(
            "| {name} | {whole:.2} | {four:.2} | {:.2}x | {sixteen:.2} | {:.2}x |",
            four / whole,
            sixteen / whole
        );
    }
    Ok(())
}
