//! The HUD: what the loop measured ([`Stats`]) and the live switches, drawn with egui. The
//! drawing returns what the user asked for ([`HudRequest`]); the viewer applies it.

use super::edit::{self, Playback, Selection, KINDS};
use super::keys;
use crate::render::metrics::AgeStats;
use crate::render::UpdateReport;
use crate::render::{Mode, PixelOrder};
use crate::scene::{Light, MaterialKind, Scene, ShadowMode};
use glam::DVec3;
use std::collections::VecDeque;
use std::time::{Duration, Instant};

/// How far back the rates look.
const WINDOW: Duration = Duration::from_secs(1);

/// Rates over the last second of steps and presents, and smoothed per-event times.
#[derive(Debug, Default)]
pub struct Stats {
    /// (when, eye rays, pixels, trace time) per step.
    steps: VecDeque<(Instant, u64, u64, Duration)>,
    presents: VecDeque<Instant>,
    /// Mean trace time of one step and of one present (blit + HUD + present), smoothed.
    pub step_ms: f64,
    pub present_ms: f64,
    /// Steps run for the last present.
    pub steps_per_present: u32,
    steps_since_present: u32,
}

fn smooth(old: f64, new: f64) -> f64 {
    if old == 0.0 {
        new
    } else {
        0.8 * old + 0.2 * new
    }
}

impl Stats {
    pub fn step(&mut self, now: Instant, eye_rays: u64, pixels: u64, trace: Duration) {
        self.steps.push_back((now, eye_rays, pixels, trace));
        self.step_ms = smooth(self.step_ms, trace.as_secs_f64() * 1e3);
        self.steps_since_present += 1;
        self.prune(now);
    }

    pub fn present(&mut self, now: Instant, took: Duration) {
        self.presents.push_back(now);
        self.present_ms = smooth(self.present_ms, took.as_secs_f64() * 1e3);
        self.steps_per_present = self.steps_since_present;
        self.steps_since_present = 0;
        self.prune(now);
    }

    fn prune(&mut self, now: Instant) {
        while self.steps.front().is_some_and(|s| now - s.0 > WINDOW) {
            self.steps.pop_front();
        }
        while self.presents.front().is_some_and(|&t| now - t > WINDOW) {
            self.presents.pop_front();
        }
    }

    /// Presents per second over the last second.
    pub fn fps(&self, now: Instant) -> f64 {
        self.presents.iter().filter(|&&t| now - t <= WINDOW).count() as f64 / WINDOW.as_secs_f64()
    }

    /// (eye rays per wall second, eye rays per second of tracing, pixel updates per wall second)
    /// over the last second.
    pub fn rates(&self, now: Instant) -> (f64, f64, f64) {
        let recent = self.steps.iter().filter(|s| now - s.0 <= WINDOW);
        let (mut rays, mut pixels, mut trace) = (0u64, 0u64, Duration::ZERO);
        for s in recent {
            rays += s.1;
            pixels += s.2;
            trace += s.3;
        }
        let wall = WINDOW.as_secs_f64();
        let per_trace = if trace.is_zero() { 0.0 } else { rays as f64 / trace.as_secs_f64() };
        (rays as f64 / wall, per_trace, pixels as f64 / wall)
    }
}

/// The shadow modes of keys 1..4.
pub const SHADOW_CHOICES: [&str; 4] = ["hard", "bundle:4", "bundle:16", "shell"];

/// Resolution scale divisors of `[` / `]`.
pub const SCALES: [u32; 3] = [1, 2, 4];

pub fn scale_name(div: u32) -> String {
    if div == 1 {
        "1".into()
    } else {
        format!("1/{div}")
    }
}

