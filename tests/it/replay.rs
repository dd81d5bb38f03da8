//! `irt replay` on lavapipe: a short replay on a tiny image is deterministic on the virtual
//! clock, frameless reaches 90% of the screen sooner than conventional at equal cost, a resting
//! camera has no dynamic error, and both device paths agree. (The command's arguments are
//! tested in src/cli/replay.rs and tests/it/cli.rs.)
use crate::common;

use irt::render::metrics::Clock;
use irt::render::replay::{replay, CameraPath, ReplayOptions, ReplayReport};
use irt::render::{Mode, PixelOrder, Settings};
use std::time::Duration;

/// Three keys in 0.6 s: a swing to the right and a rise.
const PATH: &str = "\
[[key]]
t = 0
eye = [0, 2, 7.8]
look_at = [0, 0.75, -0.3]
fov = 40

[[key]]
t = 0.3
eye = [2.5, 2, 7.3]
look_at = [0, 0.75, -0.3]
fov = 40

[[key]]
t = 0.6
eye = [4, 3, 6]
look_at = [0, 0.75, -0.3]
fov = 40
";

fn tiny_scene() -> irt::scene::Scene {
    let mut s = irt::scene::default_scene();
    (s.camera.width, s.camera.height) = (64, 48);
    s
}

fn frameless(slice: u32) -> Mode {
    Mode::Frameless {
        order: PixelOrder::default(),
        slice,
        present_every: 0,
        blend: None,
        jitter_pairs: false,
    }
}

/// 30 µs per pixel: a 64×48 frame is 92 ms of clock time, several refreshes long.
const CLOCK: Clock = Clock::Virtual { seconds_per_pixel: 30e-6 };

fn run(ctx: &irt::gpu::GpuContext, mode: Mode, path: &CameraPath, error_every: u32) -> ReplayReport {
    let settings = Settings { mode, max_samples: 1, ..Settings::default() };
    let opts = ReplayOptions { clock: CLOCK, error_every, ..ReplayOptions::default() };
    replay(ctx, &tiny_scene(), &settings, path, &opts).unwrap()
}

fn deterministic(r: ReplayReport) -> ReplayReport {
    assert!(r.wall.trace > Duration::ZERO && r.wall.median_s_per_pixel > 0.0);
    r.without_wall_times()
}

#[test]
fn a_virtual_clock_replay_repeats_and_frameless_reaches_the_screen_sooner() {
    let ctx = common::gpu();
    let path = CameraPath::parse_str(PATH, "test path").unwrap();
    let mut latency90 = Vec::new();
    for mode in [frameless(128), Mode::conventional()] {
        let a = run(&ctx, mode, &path, 3);
        let b = run(&ctx, mode, &path, 3);
        let a = deterministic(a);
        assert_eq!(a, deterministic(b), "{mode}: two runs on the virtual clock differ");
        // Every refresh instant of the 0.6 s moves the camera: 36 inputs, all measured.
        assert_eq!((a.latency.inputs, a.latency.unfinished), (36, 0), "{mode}");
        assert!(a.latency.mean.windows(2).all(|w| w[0] <= w[1]), "{mode}: levels in order {:?}", a.latency);
        let e = a.dynamic_error.expect("errors were measured");
        assert!(e.samples >= 10 && e.mean > 0.0, "{mode}: a moving camera shows an error {e:?}");
        let frame = 64.0 * 48.0 * 30e-6;
        match mode {
            Mode::Conventional { .. } => {
                // At its present a frame is as old as its trace; between presents it ages.
                assert!((a.age_at_presents.mean - frame).abs() < 1e-9, "{:?}", a.age_at_presents);
                assert!(a.age_at_refreshes.mean > frame * 1.2, "{:?}", a.age_at_refreshes);
                // The whole screen changes at once.
                assert_eq!(a.latency.mean[0], a.latency.mean[3]);
            }
            Mode::Frameless { .. } | Mode::Bands => {
                assert!(a.age_at_presents.mean < frame * 0.75, "{:?}", a.age_at_presents);
                assert!(a.latency.mean[0] < frame / 2.0, "{:?}", a.latency);
            }
        }
        latency90.push(a.latency.mean[2]);
    }
    assert!(
        latency90[0] < latency90[1],
        "frameless 90% latency {:.1} ms should beat conventional {:.1} ms at equal cost",
        latency90[0] * 1e3,
        latency90[1] * 1e3
    );
}

#[test]
fn a_resting_camera_has_no_dynamic_error() {
    let ctx = common::gpu();
    let rest = "[[key]]\nt = 0\neye = [0, 2, 7.8]\nlook_at = [0, 0.75, -0.3]\n\n[[key]]\nt = 0.2\neye = [0, 2, 7.8]\nlook_at = [0, 0.75, -0.3]\n";
    let path = CameraPath::parse_str(rest, "rest").unwrap();
    for mode in [frameless(1000), Mode::conventional()] {
        let r = run(&ctx, mode, &path, 1);
        // The ideal is this session's own single-sample picture: exactly what is shown.
        let e = r.dynamic_error.unwrap();
        assert_eq!(e.max, 0.0, "{mode}: {e:?}");
        assert_eq!(r.latency.inputs, 0, "{mode}: no input without a camera change");
        assert_eq!(r.steps, 0, "{mode}: nothing to trace after the warm start");
    }
}

/// `irt replay --backend ash`: the same replay on raw Vulkan, on a virtual clock, reports the same
/// presents, ages, latencies and dynamic errors as on wgpu (the session and its ideal images run
/// the same recordings on both paths).
#[test]
fn a_replay_on_ash_reports_what_wgpu_reports() {
    let ctx = common::gpu();
    let vk = irt::gpu::vk::VkContext::new(&common::adapter()).expect("the same adapter through ash");
    let path = CameraPath::parse_str(PATH, "test path").unwrap();
    for mode in [frameless(128), Mode::conventional()] {
        let settings = Settings { mode, max_samples: 1, ..Settings::default() };
        let opts = ReplayOptions { clock: CLOCK, error_every: 2, ..ReplayOptions::default() };
        let a = deterministic(run(&ctx, mode, &path, 2));
        let b = deterministic(replay(&vk, &tiny_scene(), &settings, &path, &opts).unwrap());
        assert!(a.dynamic_error.is_some() && a.presents.len() > 3, "{mode}: something was measured");
        assert_eq!(a, b, "{mode}: the two paths' replays differ");
    }
}
