//! Every shader variant parses and validates with naga (no GPU needed).
use irt::gpu::shaders::{compose, validate, Program, Variant};

#[test]
fn every_variant_validates() {
    for kernel in [Program::Render, Program::Modes, Program::Tests] {
        for v in Variant::all() {
            let src = compose(kernel, v);
            if let Err(e) = validate(&src) {
                panic!("{kernel:?} {v:?} does not validate:\n{e}");
            }
        }
    }
}
