use irt::render::*;
use std::time::Instant;
fn main() {
    let ctx = irt::gpu::GpuContext::new(&irt::gpu::AdapterChoice::Lavapipe).unwrap();
    let args: Vec<String> = std::env::args().collect();
    let (w, h): (u32, u32) = (args[1].parse().unwrap(), args[2].parse().unwrap());
    let mut scene = if args.len() > 4 {
        irt::io::load(std::path::Path::new(&args[4])).unwrap()
    } else {
        irt::scene::default_scene()
    };
    scene.camera.width = w;
    scene.camera.height = h;
    let r = irt::gpu::Renderer::new(&ctx, &scene, Default::default()).unwrap();
    r.render(&ctx, &mut |_, _| {});
    println!("bands: {:?}", r.median_frame_time(&ctx, 3));
    for m in args[3].split(',') {
        let (mode, rest) = m.split_once('/').unwrap();
        let m = if mode == "c" {
            Mode::Conventional { schedule: rest.parse().unwrap(), workers: 0 }
        } else {
            let (o, sl) = rest.split_once('@').unwrap();
            Mode::Frameless {
                order: o.parse().unwrap(),
                slice: sl.parse().unwrap(),
                present_every: 0,
                blend: None,
                jitter_pairs: false,
            }
        };
        let waves: u32 = std::env::var("WAVES").ok().and_then(|v| v.parse().ok()).unwrap_or(4);
        let mut s =
            Session::new(&ctx, &scene, Settings { mode: m, max_samples: 0, waves, ..Default::default() })
                .unwrap();
        s.complete_pass(&ctx);
        let mut ts = vec![];
        for _ in 0..5 {
            let t = Instant::now();
            s.complete_pass(&ctx);
            ts.push(t.elapsed());
        }
        ts.sort();
        println!("{m}: {:?}", ts[2]);
    }
}
