//! `[[model]]`: model files (glTF here; OBJ and PLY in their own tests) placed in a TOML scene
//! with a transform and an optional material, and the errors that can go with it.
use crate::common;

use glam::DVec3;
use irt::io::{self, stage};
use std::path::{Path, PathBuf};

fn data() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/scenes/gltf")
}

/// A scene file next to the glTF samples (model paths are relative to the scene file).
fn scene_with(body: &str) -> (PathBuf, String) {
    let src = format!(
        "[camera]\neye = [0, 1, 4]\nlook_at = [0, 0.5, 0]\nfov = 40\nwidth = 48\nheight = 36\n\n\
         [[light]]\nposition = [3, 5, 4]\ncolor = [1, 1, 1]\n\n\
         [[material]]\nname = \"red\"\ntype = \"diffuse\"\ncolor = [0.8, 0.1, 0.1]\n\n{body}"
    );
    // A directory per scene: tests run in parallel and copy the models in.
    static NEXT: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let n = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!("irt-models-{}-{n}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for f in ["Duck.glb", "Box.gltf"] {
        std::fs::copy(data().join(f), dir.join(f)).unwrap();
    }
    let path = dir.join("scene.toml");
    std::fs::write(&path, &src).unwrap();
    (path, src)
}

fn bounds(scene: &irt::scene::Scene) -> (DVec3, DVec3) {
    let points = scene.meshes.iter().flat_map(|m| &m.positions);
    points.fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| (lo.min(*p), hi.max(*p)))
}

#[test]
fn a_model_keeps_its_materials_and_textures_and_is_placed_by_its_transform() {
    let alone = io::load_model(&data().join("Duck.glb")).expect("Duck loads as a model");
    let (path, _) = scene_with(
        "[[model]]\nfile = \"Duck.glb\"\nscale = 0.01\nrotate = [0, 90, 0]\ntranslate = [1, 0, -2]\n",
    );
    let scene = io::load(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.triangle_count(), alone.meshes.iter().map(|m| m.indices.len()).sum::<usize>());
    assert_eq!(scene.materials.len(), 1 + alone.materials.len());
    assert_eq!(scene.textures.len(), alone.textures.len());
    assert!(scene.materials[1].name.starts_with("Duck.glb:"), "{}", scene.materials[1].name);
    assert_eq!(scene.materials[1].texture, alone.materials[0].texture);
    // Every vertex went through p' = R (s p) + t, R a quarter turn about y: (x, y, z) → (z, y, -x).
    for (a, b) in alone.meshes[0].positions.iter().zip(&scene.meshes[0].positions) {
        let want = DVec3::new(a.z, a.y, -a.x) * 0.01 + DVec3::new(1.0, 0.0, -2.0);
        assert!((want - *b).length() < 1e-12, "{want} vs {b}");
    }
    let (lo, hi) = bounds(&scene);
    assert!(lo.x > 0.0 && hi.z < -1.0, "moved to (1, 0, -2): {lo} .. {hi}");
    let ctx = common::gpu();
    common::assert_matches_reference(
        "model-duck",
        &common::render_gpu(&ctx, &scene),
        &common::reference_image(&scene),
    );
}

#[test]
fn a_model_material_override_replaces_all_its_materials_and_the_identity_changes_nothing() {
    let (path, _) = scene_with("[[model]]\nfile = \"Box.gltf\"\nmaterial = \"red\"\n");
    let scene = io::load(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.materials.len(), 1, "no model materials added");
    assert!(scene.meshes.iter().all(|m| m.material == 0));
    let alone = io::load_model(&data().join("Box.gltf")).unwrap();
    assert!(scene
        .meshes
        .iter()
        .zip(&alone.meshes)
        .all(|(a, b)| a.positions == b.positions && a.normals == b.normals));
}

