//! Rank 0: the paper's master. It holds the scene and sends it once, keeps the state
//! (camera, settings, time) and sends it as it changes, hands out work on demand — chunks of a
//! conventional frame's tiles from the schedule, or slices of the frameless pixel order — with a
//! few pieces in flight per worker to hide the round trip, and writes what comes back into its
//! frame buffer ([`HostFrame`]). A worker that does not answer a piece within the deadline is
//! named and the job ends.

use super::cluster::{say, Cluster};
use super::wire::{build_id, Hello, Piece, Pixels, Ready, SceneMsg, SharedFile, State, Tag, Work, PROTOCOL};
use crate::render::frame::HostFrame;
use crate::render::modes::{chunk_pixels, frameless_sample, resolve_sample, Slices};
use crate::render::order::{order_pixels, Dissolve, PixelOrder};
use crate::render::pieces::split_settings;
use crate::render::schedule::tile_grid;
use crate::render::{Mode, RenderError, Schedule, Settings, StepReport};
use crate::scene::{Camera, Scene};
use std::collections::{BTreeMap, VecDeque};
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// Pieces of work each worker holds at once: one traced, the next already there when it is done.
pub const IN_FLIGHT: usize = 2;

/// How long rank 0 waits for a worker before it names it and ends the job.
#[derive(Clone, Copy, Debug)]
pub struct Deadlines {
    /// For each piece of work handed out: a chunk or slice takes milliseconds on lavapipe, a
    /// stall of many seconds is a dead rank, not a slow one.
    pub work: Duration,
    /// For opening the device and setting the scene up (its accelerator included: a
    /// 16M-triangle BVH takes a minute on one core).
    pub setup: Duration,
}

impl Default for Deadlines {
    fn default() -> Self {
        Deadlines { work: Duration::from_secs(30), setup: Duration::from_secs(600) }
    }
}

