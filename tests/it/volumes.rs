//! Volume files (tests/data/volumes, written by its make.py with numpy and nibabel, and a real
//! MRI template from nilearn's wheel): every format and encoding gives the same grid, and bad
//! files fail in words, with the limits checked before anything is allocated.

use glam::DVec3;
use irt::io::volume;
use irt::scene::volume::{Grid, Voxels};
use std::path::{Path, PathBuf};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/volumes").join(name)
}

const DIMS: [u32; 3] = [17, 15, 13];
const CENTRE: DVec3 = DVec3::new(0.25, -0.5, 0.75);

fn world(g: &Grid, [i, j, k]: [u32; 3]) -> DVec3 {
    g.origin + DVec3::new(i as f64, j as f64, k as f64) * g.spacing
}

/// Every sample is the distance from its world position to the centre, within `tolerance`:
/// the grid's placement and its samples' order both checked at once.
fn assert_distance_field(name: &str, tolerance: f64) {
    let g = volume::load(&data(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
    assert_eq!(g.dims, DIMS, "{name}");
    assert!((g.spacing - DVec3::new(0.5, 0.5, 0.6)).abs().max_element() < 1e-6, "{name}: {}", g.spacing);
    assert!((g.origin - DVec3::new(-4.0, -3.5, -3.6)).abs().max_element() < 1e-6, "{name}: {}", g.origin);
    let mut worst: f64 = 0.0;
    for k in 0..DIMS[2] {
        for j in 0..DIMS[1] {
            for i in 0..DIMS[0] {
                let want = (world(&g, [i, j, k]) - CENTRE).length();
                worst = worst.max((g.at(i, j, k) as f64 - want).abs());
            }
        }
    }
    assert!(worst <= tolerance, "{name}: a sample is {worst} from the distance");
}

#[test]
fn every_format_and_encoding_gives_the_same_field() {
    // float32 files hold the field to f32's rounding (the ascii ones to 9 digits).
    for name in
        ["sphere_raw.nrrd", "sphere_ascii.nrrd", "sphere_gzip.nhdr", "sphere_ascii.vti", "sphere_binary.vti"]
    {
        assert_distance_field(name, 1e-5);
    }
    // The sform runs x backwards: the reader flips the samples so x runs forwards.
    assert_distance_field("sphere_flipped.nii.gz", 1e-5);
    // uint16 of the field times 1000, big-endian: half a step of 1/1000 (a factor of 1000 kept
    // in the samples, so compare scaled).
    let g = volume::load(&data("sphere_u16be.nrrd")).unwrap();
    assert!(matches!(g.voxels, Voxels::U16(_)));
    let want = (world(&g, [3, 4, 5]) - CENTRE).length() * 1000.0;
    assert!((g.at(3, 4, 5) as f64 - want).abs() <= 0.5, "{} against {want}", g.at(3, 4, 5));
    // int16 with nibabel's scl_slope (1.07e-4) and scl_inter: within half a step of the slope.
    assert_distance_field("sphere_int16_qform.nii", 0.6e-4);
}

#[test]
fn a_real_mri_template_loads_where_its_header_puts_it() {
    let g = volume::load(&data("mni152_t1.nii.gz")).unwrap();
    assert_eq!(g.dims, [197, 233, 189]);
    assert!(matches!(g.voxels, Voxels::U8(_)), "{}", g.voxels.type_name());
    assert_eq!((g.spacing, g.origin), (DVec3::ONE, DVec3::new(-98.0, -134.0, -72.0)));
    assert_eq!(g.range(), (0.0, 255.0));
    // The head is in the middle and air at the corners.
    assert_eq!(g.at(0, 0, 0), 0.0);
    assert!(g.at(98, 116, 94) > 50.0, "{}", g.at(98, 116, 94));
}

fn dir(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("volumes").join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// `bytes` written as `name` fail to load with every one of `words` in the message.
fn fails(d: &Path, name: &str, bytes: &[u8], words: &[&str]) {
    let path = d.join(name);
    std::fs::write(&path, bytes).unwrap();
    let e = volume::load(&path).expect_err(name).to_string();
    for w in words {
        assert!(e.contains(w), "{name}: `{w}` not in: {e}");
    }
    assert!(e.contains(name), "{name}: the message names the file: {e}");
}

fn nrrd(fields: &str, data: &[u8]) -> Vec<u8> {
    let mut b = format!("NRRD0004\n{fields}\n").into_bytes();
    b.extend_from_slice(data);
    b
}

#[test]
fn bad_nrrd_files_fail_in_words_before_allocating() {
    let d = dir("nrrd");
    let base = "type: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n";
    let ok = nrrd(base, &[0; 8]);
    std::fs::write(d.join("ok.nrrd"), &ok).unwrap();
    assert_eq!(volume::load(&d.join("ok.nrrd")).unwrap().dims, [2, 2, 2]);
    // Sizes that promise more samples than the file holds.
    fails(&d, "short.nrrd", &nrrd(base, &[0; 7]), &["7 bytes of data", "need 8"]);
    // Past the limit: refused from the header (a 64 GiB allocation would be the other way).
    let huge = "type: float\ndimension: 3\nsizes: 4096 4096 4096\nencoding: raw\n";
    fails(&d, "huge.nrrd", &nrrd(huge, &[0; 8]), &["4096x4096x4096", "limited to"]);
    fails(&d, "type.nrrd", &nrrd(&base.replace("uint8", "block"), &[0; 8]), &["type `block`", ":2:"]);
    fails(&d, "enc.nrrd", &nrrd(&base.replace("raw", "bzip2"), &[0; 8]), &["encoding `bzip2`"]);
    fails(
        &d,
        "dim.nrrd",
        &nrrd("type: uint8\ndimension: 2\nsizes: 4 2\nencoding: raw\n", &[0; 8]),
        &["3-dimensional"],
    );
    fails(&d, "magic.nrrd", b"PLY\n", &["not a NRRD file"]);
    let oblique = format!("{base}space directions: (1,1,0) (0,1,0) (0,0,1)\n");
    fails(&d, "oblique.nrrd", &nrrd(&oblique, &[0; 8]), &["axis 0 runs along", "rotate"]);
    // A gzip stream cut short.
    let whole = {
        use std::io::Write;
        let mut z = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
        z.write_all(&[7u8; 8 * 1000]).unwrap();
        z.finish().unwrap()
    };
    let gz = "type: uint8\ndimension: 3\nsizes: 10 10 80\nencoding: gzip\n";
    std::fs::write(d.join("gz.nrrd"), nrrd(gz, &whole)).unwrap();
    assert_eq!(volume::load(&d.join("gz.nrrd")).unwrap().at(9, 9, 79), 7.0);
    fails(&d, "cut.nrrd", &nrrd(gz, &whole[..whole.len() / 2]), &["gzip"]);
    let more = "type: uint8\ndimension: 3\nsizes: 10 10 40\nencoding: gzip\n";
    fails(&d, "more.nrrd", &nrrd(more, &whole), &["more than the 4000 bytes"]);
    // A detached header whose data file is missing.
    let detached = format!("NRRD0004\n{base}data file: nowhere.raw\n");
    fails(&d, "lost.nhdr", detached.as_bytes(), &["nowhere.raw", "data file"]);
    // NaN samples.
    let nan: Vec<u8> = (0..8).flat_map(|i| if i == 3 { f32::NAN } else { 1.0 }.to_le_bytes()).collect();
    fails(&d, "nan.nrrd", &nrrd(&base.replace("uint8", "float"), &nan), &["sample 3 is NaN"]);
}

#[test]
fn bad_nifti_and_vti_files_fail_in_words() {
    let d = dir("nifti");
    let good = std::fs::read(data("sphere_int16_qform.nii")).unwrap();
    // Cut in its voxels.
    fails(&d, "cut.nii", &good[..good.len() - 100], &["truncated"]);
    // Cut in its header.
    fails(&d, "stub.nii", &good[..100], &["not a NIfTI-1 file"]);
    // Two time points.
    let mut four = good.clone();
    four[40..42].copy_from_slice(&4i16.to_le_bytes());
    four[48..50].copy_from_slice(&2i16.to_le_bytes());
    fails(&d, "four.nii", &four, &["one time point"]);
    // A datatype NIfTI does not have.
    let mut odd = good.clone();
    odd[70..72].copy_from_slice(&3i16.to_le_bytes());
    fails(&d, "odd.nii", &odd, &["datatype 3"]);
    let vti = std::fs::read_to_string(data("sphere_ascii.vti")).unwrap();
    fails(
        &d,
        "short.vti",
        vti.replace("0 16 0 14", "0 17 0 14").as_bytes(),
        &["no point-data array of 18x15x13 = 3510 values"],
    );
    fails(&d, "poly.vti", b"<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\">", &["VTK"]);
}

/// A small deterministic generator, so that a failure names its case.
fn lcg(seed: &mut u64) -> f64 {
    *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    (*seed >> 11) as f64 / (1u64 << 53) as f64
}

/// The sampled distance field's level set 2 is the sphere of radius 2 about its centre: the
/// f64 reference's hits lie on irt's analytic sphere. Tolerance: trilinear interpolation of a
/// distance r errs by at most (hx² + hy² + hz²) / (8 r) = 0.054 here (spacings 0.5, 0.5, 0.6 at
/// r = 2), and the field's gradient has length 1, so a hit is within 0.055 of the sphere. The
/// interpolant's gradient (the normal) is right to first order only: each component errs by up
/// to h |f''| / 2 = 0.15, so up to 15 degrees. On average it measured 4.7; the mean is held under
/// half the worst case (7.5), which a gradient with a swapped or negated axis would break.
#[test]
fn the_isosurface_of_a_sampled_distance_field_is_the_analytic_sphere() {
    let g = volume::load(&data("sphere_raw.nrrd")).unwrap();
    let mut seed = 11u64;
    let (mut angles, mut count) = (0.0, 0);
    for case in 0..400 {
        let from = CENTRE
            + DVec3::new(lcg(&mut seed) - 0.5, lcg(&mut seed) - 0.5, lcg(&mut seed) - 0.5).normalize() * 30.0;
        let aim = CENTRE + DVec3::new(lcg(&mut seed) - 0.5, lcg(&mut seed) - 0.5, lcg(&mut seed) - 0.5) * 2.5;
        let dir = (aim - from).normalize();
        let analytic = irt::reference::intersect_sphere(from, dir, CENTRE, 2.0, 0.0, f64::INFINITY);
        let sampled = irt::reference::volume::iso_hit(&g, from, dir, [0.0, f64::INFINITY], 2.0);
        match (analytic, sampled) {
            (Some(t), Some((s, n))) => {
                let off = ((from + dir * s - CENTRE).length() - 2.0).abs();
                assert!(
                    off < 0.055,
                    "case {case}: the isosurface hit at {s} is {off} off the sphere (hit at {t})"
                );
                let want = (from + dir * t - CENTRE).normalize();
                let angle = n.dot(want).clamp(-1.0, 1.0).acos().to_degrees();
                assert!(angle < 15.0, "case {case}: normal {n} against {want}");
                (angles, count) = (angles + angle, count + 1);
            }
            (None, None) => {}
            // Within the tolerance of the silhouette.
            (a, s) => {
                let miss = (CENTRE - from).cross(dir).length() - 2.0;
                assert!(
                    miss.abs() < 0.06,
                    "case {case}: sphere {a:?}, isosurface {s:?}, {miss} from the rim"
                );
            }
        }
    }
    assert!(count > 200, "{count} rays hit");
    assert!(
        angles / (count as f64) < 7.5,
        "the normals are {} degrees off on average",
        angles / count as f64
    );
}

/// The walk through the macrocells with the cell's cubic finds what the independent dense
/// sampling finds, on a real MRI volume at several isovalues: the same first hit to 1e-6 of a
/// voxel, and never a miss where the sampling hits. The cubic may find a crossing pair closer
/// than the sampling's step (a graze) that the sampling steps over: those hits come earlier,
/// and are fewer than 1 in 100.
#[test]
fn the_macrocell_walk_finds_the_reference_s_hits_on_a_real_volume() {
    let g = volume::load(&data("mni152_t1.nii.gz")).unwrap();
    let m = irt::accel::macrocells::Macrocells::build(&g);
    let (lo, hi) = g.bounds();
    let mut seed = 5u64;
    let (mut hits, mut grazes, mut rays) = (0, 0, 0);
    for iso in [40.0f32, 80.0, 150.0] {
        for case in 0..150 {
            let inside = lo + (hi - lo) * DVec3::new(lcg(&mut seed), lcg(&mut seed), lcg(&mut seed));
            let dir =
                DVec3::new(lcg(&mut seed) - 0.5, lcg(&mut seed) - 0.5, lcg(&mut seed) - 0.5).normalize();
            let from = inside - dir * 400.0;
            let walked = m.iso_hit(&g, from, dir, [0.0, f64::INFINITY], iso);
            let sampled = irt::reference::volume::iso_hit(&g, from, dir, [0.0, f64::INFINITY], iso as f64);
            rays += 1;
            match (walked, sampled) {
                (Some(w), Some((s, _))) if (w - s).abs() <= 1e-6 => hits += 1,
                (Some(w), Some((s, _))) if w < s => grazes += 1,
                (Some(_), None) => grazes += 1,
                (None, None) => {}
                (w, s) => panic!("iso {iso} case {case}: the walk gives {w:?}, the sampling {s:?}"),
            }
        }
    }
    assert!(hits > rays / 3, "{hits} of {rays} rays hit");
    assert!(grazes * 100 < rays, "{grazes} grazes of {rays}");
}
