//! The frame buffer onto the window: one full-screen triangle whose fragment shader reads the
//! session's storage buffer (sums and counts) and writes the mean, nearest-neighbour scaled.

use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

const SHADER: &str = r#"
struct Blit {
    // Render size (the frame buffer's width and height) and window size, in pixels.
    render: vec2<u32>,
    window: vec2<u32>,
    // 1: the target is not sRGB, encode here.
    encode_srgb: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
};

@group(0) @binding(0) var<storage, read> frame: array<vec4<f32>>;
@group(0) @binding(1) var<uniform> blit: Blit;

@vertex
fn vs_main(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    // (-1, 1), (3, 1), (-1, -3): one triangle over the whole target.
    let x = f32((i << 1u) & 2u);
    let y = f32(i & 2u);
    return vec4<f32>(x * 2.0 - 1.0, 1.0 - y * 2.0, 0.0, 1.0);
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
    let v = frame[fy * blit.render.x + fx];
    var c = vec3<f32>(0.0);
    if (v.w > 0.0) {
        c = clamp(v.xyz / v.w, vec3<f32>(0.0), vec3<f32>(1.0));
    }
    if (blit.encode_srgb != 0u) {
        c = srgb(c);
    }
    return vec4<f32>(c, 1.0);
}
"#;

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
struct BlitUniform {
    render: [u32; 2],
    window: [u32; 2],
    encode_srgb: u32,
    _pad: [u32; 3],
}

/// The picture to show: a device's frame buffer, or the same layout in host memory (the MPI
/// master's frame buffer, assembled from the workers' pixels), which the blit uploads.
#[derive(Clone, Copy)]
pub enum Shown<'a> {
    Device(&'a wgpu::Buffer),
    Host(&'a [u8]),
}

pub struct Blit {
    /// Where host pictures are uploaded to (grown as needed).
    upload: Option<wgpu::Buffer>,
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    uniform: wgpu::Buffer,
    last: BlitUniform,
    /// The frame buffer the bind group was made for (the session may replace it).
    bound: Option<(wgpu::Buffer, wgpu::BindGroup)>,
    encode_srgb: bool,
}

impl Blit {
    /// A pipeline writing to `format`; non-sRGB formats get the sRGB encoding in the shader.
    pub fn new(device: &wgpu::Device, format: wgpu::TextureFormat) -> Self {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("blit"),
            source: wgpu::ShaderSource::Wgsl(SHADER.into()),
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
            bound: None,
            encode_srgb: !format.is_srgb(),
        }
    }

    /// Whether the shader encodes sRGB itself (the surface format is not an sRGB one).
    pub fn encodes_srgb(&self) -> bool {
        self.encode_srgb
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
        let frame = match shown {
            Shown::Device(b) => b,
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
                upload
            }
        };
        let u = BlitUniform {
            render: [render[0].max(1), render[1].max(1)],
            window: [window[0].max(1), window[1].max(1)],
            encode_srgb: self.encode_srgb as u32,
            _pad: [0; 3],
        };
        if u != self.last {
            queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(&u));
            self.last = u;
        }
        if self.bound.as_ref().is_none_or(|(b, _)| b != frame) {
            let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("blit"),
                layout: &self.layout,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: frame.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 1, resource: self.uniform.as_entire_binding() },
                ],
            });
            self.bound = Some((frame.clone(), group));
        }
        let (_, group) = self.bound.as_ref().expect("bound above");
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, group, &[]);
        pass.draw(0..3, 0..1);
    }
}
