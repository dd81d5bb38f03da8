//! wgpu device, GPU layouts, shader composition and dispatch.
pub mod cache;
pub mod context;
pub mod instance;
pub mod layout;
pub mod shaders;

pub use cache::CacheSetting;
pub use context::{AdapterChoice, GpuContext};
pub use instance::vulkan_instance;
pub mod backend;
pub mod dispatch;
pub mod readback;
pub mod renderer;
pub mod vk;

pub use dispatch::{Dispatcher, GpuScene, ModeBuffers, RayCounts, SimdCount};
pub use renderer::{Frame, RenderOptions, Renderer, SetupProgress, SetupStage};
