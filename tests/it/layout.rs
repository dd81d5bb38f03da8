//! Every GPU struct declared in Rust (src/gpu/layout/mod.rs) has exactly the layout naga gives the
//! WGSL struct of the same name (shaders/types.wgsl): same member names in order, same offsets,
//! same size. Both sides are declared once; this test is what ties them (the binding table is tied
//! the same way by `gpu::bindings`'s unit test).
use irt::gpu::layout::{BvhNode, GpuLight, Launch, Params};
use irt::gpu::shaders::{compose, validate, Program, Variant};
use std::mem::{offset_of, size_of};

macro_rules! rust_layout {
    ($t:ty; $($f:ident),* $(,)?) => {
        (size_of::<$t>(), vec![$((stringify!($f), offset_of!($t, $f))),*])
    };
}

fn wgsl_layout(module: &naga::Module, name: &str) -> (usize, Vec<(String, usize)>) {
    let (_, ty) = module
        .types
        .iter()
        .find(|(_, t)| t.name.as_deref() == Some(name))
        .unwrap_or_else(|| panic!("WGSL struct {name} not found"));
    match &ty.inner {
        naga::TypeInner::Struct { members, span } => (
            *span as usize,
            members.iter().map(|m| (m.name.clone().unwrap_or_default(), m.offset as usize)).collect(),
        ),
        other => panic!("{name} is not a struct: {other:?}"),
    }
}

fn check(module: &naga::Module, name: &str, rust: (usize, Vec<(&str, usize)>)) {
    let (wsize, wfields) = wgsl_layout(module, name);
    let rfields: Vec<(String, usize)> = rust.1.iter().map(|(n, o)| (n.to_string(), *o)).collect();
    assert_eq!(rfields, wfields, "{name}: member names/offsets differ (Rust left, WGSL right)");
    assert_eq!(rust.0, wsize, "{name}: size differs (Rust {}, WGSL {wsize})", rust.0);
}

#[test]
fn rust_structs_match_wgsl() {
    let (module, _) = validate(&compose(Program::Render, Variant::FULL)).expect("shader validates");
    check(&module, "Light", rust_layout!(GpuLight; position_radius, color));
    check(&module, "Launch", rust_layout!(Launch; rect, pass_range, work, sample, jitter));
    check(&module, "BvhNode", rust_layout!(BvhNode; lo, a, hi, b));
    // The packing writes a node as two whole texels.
    assert_eq!(size_of::<BvhNode>(), 16 * irt::gpu::layout::BVH_NODE_TEXELS as usize);
    check(
        &module,
        "Params",
        rust_layout!(Params; eye, cam_u, cam_v, cam_w, ambient_sky, ambient_ground, ambient_up,
            background, accel_min, accel_max, cell, inv_cell, cells, macro_res,
            prim_base, aux_base, accel_base, image, eye_grid, trace, shadow, lights, volume, iso, patches),
    );
}

#[test]
fn uniform_sizes_are_16_byte_multiples() {
    // Uniform buffer bindings are sized in 16-byte units.
    assert_eq!(size_of::<Params>() % 16, 0);
    assert_eq!(size_of::<Launch>() % 16, 0);
}
