//! The viewer's edits and the HUD's requests: picking, lights and materials changed live,
//! playback, the scene written as TOML.

use super::Viewer;
use crate::app::edit::{self, scene_file_name, write_scene, Selection};
use crate::app::hud::{self, HudRequest};
use crate::render::Mode;
use crate::scene::Scene;
use std::io::Write as _;
use std::path::PathBuf;
use std::time::{Instant, SystemTime};
use winit::dpi::PhysicalPosition;

impl Viewer<'_> {
    /// Selects what shows at window position `at` (a light near it, else the object hit).
    pub(super) fn pick(&mut self, at: PhysicalPosition<f64>) {
        let t = Instant::now();
        let sel = self.picker.pick(self.source.scene(), [at.x, at.y], self.window_size());
        let took = t.elapsed();
        self.select(sel);
        log::info!("pick at ({}, {}): {:.2} ms", at.x, at.y, took.as_secs_f64() * 1e3);
    }

    pub(super) fn select(&mut self, sel: Option<Selection>) {
        self.selection = sel;
        let text = sel.map_or("nothing".into(), |s| s.describe(self.source.base_scene()));
        let mut out = std::io::stdout().lock();
        let _ = writeln!(out, "selected: {text}");
        let _ = out.flush();
        self.say(format!("selected {text}"));
    }

    /// Prints `edit: <what>` with the last update's cost on stdout (and the HUD's message line).
    pub(super) fn report_edit(&mut self, what: String) {
        let cost = self.last_update.map_or(String::new(), |(_, r)| format!(" [{}]", hud::update_cost(&r)));
        let mut out = std::io::stdout().lock();
        let _ = writeln!(out, "edit: {what}{cost}");
        let _ = out.flush();
        self.say(what);
    }

    /// Applies `f` to a copy of the scene as given and hands it to the session (from the next
    /// step; refinement restarts). A scene the session refuses leaves everything as it was and
    /// says why in the HUD.
    pub(super) fn edit(&mut self, what: &'static str, f: impl FnOnce(&mut Scene)) -> bool {
        let mut s = self.source.base_scene().clone();
        f(&mut s);
        if s == *self.source.base_scene() {
            return false;
        }
        let ok = match self.source.set_scene(&self.ctx, &s) {
            Ok(r) => {
                self.last_update = Some((what, r));
                true
            }
            Err(e) => {
                self.say(format!("edit refused: {e}"));
                false
            }
        };
        self.host.restart();
        self.dirty = true;
        self.out.window.request_redraw();
        ok
    }

    pub(super) fn selected_light(&mut self, key: &str) -> Option<usize> {
        match self.selection {
            Some(Selection::Light(i)) if i < self.source.scene().lights.len() => Some(i),
            _ => {
                self.say(format!("{key}: select a light first (click near it, L, or the HUD's list)"));
                None
            }
        }
    }

    /// PgUp / PgDn: the selected light a tenth of its distance farther / nearer.
    pub(super) fn light_depth(&mut self, steps: f64) {
        let Some(i) = self.selected_light("PgUp/PgDn") else { return };
        let off = edit::depth_offset(self.source.camera(), self.source.scene().lights[i].position, steps);
        if self.edit("light moved", |s| s.lights[i].position += off) {
            let p = self.source.base_scene().lights[i].position;
            self.report_edit(format!("light {i} at ({}, {}, {})", p.x, p.y, p.z));
        }
    }

    /// K: the selected object's material becomes the next kind.
    pub(super) fn next_material_kind(&mut self) {
        let Some(Selection::Object(p)) = self.selection else {
            self.say("K: select an object first (click it)");
            return;
        };
        let Some(m) = edit::object_material(self.source.base_scene(), p) else { return };
        let kind = edit::next_kind(&self.source.base_scene().materials[m as usize].kind);
        let name = edit::kind_name(&kind);
        if self.edit("material", |s| s.materials[m as usize].kind = kind) {
            self.report_edit(format!("material {m} is now {name}"));
        }
    }

    /// U / I: every volume's isovalues moved by `sign` fiftieths of its samples' range.
    pub(super) fn change_iso(&mut self, sign: f64) {
        if self.source.base_scene().volumes.is_empty() {
            self.say("the scene has no volume");
            return;
        }
        let ok = self.edit("isovalue", |s| {
            for v in &mut s.volumes {
                let (lo, hi) = v.grid.range();
                let step = sign * (hi as f64 - lo as f64) / 50.0;
                for iso in &mut v.isos {
                    iso.value = (iso.value + step).clamp(lo as f64, hi as f64);
                }
            }
        });
        if ok {
            let values: Vec<String> =
                self.source.base_scene().volumes[0].isos.iter().map(|i| format!("{:.4}", i.value)).collect();
            self.report_edit(format!("isovalue {}", values.join(", ")));
        }
    }

    /// V: every volume drawn with the look after the first volume's.
    pub(super) fn next_look(&mut self) {
        let Some(first) = self.source.base_scene().volumes.first() else {
            self.say("the scene has no volume");
            return;
        };
        let look = first.look.next();
        let ok = self.edit("volume look", |s| {
            for i in 0..s.volumes.len() {
                crate::app::volume_panel::set_look(s, i, look);
            }
        });
        if ok {
            self.report_edit(format!("volumes drawn as {}", look.name()));
        }
    }

    /// L: selects the light after the selected one (the first if none is).
    pub(super) fn next_light(&mut self) {
        let n = self.source.scene().lights.len();
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
    pub(super) fn save_scene(&mut self) {
        let path =
            self.args.save.clone().unwrap_or_else(|| PathBuf::from(scene_file_name(SystemTime::now())));
        let [w, h] = self.window_size();
        let mut scene = self.source.base_scene().clone();
        scene.camera = self.controller.camera(w.max(1), h.max(1));
        scene.trace = self.source.scene().trace.clone();
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

    pub(super) fn toggle_play(&mut self) {
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

    pub(super) fn play_speed(&mut self, factor: f64) {
        if let Some(p) = &mut self.playback {
            p.scale_speed(factor);
            let msg = format!("playback speed x{}", p.speed);
            self.say(msg);
        }
    }

    /// Shows scene time `t` from the next step.
    pub(super) fn set_time(&mut self, t: f64) {
        match self.source.set_time(&self.ctx, t) {
            Ok(r) => self.last_update = Some(("time", r)),
            Err(e) => self.say(format!("time {t}: {e}")),
        }
        self.host.restart();
        self.dirty = true;
    }

    pub(super) fn apply_hud(&mut self, r: HudRequest) {
        if let Some(p) = r.panel {
            self.panel = p;
            self.dirty = true;
        }
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
            let now = self.source.scene().trace.max_depth as i32;
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
        if let Some((i, value)) = r.iso {
            if self.edit("isovalue", |s| crate::app::volume_panel::set_first_iso(s, i, value)) {
                self.report_edit(format!("volume {i}: isovalue {value:.4}"));
            }
        }
        if let Some((i, look)) = r.look {
            if self.edit("volume look", |s| crate::app::volume_panel::set_look(s, i, look)) {
                self.report_edit(format!("volume {i} drawn as {}", look.name()));
            }
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
}
