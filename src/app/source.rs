//! What the window drives: the pictures' source, as the viewer needs it of
//! [`crate::render::Session`] — the scene as given and as posed, settings, size, camera, time,
//! live edits, a step of work, refinement, and the picture to show. [`Local`] is a session on
//! the window's own device; [`Distributed`] is the MPI master ([`crate::dist::master`]), whose
//! workers trace and whose host frame buffer (assembled on rank 0) is what the window shows.

use super::blit::Shown;
use crate::dist::cluster::Cluster;
use crate::dist::master::{Deadlines, Master};
use crate::gpu::GpuContext;
use crate::image::Image;
use crate::render::{Mode, PixelOrder, Schedule, Session, Settings, StepReport, UpdateReport};
use crate::scene::{Camera, Scene};
use anyhow::{anyhow, Result};
use std::time::{Duration, Instant};

/// The viewer's tracer. Methods that may reach the device take the window's context.
pub trait Source {
    /// The scene as traced now (posed at the current time, settings applied).
    fn scene(&self) -> &Scene;
    /// The scene as given (lights and materials as written: what an edit changes).
    fn base_scene(&self) -> &Scene;
    fn settings(&self) -> &Settings;
    /// The picture's size in pixels.
    fn size(&self) -> [u32; 2];
    fn camera(&self) -> &Camera;
    /// The view of `camera` (its size is the source's).
    fn set_camera(&mut self, ctx: &GpuContext, camera: &Camera) -> Result<()>;
    fn set_size(&mut self, ctx: &GpuContext, width: u32, height: u32) -> Result<()>;
    /// The scene at time `t` (animated scenes).
    fn set_time(&mut self, ctx: &GpuContext, t: f64) -> Result<UpdateReport>;
    /// A live edit: the scene as given becomes `scene` (the camera stays).
    fn set_scene(&mut self, ctx: &GpuContext, scene: &Scene) -> Result<UpdateReport>;
    fn apply(&mut self, ctx: &GpuContext, settings: Settings) -> Result<()>;
    /// Frameless: the next steps' slice size, restarting nothing (the MPI master keeps its own).
    fn set_slice(&mut self, _slice: u32) {}
    /// Conventional: the next frame's schedule, between frames, restarting nothing; whether it
    /// changed (the MPI master keeps its own).
    fn set_schedule(&mut self, _ctx: &GpuContext, _schedule: Schedule) -> Result<bool> {
        Ok(false)
    }
    /// One step of work: a wave or slice on the device, or one turn of the master's loop.
    fn step(&mut self, ctx: &GpuContext) -> Result<StepReport>;
    /// Samples per pixel so far since the last change.
    fn samples(&self) -> u32;
    fn converged(&self) -> bool;
    /// Positions of one frameless pass (pixel age is counted over it).
    fn pass_len(&self) -> u64;
    /// The pixels the last frameless slice traced, where the order is not a fixed permutation
    /// (adaptive; see `Session::last_slice_pixels`).
    fn last_slice_pixels(&self) -> Option<&[u32]> {
        None
    }
    /// The picture to present, in the frame buffer's layout.
    fn shown(&self) -> Shown<'_>;
    /// Brings what [`Self::shown`] draws up to date (the adaptive order's fill).
    fn prepare_shown(&mut self) {}
    /// The picture as an image, as the screen shows it (a screenshot).
    fn read_image(&mut self, ctx: &GpuContext) -> Result<Image>;
    /// Adopts an accelerator built in the background, if one is ready: whether it did.
    fn adopt_bvh(&mut self, _ctx: &GpuContext) -> Result<bool> {
        Ok(false)
    }
    /// A BVH is building in the background while the grid is traced.
    fn bvh_pending(&self) -> bool {
        false
    }
    /// Who traces, in a few words (the HUD's device line).
    fn device(&self, ctx: &GpuContext) -> String {
        ctx.info.name.clone()
    }
    /// The window closed: the work ends (workers are told).
    fn finish(self: Box<Self>) {}
}

