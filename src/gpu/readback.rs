//! Runs one readback kernel of `shaders/tests.wgsl` on a batch of inputs (for the unit tests of
//! single shader functions).

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
    d.dispatch(ctx, [0, 0, items, 1]);
    d.read(ctx).0
}
