//! The window's orchestration: winit 0.30's `ApplicationHandler`, one wgpu device shared by the
//! tracer and the surface, and each redraw: input → camera ([`super::input`]) → the session's
//! steps as the host loop says ([`crate::render::host_loop`], the policy `irt replay` measures)
//! → present ([`super::present`]); the next redraw follows at once unless the picture converged
//! and nothing moves (then the loop waits for events). Keys are [`super::keys`]' table.

use super::camera::{camera_toml, scene_bounds, CameraController};
use super::display::{os_words, wayland_reachable};
use super::edit::{self, screenshot_name, Picker, Playback, Selection};
use super::hud::{EditView, HudRequest, HudView, Stats, SCALES, SHADOW_CHOICES};
use super::input::{ButtonIntent, Input};
use super::keys::{self, Action};
use super::present::Presenter;
use super::scale::{fit_divisor, render_size};
use super::source::{Distributed, Local, Source};
use super::ViewOptions;
use crate::dist::cluster::Cluster;
use crate::dist::master::Deadlines;
use crate::gpu::GpuContext;
use crate::render::adapt::Adaptation;
use crate::render::metrics::AgeTracker;
use crate::render::{Cancel, HostLoop, UpdateReport, DEFAULT_SLICE, FRAME_BUDGET};
use crate::render::{Mode, Schedule, Session, Settings};
use crate::scene::{Camera, Scene, MAX_TRACE_DEPTH};
use anyhow::{anyhow, Result};
use std::io::Write as _;
use std::path::PathBuf;
use std::time::{Duration, Instant, SystemTime};
use winit::application::ApplicationHandler;
use winit::event::{ElementState, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::PhysicalKey;
use winit::window::WindowId;

/// "Moving" lasts this long after the last camera change (for the lower resolution).
const MOVING_GRACE: Duration = Duration::from_millis(200);
/// Presents that may follow egui's repaint requests after an input event.
const EGUI_FOLLOWUPS: u32 = 10;
/// The window on `scene` until it is closed; with `cluster`, rank 0 of an MPI job whose workers
/// trace (the job's deadlines for them).
pub fn run(args: ViewOptions, scene: Scene, cluster: Option<(&Cluster, Deadlines)>) -> Result<()> {
    let wayland = wayland_reachable();
    // Before the event loop and the device: Mesa's Wayland probe stays quiet (gpu::instance).
    crate::gpu::instance::ensure_runtime_dir();
    let mut builder = EventLoop::builder();
    let x11 = std::env::var_os("DISPLAY").is_some_and(|d| !d.is_empty());
    if !wayland && x11 {
        // A stale WAYLAND_DISPLAY (no compositor behind it) would make winit fail, not fall back.
        use winit::platform::x11::EventLoopBuilderExtX11;
        builder.with_x11();
    }
    let event_loop = builder.build().map_err(|e| {
        anyhow!(
            "cannot open a window: {} (is DISPLAY or WAYLAND_DISPLAY set? `irt render` works without one)",
            os_words(&e.to_string())
        )
    })?;
    let mut app = App { args, scene: Some(scene), cluster, viewer: None, error: None };
    let ran = event_loop.run_app(&mut app).map_err(|e| anyhow!("the window's event loop failed: {e}"));
    if let Some(v) = app.viewer.take() {
        v.ctx.save_pipeline_cache();
        if app.error.is_none() && ran.is_ok() {
            // Closed as asked: the workers are told the job is over.
            v.source.finish();
        }
    }
    ran?;
    match app.error {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

struct App<'a> {
    cluster: Option<(&'a Cluster, Deadlines)>,
    args: ViewOptions,
    scene: Option<Scene>,
    viewer: Option<Viewer<'a>>,
    error: Option<anyhow::Error>,
}

impl App<'_> {
    fn fail(&mut self, event_loop: &ActiveEventLoop, e: anyhow::Error) {
        if self.error.is_none() {
            self.error = Some(e);
        }
        event_loop.exit();
    }
}

impl ApplicationHandler for App<'_> {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.viewer.is_some() {
            return;
        }
        let Some(scene) = self.scene.take() else { return };
        match Viewer::new(event_loop, &self.args, scene, self.cluster) {
            Ok(v) => {
                v.out.window.request_redraw();
                self.viewer = Some(v);
            }
            Err(e) => self.fail(event_loop, e),
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        let Some(v) = self.viewer.as_mut() else { return };
        match v.window_event(event_loop, event) {
            Ok(()) => {}
            Err(e) => self.fail(event_loop, e),
        }
    }

    fn about_to_wait(&mut self, event_loop: &ActiveEventLoop) {
        let Some(v) = self.viewer.as_mut() else { return };
        match v.out.retry_at {
            Some(t) if t <= Instant::now() => {
                v.out.retry_at = None;
                v.out.window.request_redraw();
                event_loop.set_control_flow(ControlFlow::Wait);
            }
            Some(t) => event_loop.set_control_flow(ControlFlow::WaitUntil(t)),
            None => event_loop.set_control_flow(ControlFlow::Wait),
        }
    }
}