/// What the HUD shows this present.
pub struct HudView<'a> {
    /// The full panel; otherwise the compact status in a corner.
    pub panel: bool,
    /// How the slice size or the schedule in use came about ([`crate::render::adapt::Adaptation`]).
    pub adapting: &'a str,
    pub adapter: &'a str,
    pub cpu_device: bool,
    pub mode: Mode,
    pub shadows: ShadowMode,
    /// `soft`'s pick for the scene and why, while its mode is in use.
    pub soft_pick: Option<&'a str>,
    pub max_depth: u32,
    pub render: [u32; 2],
    pub window: [u32; 2],
    /// The resolution scale chosen, and the one in effect (lower while moving).
    pub scale: u32,
    pub effective_scale: u32,
    /// The device's frame buffers hold this many pixels, fewer than the window at the scale
    /// chosen: the scale in effect is lowered to fit (`scale::fit_divisor`).
    pub frame_limit: Option<u64>,
    pub lowres_moving: bool,
    pub samples: u32,
    pub max_samples: u32,
    pub converged: bool,
    pub age: Option<AgeStats>,
    pub speed: f64,
    pub status: &'a str,
    pub now: Instant,
    pub stats: &'a Stats,
    pub edit: EditView<'a>,
}

/// What the HUD's edit and playback sections show.
pub struct EditView<'a> {
    /// The scene as given (lights and materials as written: what an edit changes).
    pub base: &'a Scene,
    pub selection: Option<Selection>,
    /// The last update of the device's scene: what caused it, and what it cost.
    pub last_update: Option<(&'a str, UpdateReport)>,
    /// The clock of an animated scene (`None`: a still, no playback controls).
    pub playback: Option<Playback>,
}

/// What the user changed in the HUD.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct HudRequest {
    /// Show the full panel (a click on the compact status) or close it.
    pub panel: Option<bool>,
    pub mode: Option<&'static str>,
    pub order: Option<PixelOrder>,
    pub shadows: Option<ShadowMode>,
    pub max_depth: Option<u32>,
    pub scale: Option<u32>,
    pub lowres_moving: Option<bool>,
    pub frame: bool,
    pub reset: bool,
    pub screenshot: bool,
    /// Select this (`Some(None)`: nothing).
    pub select: Option<Option<Selection>>,
    /// Light `i` becomes this.
    pub light: Option<(usize, Light)>,
    /// Material `i` becomes this kind.
    pub material: Option<(u32, MaterialKind)>,
    pub save_scene: bool,
    pub toggle_play: bool,
    pub seek: Option<f64>,
    /// Playback speed ×this.
    pub speed: Option<f64>,
    /// Volume `i`'s first isovalue becomes this.
    pub iso: Option<(usize, f64)>,
    /// Volume `i` is drawn with this look.
    pub look: Option<(usize, crate::scene::transfer::Look)>,
}

fn ms(d: Duration) -> String {
    format!("{:.1} ms", d.as_secs_f64() * 1e3)
}

/// "1.2 ms (grid 0.8, pack 0.1, upload 0.3)": what an update cost, in milliseconds.
pub fn update_cost(r: &UpdateReport) -> String {
    let f = |d: Duration| format!("{:.1}", d.as_secs_f64() * 1e3);
    if r.uniform_only {
        return format!("{} (the frame uniform alone)", ms(r.total()));
    }
    let grid = match r.accel {
        Some(g) => format!("grid {}", f(g)),
        None => "grid kept".into(),
    };
    let pose = if r.pose.is_zero() { String::new() } else { format!("pose {}, ", f(r.pose)) };
    let kernel = if r.recompiled { ", new kernel" } else { "" };
    format!("{} ({pose}{grid}, pack {}, upload {}{kernel})", ms(r.total()), f(r.pack), f(r.upload))
}

/// Three drag values in a row; whether one changed.
fn drag3(ui: &mut egui::Ui, v: &mut DVec3, speed: f64, range: std::ops::RangeInclusive<f64>) -> bool {
    let mut a = v.to_array();
    let mut changed = false;
    for c in &mut a {
        changed |=
            ui.add(egui::DragValue::new(c).speed(speed).range(range.clone()).max_decimals(3)).changed();
    }
    *v = DVec3::from_array(a);
    changed
}

