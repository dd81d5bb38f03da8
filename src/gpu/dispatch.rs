//! Uploading a scene and dispatching kernels over it: the render pipeline and the readback
//! kernels of the tests share this one binding layout (shaders/types.wgsl).

use super::layout::{self, PackedScene, Params, Tile, SCENE_LAYER_ROWS, SCENE_TEX_WIDTH};
use super::shaders::{self, Kernel, Variant};
use super::GpuContext;
use crate::accel::Grid;
use crate::scene::Scene;
use glam::DVec3;
use std::sync::Mutex;

/// A scene resident on the device: the scene texture and the frame constants.
pub struct GpuScene {
    pub params: Params,
    params_buf: wgpu::Buffer,
    texture: wgpu::Texture,
    texture_view: wgpu::TextureView,
    /// Rows the texture holds (all layers): updates that fit are written in place.
    capacity_rows: u32,
    /// The `max_rows` it was uploaded with (updates keep it).
    max_rows: Option<u32>,
    /// The scene texture is a 2D array of layers (the scene's rows exceed the device's largest
    /// texture side; see `Variant::layered`).
    pub layered: bool,
    /// Bytes uploaded (texture + uniforms), for logs and benches.
    pub bytes: u64,
}

impl GpuScene {
    /// Replaces the frame constants (camera, depth, image size); the next dispatch sees them.
    pub fn write_params(&mut self, ctx: &GpuContext, params: Params) {
        self.params = params;
        ctx.queue.write_buffer(&self.params_buf, 0, bytemuck::bytes_of(&params));
    }

    /// Uploads in world coordinates (what readback tests, which give world-space rays, need).
    pub fn upload(ctx: &GpuContext, scene: &Scene, grid: &Grid) -> Result<Self, String> {
        Self::upload_at(ctx, scene, grid, DVec3::ZERO)
    }

    /// Uploads with every position relative to `origin` (subtracted in f64, then rounded to
    /// f32): rendering passes the camera's eye, so f32 precision follows distances from the
    /// viewer instead of from the world's origin (docs/stability.md).
    pub fn upload_at(ctx: &GpuContext, scene: &Scene, grid: &Grid, origin: DVec3) -> Result<Self, String> {
        let packed = layout::pack_scene(scene, grid, origin);
        let params = layout::params(scene, grid, &packed, origin);
        Self::upload_packed(ctx, packed, params)
    }

    /// Uploads `packed` into the scene texture. It is consumed: bands of
    /// [`SCENE_LAYER_ROWS`] rows are written from the last to the first, each followed by a
    /// wait (so wgpu's staging copy is one band) and by freeing that band's host texels, so a
    /// large scene is not held twice on the host while the device's copy fills.
    pub fn upload_packed(ctx: &GpuContext, packed: PackedScene, params: Params) -> Result<Self, String> {
        Self::upload_packed_with(ctx, packed, params, None)
    }

    /// [`Self::upload_packed`], layered past `max_rows` rows if that is fewer than the device's
    /// largest texture side (tests and studies trace the layered path with small scenes).
    pub fn upload_packed_with(
        ctx: &GpuContext,
        packed: PackedScene,
        params: Params,
        max_rows: Option<u32>,
    ) -> Result<Self, String> {
        Self::upload_reserving(ctx, packed, params, max_rows, 0)
    }

