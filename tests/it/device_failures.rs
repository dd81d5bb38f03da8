//! A device that fails (an allocation it refuses, a lost device), forced by `IRT_FAULT`: the
//! command says so in words and what to do, exits non-zero, panics not, names no source file
//! and writes no picture. Under MPI: `distributed`'s tests.
use std::process::Command;

const IRT: &str = env!("CARGO_BIN_EXE_irt");

#[test]
fn a_failing_device_is_reported_in_words() {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("device_failures");
    std::fs::create_dir_all(&dir).unwrap();
    for (fault, words) in [
        ("device-alloc", ["the device refused irt's work", "a smaller --size"]),
        ("device-lost", ["the device was lost", "run the command again"]),
    ] {
        for mode in [&[][..], &["--mode", "conventional"], &["--mode", "frameless"]] {
            let out = dir.join(format!("{fault}-{}.png", mode.len()));
            let _ = std::fs::remove_file(&out);
            let r = Command::new(IRT)
                .args(["render", "--size", "96x64", "--out", out.to_str().unwrap()])
                .args(mode)
                .env("IRT_FAULT", fault)
                .output()
                .unwrap();
            let err = String::from_utf8_lossy(&r.stderr);
            assert_eq!(r.status.code(), Some(1), "{fault}, {mode:?}: {err}");
            for w in words {
                assert!(err.contains(w), "{fault}, {mode:?}: lacks {w:?}:\n{err}");
            }
            assert!(!err.contains("panicked") && !err.contains(".rs:"), "{fault}, {mode:?}:\n{err}");
            assert!(!out.exists(), "{fault}, {mode:?}: a picture was written");
        }
    }
}