struct Viewer<'a> {
    args: ViewOptions,
    /// The window, its surface, the blit and the HUD.
    out: Presenter,
    ctx: GpuContext,
    /// What traces: a session on this device, or the MPI master.
    source: Box<dyn Source + 'a>,
    /// Who traces, in words (the HUD).
    device: String,
    /// The compact status shows in a corner while the panel is off (not with `--no-hud`).
    compact: bool,
    /// The full HUD panel (`H`, or a click on the compact status).
    panel: bool,
    /// The frameless slice size and the conventional schedule as this device's timings say.
    adapt: Adaptation,
    controller: CameraController,
    input: Input,
    /// When to step, present and cancel (on seconds since `start`).
    host: HostLoop,
    /// Resolution divisor chosen (1, 2, 4) and whether it doubles while moving.
    scale: u32,
    lowres_moving: bool,
    /// The divisor in effect (doubled while moving with `lowres_moving`).
    effective_scale: u32,
    /// Pixels the device's frame buffers hold: the render size never exceeds it.
    frame_most: u64,
    last_move: Option<Instant>,
    /// Settings the user asked for, applied at the next redraw.
    pending: Option<Settings>,
    /// The mode `M` switches back to.
    other_mode: Mode,
    /// A redraw should present even if nothing was traced (HUD input, resize).
    dirty: bool,
    /// Presents left that may follow egui's own repaint requests (after input).
    egui_followups: u32,
    start: Instant,
    last_tick: Instant,
    presents: u64,
    stats: Stats,
    ages: AgeTracker,
    status: String,
    status_until: Option<Instant>,
    /// The HUD says that the grid is traced while a BVH builds (`Session::bvh_pending`).
    bvh_announced: bool,
    picker: Picker,
    selection: Option<Selection>,
    /// The last update of the device's scene (an edit, a new time) and what it cost.
    last_update: Option<(&'static str, UpdateReport)>,
    /// An animated scene's clock (`None` for a still), and when it last advanced.
    playback: Option<Playback>,
    last_play: Instant,
}

fn same_view(a: &Camera, b: &Camera) -> bool {
    a.eye == b.eye && a.look_at == b.look_at && a.up == b.up && a.vfov_deg == b.vfov_deg
}

mod edits;

