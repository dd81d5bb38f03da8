//! Dealt band tiles against tiles in order (issue #11, item 3: balancing lavapipe's threads), the
//! same scene and rays in one process, rounds interleaved; medians and the ratio.
//!
//!     cargo run --release --example deal -- ROUNDS SCENE...

use irt::gpu::{AdapterChoice, GpuContext, RenderOptions, Renderer};
use irt::render::{Mode, Schedule, Session, Settings};
use std::time::{Duration, Instant};

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let rounds: usize = args.first().map_or(Ok(9), |a| a.parse())?;
    let ctx = GpuContext::new(&AdapterChoice::from_arg_or_env(None))?;
    let threads = irt::gpu::backend::dealing_threads(&ctx);
    println!("{} ({}), dealt to {threads} threads; {rounds} rounds", ctx.info.name, ctx.info.driver_info);
    println!("| scene | in order ms | dealt ms | dealt / in order |");
    println!("| --- | --- | --- | --- |");
    for path in &args[1..] {
        let p = (path != "default").then(|| std::path::PathBuf::from(path));
        let mut scene = irt::io::load_or_default(p.as_deref())?;
        (scene.camera.width, scene.camera.height) = (512, 512);
        let make =
            |deal| Renderer::new(&ctx, &scene, RenderOptions { deal: Some(deal), ..Default::default() });
        let (a, b) = (make(0).map_err(anyhow::Error::msg)?, make(threads).map_err(anyhow::Error::msg)?);
        let (fa, fb) = (a.render(&ctx, &mut |_, _| {}), b.render(&ctx, &mut |_, _| {}));
        let same = fa.image.pixels == fb.image.pixels;
        let (mut ta, mut tb) = (Vec::new(), Vec::new());
        for _ in 0..rounds {
            let t = Instant::now();
            a.render(&ctx, &mut |_, _| {});
            ta.push(t.elapsed());
            let t = Instant::now();
            b.render(&ctx, &mut |_, _| {});
            tb.push(t.elapsed());
        }
        let med = |mut v: Vec<Duration>| {
            v.sort();
            v[v.len() / 2].as_secs_f64() * 1e3
        };
        let (ma, mb) = (med(ta), med(tb));
        println!(
            "| {path}{} | {ma:.1} | {mb:.1} | {:.3} |",
            if same { "" } else { " (IMAGES DIFFER)" },
            mb / ma
        );
        // The whole frame in one dispatch (conventional, plain schedule): where a static split
        // of the workgroups gives one thread the top half of the image and the other the bottom.
        let mode = Mode::Conventional { schedule: Schedule::Plain, workers: 0 };
        let mut s = Session::new(&ctx, &scene, Settings { mode, max_samples: 0, ..Settings::default() })
            .map_err(anyhow::Error::msg)?;
        let (mut ta, mut tb) = (Vec::new(), Vec::new());
        for k in 0..=rounds {
            for (deal, times) in [("1", &mut ta), ("", &mut tb)] {
                // Read by `dealing_threads` at each dispatch; lavapipe's pool was made at device
                // creation and keeps its threads (a measuring trick, not a setting).
                std::env::set_var(
                    "LP_NUM_THREADS",
                    if deal.is_empty() { threads.to_string() } else { deal.into() },
                );
                let t = Instant::now();
                s.complete_pass(&ctx);
                if k > 0 {
                    times.push(t.elapsed());
                }
            }
        }
        let (ma, mb) = (med(ta), med(tb));
        println!("| {path}, one dispatch | {ma:.1} | {mb:.1} | {:.3} |", mb / ma);
    }
    Ok(())
}
