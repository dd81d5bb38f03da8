//! The scene image, the binding layout and compiled kernels on the ash path: the counterparts of
//! src/gpu/wgpu/scene.rs and kernel.rs, with the binding table, the scene texture's extent and
//! bands, and the output's decoding shared with them.

use super::spirv::{compile_entry, launch_as_push_constants, options_for};
use super::{fail, Buffer, Shared, VkContext, VkError};
use crate::gpu::bindings::{BindingKind, BINDINGS};
use crate::gpu::device::{DeviceScene, KernelSpec};
use crate::gpu::layout::{Launch, Params, SCENE_LAYER_ROWS, SCENE_TEX_WIDTH};
use crate::gpu::output::{decode_output, RayCounts, STATS_BYTES};
use crate::gpu::scene_texture::{pad_rows, scene_bands, SceneExtent};
use crate::gpu::shaders::{self, Variant};
use ash::vk;
use std::sync::{Arc, Mutex};
use std::time::Instant;

/// The descriptor type of a binding of the table. The scene texture: naga writes the read-only
/// `texture_storage_2d<rgba32uint, read>` as an `OpTypeImage` with Sampled = 2 and reads it with
/// `OpImageRead`: a storage image, in the GENERAL layout.
pub(super) fn descriptor_type(kind: BindingKind) -> vk::DescriptorType {
    match kind {
        BindingKind::Uniform => vk::DescriptorType::UNIFORM_BUFFER,
        BindingKind::SceneImage => vk::DescriptorType::STORAGE_IMAGE,
        BindingKind::Storage { .. } => vk::DescriptorType::STORAGE_BUFFER,
    }
}

/// The one descriptor set layout and pipeline layout every kernel uses.
pub(crate) struct Layout {
    shared: Arc<Shared>,
    set_layout: vk::DescriptorSetLayout,
    pipeline_layout: vk::PipelineLayout,
}

impl Layout {
    pub fn new(shared: &Arc<Shared>) -> Result<Self, VkError> {
        let bindings: Vec<_> = BINDINGS
            .iter()
            .enumerate()
            .map(|(i, b)| {
                vk::DescriptorSetLayoutBinding::default()
                    .binding(i as u32)
                    .descriptor_type(descriptor_type(b.kind))
                    .descriptor_count(1)
                    .stage_flags(vk::ShaderStageFlags::COMPUTE)
            })
            .collect();
        let d = &shared.device;
        // SAFETY: plain object creation; destroyed by `drop`.
        unsafe {
            let set_layout = d
                .create_descriptor_set_layout(
                    &vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings),
                    None,
                )
                .map_err(fail("vkCreateDescriptorSetLayout"))?;
            let sets = [set_layout];
            // `VkOptions::push_tile`: the launch uniform in push constants instead of its binding.
            let push = [vk::PushConstantRange {
                stage_flags: vk::ShaderStageFlags::COMPUTE,
                offset: 0,
                size: std::mem::size_of::<Launch>() as u32,
            }];
            let mut info = vk::PipelineLayoutCreateInfo::default().set_layouts(&sets);
            if shared.caps.options.push_tile {
                info = info.push_constant_ranges(&push);
            }
            let pipeline_layout = match d.create_pipeline_layout(&info, None) {
                Ok(p) => p,
                Err(e) => {
                    d.destroy_descriptor_set_layout(set_layout, None);
                    return Err(fail("vkCreatePipelineLayout")(e));
                }
            };
            Ok(Layout { shared: shared.clone(), set_layout, pipeline_layout })
        }
    }

    /// A compute pipeline of `entry` from checked SPIR-V `words`.
    pub fn pipeline(&self, words: &[u32], entry: &str) -> Result<vk::Pipeline, VkError> {
        // The structural check and naga's read-back always (about 1 % of lavapipe's pipeline
        // creation), spirv-val on request (about a fifth; docs/backends.md).
        super::check_spirv(words, entry)?;
        super::naga_check(words, entry)?;
        if self.shared.caps.options.full_spirv_check {
            super::spirv_val_check(words, entry)?;
        }
        let d = &self.shared.device;
        let name =
            std::ffi::CString::new(entry).map_err(|_| VkError::Shader(format!("entry point {entry:?}")))?;
        // SAFETY: the words were checked above; the module is destroyed once the pipeline holds
        // its code.
        unsafe {
            let module = d
                .create_shader_module(&vk::ShaderModuleCreateInfo::default().code(words), None)
                .map_err(|e| match e {
                    vk::Result::ERROR_DEVICE_LOST => VkError::DeviceLost { what: "shader module creation" },
                    e => VkError::Shader(format!("the driver rejected the SPIR-V of '{entry}': {e}")),
                })?;
            let stage = vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::COMPUTE)
                .module(module)
                .name(&name);
            let info = vk::ComputePipelineCreateInfo::default().stage(stage).layout(self.pipeline_layout);
            let made = d.create_compute_pipelines(vk::PipelineCache::null(), &[info], None);
            d.destroy_shader_module(module, None);
            match made {
                Ok(p) => Ok(p[0]),
                Err((_, vk::Result::ERROR_DEVICE_LOST)) => {
                    Err(VkError::DeviceLost { what: "pipeline creation" })
                }
                Err((_, e)) => {
                    Err(VkError::Shader(format!("the driver could not make a pipeline of '{entry}': {e}")))
                }
            }
        }
    }
}

