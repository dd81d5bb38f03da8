//! Volumes traced as scene objects (docs/volumes.md): the GPU's isosurfaces against the f64
//! reference's independent twin (dense sampling and bisection) with shadows, a mirror and other
//! primitives in the scene, on both accelerators; and a sampled distance field's isosurface
//! against irt's analytic sphere.

use crate::common::{assert_matches_reference, gpu, reference_image, render_gpu_with};
use irt::accel::AccelChoice;
use irt::render::Settings;
use std::path::Path;

fn data(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/volumes").join(name).display().to_string()
}

/// The test distance field (distance to (0.25, -0.5, 0.75), 17x15x13 samples 0.5/0.5/0.6 apart)
/// as isosurface `iso`, over a mirror floor, under a light that casts its shadow; `extra`: more
/// tables.
fn scene(iso: &str, extra: &str) -> irt::scene::Scene {
    let src = format!(
        r#"
        background = [0.1, 0.12, 0.15]
        [camera]
        eye = [0.5, 3.0, 9.0]
        look_at = [0.25, -0.5, 0.75]
        fov = 40
        width = 64
        height = 64
        [[light]]
        position = [4.0, 8.0, 6.0]
        color = [0.9, 0.9, 0.9]
        [[material]]
        name = "bone"
        type = "diffuse"
        color = [0.9, 0.8, 0.7]
        [[material]]
        name = "mirror"
        type = "metal"
        color = [0.8, 0.8, 0.8]
        exponent = 40
        [[mesh]]
        material = "mirror"
        positions = [[-6, -3, -6], [6, -3, -6], [6, -3, 6], [-6, -3, 6]]
        indices = [[0, 2, 1], [0, 3, 2]]
        [[volume]]
        file = "{}"
        iso = {iso}
        material = "bone"
        {extra}
        "#,
        data("sphere_raw.nrrd")
    );
    irt::io::toml::parse_str(&src, "volume-test.toml").expect("scene")
}

/// Each scene on the GPU, with the BVH and the grid, against the f64 reference.
fn assert_match_on_both_accelerators(ctx: &irt::gpu::GpuContext, scenes: &[(&str, irt::scene::Scene)]) {
    for (name, s) in scenes {
        let reference = reference_image(s);
        for accel in [AccelChoice::Bvh, AccelChoice::Grid] {
            let img = render_gpu_with(ctx, s, Settings { accel, ..Settings::bands() });
            assert_matches_reference(&format!("volume-{name}-{accel}"), &img, &reference);
        }
    }
}

#[test]
fn isosurfaces_match_the_reference_with_shadows_and_a_mirror() {
    let ctx = gpu();
    let scenes = [
        ("one", scene("2.0", "")),
        // Two nested isosurfaces seen through each other's gaps, and a sphere beside them.
        (
            "two",
            scene(
                r#"[{ value = 1.2, material = "mirror" }, { value = 2.6 }]"#,
                "[[sphere]]\ncenter = [3.0, -1.0, 1.0]\nradius = 0.8\nmaterial = \"bone\"",
            ),
        ),
    ];
    assert_match_on_both_accelerators(&ctx, &scenes);
}

/// The isosurface r = 2 of the sampled distance field covers the pixels the analytic sphere of
/// radius 2 covers, except at the silhouette: the trilinear interpolant of |x| lies within
/// h²/(8r) ≈ 0.016 of it here (h = 0.5-0.6 apart), a tenth of a pixel at this size, so a pixel
/// may differ only where the sphere's own coverage changes within one pixel of it.
#[test]
fn a_distance_fields_isosurface_draws_the_analytic_sphere() {
    let ctx = gpu();
    let volume = scene("2.0", "");
    let mut sphere =
        scene("2.0", "[[sphere]]\ncenter = [0.25, -0.5, 0.75]\nradius = 2.0\nmaterial = \"bone\"");
    sphere.volumes.clear();
    let covered = |s: &irt::scene::Scene| {
        let mut s = s.clone();
        // Only what the eye rays hit: no floor, no shading differences.
        s.meshes.clear();
        s.background = glam::DVec3::ZERO;
        s.ambient.sky = glam::DVec3::ONE;
        s.ambient.ground = glam::DVec3::ONE;
        let img = render_gpu_with(&ctx, &s, Settings::bands());
        img.pixels.iter().map(|p| p.iter().any(|&c| c > 0.0)).collect::<Vec<bool>>()
    };
    let (v, a) = (covered(&volume), covered(&sphere));
    let n = 64usize;
    let area = a.iter().filter(|&&x| x).count();
    assert!(area > 400, "the sphere covers {area} pixels");
    let mut differ = 0;
    for y in 0..n {
        for x in 0..n {
            let i = y * n + x;
            if v[i] != a[i] {
                differ += 1;
                let near_edge = [(0i64, 1i64), (0, -1), (1, 0), (-1, 0)].iter().any(|(dx, dy)| {
                    let (xx, yy) = (x as i64 + dx, y as i64 + dy);
                    (0..n as i64).contains(&xx)
                        && (0..n as i64).contains(&yy)
                        && a[yy as usize * n + xx as usize] != a[i]
                });
                assert!(near_edge, "pixel ({x}, {y}) differs away from the sphere's silhouette");
            }
        }
    }
    println!("{differ} of {area} covered pixels differ, all at the silhouette");
    assert!(differ * 10 < area, "{differ} pixels differ of {area}");
}

