//! The integration tests, one test binary: each module was a file of tests/ and a binary of its
//! own, and each of those 34 binaries linked wgpu, winit and egui, which was most of
//! `cargo test --release`'s compile time on 2 cores. `cargo test --release --test it gltf::`
//! runs one module; `common` holds the helpers they share (a seeded RNG, the device, scene
//! builders, the comparison against the f64 reference).
//!
//! The modules' tests run in the threads of one process. What that shares was checked: temporary
//! files go to a directory per module (under `CARGO_TARGET_TMPDIR`) or carry a counter; no test
//! sets an environment variable of this process (children get theirs from `Command::env`; the
//! library sets an unset `XDG_RUNTIME_DIR` once per process before the first device, to the
//! directory a child `irt` would pick for itself, and the test of that clears it in the child);
//! the window tests (`viewer`) start their own Xvfb on a display it picks, one at a time; `obj`'s
//! warning logger is process-wide and each of its tests looks only for its own file's name.
//!
//! Tests that stay binaries of their own, and why:
//! - `tests/fuzz_loaders.rs`: its `#[global_allocator]` (counting each thread's bytes) would be
//!   every test's allocator here, and each mutant's 2 s and 512 MiB budgets assume no renders in
//!   the same process;
//! - `tests/large_mesh.rs`: it bounds the process's peak resident memory (VmHWM), which has to be
//!   its 5.8M-triangle scene's alone.
//!
//! `embree_peer` is compiled only with `--features embree` (it links the system's libembree3).

mod acne;
mod adaptive;
mod backends;
mod bvh;
mod cli;
mod common;
mod convert;
mod device_failures;
mod distributed;
#[cfg(feature = "embree")]
mod embree_peer;
mod extremes;
mod farm;
mod gltf;
mod gltf_animation;
mod golden;
mod gpu_functions;
mod grid_traversal;
mod layout;
mod models;
mod modes;
mod motion;
mod native_peer;
mod obj;
mod output_format;
mod particles;
mod patches;
mod pieces;
mod pipeline_cache;
mod ply;
mod replay;
mod scene_nff;
mod scene_toml;
mod shaders_validate;
mod simd_counters;
mod slurm;
mod soft_shadows;
mod spd;
mod specialisation;
mod textures;
mod viewer;
mod volume_render;
mod volume_shader;
mod volumes;
mod watertight;
