//! The on-disk pipeline cache, through the `irt` binary: each run gets its own IRT_CACHE_DIR in
//! the child's environment, so tests never race on a shared directory or on this process's env.
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn dir(name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("pipeline_cache").join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Renders the default scene at 48x32 into `out` with `IRT_CACHE_DIR=cache` and `extra` args.
fn render(cache: &str, out: &Path, extra: &[&str]) -> Output {
    let out = Command::new(env!("CARGO_BIN_EXE_irt"))
        .args(["render", "--size", "48x32", "--out", out.to_str().unwrap()])
        .args(extra)
        .env("IRT_CACHE_DIR", cache)
        .env("RUST_LOG", "warn")
        .output()
        .expect("irt runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "render failed:\n{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    out
}

fn info(cache: &str, extra: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_irt"))
        .arg("info")
        .args(extra)
        .env("IRT_CACHE_DIR", cache)
        .output()
        .expect("irt runs");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn cache_files(d: &Path) -> Vec<PathBuf> {
    std::fs::read_dir(d)
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "bin"))
        .collect()
}

fn pixels(p: &Path) -> Vec<u8> {
    image::open(p).expect("a readable PNG").to_rgb8().into_raw()
}

fn supported() -> bool {
    let d = dir("probe");
    let text = info(d.to_str().unwrap(), &[]);
    if text.contains("lacks PIPELINE_CACHE") {
        eprintln!("skipping: this adapter has no PIPELINE_CACHE");
        return false;
    }
    true
}

#[test]
fn second_start_loads_the_cache_and_renders_the_same_image() {
    if !supported() {
        return;
    }
    let d = dir("warm");
    let cache = d.join("cache");
    let c = cache.to_str().unwrap();
    render(c, &d.join("first.png"), &[]);
    let files = cache_files(&cache);
    assert_eq!(files.len(), 1, "one cache file per adapter: {files:?}");
    let saved = std::fs::read(&files[0]).unwrap();
    assert!(!saved.is_empty());
    assert!(info(c, &[]).contains("bytes loaded"), "the next start loads it");
    render(c, &d.join("second.png"), &[]);
    assert_eq!(pixels(&d.join("first.png")), pixels(&d.join("second.png")));
    // No temporary files left beside it.
    let tmp: Vec<_> = std::fs::read_dir(&cache)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
        .collect();
    assert!(tmp.is_empty(), "{tmp:?}");
}

#[test]
fn a_corrupt_cache_file_is_ignored_with_a_warning_and_rewritten() {
    if !supported() {
        return;
    }
    let d = dir("corrupt");
    let cache = d.join("cache");
    let c = cache.to_str().unwrap();
    render(c, &d.join("clean.png"), &[]);
    let file = cache_files(&cache).pop().expect("a cache file");
    let good = std::fs::read(&file).unwrap();
    // Garbage; a damaged body (irt's checksum no longer matches); and an intact irt envelope
    // around bytes wgpu rejects (what a foreign or outdated cache looks like to wgpu).
    let mut damaged = good.clone();
    *damaged.last_mut().unwrap() ^= 0x5a;
    let foreign = envelope(b"WGPUPLCH but nothing wgpu accepts");
    for bad in [b"not a pipeline cache at all, just garbage bytes".to_vec(), damaged, foreign] {
        std::fs::write(&file, &bad).unwrap();
        let out = render(c, &d.join("after.png"), &[]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(stderr.contains("ignoring pipeline cache"), "no warning:\n{stderr}");
        eprintln!("{stderr}");
        assert_eq!(pixels(&d.join("clean.png")), pixels(&d.join("after.png")));
        assert_eq!(std::fs::read(&file).unwrap(), good, "the bad file is replaced");
    }
}

/// irt's file envelope (src/gpu/cache.rs) around `data`.
fn envelope(data: &[u8]) -> Vec<u8> {
    let fnv =
        data.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| (h ^ b as u64).wrapping_mul(0x0100_0000_01b3));
    let mut out = b"IRTPCv1\n".to_vec();
    out.extend_from_slice(&(data.len() as u64).to_le_bytes());
    out.extend_from_slice(&fnv.to_le_bytes());
    out.extend_from_slice(data);
    out
}

#[test]
fn an_unwritable_cache_directory_never_fails_a_render() {
    if !supported() {
        return;
    }
    let d = dir("unwritable");
    // A regular file where the directory should be: every save fails.
    let blocker = d.join("not-a-dir");
    std::fs::write(&blocker, b"x").unwrap();
    let out = render(blocker.to_str().unwrap(), &d.join("img.png"), &[]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("could not save pipeline cache"), "{stderr}");
}

#[test]
fn the_cache_can_be_turned_off() {
    let d = dir("off");
    let cache = d.join("cache");
    let c = cache.to_str().unwrap();
    render(c, &d.join("a.png"), &["--no-cache"]);
    assert!(!cache.exists(), "--no-cache wrote {}", cache.display());
    assert!(info(c, &["--no-cache"]).contains("pipeline cache: off (disabled by --no-cache)"));
    render("off", &d.join("b.png"), &[]);
    assert!(info("off", &[]).contains("pipeline cache: off (disabled by IRT_CACHE_DIR=off)"));
    assert!(!Path::new("off").exists(), "IRT_CACHE_DIR=off is not a directory name");
    assert_eq!(pixels(&d.join("a.png")), pixels(&d.join("b.png")));
}