    /// [`Self::upload_packed_with`] into a texture of at least `reserve_rows` rows, so that
    /// later [`Self::update`]s of a growing scene (moving objects change the grid's lists) fit.
    pub(crate) fn upload_reserving(
        ctx: &GpuContext,
        packed: PackedScene,
        params: Params,
        max_rows: Option<u32>,
        reserve_rows: u32,
    ) -> Result<Self, String> {
        let limits = ctx.device.limits();
        let (height, layers, layered) = scene_texture_extent(
            &packed,
            reserve_rows,
            max_rows,
            limits.max_texture_dimension_2d,
            limits.max_texture_array_layers,
        )?;
        let size = wgpu::Extent3d { width: SCENE_TEX_WIDTH, height, depth_or_array_layers: layers };
        let texture = ctx.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("scene"),
            size,
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba32Uint,
            usage: wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::STORAGE_BINDING
                | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        let bytes =
            write_rows(ctx, &texture, 0, packed.texels, layered) + std::mem::size_of::<Params>() as u64;
        let params_buf = uniform(ctx, "params", bytemuck::bytes_of(&params));
        let view = texture.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(view_dimension(layered)),
            ..Default::default()
        });
        Ok(GpuScene {
            params,
            params_buf,
            texture,
            texture_view: view,
            capacity_rows: height * layers,
            max_rows,
            layered,
            bytes,
        })
    }

    /// Replaces the scene's contents with `packed` (a moved object, an edited light or
    /// material): written into the texture in place while it fits, else into a new texture
    /// with a quarter more rows than needed. Returns whether the texture is new (dispatchers
    /// bound to this scene must then [`Dispatcher::rebind`]).
    pub fn update(&mut self, ctx: &GpuContext, packed: PackedScene, params: Params) -> Result<bool, String> {
        let rows = packed.rows();
        if self.fits(ctx, rows) {
            self.bytes = write_rows(ctx, &self.texture, 0, packed.texels, self.layered)
                + std::mem::size_of::<Params>() as u64;
            self.write_params(ctx, params);
            return Ok(false);
        }
        let reserve = rows.saturating_add(rows / 4);
        *self = Self::upload_reserving(ctx, packed, params, self.max_rows, reserve)?;
        Ok(true)
    }

    /// Whether `rows` rows fit the texture as it is (and would be layered as it is).
    fn fits(&self, ctx: &GpuContext, rows: u32) -> bool {
        let max_dim = ctx.device.limits().max_texture_dimension_2d;
        let max_side = self.max_rows.map_or(max_dim, |m| m.min(max_dim));
        rows <= self.capacity_rows && layout::scene_extent(rows, max_side).2 == self.layered
    }

    /// Writes `texels`, the packed scene's texels from row `from` on, in place of the texture's
    /// (the rows before stay), with the frame constants `params`: a new accelerator for the same
    /// scene ([`layout::swap_accel`]). False, and nothing written, when they do not fit.
    pub fn update_from(
        &mut self,
        ctx: &GpuContext,
        from: u32,
        texels: Vec<[u32; 4]>,
        params: Params,
    ) -> bool {
        if !self.fits(ctx, from + layout::rows_of(texels.len())) {
            return false;
        }
        let written = write_rows(ctx, &self.texture, from, texels, self.layered);
        self.bytes =
            from as u64 * SCENE_TEX_WIDTH as u64 * 16 + written + std::mem::size_of::<Params>() as u64;
        self.write_params(ctx, params);
        true
    }
}

/// Writes `texels` (consumed) into the rows of `texture` from row `from` on. Bands of
/// [`SCENE_LAYER_ROWS`] rows go from the last to the first, each followed by a wait (so wgpu's
/// staging copy is one band) and by freeing that band's host texels, so a large scene is not
/// held twice on the host while the device's copy fills. Returns the bytes written.
fn write_rows(
    ctx: &GpuContext,
    texture: &wgpu::Texture,
    from: u32,
    texels: Vec<[u32; 4]>,
    layered: bool,
) -> u64 {
    let mut data = texels;
    let rows = pad_rows(&mut data);
    let bytes = data.len() as u64 * 16;
    for band in scene_bands(from, from + rows, layered) {
        let origin = wgpu::Origin3d { x: 0, y: band.y, z: band.layer };
        let start = (band.first * SCENE_TEX_WIDTH) as usize;
        ctx.queue.write_texture(
            wgpu::TexelCopyTextureInfo { texture, mip_level: 0, origin, aspect: wgpu::TextureAspect::All },
            bytemuck::cast_slice(&data[start..]),
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(SCENE_TEX_WIDTH * 16),
                rows_per_image: Some(band.rows),
            },
            wgpu::Extent3d { width: SCENE_TEX_WIDTH, height: band.rows, depth_or_array_layers: 1 },
        );
        if band.first > 0 {
            ctx.queue.submit([]);
            ctx.wait();
            data.truncate(start);
            data.shrink_to_fit();
        }
    }
    bytes
}

