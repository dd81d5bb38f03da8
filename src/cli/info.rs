//! `irt info`: the Vulkan adapters, and the device, features and limits irt would use.

use super::args::DeviceArgs;
use super::open_device;
use anyhow::Result;
use clap::Args;

#[derive(Args)]
pub struct InfoArgs {
    #[command(flatten)]
    pub device: DeviceArgs,
}

pub fn run(args: InfoArgs) -> Result<()> {
    let instance = irt::gpu::vulkan_instance();
    let adapters = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::VULKAN));
    println!("Vulkan adapters:");
    for a in &adapters {
        let i = a.get_info();
        println!("  {} ({:?}, driver {} {})", i.name, i.device_type, i.driver, i.driver_info);
    }
    let ctx = open_device(&args.device)?;
    let i = &ctx.info;
    println!("irt uses: {} — driver {} {}", i.name, i.driver, i.driver_info);
    if let Some(w) = ctx.old_driver_warning() {
        println!("  warning: {w}");
    }
    let f = ctx.adapter.features();
    println!(
        "  features: SHADER_F64 {}  TIMESTAMP_QUERY {}  PIPELINE_CACHE {}",
        f.contains(wgpu::Features::SHADER_F64),
        f.contains(wgpu::Features::TIMESTAMP_QUERY),
        f.contains(wgpu::Features::PIPELINE_CACHE)
    );
    let l = ctx.device.limits();
    println!(
        "  limits: 2D texture {}  storage binding {} MiB  workgroups/dim {}",
        l.max_texture_dimension_2d,
        l.max_storage_buffer_binding_size >> 20,
        l.max_compute_workgroups_per_dimension
    );
    println!("  pipeline cache: {}", ctx.cache_status);
    // scripts/peer-table.sh reads this line to find out whether the Embree peer is built in.
    #[cfg(feature = "embree")]
    match irt::lab::peer::embree::version() {
        Ok(v) => println!("  bench peers: native, embree (Embree {v})"),
        Err(e) => println!("  bench peers: native (embree built in but no device: {e})"),
    }
    #[cfg(not(feature = "embree"))]
    println!(
        "  bench peers: native (no embree: cargo build --release --features embree, needs libembree-dev)"
    );
    Ok(())
}
