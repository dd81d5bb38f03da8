//! Frame time and Mrays/s on the device (docs/performance.md, *Benches*):
//! - `ray_kind`: eye only, eye + shadow (the primary-shadow workload), full (the scene's own
//!   settings) on the default scene and two SPD scenes at 256² and 512²;
//! - `primitives`: fractal terrains of 10k, 100k and 1M triangles at 512²;
//! - `resolution`: the default scene at 128² to 1024²;
//! - `native_peer`: irt and `irt::peer::native` on the primary-shadow workload, same scene and
//!   grid, same run, each side alone and both interleaved; the summary prints irt / native;
//! - `accel`: the grid and the BVH (`--accel bvh`) on the default scene, SPD balls_s4 and
//!   gears_s1, the teapot in a stadium and a 100k-triangle terrain, one frame of each per
//!   iteration; the summary prints BVH / grid.
//!
//! Throughput is rays per second, the ray count from one counted frame. Thread scaling and cold
//! vs warm start need fresh processes: `benches/process.rs`.
//!
//!     cargo bench --bench trace [-- FILTER]
mod common;

use common::{bench_frames, cases, group, Kind};
use criterion::Criterion;
use irt::gpu::GpuContext;
use irt::peer::native::NativePeer;

const SCENES: [&str; 3] = ["default", "spd/gears_s1.nff", "spd/balls_s2.nff"];

fn short(scene: &str) -> &str {
    scene.trim_start_matches("spd/").trim_end_matches(".nff")
}

fn ray_kind(c: &mut Criterion, ctx: &GpuContext) {
    let mut g = group(c, "ray_kind");
    for scene in cases(&SCENES) {
        for kind in cases(&Kind::ALL) {
            for side in cases(&[256, 512]) {
                let id = format!("{}/{}/{side}", short(scene), kind.name());
                if !common::wanted(&format!("ray_kind/{id}")) {
                    continue;
                }
                let t = common::traced(ctx, &kind.apply(&common::scene(scene, side)));
                bench_frames(&mut g, &id, t.rays, t.primitives, || {
                    t.renderer.render(ctx, &mut |_, _| {});
                });
            }
        }
    }
    g.finish();
}

fn primitives(c: &mut Criterion, ctx: &GpuContext) {
    let mut g = group(c, "primitives");
    for n in cases(&[10_000, 100_000, 1_000_000]) {
        let id = format!("terrain_{}k/512", n / 1000);
        if !common::wanted(&format!("primitives/{id}")) {
            continue;
        }
        let t = common::traced(ctx, &common::terrain_scene(n, 512));
        bench_frames(&mut g, &id, t.rays, t.primitives, || {
            t.renderer.render(ctx, &mut |_, _| {});
        });
    }
    g.finish();
}

fn resolution(c: &mut Criterion, ctx: &GpuContext) {
    let mut g = group(c, "resolution");
    for side in cases(&[128, 256, 512, 1024]) {
        let id = format!("default/{side}");
        if !common::wanted(&format!("resolution/{id}")) {
            continue;
        }
        let t = common::traced(ctx, &common::scene("default", side));
        bench_frames(&mut g, &id, t.rays, t.primitives, || {
            t.renderer.render(ctx, &mut |_, _| {});
        });
    }
    g.finish();
}

