//! The SIMD counters (`Variant::simd_stats`, `irt bench --simd`): per loop, lane-iterations a
//! lane was active in and iterations its SIMD group ran. Checked against the loop meter (the
//! same `loop_tick` advances it, but it leaves through each pixel's output alpha and is summed on
//! the host, where the counters go through the stats buffer's 64-bit atomics), against an
//! all-miss frame whose value is known exactly, and across the two device paths.
use crate::common;

use irt::accel::AccelChoice;
use irt::gpu::device::Device;
use irt::gpu::vk::VkContext;
use irt::render::Session;
use irt::scene::Scene;

fn load(path: &str, w: u32, h: u32) -> Scene {
    let mut s = irt::io::load_or_default(Some(std::path::Path::new(path))).expect(path);
    (s.camera.width, s.camera.height) = (w, h);
    s
}

fn counting(accel: AccelChoice) -> irt::render::Settings {
    irt::render::Settings { simd_stats: true, accel, ..irt::render::Settings::bands() }
}

#[test]
fn lane_iterations_are_the_loop_meter_and_groups_bound_them() {
    let ctx = common::gpu();
    let size = ctx.subgroup_size().expect("lavapipe has subgroup operations and one group size");
    for (what, path, accel) in [
        ("default, BVH", "scenes/default.toml", AccelChoice::Bvh),
        ("default, grid", "scenes/default.toml", AccelChoice::Grid),
        ("tetra_s4, BVH", "scenes/spd/tetra_s4.nff", AccelChoice::Bvh),
        ("balls_s2, grid", "scenes/spd/balls_s2.nff", AccelChoice::Grid),
    ] {
        let (w, h) = (96, 72);
        let scene = load(path, w, h);
        let mut r = Session::new(&ctx, &scene, counting(accel)).expect("renderer");
        assert!(r.variant.simd_stats, "{what}");
        let f = r.picture(&ctx, &mut |_, _| {});
        // Every tracing loop's `loop_tick` advances the meter and one counter: their lanes sum to it.
        let lanes: u64 = f.rays.simd.iter().map(|c| c.lane_iterations).sum();
        let meter = (f.loops.mean * (w * h) as f64).round() as u64;
        assert_eq!(lanes, meter, "{what}: lane-iterations against the loop meter");
        let mut run = 0;
        for (name, c) in irt::gpu::layout::SIMD_LOOPS.iter().zip(&f.rays.simd) {
            // A group runs an iteration for at least one lane and at most `size`.
            assert!(c.group_iterations <= c.lane_iterations, "{what}, {name}: {c:?}");
            assert!(c.lane_iterations <= c.group_iterations * size as u64, "{what}, {name}: {c:?}");
            run += c.group_iterations * size as u64;
        }
        assert!(f.rays.simd[0].lane_iterations > 0, "{what}: the walk ran");
        // The meter's occupancy is an upper bound (one block's loops counted as one loop).
        let exact = lanes as f64 / run as f64;
        assert!(exact <= f.loops.occupancy + 1e-12, "{what}: {exact} above the bound {}", f.loops.occupancy);
        assert!(exact > 0.5, "{what}: coherent eye rays, yet {exact}");
    }
}

/// The camera turned away from everything: each eye ray tests the BVH's root box once and
/// misses, so every walk iteration has all lanes of its group active, one group iteration per
/// `size` pixels, and no light is looked at.
#[test]
fn an_all_miss_frame_keeps_every_lane_busy() {
    let ctx = common::gpu();
    let size = ctx.subgroup_size().expect("subgroups") as u64;
    let mut scene = load("scenes/diffuse.toml", 64, 48);
    scene.camera.look_at = glam::DVec3::new(0.0, 1.6, 12.0);
    let mut r = Session::new(&ctx, &scene, counting(AccelChoice::Bvh)).expect("renderer");
    let f = r.picture(&ctx, &mut |_, _| {});
    assert_eq!(f.eye_hits, 0);
    let pixels = 64 * 48;
    let [walk, candidates, tree, lights] = f.rays.simd;
    assert_eq!((walk.lane_iterations, walk.group_iterations), (pixels, pixels / size));
    assert_eq!((tree.lane_iterations, tree.group_iterations), (pixels, pixels / size));
    assert_eq!((candidates.group_iterations, lights.group_iterations), (0, 0));
    assert_eq!(walk.efficiency(size as u32), Some(1.0));
    assert_eq!(lights.efficiency(size as u32), None);
}

/// The counters change no pixel, and the ash path counts what wgpu counts.
#[test]
fn counters_leave_the_image_alone_and_agree_across_paths() {
    let ctx = common::gpu();
    let vk = VkContext::new(&common::adapter()).expect("the same adapter through ash");
    assert_eq!(vk.subgroup_size(), ctx.subgroup_size());
    let scene = load("scenes/default.toml", 64, 48);
    let mut plain = Session::new(&ctx, &scene, irt::render::Settings::bands()).expect("renderer");
    let mut with = Session::new(&ctx, &scene, counting(AccelChoice::Auto)).expect("renderer");
    let a = plain.picture(&ctx, &mut |_, _| {});
    let b = with.picture(&ctx, &mut |_, _| {});
    let bits = |i: &irt::image::Image| i.pixels.iter().flat_map(|p| p.map(f32::to_bits)).collect::<Vec<_>>();
    assert_eq!(bits(&a.image), bits(&b.image), "the counters changed the image");
    assert_eq!(a.rays.simd, [irt::gpu::SimdCount::default(); 4], "a plain pipeline counts nothing");
    let mut c = Session::new(&vk, &scene, counting(AccelChoice::Auto)).expect("ash renderer");
    let c = c.try_picture(&vk, &mut |_, _| {}).expect("ash render");
    assert_eq!(b.rays.simd, c.rays.simd, "wgpu and ash counters");
}
