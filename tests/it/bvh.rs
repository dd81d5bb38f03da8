//! The BVH (`--accel bvh`, accel::bvh + shaders/bvh.wgsl) against the f64 CPU reference per
//! pixel, against the grid's image, in f64, in every shadow mode, and in a moving scene.
//!
//! Tolerance: the golden tests' (`common::assert_matches_reference`: p99.9 ≤ 2/255, at most
//! 0.25% of pixels off by more than 2/255, no NaN). The accelerator only decides which
//! primitives a ray is tested against, so a correct BVH gives the grid's tolerance; a box that
//! loses a primitive to rounding shows as a missing surface, far past both bounds.
use crate::common;

use irt::accel::AccelChoice;
use irt::render::{Mode, Schedule, Session, Settings};
use irt::scene::{Scene, ShadowMode};
use std::path::PathBuf;

fn scene_file(name: &str) -> Scene {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name);
    irt::io::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

fn sized(mut s: Scene, w: u32, h: u32) -> Scene {
    (s.camera.width, s.camera.height) = (w, h);
    s
}

fn with(accel: AccelChoice) -> irt::render::Settings {
    irt::render::Settings { accel, ..irt::render::Settings::bands() }
}

/// Spheres, triangles, cones, textures, dielectrics, metal: each scene file through both BVH
/// walks against the reference.
#[test]
fn bvh_images_match_the_reference() {
    let ctx = common::gpu();
    for (name, size) in [
        ("diffuse.toml", None),
        ("mesh.toml", None),
        ("cones.toml", None),
        ("textured.toml", None),
        ("dielectric.toml", None),
        ("metal.toml", None),
        ("spd/tetra_s4.nff", Some(96)),
        ("spd/teapot_s2.nff", Some(96)),
    ] {
        let mut s = scene_file(name);
        if let Some(n) = size {
            s = sized(s, n, n);
        }
        let reference = common::reference_image(&s);
        for accel in [AccelChoice::Bvh, AccelChoice::BvhStack] {
            let gpu = common::render_gpu_with(&ctx, &s, with(accel));
            common::assert_matches_reference(&format!("bvh-{accel}-{name}"), &gpu, &reference);
        }
    }
}

#[test]
fn default_scene_with_the_bvh_matches_the_reference() {
    let ctx = common::gpu();
    let mut s = irt::scene::default_scene();
    // Half resolution keeps the brute-force reference to a few seconds (as tests/golden.rs).
    s.camera.width /= 2;
    s.camera.height /= 2;
    let gpu = common::render_gpu_with(&ctx, &s, with(AccelChoice::Bvh));
    common::assert_matches_reference("bvh-default", &gpu, &common::reference_image(&s));
}

/// The f64 pipeline variant walks the BVH in f64 too (the slab test in `real`).
#[test]
fn f64_bvh_matches_the_reference() {
    let ctx = common::gpu();
    for name in ["mesh.toml", "cones.toml"] {
        let s = scene_file(name);
        for accel in [AccelChoice::Bvh, AccelChoice::BvhStack] {
            let gpu = common::render_gpu_with(
                &ctx,
                &s,
                irt::render::Settings { accel, f64: true, ..irt::render::Settings::bands() },
            );
            common::assert_matches_reference(
                &format!("bvh-f64-{accel}-{name}"),
                &gpu,
                &common::reference_image(&s),
            );
        }
    }
}