/// The scene texture's rows per layer, layers and whether it is layered, for `packed` (at
/// least `reserve_rows` rows) on a device whose largest 2D side is `max_dim` and which holds
/// `max_layers` array layers, layered past `max_rows` if given: what every backend allocates.
pub fn scene_texture_extent(
    packed: &PackedScene,
    reserve_rows: u32,
    max_rows: Option<u32>,
    max_dim: u32,
    max_layers: u32,
) -> Result<(u32, u32, bool), String> {
    let max_side = max_rows.map_or(max_dim, |m| m.min(max_dim));
    let (height, layers, layered) = layout::scene_extent(packed.rows().max(reserve_rows), max_side);
    if layers > max_layers {
        let most = max_layers as u64 * (SCENE_LAYER_ROWS * SCENE_TEX_WIDTH) as u64;
        return Err(format!(
            "the scene needs {} MiB of scene texture ({} texels of 16 bytes); this device holds at \
             most {} MiB ({} layers of {}x{SCENE_LAYER_ROWS})",
            packed.texels.len() >> 16,
            packed.texels.len(),
            most >> 16,
            max_layers,
            SCENE_TEX_WIDTH,
        ));
    }
    Ok((height, layers, layered))
}

/// Pads `texels` to whole rows of the scene texture; returns the rows.
pub fn pad_rows(texels: &mut Vec<[u32; 4]>) -> u32 {
    let rows = layout::rows_of(texels.len());
    texels.resize((rows * SCENE_TEX_WIDTH) as usize, [0; 4]);
    rows
}

/// One upload band of the scene texture: `rows` rows from row `first` of the texels handed
/// over, at row `y` of layer `layer`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SceneBand {
    pub first: u32,
    pub rows: u32,
    pub y: u32,
    pub layer: u32,
}

/// The upload bands of the packed scene's rows `from..rows`, handed over as texels that start
/// at row `from` (`SceneBand::first` counts from there), from the last band to the first (so
/// each band's host texels can be freed once it is on the device): at most
/// [`SCENE_LAYER_ROWS`] rows each, none across a layer's end if layered.
pub fn scene_bands(from: u32, rows: u32, layered: bool) -> impl Iterator<Item = SceneBand> {
    (from / SCENE_LAYER_ROWS..rows.div_ceil(SCENE_LAYER_ROWS)).rev().map(move |band| {
        let start = (band * SCENE_LAYER_ROWS).max(from);
        let count = ((band + 1) * SCENE_LAYER_ROWS).min(rows) - start;
        let first = start - from;
        if layered {
            SceneBand { first, rows: count, y: start - band * SCENE_LAYER_ROWS, layer: band }
        } else {
            SceneBand { first, rows: count, y: start, layer: 0 }
        }
    })
}

fn uniform(ctx: &GpuContext, label: &str, bytes: &[u8]) -> wgpu::Buffer {
    use wgpu::util::DeviceExt;
    ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents: bytes,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
    })
}

fn storage(ctx: &GpuContext, label: &str, size: u64, extra: wgpu::BufferUsages) -> wgpu::Buffer {
    ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: size.max(16),
        usage: wgpu::BufferUsages::STORAGE | extra,
        mapped_at_creation: false,
    })
}

fn view_dimension(layered: bool) -> wgpu::TextureViewDimension {
    if layered {
        wgpu::TextureViewDimension::D2Array
    } else {
        wgpu::TextureViewDimension::D2
    }
}

/// The one bind group layout every kernel uses (bindings 0–8 of shaders/types.wgsl), its scene
/// texture layered or not.
fn bind_group_layout(device: &wgpu::Device, layered: bool) -> wgpu::BindGroupLayout {
    use wgpu::{BindingType as B, BufferBindingType as Bb, ShaderStages};
    let entry = |binding, ty| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: ShaderStages::COMPUTE,
        ty,
        count: None,
    };
    let buffer = |ty| B::Buffer { ty, has_dynamic_offset: false, min_binding_size: None };
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("irt"),
        entries: &[
            entry(0, buffer(Bb::Uniform)),
            entry(
                1,
                B::StorageTexture {
                    access: wgpu::StorageTextureAccess::ReadOnly,
                    format: wgpu::TextureFormat::Rgba32Uint,
                    view_dimension: view_dimension(layered),
                },
            ),
            entry(2, buffer(Bb::Storage { read_only: false })),
            entry(3, buffer(Bb::Storage { read_only: false })),
            entry(4, buffer(Bb::Uniform)),
            entry(5, buffer(Bb::Storage { read_only: true })),
            entry(6, buffer(Bb::Storage { read_only: true })),
            entry(7, buffer(Bb::Storage { read_only: false })),
            entry(8, buffer(Bb::Storage { read_only: false })),
        ],
    })
}