impl Drop for Layout {
    fn drop(&mut self) {
        // SAFETY: pipelines made with it are gone or never used again.
        unsafe {
            self.shared.device.destroy_pipeline_layout(self.pipeline_layout, None);
            self.shared.device.destroy_descriptor_set_layout(self.set_layout, None);
        }
    }
}

/// The scene's image and frame constants, shared by the scene and the dispatchers bound to it.
pub(super) struct SceneResources {
    pub(super) shared: Arc<Shared>,
    pub(super) image: vk::Image,
    pub(super) memory: vk::DeviceMemory,
    pub(super) view: vk::ImageView,
    pub(super) params: Buffer,
    /// All of the image's layers.
    pub(super) range: vk::ImageSubresourceRange,
}

impl Drop for SceneResources {
    fn drop(&mut self) {
        // SAFETY: no dispatcher holds it any more, and every submission was waited for.
        unsafe {
            self.shared.device.destroy_image_view(self.view, None);
            self.shared.device.destroy_image(self.image, None);
            self.shared.device.free_memory(self.memory, None);
        }
    }
}

/// The ash path's scene texture: the image and frame constants (shared with the kernels bound
/// to them), and whether the image has been written (its layout is then GENERAL).
pub struct SceneImage {
    res: Arc<SceneResources>,
    written: bool,
}

/// A scene resident on the device (the ash path's `GpuScene`).
pub type VkScene = DeviceScene<SceneImage>;

impl SceneImage {
    /// An image of `extent`, nothing written yet, and the frame constants `params`.
    pub(super) fn new(ctx: &VkContext, extent: &SceneExtent, params: &Params) -> Result<Self, VkError> {
        let shared = &ctx.shared;
        let SceneExtent { height, layers, layered, .. } = *extent;
        let format = vk::Format::R32G32B32A32_UINT;
        let d = &shared.device;
        let range = vk::ImageSubresourceRange {
            aspect_mask: vk::ImageAspectFlags::COLOR,
            base_mip_level: 0,
            level_count: 1,
            base_array_layer: 0,
            layer_count: layers,
        };
        let params_buf = shared.buffer(
            std::mem::size_of::<Params>() as u64,
            vk::BufferUsageFlags::UNIFORM_BUFFER,
            true,
        )?;
        params_buf.write(0, bytemuck::bytes_of(params));
        // SAFETY: object creation; `SceneResources` destroys what is made once it exists, and the
        // error arms before it destroy what they made.
        let res = unsafe {
            let image = d
                .create_image(
                    &vk::ImageCreateInfo::default()
                        .image_type(vk::ImageType::TYPE_2D)
                        .format(format)
                        .extent(vk::Extent3D { width: SCENE_TEX_WIDTH, height, depth: 1 })
                        .mip_levels(1)
                        .array_layers(layers)
                        .samples(vk::SampleCountFlags::TYPE_1)
                        .tiling(vk::ImageTiling::OPTIMAL)
                        .usage(vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_DST)
                        .initial_layout(vk::ImageLayout::UNDEFINED),
                    None,
                )
                .map_err(fail("vkCreateImage"))?;
            let req = d.get_image_memory_requirements(image);
            let memory = match shared.allocate(
                req,
                vk::MemoryPropertyFlags::empty(),
                vk::MemoryPropertyFlags::DEVICE_LOCAL,
            ) {
                Ok(m) => m,
                Err(e) => {
                    d.destroy_image(image, None);
                    return Err(e);
                }
            };
            if let Err(e) = d.bind_image_memory(image, memory, 0) {
                d.destroy_image(image, None);
                d.free_memory(memory, None);
                return Err(fail("vkBindImageMemory")(e));
            }
            let view_type =
                if layered { vk::ImageViewType::TYPE_2D_ARRAY } else { vk::ImageViewType::TYPE_2D };
            let view = match d.create_image_view(
                &vk::ImageViewCreateInfo::default()
                    .image(image)
                    .view_type(view_type)
                    .format(format)
                    .subresource_range(range),
                None,
            ) {
                Ok(v) => v,
                Err(e) => {
                    d.destroy_image(image, None);
                    d.free_memory(memory, None);
                    return Err(fail("vkCreateImageView")(e));
                }
            };
            SceneResources { shared: shared.clone(), image, memory, view, params: params_buf, range }
        };
        Ok(SceneImage { res: Arc::new(res), written: false })
    }

