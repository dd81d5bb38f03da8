//! The floor under every frame of the bands: a 512² dispatch of the bands' workgroup
//! shape whose kernel does nothing, or writes one vec4 per pixel (the frame's output), timed as
//! a session times a dispatch (submit + wait). docs/performance.md, "Where an all-miss frame's
//! time goes".
//!
//!     cargo run --release -p irt-tools -- dispatch-floor [DISPATCHES]

use irt::gpu::layout::RENDER_TILE;
use irt::gpu::{AdapterChoice, GpuContext};
use std::time::Instant;

const SIZE: u32 = 512;

fn kernel(body: &str) -> String {
    format!(
        "@group(0) @binding(0) var<storage, read_write> out_buf: array<vec4f>;\n\
         @compute @workgroup_size({}, {}, 1)\n\
         fn main(@builtin(global_invocation_id) g: vec3u) {{ {body} }}\n",
        RENDER_TILE[0], RENDER_TILE[1]
    )
}

pub fn run(args: &[String]) -> anyhow::Result<()> {
    let dispatches: usize = args.first().map_or(Ok(200), |s| s.parse())?;
    let ctx = GpuContext::new(&AdapterChoice::from_arg_or_env(None))?;
    let d = &ctx.device;
    let out = d.create_buffer(&wgpu::BufferDescriptor {
        label: Some("out"),
        size: (SIZE * SIZE * 16) as u64,
        usage: wgpu::BufferUsages::STORAGE,
        mapped_at_creation: false,
    });
    println!("{} ({}), {SIZE}x{SIZE}, {dispatches} dispatches each", ctx.info.name, ctx.info.driver_info);
    let cases = [
        // A write no invocation makes keeps the binding alive.
        ("empty", "if g.x > 100000u { out_buf[0] = vec4f(0.0); }".to_string()),
        ("one vec4 per pixel", format!("out_buf[g.y * {SIZE}u + g.x] = vec4f(f32(g.x), 0.0, 0.0, 1.0);")),
    ];
    for (name, body) in cases {
        let module = d.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(name),
            source: wgpu::ShaderSource::Wgsl(kernel(&body).into()),
        });
        let pipeline = d.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(name),
            layout: None,
            module: &module,
            entry_point: Some("main"),
            compilation_options: Default::default(),
            cache: None,
        });
        let bind_group = d.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &pipeline.get_bind_group_layout(0),
            entries: &[wgpu::BindGroupEntry { binding: 0, resource: out.as_entire_binding() }],
        });
        let mut ms = Vec::with_capacity(dispatches + 1);
        // The first dispatch compiles (lavapipe compiles there): not timed.
        for _ in 0..=dispatches {
            let t = Instant::now();
            let mut enc = d.create_command_encoder(&Default::default());
            {
                let mut pass = enc.begin_compute_pass(&Default::default());
                pass.set_pipeline(&pipeline);
                pass.set_bind_group(0, &bind_group, &[]);
                pass.dispatch_workgroups(SIZE / RENDER_TILE[0], SIZE / RENDER_TILE[1], 1);
            }
            ctx.queue.submit([enc.finish()]);
            ctx.wait();
            ms.push(t.elapsed().as_secs_f64() * 1e3);
        }
        let mut ms = ms.split_off(1);
        ms.sort_by(f64::total_cmp);
        let at = |q: f64| ms[((ms.len() - 1) as f64 * q) as usize];
        println!("{name:<20} median {:.2} ms (p10 {:.2}, p90 {:.2})", at(0.5), at(0.1), at(0.9));
    }
    Ok(())
}