impl<'a> Viewer<'a> {
    fn new(
        event_loop: &ActiveEventLoop,
        args: &ViewOptions,
        scene: Scene,
        cluster: Option<(&'a Cluster, Deadlines)>,
    ) -> Result<Self> {
        let aspect = scene.camera.width.max(1) as f64 / scene.camera.height.max(1) as f64;
        let (out, ctx) = Presenter::new(event_loop, args, aspect)?;
        let scale = args.scale;
        let win = match (out.minimised, args.size) {
            (false, _) => out.window_size(),
            (true, Some(size)) => size,
            (true, None) => [scene.camera.width, scene.camera.height],
        };
        let frame_most = crate::render::session::buffer_rays(&ctx, &args.settings);
        let [rw, rh] = render_size(win, fit_divisor(win, scale, frame_most));
        let mut traced = scene.clone();
        traced.camera.width = rw;
        traced.camera.height = rh;
        let settings = args.settings.clone();
        let other_mode = match settings.mode {
            Mode::Conventional { .. } | Mode::Bands => args.frameless,
            Mode::Frameless { .. } => args.conventional,
        };
        let present_every = match settings.mode {
            Mode::Frameless { present_every, .. } => present_every,
            _ => 0,
        };
        let adapt = if cluster.is_some() {
            // The master slices as it was told; the window shows what it uses.
            Adaptation::fixed()
        } else {
            let start = match args.frameless {
                Mode::Frameless { slice, .. } => slice,
                _ => DEFAULT_SLICE,
            };
            let queue = match args.conventional {
                Mode::Conventional { schedule, .. } => schedule,
                _ => Schedule::default(),
            };
            Adaptation::new(FRAME_BUDGET, start, queue, args.fixed_slice, args.fixed_schedule)
        };
        let mut source: Box<dyn Source + 'a> = match cluster {
            Some((cluster, deadlines)) => {
                Box::new(Distributed::start(cluster, &traced, settings, deadlines)?)
            }
            None => {
                Box::new(Local(Session::new_interactive(&ctx, &traced, settings).map_err(|e| anyhow!(e))?))
            }
        };
        let playback = scene.is_animated().then(|| Playback::new(scene.duration(), args.time, args.paused));
        let mut last_update = None;
        if let Some(p) = playback {
            last_update = Some(("time", source.set_time(&ctx, p.time)?));
        }
        let controller = CameraController::new(&scene.camera, scene_bounds(&scene));
        let now = Instant::now();
        let ages = AgeTracker::new(source.pass_len(), 0.0);
        let device = source.device(&ctx);
        let mut v = Viewer {
            args: args.clone(),
            out,
            compact: !args.no_hud,
            panel: false,
            adapt,
            controller,
            input: Input::default(),
            host: HostLoop::new(FRAME_BUDGET.as_secs_f64(), present_every, Cancel::FirstWave),
            scale,
            lowres_moving: false,
            effective_scale: scale,
            frame_most,
            last_move: None,
            pending: None,
            other_mode,
            dirty: true,
            egui_followups: EGUI_FOLLOWUPS,
            start: now,
            last_tick: now,
            presents: 0,
            stats: Stats::default(),
            ages,
            status: String::new(),
            status_until: None,
            bvh_announced: false,
            picker: Picker::default(),
            selection: None,
            last_update,
            playback,
            last_play: now,
            source,
            device,
            ctx,
        };
        eprintln!(
            "irt view: {} on {}{}",
            args.scene_name,
            v.ctx.info.name,
            if v.ctx.info.device_type == wgpu::DeviceType::Cpu {
                " (CPU: expect a few frames per second)"
            } else {
                ""
            }
        );
        v.announce_bvh();
        Ok(v)
    }

    /// The device's failure, if it failed (its words say what to do).
    fn check_gpu(&self) -> Result<()> {
        Ok(self.ctx.check()?)
    }

    /// Seconds since the window opened: the host loop's clock.
    fn clock(&self) -> f64 {
        (Instant::now() - self.start).as_secs_f64()
    }

    /// Says, until it is adopted, that a BVH is being built behind the grid: at the start, and
    /// again when a settings change that rebuilds the session starts a new one.
    fn announce_bvh(&mut self) {
        let pending = self.source.bvh_pending();
        if pending && !self.bvh_announced {
            self.say(format!(
                "{} primitives: the grid is traced while the BVH builds",
                self.source.scene().primitive_count()
            ));
            // Until it is adopted: `say`'s message would be gone after a few seconds.
            self.status_until = None;
        }
        self.bvh_announced = pending;
    }

    fn say(&mut self, msg: impl Into<String>) {
        self.status = msg.into();
        self.status_until = Some(Instant::now() + Duration::from_secs(4));
        self.dirty = true;
    }

    fn window_size(&self) -> [u32; 2] {
        self.out.window_size()
    }

    /// Whether anything of the HUD is drawn (the panel or the compact status).
    fn hud_visible(&self) -> bool {
        self.panel || self.compact
    }