    /// The image and constants kernels bind.
    pub(super) fn resources(&self) -> &Arc<SceneResources> {
        &self.res
    }

    /// Writes the frame constants; the next dispatch sees them.
    pub(super) fn write_params(&self, params: &Params) {
        self.res.params.write(0, bytemuck::bytes_of(params));
    }

    /// Writes `texels` into the rows from `first_row` on (see `SceneResources::write_rows`).
    pub(super) fn write_rows(
        &mut self,
        first_row: u32,
        texels: Vec<[u32; 4]>,
        layered: bool,
    ) -> Result<u64, VkError> {
        let from = if self.written { vk::ImageLayout::GENERAL } else { vk::ImageLayout::UNDEFINED };
        let bytes = self.res.write_rows(first_row, texels, layered, from)?;
        self.written = true;
        Ok(bytes)
    }
}

impl SceneResources {
    /// Writes `texels` (consumed) into the rows of the image from row `first_row` on, whose
    /// layout is `from` (UNDEFINED when new, GENERAL when updated), and leaves it ready for the
    /// kernels. The texels go through one host-visible staging band of [`SCENE_LAYER_ROWS`] rows
    /// at a time, from the last band to the first, each freed on the host once copied (as
    /// `GpuScene::upload_packed` does through wgpu's staging). Returns the bytes written.
    fn write_rows(
        &self,
        first_row: u32,
        texels: Vec<[u32; 4]>,
        layered: bool,
        from: vk::ImageLayout,
    ) -> Result<u64, VkError> {
        let shared = &self.shared;
        let (res, range) = (self, self.range);
        let mut data = texels;
        let rows = pad_rows(&mut data);
        let bytes = data.len() as u64 * 16;
        let row_bytes = SCENE_TEX_WIDTH as u64 * 16;
        let staging = shared.buffer(
            rows.min(SCENE_LAYER_ROWS) as u64 * row_bytes,
            vk::BufferUsageFlags::TRANSFER_SRC,
            true,
        )?;
        let mut first_band = true;
        for band in scene_bands(first_row, first_row + rows, layered) {
            let start = (band.first * SCENE_TEX_WIDTH) as usize;
            let end = start + (band.rows * SCENE_TEX_WIDTH) as usize;
            staging.write(0, bytemuck::cast_slice(&data[start..end]));
            let last_band = band.first == 0;
            let barrier = |old, new, src, dst| {
                vk::ImageMemoryBarrier::default()
                    .old_layout(old)
                    .new_layout(new)
                    .src_access_mask(src)
                    .dst_access_mask(dst)
                    .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                    .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                    .image(res.image)
                    .subresource_range(range)
            };
            shared.submit("the scene upload", |d, cmd| unsafe {
                // SAFETY: recording into the command buffer `submit` began.
                if first_band {
                    let b = barrier(
                        from,
                        vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                        vk::AccessFlags::SHADER_READ,
                        vk::AccessFlags::TRANSFER_WRITE,
                    );
                    d.cmd_pipeline_barrier(
                        cmd,
                        vk::PipelineStageFlags::COMPUTE_SHADER,
                        vk::PipelineStageFlags::TRANSFER,
                        vk::DependencyFlags::empty(),
                        &[],
                        &[],
                        &[b],
                    );
                }
                let region = vk::BufferImageCopy {
                    buffer_offset: 0,
                    buffer_row_length: 0,
                    buffer_image_height: 0,
                    image_subresource: vk::ImageSubresourceLayers {
                        aspect_mask: vk::ImageAspectFlags::COLOR,
                        mip_level: 0,
                        base_array_layer: band.layer,
                        layer_count: 1,
                    },
                    image_offset: vk::Offset3D { x: 0, y: band.y as i32, z: 0 },
                    image_extent: vk::Extent3D { width: SCENE_TEX_WIDTH, height: band.rows, depth: 1 },
                };
                d.cmd_copy_buffer_to_image(
                    cmd,
                    staging.raw,
                    res.image,
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    &[region],
                );
                if last_band {
                    let b = barrier(
                        vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                        vk::ImageLayout::GENERAL,
                        vk::AccessFlags::TRANSFER_WRITE,
                        vk::AccessFlags::SHADER_READ,
                    );
                    d.cmd_pipeline_barrier(
                        cmd,
                        vk::PipelineStageFlags::TRANSFER,
                        vk::PipelineStageFlags::COMPUTE_SHADER,
                        vk::DependencyFlags::empty(),
                        &[],
                        &[],
                        &[b],
                    );
                }
            })?;
            first_band = false;
            data.truncate(start);
            data.shrink_to_fit();
        }
        Ok(bytes)
    }
}

