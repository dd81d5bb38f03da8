//! Ranks 1..N: a worker is the session the window drives, fed by messages. It opens its own
//! device, says hello, receives the scene once (checked by its hash), opens a session with the
//! first state, and then traces what the master hands out — tiles of a conventional frame or
//! slices of the frameless order — always with the newest state it has, until the master says
//! bye.

use super::cluster::{say, Cluster};
use super::files::{Arrival, FileError};
use super::wire::{build_id, FilePart, Hello, Piece, Pixels, Ready, SceneMsg, State, Tag, Work, PROTOCOL};
use crate::gpu::device::Device;
use crate::render::{RenderError, Session, SliceSpan};
use crate::scene::Scene;
use std::time::Duration;

/// How long a worker waits for the master's next word before it stops waiting: a master that
/// died leaves the job to mpirun, which ends it; this only bounds a hang.
const MASTER_SILENCE: Duration = Duration::from_secs(3600);

/// Runs this rank as a worker on the device `open` gives (or the message of why it could not
/// be opened, which the master reports and ends the job with).
pub fn run<D: Device>(cluster: &Cluster, open: impl FnOnce() -> Result<D, String>) {
    let rank = cluster.rank();
    let device = open();
    let hello = Hello {
        protocol: PROTOCOL,
        version: match crate::fault::armed("version") {
            true => format!("{}+another-build", build_id()),
            false => build_id(),
        },
        device: device
            .as_ref()
            .map(|d| format!("{} ({})", d.adapter_name(), d.adapter_driver()))
            .map_err(Clone::clone),
    };
    cluster.send(0, Tag::Hello, &hello.encode());
    let Ok(ctx) = device else { return wait_for_bye(cluster) };
    // The scene (and the hash it arrived with), then the first state: the session needs both.
    let mut scene: Option<(Scene, u64)> = None;
    // A scene whose shared files are still coming.
    let mut arriving: Option<Arrival> = None;
    let mut state: Option<State> = None;
    let mut session: Option<Session<D>> = None;
    loop {
        let Some((_, tag, bytes)) = cluster.receive_within(MASTER_SILENCE) else {
            say(rank, "the master has been silent for an hour: stopping");
            return;
        };
        match tag {
            t if t == Tag::Scene.code() => {
                (session, arriving) = (None, None);
                let arrived = begin(&bytes).and_then(|(a, need)| match need.is_empty() {
                    true => load(a).map(Some),
                    false => {
                        // Rank 0 sends what this rank cannot read; the scene loads when it is here.
                        cluster.send(0, Tag::Ready, &Ready { hash: a.msg.hash, error: None, need }.encode());
                        arriving = Some(a);
                        Ok(None)
                    }
                });
                match arrived {
                    Ok(loaded) => scene = loaded,
                    Err(ready) => {
                        cluster.send(0, Tag::Ready, &ready.encode());
                        return wait_for_bye(cluster);
                    }
                }
            }
            t if t == Tag::File.code() => {
                let part = FilePart::decode(&bytes).unwrap_or_else(|e| cluster.abort(&e.to_string()));
                let index = part.index;
                let Some(a) = arriving.as_mut() else {
                    cluster.abort(&FileError::Unexpected(index).to_string())
                };
                let hash = a.msg.hash;
                let taken =
                    a.take(part).map_err(|e| Ready { hash, error: Some(e.to_string()), need: vec![] });
                let loaded = match taken {
                    Ok(()) if a.complete() => arriving.take().map(load).transpose(),
                    Ok(()) => Ok(None),
                    Err(e) => Err(e),
                };
                match loaded {
                    Ok(loaded) => scene = loaded.or(scene),
                    Err(ready) => {
                        cluster.send(0, Tag::Ready, &ready.encode());
                        return wait_for_bye(cluster);
                    }
                }
            }
            t if t == Tag::State.code() => {
                let st = State::decode(&bytes).unwrap_or_else(|e| cluster.abort(&e.to_string()));
                if let Some(s) = &mut session {
                    apply_state(&ctx, s, &st, cluster);
                }
                state = Some(st);
            }
            t if t == Tag::Work.code() => {
                let work = Work::decode(&bytes).unwrap_or_else(|e| cluster.abort(&e.to_string()));
                if crate::fault::armed("panic") {
                    panic!("IRT_FAULT=panic: the fault injected at work {}", work.id);
                }
                let (Some(s), Some(st)) = (&mut session, &state) else {
                    cluster.abort("work arrived before the scene and state: the master broke the protocol")
                };
                let pixels = trace(&ctx, s, &work, st.version)
                    .unwrap_or_else(|e| cluster.abort(&format!("tracing work {}: {e}", work.id)));
                cluster.send(0, Tag::Pixels, &pixels.encode());
            }
            t if t == Tag::Bye.code() => return,
            t => cluster.abort(&format!("a message with tag {t} is not irt's")),
        }
        if let (None, Some(_), Some(st)) = (&session, &scene, &state) {
            // The session holds the scene from now on: a 35M-sphere scene is 1.1 GB a copy.
            let (sc, hash) = scene.take().expect("a scene");
            let opened = open_session(&ctx, sc, st);
            let ready = Ready { hash, error: opened.as_ref().err().map(|e| e.to_string()), need: vec![] };
            cluster.send(0, Tag::Ready, &ready.encode());
            match opened {
                Ok(s) => session = Some(s),
                Err(_) => return wait_for_bye(cluster),
            }
        }
    }
}

