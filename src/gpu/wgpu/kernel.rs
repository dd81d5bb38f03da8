//! A compiled kernel on the wgpu path: its pipelines (one per entry point), the bind group of
//! the binding table (`gpu::bindings`) and its buffers.

use super::{storage, uniform, view_dimension, GpuContext, GpuScene};
use crate::gpu::bindings::{BindingKind, BINDINGS};
use crate::gpu::device::KernelSpec;
use crate::gpu::failure::{DeviceFailure, FailureKind};
use crate::gpu::layout::Launch;
use crate::gpu::output::{decode_output, RayCounts, STATS_BYTES};
use crate::gpu::shaders::{self, Variant};
use crate::gpu::GpuError;
use std::sync::Mutex;

/// The one bind group layout every kernel uses: the binding table, its scene texture layered
/// or not.
fn bind_group_layout(device: &wgpu::Device, layered: bool) -> wgpu::BindGroupLayout {
    use wgpu::{BindingType as B, BufferBindingType as Bb};
    let buffer = |ty| B::Buffer { ty, has_dynamic_offset: false, min_binding_size: None };
    let entries: Vec<_> = BINDINGS
        .iter()
        .enumerate()
        .map(|(slot, b)| wgpu::BindGroupLayoutEntry {
            binding: slot as u32,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: match b.kind {
                BindingKind::Uniform => buffer(Bb::Uniform),
                BindingKind::Storage { read_only } => buffer(Bb::Storage { read_only }),
                BindingKind::SceneImage => B::StorageTexture {
                    access: wgpu::StorageTextureAccess::ReadOnly,
                    format: wgpu::TextureFormat::Rgba32Uint,
                    view_dimension: view_dimension(layered),
                },
            },
            count: None,
        })
        .collect();
    device
        .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some("irt"), entries: &entries })
}

/// The kernel's own buffers, by binding: everything but the scene's constants and texture.
struct Buffers {
    out: wgpu::Buffer,
    stats: wgpu::Buffer,
    launch: wgpu::Buffer,
    inputs: wgpu::Buffer,
    work: wgpu::Buffer,
    queue: wgpu::Buffer,
    frame: wgpu::Buffer,
}

impl Buffers {
    /// The resource bound at `slot` (the binding table's order), the scene's among them.
    fn at<'a>(&'a self, scene: &'a GpuScene, slot: usize) -> wgpu::BindingResource<'a> {
        match BINDINGS[slot].name {
            "params" => scene.texture.params.as_entire_binding(),
            "scene_tex" => wgpu::BindingResource::TextureView(&scene.texture.view),
            "out_buf" => self.out.as_entire_binding(),
            "stats" => self.stats.as_entire_binding(),
            "launch" => self.launch.as_entire_binding(),
            "test_in" => self.inputs.as_entire_binding(),
            "work_buf" => self.work.as_entire_binding(),
            "queue" => self.queue.as_entire_binding(),
            "frame_buf" => self.frame.as_entire_binding(),
            other => unreachable!("binding {other} has no resource"),
        }
    }

    /// The bind group of every binding: the scene's constants and texture, and these buffers.
    fn bind_group(
        &self,
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        scene: &GpuScene,
    ) -> wgpu::BindGroup {
        let entries: Vec<_> = (0..BINDINGS.len())
            .map(|slot| wgpu::BindGroupEntry { binding: slot as u32, resource: self.at(scene, slot) })
            .collect();
        device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some("irt"), layout, entries: &entries })
    }
}

/// A compiled kernel bound to a scene and its output buffers. Pipelines are created per entry
/// point on first use (lavapipe compiles each at its first dispatch anyway).
pub struct Dispatcher {
    /// What was compiled: the caller's variant with `layered` and `accel` as the scene's are.
    variant: Variant,
    module: wgpu::ShaderModule,
    pipeline_layout: wgpu::PipelineLayout,
    pipelines: Mutex<Vec<(String, wgpu::ComputePipeline)>>,
    bind_group_layout: wgpu::BindGroupLayout,
    bind_group: wgpu::BindGroup,
    buffers: Buffers,
    readback: wgpu::Buffer,
    out_len: u64,
    frame_len: u64,
}

impl Dispatcher {
    /// The variant compiled (what a session reports, `layered` included).
    pub fn variant(&self) -> Variant {
        self.variant
    }