/// What setting the job up can fail with (each names the rank).
#[derive(Debug, thiserror::Error)]
pub enum MasterError {
    #[error("rank {rank} runs {theirs}, rank 0 runs {ours}: start every rank from the same irt build")]
    Version { rank: i32, theirs: String, ours: String },
    #[error("rank {rank} could not open a device: {why}")]
    Device { rank: i32, why: String },
    #[error("rank {rank} could not set the scene up: {why}")]
    Scene { rank: i32, why: String },
    #[error("rank {rank} said nothing for {seconds:.0} s while {doing}")]
    Silent { rank: i32, seconds: f64, doing: String },
    #[error("rank {rank} sent a {what} message where none was expected")]
    Protocol { rank: i32, what: &'static str },
    #[error("the scene cannot be sent: {0}")]
    Encode(#[from] crate::io::toml_write::TextureError),
    #[error("the scene cannot be sent: {0}")]
    Unsendable(String),
    #[error("{path}: {why} (rank 0 reads it to send it to the workers)")]
    File { path: PathBuf, why: String },
    #[error("{0} with --mpi: the ranks do not split it (drop one of them)")]
    Unsupported(&'static str),
    #[error(transparent)]
    Wire(#[from] super::wire::WireError),
    #[error(transparent)]
    Render(#[from] RenderError),
}

/// One worker as the master sees it.
struct Worker {
    rank: i32,
    device: String,
    /// Pieces sent and not returned, oldest first, with when they were sent.
    out: VecDeque<(Work, Instant)>,
}

/// The conventional frame being assembled.
struct Frame {
    state: u64,
    sample: u32,
    /// The schedule's chunk boundaries over the frame's tiles.
    chunks: Vec<u32>,
    next: usize,
    returned: usize,
    values: Vec<[f32; 3]>,
}

/// A piece that reached the frame buffer in a pump, for measuring pixel age and latency as one
/// process does (src/render/replay.rs): which state it was traced with and how much of the
/// screen it covers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Applied {
    /// The state version the workers traced it with ([`Master::version`]).
    pub state: u64,
    /// Frameless: positions of the pixel order (a pass is [`Master::pass_len`] of them);
    /// conventional: the frame's pixels.
    pub positions: u64,
    /// A whole conventional frame (else a frameless slice).
    pub frame: bool,
}

/// What the master hands out.
enum Plan {
    Frames(Option<Frame>),
    Slices { slices: Slices, table: Option<Vec<u32>> },
}

pub struct Master<'a> {
    cluster: &'a Cluster,
    workers: Vec<Worker>,
    deadline: Duration,
    state: State,
    frame: HostFrame,
    plan: Plan,
    next_id: u64,
    /// Pieces back before an earlier one, by id: results are applied in the order the pieces
    /// were handed out, the order one process traces them in, so that the picture is the same
    /// bit for bit (a frameless pixel's blend depends on the visits before it).
    early: BTreeMap<u64, (Work, Pixels)>,
    /// The id of the next piece to apply.
    next_apply: u64,
    /// Samples complete since the last change.
    samples: u32,
    /// The most shader loop iterations a returned pixel ran (lavapipe's limit).
    pub max_loop_iterations: u32,
    /// What reached the frame buffer since [`Master::pump_applied`] last returned it.
    applied: Vec<Applied>,
}

impl<'a> Master<'a> {
    /// Greets the workers, checks their builds and devices, sends the scene and the first state
    /// (`scene`'s camera, `settings`) and waits until every worker has set it up.
    pub fn start(
        cluster: &'a Cluster,
        scene: &Scene,
        settings: Settings,
        deadlines: Deadlines,
    ) -> Result<Master<'a>, MasterError> {
        let settings = split_settings(settings).map_err(MasterError::Unsupported)?;
        let mut workers = Vec::new();
        let ours = build_id();
        let setup = deadlines.setup;
        for _ in 1..cluster.size() {
            let (rank, bytes) = expect(cluster, Tag::Hello, setup, "opening its device", None)?;
            let hello = Hello::decode(&bytes)?;
            if hello.protocol != PROTOCOL || hello.version != ours {
                return Err(MasterError::Version { rank, theirs: hello.version, ours });
            }
            let device = hello.device.map_err(|why| MasterError::Device { rank, why })?;
            workers.push(Worker { rank, device, out: VecDeque::new() });
        }
        workers.sort_by_key(|w| w.rank);
        let out = Outgoing::new(scene)?;
        let state = State { version: 1, camera: scene.camera.clone(), settings, time: 0.0 };
        for w in &workers {
            // A rank stopped before it took its first message would hold rank 0 in the send.
            cluster.send_within(w.rank, Tag::Scene, &out.msg, setup, "sending the scene");
            cluster.send_within(w.rank, Tag::State, &state.encode(), setup, "sending the first state");
        }
        let mut ready = 0;
        while ready < workers.len() {
            let (rank, bytes) = expect(cluster, Tag::Ready, setup, "setting the scene up", None)?;
            ready += out.settle(cluster, rank, Ready::decode(&bytes)?, setup)? as usize;
        }
        let (w, h) = (scene.camera.width, scene.camera.height);
        let mut m = Master {
            cluster,
            workers,
            deadline: deadlines.work,
            frame: HostFrame::new(w, h),
            plan: Plan::Frames(None),
            state,
            next_id: 0,
            early: BTreeMap::new(),
            next_apply: 0,
            samples: 0,
            max_loop_iterations: 0,
            applied: Vec::new(),
        };
        m.restart()?;
        let kib = out.msg.len().div_ceil(1024);
        let files = match (out.files.len(), out.sent.get()) {
            (0, _) => String::new(),
            (n, 0) => format!("; every worker read its {n} file(s) itself"),
            (_, b) => format!("; {:.1} MB of files sent", b as f64 / 1e6),
        };
        say(
            0,
            &format!(
                "{} workers ready on {}; scene sent ({kib} KiB{files}), tracing",
                m.workers.len(),
                m.device_summary()
            ),
        );
        Ok(m)
    }

    /// The workers' devices in a few words: one name when they all have the same device.
    pub fn device_summary(&self) -> String {
        match self.workers.as_slice() {
            [first, rest @ ..] if rest.iter().all(|w| w.device == first.device) => first.device.clone(),
            _ => self
                .workers
                .iter()
                .map(|w| format!("rank {}: {}", w.rank, w.device))
                .collect::<Vec<_>>()
                .join("; "),
        }
    }

    /// Worker ranks.
    pub fn workers(&self) -> usize {
        self.workers.len()
    }

    pub fn frame(&self) -> &HostFrame {
        &self.frame
    }

    pub fn settings(&self) -> &Settings {
        &self.state.settings
    }

    pub fn camera(&self) -> &Camera {
        &self.state.camera
    }

    /// The version of the current state: 1 at the start, one more at each change.
    pub fn version(&self) -> u64 {
        self.state.version
    }

    /// Positions of a frameless pass of the pixel order (the dissolve's include values past the
    /// image), or the pixels of a conventional frame: the screen [`Applied::positions`] fill.
    pub fn pass_len(&self) -> u64 {
        let pixels = self.state.camera.width as u64 * self.state.camera.height as u64;
        match &self.plan {
            Plan::Slices { table: Some(t), .. } => t.len() as u64,
            Plan::Slices { table: None, .. } => Dissolve::new(pixels).period(),
            Plan::Frames(_) => pixels,
        }
    }

    /// Samples since the last change: conventional frames assembled, frameless visits handed
    /// out.
    pub fn samples(&self) -> u32 {
        match &self.plan {
            Plan::Slices { slices, .. } => slices.visit(),
            Plan::Frames(_) => self.samples,
        }
    }

    /// The samples refinement stops at (0: never).
    fn max_samples(&self) -> u32 {
        match self.state.settings.mode {
            Mode::Bands => 1,
            _ => self.state.settings.max_samples,
        }
    }

    /// Refinement reached its sample limit: every piece is handed out (some may be on their
    /// way back).
    pub fn converged(&self) -> bool {
        let max = self.max_samples();
        max > 0
            && match &self.plan {
                Plan::Frames(f) => f.is_none() && self.samples >= max,
                Plan::Slices { slices, .. } => slices.visit() >= max,
            }
    }

    /// Converged, and every piece is back: the picture is final.
    pub fn done(&self) -> bool {
        self.converged() && self.workers.iter().all(|w| w.out.is_empty())
    }

    /// A new camera, settings or time: sent to every worker as the next state, and the work
    /// handed out from now on traces it (a conventional frame in flight is cancelled).
    pub fn set_state(&mut self, camera: &Camera, settings: &Settings, time: f64) -> Result<(), MasterError> {
        let (w, h) = (camera.width, camera.height);
        let changed =
            *camera != self.state.camera || *settings != self.state.settings || time != self.state.time;
        if !changed {
            return Ok(());
        }
        self.state = State {
            version: self.state.version + 1,
            camera: camera.clone(),
            settings: settings.clone(),
            time,
        };
        for wk in &self.workers {
            self.cluster.send(wk.rank, Tag::State, &self.state.encode());
        }
        if [w, h] != [self.frame.width, self.frame.height] {
            self.frame = HostFrame::new(w, h);
        }
        self.restart()
    }

    /// A new scene (a live edit in the window; its camera is ignored): sent to every worker,
    /// which sets it up anew and says so, then a new state, so that work traced on the old
    /// scene is dropped. Pixels that arrive meanwhile are taken as usual. There is no smaller
    /// message for an edit: the scene is what the workers hold.
    pub fn set_scene(&mut self, scene: &Scene, deadline: Duration) -> Result<(), MasterError> {
        let out = Outgoing::new(scene)?;
        self.state.version += 1;
        for w in &self.workers {
            self.cluster.send_within(w.rank, Tag::Scene, &out.msg, deadline, "sending an edited scene");
            self.cluster.send_within(w.rank, Tag::State, &self.state.encode(), deadline, "sending its state");
        }
        let mut ready = 0;
        let start = Instant::now();
        while ready < self.workers.len() {
            let left = deadline.saturating_sub(start.elapsed());
            let Some((rank, tag, bytes)) = self.cluster.receive_within(left) else {
                let rank = self.workers.first().map_or(-1, |w| w.rank);
                let seconds = start.elapsed().as_secs_f64();
                return Err(MasterError::Silent {
                    rank,
                    seconds,
                    doing: "setting an edited scene up".into(),
                });
            };
            if tag == Tag::Pixels.code() {
                let px = Pixels::decode(&bytes)?;
                self.take(rank, px, &mut StepReport::default())?;
            } else if tag == Tag::Ready.code() {
                ready += out.settle(self.cluster, rank, Ready::decode(&bytes)?, deadline)? as usize;
            } else {
                return Err(MasterError::Protocol { rank, what: "out-of-turn" });
            }
        }
        // Pieces handed out before the edit are still on their way; their work restarts.
        self.restart()
    }

    /// Refinement starts again with the current state (the frame buffer keeps its pixels: the
    /// first new sample of each replaces it).
    fn restart(&mut self) -> Result<(), MasterError> {
        self.samples = 0;
        let [w, h] = [self.state.camera.width, self.state.camera.height];
        self.plan = match self.state.settings.mode {
            Mode::Frameless { order: PixelOrder::Adaptive { .. }, .. } => {
                // Its slices follow the samples as they come back, one slice after another:
                // not yet dealt to ranks.
                return Err(RenderError::Mode(
                    "--order adaptive runs in one process; with --mpi use hilbert, random or dissolve",
                )
                .into());
            }
            Mode::Frameless { order, .. } => {
                let (slices, _) = Slices::new(order, [w, h]).map_err(RenderError::from)?;
                let table = order.table(w, h);
                Plan::Slices { slices, table }
            }
            _ => Plan::Frames(None),
        };
        Ok(())
    }

    /// Hands out work until every worker holds [`IN_FLIGHT`] pieces, takes in what has come
    /// back, and checks the deadline: one turn of the master's loop, never blocking longer than
    /// `wait` for a message.
    pub fn pump(&mut self, wait: Duration) -> Result<StepReport, MasterError> {
        self.pump_applied(wait).map(|(report, _)| report)
    }

    /// [`Master::pump`], and the pieces that reached the frame buffer in it, in the order they
    /// were applied.
    pub fn pump_applied(&mut self, wait: Duration) -> Result<(StepReport, Vec<Applied>), MasterError> {
        self.applied.clear();
        self.deal()?;
        let mut report = StepReport { camera_version: self.state.version, ..Default::default() };
        let t = Instant::now();
        if let Some((rank, tag, bytes)) = self.cluster.receive_within(wait) {
            if tag != Tag::Pixels.code() {
                return Err(MasterError::Protocol { rank, what: "non-pixel" });
            }
            let px = Pixels::decode(&bytes)?;
            self.take(rank, px, &mut report)?;
            self.deal()?;
        }
        report.trace_time = t.elapsed();
        report.idle = self.done();
        self.check_deadline()?;
        Ok((report, std::mem::take(&mut self.applied)))
    }

    fn check_deadline(&self) -> Result<(), MasterError> {
        for w in &self.workers {
            if let Some((work, sent)) = w.out.front() {
                if sent.elapsed() > self.deadline {
                    return Err(MasterError::Silent {
                        rank: w.rank,
                        seconds: sent.elapsed().as_secs_f64(),
                        doing: describe(work),
                    });
                }
            }
        }
        Ok(())
    }

    /// The next piece for a worker, if the plan has one.
    fn next_piece(&mut self) -> Option<(Piece, u32)> {
        let workers = self.workers.len() as u32;
        let [w, h] = [self.state.camera.width, self.state.camera.height];
        let max = self.max_samples();
        match &mut self.plan {
            Plan::Frames(frame) => {
                if frame.is_none() {
                    if max > 0 && self.samples >= max {
                        return None;
                    }
                    let [tx, ty] = tile_grid(w, h);
                    let (schedule, p) = match self.state.settings.mode {
                        Mode::Conventional { schedule, workers: p } => (schedule, p),
                        _ => (Schedule::default(), 0),
                    };
                    let p = if p == 0 { workers } else { p };
                    *frame = Some(Frame {
                        state: self.state.version,
                        sample: self.samples,
                        chunks: schedule.boundaries(tx * ty, p),
                        next: 0,
                        returned: 0,
                        values: vec![[0.0; 3]; w as usize * h as usize],
                    });
                }
                let f = frame.as_mut().expect("made above");
                // Every chunk handed out: the next frame waits for this one to come back.
                if f.next + 1 >= f.chunks.len() {
                    return None;
                }
                let piece = Piece::Tiles { first: f.chunks[f.next], end: f.chunks[f.next + 1] };
                f.next += 1;
                Some((piece, f.sample))
            }
            Plan::Slices { slices, .. } => {
                if max > 0 && slices.visit() >= max {
                    return None;
                }
                let Mode::Frameless { slice, .. } = self.state.settings.mode else { return None };
                let span = slices.next_span(slice);
                let visit = slices.visit();
                slices.advance(span);
                Some((Piece::Slice { first: span.first, len: span.len }, visit))
            }
        }
    }

    fn deal(&mut self) -> Result<(), MasterError> {
        for i in 0..self.workers.len() {
            while self.workers[i].out.len() < IN_FLIGHT {
                let Some((piece, sample)) = self.next_piece() else { return Ok(()) };
                let work = Work { id: self.next_id, state: self.state.version, sample, piece };
                self.next_id += 1;
                self.cluster.send(self.workers[i].rank, Tag::Work, &work.encode());
                self.workers[i].out.push_back((work, Instant::now()));
            }
        }
        Ok(())
    }

    /// Pixels back from `rank`: applied now if every earlier piece is, else kept until it is.
    fn take(&mut self, rank: i32, px: Pixels, report: &mut StepReport) -> Result<(), MasterError> {
        let w = self
            .workers
            .iter_mut()
            .find(|w| w.rank == rank)
            .ok_or(MasterError::Protocol { rank, what: "pixel" })?;
        let Some(at) = w.out.iter().position(|(work, _)| work.id == px.id) else {
            return Err(MasterError::Protocol { rank, what: "unasked-for pixel" });
        };
        let (work, _) = w.out.remove(at).expect("found");
        self.max_loop_iterations = self.max_loop_iterations.max(px.max_loop_iterations);
        self.early.insert(work.id, (work, px));
        while let Some((work, px)) = self.early.remove(&self.next_apply) {
            self.next_apply += 1;
            self.apply(work, px, report);
        }
        Ok(())
    }

    /// A piece's pixels into the frame being assembled, or into the frame buffer.
    fn apply(&mut self, work: Work, px: Pixels, report: &mut StepReport) {
        let [width, height] = [self.frame.width, self.frame.height];
        let current = work.state == self.state.version;
        match (&mut self.plan, work.piece) {
            (Plan::Frames(frame), Piece::Tiles { first, end }) => {
                // A cancelled frame's pieces are dropped.
                let Some(f) = frame.as_mut().filter(|f| f.state == work.state && current) else { return };
                let [columns, _] = tile_grid(width, height);
                for (p, v) in chunk_pixels(first..end, columns, width, height).zip(&px.values) {
                    f.values[p as usize] = *v;
                }
                f.returned += 1;
                report.eye_rays += px.values.len() as u64;
                if f.returned + 1 == f.chunks.len() {
                    let s = resolve_sample(f.sample);
                    for (i, v) in f.values.iter().enumerate() {
                        self.frame.update(i, *v, &s);
                    }
                    self.samples += 1;
                    report.pixels = f.values.len() as u64;
                    report.frame_done = true;
                    let positions = f.values.len() as u64;
                    self.applied.push(Applied { state: f.state, positions, frame: true });
                    *frame = None;
                }
            }
            (Plan::Slices { table, .. }, Piece::Slice { first, len }) => {
                let Mode::Frameless { blend, jitter_pairs, .. } = self.state.settings.mode else { return };
                // A slice traced before the last change replaces what it lands on: its sample
                // does not belong to the refinement of the new state.
                let visit = if current { work.sample } else { 0 };
                let s = frameless_sample(visit, blend, jitter_pairs);
                let pixels = (width * height) as u64;
                let positions = order_pixels(table.as_deref(), first, len, pixels);
                for (p, v) in positions.zip(&px.values) {
                    if let Some(p) = p {
                        self.frame.update(p as usize, *v, &s);
                        report.pixels += 1;
                    }
                }
                report.eye_rays += px.values.len() as u64;
                self.applied.push(Applied { state: work.state, positions: len, frame: false });
                let pass = if table.is_some() { pixels } else { Dissolve::new(pixels).period() };
                report.frame_done = (first + len) % pass == 0;
            }
            _ => {}
        }
    }

    /// Every worker is told the job is over, once the pieces still out are back (the window
    /// may close mid-frame): a worker sending a large result waits for rank 0 to take it, and
    /// would never read the bye. A worker silent past the work deadline is not waited for.
    pub fn finish(mut self) {
        let start = Instant::now();
        while self.workers.iter().any(|w| !w.out.is_empty()) && start.elapsed() < self.deadline {
            if let Some((rank, tag, bytes)) = self.cluster.receive_within(Duration::from_millis(50)) {
                if let (true, Ok(px)) = (tag == Tag::Pixels.code(), Pixels::decode(&bytes)) {
                    let _ = self.take(rank, px, &mut StepReport::default());
                }
            }
        }
        for w in &self.workers {
            self.cluster.send(w.rank, Tag::Bye, &[]);
        }
    }

    /// Ends the job: `e` on stderr, every rank stopped.
    pub fn abort(&self, e: &MasterError) -> ! {
        self.cluster.abort(&e.to_string())
    }
}

/// A piece of work in words, for the message that names a silent rank.
fn describe(w: &Work) -> String {
    match w.piece {
        Piece::Tiles { first, end } => format!("tracing tiles {first}..{end} (sample {})", w.sample),
        Piece::Slice { first, len } => {
            format!("tracing positions {first}..{} of the pixel order (visit {})", first + len, w.sample)
        }
    }
}

/// The next message of kind `tag` from any worker (or from `from`), within `wait`.
fn expect(
    cluster: &Cluster,
    tag: Tag,
    wait: Duration,
    doing: &str,
    from: Option<i32>,
) -> Result<(i32, Vec<u8>), MasterError> {
    let start = Instant::now();
    match cluster.receive_within(wait) {
        Some((rank, t, bytes)) if t == tag.code() && from.is_none_or(|f| f == rank) => Ok((rank, bytes)),
        Some((rank, _, _)) => Err(MasterError::Protocol { rank, what: "out-of-turn" }),
        None => {
            let rank = from.unwrap_or(-1);
            say(0, &format!("no rank answered within {:.0} s while {doing}", start.elapsed().as_secs_f64()));
            Err(MasterError::Silent { rank, seconds: start.elapsed().as_secs_f64(), doing: doing.into() })
        }
    }
}

/// The scene as every worker receives it, and the files it names that a worker may ask for.
struct Outgoing {
    msg: Vec<u8>,
    hash: u64,
    files: Vec<(SharedFile, PathBuf)>,
    /// The bytes of files sent so far, to every worker that asked.
    sent: std::cell::Cell<u64>,
}

impl Outgoing {
    fn new(scene: &Scene) -> Result<Outgoing, MasterError> {
        // A volume's file goes like a particle file; a detached NRRD header names its data
        // file relative to itself, which a copy beside the scene would lose.
        for v in &scene.volumes {
            match &v.file {
                None => return Err(MasterError::Unsendable("it holds a volume made in code, with no file to send".into())),
                Some(f) if f.extension().is_some_and(|e| e.eq_ignore_ascii_case("nhdr")) => {
                    return Err(MasterError::Unsendable(format!(
                        "volume {} is a detached NRRD header, whose data file MPI ranks are not sent: give it as one .nrrd",
                        f.display()
                    )))
                }
                Some(_) => {}
            }
        }
        let (files, beside) = crate::io::toml_write::to_files_beside(scene, "scene")?;
        let shared = beside
            .into_iter()
            .map(|(name, path)| {
                let start = Instant::now();
                let (len, digest) = super::files::file_digest(&path)
                    .map_err(|e| MasterError::File { path: path.clone(), why: e.to_string() })?;
                let (mb, s) = (len as f64 / 1e6, start.elapsed().as_secs_f64());
                log::info!("{}: {mb:.1} MB, digest {digest:016x} in {s:.2} s", path.display());
                Ok((SharedFile { name, path: path.display().to_string(), len, digest }, path))
            })
            .collect::<Result<Vec<_>, MasterError>>()?;
        let files = SceneMsg {
            toml: files.toml,
            textures: files.textures,
            files: shared.iter().map(|(f, _)| f.clone()).collect(),
            hash: 0,
        };
        let hash = files.content_hash();
        Ok(Outgoing {
            msg: SceneMsg { hash, ..files }.encode(),
            hash,
            files: shared,
            sent: Default::default(),
        })
    }

    /// A worker's [`Ready`]: `true` once it holds this scene. The files it cannot read are
    /// sent (`false`: it says it is ready once they are in).
    /// A rank that stops taking a file for `deadline` ends the job.
    fn settle(
        &self,
        cluster: &Cluster,
        rank: i32,
        ready: Ready,
        deadline: Duration,
    ) -> Result<bool, MasterError> {
        if let Some(why) = ready.error {
            return Err(MasterError::Scene { rank, why });
        }
        for (i, why) in &ready.need {
            let Some((f, path)) = self.files.get(*i as usize) else {
                return Err(MasterError::Protocol { rank, what: "ready" });
            };
            let start = Instant::now();
            super::files::send(cluster, rank, *i, f, path, deadline)
                .map_err(|e| MasterError::File { path: path.clone(), why: e.to_string() })?;
            let (mb, s) = (f.len as f64 / 1e6, start.elapsed().as_secs_f64());
            say(0, &format!("rank {rank} cannot read {why}: sent it the file ({mb:.1} MB in {s:.2} s)"));
            self.sent.set(self.sent.get() + f.len);
        }
        if !ready.need.is_empty() {
            return Ok(false);
        }
        if ready.hash != self.hash {
            let why = format!("it holds scene {:016x}, rank 0 sent {:016x}", ready.hash, self.hash);
            return Err(MasterError::Scene { rank, why });
        }
        Ok(true)
    }
}

/// A picture the workers traced.
pub struct Rendered {
    pub image: crate::image::Image,
    pub workers: usize,
    /// Their devices, in a few words ([`Master::device_summary`]).
    pub devices: String,
    /// From the first greeting to every worker holding the scene (devices opened, scene sent,
    /// accelerators built).
    pub setup: Duration,
    /// From then to the last pixel back.
    pub trace: Duration,
    /// Rank 0's traffic during `trace` (the scene's bytes are in setup's).
    pub traffic: super::cluster::Traffic,
    /// Rank 0's CPU time during `trace`: how much of a core leading takes.
    pub cpu: Duration,
}

/// This process's CPU time so far (user and system).
fn cpu_time() -> Duration {
    // SAFETY: getrusage writes the struct it is given and nothing else.
    let mut u: libc::rusage = unsafe { std::mem::zeroed() };
    unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut u) };
    let tv = |t: libc::timeval| Duration::new(t.tv_sec as u64, t.tv_usec as u32 * 1000);
    tv(u.ru_utime) + tv(u.ru_stime)
}

