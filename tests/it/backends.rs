//! The two device paths agree: the bands and readback kernels give the same bits on wgpu and on
//! raw Vulkan through ash, and the ash path's failures are messages.
use crate::common;

use common::*;
use glam::DVec3;
use irt::accel::AccelChoice;
use irt::accel::Grid;
use irt::gpu::vk::{self, VkContext, VkError};
use irt::gpu::{AdapterChoice, GpuContext};
use irt::render::{Session, Settings};
use irt::scene::Scene;

fn vk_ctx() -> VkContext {
    VkContext::new(&common::adapter()).expect("lavapipe through ash (or $IRT_ADAPTER)")
}

fn load(path: &str, w: u32, h: u32) -> Scene {
    let mut s = irt::io::load_or_default(Some(std::path::Path::new(path))).expect(path);
    s.camera.width = w;
    s.camera.height = h;
    s
}

/// Renders `scene` with `opts` on both paths and asserts the same pixels (bit for bit), rays and
/// loop meter.
fn assert_same(what: &str, ctx: &GpuContext, vk: &VkContext, scene: &Scene, opts: Settings) {
    let mut a = Session::new(ctx, scene, opts.clone()).expect("wgpu session");
    let fa = a.picture(ctx, &mut |_, _| {});
    let mut b = Session::new(vk, scene, opts).expect("ash session");
    let fb = b.try_picture(vk, &mut |_, _| {}).expect("ash render");
    assert_eq!(a.variant, b.variant, "{what}: variant");
    let bits = |i: &irt::image::Image| i.pixels.iter().flat_map(|p| p.map(f32::to_bits)).collect::<Vec<_>>();
    let (pa, pb) = (bits(&fa.image), bits(&fb.image));
    let differ = pa.iter().zip(&pb).filter(|(x, y)| x != y).count();
    assert_eq!(differ, 0, "{what}: {differ} of {} channels differ", pa.len());
    assert_eq!(fa.rays, fb.rays, "{what}: ray counts");
    assert_eq!((fa.eye_hits, fa.max_loop_iterations), (fb.eye_hits, fb.max_loop_iterations), "{what}");
    // Not a blank image agreeing with a blank image.
    assert!(fa.eye_hits > 0, "{what}: nothing hit");
}

#[test]
fn bands_agree_bit_for_bit() {
    let (ctx, vk) = (gpu(), vk_ctx());
    let counting = Settings { count_rays: true, ..Settings::bands() };
    assert_same("default", &ctx, &vk, &load("scenes/default.toml", 96, 72), counting.clone());
    let grid = Settings { accel: AccelChoice::Grid, ..counting.clone() };
    assert_same("default, grid", &ctx, &vk, &load("scenes/default.toml", 96, 72), grid);
    assert_same("textured", &ctx, &vk, &load("scenes/textured.toml", 80, 60), Settings::bands());
    assert_same("dielectric", &ctx, &vk, &load("scenes/dielectric.toml", 80, 60), counting.clone());
    assert_same("cones", &ctx, &vk, &load("scenes/cones.toml", 64, 48), Settings::bands());
    // Bezier patches: the Newton solve at a leaf, on the BVH and the grid.
    let teapot = load("scenes/teapot-patches.obj", 64, 48);
    assert_same("teapot patches", &ctx, &vk, &teapot, counting.clone());
    let grid = Settings { accel: AccelChoice::Grid, ..Settings::bands() };
    assert_same("teapot patches, grid", &ctx, &vk, &teapot, grid);
    // Split soft-shadow bundles: several passes per band.
    let mut soft = load("scenes/default.toml", 64, 48);
    soft.trace.shadows = "bundle:24".parse().expect("bundle mode");
    soft.lights.iter_mut().for_each(|l| l.radius = 0.4);
    assert_same("default, bundle:24", &ctx, &vk, &soft, counting.clone());
    // SPD at small size: SPD's corner rays, and triangles.
    let spd = Settings { corner_rays: true, count_rays: true, ..Settings::bands() };
    assert_same("balls_s1", &ctx, &vk, &load("scenes/spd/balls_s1.nff", 64, 64), spd);
    assert_same("gears_s1", &ctx, &vk, &load("scenes/spd/gears_s1.nff", 64, 64), Settings::bands());
}

#[test]
fn layered_uber_and_f64_variants_agree() {
    let (ctx, vk) = (gpu(), vk_ctx());
    let s = load("scenes/default.toml", 48, 36);
    // A 2D-array scene texture (layered past 0 rows), the uber-shader, f64 traversal.
    assert_same("layered", &ctx, &vk, &s, Settings { max_scene_rows: Some(0), ..Settings::bands() });
    assert_same("uber", &ctx, &vk, &s, Settings { uber_shader: true, count_rays: true, ..Settings::bands() });
    assert_same("f64", &ctx, &vk, &s, Settings { f64: true, ..Settings::bands() });
}

