//! Structured mutation fuzzing of the scene loaders (issue #5; results in docs/fuzzing.md).
//!
//! Every real scene file (`scenes/*.toml`, `scenes/spd/*.nff`, the glTF samples, the PLY and
//! OBJ models of `tests/data/models` and the OBJ models' MTL libraries) is mutated at the byte,
//! line and token level (numbers replaced by extremes: 0, -0, ±1e308, nan, inf, 2³², 1e9
//! counts, ...); glTF also gets JSON-aware edits
//! (accessor counts, byteLength, byteOffset, buffers moved to external files) and GLB
//! chunk-length edits; binary PLY gets edits of its header's counts and of its body's bytes.
//! Each mutant is written into `CARGO_TARGET_TMPDIR` and loaded with [`irt::io::load`], on a
//! worker thread, and must
//!
//! - not panic (the worker catches it),
//! - finish within [`TIME_BUDGET`] (the main thread stops waiting then),
//! - not allocate more than [`MEMORY_BUDGET`] at its peak (a counting allocator), which is what
//!   an allocation sized by a declared count would break,
//! - give a valid scene or an error with a message.
//!
//! Mutant `i` of a file is seeded by (file name, `i`), so a run of N iterations contains every
//! shorter run, and a finding is reproduced by its file and index. CI runs [`CI_ITERATIONS`]
//! per file; `IRT_FUZZ_ITERATIONS=N` runs more (`IRT_FUZZ_FILTER=word` keeps only matching
//! files). Failing inputs are written to `CARGO_TARGET_TMPDIR/fuzz_failures/` for the corpus.
//!
//! `tests/fuzz_corpus/{toml,nff,gltf,ply,obj}/` keeps every input that ever failed and some edge
//! inputs; [`corpus_inputs_load_cleanly`] loads each under the same guards.

#[path = "it/common.rs"]
mod common;

use common::Rng;
use serde_json::{json, Value};
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::{Duration, Instant};

const CI_ITERATIONS: usize = 300;
/// The loaders take milliseconds on these files; seconds means a loop that depends on a value.
const TIME_BUDGET: Duration = Duration::from_secs(2);
/// Well above what the largest real file needs (balls_s4.nff: tens of MiB), far below what an
/// allocation sized by a mutated count (1e9, 2³²) would take.
const MEMORY_BUDGET: usize = 512 << 20;

// ---- Peak memory per thread ------------------------------------------------------------------

/// The system allocator, counting the live bytes of each thread and their peak. The loaders
/// are single-threaded, so a worker's counters are the load's.
struct Counting;

thread_local! {
    static LIVE: Cell<isize> = const { Cell::new(0) };
    static PEAK: Cell<isize> = const { Cell::new(0) };
}

