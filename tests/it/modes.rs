//! The dispatch modes (src/render): every schedule and pixel order covers every pixel exactly
//! once on the GPU, and the conventional frame, the frameless pass and the headless bands give
//! the same picture bit for bit.
use crate::common;

use irt::gpu::device::{Device, KernelSpec, ModeBuffers};
use irt::gpu::layout::MAX_CHUNK_TILES;
use irt::gpu::layout::{Launch, FRAME_ACCUMULATE, FRAME_WRITE, ORDER_DISSOLVE, ORDER_TABLE};
use irt::gpu::shaders::Variant;
use irt::gpu::Dispatcher;
use irt::image::Image;
use irt::render::modes::{cap_chunks, wave_groups, QUEUE_LOOP_BUDGET, TILE_BUDGET};
use irt::render::order::Dissolve;
use irt::render::schedule::tile_grid;
use irt::render::{Mode, PixelOrder, Schedule, Session, Settings};
use irt::scene::{Scene, ShadowMode};

fn small_default(w: u32, h: u32) -> Scene {
    let mut s = irt::scene::default_scene();
    (s.camera.width, s.camera.height) = (w, h);
    s
}

/// A dispatcher over `scene` whose frame buffer counts visits: every traced pixel adds 1 to
/// its alpha (FRAME_ACCUMULATE on a cleared buffer).
fn counting_dispatcher(ctx: &irt::gpu::GpuContext, scene: &Scene, work: &[u32]) -> Dispatcher {
    let grid = irt::accel::Grid::build(scene);
    let gs = irt::gpu::readback::upload_at(ctx, scene, &grid, scene.camera.eye).unwrap();
    let n = scene.camera.width as u64 * scene.camera.height as u64;
    let modes = ModeBuffers { work_len: work.len() as u64, frame_len: n };
    let d = ctx.compile(&gs, KernelSpec::modes(Variant::for_scene(scene, false), n, modes)).unwrap();
    d.write_work(ctx, work).unwrap();
    d.clear_frame(ctx);
    d
}

fn visit_counts(ctx: &irt::gpu::GpuContext, d: &Dispatcher) -> Vec<u32> {
    d.read_frame(ctx).unwrap().iter().map(|p| p[3] as u32).collect()
}

const COUNT: [u32; 4] = [0, FRAME_WRITE | FRAME_ACCUMULATE, 0, 0];

#[test]
fn tile_queue_covers_every_pixel_once() {
    let ctx = common::gpu();
    for (w, h) in [(1, 1), (33, 3), (100, 37), (257, 129)] {
        let scene = small_default(w, h);
        let [tx, ty] = tile_grid(w, h);
        let tiles = tx * ty;
        for schedule in Schedule::ALL {
            for workers in [1, 2, 7] {
                let b = cap_chunks(&schedule.boundaries(tiles, workers), MAX_CHUNK_TILES);
                let d = counting_dispatcher(&ctx, &scene, &b);
                d.reset_queue(&ctx);
                // The loop budget as the session sets it, and one so small that workgroups stop
                // after a chunk or two: the host's extra waves must still take every tile.
                for (waves, budget) in [(1, QUEUE_LOOP_BUDGET), (3, QUEUE_LOOP_BUDGET), (2, 600)] {
                    d.clear_frame(&ctx);
                    d.reset_queue(&ctx);
                    let groups = wave_groups(tiles, waves);
                    let chunks = b.len() as u32 - 1;
                    let mut runs = 0;
                    while d.read_queue(&ctx).unwrap() < chunks {
                        let tile = Launch {
                            work: [chunks, TILE_BUDGET, tx, budget],
                            sample: COUNT,
                            ..Launch::whole([0; 4])
                        };
                        d.run(&ctx, "render_queue", tile, [groups, 1, 1]).unwrap();
                        runs += 1;
                        assert!(runs <= tiles, "the queue makes no progress");
                    }
                    let counts = visit_counts(&ctx, &d);
                    let bad = counts.iter().filter(|&&c| c != 1).count();
                    assert_eq!(
                        bad, 0,
                        "{w}x{h} {schedule} P={workers} waves={waves}: {bad} pixels not traced exactly once"
                    );
                }
            }
        }
    }
}

