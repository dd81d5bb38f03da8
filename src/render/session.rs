//! A scene on a device, traced again and again with a changing camera: the one render path of
//! the window, the headless commands, `irt replay` and the measurements. One call to
//! [`Session::try_step`] is one unit of work of the current mode (the bands' frame, a wave of
//! the conventional tile queue, or one frameless slice); the caller decides when to present.
//!
//! Every step is a [`Recording`] built by the mode's plain functions (`render::modes`) and run
//! by the session's device path: a session is generic over the [`Device`] (wgpu's
//! [`GpuContext`], the default, or raw Vulkan's `gpu::vk::VkContext`), so each mode exists once
//! and runs on both. On wgpu, which cannot fail a dispatch, the plain methods
//! ([`Session::step`] …) return their values; the `try_` forms return the path's errors.
//! What changes the scene on the device (a new time, an edit, a BVH ordered or adopted) is in
//! `render::updates`.

use super::adaptive::AdaptiveOrder;
use super::animation::Animation;
use super::background::{builds_bvh_in_background, PendingBvh};
use super::fill::BlockFill;
use super::modes::{self, Bands, Queue, SliceSpan, Slices, BAND_PIXELS, GPU_BAND_PIXELS};
use super::order::PixelOrder;
use super::picture::OutputGrid;
use super::schedule::{tile_grid, Schedule};
use super::{Mode, RenderError, Settings};
use crate::accel::{Accel, AccelKind, Grid};
use crate::gpu::device::{dealing_threads, BoundKernel, Device, DeviceScene, KernelSpec, ModeBuffers};
use crate::gpu::layout::{self, Prefix, TILE_H};
use crate::gpu::shaders::Variant;
use crate::gpu::{GpuContext, GpuError};
use crate::scene::{Camera, Scene, MAX_IMAGE_SIDE};
use glam::DVec3;
use std::time::{Duration, Instant};

/// What one [`Session::try_step`] did.
#[derive(Clone, Copy, Debug, Default)]
pub struct StepReport {
    /// Pixels whose value this step changed in the frame buffer (conventional: the whole frame
    /// when it completes, else 0; bands: the picture).
    pub pixels: u64,
    /// Eye rays traced (conventional waves trace pixels that show only when the frame
    /// completes; jittered pairs trace two per pixel).
    pub eye_rays: u64,
    /// Wall time of the dispatches (submit to done).
    pub trace_time: Duration,
    /// Bands and conventional: the frame finished in this step; frameless: a pass of the order
    /// finished.
    pub frame_done: bool,
    /// Frameless: the slice this step traced (positions of the current pass).
    pub slice: Option<SliceSpan>,
    /// The camera version the traced pixels saw (see [`Session::camera_version`]).
    pub camera_version: u64,
    /// Nothing to do: refinement reached its sample limit.
    pub idle: bool,
}

/// What [`Session::with_progress`] reports: the stage, and how far it is (`done` of `total`).
pub type SetupProgress<'a> = &'a (dyn Fn(SetupStage, u64, u64) + Sync);

/// The stages of setting up a scene on the device that take long for large scenes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SetupStage {
    /// Inserting primitives into the grid (`done` of `total` primitives).
    Grid,
    /// Building the BVH (`done` of `total` primitives placed in leaves).
    Bvh,
    /// Packing and uploading the scene texture (reported once, `0` of `1`).
    Upload,
}

/// How long each stage of setting up took.
#[derive(Clone, Copy, Debug, Default)]
pub struct SetupTimings {
    /// Building the grid or BVH.
    pub accel_build: Duration,
    /// Packing the scene texture and uploading it.
    pub upload: Duration,
    /// Shader module and pipeline layout (lavapipe compiles at the first dispatch, which is in
    /// the first frame's time).
    pub pipeline: Duration,
}

/// The mode's state: what it traces next.
#[derive(Clone, Debug)]
pub(super) enum ModeState {
    /// Bands of whole rows (the bands mode, or the conventional mode's plain schedule, one band
    /// per pass), each of at most this many eye rays.
    Bands { band_pixels: u32 },
    /// The conventional tile queue, and whether a frame is in flight.
    Queue { queue: Queue, in_flight: bool },
    /// Frameless slices.
    Slices(Slices),
}