fn count(delta: isize) {
    let _ = LIVE.try_with(|live| {
        let now = live.get() + delta;
        live.set(now);
        let _ = PEAK.try_with(|peak| peak.set(peak.get().max(now)));
    });
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count(layout.size() as isize);
        System.alloc(layout)
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        count(-(layout.size() as isize));
        System.dealloc(ptr, layout)
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        count(layout.size() as isize);
        System.alloc_zeroed(layout)
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count(new_size as isize - layout.size() as isize);
        System.realloc(ptr, layout, new_size)
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

// ---- Running one input under the guards --------------------------------------------------------

/// What went wrong with one input, or `None`; also its time and peak memory.
struct Outcome {
    problem: Option<String>,
    elapsed: Duration,
    peak: usize,
}

/// Loads `path` on a worker thread: panics are caught, time and peak memory measured.
/// What is wrong with loading the scene at `path`: nothing, or the problem in words.
fn scene_problem(path: &Path) -> Option<String> {
    match irt::io::load(path) {
        Ok(scene) => {
            scene.validate().err().map(|e| format!("loaded an invalid scene: {}", e.0)).or_else(|| {
                // Posing must not panic at any time, in range or not (a posed scene may
                // still be invalid, e.g. scaled past f64's range: renderers check it).
                let end = scene.duration();
                for t in [-1.0, 0.0, 0.37 * end, end, end + 1.0, f64::NAN] {
                    let _ = scene.at(t).validate();
                }
                None
            })
        }
        Err(e) if e.message.is_empty() => Some("an error without a message".to_string()),
        Err(_) => None,
    }
}

fn guarded_load(path: &Path) -> Outcome {
    let (tx, rx) = mpsc::channel();
    let owned = path.to_path_buf();
    let start = Instant::now();
    std::thread::Builder::new()
        .name("fuzz-load".into())
        .spawn(move || {
            LIVE.with(|l| l.set(0));
            PEAK.with(|p| p.set(0));
            // A volume file is not a scene yet (docs/volumes.md): its own reader, checked alike.
            let result = std::panic::catch_unwind(|| match irt::io::volume::is_volume(&owned) {
                true => match irt::io::volume::load(&owned) {
                    Err(e) if e.message.is_empty() => Some("an error without a message".to_string()),
                    _ => None,
                },
                false => scene_problem(&owned),
            });
            let peak = PEAK.with(|p| p.get()).max(0) as usize;
            let problem = result.unwrap_or_else(|payload| {
                let text = payload
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| payload.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_default();
                Some(format!("panic: {text}"))
            });
            let _ = tx.send((problem, peak));
        })
        .unwrap();
    match rx.recv_timeout(TIME_BUDGET) {
        Ok((problem, peak)) => {
            let elapsed = start.elapsed();
            let problem =
                problem.or_else(|| (peak > MEMORY_BUDGET).then(|| format!("peak memory {} MiB", peak >> 20)));
            Outcome { problem, elapsed, peak }
        }
        // The worker is left running; the test fails and the process ends.
        Err(_) => Outcome {
            problem: Some(format!("no result within {TIME_BUDGET:?} (hang)")),
            elapsed: start.elapsed(),
            peak: 0,
        },
    }
}

// ---- Mutations -------------------------------------------------------------------------------

/// Numbers that break assumptions: signs, zero, overflow in f32/f64/u32/i64, counts.
const EXTREMES: &[&str] = &[
    "0",
    "-0",
    "-0.0",
    "1",
    "-1",
    "2",
    "3",
    "7",
    "1e308",
    "-1e308",
    "1e-308",
    "1e39",
    "nan",
    "inf",
    "-inf",
    "+inf",
    "4294967296",
    "4294967295",
    "2147483648",
    "1000000000",
    "18446744073709551616",
    "99999999999999999999999",
    "65536",
    "0.5",
];

/// Byte ranges of the numbers in a text.
fn number_spans(text: &[u8]) -> Vec<(usize, usize)> {
    let mut spans = Vec::new();
    let mut i = 0;
    while i < text.len() {
        let c = text[i];
        let starts = c.is_ascii_digit()
            || ((c == b'-' || c == b'+' || c == b'.') && text.get(i + 1).is_some_and(|d| d.is_ascii_digit()));
        let after_word = i > 0 && (text[i - 1].is_ascii_alphanumeric() || text[i - 1] == b'_');
        if starts && !after_word {
            let start = i;
            i += 1;
            while i < text.len()
                && (text[i].is_ascii_digit()
                    || text[i] == b'.'
                    || text[i] == b'e'
                    || text[i] == b'E'
                    || ((text[i] == b'-' || text[i] == b'+') && matches!(text[i - 1], b'e' | b'E')))
            {
                i += 1;
            }
            spans.push((start, i));
        } else {
            i += 1;
        }
    }
    spans
}

fn line_spans(text: &[u8]) -> Vec<(usize, usize)> {
    let mut spans = Vec::new();
    let mut start = 0;
    for (i, &c) in text.iter().enumerate() {
        if c == b'\n' {
            spans.push((start, i + 1));
            start = i + 1;
        }
    }
    if start < text.len() {
        spans.push((start, text.len()));
    }
    spans
}

/// One generic mutation of `b`: bytes, lines or numbers.
fn mutate_bytes(rng: &mut Rng, b: &mut Vec<u8>, numbers: &[(usize, usize)]) {
    if b.is_empty() {
        b.push(b'0');
        return;
    }
    let at = rng.below(b.len());
    match rng.below(11) {
        0 => b[at] ^= 1 << rng.below(8),
        1 => b[at] = [0, 0xff, 0x7f, 0x80, b'\n', b'"', b'[', b'{', b'-', b'e'][rng.below(10)],
        2 => {
            let n = 1 + rng.below(4);
            for _ in 0..n {
                b.insert(at, rng.below(256) as u8);
            }
        }
        3 => {
            let end = (at + 1 + rng.below(16)).min(b.len());
            b.drain(at..end);
        }
        4 => b.truncate(at),
        5 => {
            // Duplicate a range in place.
            let end = (at + 1 + rng.below(64)).min(b.len());
            let copy = b[at..end].to_vec();
            b.splice(at..at, copy);
        }
        6 | 7 => {
            // Duplicate, delete or swap lines.
            let lines = line_spans(b);
            let (s, e) = lines[rng.below(lines.len())];
            let line = b[s..e].to_vec();
            match rng.below(3) {
                0 => {
                    b.splice(s..s, line);
                }
                1 => {
                    b.drain(s..e);
                }
                _ => {
                    let (s2, e2) = lines[rng.below(lines.len())];
                    if s2 > e {
                        let other = b[s2..e2].to_vec();
                        b.splice(s2..e2, line);
                        b.splice(s..e, other);
                    } else if e2 < s {
                        let other = b[s2..e2].to_vec();
                        b.splice(s..e, other);
                        b.splice(s2..e2, line);
                    }
                }
            }
        }
        _ => {
            // A number becomes an extreme (the spans are of the original: clamp).
            if let Some(&(s, e)) = numbers.get(rng.below(numbers.len().max(1))) {
                if e <= b.len() {
                    let word = EXTREMES[rng.below(EXTREMES.len())];
                    b.splice(s..e, word.bytes());
                }
            }
        }
    }
}

/// A text mutant: 1 to 4 generic mutations.
fn mutate_text(rng: &mut Rng, original: &[u8]) -> Vec<u8> {
    let numbers = number_spans(original);
    let mut b = original.to_vec();
    for _ in 0..1 + rng.below(4) {
        mutate_bytes(rng, &mut b, &numbers);
    }
    b
}

/// JSON values for a number's place: the extremes JSON can say, and wrong types.
fn json_extreme(rng: &mut Rng, old: &Value) -> Value {
    let old = old.as_f64().unwrap_or(1.0);
    match rng.below(16) {
        0 => json!(0),
        1 => json!(-0.0),
        2 => json!(1e308),
        3 => json!(-1e308),
        4 => json!(4294967296u64),
        5 => json!(4294967295u64),
        6 => json!(1_000_000_000u64),
        7 => json!(u64::MAX),
        8 => json!(i64::MIN),
        9 => json!(-1),
        10 => json!(old + 1.0),
        11 => json!(old - 1.0),
        12 => json!(old * 2.0),
        13 => json!(old * 1e6),
        14 => json!(1e-308),
        _ => [json!(null), json!("1"), json!([1]), json!({})][rng.below(4)].clone(),
    }
}

/// Fields a loader must check against its buffers and limits; edited more often.
const GLTF_FIELDS: &[&str] = &[
    "count",
    "byteLength",
    "byteOffset",
    "byteStride",
    "bufferView",
    "componentType",
    // Animations: a channel's sampler and node, a sampler's accessors.
    "sampler",
    "node",
    "input",
    "output",
];

/// What an animation's `interpolation` or channel `path` may be set to: each valid name (a
/// CUBICSPLINE sampler then has a third of its outputs, a rotation reads VEC3 outputs) and one
/// that is not.
const ANIMATION_NAMES: &[&str] =
    &["STEP", "LINEAR", "CUBICSPLINE", "translation", "rotation", "scale", "weights", "sideways"];

/// A JSON-aware mutation of a glTF document.
fn mutate_json(rng: &mut Rng, doc: &mut Value, dir: &Path) {
    let mut pointers = Vec::new();
    common::number_pointers(doc, String::new(), &mut pointers);
    if pointers.is_empty() {
        return;
    }
    let names: Vec<String> = (0..doc["animations"].as_array().map_or(0, Vec::len))
        .flat_map(|a| {
            let n = |key: &str| doc["animations"][a][key].as_array().map_or(0, Vec::len);
            let samplers =
                (0..n("samplers")).map(move |s| format!("/animations/{a}/samplers/{s}/interpolation"));
            let channels =
                (0..n("channels")).map(move |c| format!("/animations/{a}/channels/{c}/target/path"));
            samplers.chain(channels).collect::<Vec<_>>()
        })
        .collect();
    match rng.below(6) {
        5 if !names.is_empty() => {
            let p = &names[rng.below(names.len())];
            let name = ANIMATION_NAMES[rng.below(ANIMATION_NAMES.len())];
            if let Some(slot) = doc.pointer_mut(p) {
                *slot = json!(name);
            }
        }
        0 | 1 | 5 => {
            let focused: Vec<&String> = pointers
                .iter()
                .filter(|p| GLTF_FIELDS.iter().any(|f| p.ends_with(&format!("/{f}"))))
                .collect();
            let p = if focused.is_empty() {
                &pointers[rng.below(pointers.len())]
            } else {
                focused[rng.below(focused.len())]
            };
            let slot = doc.pointer_mut(p).unwrap();
            *slot = json_extreme(rng, slot);
        }
        2 => {
            let p = &pointers[rng.below(pointers.len())];
            let slot = doc.pointer_mut(p).unwrap();
            *slot = json_extreme(rng, slot);
        }
        3 => {
            // An external buffer beside the file: the real data, a short one, or none.
            if let Some(buffers) = doc.get_mut("buffers").and_then(Value::as_array_mut) {
                if let Some(buffer) = buffers.first_mut() {
                    let name = ["buffer.bin", "short.bin", "missing.bin", "../buffer.bin", "/dev/zero", ""]
                        [rng.below(6)];
                    buffer["uri"] = json!(name);
                    let _ = dir;
                }
            }
        }
        _ => {
            // Drop a key somewhere under a top-level array.
            let p = &pointers[rng.below(pointers.len())];
            if let Some((parent, key)) = p.rsplit_once('/') {
                if let Some(Value::Object(o)) = doc.pointer_mut(parent) {
                    o.remove(key);
                }
            }
        }
    }
}

/// A GLB from its JSON and binary chunks, padded as the format requires.
fn glb(json_text: &[u8], bin: Option<&[u8]>) -> Vec<u8> {
    let mut json_chunk = json_text.to_vec();
    while !json_chunk.len().is_multiple_of(4) {
        json_chunk.push(b' ');
    }
    let mut out = Vec::new();
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend(0u32.to_le_bytes());
    out.extend((json_chunk.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(&json_chunk);
    if let Some(bin) = bin {
        let mut bin = bin.to_vec();
        while bin.len() % 4 != 0 {
            bin.push(0);
        }
        out.extend((bin.len() as u32).to_le_bytes());
        out.extend(b"BIN\0");
        out.extend(&bin);
    }
    let total = out.len() as u32;
    out[8..12].copy_from_slice(&total.to_le_bytes());
    out
}

/// The JSON and BIN chunks of a well-formed GLB.
fn glb_chunks(bytes: &[u8]) -> (Vec<u8>, Vec<u8>) {
    let word = |at: usize| u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()) as usize;
    let json_len = word(12);
    let json = bytes[20..20 + json_len].to_vec();
    let bin_at = 20 + json_len;
    let bin_len = word(bin_at);
    (json, bytes[bin_at + 8..bin_at + 8 + bin_len].to_vec())
}

fn mutate_glb(rng: &mut Rng, original: &[u8], dir: &Path) -> Vec<u8> {
    let (json_text, bin) = glb_chunks(original);
    match rng.below(4) {
        0 => {
            // The container's length fields: total, JSON chunk, BIN chunk.
            let mut b = original.to_vec();
            let at = [8, 12, 20 + json_text.len()][rng.below(3)];
            let value: u32 =
                [0, 1, 4, 19, 20, u32::MAX, u32::MAX - 3, 1 << 31, b.len() as u32, b.len() as u32 + 4]
                    [rng.below(10)];
            b[at..at + 4].copy_from_slice(&value.to_le_bytes());
            b
        }
        1 => {
            // JSON edits in a well-formed container.
            let mut doc: Value = serde_json::from_slice(&json_text).unwrap();
            for _ in 0..1 + rng.below(3) {
                mutate_json(rng, &mut doc, dir);
            }
            glb(&serde_json::to_vec(&doc).unwrap(), Some(&bin))
        }
        2 => {
            // Binary data edits (indices, floats) in a well-formed container.
            let mut bin = bin;
            for _ in 0..1 + rng.below(8) {
                let i = rng.below(bin.len());
                bin[i] = [0x00, 0xff, 0x7f, 0x80, rng.below(256) as u8][rng.below(5)];
            }
            if rng.below(4) == 0 {
                bin.truncate(rng.below(bin.len()));
            }
            glb(&json_text, Some(&bin))
        }
        _ => mutate_text(rng, original),
    }
}

/// Byte offset just past a PLY header's `end_header` line (the whole file if there is none).
fn ply_body(b: &[u8]) -> usize {
    b.windows(11).position(|w| w == b"end_header\n").map_or(b.len(), |i| i + 11)
}

/// A PLY mutant. ASCII files are text; binary ones get their header's numbers (element counts)
/// edited, or their body's bytes (indices, list counts, floats) with the header kept, or generic
/// edits of the whole file.
fn mutate_ply(rng: &mut Rng, original: &[u8]) -> Vec<u8> {
    let body = ply_body(original);
    if !original[..body].windows(13).any(|w| w == b"format binary") {
        return mutate_text(rng, original);
    }
    match rng.below(4) {
        0 => {
            let numbers = number_spans(&original[..body]);
            let mut b = original.to_vec();
            for _ in 0..1 + rng.below(2) {
                if let Some(&(s, e)) = numbers.get(rng.below(numbers.len().max(1))) {
                    let old: u64 = std::str::from_utf8(&original[s..e]).unwrap().parse().unwrap_or(1);
                    let new = [old + 1, old.saturating_sub(1), old * 2, old / 2].map(|x| x.to_string());
                    let word = match rng.below(2) {
                        0 => EXTREMES[rng.below(EXTREMES.len())].to_string(),
                        _ => new[rng.below(4)].clone(),
                    };
                    if e <= b.len() {
                        b.splice(s..e, word.bytes());
                    }
                }
            }
            b
        }
        1 | 2 => {
            let mut b = original.to_vec();
            if b.len() > body {
                for _ in 0..1 + rng.below(8) {
                    let i = body + rng.below(b.len() - body);
                    b[i] = [0x00, 0xff, 0x7f, 0x80, 0x03, rng.below(256) as u8][rng.below(6)];
                }
                if rng.below(4) == 0 {
                    b.truncate(body + rng.below(b.len() - body));
                }
            }
            b
        }
        _ => mutate_text(rng, original),
    }
}

// ---- The corpus of real files ----------------------------------------------------------------

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn files(dir: &str, extensions: &[&str]) -> Vec<PathBuf> {
    let mut out: Vec<PathBuf> = std::fs::read_dir(root().join(dir))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().and_then(|e| e.to_str()).is_some_and(|e| extensions.contains(&e)))
        .collect();
    out.sort();
    out
}

fn iterations() -> usize {
    std::env::var("IRT_FUZZ_ITERATIONS").ok().and_then(|v| v.parse().ok()).unwrap_or(CI_ITERATIONS)
}

fn seed(name: &str, i: usize) -> u64 {
    // FNV-1a of the name, then the index: stable across runs and platforms.
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in name.bytes() {
        h = (h ^ b as u64).wrapping_mul(0x100_0000_01b3);
    }
    h ^ (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
}

fn work_dir(format: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("fuzz").join(format);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Fuzzes each file with `mutate(rng, original, dir)`, writing mutants as `dir/mutant.<ext>`.
/// Prints a summary line (inputs, time, slowest, largest peak); fails listing every finding.
fn fuzz(format: &str, inputs: Vec<PathBuf>, mutate: impl Fn(&mut Rng, &[u8], &Path) -> Vec<u8>) {
    let filter = std::env::var("IRT_FUZZ_FILTER").unwrap_or_default();
    let dir = work_dir(format);
    let failures = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("fuzz_failures");
    let n = iterations();
    let start = Instant::now();
    let (mut total, mut slowest, mut peak) =
        (0usize, (Duration::ZERO, String::new()), (0usize, String::new()));
    let mut findings = Vec::new();
    for input in inputs.iter().filter(|p| p.display().to_string().contains(&filter)) {
        let name = input.file_name().unwrap().to_str().unwrap().to_string();
        let ext = input.extension().unwrap().to_str().unwrap();
        let original = std::fs::read(input).unwrap();
        for i in 0..n {
            let mut rng = Rng::new(seed(&name, i));
            let mutant = mutate(&mut rng, &original, &dir);
            let path = dir.join(format!("mutant.{ext}"));
            std::fs::write(&path, &mutant).unwrap();
            let outcome = guarded_load(&path);
            total += 1;
            let label = format!("{name} #{i}");
            if outcome.elapsed > slowest.0 {
                slowest = (outcome.elapsed, label.clone());
            }
            if outcome.peak > peak.0 {
                peak = (outcome.peak, label.clone());
            }
            if let Some(problem) = outcome.problem {
                std::fs::create_dir_all(&failures).unwrap();
                let saved = failures.join(format!("{name}-{i}.{ext}"));
                std::fs::write(&saved, &mutant).unwrap();
                findings.push(format!("{label}: {problem} (input: {})", saved.display()));
                if findings.len() >= 20 {
                    break;
                }
            }
        }
    }
    eprintln!(
        "fuzz {format}: {total} inputs in {:.1} s; slowest {:.1} ms ({}); largest peak {:.1} MiB ({})",
        start.elapsed().as_secs_f64(),
        slowest.0.as_secs_f64() * 1e3,
        slowest.1,
        peak.0 as f64 / (1 << 20) as f64,
        peak.1
    );
    assert!(findings.is_empty(), "{} finding(s):\n{}", findings.len(), findings.join("\n"));
}

#[test]
fn mutated_toml_scenes() {
    // The textures scenes refer to, where the mutants are loaded from, so that they get read.
    let textures = work_dir("toml").join("textures");
    std::fs::create_dir_all(&textures).unwrap();
    for png in files("scenes/textures", &["png"]) {
        std::fs::copy(&png, textures.join(png.file_name().unwrap())).unwrap();
    }
    // And the volumes, so that a mutated `[[volume]]` table reaches the volume readers.
    let volumes = work_dir("toml").join("volumes");
    std::fs::create_dir_all(&volumes).unwrap();
    for v in files("scenes/volumes", &["nrrd"]) {
        std::fs::copy(&v, volumes.join(v.file_name().unwrap())).unwrap();
    }
    fuzz("toml", files("scenes", &["toml"]), |rng, b, _| mutate_text(rng, b));
}

#[test]
fn mutated_nff_scenes() {
    fuzz("nff", files("scenes/spd", &["nff"]), |rng, b, _| mutate_text(rng, b));
}

#[test]
fn mutated_gltf_scenes() {
    let dir = work_dir("gltf");
    // The targets of the external-buffer edits: Box's real buffer and a short one.
    let box_doc: Value =
        serde_json::from_slice(&std::fs::read(root().join("tests/data/scenes/gltf/Box.gltf")).unwrap())
            .unwrap();
    let uri = box_doc["buffers"][0]["uri"].as_str().unwrap();
    let bin = decode_base64(uri.split_once(',').unwrap().1);
    std::fs::write(dir.join("buffer.bin"), &bin).unwrap();
    std::fs::write(dir.join("short.bin"), &bin[..bin.len() / 2]).unwrap();
    // The Khronos samples, and the animated files (a Khronos one, irt's own with every sampler
    // kind and a node path of keyed and fixed stages).
    let mut seeds = files("tests/data/scenes/gltf", &["gltf", "glb"]);
    seeds.extend(files("tests/data/models/animated", &["gltf", "glb"]));
    fuzz("gltf", seeds, |rng, b, dir| {
        if b.starts_with(b"glTF") {
            return mutate_glb(rng, b, dir);
        }
        if rng.below(2) == 0 {
            mutate_text(rng, b)
        } else {
            let mut doc: Value = serde_json::from_slice(b).unwrap();
            for _ in 0..1 + rng.below(3) {
                mutate_json(rng, &mut doc, dir);
            }
            serde_json::to_vec(&doc).unwrap()
        }
    });
}

#[test]
fn mutated_ply_scenes() {
    fuzz("ply", files("tests/data/models", &["ply"]), |rng, b, _| mutate_ply(rng, b));
}

/// PLY files of points alone (particles): the stress plate in ASCII and big-endian, and four
/// points with a double radius, mutated as the meshes are.
/// Volume files (tests/data/volumes): NRRD raw, ascii and big-endian, NIfTI-1 uncompressed and
/// VTK ImageData, their headers' numbers and their bytes mutated. (The gzip files would only
/// test inflate's checksums.)
#[test]
fn mutated_volume_files() {
    let inputs = files("tests/data/volumes", &["nrrd", "nii", "vti"]);
    fuzz("volumes", inputs, |rng, b, _| mutate_text(rng, b));
}

#[test]
fn mutated_particle_files() {
    fuzz("particles", files("tests/data/particles", &["ply"]), |rng, b, _| mutate_ply(rng, b));
}

/// The real OBJ models (tests/data/models/*/), and their libraries and textures copied into
/// `format`'s work directory, where the mutants are loaded from, so that they get read.
fn obj_models(format: &str) -> Vec<PathBuf> {
    let dir = work_dir(format);
    let mut objs = Vec::new();
    let models = root().join("tests/data/models");
    let mut subdirs: Vec<PathBuf> = std::fs::read_dir(&models).unwrap().map(|e| e.unwrap().path()).collect();
    subdirs.sort();
    for model in subdirs.into_iter().filter(|p| p.is_dir()) {
        for file in std::fs::read_dir(&model).unwrap().map(|e| e.unwrap().path()) {
            if file.extension().is_some_and(|e| e == "obj") {
                objs.push(file);
            } else {
                std::fs::copy(&file, dir.join(file.file_name().unwrap())).unwrap();
            }
        }
    }
    objs.sort();
    assert!(objs.len() >= 4, "the real OBJ files are in tests/data/models");
    objs
}

#[test]
fn mutated_obj_scenes() {
    fuzz("obj", obj_models("obj"), |rng, b, _| mutate_text(rng, b));
}

/// The real OBJ files unchanged, one of their MTL libraries mutated: the OBJ's `mtllib` for it
/// is pointed at the mutant, written beside it.
#[test]
fn mutated_mtl_libraries() {
    fuzz("mtl", obj_models("mtl"), |rng, b, dir| {
        let text = String::from_utf8(b.to_vec()).unwrap();
        let libraries: Vec<&str> = text.lines().filter(|l| l.starts_with("mtllib ")).collect();
        let Some(&line) = libraries.get(rng.below(libraries.len().max(1))) else { return b.to_vec() };
        let original = std::fs::read(dir.join(line["mtllib ".len()..].trim())).unwrap();
        std::fs::write(dir.join("mutant-library.mtl"), mutate_text(rng, &original)).unwrap();
        text.replacen(line, "mtllib mutant-library.mtl", 1).into_bytes()
    });
}

fn decode_base64(text: &str) -> Vec<u8> {
    const ALPHABET: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let digits: Vec<u32> = text
        .trim_end_matches('=')
        .bytes()
        .map(|c| ALPHABET.iter().position(|&a| a == c).unwrap() as u32)
        .collect();
    let mut bytes = Vec::new();
    for q in digits.chunks(4) {
        let n = q.iter().enumerate().fold(0u32, |n, (i, &d)| n | d << (18 - 6 * i));
        bytes.extend(&n.to_be_bytes()[1..q.len()]);
    }
    bytes
}

// ---- The regression corpus -------------------------------------------------------------------

#[test]
fn corpus_inputs_load_cleanly() {
    let mut checked = 0;
    let mut findings = Vec::new();
    for (format, extensions) in [
        ("toml", &["toml"][..]),
        ("nff", &["nff"]),
        ("gltf", &["gltf", "glb"]),
        ("ply", &["ply"]),
        ("obj", &["obj"]),
    ] {
        let inputs = files(&format!("tests/fuzz_corpus/{format}"), extensions);
        assert!(!inputs.is_empty(), "tests/fuzz_corpus/{format} is empty");
        for input in inputs {
            let outcome = guarded_load(&input);
            checked += 1;
            if let Some(problem) = outcome.problem {
                findings.push(format!("{}: {problem}", input.display()));
            }
        }
    }
    assert!(findings.is_empty(), "{}", findings.join("\n"));
    assert!(checked >= 10);
}
