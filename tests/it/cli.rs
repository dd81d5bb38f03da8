//! The `irt` binary end to end: it renders, and bad input gives a clear error and a non-zero
//! exit, never a panic.
use std::path::PathBuf;
use std::process::{Command, Output};

fn irt(args: &[&str]) -> Output {
    // The pipeline cache goes to the test's own directory, not the user's ~/.cache.
    let cache = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("cli-cache");
    Command::new(env!("CARGO_BIN_EXE_irt")).args(args).env("IRT_CACHE_DIR", cache).output().expect("irt runs")
}

fn tmp(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("cli");
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// Asserts a clean failure whose message contains every one of `words`.
fn fails_with(out: &Output, words: &[&str]) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "expected failure, got success; stderr:\n{stderr}");
    assert!(!stderr.contains("panicked"), "irt panicked:\n{stderr}");
    for w in words {
        assert!(stderr.contains(w), "stderr lacks '{w}':\n{stderr}");
    }
}

#[test]
fn renders_the_default_scene_to_png() {
    // A directory of its own: other tests write (temporary files) beside `tmp`'s at the same time.
    let out_path = tmp("default").join("default.png");
    let _ = std::fs::remove_dir_all(out_path.parent().unwrap());
    std::fs::create_dir_all(out_path.parent().unwrap()).unwrap();
    let out = irt(&["render", "--size", "64x48", "--out", out_path.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let img = image::open(&out_path).expect("a readable PNG").to_rgb8();
    assert_eq!(img.dimensions(), (64, 48));
    // Not a blank frame: the default scene has many distinct colours.
    let mut colours: Vec<[u8; 3]> = img.pixels().map(|p| p.0).collect();
    colours.sort();
    colours.dedup();
    assert!(colours.len() > 100, "only {} distinct colours", colours.len());
    // Nothing but the PNG is left behind (the write is atomic via a temporary file).
    let leftovers: Vec<_> = std::fs::read_dir(out_path.parent().unwrap())
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
        .collect();
    assert!(leftovers.is_empty(), "temporary files left: {leftovers:?}");
}

#[test]
fn stats_prints_ray_counts_by_kind() {
    let out_path = tmp("stats.png");
    let out = irt(&["render", "--size", "32x24", "--stats", "--out", out_path.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stdout = String::from_utf8_lossy(&out.stdout);
    // One eye ray per pixel.
    assert!(stdout.contains("eye 768 "), "{stdout}");
    for kind in ["reflection", "refraction", "shadow"] {
        assert!(stdout.contains(kind), "{stdout}");
    }
}

#[test]
fn missing_scene_file() {
    fails_with(&irt(&["render", "no/such/scene.toml", "--out", "x.png"]), &["error:", "no/such/scene.toml"]);
}

/// A directory given as the scene is named as one (not "unknown scene file extension"), by
/// every command that reads a scene, before any device or window is opened.
#[test]
fn a_directory_is_not_a_scene() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes");
    let png = tmp("dir.png");
    for args in [
        &["render", dir, "--out", png.to_str().unwrap()][..],
        &["view", dir],
        &["replay", concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/paths/orbit.toml"), dir],
        &["bench", dir],
        &["convert", dir, tmp("dir.toml").to_str().unwrap()],
    ] {
        fails_with(&irt(args), &["error:", "is a directory", ".toml", ".ply"]);
    }
}

/// The help a user reads: one spelling of the image size, the formats irt reads, the keys of
/// the window, each command's own default size.
#[test]
fn help_is_true() {
    let help = |args: &[&str]| {
        let out = irt(args);
        assert!(out.status.success(), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
        String::from_utf8_lossy(&out.stdout).into_owned()
    };
    let top = help(&["--help"]);
    assert!(top.contains("--size 800x600") && !top.contains("--width"), "{top}");
    assert!(top.contains("(TOML, glTF/GLB, NFF, OBJ, PLY)") && top.contains("accelerator build"), "{top}");
    let formats = ".toml, .gltf, .glb, .nff, .obj, .ply";
    for command in ["render", "view", "replay", "bench", "tradeoff", "stability"] {
        let h = help(&[command, "--help"]);
        assert!(h.contains("--size <WxH>") && !h.contains("--width") && !h.contains("--height"), "{h}");
        assert!(h.contains(formats) && h.contains("--accel <ACCEL>"), "{command}: {h}");
        // A flag a command refuses is not offered.
        assert_eq!(h.contains("--shadows <MODE>"), command != "tradeoff", "{command}: {h}");
        assert_eq!(h.contains("--precision <BITS>"), command != "stability", "{command}: {h}");
        assert_eq!(h.contains("--backend"), command != "view", "{command}: {h}");
    }
    assert!(help(&["view", "--help"]).contains("Keys and mouse:"));
    assert!(help(&["bench", "--help"]).contains("[default: 512x512]"));
    assert!(help(&["tradeoff", "--help"]).contains("[default: 320x240]"));
    assert!(help(&["stability", "--help"]).contains("[default: 160x120]"));
}

/// The README's key list is the window's key table (src/app/keys.rs) rendered; the window's
/// `--help` lists the same rows.
#[test]
fn readme_keys_are_the_key_table() {
    let readme = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/README.md")).unwrap();
    let block =
        irt::app::keys::readme_block(&readme).expect("README.md has the keys block between its markers");
    let expected = irt::app::keys::markdown();
    assert!(
        block == expected,
        "README.md's keys block differs from src/app/keys.rs; replace it with:\n{expected}"
    );
    let out = irt(&["view", "--help"]);
    let help = String::from_utf8_lossy(&out.stdout);
    for b in irt::app::keys::TABLE {
        assert!(help.contains(&irt::app::keys::plain(b.words)), "--help lacks {:?}: {help}", b.words);
    }
    assert!(!help.contains("Esc, Q") && help.contains("Esc"), "{help}");
}

/// The measurement commands refuse a scene flag they would otherwise ignore.
#[test]
fn measurements_refuse_flags_they_would_ignore() {
    fails_with(&irt(&["tradeoff", "--shadows", "hard"]), &["--shadows", "--modes"]);
    fails_with(&irt(&["stability", "--precision", "f64"]), &["--precision", "side by side"]);
}

#[test]
fn zero_resolution() {
    fails_with(
        &irt(&["render", "--size", "0x48", "--out", tmp("z.png").to_str().unwrap()]),
        &["error:", "resolution"],
    );
}

#[test]
fn huge_resolution_is_refused_before_allocating() {
    let out = irt(&["render", "--size", "100000x100000", "--out", tmp("h.png").to_str().unwrap()]);
    fails_with(&out, &["error:", "exceeds"]);
}

#[test]
fn output_directory_must_exist() {
    fails_with(
        &irt(&["render", "--size", "8x8", "--out", "/no/such/dir/x.png"]),
        &["error:", "/no/such/dir"],
    );
}

#[test]
fn unknown_adapter_lists_the_available_ones() {
    let out = irt(&[
        "render",
        "--size",
        "8x8",
        "--adapter",
        "no-such-gpu",
        "--out",
        tmp("a.png").to_str().unwrap(),
    ]);
    fails_with(&out, &["error:", "no-such-gpu", "available"]);
}

#[test]
fn bad_arguments_are_usage_errors() {
    let out = irt(&["render", "--size", "-3x4"]);
    fails_with(&out, &["--size", "expected WxH"]);
    let out = irt(&["render", "--size", "64"]);
    fails_with(&out, &["--size", "expected WxH"]);
    let out = irt(&["frobnicate"]);
    fails_with(&out, &["frobnicate"]);
}

#[test]
fn info_names_the_device() {
    let out = irt(&["info"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stdout).contains("irt uses:"));
}

#[test]
fn spd_rules_trace_the_pixel_corners() {
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/spd/balls_s1.nff");
    let out_path = tmp("balls.png");
    let out = irt(&[
        "render",
        scene,
        "--size",
        "16x16",
        "--stats",
        "--spd-rules",
        "--out",
        out_path.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    // 17x17 corner rays, every one of them hits (the floor fills the view).
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("eye 289 (289 hit)"), "{stdout}");
    let img = image::open(&out_path).expect("a readable PNG").to_rgb8();
    assert_eq!(img.dimensions(), (16, 16));
    // The rules fix the shadow mode.
    fails_with(&irt(&["render", scene, "--spd-rules", "--shadows", "shell"]), &["--shadows"]);
}

#[test]
fn spd_writes_a_scalable_database_that_loads() {
    let path = tmp("tetra_s3.nff");
    let out = irt(&["spd", "tetra", "--size", "3", "--out", path.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stderr).contains("64 triangles"));
    let scene = irt::io::load(&path).unwrap();
    assert_eq!((scene.triangle_count(), scene.lights.len()), (64, 1));
    // Past what irt loads: refused before anything is generated, with the range.
    let big = tmp("balls_s8.nff");
    fails_with(
        &irt(&["spd", "balls", "--size", "8", "--out", big.to_str().unwrap()]),
        &["balls size 8", "1 to 7"],
    );
    assert!(!big.exists());
    fails_with(&irt(&["spd", "mount", "--out", big.to_str().unwrap()]), &["mount"]);
}

#[test]
fn nff_errors_name_the_place() {
    let path = tmp("bad.nff");
    std::fs::write(&path, "v\nfrom 0 0 5\nat 0 0 0\nup 0 1 0\nangle 40\nhither 1\nresolution 8 8\nq 1 2\n")
        .unwrap();
    let out = irt(&["render", path.to_str().unwrap(), "--out", tmp("bad.png").to_str().unwrap()]);
    fails_with(&out, &["bad.nff:8:1:", "unknown command `q`"]);
}

/// Decodes an OpenEXR file irt wrote into linear RGB pixels.
fn read_exr(path: &std::path::Path) -> irt::image::Image {
    let img = image::open(path).expect("a readable OpenEXR file");
    assert!(matches!(img, image::DynamicImage::ImageRgb32F(_)), "not RGB f32: {:?}", img.color());
    let img = img.into_rgb32f();
    let (width, height) = img.dimensions();
    irt::image::Image { width, height, pixels: img.pixels().map(|p| p.0).collect() }
}

#[test]
fn exr_output_is_the_linear_radiance_behind_the_png() {
    let (exr, png) = (tmp("radiance.exr"), tmp("radiance.png"));
    for path in [&exr, &png] {
        let _ = std::fs::remove_file(path);
        let out = irt(&["render", "--size", "32x24", "--out", path.to_str().unwrap()]);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    }
    let linear = read_exr(&exr);
    assert_eq!((linear.width, linear.height), (32, 24));
    // The same frame: the PNG is exactly the sRGB encoding of the EXR's floats.
    let png = image::open(&png).expect("a readable PNG").to_rgb8();
    assert_eq!(png.into_raw(), linear.to_srgb8());
    // Linear, not display values: the sRGB curve maps mid-grey 0.5 to 0.735, so an encoded image
    // would be brighter on average.
    let mean = linear.pixels.iter().flatten().map(|&c| c as f64).sum::<f64>() / (32.0 * 24.0 * 3.0);
    let srgb_mean = linear.to_srgb8().iter().map(|&c| c as f64 / 255.0).sum::<f64>() / (32.0 * 24.0 * 3.0);
    assert!(mean < srgb_mean, "mean {mean} vs sRGB mean {srgb_mean}");
}

#[test]
fn unsupported_output_extension_is_refused_before_rendering() {
    for name in ["x.jpg", "x"] {
        let path = tmp(name);
        let _ = std::fs::remove_file(&path);
        let out = irt(&["render", "--size", "8x8", "--out", path.to_str().unwrap()]);
        fails_with(&out, &["error:", name, ".png", ".exr"]);
        assert!(!path.exists(), "{} was created", path.display());
    }
    fails_with(
        &irt(&["render", "--size", "8x8", "--out", tmp("x.jpg").to_str().unwrap()]),
        &["unsupported image format .jpg"],
    );
    // Refused before the scene is even read.
    fails_with(&irt(&["render", "no/such/scene.toml", "--out", "x.jpg"]), &["x.jpg"]);
}

#[test]
fn upper_case_extensions_choose_the_format_too() {
    let (png, exr) = (tmp("UPPER.PNG"), tmp("UPPER.EXR"));
    for path in [&png, &exr] {
        let _ = std::fs::remove_file(path);
        let out = irt(&["render", "--size", "16x8", "--out", path.to_str().unwrap()]);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    }
    let bytes = std::fs::read(&png).unwrap();
    assert!(bytes.starts_with(b"\x89PNG\r\n\x1a\n"), "not a PNG");
    assert_eq!(image::load_from_memory(&bytes).unwrap().to_rgb8().dimensions(), (16, 8));
    let bytes = std::fs::read(&exr).unwrap();
    assert!(bytes.starts_with(&[0x76, 0x2f, 0x31, 0x01]), "not an OpenEXR file");
    assert_eq!((read_exr(&exr).width, read_exr(&exr).height), (16, 8));
}

/// Without $XDG_RUNTIME_DIR (containers, CI, ssh), Mesa's device-select layer probing for a
/// Wayland compositor made libwayland print "error: XDG_RUNTIME_DIR is invalid or not set in the
/// environment." on every command (src/gpu/instance.rs). Newer Mesa probes only when
/// $WAYLAND_DISPLAY is set, older Mesa always: both cases.
#[test]
fn no_runtime_dir_complaint_without_xdg_runtime_dir() {
    let tmpdir = tmp("runtime-tmp");
    std::fs::create_dir_all(&tmpdir).unwrap();
    for display in [None, Some("wayland-0")] {
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_irt"));
        cmd.arg("info")
            .env("IRT_CACHE_DIR", "off")
            .env("TMPDIR", &tmpdir)
            .env_remove("XDG_RUNTIME_DIR")
            .env_remove("WAYLAND_SOCKET");
        match display {
            Some(d) => cmd.env("WAYLAND_DISPLAY", d),
            None => cmd.env_remove("WAYLAND_DISPLAY"),
        };
        let out = cmd.output().expect("irt runs");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "WAYLAND_DISPLAY={display:?}: {stderr}");
        assert!(String::from_utf8_lossy(&out.stdout).contains("irt uses:"));
        assert!(!stderr.contains("XDG_RUNTIME_DIR"), "WAYLAND_DISPLAY={display:?}:\n{stderr}");
    }
    // What made it quiet: a private runtime directory in $TMPDIR.
    use std::os::unix::fs::PermissionsExt;
    let dir = tmpdir.join(format!("irt-runtime-{}", unsafe { libc::geteuid() }));
    assert_eq!(std::fs::metadata(&dir).expect("the private runtime dir").permissions().mode() & 0o777, 0o700);
}

#[test]
fn interactive_modes_render_the_same_file_headless() {
    let bands = tmp("modes-bands.png");
    let size = ["--size", "160x100"];
    let run = |extra: &[&str], out: &PathBuf| {
        let mut a = vec!["render", "--out", out.to_str().unwrap()];
        a.extend_from_slice(&size);
        a.extend_from_slice(extra);
        let o = irt(&a);
        assert!(o.status.success(), "{extra:?}: {}", String::from_utf8_lossy(&o.stderr));
        std::fs::read(out).unwrap()
    };
    let want = run(&[], &bands);
    for extra in [
        &["--mode", "conventional"][..],
        &["--mode", "conventional", "--schedule", "guided", "--workers", "3"],
        &["--mode", "frameless"],
        &["--mode", "frameless", "--order", "dissolve", "--slice", "1000"],
    ] {
        assert!(run(extra, &tmp("modes-other.png")) == want, "{extra:?} wrote a different image");
    }
}

#[test]
fn bad_mode_arguments_are_named() {
    let out = tmp("never.png");
    let o = irt(&["render", "--mode", "frameless", "--slice", "0", "--out", out.to_str().unwrap()]);
    fails_with(&o, &["--slice 0"]);
    let o = irt(&["render", "--mode", "frameless", "--order", "hilbert:8", "--out", out.to_str().unwrap()]);
    fails_with(&o, &["power of 4"]);
    let o =
        irt(&["render", "--mode", "conventional", "--schedule", "fixed:0", "--out", out.to_str().unwrap()]);
    fails_with(&o, &["fixed:0"]);
    let o = irt(&["render", "--mode", "diagonal", "--out", out.to_str().unwrap()]);
    fails_with(&o, &["conventional", "frameless"]);
    assert!(!out.exists());
}

/// `irt bench --workload primary-shadow --peer native`: both sides trace the same rays (the
/// counts printed agree) and the ratio is reported; without the workload, a clear refusal.
#[test]
fn bench_races_the_native_peer_on_the_same_rays() {
    let out = irt(&[
        "bench",
        "--workload",
        "primary-shadow",
        "--peer",
        "native",
        "--size",
        "64x64",
        "--frames",
        "1",
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let line = stdout.lines().find(|l| l.starts_with("rays/frame")).expect("a rays line");
    let counts: Vec<&str> =
        line.split_whitespace().filter(|w| w.chars().all(|c| c.is_ascii_digit() || c == ',')).collect();
    assert_eq!(counts.len(), 2, "{line}");
    assert_eq!(counts[0].trim_end_matches(','), counts[1], "irt and the peer traced different rays: {line}");
    assert!(stdout.contains("irt / native"), "{stdout}");
    fails_with(&irt(&["bench", "--peer", "native", "--size", "8x8"]), &["--workload primary-shadow"]);
}

/// `irt bench --simd`: a line per shader loop with its efficiency, a percentage no larger than
/// 100; with the peer rounds (which print their own table), a clear refusal.
#[test]
fn bench_prints_each_loops_simd_efficiency() {
    let out = irt(&["bench", "--simd", "--size", "32x24", "--frames", "1"]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(stdout.contains("SIMD efficiency"), "{stdout}");
    for name in irt::gpu::layout::SIMD_LOOPS {
        let line = stdout.lines().find(|l| l.trim_start().starts_with(name)).expect(name);
        let pct: f64 = line[line.find(name).unwrap() + name.len()..]
            .split_whitespace()
            .next()
            .and_then(|w| w.strip_suffix('%'))
            .and_then(|w| w.parse().ok())
            .unwrap_or_else(|| panic!("no percentage: {line}"));
        assert!(pct > 0.0 && pct <= 100.0, "{line}");
    }
    fails_with(
        &irt(&["bench", "--simd", "--workload", "primary-shadow", "--peer", "native"]),
        &["--simd", "--peer"],
    );
}

/// `--frames` writes one numbered file per frame, each what `--time` renders for its instant
/// (the sequence's session updates in place; the single render builds afresh: the same picture
/// within the golden tolerance, since their grid frames differ).
#[test]
fn frames_write_a_numbered_sequence_of_the_animation() {
    let dir = tmp("frames");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/animated.toml");
    let pattern = dir.join("f_%03d.png");
    let out = irt(&[
        "render",
        scene,
        "--size",
        "64x48",
        "--frames",
        "2..5",
        "--fps",
        "2",
        "--out",
        pattern.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("wrote 3 frames") && stderr.contains("per frame: update"), "{stderr}");
    let mut names: Vec<String> =
        std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into()).collect();
    names.sort();
    assert_eq!(names, ["f_002.png", "f_003.png", "f_004.png"]);
    // Frame 3 at 2 frames/s is t = 1.5 s.
    let single = dir.join("single.png");
    let out = irt(&["render", scene, "--size", "64x48", "--time", "1.5", "--out", single.to_str().unwrap()]);
    assert!(out.status.success());
    // Pixels off by more than 2 of 255 in a channel (the golden tolerance's measure).
    let off = |a: &std::path::Path, b: &std::path::Path| {
        let (a, b) = (image::open(a).unwrap().to_rgb8(), image::open(b).unwrap().to_rgb8());
        let bad =
            a.pixels().zip(b.pixels()).filter(|(p, q)| (0..3).any(|c| p.0[c].abs_diff(q.0[c]) > 2)).count();
        bad as f64 / (a.width() * a.height()) as f64
    };
    assert!(off(&dir.join("f_003.png"), &single) <= 0.0025, "frame 3 is the scene at 1.5 s");
    assert!(off(&dir.join("f_002.png"), &single) > 0.01, "frames 2 and 3 differ");
}

#[test]
fn animation_arguments_are_checked() {
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/animated.toml");
    let png = tmp("anim.png");
    let png = png.to_str().unwrap();
    fails_with(&irt(&["render", scene, "--frames", "0..4", "--out", png]), &["no frame number", "%04d"]);
    fails_with(&irt(&["render", scene, "--frames", "4..4", "--out", "f_%d.png"]), &["no frames"]);
    fails_with(&irt(&["render", scene, "--frames", "a..4", "--out", "f_%d.png"]), &["not a frame number"]);
    fails_with(&irt(&["render", scene, "--frames", "0..4", "--fps", "0", "--out", "f_%d.png"]), &["--fps"]);
    fails_with(&irt(&["render", scene, "--time", "nan", "--out", png]), &["--time", "finite"]);
    fails_with(
        &irt(&["render", scene, "--time", "1", "--frames", "0..2", "--out", "f_%d.png"]),
        &["cannot be used with"],
    );
}

/// `--peer native,embree`: with the `embree` feature, all three trace the same rays; without it,
/// a refusal that says how to build it.
#[test]
fn bench_embree_peer_or_how_to_build_it() {
    let args = ["bench", "--workload", "primary-shadow", "--peer", "native,embree"];
    let size = ["--size", "64x64", "--frames", "1"];
    let out = irt(&[&args[..], &size[..]].concat());
    if cfg!(feature = "embree") {
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let line = stdout.lines().find(|l| l.starts_with("rays/frame")).expect("a rays line");
        let counts: Vec<&str> = line
            .split_whitespace()
            .map(|w| w.trim_end_matches(','))
            .filter(|w| w.chars().all(|c| c.is_ascii_digit()))
            .collect();
        assert_eq!(counts.len(), 3, "{line}");
        assert!(counts.iter().all(|c| *c == counts[0]), "irt and the peers traced different rays: {line}");
        assert!(stdout.contains("irt / embree"), "{stdout}");
    } else {
        fails_with(&out, &["built without Embree", "--features embree", "libembree-dev"]);
    }
}

/// `--backend ash` runs the interactive modes and image sequences too, writing the files the
/// wgpu path writes, byte for byte.
#[test]
fn ash_renders_modes_and_sequences_like_wgpu() {
    let size = ["--size", "64x48"];
    let cases: [(&str, &[&str]); 3] = [
        ("frameless", &["--mode", "frameless"]),
        ("conventional", &["--mode", "conventional"]),
        ("frames_%02d", &["scenes/animated.toml", "--frames", "3..5", "--fps", "2"]),
    ];
    for (name, extra) in cases {
        let mut files = Vec::new();
        for backend in ["wgpu", "ash"] {
            let out = tmp(&format!("ash-{backend}-{name}.png"));
            let path = out.to_str().unwrap();
            let mut args = vec!["render", "--backend", backend, "--out", path];
            args.extend_from_slice(&size);
            args.extend_from_slice(extra);
            let run = irt(&args);
            assert!(run.status.success(), "{backend} {name}: {}", String::from_utf8_lossy(&run.stderr));
            files.push(path.replace("%02d", "04"));
        }
        let read = |p: &String| std::fs::read(p).unwrap_or_else(|e| panic!("{p}: {e}"));
        assert_eq!(read(&files[0]), read(&files[1]), "{name}: the two paths wrote different files");
    }
}

/// A scene file's `[trace] shadows = "soft"` is resolved for the scene as traced, and says what
/// it picked; `--shadows` overrides it; `irt convert` keeps the word.
#[test]
fn a_scene_file_asks_for_soft_shadows() {
    let text = std::fs::read_to_string("scenes/shadows.toml").unwrap();
    assert!(!text.contains("[trace]"), "the test adds its own [trace] table");
    let file = tmp("soft.toml");
    std::fs::write(&file, format!("{text}\n[trace]\nshadows = \"soft\"\n")).unwrap();
    let out_path = tmp("soft.png");
    let render = |extra: &[&str]| {
        let mut args =
            vec!["render", file.to_str().unwrap(), "--size", "64x48", "--out", out_path.to_str().unwrap()];
        args.extend_from_slice(extra);
        let out = irt(&args);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    // Its lights are points: soft has nothing to soften …
    let said = render(&[]);
    assert!(said.contains("shadows: soft → hard (point lights only)"), "the pick is not said:\n{said}");
    // … until the command line gives them a radius, which the pick sees.
    let said = render(&["--light-radius", "0.3"]);
    assert!(said.contains("shadows: soft → ") && !said.contains("point lights"), "{said}");
    let said = render(&["--shadows", "hard", "--light-radius", "0.3"]);
    assert!(!said.contains("soft →"), "--shadows hard still ran the soft pilot:\n{said}");
    let back = tmp("soft-back.toml");
    let out = irt(&["convert", file.to_str().unwrap(), back.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(std::fs::read_to_string(&back).unwrap().contains("shadows = \"soft\""));
}
