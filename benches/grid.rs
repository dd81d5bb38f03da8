//! Grid build time on the CPU (criterion, throughput in primitives) and, printed as a table, the
//! bytes per primitive of the grid and of the packed scene texture (docs/performance.md,
//! *Benches*), on fractal terrains of 10k, 100k and 1M triangles and on the default scene.
//!
//!     cargo bench --bench grid
mod common;

use common::cases;
use criterion::{Criterion, Throughput};
use irt::accel::Grid;
use irt::scene::Scene;

fn scenes() -> Vec<(String, Scene)> {
    let mut v = vec![("default".to_string(), common::scene("default", 512))];
    for n in cases(&[10_000, 100_000, 1_000_000]) {
        v.push((format!("terrain_{}k", n / 1000), common::terrain_scene(n, 512)));
    }
    v
}

fn main() {
    let mut c: Criterion = common::config().configure_from_args();
    let scenes: Vec<_> =
        scenes().into_iter().filter(|(name, _)| common::wanted(&format!("grid_build/{name}"))).collect();
    let mut g = common::group(&mut c, "grid_build");
    for (name, scene) in &scenes {
        g.throughput(Throughput::Elements(scene.primitive_count() as u64));
        g.bench_function(name.as_str(), |b| b.iter(|| Grid::build(std::hint::black_box(scene))));
    }
    g.finish();
    c.final_summary();

    // What the device holds: the packed scene texture (primitives, normals, materials, lights
    // and a copy of the grid; 16-byte texels) is `GpuScene.bytes` less the params block, so it
    // is computed here without a device.
    println!("\n| scene | primitives | grid res | grid refs | grid bytes/prim | scene texture bytes/prim |");
    println!("|---|---|---|---|---|---|");
    for (name, scene) in &scenes {
        let grid = Grid::build(scene);
        let stats = grid.stats();
        let texels = irt::gpu::layout::pack_scene(scene, &grid, scene.camera.eye).texels.len();
        let n = scene.primitive_count() as f64;
        println!(
            "| {name} | {} | {}x{}x{} | {} | {:.1} | {:.1} |",
            scene.primitive_count(),
            stats.res[0],
            stats.res[1],
            stats.res[2],
            stats.refs,
            stats.bytes as f64 / n,
            (texels * 16) as f64 / n,
        );
    }
}
