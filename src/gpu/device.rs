//! The seam between what is traced and who runs it: a [`Device`] (a device path: scene textures,
//! kernels compiled for a variant, binding) and the [`BoundKernel`] it hands out to run
//! [`Recording`]s. Implemented once each by wgpu (`gpu::wgpu`) and raw Vulkan through ash
//! (`gpu::vk`); everything that is the same on both (uploading a scene in bands, updating it in
//! place while it fits, checking what a variant needs) is written here once.

use super::layout::{PackedScene, Params};
use super::output::RayCounts;
use super::recording::{Command, Recording};
use super::scene_texture::{grown_rows, SceneExtent};
use super::shaders::{Program, Variant};
use super::vk::VkError;
use std::convert::Infallible;

/// The device path of a command (`--backend`): wgpu, or raw Vulkan through ash.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Backend {
    /// wgpu (Vulkan only), the window's path too.
    #[default]
    Wgpu,
    /// Raw Vulkan through ash: the same SPIR-V, adapter, modes and pictures (docs/backends.md).
    Ash,
}

/// What setting up a scene or a kernel on a device can fail with, on either path.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error(
        "the scene needs {needed_mib} MiB of scene texture ({texels} texels of 16 bytes); this device \
         holds at most {most_mib} MiB ({layers} layers of {width}x{rows})",
        width = super::layout::SCENE_TEX_WIDTH,
        rows = super::layout::SCENE_LAYER_ROWS
    )]
    SceneTooLarge { needed_mib: u64, texels: u64, most_mib: u64, layers: u32 },
    #[error("{adapter} has no f64 shader support (SHADER_F64): use --precision f32")]
    NoF64 { adapter: String },
    #[error(
        "{adapter} lacks what the SIMD counters (--simd) need: subgroup operations in compute shaders, \
         with one SIMD group size"
    )]
    NoSubgroups { adapter: String },
    #[error("{bytes} bytes of work data for a {size} byte work buffer")]
    WorkTooLarge { bytes: u64, size: u64 },
    #[error("a scene texture that became layered needs a recompiled kernel")]
    LayeredRebind,
    #[error(
        "a {width}x{height} frame is more than this device's frame buffers hold ({most} pixels, its \
         largest storage binding in vec4s): the interactive modes trace at most that many pixels at \
         once (irt render traces larger pictures in pieces)"
    )]
    FrameTooLarge { width: u32, height: u32, most: u64 },
    #[error(transparent)]
    Device(#[from] super::failure::DeviceFailure),
    #[error(transparent)]
    Vulkan(#[from] VkError),
}

impl From<Infallible> for GpuError {
    fn from(never: Infallible) -> Self {
        match never {}
    }
}

/// Sizes of the dispatch modes' buffers (`render::modes`): none for the bands and the readback
/// kernels.
#[derive(Clone, Copy, Debug, Default)]
pub struct ModeBuffers {
    /// u32s the work buffer holds (boundary arrays, pixel orders).
    pub work_len: u64,
    /// Pixels of the frame buffer.
    pub frame_len: u64,
}

/// What a kernel is compiled as: its program and variant, and the buffers it is bound to.
#[derive(Clone, Copy, Debug)]
pub struct KernelSpec<'a> {
    pub program: Program,
    pub variant: Variant,
    /// Vec4s of the output buffer.
    pub out_len: u64,
    /// The read-only test inputs (the readback kernels; empty otherwise).
    pub inputs: &'a [[f32; 4]],
    pub modes: ModeBuffers,
}

impl<'a> KernelSpec<'a> {
    /// The bands' `render` program, an output of `out_len` eye rays.
    pub fn render(variant: Variant, out_len: u64) -> Self {
        KernelSpec { program: Program::Render, variant, out_len, inputs: &[], modes: ModeBuffers::default() }
    }

    /// The interactive modes' program over `pixels` pixels, with the modes' buffers.
    pub fn modes(variant: Variant, pixels: u64, modes: ModeBuffers) -> Self {
        KernelSpec { program: Program::Modes, variant, out_len: pixels, inputs: &[], modes }
    }

    /// The readback kernels (every variant feature on) over `inputs`, an output of `out_len`.
    pub fn tests(inputs: &'a [[f32; 4]], out_len: u64) -> Self {
        KernelSpec {
            program: Program::Tests,
            variant: Variant::FULL,
            out_len,
            inputs,
            modes: ModeBuffers::default(),
        }
    }
}

/// A scene resident on a device: its frame constants, how its texture is allocated and the bytes
/// uploaded (the same on every path), and the path's own texture and constant buffer.
pub struct DeviceScene<T> {
    pub params: Params,
    pub extent: SceneExtent,
    /// Bytes uploaded (texture + frame constants), for reports.
    pub bytes: u64,
    pub texture: T,
}

