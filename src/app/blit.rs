//! The frame buffer onto the window: one full-screen triangle whose fragment shader reads the
//! session's storage buffer (sums and counts) and writes the mean, nearest-neighbour scaled;
//! under the adaptive order, filled as `render::fill` says (the same rule as its `fill`, which
//! the test below holds it to).

use crate::render::adaptive::BLOCK_SIDE;
use crate::render::fill::{BlockFill, FILL_EPS, FILL_RADIUS};
use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

const SHADER: &str = r#"
struct Blit {
    // Render size (the frame buffer's width and height) and window size, in pixels.
    render: vec2<u32>,
    window: vec2<u32>,
    // 1: the target is not sRGB, encode here.
    encode_srgb: u32,
    // The fill's blocks a row (0: no fill).
    blocks_x: u32,
    _pad0: u32,
    _pad1: u32,
};

@group(0) @binding(0) var<storage, read> frame: array<vec4<f32>>;
@group(0) @binding(1) var<uniform> blit: Blit;
// Per block: the change it missed, its gradient (render::fill::BlockFill).
@group(0) @binding(2) var<storage, read> blocks: array<vec2<f32>>;

const FILL_RADIUS: i32 = {FILL_RADIUS};
const BLOCK_SIDE: u32 = {BLOCK_SIDE}u;
const FILL_EPS: f32 = {FILL_EPS};

@vertex
fn vs_main(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    // (-1, 1), (3, 1), (-1, -3): one triangle over the whole target.
    let x = f32((i << 1u) & 2u);
    let y = f32(i & 2u);
    return vec4<f32>(x * 2.0 - 1.0, 1.0 - y * 2.0, 0.0, 1.0);
}

fn mean(i: u32) -> vec3<f32> {
    let v = frame[i];
    if (v.w > 0.0) {
        return v.xyz / v.w;
    }
    return vec3<f32>(0.0);
}

fn block_of(x: u32, y: u32) -> u32 {
    return (y / BLOCK_SIDE) * blit.blocks_x + x / BLOCK_SIDE;
}

// render::fill::fill for one pixel: its fresher neighbours blended in by the inverse of each
// sample's expected squared error.
fn filled(x: u32, y: u32) -> vec3<f32> {
    let own = blocks[block_of(x, y)];
    if (own.x <= 0.0) {
        return mean(y * blit.render.x + x);
    }
    var sum = vec3<f32>(0.0);
    var weights = 0.0;
    for (var dy = -FILL_RADIUS; dy <= FILL_RADIUS; dy++) {
        for (var dx = -FILL_RADIUS; dx <= FILL_RADIUS; dx++) {
            let qx = i32(x) + dx;
            let qy = i32(y) + dy;
            if (qx < 0 || qy < 0 || qx >= i32(blit.render.x) || qy >= i32(blit.render.y)) {
                continue;
            }
            let e = blocks[block_of(u32(qx), u32(qy))].x;
            let d2 = f32(dx * dx + dy * dy);
            let wt = 1.0 / (FILL_EPS * FILL_EPS + e * e + own.y * own.y * d2);
            sum += wt * mean(u32(qy) * blit.render.x + u32(qx));
            weights += wt;
        }
    }
    return sum / weights;
}

fn srgb(c: vec3<f32>) -> vec3<f32> {
    let lo = c * 12.92;
    let hi = 1.055 * pow(c, vec3<f32>(1.0 / 2.4)) - 0.055;
    return select(hi, lo, c <= vec3<f32>(0.0031308));
}

@fragment
fn fs_main(@builtin(position) p: vec4<f32>) -> @location(0) vec4<f32> {
    // Window pixel -> frame pixel, in integers: exact at scale 1, nearest below it. Row 0 is the
    // top of both.
    let wx = min(u32(p.x), blit.window.x - 1u);
    let wy = min(u32(p.y), blit.window.y - 1u);
    let fx = min(wx * blit.render.x / blit.window.x, blit.render.x - 1u);
    let fy = min(wy * blit.render.y / blit.window.y, blit.render.y - 1u);
    var c: vec3<f32>;
    if (blit.blocks_x > 0u) {
        c = filled(fx, fy);
    } else {
        c = mean(fy * blit.render.x + fx);
    }
    c = clamp(c, vec3<f32>(0.0), vec3<f32>(1.0));
    if (blit.encode_srgb != 0u) {
        c = srgb(c);
    }
    return vec4<f32>(c, 1.0);
}
"#;