#[test]
fn readback_kernels_agree() {
    let (ctx, vkc) = (gpu(), vk_ctx());
    let s = scene_of(vec![irt::scene::Sphere { center: DVec3::ZERO, radius: 1.0, material: 0 }], vec![]);
    let grid = Grid::build(&s);
    let (a, b) = (
        crate::common::upload(&ctx, &s, &grid),
        irt::gpu::readback::upload_at(&vkc, &s, &grid, DVec3::ZERO).expect("upload"),
    );
    let mut rng = Rng::new(7);
    let n = 1000;
    // k_sphere: (o, t_min), (d, t_max), (c, r), anchor.
    let mut sphere = Vec::new();
    for _ in 0..n {
        let (c, o) = (rng.vec(-5.0, 5.0), rng.vec(-10.0, 10.0));
        sphere.extend([v4(o, 1e-4), v4((c - o).normalize(), 1e30), v4(c, rng.range(0.1, 3.0)), v4(o, 0.0)]);
    }
    // k_fresnel: (cos, r0, eta, inside).
    let fresnel: Vec<[f32; 4]> = (0..n)
        .map(|i| [rng.f() as f32, rng.range(0.0, 0.2) as f32, rng.range(1.0, 2.5) as f32, (i % 2) as f32])
        .collect();
    for (entry, inputs) in [("k_sphere", &sphere), ("k_fresnel", &fresnel)] {
        let wa = crate::common::run_kernel(&ctx, &a, entry, inputs, n, 1);
        let wb = irt::gpu::readback::run_kernel(&vkc, &b, entry, inputs, n, 1).expect(entry);
        let bits = |v: &[[f32; 4]]| v.iter().flat_map(|p| p.map(f32::to_bits)).collect::<Vec<_>>();
        assert_eq!(bits(&wa), bits(&wb), "{entry}");
        assert!(wa.iter().any(|p| p[0] > 0.0), "{entry}: all zero");
    }
}

#[test]
fn corrupted_spirv_is_rejected_with_a_message() {
    let vk = vk_ctx();
    let src =
        irt::gpu::shaders::compose(irt::gpu::shaders::Program::Render, irt::gpu::shaders::Variant::FULL);
    let (module, info) = irt::gpu::shaders::validate(&src).expect("valid WGSL");
    let good = vk::compile_entry(&module, &info, "render", &vk::spv_options(&vk)).expect("SPIR-V");
    vk.try_pipeline(&good, "render").expect("naga's SPIR-V is accepted");
    // An instruction's opcode half of its first word, past the header (word 5 is the first
    // instruction, an OpCapability).
    let at = 5 + (good[5] >> 16) as usize;
    type Corrupt = Box<dyn Fn(&mut Vec<u32>)>;
    let corruptions: [(&str, Corrupt); 4] = [
        ("magic", Box::new(|w: &mut Vec<u32>| w[0] ^= 1)),
        ("opcode", Box::new(move |w: &mut Vec<u32>| w[at] = (w[at] & 0xffff_0000) | 0xfff0)),
        ("word count", Box::new(move |w: &mut Vec<u32>| w[at] |= 0xffff_0000)),
        ("truncated", Box::new(|w: &mut Vec<u32>| w.truncate(w.len() - 3))),
    ];
    for (what, corrupt) in corruptions {
        let mut words = good.clone();
        corrupt(&mut words);
        match vk.try_pipeline(&words, "render") {
            Err(VkError::Shader(msg)) => assert!(msg.contains("SPIR-V rejected"), "{what}: {msg}"),
            other => panic!("{what}: expected a SPIR-V rejection, got {other:?}"),
        }
    }
    match vk.try_pipeline(&good, "no_such_entry") {
        Err(VkError::Shader(msg)) => assert!(msg.contains("no OpEntryPoint"), "{msg}"),
        other => panic!("a missing entry point: {other:?}"),
    }
}

#[test]
fn unknown_adapter_has_the_wgpu_message() {
    let choice = AdapterChoice::Named("no-such-adapter-42".into());
    let a = GpuContext::new(&choice).expect_err("no such adapter").to_string();
    let b = VkContext::new(&choice).expect_err("no such adapter").to_string();
    assert_eq!(a, b);
    assert!(a.starts_with("no Vulkan adapter matches 'no-such-adapter-42'; available: "), "{a}");
}