/// BVH and grid images of the same scene agree pixel for pixel in every shadow mode (hard,
/// bundles over split passes, shells with the large-mesh walk, which walks the accelerator):
/// the two find the same nearest hits, so they differ at most where two primitives are hit at
/// the same distance (a shared edge) and each picks another. Measured on these scenes: none.
#[test]
fn bvh_and_grid_images_agree_in_every_shadow_mode() {
    let ctx = common::gpu();
    let modes = [
        ShadowMode::Hard,
        ShadowMode::Bundle { samples: 20, rotate: true },
        ShadowMode::Shell { falloff: Default::default(), combine: Default::default() },
    ];
    for name in ["shadows.toml", "mesh.toml", "cones.toml"] {
        for mode in modes {
            let mut s = sized(scene_file(name), 96, 72);
            s.trace.shadows = mode;
            for l in &mut s.lights {
                l.radius = l.radius.max(0.3);
            }
            let grid = common::render_gpu_with(&ctx, &s, with(AccelChoice::Grid));
            for accel in [AccelChoice::Bvh, AccelChoice::BvhStack] {
                let bvh = common::render_gpu_with(&ctx, &s, with(accel));
                let diff = irt::metrics::compare(&bvh, &grid);
                println!("{name} {mode:?} {accel}: {diff}");
                assert!(diff.non_finite == 0 && diff.bad_pixels == 0.0, "{name} {mode:?} {accel}: {diff}");
            }
        }
    }
}

/// The shell walk runs only for meshes past `SHELL_DIRECT_TRIANGLES`; mesh.toml's is, so the
/// shell kernel above walked the BVH. Checked here so that test cannot pass by not walking.
#[test]
fn the_shell_test_scene_walks_the_accelerator() {
    let mut s = scene_file("mesh.toml");
    s.trace.shadows = ShadowMode::Shell { falloff: Default::default(), combine: Default::default() };
    assert!(irt::scene::shells_walk_grid(&s));
}

fn session(ctx: &irt::gpu::GpuContext, scene: &Scene, accel: AccelChoice) -> Session {
    let settings = Settings {
        mode: Mode::Conventional { schedule: Schedule::Plain, workers: 0 },
        max_samples: 1,
        accel,
        ..Settings::default()
    };
    Session::new(ctx, scene, settings).unwrap()
}

/// A session orders its stackless BVH towards the eye again once the camera has moved far
/// enough, not for a small move, and the picture is what a session started at that camera
/// draws (the order changes which boxes are tested first, not what is hit).
#[test]
fn a_session_reorders_its_bvh_for_a_far_eye_and_draws_the_same_picture() {
    let ctx = common::gpu();
    let scene = sized(scene_file("spd/balls_s2.nff"), 64, 64);
    let mut moved = session(&ctx, &scene, AccelChoice::Bvh);
    let start = scene.camera.eye;
    assert_eq!(moved.bvh_ordered_for(), Some(start));
    let mut camera = scene.camera.clone();
    camera.eye = start * 1.001;
    moved.set_camera(&ctx, &camera);
    assert_eq!(moved.bvh_ordered_for(), Some(start), "a small move keeps the order");
    // Seen from the opposite side: the old order would test the far side's boxes first.
    camera.eye = glam::DVec3::new(-start.x, start.y, -start.z);
    moved.set_camera(&ctx, &camera);
    assert_eq!(moved.bvh_ordered_for(), Some(camera.eye), "a far move orders the tree again");
    moved.complete_pass(&ctx);
    let mut fresh = session(&ctx, &Scene { camera: camera.clone(), ..scene.clone() }, AccelChoice::Bvh);
    fresh.complete_pass(&ctx);
    let diff = irt::metrics::compare(&moved.read_image(&ctx), &fresh.read_image(&ctx));
    assert!(diff.bad_pixels == 0.0, "the reordered session and a fresh one differ: {diff}");
    assert!(session(&ctx, &scene, AccelChoice::Grid).bvh_ordered_for().is_none());
}

