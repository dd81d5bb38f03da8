//! The scene image, the binding layout, compiled kernels and the band renderer on the ash path:
//! the counterparts of src/gpu/dispatch.rs and src/gpu/renderer.rs, with the scene packing, the
//! texture's extent and bands, the recording of a frame and its read-out shared with them.

use super::spirv::{compile_entry, options_for, tile_as_push_constants};
use super::{fail, Buffer, Shared, VkContext, VkError};
use crate::accel::Grid;
use crate::gpu::backend::{ComputeBackend, Dispatch};
use crate::gpu::dispatch::{
    pad_rows, scene_bands, scene_texture_extent, ModeBuffers, RayCounts, STATS_BYTES,
};
use crate::gpu::layout::{self, PackedScene, Params, Tile, SCENE_LAYER_ROWS, SCENE_TEX_WIDTH};
use crate::gpu::shaders::{self, Kernel, Variant};
use crate::scene::Scene;
use ash::vk;
use glam::DVec3;
use std::sync::{Arc, Mutex};
use std::time::Instant;

mod modes;

/// Descriptor types of bindings 0–8 (shaders/types.wgsl): the frame constants, the scene texture
/// (naga writes the read-only `texture_storage_2d<rgba32uint, read>` as an `OpTypeImage` with
/// Sampled = 2 and reads it with `OpImageRead`: a storage image, in the GENERAL layout), then
/// out, stats, tile,
/// test inputs, work, queue, frame.
const BINDINGS: [vk::DescriptorType; 9] = [
    vk::DescriptorType::UNIFORM_BUFFER,
    vk::DescriptorType::STORAGE_IMAGE,
    vk::DescriptorType::STORAGE_BUFFER,
    vk::DescriptorType::STORAGE_BUFFER,
    vk::DescriptorType::UNIFORM_BUFFER,
    vk::DescriptorType::STORAGE_BUFFER,
    vk::DescriptorType::STORAGE_BUFFER,
    vk::DescriptorType::STORAGE_BUFFER,
    vk::DescriptorType::STORAGE_BUFFER,
];

/// The one descriptor set layout and pipeline layout every kernel uses.
pub(crate) struct Layout {
    shared: Arc<Shared>,
    set_layout: vk::DescriptorSetLayout,
    pipeline_layout: vk::PipelineLayout,
}

