//! Moving objects (scene::motion): TOML keyframes, the posed scene on the GPU against the f64
//! reference at several times, the session's in-place updates against fresh renders, and the
//! loader's errors.
use crate::common;

use irt::render::{Mode, Schedule, Session, Settings};
use irt::scene::{Scene, Target};
use std::path::PathBuf;

fn animated() -> Scene {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes/animated.toml");
    irt::io::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

/// The animated scene small enough for the reference.
fn small(w: u32, h: u32) -> Scene {
    let mut s = animated();
    (s.camera.width, s.camera.height) = (w, h);
    s
}

#[test]
fn the_animated_scene_moves_what_it_says() {
    let s = animated();
    assert!(s.is_animated());
    assert_eq!(s.duration(), 4.0);
    let targets: Vec<Target> = s.motions.iter().map(|a| a.target).collect();
    assert_eq!(
        targets,
        [Target::Light(0), Target::Sphere(0), Target::Sphere(1), Target::Cone(0), Target::Mesh(1)]
    );
    // The ball's cubic bounce passes through its keys: 1.6 up at t = 1, back down at t = 2.
    let y = |t: f64| s.at(t).spheres[0].center.y;
    assert!((y(1.0) - 2.2).abs() < 1e-12 && (y(2.0) - 0.6).abs() < 1e-12, "{} {}", y(1.0), y(2.0));
    assert!(y(0.5) > 0.6 && y(0.5) < 2.2);
    // The glass sphere steps: still at its key's value just before the next key.
    assert_eq!(s.at(1.999).spheres[1].center.x, -1.0 + 0.7);
    // The light has turned half way round at t = 2 (about +y, through the origin).
    let l = s.at(2.0).lights[0].position;
    assert!((l - glam::DVec3::new(-4.0, 7.0, 0.0)).length() < 1e-12, "{l}");
    // The box turns about its pivot: its centre stays put while it turns, and it grows.
    let centre = |t: f64| {
        let m = &s.at(t).meshes[1];
        m.positions.iter().sum::<glam::DVec3>() / m.positions.len() as f64
    };
    assert!((centre(1.3) - centre(0.0)).length() < 1e-12);
    let extent = |t: f64| {
        let m = &s.at(t).meshes[1];
        m.positions.iter().map(|p| p.y).fold(f64::MIN, f64::max)
    };
    assert!((extent(2.0) - (0.6 + 0.6 * 1.25)).abs() < 1e-12);
    // Outside the keys: the first and last poses.
    assert_eq!(s.at(-3.0), s.at(0.0));
    assert_eq!(s.at(10.0), s.at(4.0));
    assert!(!s.at(1.0).is_animated(), "a posed scene is a still");
}

/// The GPU renders the scene at each time as the f64 reference does, within the golden
/// tolerance (common::assert_matches_reference).
#[test]
fn gpu_matches_the_reference_at_every_time() {
    let ctx = common::gpu();
    let scene = small(96, 72);
    for t in [0.0, 0.7, 1.5, 2.25, 3.9] {
        let posed = scene.at(t);
        let gpu = common::render_gpu(&ctx, &posed);
        common::assert_matches_reference(&format!("animated-t{t}"), &gpu, &common::reference_image(&posed));
    }
}

/// A grid session: these tests are about the grid's in-place updates (tests/bvh.rs moves a BVH).
fn plain_session(ctx: &irt::gpu::GpuContext, scene: &Scene) -> Session {
    let settings = Settings {
        mode: Mode::Conventional { schedule: Schedule::Plain, workers: 0 },
        max_samples: 1,
        accel: irt::accel::AccelChoice::Grid,
        ..Settings::default()
    };
    Session::new(ctx, scene, settings).unwrap()
}

fn session_image(ctx: &irt::gpu::GpuContext, s: &mut Session) -> irt::image::Image {
    s.complete_pass(ctx);
    s.read_image(ctx)
}

fn fresh_image(ctx: &irt::gpu::GpuContext, still: &Scene) -> irt::image::Image {
    let opts =
        irt::render::Settings { accel: irt::accel::AccelChoice::Grid, ..irt::render::Settings::bands() };
    Session::new(ctx, still, opts).unwrap().picture(ctx, &mut |_, _| {}).image
}

/// A session moved to time t re-inserts only the moving primitives into its grid; that draws
/// exactly what rebuilding the grid (in the same frame) draws, matches the f64 reference of
/// `scene.at(t)`, and going back to a time gives back its picture bit for bit.
#[test]
fn updates_in_place_equal_full_rebuilds_bit_for_bit() {
    let ctx = common::gpu();
    let scene = small(80, 60);
    let mut s = plain_session(&ctx, &scene);
    let mut full = plain_session(&ctx, &scene);
    full.incremental = false;
    let first = session_image(&ctx, &mut s);
    assert_eq!(first, session_image(&ctx, &mut full));
    for t in [0.5, 1.25, 3.0] {
        let r = s.set_time(&ctx, t).unwrap();
        assert!(r.accel.is_some(), "geometry moved: the grid follows");
        full.set_time(&ctx, t).unwrap();
        assert!(s.accel == full.accel, "at {t}: the updated grid is the rebuilt one");
        let image = session_image(&ctx, &mut s);
        assert_eq!(image, session_image(&ctx, &mut full), "at {t}");
        assert_ne!(image, first, "at {t} something moved");
        let posed = scene.at(t);
        common::assert_matches_reference(&format!("session-t{t}"), &image, &common::reference_image(&posed));
    }
    s.set_time(&ctx, 0.0).unwrap();
    assert_eq!(session_image(&ctx, &mut s), first, "moved and moved back");
}

/// A still scene's session is a fresh render's, bit for bit, and an edit is the edited
/// scene's fresh render (the grid is fitted to a still scene as `Renderer` fits it).
#[test]
fn a_still_session_equals_a_fresh_render() {
    let ctx = common::gpu();
    let scene = small(64, 48).at(1.0);
    let mut s = plain_session(&ctx, &scene);
    assert_eq!(session_image(&ctx, &mut s), fresh_image(&ctx, &scene));
    let mut edited = scene.clone();
    edited.spheres[0].center.x += 0.5;
    let r = s.set_scene(&ctx, &edited).unwrap();
    assert!(r.accel.is_some());
    assert_eq!(session_image(&ctx, &mut s), fresh_image(&ctx, &edited));
}

/// A sphere that swells over a field of small ones lands in every cell: the grid's lists
/// outgrow the texture, which is replaced (the dispatcher rebinds), and the picture is still
/// the one a session that never grew draws; the smaller scene then fits the grown texture.
#[test]
fn a_growing_scene_gets_a_new_texture() {
    use irt::scene::{Animated, Channel, Interpolation, Motion, Sphere, Stage, Trs};
    let ctx = common::gpu();
    let mut scene = small(64, 48).at(0.0);
    let mut rng = common::Rng::new(7);
    for _ in 0..20000 {
        let center = rng.vec(-3.0, 3.0) + 3.0 * glam::DVec3::Y;
        scene.spheres.push(Sphere { center, radius: 0.02, material: 1 });
    }
    let ball = Sphere { center: 3.0 * glam::DVec3::Y, radius: 0.1, material: 3 };
    scene.spheres.push(ball);
    let scale = Channel {
        interpolation: Interpolation::Linear,
        times: vec![0.0, 1.0],
        values: vec![glam::DVec3::ONE, glam::DVec3::splat(28.0)],
    };
    let about_centre = vec![
        Stage::Fixed(glam::DAffine3::from_translation(3.0 * glam::DVec3::Y)),
        Stage::Keyed { translation: None, rotation: None, scale: Some(scale), rest: Trs::default() },
        Stage::Fixed(glam::DAffine3::from_translation(-3.0 * glam::DVec3::Y)),
    ];
    let target = Target::Sphere(scene.spheres.len() as u32 - 1);
    scene.motions.push(Animated { target, motion: Motion { stages: about_centre } });
    scene.validate().unwrap();
    let mut s = plain_session(&ctx, &scene);
    let refs_before = s.grid().expect("a grid session").prim_refs.len();
    // (The swollen ball stays inside the field's box, so the cells keep their size.)
    let r = s.set_time(&ctx, 1.0).unwrap();
    println!("references {refs_before} → {}", s.grid().expect("a grid session").prim_refs.len());
    assert!(r.reallocated, "the texture was replaced");
    let mut full = plain_session(&ctx, &scene);
    full.incremental = false;
    full.set_time(&ctx, 1.0).unwrap();
    assert_eq!(session_image(&ctx, &mut s), session_image(&ctx, &mut full));
    let r = s.set_time(&ctx, 0.0).unwrap();
    assert!(!r.reallocated, "the smaller scene fits the grown texture");
    full.set_time(&ctx, 0.0).unwrap();
    assert_eq!(session_image(&ctx, &mut s), session_image(&ctx, &mut full));
}

/// Edits through `set_scene`: a light moved (no grid rebuild, no new kernel), a material of a
/// kind the scene did not have (a recompiled kernel), each equal to a fresh render of the
/// edited scene.
#[test]
fn edits_equal_fresh_renders() {
    use irt::scene::MaterialKind;
    let ctx = common::gpu();
    let mut scene = small(64, 48).at(0.0);
    // Diffuse and metal only: the specialised kernel has no refraction.
    for m in &mut scene.materials {
        if !matches!(m.kind, MaterialKind::Metal { .. }) {
            m.kind = MaterialKind::Diffuse { color: glam::DVec3::splat(0.6) };
        }
    }
    let mut s = plain_session(&ctx, &scene);
    let mut edited = scene.clone();
    edited.lights[0].position.x -= 3.0;
    let r = s.set_scene(&ctx, &edited).unwrap();
    assert!(r.accel.is_none() && !r.recompiled, "a light moved: nothing rebuilt");
    assert_eq!(session_image(&ctx, &mut s), fresh_image(&ctx, &edited));
    let ball = edited.spheres[0].material as usize;
    edited.materials[ball].kind = MaterialKind::Dielectric { eta: 1.5, exponent: 100.0 };
    let r = s.set_scene(&ctx, &edited).unwrap();
    assert!(r.accel.is_none() && r.recompiled, "glass needs refraction in the kernel");
    assert_eq!(session_image(&ctx, &mut s), fresh_image(&ctx, &edited));
    // Back to the scene as it was: its picture again.
    s.set_scene(&ctx, &scene).unwrap();
    assert_eq!(session_image(&ctx, &mut s), fresh_image(&ctx, &scene));
}

fn parse(src: &str) -> Result<Scene, irt::io::LoadError> {
    irt::io::toml::parse_str(src, "motion.toml")
}

const HEAD: &str =
    "[camera]\neye = [0, 0, 5]\nlook_at = [0, 0, 0]\n[[material]]\nname = \"m\"\ntype = \"diffuse\"\n\
    [[sphere]]\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"m\"\n";

#[test]
fn keyframe_errors_name_the_place() {
    let cases: &[(&str, &str, &[&str])] = &[
        (
            "[[sphere.motion]]\ntranslate = { times = [0, 2, 1], values = [[0,0,0],[1,0,0],[2,0,0]] }\n",
            "{ times",
            &["`translate`", "key 2 at time 1 does not come after key 1 at 2", "times must increase"],
        ),
        (
            "[[sphere.motion]]\ntranslate = { times = [0, 1], values = [[0,0,0]] }\n",
            "{ times",
            &["2 times but 1 values"],
        ),
        (
            "[[sphere.motion]]\ntranslate = { times = [0, nan], values = [[0,0,0],[1,0,0]] }\n",
            "{ times",
            &["not finite"],
        ),
        (
            "[[sphere.motion]]\ntranslate = { times = [0, 1], values = [[0,0,0],[inf,0,0]] }\n",
            "{ times",
            &["translate.values", "finite"],
        ),
        ("[[sphere.motion]]\nscale = { times = [0, 1], values = [1, [1, 2, 1]] }\n", "{ times", &["alike on every axis"]),
        ("[[sphere.motion]]\nscale = 0\n", "0", &["greater than 0"]),
        (
            "[[sphere.motion]]\nrotate = [0, 90, 0]\nquaternion = [0, 0, 0, 1]\n",
            "[0, 0, 0, 1]",
            &["`rotate` (degrees) or `quaternion`, not both"],
        ),
        ("[[sphere.motion]]\nquaternion = [0, 0, 0, 0]\n", "[0, 0, 0, 0]", &["names no rotation"]),
        (
            "[[sphere.motion]]\ntranslate = { times = [0, 1], values = [[0,0,0],[1,0,0]], interpolation = \"smooth\" }\n",
            "{ times",
            &["unknown `translate.interpolation` \"smooth\"", "\"step\", \"linear\", \"cubic\""],
        ),
        (
            "[[sphere.motion]]\ntranslate = { times = [0, 1], values = [[0,0,0],[1,0,0]], in_tangents = [[0,0,0],[0,0,0]] }\n",
            "{ times",
            &["tangents apply only to \"cubic\""],
        ),
        ("[[sphere.motion]]\nmatrix = [[1,0,0,0],[0,1,0,0],[0,0,0,0]]\n", "[[1,0", &["singular"]),
        ("[[sphere.motion]]\nmatrix = [[2,0,0,0],[0,1,0,0],[0,0,1,0]]\n", "[[2,0", &["scale alike on every axis"]),
        ("[[sphere.motion]]\nmatrix = [[1,0,0,0],[0,1,0,0],[0,0,1,0]]\npivot = [0, 1, 0]\n", "[0, 1, 0]", &["takes no other key"]),
        ("[[sphere.motion]]\n", "[[sphere.motion]]", &["needs `translate`"]),
        ("[[sphere.motion]]\ntranslate = \"up\"\n", "\"up\"", &["a value, or keys"]),
    ];
    for (tail, at, words) in cases {
        let src = format!("{HEAD}{tail}");
        common::assert_fails_at(parse(&src), &src, "motion.toml", at, words);
    }
}

#[test]
fn keyframes_load_as_channels() {
    let src = format!(
        "{HEAD}[[sphere.motion]]\npivot = [0, 1, 0]\nrotate = {{ times = [0, 1], values = [[0,0,0],[0,90,0]], interpolation = \"step\" }}\n\
         translate = [1, 2, 3]\n[[sphere.motion]]\nscale = {{ times = [0, 1, 2], values = [1, 2, 1], interpolation = \"cubic\" }}\n"
    );
    let s = parse(&src).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.motions.len(), 1);
    // pivot → fixed, keyed, fixed; then the second stage.
    assert_eq!(s.motions[0].motion.stages.len(), 4);
    assert_eq!(s.duration(), 2.0);
    // Scale 2 at t = 1 about the origin, then moved by (1, 2, 3) (the first stage is outermost).
    let c = s.at(1.0).spheres[0].center;
    assert!((c - glam::DVec3::new(1.0, 2.0, 3.0)).length() < 1e-12, "{c}");
    assert_eq!(s.at(1.0).spheres[0].radius, 2.0);
}

/// The writer gives every motion back: written, loaded, equal (the same holds for every scene
/// file in tests/convert.rs; this one checks explicit tangents and held values too).
#[test]
fn motions_round_trip_through_the_writer() {
    let src = format!(
        "{HEAD}[[sphere.motion]]\nquaternion = [0, 0.6, 0, 0.8]\n\
         translate = {{ times = [0, 1], values = [[0,0,0],[1,0,0]], interpolation = \"cubic\", in_tangents = [[1,0,0],[0,0,0]], out_tangents = [[0,2,0],[0,0,0]] }}\n\
         [[sphere.motion]]\nmatrix = [[0,-1,0,1],[1,0,0,2],[0,0,1,3]]\n"
    );
    let s = parse(&src).unwrap_or_else(|e| panic!("{e}"));
    let text = irt::io::toml_write::to_toml(&s, &[]);
    let back = parse(&text).unwrap_or_else(|e| panic!("{e}\n{text}"));
    assert_eq!(back, s, "{text}");
    assert_eq!(back.at(0.4), s.at(0.4));
}