pub struct Session<D: Device = GpuContext> {
    /// The scene as given, motions included (settings are applied to a copy, so that dropping
    /// an override restores the scene's own value); `None` in the bands mode, which keeps one
    /// copy of its still scene, the traced one ([`Session::base_scene`]).
    pub(super) base: Option<Scene>,
    /// The scene as traced: `base` at `time`, settings applied, the current camera.
    pub(super) scene: Scene,
    /// The time `scene` shows (seconds; 0 for a still).
    pub(super) time: f64,
    pub(super) settings: Settings,
    /// Positions were packed relative to this point (the camera's eye when uploaded).
    pub(super) origin: DVec3,
    /// The grid or BVH traced (`Settings::accel`); see [`Session::grid`].
    pub accel: Accel,
    pub(super) gpu_scene: DeviceScene<D::Texture>,
    pub(super) kernel: D::Kernel,
    pub variant: Variant,
    /// The largest render size the buffers were made for (the render size never exceeds it).
    pub(super) capacity: [u32; 2],
    /// Eye rays the output, frame and work buffers hold: the capacity's, or [`buffer_rays`]
    /// where that is fewer. A picture of more is traced in pieces (`render::pieces`).
    pub(super) buffer_rays: u64,
    /// What the mode reads from the work buffer (a schedule's boundaries, a pixel order's
    /// table, the dissolve's jumps), kept on the host: pieces write their own work there, and a
    /// table too large for the buffer is written a slice at a time.
    pub(super) mode_work: Vec<u32>,
    /// The work buffer holds `mode_work` (pieces overwrite it; the next step writes it back).
    pub(super) work_resident: bool,
    /// The `Launch::pass_range` of each pass over a pixel (one unless a bundle is split).
    pub(super) passes: Vec<[u32; 4]>,
    /// The bands' rows of tiles are dealt to this many device threads.
    pub(super) deal: u32,
    /// Bumped by every change that makes the frame buffer stale (camera, settings).
    pub(super) camera_version: u64,
    /// Samples (conventional frames, frameless passes) completed since the last change.
    pub(super) samples: u32,
    pub(super) state: ModeState,
    /// Loop iterations the last read output's busiest invocation ran (lavapipe's limit).
    pub max_loop_iterations: u32,
    pub(super) animation: Animation,
    /// Re-insert only the moving primitives when the time changes (else rebuild the grid in the
    /// same lattice: the two give the same grid; this is for measuring).
    pub incremental: bool,
    /// A stackless BVH's children are ordered towards this eye (`Session::reorder`).
    pub(super) ordered_eye: DVec3,
    /// What the last ordering and upload took (zero before the first): above the budget, a
    /// moving camera keeps the old order until it comes to rest.
    pub(super) reorder_cost: Duration,
    /// Opened by [`Session::new_interactive`]: a rebuild for new settings opens the same way.
    pub(super) interactive: bool,
    /// The BVH being built on another thread while the grid is traced (`Session::adopt_bvh`).
    pub(super) pending: Option<PendingBvh>,
    /// What the grid's packing keeps for that BVH: only its section is written when it comes
    /// (`layout::swap_accel`); `None` when the whole scene is packed again (shell shadows).
    pub(super) prefix: Option<Prefix>,
    pub(super) timings: SetupTimings,
    /// The first frame has run (drivers that compile at the first dispatch have compiled).
    pub(super) compiled: bool,
    /// The adaptive frameless order's state (`--order adaptive`); the slices' bookkeeping is
    /// in `state` as for any order.
    pub(super) adaptive: Option<Box<AdaptiveOrder>>,
    /// The adaptive order's fill, as last computed (work space of `fill_blocks`).
    pub(super) fill: Vec<BlockFill>,
}

impl<D: Device> Session<D> {
    /// Builds the accelerator, uploads the scene (positions relative to its camera's eye) and
    /// compiles the kernel for the scene and `settings`.
    pub fn new(ctx: &D, scene: &Scene, settings: Settings) -> Result<Self, RenderError> {
        Self::open(ctx, scene.clone(), settings, false, &|_, _, _| {})
    }

    /// [`Session::new`] taking the scene: a large one is then not held twice.
    pub fn from_scene(ctx: &D, scene: Scene, settings: Settings) -> Result<Self, RenderError> {
        Self::open(ctx, scene, settings, false, &|_, _, _| {})
    }