    /// Compiles `spec` (a pipeline per entry point at its first run) and binds it to `scene` and
    /// the buffers it asks for.
    pub(super) fn new(ctx: &GpuContext, scene: &GpuScene, spec: KernelSpec) -> Self {
        let KernelSpec { program, variant, out_len, inputs, modes } = spec;
        let device = &ctx.device;
        let src = shaders::compose(program, variant);
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(program.name()),
            source: wgpu::ShaderSource::Wgsl(src.into()),
        });
        let bgl = bind_group_layout(device, scene.layered());
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("irt"),
            bind_group_layouts: &[Some(&bgl)],
            immediate_size: 0,
        });
        let out_bytes = out_len * 16;
        use wgpu::BufferUsages as U;
        let input_bytes: &[u8] = if inputs.is_empty() { &[0; 16] } else { bytemuck::cast_slice(inputs) };
        // The test hook of a failed allocation: a buffer past the device's largest.
        let out_size = match crate::fault::armed("device-alloc") {
            true => ctx.device.limits().max_buffer_size.saturating_add(1 << 20),
            false => out_bytes,
        };
        let buffers = Buffers {
            out: storage(ctx, "out", out_size, U::COPY_SRC),
            stats: storage(ctx, "stats", STATS_BYTES, U::COPY_SRC | U::COPY_DST),
            launch: uniform(ctx, "launch", bytemuck::bytes_of(&Launch::default())),
            inputs: {
                use wgpu::util::DeviceExt;
                device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("test inputs"),
                    contents: input_bytes,
                    usage: U::STORAGE,
                })
            },
            work: storage(ctx, "work", modes.work_len * 4, U::COPY_DST),
            queue: storage(ctx, "queue", 16, U::COPY_DST | U::COPY_SRC),
            frame: storage(ctx, "frame", modes.frame_len * 16, U::COPY_SRC | U::COPY_DST),
        };
        let readback = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size: out_bytes.max(modes.frame_len * 16).max(16) + STATS_BYTES,
            usage: U::MAP_READ | U::COPY_DST,
            mapped_at_creation: false,
        });
        let bind_group = buffers.bind_group(device, &bgl, scene);
        Dispatcher {
            variant,
            module,
            pipeline_layout,
            pipelines: Mutex::new(Vec::new()),
            bind_group_layout: bgl,
            bind_group,
            buffers,
            readback,
            out_len,
            frame_len: modes.frame_len,
        }
    }

    /// Binds to `scene`'s new texture (after an update replaced it), keeping every buffer, the
    /// frame buffer's samples included. The texture must be layered as before.
    pub fn rebind(&mut self, ctx: &GpuContext, scene: &GpuScene) -> Result<(), GpuError> {
        if scene.layered() != self.variant.layered {
            return Err(GpuError::LayeredRebind);
        }
        self.bind_group = self.buffers.bind_group(&ctx.device, &self.bind_group_layout, scene);
        Ok(())
    }

    /// Copies `other`'s frame buffer into this one's (as much as both hold): what a recompiled
    /// kernel takes over, so the picture on screen does not go black.
    pub fn copy_frame_from(&self, ctx: &GpuContext, other: &Dispatcher) {
        let bytes = self.buffers.frame.size().min(other.buffers.frame.size());
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        enc.copy_buffer_to_buffer(&other.buffers.frame, 0, &self.buffers.frame, 0, bytes);
        ctx.queue.submit([enc.finish()]);
    }

    fn pipeline(&self, ctx: &GpuContext, entry: &str) -> wgpu::ComputePipeline {
        let mut pipes = self.pipelines.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((_, p)) = pipes.iter().find(|(e, _)| e == entry) {
            return p.clone();
        }
        let p = ctx.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(entry),
            layout: Some(&self.pipeline_layout),
            module: &self.module,
            entry_point: Some(entry),
            compilation_options: Default::default(),
            cache: ctx.wgpu_pipeline_cache(),
        });
        pipes.push((entry.to_string(), p.clone()));
        p
    }

    /// Writes `data` at the start of the work buffer (boundary array or pixel order).
    pub fn write_work(&self, ctx: &GpuContext, data: &[u32]) -> Result<(), GpuError> {
        let (bytes, size) = (data.len() as u64 * 4, self.buffers.work.size());
        if bytes > size {
            return Err(GpuError::WorkTooLarge { bytes, size });
        }
        if !data.is_empty() {
            ctx.queue.write_buffer(&self.buffers.work, 0, bytemuck::cast_slice(data));
        }
        ctx.check()
    }

    /// Restarts the tile queue (takes effect before the next submitted dispatch).
    pub fn reset_queue(&self, ctx: &GpuContext) {
        ctx.queue.write_buffer(&self.buffers.queue, 0, &[0u8; 16]);
    }

    /// The tile queue's counter: chunks taken so far (past the last chunk once the queue is
    /// empty).
    pub fn read_queue(&self, ctx: &GpuContext) -> Result<u32, GpuError> {
        self.read_back(ctx, &[(&self.buffers.queue, 0, 16)], |d| bytemuck::cast_slice::<u8, u32>(d)[0])
    }

    /// Copies `(buffer, offset, bytes)` one after another into the readback buffer, waits, and
    /// hands the mapped bytes to `read`: the one readback path of every `read*` method.
    fn read_back<T>(
        &self,
        ctx: &GpuContext,
        copies: &[(&wgpu::Buffer, u64, u64)],
        read: impl FnOnce(&[u8]) -> T,
    ) -> Result<T, GpuError> {
        ctx.check()?;
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        let mut at = 0;
        for &(buf, offset, bytes) in copies {
            if bytes > 0 {
                enc.copy_buffer_to_buffer(buf, offset, &self.readback, at, bytes);
            }
            at += bytes;
        }
        ctx.queue.submit([enc.finish()]);
        let slice = self.readback.slice(..at.max(16));
        let failure = ctx.failure_slot();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            if let Err(e) = r {
                let f = DeviceFailure::new(FailureKind::Lost, format!("mapping the readback: {e}"));
                failure.lock().unwrap_or_else(|p| p.into_inner()).get_or_insert(f);
            }
        });
        ctx.wait();
        ctx.check()?;
        let mapped = slice.get_mapped_range().map_err(|e| {
            GpuError::Device(DeviceFailure::new(FailureKind::Lost, format!("mapping the readback: {e}")))
        })?;
        let out = read(&mapped[..at as usize]);
        drop(mapped);
        self.readback.unmap();
        Ok(out)
    }

    /// Output vec4s `first..first + len` (clamped to the buffer), copied.
    pub fn read_output_range(
        &self,
        ctx: &GpuContext,
        first: u64,
        len: u64,
    ) -> Result<Vec<[f32; 4]>, GpuError> {
        let (first, len) = (first.min(self.out_len), len.min(self.out_len - first.min(self.out_len)));
        self.read_back(ctx, &[(&self.buffers.out, first * 16, len * 16)], bytemuck::pod_collect_to_vec)
    }

    /// Zeroes the frame buffer (no samples anywhere).
    pub fn clear_frame(&self, ctx: &GpuContext) {
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        enc.clear_buffer(&self.buffers.frame, 0, None);
        ctx.queue.submit([enc.finish()]);
    }

    /// The frame buffer: per pixel the sum of its samples (rgb) and their count (a).
    pub fn frame_buffer(&self) -> &wgpu::Buffer {
        &self.buffers.frame
    }

    /// Runs `entry` over `groups` workgroups with `launch` as its uniform and waits for it.
    pub fn run(
        &self,
        ctx: &GpuContext,
        entry: &str,
        launch: Launch,
        groups: [u32; 3],
    ) -> Result<(), GpuError> {
        ctx.check()?;
        ctx.queue.write_buffer(&self.buffers.launch, 0, bytemuck::bytes_of(&launch));
        let pipeline = self.pipeline(ctx, entry);
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            pass.set_pipeline(&pipeline);
            pass.set_bind_group(0, &self.bind_group, &[]);
            pass.dispatch_workgroups(groups[0], groups[1], groups[2]);
        }
        ctx.queue.submit([enc.finish()]);
        ctx.wait();
        if crate::fault::armed("device-lost") {
            ctx.lose_device();
        }
        ctx.check()
    }

    /// Reads back the frame buffer.
    pub fn read_frame(&self, ctx: &GpuContext) -> Result<Vec<[f32; 4]>, GpuError> {
        self.read_back(ctx, &[(&self.buffers.frame, 0, self.frame_len * 16)], |d| {
            bytemuck::cast_slice(d).to_vec()
        })
    }

    /// Clears the ray counters.
    pub fn reset_counts(&self, ctx: &GpuContext) {
        ctx.queue.write_buffer(&self.buffers.stats, 0, &[0u8; STATS_BYTES as usize]);
    }

    /// Reads back the first `len` vec4s of the output buffer (clamped to it) and the ray
    /// counters: `read` gets them in the mapped readback memory, which no copy precedes.
    pub fn read_with<T>(
        &self,
        ctx: &GpuContext,
        len: u64,
        read: impl FnOnce(&[[f32; 4]], RayCounts) -> T,
    ) -> Result<T, GpuError> {
        let out_bytes = self.out_len.min(len) * 16;
        self.read_back(
            ctx,
            &[(&self.buffers.out, 0, out_bytes), (&self.buffers.stats, 0, STATS_BYTES)],
            |d| decode_output(d, out_bytes, read),
        )
    }
}