/// The bind group of bindings 0–8: the scene's uniforms and texture, then `buffers` (out, stats,
/// tile, test inputs, work, queue, frame).
fn bind_group(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    scene: &GpuScene,
    buffers: [&wgpu::Buffer; 7],
) -> wgpu::BindGroup {
    let mut entries = vec![
        wgpu::BindGroupEntry { binding: 0, resource: scene.params_buf.as_entire_binding() },
        wgpu::BindGroupEntry {
            binding: 1,
            resource: wgpu::BindingResource::TextureView(&scene.texture_view),
        },
    ];
    for (i, b) in buffers.iter().enumerate() {
        entries.push(wgpu::BindGroupEntry { binding: 2 + i as u32, resource: b.as_entire_binding() });
    }
    device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some("irt"), layout, entries: &entries })
}

/// A compiled kernel bound to a scene and its output buffers. Pipelines are created per entry
/// point on first use (lavapipe compiles each at its first dispatch anyway).
pub struct Dispatcher {
    /// What was compiled: the caller's variant with `layered` as the scene's texture is.
    variant: Variant,
    module: wgpu::ShaderModule,
    pipeline_layout: wgpu::PipelineLayout,
    pipelines: Mutex<Vec<(String, wgpu::ComputePipeline)>>,
    bind_group_layout: wgpu::BindGroupLayout,
    bind_group: wgpu::BindGroup,
    in_buf: wgpu::Buffer,
    out_buf: wgpu::Buffer,
    stats_buf: wgpu::Buffer,
    tile_buf: wgpu::Buffer,
    work_buf: wgpu::Buffer,
    queue_buf: wgpu::Buffer,
    frame_buf: wgpu::Buffer,
    readback: wgpu::Buffer,
    out_len: u64,
    frame_len: u64,
}

/// Sizes of the dispatch modes' buffers (src/render): none for the headless bands and the
/// readback kernels.
#[derive(Clone, Copy, Debug, Default)]
pub struct ModeBuffers {
    /// u32s the work buffer holds (boundary arrays, pixel orders).
    pub work_len: u64,
    /// Pixels of the frame buffer.
    pub frame_len: u64,
}

/// Rays traced in a frame, by kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayCounts {
    pub eye: u64,
    pub reflection: u64,
    pub refraction: u64,
    pub shadow: u64,
    /// Per loop of `layout::SIMD_LOOPS`, from a `Variant::simd_stats` kernel (zero otherwise).
    pub simd: [SimdCount; layout::SIMD_LOOPS.len()],
}

/// One loop's SIMD counters over a frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SimdCount {
    /// Iterations summed over lanes, each counting those it was active in.
    pub lane_iterations: u64,
    /// Iterations the SIMD groups ran (each once per group, however many lanes were active).
    pub group_iterations: u64,
}

impl SimdCount {
    /// Active lanes per lane slot run, for groups of `subgroup_size` lanes (`None`: the loop
    /// never ran).
    pub fn efficiency(&self, subgroup_size: u32) -> Option<f64> {
        (self.group_iterations > 0)
            .then(|| self.lane_iterations as f64 / (self.group_iterations as f64 * subgroup_size as f64))
    }
}

/// Bytes of the stats buffer (`layout::STATS_WORDS` counters).
pub const STATS_BYTES: u64 = layout::STATS_WORDS as u64 * 4;

impl RayCounts {
    pub fn total(&self) -> u64 {
        self.eye + self.reflection + self.refraction + self.shadow
    }
}

