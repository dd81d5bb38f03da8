//! What changes the scene a session holds on the device: a new time of its animation, an edit,
//! a BVH ordered towards a new eye, and the BVH built in the background adopted.

use super::background::{builds_bvh_in_background, Adoption, PendingBvh};
use super::session::{compile, Session};
use super::RenderError;
use crate::accel::{Accel, AccelKind, BvhWalk};
use crate::gpu::device::Device;
use crate::gpu::layout;
use crate::gpu::shaders::Variant;
use crate::scene::Scene;
use glam::DVec3;
use std::time::{Duration, Instant};

/// The eye moves this far, as a fraction of the scene's box diagonal, before a stackless BVH is
/// ordered towards it again ([`Session::reorder`]).
pub const REORDER_MOVE: f64 = 0.05;
/// A reordering that took longer than this waits for the camera to come to rest (one complete
/// frame or pass), so that dragging a large model does not stutter.
pub const REORDER_BUDGET: Duration = Duration::from_millis(8);

/// What replacing the scene's contents cost ([`Session::set_time`], [`Session::set_scene`]).
#[derive(Clone, Copy, Debug, Default)]
pub struct UpdateReport {
    /// Moving the objects to the new time.
    pub pose: Duration,
    /// Rebuilding the grid or BVH (`None`: no geometry changed, it was kept).
    pub accel: Option<Duration>,
    /// Packing the scene texture.
    pub pack: Duration,
    /// Writing it to the device (and compiling a new kernel, if `recompiled`).
    pub upload: Duration,
    /// The scene now needs a different shader variant (a material changed kind).
    pub recompiled: bool,
    /// The scene outgrew its texture, which was replaced (with a quarter more rows to spare).
    pub reallocated: bool,
    /// Only the frame uniform was written (volumes' isovalues or looks changed, nothing else).
    pub uniform_only: bool,
}

impl UpdateReport {
    pub fn total(&self) -> Duration {
        self.pose + self.accel.unwrap_or_default() + self.pack + self.upload
    }
}

/// Whether `scene` differs from `old` only in what the frame uniform holds of its volumes: their
/// isovalues (as many as before, with the same materials, which the texture holds) and looks.
fn uniform_only(scene: &Scene, old: &Scene) -> bool {
    if scene.volumes.is_empty() || scene.volumes.len() != old.volumes.len() {
        return false;
    }
    let mut same = scene.clone();
    for (v, o) in same.volumes.iter_mut().zip(&old.volumes) {
        if v.isos.len() != o.isos.len() || v.isos.iter().zip(&o.isos).any(|(a, b)| a.material != b.material) {
            return false;
        }
        v.isos.clone_from(&o.isos);
        v.look = o.look;
    }
    same == *old
}

impl<D: Device> Session<D> {
    /// Shows the scene at time `t` (seconds; clamped to its keys, see `scene::motion`): the
    /// moved objects are posed, the grid rebuilt and the texture rewritten, from the next step.
    /// Restarts refinement; frameless slices carry on over the old pixels. A still scene
    /// costs nothing.
    pub fn set_time(&mut self, ctx: &D, t: f64) -> Result<UpdateReport, RenderError> {
        self.time = t;
        if !self.base_scene().is_animated() {
            return Ok(UpdateReport::default());
        }
        let t0 = Instant::now();
        let posed = self.base_scene().at(t);
        let mut r = self.update(ctx, posed, true)?;
        r.pose = t0.elapsed() - r.accel.unwrap_or_default() - r.pack - r.upload;
        Ok(r)
    }

    /// Replaces what the scene holds (lights, materials, objects, motions; the camera stays the
    /// session's): an edit in the viewer. The grid is rebuilt only if geometry moved; a
    /// material of a new kind recompiles the kernel. Restarts refinement.
    pub fn set_scene(&mut self, ctx: &D, scene: &Scene) -> Result<UpdateReport, RenderError> {
        scene.validate()?;
        let base = Scene { camera: self.base_scene().camera.clone(), ..scene.clone() };
        self.animation = super::animation::Animation::of(&base);
        let posed = base.at(self.time);
        self.base = Some(base);
        self.update(ctx, posed, false)
    }

