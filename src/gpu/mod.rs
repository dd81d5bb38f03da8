//! The device layer: what runs on a Vulkan device, behind one seam.
//!
//! Backend-neutral: [`recording`] (a frame's work as a list of commands), [`device`] (the traits
//! each path implements, and what is the same on every path), [`bindings`] (the one binding
//! table), [`layout`] (the GPU records, the scene packing, BVH quantisation and the generated
//! WGSL constants), [`shaders`] (composition and variants), [`scene_texture`] (the scene
//! texture's extent, upload bands and growth), [`output`] (ray counters and the output buffer),
//! [`readback`] (single shader functions run over a batch: the tests' kernels), [`adapter`]
//! (which adapter to open). Then one module per device path: [`wgpu`] (the default, and the
//! window's) and [`vk`] (raw Vulkan through ash).

pub mod adapter;
pub mod bindings;
pub mod device;
pub mod failure;
pub mod instance;
pub mod layout;
pub mod output;
pub mod readback;
pub mod recording;
pub mod scene_texture;
pub mod shaders;
pub mod vk;
pub mod wgpu;

pub use self::wgpu::{CacheSetting, Dispatcher, GpuContext, GpuScene};
pub use adapter::AdapterChoice;
pub use device::{Backend, BoundKernel, Device, DeviceScene, GpuError, ModeBuffers};
pub use failure::{DeviceFailure, FailureKind};
pub use instance::vulkan_instance;
pub use output::{RayCounts, SimdCount};
pub use recording::{Command, Dispatch, Recording};