impl Dispatcher {
    /// The variant compiled (what a renderer reports, `layered` included).
    pub fn variant(&self) -> Variant {
        self.variant
    }

    /// Compiles `kernel` for `variant` (the module labelled `entry`; a pipeline per entry point at
    /// its first run) and binds it to `scene`, an output buffer of `out_len` vec4s and the
    /// read-only input `inputs` (test kernels; may be empty).
    pub fn new(
        ctx: &GpuContext,
        scene: &GpuScene,
        kernel: Kernel,
        variant: Variant,
        entry: &str,
        out_len: u64,
        inputs: &[[f32; 4]],
    ) -> Self {
        Self::with_modes(ctx, scene, kernel, variant, entry, out_len, inputs, ModeBuffers::default())
    }

    /// [`Self::new`] with the dispatch modes' buffers sized as `modes` says.
    #[allow(clippy::too_many_arguments)]
    pub fn with_modes(
        ctx: &GpuContext,
        scene: &GpuScene,
        kernel: Kernel,
        variant: Variant,
        entry: &str,
        out_len: u64,
        inputs: &[[f32; 4]],
        modes: ModeBuffers,
    ) -> Self {
        let device = &ctx.device;
        let variant = Variant { layered: scene.layered, accel: layout::accel_code(&scene.params), ..variant };
        let src = shaders::compose(kernel, variant);
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(entry),
            source: wgpu::ShaderSource::Wgsl(src.into()),
        });
        let bgl = bind_group_layout(device, scene.layered);
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("irt"),
            bind_group_layouts: &[Some(&bgl)],
            immediate_size: 0,
        });
        let out_bytes = out_len * 16;
        let out_buf = storage(ctx, "out", out_bytes, wgpu::BufferUsages::COPY_SRC);
        let stats_buf =
            storage(ctx, "stats", STATS_BYTES, wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST);
        let tile_buf = uniform(ctx, "tile", bytemuck::bytes_of(&Tile::default()));
        let input_bytes: &[u8] = if inputs.is_empty() { &[0; 16] } else { bytemuck::cast_slice(inputs) };
        let in_buf = {
            use wgpu::util::DeviceExt;
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("test inputs"),
                contents: input_bytes,
                usage: wgpu::BufferUsages::STORAGE,
            })
        };
        let work_buf = storage(ctx, "work", modes.work_len * 4, wgpu::BufferUsages::COPY_DST);
        let queue_buf =
            storage(ctx, "queue", 16, wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC);
        let frame_buf = storage(
            ctx,
            "frame",
            modes.frame_len * 16,
            wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
        );
        let readback_len = out_bytes.max(modes.frame_len * 16);
        let readback = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size: readback_len.max(16) + STATS_BYTES,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bind_group = bind_group(
            device,
            &bgl,
            scene,
            [&out_buf, &stats_buf, &tile_buf, &in_buf, &work_buf, &queue_buf, &frame_buf],
        );
        Dispatcher {
            variant,
            module,
            pipeline_layout,
            pipelines: Mutex::new(Vec::new()),
            bind_group_layout: bgl,
            bind_group,
            in_buf,
            out_buf,
            stats_buf,
            tile_buf,
            work_buf,
            queue_buf,
            frame_buf,
            readback,
            out_len,
            frame_len: modes.frame_len,
        }
    }

    /// Binds to `scene`'s new texture (after [`GpuScene::update`] replaced it), keeping every
    /// buffer, the frame buffer's samples included. The texture must be layered as before.
    pub fn rebind(&mut self, ctx: &GpuContext, scene: &GpuScene) {
        assert_eq!(scene.layered, self.variant.layered, "a layered scene needs a recompiled kernel");
        self.bind_group = bind_group(
            &ctx.device,
            &self.bind_group_layout,
            scene,
            [
                &self.out_buf,
                &self.stats_buf,
                &self.tile_buf,
                &self.in_buf,
                &self.work_buf,
                &self.queue_buf,
                &self.frame_buf,
            ],
        );
    }

    /// Copies `other`'s frame buffer into this one's (as much as both hold): what a recompiled
    /// kernel takes over, so the picture on screen does not go black.
    pub fn copy_frame_from(&self, ctx: &GpuContext, other: &Dispatcher) {
        let bytes = self.frame_buf.size().min(other.frame_buf.size());
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        enc.copy_buffer_to_buffer(&other.frame_buf, 0, &self.frame_buf, 0, bytes);
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
    pub fn write_work(&self, ctx: &GpuContext, data: &[u32]) {
        assert!(data.len() as u64 * 4 <= self.work_buf.size(), "work buffer too small");
        if !data.is_empty() {
            ctx.queue.write_buffer(&self.work_buf, 0, bytemuck::cast_slice(data));
        }
    }

    /// Restarts the tile queue (takes effect before the next submitted dispatch).
    pub fn reset_queue(&self, ctx: &GpuContext) {
        ctx.queue.write_buffer(&self.queue_buf, 0, &[0u8; 16]);
    }

    /// The tile queue's counter: chunks taken so far (past the last chunk once the queue is
    /// empty).
    pub fn read_queue(&self, ctx: &GpuContext) -> u32 {
        self.read_back(ctx, &[(&self.queue_buf, 16)], |d| bytemuck::cast_slice::<u8, u32>(d)[0])
    }

    /// Copies `(buffer, bytes)` one after another into the readback buffer, waits, and hands the
    /// mapped bytes to `read`: the one readback path of every `read*` method.
    fn read_back<T>(
        &self,
        ctx: &GpuContext,
        copies: &[(&wgpu::Buffer, u64)],
        read: impl FnOnce(&[u8]) -> T,
    ) -> T {
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        let mut at = 0;
        for &(buf, bytes) in copies {
            if bytes > 0 {
                enc.copy_buffer_to_buffer(buf, 0, &self.readback, at, bytes);
            }
            at += bytes;
        }
        ctx.queue.submit([enc.finish()]);
        let slice = self.readback.slice(..at.max(16));
        slice.map_async(wgpu::MapMode::Read, |r| r.expect("mapping the readback buffer"));
        ctx.wait();
        let out = read(&slice.get_mapped_range().expect("readback buffer is mapped")[..at as usize]);
        self.readback.unmap();
        out
    }

    /// Zeroes the frame buffer (no samples anywhere).
    pub fn clear_frame(&self, ctx: &GpuContext) {
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        enc.clear_buffer(&self.frame_buf, 0, None);
        ctx.queue.submit([enc.finish()]);
    }

    /// The frame buffer: per pixel the sum of its samples (rgb) and their count (a).
    pub fn frame_buffer(&self) -> &wgpu::Buffer {
        &self.frame_buf
    }

    /// Runs `entry` over `groups` workgroups with `tile` as its uniform and waits for it.
    pub fn run(&self, ctx: &GpuContext, entry: &str, tile: Tile, groups: [u32; 3]) {
        ctx.queue.write_buffer(&self.tile_buf, 0, bytemuck::bytes_of(&tile));
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
    }

    /// Reads back the frame buffer.
    pub fn read_frame(&self, ctx: &GpuContext) -> Vec<[f32; 4]> {
        self.read_back(ctx, &[(&self.frame_buf, self.frame_len * 16)], |d| bytemuck::cast_slice(d).to_vec())
    }

    /// Clears the ray counters.
    pub fn reset_counts(&self, ctx: &GpuContext) {
        ctx.queue.write_buffer(&self.stats_buf, 0, &[0u8; STATS_BYTES as usize]);
    }

    /// Reads back the output buffer and the ray counters: `read` gets them in the mapped
    /// readback memory, which no copy precedes.
    pub fn read_with<T>(&self, ctx: &GpuContext, read: impl FnOnce(&[[f32; 4]], RayCounts) -> T) -> T {
        let out_bytes = self.out_len * 16;
        self.read_back(ctx, &[(&self.out_buf, out_bytes), (&self.stats_buf, STATS_BYTES)], |d| {
            decode_output(d, out_bytes, read)
        })
    }
}

