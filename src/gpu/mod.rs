//! wgpu device, GPU layouts, shader composition and dispatch.
