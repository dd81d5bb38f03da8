//! A large scene's BVH built on another thread while a viewer traces its grid, and adopted once
//! built (the pictures are the same; the frames get faster).

use super::RenderError;
use super::Settings;
use crate::accel::bvh::BvhInput;
use crate::accel::{AccelChoice, AccelKind, AccelRef, Bvh, BvhWalk};
use crate::gpu::layout;
use crate::scene::Scene;
use glam::DVec3;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// Past this many primitives an interactive session whose `auto` accelerator is the BVH first
/// traces the grid (built several times faster) while the BVH builds on another thread, so that
/// the first frames do not wait for it (docs/large-models.md, "Which accelerator").
pub const BACKGROUND_BVH_ABOVE: usize = 1 << 20;

/// How [`super::Session::adopt_bvh`] put the BVH on the device.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Adoption {
    /// Only its section of the scene texture was written (the rest is the grid's packing).
    SectionWritten,
    /// The whole scene was packed and uploaded again (shell shadows, or a texture too small).
    ScenePacked,
}

/// Whether a viewer's session over `scene` (posed from `base`, with `settings` applied) traces
/// the grid while its BVH builds on another thread: `auto` picks the BVH and the scene is past
/// [`BACKGROUND_BVH_ABOVE`] primitives.
pub(super) fn builds_bvh_in_background(settings: &Settings, base: &Scene, scene: &Scene) -> bool {
    settings.accel == AccelChoice::Auto
        && settings.accel.resolve(base) == AccelKind::Bvh(BvhWalk::Stackless)
        && scene.primitive_count() > BACKGROUND_BVH_ABOVE
}

/// A BVH being built on its own thread, ordered towards `eye`, and its section of the scene
/// texture packed there too. Dropped (the scene's geometry was edited, or the session closed),
/// it tells the build to stop.
pub(super) struct PendingBvh {
    handle: Option<std::thread::JoinHandle<Option<(Bvh, layout::AccelSection)>>>,
    pub eye: DVec3,
    cancel: Arc<AtomicBool>,
}

impl PendingBvh {
    /// Starts building `scene`'s BVH, ordered towards its eye, and packing it for a scene packed
    /// relative to `origin`.
    pub fn start(scene: &Scene, origin: DVec3) -> Result<PendingBvh, RenderError> {
        let (input, eye) = (BvhInput::of(scene), scene.camera.eye);
        let cancel = Arc::new(AtomicBool::new(false));
        let flag = cancel.clone();
        let build = move || {
            let bvh = input.build_unless(&flag)?.ordered_towards(eye);
            let section = layout::pack_accel(AccelRef::Bvh(&bvh, BvhWalk::Stackless), origin);
            Some((bvh, section))
        };
        let handle =
            std::thread::Builder::new().name("irt-bvh".into()).spawn(build).map_err(RenderError::Thread)?;
        Ok(PendingBvh { handle: Some(handle), eye, cancel })
    }

    pub fn is_finished(&self) -> bool {
        self.handle.as_ref().is_none_or(|h| h.is_finished())
    }

    /// The BVH and its packed section, once built (waits for the thread).
    pub fn take(&mut self) -> Result<(Bvh, layout::AccelSection), RenderError> {
        let built = self.handle.take().ok_or(RenderError::BvhBuild("it was taken already"))?.join();
        built
            .map_err(|_| RenderError::BvhBuild("its thread panicked"))?
            .ok_or(RenderError::BvhBuild("it was cancelled"))
    }
}

impl Drop for PendingBvh {
    fn drop(&mut self) {
        self.cancel.store(true, Ordering::Relaxed);
    }
}