    /// [`Session::from_scene`], reporting the accelerator's build and the upload as they go.
    pub fn with_progress(
        ctx: &D,
        scene: Scene,
        settings: Settings,
        progress: SetupProgress,
    ) -> Result<Self, RenderError> {
        Self::open(ctx, scene, settings, false, progress)
    }

    /// [`Session::new`] for a viewer: when `--accel auto` picks the BVH for a scene past
    /// `background::BACKGROUND_BVH_ABOVE` primitives, the grid is traced until the BVH, built on
    /// another thread, is adopted by [`Session::adopt_bvh`] (the pictures are the same; the
    /// frames get faster). An accelerator asked for by name is built before the first frame.
    pub fn new_interactive(ctx: &D, scene: &Scene, settings: Settings) -> Result<Self, RenderError> {
        Self::open(ctx, scene.clone(), settings, true, &|_, _, _| {})
    }

    pub(super) fn open(
        ctx: &D,
        scene: Scene,
        settings: Settings,
        interactive: bool,
        progress: SetupProgress,
    ) -> Result<Self, RenderError> {
        let t0 = Instant::now();
        // The bands trace one still picture (an animated scene at time 0), and keep one copy of
        // it: a large model's one-off render holds its geometry once.
        let (base, mut scene) = if settings.mode == Mode::Bands {
            (None, if scene.is_animated() { scene.at(0.0) } else { scene })
        } else {
            let posed = scene.at(0.0);
            (Some(scene), posed)
        };
        settings.apply_to(&mut scene);
        let given = base.as_ref().unwrap_or(&scene);
        let animation = Animation::of(given);
        // Chosen on the scene with its motions: `auto` keeps a large scene that moves on the grid.
        let kind = settings.accel.resolve(given);
        let background = interactive && builds_bvh_in_background(&settings, given, &scene);
        let kind = if background { AccelKind::Grid } else { kind };
        let stage = match kind {
            AccelKind::Grid => SetupStage::Grid,
            AccelKind::Bvh(_) => SetupStage::Bvh,
        };
        let accel =
            animation.first_accel(&scene, kind, &|done, total| progress(stage, done as u64, total as u64));
        let accel_build = t0.elapsed();
        progress(SetupStage::Upload, 0, 1);
        let origin = scene.camera.eye;
        let packed = layout::pack_scene(&scene, &accel, origin);
        let prefix = if background { packed.prefix() } else { None };
        let mut params = layout::params(&scene, &accel, &packed, origin);
        let corners = settings.corner_rays && settings.mode == Mode::Bands;
        params.eye_grid = layout::eye_grid(scene.camera.width, scene.camera.height, corners);
        // Room for the BVH's section to be written in place of the grid's when it comes.
        let reserve = if background { layout::bvh_rows_bound(&packed, scene.primitive_count()) } else { 0 };
        let scene_bytes = packed.texels.len() as u64 * 16;
        let gpu_scene = ctx
            .upload(packed, params, settings.max_scene_rows, reserve)
            .map_err(|e| scene_upload_error(e, scene_bytes, kind))?;
        let t1 = Instant::now();
        let capacity = [scene.camera.width, scene.camera.height];
        let kernel = compile(ctx, &gpu_scene, &settings, settings.variant(&scene), capacity)?;
        let buffer_rays = buffers_hold(ctx, &settings, capacity);
        let timings = SetupTimings { accel_build, upload: t1 - t0 - accel_build, pipeline: t1.elapsed() };
        let mut s = Session {
            variant: D::variant(&kernel),
            passes: modes::passes(&scene),
            deal: settings.deal.unwrap_or_else(|| dealing_threads(ctx)),
            base,
            scene,
            time: 0.0,
            settings,
            origin,
            accel,
            gpu_scene,
            kernel,
            capacity,
            buffer_rays,
            mode_work: Vec::new(),
            work_resident: false,
            camera_version: 0,
            samples: 0,
            state: ModeState::Bands { band_pixels: u32::MAX },
            max_loop_iterations: 0,
            animation,
            incremental: true,
            ordered_eye: origin,
            // Unknown until the first reordering measures itself.
            reorder_cost: Duration::ZERO,
            interactive,
            pending: None,
            prefix,
            timings,
            compiled: false,
            adaptive: None,
            fill: Vec::new(),
        };
        s.configure_mode(ctx)?;
        s.bound(ctx).clear_frame().map_err(Into::into)?;
        if background {
            // Started once the grid is set up, so that the two builds do not share the cores
            // before the first frame.
            s.pending = Some(PendingBvh::start(&s.scene, s.origin)?);
        }
        Ok(s)
    }

