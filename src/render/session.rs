//! A scene on the device that can be traced again and again with a changing camera: what the
//! window, the headless mode renders, `irt replay` and the benches share. One call to
//! [`Session::step`] is one unit of work of the current mode (a wave of the conventional tile
//! queue, or one frameless slice); the caller decides when to present.
//!
//! Every step is a [`Recording`] that the session's device path runs: a session is generic over
//! the [`Device`] (wgpu's [`GpuContext`], the default, or raw Vulkan's `gpu::vk::VkContext`), so
//! each mode exists once and runs on both. On wgpu, which cannot fail a dispatch, the plain
//! methods ([`Session::step`] …) return their values; the `try_` forms return the path's errors.

use super::order::{Dissolve, PixelOrder};
use super::schedule::{tile_grid, Schedule};
use super::{Mode, Settings};
use crate::accel::bvh::BvhInput;
use crate::accel::grid::Frame;
use crate::accel::{Accel, AccelChoice, AccelKind, AccelRef, Bvh, BvhWalk, Grid};
use crate::gpu::backend::{infallible, Command, ComputeBackend, Device, Dispatch, Recording};
use crate::gpu::dispatch::ModeBuffers;
use crate::gpu::layout::{
    self, Params, Tile, FRAME_ACCUMULATE, FRAME_BLEND, FRAME_JITTER_PAIRS, FRAME_WRITE, LAVAPIPE_LOOP_LIMIT,
    MAX_CHUNK_TILES, ORDER_DISSOLVE, ORDER_TABLE, TILE_H, TILE_W,
};
use crate::gpu::shaders::{Kernel, Variant};
use crate::gpu::GpuContext;
use crate::image::Image;
use crate::scene::{Camera, Scene};
use glam::DVec3;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Tiles a workgroup of the conventional queue traces before it exits (plus at most one
/// chunk): what lets a frame be split into waves that input can cancel between.
pub const TILE_BUDGET: u32 = 16;

/// Workgroups per wave for a frame of `tiles` tiles cut into about `waves` waves (each
/// workgroup traces up to [`TILE_BUDGET`] tiles; fewer where the loop budget stops it, and the
/// host then runs more waves until the queue is empty).
pub fn wave_groups(tiles: u32, waves: u32) -> u32 {
    tiles.div_ceil(waves.max(1)).div_ceil(TILE_BUDGET).max(1)
}

/// A workgroup of the queue takes no further chunk once its busiest invocation, plus one more
/// chunk at the dearest tile it has seen, would pass this many loop iterations: half of
/// lavapipe's limit, leaving the other half as margin for a tile dearer than any before.
pub const QUEUE_LOOP_BUDGET: u32 = LAVAPIPE_LOOP_LIMIT / 2;

/// `b` with every chunk longer than `max` tiles cut into pieces of `max` (the last shorter).
pub fn cap_chunks(b: &[u32], max: u32) -> Vec<u32> {
    let mut out = vec![b[0]];
    for w in b.windows(2) {
        let mut t = w[0];
        while w[1] - t > max {
            t += max;
            out.push(t);
        }
        out.push(w[1]);
    }
    out
}

/// Frameless slices never straddle a pass of the order: positions `[first, first + len)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SliceSpan {
    pub first: u64,
    pub len: u64,
}

/// What one [`Session::step`] did.
#[derive(Clone, Copy, Debug, Default)]
pub struct StepReport {
    /// Pixels whose value this step changed in the frame buffer (conventional: the whole frame
    /// when it completes, else 0).
    pub pixels: u64,
    /// Eye rays traced (conventional waves trace pixels that show only when the frame
    /// completes; jittered pairs trace two per pixel).
    pub eye_rays: u64,
    /// Wall time of the dispatches (submit to done).
    pub trace_time: Duration,
    /// Conventional: the frame finished in this step; frameless: a pass of the order finished.
    pub frame_done: bool,
    /// Frameless: the slice this step traced (positions of the current pass).
    pub slice: Option<SliceSpan>,
    /// The camera version the traced pixels saw (see [`Session::camera_version`]).
    pub camera_version: u64,
    /// Nothing to do: refinement reached its sample limit.
    pub idle: bool,
}

/// The refinement jitter of sample `k`: (0, 0) for the first (pixel centres, as a headless
/// render), then the R2 sequence (Roberts 2018) over the pixel, in [-0.5, 0.5)².
pub fn refinement_jitter(k: u32) -> [f32; 2] {
    if k == 0 {
        return [0.0, 0.0];
    }
    const A1: f64 = 0.754_877_666_246_692_8; // 1/φ₂, φ₂ the plastic number
    const A2: f64 = 0.569_840_290_998_053_3; // 1/φ₂²
    let f = |a: f64| ((0.5 + a * k as f64).fract() - 0.5) as f32;
    [f(A1), f(A2)]
}

/// What replacing the scene's contents cost ([`Session::set_time`], [`Session::set_scene`]).
#[derive(Clone, Copy, Debug, Default)]
pub struct UpdateReport {
    /// Moving the objects to the new time.
    pub pose: Duration,
    /// Rebuilding the grid or BVH (`None`: no geometry changed, it was kept).
    pub grid: Option<Duration>,
    /// Packing the scene texture.
    pub pack: Duration,
    /// Writing it to the device (and compiling a new kernel, if `recompiled`).
    pub upload: Duration,
    /// The scene now needs a different shader variant (a material changed kind).
    pub recompiled: bool,
    /// The scene outgrew its texture, which was replaced (with a quarter more rows to spare).
    pub reallocated: bool,
}

