//! The backend-neutral seam: what a frame dispatches, written once as a [`Recording`] (in the
//! manner of vello's), and the [`ComputeBackend`] each device path implements to run it — wgpu
//! ([`WgpuKernel`]) or raw Vulkan through `ash` ([`super::vk::VkKernel`]).
//!
//! A backend holds one compiled kernel bound to an uploaded scene and its buffers (the bindings of
//! shaders/types.wgsl); the recording says which entry points run over which tiles, in order.
//! The headless bands, the readback kernels of the tests and the interactive modes of
//! `render::Session` (the conventional tile queue's waves, the frameless slices) are all
//! recordings; a [`Device`] is what a session needs beyond them: uploading and updating a scene,
//! compiling a kernel, binding it.

use super::dispatch::{Dispatcher, GpuScene, ModeBuffers, RayCounts};
use super::layout::{PackedScene, Params, Tile};
use super::shaders::{Kernel, Variant};
use super::GpuContext;
use std::convert::Infallible;
use std::time::{Duration, Instant};

/// The device path of the headless commands (issue #12): wgpu, or raw Vulkan through ash.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum Backend {
    /// wgpu (Vulkan only), the window's path too.
    #[default]
    Wgpu,
    /// Raw Vulkan through ash: the same SPIR-V, adapter, bands and modes (docs/backends.md).
    Ash,
}

/// One compute dispatch: `groups` workgroups of `entry`, with `tile` as its uniform.
#[derive(Clone, Debug, PartialEq)]
pub struct Dispatch {
    pub entry: String,
    pub tile: Tile,
    pub groups: [u32; 3],
}

impl Dispatch {
    /// `entry` over the invocations of `tile.rect` in 8x8 workgroups (the readback kernels).
    pub fn over_rect(entry: &str, tile: Tile) -> Self {
        let rect = tile.rect;
        Dispatch { entry: entry.to_string(), tile, groups: [rect[2].div_ceil(8), rect[3].div_ceil(8), 1] }
    }

    /// The `render` entry point over `tile.rect` with its rows of tiles (`layout::RENDER_TILE`)
    /// dealt round-robin to `threads` workers (see shaders/trace.wgsl): lavapipe splits a
    /// dispatch's workgroups into one contiguous run per thread (x fastest, z slowest), so
    /// workgroup (x, y, z) traces tile (x, y · threads + z) and the z-th thread takes every
    /// `threads`-th row of tiles over the whole rect. Multiplies only: lavapipe has no vector
    /// integer divide, and working out a dealt tile with divides cost about 0.9 ms of a 512²
    /// frame (docs/performance.md, "Dealing rows of tiles without a divide"). `threads` ≤ 1: the
    /// tiles in order.
    pub fn dealt(tile: Tile, threads: u32) -> Self {
        let [tw, th] = super::layout::RENDER_TILE;
        let (nx, ny) = (tile.rect[2].div_ceil(tw), tile.rect[3].div_ceil(th));
        let n = threads.max(1);
        let tile = Tile { work: [n, 0, 0, 0], ..tile };
        Dispatch { entry: "render".into(), tile, groups: [nx, ny.div_ceil(n), n] }
    }
}

/// How many threads a device deals the band renderer's tiles to: lavapipe's pool
/// (`LP_NUM_THREADS`, else one thread per core); 0 for a GPU, whose scheduler balances itself and
/// whose caches prefer neighbouring workgroups on neighbouring tiles.
pub fn dealing_threads(device: &impl Device) -> u32 {
    if !device.is_cpu() {
        return 0;
    }
    std::env::var("LP_NUM_THREADS")
        .ok()
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(2, |n| n.get() as u32))
}

/// What a recording asks of a backend, in order.
#[derive(Clone, Debug, PartialEq)]
pub enum Command {
    /// Zero the ray counters.
    ResetCounts,
    /// Restart the conventional mode's tile queue (its counter to 0).
    ResetQueue,
    /// Run a dispatch and wait for it (each waits, so a progress mark after it is true).
    Dispatch(Dispatch),
    /// Report progress: `done` of `total` (rows, for the bands).
    Progress { done: u32, total: u32 },
}

/// A frame's work, independent of the device path.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Recording {
    pub commands: Vec<Command>,
}

impl Recording {
    /// The dispatches, in order.
    pub fn dispatches(&self) -> impl Iterator<Item = &Dispatch> {
        self.commands.iter().filter_map(|c| match c {
            Command::Dispatch(d) => Some(d),
            _ => None,
        })
    }
}