/// MIP and DVR against the f64 twin, which knows no macrocells: MIP is its dense sampling's
/// greatest value (64 samples a cell: below the exact maximum the shader finds by a fraction of
/// the interpolant's curvature, far under the 2/255 the comparison allows), DVR its integral on
/// the same lattice of samples run to the end (the shader stops once under 1/256 of the light
/// gets through, so it may lack up to 1/256 of what lies behind: the tolerance holds it). Each
/// with a mirror floor that reflects the volume and a sphere seen through it, on both
/// accelerators.
#[test]
fn mip_and_dvr_match_the_reference_in_front_of_and_in_mirrors() {
    let ctx = gpu();
    // (Placed so that no pixel centre falls on its reflection's silhouette, where f32 and f64
    // disagree whatever the volume does: at z = -4.5 one did.)
    let sphere = "[[sphere]]\ncenter = [0.3, -0.8, -4.7]\nradius = 1.5\nmaterial = \"bone\"";
    let scenes = [
        ("mip", scene("2.0", &format!("mode = \"mip\"\nwindow = [1.0, 6.0]\n{sphere}"))),
        ("dvr", scene("2.0", &format!("mode = \"dvr\"\nwindow = [0.5, 5.0]\nopacity = 0.25\n{sphere}"))),
        (
            "dvr-map",
            scene("2.0", &format!("mode = \"dvr\"\ncolormap = \"viridis\"\nwindow = [2.0, 3.0]\n{sphere}")),
        ),
    ];
    assert_match_on_both_accelerators(&ctx, &scenes);
}

/// Volumes seen through glass: a glass sphere between the eye and the volume refracts the
/// rays that then meet the isosurface, the MIP or the DVR (and the mirror floor behind), on
/// both accelerators against the f64 twin.
#[test]
fn volumes_show_through_glass() {
    let ctx = gpu();
    let glass = "[[material]]\nname = \"glass\"\ntype = \"dielectric\"\neta = 1.5\n\
                 [[sphere]]\ncenter = [0.4, 1.2, 5.5]\nradius = 1.3\nmaterial = \"glass\"";
    let scenes = [
        ("glass-iso", scene("2.0", glass)),
        ("glass-mip", scene("2.0", &format!("mode = \"mip\"\nwindow = [1.0, 6.0]\n{glass}"))),
        ("glass-dvr", scene("2.0", &format!("mode = \"dvr\"\nwindow = [0.5, 5.0]\nopacity = 0.25\n{glass}"))),
    ];
    assert_match_on_both_accelerators(&ctx, &scenes);
}

/// The real MRI template as a MIP: the shader's walk, which passes over every macrocell whose
/// greatest sample cannot raise the maximum found so far, against the reference's brute force
/// along each whole ray.
#[test]
fn an_mri_mip_matches_the_brute_force_maximum_along_each_ray() {
    let ctx = gpu();
    let src = format!(
        r#"
        background = [0.0, 0.0, 0.0]
        [camera]
        eye = [60.0, -260.0, 90.0]
        look_at = [0.0, -18.0, 18.0]
        up = [0.0, 0.0, 1.0]
        fov = 50
        width = 48
        height = 48
        [[volume]]
        file = "{}"
        mode = "mip"
        window = [20.0, 110.0]
        "#,
        data("mni152_t1.nii.gz")
    );
    let s = irt::io::toml::parse_str(&src, "mri-mip.toml").expect("scene");
    let reference = reference_image(&s);
    let lit = reference.pixels.iter().filter(|p| p[0] > 0.05).count();
    assert!(lit > 300, "the head covers {lit} pixels");
    let img = render_gpu_with(&ctx, &s, Settings::bands());
    assert_matches_reference("volume-mri-mip", &img, &reference);
}