/// A `size` target of `format` for [`Blit::draw_offscreen`], with `usage` besides.
pub fn offscreen_target(
    device: &wgpu::Device,
    format: wgpu::TextureFormat,
    size: [u32; 2],
    usage: wgpu::TextureUsages,
) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some("blit offscreen"),
        size: wgpu::Extent3d { width: size[0], height: size[1], depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: usage | wgpu::TextureUsages::RENDER_ATTACHMENT,
        view_formats: &[],
    })
}

/// The shader with the fill's constants (one source: `render::fill`).
fn shader() -> String {
    SHADER
        .replace("{FILL_RADIUS}", &FILL_RADIUS.to_string())
        .replace("{BLOCK_SIDE}", &BLOCK_SIDE.to_string())
        .replace("{FILL_EPS}", &format!("{:?}", FILL_EPS))
}

fn blocks_buffer(device: &wgpu::Device, size: u64) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("blit fill blocks"),
        size,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
struct BlitUniform {
    render: [u32; 2],
    window: [u32; 2],
    encode_srgb: u32,
    blocks_x: u32,
    _pad0: u32,
    _pad1: u32,
}

/// The picture to show: a device's frame buffer, or the same layout in host memory (the MPI
/// master's frame buffer, assembled from the workers' pixels), which the blit uploads.
#[derive(Clone, Copy)]
pub enum Shown<'a> {
    /// The frame buffer, and the fill it is shown with ([`crate::render::Session::fill`]).
    Device(&'a wgpu::Buffer, Option<(&'a [BlockFill], u32)>),
    Host(&'a [u8]),
}

pub struct Blit {
    /// Where host pictures are uploaded to (grown as needed).
    upload: Option<wgpu::Buffer>,
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    uniform: wgpu::Buffer,
    last: BlitUniform,
    /// The fill's blocks (grown as needed; 16 bytes while there is no fill).
    blocks: wgpu::Buffer,
    /// The frame and blocks buffers the bind group was made for (the session may replace the
    /// first, a larger fill the second).
    bound: Option<([wgpu::Buffer; 2], wgpu::BindGroup)>,
    encode_srgb: bool,
}