/// A compiled kernel bound to a scene, on some device path.
pub trait ComputeBackend {
    /// What fails on this path (`Infallible` for wgpu, whose errors surface as device loss).
    type Error: std::fmt::Display;
    /// Zeroes the ray counters.
    fn reset_counts(&self) -> Result<(), Self::Error>;
    /// Runs `d` and waits for it.
    fn dispatch(&self, d: &Dispatch) -> Result<(), Self::Error>;
    /// `read` of the output buffer and the ray counters, where the device left them (no copy).
    fn read_output_with<T>(&self, read: impl FnOnce(&[[f32; 4]], RayCounts) -> T) -> Result<T, Self::Error>;
    /// A copy of the output buffer, and the ray counters.
    fn read_output(&self) -> Result<(Vec<[f32; 4]>, RayCounts), Self::Error> {
        self.read_output_with(|out, rays| (out.to_vec(), rays))
    }
    /// Restarts the tile queue.
    fn reset_queue(&self) -> Result<(), Self::Error>;
    /// The tile queue's counter: chunks taken so far (past the last once the queue is empty).
    fn read_queue(&self) -> Result<u32, Self::Error>;
    /// Writes `data` at the start of the work buffer (a schedule's boundaries, a pixel order).
    fn write_work(&self, data: &[u32]) -> Result<(), Self::Error>;
    /// Zeroes the frame buffer (no samples anywhere).
    fn clear_frame(&self) -> Result<(), Self::Error>;
    /// The frame buffer: per pixel the sum of its samples (rgb) and their count (a).
    fn read_frame(&self) -> Result<Vec<[f32; 4]>, Self::Error>;

    /// Runs every command of `rec`, reporting its progress marks to `progress`.
    fn run(&self, rec: &Recording, progress: &mut dyn FnMut(u32, u32)) -> Result<(), Self::Error> {
        for c in &rec.commands {
            match c {
                Command::ResetCounts => self.reset_counts()?,
                Command::ResetQueue => self.reset_queue()?,
                Command::Dispatch(d) => self.dispatch(d)?,
                &Command::Progress { done, total } => progress(done, total),
            }
        }
        Ok(())
    }
}

/// The wgpu path: a [`Dispatcher`] and the context it was made on.
pub struct WgpuKernel<'a> {
    pub ctx: &'a GpuContext,
    pub dispatcher: &'a Dispatcher,
}

impl ComputeBackend for WgpuKernel<'_> {
    type Error = Infallible;
    fn reset_counts(&self) -> Result<(), Infallible> {
        self.dispatcher.reset_counts(self.ctx);
        Ok(())
    }
    fn dispatch(&self, d: &Dispatch) -> Result<(), Infallible> {
        self.dispatcher.run(self.ctx, &d.entry, d.tile, d.groups);
        Ok(())
    }
    fn read_output_with<T>(&self, read: impl FnOnce(&[[f32; 4]], RayCounts) -> T) -> Result<T, Infallible> {
        Ok(self.dispatcher.read_with(self.ctx, read))
    }
    fn reset_queue(&self) -> Result<(), Infallible> {
        self.dispatcher.reset_queue(self.ctx);
        Ok(())
    }
    fn read_queue(&self) -> Result<u32, Infallible> {
        Ok(self.dispatcher.read_queue(self.ctx))
    }
    fn write_work(&self, data: &[u32]) -> Result<(), Infallible> {
        self.dispatcher.write_work(self.ctx, data);
        Ok(())
    }
    fn clear_frame(&self) -> Result<(), Infallible> {
        self.dispatcher.clear_frame(self.ctx);
        Ok(())
    }
    fn read_frame(&self) -> Result<Vec<[f32; 4]>, Infallible> {
        Ok(self.dispatcher.read_frame(self.ctx))
    }
}

/// A device path as `render::Session` uses it: scenes uploaded and updated in place, kernels
/// compiled for a variant with the interactive modes' buffers, and bound as a [`ComputeBackend`]
/// that runs the recordings. Implemented by [`GpuContext`] (wgpu) and `vk::VkContext` (ash).
pub trait Device {
    /// What a dispatch or readback can fail with.
    type Error: std::error::Error + Send + Sync + 'static;
    /// A scene resident on the device (texture and frame constants).
    type Scene;
    /// A compiled kernel bound to a scene and its buffers.
    type Kernel;
    /// A kernel bound to this device, ready to run recordings.
    type Bound<'a>: ComputeBackend<Error = Self::Error>
    where
        Self: 'a;