    /// Draws `posed` from the next step. `motion`: it differs from the scene traced now only by
    /// where the moving primitives are (a new time), so their cells can be updated alone.
    fn update(&mut self, ctx: &D, posed: Scene, motion: bool) -> Result<UpdateReport, RenderError> {
        // Keys can move objects past what f32 (or f64) holds; say so rather than trace NaNs.
        posed.validate().map_err(|e| RenderError::SceneAt { time: self.time, message: e.0 })?;
        let mut report = UpdateReport::default();
        let mut scene = Scene { camera: self.scene.camera.clone(), ..posed };
        self.settings.apply_to(&mut scene);
        if scene == self.scene {
            // Nothing changed (a time past the last key, an edit undone): keep refining.
            return Ok(report);
        }
        if !motion && uniform_only(&scene, &self.scene) {
            // A new isovalue or look: the frame uniform alone (PAPER.md §10: nothing rebuilt).
            let t = Instant::now();
            let mut params = self.gpu_scene.params;
            params.iso = layout::volume::iso_values(&scene);
            params.volume[2] = layout::volume::look_bits(&scene);
            ctx.set_params(&mut self.gpu_scene, params);
            report.upload = t.elapsed();
            report.uniform_only = true;
            self.scene = scene;
            self.restart();
            return Ok(report);
        }
        let moved = scene.spheres != self.scene.spheres
            || scene.cones != self.scene.cones
            || scene.meshes != self.scene.meshes;
        // An edit to a large scene that a viewer traces by a BVH built in the background: the
        // grid again at once (a BVH rebuild of a large scene would hold the window for seconds),
        // and a new BVH behind it. A new time (`motion`) updates the accelerator in place.
        let behind = moved
            && !motion
            && self.interactive
            && builds_bvh_in_background(&self.settings, self.base_scene(), &scene);
        if moved {
            // A BVH being built for the old geometry no longer fits: it is given up.
            self.pending = None;
            let t = Instant::now();
            self.accel = if behind {
                self.animation.first_accel(&scene, AccelKind::Grid, &|_, _| {})
            } else {
                self.reaccel(&scene, motion)
            };
            report.accel = Some(t.elapsed());
        }
        let t = Instant::now();
        let packed = layout::pack_scene(&scene, &self.accel, self.origin);
        self.prefix = if behind || self.pending.is_some() { packed.prefix() } else { None };
        let mut params = layout::params(&scene, &self.accel, &packed, self.origin);
        params.eye_grid = self.gpu_scene.params.eye_grid;
        report.pack = t.elapsed();
        let t = Instant::now();
        let new_texture = ctx.update_scene(&mut self.gpu_scene, packed, params)?;
        report.reallocated = new_texture;
        let variant = self.settings.variant(&scene);
        let layered = self.gpu_scene.layered();
        // The accelerator may have changed too (a background BVH given up for the grid).
        let accel = layout::accel_code(&self.gpu_scene.params);
        if (Variant { layered, accel, ..variant }) != self.variant {
            self.recompile(ctx, variant)?;
            report.recompiled = true;
        } else if new_texture {
            ctx.rebind(&mut self.kernel, &self.gpu_scene)?;
        }
        report.upload = t.elapsed();
        self.passes = super::modes::passes(&scene);
        self.scene = scene;
        self.restart();
        if behind {
            self.pending = Some(PendingBvh::start(&self.scene, self.origin)?);
        }
        Ok(report)
    }

    /// A new kernel for `variant` that takes over the old one's frame buffer (the picture does
    /// not go black), and the mode configured for it.
    fn recompile(&mut self, ctx: &D, variant: Variant) -> Result<(), RenderError> {
        let fresh = compile(ctx, &self.gpu_scene, &self.settings, variant, self.capacity)?;
        ctx.copy_frame(&fresh, &self.kernel)?;
        self.kernel = fresh;
        self.variant = D::variant(&self.kernel);
        self.configure_mode(ctx)
    }