#[test]
fn frameless_pass_covers_every_pixel_once() {
    let ctx = common::gpu();
    for (w, h) in [(1, 1), (1, 70), (70, 1), (513, 257)] {
        let scene = small_default(w, h);
        for order in [PixelOrder::default(), PixelOrder::Random, PixelOrder::Dissolve] {
            let n = w as u64 * h as u64;
            let dissolve = (order == PixelOrder::Dissolve).then(|| Dissolve::new(n));
            let work = match &dissolve {
                Some(d) => d.jumps(),
                None => order.table(w, h).unwrap(),
            };
            let d = counting_dispatcher(&ctx, &scene, &work);
            let pass = order.pass_len(w, h);
            for slice in [7u64, 4096] {
                d.clear_frame(&ctx);
                let mut first = 0;
                while first < pass {
                    let len = slice.min(pass - first);
                    let (kind, bits, state) = match &dissolve {
                        Some(dz) => (ORDER_DISSOLVE, dz.bits, dz.state_at(first)),
                        None => (ORDER_TABLE, 0, 0),
                    };
                    let tile = Launch {
                        work: [first as u32, len as u32, kind, bits],
                        sample: [0, COUNT[1], state, 0],
                        ..Launch::whole([0; 4])
                    };
                    d.run(&ctx, "render_slice", tile, [(len as u32).div_ceil(64), 1, 1]).unwrap();
                    first += len;
                }
                let counts = visit_counts(&ctx, &d);
                let bad = counts.iter().filter(|&&c| c != 1).count();
                assert_eq!(bad, 0, "{w}x{h} {order} S={slice}: {bad} pixels not traced exactly once");
            }
        }
    }
}

/// The host sequence of pixels an order visits in one pass.
fn visits(order: PixelOrder, w: u32, h: u32) -> Vec<u32> {
    match order.table(w, h) {
        Some(t) => t,
        None => {
            let n = w as u64 * h as u64;
            let d = Dissolve::new(n);
            let mut s = 1u32;
            let mut out = Vec::new();
            for _ in 0..d.period() {
                if (s as u64) <= n {
                    out.push(s - 1);
                }
                s = d.step(s);
            }
            out
        }
    }
}

/// The fraction of a pass after which every whole 16×16 block of the image has been visited.
fn fraction_until_every_block_is_visited(v: &[u32], w: u32, h: u32) -> f64 {
    let (bx, by) = (w / 16, h / 16);
    let mut touched = vec![false; (bx * by) as usize];
    let mut left = bx * by;
    for (k, &p) in v.iter().enumerate() {
        let (x, y) = (p % w / 16, p / w / 16);
        if x < bx && y < by && !touched[(y * bx + x) as usize] {
            touched[(y * bx + x) as usize] = true;
            left -= 1;
            if left == 0 {
                return (k + 1) as f64 / v.len() as f64;
            }
        }
    }
    1.0
}

#[test]
fn every_order_spreads_over_the_image() {
    // Every 16×16 block is visited early in a pass: the image updates all over, not in a
    // sweep. The orders are seeded, so these fractions are exact, not luck. Random and the
    // dissolve cover every block within a few percent of a pass; the Hilbert order deals
    // 8×8-pixel chunks (its speed on SIMD lanes, docs/interactive.md), 4 to a block, so it
    // needs longer: 0.77 of a pass at 512², 0.87 at 1280×720 when measured, bound 0.9 here.
    for (w, h) in [(512, 512), (1280, 720), (513, 257)] {
        for (order, bound) in
            [(PixelOrder::default(), 0.9), (PixelOrder::Random, 0.05), (PixelOrder::Dissolve, 0.05)]
        {
            let v = visits(order, w, h);
            assert_eq!(v.len(), (w * h) as usize);
            let f = fraction_until_every_block_is_visited(&v, w, h);
            eprintln!("{order} {w}x{h}: every 16x16 block visited after {f:.3} of a pass");
            assert!(f <= bound, "{order} at {w}x{h}: every block visited only after {f:.3} of a pass");
        }
    }
}

fn bands(ctx: &irt::gpu::GpuContext, scene: &Scene) -> Image {
    common::render_gpu(ctx, scene)
}

fn session_image(ctx: &irt::gpu::GpuContext, scene: &Scene, mode: Mode) -> Image {
    let mut s = Session::new(ctx, scene, Settings { mode, ..Settings::default() }).unwrap();
    s.complete_pass(ctx);
    let out = s.read_output(ctx);
    // The queue's workgroups trace many pixels each: their invocations stay below the budget
    // plus one chunk; the slices' below a quarter of the limit, as every headless render.
    let limit = irt::gpu::layout::LAVAPIPE_LOOP_LIMIT;
    assert!(s.max_loop_iterations < limit * 3 / 4, "{mode}: {} loop iterations", s.max_loop_iterations);
    drop(out);
    s.read_image(ctx)
}

