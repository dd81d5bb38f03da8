//! The window and its loop: winit 0.30's `ApplicationHandler`, one wgpu device shared by the
//! tracer and the surface.
//!
//! Each redraw: input → camera → [`Session::step`] → present (→ the next redraw unless the
//! picture converged and nothing moves; then the loop waits for events).
//! - conventional: one wave per redraw, so input is read between waves; the picture is
//!   presented when the frame is whole. New camera input cancels the frame in flight if it is
//!   at most one wave in and no frame was cancelled since the last present; otherwise the frame
//!   is finished first. A sporadic move so shows up to a frame sooner, while a continuous drag
//!   (on a CPU device, input comes faster than waves) cannot cancel every frame and freeze the
//!   screen: it shows a picture at least every frame time plus one wave.
//! - frameless: slices until about one display interval ([`FRAME_BUDGET`]) is spent (at least
//!   one; or exactly `present_every` slices when that is set), then a present.

use super::blit::Blit;
use super::camera::{camera_toml, scene_bounds, CameraController, FlyInput};
use super::edit::{self, Picker, Playback, Selection, CLICK_SLOP};
use super::hud::{self, EditView, HudRequest, HudView, Stats, SCALES, SHADOW_CHOICES};
use super::ViewOptions;
use crate::gpu::{AdapterChoice, CacheSetting, GpuContext};
use crate::render::metrics::AgeTracker;
use crate::render::UpdateReport;
use crate::render::{Mode, Session, Settings};
use crate::scene::{Camera, Scene, MAX_TRACE_DEPTH};
use anyhow::{anyhow, Context as _, Result};
use glam::DVec3;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant, SystemTime};
use winit::application::ApplicationHandler;
use winit::dpi::{PhysicalPosition, PhysicalSize};
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{Key, KeyCode, ModifiersState, NamedKey, PhysicalKey};
use winit::window::{Window, WindowId};

/// Frameless: slices per present fill about one display interval.
pub const FRAME_BUDGET: Duration = Duration::from_millis(16);
/// "Moving" lasts this long after the last camera change (for the lower resolution).
const MOVING_GRACE: Duration = Duration::from_millis(200);
/// Presents that may follow egui's repaint requests after an input event.
const EGUI_FOLLOWUPS: u32 = 10;
/// A tap of a movement key moves at least this long's worth.
const TAP: Duration = Duration::from_millis(50);