    /// Traces the BVH [`Session::new_interactive`] started building, once it is built: uploads
    /// it and compiles its kernel, keeping the frame buffer (the picture is the same). How, when
    /// it was adopted now; `None` while it is building, or when there is none.
    pub fn adopt_bvh(&mut self, ctx: &D) -> Result<Option<Adoption>, RenderError> {
        if !self.pending.as_ref().is_some_and(PendingBvh::is_finished) {
            return Ok(None);
        }
        let mut pending = self.pending.take().expect("checked");
        let (bvh, section) = pending.take()?;
        let t = Instant::now();
        self.accel = Accel::Bvh(bvh, BvhWalk::Stackless);
        self.ordered_eye = pending.eye;
        let eye_grid = self.gpu_scene.params.eye_grid;
        // Only the BVH's section is written, from the row it starts in, while it fits the
        // texture: packing the whole scene again takes seconds for the largest scenes
        // (docs/large-models.md).
        let swapped = match self.prefix.take() {
            Some(prefix) => {
                let (row, packed) = layout::swap_accel(&prefix, section, self.scene.trace.shadows);
                let mut params = layout::params(&self.scene, &self.accel, &packed, self.origin);
                params.eye_grid = eye_grid;
                ctx.update_scene_from(&mut self.gpu_scene, row, packed.texels, params)?
            }
            None => false,
        };
        if !swapped {
            let packed = layout::pack_scene(&self.scene, &self.accel, self.origin);
            let mut params = layout::params(&self.scene, &self.accel, &packed, self.origin);
            params.eye_grid = eye_grid;
            ctx.update_scene(&mut self.gpu_scene, packed, params)?;
        }
        // The variant follows the uploaded scene's accelerator (`layout::accel_code`).
        self.recompile(ctx, self.variant)?;
        self.restart();
        let how = if swapped { Adoption::SectionWritten } else { Adoption::ScenePacked };
        log::info!("the BVH built in the background is traced from now on ({how:?}, {:.2?})", t.elapsed());
        Ok(Some(how))
    }

    /// A BVH is being built on another thread for this session ([`Session::adopt_bvh`]).
    pub fn bvh_pending(&self) -> bool {
        self.pending.is_some()
    }

    /// The eye a stackless BVH's children are ordered towards (`None`: another accelerator).
    pub fn bvh_ordered_for(&self) -> Option<DVec3> {
        matches!(self.accel, Accel::Bvh(_, BvhWalk::Stackless)).then_some(self.ordered_eye)
    }

    /// The accelerator for `scene` after its geometry changed: a grid as the animation says; a
    /// BVH is rebuilt whole (a refit of the moving primitives' boxes would be the cheaper
    /// update, not done yet).
    fn reaccel(&mut self, scene: &Scene, motion: bool) -> Accel {
        match &self.accel {
            Accel::Grid(grid) => {
                Accel::Grid(self.animation.regrid(Some(grid), scene, motion, self.incremental))
            }
            Accel::Bvh(_, walk) => {
                let walk = *walk;
                self.ordered_eye = scene.camera.eye;
                Accel::bvh(scene, walk)
            }
        }
    }

    /// Orders a stackless BVH towards the camera's eye again once the eye has moved
    /// [`REORDER_MOVE`] of the scene's size from the eye it was ordered for: a tree ordered for
    /// one side walks the far side's boxes first when seen from the other. The picture does not
    /// change, so refinement goes on. Unless `at_rest`, only when the last reordering took at
    /// most [`REORDER_BUDGET`].
    pub(super) fn reorder(&mut self, ctx: &D, at_rest: bool) {
        let Accel::Bvh(bvh, BvhWalk::Stackless) = &self.accel else { return };
        let eye = self.scene.camera.eye;
        let root = &bvh.nodes[0];
        if eye.distance(self.ordered_eye) <= REORDER_MOVE * (root.hi - root.lo).length()
            || (!at_rest && self.reorder_cost > REORDER_BUDGET)
        {
            return;
        }
        let t = Instant::now();
        self.accel = Accel::Bvh(bvh.ordered_towards(eye), BvhWalk::Stackless);
        self.ordered_eye = eye;
        let ordered = t.elapsed();
        let packed = layout::pack_scene(&self.scene, &self.accel, self.origin);
        let mut params = layout::params(&self.scene, &self.accel, &packed, self.origin);
        params.eye_grid = self.gpu_scene.params.eye_grid;
        let packed_at = t.elapsed();
        let uploaded = ctx.update_scene(&mut self.gpu_scene, packed, params).and_then(|new_texture| {
            if new_texture {
                ctx.rebind(&mut self.kernel, &self.gpu_scene)?;
            }
            Ok(())
        });
        if let Err(e) = uploaded {
            log::warn!("ordering the BVH towards the new eye: {e}");
        }
        self.reorder_cost = t.elapsed();
        log::debug!(
            "BVH ordered towards the eye {eye} in {:.1?} (order {:.1?}, pack {:.1?}, upload {:.1?})",
            self.reorder_cost,
            ordered,
            packed_at - ordered,
            self.reorder_cost - packed_at
        );
    }
}