/// A compiled kernel bound to a scene and its buffers (the ash path's
/// [`crate::gpu::Dispatcher`]); pipelines are made per entry point at first use.
pub struct VkDispatcher {
    pub(super) shared: Arc<Shared>,
    pub(super) variant: Variant,
    pub(super) module: naga::Module,
    pub(super) info: naga::valid::ModuleInfo,
    pub(super) options: naga::back::spv::Options<'static>,
    pub(super) layout: Layout,
    pub(super) pipelines: Mutex<Vec<(String, vk::Pipeline)>>,
    pub(super) pool: vk::DescriptorPool,
    pub(super) set: vk::DescriptorSet,
    pub(super) out: Buffer,
    pub(super) stats: Buffer,
    pub(super) launch: Buffer,
    pub(super) _inputs: Buffer,
    pub(super) work: Buffer,
    pub(super) queue: Buffer,
    pub(super) frame: Buffer,
    pub(super) readback: Buffer,
    pub(super) out_len: u64,
    pub(super) frame_len: u64,
    pub(super) scene: Arc<SceneResources>,
}

impl Drop for VkDispatcher {
    fn drop(&mut self) {
        // SAFETY: every submission was waited for; the set goes with its pool.
        unsafe {
            for (_, p) in self.pipelines.get_mut().unwrap_or_else(|e| e.into_inner()).drain(..) {
                self.shared.device.destroy_pipeline(p, None);
            }
            self.shared.device.destroy_descriptor_pool(self.pool, None);
        }
    }
}