    /// The adapter's name, for reports.
    fn adapter_name(&self) -> &str;
    /// Its driver's own description (version), for reports.
    fn adapter_driver(&self) -> &str;
    /// The device runs on the CPU (lavapipe): schedules are built for its threads.
    fn is_cpu(&self) -> bool;
    /// Lanes of a SIMD group (what `SimdCount::efficiency` divides by), where the device runs the
    /// SIMD counters (`Variant::simd_stats`) and its groups have one size.
    fn subgroup_size(&self) -> Option<u32>;
    /// Uploads `packed` with its frame constants (and waits for it) into a texture of at least
    /// `reserve_rows` rows, layered past `max_rows` rows if given and fewer than the device's
    /// largest texture side.
    fn upload(
        &self,
        packed: PackedScene,
        params: Params,
        max_rows: Option<u32>,
        reserve_rows: u32,
    ) -> Result<Self::Scene, String>;
    /// Replaces `scene`'s contents: in place while they fit, else in a new texture with room to
    /// spare; returns whether the texture is new (kernels bound to it must [`Device::rebind`]).
    fn update_scene(
        &self,
        scene: &mut Self::Scene,
        packed: PackedScene,
        params: Params,
    ) -> Result<bool, String>;
    /// Writes `texels`, the packed scene's texels from row `from` on, in place (the rows before
    /// stay), with `params`: a new accelerator for the same scene (`layout::swap_accel`). False,
    /// and nothing written, when they do not fit the texture as it is.
    fn update_scene_from(
        &self,
        scene: &mut Self::Scene,
        from: u32,
        texels: Vec<[u32; 4]>,
        params: Params,
    ) -> Result<bool, String>;
    /// The frame constants `scene` holds now.
    fn params(scene: &Self::Scene) -> Params;
    /// `scene`'s texture is layered (see `Variant::layered`).
    fn layered(scene: &Self::Scene) -> bool;
    /// Bytes `scene` took to upload (texture and frame constants).
    fn scene_bytes(scene: &Self::Scene) -> u64;
    /// Replaces the frame constants; the next dispatch sees them.
    fn write_params(&self, scene: &mut Self::Scene, params: Params);
    /// Compiles `kernel` for `variant` (`layered` taken from the scene) bound to `scene`, an
    /// output of `out_len` vec4s, the read-only test `inputs` (may be empty) and the modes'
    /// buffers. Fails, naming what is missing, when the
    /// device cannot run it (f64 without shader f64).
    fn compile(
        &self,
        scene: &Self::Scene,
        kernel: Kernel,
        variant: Variant,
        out_len: u64,
        inputs: &[[f32; 4]],
        modes: ModeBuffers,
    ) -> Result<Self::Kernel, String>;
    /// The variant `kernel` was compiled for.
    fn variant(kernel: &Self::Kernel) -> Variant;
    /// Binds `kernel` to `scene`'s new texture (after [`Device::update_scene`] replaced it),
    /// keeping its buffers.
    fn rebind(&self, kernel: &mut Self::Kernel, scene: &Self::Scene) -> Result<(), String>;
    /// Copies `from`'s frame buffer into `to`'s (as much as both hold): what a recompiled kernel
    /// takes over, so that the picture does not go black.
    fn copy_frame(&self, to: &Self::Kernel, from: &Self::Kernel) -> Result<(), String>;
    /// `kernel` on this device, as a backend.
    fn bind<'a>(&'a self, kernel: &'a Self::Kernel) -> Self::Bound<'a>;
    /// A first frame has run, so drivers that compile at the first dispatch have compiled: what
    /// a pipeline cache on disk waits for.
    fn pipelines_compiled(&self) {}
}

impl Device for GpuContext {
    type Error = Infallible;
    type Scene = GpuScene;
    type Kernel = Dispatcher;
    type Bound<'a> = WgpuKernel<'a>;

    fn adapter_name(&self) -> &str {
        &self.info.name
    }
    fn adapter_driver(&self) -> &str {
        &self.info.driver_info
    }
    fn is_cpu(&self) -> bool {
        self.info.device_type == wgpu::DeviceType::Cpu
    }
    fn subgroup_size(&self) -> Option<u32> {
        let (min, max) = (self.info.subgroup_min_size, self.info.subgroup_max_size);
        (self.device.features().contains(wgpu::Features::SUBGROUP) && min == max).then_some(min)
    }
    fn upload(
        &self,
        packed: PackedScene,
        params: Params,
        max_rows: Option<u32>,
        reserve_rows: u32,
    ) -> Result<GpuScene, String> {
        let scene = GpuScene::upload_reserving(self, packed, params, max_rows, reserve_rows)?;
        self.wait();
        Ok(scene)
    }
    fn update_scene(
        &self,
        scene: &mut GpuScene,
        packed: PackedScene,
        params: Params,
    ) -> Result<bool, String> {
        scene.update(self, packed, params)
    }
    fn update_scene_from(
        &self,
        scene: &mut GpuScene,
        from: u32,
        texels: Vec<[u32; 4]>,
        params: Params,
    ) -> Result<bool, String> {
        Ok(scene.update_from(self, from, texels, params))
    }
    fn params(scene: &GpuScene) -> Params {
        scene.params
    }
    fn layered(scene: &GpuScene) -> bool {
        scene.layered
    }
    fn scene_bytes(scene: &GpuScene) -> u64 {
        scene.bytes
    }
    fn write_params(&self, scene: &mut GpuScene, params: Params) {
        scene.write_params(self, params)
    }
    fn compile(
        &self,
        scene: &GpuScene,
        kernel: Kernel,
        variant: Variant,
        out_len: u64,
        inputs: &[[f32; 4]],
        modes: ModeBuffers,
    ) -> Result<Dispatcher, String> {
        if variant.f64 && !self.device.features().contains(wgpu::Features::SHADER_F64) {
            return Err(super::context::no_f64_message(&self.info.name));
        }
        if variant.simd_stats && !self.device.features().contains(wgpu::Features::SUBGROUP) {
            return Err(super::context::no_subgroups_message(&self.info.name));
        }
        Ok(Dispatcher::with_modes(self, scene, kernel, variant, "render", out_len, inputs, modes))
    }
    fn variant(kernel: &Dispatcher) -> Variant {
        kernel.variant()
    }
    fn rebind(&self, kernel: &mut Dispatcher, scene: &GpuScene) -> Result<(), String> {
        kernel.rebind(self, scene);
        Ok(())
    }
    fn copy_frame(&self, to: &Dispatcher, from: &Dispatcher) -> Result<(), String> {
        to.copy_frame_from(self, from);
        Ok(())
    }
    fn bind<'a>(&'a self, kernel: &'a Dispatcher) -> WgpuKernel<'a> {
        WgpuKernel { ctx: self, dispatcher: kernel }
    }
    fn pipelines_compiled(&self) {
        self.save_pipeline_cache();
    }
}