/// Binding 1 is a STORAGE_IMAGE descriptor (in the GENERAL layout) because naga writes the
/// scene texture, a read-only `texture_storage_2d<rgba32uint, read>`, as an `OpTypeImage` with
/// Sampled = 2 and format Rgba32ui, read by `OpImageRead`: no sampled image, no sampler.
/// (lavapipe's sampled-image fetch computes every lane's mip level; its storage-image read
/// does not, which is 12-22% of a frame: docs/performance.md, "Scene texture as a storage image".)
#[test]
fn scene_texture_is_a_storage_image_read_without_a_sampler() {
    const RGBA32UI: u32 = 30;
    let vkc = vk_ctx();
    for layered in [false, true] {
        let variant = irt::gpu::shaders::Variant { layered, ..irt::gpu::shaders::Variant::FULL };
        let src = irt::gpu::shaders::compose(irt::gpu::shaders::Program::Render, variant);
        let (module, info) = irt::gpu::shaders::validate(&src).expect("valid WGSL");
        let words = vk::compile_entry(&module, &info, "render", &vk::spv_options(&vkc)).expect("SPIR-V");
        let (mut images, mut reads, mut fetches, mut samplers) = (Vec::new(), 0, 0, 0);
        let mut at = 5;
        while at < words.len() {
            let (count, op) = ((words[at] >> 16) as usize, words[at] & 0xffff);
            match op {
                // OpTypeImage: result, sampled type, dim, depth, arrayed, MS, sampled, format.
                25 => images.push((words[at + 5], words[at + 7], words[at + 8])),
                26 | 27 => samplers += 1,
                95 => fetches += 1,
                98 => reads += 1,
                _ => {}
            }
            at += count;
        }
        assert_eq!(
            images,
            vec![(layered as u32, 2, RGBA32UI)],
            "layered {layered}: (arrayed, sampled, format) of each image type"
        );
        assert_eq!((samplers, fetches), (0, 0), "no sampler types, no sampled fetch");
        assert!(reads > 0, "textureLoad is an OpImageRead");
    }
}

/// The bits of every channel of `i`.
fn bits(i: &irt::image::Image) -> Vec<u32> {
    i.pixels.iter().flat_map(|p| p.map(f32::to_bits)).collect()
}

/// Asserts the same picture (bit for bit) and, for images that should show something, that it
/// is not blank.
fn assert_images(what: &str, a: &irt::image::Image, b: &irt::image::Image) {
    let (pa, pb) = (bits(a), bits(b));
    assert_eq!(pa.len(), pb.len(), "{what}: sizes");
    let differ = pa.iter().zip(&pb).filter(|(x, y)| x != y).count();
    assert_eq!(differ, 0, "{what}: {differ} of {} channels differ", pa.len());
    assert!(a.pixels.iter().any(|p| p.iter().any(|&c| c > 0.0)), "{what}: a blank picture");
}

/// Sessions on both paths, stepped alike: `steps` steps (0: one complete frame or pass), then
/// the frame buffer and the raw
/// output of the last traced pixels compared bit for bit, as are the step reports.
fn assert_sessions_agree(
    what: &str,
    ctx: &GpuContext,
    vk: &VkContext,
    scene: &Scene,
    settings: Settings,
    steps: u32,
) {
    let mut a = Session::new(ctx, scene, settings.clone()).expect("wgpu session");
    let mut b = Session::new(vk, scene, settings.clone()).expect("ash session");
    assert_eq!(a.variant, b.variant, "{what}: variant");
    // How many waves finish a frame of the tile queue depends on how lavapipe's threads raced
    // for it (each workgroup stops at a loop budget): there a step is a whole frame.
    let queue = matches!(settings.mode, irt::render::Mode::Conventional { schedule, .. } if schedule != irt::render::Schedule::Plain);
    for k in 0..steps {
        if queue {
            a.complete_pass(ctx);
            b.try_complete_pass(vk).expect("ash frame");
            continue;
        }
        let (ra, rb) = (a.step(ctx), b.try_step(vk).expect("ash step"));
        let key = |r: &irt::render::StepReport| (r.pixels, r.eye_rays, r.frame_done, r.slice, r.idle);
        assert_eq!(key(&ra), key(&rb), "{what}: step {k}");
    }
    if steps == 0 {
        a.complete_pass(ctx);
        b.try_complete_pass(vk).expect("ash pass");
    }
    assert_eq!(a.samples(), b.samples(), "{what}: samples");
    assert_images(what, &a.read_image(ctx), &b.try_read_image(vk).expect("ash frame buffer"));
    let (oa, ob) = (a.read_output(ctx), b.try_read_output(vk).expect("ash output"));
    // The radiance, bit for bit. The alpha's loop meter only where each invocation's work is
    // fixed: the tile queue's workgroups meter all the tiles they took, which depends on the
    // race too (two wgpu runs differ there as well).
    let channels = if queue { 3 } else { 4 };
    let same = oa.iter().zip(&ob).all(|(x, y)| (0..channels).all(|c| x[c].to_bits() == y[c].to_bits()));
    assert!(same, "{what}: output");
}