    pub fn settings(&self) -> &Settings {
        &self.settings
    }

    /// The scene as traced: settings applied, the current camera.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The scene as given to [`Session::new`] or [`Session::set_scene`], motions included (its
    /// own camera: what "reset" goes back to). In the bands mode, the traced scene.
    pub fn base_scene(&self) -> &Scene {
        self.base.as_ref().unwrap_or(&self.scene)
    }

    /// The scene as given (see [`Session::base_scene`]), the device's resources freed.
    pub fn into_scene(self) -> Scene {
        self.base.unwrap_or(self.scene)
    }

    /// The time the traced scene shows.
    pub fn time(&self) -> f64 {
        self.time
    }

    /// How long setting up took.
    pub fn setup_timings(&self) -> SetupTimings {
        self.timings
    }

    /// The scene on the device (its frame constants, extent and bytes).
    pub fn device_scene(&self) -> &DeviceScene<D::Texture> {
        &self.gpu_scene
    }

    /// The grid traced, if the session traces one.
    pub fn grid(&self) -> Option<&Grid> {
        self.accel.grid()
    }

    pub fn camera(&self) -> &Camera {
        &self.scene.camera
    }

    /// Render size in pixels.
    pub fn size(&self) -> [u32; 2] {
        [self.scene.camera.width, self.scene.camera.height]
    }

    /// Bumped by every change that restarts refinement.
    pub fn camera_version(&self) -> u64 {
        self.camera_version
    }

    /// Samples accumulated since the last change (conventional: frames; frameless: passes).
    pub fn samples(&self) -> u32 {
        self.samples
    }

    /// Frameless: positions in one pass of the order (≥ the pixel count for the dissolve); the
    /// other modes: the pixels.
    pub fn pass_len(&self) -> u64 {
        match &self.state {
            ModeState::Slices(s) => s.pass_len,
            _ => self.pixels(),
        }
    }

    /// Frameless: where in the pass the next slice starts.
    pub fn cursor(&self) -> u64 {
        match &self.state {
            ModeState::Slices(s) => s.cursor,
            _ => 0,
        }
    }

    pub(super) fn pixels(&self) -> u64 {
        let [w, h] = self.size();
        w as u64 * h as u64
    }

    /// Eye rays of the picture: its pixels, or one more row and column of them with corner
    /// rays.
    pub(super) fn eye_rays(&self) -> u64 {
        let grid = self.gpu_scene.params.eye_grid;
        grid[0] as u64 * grid[1] as u64
    }

    /// Whether the picture fits the device's buffers at once. A picture that does not is
    /// traced in pieces (`irt render`, farm tiles, MPI workers: `render::pieces`); the
    /// interactive modes' steps need it whole ([`GpuError::FrameTooLarge`]).
    pub fn whole(&self) -> bool {
        self.eye_rays() <= self.buffer_rays
    }

    /// Eye rays the session's buffers hold (see [`Session::whole`]).
    pub fn buffer_rays(&self) -> u64 {
        self.buffer_rays
    }

    /// The error of a step that needs the whole picture in the buffers.
    pub(super) fn too_large(&self) -> GpuError {
        let [width, height] = self.size();
        GpuError::FrameTooLarge { width, height, most: self.buffer_rays }
    }

    /// The bands of the current picture: its eye-ray grid in bands of `band_pixels`.
    pub(super) fn bands(&self, band_pixels: u32) -> Bands {
        let grid = self.gpu_scene.params.eye_grid;
        Bands { grid_size: [grid[0], grid[1]], passes: self.passes.clone(), deal: self.deal, band_pixels }
    }

    /// How the output buffer is laid out.
    pub(super) fn output_grid(&self) -> OutputGrid {
        let [width, height] = self.size();
        let grid = self.gpu_scene.params.eye_grid;
        OutputGrid { width, height, grid_size: [grid[0], grid[1]] }
    }

    /// Moves the camera (its width and height are ignored: see [`Session::set_size`]); takes
    /// effect from the next step. Cancels the conventional frame in flight and restarts
    /// refinement; frameless slices simply carry on with the new camera.
    pub fn set_camera(&mut self, ctx: &D, camera: &Camera) {
        let [w, h] = self.size();
        let cam = Camera { width: w, height: h, ..camera.clone() };
        if cam == self.scene.camera {
            return;
        }
        self.scene.camera = cam;
        self.write_camera(ctx);
        self.reorder(ctx, false);
        self.restart();
    }

