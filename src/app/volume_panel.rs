//! The HUD's volume section: per volume, its look and a slider for its isovalue (the first;
//! the others keep their distance to it). Both are uniform-only edits on the device
//! (`render::updates`): nothing is packed or rebuilt, so the slider follows the hand.

use super::hud::HudRequest;
use crate::scene::transfer::LOOKS;
use crate::scene::Scene;

pub fn volume_section(ui: &mut egui::Ui, scene: &Scene, req: &mut HudRequest) {
    for (i, v) in scene.volumes.iter().enumerate() {
        ui.horizontal(|ui| {
            ui.label(format!("volume {i}:"));
            for (name, look) in LOOKS {
                if ui.selectable_label(v.look == look, name).clicked() && v.look != look {
                    req.look = Some((i, look));
                }
            }
            ui.label("(V)");
        });
        let (lo, hi) = v.grid.range();
        if let Some(first) = v.isos.first() {
            let mut x = first.value;
            let slider = egui::Slider::new(&mut x, lo as f64..=hi as f64).text("isovalue (U / I)");
            if ui.add_enabled(v.look == crate::scene::transfer::Look::Iso, slider).changed() {
                req.iso = Some((i, x));
            }
        }
    }
}

/// Volume `i`'s isovalues moved so that the first is `value` (the others keep their distance to
/// it), each clamped to the samples' range.
pub fn set_first_iso(scene: &mut Scene, i: usize, value: f64) {
    let Some(v) = scene.volumes.get_mut(i) else { return };
    let Some(first) = v.isos.first().map(|f| f.value) else { return };
    let (lo, hi) = v.grid.range();
    for iso in &mut v.isos {
        iso.value = (iso.value - first + value).clamp(lo as f64, hi as f64);
    }
}

/// Volume `i` drawn with `look` ([`crate::scene::volume::Volume::switch_look`]).
pub fn set_look(scene: &mut Scene, i: usize, look: crate::scene::transfer::Look) {
    if let Some(v) = scene.volumes.get_mut(i) {
        v.switch_look(look);
    }
}