#[test]
fn sessions_agree_in_every_mode() {
    use irt::render::{Mode, PixelOrder, Schedule};
    let (ctx, vk) = (gpu(), vk_ctx());
    let scene = load("scenes/default.toml", 131, 67);
    let frameless = |order, slice, blend, jitter_pairs| Mode::Frameless {
        order,
        slice,
        present_every: 0,
        blend,
        jitter_pairs,
    };
    let modes = [
        ("conventional", Mode::conventional(), 3),
        (
            "conventional fixed:1 ×1",
            Mode::Conventional { schedule: Schedule::Fixed { tiles: 1 }, workers: 1 },
            2,
        ),
        ("conventional guided ×3", Mode::Conventional { schedule: Schedule::Guided, workers: 3 }, 2),
        ("conventional plain", Mode::Conventional { schedule: Schedule::Plain, workers: 0 }, 3),
        ("frameless", Mode::frameless(), 2),
        ("frameless random 999", frameless(PixelOrder::Random, 999, None, false), 25),
        ("frameless dissolve 1000", frameless(PixelOrder::Dissolve, 1000, None, false), 20),
        ("frameless blend 0.3", frameless(PixelOrder::default(), 4000, Some(0.3), false), 5),
        ("frameless jitter pairs", frameless(PixelOrder::default(), 4000, None, true), 5),
    ];
    for (name, mode, steps) in modes {
        // Several steps (frameless slices, or whole conventional frames): refinement samples after
        // the first.
        assert_sessions_agree(name, &ctx, &vk, &scene, Settings { mode, ..Settings::default() }, steps);
    }
}

#[test]
fn sessions_agree_in_every_shadow_mode_and_precision() {
    use irt::render::Mode;
    let (ctx, vk) = (gpu(), vk_ctx());
    let base = load("scenes/default.toml", 64, 48);
    for shadows in ["hard", "bundle:32", "bundle:4:fixed", "shell", "shell:smoothstep:product"] {
        for mode in [Mode::conventional(), Mode::frameless()] {
            let settings = Settings {
                mode,
                shadows: Some(shadows.parse().expect("shadow mode")),
                light_radius: Some(0.4),
                ..Settings::default()
            };
            assert_sessions_agree(&format!("{shadows}, {mode}"), &ctx, &vk, &base, settings, 6);
        }
    }
    for (path, w, h) in [
        ("scenes/textured.toml", 48, 36),
        ("scenes/dielectric.toml", 48, 36),
        ("scenes/cones.toml", 48, 36),
        ("scenes/spd/balls_s1.nff", 48, 48),
        ("scenes/spd/gears_s1.nff", 48, 48),
    ] {
        let s = load(path, w, h);
        for f64 in [false, true] {
            let settings = Settings { mode: Mode::frameless(), f64, ..Settings::default() };
            assert_sessions_agree(&format!("{path} f64 {f64}"), &ctx, &vk, &s, settings, 3);
        }
    }
}