    /// Changes the render size (at most the size the session was made with: scale down for
    /// speed); restarts everything.
    pub fn set_size(&mut self, ctx: &D, width: u32, height: u32) -> Result<(), RenderError> {
        let (width, height) = (width.max(1), height.max(1));
        if [width, height] == self.size() {
            return Ok(());
        }
        if width > self.capacity[0]
            || height > self.capacity[1]
            || width as u64 * height as u64 > self.capacity[0] as u64 * self.capacity[1] as u64
        {
            self.capacity = [width.max(self.capacity[0]), height.max(self.capacity[1])];
            self.kernel = compile(ctx, &self.gpu_scene, &self.settings, self.variant, self.capacity)?;
            self.buffer_rays = buffers_hold(ctx, &self.settings, self.capacity);
        }
        self.scene.camera.width = width;
        self.scene.camera.height = height;
        self.write_camera(ctx);
        self.configure_mode(ctx)?;
        self.bound(ctx).clear_frame().map_err(Into::into)?;
        self.restart();
        Ok(())
    }

    /// Applies new settings: the mode, depth and refinement limit take effect at once; a new
    /// shadow mode, light radius or precision repacks the scene (shell mode adds its shell
    /// objects) and recompiles the kernel, as does a change to or from the bands mode or of what
    /// is instrumented.
    pub fn apply(&mut self, ctx: &D, settings: Settings) -> Result<(), RenderError> {
        if settings == self.settings {
            return Ok(());
        }
        let bands = |s: &Settings| s.mode == Mode::Bands;
        let rebuild = settings.shadows != self.settings.shadows
            || settings.light_radius != self.settings.light_radius
            || settings.f64 != self.settings.f64
            || bands(&settings) != bands(&self.settings)
            || settings.count_rays != self.settings.count_rays
            || settings.simd_stats != self.settings.simd_stats
            || settings.uber_shader != self.settings.uber_shader
            || settings.corner_rays != self.settings.corner_rays
            || settings.max_scene_rows != self.settings.max_scene_rows
            || settings.accel != self.settings.accel;
        if rebuild {
            // A BVH building for the old settings would share the cores with the new set-up:
            // given up first.
            self.pending = None;
            let base = Scene { camera: self.scene.camera.clone(), ..self.base_scene().clone() };
            let camera = self.base_scene().camera.clone();
            let mut fresh = Session::open(ctx, base, settings, self.interactive, &|_, _, _| {})?;
            if let Some(b) = &mut fresh.base {
                b.camera = camera;
            }
            fresh.set_time(ctx, self.time)?;
            fresh.camera_version = self.camera_version + 1;
            *self = fresh;
            return Ok(());
        }
        self.settings = settings;
        self.deal = self.settings.deal.unwrap_or_else(|| dealing_threads(ctx));
        self.scene.trace = self.base_scene().trace.clone();
        self.settings.apply_to(&mut self.scene);
        let mut p = self.gpu_scene.params;
        p.image[2] = self.scene.trace.max_depth;
        ctx.set_params(&mut self.gpu_scene, p);
        self.configure_mode(ctx)?;
        self.restart();
        Ok(())
    }

    /// Frameless: the next steps trace slices of `slice` positions. Unlike [`Session::apply`] it
    /// restarts nothing: S is only how much of the pass one dispatch traces (the window's
    /// [`super::adapt::Adaptation`] changes it slice by slice). Other modes ignore it.
    pub fn set_slice(&mut self, slice: u32) {
        if let Mode::Frameless { slice: s, .. } = &mut self.settings.mode {
            *s = slice.max(1);
        }
    }

    /// Conventional: the next frame is handed out by `schedule`; refinement carries on (a frame's
    /// pixels do not depend on how its tiles are handed out). Only between frames: with a frame
    /// in flight, or in another mode, nothing changes. Whether it changed.
    pub fn set_schedule(&mut self, ctx: &D, schedule: Schedule) -> Result<bool, RenderError> {
        let Mode::Conventional { schedule: now, workers } = self.settings.mode else { return Ok(false) };
        if now == schedule || matches!(self.state, ModeState::Queue { in_flight: true, .. }) {
            return Ok(false);
        }
        self.settings.mode = Mode::Conventional { schedule, workers };
        self.configure_mode(ctx)?;
        Ok(true)
    }

