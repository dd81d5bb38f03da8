//! The ash path as a [`Device`], its kernels as [`BoundKernel`]s, and what the modes ask of a
//! kernel (the work, queue and frame buffers; a new scene image bound in place): the
//! counterparts of the wgpu dispatcher's methods of the same names.

use super::kernel::{descriptor_type, SceneImage};
use super::{VkContext, VkDispatcher, VkError, VkScene};
use crate::gpu::bindings::{slot, BINDINGS};
use crate::gpu::device::{BoundKernel, Device, KernelSpec};
use crate::gpu::layout::Params;
use crate::gpu::output::RayCounts;
use crate::gpu::recording::Dispatch;
use crate::gpu::scene_texture::SceneExtent;
use crate::gpu::shaders::Variant;
use crate::gpu::GpuError;
use ash::vk;

impl VkDispatcher {
    /// Restarts the tile queue.
    pub fn reset_queue(&self) -> Result<(), VkError> {
        // SAFETY: recording into the command buffer `submit` began.
        self.shared.submit("restarting the tile queue", |d, cmd| unsafe {
            d.cmd_fill_buffer(cmd, self.queue.raw, 0, 16, 0)
        })
    }

    /// The tile queue's counter: chunks taken so far.
    pub fn read_queue(&self) -> Result<u32, VkError> {
        Ok(bytemuck::pod_read_unaligned(&self.read_back(&self.queue, 0, 4)?[..4]))
    }

    /// Writes `data` at the start of the work buffer (device-local: through a staging buffer).
    pub fn write_work(&self, data: &[u32]) -> Result<(), VkError> {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        if bytes.is_empty() {
            return Ok(());
        }
        if bytes.len() as u64 > self.work.size {
            return Err(VkError::Other(
                GpuError::WorkTooLarge { bytes: bytes.len() as u64, size: self.work.size }.to_string(),
            ));
        }
        let staging = self.shared.buffer(bytes.len() as u64, vk::BufferUsageFlags::TRANSFER_SRC, true)?;
        staging.write(0, bytes);
        let size = bytes.len() as u64;
        // SAFETY: recording into the command buffer `submit` began; both buffers live past it.
        self.shared.submit("the work buffer's upload", |d, cmd| unsafe {
            d.cmd_copy_buffer(
                cmd,
                staging.raw,
                self.work.raw,
                &[vk::BufferCopy { src_offset: 0, dst_offset: 0, size }],
            )
        })
    }

    /// Zeroes the frame buffer.
    pub fn clear_frame(&self) -> Result<(), VkError> {
        // SAFETY: recording into the command buffer `submit` began.
        self.shared.submit("clearing the frame buffer", |d, cmd| unsafe {
            d.cmd_fill_buffer(cmd, self.frame.raw, 0, vk::WHOLE_SIZE, 0)
        })
    }

    /// The frame buffer: per pixel the sum of its samples (rgb) and their count (a).
    pub fn read_frame(&self) -> Result<Vec<[f32; 4]>, VkError> {
        Ok(bytemuck::pod_collect_to_vec(&self.read_back(&self.frame, 0, self.frame_len * 16)?))
    }

    /// Output vec4s `first..first + len` (clamped to the buffer), copied.
    pub fn read_output_range(&self, first: u64, len: u64) -> Result<Vec<[f32; 4]>, VkError> {
        let (first, len) = (first.min(self.out_len), len.min(self.out_len - first.min(self.out_len)));
        Ok(bytemuck::pod_collect_to_vec(&self.read_back(&self.out, first * 16, len * 16)?))
    }

    /// `bytes` of `buf` from `offset`, through the readback buffer.
    fn read_back(&self, buf: &super::Buffer, offset: u64, bytes: u64) -> Result<Vec<u8>, VkError> {
        if bytes > 0 {
            // SAFETY: recording into the command buffer `submit` began.
            self.shared.submit("the readback", |d, cmd| unsafe {
                let copy = vk::BufferCopy { src_offset: offset, dst_offset: 0, size: bytes };
                d.cmd_copy_buffer(cmd, buf.raw, self.readback.raw, &[copy])
            })?;
        }
        Ok(self.readback.read(bytes))
    }