#[test]
fn model_errors_point_at_the_scene_and_name_the_model_file() {
    let origin = |p: &Path| p.display().to_string();
    let (path, src) = scene_with("[[model]]\nfile = \"missing.glb\"\n");
    let e = common::assert_fails_at(
        io::load(&path),
        &src,
        &origin(&path),
        "\"missing.glb\"",
        &["model", "missing.glb"],
    );
    assert!(e.message.contains("cannot read"), "{e}");
    let (path, src) = scene_with("[[model]]\nfile = \"scene.nff\"\n");
    common::assert_fails_at(
        io::load(&path),
        &src,
        &origin(&path),
        "\"scene.nff\"",
        &["not a model file", ".glb"],
    );
    let (path, src) = scene_with("[[model]]\nfile = \"Box.gltf\"\nmaterial = \"blue\"\n");
    common::assert_fails_at(io::load(&path), &src, &origin(&path), "\"blue\"", &["blue"]);
    let (path, src) = scene_with("[[model]]\nfile = \"Box.gltf\"\nscale = 0\n");
    common::assert_fails_at(io::load(&path), &src, &origin(&path), "0\n", &["scale"]);
    let (path, src) = scene_with("[[model]]\nfile = \"Box.gltf\"\nrotate = [0, 1]\n");
    common::assert_fails_at(io::load(&path), &src, &origin(&path), "[0, 1]", &["rotate"]);
    let (path, src) = scene_with("[[model]]\nfile = \"Box.gltf\"\nspin = 3\n");
    common::assert_fails_at(io::load(&path), &src, &origin(&path), "spin", &["spin"]);
}

#[test]
fn a_model_alone_is_staged_with_a_camera_that_sees_it_and_a_light() {
    let scene = stage::stage(io::load_model(&data().join("Duck.glb")).unwrap());
    assert_eq!(scene.lights.len(), 1);
    let (lo, hi) = bounds(&scene);
    assert!((scene.camera.look_at - 0.5 * (lo + hi)).length() < 1e-9);
    // Every corner of the box lies in front of the camera and inside its field of view.
    let b = scene.camera.basis();
    for i in 0..8 {
        let c = DVec3::new([lo.x, hi.x][i & 1], [lo.y, hi.y][i >> 1 & 1], [lo.z, hi.z][i >> 2]);
        let d = c - scene.camera.eye;
        let depth = d.dot(b.w);
        assert!(depth > 0.0);
        assert!(
            (d.dot(b.u.normalize()) / depth).abs() < b.u.length()
                && (d.dot(b.v.normalize()) / depth).abs() < b.v.length()
        );
    }
}

#[test]
fn a_ply_scan_is_placed_as_a_model() {
    let models = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/models");
    let (path, _) = scene_with(&format!(
        "[[model]]\nfile = \"{}\"\nscale = 8\ntranslate = [0, -0.3, 0]\nmaterial = \"red\"\n",
        models.join("bun_zipper_res4.ply").display()
    ));
    let scene = io::load(&path).unwrap_or_else(|e| panic!("{e}"));
    let alone = io::load_model(&models.join("bun_zipper_res4.ply")).unwrap();
    assert_eq!(scene.triangle_count(), alone.meshes.iter().map(|m| m.indices.len()).sum::<usize>());
    let (lo, hi) = bounds(&scene);
    let (alo, ahi) = (bounds(&stage::stage(alone.clone())).0, bounds(&stage::stage(alone)).1);
    assert!(
        (lo - (alo * 8.0 - DVec3::Y * 0.3)).length() < 1e-9
            && (hi - (ahi * 8.0 - DVec3::Y * 0.3)).length() < 1e-9
    );
    let ctx = common::gpu();
    common::assert_matches_reference(
        "model-bunny",
        &common::render_gpu(&ctx, &scene),
        &common::reference_image(&scene),
    );
}

#[test]
fn an_open_model_is_seen_from_its_open_side_and_a_closed_one_from_the_front() {
    let models = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/models");
    // The Cornell box has no wall at -z: the camera looks in from there.
    let cornell = stage::stage(io::load_model(&models.join("cornell/cornell_box.obj")).unwrap());
    assert!(cornell.camera.eye.z < cornell.camera.look_at.z, "eye {}", cornell.camera.eye);
    // A single flat polygon facing +x is seen face on, not edge on.
    let ring = stage::stage(io::load_model(&models.join("concave/concave_polygon.obj")).unwrap());
    let view = (ring.camera.eye - ring.camera.look_at).normalize();
    assert!(view.x > 0.7, "view from {view}");
    // Closed (or nearly closed) models keep the front view from +z, right and above.
    for f in ["bun_zipper_res4.ply", "spot/spot.obj"] {
        let s = stage::stage(io::load_model(&models.join(f)).unwrap());
        let view = (s.camera.eye - s.camera.look_at).normalize();
        assert!((view - stage::FRAMING_DIRECTION.normalize()).length() < 1e-12, "{f}: {view}");
    }
}
