//! Batch on a farm, as a job array runs it: `irt render --tile I/N --out DIR` per task, then
//! `irt merge DIR --out F`. The merged picture is `irt render`'s file byte for byte; a merge
//! with a tile missing or foreign writes nothing; a task run twice changes nothing; a task killed
//! at any moment leaves a whole tile or none.

use irt::farm::Tile;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::Duration;

const IRT: &str = env!("CARGO_BIN_EXE_irt");

fn dir(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("farm").join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn irt(args: &[&str]) -> Output {
    Command::new(IRT).args(args).output().unwrap()
}

fn ok(args: &[&str]) -> String {
    let out = irt(args);
    assert!(out.status.success(), "irt {args:?}: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn size(w: u32, h: u32) -> Vec<String> {
    vec!["--size".into(), format!("{w}x{h}")]
}

/// Renders `args` whole and as `n` tiles merged, to `ext`; the files must be the same bytes.
fn assert_tiles_merge_to_the_render(name: &str, args: &[String], n: u32, ext: &str) {
    let d = dir(name);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let whole = d.join(format!("whole.{ext}"));
    let merged = d.join(format!("merged.{ext}"));
    let tiles = d.join("tiles");
    ok(&[&["render", "--out", whole.to_str().unwrap()], &args[..]].concat());
    // In another order than the indexes: the farm runs them as it likes.
    for i in (0..n).rev() {
        let spec = format!("{i}/{n}");
        ok(&[&["render", "--tile", &spec, "--out", tiles.to_str().unwrap()], &args[..]].concat());
    }
    ok(&["merge", tiles.to_str().unwrap(), "--out", merged.to_str().unwrap()]);
    assert!(std::fs::read(&whole).unwrap() == std::fs::read(&merged).unwrap(), "{name}: the merge differs");
}

#[test]
fn every_split_merges_to_the_whole_render_bit_for_bit() {
    // Awkward sizes: columns that are no multiple of the 32-pixel tiles, an odd height, seven
    // tiles of uneven rows.
    assert_tiles_merge_to_the_render("one", &size(97, 61), 1, "png");
    assert_tiles_merge_to_the_render("three", &size(97, 61), 3, "png");
    assert_tiles_merge_to_the_render("seven", &size(130, 45), 7, "exr");
    // Refinement and soft shadows: the samples' jitter and bundle rotation depend on the pixel
    // and the sample only, never on the tile.
    let mut refined = size(70, 50);
    refined.extend(["--mode", "conventional", "--samples", "3", "--shadows", "bundle:8"].map(String::from));
    assert_tiles_merge_to_the_render("refined", &refined, 3, "exr");
}

#[test]
fn a_picture_past_the_device_s_buffers_merges_from_its_tiles_in_every_mode() {
    // 4096² is twice what lavapipe's 128 MiB bindings hold: the whole render is traced in
    // pieces, each quarter whole; the pieces' seams must not show in the merge.
    assert_tiles_merge_to_the_render("big-bands", &size(4096, 4096), 4, "png");
    let mut conventional = size(4096, 4096);
    conventional.extend(["--mode", "conventional", "--samples", "2"].map(String::from));
    assert_tiles_merge_to_the_render("big-conventional", &conventional, 4, "png");
    // A farm cuts no frameless pass into tiles (it renders stills); the frameless picture in
    // pieces is the bands' picture, so it must be the merge of the bands' tiles.
    let frameless = dir("big-frameless").join("whole.png");
    let size = size(4096, 4096);
    ok(&[
        &["render", "--mode", "frameless", "--out", frameless.to_str().unwrap()],
        &[size[0].as_str(), &size[1]][..],
    ]
    .concat());
    let merged = Path::new(env!("CARGO_TARGET_TMPDIR")).join("farm/big-bands/merged.png");
    assert!(
        std::fs::read(&frameless).unwrap() == std::fs::read(&merged).unwrap(),
        "frameless: not the bands' merge"
    );
}

#[test]
fn the_merge_refuses_missing_or_foreign_tiles_and_writes_nothing() {
    let d = dir("refuse");
    let tiles = d.join("tiles");
    let t = tiles.to_str().unwrap();
    let out = d.join("out.png");
    let small = size(64, 40);
    let small: Vec<&str> = small.iter().map(String::as_str).collect();
    for i in [0, 2, 4] {
        ok(&[&["render", "--tile", &format!("{i}/5"), "--out", t], &small[..]].concat());
    }
    let r = irt(&["merge", t, "--out", out.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(!r.status.success() && err.contains("2 of 5 tiles missing (1, 3)"), "{err}");
    assert!(!out.exists());
    // Tile 1 of another render (other shadows) beside the others.
    ok(&[&["render", "--tile", "1/5", "--out", t, "--shadows", "bundle:4"], &small[..]].concat());
    let r = irt(&["merge", t, "--out", out.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(!r.status.success() && err.contains("different renders"), "{err}");
    assert!(!out.exists());
    // And the task of this render whose tile name is taken says so instead of replacing it.
    let r = irt(&[&["render", "--tile", "1/5", "--out", t], &small[..]].concat());
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(!r.status.success() && err.contains("already there from another render"), "{err}");
    let r = irt(&["merge", d.join("nothing").to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert!(!r.status.success());
    assert!(!out.exists());
}

#[test]
fn a_task_run_again_changes_nothing() {
    let d = dir("again");
    let t = d.join("tiles");
    let args = ["render", "--tile", "1/2", "--out", t.to_str().unwrap(), "--size", "64x32"];
    ok(&args);
    let file = t.join(Tile::file_name("1/2".parse().unwrap()));
    let (bytes, modified) =
        (std::fs::read(&file).unwrap(), std::fs::metadata(&file).unwrap().modified().unwrap());
    let said = ok(&args);
    assert!(said.contains("nothing to do"), "{said}");
    assert_eq!(std::fs::read(&file).unwrap(), bytes);
    assert_eq!(std::fs::metadata(&file).unwrap().modified().unwrap(), modified);
}

#[test]
fn a_task_killed_at_any_moment_leaves_a_whole_tile_or_none() {
    let d = dir("killed");
    let t = d.join("tiles");
    // Long enough (bundle shadows, refined) that the kills land before, during and after the
    // write.
    let args = [
        "render",
        "--tile",
        "0/1",
        "--out",
        t.to_str().unwrap(),
        "--size",
        "200x150",
        "--mode",
        "conventional",
        "--samples",
        "4",
        "--shadows",
        "bundle:16",
    ];
    let mut outcomes = [0, 0];
    for delay_ms in [50, 150, 300, 500, 800, 1200, 2000, 3000] {
        let _ = std::fs::remove_dir_all(&t);
        let mut child = Command::new(IRT).args(args).stdout(std::process::Stdio::null()).spawn().unwrap();
        std::thread::sleep(Duration::from_millis(delay_ms));
        let _ = child.kill();
        child.wait().unwrap();
        let files: Vec<_> =
            std::fs::read_dir(&t).map(|r| r.flatten().map(|e| e.path()).collect()).unwrap_or_default();
        match files.as_slice() {
            [] => outcomes[0] += 1,
            [one] => {
                Tile::decode(&std::fs::read(one).unwrap(), false)
                    .unwrap_or_else(|e| panic!("killed at {delay_ms} ms: {e}"));
                outcomes[1] += 1;
            }
            more => panic!("killed at {delay_ms} ms, the directory holds {more:?}"),
        }
    }
    eprintln!("no tile after {} kills, a whole one after {}", outcomes[0], outcomes[1]);
}

/// Volumes on the farm: each task loads the volume file itself, so a DVR and an isosurface
/// picture split into tiles merge to the whole render.
#[test]
fn volume_pictures_merge_from_their_tiles() {
    let file = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/volumes/sphere_raw.nrrd");
    for (name, look) in [("volume-iso", "iso"), ("volume-dvr", "dvr")] {
        let mut args = size(75, 53);
        args.extend([file, "--volume-mode", look].map(String::from));
        assert_tiles_merge_to_the_render(name, &args, 3, "png");
    }
}

/// Newell's teapot as Bezier patches: each tile's Newton solves are the whole render's.
#[test]
fn patch_pictures_merge_from_their_tiles() {
    let file = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/teapot-patches.obj");
    let mut args = size(81, 57);
    args.extend([file, "--mode", "conventional", "--samples", "2"].map(String::from));
    assert_tiles_merge_to_the_render("patches", &args, 3, "png");
}