/// `irt render --mpi` on rank 0: the workers trace one picture (`settings.max_samples` samples
/// in the interactive modes; one for the bands, whose picture is traced as conventional tiles);
/// the image is what one process writes, bit for bit.
pub fn render(
    cluster: &Cluster,
    scene: &Scene,
    settings: Settings,
    deadlines: Deadlines,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<Rendered, MasterError> {
    let t = Instant::now();
    let mut m = Master::start(cluster, scene, settings, deadlines)?;
    let (workers, devices) = (m.workers.len(), m.device_summary());
    let (setup, traffic, cpu, t) = (t.elapsed(), cluster.traffic(), cpu_time(), Instant::now());
    let total =
        (scene.camera.width as u64 * scene.camera.height as u64) * m.state.settings.max_samples.max(1) as u64;
    let mut done = 0;
    while !m.done() {
        let r = m.pump(Duration::from_millis(50))?;
        done += r.eye_rays;
        progress(done.min(total), total);
    }
    let (trace, traffic, cpu) = (t.elapsed(), cluster.traffic() - traffic, cpu_time() - cpu);
    let image = m.frame.image();
    m.finish();
    Ok(Rendered { image, workers, devices, setup, trace, traffic, cpu })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The dissolve's positions name every pixel once and skip the values past the image, as
    /// the shader's slice does.
    #[test]
    fn dissolve_positions_name_every_pixel_once() {
        let pixels = 37 * 11;
        let period = Dissolve::new(pixels).period();
        let mut seen = vec![0; pixels as usize];
        for first in (0..period).step_by(50) {
            let len = 50.min(period - first);
            for p in order_pixels(None, first, len, pixels).flatten() {
                seen[p as usize] += 1;
            }
        }
        assert!(seen.iter().all(|&c| c == 1));
    }
}
