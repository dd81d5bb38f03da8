//! The native peer (irt::lab::peer::native) traces the same work as irt's GPU path: same image, same
//! rays, on the primary-shadow workload, over irt's grid (`native`) and over irt's BVH
//! (`native-bvh`). Both are f32 with the same algorithms, so they agree far more closely than the GPU and the f64 reference do (measured:
//! at most 0.2/255 on any channel, on these four scenes). The bound is tighter than the
//! reference's (`assert_matches_reference`) but not zero: lavapipe's `normalize`, `inverseSqrt`
//! and division may round differently from Rust's, and a ray that grazes a silhouette or a
//! shadow edge can then go either way. So: at most 0.05% of pixels off by more than 2/255 (8 of
//! 160²), the 99.9th-percentile error ≤ 0.5/255, nothing non-finite. A wrong normal, a missed
//! cell or a wrong light term changes whole regions and fails both bounds.

use crate::common;

use irt::accel::{bvh_for, BvhWalk, Grid};
use irt::lab::peer::{native::NativePeer, primary_shadow};
use irt::render::Session;
use std::path::Path;

/// Renders `file` (None: the default scene) at `size`² both ways and compares.
fn check(name: &str, file: Option<&str>, size: u32) {
    let path = file.map(|f| Path::new(env!("CARGO_MANIFEST_DIR")).join(f));
    let mut scene = primary_shadow(&irt::io::load_or_default(path.as_deref()).expect("scene loads"));
    scene.camera.width = size;
    scene.camera.height = size;
    let ctx = common::gpu();
    let opts = irt::render::Settings { count_rays: true, ..irt::render::Settings::bands() };
    let gpu = Session::new(&ctx, &scene, opts).expect("renderer").picture(&ctx, &mut |_, _| {});
    // Both accelerators of the peer: irt's grid (`native`) and irt's BVH (`native-bvh`).
    let peers = [
        NativePeer::new(&scene, &Grid::build(&scene)).expect("peer"),
        // The tree the device walks (ordered towards the eye), as `irt bench --peer native-bvh`.
        NativePeer::with_bvh(&scene, &bvh_for(&scene, BvhWalk::Stackless)).expect("BVH peer"),
    ];
    for peer in &peers {
        let who = peer.name();
        let peer = peer.render(2);
        let diff = irt::metrics::compare(&peer.image, &gpu.image);
        println!("{name}, {who}: {diff}");
        assert!(
            diff.bad_pixels <= 5e-4 && diff.p999 <= 0.5 / 255.0 && diff.non_finite == 0,
            "{name}: {who} peer differs from the GPU: {diff}"
        );
        assert_eq!(gpu.rays.eye, peer.rays.eye, "{name}, {who}: eye rays");
        assert_eq!(
            gpu.rays.reflection + gpu.rays.refraction,
            0,
            "{name}: the workload has no secondary rays"
        );
        // A shadow ray is cast where n·l > 0: a grazing light can flip that, one ray per such
        // pixel and light, which the image bound above already keeps rare.
        let (g, p) = (gpu.rays.shadow as f64, peer.rays.shadow as f64);
        assert!(g > 0.0, "{name}: the workload casts shadow rays");
        assert!((g - p).abs() <= 5e-4 * g, "{name}, {who}: shadow rays GPU {g} vs native {p}");
    }
}

#[test]
fn default_scene_matches_gpu() {
    check("default", None, 160);
}

#[test]
fn spd_balls_matches_gpu() {
    check("balls_s2", Some("scenes/spd/balls_s2.nff"), 160);
}

#[test]
fn spd_gears_matches_gpu() {
    check("gears_s1", Some("scenes/spd/gears_s1.nff"), 160);
}

#[test]
fn mesh_scene_matches_gpu() {
    check("mesh", Some("scenes/mesh.toml"), 160);
}

#[test]
fn cones_match_gpu() {
    check("cones", Some("scenes/cones.toml"), 160);
}

#[test]
fn spd_jacks_matches_gpu() {
    check("jacks_s2", Some("scenes/spd/jacks_s2.nff"), 160);
}

/// The workload leaves nothing the peer would shade differently, and the peer refuses what it
/// does not trace (deeper rays, other materials) instead of drawing something else.
#[test]
fn workload_is_lambert_and_peer_refuses_the_rest() {
    let full = irt::io::load_or_default(None).unwrap();
    let err = NativePeer::new(&full, &Grid::build(&full))
        .err()
        .expect("full scene (depth > 1) refused")
        .to_string();
    assert!(err.contains("primary-shadow"), "{err}");
    let scene = primary_shadow(&full);
    assert_eq!(scene.trace.max_depth, 1);
    assert!(scene.materials.iter().all(|m| matches!(m.kind, irt::scene::MaterialKind::Diffuse { .. })));
    let mut metal = scene.clone();
    metal.materials[0].kind = irt::scene::MaterialKind::Metal { color: glam::DVec3::ONE, exponent: 10.0 };
    let err = NativePeer::new(&metal, &Grid::build(&metal)).err().expect("metal refused").to_string();
    assert!(err.contains("diffuse"), "{err}");
}