/// A new isovalue, and a new look that keeps the transfer function, are written to the frame
/// uniform alone (nothing packed, nothing rebuilt), and the session then draws what a session
/// started on the edited scene draws.
#[test]
fn a_new_isovalue_or_look_changes_only_the_uniform_and_draws_the_edited_scene() {
    use irt::render::{Mode, Schedule, Session};
    let ctx = gpu();
    let settings = Settings {
        mode: Mode::Conventional { schedule: Schedule::Plain, workers: 0 },
        max_samples: 1,
        ..Settings::default()
    };
    let picture = |s: &mut Session| {
        s.complete_pass(&ctx);
        s.read_image(&ctx)
    };
    let start = scene("2.0", "");
    let mut session = Session::new(&ctx, &start, settings.clone()).unwrap();
    let before = picture(&mut session);
    let mut edits = Vec::new();
    let mut iso = start.clone();
    iso.volumes[0].isos[0].value = 2.5;
    edits.push(("isovalue", iso.clone(), true));
    let mut mip = iso.clone();
    mip.volumes[0].look = irt::scene::transfer::Look::Mip;
    edits.push(("look", mip.clone(), true));
    // A new transfer function is in the texture: packed again.
    let mut map = mip.clone();
    map.volumes[0].transfer.map = irt::scene::colour_map::ColourMap::Viridis;
    edits.push(("colour map", map, false));
    for (what, edited, uniform) in edits {
        let report = session.set_scene(&ctx, &edited).unwrap();
        assert_eq!(report.uniform_only, uniform, "{what}: {report:?}");
        if uniform {
            assert!(report.accel.is_none() && report.pack.is_zero() && !report.recompiled, "{what}");
        }
        let got = picture(&mut session);
        let fresh = picture(&mut Session::new(&ctx, &edited, settings.clone()).unwrap());
        assert!(got.pixels == fresh.pixels, "{what}: the edited session's picture");
        assert!(got.pixels != before.pixels, "{what}: the picture changed");
    }
}

/// `irt convert` keeps volumes: a MIP volume with a window, a colour map and a placement is
/// written as a `[[volume]]` table that loads back as the same volume, its layout too.
#[test]
fn a_volume_round_trips_through_the_toml_writer() {
    let s = scene(
        "2.0",
        "mode = \"mip\"\ncolormap = \"viridis\"\nwindow = [1.0, 6.0]\nrotate = [0, 30, 10]\ntranslate = [1, 2, 3]\nbrick = 4\nmacrocell_levels = 1",
    );
    let toml = irt::io::toml_write::to_toml(&s, &[]);
    let back = irt::io::toml::parse_str(&toml, "round-trip.toml").expect(&toml);
    let (a, b) = (&s.volumes[0], &back.volumes[0]);
    assert!(a.grid == b.grid && a.isos == b.isos && a.look == b.look && a.transfer == b.transfer);
    assert_eq!((a.layout.brick, a.layout.levels), (4, 1));
    assert_eq!(a.layout, b.layout, "{toml}");
    assert_eq!(a.transform, b.transform, "{toml}");
}

/// Bad `[[volume]]` keys fail in words, each at its own line of the file: the message names
/// what is wrong and the line holds the key.
#[test]
fn bad_volume_tables_fail_in_words_at_their_key() {
    for (key, words) in [
        ("window = [6.0, 1.0]", &["window"][..]),
        ("opacity = 2.0", &["opacity"]),
        ("mode = \"xray\"", &["unknown volume mode `xray`", "mip"]),
        ("colormap = \"jet\"", &["unknown colour map `jet`"]),
        ("matrix = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 0, 0]]", &["invertible"]),
        ("matrix = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0]]\nscale = 2", &["not both"]),
        ("brick = 3", &["brick 3 is not a power of two from 1 to 16"]),
        ("brick = 32", &["brick 32"]),
        ("macrocell_levels = 4", &["macrocell_levels 4 is more than 3"]),
    ] {
        let src = format!(
            "[camera]\neye = [0, 0, 9]\nlook_at = [0, 0, 0]\n[[volume]]\nfile = \"{}\"\niso = 2.0\n{key}\n",
            data("sphere_raw.nrrd")
        );
        let e = irt::io::toml::parse_str(&src, "bad.toml").expect_err(key).to_string();
        for w in words {
            assert!(e.contains(w), "{key}: message lacks '{w}': {e}");
        }
        let line = src.lines().position(|l| l == key.lines().next().unwrap()).unwrap() + 1;
        assert!(
            e.contains(&format!("line {line}")) || e.contains(&format!(":{line}:")),
            "{key}: not at line {line}: {e}"
        );
    }
}