impl UpdateReport {
    pub fn total(&self) -> Duration {
        self.pose + self.grid.unwrap_or_default() + self.pack + self.upload
    }
}

pub struct Session<D: Device = GpuContext> {
    /// The scene as given, motions included (settings are applied to a copy, so that dropping
    /// an override restores the scene's own value).
    base: Scene,
    /// The scene as traced: `base` at `time`, settings applied, the current camera.
    scene: Scene,
    /// The time `scene` shows (seconds; 0 for a still).
    time: f64,
    settings: Settings,
    /// Positions were packed relative to this point (the camera's eye when uploaded).
    origin: DVec3,
    /// The grid or BVH traced (`Settings::accel`); see [`Session::grid`].
    pub accel: Accel,
    gpu_scene: D::Scene,
    dispatcher: D::Kernel,
    pub variant: Variant,
    /// Pixels the buffers hold (the render size never exceeds it).
    capacity: [u32; 2],
    /// The `Tile::pass_range` of each pass over a pixel (one unless a bundle is split).
    passes: Vec<[u32; 4]>,
    /// Bumped by every change that makes the frame buffer stale (camera, settings).
    camera_version: u64,
    /// Samples (conventional frames, frameless passes) completed since the last change.
    samples: u32,
    // Conventional: the frame in flight.
    chunks: u32,
    frame_in_flight: bool,
    wave_groups: u32,
    // Frameless: the position in the current pass, and where the last change happened.
    cursor: u64,
    pass_len: u64,
    /// The dissolve, and its register's state at `cursor` (carried from slice to slice, so the
    /// host never jumps).
    dissolve: Option<(Dissolve, u32)>,
    /// Positions traced since the last change (a pixel's visit index since then is
    /// `positions_since_change / pass_len`).
    positions_since_change: u64,
    /// Loop iterations the last step's busiest invocation group ran (lavapipe's limit).
    pub max_loop_iterations: u32,
    /// Moving scenes: the primitives that move, and the grid frame that holds them over the
    /// whole animation (with the box it was fitted to), so that a new time re-inserts only
    /// them ([`Grid::update`]) instead of rebuilding the grid.
    moving: Vec<std::ops::Range<usize>>,
    frame: Option<(Frame, DVec3, DVec3)>,
    /// Re-insert only the moving primitives when the time changes (else rebuild the grid in the
    /// same frame: the two give the same grid; this is for measuring).
    pub incremental: bool,
    /// A stackless BVH's children are ordered towards this eye ([`Session::reorder`]).
    ordered_eye: DVec3,
    /// What the last ordering and upload took (zero before the first): above
    /// [`REORDER_BUDGET`], a moving camera keeps the old order until it comes to rest.
    reorder_cost: Duration,
    /// Opened by [`Session::new_interactive`]: a rebuild for new settings opens the same way.
    interactive: bool,
    /// The BVH being built on another thread while the grid is traced ([`Session::adopt_bvh`]).
    pending: Option<PendingBvh>,
    /// What the grid's packing keeps for that BVH: only its section is written when it comes
    /// (`layout::swap_accel`); `None` when the whole scene is packed again (shell shadows).
    prefix: Option<layout::Prefix>,
}

/// How [`Session::adopt_bvh`] put the BVH on the device.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Adoption {
    /// Only its section of the scene texture was written (the rest is the grid's packing).
    SectionWritten,
    /// The whole scene was packed and uploaded again (shell shadows, or a texture too small).
    ScenePacked,
}

/// A BVH being built on its own thread, ordered towards `eye`, and its section of the scene
/// texture packed there too. Dropped (the scene's geometry was edited, or the session closed),
/// it tells the build to stop.
struct PendingBvh {
    handle: Option<std::thread::JoinHandle<Option<(Bvh, layout::AccelSection)>>>,
    eye: DVec3,
    cancel: Arc<AtomicBool>,
}

impl PendingBvh {
    /// Starts building `scene`'s BVH, ordered towards its eye, and packing it for a scene packed
    /// relative to `origin`.
    fn start(scene: &Scene, origin: DVec3) -> Result<PendingBvh, String> {
        let (input, eye) = (BvhInput::of(scene), scene.camera.eye);
        let cancel = Arc::new(AtomicBool::new(false));
        let flag = cancel.clone();
        let build = move || {
            let bvh = input.build_unless(&flag)?.ordered_towards(eye);
            let section = layout::pack_accel(AccelRef::Bvh(&bvh, BvhWalk::Stackless), origin);
            Some((bvh, section))
        };
        let handle = std::thread::Builder::new()
            .name("irt-bvh".into())
            .spawn(build)
            .map_err(|e| format!("starting the BVH build thread: {e}"))?;
        Ok(PendingBvh { handle: Some(handle), eye, cancel })
    }

    fn is_finished(&self) -> bool {
        self.handle.as_ref().is_none_or(|h| h.is_finished())
    }
}

impl Drop for PendingBvh {
    fn drop(&mut self) {
        self.cancel.store(true, Ordering::Relaxed);
    }
}

/// Past this many primitives an interactive session whose `auto` accelerator is the BVH first
/// traces the grid (built 4–18 times faster: 0.47 against 1.77 s at 3M triangles, 0.38 against
/// 6.74 s at 5.4M spheres, two cores) while the BVH builds on another thread, so that the first
/// frames do not wait for it (docs/large-models.md, "Which accelerator").
pub const BACKGROUND_BVH_ABOVE: usize = 1 << 20;

