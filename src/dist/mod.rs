//! Past one machine: the paper's master and workers as MPI ranks (`--mpi`, under `mpirun`).
//! Rank 0 is the master ([`master`]): the window or nothing, the scene sent once, the state as
//! it changes, work handed out on demand, the frame buffer ([`frame`]). Ranks 1..N are workers
//! ([`worker`]): each a `render::Session` on its own device, fed by messages ([`wire`]). Every
//! failure ends the whole job with the rank's name and what it was doing ([`cluster`]).
//!
//! Only [`cluster`]'s link speaks MPI, behind the `mpi` cargo feature (on by default;
//! `--no-default-features` builds irt without MPI, and `--mpi` then says so).

pub mod cluster;
pub mod files;
pub mod master;
pub mod replay;
pub mod wire;
pub mod worker;
