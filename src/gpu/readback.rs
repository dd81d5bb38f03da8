//! One shader function over a batch of inputs, read back (the unit tests of single shader
//! functions, `shaders/tests.wgsl`), on any device path.

use super::device::{BoundKernel, Device, DeviceScene, KernelSpec};
use super::layout;
use super::recording::Recording;
use super::GpuError;
use crate::accel::AccelRef;
use crate::scene::Scene;
use glam::DVec3;

/// Uploads `scene` and its accelerator with positions relative to `origin` (`DVec3::ZERO`: in
/// world coordinates, what the readback kernels' world-space rays need), without a reserve.
pub fn upload_at<'a, D: Device>(
    ctx: &D,
    scene: &Scene,
    accel: impl Into<AccelRef<'a>>,
    origin: DVec3,
) -> Result<DeviceScene<D::Texture>, GpuError> {
    let accel = accel.into();
    let packed = layout::pack_scene(scene, accel, origin);
    let params = layout::params(scene, accel, &packed, origin);
    ctx.upload(packed, params, None, 0)
}

/// Dispatches `entry` of the test program over `items` items whose inputs are `inputs` (the
/// kernel's stride per item) and returns `out_per_item * items` output vec4s.
pub fn run_kernel<D: Device>(
    ctx: &D,
    scene: &DeviceScene<D::Texture>,
    entry: &str,
    inputs: &[[f32; 4]],
    items: u32,
    out_per_item: u32,
) -> Result<Vec<[f32; 4]>, GpuError> {
    let out_len = items as u64 * out_per_item as u64;
    let kernel = ctx.compile(scene, KernelSpec::tests(inputs, out_len))?;
    let bound = ctx.bind(&kernel);
    bound.run(&Recording::readback(entry, items), &mut |_, _| {}).map_err(Into::into)?;
    Ok(bound.read_output().map_err(Into::into)?.0)
}