/// The eye moves this far, as a fraction of the scene's box diagonal, before a stackless BVH is
/// ordered towards it again ([`Session::reorder`]).
pub const REORDER_MOVE: f64 = 0.05;
/// A reordering that took longer than this waits for the camera to come to rest (one complete
/// frame or pass), so that dragging a large model does not stutter.
pub const REORDER_BUDGET: Duration = Duration::from_millis(8);

/// Times at which an animation is posed to find the box its moving objects sweep (plus its
/// ends); a cubic that overshoots between them makes the frame grow when it happens.
const FRAME_SAMPLES: u32 = 64;

/// The grid frame for `base`'s whole animation: the box of its still primitives and of its
/// moving ones at [`FRAME_SAMPLES`] times, grown by 2% so that small overshoots still fit.
/// `None` for a still scene (its grid is fitted to it as always).
fn animation_frame(base: &Scene, moving: &[std::ops::Range<usize>]) -> Option<(Frame, DVec3, DVec3)> {
    if moving.is_empty() {
        return None;
    }
    let end = base.duration();
    let mut lo = DVec3::INFINITY;
    let mut hi = DVec3::NEG_INFINITY;
    let n = base.primitive_count();
    let mut first = true;
    for k in 0..=FRAME_SAMPLES {
        let posed = base.at(end * k as f64 / FRAME_SAMPLES as f64);
        // The still primitives once; the moving ones at every sample.
        let ranges: Vec<std::ops::Range<usize>> =
            if first { std::iter::once(0..n).collect() } else { moving.to_vec() };
        first = false;
        if let Some((a, b)) = Grid::bounds_of(&posed, &ranges) {
            (lo, hi) = (lo.min(a), hi.max(b));
        }
    }
    if !(lo.is_finite() && hi.is_finite()) {
        return None;
    }
    let grow = (hi - lo).max_element() * 0.02;
    let (lo, hi) = (lo - grow, hi + grow);
    Some((Frame::around(lo, hi, n), lo, hi))
}

impl<D: Device> Session<D> {
    /// Builds the grid, uploads the scene (positions relative to its camera's eye) and compiles
    /// the kernel for the scene and `settings`.
    pub fn new(ctx: &D, scene: &Scene, settings: Settings) -> Result<Self, String> {
        Self::open(ctx, scene, settings, false)
    }

    /// [`Session::new`] for a viewer: when `--accel auto` picks the BVH for a scene past
    /// [`BACKGROUND_BVH_ABOVE`] primitives, the grid is traced until the BVH, built on another
    /// thread, is adopted by [`Session::adopt_bvh`] (the pictures are the same; the frames get
    /// faster). An accelerator asked for by name is built before the first frame.
    pub fn new_interactive(ctx: &D, scene: &Scene, settings: Settings) -> Result<Self, String> {
        Self::open(ctx, scene, settings, true)
    }

