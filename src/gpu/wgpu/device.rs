//! The wgpu path as a [`Device`], and its compiled kernels as [`BoundKernel`]s.

use super::{Dispatcher, GpuContext, GpuScene, SceneTexture};
use crate::gpu::device::{BoundKernel, Device, KernelSpec};
use crate::gpu::layout::Params;
use crate::gpu::output::RayCounts;
use crate::gpu::recording::Dispatch;
use crate::gpu::scene_texture::SceneExtent;
use crate::gpu::shaders::Variant;
use crate::gpu::GpuError;

/// A [`Dispatcher`] bound to the context it was made on.
pub struct WgpuBound<'a> {
    pub ctx: &'a GpuContext,
    pub dispatcher: &'a Dispatcher,
}

impl BoundKernel for WgpuBound<'_> {
    type Error = GpuError;
    fn reset_counts(&self) -> Result<(), GpuError> {
        self.dispatcher.reset_counts(self.ctx);
        self.ctx.check()
    }
    fn dispatch(&self, d: &Dispatch) -> Result<(), GpuError> {
        self.dispatcher.run(self.ctx, &d.entry, d.launch, d.groups)
    }
    fn read_output_with<T>(
        &self,
        len: u64,
        read: impl FnOnce(&[[f32; 4]], RayCounts) -> T,
    ) -> Result<T, GpuError> {
        self.dispatcher.read_with(self.ctx, len, read)
    }
    fn reset_queue(&self) -> Result<(), GpuError> {
        self.dispatcher.reset_queue(self.ctx);
        self.ctx.check()
    }
    fn read_queue(&self) -> Result<u32, GpuError> {
        self.dispatcher.read_queue(self.ctx)
    }
    fn write_work(&self, data: &[u32]) -> Result<(), GpuError> {
        self.dispatcher.write_work(self.ctx, data)
    }
    fn clear_frame(&self) -> Result<(), GpuError> {
        self.dispatcher.clear_frame(self.ctx);
        self.ctx.check()
    }
    fn read_frame(&self) -> Result<Vec<[f32; 4]>, GpuError> {
        self.dispatcher.read_frame(self.ctx)
    }
    fn read_output_range(&self, first: u64, len: u64) -> Result<Vec<[f32; 4]>, GpuError> {
        self.dispatcher.read_output_range(self.ctx, first, len)
    }
}

impl Device for GpuContext {
    type Error = GpuError;
    type Texture = SceneTexture;
    type Kernel = Dispatcher;
    type Bound<'a> = WgpuBound<'a>;

    fn adapter(&self) -> (&str, &str, wgpu::DeviceType) {
        (&self.info.name, &self.info.driver_info, self.info.device_type)
    }
    fn subgroup_size(&self) -> Option<u32> {
        let (min, max) = (self.info.subgroup_min_size, self.info.subgroup_max_size);
        (self.device.features().contains(wgpu::Features::SUBGROUP) && min == max).then_some(min)
    }
    fn has_f64(&self) -> bool {
        self.device.features().contains(wgpu::Features::SHADER_F64)
    }
    fn texture_limits(&self) -> (u32, u32) {
        let limits = self.device.limits();
        (limits.max_texture_dimension_2d, limits.max_texture_array_layers)
    }
    fn max_binding_bytes(&self) -> u64 {
        let limits = self.device.limits();
        limits.max_storage_buffer_binding_size.min(limits.max_buffer_size)
    }
    fn allocate_texture(&self, extent: &SceneExtent, params: &Params) -> Result<SceneTexture, GpuError> {
        let t = SceneTexture::new(self, extent, params);
        self.check().map(|()| t)
    }
    fn write_rows(
        &self,
        texture: &mut SceneTexture,
        extent: &SceneExtent,
        from: u32,
        texels: Vec<[u32; 4]>,
    ) -> Result<u64, GpuError> {
        let bytes = texture.write_rows(self, from, texels, extent.layered);
        self.check().map(|()| bytes)
    }
    fn write_constants(&self, texture: &SceneTexture, params: &Params) {
        self.queue.write_buffer(&texture.params, 0, bytemuck::bytes_of(params));
    }
    fn compile_kernel(&self, scene: &GpuScene, spec: KernelSpec) -> Result<Dispatcher, GpuError> {
        let d = Dispatcher::new(self, scene, spec);
        self.check().map(|()| d)
    }
    fn variant(kernel: &Dispatcher) -> Variant {
        kernel.variant()
    }
    fn rebind(&self, kernel: &mut Dispatcher, scene: &GpuScene) -> Result<(), GpuError> {
        kernel.rebind(self, scene)?;
        self.check()
    }
    fn copy_frame(&self, to: &Dispatcher, from: &Dispatcher) -> Result<(), GpuError> {
        to.copy_frame_from(self, from);
        self.check()
    }
    fn bind<'a>(&'a self, kernel: &'a Dispatcher) -> WgpuBound<'a> {
        WgpuBound { ctx: self, dispatcher: kernel }
    }
    fn pipelines_compiled(&self) {
        self.save_pipeline_cache();
    }
}