/// A viewer's session of a scene past `BACKGROUND_BVH_ABOVE` primitives traces the grid while
/// its BVH builds on another thread, then adopts it: from then on it draws what a session that
/// built the BVH first draws, bit for bit, and before it what a grid session draws. A geometry
/// edit goes back to the grid and builds the edited scene's BVH behind it (one in flight, which
/// would no longer fit, is given up).
#[test]
fn a_viewer_traces_the_grid_until_its_background_bvh_is_built() {
    use irt::accel::AccelKind;
    use irt::io::stage::{stage, Model};
    use irt::render::{background::BACKGROUND_BVH_ABOVE, Adoption};
    let ctx = common::gpu();
    let model = Model {
        meshes: vec![irt::io::shapes::terrain(740, 3, false).into_mesh(0)],
        materials: vec![irt::scene::Material::new(
            "terrain",
            irt::scene::MaterialKind::Diffuse { color: glam::DVec3::splat(0.8) },
        )],
        textures: vec![],
        motions: vec![],
        ..Default::default()
    };
    let scene = sized(stage(model), 40, 30);
    assert!(scene.primitive_count() > BACKGROUND_BVH_ABOVE);
    let settings = Settings {
        mode: Mode::Conventional { schedule: Schedule::Plain, workers: 0 },
        max_samples: 1,
        ..Settings::default()
    };
    let picture = |s: &mut Session| {
        s.complete_pass(&ctx);
        s.read_image(&ctx)
    };
    let same = |a: &irt::image::Image, b: &irt::image::Image| a.pixels == b.pixels;
    let adopt = |s: &mut Session| {
        let started = std::time::Instant::now();
        loop {
            if let Some(how) = s.adopt_bvh(&ctx).unwrap() {
                return how;
            }
            assert!(started.elapsed().as_secs() < 120, "the background build never finished");
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
    };

    let mut viewer = Session::new_interactive(&ctx, &scene, settings.clone()).unwrap();
    assert!(viewer.bvh_pending());
    assert_eq!(viewer.accel.kind(), AccelKind::Grid);
    let before = picture(&mut viewer);
    assert!(same(&before, &picture(&mut session(&ctx, &scene, AccelChoice::Grid))), "the grid's picture");
    assert_eq!(adopt(&mut viewer), Adoption::SectionWritten, "only the BVH's section is written");
    assert!(!viewer.bvh_pending() && viewer.adopt_bvh(&ctx).unwrap().is_none());
    assert_eq!(viewer.accel.kind(), AccelKind::Bvh(irt::accel::BvhWalk::Stackless));
    let after = picture(&mut viewer);
    let mut built_first = Session::new(&ctx, &scene, settings.clone()).unwrap();
    assert_eq!(built_first.accel.kind(), AccelKind::Bvh(irt::accel::BvhWalk::Stackless));
    assert!(same(&after, &picture(&mut built_first)), "the adopted BVH's picture");
    let diff = irt::metrics::compare(&before, &after);
    assert!(diff.bad_pixels == 0.0, "grid and BVH pictures: {diff}");

    // An edit that moves geometry: back to the grid at once (no BVH rebuilt before the next
    // frame), the edited scene's BVH built behind it and adopted, as at the start.
    let mut moved = scene.clone();
    moved.meshes[0].positions.iter_mut().for_each(|p| p.y += 0.01);
    viewer.set_scene(&ctx, &moved).unwrap();
    assert!(viewer.bvh_pending() && viewer.accel.kind() == AccelKind::Grid);
    let edited_grid = picture(&mut viewer);
    assert!(
        same(&edited_grid, &picture(&mut session(&ctx, &moved, AccelChoice::Grid))),
        "the edit's grid picture"
    );
    assert_eq!(adopt(&mut viewer), Adoption::SectionWritten);
    let mut moved_first = Session::new(&ctx, &moved, settings.clone()).unwrap();
    assert!(same(&picture(&mut viewer), &picture(&mut moved_first)), "the edit's adopted BVH");

    // Named accelerators are built before the first frame; an edit while a build is in flight
    // gives it up and starts the edited scene's.
    let named = Settings { accel: AccelChoice::Bvh, ..settings.clone() };
    assert!(!Session::new_interactive(&ctx, &scene, named).unwrap().bvh_pending());
    let mut edited = Session::new_interactive(&ctx, &scene, settings).unwrap();
    edited.set_scene(&ctx, &moved).unwrap();
    assert!(edited.bvh_pending() && edited.accel.kind() == AccelKind::Grid);
}

/// A moving scene with the BVH: the session rebuilds the tree at every time (no refit yet), and
/// its image matches the reference of the posed scene and the grid session's.
#[test]
fn a_moving_scene_with_the_bvh_matches_the_reference_at_every_time() {
    let ctx = common::gpu();
    let scene = sized(scene_file("animated.toml"), 80, 60);
    let mut bvh = session(&ctx, &scene, AccelChoice::Bvh);
    let mut grid = session(&ctx, &scene, AccelChoice::Grid);
    assert!(bvh.grid().is_none() && grid.grid().is_some());
    for t in [0.5, 1.25, 3.0] {
        let r = bvh.set_time(&ctx, t).unwrap();
        assert!(r.accel.is_some() && !r.recompiled, "geometry moved: the BVH was rebuilt, same kernel");
        grid.set_time(&ctx, t).unwrap();
        bvh.complete_pass(&ctx);
        grid.complete_pass(&ctx);
        let image = bvh.read_image(&ctx);
        let diff = irt::metrics::compare(&image, &grid.read_image(&ctx));
        assert!(diff.bad_pixels == 0.0, "at {t}: BVH and grid sessions differ: {diff}");
        common::assert_matches_reference(
            &format!("bvh-session-t{t}"),
            &image,
            &common::reference_image(&scene.at(t)),
        );
    }
}

#[test]
fn accel_names_parse_and_bad_ones_are_errors() {
    for (name, choice) in AccelChoice::NAMES {
        assert_eq!(name.parse::<AccelChoice>(), Ok(choice));
        assert_eq!(choice.to_string(), name);
    }
    let err = "kd-tree".parse::<AccelChoice>().unwrap_err().to_string();
    assert!(err.contains("kd-tree") && err.contains("grid, bvh"), "{err}");
}

/// `--accel auto` (accel::auto): the BVH, which won on every scene of docs/performance.md's
/// "Grid vs BVH" table (the evenly scattered random spheres, the grid's own case, included) and
/// on the largest SPD scenes; the grid only past `AUTO_GRID_ABOVE` primitives when some of them
/// move (a BVH would be rebuilt whole at every frame).
#[test]
fn auto_picks_the_bvh_unless_a_large_scene_moves() {
    use irt::accel::{auto_for, AccelKind, BvhWalk, AUTO_GRID_ABOVE};
    let bvh = AccelKind::Bvh(BvhWalk::Stackless);
    for name in [
        "accel/random_spheres.nff",
        "accel/stadium.nff",
        "spd/jacks_s2.nff",
        "spd/balls_s4.nff",
        "spd/tree_s3.nff",
        "spd/gears_s1.nff",
        "textured.toml",
        "cones.toml",
        "animated.toml",
    ] {
        assert_eq!(AccelChoice::Auto.resolve(&scene_file(name)), bvh, "{name}");
    }
    assert_eq!(AccelChoice::Auto.resolve(&irt::scene::default_scene()), bvh, "default");
    let (n, big) = (AUTO_GRID_ABOVE, AUTO_GRID_ABOVE + 1);
    assert_eq!([auto_for(n, true), auto_for(big, false)], [bvh, bvh]);
    assert_eq!(auto_for(big, true), AccelKind::Grid);
    // Past AUTO_GRID_PRIMITIVES (particle files) the grid, moving or not: a BVH's scene texture
    // would not fit one device allocation.
    use irt::accel::AUTO_GRID_PRIMITIVES;
    assert_eq!(auto_for(AUTO_GRID_PRIMITIVES, false), bvh);
    assert_eq!(auto_for(AUTO_GRID_PRIMITIVES + 1, false), AccelKind::Grid);
    assert_eq!(AccelChoice::default(), AccelChoice::Auto);
    // A scene past the limit: moving spheres and a mesh keep it on the grid, a moving light
    // alone does not, and neither does a still of it (what `irt render --time` traces).
    let mut scene = scene_file("animated.toml");
    let s = scene.spheres[0].clone();
    scene.spheres.resize(AUTO_GRID_ABOVE + 1, s);
    assert_eq!(AccelChoice::Auto.resolve(&scene), AccelKind::Grid);
    assert_eq!(AccelChoice::Auto.resolve(&scene.at(0.0)), bvh, "a still");
    scene.motions.retain(|m| matches!(m.target, irt::scene::Target::Light(_)));
    assert!(!scene.motions.is_empty());
    assert_eq!(AccelChoice::Auto.resolve(&scene), bvh, "only the light moves");
}

/// The renderer builds what the choice resolves to, and the kernel walks what was packed.
#[test]
fn the_renderer_builds_what_the_choice_asks_for() {
    let ctx = common::gpu();
    for (name, choice, grid) in [
        ("accel/random_spheres.nff", AccelChoice::Auto, false),
        ("accel/random_spheres.nff", AccelChoice::Grid, true),
        ("spd/tetra_s4.nff", AccelChoice::Auto, false),
    ] {
        let s = sized(scene_file(name), 32, 32);
        let r = irt::render::Session::new(&ctx, &s, with(choice)).expect("renderer");
        assert_eq!(r.accel.grid().is_some(), grid, "{name} {choice}");
        let kernel_walks_bvh = r.variant.accel != irt::gpu::layout::ACCEL_GRID;
        assert_eq!(kernel_walks_bvh, !grid, "{name} {choice}: the kernel walks what was packed");
    }
}

/// The shader's decode of compact nodes (`bvh_qnode`, through the readback kernel
/// `k_bvh_qnode`) against the host's: each decoded box is the host's fused or unfused decode
/// and holds the node's f32 box, the link word comes through unchanged. Scenes with spheres and
/// triangles, packed relative to the eye and to a point 1e5 away.
#[test]
fn shader_decodes_compact_nodes_as_the_host_packs_them() {
    use irt::accel::{AccelRef, Bvh, BvhWalk};
    use irt::gpu::device::Device;
    use irt::gpu::layout::{bvh_nodes, decode_qnode, pack_scene, params, quantise_node, BvhLattice};
    let ctx = common::gpu();
    for name in ["spd/balls_s2.nff", "spd/teapot_s2.nff", "mesh.toml"] {
        let s = scene_file(name);
        let bvh = Bvh::build(&s);
        for origin in [s.camera.eye, s.camera.eye + glam::DVec3::splat(1e5)] {
            let accel = AccelRef::Bvh(&bvh, BvhWalk::Stackless);
            let packed = pack_scene(&s, accel, origin);
            let p = params(&s, accel, &packed, origin);
            let scene = ctx.upload(packed, p, None, 0).expect("upload");
            let nodes = bvh_nodes(&bvh, origin);
            let inputs: Vec<[f32; 4]> =
                (0..nodes.len()).map(|i| [f32::from_bits(i as u32), 0.0, 0.0, 0.0]).collect();
            let out = crate::common::run_kernel(&ctx, &scene, "k_bvh_qnode", &inputs, nodes.len() as u32, 2);
            let lattice = BvhLattice::of(&bvh, origin);
            for (i, n) in nodes.iter().enumerate() {
                let t = quantise_node(n, &lattice);
                let (lo, hi) = decode_qnode(t, &lattice);
                let (glo, ghi) = (&out[2 * i][..3], &out[2 * i + 1][..3]);
                assert_eq!(out[2 * i][3].to_bits(), t[3], "{name}: node {i} link");
                for k in 0..3 {
                    assert!(
                        glo[k] <= n.lo[k] && ghi[k] >= n.hi[k],
                        "{name}: node {i} axis {k} loses its box"
                    );
                    // The device fuses the decode's multiply-add or not: within an ulp of the
                    // host's fused decode either way.
                    assert!(
                        (glo[k] - lo[k]).abs() <= lo[k].abs().max(lattice.base[k].abs()) * f32::EPSILON,
                        "{name}: node {i} axis {k}: {} vs {}",
                        glo[k],
                        lo[k]
                    );
                    assert!(
                        (ghi[k] - hi[k]).abs() <= hi[k].abs().max(lattice.base[k].abs()) * f32::EPSILON,
                        "{name}: node {i} axis {k}: {} vs {}",
                        ghi[k],
                        hi[k]
                    );
                }
            }
        }
    }
}
