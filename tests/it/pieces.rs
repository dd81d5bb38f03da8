//! Pictures larger than the device's buffers (`render::pieces`): with the buffers capped at
//! `MIN_BUFFER_RAYS`, a picture of four times as many pixels is traced in pieces and must be
//! the picture a session with room for it traces whole, bit for bit, in every mode and order,
//! with progressive samples, split bundle passes and corner rays, on both device paths. The
//! real sizes (4096², where lavapipe's 128 MiB bindings force the pieces) are `farm`'s and
//! `distributed`'s tests through the CLI.
use crate::common;

use irt::gpu::device::Device;
use irt::gpu::GpuError;
use irt::image::Image;
use irt::render::session::MIN_BUFFER_RAYS;
use irt::render::{Mode, PixelOrder, Schedule, Session, Settings};
use irt::scene::{Scene, ShadowMode};

/// 611×397: four pieces of the capped buffers, and neither side a multiple of a tile.
fn scene() -> Scene {
    let mut s = irt::scene::default_scene();
    (s.camera.width, s.camera.height) = (611, 397);
    const { assert!(611 * 397 > 3 * MIN_BUFFER_RAYS) };
    s
}

fn render<D: Device>(ctx: &D, scene: &Scene, settings: Settings) -> Image {
    let mut s = Session::new(ctx, scene, settings).unwrap();
    s.try_render_image(ctx, &mut |_, _| {}).unwrap_or_else(|e| panic!("{e}"))
}

fn assert_same(what: &str, a: &Image, b: &Image) {
    assert_eq!((a.width, a.height), (b.width, b.height), "{what}");
    let diff =
        a.pixels.iter().zip(&b.pixels).filter(|(x, y)| x.map(f32::to_bits) != y.map(f32::to_bits)).count();
    assert_eq!(diff, 0, "{what}: {diff} of {} pixels differ", a.pixels.len());
}

fn frameless(order: PixelOrder, slice: u32, blend: Option<f32>, jitter_pairs: bool) -> Mode {
    Mode::Frameless { order, slice, present_every: 0, blend, jitter_pairs }
}

/// Every mode's picture, whole and in pieces, on `ctx`.
fn assert_pieces_are_whole<D: Device>(ctx: &D, cases: &[(&str, Settings)]) {
    let scene = scene();
    for (name, settings) in cases {
        let whole = render(ctx, &scene, settings.clone());
        let capped = Settings { max_buffer_rays: Some(MIN_BUFFER_RAYS), ..settings.clone() };
        assert_same(name, &render(ctx, &scene, capped), &whole);
    }
}

fn cases() -> Vec<(&'static str, Settings)> {
    let bundle = Some(ShadowMode::Bundle { samples: 32, rotate: true });
    let hilbert = PixelOrder::default();
    vec![
        ("bands", Settings::bands()),
        ("bands, corner rays", Settings { corner_rays: true, ..Settings::bands() }),
        ("bands, split bundle passes", Settings { shadows: bundle, ..Settings::bands() }),
        ("conventional", Settings { mode: Mode::conventional(), ..Settings::default() }),
        (
            "conventional, guided, 3 samples, bundle",
            Settings {
                mode: Mode::Conventional { schedule: Schedule::Guided, workers: 3 },
                max_samples: 3,
                shadows: bundle,
                ..Settings::default()
            },
        ),
        ("frameless", Settings { mode: Mode::frameless(), ..Settings::default() }),
        (
            "frameless, hilbert, 2 samples, odd slice",
            Settings { mode: frameless(hilbert, 9999, None, false), max_samples: 2, ..Settings::default() },
        ),
        (
            "frameless, random (a table larger than the buffer)",
            Settings { mode: frameless(PixelOrder::Random, 4096, None, false), ..Settings::default() },
        ),
        (
            "frameless, dissolve, blend and jitter pairs, 2 samples",
            Settings {
                mode: frameless(PixelOrder::Dissolve, 4096, Some(0.5), true),
                max_samples: 2,
                ..Settings::default()
            },
        ),
        (
            "frameless, hilbert, blend, 2 samples",
            Settings {
                mode: frameless(hilbert, 4096, Some(0.3), false),
                max_samples: 2,
                ..Settings::default()
            },
        ),
        (
            "frameless, adaptive (its first pass: the Hilbert order)",
            Settings {
                mode: frameless(PixelOrder::Adaptive { revisit: 8 }, 4096, None, false),
                max_samples: 1,
                ..Settings::default()
            },
        ),
    ]
}

#[test]
fn a_picture_in_pieces_is_the_whole_picture_bit_for_bit_in_every_mode() {
    assert_pieces_are_whole(&common::gpu(), &cases());
}

#[test]
fn the_ash_path_traces_the_same_pieces() {
    let vk = irt::gpu::vk::VkContext::new(&common::adapter()).expect("lavapipe through ash");
    let cases = cases();
    let some: Vec<_> =
        cases.into_iter().filter(|(n, _)| ["bands", "conventional", "frameless"].contains(n)).collect();
    assert_eq!(some.len(), 3);
    assert_pieces_are_whole(&vk, &some);
}

#[test]
fn interactive_steps_past_the_buffers_say_so_and_do_not_trace() {
    let ctx = common::gpu();
    let settings = Settings { max_buffer_rays: Some(MIN_BUFFER_RAYS), ..Settings::default() };
    let mut s = Session::new(&ctx, &scene(), settings).unwrap();
    assert!(!s.whole());
    match s.try_step(&ctx) {
        Err(GpuError::FrameTooLarge { width: 611, height: 397, most }) => assert_eq!(most, MIN_BUFFER_RAYS),
        other => panic!("expected FrameTooLarge, got {:?}", other.map(|_| ())),
    }
    let words = s.try_read_image(&ctx).unwrap_err().to_string();
    assert!(words.contains("611x397") || words.contains("611×397"), "{words}");
    // The same session still renders the picture, in pieces.
    let image = s.try_render_image(&ctx, &mut |_, _| {}).unwrap();
    assert_eq!((image.width, image.height), (611, 397));
}
