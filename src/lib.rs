//! irt: an interactive ray tracer whose tracing runs as Vulkan compute shaders.
//!
//! Data flows one way: [`scene`] (what the user describes, loaded by [`io`]) → [`accel`] (the
//! flattened grid or BVH) → [`gpu`] (the packed scene, shaders and the device paths) →
//! [`render`] (the one render path: a `Session` in one of its modes) → an [`image`], a window
//! ([`app`]) or a measurement ([`lab`]). [`reference`] is an independent f64 tracer of the same
//! equations, the oracle of every test.

pub mod accel;
pub mod app;
pub mod dist;
mod error;
pub mod farm;
pub mod fault;
pub mod gpu;
pub mod image;
pub mod io;
pub mod lab;
pub mod metrics;
pub mod reference;
pub mod render;
pub mod scene;

pub use error::ParseError;