/// After a failed start: the master ends the job; until then nothing to do.
fn wait_for_bye(cluster: &Cluster) {
    while let Some((_, tag, _)) = cluster.receive_within(MASTER_SILENCE) {
        if tag == Tag::Bye.code() {
            return;
        }
    }
}

/// A [`SceneMsg`] checked by its hash and written into a private directory (no file system need
/// be shared with the master), with the shared files it still needs; or the [`Ready`] that says
/// why not.
fn begin(bytes: &[u8]) -> Result<(Arrival, Vec<(u32, String)>), Ready> {
    let fail = |hash, e: String| Ready { hash, error: Some(e), need: vec![] };
    let msg = SceneMsg::decode(bytes).map_err(|e| fail(0, e.to_string()))?;
    let hash = msg.content_hash();
    if hash != msg.hash {
        return Err(fail(
            hash,
            format!("the scene arrived with hash {hash:016x}, the master sent {:016x}", msg.hash),
        ));
    }
    let dir = std::env::temp_dir().join(format!("irt-rank-{}", std::process::id()));
    Arrival::begin(msg, dir, crate::fault::armed("unseen-files")).map_err(|e| fail(hash, e.to_string()))
}

/// The scene of a complete arrival, and its hash (its directory goes once it is loaded).
fn load(a: Arrival) -> Result<(Scene, u64), Ready> {
    let hash = a.msg.hash;
    crate::io::load(&a.toml()).map(|s| (s, hash)).map_err(|e| Ready {
        hash,
        error: Some(SetupError::Load(e).to_string()),
        need: vec![],
    })
}

/// Why a worker could not set the scene up; its words go back to the master in [`Ready`].
#[derive(Debug, thiserror::Error)]
enum SetupError {
    #[error(transparent)]
    Load(#[from] crate::io::LoadError),
    #[error("setting the scene up: {0}")]
    Session(RenderError),
    #[error("posing the scene at {0} s: {1}")]
    Pose(f64, RenderError),
}

/// A session of `scene` seen by the state's camera, with its settings and time: the same
/// origin, variant and accelerator as the master's own picture would have.
fn open_session<D: Device>(ctx: &D, mut s: Scene, st: &State) -> Result<Session<D>, SetupError> {
    s.camera = st.camera.clone();
    let mut session = Session::from_scene(ctx, s, st.settings.clone()).map_err(SetupError::Session)?;
    session.set_time(ctx, st.time).map_err(|e| SetupError::Pose(st.time, e))?;
    Ok(session)
}

/// A new state: settings, size, time and camera, each only if it changed.
fn apply_state<D: Device>(ctx: &D, s: &mut Session<D>, st: &State, cluster: &Cluster) {
    let applied = s
        .apply(ctx, st.settings.clone())
        .and_then(|()| s.set_size(ctx, st.camera.width, st.camera.height))
        .and_then(|()| s.set_time(ctx, st.time).map(|_| ()));
    if let Err(e) = applied {
        cluster.abort(&format!("applying state {}: {e}", st.version));
    }
    s.set_camera(ctx, &st.camera);
}

/// The pixels of `work`, traced with the session's state.
fn trace<D: Device>(ctx: &D, s: &mut Session<D>, work: &Work, state: u64) -> Result<Pixels, RenderError> {
    let (values, max) = match work.piece {
        Piece::Tiles { first, end } => s.try_trace_tiles(ctx, first..end, work.sample)?,
        Piece::Slice { first, len } => s.try_trace_slice(ctx, SliceSpan { first, len }, work.sample)?,
    };
    Ok(Pixels { id: work.id, state, max_loop_iterations: max, values })
}
