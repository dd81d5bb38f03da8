//! SPIR-V for the ash path: naga's output for one entry point of a composed, validated module,
//! written with the options wgpu-hal uses on the same device, and checked before the driver sees
//! it (a driver such as lavapipe does not validate what it is given).

use super::{Caps, VkError};
use ash::vk;
use naga::back::spv;

/// The SPIR-V writer options wgpu-hal 30 uses for a device with `caps` and irt's features
/// (wgpu-hal/src/vulkan/adapter.rs, `naga_options`): the same SPIR-V version, capabilities,
/// bounds-check policies (naga's checks off where the device's robustness covers them),
/// workgroup zeroing and loop bounding. `caps.options` can turn the checks off
/// (`VkOptions::robust`, `VkOptions::index_checks`).
pub(crate) fn options_for(caps: &Caps) -> spv::Options<'static> {
    use spv::Capability as C;
    let capabilities = [
        C::Shader,
        C::Matrix,
        C::Sampled1D,
        C::Image1D,
        C::ImageQuery,
        C::DerivativeControl,
        C::StorageImageExtendedFormats,
        C::SampledCubeArray,
        C::SampleRateShading,
    ];
    // Subgroup operations where the device has them, as wgpu-hal allows them with
    // Features::SUBGROUP: the SIMD counters' subgroupBroadcastFirst (`Variant::simd_stats`).
    let subgroups =
        caps.subgroup_size.map(|_| [C::GroupNonUniform, C::GroupNonUniformBallot]).into_iter().flatten();
    let policy = |robust: bool| {
        if robust {
            naga::proc::BoundsCheckPolicy::Unchecked
        } else {
            naga::proc::BoundsCheckPolicy::Restrict
        }
    };
    // Robustness off (`VkOptions::robust`): the device checks nothing, and neither does naga.
    let off = !caps.options.robust;
    let v = caps.api_version;
    spv::Options {
        lang_version: match (vk::api_version_major(v), vk::api_version_minor(v)) {
            (1, 0) => (1, 0),
            (1, 1) => (1, 3),
            (1, 2) => (1, 5),
            _ => (1, 6),
        },
        flags: spv::WriterFlags::LABEL_VARYINGS | spv::WriterFlags::FORCE_POINT_SIZE,
        capabilities: Some(capabilities.iter().cloned().chain(subgroups).collect()),
        bounds_check_policies: naga::proc::BoundsCheckPolicies {
            index: policy(!caps.options.index_checks),
            buffer: policy(off || caps.robust_buffer_access2),
            image_load: policy(off || caps.robust_image_access),
            binding_array: naga::proc::BoundsCheckPolicy::Unchecked,
        },
        zero_initialize_workgroup_memory: if caps.zero_init_workgroup {
            spv::ZeroInitializeWorkgroupMemoryMode::Native
        } else {
            spv::ZeroInitializeWorkgroupMemoryMode::Polyfill
        },
        force_loop_bounding: true,
        ray_query_initialization_tracking: true,
        ..spv::Options::default()
    }
}

/// `module` with its launch uniform (`var<uniform> launch`, `bindings::LAUNCH_SLOT`) moved to the
/// immediate address space (push constants in SPIR-V), validated again: the same WGSL, one
/// module transform, so the shaders keep one source. An error if the module has no such global.
pub(crate) fn launch_as_push_constants(
    mut module: naga::Module,
) -> Result<(naga::Module, naga::valid::ModuleInfo), VkError> {
    let launch = module.global_variables.iter_mut().find(|(_, g)| {
        g.space == naga::AddressSpace::Uniform
            && g.binding
                == Some(naga::ResourceBinding { group: 0, binding: crate::gpu::bindings::LAUNCH_SLOT })
    });
    let Some((_, g)) = launch else {
        let slot = crate::gpu::bindings::LAUNCH_SLOT;
        return Err(VkError::Shader(format!("the kernel has no uniform at binding {slot} to push")));
    };
    g.space = naga::AddressSpace::Immediate;
    g.binding = None;
    let info = crate::gpu::shaders::validator()
        .validate(&module)
        .map_err(|e| VkError::Shader(format!("the kernel with its launch uniform in push constants: {e}")))?;
    Ok((module, info))
}