fn assert_same(what: &str, a: &Image, b: &Image) {
    assert_eq!((a.width, a.height), (b.width, b.height));
    let diff =
        a.pixels.iter().zip(&b.pixels).filter(|(x, y)| x.map(f32::to_bits) != y.map(f32::to_bits)).count();
    assert_eq!(diff, 0, "{what}: {diff} pixels differ");
}

#[test]
fn every_mode_gives_the_headless_picture_bit_for_bit() {
    let ctx = common::gpu();
    let mut soft = small_default(96, 72);
    soft.trace.shadows = ShadowMode::Bundle { samples: 32, rotate: true };
    // Newell's teapot as 32 Bezier patches: the Newton solve at a leaf in every schedule.
    let mut teapot = irt::io::load(std::path::Path::new("scenes/teapot-patches.obj")).expect("teapot");
    (teapot.camera.width, teapot.camera.height) = (72, 56);
    for (name, scene) in
        [("default", small_default(131, 67)), ("bundle:32 (split passes)", soft), ("teapot patches", teapot)]
    {
        let want = bands(&ctx, &scene);
        for mode in [
            Mode::conventional(),
            Mode::Conventional { schedule: Schedule::Guided, workers: 3 },
            Mode::Conventional { schedule: Schedule::Fixed { tiles: 1 }, workers: 1 },
            Mode::Conventional { schedule: Schedule::Plain, workers: 0 },
            Mode::frameless(),
            Mode::Frameless {
                order: PixelOrder::Random,
                slice: 999,
                present_every: 0,
                blend: None,
                jitter_pairs: false,
            },
            Mode::Frameless {
                order: PixelOrder::Dissolve,
                slice: 4096,
                present_every: 0,
                blend: None,
                jitter_pairs: false,
            },
        ] {
            assert_same(&format!("{name}, {mode}"), &session_image(&ctx, &scene, mode), &want);
        }
    }
}

#[test]
fn a_moved_camera_is_what_the_next_frame_or_pass_shows() {
    let ctx = common::gpu();
    let scene = small_default(120, 90);
    let mut moved = scene.clone();
    moved.camera.eye += glam::DVec3::new(1.5, 0.5, -0.5);
    let still = bands(&ctx, &scene);
    for mode in [Mode::conventional(), Mode::frameless()] {
        let settings = Settings { mode, waves: 4, ..Settings::default() };
        // What the moved camera looks like from this session's upload (positions are relative
        // to the eye the scene was uploaded at, so compare with the same upload).
        let mut fresh = Session::new(&ctx, &scene, settings.clone()).unwrap();
        fresh.set_camera(&ctx, &moved.camera);
        fresh.complete_pass(&ctx);
        let want = fresh.read_image(&ctx);
        let changed = want.pixels.iter().zip(&still.pixels).filter(|(a, b)| a != b).count();
        assert!(changed > want.pixels.len() / 2, "{mode}: the camera moved ({changed} pixels changed)");

        let mut s = Session::new(&ctx, &scene, settings).unwrap();
        // Part of a frame / pass with the old camera, then the camera moves.
        s.step(&ctx);
        s.step(&ctx);
        s.set_camera(&ctx, &moved.camera);
        assert_eq!(s.samples(), 0);
        // Until one whole visit since the change: conventional, the rest of the frame is
        // cancelled and a new one traced; frameless, the slices carry on where they were, each
        // with the new camera, until every pixel has been visited once since the change.
        while s.samples() == 0 {
            s.step(&ctx);
        }
        assert_same(&format!("{mode} after a camera change"), &s.read_image(&ctx), &want);
    }
}

fn rms(a: &Image, b: &Image) -> f64 {
    let s: f64 = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .map(|(x, y)| (0..3).map(|k| (x[k] as f64 - y[k] as f64).powi(2)).sum::<f64>())
        .sum();
    (s / (3 * a.pixels.len()) as f64).sqrt()
}

