//! The colour bar of a scene's particles: in the window's bottom-right corner, each particle
//! file's field, its map as a gradient and the values at the map's ends (the range the colours
//! were quantised over, `scene::colour_map`).

use crate::scene::colour_map::MAP_LEVELS;
use crate::scene::particles::Legend;

/// Segments the gradient is painted in (every fourth level: finer than the eye tells apart).
const SEGMENTS: usize = MAP_LEVELS / 4;
const BAR: [f32; 2] = [220.0, 12.0];

/// The numbers at a bar's ends: short, and in scientific notation where a field's values are
/// very large or small.
pub fn end_label(x: f64) -> String {
    let a = x.abs();
    if a != 0.0 && !(1e-3..1e5).contains(&a) {
        format!("{x:.3e}")
    } else {
        let s = format!("{x:.4}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        if s == "-0" {
            "0".into()
        } else {
            s.into()
        }
    }
}

/// Draws one bar per legend, stacked upwards from the bottom-right corner.
pub fn draw(ctx: &egui::Context, legends: &[&Legend]) {
    for (i, l) in legends.iter().enumerate() {
        let frame = egui::Frame::popup(&ctx.global_style())
            .fill(egui::Color32::from_black_alpha(150))
            .inner_margin(egui::Margin::symmetric(6, 4))
            .shadow(egui::epaint::Shadow::NONE);
        egui::Area::new(egui::Id::unique(("irt-colour-bar", i)))
            .anchor(egui::Align2::RIGHT_BOTTOM, [-6.0, -6.0 - 58.0 * i as f32])
            .movable(false)
            .interactable(false)
            .show(ctx, |ui| {
                frame.show(ui, |ui| {
                    let title = format!("{} ({})", l.field, l.map.name());
                    ui.label(egui::RichText::new(title).color(egui::Color32::from_gray(230)));
                    let (rect, _) = ui.allocate_exact_size(BAR.into(), egui::Sense::hover());
                    let w = rect.width() / SEGMENTS as f32;
                    for k in 0..SEGMENTS {
                        let [r, g, b] = l.map.srgb8(k as f64 / (SEGMENTS - 1) as f64);
                        let x = rect.left() + k as f32 * w;
                        let seg = egui::Rect::from_min_max(
                            [x, rect.top()].into(),
                            [x + w + 0.5, rect.bottom()].into(),
                        );
                        ui.painter().rect_filled(seg, 0.0, egui::Color32::from_rgb(r, g, b));
                    }
                    ui.horizontal(|ui| {
                        ui.set_width(BAR[0]);
                        ui.label(
                            egui::RichText::new(end_label(l.lo)).small().color(egui::Color32::from_gray(210)),
                        );
                        ui.with_layout(egui::Layout::right_to_left(egui::Align::Center), |ui| {
                            ui.label(
                                egui::RichText::new(end_label(l.hi))
                                    .small()
                                    .color(egui::Color32::from_gray(210)),
                            );
                        });
                    });
                });
            });
    }
}

#[cfg(test)]
mod tests {
    use super::end_label;

    #[test]
    fn end_labels_are_short() {
        assert_eq!(end_label(3.0), "3");
        assert_eq!(end_label(-1.25), "-1.25");
        assert_eq!(end_label(0.0), "0");
        assert_eq!(end_label(2.0 / 3.0), "0.6667");
        assert_eq!(end_label(1.5e7), "1.500e7");
        assert_eq!(end_label(-2e-5), "-2.000e-5");
    }
}