    fn open(ctx: &D, scene: &Scene, settings: Settings, interactive: bool) -> Result<Self, String> {
        let base = scene.clone();
        let mut scene = scene.at(0.0);
        settings.apply_to(&mut scene);
        let moving = Grid::moving_prims(&base);
        let frame = animation_frame(&base, &moving);
        // Chosen on the scene with its motions: `auto` keeps a large scene that moves on the grid.
        let kind = settings.accel.resolve(&base);
        let background = interactive && builds_bvh_in_background(&settings, &base, &scene);
        let kind = if background { AccelKind::Grid } else { kind };
        let accel = first_accel(&scene, kind, &frame);
        let origin = scene.camera.eye;
        let packed = layout::pack_scene(&scene, &accel, origin);
        let prefix = if background { packed.prefix() } else { None };
        let params = layout::params(&scene, &accel, &packed, origin);
        // Room for the BVH's section to be written in place of the grid's when it comes.
        let reserve = if background { layout::bvh_rows_bound(&packed, scene.primitive_count()) } else { 0 };
        let gpu_scene = ctx.upload(packed, params, None, reserve)?;
        let variant = Variant { f64: settings.f64, ..Variant::for_scene(&scene, false) };
        let capacity = [scene.camera.width, scene.camera.height];
        let dispatcher = make_dispatcher(ctx, &gpu_scene, variant, capacity)?;
        let variant = D::variant(&dispatcher);
        let mut s = Session {
            base,
            passes: crate::gpu::renderer::passes(&scene),
            scene,
            time: 0.0,
            settings,
            origin,
            accel,
            gpu_scene,
            dispatcher,
            variant,
            capacity,
            camera_version: 0,
            samples: 0,
            chunks: 0,
            frame_in_flight: false,
            wave_groups: 0,
            cursor: 0,
            pass_len: 0,
            dissolve: None,
            positions_since_change: 0,
            max_loop_iterations: 0,
            moving,
            frame,
            incremental: true,
            ordered_eye: origin,
            // Unknown until the first reordering measures itself.
            reorder_cost: Duration::ZERO,
            interactive,
            pending: None,
            prefix,
        };
        s.configure_mode(ctx)?;
        s.bound(ctx).clear_frame().map_err(|e| e.to_string())?;
        if background {
            // Started once the grid is set up, so that the two builds do not share the cores
            // before the first frame (at 16M triangles that took the grid's set-up from 5 to 15 s).
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
    /// own camera: what "reset" goes back to).
    pub fn base_scene(&self) -> &Scene {
        &self.base
    }

    /// The time the traced scene shows.
    pub fn time(&self) -> f64 {
        self.time
    }

    /// Shows the scene at time `t` (seconds; clamped to its keys, see `scene::motion`): the
    /// moved objects are posed, the grid rebuilt and the texture rewritten, from the next step.
    /// Restarts refinement; frameless slices carry on over the old pixels. A still scene
    /// costs nothing.
    pub fn set_time(&mut self, ctx: &D, t: f64) -> Result<UpdateReport, String> {
        self.time = t;
        if !self.base.is_animated() {
            return Ok(UpdateReport::default());
        }
        let t0 = Instant::now();
        let posed = self.base.at(t);
        let mut r = self.update(ctx, posed, true)?;
        r.pose = t0.elapsed() - r.grid.unwrap_or_default() - r.pack - r.upload;
        Ok(r)
    }

    /// Replaces what the scene holds (lights, materials, objects, motions; the camera stays the
    /// session's): an edit in the viewer. The grid is rebuilt only if geometry moved; a
    /// material of a new kind recompiles the kernel. Restarts refinement.
    pub fn set_scene(&mut self, ctx: &D, scene: &Scene) -> Result<UpdateReport, String> {
        scene.validate().map_err(|e| e.0)?;
        self.base = Scene { camera: self.base.camera.clone(), ..scene.clone() };
        self.moving = Grid::moving_prims(&self.base);
        self.frame = animation_frame(&self.base, &self.moving);
        let posed = self.base.at(self.time);
        self.update(ctx, posed, false)
    }

    /// Draws `posed` from the next step. `motion`: it differs from the scene traced now only by
    /// where the moving primitives are (a new time), so their cells can be updated alone.
    fn update(&mut self, ctx: &D, posed: Scene, motion: bool) -> Result<UpdateReport, String> {
        // Keys can move objects past what f32 (or f64) holds; say so rather than trace NaNs.
        posed.validate().map_err(|e| format!("at time {} s: {}", self.time, e.0))?;
        let mut report = UpdateReport::default();
        let mut scene = Scene { camera: self.scene.camera.clone(), ..posed };
        self.settings.apply_to(&mut scene);
        if scene == self.scene {
            // Nothing changed (a time past the last key, an edit undone): keep refining.
            return Ok(report);
        }
        let moved = scene.spheres != self.scene.spheres
            || scene.cones != self.scene.cones
            || scene.meshes != self.scene.meshes;
        // An edit to a large scene that a viewer traces by a BVH built in the background: the
        // grid again at once (at 16M triangles a BVH rebuild would hold the window 10 s), and a
        // new BVH behind it. A new time (`motion`) updates the accelerator in place.
        let behind = moved
            && !motion
            && self.interactive
            && builds_bvh_in_background(&self.settings, &self.base, &scene);
        if moved {
            // A BVH being built for the old geometry no longer fits: it is given up.
            self.pending = None;
            let t = Instant::now();
            self.accel = if behind {
                first_accel(&scene, AccelKind::Grid, &self.frame)
            } else {
                self.reaccel(&scene, motion)
            };
            report.grid = Some(t.elapsed());
        }
        let t = Instant::now();
        let packed = layout::pack_scene(&scene, &self.accel, self.origin);
        self.prefix = if behind || self.pending.is_some() { packed.prefix() } else { None };
        let mut params = layout::params(&scene, &self.accel, &packed, self.origin);
        params.eye_grid = D::params(&self.gpu_scene).eye_grid;
        report.pack = t.elapsed();
        let t = Instant::now();
        let new_texture = ctx.update_scene(&mut self.gpu_scene, packed, params)?;
        report.reallocated = new_texture;
        let variant = Variant { f64: self.settings.f64, ..Variant::for_scene(&scene, false) };
        let layered = D::layered(&self.gpu_scene);
        // The accelerator may have changed too (a background BVH given up for the grid).
        let accel = layout::accel_code(&D::params(&self.gpu_scene));
        if (Variant { layered, accel, ..variant }) != self.variant {
            let fresh = make_dispatcher(ctx, &self.gpu_scene, variant, self.capacity)?;
            ctx.copy_frame(&fresh, &self.dispatcher)?;
            self.dispatcher = fresh;
            self.variant = D::variant(&self.dispatcher);
            self.configure_mode(ctx)?;
            report.recompiled = true;
        } else if new_texture {
            ctx.rebind(&mut self.dispatcher, &self.gpu_scene)?;
        }
        report.upload = t.elapsed();
        self.passes = crate::gpu::renderer::passes(&scene);
        self.scene = scene;
        self.restart();
        if behind {
            self.pending = Some(PendingBvh::start(&self.scene, self.origin)?);
        }
        Ok(report)
    }

    /// Traces the BVH [`Session::new_interactive`] started building, once it is built: uploads
    /// it and compiles its kernel, keeping the frame buffer (the picture is the same). How, when
    /// it was adopted now; `None` while it is building, or when there is none.
    pub fn adopt_bvh(&mut self, ctx: &D) -> Result<Option<Adoption>, String> {
        if !self.pending.as_ref().is_some_and(PendingBvh::is_finished) {
            return Ok(None);
        }
        let mut pending = self.pending.take().expect("checked");
        let eye = pending.eye;
        let built = pending.handle.take().expect("joined once").join();
        let (bvh, section) = built
            .map_err(|_| "the BVH build thread panicked".to_string())?
            .ok_or("the BVH build was cancelled")?;
        let t = Instant::now();
        self.accel = Accel::Bvh(bvh, BvhWalk::Stackless);
        self.ordered_eye = eye;
        let eye_grid = D::params(&self.gpu_scene).eye_grid;
        // Only the BVH's section is written, from the row it starts in, while it fits the
        // texture: packing the whole scene again took 0.5 s at 3M triangles, 4.6 s at 16M.
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
        let fresh = make_dispatcher(ctx, &self.gpu_scene, self.variant, self.capacity)?;
        ctx.copy_frame(&fresh, &self.dispatcher)?;
        self.dispatcher = fresh;
        self.variant = D::variant(&self.dispatcher);
        self.configure_mode(ctx)?;
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

    /// Frameless: positions in one pass of the order (≥ the pixel count for the dissolve).
    pub fn pass_len(&self) -> u64 {
        self.pass_len
    }

    /// Frameless: where in the pass the next slice starts.
    pub fn cursor(&self) -> u64 {
        self.cursor
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
    pub fn set_size(&mut self, ctx: &D, width: u32, height: u32) -> Result<(), String> {
        let (width, height) = (width.max(1), height.max(1));
        if [width, height] == self.size() {
            return Ok(());
        }
        if width > self.capacity[0]
            || height > self.capacity[1]
            || width as u64 * height as u64 > self.capacity_pixels()
        {
            self.capacity = [width.max(self.capacity[0]), height.max(self.capacity[1])];
            self.dispatcher = make_dispatcher(ctx, &self.gpu_scene, self.variant, self.capacity)?;
        }
        self.scene.camera.width = width;
        self.scene.camera.height = height;
        self.write_camera(ctx);
        self.configure_mode(ctx)?;
        self.bound(ctx).clear_frame().map_err(|e| e.to_string())?;
        self.restart();
        Ok(())
    }

    fn capacity_pixels(&self) -> u64 {
        self.capacity[0] as u64 * self.capacity[1] as u64
    }

    /// Applies new settings: the mode, depth and refinement limit take effect at once; a new
    /// shadow mode or precision repacks the scene (shell mode adds its shell objects) and
    /// recompiles the kernel.
    pub fn apply(&mut self, ctx: &D, settings: Settings) -> Result<(), String> {
        if settings == self.settings {
            return Ok(());
        }
        let rebuild = settings.shadows != self.settings.shadows
            || settings.light_radius != self.settings.light_radius
            || settings.f64 != self.settings.f64;
        if rebuild {
            // A BVH building for the old settings would share the cores with the new set-up
            // (at 16M triangles that took it from 5 to 14 s): given up first.
            self.pending = None;
            let base = Scene { camera: self.scene.camera.clone(), ..self.base.clone() };
            let mut fresh = Session::open(ctx, &base, settings.clone(), self.interactive)?;
            fresh.base.camera = self.base.camera.clone();
            fresh.set_time(ctx, self.time)?;
            fresh.camera_version = self.camera_version + 1;
            *self = fresh;
            return Ok(());
        }
        self.settings = settings;
        self.scene.trace = self.base.trace.clone();
        self.settings.apply_to(&mut self.scene);
        let mut p = D::params(&self.gpu_scene);
        p.image[2] = self.scene.trace.max_depth;
        ctx.write_params(&mut self.gpu_scene, p);
        self.configure_mode(ctx)?;
        self.restart();
        Ok(())
    }

    fn write_camera(&mut self, ctx: &D) {
        let mut p: Params = D::params(&self.gpu_scene);
        layout::set_camera(&mut p, &self.scene.camera, self.origin);
        ctx.write_params(&mut self.gpu_scene, p);
    }

    /// The kernel on `ctx`, to run recordings and buffer operations.
    fn bound<'a>(&'a self, ctx: &'a D) -> D::Bound<'a> {
        ctx.bind(&self.dispatcher)
    }

    fn restart(&mut self) {
        self.camera_version += 1;
        self.samples = 0;
        self.frame_in_flight = false;
        self.positions_since_change = 0;
    }

    /// Uploads what the mode reads from the work buffer.
    fn configure_mode(&mut self, ctx: &D) -> Result<(), String> {
        let [w, h] = self.size();
        let write_work = |s: &Self, data: &[u32]| s.bound(ctx).write_work(data).map_err(|e| e.to_string());
        match self.settings.mode {
            Mode::Conventional { schedule, workers } => {
                let [tx, ty] = tile_grid(w, h);
                let workers = if workers == 0 { Schedule::default_workers(ctx) } else { workers };
                let b = cap_chunks(&schedule.boundaries(tx * ty, workers), MAX_CHUNK_TILES);
                self.chunks = b.len() as u32 - 1;
                write_work(self, &b)?;
                self.frame_in_flight = false;
            }
            Mode::Frameless { order, .. } => {
                let pixels = w as u64 * h as u64;
                if order == PixelOrder::Dissolve {
                    if !Dissolve::fits(pixels) {
                        return Err(format!(
                            "the dissolve order handles at most 2^26 - 1 pixels; {w}x{h} has {pixels}"
                        ));
                    }
                    let d = Dissolve::new(pixels);
                    write_work(self, &d.jumps())?;
                    self.dissolve = Some((d, 1));
                } else {
                    let table = order.table(w, h).expect("table orders have tables");
                    write_work(self, &table)?;
                    self.dissolve = None;
                }
                self.pass_len = order.pass_len(w, h);
                self.cursor = 0;
            }
        }
        Ok(())
    }

    /// Whether refinement has reached its sample limit (nothing left to trace).
    pub fn converged(&self) -> bool {
        self.settings.max_samples > 0 && self.samples >= self.settings.max_samples
    }

    /// One unit of work: a wave of the conventional frame, or one frameless slice.
    pub fn try_step(&mut self, ctx: &D) -> Result<StepReport, D::Error> {
        if self.converged() {
            return Ok(StepReport { idle: true, camera_version: self.camera_version, ..Default::default() });
        }
        if self.samples > 0 {
            self.reorder(ctx, true);
        }
        match self.settings.mode {
            Mode::Conventional { .. } => self.step_conventional(ctx),
            Mode::Frameless { .. } => self.step_frameless(ctx),
        }
    }

    /// Runs steps until the current conventional frame or frameless pass is complete (or
    /// refinement converged): one whole picture, what the headless commands write.
    pub fn try_complete_pass(&mut self, ctx: &D) -> Result<Duration, D::Error> {
        let mut t = Duration::ZERO;
        loop {
            let r = self.try_step(ctx)?;
            t += r.trace_time;
            if r.frame_done || r.idle {
                return Ok(t);
            }
        }
    }

    /// Runs `rec` on the session's kernel.
    fn run(&self, ctx: &D, rec: &Recording) -> Result<(), D::Error> {
        self.bound(ctx).run(rec, &mut |_, _| {})
    }

    fn step_conventional(&mut self, ctx: &D) -> Result<StepReport, D::Error> {
        let [w, h] = self.size();
        if let Mode::Conventional { schedule: Schedule::Plain, .. } = self.settings.mode {
            return self.step_plain(ctx);
        }
        let [tx, ty] = tile_grid(w, h);
        let tiles = tx * ty;
        let new_frame = !self.frame_in_flight;
        if new_frame {
            self.wave_groups = wave_groups(tiles, self.settings.waves);
        }
        let k = self.samples;
        let jitter = refinement_jitter(k);
        let split = self.passes.len() > 1;
        let t0 = Instant::now();
        let mut done = true;
        for &pass in &self.passes {
            let tile = Tile {
                pass_range: pass,
                work: [self.chunks, TILE_BUDGET, tx, QUEUE_LOOP_BUDGET],
                sample: [k, 0, 0, 0],
                jitter: [jitter[0], jitter[1], 0.0, 0.0],
                ..Tile::default()
            };
            let wave = Command::Dispatch(Dispatch {
                entry: "render_queue".into(),
                tile,
                groups: [self.wave_groups, 1, 1],
            });
            let mut rec = Recording::default();
            if split || new_frame {
                rec.commands.push(Command::ResetQueue);
            }
            rec.commands.push(wave);
            loop {
                // One wave; the queue's counter carries over between waves. A split bundle's
                // passes each walk the whole queue here (waves would interleave passes).
                self.run(ctx, &rec)?;
                done = self.bound(ctx).read_queue()? >= self.chunks;
                if done || !split {
                    break;
                }
                rec.commands.retain(|c| *c != Command::ResetQueue);
            }
        }
        self.frame_in_flight = !done;
        if done {
            return self.finish_frame(ctx, t0.elapsed());
        }
        Ok(StepReport { trace_time: t0.elapsed(), camera_version: self.camera_version, ..Default::default() })
    }

    /// The whole frame in one dispatch per pass, no queue.
    fn step_plain(&mut self, ctx: &D) -> Result<StepReport, D::Error> {
        let [w, h] = self.size();
        let k = self.samples;
        let jitter = refinement_jitter(k);
        let t0 = Instant::now();
        let commands = self
            .passes
            .iter()
            .map(|&pass| {
                let tile = Tile {
                    rect: [0, 0, w, h],
                    pass_range: pass,
                    sample: [k, 0, 0, 0],
                    jitter: [jitter[0], jitter[1], 0.0, 0.0],
                    ..Tile::default()
                };
                Command::Dispatch(Dispatch::dealt(tile, crate::gpu::backend::dealing_threads(ctx)))
            })
            .collect();
        self.run(ctx, &Recording { commands })?;
        let trace_time = t0.elapsed();
        self.finish_frame(ctx, trace_time)
    }

    /// A conventional frame is whole: into the frame buffer (a first sample replaces, later
    /// ones add).
    fn finish_frame(&mut self, ctx: &D, trace_time: Duration) -> Result<StepReport, D::Error> {
        let [w, h] = self.size();
        let k = self.samples;
        let flags = if k == 0 { FRAME_WRITE } else { FRAME_WRITE | FRAME_ACCUMULATE };
        let t1 = Instant::now();
        let tile = Tile { sample: [k, flags, 0, 0], work: [w * h, 0, 0, 0], ..Tile::default() };
        let resolve = Dispatch { entry: "resolve_frame".into(), tile, groups: [(w * h).div_ceil(64), 1, 1] };
        self.run(ctx, &Recording { commands: vec![Command::Dispatch(resolve)] })?;
        self.samples += 1;
        let pixels = w as u64 * h as u64;
        Ok(StepReport {
            pixels,
            eye_rays: pixels,
            trace_time: trace_time + t1.elapsed(),
            frame_done: true,
            camera_version: self.camera_version,
            ..Default::default()
        })
    }

    fn step_frameless(&mut self, ctx: &D) -> Result<StepReport, D::Error> {
        let Mode::Frameless { slice, blend, jitter_pairs, .. } = self.settings.mode else { unreachable!() };
        let visit = (self.positions_since_change / self.pass_len) as u32;
        // A slice ends at the end of the pass and where this visit since the change ends, so
        // every slice's pixels share one sample index.
        let to_visit_end = self.pass_len - self.positions_since_change % self.pass_len;
        let len = (slice.max(1) as u64).min(self.pass_len - self.cursor).min(to_visit_end);
        let first = self.cursor;
        let refine = blend.is_none() && !jitter_pairs;
        let mut flags = FRAME_WRITE;
        if jitter_pairs {
            flags |= FRAME_JITTER_PAIRS | FRAME_BLEND;
        } else if blend.is_some() {
            flags |= FRAME_BLEND;
        } else if visit > 0 {
            flags |= FRAME_ACCUMULATE;
        }
        let alpha = if jitter_pairs { 0.5 } else { blend.unwrap_or(1.0) };
        let jitter = if refine { refinement_jitter(visit) } else { [0.0, 0.0] };
        let (kind, bits, state) = match &self.dissolve {
            Some((d, state)) => (ORDER_DISSOLVE, d.bits, *state),
            None => (ORDER_TABLE, 0, 0),
        };
        let t0 = Instant::now();
        let commands = self
            .passes
            .iter()
            .map(|&pass| {
                let tile = Tile {
                    pass_range: pass,
                    work: [first as u32, len as u32, kind, bits],
                    sample: [visit, flags, state, 0],
                    jitter: [jitter[0], jitter[1], alpha, 0.0],
                    ..Tile::default()
                };
                let groups = [(len as u32).div_ceil(64), 1, 1];
                Command::Dispatch(Dispatch { entry: "render_slice".into(), tile, groups })
            })
            .collect();
        self.run(ctx, &Recording { commands })?;
        let trace_time = t0.elapsed();
        self.cursor += len;
        self.positions_since_change += len;
        let pass_done = self.cursor == self.pass_len;
        if pass_done {
            self.cursor = 0;
        }
        if self.positions_since_change.is_multiple_of(self.pass_len) {
            self.samples += 1;
        }
        let [w, h] = self.size();
        let pixels = match &mut self.dissolve {
            // Values past the image are skipped: count the positions that name pixels, and
            // step the register to the next slice's first state.
            Some((d, state)) => {
                let mut n = 0;
                for _ in 0..len {
                    n += (*state as u64 <= w as u64 * h as u64) as u64;
                    *state = d.step(*state);
                }
                n
            }
            None => len,
        };
        Ok(StepReport {
            pixels,
            eye_rays: pixels * if jitter_pairs { 2 } else { 1 },
            trace_time,
            frame_done: pass_done,
            slice: Some(SliceSpan { first, len }),
            camera_version: self.camera_version,
            idle: false,
        })
    }

    /// The frame buffer as an image (each pixel the mean of its samples): what is on screen.
    pub fn try_read_image(&self, ctx: &D) -> Result<Image, D::Error> {
        let [w, h] = self.size();
        let f = self.bound(ctx).read_frame()?;
        let pixels = f[..(w * h) as usize]
            .iter()
            .map(|p| if p[3] > 0.0 { [p[0] / p[3], p[1] / p[3], p[2] / p[3]] } else { [0.0; 3] })
            .collect();
        Ok(Image { width: w, height: h, pixels })
    }

    /// The raw output buffer of the last traced pixels (rgb radiance, alpha 2 × loop
    /// iterations + eye hit), for tests that compare modes bit for bit.
    pub fn try_read_output(&mut self, ctx: &D) -> Result<Vec<[f32; 4]>, D::Error> {
        let [w, h] = self.size();
        let (out, _) = self.bound(ctx).read_output()?;
        let out = out[..(w * h) as usize].to_vec();
        self.max_loop_iterations = out.iter().map(|p| p[3] as u32 >> 1).max().unwrap_or(0);
        if self.max_loop_iterations > LAVAPIPE_LOOP_LIMIT / 2 {
            log::warn!(
                "an invocation ran {} shader loop iterations; lavapipe stops loops after {LAVAPIPE_LOOP_LIMIT}",
                self.max_loop_iterations
            );
        }
        Ok(out)
    }
}

/// The wgpu path, whose dispatches cannot fail (its errors surface as device loss): the values
/// without a `Result`, and the frame buffer the window blits.
impl Session<GpuContext> {
    /// [`Session::try_step`].
    pub fn step(&mut self, ctx: &GpuContext) -> StepReport {
        infallible(self.try_step(ctx))
    }

    /// [`Session::try_complete_pass`].
    pub fn complete_pass(&mut self, ctx: &GpuContext) -> Duration {
        infallible(self.try_complete_pass(ctx))
    }

    /// [`Session::try_read_image`].
    pub fn read_image(&self, ctx: &GpuContext) -> Image {
        infallible(self.try_read_image(ctx))
    }

    /// [`Session::try_read_output`].
    pub fn read_output(&mut self, ctx: &GpuContext) -> Vec<[f32; 4]> {
        infallible(self.try_read_output(ctx))
    }

    /// The frame buffer the window blits: `size()[0] × size()[1]` vec4s, row-major, rgb the sum
    /// of a pixel's samples and a their count (0: never traced).
    pub fn frame_buffer(&self) -> &wgpu::Buffer {
        self.dispatcher.frame_buffer()
    }
}

/// Whether a viewer's session over `scene` (posed from `base`, with `settings` applied) traces
/// the grid while its BVH builds on another thread: `auto` picks the BVH and the scene is past
/// [`BACKGROUND_BVH_ABOVE`] primitives.
fn builds_bvh_in_background(settings: &Settings, base: &Scene, scene: &Scene) -> bool {
    settings.accel == AccelChoice::Auto
        && settings.accel.resolve(base) == AccelKind::Bvh(BvhWalk::Stackless)
        && scene.primitive_count() > BACKGROUND_BVH_ABOVE
}

/// A session's first accelerator: a grid in the animation's frame (`Grid::update` then moves only
/// what moves) or fitted to a still scene; a BVH fitted either way.
fn first_accel(scene: &Scene, kind: AccelKind, frame: &Option<(Frame, DVec3, DVec3)>) -> Accel {
    match (kind, frame) {
        (AccelKind::Grid, Some((f, ..))) => Accel::Grid(Grid::build_in(scene, *f)),
        (AccelKind::Grid, None) => Accel::Grid(Grid::build(scene)),
        (AccelKind::Bvh(walk), _) => Accel::bvh(scene, walk),
    }
}

impl<D: Device> Session<D> {
    /// The grid traced, if the session traces one.
    pub fn grid(&self) -> Option<&Grid> {
        self.accel.grid()
    }

    /// The accelerator for `scene` after its geometry changed: a grid as [`Session::regrid`]
    /// says; a BVH is rebuilt whole (a refit of the moving primitives' boxes would be the
    /// cheaper update, not done yet).
    fn reaccel(&mut self, scene: &Scene, motion: bool) -> Accel {
        match self.accel {
            Accel::Grid(_) => Accel::Grid(self.regrid(scene, motion)),
            Accel::Bvh(_, walk) => {
                self.ordered_eye = scene.camera.eye;
                Accel::bvh(scene, walk)
            }
        }
    }

    /// Orders a stackless BVH towards the camera's eye again once the eye has moved
    /// [`REORDER_MOVE`] of the scene's size from the eye it was ordered for: a tree ordered for
    /// one side walks the far side's boxes first when seen from the other (2.7x the loop
    /// iterations on SPD balls_s4 seen from the opposite side). The picture does not change, so
    /// refinement goes on. Unless `at_rest`, only when the last reordering took at most
    /// [`REORDER_BUDGET`].
    fn reorder(&mut self, ctx: &D, at_rest: bool) {
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
        params.eye_grid = D::params(&self.gpu_scene).eye_grid;
        let packed_at = t.elapsed();
        let uploaded = ctx.update_scene(&mut self.gpu_scene, packed, params).and_then(|new_texture| {
            if new_texture {
                ctx.rebind(&mut self.dispatcher, &self.gpu_scene)?;
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

    /// The grid of `scene`: the moving primitives re-inserted into the current grid when only
    /// they moved and the frame still holds them; else a build in the animation's frame (grown
    /// to hold the scene if it must) or, for a still scene, a fitted build.
    fn regrid(&mut self, scene: &Scene, motion: bool) -> Grid {
        let Some((frame, lo, hi)) = self.frame else { return Grid::build(scene) };
        let swept = Grid::bounds_of(scene, &self.moving);
        let inside = swept.is_none_or(|(a, b)| a.cmpge(lo).all() && b.cmple(hi).all());
        if !inside {
            // An overshoot the samples missed: a frame holding it too, from now on.
            let (a, b) = swept.expect("outside means something moved");
            let (lo, hi) = (lo.min(a), hi.max(b));
            let frame = Frame::around(lo, hi, scene.primitive_count());
            self.frame = Some((frame, lo, hi));
            return Grid::build_in(scene, frame);
        }
        let current = self.accel.grid().expect("regrid is only called for a grid");
        if motion && self.incremental && current.frame() == frame {
            current.update(scene, &self.moving)
        } else {
            Grid::build_in(scene, frame)
        }
    }
}

fn make_dispatcher<D: Device>(
    ctx: &D,
    scene: &D::Scene,
    variant: Variant,
    capacity: [u32; 2],
) -> Result<D::Kernel, String> {
    let pixels = capacity[0] as u64 * capacity[1] as u64;
    let [tx, ty] = tile_grid(capacity[0], capacity[1]);
    let work_len = pixels.max(tx as u64 * ty as u64 + 1).max(Dissolve::new(pixels).jumps().len() as u64);
    let modes = ModeBuffers { work_len, frame_len: pixels };
    ctx.compile(scene, Kernel::Modes, variant, pixels, &[], modes)
}

// render_queue's workgroup is one tile.
const _: () = assert!(TILE_W * TILE_H == 64);

impl Schedule {
    /// The workers P a schedule is built for by default on `ctx`'s device: lavapipe's threads
    /// (`backend::dealing_threads`: `LP_NUM_THREADS`, else one a core), or a GPU's many workgroups in flight.
    pub fn default_workers(ctx: &impl Device) -> u32 {
        if ctx.is_cpu() {
            crate::gpu::backend::dealing_threads(ctx)
        } else {
            256
        }
    }
}