pub fn run(args: ViewOptions, scene: Scene) -> Result<()> {
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
            "cannot open a window: {e} (is DISPLAY or WAYLAND_DISPLAY set? `irt render` works without one)"
        )
    })?;
    let mut app = App { args, scene: Some(scene), viewer: None, error: None };
    event_loop.run_app(&mut app).map_err(|e| anyhow!("the window's event loop failed: {e}"))?;
    if let Some(v) = &app.viewer {
        v.ctx.save_pipeline_cache();
    }
    match app.error {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

/// Whether a Wayland compositor's socket is there: `$WAYLAND_SOCKET`, or `$WAYLAND_DISPLAY` as
/// an absolute path or under `$XDG_RUNTIME_DIR`.
fn wayland_reachable() -> bool {
    let var = |name: &str| std::env::var_os(name).filter(|v| !v.is_empty());
    if var("WAYLAND_SOCKET").is_some() {
        return true;
    }
    let Some(display) = var("WAYLAND_DISPLAY") else { return false };
    let path = std::path::Path::new(&display);
    if path.is_absolute() {
        return path.exists();
    }
    var("XDG_RUNTIME_DIR").is_some_and(|dir| std::path::Path::new(&dir).join(path).exists())
}

struct App {
    args: ViewOptions,
    scene: Option<Scene>,
    viewer: Option<Viewer>,
    error: Option<anyhow::Error>,
}

impl App {
    fn fail(&mut self, event_loop: &ActiveEventLoop, e: anyhow::Error) {
        if self.error.is_none() {
            self.error = Some(e);
        }
        event_loop.exit();
    }
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.viewer.is_some() {
            return;
        }
        let Some(scene) = self.scene.take() else { return };
        match Viewer::new(event_loop, &self.args, scene) {
            Ok(v) => {
                v.window.request_redraw();
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
        match v.retry_at {
            Some(t) if t <= Instant::now() => {
                v.retry_at = None;
                v.window.request_redraw();
                event_loop.set_control_flow(ControlFlow::Wait);
            }
            Some(t) => event_loop.set_control_flow(ControlFlow::WaitUntil(t)),
            None => event_loop.set_control_flow(ControlFlow::Wait),
        }
    }
}

/// Mouse and keys as the camera reads them.
#[derive(Default)]
struct Input {
    mods: ModifiersState,
    cursor: Option<PhysicalPosition<f64>>,
    left: bool,
    right: bool,
    /// Where the left button went down (outside the HUD), and how far the cursor went from
    /// there since (a release within `CLICK_SLOP` is a click: it picks).
    press: Option<PhysicalPosition<f64>>,
    travel: f64,
    /// A light being moved in the view plane (Shift+left or middle drag).
    light_drag: Option<LightDrag>,
    /// Drag accumulated since the last redraw, (dx, dy) in pixels.
    orbit: (f64, f64),
    look: (f64, f64),
    // Movement keys held.
    w: bool,
    a: bool,
    s: bool,
    d: bool,
    q: bool,
    e: bool,
    /// Movement keys pressed and released before a redraw saw them held.
    taps: FlyInput,
}

impl Input {
    fn fly(&self) -> FlyInput {
        let axis = |p: bool, n: bool| p as i32 as f64 - n as i32 as f64;
        FlyInput {
            forward: axis(self.w, self.s),
            right: axis(self.d, self.a),
            up: axis(self.e, self.q && self.right),
        }
    }

    fn speed_modifier(&self) -> f64 {
        if self.mods.shift_key() {
            4.0
        } else if self.mods.control_key() {
            0.25
        } else {
            1.0
        }
    }

    fn active(&self) -> bool {
        self.left || self.right || self.light_drag.is_some() || !self.fly().is_zero()
    }
}

/// A light drag: the light, its position when the drag began (as written, and as posed), and
/// the cursor's offset since, in window pixels. The position follows from the start and the
/// whole offset, so a drag back to where it began puts the light back exactly.
#[derive(Clone, Copy)]
struct LightDrag {
    light: usize,
    start: DVec3,
    posed: DVec3,
    offset: (f64, f64),
}

struct Egui {
    ctx: egui::Context,
    state: egui_winit::State,
    renderer: egui_wgpu::Renderer,
    /// The HUD window's rectangle in points at the last present (clicks there are the HUD's).
    rect: Option<egui::Rect>,
    /// The view format egui draws to.
    format: wgpu::TextureFormat,
}

struct Viewer {
    args: ViewOptions,
    window: Arc<Window>,
    instance: wgpu::Instance,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    /// The window is minimised (0×0): nothing is configured or drawn.
    minimised: bool,
    ctx: GpuContext,
    session: Session,
    blit: Blit,
    egui: Egui,
    hud_visible: bool,
    controller: CameraController,
    input: Input,
    /// Resolution divisor chosen (1, 2, 4) and whether it doubles while moving.
    scale: u32,
    lowres_moving: bool,
    /// The divisor in effect (doubled while moving with `lowres_moving`).
    effective_scale: u32,
    last_move: Option<Instant>,
    /// Settings the user asked for, applied at the next redraw.
    pending: Option<Settings>,
    /// The mode `M` switches back to.
    other_mode: Mode,
    /// A redraw should present even if nothing was traced (HUD input, resize).
    dirty: bool,
    /// Presents left that may follow egui's own repaint requests (after input).
    egui_followups: u32,
    retry_at: Option<Instant>,
    start: Instant,
    last_tick: Instant,
    /// Conventional: waves run for the frame in flight; whether a frame was cancelled since the
    /// last present.
    waves_in_flight: u32,
    cancelled: bool,
    presents: u64,
    stats: Stats,
    ages: AgeTracker,
    status: String,
    status_until: Option<Instant>,
    /// The HUD says that the grid is traced while a BVH builds (`Session::bvh_pending`).
    bvh_announced: bool,
    gpu_error: Arc<Mutex<Option<String>>>,
    picker: Picker,
    selection: Option<Selection>,
    /// The last update of the device's scene (an edit, a new time) and what it cost.
    last_update: Option<(&'static str, UpdateReport)>,
    /// An animated scene's clock (`None` for a still), and when it last advanced.
    playback: Option<Playback>,
    last_play: Instant,
}

/// Frame-buffer size for a window of `window` pixels at divisor `div`.
pub fn render_size(window: [u32; 2], div: u32) -> [u32; 2] {
    [window[0].div_ceil(div).max(1), window[1].div_ceil(div).max(1)]
}

fn same_view(a: &Camera, b: &Camera) -> bool {
    a.eye == b.eye && a.look_at == b.look_at && a.up == b.up && a.vfov_deg == b.vfov_deg
}

/// `irt-YYYYmmdd-HHMMSS.png` for now (UTC).
pub fn screenshot_name(t: SystemTime) -> String {
    format!("irt-{}.png", utc_stamp(t))
}

/// `irt-scene-YYYYmmdd-HHMMSS.toml` for now (UTC): where T writes the scene without --save.
pub fn scene_file_name(t: SystemTime) -> String {
    format!("irt-scene-{}.toml", utc_stamp(t))
}

/// Writes `scene` as the native TOML (`io::toml_write`, what `irt convert` writes) to `path`,
/// atomically, its textures beside it first (the TOML never names a file not yet there).
pub fn write_scene(scene: &Scene, path: &Path) -> Result<(), String> {
    let stem = path.file_stem().map_or("scene".into(), |s| s.to_string_lossy().into_owned());
    let files = crate::io::toml_write::to_files(scene, &stem)?;
    if files.toml.len() as u64 > crate::io::MAX_SCENE_FILE_BYTES {
        return Err(format!(
            "the TOML would be {} bytes, above the {}-byte limit irt loads: not written",
            files.toml.len(),
            crate::io::MAX_SCENE_FILE_BYTES
        ));
    }
    let dir = path.parent().unwrap_or(Path::new(""));
    for (name, png) in &files.textures {
        let p = dir.join(name);
        crate::image::write_atomic(&p, png).map_err(|e| format!("writing {}: {e}", p.display()))?;
    }
    crate::image::write_atomic(path, files.toml.as_bytes())
        .map_err(|e| format!("writing {}: {e}", path.display()))
}

/// `YYYYmmdd-HHMMSS` (UTC).
fn utc_stamp(t: SystemTime) -> String {
    let secs = t.duration_since(SystemTime::UNIX_EPOCH).map_or(0, |d| d.as_secs()) as i64;
    let (days, rem) = (secs.div_euclid(86_400), secs.rem_euclid(86_400));
    // Civil date from days since 1970-01-01 (Howard Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + (month <= 2) as i64;
    format!("{year:04}{month:02}{day:02}-{:02}{:02}{:02}", rem / 3600, rem / 60 % 60, rem % 60)
}

impl Viewer {
    fn new(event_loop: &ActiveEventLoop, args: &ViewOptions, scene: Scene) -> Result<Self> {
        let [ww, wh] = args.size;
        let attrs = Window::default_attributes()
            .with_title(format!("irt — {}", args.scene_name))
            .with_inner_size(PhysicalSize::new(ww, wh));
        let window = Arc::new(event_loop.create_window(attrs).context("creating the window")?);

        let mut desc =
            wgpu::InstanceDescriptor::new_with_display_handle(Box::new(event_loop.owned_display_handle()));
        desc.backends = wgpu::Backends::VULKAN;
        let instance = wgpu::Instance::new(desc);
        let surface =
            instance.create_surface(window.clone()).context("creating the window's Vulkan surface")?;
        let choice = AdapterChoice::from_arg_or_env(args.adapter.as_deref());
        let ctx = GpuContext::for_surface(
            &instance,
            &surface,
            &choice,
            &CacheSetting::from_flag_or_env(args.no_cache),
        )?;
        let gpu_error = Arc::new(Mutex::new(None));
        {
            let e = gpu_error.clone();
            ctx.device.on_uncaptured_error(Arc::new(move |err: wgpu::Error| {
                e.lock()
                    .unwrap_or_else(|p| p.into_inner())
                    .get_or_insert_with(|| format!("GPU error: {err}"));
            }));
            let e = gpu_error.clone();
            ctx.device.set_device_lost_callback(move |reason, msg| {
                e.lock()
                    .unwrap_or_else(|p| p.into_inner())
                    .get_or_insert_with(|| format!("the GPU device was lost ({reason:?}): {msg}"));
            });
        }

        let size = window.inner_size();
        let config = surface_config(&surface, &ctx.adapter, size.width.max(1), size.height.max(1))?;
        let minimised = size.width == 0 || size.height == 0;
        if !minimised {
            surface.configure(&ctx.device, &config);
        }
        let blit = Blit::new(&ctx.device, config.format);

        let scale = args.scale;
        let win = if minimised { [ww, wh] } else { [size.width, size.height] };
        let [rw, rh] = render_size(win, scale);
        let mut traced = scene.clone();
        traced.camera.width = rw;
        traced.camera.height = rh;
        let settings = args.settings.clone();
        let other_mode = match settings.mode {
            Mode::Conventional { .. } | Mode::Bands => args.frameless,
            Mode::Frameless { .. } => args.conventional,
        };
        let mut session = Session::new_interactive(&ctx, &traced, settings).map_err(|e| anyhow!(e))?;
        let playback = scene.is_animated().then(|| Playback::new(scene.duration(), args.time, args.paused));
        let mut last_update = None;
        if let Some(p) = playback {
            last_update = Some(("time", session.set_time(&ctx, p.time).map_err(|e| anyhow!(e))?));
        }
        let controller = CameraController::new(&scene.camera, scene_bounds(&scene));

        let egui_ctx = egui::Context::default();
        // A compact HUD: it shares the window with the picture.
        egui_ctx.global_style_mut(|style| {
            for font in style.text_styles.values_mut() {
                font.size = (font.size * 0.85).round();
            }
            style.spacing.item_spacing = egui::vec2(6.0, 2.0);
            style.spacing.button_padding = egui::vec2(3.0, 0.0);
            style.spacing.interact_size.y = 16.0;
        });
        let max_side = ctx.device.limits().max_texture_dimension_2d as usize;
        let state = egui_winit::State::new(
            egui_ctx.clone(),
            egui::ViewportId::ROOT,
            &window,
            Some(window.scale_factor() as f32),
            None,
            Some(max_side),
        );
        // egui blends in gamma space: give it a non-sRGB view of the sRGB image where the device
        // can (VK_KHR_swapchain_mutable_format), else the sRGB image itself.
        let hud_format = config.view_formats.first().copied().unwrap_or(config.format);
        let renderer =
            egui_wgpu::Renderer::new(&ctx.device, hud_format, egui_wgpu::RendererOptions::default());
        let now = Instant::now();
        let ages = AgeTracker::new(session.pass_len(), 0.0);
        let mut v = Viewer {
            args: args.clone(),
            window,
            instance,
            surface,
            config,
            minimised,
            blit,
            egui: Egui { ctx: egui_ctx, state, renderer, rect: None, format: hud_format },
            hud_visible: !args.no_hud,
            controller,
            input: Input::default(),
            scale,
            lowres_moving: false,
            effective_scale: scale,
            last_move: None,
            pending: None,
            other_mode,
            dirty: true,
            egui_followups: EGUI_FOLLOWUPS,
            retry_at: None,
            start: now,
            last_tick: now,
            waves_in_flight: 0,
            cancelled: false,
            presents: 0,
            stats: Stats::default(),
            ages,
            status: String::new(),
            status_until: None,
            bvh_announced: false,
            gpu_error,
            picker: Picker::default(),
            selection: None,
            last_update,
            playback,
            last_play: now,
            session,
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

    fn check_gpu(&self) -> Result<()> {
        match self.gpu_error.lock().unwrap_or_else(|p| p.into_inner()).take() {
            Some(msg) => Err(anyhow!(msg)),
            None => Ok(()),
        }
    }

    /// Says, until it is adopted, that a BVH is being built behind the grid: at the start, and
    /// again when a settings change that rebuilds the session starts a new one.
    fn announce_bvh(&mut self) {
        let pending = self.session.bvh_pending();
        if pending && !self.bvh_announced {
            self.say(format!(
                "{} primitives: the grid is traced while the BVH builds",
                self.session.scene().primitive_count()
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
        [self.config.width, self.config.height]
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, event: WindowEvent) -> Result<()> {
        let egui_response = self.egui.state.on_window_event(&self.window, &event);
        // (egui asks to repaint after a redraw too: that is no news.)
        let news = !matches!(event, WindowEvent::RedrawRequested);
        if egui_response.repaint && news && self.hud_visible {
            self.dirty = true;
            self.egui_followups = EGUI_FOLLOWUPS;
            self.window.request_redraw();
        }
        match event {
            WindowEvent::CloseRequested | WindowEvent::Destroyed => event_loop.exit(),
            WindowEvent::Resized(size) => self.resize(size),
            WindowEvent::RedrawRequested if self.redraw(event_loop)? => self.window.request_redraw(),
            WindowEvent::ModifiersChanged(m) => self.input.mods = m.state(),
            WindowEvent::CursorMoved { position, .. } => {
                if let Some(old) = self.input.cursor {
                    let (dx, dy) = (position.x - old.x, position.y - old.y);
                    if let Some(p) = self.input.press {
                        self.input.travel = self.input.travel.max((position.x - p.x).hypot(position.y - p.y));
                    }
                    if let Some(d) = &mut self.input.light_drag {
                        d.offset.0 += dx;
                        d.offset.1 += dy;
                        self.window.request_redraw();
                    } else if self.input.left {
                        self.input.orbit.0 += dx;
                        self.input.orbit.1 += dy;
                    } else if self.input.right {
                        self.input.look.0 += dx;
                        self.input.look.1 += dy;
                    }
                    if self.input.left || self.input.right {
                        self.window.request_redraw();
                    }
                }
                self.input.cursor = Some(position);
            }
            WindowEvent::CursorLeft { .. } => self.input.cursor = None,
            WindowEvent::MouseInput { state, button, .. } => {
                let down = state == ElementState::Pressed;
                // A press on the HUD is the HUD's; a release always ends our drag.
                if down && self.over_hud() {
                    return Ok(());
                }
                self.mouse_button(button, down);
                self.window.request_redraw();
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
                self.window.request_redraw();
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
                let typing = self.hud_visible && self.egui.ctx.egui_wants_keyboard_input();
                if let PhysicalKey::Code(code) = event.physical_key {
                    if !(down && typing) {
                        self.movement_key(code, down);
                    }
                }
                // Synthetic presses (keys already held when the window gains the focus) only
                // update what is held.
                if down && !event.repeat && !is_synthetic && !typing {
                    self.key(event_loop, &event.logical_key, event.physical_key)?;
                }
                self.window.request_redraw();
            }
            WindowEvent::Focused(false) => {
                // Keys released while another window has the focus never reach us.
                let taps = self.input.taps;
                self.input = Input {
                    mods: ModifiersState::empty(),
                    cursor: self.input.cursor,
                    taps,
                    ..Input::default()
                };
            }
            _ => {}
        }
        Ok(())
    }

    fn mouse_button(&mut self, button: MouseButton, down: bool) {
        let light = match self.selection {
            Some(Selection::Light(i)) if i < self.session.scene().lights.len() => Some(i),
            _ => None,
        };
        let drag_button = match button {
            MouseButton::Left => self.input.mods.shift_key(),
            MouseButton::Middle => true,
            _ => false,
        };
        if let (true, true, Some(i), None) = (down, drag_button, light, self.input.light_drag) {
            self.input.light_drag = Some(LightDrag {
                light: i,
                start: self.session.base_scene().lights[i].position,
                posed: self.session.scene().lights[i].position,
                offset: (0.0, 0.0),
            });
            return;
        }
        if !down && matches!(button, MouseButton::Left | MouseButton::Middle) {
            if let Some(d) = self.input.light_drag.take() {
                let p = self.session.base_scene().lights.get(d.light).map(|l| l.position);
                if let Some(p) = p {
                    self.report_edit(format!("light {} at ({}, {}, {})", d.light, p.x, p.y, p.z));
                }
                if button == MouseButton::Middle || !self.input.left {
                    return;
                }
            }
        }
        match button {
            MouseButton::Left => {
                if down {
                    self.input.press = self.input.cursor;
                    self.input.travel = 0.0;
                } else if self.input.left {
                    let click = self.input.press.take().filter(|_| self.input.travel <= CLICK_SLOP);
                    if let Some(at) = click {
                        self.pick(at);
                    }
                }
                self.input.left = down;
            }
            MouseButton::Right => self.input.right = down,
            _ => {}
        }
    }

    /// Selects what shows at window position `at` (a light near it, else the object hit).
    fn pick(&mut self, at: PhysicalPosition<f64>) {
        let t = Instant::now();
        let sel = self.picker.pick(self.session.scene(), [at.x, at.y], self.window_size());
        let took = t.elapsed();
        self.select(sel);
        log::info!("pick at ({}, {}): {:.2} ms", at.x, at.y, took.as_secs_f64() * 1e3);
    }

    fn select(&mut self, sel: Option<Selection>) {
        self.selection = sel;
        let text = sel.map_or("nothing".into(), |s| s.describe(self.session.base_scene()));
        let mut out = std::io::stdout().lock();
        let _ = writeln!(out, "selected: {text}");
        let _ = out.flush();
        self.say(format!("selected {text}"));
    }

    /// Prints `edit: <what>` with the last update's cost on stdout (and the HUD's message line).
    fn report_edit(&mut self, what: String) {
        let cost = self.last_update.map_or(String::new(), |(_, r)| format!(" [{}]", hud::update_cost(&r)));
        let mut out = std::io::stdout().lock();
        let _ = writeln!(out, "edit: {what}{cost}");
        let _ = out.flush();
        self.say(what);
    }

    /// Applies `f` to a copy of the scene as given and hands it to the session (from the next
    /// step; refinement restarts). A scene the session refuses leaves everything as it was and
    /// says why in the HUD.
    fn edit(&mut self, what: &'static str, f: impl FnOnce(&mut Scene)) -> bool {
        let mut s = self.session.base_scene().clone();
        f(&mut s);
        if s == *self.session.base_scene() {
            return false;
        }
        let ok = match self.session.set_scene(&self.ctx, &s) {
            Ok(r) => {
                self.last_update = Some((what, r));
                true
            }
            Err(e) => {
                self.say(format!("edit refused: {e}"));
                false
            }
        };
        self.waves_in_flight = 0;
        self.dirty = true;
        self.window.request_redraw();
        ok
    }

    fn selected_light(&mut self, key: &str) -> Option<usize> {
        match self.selection {
            Some(Selection::Light(i)) if i < self.session.scene().lights.len() => Some(i),
            _ => {
                self.say(format!("{key}: select a light first (click near it, L, or the HUD's list)"));
                None
            }
        }
    }

    /// PgUp / PgDn: the selected light a tenth of its distance farther / nearer.
    fn light_depth(&mut self, steps: f64) {
        let Some(i) = self.selected_light("PgUp/PgDn") else { return };
        let off = edit::depth_offset(self.session.camera(), self.session.scene().lights[i].position, steps);
        if self.edit("light moved", |s| s.lights[i].position += off) {
            let p = self.session.base_scene().lights[i].position;
            self.report_edit(format!("light {i} at ({}, {}, {})", p.x, p.y, p.z));
        }
    }

    /// K: the selected object's material becomes the next kind.
    fn next_material_kind(&mut self) {
        let Some(Selection::Object(p)) = self.selection else {
            self.say("K: select an object first (click it)");
            return;
        };
        let Some(m) = edit::object_material(self.session.base_scene(), p) else { return };
        let kind = edit::next_kind(&self.session.base_scene().materials[m as usize].kind);
        let name = edit::kind_name(&kind);
        if self.edit("material", |s| s.materials[m as usize].kind = kind) {
            self.report_edit(format!("material {m} is now {name}"));
        }
    }

    /// L: selects the light after the selected one (the first if none is).
    fn next_light(&mut self) {
        let n = self.session.scene().lights.len();
        if n == 0 {
            self.say("the scene has no lights");
            return;
        }
        let i = match self.selection {
            Some(Selection::Light(i)) => (i + 1) % n,
            _ => 0,
        };
        self.select(Some(Selection::Light(i)));
    }

    /// T: writes the scene as given, edits included, with the current camera (at the window's
    /// size) and the shadow mode and depth in effect.
    fn save_scene(&mut self) {
        let path =
            self.args.save.clone().unwrap_or_else(|| PathBuf::from(scene_file_name(SystemTime::now())));
        let [w, h] = self.window_size();
        let mut scene = self.session.base_scene().clone();
        scene.camera = self.controller.camera(w.max(1), h.max(1));
        scene.trace = self.session.scene().trace.clone();
        match write_scene(&scene, &path) {
            Ok(()) => {
                println!("scene: {}", path.display());
                let _ = std::io::stdout().flush();
                self.say(format!("wrote {}", path.display()));
            }
            Err(e) => {
                eprintln!("error: {e}");
                self.say(format!("could not save: {e}"));
            }
        }
    }

    fn toggle_play(&mut self) {
        match &mut self.playback {
            Some(p) => {
                p.playing = !p.playing;
                self.last_play = Instant::now();
                let what = if p.playing { "playing" } else { "paused" };
                self.say(what);
            }
            None => self.say("a still scene: nothing to play"),
        }
    }

    fn play_speed(&mut self, factor: f64) {
        if let Some(p) = &mut self.playback {
            p.scale_speed(factor);
            let msg = format!("playback speed x{}", p.speed);
            self.say(msg);
        }
    }

    /// Shows scene time `t` from the next step.
    fn set_time(&mut self, t: f64) {
        match self.session.set_time(&self.ctx, t) {
            Ok(r) => self.last_update = Some(("time", r)),
            Err(e) => self.say(format!("time {t}: {e}")),
        }
        self.waves_in_flight = 0;
        self.dirty = true;
    }

    fn over_hud(&self) -> bool {
        if !self.hud_visible {
            return false;
        }
        let (Some(rect), Some(c)) = (self.egui.rect, self.input.cursor) else { return false };
        let ppp = self.egui.ctx.pixels_per_point() as f64;
        rect.contains(egui::pos2((c.x / ppp) as f32, (c.y / ppp) as f32))
    }

    fn movement_key(&mut self, code: KeyCode, down: bool) {
        let i = &mut self.input;
        let (held, tap): (&mut bool, &mut f64) = match code {
            KeyCode::KeyW => (&mut i.w, &mut i.taps.forward),
            KeyCode::KeyS => (&mut i.s, &mut i.taps.forward),
            KeyCode::KeyD => (&mut i.d, &mut i.taps.right),
            KeyCode::KeyA => (&mut i.a, &mut i.taps.right),
            KeyCode::KeyE => (&mut i.e, &mut i.taps.up),
            KeyCode::KeyQ => (&mut i.q, &mut i.taps.up),
            _ => return,
        };
        if down && !*held {
            // A press always moves a little, even if released before the next redraw.
            let sign = match code {
                KeyCode::KeyS | KeyCode::KeyA | KeyCode::KeyQ => -1.0,
                _ => 1.0,
            };
            if code != KeyCode::KeyQ || i.right {
                *tap = sign;
            }
        }
        *held = down;
    }

    fn key(&mut self, event_loop: &ActiveEventLoop, logical: &Key, physical: PhysicalKey) -> Result<()> {
        if let Key::Named(NamedKey::Escape) = logical {
            event_loop.exit();
            return Ok(());
        }
        let text = match logical {
            Key::Character(c) => c.to_lowercase(),
            _ => String::new(),
        };
        let code = match physical {
            PhysicalKey::Code(c) => Some(c),
            _ => None,
        };
        match (text.as_str(), code) {
            ("q", _) if !self.input.right => event_loop.exit(),
            ("f", _) => {
                let [w, h] = self.window_size();
                self.controller.frame(w.max(1) as f64 / h.max(1) as f64);
            }
            ("r", _) => self.controller.reset(),
            ("c", _) => {
                let [w, h] = self.window_size();
                let mut out = std::io::stdout().lock();
                let _ = writeln!(out, "{}", camera_toml(&self.controller.camera(w, h)));
                let _ = out.flush();
                self.say("camera printed on stdout");
            }
            ("h", _) => {
                self.hud_visible = !self.hud_visible;
                self.dirty = true;
            }
            ("p", _) => self.screenshot()?,
            ("t", _) => self.save_scene(),
            ("k", _) => self.next_material_kind(),
            ("l", _) => self.next_light(),
            (",", _) => self.play_speed(0.5),
            (".", _) => self.play_speed(2.0),
            (_, Some(KeyCode::Space)) => self.toggle_play(),
            (_, Some(KeyCode::PageUp)) => self.light_depth(1.0),
            (_, Some(KeyCode::PageDown)) => self.light_depth(-1.0),
            ("m", _) => self.toggle_mode(),
            ("+", _) | ("=", _) | (_, Some(KeyCode::NumpadAdd)) => self.change_depth(1),
            ("-", _) | (_, Some(KeyCode::NumpadSubtract)) => self.change_depth(-1),
            ("[", _) => self.change_scale(1),
            ("]", _) => self.change_scale(-1),
            (d @ ("1" | "2" | "3" | "4"), _) => {
                let name = SHADOW_CHOICES[d.parse::<usize>().expect("digit") - 1];
                let mut s = self.next_settings();
                s.shadows = Some(name.parse().expect("valid shadow mode"));
                self.pending = Some(s);
            }
            _ => {}
        }
        Ok(())
    }

    /// The settings to change: the pending ones, else the session's.
    fn next_settings(&self) -> Settings {
        self.pending.clone().unwrap_or_else(|| self.session.settings().clone())
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
        let now = s.max_depth.unwrap_or(self.session.scene().trace.max_depth) as i32;
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
        let image = self.session.read_image(&self.ctx);
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

    fn resize(&mut self, size: PhysicalSize<u32>) {
        self.minimised = size.width == 0 || size.height == 0;
        if !self.minimised {
            self.config.width = size.width;
            self.config.height = size.height;
            self.surface.configure(&self.ctx.device, &self.config);
        }
        self.dirty = true;
        self.window.request_redraw();
    }

    fn apply_hud(&mut self, r: HudRequest) {
        if let Some(m) = r.mode {
            self.set_mode_named(m);
        }
        if let Some(o) = r.order {
            let mut s = self.next_settings();
            if let Mode::Frameless { order, .. } = &mut s.mode {
                *order = o;
            }
            self.pending = Some(s);
        }
        if let Some(sh) = r.shadows {
            let mut s = self.next_settings();
            s.shadows = Some(sh);
            self.pending = Some(s);
        }
        if let Some(d) = r.max_depth {
            let now = self.session.scene().trace.max_depth as i32;
            self.change_depth(d as i32 - now);
        }
        if let Some(sc) = r.scale {
            self.scale = sc;
        }
        if let Some(l) = r.lowres_moving {
            self.lowres_moving = l;
        }
        if r.frame {
            let [w, h] = self.window_size();
            self.controller.frame(w.max(1) as f64 / h.max(1) as f64);
        }
        if r.reset {
            self.controller.reset();
        }
        if r.screenshot {
            // Errors here are reported by the next redraw's GPU check.
            let _ = self.screenshot();
        }
        if let Some(sel) = r.select {
            self.select(sel);
        }
        if let Some((i, light)) = r.light {
            self.edit("light", |s| {
                if let Some(l) = s.lights.get_mut(i) {
                    *l = light;
                }
            });
        }
        if let Some((m, kind)) = r.material {
            self.edit("material", |s| {
                if let Some(x) = s.materials.get_mut(m as usize) {
                    x.kind = kind;
                }
            });
        }
        if r.save_scene {
            self.save_scene();
        }
        if r.toggle_play {
            self.toggle_play();
        }
        if let Some(f) = r.speed {
            self.play_speed(f);
        }
        if let Some(t) = r.seek {
            if let Some(p) = &mut self.playback {
                p.seek(t);
                let t = p.time;
                self.set_time(t);
            }
        }
        self.dirty = true;
    }

    /// One redraw; returns whether another should follow at once.
    fn redraw(&mut self, event_loop: &ActiveEventLoop) -> Result<bool> {
        self.check_gpu()?;
        if self.minimised {
            return Ok(false);
        }
        let now = Instant::now();
        let dt = (now - self.last_tick).min(Duration::from_millis(100));
        self.last_tick = now;
        if self.status_until.is_some_and(|t| now > t) {
            self.status.clear();
            self.status_until = None;
        }

        // Input -> camera.
        let (ox, oy) = std::mem::take(&mut self.input.orbit);
        let (lx, ly) = std::mem::take(&mut self.input.look);
        self.controller.orbit(ox, oy);
        self.controller.look(lx, ly);
        let held = self.input.fly();
        let modifier = self.input.speed_modifier();
        self.controller.fly(held, dt.as_secs_f64(), modifier);
        let taps = std::mem::take(&mut self.input.taps);
        // Taps not also held: a press and release between two redraws.
        let tap_only = FlyInput {
            forward: if held.forward == 0.0 { taps.forward } else { 0.0 },
            right: if held.right == 0.0 { taps.right } else { 0.0 },
            up: if held.up == 0.0 { taps.up } else { 0.0 },
        };
        self.controller.fly(tap_only, TAP.as_secs_f64(), modifier);

        // Settings.
        if let Some(s) = self.pending.take() {
            if let Err(e) = self.session.apply(&self.ctx, s) {
                self.say(format!("could not apply: {e}"));
            }
            self.check_gpu()?;
            self.waves_in_flight = 0;
            self.dirty = true;
        }

        // A large scene's BVH, built on another thread while the grid was traced.
        match self.session.adopt_bvh(&self.ctx) {
            Ok(Some(_)) => {
                self.say("the BVH is built: it is traced from now on");
                self.waves_in_flight = 0;
                self.dirty = true;
            }
            Ok(None) => {}
            Err(e) => self.say(format!("could not use the BVH built in the background: {e}")),
        }
        self.announce_bvh();
        if self.session.bvh_pending() && self.retry_at.is_none() {
            // Look again shortly, even with nothing left to trace.
            self.retry_at = Some(now + Duration::from_millis(100));
        }

        // Edits: the light being dragged follows the cursor (conventional: between frames, so
        // that a drag cannot restart every frame and freeze the picture).
        let [ww, wh] = self.window_size();
        let conventional = matches!(self.session.settings().mode, Mode::Conventional { .. });
        let between_frames = !conventional || self.waves_in_flight == 0;
        if let Some(d) = self.input.light_drag.filter(|_| between_frames) {
            let off = edit::view_offset(self.session.camera(), [ww, wh], d.posed, d.offset.0, d.offset.1);
            let to = d.start + off;
            if self.session.base_scene().lights.get(d.light).is_some_and(|l| l.position != to) {
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

        // Camera, with the conventional frame's hold.
        let camera = self.controller.camera(ww, wh);
        let changed = !same_view(&camera, self.session.camera());
        if changed || self.input.active() {
            self.last_move = Some(now);
        }
        let moving = self.last_move.is_some_and(|t| now - t < MOVING_GRACE);
        let in_flight = conventional && self.waves_in_flight > 0;
        let hold = changed && in_flight && (self.waves_in_flight > 1 || self.cancelled);

        // Render size.
        let div = if self.lowres_moving && moving { (self.scale * 2).min(8) } else { self.scale };
        self.effective_scale = div;
        let [rw, rh] = render_size([ww, wh], div);
        if [rw, rh] != self.session.size() {
            self.session.set_size(&self.ctx, rw, rh).map_err(|e| anyhow!(e))?;
            self.waves_in_flight = 0;
        }
        if self.ages.pass_len() != self.session.pass_len() {
            let now = (Instant::now() - self.start).as_secs_f64();
            self.ages = AgeTracker::new(self.session.pass_len(), now);
        }
        if changed && !hold {
            self.session.set_camera(&self.ctx, &camera);
            self.cancelled |= in_flight;
            self.waves_in_flight = 0;
        }

        // Trace.
        let mut present;
        let mut idle = false;
        let t0 = Instant::now();
        match self.session.settings().mode {
            Mode::Conventional { .. } | Mode::Bands => {
                let r = self.session.step(&self.ctx);
                idle = r.idle;
                if !r.idle {
                    self.record(&r);
                    self.waves_in_flight += 1;
                }
                if r.frame_done || r.idle {
                    self.waves_in_flight = 0;
                }
                present = r.frame_done;
            }
            Mode::Frameless { present_every, .. } => {
                let mut slices = 0;
                loop {
                    let r = self.session.step(&self.ctx);
                    if r.idle {
                        idle = true;
                        break;
                    }
                    self.record(&r);
                    slices += 1;
                    let enough = if present_every > 0 {
                        slices >= present_every
                    } else {
                        t0.elapsed() >= FRAME_BUDGET
                    };
                    if enough {
                        break;
                    }
                }
                present = slices > 0;
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
        Ok(busy || (self.dirty && self.retry_at.is_none()))
    }

    fn record(&mut self, r: &crate::render::StepReport) {
        let now = Instant::now();
        self.stats.step(now, r.eye_rays, r.pixels, r.trace_time);
        if let Some(span) = r.slice {
            self.ages.record_slice((now - self.start).as_secs_f64(), span.len);
        }
    }

    /// Blit + HUD + present; times itself.
    fn present(&mut self) -> Result<()> {
        let t0 = Instant::now();
        let frame = match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(f) => Some((f, false)),
            wgpu::CurrentSurfaceTexture::Suboptimal(f) => Some((f, true)),
            wgpu::CurrentSurfaceTexture::Timeout | wgpu::CurrentSurfaceTexture::Occluded => {
                // Try again a little later rather than spin.
                self.retry_at = Some(Instant::now() + Duration::from_millis(50));
                None
            }
            wgpu::CurrentSurfaceTexture::Outdated => {
                self.surface.configure(&self.ctx.device, &self.config);
                self.window.request_redraw();
                None
            }
            wgpu::CurrentSurfaceTexture::Lost => {
                self.surface = self
                    .instance
                    .create_surface(self.window.clone())
                    .context("the window's surface was lost and could not be made again")?;
                self.surface.configure(&self.ctx.device, &self.config);
                self.window.request_redraw();
                None
            }
            wgpu::CurrentSurfaceTexture::Validation => {
                self.check_gpu()?;
                return Err(anyhow!("the window's surface could not give an image (validation error)"));
            }
        };
        let Some((frame, suboptimal)) = frame else { return Ok(()) };
        let view = frame.texture.create_view(&wgpu::TextureViewDescriptor::default());
        let window = self.window_size();
        let device = &self.ctx.device;
        let queue = &self.ctx.queue;
        let mut encoder =
            device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("present") });

        // The HUD's shapes (before the pass: egui textures and buffers are uploaded first).
        let mut paint = None;
        if self.hud_visible {
            let raw = self.egui.state.take_egui_input(&self.window);
            let now = Instant::now();
            let settings = self.session.settings();
            let view_data = HudView {
                adapter: &self.ctx.info.name,
                cpu_device: self.ctx.info.device_type == wgpu::DeviceType::Cpu,
                mode: settings.mode,
                shadows: self.session.scene().trace.shadows,
                max_depth: self.session.scene().trace.max_depth,
                render: self.session.size(),
                window,
                scale: self.scale,
                effective_scale: self.effective_scale,
                lowres_moving: self.lowres_moving,
                samples: self.session.samples(),
                max_samples: settings.max_samples,
                converged: self.session.converged(),
                age: match settings.mode {
                    Mode::Frameless { .. } => Some(self.ages.stats((now - self.start).as_secs_f64())),
                    Mode::Conventional { .. } | Mode::Bands => None,
                },
                speed: self.controller.speed(self.input.speed_modifier()),
                status: &self.status,
                now,
                stats: &self.stats,
                edit: EditView {
                    base: self.session.base_scene(),
                    selection: self.selection,
                    last_update: self.last_update,
                    playback: self.playback,
                },
            };
            let mut request = HudRequest::default();
            let mut rect = None;
            let mut out = self.egui.ctx.run_pass(raw, |ctx| {
                let (r, area) = hud::draw(ctx, &view_data);
                request = r;
                rect = area;
            });
            self.egui.rect = rect;
            self.egui.state.handle_platform_output(&self.window, out.platform_output);
            let jobs = self.egui.ctx.tessellate(out.shapes, out.pixels_per_point);
            let screen = egui_wgpu::ScreenDescriptor {
                size_in_pixels: window,
                pixels_per_point: out.pixels_per_point,
            };
            let set = std::mem::take(&mut out.textures_delta.set);
            let free = std::mem::take(&mut out.textures_delta.free);
            for (id, deltas) in &set {
                for delta in deltas {
                    self.egui.renderer.update_texture(device, queue, *id, delta);
                }
            }
            let extra = self.egui.renderer.update_buffers(device, queue, &mut encoder, &jobs, &screen);
            let repaint =
                out.viewport_output.get(&egui::ViewportId::ROOT).is_some_and(|v| v.repaint_delay.is_zero());
            paint = Some((jobs, screen, extra, free, request, repaint));
        }
        let attachment = |view| {
            Some(wgpu::RenderPassColorAttachment {
                view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Store },
            })
        };
        {
            // The blit covers every pixel: nothing to clear.
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("blit"),
                color_attachments: &[attachment(&view)],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            self.blit.draw(
                device,
                queue,
                &mut pass,
                self.session.frame_buffer(),
                self.session.size(),
                window,
            );
        }
        if let Some((jobs, screen, ..)) = &paint {
            let hud_view = frame.texture.create_view(&wgpu::TextureViewDescriptor {
                format: Some(self.egui.format),
                ..Default::default()
            });
            let mut pass = encoder
                .begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("hud"),
                    color_attachments: &[attachment(&hud_view)],
                    depth_stencil_attachment: None,
                    timestamp_writes: None,
                    occlusion_query_set: None,
                    multiview_mask: None,
                })
                .forget_lifetime();
            self.egui.renderer.render(&mut pass, jobs, screen);
        }
        let mut buffers = Vec::new();
        let mut request = None;
        let mut repaint = false;
        if let Some((_, _, extra, free, r, rp)) = paint {
            buffers = extra;
            for id in &free {
                self.egui.renderer.free_texture(id);
            }
            request = Some(r);
            repaint = rp;
        }
        buffers.push(encoder.finish());
        queue.submit(buffers);
        self.window.pre_present_notify();
        queue.present(frame);
        // The software present copies the image: wait for it here so that the trace time of the
        // next step does not include it.
        self.ctx.wait();
        self.check_gpu()?;
        if suboptimal {
            self.surface.configure(device, &self.config);
        }
        let now = Instant::now();
        self.stats.present(now, now - t0);
        self.presents += 1;
        self.cancelled = false;
        // egui asks for another pass after input (a popup opening, a window settling). Its
        // numbers change every present and its window sizes itself to them, so it would ask
        // for ever: follow up only a few times after real input.
        self.dirty = repaint && self.egui_followups > 0;
        self.egui_followups = self.egui_followups.saturating_sub(1);
        if let Some(r) = request {
            if r != HudRequest::default() {
                self.apply_hud(r);
            }
        }
        Ok(())
    }
}

/// The surface's configuration: an sRGB format where offered (Bgra8UnormSrgb first), present
/// mode Mailbox > Immediate > Fifo, one frame of latency.
fn surface_config(
    surface: &wgpu::Surface,
    adapter: &wgpu::Adapter,
    w: u32,
    h: u32,
) -> Result<wgpu::SurfaceConfiguration> {
    let caps = surface.get_capabilities(adapter);
    if caps.formats.is_empty() {
        return Err(anyhow!("the window's surface offers no format this device can draw to"));
    }
    let format = [wgpu::TextureFormat::Bgra8UnormSrgb, wgpu::TextureFormat::Rgba8UnormSrgb]
        .into_iter()
        .find(|f| caps.formats.contains(f))
        .or_else(|| caps.formats.iter().copied().find(|f| f.is_srgb()))
        .unwrap_or(caps.formats[0]);
    let present_mode = [wgpu::PresentMode::Mailbox, wgpu::PresentMode::Immediate, wgpu::PresentMode::Fifo]
        .into_iter()
        .find(|m| caps.present_modes.contains(m))
        .unwrap_or(wgpu::PresentMode::Fifo);
    let mut config = surface
        .get_default_config(adapter, w, h)
        .ok_or_else(|| anyhow!("the window's surface is not supported by this device"))?;
    config.format = format;
    config.present_mode = present_mode;
    config.desired_maximum_frame_latency = 1;
    config.usage = wgpu::TextureUsages::RENDER_ATTACHMENT;
    config.view_formats = vec![];
    let gamma = format.remove_srgb_suffix();
    let mutable =
        adapter.get_downlevel_capabilities().flags.contains(wgpu::DownlevelFlags::SURFACE_VIEW_FORMATS);
    if gamma != format && mutable {
        config.view_formats.push(gamma);
    }
    Ok(config)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn render_sizes_round_up_and_never_vanish() {
        assert_eq!(render_size([640, 480], 1), [640, 480]);
        assert_eq!(render_size([641, 481], 2), [321, 241]);
        assert_eq!(render_size([1, 1], 4), [1, 1]);
    }

    #[test]
    fn screenshot_names_are_utc_timestamps() {
        let t = SystemTime::UNIX_EPOCH + Duration::from_secs(951_782_400 + 3 * 3600 + 4 * 60 + 5);
        assert_eq!(screenshot_name(t), "irt-20000229-030405.png");
        assert_eq!(screenshot_name(SystemTime::UNIX_EPOCH), "irt-19700101-000000.png");
        assert_eq!(scene_file_name(t), "irt-scene-20000229-030405.toml");
    }
}
