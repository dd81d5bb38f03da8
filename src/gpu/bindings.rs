//! The one binding table: every kernel binds the same nine resources in group 0, declared here
//! once for Rust (the wgpu bind group layout and the ash descriptor set layout are both made
//! from it) and once for WGSL (shaders/types.wgsl; the scene texture in the generated prelude,
//! `gpu::shaders`). A test below ties the two.

/// What a binding holds, as both device paths declare it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BindingKind {
    /// A uniform buffer.
    Uniform,
    /// The scene texture: a read-only `rgba32uint` storage image, 2D or a 2D array of layers.
    SceneImage,
    /// A storage buffer.
    Storage { read_only: bool },
}

/// One binding of group 0.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Binding {
    /// The WGSL global's name.
    pub name: &'static str,
    pub kind: BindingKind,
}

use BindingKind::{SceneImage, Storage, Uniform};

/// Bindings 0–8 of group 0, in binding order.
pub const BINDINGS: [Binding; 9] = [
    // The frame constants (`layout::Params`).
    Binding { name: "params", kind: Uniform },
    Binding { name: "scene_tex", kind: SceneImage },
    // One vec4 per eye ray: radiance and the loop meter (`render::Picture`).
    Binding { name: "out_buf", kind: Storage { read_only: false } },
    // Ray counters and SIMD counters (`gpu::output`).
    Binding { name: "stats", kind: Storage { read_only: false } },
    // The per-dispatch uniform (`layout::Launch`).
    Binding { name: "launch", kind: Uniform },
    // The readback kernels' inputs.
    Binding { name: "test_in", kind: Storage { read_only: true } },
    // The modes' inputs: a schedule's chunk boundaries or a pixel order.
    Binding { name: "work_buf", kind: Storage { read_only: true } },
    // The tile queue's counter.
    Binding { name: "queue", kind: Storage { read_only: false } },
    // What the viewer shows: per pixel the sum of its samples and their count.
    Binding { name: "frame_buf", kind: Storage { read_only: false } },
];

/// The slot of the binding named `name`.
pub const fn slot(name: &str) -> u32 {
    let mut i = 0;
    while i < BINDINGS.len() {
        if eq(BINDINGS[i].name, name) {
            return i as u32;
        }
        i += 1;
    }
    panic!("no binding of that name")
}

const fn eq(a: &str, b: &str) -> bool {
    let (a, b) = (a.as_bytes(), b.as_bytes());
    if a.len() != b.len() {
        return false;
    }
    let mut i = 0;
    while i < a.len() {
        if a[i] != b[i] {
            return false;
        }
        i += 1;
    }
    true
}

/// The per-dispatch uniform's slot (the ash path can move it into push constants).
pub const LAUNCH_SLOT: u32 = slot("launch");

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::shaders::{compose, validate, Program, Variant};

    /// Every binding of the composed WGSL (each program, the scene texture 2D and layered) is the
    /// table's entry of that slot: same name, same kind, and no binding outside the table.
    #[test]
    fn the_table_is_what_the_shaders_declare() {
        for program in [Program::Render, Program::Modes, Program::Tests] {
            for layered in [false, true] {
                let (module, _) =
                    validate(&compose(program, Variant { layered, ..Variant::FULL })).expect("validates");
                let mut seen = 0;
                for (_, var) in module.global_variables.iter() {
                    let Some(b) = &var.binding else { continue };
                    assert_eq!(b.group, 0, "{:?}", var.name);
                    let entry = BINDINGS.get(b.binding as usize).unwrap_or_else(|| {
                        panic!("binding {} ({:?}) is not in the table", b.binding, var.name)
                    });
                    assert_eq!(var.name.as_deref(), Some(entry.name), "binding {}", b.binding);
                    let kind = match (var.space, &module.types[var.ty].inner) {
                        (naga::AddressSpace::Uniform, _) => Uniform,
                        (naga::AddressSpace::Storage { access }, _) => {
                            Storage { read_only: !access.contains(naga::StorageAccess::STORE) }
                        }
                        (naga::AddressSpace::Handle, naga::TypeInner::Image { class, arrayed, .. }) => {
                            assert_eq!(*arrayed, layered, "{}", entry.name);
                            match class {
                                naga::ImageClass::Storage { format, access } => {
                                    assert_eq!(*format, naga::StorageFormat::Rgba32Uint);
                                    assert!(!access.contains(naga::StorageAccess::STORE));
                                    SceneImage
                                }
                                other => panic!("{}: {other:?}", entry.name),
                            }
                        }
                        other => panic!("{}: {other:?}", entry.name),
                    };
                    assert_eq!(kind, entry.kind, "binding {} ({})", b.binding, entry.name);
                    seen |= 1 << b.binding;
                }
                // The render program leaves the modes' and tests' bindings unused, and naga drops
                // unused globals only from the SPIR-V, not from the module: all nine are here.
                assert_eq!(seen, (1 << BINDINGS.len()) - 1, "{program:?}");
            }
        }
    }

    #[test]
    fn slots_are_found_by_name() {
        assert_eq!(slot("params"), 0);
        assert_eq!(LAUNCH_SLOT, 4);
        assert_eq!(slot("frame_buf"), 8);
    }
}