/// `read` of the output buffer's vec4s and the ray counters, from `out_bytes` of output followed
/// by the `STATS_BYTES` of counters (how both device paths read them back), in place.
pub fn decode_output<T>(d: &[u8], out_bytes: u64, read: impl FnOnce(&[[f32; 4]], RayCounts) -> T) -> T {
    let (out, c) = d.split_at(out_bytes as usize);
    let c: [u32; layout::STATS_WORDS as usize] = bytemuck::pod_read_unaligned(&c[..STATS_BYTES as usize]);
    let wide = |at: usize| c[at] as u64 | (c[at + 1] as u64) << 32;
    let counts = RayCounts {
        eye: c[0] as u64,
        reflection: c[1] as u64,
        refraction: c[2] as u64,
        shadow: c[3] as u64,
        simd: std::array::from_fn(|k| {
            let at = layout::STATS_SIMD_AT as usize + 4 * k;
            SimdCount { lane_iterations: wide(at), group_iterations: wide(at + 2) }
        }),
    };
    match bytemuck::try_cast_slice(out) {
        Ok(out) => read(out, counts),
        // Mapped memory is aligned on every device seen; a copy only if one is not.
        Err(_) => read(&bytemuck::pod_collect_to_vec(out), counts),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bands of rows `from..rows` cover each of them once, last band first, none across a
    /// layer's end when layered; each band's `first` counts from `from`, and its `y` and
    /// `layer` place it where the whole scene's row would go.
    #[test]
    fn scene_bands_cover_the_rows_from_any_row_once() {
        let l = SCENE_LAYER_ROWS;
        for (from, rows) in
            [(0, 1), (0, l), (0, 2 * l + 5), (3, 4), (l - 1, l + 1), (l, 3 * l), (l + 7, 3 * l - 2)]
        {
            for layered in [false, true] {
                let bands: Vec<SceneBand> = scene_bands(from, rows, layered).collect();
                let mut covered: Vec<u32> =
                    bands.iter().flat_map(|b| from + b.first..from + b.first + b.rows).collect();
                assert!(bands.windows(2).all(|w| w[0].first > w[1].first), "last band first");
                covered.sort_unstable();
                assert_eq!(covered, (from..rows).collect::<Vec<_>>(), "{from}..{rows} layered {layered}");
                for b in &bands {
                    let row = from + b.first;
                    let (y, layer) = if layered { (row % l, row / l) } else { (row, 0) };
                    assert_eq!((b.y, b.layer), (y, layer), "{b:?} from {from}");
                    assert!(b.rows <= l && (!layered || b.y + b.rows <= l), "{b:?}");
                }
            }
        }
    }

    /// Two vec4s and the counters, read in place where the bytes are aligned and through the
    /// copy where they are not: the same values either way.
    #[test]
    fn output_decodes_aligned_or_not() {
        let out = [[1.0f32, 2.0, 3.0, 4.0], [5.0, 6.0, 7.0, 8.0]];
        // The ray counts, then per loop its two 64-bit counters (low word first).
        let mut counts = vec![9u32, 10, 11, 12];
        for k in 0..layout::SIMD_LOOPS.len() as u32 {
            counts.extend([100 + k, k, 200 + k, 0]);
        }
        let mut bytes = vec![0u8; 1];
        bytes.extend_from_slice(bytemuck::cast_slice(&out));
        bytes.extend_from_slice(bytemuck::cast_slice(&counts));
        let words: Vec<u32> = bytemuck::pod_collect_to_vec(&bytes[1..]);
        let simd = std::array::from_fn(|k| SimdCount {
            lane_iterations: 100 + k as u64 + ((k as u64) << 32),
            group_iterations: 200 + k as u64,
        });
        let expect = RayCounts { eye: 9, reflection: 10, refraction: 11, shadow: 12, simd };
        for d in [bytemuck::cast_slice::<u32, u8>(&words), &bytes[1..]] {
            let (o, c) = decode_output(d, 32, |o, c| (o.to_vec(), c));
            assert_eq!((o.as_slice(), c), (&out[..], expect));
        }
        // The second case really is unaligned (malloc aligns `bytes` to 16), so it took the copy.
        assert_ne!(bytes[1..].as_ptr() as usize % std::mem::align_of::<[f32; 4]>(), 0);
    }
}