    fn over_hud(&self) -> bool {
        let Some(c) = self.input.cursor else { return false };
        self.hud_visible() && self.out.over_hud([c.x, c.y])
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, event: WindowEvent) -> Result<()> {
        let egui_response = self.out.egui.state.on_window_event(&self.out.window, &event);
        // (egui asks to repaint after a redraw too: that is no news.)
        let news = !matches!(event, WindowEvent::RedrawRequested);
        if egui_response.repaint && news && self.hud_visible() {
            self.dirty = true;
            self.egui_followups = EGUI_FOLLOWUPS;
            self.out.window.request_redraw();
        }
        match event {
            WindowEvent::CloseRequested | WindowEvent::Destroyed => event_loop.exit(),
            WindowEvent::Resized(size) => {
                self.out.resize(&self.ctx, size);
                self.dirty = true;
            }
            WindowEvent::RedrawRequested if self.redraw(event_loop)? => self.out.window.request_redraw(),
            WindowEvent::ModifiersChanged(m) => self.input.mods = m.state(),
            WindowEvent::CursorMoved { position, .. } if self.input.cursor_moved(position) => {
                self.out.window.request_redraw();
            }
            WindowEvent::CursorLeft { .. } => self.input.cursor = None,
            WindowEvent::MouseInput { state, button, .. } => {
                let down = state == ElementState::Pressed;
                // A press on the HUD is the HUD's; a release always ends our drag.
                if down && self.over_hud() {
                    return Ok(());
                }
                let light = match self.selection {
                    Some(Selection::Light(i)) if i < self.source.scene().lights.len() => Some((
                        i,
                        self.source.base_scene().lights[i].position,
                        self.source.scene().lights[i].position,
                    )),
                    _ => None,
                };
                match self.input.mouse_button(button, down, light) {
                    ButtonIntent::Pick(at) => self.pick(at),
                    ButtonIntent::LightDropped(i) => {
                        if let Some(p) = self.source.base_scene().lights.get(i).map(|l| l.position) {
                            self.report_edit(format!("light {i} at ({}, {}, {})", p.x, p.y, p.z));
                        }
                    }
                    ButtonIntent::Nothing => {}
                }
                self.out.window.request_redraw();
            }
            WindowEvent::MouseWheel { delta, .. } => {
                if self.over_hud() {
                    return Ok(());
                }
                let notches = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y as f64,
                    MouseScrollDelta::PixelDelta(p) => p.y / 40.0,
                };
                self.controller.wheel(notches);
                self.dirty = true;
                self.out.window.request_redraw();
            }
            WindowEvent::KeyboardInput { event, is_synthetic, .. } => {
                log::debug!(
                    "key {:?} {:?} repeat {} synthetic {is_synthetic}",
                    event.logical_key,
                    event.state,
                    event.repeat
                );
                let down = event.state == ElementState::Pressed;
                // Keys typed into a HUD field (a number being entered) are the HUD's.
                let typing = self.hud_visible() && self.out.egui.ctx.egui_wants_keyboard_input();
                let action = match event.physical_key {
                    PhysicalKey::Code(code) => keys::action(code),
                    PhysicalKey::Unidentified(_) => None,
                };
                if let Some(a) = action {
                    // Fly keys: what is held (a release always counts).
                    let fly = !(down && typing) && self.input.fly_key(a, down);
                    // Synthetic presses (keys already held when the window gains the focus)
                    // only update what is held.
                    if !fly && down && !event.repeat && !is_synthetic && !typing {
                        self.act(event_loop, a)?;
                    }
                }
                self.out.window.request_redraw();
            }
            WindowEvent::Focused(false) => self.input.focus_lost(),
            _ => {}
        }
        Ok(())
    }

    /// A key of the table was pressed.
    fn act(&mut self, event_loop: &ActiveEventLoop, action: Action) -> Result<()> {
        match action {
            Action::Quit => event_loop.exit(),
            Action::Frame => {
                let [w, h] = self.window_size();
                self.controller.frame(w.max(1) as f64 / h.max(1) as f64);
            }
            Action::Reset => self.controller.reset(),
            Action::PrintCamera => {
                let [w, h] = self.window_size();
                let mut out = std::io::stdout().lock();
                let _ = writeln!(out, "{}", camera_toml(&self.controller.camera(w, h)));
                let _ = out.flush();
                self.say("camera printed on stdout");
            }
            Action::Hud => {
                self.panel = !self.panel;
                self.dirty = true;
            }
            Action::Screenshot => self.screenshot()?,
            Action::SaveScene => self.save_scene(),
            Action::NextMaterial => self.next_material_kind(),
            Action::NextLight => self.next_light(),
            Action::PlaySpeed(d) => self.play_speed(if d < 0 { 0.5 } else { 2.0 }),
            Action::PlayPause => self.toggle_play(),
            Action::LightDepth(d) => self.light_depth(d as f64),
            Action::SwitchMode => self.toggle_mode(),
            Action::Depth(d) => self.change_depth(d as i32),
            Action::Scale(d) => self.change_scale(d as i32),
            Action::Iso(d) => self.change_iso(d as f64),
            Action::VolumeLook => self.next_look(),
            Action::Shadows(i) => {
                let name = SHADOW_CHOICES[i as usize];
                let mut s = self.next_settings();
                s.shadows = Some(name.parse().expect("valid shadow mode"));
                self.pending = Some(s);
            }
            // The mouse's and the fly keys' (handled as held keys).
            Action::Orbit
            | Action::Look
            | Action::FlySpeed
            | Action::SpeedModifier
            | Action::Pick
            | Action::DragLight
            | Action::FlyForward
            | Action::FlyLeft
            | Action::FlyBack
            | Action::FlyRight
            | Action::FlyDown
            | Action::FlyUp => {}
        }
        Ok(())
    }

    /// The settings to change: the pending ones, else the session's.
    fn next_settings(&self) -> Settings {
        self.pending.clone().unwrap_or_else(|| self.source.settings().clone())
    }

    fn toggle_mode(&mut self) {
        let mut s = self.next_settings();
        std::mem::swap(&mut s.mode, &mut self.other_mode);
        self.pending = Some(s);
    }

    fn set_mode_named(&mut self, name: &str) {
        if self.next_settings().mode.name() != name {
            self.toggle_mode();
        }
    }

    fn change_depth(&mut self, delta: i32) {
        let mut s = self.next_settings();
        let now = s.max_depth.unwrap_or(self.source.scene().trace.max_depth) as i32;
        s.max_depth = Some((now + delta).clamp(1, MAX_TRACE_DEPTH as i32) as u32);
        self.pending = Some(s);
    }

    /// `steps` > 0: coarser (`[`), < 0: finer (`]`).
    fn change_scale(&mut self, steps: i32) {
        let i = SCALES.iter().position(|&s| s == self.scale).unwrap_or(0) as i32;
        self.scale = SCALES[(i + steps).clamp(0, SCALES.len() as i32 - 1) as usize];
        self.dirty = true;
    }

    fn screenshot(&mut self) -> Result<()> {
        let path =
            self.args.screenshot.clone().unwrap_or_else(|| PathBuf::from(screenshot_name(SystemTime::now())));
        let image = self.source.read_image(&self.ctx)?;
        self.check_gpu()?;
        match image.save_png(&path) {
            Ok(()) => {
                println!("screenshot: {}", path.display());
                let _ = std::io::stdout().flush();
                self.say(format!("wrote {}", path.display()));
            }
            Err(e) => {
                eprintln!("error: writing {}: {e}", path.display());
                self.say(format!("could not write {}: {e}", path.display()));
            }
        }
        Ok(())
    }

    /// One redraw; returns whether another should follow at once.
    fn redraw(&mut self, event_loop: &ActiveEventLoop) -> Result<bool> {
        self.check_gpu()?;
        if self.out.minimised {
            return Ok(false);
        }
        let now = Instant::now();
        let dt = (now - self.last_tick).min(Duration::from_millis(100));
        self.last_tick = now;
        if self.status_until.is_some_and(|t| now > t) {
            self.status.clear();
            self.status_until = None;
        }
        self.input.move_camera(&mut self.controller, dt);

        // Settings.
        if let Some(s) = self.pending.take() {
            if let Err(e) = self.source.apply(&self.ctx, s) {
                self.say(format!("could not apply: {e}"));
            }
            self.check_gpu()?;
            let present_every = match self.source.settings().mode {
                Mode::Frameless { present_every, .. } => present_every,
                _ => 0,
            };
            self.host.set_present_every(present_every);
            self.host.restart();
            self.dirty = true;
        }

        // A large scene's BVH, built on another thread while the grid was traced.
        match self.source.adopt_bvh(&self.ctx) {
            Ok(true) => {
                self.say("the BVH is built: it is traced from now on");
                self.host.restart();
                self.dirty = true;
            }
            Ok(false) => {}
            Err(e) => self.say(format!("could not use the BVH built in the background: {e}")),
        }
        self.announce_bvh();
        if self.source.bvh_pending() && self.out.retry_at.is_none() {
            // Look again shortly, even with nothing left to trace.
            self.out.retry_at = Some(now + Duration::from_millis(100));
        }

        // Edits: the light being dragged follows the cursor (conventional: between frames, so
        // that a drag cannot restart every frame and freeze the picture).
        let [ww, wh] = self.window_size();
        let conventional = matches!(self.source.settings().mode, Mode::Conventional { .. } | Mode::Bands);
        let between_frames = !conventional || !self.host.in_frame();
        if let Some(d) = self.input.light_drag.filter(|_| between_frames) {
            let off = edit::view_offset(self.source.camera(), [ww, wh], d.posed, d.offset.0, d.offset.1);
            let to = d.start + off;
            if self.source.base_scene().lights.get(d.light).is_some_and(|l| l.position != to) {
                self.edit("light moved", |s| s.lights[d.light].position = to);
            }
        }

        // Playback: scene time follows wall time x speed (conventional: between frames).
        if let Some(p) = &mut self.playback {
            if !p.playing {
                self.last_play = now;
            } else if between_frames {
                let wall = (now - self.last_play).as_secs_f64();
                self.last_play = now;
                if p.advance(wall) {
                    let t = p.time;
                    self.set_time(t);
                }
            }
        }

        // Camera: taken now, or held while the conventional frame in flight finishes.
        let camera = self.controller.camera(ww, wh);
        let changed = !same_view(&camera, self.source.camera());
        if changed || self.input.active() {
            self.last_move = Some(now);
        }
        let moving = self.last_move.is_some_and(|t| now - t < MOVING_GRACE);

        // Render size.
        let div = if self.lowres_moving && moving { (self.scale * 2).min(8) } else { self.scale };
        let div = fit_divisor([ww, wh], div, self.frame_most);
        self.effective_scale = div;
        let [rw, rh] = render_size([ww, wh], div);
        if [rw, rh] != self.source.size() {
            self.source.set_size(&self.ctx, rw, rh)?;
            self.host.restart();
        }
        let per_pixel = self.source.last_slice_pixels().is_some();
        if self.ages.pass_len() != self.source.pass_len() || self.ages.is_per_pixel() != per_pixel {
            self.ages = match per_pixel {
                true => AgeTracker::per_pixel(self.source.pass_len(), self.clock()),
                false => AgeTracker::new(self.source.pass_len(), self.clock()),
            };
        }
        if changed && self.host.take_input(conventional, changed) {
            self.source.set_camera(&self.ctx, &camera)?;
            self.host.restart();
        }

        // Trace: one wave of a conventional frame, or frameless slices until a refresh is due.
        let mut present;
        let mut idle;
        loop {
            self.adapt_mode()?;
            let r = self.source.step(&self.ctx)?;
            self.adapt.stepped(&self.source.settings().mode, self.source.pass_len(), &r);
            idle = r.idle;
            if !r.idle {
                self.record(&r);
            }
            present = self.host.stepped(self.clock(), conventional, &r);
            if idle || present || conventional {
                break;
            }
        }
        self.check_gpu()?;
        let scripted = self.args.frames.is_some();
        if idle && (self.dirty || scripted) {
            present = true;
        }
        if present {
            self.present()?;
        }
        if let Some(n) = self.args.frames {
            if present && self.presents.is_multiple_of(100) {
                eprintln!("irt view: {}/{n} pictures", self.presents);
            }
            if self.presents >= n as u64 {
                if self.args.screenshot.is_some() {
                    self.screenshot()?;
                }
                event_loop.exit();
                return Ok(false);
            }
        }
        // Keep going while there is work or motion; a held camera change needs the frame done.
        let playing = self.playback.is_some_and(|p| p.playing && p.duration > 0.0);
        let busy = !idle
            || self.input.active()
            || changed
            || scripted
            || self.pending.is_some()
            || moving
            || playing;
        Ok(busy || (self.dirty && self.out.retry_at.is_none()))
    }

    /// The slice size (before each frameless step) and the schedule (between conventional
    /// frames) as [`Adaptation`] says; neither restarts the picture.
    fn adapt_mode(&mut self) -> Result<()> {
        match self.source.settings().mode {
            Mode::Frameless { slice, .. } => {
                if let Some(s) = self.adapt.slice().filter(|&s| s != slice) {
                    self.source.set_slice(s);
                }
            }
            Mode::Conventional { .. } if !self.host.in_frame() => {
                if let Some(s) = self.adapt.schedule() {
                    self.source.set_schedule(&self.ctx, s)?;
                }
            }
            Mode::Conventional { .. } | Mode::Bands => {}
        }
        Ok(())
    }

    fn record(&mut self, r: &crate::render::StepReport) {
        let now = Instant::now();
        self.stats.step(now, r.eye_rays, r.pixels, r.trace_time);
        let t = (now - self.start).as_secs_f64();
        match (r.slice, self.source.last_slice_pixels()) {
            (Some(_), Some(pixels)) if self.ages.is_per_pixel() => self.ages.record_pixels(t, pixels),
            (Some(span), _) if !self.ages.is_per_pixel() => self.ages.record_slice(t, span.len),
            _ => {}
        }
    }

    /// Blit + HUD + present; times itself.
    fn present(&mut self) -> Result<()> {
        let t0 = Instant::now();
        let window = self.window_size();
        // Without it the fill stays empty: the blit shows the frame buffer as traced.
        if !self.args.no_fill {
            self.source.prepare_shown();
        }
        let settings = self.source.settings();
        let adapting = self.adapt.describe(&settings.mode);
        let hud = self.hud_visible().then(|| HudView {
            panel: self.panel,
            adapting: &adapting,
            adapter: &self.device,
            cpu_device: self.ctx.info.device_type == wgpu::DeviceType::Cpu,
            mode: settings.mode,
            shadows: self.source.scene().trace.shadows,
            soft_pick: self
                .args
                .soft_pick
                .as_ref()
                .filter(|(mode, _)| *mode == self.source.scene().trace.shadows)
                .map(|(_, why)| why.as_str()),
            max_depth: self.source.scene().trace.max_depth,
            render: self.source.size(),
            window,
            scale: self.scale,
            effective_scale: self.effective_scale,
            frame_limit: (fit_divisor(window, self.scale, self.frame_most) > self.scale)
                .then_some(self.frame_most),
            lowres_moving: self.lowres_moving,
            samples: self.source.samples(),
            max_samples: settings.max_samples,
            converged: self.source.converged(),
            age: match settings.mode {
                Mode::Frameless { .. } => Some(self.ages.stats((t0 - self.start).as_secs_f64())),
                Mode::Conventional { .. } | Mode::Bands => None,
            },
            speed: self.controller.speed(self.input.speed_modifier()),
            status: &self.status,
            now: t0,
            stats: &self.stats,
            edit: EditView {
                base: self.source.base_scene(),
                selection: self.selection,
                last_update: self.last_update,
                playback: self.playback,
            },
        });
        let shown = self.source.shown();
        let Some(done) = self.out.present(&self.ctx, shown, self.source.size(), hud.as_ref())? else {
            return Ok(());
        };
        let now = Instant::now();
        self.stats.present(now, now - t0);
        self.adapt.presented(now - t0);
        self.presents += 1;
        self.host.presented(self.clock());
        // egui asks for another pass after input (a popup opening, a window settling). Its
        // numbers change every present and its window sizes itself to them, so it would ask
        // for ever: follow up only a few times after real input.
        self.dirty = done.repaint && self.egui_followups > 0;
        self.egui_followups = self.egui_followups.saturating_sub(1);
        if let Some(r) = done.request {
            if r != HudRequest::default() {
                self.apply_hud(r);
            }
        }
        Ok(())
    }
}