fn native_peer(c: &mut Criterion, ctx: &GpuContext) {
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut g = group(c, "native_peer");
    for scene in cases(&SCENES[..2]) {
        let name = short(scene);
        if !common::wanted(&format!("native_peer/{name}")) {
            continue;
        }
        let s = irt::peer::primary_shadow(&common::scene(scene, 512));
        // The peer walks irt's grid: so does irt here.
        let grid_opts =
            irt::gpu::RenderOptions { accel: irt::accel::AccelChoice::Grid, ..Default::default() };
        let t = common::traced_with(ctx, &s, grid_opts);
        let grid = t.renderer.accel.grid().expect("a grid renderer");
        let peer = NativePeer::new(&s, grid).expect("native peer");
        let peer_rays = peer.render(threads).rays.total();
        bench_frames(&mut g, &format!("{name}/irt"), t.rays, t.primitives, || {
            t.renderer.render(ctx, &mut |_, _| {});
        });
        bench_frames(&mut g, &format!("{name}/native_{threads}t"), peer_rays, t.primitives, || {
            std::hint::black_box(peer.render(threads));
        });
        // Both in one iteration, one frame each, so that a change in the machine's load falls on
        // both alike (as `irt bench --peer native`); criterion's number here is the pair's time,
        // the summary's ratio is that of the two sides' medians.
        let (irt_id, peer_id) = (
            format!("native_peer/{name}/irt (interleaved)"),
            format!("native_peer/{name}/native_{threads}t (interleaved)"),
        );
        g.throughput(criterion::Throughput::Elements(t.rays + peer_rays));
        g.bench_function(format!("{name}/interleaved"), |b| {
            b.iter_custom(|iters| {
                let mut total = std::time::Duration::ZERO;
                for _ in 0..iters {
                    let start = std::time::Instant::now();
                    t.renderer.render(ctx, &mut |_, _| {});
                    let mid = std::time::Instant::now();
                    std::hint::black_box(peer.render(threads));
                    let (a, b) = (mid - start, mid.elapsed());
                    common::record(&irt_id, t.rays, t.primitives, vec![a]);
                    common::record(&peer_id, peer_rays, t.primitives, vec![b]);
                    total += a + b;
                }
                total
            })
        });
        let label = format!("irt / native ({name}, primary-shadow, 512², {threads} threads)");
        common::ratio(
            &format!("{label}, separate benches"),
            &format!("native_peer/{name}/irt"),
            &format!("native_peer/{name}/native_{threads}t"),
        );
        common::ratio(&format!("{label}, interleaved"), &irt_id, &peer_id);
    }
    g.finish();
}

/// Grid and BVH on the same scene in one iteration (one frame each), so the machine's load falls
/// on both alike; criterion's number is the pair's time, the summary's ratio that of the medians.
fn accel(c: &mut Criterion, ctx: &GpuContext) {
    use irt::accel::AccelChoice;
    let mut g = group(c, "accel");
    let scenes = ["default", "spd/balls_s4.nff", "spd/gears_s1.nff", "accel/stadium.nff", "terrain_100k"];
    for scene in cases(&scenes) {
        let name = short(scene).trim_start_matches("accel/");
        if !common::wanted(&format!("accel/{name}")) {
            continue;
        }
        let s = if scene == "terrain_100k" {
            common::terrain_scene(100_000, 512)
        } else {
            common::scene(scene, 512)
        };
        let opts = |accel| irt::gpu::RenderOptions { accel, ..Default::default() };
        let grid = common::traced_with(ctx, &s, opts(AccelChoice::Grid));
        let bvh = common::traced_with(ctx, &s, opts(AccelChoice::Bvh));
        assert_eq!(grid.rays, bvh.rays, "{name}: the accelerators trace the same rays");
        let (grid_id, bvh_id) = (format!("accel/{name}/grid"), format!("accel/{name}/bvh"));
        g.throughput(criterion::Throughput::Elements(2 * grid.rays));
        g.bench_function(format!("{name}/interleaved"), |b| {
            b.iter_custom(|iters| {
                let mut total = std::time::Duration::ZERO;
                for _ in 0..iters {
                    let start = std::time::Instant::now();
                    grid.renderer.render(ctx, &mut |_, _| {});
                    let mid = std::time::Instant::now();
                    bvh.renderer.render(ctx, &mut |_, _| {});
                    let (a, b) = (mid - start, mid.elapsed());
                    common::record(&grid_id, grid.rays, grid.primitives, vec![a]);
                    common::record(&bvh_id, bvh.rays, bvh.primitives, vec![b]);
                    total += a + b;
                }
                total
            })
        });
        common::ratio(&format!("BVH / grid ({name}, 512², interleaved)"), &bvh_id, &grid_id);
    }
    g.finish();
}

fn main() {
    let mut c = common::config().configure_from_args();
    let ctx = common::gpu();
    println!("device: {} ({})", ctx.info.name, ctx.info.driver_info);
    ray_kind(&mut c, &ctx);
    primitives(&mut c, &ctx);
    resolution(&mut c, &ctx);
    native_peer(&mut c, &ctx);
    accel(&mut c, &ctx);
    c.final_summary();
    common::print_summary();
}