/// What the interactive loop changes between steps, alike on both paths: the camera, the render
/// size, a live setting, a material of a new kind (a recompiled kernel taking the frame buffer
/// over), an animated scene's time, and a scene that outgrows its texture (a new image bound in
/// place).
#[test]
fn live_changes_agree() {
    use irt::render::Mode;
    use irt::scene::{Animated, Channel, Interpolation, Motion, Sphere, Stage, Target, Trs};
    let (ctx, vk) = (gpu(), vk_ctx());
    // Diffuse only, so that a metal later needs a kernel with metal compiled in.
    let mut scene = load("scenes/default.toml", 80, 60);
    for m in &mut scene.materials {
        m.kind = irt::scene::MaterialKind::Diffuse { color: DVec3::splat(0.6) };
    }
    for mode in [Mode::conventional(), Mode::frameless()] {
        let settings = Settings { mode, ..Settings::default() };
        let mut a = Session::new(&ctx, &scene, settings.clone()).unwrap();
        let mut b = Session::new(&vk, &scene, settings.clone()).unwrap();
        // Whole frames or passes: how many waves finish a frame of the tile queue depends on
        // how lavapipe's threads raced for it.
        let both = |a: &mut Session, b: &mut Session<VkContext>, passes: u32, what: &str| {
            for _ in 0..passes {
                a.complete_pass(&ctx);
                b.try_complete_pass(&vk).unwrap();
            }
            assert_images(&format!("{mode}: {what}"), &a.read_image(&ctx), &b.try_read_image(&vk).unwrap());
        };
        both(&mut a, &mut b, 3, "start");
        let mut cam = scene.camera.clone();
        cam.eye += DVec3::new(0.4, 0.2, -0.3);
        a.set_camera(&ctx, &cam);
        b.set_camera(&vk, &cam);
        both(&mut a, &mut b, 2, "moved camera");
        a.set_size(&ctx, 40, 30).unwrap();
        b.set_size(&vk, 40, 30).unwrap();
        both(&mut a, &mut b, 2, "smaller");
        let deeper = Settings { max_depth: Some(1), ..settings.clone() };
        a.apply(&ctx, deeper.clone()).unwrap();
        b.apply(&vk, deeper).unwrap();
        both(&mut a, &mut b, 2, "max depth 1");
        let mut edited = a.base_scene().clone();
        edited.materials[0].kind =
            irt::scene::MaterialKind::Metal { color: DVec3::splat(0.9), exponent: 40.0 };
        let (ra, rb) = (a.set_scene(&ctx, &edited).unwrap(), b.set_scene(&vk, &edited).unwrap());
        assert_eq!((ra.recompiled, rb.recompiled), (true, true), "a new kind recompiles on both");
        both(&mut a, &mut b, 1, "recompiled, frame buffer taken over");
        both(&mut a, &mut b, 2, "metal");
    }

    // Animated: the default scene's motions, and a ball that swells past the texture.
    let animated = load("scenes/animated.toml", 64, 48);
    let mut a = Session::new(&ctx, &animated, Settings::default()).unwrap();
    let mut b = Session::new(&vk, &animated, Settings::default()).unwrap();
    for t in [0.0, 0.7, 1.9, 0.2] {
        a.set_time(&ctx, t).unwrap();
        b.set_time(&vk, t).unwrap();
        a.complete_pass(&ctx);
        b.try_complete_pass(&vk).unwrap();
        assert_images(&format!("animated at {t}"), &a.read_image(&ctx), &b.try_read_image(&vk).unwrap());
    }
    let mut grows = load("scenes/default.toml", 48, 36);
    let mut rng = Rng::new(7);
    for _ in 0..20000 {
        let center = rng.vec(-3.0, 3.0) + 3.0 * DVec3::Y;
        grows.spheres.push(Sphere { center, radius: 0.02, material: 1 });
    }
    grows.spheres.push(Sphere { center: 3.0 * DVec3::Y, radius: 0.1, material: 0 });
    let scale = Channel {
        interpolation: Interpolation::Linear,
        times: vec![0.0, 1.0],
        values: vec![DVec3::ONE, DVec3::splat(28.0)],
    };
    let stages = vec![
        Stage::Fixed(glam::DAffine3::from_translation(3.0 * DVec3::Y)),
        Stage::Keyed { translation: None, rotation: None, scale: Some(scale), rest: Trs::default() },
        Stage::Fixed(glam::DAffine3::from_translation(-3.0 * DVec3::Y)),
    ];
    let target = Target::Sphere(grows.spheres.len() as u32 - 1);
    grows.motions.push(Animated { target, motion: Motion { stages } });
    grows.validate().unwrap();
    // The grid's lists grow with the ball (a BVH's nodes keep their number).
    let settings = Settings { mode: Mode::conventional(), accel: AccelChoice::Grid, ..Settings::default() };
    let mut a = Session::new(&ctx, &grows, settings.clone()).unwrap();
    let mut b = Session::new(&vk, &grows, settings).unwrap();
    for (t, grown) in [(1.0, true), (0.0, false)] {
        let (ra, rb) = (a.set_time(&ctx, t).unwrap(), b.set_time(&vk, t).unwrap());
        assert_eq!((ra.reallocated, rb.reallocated), (grown, grown), "texture replaced at {t}");
        a.complete_pass(&ctx);
        b.try_complete_pass(&vk).unwrap();
        assert_images(&format!("grown scene at {t}"), &a.read_image(&ctx), &b.try_read_image(&vk).unwrap());
    }
}

/// Every scene of scenes/ and every SPD scene, small, in both kinds of mode (a conventional
/// frame, a frameless pass), f32 and f64, grid and BVH: the same bits on both paths.
#[test]
fn every_scene_agrees_in_both_modes_and_precisions() {
    use irt::render::Mode;
    let (ctx, vk) = (gpu(), vk_ctx());
    let mut files: Vec<std::path::PathBuf> = ["scenes", "scenes/spd"]
        .iter()
        .flat_map(|d| std::fs::read_dir(d).expect(d).map(|e| e.expect("entry").path()))
        .filter(|p| p.extension().is_some_and(|e| e == "toml" || e == "nff"))
        .collect();
    files.sort();
    assert!(files.len() >= 20, "found only {} scenes", files.len());
    for file in &files {
        let s = load(file.to_str().unwrap(), 40, 30);
        // Each accelerator in each kind of mode and precision, over the scenes.
        let cases = [
            (Mode::conventional(), false, AccelChoice::Grid),
            (Mode::frameless(), false, AccelChoice::Auto),
            (Mode::frameless(), true, AccelChoice::Grid),
            (Mode::conventional(), true, AccelChoice::Bvh),
        ];
        for (mode, f64, accel) in cases {
            let settings = Settings { mode, f64, accel, max_samples: 1, ..Settings::default() };
            let what = format!("{} {mode} f64 {f64} {accel}", file.display());
            assert_sessions_agree(&what, &ctx, &vk, &s, settings, 0);
        }
    }
}