/// The value of a result that cannot fail.
pub fn infallible<T>(r: Result<T, Infallible>) -> T {
    match r {
        Ok(v) => v,
        Err(never) => match never {},
    }
}

/// The readback kernels of the tests: `entry` over `items` invocations (one row), then the output.
pub fn readback_recording(entry: &str, items: u32) -> Recording {
    Recording { commands: vec![Command::Dispatch(Dispatch::over_rect(entry, Tile::whole([0, 0, items, 1])))] }
}

/// The median wall time of `samples` (at least 1) dispatches of one workgroup of `entry` over a
/// single item, after one untimed (which compiles the pipeline): what a dispatch costs the
/// path, submit and wait included, with next to no work in it.
pub fn dispatch_overhead<B: ComputeBackend>(
    backend: &B,
    entry: &str,
    samples: u32,
) -> Result<Duration, B::Error> {
    let d = Dispatch { entry: entry.to_string(), tile: Tile::whole([0, 0, 1, 1]), groups: [1, 1, 1] };
    backend.dispatch(&d)?;
    let mut times = Vec::with_capacity(samples.max(1) as usize);
    for _ in 0..samples.max(1) {
        let t = Instant::now();
        backend.dispatch(&d)?;
        times.push(t.elapsed());
    }
    times.sort();
    Ok(times[times.len() / 2])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The shader's dealing (shaders/trace.wgsl, `render`) reaches every tile exactly once, and
    /// each thread's contiguous run of workgroups (lavapipe's split of the linear workgroup
    /// index) spreads over the rect: every n-th row of tiles.
    #[test]
    fn dealt_tiles_cover_the_rect_once() {
        let [tw, th] = crate::gpu::layout::RENDER_TILE;
        for (w, h) in [(512, 32), (131, 67), (8, 8), (1, 1), (1000, 16), (512, 512)] {
            for threads in [0, 1, 2, 3, 4, 7, 16] {
                let d = Dispatch::dealt(Tile::whole([0, 0, w, h]), threads);
                let n = d.tile.work[0];
                let (nx, ny) = (w.div_ceil(tw), h.div_ceil(th));
                assert_eq!((n, d.groups[0], d.groups[2]), (threads.max(1), nx, threads.max(1)));
                let [gx, gy, gz] = d.groups;
                let run = (gx * gy * gz / n) as usize;
                let mut seen = vec![0u32; (nx * ny) as usize];
                let mut runs = vec![Vec::new(); n as usize];
                for g in 0..gx * gy * gz {
                    let (x, y, z) = (g % gx, g / gx % gy, g / (gx * gy));
                    let row = y * n + z;
                    if row < ny {
                        seen[(row * nx + x) as usize] += 1;
                        runs[g as usize / run].push(row);
                    }
                }
                assert!(seen.iter().all(|&c| c == 1), "{w}x{h}, {threads} threads: {seen:?}");
                // Thread k's rows: k, k + n, … to near the last row.
                for (k, rows) in runs.iter().enumerate() {
                    assert!(rows.iter().all(|&r| r % n == k as u32), "{w}x{h}, {threads}: {runs:?}");
                    if ny >= 2 * n {
                        assert!(rows.last().unwrap() + n >= ny, "{w}x{h}, {threads}: {runs:?}");
                    }
                }
            }
        }
    }
}