    /// Binds to `scene`'s new image and frame constants (after [`VkScene::update`] replaced
    /// them), keeping every buffer, the frame buffer's samples included. The image must be
    /// layered as before (a layered scene needs a recompiled kernel).
    pub fn rebind(&mut self, scene: &VkScene) -> Result<(), GpuError> {
        if scene.layered() != self.variant.layered {
            return Err(GpuError::LayeredRebind);
        }
        let res = scene.texture.resources();
        let params = [vk::DescriptorBufferInfo { buffer: res.params.raw, offset: 0, range: vk::WHOLE_SIZE }];
        let image = [vk::DescriptorImageInfo {
            sampler: vk::Sampler::null(),
            image_view: res.view,
            image_layout: vk::ImageLayout::GENERAL,
        }];
        let write = |binding: u32| {
            vk::WriteDescriptorSet::default()
                .dst_set(self.set)
                .dst_binding(binding)
                .descriptor_type(descriptor_type(BINDINGS[binding as usize].kind))
        };
        let writes =
            [write(slot("params")).buffer_info(&params), write(slot("scene_tex")).image_info(&image)];
        // SAFETY: every submission was waited for, so the set is not in use; both objects live
        // as long as `self.scene`, which holds them from here on.
        unsafe { self.shared.device.update_descriptor_sets(&writes, &[]) };
        self.scene = res.clone();
        Ok(())
    }

    /// Copies `other`'s frame buffer into this one's (as much as both hold).
    pub fn copy_frame_from(&self, other: &VkDispatcher) -> Result<(), VkError> {
        let size = self.frame.size.min(other.frame.size);
        // SAFETY: recording into the command buffer `submit` began.
        self.shared.submit("copying the frame buffer", |d, cmd| unsafe {
            d.cmd_copy_buffer(
                cmd,
                other.frame.raw,
                self.frame.raw,
                &[vk::BufferCopy { src_offset: 0, dst_offset: 0, size }],
            )
        })
    }
}

/// A [`VkDispatcher`] as a [`BoundKernel`].
pub struct VkBound<'a>(pub &'a VkDispatcher);

impl BoundKernel for VkBound<'_> {
    type Error = VkError;
    fn reset_counts(&self) -> Result<(), VkError> {
        self.0.reset_counts()
    }
    fn dispatch(&self, d: &Dispatch) -> Result<(), VkError> {
        self.0.run(&d.entry, d.launch, d.groups)
    }
    fn read_output_with<T>(
        &self,
        len: u64,
        read: impl FnOnce(&[[f32; 4]], RayCounts) -> T,
    ) -> Result<T, VkError> {
        self.0.read_with(len, read)
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
    fn read_output_range(&self, first: u64, len: u64) -> Result<Vec<[f32; 4]>, VkError> {
        self.0.read_output_range(first, len)
    }
}

impl Device for VkContext {
    type Error = VkError;
    type Texture = SceneImage;
    type Kernel = VkDispatcher;
    type Bound<'a> = VkBound<'a>;

    fn adapter(&self) -> (&str, &str, wgpu::DeviceType) {
        (&self.info.name, &self.info.driver_info, self.info.device_type)
    }
    fn subgroup_size(&self) -> Option<u32> {
        self.shared.caps.subgroup_size
    }
    fn has_f64(&self) -> bool {
        self.shared.caps.f64
    }
    fn texture_limits(&self) -> (u32, u32) {
        (self.shared.caps.max_texture_dimension_2d, self.shared.caps.max_texture_array_layers)
    }
    fn max_binding_bytes(&self) -> u64 {
        self.shared.caps.max_binding_bytes
    }
    fn allocate_texture(&self, extent: &SceneExtent, params: &Params) -> Result<SceneImage, GpuError> {
        Ok(SceneImage::new(self, extent, params)?)
    }
    fn write_rows(
        &self,
        texture: &mut SceneImage,
        extent: &SceneExtent,
        from: u32,
        texels: Vec<[u32; 4]>,
    ) -> Result<u64, GpuError> {
        Ok(texture.write_rows(from, texels, extent.layered)?)
    }
    fn write_constants(&self, texture: &SceneImage, params: &Params) {
        texture.write_params(params)
    }
    fn compile_kernel(&self, scene: &VkScene, spec: KernelSpec) -> Result<VkDispatcher, GpuError> {
        Ok(VkDispatcher::new(self, scene, spec)?)
    }
    fn variant(kernel: &VkDispatcher) -> Variant {
        kernel.variant()
    }
    fn rebind(&self, kernel: &mut VkDispatcher, scene: &VkScene) -> Result<(), GpuError> {
        kernel.rebind(scene)
    }
    fn copy_frame(&self, to: &VkDispatcher, from: &VkDispatcher) -> Result<(), GpuError> {
        Ok(to.copy_frame_from(from)?)
    }
    fn bind<'a>(&'a self, kernel: &'a VkDispatcher) -> VkBound<'a> {
        VkBound(kernel)
    }
}