impl Layout {
    pub fn new(shared: &Arc<Shared>, _layered: bool) -> Result<Self, VkError> {
        let bindings: Vec<_> = BINDINGS
            .iter()
            .enumerate()
            .map(|(i, &t)| {
                vk::DescriptorSetLayoutBinding::default()
                    .binding(i as u32)
                    .descriptor_type(t)
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
            // `VkOptions::push_tile`: the tile in push constants instead of binding 4.
            let push = [vk::PushConstantRange {
                stage_flags: vk::ShaderStageFlags::COMPUTE,
                offset: 0,
                size: std::mem::size_of::<Tile>() as u32,
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
struct SceneResources {
    shared: Arc<Shared>,
    image: vk::Image,
    memory: vk::DeviceMemory,
    view: vk::ImageView,
    params: Buffer,
    /// All of the image's layers.
    range: vk::ImageSubresourceRange,
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

/// A scene resident on the device (the ash path's [`crate::gpu::GpuScene`]).
pub struct VkScene {
    pub params: Params,
    res: Arc<SceneResources>,
    pub layered: bool,
    /// Bytes uploaded (texture + uniforms).
    pub bytes: u64,
    /// Rows the image holds (all layers): updates that fit are written in place.
    capacity_rows: u32,
    /// The `max_rows` it was uploaded with (updates keep it).
    max_rows: Option<u32>,
}

impl VkScene {
    /// Uploads in world coordinates (the readback tests' rays are in world space).
    pub fn upload(ctx: &VkContext, scene: &Scene, grid: &Grid) -> Result<Self, VkError> {
        let packed = layout::pack_scene(scene, grid, DVec3::ZERO);
        let params = layout::params(scene, grid, &packed, DVec3::ZERO);
        Self::upload_packed_with(ctx, packed, params, None)
    }

    /// Uploads `packed` into the scene image, layered past `max_rows` rows if given and fewer than
    /// the device's largest side. The texels go through one host-visible staging band of
    /// [`SCENE_LAYER_ROWS`] rows at a time, from the last band to the first, each freed on the
    /// host once copied (as `GpuScene::upload_packed` does through wgpu's staging).
    pub fn upload_packed_with(
        ctx: &VkContext,
        packed: PackedScene,
        params: Params,
        max_rows: Option<u32>,
    ) -> Result<Self, VkError> {
        Self::upload_reserving(ctx, packed, params, max_rows, 0)
    }

    /// [`Self::upload_packed_with`] into an image of at least `reserve_rows` rows, so that later
    /// [`Self::update`]s of a growing scene fit.
    fn upload_reserving(
        ctx: &VkContext,
        packed: PackedScene,
        params: Params,
        max_rows: Option<u32>,
        reserve_rows: u32,
    ) -> Result<Self, VkError> {
        let shared = &ctx.shared;
        let caps = shared.caps;
        let (height, layers, layered) = scene_texture_extent(
            &packed,
            reserve_rows,
            max_rows,
            caps.max_texture_dimension_2d,
            caps.max_texture_array_layers,
        )
        .map_err(VkError::Other)?;
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
        params_buf.write(0, bytemuck::bytes_of(&params));
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
        let bytes = res.write_rows(0, packed.texels, layered, vk::ImageLayout::UNDEFINED)?
            + std::mem::size_of::<Params>() as u64;
        let capacity_rows = height * layers;
        Ok(VkScene { params, res: Arc::new(res), layered, bytes, capacity_rows, max_rows })
    }

    /// Replaces the frame constants; the next dispatch sees them.
    pub fn write_params(&mut self, params: Params) {
        self.params = params;
        self.res.params.write(0, bytemuck::bytes_of(&params));
    }

    /// Replaces the scene's contents with `packed`: written into the image in place while it fits
    /// (and stays as layered), else into a new image with a quarter more rows than needed, as
    /// `GpuScene::update` does. Returns whether the image is new (dispatchers bound to this scene
    /// must then [`VkDispatcher::rebind`]).
    pub fn update(&mut self, ctx: &VkContext, packed: PackedScene, params: Params) -> Result<bool, VkError> {
        let rows = packed.rows();
        if self.fits(ctx, rows) {
            self.bytes = self.res.write_rows(0, packed.texels, self.layered, vk::ImageLayout::GENERAL)?
                + std::mem::size_of::<Params>() as u64;
            self.write_params(params);
            return Ok(false);
        }
        let reserve = rows.saturating_add(rows / 4);
        *self = Self::upload_reserving(ctx, packed, params, self.max_rows, reserve)?;
        Ok(true)
    }

    /// Whether `rows` rows fit the image as it is (and would be layered as it is).
    fn fits(&self, ctx: &VkContext, rows: u32) -> bool {
        let max_dim = ctx.shared.caps.max_texture_dimension_2d;
        let max_side = self.max_rows.map_or(max_dim, |m| m.min(max_dim));
        rows <= self.capacity_rows && layout::scene_extent(rows, max_side).2 == self.layered
    }

    /// `texels`, the packed scene's from row `from` on, in place of the image's (the rows before
    /// stay), with `params`, as `GpuScene::update_from` does. False, and nothing written, when
    /// they do not fit.
    pub fn update_from(
        &mut self,
        ctx: &VkContext,
        from: u32,
        texels: Vec<[u32; 4]>,
        params: Params,
    ) -> Result<bool, VkError> {
        if !self.fits(ctx, from + layout::rows_of(texels.len())) {
            return Ok(false);
        }
        let written = self.res.write_rows(from, texels, self.layered, vk::ImageLayout::GENERAL)?;
        self.bytes =
            from as u64 * SCENE_TEX_WIDTH as u64 * 16 + written + std::mem::size_of::<Params>() as u64;
        self.write_params(params);
        Ok(true)
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
    shared: Arc<Shared>,
    variant: Variant,
    module: naga::Module,
    info: naga::valid::ModuleInfo,
    options: naga::back::spv::Options<'static>,
    layout: Layout,
    pipelines: Mutex<Vec<(String, vk::Pipeline)>>,
    pool: vk::DescriptorPool,
    set: vk::DescriptorSet,
    out: Buffer,
    stats: Buffer,
    tile: Buffer,
    _inputs: Buffer,
    work: Buffer,
    queue: Buffer,
    frame: Buffer,
    readback: Buffer,
    out_len: u64,
    frame_len: u64,
    scene: Arc<SceneResources>,
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
    /// Compiles `kernel` for `variant` (its `layered` set from the scene), and binds it to
    /// `scene`, an output buffer of `out_len` vec4s and the test inputs `inputs` (may be empty).
    /// The WGSL is validated by naga here; each entry point's SPIR-V when first run.
    pub fn new(
        ctx: &VkContext,
        scene: &VkScene,
        kernel: Kernel,
        variant: Variant,
        out_len: u64,
        inputs: &[[f32; 4]],
    ) -> Result<Self, VkError> {
        Self::with_modes(ctx, scene, kernel, variant, out_len, inputs, ModeBuffers::default())
    }

    /// [`Self::new`] with the dispatch modes' buffers sized as `modes` says.
    pub fn with_modes(
        ctx: &VkContext,
        scene: &VkScene,
        kernel: Kernel,
        variant: Variant,
        out_len: u64,
        inputs: &[[f32; 4]],
        modes: ModeBuffers,
    ) -> Result<Self, VkError> {
        let shared = &ctx.shared;
        let variant = Variant { layered: scene.layered, accel: layout::accel_code(&scene.params), ..variant };
        if variant.f64 && !shared.caps.f64 {
            return Err(VkError::Other(crate::gpu::context::no_f64_message(&ctx.info.name)));
        }
        if variant.simd_stats && shared.caps.subgroup_size.is_none() {
            return Err(VkError::Other(crate::gpu::context::no_subgroups_message(&ctx.info.name)));
        }
        let src = shaders::compose(kernel, variant);
        let (module, info) =
            shaders::validate(&src).map_err(|e| VkError::Shader(format!("naga rejected the kernel: {e}")))?;
        let (module, info) =
            if shared.caps.options.push_tile { tile_as_push_constants(module)? } else { (module, info) };
        let options = options_for(&shared.caps);
        let layout = Layout::new(shared, scene.layered)?;
        use vk::BufferUsageFlags as U;
        let storage = |bytes: u64, extra: U| shared.buffer(bytes, U::STORAGE_BUFFER | extra, false);
        let out = storage(out_len * 16, U::TRANSFER_SRC)?;
        let stats = storage(STATS_BYTES, U::TRANSFER_SRC | U::TRANSFER_DST)?;
        let tile = shared.buffer(std::mem::size_of::<Tile>() as u64, U::UNIFORM_BUFFER, true)?;
        tile.write(0, bytemuck::bytes_of(&Tile::default()));
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
        let sizes = [
            vk::DescriptorPoolSize { ty: vk::DescriptorType::UNIFORM_BUFFER, descriptor_count: 2 },
            vk::DescriptorPoolSize { ty: vk::DescriptorType::STORAGE_IMAGE, descriptor_count: 1 },
            vk::DescriptorPoolSize { ty: vk::DescriptorType::STORAGE_BUFFER, descriptor_count: 6 },
        ];
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
        let buffers = [&scene.res.params, &out, &stats, &tile, &inputs_buf, &work, &queue, &frame];
        let buffer_infos: Vec<[vk::DescriptorBufferInfo; 1]> = buffers
            .iter()
            .map(|b| [vk::DescriptorBufferInfo { buffer: b.raw, offset: 0, range: vk::WHOLE_SIZE }])
            .collect();
        let image_info = [vk::DescriptorImageInfo {
            sampler: vk::Sampler::null(),
            image_view: scene.res.view,
            image_layout: vk::ImageLayout::GENERAL,
        }];
        let mut writes = Vec::new();
        for (binding, &ty) in BINDINGS.iter().enumerate() {
            let w = vk::WriteDescriptorSet::default()
                .dst_set(set)
                .dst_binding(binding as u32)
                .descriptor_type(ty);
            writes.push(match binding {
                1 => w.image_info(&image_info),
                0 => w.buffer_info(&buffer_infos[0]),
                b => w.buffer_info(&buffer_infos[b - 1]),
            });
        }
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
            tile,
            _inputs: inputs_buf,
            work,
            queue,
            frame,
            readback,
            out_len,
            frame_len: modes.frame_len,
            scene: scene.res.clone(),
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

    /// Runs `entry` over `groups` workgroups with `tile` as its uniform, and waits for it.
    /// With `VkOptions::push_tile` the tile goes in push constants, else into the tile buffer;
    /// with `VkOptions::profile` the dispatch is timed and its invocations counted
    /// (`VkContext::take_samples`).
    pub fn run(&self, entry: &str, tile: Tile, groups: [u32; 3]) -> Result<(), VkError> {
        let pipeline = self.pipeline(entry)?;
        let (layout, set) = (self.layout.pipeline_layout, self.set);
        let push = self.shared.caps.options.push_tile;
        let queries = self.shared.queries.as_ref();
        let start = Instant::now();
        let record = |d: &ash::Device, cmd| {
            if !push {
                // Under the submit lock, so no other submission reads the tile now.
                self.tile.write(0, bytemuck::bytes_of(&tile));
            }
            // SAFETY: recording into the command buffer `submit` began; all bound objects live;
            // the queries' begin and end enclose only the dispatch.
            unsafe {
                d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, pipeline);
                d.cmd_bind_descriptor_sets(cmd, vk::PipelineBindPoint::COMPUTE, layout, 0, &[set], &[]);
                if push {
                    let bytes = bytemuck::bytes_of(&tile);
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

    /// `read` of the output buffer and the ray counters, in the mapped readback memory.
    pub fn read_with<T>(&self, read: impl FnOnce(&[[f32; 4]], RayCounts) -> T) -> Result<T, VkError> {
        let out_bytes = self.out_len * 16;
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
        Ok(self
            .readback
            .read_with(out_bytes + STATS_BYTES, |d| crate::gpu::dispatch::decode_output(d, out_bytes, read)))
    }
}

/// The ash path as a [`ComputeBackend`].
pub struct VkKernel<'a>(pub &'a VkDispatcher);

impl ComputeBackend for VkKernel<'_> {
    type Error = VkError;
    fn reset_counts(&self) -> Result<(), VkError> {
        self.0.reset_counts()
    }
    fn dispatch(&self, d: &Dispatch) -> Result<(), VkError> {
        self.0.run(&d.entry, d.tile, d.groups)
    }
    fn read_output_with<T>(&self, read: impl FnOnce(&[[f32; 4]], RayCounts) -> T) -> Result<T, VkError> {
        self.0.read_with(read)
    }
    fn reset_queue(&self) -> Result<(), VkError> {
        self.0.reset_queue()
    }
    fn read_queue(&self) -> Result<u32, VkError> {
        self.0.read_queue()
    }
    fn write_work(&self, data: &[u32]) -> Result<(), VkError> {
        self.0.write_work(data)
    }
    fn clear_frame(&self) -> Result<(), VkError> {
        self.0.clear_frame()
    }
    fn read_frame(&self) -> Result<Vec<[f32; 4]>, VkError> {
        self.0.read_frame()
    }
}

/// Runs one readback kernel of shaders/tests.wgsl on the ash path, as
/// [`crate::gpu::readback::run_kernel`] does on wgpu.
pub fn run_kernel(
    ctx: &VkContext,
    scene: &VkScene,
    entry: &str,
    inputs: &[[f32; 4]],
    items: u32,
    out_per_item: u32,
) -> Result<Vec<[f32; 4]>, VkError> {
    let out_len = items as u64 * out_per_item as u64;
    let d = VkDispatcher::new(ctx, scene, Kernel::Tests, Variant::FULL, out_len, inputs)?;
    crate::gpu::readback::run_readback(&VkKernel(&d), entry, items)
}

/// The headless band renderer on the ash path: the one band renderer, on raw Vulkan.
pub type VkRenderer = crate::gpu::Renderer<VkContext>;
