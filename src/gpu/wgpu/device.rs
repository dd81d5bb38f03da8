//! The wgpu path as a [`Device`], and its compiled kernels as [`BoundKernel`]s.

use super::{Dispatcher, GpuContext, GpuScene, SceneTexture};
use crate::gpu::device::{BoundKernel, Device, KernelSpec};
use crate::gpu::layout::Params;
use crate::gpu::output::RayCounts;
use crate::gpu::recording::Dispatch;
use crate::gpu::scene_texture::SceneExtent;
use crate::gpu::shaders::Variant;
use crate::gpu::GpuError;
use std::convert::Infallible;

/// A [`Dispatcher`] bound to the context it was made on.
pub struct WgpuBound<'a> {
    pub ctx: &'a GpuContext,
    pub dispatcher: &'a Dispatcher,
}

impl BoundKernel for WgpuBound<'_> {
    type Error = Infallible;
    fn reset_counts(&self) -> Result<(), Infallible> {
        self.dispatcher.reset_counts(self.ctx);
        Ok(())
    }
    fn dispatch(&self, d: &Dispatch) -> Result<(), Infallible> {
        self.dispatcher.run(self.ctx, &d.entry, d.launch, d.groups);
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
    fn read_output_range(&self, first: u64, len: u64) -> Result<Vec<[f32; 4]>, Infallible> {
        Ok(self.dispatcher.read_output_range(self.ctx, first, len))
    }
}

impl Device for GpuContext {
    type Error = Infallible;
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
    fn allocate_texture(&self, extent: &SceneExtent, params: &Params) -> Result<SceneTexture, GpuError> {
        Ok(SceneTexture::new(self, extent, params))
    }
    fn write_rows(
        &self,
        texture: &mut SceneTexture,
        extent: &SceneExtent,
        from: u32,
        texels: Vec<[u32; 4]>,
    ) -> Result<u64, GpuError> {
        Ok(texture.write_rows(self, from, texels, extent.layered))
    }
    fn write_constants(&self, texture: &SceneTexture, params: &Params) {
        self.queue.write_buffer(&texture.params, 0, bytemuck::bytes_of(params));
    }
    fn compile_kernel(&self, scene: &GpuScene, spec: KernelSpec) -> Result<Dispatcher, GpuError> {
        Ok(Dispatcher::new(self, scene, spec))
    }
    fn variant(kernel: &Dispatcher) -> Variant {
        kernel.variant()
    }
    fn rebind(&self, kernel: &mut Dispatcher, scene: &GpuScene) -> Result<(), GpuError> {
        kernel.rebind(self, scene)
    }
    fn copy_frame(&self, to: &Dispatcher, from: &Dispatcher) -> Result<(), GpuError> {
        to.copy_frame_from(self, from);
        Ok(())
    }
    fn bind<'a>(&'a self, kernel: &'a Dispatcher) -> WgpuBound<'a> {
        WgpuBound { ctx: self, dispatcher: kernel }
    }
    fn pipelines_compiled(&self) {
        self.save_pipeline_cache();
    }
}
