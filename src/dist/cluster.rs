//! The ranks of one job, over MPI (the `mpi` crate on the system's Open MPI or MPICH): who this
//! rank is, sending and receiving [`wire`](super::wire) records by tag, and ending the whole job
//! loudly. A panic in any rank aborts the job with the rank's message: unwinding would drop the
//! MPI universe, whose `MPI_Finalize` waits for the other ranks for ever.

use super::wire::Tag;
use std::cell::Cell;
use std::io::Write as _;
use std::time::Duration;

/// This process's place in the job.
pub struct Cluster {
    link: link::Link,
    rank: i32,
    size: i32,
    traffic: Cell<Traffic>,
}

/// Bytes and messages this rank sent and received (payloads, not MPI's envelopes).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Traffic {
    pub sent: u64,
    pub received: u64,
    pub messages_sent: u64,
    pub messages_received: u64,
}

impl std::ops::Sub for Traffic {
    type Output = Traffic;
    fn sub(self, o: Traffic) -> Traffic {
        Traffic {
            sent: self.sent - o.sent,
            received: self.received - o.received,
            messages_sent: self.messages_sent - o.messages_sent,
            messages_received: self.messages_received - o.messages_received,
        }
    }
}

/// What setting up the job can fail with.
#[derive(Debug, thiserror::Error)]
pub enum ClusterError {
    #[error("MPI was initialised already in this process")]
    Initialised,
    #[error(
        "irt --mpi runs as one rank per process under mpirun (e.g. `mpirun -n 3 irt render --mpi`); \
         this job has {0} rank: at least 2 are needed (rank 0 leads, the others trace)"
    )]
    TooFew(i32),
    #[error("this irt was built without MPI (`--no-default-features`): build it with the default features (scripts/setup.sh installs Open MPI)")]
    NotBuilt,
}

/// One line on stderr, written at once (the lines of several ranks interleave, their words do
/// not), prefixed with the rank.
pub fn say(rank: i32, line: &str) {
    let text = format!("irt rank {rank}: {line}\n");
    let _ = std::io::stderr().lock().write_all(text.as_bytes());
}

impl Cluster {
    /// Joins the job. Rank 0 leads; a job of one rank is refused (nothing would trace).
    pub fn join() -> Result<Cluster, ClusterError> {
        let (link, rank, size) = link::Link::join()?;
        std::panic::set_hook(Box::new(move |info| {
            say(rank, &format!("{}; ending the job", info.to_string().replace('\n', " ")));
            link::abort_world(101);
        }));
        if size < 2 {
            return Err(ClusterError::TooFew(size));
        }
        Ok(Cluster { link, rank, size, traffic: Cell::default() })
    }

    pub fn rank(&self) -> i32 {
        self.rank
    }

    /// Ranks in the job, this one included.
    pub fn size(&self) -> i32 {
        self.size
    }

    /// Sends `bytes` to rank `to` under `tag` (returns once the buffer may be reused).
    pub fn send(&self, to: i32, tag: Tag, bytes: &[u8]) {
        self.link.send(to, tag.code(), bytes);
        let mut t = self.traffic.get();
        t.sent += bytes.len() as u64;
        t.messages_sent += 1;
        self.traffic.set(t);
    }

    /// [`Cluster::send`] for a large message, which MPI hands over only as the receiver takes
    /// it: a rank that stops taking it (stopped, or stuck) for `deadline` is named with what the
    /// sender was `doing` and the job ends, rather than rank 0 waiting in the send for ever.
    pub fn send_within(&self, to: i32, tag: Tag, bytes: &[u8], deadline: Duration, doing: &str) {
        let timeout = || -> std::convert::Infallible {
            let s = deadline.as_secs_f64();
            self.abort(&format!("rank {to} took nothing for {s:.0} s while rank 0 was {doing}"))
        };
        self.link.send_within(to, tag.code(), bytes, deadline, timeout);
        let mut t = self.traffic.get();
        t.sent += bytes.len() as u64;
        t.messages_sent += 1;
        self.traffic.set(t);
    }

    /// The next message from any rank, if one has arrived: (from, tag, bytes).
    pub fn try_receive(&self) -> Option<(i32, i32, Vec<u8>)> {
        let m = self.link.try_receive()?;
        let mut t = self.traffic.get();
        t.received += m.2.len() as u64;
        t.messages_received += 1;
        self.traffic.set(t);
        Some(m)
    }