impl<T> DeviceScene<T> {
    /// The texture is a 2D array of layers (see `Variant::layered`).
    pub fn layered(&self) -> bool {
        self.extent.layered
    }
}

/// A compiled kernel bound to a scene, on some device path: what runs recordings.
pub trait BoundKernel {
    /// What fails on this path.
    type Error: std::error::Error + Send + Sync + Into<GpuError> + From<GpuError> + 'static;
    /// Zeroes the ray counters.
    fn reset_counts(&self) -> Result<(), Self::Error>;
    /// Runs `d` and waits for it.
    fn dispatch(&self, d: &super::recording::Dispatch) -> Result<(), Self::Error>;
    /// `read` of the first `len` vec4s of the output buffer (clamped to it) and the ray
    /// counters, where the device left them (no copy).
    fn read_output_with<T>(
        &self,
        len: u64,
        read: impl FnOnce(&[[f32; 4]], RayCounts) -> T,
    ) -> Result<T, Self::Error>;
    /// A copy of the output buffer, and the ray counters.
    fn read_output(&self) -> Result<(Vec<[f32; 4]>, RayCounts), Self::Error> {
        self.read_output_with(u64::MAX, |out, rays| (out.to_vec(), rays))
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
    /// Output vec4s `first..first + len` (clamped to the buffer): a piece of a picture, read
    /// back without the rest.
    fn read_output_range(&self, first: u64, len: u64) -> Result<Vec<[f32; 4]>, Self::Error>;

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

/// A device path as `render::Session` uses it. Each path implements the primitives (a scene
/// texture allocated and written by rows, a kernel compiled and bound); uploading in bands and
/// updating in place are the provided methods, the same on every path.
pub trait Device {
    /// What a dispatch or readback can fail with.
    type Error: std::error::Error + Send + Sync + Into<GpuError> + From<GpuError> + 'static;
    /// The path's scene texture and frame-constant buffer.
    type Texture;
    /// A compiled kernel bound to a scene and its buffers.
    type Kernel;
    /// A kernel bound to this device, ready to run recordings.
    type Bound<'a>: BoundKernel<Error = Self::Error>
    where
        Self: 'a;

    /// The adapter's name, its driver's own description (version) and its kind.
    fn adapter(&self) -> (&str, &str, wgpu::DeviceType);
    /// The adapter's name, for reports.
    fn adapter_name(&self) -> &str {
        self.adapter().0
    }
    /// Its driver's own description (version), for reports.
    fn adapter_driver(&self) -> &str {
        self.adapter().1
    }
    /// The device runs on the CPU (lavapipe): schedules are built for its threads.
    fn is_cpu(&self) -> bool {
        self.adapter().2 == wgpu::DeviceType::Cpu
    }
    /// Lanes of a SIMD group (what `SimdCount::efficiency` divides by), where the device runs the
    /// SIMD counters (`Variant::simd_stats`) and its groups have one size.
    fn subgroup_size(&self) -> Option<u32>;
    /// The device runs f64 shaders.
    fn has_f64(&self) -> bool;
    /// The largest 2D texture side, and the most array layers.
    fn texture_limits(&self) -> (u32, u32);
    /// The most bytes one storage buffer binding may cover (the device's largest storage
    /// binding, and largest buffer): what the output, frame and work buffers are sized within
    /// (a picture past it is traced in pieces, `render::pieces`).
    fn max_binding_bytes(&self) -> u64;
    /// A scene texture of `extent`, its frame constants `params`; nothing written yet.
    fn allocate_texture(&self, extent: &SceneExtent, params: &Params) -> Result<Self::Texture, GpuError>;
    /// Writes `texels` (consumed: freed band by band as they reach the device) into the rows of
    /// `texture` from row `from` on, and waits; returns the bytes written.
    fn write_rows(
        &self,
        texture: &mut Self::Texture,
        extent: &SceneExtent,
        from: u32,
        texels: Vec<[u32; 4]>,
    ) -> Result<u64, GpuError>;
    /// Writes the frame constants; the next dispatch sees them.
    fn write_constants(&self, texture: &Self::Texture, params: &Params);
    /// Compiles `spec` (its variant's `layered` and `accel` taken from the scene) bound to
    /// `scene`.
    fn compile_kernel(
        &self,
        scene: &DeviceScene<Self::Texture>,
        spec: KernelSpec,
    ) -> Result<Self::Kernel, GpuError>;
    /// The variant `kernel` was compiled for.
    fn variant(kernel: &Self::Kernel) -> Variant;
    /// Binds `kernel` to `scene`'s new texture (after an update replaced it), keeping its
    /// buffers.
    fn rebind(&self, kernel: &mut Self::Kernel, scene: &DeviceScene<Self::Texture>) -> Result<(), GpuError>;
    /// Copies `from`'s frame buffer into `to`'s (as much as both hold): what a recompiled kernel
    /// takes over, so that the picture does not go black.
    fn copy_frame(&self, to: &Self::Kernel, from: &Self::Kernel) -> Result<(), GpuError>;
    /// `kernel` on this device, as a backend.
    fn bind<'a>(&'a self, kernel: &'a Self::Kernel) -> Self::Bound<'a>;
    /// A first frame has run, so drivers that compile at the first dispatch have compiled: what
    /// a pipeline cache on disk waits for.
    fn pipelines_compiled(&self) {}

    /// Uploads `packed` with its frame constants (and waits for it) into a texture of at least
    /// `reserve_rows` rows, layered past `max_rows` rows if given and fewer than the device's
    /// largest texture side.
    fn upload(
        &self,
        packed: PackedScene,
        params: Params,
        max_rows: Option<u32>,
        reserve_rows: u32,
    ) -> Result<DeviceScene<Self::Texture>, GpuError> {
        let (max_dim, max_layers) = self.texture_limits();
        let extent = SceneExtent::of(&packed, reserve_rows, max_rows, max_dim, max_layers)?;
        let mut texture = self.allocate_texture(&extent, &params)?;
        let bytes = self.write_rows(&mut texture, &extent, 0, packed.texels)? + PARAMS_BYTES;
        Ok(DeviceScene { params, extent, bytes, texture })
    }

    /// Replaces `scene`'s contents: in place while they fit, else in a new texture with room to
    /// spare; returns whether the texture is new (kernels bound to it must [`Device::rebind`]).
    fn update_scene(
        &self,
        scene: &mut DeviceScene<Self::Texture>,
        packed: PackedScene,
        params: Params,
    ) -> Result<bool, GpuError> {
        let rows = packed.rows();
        if scene.extent.fits(rows) {
            scene.bytes =
                self.write_rows(&mut scene.texture, &scene.extent, 0, packed.texels)? + PARAMS_BYTES;
            self.set_params(scene, params);
            return Ok(false);
        }
        *scene = self.upload(packed, params, scene.extent.max_rows(), grown_rows(rows))?;
        Ok(true)
    }

    /// Writes `texels`, the packed scene's texels from row `from` on, in place (the rows before
    /// stay), with `params`: a new accelerator for the same scene (`layout::swap_accel`). False,
    /// and nothing written, when they do not fit the texture as it is.
    fn update_scene_from(
        &self,
        scene: &mut DeviceScene<Self::Texture>,
        from: u32,
        texels: Vec<[u32; 4]>,
        params: Params,
    ) -> Result<bool, GpuError> {
        if !scene.extent.fits(from + super::layout::rows_of(texels.len())) {
            return Ok(false);
        }
        let written = self.write_rows(&mut scene.texture, &scene.extent, from, texels)?;
        scene.bytes = from as u64 * super::layout::SCENE_TEX_WIDTH as u64 * 16 + written + PARAMS_BYTES;
        self.set_params(scene, params);
        Ok(true)
    }

    /// Replaces the frame constants; the next dispatch sees them.
    fn set_params(&self, scene: &mut DeviceScene<Self::Texture>, params: Params) {
        scene.params = params;
        self.write_constants(&scene.texture, &params);
    }

    /// [`Device::compile_kernel`], after checking that the device has what the variant needs.
    fn compile(
        &self,
        scene: &DeviceScene<Self::Texture>,
        spec: KernelSpec,
    ) -> Result<Self::Kernel, GpuError> {
        let adapter = || self.adapter_name().to_string();
        if spec.variant.f64 && !self.has_f64() {
            return Err(GpuError::NoF64 { adapter: adapter() });
        }
        if spec.variant.simd_stats && self.subgroup_size().is_none() {
            return Err(GpuError::NoSubgroups { adapter: adapter() });
        }
        let accel = super::layout::accel_code(&scene.params);
        let variant = Variant { layered: scene.layered(), accel, ..spec.variant };
        self.compile_kernel(scene, KernelSpec { variant, ..spec })
    }
}

/// Bytes of the frame constants.
const PARAMS_BYTES: u64 = std::mem::size_of::<Params>() as u64;

/// How many threads a device deals the bands' tiles to: lavapipe's pool (`LP_NUM_THREADS`, else
/// one thread per core); 0 for a GPU, whose scheduler balances itself and whose caches prefer
/// neighbouring workgroups on neighbouring tiles.
pub fn dealing_threads(device: &impl Device) -> u32 {
    if !device.is_cpu() {
        return 0;
    }
    std::env::var("LP_NUM_THREADS")
        .ok()
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(2, |n| n.get() as u32))
}
