//! A device's failure in words a user can act on: what the driver or wgpu's validation said,
//! boiled down to its cause, and what to do about it. Both device paths report these; the
//! commands print them and exit non-zero, an MPI rank names itself and ends the job.

use std::fmt;

/// What failed on a device.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FailureKind {
    /// An allocation the device could not make.
    OutOfMemory,
    /// Work the device (wgpu's validation) refused: irt asked for something the device's limits
    /// do not allow.
    Validation,
    /// The device was lost: its driver failed or was reset.
    Lost,
    /// Anything else the driver reported.
    Internal,
}

/// A device's failure: its kind and the driver's or wgpu's own words, condensed to one line.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub struct DeviceFailure {
    pub kind: FailureKind,
    pub detail: String,
}

/// What to do after a failure, in the words of irt's own options.
const SMALLER: &str = "render a smaller --size, split the picture over a farm with --tile I/N, or \
                       use fewer --samples";

impl fmt::Display for DeviceFailure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let d = &self.detail;
        match self.kind {
            FailureKind::OutOfMemory => write!(f, "the device ran out of memory ({d}): {SMALLER}"),
            FailureKind::Validation => write!(
                f,
                "the device refused irt's work ({d}): {SMALLER}; if a smaller picture fails too, \
                 please report it with the command line"
            ),
            FailureKind::Lost => write!(
                f,
                "the device was lost ({d}): its driver failed or reset it; run the command again, \
                 and if it recurs, {SMALLER}"
            ),
            FailureKind::Internal => write!(f, "the device failed ({d}): {SMALLER}"),
        }
    }
}

impl DeviceFailure {
    pub fn new(kind: FailureKind, detail: impl AsRef<str>) -> Self {
        DeviceFailure { kind, detail: condense(detail.as_ref()) }
    }
}

/// A driver's or wgpu's multi-line error as one line: the lines that say something, joined,
/// without wgpu's headings ("Validation Error", "Caused by:") and without any source path.
pub fn condense(text: &str) -> String {
    let lines: Vec<&str> = text
        .lines()
        .map(str::trim)
        .filter(|l| {
            !l.is_empty()
                && !l.eq_ignore_ascii_case("validation error")
                && !l.eq_ignore_ascii_case("caused by:")
                && !l.contains(".rs:")
        })
        .collect();
    let joined = lines.join(": ");
    if joined.is_empty() {
        "no details given".into()
    } else {
        joined
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wgpu_s_multi_line_errors_become_one_line_without_source_paths() {
        let text = "Validation Error\n\nCaused by:\n  In Device::create_bind_group, label = 'irt'\n    \
                    Buffer binding 2 range 268435456 exceeds max_*_buffer_binding_size limit 134217728\n";
        let f = DeviceFailure::new(FailureKind::Validation, text);
        assert_eq!(
            f.detail,
            "In Device::create_bind_group, label = 'irt': Buffer binding 2 range 268435456 exceeds \
             max_*_buffer_binding_size limit 134217728"
        );
        let said = f.to_string();
        assert!(said.starts_with("the device refused irt's work"), "{said}");
        assert!(said.contains("--size") && said.contains("--tile"), "{said}");
        let lost = DeviceFailure::new(FailureKind::Lost, "at src/gpu/wgpu/kernel.rs:12:5\nDestroyed");
        assert_eq!(lost.detail, "Destroyed");
        assert_eq!(DeviceFailure::new(FailureKind::Internal, "\n\n").detail, "no details given");
    }
}
