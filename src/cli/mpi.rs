//! `--mpi`: a command as the ranks of an MPI job (src/dist). Every rank runs the same command
//! line; rank 0 leads (it alone reads the scene file and writes the output), the others trace.

use anyhow::Result;
use clap::Args;
use irt::dist::cluster::Cluster;
use irt::dist::master::Deadlines;
use irt::dist::worker;
use std::time::Duration;

#[derive(Args, Clone, Debug, Default)]
pub struct MpiArgs {
    /// Run as one rank of an MPI job, under `mpirun -n N` (N ≥ 2): rank 0 reads the scene, hands
    /// out the work and writes the result; ranks 1..N-1 each trace on their own device
    /// (--adapter, or $IRT_ADAPTER set per rank; on lavapipe each takes its share of the cores
    /// unless LP_NUM_THREADS says otherwise). The picture is the one a single process makes, bit
    /// for bit. See docs/distributed.md.
    #[arg(long)]
    pub mpi: bool,
    /// With --mpi: seconds a worker may take to return a piece of work before rank 0 names it
    /// and ends the job.
    #[arg(long, value_name = "SECONDS", default_value_t = Deadlines::default().work.as_secs_f64(), requires = "mpi")]
    pub deadline: f64,
    /// With --mpi: seconds a worker may take to open its device and set the scene up (a large
    /// model's accelerator is built on every worker).
    #[arg(long, value_name = "SECONDS", default_value_t = Deadlines::default().setup.as_secs_f64(), requires = "mpi")]
    pub setup_deadline: f64,
}

impl MpiArgs {
    pub fn deadlines(&self) -> Result<Deadlines> {
        let seconds = |flag: &str, v: f64| {
            if !(v.is_finite() && v > 0.0) {
                anyhow::bail!("--{flag} {v}: give a number of seconds above 0");
            }
            Ok(Duration::from_secs_f64(v))
        };
        Ok(Deadlines {
            work: seconds("deadline", self.deadline)?,
            setup: seconds("setup-deadline", self.setup_deadline)?,
        })
    }
}

/// Joins the job: `Some(cluster)` on rank 0, which leads; on a worker rank, traces on the
/// device the arguments name (its path `backend`) until rank 0 ends the job, then `None`.
pub fn join(backend: irt::gpu::device::Backend, device: &super::args::DeviceArgs) -> Result<Option<Cluster>> {
    let cluster = Cluster::join()?;
    if cluster.rank() == 0 {
        return Ok(Some(cluster));
    }
    share_the_cores(cluster.size());
    let words = |e: anyhow::Error| format!("{e:#}");
    match backend {
        irt::gpu::device::Backend::Wgpu => {
            worker::run(&cluster, || super::open_device(device).map_err(words))
        }
        irt::gpu::device::Backend::Ash => {
            worker::run(&cluster, || super::open_vk_device(device, Default::default()).map_err(words))
        }
    }
    Ok(None)
}

/// Lavapipe starts a thread per core in every process: each worker rank of this machine takes
/// its share instead, unless LP_NUM_THREADS is set.
pub fn share_the_cores(ranks: i32) {
    if std::env::var_os("LP_NUM_THREADS").is_some() {
        return;
    }
    // The ranks on this node: Open MPI and MPICH say; else every rank of the job.
    let local = ["OMPI_COMM_WORLD_LOCAL_SIZE", "MPI_LOCALNRANKS"]
        .iter()
        .find_map(|v| std::env::var(v).ok()?.parse::<usize>().ok())
        .unwrap_or(ranks as usize);
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    // Rank 0 leads and traces nothing: the workers share the cores.
    let share = (cores / local.saturating_sub(1).max(1)).max(1);
    std::env::set_var("LP_NUM_THREADS", share.to_string());
}