impl VkDispatcher {
    /// Compiles `spec` (its variant's `layered` and `accel` the scene's) and binds it to `scene`
    /// and the buffers it asks for. The WGSL is validated by naga here; each entry point's SPIR-V
    /// when first run.
    pub(super) fn new(ctx: &VkContext, scene: &VkScene, spec: KernelSpec) -> Result<Self, VkError> {
        let KernelSpec { program, variant, out_len, inputs, modes } = spec;
        let shared = &ctx.shared;
        let src = shaders::compose(program, variant);
        let (module, info) =
            shaders::validate(&src).map_err(|e| VkError::Shader(format!("naga rejected the kernel: {e}")))?;
        let (module, info) =
            if shared.caps.options.push_tile { launch_as_push_constants(module)? } else { (module, info) };
        let options = options_for(&shared.caps);
        let layout = Layout::new(shared)?;
        use vk::BufferUsageFlags as U;
        let storage = |bytes: u64, extra: U| shared.buffer(bytes, U::STORAGE_BUFFER | extra, false);
        let out = storage(out_len * 16, U::TRANSFER_SRC)?;
        let stats = storage(STATS_BYTES, U::TRANSFER_SRC | U::TRANSFER_DST)?;
        let launch = shared.buffer(std::mem::size_of::<Launch>() as u64, U::UNIFORM_BUFFER, true)?;
        launch.write(0, bytemuck::bytes_of(&Launch::default()));
        let input_bytes: &[u8] = if inputs.is_empty() { &[0; 16] } else { bytemuck::cast_slice(inputs) };
        let inputs_buf = storage(input_bytes.len() as u64, U::TRANSFER_DST)?;
        {
            let staging = shared.buffer(input_bytes.len() as u64, U::TRANSFER_SRC, true)?;
            staging.write(0, input_bytes);
            let size = input_bytes.len() as u64;
            // SAFETY: recording into the command buffer `submit` began.
            shared.submit("the test inputs' upload", |d, cmd| unsafe {
                d.cmd_copy_buffer(
                    cmd,
                    staging.raw,
                    inputs_buf.raw,
                    &[vk::BufferCopy { src_offset: 0, dst_offset: 0, size }],
                )
            })?;
        }
        let work = storage(modes.work_len * 4, U::TRANSFER_DST)?;
        let queue = storage(16, U::TRANSFER_DST | U::TRANSFER_SRC)?;
        let frame = storage(modes.frame_len * 16, U::TRANSFER_DST | U::TRANSFER_SRC)?;
        let readback =
            shared.buffer((out_len * 16).max(modes.frame_len * 16) + STATS_BYTES, U::TRANSFER_DST, true)?;
        let d = &shared.device;
        let count = |ty| BINDINGS.iter().filter(|b| descriptor_type(b.kind) == ty).count() as u32;
        let sizes = [
            vk::DescriptorType::UNIFORM_BUFFER,
            vk::DescriptorType::STORAGE_IMAGE,
            vk::DescriptorType::STORAGE_BUFFER,
        ]
        .map(|ty| vk::DescriptorPoolSize { ty, descriptor_count: count(ty) });
        // SAFETY: object creation; the pool is destroyed by `drop` (or below on failure).
        let (pool, set) = unsafe {
            let pool = d
                .create_descriptor_pool(
                    &vk::DescriptorPoolCreateInfo::default().max_sets(1).pool_sizes(&sizes),
                    None,
                )
                .map_err(fail("vkCreateDescriptorPool"))?;
            let layouts = [layout.set_layout];
            let set = match d.allocate_descriptor_sets(
                &vk::DescriptorSetAllocateInfo::default().descriptor_pool(pool).set_layouts(&layouts),
            ) {
                Ok(s) => s[0],
                Err(e) => {
                    d.destroy_descriptor_pool(pool, None);
                    return Err(fail("vkAllocateDescriptorSets")(e));
                }
            };
            (pool, set)
        };
        let buffer = |name: &str| match name {
            "params" => &scene.texture.res.params,
            "out_buf" => &out,
            "stats" => &stats,
            "launch" => &launch,
            "test_in" => &inputs_buf,
            "work_buf" => &work,
            "queue" => &queue,
            "frame_buf" => &frame,
            other => unreachable!("binding {other} is not a buffer"),
        };
        let buffer_infos: Vec<[vk::DescriptorBufferInfo; 1]> = BINDINGS
            .iter()
            .map(|b| match b.kind {
                BindingKind::SceneImage => [vk::DescriptorBufferInfo::default()],
                _ => [vk::DescriptorBufferInfo {
                    buffer: buffer(b.name).raw,
                    offset: 0,
                    range: vk::WHOLE_SIZE,
                }],
            })
            .collect();
        let image_info = [vk::DescriptorImageInfo {
            sampler: vk::Sampler::null(),
            image_view: scene.texture.res.view,
            image_layout: vk::ImageLayout::GENERAL,
        }];
        let writes: Vec<_> = BINDINGS
            .iter()
            .enumerate()
            .map(|(slot, b)| {
                let w = vk::WriteDescriptorSet::default()
                    .dst_set(set)
                    .dst_binding(slot as u32)
                    .descriptor_type(descriptor_type(b.kind));
                match b.kind {
                    BindingKind::SceneImage => w.image_info(&image_info),
                    _ => w.buffer_info(&buffer_infos[slot]),
                }
            })
            .collect();
        // SAFETY: every written object is alive and of the binding's type.
        unsafe { d.update_descriptor_sets(&writes, &[]) };
        Ok(VkDispatcher {
            shared: shared.clone(),
            variant,
            module,
            info,
            options,
            layout,
            pipelines: Mutex::new(Vec::new()),
            pool,
            set,
            out,
            stats,
            launch,
            _inputs: inputs_buf,
            work,
            queue,
            frame,
            readback,
            out_len,
            frame_len: modes.frame_len,
            scene: scene.texture.res.clone(),
        })
    }

