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
    for (name, s) in scenes {
        let reference = reference_image(&s);
        for accel in [AccelChoice::Bvh, AccelChoice::Grid] {
            let img = render_gpu_with(&ctx, &s, Settings { accel, ..Settings::bands() });
            assert_matches_reference(&format!("volume-{name}-{accel}"), &img, &reference);
        }
    }
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
