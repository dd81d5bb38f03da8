//! The full SPIR-V check of the ash path (`VkOptions::full_spirv_check`, and the tests): the
//! words read back by naga's SPIR-V front end (which resolves every id and type), then
//! `spirv-val` (SPIRV-Tools), the validator of the SPIR-V rules, on them where it is installed. The structural
//! [`super::check_spirv`] runs before every pipeline regardless; this one also catches what only
//! a reader of the operands can (an undefined id, a wrong type), at a cost measured in
//! docs/backends.md.

use super::VkError;
use std::io::Write;
use std::process::{Command, Stdio};
use std::sync::OnceLock;

/// Which checks ran on a module that passed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FullCheck {
    /// naga's SPIR-V front end read the words back (`false`: it stopped at something it does
    /// not implement; malformed words are an error).
    pub naga: bool,
    /// `spirv-val` (only where it is installed).
    pub spirv_val: bool,
}

/// The `spirv-val` to run: `$IRT_SPIRV_VAL`, else `spirv-val` on the `PATH`; `None` when it does
/// not run (`spirv-val --version` fails), decided once per process.
fn spirv_val_program() -> Option<&'static str> {
    static PROGRAM: OnceLock<Option<String>> = OnceLock::new();
    PROGRAM
        .get_or_init(|| {
            let program = std::env::var("IRT_SPIRV_VAL").unwrap_or_else(|_| "spirv-val".into());
            let runs = Command::new(&program)
                .arg("--version")
                .stdout(Stdio::null())
                .stderr(Stdio::null())
                .status()
                .is_ok_and(|s| s.success());
            runs.then_some(program)
        })
        .as_deref()
}

/// Whether [`full_check`] will also run `spirv-val`.
pub fn spirv_val_available() -> bool {
    spirv_val_program().is_some()
}

/// Checks `words`, the SPIR-V of entry point `entry`, fully: naga parses them back (and finds
/// `entry` in them), then `spirv-val` validates them for the Vulkan version
/// whose SPIR-V version they declare, where it is installed. Errors name the entry point.
pub fn full_check(words: &[u32], entry: &str) -> Result<FullCheck, VkError> {
    super::check_spirv(words, entry)?;
    let naga = naga_check(words, entry)?;
    Ok(FullCheck { naga, spirv_val: spirv_val_check(words, entry)? })
}

/// Whether naga's SPIR-V front end stopped at something it does not implement rather than at
/// malformed words: naga 30 cannot read back all of its own output (a workgroup atomic with a
/// zero initializer, as `render_queue` has, is an `AtomicUpgradeError`).
fn naga_cannot_read(e: &naga::front::spv::Error) -> bool {
    use naga::front::spv::Error as E;
    matches!(
        e,
        E::UnsupportedInstruction(..)
            | E::UnsupportedCapability(_)
            | E::UnsupportedExtension(_)
            | E::UnsupportedExtSet(_)
            | E::UnsupportedExtInstSet(_)
            | E::UnsupportedExtInst(_)
            | E::UnsupportedType(_)
            | E::UnsupportedExecutionModel(_)
            | E::UnsupportedExecutionMode(_)
            | E::UnsupportedStorageClass(_)
            | E::UnsupportedImageDim(_)
            | E::UnsupportedImageFormat(_)
            | E::UnsupportedBuiltIn(_)
            | E::UnsupportedControlFlow(_)
            | E::UnsupportedBinaryOperator(_)
            | E::UnsupportedRuntimeArrayStorageClass
            | E::UnsupportedGroupOperation(_)
            | E::AtomicUpgradeError(_)
    )
}

fn rejected(entry: &str) -> impl Fn(String) -> VkError + '_ {
    move |why| VkError::Shader(format!("SPIR-V rejected (entry point '{entry}'): {why}"))
}

/// The first half of [`full_check`]: naga's SPIR-V front end reads `words` back (which have
/// passed [`super::check_spirv`]). An error where the words are malformed (an undefined id, a
/// type where a value belongs, a bad operand count, …); `Ok(false)` where naga stopped at
/// something it does not implement, which says nothing about the words.
pub fn naga_check(words: &[u32], entry: &str) -> Result<bool, VkError> {
    let bad = rejected(entry);
    let options = naga::front::spv::Options {
        // The words are naga's own compute SPIR-V: no coordinate flip, only known capabilities.
        adjust_coordinate_space: false,
        strict_capabilities: true,
        block_ctx_dump_prefix: None,
    };
    let module = match naga::front::spv::parse_u8_slice(bytemuck::cast_slice(words), &options) {
        Ok(m) => m,
        Err(e) if naga_cannot_read(&e) => {
            log::debug!("entry point '{entry}': naga's SPIR-V front end cannot read it back: {e}");
            return Ok(false);
        }
        Err(e) => return Err(bad(format!("naga's SPIR-V front end: {e}"))),
    };
    // naga's validator is not run on the module read back: naga 30's front end builds, from
    // naga's own valid SPIR-V of these kernels, IR its validator rejects (a `Min` of an i32 and
    // a u32 from the `UMin` of an index check, a `LogicalOr` of a vec3<bool> and a bool, a call
    // result "already populated"), with any subset of the validation flags. The parse itself
    // resolves every id and type it reads.
    if !module.entry_points.iter().any(|e| e.name == entry) {
        return Err(bad("naga's SPIR-V front end found no entry point of that name".into()));
    }
    Ok(true)
}

/// The second half of [`full_check`]: `spirv-val` on `words` (which have passed
/// [`super::check_spirv`]); `Ok(false)` when it is not installed.
pub fn spirv_val_check(words: &[u32], entry: &str) -> Result<bool, VkError> {
    let bad = rejected(entry);
    let Some(program) = spirv_val_program() else {
        return Ok(false);
    };
    // The SPIR-V version decides the Vulkan environment (1.6 needs Vulkan 1.3, 1.5: 1.2,
    // 1.4 and 1.3: 1.1), as spirv::options_for chose it from the device's API version.
    let env = match (words[1] >> 16 & 0xff, words[1] >> 8 & 0xff) {
        (1, 6) => "vulkan1.3",
        (1, 5) => "vulkan1.2",
        (1, 4) => "vulkan1.1spv1.4",
        (1, 3) => "vulkan1.1",
        _ => "vulkan1.0",
    };
    let mut child = Command::new(program)
        .args(["--target-env", env, "-"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| bad(format!("could not run {program}: {e}")))?;
    // Written from here and read by `wait_with_output` (spirv-val reads all input first).
    let written = child.stdin.take().map(|mut stdin| stdin.write_all(bytemuck::cast_slice(words)));
    let out = child.wait_with_output().map_err(|e| bad(format!("{program}: {e}")))?;
    if let Some(Err(e)) = written {
        return Err(bad(format!("writing to {program}: {e}")));
    }
    if !out.status.success() {
        let text = String::from_utf8_lossy(&out.stderr);
        let text = if text.trim().is_empty() { String::from_utf8_lossy(&out.stdout) } else { text };
        return Err(bad(format!("{program} --target-env {env}: {}", text.trim())));
    }
    Ok(true)
}