/// The options of [`options_for`] for an open context (tests and tools).
pub fn spv_options(ctx: &super::VkContext) -> spv::Options<'static> {
    options_for(&ctx.shared.caps)
}

/// The SPIR-V of compute entry point `entry` of `module` (validated, `info` its validation), as
/// wgpu-hal writes it per pipeline: overrides processed for that entry point, then
/// [`check_spirv`]ed.
pub fn compile_entry(
    module: &naga::Module,
    info: &naga::valid::ModuleInfo,
    entry: &str,
    options: &spv::Options,
) -> Result<Vec<u32>, VkError> {
    let stage = naga::ShaderStage::Compute;
    let (module, info) = naga::back::pipeline_constants::process_overrides(
        module,
        info,
        Some((stage, entry)),
        &Default::default(),
    )
    .map_err(|e| VkError::Shader(format!("entry point '{entry}': pipeline constants: {e}")))?;
    let pipeline = spv::PipelineOptions { entry_point: entry.to_string(), shader_stage: stage };
    let words = spv::write_vec(&module, &info, options, Some(&pipeline))
        .map_err(|e| VkError::Shader(format!("entry point '{entry}': naga could not write SPIR-V: {e}")))?;
    check_spirv(&words, entry)?;
    Ok(words)
}

/// Checks `words` as a SPIR-V module before a driver sees it: the header (magic, a version up to
/// 1.6, an id bound, schema 0), every instruction's word count within the module and its opcode
/// known to the SPIR-V grammar, and an `OpEntryPoint` named `entry`. This catches truncation and
/// most corrupted words (an opcode or a length); a changed operand is not caught (naga's
/// validator checked the module it was written from).
pub fn check_spirv(words: &[u32], entry: &str) -> Result<(), VkError> {
    let bad = |why: String| Err(VkError::Shader(format!("SPIR-V rejected (entry point '{entry}'): {why}")));
    if words.len() < 5 {
        return bad(format!("{} words is shorter than the header", words.len()));
    }
    if words[0] != spirv::MAGIC_NUMBER {
        return bad(format!("word 0 is {:#010x}, not the SPIR-V magic number", words[0]));
    }
    let (major, minor) = ((words[1] >> 16) & 0xff, (words[1] >> 8) & 0xff);
    if words[1] & 0xff00_00ff != 0 || major != 1 || minor > 6 {
        return bad(format!("word 1 ({:#010x}) is no SPIR-V version up to 1.6", words[1]));
    }
    if words[3] == 0 || words[4] != 0 {
        return bad(format!("header id bound {} / schema {} are invalid", words[3], words[4]));
    }
    let mut at = 5;
    let mut found_entry = false;
    while at < words.len() {
        let (count, code) = ((words[at] >> 16) as usize, words[at] & 0xffff);
        if count == 0 || at + count > words.len() {
            return bad(format!(
                "the instruction at word {at} has a word count of {count}, past the module's end"
            ));
        }
        let Some(op) = spirv::Op::from_u32(code) else {
            return bad(format!(
                "the instruction at word {at} has opcode {code}, which SPIR-V does not define"
            ));
        };
        if op == spirv::Op::EntryPoint && count > 3 {
            let name: Vec<u8> = words[at + 3..at + count].iter().flat_map(|w| w.to_le_bytes()).collect();
            let name = name.split(|&b| b == 0).next().unwrap_or_default();
            found_entry |= name == entry.as_bytes();
        }
        at += count;
    }
    if !found_entry {
        return bad("no OpEntryPoint of that name".into());
    }
    Ok(())
}
