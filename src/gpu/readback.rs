//! Runs one readback kernel of `shaders/tests.wgsl` on a batch of inputs (for the unit tests of
//! single shader functions).

use super::backend::{infallible, readback_recording, ComputeBackend, WgpuKernel};
use super::dispatch::{Dispatcher, GpuScene};
use super::shaders::{Kernel, Variant};
use super::GpuContext;

/// Dispatches `entry` over `items` items whose inputs are `inputs` (the kernel's stride per
/// item) and returns `out_per_item * items` output vec4s.
pub fn run_kernel(
    ctx: &GpuContext,
    scene: &GpuScene,
    entry: &str,
    inputs: &[[f32; 4]],
    items: u32,
    out_per_item: u32,
) -> Vec<[f32; 4]> {
    let out_len = items as u64 * out_per_item as u64;
    let d = Dispatcher::new(ctx, scene, Kernel::Tests, Variant::FULL, entry, out_len, inputs);
    infallible(run_readback(&WgpuKernel { ctx, dispatcher: &d }, entry, items))
}

/// The readback of `entry` over `items` items on any backend whose kernel is bound to its inputs.
pub fn run_readback<B: ComputeBackend>(
    backend: &B,
    entry: &str,
    items: u32,
) -> Result<Vec<[f32; 4]>, B::Error> {
    backend.run(&readback_recording(entry, items), &mut |_, _| {})?;
    Ok(backend.read_output()?.0)
}