/// The ash path with `options` against the default ash path: the same pixels bit for bit, rays
/// and loop meter, on scenes of every primitive kind.
fn assert_options_keep_the_image(what: &str, options: vk::VkOptions) {
    let (a, b) = (vk_ctx(), VkContext::with_options(&common::adapter(), options).expect(what));
    let counting = Settings { count_rays: true, ..Settings::bands() };
    let spd = Settings { corner_rays: true, count_rays: true, ..Settings::bands() };
    let mut soft = load("scenes/default.toml", 48, 40);
    soft.trace.shadows = "bundle:24".parse().expect("bundle mode");
    soft.lights.iter_mut().for_each(|l| l.radius = 0.4);
    let cases = [
        ("default", load("scenes/default.toml", 80, 60), counting.clone()),
        ("default, bundle:24", soft, counting.clone()),
        ("textured", load("scenes/textured.toml", 64, 48), counting.clone()),
        ("dielectric", load("scenes/dielectric.toml", 64, 48), counting.clone()),
        ("cones", load("scenes/cones.toml", 48, 40), counting),
        ("balls_s1", load("scenes/spd/balls_s1.nff", 48, 48), spd.clone()),
        ("gears_s1", load("scenes/spd/gears_s1.nff", 48, 48), spd),
    ];
    for (name, scene, opts) in cases {
        let fa =
            Session::new(&a, &scene, opts.clone()).expect(name).try_picture(&a, &mut |_, _| {}).expect(name);
        let fb = Session::new(&b, &scene, opts).expect(name).try_picture(&b, &mut |_, _| {}).expect(name);
        let bits =
            |i: &irt::image::Image| i.pixels.iter().flat_map(|p| p.map(f32::to_bits)).collect::<Vec<_>>();
        let (pa, pb) = (bits(&fa.image), bits(&fb.image));
        let differ = pa.iter().zip(&pb).filter(|(x, y)| x != y).count();
        assert_eq!(differ, 0, "{what}, {name}: {differ} of {} channels differ", pa.len());
        assert_eq!(fa.rays, fb.rays, "{what}, {name}: ray counts");
        assert_eq!(fa.max_loop_iterations, fb.max_loop_iterations, "{what}, {name}: loop meter");
        assert!(fa.eye_hits > 0, "{what}, {name}: nothing hit");
    }
}

#[test]
fn robustness_and_index_checks_off_keep_the_image() {
    assert_options_keep_the_image(
        "robust off, index checks off",
        vk::VkOptions { robust: false, index_checks: false, ..Default::default() },
    );
}

#[test]
fn tile_in_push_constants_keeps_the_image() {
    assert_options_keep_the_image("push tile", vk::VkOptions { push_tile: true, ..Default::default() });
}

/// Robustness off changes what naga writes (no index clamps) and what the device was opened with.
#[test]
fn robustness_off_writes_unchecked_spirv() {
    let (on, off) = (
        vk_ctx(),
        VkContext::with_options(
            &common::adapter(),
            vk::VkOptions { robust: false, index_checks: false, ..Default::default() },
        )
        .expect("robust off"),
    );
    let p = |c: &VkContext| vk::spv_options(c).bounds_check_policies;
    use naga::proc::BoundsCheckPolicy::{Restrict, Unchecked};
    assert_eq!((p(&on).index, p(&on).buffer, p(&on).image_load), (Restrict, Unchecked, Unchecked));
    assert_eq!((p(&off).index, p(&off).buffer, p(&off).image_load), (Unchecked, Unchecked, Unchecked));
    let src =
        irt::gpu::shaders::compose(irt::gpu::shaders::Program::Render, irt::gpu::shaders::Variant::FULL);
    let (module, info) = irt::gpu::shaders::validate(&src).expect("valid WGSL");
    let words =
        |c: &VkContext| vk::compile_entry(&module, &info, "render", &vk::spv_options(c)).expect("SPIR-V");
    assert!(words(&off).len() < words(&on).len(), "no index clamps written");
}