    /// What this rank has sent and received so far.
    pub fn traffic(&self) -> Traffic {
        self.traffic.get()
    }

    /// The next message from any rank, waiting for it at most `deadline`: first spinning, then
    /// sleeping a little longer each time (a fixed 200 µs sleep slowed a frame of small messages
    /// threefold; docs/distributed.md).
    pub fn receive_within(&self, deadline: Duration) -> Option<(i32, i32, Vec<u8>)> {
        let start = std::time::Instant::now();
        let mut nap = Duration::from_micros(1);
        loop {
            if let Some(m) = self.try_receive() {
                return Some(m);
            }
            if start.elapsed() > deadline {
                return None;
            }
            if start.elapsed() > Duration::from_micros(200) {
                std::thread::sleep(nap);
                nap = (nap * 2).min(Duration::from_micros(500));
            } else {
                std::hint::spin_loop();
            }
        }
    }

    /// Ends every rank of the job now, after `line` on stderr: how a failure anywhere is loud
    /// and never a hang.
    pub fn abort(&self, line: &str) -> ! {
        say(self.rank, line);
        link::abort_world(1)
    }
}

/// What speaks MPI (the `mpi` cargo feature).
#[cfg(feature = "mpi")]
mod link {
    use super::ClusterError;
    use mpi::topology::SimpleCommunicator;
    use mpi::traits::*;
    use std::time::{Duration, Instant};

    pub struct Link {
        _universe: mpi::environment::Universe,
        world: SimpleCommunicator,
    }

    impl Link {
        pub fn join() -> Result<(Link, i32, i32), ClusterError> {
            let universe = mpi::initialize().ok_or(ClusterError::Initialised)?;
            let world = universe.world();
            let (rank, size) = (world.rank(), world.size());
            Ok((Link { _universe: universe, world }, rank, size))
        }

        pub fn send(&self, to: i32, tag: i32, bytes: &[u8]) {
            self.world.process_at_rank(to).send_with_tag(bytes, tag);
        }

        /// An immediate send, tested until it completes or `deadline` passes (then `timeout`,
        /// which ends the job: a pending request must not outlive its scope).
        pub fn send_within(
            &self,
            to: i32,
            tag: i32,
            bytes: &[u8],
            deadline: Duration,
            timeout: impl FnOnce() -> std::convert::Infallible,
        ) {
            let start = Instant::now();
            mpi::request::scope(|scope| {
                let mut request = self.world.process_at_rank(to).immediate_send_with_tag(scope, bytes, tag);
                loop {
                    match request.test() {
                        Ok(_) => return,
                        Err(pending) => request = pending,
                    }
                    if start.elapsed() > deadline {
                        match timeout() {}
                    }
                    std::thread::sleep(Duration::from_micros(200));
                }
            })
        }

        pub fn try_receive(&self) -> Option<(i32, i32, Vec<u8>)> {
            let probed = self.world.any_process().immediate_matched_probe()?;
            let (bytes, status) = probed.matched_receive_vec::<u8>();
            Some((status.source_rank(), status.tag(), bytes))
        }
    }

    pub fn abort_world(code: i32) -> ! {
        SimpleCommunicator::world().abort(code)
    }
}

/// Built without MPI: joining fails with [`ClusterError::NotBuilt`], so no `Link` exists.
#[cfg(not(feature = "mpi"))]
mod link {
    use super::ClusterError;

    pub enum Link {}

    impl Link {
        pub fn join() -> Result<(Link, i32, i32), ClusterError> {
            Err(ClusterError::NotBuilt)
        }

        pub fn send(&self, _: i32, _: i32, _: &[u8]) {
            match *self {}
        }

        pub fn send_within(
            &self,
            _: i32,
            _: i32,
            _: &[u8],
            _: std::time::Duration,
            _: impl FnOnce() -> std::convert::Infallible,
        ) {
            match *self {}
        }

        pub fn try_receive(&self) -> Option<(i32, i32, Vec<u8>)> {
            match *self {}
        }
    }

    pub fn abort_world(code: i32) -> ! {
        std::process::exit(code)
    }
}