/// A session on the window's device.
pub struct Local(pub Session);

impl Source for Local {
    fn scene(&self) -> &Scene {
        self.0.scene()
    }
    fn base_scene(&self) -> &Scene {
        self.0.base_scene()
    }
    fn settings(&self) -> &Settings {
        self.0.settings()
    }
    fn size(&self) -> [u32; 2] {
        self.0.size()
    }
    fn camera(&self) -> &Camera {
        self.0.camera()
    }
    fn set_camera(&mut self, ctx: &GpuContext, camera: &Camera) -> Result<()> {
        self.0.set_camera(ctx, camera);
        Ok(())
    }
    fn set_size(&mut self, ctx: &GpuContext, width: u32, height: u32) -> Result<()> {
        Ok(self.0.set_size(ctx, width, height)?)
    }
    fn set_time(&mut self, ctx: &GpuContext, t: f64) -> Result<UpdateReport> {
        Ok(self.0.set_time(ctx, t)?)
    }
    fn set_scene(&mut self, ctx: &GpuContext, scene: &Scene) -> Result<UpdateReport> {
        Ok(self.0.set_scene(ctx, scene)?)
    }
    fn apply(&mut self, ctx: &GpuContext, settings: Settings) -> Result<()> {
        Ok(self.0.apply(ctx, settings)?)
    }
    fn set_slice(&mut self, slice: u32) {
        self.0.set_slice(slice);
    }
    fn set_schedule(&mut self, ctx: &GpuContext, schedule: Schedule) -> Result<bool> {
        Ok(self.0.set_schedule(ctx, schedule)?)
    }
    fn step(&mut self, ctx: &GpuContext) -> Result<StepReport> {
        Ok(self.0.step(ctx))
    }
    fn samples(&self) -> u32 {
        self.0.samples()
    }
    fn last_slice_pixels(&self) -> Option<&[u32]> {
        self.0.last_slice_pixels()
    }
    fn converged(&self) -> bool {
        self.0.converged()
    }
    fn pass_len(&self) -> u64 {
        self.0.pass_len()
    }
    fn shown(&self) -> Shown<'_> {
        Shown::Device(self.0.frame_buffer(), self.0.fill())
    }
    fn prepare_shown(&mut self) {
        self.0.update_fill();
    }
    fn read_image(&mut self, ctx: &GpuContext) -> Result<Image> {
        // As the screen shows it: filled where the last present was.
        let image = self.0.read_image(ctx);
        Ok(self.0.filled(image))
    }
    fn adopt_bvh(&mut self, ctx: &GpuContext) -> Result<bool> {
        Ok(self.0.adopt_bvh(ctx)?.is_some())
    }
    fn bvh_pending(&self) -> bool {
        self.0.bvh_pending()
    }
}

/// How long one step of the master waits for a worker's pixels: short, so that input is read
/// often; the pixels that arrive meanwhile are taken at the next step.
const PUMP_WAIT: Duration = Duration::from_millis(4);

/// The MPI master on rank 0: camera, settings and time go to the workers as its state; an edit
/// sends the scene again (the workers set it up anew; there is no smaller message for it).
pub struct Distributed<'a> {
    master: Master<'a>,
    /// The scene as given, and as posed at `time` with the settings applied.
    base: Scene,
    posed: Scene,
    time: f64,
    workers: usize,
    /// How long the workers may take to set an edited scene up.
    setup: Duration,
}

impl<'a> Distributed<'a> {
    /// Starts the job's workers on `scene` (its camera and size) with `settings`.
    pub fn start(
        cluster: &'a Cluster,
        scene: &Scene,
        settings: Settings,
        deadlines: Deadlines,
    ) -> Result<Self> {
        let master = Master::start(cluster, scene, settings, deadlines)?;
        let mut d = Distributed {
            master,
            base: scene.clone(),
            posed: scene.clone(),
            time: 0.0,
            workers: cluster.size() as usize - 1,
            setup: deadlines.setup,
        };
        d.pose();
        Ok(d)
    }