    pub(super) fn write_camera(&mut self, ctx: &D) {
        let mut p = self.gpu_scene.params;
        layout::set_camera(&mut p, &self.scene.camera, self.origin);
        ctx.set_params(&mut self.gpu_scene, p);
    }

    /// The kernel on `ctx`, to run recordings and buffer operations.
    pub(super) fn bound<'a>(&'a self, ctx: &'a D) -> D::Bound<'a> {
        ctx.bind(&self.kernel)
    }

    pub(super) fn restart(&mut self) {
        self.camera_version += 1;
        self.samples = 0;
        match &mut self.state {
            ModeState::Queue { in_flight, .. } => *in_flight = false,
            ModeState::Slices(s) => s.restart(),
            ModeState::Bands { .. } => {}
        }
        if let Some(a) = &mut self.adaptive {
            a.restart();
        }
    }

    /// The mode's state for the current size, and what it reads from the work buffer (written
    /// there now where it fits the buffer; a frameless table that does not is written a slice
    /// at a time, `render::pieces`).
    pub(super) fn configure_mode(&mut self, ctx: &D) -> Result<(), RenderError> {
        let size = self.size();
        let whole = self.whole();
        let (state, work) = match self.settings.mode {
            Mode::Bands => {
                let band_pixels = if ctx.is_cpu() { BAND_PIXELS } else { GPU_BAND_PIXELS };
                (ModeState::Bands { band_pixels }, Vec::new())
            }
            Mode::Conventional { schedule: Schedule::Plain, .. } => {
                (ModeState::Bands { band_pixels: u32::MAX }, Vec::new())
            }
            Mode::Conventional { schedule, workers } => {
                let workers = if workers == 0 { Schedule::default_workers(ctx) } else { workers };
                let (queue, b) = Queue::new(schedule, workers, size, self.settings.waves);
                (ModeState::Queue { queue, in_flight: false }, b)
            }
            Mode::Frameless { order, .. } => {
                // The adaptive order follows the frame buffer on the device: a picture in
                // pieces is traced in its first pass's order, Hilbert's.
                let order = match order {
                    PixelOrder::Adaptive { .. } if !whole => PixelOrder::default(),
                    o => o,
                };
                let (slices, work) = Slices::new(order, size)?;
                (ModeState::Slices(slices), work)
            }
        };
        self.adaptive = match self.settings.mode {
            Mode::Frameless { order: PixelOrder::Adaptive { revisit }, .. } if whole => {
                Some(Box::new(AdaptiveOrder::new(size[0], size[1], revisit)))
            }
            _ => None,
        };
        self.mode_work = work;
        self.work_resident = false;
        let room = mode_buffers(ctx, &self.settings, self.capacity).work_len;
        if self.mode_work.len() as u64 <= room {
            self.restore_work(ctx).map_err(Into::into)?;
        }
        self.state = state;
        Ok(())
    }

    /// Writes the mode's work back into the work buffer if pieces overwrote it.
    pub(super) fn restore_work(&mut self, ctx: &D) -> Result<(), D::Error> {
        if !self.work_resident && !self.mode_work.is_empty() {
            self.bound(ctx).write_work(&self.mode_work)?;
        }
        self.work_resident = true;
        Ok(())
    }
}

/// The fewest eye rays a session's buffers are made for, whatever a setting asks: two rows of
/// tiles of the widest picture, or two rows of its corner rays, so that a piece is whole rows.
pub const MIN_BUFFER_RAYS: u64 = 1 << 16;
const _: () = assert!(
    2 * TILE_H as u64 * MAX_IMAGE_SIDE as u64 <= MIN_BUFFER_RAYS
        && 2 * (MAX_IMAGE_SIDE as u64 + 1) <= MIN_BUFFER_RAYS
);

/// The most eye rays one of `ctx`'s buffers may hold for `settings`: as many vec4s as its
/// largest storage binding covers (128 MiB on lavapipe: 8 388 608), or fewer where
/// `Settings::max_buffer_rays` says.
pub fn buffer_rays(ctx: &impl Device, settings: &Settings) -> u64 {
    let asked = settings.max_buffer_rays.unwrap_or(u64::MAX).max(MIN_BUFFER_RAYS);
    (ctx.max_binding_bytes() / 16).min(asked)
}

