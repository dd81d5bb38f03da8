//! What the interactive modes ask of a kernel on the ash path (the work, queue and frame
//! buffers; a new scene image bound in place) and the ash path as a [`Device`] for
//! `render::Session`: the counterparts of the wgpu dispatcher's methods of the same names.

use super::{Kernel, ModeBuffers, Params, VkContext, VkDispatcher, VkError, VkKernel, VkScene, BINDINGS};
use crate::gpu::backend::Device;
use crate::gpu::layout::PackedScene;
use crate::gpu::shaders::Variant;
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
        Ok(bytemuck::pod_read_unaligned(&self.read_back(&self.queue, 4)?[..4]))
    }

    /// Writes `data` at the start of the work buffer (device-local: through a staging buffer).
    pub fn write_work(&self, data: &[u32]) -> Result<(), VkError> {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        if bytes.is_empty() {
            return Ok(());
        }
        if bytes.len() as u64 > self.work.size {
            return Err(VkError::Other(format!(
                "{} bytes of work data for a {} byte work buffer",
                bytes.len(),
                self.work.size
            )));
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
        Ok(bytemuck::pod_collect_to_vec(&self.read_back(&self.frame, self.frame_len * 16)?))
    }

    /// The first `bytes` of `buf`, through the readback buffer.
    fn read_back(&self, buf: &super::Buffer, bytes: u64) -> Result<Vec<u8>, VkError> {
        if bytes > 0 {
            // SAFETY: recording into the command buffer `submit` began.
            self.shared.submit("the readback", |d, cmd| unsafe {
                let copy = vk::BufferCopy { src_offset: 0, dst_offset: 0, size: bytes };
                d.cmd_copy_buffer(cmd, buf.raw, self.readback.raw, &[copy])
            })?;
        }
        Ok(self.readback.read(bytes))
    }

    /// Binds to `scene`'s new image and frame constants (after [`VkScene::update`] replaced
    /// them), keeping every buffer, the frame buffer's samples included. The image must be
    /// layered as before (a layered scene needs a recompiled kernel).
    pub fn rebind(&mut self, scene: &VkScene) -> Result<(), VkError> {
        if scene.layered != self.variant.layered {
            return Err(VkError::Other("a scene that became layered needs a recompiled kernel".into()));
        }
        let params =
            [vk::DescriptorBufferInfo { buffer: scene.res.params.raw, offset: 0, range: vk::WHOLE_SIZE }];
        let image = [vk::DescriptorImageInfo {
            sampler: vk::Sampler::null(),
            image_view: scene.res.view,
            image_layout: vk::ImageLayout::GENERAL,
        }];
        let write = |binding: u32| {
            vk::WriteDescriptorSet::default()
                .dst_set(self.set)
                .dst_binding(binding)
                .descriptor_type(BINDINGS[binding as usize])
        };
        let writes = [write(0).buffer_info(&params), write(1).image_info(&image)];
        // SAFETY: every submission was waited for, so the set is not in use; both objects live
        // as long as `self.scene`, which holds them from here on.
        unsafe { self.shared.device.update_descriptor_sets(&writes, &[]) };
        self.scene = scene.res.clone();
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

impl Device for VkContext {
    type Error = VkError;
    type Scene = VkScene;
    type Kernel = VkDispatcher;
    type Bound<'a> = VkKernel<'a>;

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
        self.shared.caps.subgroup_size
    }
    fn upload(
        &self,
        packed: PackedScene,
        params: Params,
        max_rows: Option<u32>,
        reserve_rows: u32,
    ) -> Result<VkScene, String> {
        VkScene::upload_reserving(self, packed, params, max_rows, reserve_rows).map_err(|e| e.to_string())
    }
    fn update_scene(&self, scene: &mut VkScene, packed: PackedScene, params: Params) -> Result<bool, String> {
        scene.update(self, packed, params).map_err(|e| e.to_string())
    }
    fn update_scene_from(
        &self,
        scene: &mut VkScene,
        from: u32,
        texels: Vec<[u32; 4]>,
        params: Params,
    ) -> Result<bool, String> {
        scene.update_from(self, from, texels, params).map_err(|e| e.to_string())
    }
    fn params(scene: &VkScene) -> Params {
        scene.params
    }
    fn layered(scene: &VkScene) -> bool {
        scene.layered
    }
    fn scene_bytes(scene: &VkScene) -> u64 {
        scene.bytes
    }
    fn write_params(&self, scene: &mut VkScene, params: Params) {
        scene.write_params(params)
    }
    fn compile(
        &self,
        scene: &VkScene,
        kernel: Kernel,
        variant: Variant,
        out_len: u64,
        inputs: &[[f32; 4]],
        modes: ModeBuffers,
    ) -> Result<VkDispatcher, String> {
        VkDispatcher::with_modes(self, scene, kernel, variant, out_len, inputs, modes)
            .map_err(|e| e.to_string())
    }
    fn variant(kernel: &VkDispatcher) -> Variant {
        kernel.variant()
    }
    fn rebind(&self, kernel: &mut VkDispatcher, scene: &VkScene) -> Result<(), String> {
        kernel.rebind(scene).map_err(|e| e.to_string())
    }
    fn copy_frame(&self, to: &VkDispatcher, from: &VkDispatcher) -> Result<(), String> {
        to.copy_frame_from(from).map_err(|e| e.to_string())
    }
    fn bind<'a>(&'a self, kernel: &'a VkDispatcher) -> VkKernel<'a> {
        VkKernel(kernel)
    }
}
