//! Dealt band tiles against tiles in order (issue #11, item 3: balancing lavapipe's threads), the
//! same scene and rays in one process, rounds interleaved; medians and the ratio.
//!
//!     cargo run --release -p irt-tools -- deal ROUNDS SCENE...

use irt::gpu::{AdapterChoice, GpuContext};
use irt::render::{Mode, Schedule, Session, Settings};
use std::time::{Duration, Instant};

pub fn run(args: &[String]) -> anyhow::Result<()> {
    let rounds: usize = args.first().map_or(Ok(9), |a| a.parse())?;
    let ctx = GpuContext::new(&AdapterChoice::from_arg_or_env(None))?;
    let threads = irt::gpu::device::dealing_threads(&ctx);
    println!("{} ({}), dealt to {threads} threads; {rounds} rounds", ctx.info.name, ctx.info.driver_info);
    println!("| scene | in order ms | dealt ms | dealt / in order |");
    println!("| --- | --- | --- | --- |");
    for path in &args[1..] {
        let p = (path != "default").then(|| std::path::PathBuf::from(path));
        let mut scene = irt::io::load_or_default(p.as_deref())?;
        (scene.camera.width, scene.camera.height) = (512, 512);
        let make = |deal| Session::new(&ctx, &scene, Settings { deal: Some(deal), ..Settings::bands() });
        let (mut a, mut b) = (make(0)?, make(threads)?);
        let (fa, fb) = (a.picture(&ctx, &mut |_, _| {}), b.picture(&ctx, &mut |_, _| {}));
        let same = fa.image.pixels == fb.image.pixels;
        let (mut ta, mut tb) = (Vec::new(), Vec::new());
        for _ in 0..rounds {
            let t = Instant::now();
            a.picture(&ctx, &mut |_, _| {});
            ta.push(t.elapsed());
            let t = Instant::now();
            b.picture(&ctx, &mut |_, _| {});
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
        let plain = |deal| Settings { mode, max_samples: 0, deal: Some(deal), ..Settings::default() };
        let mut sessions =
            [Session::new(&ctx, &scene, plain(1))?, Session::new(&ctx, &scene, plain(threads))?];
        let (mut ta, mut tb) = (Vec::new(), Vec::new());
        for k in 0..=rounds {
            for (s, times) in sessions.iter_mut().zip([&mut ta, &mut tb]) {
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