/// A colour button for a linear colour in [0, 1]³; whether it changed.
fn colour(ui: &mut egui::Ui, c: &mut DVec3) -> bool {
    let mut rgb = c.as_vec3().to_array();
    let changed = ui.color_edit_button_rgb(&mut rgb).changed();
    if changed {
        *c = glam::Vec3::from_array(rgb).as_dvec3().clamp(DVec3::ZERO, DVec3::ONE);
    }
    changed
}

/// The selection, its editor, saving and playback.
fn edit_section(ui: &mut egui::Ui, e: &EditView, req: &mut HudRequest) {
    let scene = e.base;
    ui.horizontal_wrapped(|ui| {
        ui.label(lights_heading(scene.lights.len()));
        for i in 0..scene.lights.len() {
            let on = e.selection == Some(Selection::Light(i));
            if ui.selectable_label(on, light_button(i)).clicked() {
                req.select = Some(if on { None } else { Some(Selection::Light(i)) });
            }
        }
    });
    match e.selection {
        None => {
            ui.label("click an object or a light to edit it");
        }
        Some(Selection::Light(i)) => {
            let Some(light) = scene.lights.get(i) else { return };
            let mut l = light.clone();
            let (mut hue, mut intensity) = edit::split_light_color(l.color);
            let mut changed = false;
            ui.horizontal(|ui| {
                ui.label(format!("{} of {}: position", light_button(i), scene.lights.len()));
                let step = (l.position.length() * 0.005).max(0.01);
                changed |= drag3(ui, &mut l.position, step, f64::MIN..=f64::MAX);
            });
            ui.horizontal(|ui| {
                ui.label("colour");
                changed |= colour(ui, &mut hue);
                ui.label("intensity");
                changed |= ui
                    .add(egui::DragValue::new(&mut intensity).speed(0.01).range(0.0..=1e6).max_decimals(3))
                    .changed();
                ui.label("radius");
                changed |= ui
                    .add(egui::DragValue::new(&mut l.radius).speed(0.01).range(0.0..=1e6).max_decimals(3))
                    .changed();
            });
            if changed {
                l.color = hue * intensity.max(0.0);
                l.radius = l.radius.max(0.0);
                if l != *light {
                    req.light = Some((i, l));
                }
            }
            ui.label("Shift+left drag (or middle drag) moves it; PgUp / PgDn: farther / nearer");
        }
        Some(sel @ Selection::Object(p)) => {
            let Some(m) = edit::object_material(scene, p) else { return };
            let material = &scene.materials[m as usize];
            ui.label(format!("{}: material {m} '{}'", sel.name(), material.name));
            let users = edit::material_users(scene, m);
            if users > 1 {
                ui.colored_label(
                    egui::Color32::from_rgb(255, 200, 80),
                    format!("{users} objects use this material: an edit changes them all"),
                );
            }
            let (mut c, mut eta, mut exponent) = edit::kind_params(&material.kind);
            let mut name = edit::kind_name(&material.kind);
            let mut changed = false;
            ui.horizontal(|ui| {
                ui.label("kind");
                egui::ComboBox::from_id_salt("kind").selected_text(name).show_ui(ui, |ui| {
                    for k in KINDS {
                        ui.selectable_value(&mut name, k, k);
                    }
                });
                changed |= name != edit::kind_name(&material.kind);
                ui.label("(K: next)");
            });
            ui.horizontal(|ui| {
                if name != "dielectric" {
                    ui.label(if name == "metal" { "metal tint" } else { "colour" });
                    changed |= colour(ui, &mut c);
                }
                if name == "dielectric" || name == "polished" {
                    ui.label("eta");
                    changed |= ui
                        .add(egui::DragValue::new(&mut eta).speed(0.005).range(0.01..=10.0).max_decimals(3))
                        .changed();
                }
                if name != "diffuse" {
                    ui.label("exponent");
                    changed |= ui
                        .add(egui::DragValue::new(&mut exponent).speed(0.5).range(0.0..=1e5).max_decimals(1))
                        .changed();
                }
            });
            if changed {
                let kind = edit::make_kind(name, c, eta, exponent);
                if kind != material.kind {
                    req.material = Some((m, kind));
                }
            }
            if material.texture.is_some() {
                ui.label("(textured: the colour multiplies the texture)");
            }
        }
    }
    if let Some((what, r)) = &e.last_update {
        ui.label(format!("last update ({what}): {}", update_cost(r)));
    }
    req.save_scene = ui.button("save scene (T)").clicked();
    if let Some(p) = e.playback {
        ui.separator();
        ui.horizontal(|ui| {
            req.toggle_play = ui.button(if p.playing { "pause (Space)" } else { "play (Space)" }).clicked();
            if ui.small_button("/2").clicked() {
                req.speed = Some(0.5);
            }
            ui.label(format!("speed x{}", p.speed));
            if ui.small_button("x2").clicked() {
                req.speed = Some(2.0);
            }
            ui.label(format!("t = {:.3} / {:.3} s", p.time, p.duration));
        });
        let mut t = p.time;
        let slider = egui::Slider::new(&mut t, 0.0..=p.duration.max(1e-6)).text("time (s)");
        if ui.add(slider).changed() {
            req.seek = Some(t);
        }
    }
}

