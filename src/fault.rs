//! Faults on purpose, for the tests that check a failure is reported in words and, under MPI,
//! ends the job loudly rather than hanging it: `IRT_FAULT=panic` makes a worker panic at its
//! first piece of work, `IRT_FAULT=version` makes it claim another build, `device-alloc` makes
//! the wgpu path ask for an output buffer past the device's largest (a real validation error of
//! the device), `device-lost` destroys the device after its first dispatch (as a driver reset
//! would), and `unseen-files` makes a worker act as if it could not read the scene's particle
//! files where rank 0 did (so rank 0 sends them). Set for one rank with mpirun's MPMD form
//! (`mpirun -n 1 irt … : -n 1 env IRT_FAULT=panic irt …`); unset, nothing changes.

/// Whether `fault` is among the comma-separated names in `$IRT_FAULT`.
pub fn armed(fault: &str) -> bool {
    std::env::var("IRT_FAULT").is_ok_and(|v| v.split(',').any(|f| f.trim() == fault))
}
