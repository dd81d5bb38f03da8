//! Independent CPU tracer in f64 (the test oracle).
//!
//! Implements docs/shading.md with no code shared with the GPU path: brute force over every
//! primitive, recursion instead of a ray stack. The public functions carry the same names as
//! their WGSL twins so readback tests can compare them one pair at a time.

pub(crate) mod bvh;
mod geometry;
pub mod patch;
mod shading;
pub mod shadows;
mod texture;
mod trace;
pub mod volume;

pub use geometry::{
    cone_bounds, cone_normal, intersect_cone, intersect_sphere, intersect_triangle, triangle_normal,
};
pub use shading::{
    ambient_intensity, dielectric_reflectance, r0_from_eta, reflect, reflectance, refract, schlick,
    shade_ambient, shade_light,
};
pub use texture::{cone_uv, material_at, sample_texture, sphere_uv, wrap_index};
pub use trace::{
    render, render_with_stats, trace_pixel, Geometry, Primitive, RadianceImage, Reference, Stats, SurfaceHit,
    RAY_OFFSET_REL,
};

#[cfg(test)]
mod tests;