/// The light selector's heading: how many lights there are, in words ("lights 0" read as "no
/// lights" when it was a button for light #0).
pub fn lights_heading(n: usize) -> String {
    match n {
        0 => "no lights".into(),
        1 => "1 light:".into(),
        n => format!("{n} lights:"),
    }
}

/// A light's button in the selector, and its name in the editor.
pub fn light_button(i: usize) -> String {
    format!("light #{i}")
}

/// The compact status's lines: rates, mode and S or schedule, samples, device (and the CPU
/// note), and how to open the panel.
pub fn compact_lines(v: &HudView) -> Vec<String> {
    let (_, _, pixels) = v.stats.rates(v.now);
    let limit = if v.max_samples > 0 { format!("/{}", v.max_samples) } else { String::new() };
    let conv = if v.converged { ", converged" } else { "" };
    let knob = match v.mode {
        // The order only where it is not the paper's.
        Mode::Frameless { slice, order: PixelOrder::Hilbert { .. }, .. } => format!("S = {slice}"),
        Mode::Frameless { slice, order, .. } => format!("{order}, S = {slice}"),
        Mode::Conventional { schedule, .. } => schedule.to_string(),
        Mode::Bands => String::new(),
    };
    let mut lines = vec![
        format!("{:.1} pictures/s, {} pixel updates/s", v.stats.fps(v.now), si(pixels).trim_end()),
        format!("{} ({knob}), samples {}{limit}{conv}", v.mode.name(), v.samples),
        format!("device: {}", v.adapter),
    ];
    if v.cpu_device {
        lines.push("CPU device (lavapipe): a whole picture is slow; [ lowers the resolution".into());
    }
    lines.push("H or click: panel".into());
    lines
}

/// The compact status: a few lines in the top-left corner, never wider than 45% of the window
/// (so never over its middle); a click on it opens the panel.
fn compact(ctx: &egui::Context, v: &HudView, req: &mut HudRequest) -> egui::Rect {
    let screen = ctx.content_rect();
    let frame = egui::Frame::popup(&ctx.global_style())
        .fill(egui::Color32::from_black_alpha(150))
        .inner_margin(egui::Margin::symmetric(5, 3))
        .shadow(egui::epaint::Shadow::NONE);
    let lines = compact_lines(v);
    let shown = egui::Area::new(egui::Id::unique("irt-status"))
        .anchor(egui::Align2::LEFT_TOP, [6.0, 6.0])
        .movable(false)
        .sense(egui::Sense::click())
        .show(ctx, |ui| {
            frame.show(ui, |ui| {
                ui.set_max_width(screen.width() * 0.45);
                let last = lines.len() - 1;
                for (i, line) in lines.iter().enumerate() {
                    let text = egui::RichText::new(line);
                    let text = if line.starts_with("CPU") {
                        text.color(egui::Color32::from_rgb(255, 200, 80))
                    } else if i == last {
                        text.color(egui::Color32::from_gray(170))
                    } else {
                        text.color(egui::Color32::from_gray(230))
                    };
                    ui.add(egui::Label::new(text).selectable(false).sense(egui::Sense::hover()));
                }
            });
        });
    if shown.response.clicked() {
        req.panel = Some(true);
    }
    shown.response.rect
}

