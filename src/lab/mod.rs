//! The lab beside the renderer: measurements that use the render path and never stand in it.
//! Each opens `render::Session`s like any other caller and times or compares what they trace.
//!
//! - [`tradeoff`]: every shadow mode's time and error against the ground truth (`irt tradeoff`);
//! - [`stability`]: the GPU against the f64 reference as a scene moves from the origin
//!   (`irt stability`);
//! - [`peer`]: the benchmark peers (native Rust of the same algorithm, Embree) that `irt bench`
//!   compares against;
//! - [`plot`]: the SVG charts they draw.
//!
//! The timing harnesses that regenerate the docs' tables (`irt-lab`) are the workspace crate
//! under tools/.

pub mod peer;
pub mod plot;
pub mod stability;
pub mod tradeoff;