#[test]
fn refinement_converges_while_the_camera_rests() {
    // Jittered samples add up: the error against a 64-sample picture falls as samples come in,
    // in both modes, and a camera move starts again from one sample.
    let ctx = common::gpu();
    let scene = small_default(96, 72);
    for mode in [Mode::conventional(), Mode::frameless()] {
        let settings = Settings { mode, max_samples: 64, ..Settings::default() };
        let mut s = Session::new(&ctx, &scene, settings.clone()).unwrap();
        let mut images = Vec::new();
        while !s.converged() {
            s.step(&ctx);
            if [1, 4, 16].contains(&s.samples()) && images.len() < s.samples().ilog(4) as usize + 1 {
                images.push(s.read_image(&ctx));
            }
        }
        assert_eq!(s.samples(), 64);
        assert!(s.step(&ctx).idle, "{mode}: nothing to do once converged");
        let converged = s.read_image(&ctx);
        let errors: Vec<f64> = images.iter().map(|i| rms(i, &converged)).collect();
        assert_eq!(errors.len(), 3);
        assert!(errors[0] > 1.5 * errors[1] && errors[1] > 1.5 * errors[2], "{mode}: errors {errors:?}");
        s.set_camera(&ctx, &{
            let mut c = scene.camera.clone();
            c.eye.x += 0.1;
            c
        });
        assert_eq!(s.samples(), 0);
        assert!(!s.converged());
    }
}

#[test]
fn frameless_blend_mixes_old_and_new() {
    // The paper's blending (α = 0.25): after a pass at camera A and a pass at camera B, every
    // pixel is (1 − α)·A + α·B.
    let ctx = common::gpu();
    let scene = small_default(64, 48);
    let mut moved = scene.camera.clone();
    moved.eye.y += 0.7;
    let alpha = 0.25f32;
    let mode = Mode::Frameless {
        order: PixelOrder::default(),
        slice: 500,
        present_every: 0,
        blend: Some(alpha),
        jitter_pairs: false,
    };
    let mut s = Session::new(&ctx, &scene, Settings { mode, ..Settings::default() }).unwrap();
    s.complete_pass(&ctx);
    let a = s.read_image(&ctx);
    let mut only_b =
        Session::new(&ctx, &scene, Settings { mode: Mode::frameless(), ..Settings::default() }).unwrap();
    only_b.set_camera(&ctx, &moved);
    only_b.complete_pass(&ctx);
    let b = only_b.read_image(&ctx);
    s.set_camera(&ctx, &moved);
    s.complete_pass(&ctx);
    let got = s.read_image(&ctx);
    let mut worst = 0f32;
    for ((g, x), y) in got.pixels.iter().zip(&a.pixels).zip(&b.pixels) {
        for k in 0..3 {
            worst = worst.max((g[k] - ((1.0 - alpha) * x[k] + alpha * y[k])).abs());
        }
    }
    // mix() in f32 on values ≤ a few units: a few ulps.
    assert!(worst < 1e-5, "blend off by {worst}");
    assert!(rms(&got, &b) > 1e-3, "the old camera still shows");
}

#[test]
fn live_settings_give_what_a_fresh_session_gives() {
    // Shadow mode (a rebuild), depth and mode switched on a running session: each picture is
    // the one a session made with those settings gives; dropping an override restores the
    // scene's own value.
    let ctx = common::gpu();
    let scene = small_default(80, 60);
    let picture = |settings: &Settings| {
        let mut s = Session::new(&ctx, &scene, settings.clone()).unwrap();
        s.complete_pass(&ctx);
        s.read_image(&ctx)
    };
    let base = Settings { max_samples: 1, ..Settings::default() };
    let mut live = Session::new(&ctx, &scene, base.clone()).unwrap();
    live.complete_pass(&ctx);
    let first = live.read_image(&ctx);
    for settings in [
        Settings { shadows: Some(ShadowMode::Bundle { samples: 4, rotate: true }), ..base.clone() },
        Settings { max_depth: Some(1), ..base.clone() },
        Settings { mode: Mode::conventional(), max_depth: Some(2), ..base.clone() },
        base.clone(),
    ] {
        live.apply(&ctx, settings.clone()).unwrap();
        assert_eq!(live.samples(), 0, "a change restarts refinement");
        live.complete_pass(&ctx);
        assert_same(&format!("live {settings:?}"), &live.read_image(&ctx), &picture(&settings));
    }
    assert_same("back to the start", &live.read_image(&ctx), &first);
}

/// Dealing the band renderer's tiles to the device's threads (`irt::render::Settings::deal`) changes
/// only which workgroup traces which tile: the same picture, bit for bit, for any thread count.
#[test]
fn dealt_tiles_give_the_picture_of_tiles_in_order() {
    let ctx = common::gpu();
    let scene = small_default(131, 67);
    let render = |deal| {
        let opts = irt::render::Settings { deal: Some(deal), ..irt::render::Settings::bands() };
        irt::render::Session::new(&ctx, &scene, opts).unwrap().picture(&ctx, &mut |_, _| {}).image
    };
    let in_order = render(0);
    for threads in [2, 3, 5] {
        assert_same(&format!("dealt to {threads}"), &in_order, &render(threads));
    }
}