    fn pose(&mut self) {
        let mut posed = self.base.at(self.time);
        posed.camera = self.master.camera().clone();
        self.master.settings().apply_to(&mut posed);
        self.posed = posed;
    }

    fn send(&mut self, camera: &Camera, settings: &Settings) -> Result<()> {
        let t = self.time;
        self.master.set_state(camera, settings, t)?;
        Ok(())
    }
}

impl Source for Distributed<'_> {
    fn scene(&self) -> &Scene {
        &self.posed
    }
    fn base_scene(&self) -> &Scene {
        &self.base
    }
    fn settings(&self) -> &Settings {
        self.master.settings()
    }
    fn size(&self) -> [u32; 2] {
        let c = self.master.camera();
        [c.width, c.height]
    }
    fn camera(&self) -> &Camera {
        self.master.camera()
    }
    fn set_camera(&mut self, _: &GpuContext, camera: &Camera) -> Result<()> {
        let [w, h] = self.size();
        let camera = Camera { width: w, height: h, ..camera.clone() };
        let settings = self.master.settings().clone();
        self.send(&camera, &settings)
    }
    fn set_size(&mut self, _: &GpuContext, width: u32, height: u32) -> Result<()> {
        let camera = Camera { width, height, ..self.master.camera().clone() };
        let settings = self.master.settings().clone();
        self.send(&camera, &settings)
    }
    fn set_time(&mut self, _: &GpuContext, t: f64) -> Result<UpdateReport> {
        let start = Instant::now();
        self.time = t;
        let (camera, settings) = (self.master.camera().clone(), self.master.settings().clone());
        self.send(&camera, &settings)?;
        self.pose();
        Ok(UpdateReport { pose: start.elapsed(), ..Default::default() })
    }
    fn set_scene(&mut self, _: &GpuContext, scene: &Scene) -> Result<UpdateReport> {
        scene.validate().map_err(|e| anyhow!(e.0))?;
        let start = Instant::now();
        let base = Scene { camera: self.base.camera.clone(), ..scene.clone() };
        self.master.set_scene(&base, self.setup)?;
        self.base = base;
        self.pose();
        Ok(UpdateReport { upload: start.elapsed(), ..Default::default() })
    }
    fn apply(&mut self, _: &GpuContext, settings: Settings) -> Result<()> {
        if let Mode::Frameless { order: PixelOrder::Adaptive { .. }, .. } = settings.mode {
            // Refused before it reaches the master, which would end the job over it.
            return Err(anyhow!("the adaptive order runs in one process, not with --mpi"));
        }
        let settings =
            crate::render::pieces::split_settings(settings).map_err(|e| anyhow!("{e} with --mpi"))?;
        let camera = self.master.camera().clone();
        self.send(&camera, &settings)?;
        self.pose();
        Ok(())
    }
    fn step(&mut self, _: &GpuContext) -> Result<StepReport> {
        let (mut report, applied) = self.master.pump_applied(PUMP_WAIT)?;
        // The frameless positions that reached the frame buffer in this turn: the HUD's pixel age
        // counts them as traced now (the replay times each by its state's camera).
        let positions: u64 = applied.iter().filter(|a| !a.frame).map(|a| a.positions).sum();
        if positions > 0 {
            report.slice = Some(crate::render::SliceSpan { first: 0, len: positions });
        }
        Ok(report)
    }
    fn samples(&self) -> u32 {
        self.master.samples()
    }
    fn converged(&self) -> bool {
        self.master.converged()
    }
    fn pass_len(&self) -> u64 {
        let [w, h] = self.size();
        w as u64 * h as u64
    }
    fn shown(&self) -> Shown<'_> {
        Shown::Host(self.master.frame().bytes())
    }
    fn read_image(&mut self, _: &GpuContext) -> Result<Image> {
        Ok(self.master.frame().image())
    }
    fn device(&self, _: &GpuContext) -> String {
        format!("{} MPI workers: {}", self.workers, self.master.device_summary())
    }
    fn finish(self: Box<Self>) {
        self.master.finish();
    }
}