    /// The variant compiled.
    pub fn variant(&self) -> Variant {
        self.variant
    }

    fn pipeline(&self, entry: &str) -> Result<vk::Pipeline, VkError> {
        let mut pipes = self.pipelines.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((_, p)) = pipes.iter().find(|(e, _)| e == entry) {
            return Ok(*p);
        }
        let words = compile_entry(&self.module, &self.info, entry, &self.options)?;
        let p = self.layout.pipeline(&words, entry)?;
        pipes.push((entry.to_string(), p));
        Ok(p)
    }

    /// Runs `entry` over `groups` workgroups with `launch` as its uniform, and waits for it.
    /// With `VkOptions::push_tile` it goes in push constants, else into the launch buffer;
    /// with `VkOptions::profile` the dispatch is timed and its invocations counted
    /// (`VkContext::take_samples`).
    pub fn run(&self, entry: &str, launch: Launch, groups: [u32; 3]) -> Result<(), VkError> {
        let pipeline = self.pipeline(entry)?;
        let (layout, set) = (self.layout.pipeline_layout, self.set);
        let push = self.shared.caps.options.push_tile;
        let queries = self.shared.queries.as_ref();
        let start = Instant::now();
        let record = |d: &ash::Device, cmd| {
            if !push {
                // Under the submit lock, so no other submission reads the launch buffer now.
                self.launch.write(0, bytemuck::bytes_of(&launch));
            }
            // SAFETY: recording into the command buffer `submit` began; all bound objects live;
            // the queries' begin and end enclose only the dispatch.
            unsafe {
                d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, pipeline);
                d.cmd_bind_descriptor_sets(cmd, vk::PipelineBindPoint::COMPUTE, layout, 0, &[set], &[]);
                if push {
                    let bytes = bytemuck::bytes_of(&launch);
                    d.cmd_push_constants(cmd, layout, vk::ShaderStageFlags::COMPUTE, 0, bytes);
                }
                if let Some(q) = queries {
                    q.begin(d, cmd);
                }
                d.cmd_dispatch(cmd, groups[0], groups[1], groups[2]);
                if let Some(q) = queries {
                    q.end(d, cmd);
                }
            }
        };
        self.shared.submit_then("a dispatch", record, |d| match queries {
            Some(q) => q.collect(d, entry, groups, start.elapsed()),
            None => Ok(()),
        })
    }

    /// Zeroes the ray counters.
    pub fn reset_counts(&self) -> Result<(), VkError> {
        // SAFETY: recording into the command buffer `submit` began.
        self.shared.submit("clearing the ray counters", |d, cmd| unsafe {
            d.cmd_fill_buffer(cmd, self.stats.raw, 0, STATS_BYTES, 0)
        })
    }

    /// `read` of the first `len` vec4s of the output buffer (clamped to it) and the ray
    /// counters, in the mapped readback memory.
    pub fn read_with<T>(
        &self,
        len: u64,
        read: impl FnOnce(&[[f32; 4]], RayCounts) -> T,
    ) -> Result<T, VkError> {
        let out_bytes = self.out_len.min(len) * 16;
        self.shared.submit("the readback", |d, cmd| {
            // SAFETY: recording into the command buffer `submit` began.
            unsafe {
                if out_bytes > 0 {
                    let copy = vk::BufferCopy { src_offset: 0, dst_offset: 0, size: out_bytes };
                    d.cmd_copy_buffer(cmd, self.out.raw, self.readback.raw, &[copy]);
                }
                let copy = vk::BufferCopy { src_offset: 0, dst_offset: out_bytes, size: STATS_BYTES };
                d.cmd_copy_buffer(cmd, self.stats.raw, self.readback.raw, &[copy]);
            }
        })?;
        Ok(self.readback.read_with(out_bytes + STATS_BYTES, |d| decode_output(d, out_bytes, read)))
    }
}