/// Timestamps and the compute-invocations query around each dispatch: one sample per dispatch,
/// its invocations the dispatch's workgroups x 64, a frame's the pixels x passes (the image's
/// sides are multiples of the workgroup's), device time within host time.
#[test]
fn profile_counts_every_invocation_of_a_frame() {
    let ctx =
        VkContext::with_options(&common::adapter(), vk::VkOptions { profile: true, ..Default::default() })
            .expect("profile");
    let q = ctx.query_support();
    assert!(q.timestamps && q.invocations, "lavapipe has both: {}", q.describe());
    let mut soft = load("scenes/default.toml", 64, 48);
    soft.trace.shadows = "bundle:24".parse().expect("bundle mode");
    soft.lights.iter_mut().for_each(|l| l.radius = 0.4);
    for scene in [load("scenes/default.toml", 64, 48), soft] {
        let passes = irt::render::modes::passes(&scene).len() as u64;
        // Tiles in order: dealt to the device's threads, a band's workgroups are rounded up to a
        // multiple of the threads (the extra ones exit), which depends on the machine.
        let mut r =
            Session::new(&ctx, &scene, Settings { deal: Some(0), ..Settings::bands() }).expect("renderer");
        ctx.take_samples();
        r.try_picture(&ctx, &mut |_, _| {}).expect("frame");
        let samples = ctx.take_samples();
        // Every band of every pass (64 x 48 is one band of `BAND_PIXELS`).
        let bands = 48u32.div_ceil((irt::render::modes::BAND_PIXELS / 64).max(1)) as u64;
        assert_eq!(samples.len() as u64, bands * passes, "one sample per dispatch");
        for s in &samples {
            assert_eq!(s.entry, "render");
            let groups = s.groups.iter().map(|&g| g as u64).product::<u64>();
            assert_eq!(s.invocations, Some(groups * 64), "{s:?}");
            let device = s.device.expect("timestamps");
            assert!(device > std::time::Duration::ZERO && device <= s.host, "{s:?}");
        }
        let total: u64 = samples.iter().filter_map(|s| s.invocations).sum();
        assert_eq!(total, 64 * 48 * passes, "invocations of a frame, {passes} passes");
    }
    // Without the option nothing is recorded.
    let plain = vk_ctx();
    let mut r =
        Session::new(&plain, &load("scenes/default.toml", 16, 16), Settings::bands()).expect("renderer");
    r.try_picture(&plain, &mut |_, _| {}).expect("frame");
    assert!(plain.take_samples().is_empty());
    assert!(!plain.query_support().timestamps && !plain.query_support().invocations);
}

/// Every variant of the variant table (shaders::Variant::all) gives render SPIR-V that passes
/// the full check (naga reads it back; spirv-val where installed) and that ash makes a pipeline
/// of; the interactive and readback kernels likewise, every entry point, for the uber-variant
/// and its layered and f64 forms.
#[test]
fn every_variant_passes_the_full_check_and_makes_a_pipeline() {
    use irt::gpu::shaders::{compose, validate, Program, Variant};
    let ctx = vk_ctx();
    let options = vk::spv_options(&ctx);
    let mut jobs: Vec<(Program, Variant)> =
        Variant::all().into_iter().map(|v| (Program::Render, v)).collect();
    for kernel in [Program::Modes, Program::Tests] {
        for v in [
            Variant::FULL,
            Variant { layered: true, ..Variant::FULL },
            Variant { f64: true, ..Variant::FULL },
        ] {
            jobs.push((kernel, v));
        }
    }
    let (mut checked, mut unread) = (0, 0);
    for (kernel, v) in jobs {
        let src = compose(kernel, v);
        let (module, info) = validate(&src).expect("valid WGSL");
        for e in &module.entry_points {
            let what = format!("{kernel:?} {v:?} '{}'", e.name);
            let words = vk::compile_entry(&module, &info, &e.name, &options).expect(&what);
            let done = vk::full_check(&words, &e.name).unwrap_or_else(|err| panic!("{what}: {err}"));
            assert_eq!(done.spirv_val, vk::spirv_val_available(), "{what}");
            // naga 30 reads back all of the render kernel; of the others not the workgroup
            // atomic of `render_queue` (validate::naga_cannot_read).
            if kernel == Program::Render {
                assert!(done.naga, "{what}: naga's read-back");
            }
            unread += !done.naga as u32;
            ctx.try_pipeline(&words, &e.name).unwrap_or_else(|err| panic!("{what}: {err}"));
            checked += 1;
        }
    }
    assert!(checked > Variant::all().len(), "{checked} pipelines");
    eprintln!("{checked} pipelines; naga could not read back {unread}");
    if !vk::spirv_val_available() {
        eprintln!("spirv-val is not installed: only naga's read-back ran (apt-get install spirv-tools)");
    }
}