impl Blit {
    /// A pipeline writing to `format`; non-sRGB formats get the sRGB encoding in the shader.
    pub fn new(device: &wgpu::Device, format: wgpu::TextureFormat) -> Self {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("blit"),
            source: wgpu::ShaderSource::Wgsl(shader().into()),
        });
        let entry = |binding, ty| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::FRAGMENT,
            ty: wgpu::BindingType::Buffer { ty, has_dynamic_offset: false, min_binding_size: None },
            count: None,
        };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("blit"),
            entries: &[
                entry(0, wgpu::BufferBindingType::Storage { read_only: true }),
                entry(1, wgpu::BufferBindingType::Uniform),
                entry(2, wgpu::BufferBindingType::Storage { read_only: true }),
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("blit"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("blit"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_main"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs_main"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format,
                    blend: None,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: None,
            multisample: wgpu::MultisampleState::default(),
            multiview_mask: None,
            cache: None,
        });
        let uniform = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("blit uniform"),
            contents: bytemuck::bytes_of(&BlitUniform::default()),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        Blit {
            upload: None,
            pipeline,
            layout,
            uniform,
            last: BlitUniform::default(),
            blocks: blocks_buffer(device, 16),
            bound: None,
            encode_srgb: !format.is_srgb(),
        }
    }

    /// Whether the shader encodes sRGB itself (the surface format is not an sRGB one).
    pub fn encodes_srgb(&self) -> bool {
        self.encode_srgb
    }

    /// Draws `shown` (`render` pixels) onto `target` (offscreen: tests and benchmarks) and
    /// submits it.
    pub fn draw_offscreen(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        target: &wgpu::Texture,
        shown: Shown<'_>,
        render: [u32; 2],
    ) {
        let view = target.create_view(&Default::default());
        let mut enc = device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("blit offscreen"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Store },
                })],
                ..Default::default()
            });
            let size = target.size();
            self.draw(device, queue, &mut pass, shown, render, [size.width, size.height]);
        }
        queue.submit([enc.finish()]);
    }

    /// Records the blit of `shown` (`render` pixels) onto a target of `window` pixels.
    pub fn draw(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        pass: &mut wgpu::RenderPass<'_>,
        shown: Shown<'_>,
        render: [u32; 2],
        window: [u32; 2],
    ) {
        let (frame, fill) = match shown {
            Shown::Device(b, fill) => (b, fill),
            Shown::Host(bytes) => {
                let size = (bytes.len() as u64).max(16);
                if self.upload.as_ref().is_none_or(|b| b.size() < size) {
                    self.upload = Some(device.create_buffer(&wgpu::BufferDescriptor {
                        label: Some("blit upload"),
                        size,
                        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                        mapped_at_creation: false,
                    }));
                }
                let upload = self.upload.as_ref().expect("made above");
                queue.write_buffer(upload, 0, bytes);
                (upload, None)
            }
        };
        let u = BlitUniform {
            render: [render[0].max(1), render[1].max(1)],
            window: [window[0].max(1), window[1].max(1)],
            encode_srgb: self.encode_srgb as u32,
            blocks_x: fill.map_or(0, |f| f.1),
            _pad0: 0,
            _pad1: 0,
        };
        if let Some((blocks, _)) = fill {
            let bytes: &[u8] = bytemuck::cast_slice(blocks);
            if self.blocks.size() < bytes.len() as u64 {
                self.blocks = blocks_buffer(device, bytes.len() as u64);
            }
            queue.write_buffer(&self.blocks, 0, bytes);
        }
        if u != self.last {
            queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(&u));
            self.last = u;
        }
        if self.bound.as_ref().is_none_or(|([f, b], _)| f != frame || *b != self.blocks) {
            let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("blit"),
                layout: &self.layout,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: frame.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 1, resource: self.uniform.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 2, resource: self.blocks.as_entire_binding() },
                ],
            });
            self.bound = Some(([frame.clone(), self.blocks.clone()], group));
        }
        let (_, group) = self.bound.as_ref().expect("bound above");
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, group, &[]);
        pass.draw(0..3, 0..1);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::mem::{offset_of, size_of};

    /// [`BlitUniform`] and the shader's `Blit` have the same members at the same offsets.
    #[test]
    fn the_uniform_matches_the_shaders_struct() {
        let module = naga::front::wgsl::parse_str(&shader()).expect("the blit shader parses");
        let ty = module.types.iter().find(|(_, t)| t.name.as_deref() == Some("Blit")).expect("struct Blit").1;
        let naga::TypeInner::Struct { members, span } = &ty.inner else { panic!("Blit is not a struct") };
        let got: Vec<(&str, u32)> =
            members.iter().map(|m| (m.name.as_deref().unwrap_or(""), m.offset)).collect();
        let want = [
            ("render", offset_of!(BlitUniform, render)),
            ("window", offset_of!(BlitUniform, window)),
            ("encode_srgb", offset_of!(BlitUniform, encode_srgb)),
            ("blocks_x", offset_of!(BlitUniform, blocks_x)),
            ("_pad0", offset_of!(BlitUniform, _pad0)),
            ("_pad1", offset_of!(BlitUniform, _pad1)),
        ];
        assert_eq!(got, want.map(|(n, o)| (n, o as u32)));
        assert_eq!(*span as usize, size_of::<BlitUniform>());
    }
}