fn si(x: f64) -> String {
    if x >= 1e6 {
        format!("{:.2} M", x / 1e6)
    } else if x >= 1e3 {
        format!("{:.1} k", x / 1e3)
    } else {
        format!("{x:.0} ")
    }
}

/// Draws the HUD into `ctx`; returns the changes asked for and the HUD's rectangle (points).
pub fn draw(ctx: &egui::Context, v: &HudView) -> (HudRequest, Option<egui::Rect>) {
    let mut req = HudRequest::default();
    let legends: Vec<_> = v.edit.base.particles.iter().filter_map(|p| p.legend.as_ref()).collect();
    super::colour_bar::draw(ctx, &legends);
    if !v.panel {
        let rect = compact(ctx, v, &mut req);
        return (req, Some(rect));
    }
    let mut open = true;
    let frame = egui::Frame::window(&ctx.global_style()).fill(egui::Color32::from_black_alpha(170));
    let shown = egui::Window::new("irt")
        .frame(frame)
        .default_pos([8.0, 8.0])
        .resizable(false)
        .collapsible(true)
        .open(&mut open)
        .show(ctx, |ui| {
            ui.label(format!("device: {}", v.adapter));
            if v.cpu_device {
                ui.colored_label(
                    egui::Color32::from_rgb(255, 200, 80),
                    "CPU device (lavapipe): a whole picture is slow; [ lowers the resolution",
                );
            }
            ui.separator();
            let (rays, rays_tracing, pixels) = v.stats.rates(v.now);
            egui::Grid::new("numbers").num_columns(2).spacing([12.0, 2.0]).show(ui, |ui| {
                ui.label("trace");
                ui.label(format!(
                    "{:.1} ms/step, {} steps/picture",
                    v.stats.step_ms, v.stats.steps_per_present
                ));
                ui.end_row();
                ui.label("present");
                ui.label(format!("{:.1} ms (blit + HUD + present)", v.stats.present_ms));
                ui.end_row();
                ui.label("frame rate");
                ui.label(format!("{:.1} pictures/s", v.stats.fps(v.now)));
                ui.end_row();
                ui.label("eye rays/s");
                ui.label(format!("{}/s ({}/s while tracing)", si(rays), si(rays_tracing)));
                ui.end_row();
                ui.label("pixel updates");
                ui.label(format!("{}/s", si(pixels)));
                ui.end_row();
                if let Some(a) = v.age {
                    ui.label("pixel age");
                    ui.label(format!("mean {:.0} ms, p90 {:.0} ms", a.mean * 1e3, a.p90 * 1e3));
                    ui.end_row();
                }
                ui.label("samples");
                let conv = if v.converged { " (converged)" } else { "" };
                let limit = if v.max_samples > 0 { format!(" / {}", v.max_samples) } else { String::new() };
                ui.label(format!("{}{limit}{conv}", v.samples));
                ui.end_row();
                ui.label("render");
                ui.label(format!(
                    "{}x{} of {}x{} (scale {})",
                    v.render[0],
                    v.render[1],
                    v.window[0],
                    v.window[1],
                    scale_name(v.effective_scale)
                ));
                ui.end_row();
                ui.label("mode");
                ui.label(v.mode.to_string());
                ui.end_row();
                ui.label("");
                ui.label(v.adapting);
                ui.end_row();
                ui.label("fly speed");
                ui.label(format!("{:.3} units/s", v.speed));
                ui.end_row();
            });
            if let Some(most) = v.frame_limit {
                ui.colored_label(
                    egui::Color32::from_rgb(255, 200, 120),
                    format!(
                        "the device's frame buffers hold {:.1} Mpixel: {} res",
                        most as f64 / 1e6,
                        scale_name(v.effective_scale)
                    ),
                );
            } else if v.effective_scale != v.scale {
                ui.colored_label(
                    egui::Color32::from_rgb(120, 220, 255),
                    format!("moving: {} res", scale_name(v.effective_scale / v.scale)),
                );
            }
            ui.separator();
            ui.horizontal(|ui| {
                ui.label("mode");
                let mut name = v.mode.name();
                egui::ComboBox::from_id_salt("mode").selected_text(name).show_ui(ui, |ui| {
                    ui.selectable_value(&mut name, "conventional", "conventional");
                    ui.selectable_value(&mut name, "frameless", "frameless");
                });
                if name != v.mode.name() {
                    req.mode = Some(name);
                }
                if let Mode::Frameless { order, .. } = v.mode {
                    let mut o = order;
                    egui::ComboBox::from_id_salt("order").selected_text(o.to_string()).show_ui(ui, |ui| {
                        let adaptive =
                            PixelOrder::Adaptive { revisit: crate::render::adaptive::DEFAULT_REVISIT_PASSES };
                        for choice in
                            [PixelOrder::default(), adaptive, PixelOrder::Random, PixelOrder::Dissolve]
                        {
                            ui.selectable_value(&mut o, choice, choice.to_string());
                        }
                    });
                    if o != order {
                        req.order = Some(o);
                    }
                }
            });
            ui.horizontal(|ui| {
                ui.label("shadows");
                let mut s = v.shadows;
                egui::ComboBox::from_id_salt("shadows").selected_text(s.to_string()).show_ui(ui, |ui| {
                    for name in SHADOW_CHOICES {
                        let choice: ShadowMode = name.parse().expect("valid shadow mode");
                        ui.selectable_value(&mut s, choice, name);
                    }
                });
                if s != v.shadows {
                    req.shadows = Some(s);
                }
            });
            if let Some(why) = v.soft_pick {
                ui.label(egui::RichText::new(why).small());
            }
            ui.horizontal(|ui| {
                ui.label("scale");
                let mut s = v.scale;
                egui::ComboBox::from_id_salt("scale").selected_text(scale_name(s)).show_ui(ui, |ui| {
                    for choice in SCALES {
                        ui.selectable_value(&mut s, choice, scale_name(choice));
                    }
                });
                if s != v.scale {
                    req.scale = Some(s);
                }
                let mut low = v.lowres_moving;
                ui.checkbox(&mut low, "lower resolution while moving");
                if low != v.lowres_moving {
                    req.lowres_moving = Some(low);
                }
            });
            ui.horizontal(|ui| {
                req.frame = ui.button("frame scene (F)").clicked();
                req.reset = ui.button("reset camera (R)").clicked();
                req.screenshot = ui.button("screenshot (P)").clicked();
            });
            ui.separator();
            egui::CollapsingHeader::new("edit").default_open(true).show(ui, |ui| {
                edit_section(ui, &v.edit, &mut req);
            });
            if !v.edit.base.volumes.is_empty() {
                egui::CollapsingHeader::new("volumes").default_open(true).show(ui, |ui| {
                    super::volume_panel::volume_section(ui, v.edit.base, &mut req);
                });
            }
            if !v.status.is_empty() {
                ui.label(v.status);
            }
            egui::CollapsingHeader::new("keys").default_open(false).show(ui, |ui| {
                egui::Grid::new("keys").num_columns(2).spacing([12.0, 0.0]).show(ui, |ui| {
                    for b in keys::TABLE {
                        ui.monospace(keys::plain(b.shown));
                        ui.label(keys::plain(b.words));
                        ui.end_row();
                    }
                });
            });
        });
    if !open {
        req.panel = Some(false);
    }
    (req, shown.map(|r| r.response.rect))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rates_cover_the_last_second() {
        let mut s = Stats::default();
        let t0 = Instant::now();
        for i in 0..10 {
            s.step(t0 + Duration::from_millis(100 * i), 1000, 500, Duration::from_millis(50));
            s.present(t0 + Duration::from_millis(100 * i), Duration::from_millis(5));
        }
        let now = t0 + Duration::from_millis(950);
        let (rays, tracing, pixels) = s.rates(now);
        assert_eq!(rays, 10_000.0);
        assert_eq!(pixels, 5_000.0);
        assert!((tracing - 20_000.0).abs() < 1e-6);
        assert_eq!(s.fps(now), 10.0);
        assert_eq!(s.steps_per_present, 1);
        // Two seconds later nothing is recent.
        assert_eq!(s.fps(now + Duration::from_secs(2)), 0.0);
    }

    #[test]
    fn the_light_selector_says_which_light_and_how_many() {
        assert_eq!(lights_heading(0), "no lights");
        assert_eq!(lights_heading(1), "1 light:");
        assert_eq!(lights_heading(3), "3 lights:");
        // A button reads as the light it selects, not as a count.
        assert_eq!(light_button(0), "light #0");
    }

    fn view<'a>(mode: Mode, stats: &'a Stats, scene: &'a Scene, now: Instant) -> HudView<'a> {
        HudView {
            panel: false,
            adapting: "",
            adapter: "llvmpipe (LLVM 15.0.6, 256 bits)",
            cpu_device: true,
            mode,
            shadows: ShadowMode::Hard,
            soft_pick: None,
            max_depth: 5,
            render: [640, 480],
            window: [640, 480],
            scale: 1,
            effective_scale: 1,
            frame_limit: None,
            lowres_moving: false,
            samples: 3,
            max_samples: 64,
            converged: false,
            age: None,
            speed: 1.0,
            status: "",
            now,
            stats,
            edit: EditView { base: scene, selection: None, last_update: None, playback: None },
        }
    }

    /// The compact status: rate, mode with its S or schedule, samples, device, the CPU note and
    /// the way to the panel, in five short lines.
    #[test]
    fn the_compact_status_says_rate_mode_samples_device_and_the_way_to_the_panel() {
        let mut stats = Stats::default();
        let t0 = Instant::now();
        for i in 0..10 {
            stats.step(t0 + Duration::from_millis(100 * i), 120_000, 120_000, Duration::from_millis(4));
            stats.present(t0 + Duration::from_millis(100 * i), Duration::from_millis(5));
        }
        let scene = crate::scene::default_scene();
        let now = t0 + Duration::from_millis(950);
        let mut mode = Mode::frameless();
        if let Mode::Frameless { slice, .. } = &mut mode {
            *slice = 5632;
        }
        let lines = compact_lines(&view(mode, &stats, &scene, now));
        assert_eq!(
            lines,
            [
                "10.0 pictures/s, 1.20 M pixel updates/s",
                "frameless (S = 5632), samples 3/64",
                "device: llvmpipe (LLVM 15.0.6, 256 bits)",
                "CPU device (lavapipe): a whole picture is slow; [ lowers the resolution",
                "H or click: panel",
            ]
        );
        let plain = Mode::Conventional { schedule: crate::render::Schedule::Plain, workers: 0 };
        let mut v = view(plain, &stats, &scene, now);
        v.cpu_device = false;
        v.converged = true;
        let lines = compact_lines(&v);
        assert_eq!(lines[1], "conventional (plain), samples 3/64, converged");
        if let Mode::Frameless { order, .. } = &mut mode {
            *order = PixelOrder::Adaptive { revisit: 3 };
        }
        assert_eq!(
            compact_lines(&view(mode, &stats, &scene, now))[1],
            "frameless (adaptive, S = 5632), samples 3/64"
        );
        assert_eq!(lines.len(), 4);
    }
}