/// A corrupted operand, which the structural check lets through, is rejected by the full check
/// with a message that names the entry point; a pipeline made with the option refuses it too.
#[test]
fn a_corrupted_operand_is_rejected_by_the_full_check() {
    let ctx = vk_ctx();
    let src =
        irt::gpu::shaders::compose(irt::gpu::shaders::Program::Render, irt::gpu::shaders::Variant::FULL);
    let (module, info) = irt::gpu::shaders::validate(&src).expect("valid WGSL");
    let good = vk::compile_entry(&module, &info, "render", &vk::spv_options(&ctx)).expect("SPIR-V");
    vk::full_check(&good, "render").expect("naga's SPIR-V passes");
    // The first OpFAdd (129: result type, result, operand 1, operand 2) and OpTypeFloat (22).
    let find = |op: u32| {
        let mut at = 5;
        while good[at] & 0xffff != op {
            at += (good[at] >> 16) as usize;
        }
        at
    };
    let (fadd, float) = (find(129), find(22));
    let bound = good[3];
    let float_type = good[float + 1];
    type Corrupt = Box<dyn Fn(&mut Vec<u32>)>;
    let corruptions: [(&str, Corrupt); 2] = [
        // An id no instruction defines (the id bound itself).
        ("undefined id", Box::new(move |w: &mut Vec<u32>| w[fadd + 3] = bound)),
        // A defined id of the wrong kind: a type where a value belongs.
        ("type as operand", Box::new(move |w: &mut Vec<u32>| w[fadd + 3] = float_type)),
    ];
    for (what, corrupt) in corruptions {
        let mut words = good.clone();
        corrupt(&mut words);
        vk::check_spirv(&words, "render").expect("the structural check cannot see operands");
        // Each half catches both on its own (spirv-val where installed).
        assert!(vk::naga_check(&words, "render").is_err(), "{what}: naga's read-back");
        assert!(
            !vk::spirv_val_available() || vk::spirv_val_check(&words, "render").is_err(),
            "{what}: spirv-val"
        );
        match vk::full_check(&words, "render") {
            Err(VkError::Shader(msg)) => {
                assert!(msg.contains("SPIR-V rejected (entry point 'render')"), "{what}: {msg}")
            }
            other => panic!("{what}: expected a rejection, got {other:?}"),
        }
    }
    let checked = VkContext::with_options(
        &common::adapter(),
        vk::VkOptions { full_spirv_check: true, ..Default::default() },
    )
    .expect("full check");
    let mut words = good.clone();
    words[fadd + 3] = bound;
    match checked.try_pipeline(&words, "render") {
        Err(VkError::Shader(msg)) => assert!(msg.contains("entry point 'render'"), "{msg}"),
        other => panic!("expected a rejection, got {other:?}"),
    }
}

/// An adapter without shaderFloat64 (forced: lavapipe has it) refuses `--precision f64` with the
/// words of the wgpu path.
#[test]
fn a_missing_f64_feature_has_the_wgpu_message() {
    let ctx = VkContext::with_options(
        &common::adapter(),
        vk::VkOptions { pretend_no_f64: true, ..Default::default() },
    )
    .expect("device");
    assert!(!ctx.has_f64());
    let scene = load("scenes/default.toml", 16, 16);
    let err = match Session::new(&ctx, &scene, Settings { f64: true, ..Settings::bands() }) {
        Err(e) => e.to_string(),
        Ok(_) => panic!("f64 without shaderFloat64 was accepted"),
    };
    assert_eq!(err, irt::gpu::GpuError::NoF64 { adapter: ctx.info.name.clone() }.to_string());
    assert!(err.ends_with("has no f64 shader support (SHADER_F64): use --precision f32"), "{err}");
    // f32 still renders on it.
    Session::new(&ctx, &scene, Settings::bands())
        .expect("f32")
        .try_picture(&ctx, &mut |_, _| {})
        .expect("f32");
}

/// A viewer's session of a large scene on the ash path: the grid first, then the BVH built in
/// the background, adopted by writing only its section into the scene image from a row in the
/// middle (`Device::update_scene_from`), draws what the wgpu path draws, bit for bit, before and after.
#[test]
fn a_background_bvh_written_into_the_ash_scene_image_draws_what_wgpu_draws() {
    use irt::render::{background::BACKGROUND_BVH_ABOVE, Adoption};
    let (ctx, vk) = (gpu(), vk_ctx());
    let model = irt::io::stage::Model {
        meshes: vec![irt::io::shapes::terrain(740, 3, false).into_mesh(0)],
        materials: vec![material("terrain", irt::scene::MaterialKind::Diffuse { color: DVec3::splat(0.8) })],
        textures: vec![],
        motions: vec![],
        ..Default::default()
    };
    let mut scene = irt::io::stage::stage(model);
    (scene.camera.width, scene.camera.height) = (40, 30);
    assert!(scene.primitive_count() > BACKGROUND_BVH_ABOVE);
    let settings = Settings { max_samples: 1, ..Settings::default() };
    let mut a = Session::new_interactive(&ctx, &scene, settings.clone()).unwrap();
    let mut b = Session::new_interactive(&vk, &scene, settings).unwrap();
    let both = |a: &mut Session, b: &mut Session<VkContext>, what: &str| {
        a.complete_pass(&ctx);
        b.try_complete_pass(&vk).unwrap();
        assert_images(what, &a.read_image(&ctx), &b.try_read_image(&vk).unwrap());
    };
    both(&mut a, &mut b, "the grid");
    let started = std::time::Instant::now();
    let (mut ha, mut hb) = (None, None);
    while ha.is_none() || hb.is_none() {
        assert!(started.elapsed().as_secs() < 120, "the background builds never finished");
        ha = ha.or(a.adopt_bvh(&ctx).unwrap());
        hb = hb.or(b.adopt_bvh(&vk).unwrap());
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    assert_eq!((ha, hb), (Some(Adoption::SectionWritten), Some(Adoption::SectionWritten)));
    both(&mut a, &mut b, "the adopted BVH");
}
