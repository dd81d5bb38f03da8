//! irt: an interactive ray tracer whose tracing runs as Vulkan compute shaders.
//!
//! Data flows one way: [`scene`] (what the user describes, loaded by [`io`]) → [`accel`] (the
//! flattened grid) → [`gpu`] (buffers, shaders, dispatch) → an image. [`reference`] is an
//! independent f64 tracer of the same equations, the oracle of every test.

pub mod accel;
pub mod app;
pub mod gpu;
pub mod image;
pub mod io;
pub mod metrics;
pub mod peer;
pub mod plot;
pub mod reference;
pub mod render;
pub mod scene;
pub mod stability;
pub mod tradeoff;
