//! A scene resident on the wgpu device: the scene texture and the frame constants' buffer.

use super::{uniform, view_dimension, GpuContext};
use crate::gpu::device::DeviceScene;
use crate::gpu::layout::{Params, SCENE_TEX_WIDTH};
use crate::gpu::scene_texture::{pad_rows, scene_bands, SceneExtent};

/// The scene texture and the frame constants' buffer.
pub struct SceneTexture {
    pub(super) texture: wgpu::Texture,
    pub(super) view: wgpu::TextureView,
    pub(super) params: wgpu::Buffer,
}

/// A scene resident on the wgpu device.
pub type GpuScene = DeviceScene<SceneTexture>;

impl SceneTexture {
    /// A texture of `extent`, nothing written yet, and the frame constants `params`.
    pub(super) fn new(ctx: &GpuContext, extent: &SceneExtent, params: &Params) -> Self {
        let size = wgpu::Extent3d {
            width: SCENE_TEX_WIDTH,
            height: extent.height,
            depth_or_array_layers: extent.layers,
        };
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
        let view = texture.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(view_dimension(extent.layered)),
            ..Default::default()
        });
        SceneTexture { texture, view, params: uniform(ctx, "params", bytemuck::bytes_of(params)) }
    }

    /// Writes `texels` (consumed) into the rows of the texture from row `from` on. Bands of
    /// `SCENE_LAYER_ROWS` rows go from the last to the first, each followed by a wait (so wgpu's
    /// staging copy is one band) and by freeing that band's host texels, so a large scene is not
    /// held twice on the host while the device's copy fills. Returns the bytes written.
    pub(super) fn write_rows(
        &self,
        ctx: &GpuContext,
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
                wgpu::TexelCopyTextureInfo {
                    texture: &self.texture,
                    mip_level: 0,
                    origin,
                    aspect: wgpu::TextureAspect::All,
                },
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
        ctx.queue.submit([]);
        ctx.wait();
        bytes
    }
}