/// Eye rays the buffers of a session made for `capacity` hold.
fn buffers_hold(ctx: &impl Device, settings: &Settings, capacity: [u32; 2]) -> u64 {
    let extra = (settings.mode == Mode::Bands && settings.corner_rays) as u64;
    ((capacity[0] as u64 + extra) * (capacity[1] as u64 + extra)).min(buffer_rays(ctx, settings))
}

/// The kernel `settings` trace with, for a scene of `variant` in buffers for pictures of up to
/// `capacity` pixels (and at most [`buffer_rays`] eye rays): the bands compile only the
/// `render` entry point (their output is the eye-ray grid, one more column and row with corner
/// rays); the other modes the queue, slice and resolve entry points with their work and frame
/// buffers.
pub(super) fn compile<D: Device>(
    ctx: &D,
    scene: &DeviceScene<D::Texture>,
    settings: &Settings,
    variant: Variant,
    capacity: [u32; 2],
) -> Result<D::Kernel, GpuError> {
    let held = buffers_hold(ctx, settings, capacity);
    match settings.mode {
        Mode::Bands => ctx.compile(scene, KernelSpec::render(variant, held)),
        _ => ctx.compile(scene, KernelSpec::modes(variant, held, mode_buffers(ctx, settings, capacity))),
    }
}

/// The interactive modes' work and frame buffers for pictures of up to `capacity` pixels.
pub(super) fn mode_buffers(ctx: &impl Device, settings: &Settings, capacity: [u32; 2]) -> ModeBuffers {
    let held = buffers_hold(ctx, settings, capacity);
    let pixels = capacity[0] as u64 * capacity[1] as u64;
    let [tx, ty] = tile_grid(capacity[0], capacity[1]);
    let dissolve = super::order::Dissolve::new(pixels).jumps().len() as u64;
    ModeBuffers { work_len: held.max(tx as u64 * ty as u64 + 1).max(dissolve), frame_len: held }
}

impl Schedule {
    /// The workers P a schedule is built for by default on `ctx`'s device: lavapipe's threads
    /// (`dealing_threads`: `LP_NUM_THREADS`, else one a core), or a GPU's many workgroups in
    /// flight.
    pub fn default_workers(ctx: &impl Device) -> u32 {
        if ctx.is_cpu() {
            dealing_threads(ctx)
        } else {
            256
        }
    }
}

/// An upload the device could not allocate is the scene's size, not the picture's: said so,
/// with what makes a scene smaller (the grid packs many small primitives in less room than a
/// BVH: 1.5 GiB against 2.7 GiB for 35M spheres). Other failures pass as they are.
fn scene_upload_error(e: GpuError, bytes: u64, kind: AccelKind) -> RenderError {
    let GpuError::Device(f) = &e else { return e.into() };
    if f.kind != crate::gpu::FailureKind::OutOfMemory {
        return e.into();
    }
    let advice = match kind {
        AccelKind::Bvh(_) => "try --accel grid, which packs a large scene in less room, or a smaller model",
        AccelKind::Grid => "load a smaller model, or split it over several devices with --mpi",
    };
    let mib = bytes.div_ceil(1 << 20);
    RenderError::Scene(format!(
        "the scene's {mib} MiB on the device (geometry and accelerator) is more than it could allocate ({}): {advice}",
        f.detail
    ))
}

#[cfg(test)]
mod upload_tests {
    use super::*;
    use crate::gpu::{DeviceFailure, FailureKind};

    #[test]
    fn a_scene_the_device_cannot_hold_is_named_with_what_helps() {
        let oom =
            || GpuError::Device(DeviceFailure::new(FailureKind::OutOfMemory, "Not enough memory left."));
        let bvh = scene_upload_error(oom(), 0xa800_0000, AccelKind::Bvh(Default::default())).to_string();
        assert!(bvh.contains("scene's 2688 MiB") && bvh.contains("--accel grid"), "{bvh}");
        assert!(!bvh.contains("--size"), "not the picture's size: {bvh}");
        let grid = scene_upload_error(oom(), 1 << 30, AccelKind::Grid).to_string();
        assert!(grid.contains("1024 MiB") && !grid.contains("--accel grid"), "{grid}");
        let lost = GpuError::Device(DeviceFailure::new(FailureKind::Lost, "reset"));
        assert!(scene_upload_error(lost, 1, AccelKind::Grid).to_string().contains("was lost"));
    }
}
