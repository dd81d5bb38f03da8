//! Particles: the points of a simulation, each with a position, perhaps a radius and any number
//! of data fields, drawn as spheres coloured by one field through a colour map (the paper's
//! 35-million-sphere stress model, PAPER.md §9). The spheres themselves are ordinary
//! [`Sphere`](super::Sphere)s; what is kept here is where they came from and how they were drawn,
//! so that `irt convert` can write the file by reference and the HUD can show the colour bar.

use super::colour_map::ColourMap;
use glam::DVec3;
use std::ops::Range;

/// Where a particle's radius comes from.
#[derive(Clone, Debug, PartialEq, Default)]
pub enum Radius {
    /// The file's `radius` property if it has one, else [`auto_radius`].
    #[default]
    Auto,
    /// One radius for every particle.
    Value(f64),
    /// The named property.
    Field(String),
}

/// How a particle file is drawn: what the user chose (TOML `[[particles]]`, or the defaults for
/// a particle file alone).
#[derive(Clone, Debug, PartialEq, Default)]
pub struct ParticleStyle {
    pub radius: Radius,
    /// The field to colour by; `None`: the file's first field (its first property other than the
    /// position and the radius).
    pub field: Option<String>,
    pub map: ColourMap,
    /// The values mapped to the map's ends; `None`: the field's smallest and largest value.
    pub range: Option<[f64; 2]>,
}

/// What a colour bar shows: the field, the values at its ends, the map.
#[derive(Clone, Debug, PartialEq)]
pub struct Legend {
    pub field: String,
    pub lo: f64,
    pub hi: f64,
    pub map: ColourMap,
}

/// One particle file in a scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Particles {
    /// The file as it was named (a path relative to the working directory or absolute).
    pub file: String,
    pub style: ParticleStyle,
    /// Scale (one factor: spheres stay round), rotation (degrees about x, y, z) and offset,
    /// applied in that order as `[[model]]` applies them.
    pub scale: f64,
    pub rotate_deg: DVec3,
    pub translate: DVec3,
    /// Its spheres in `Scene::spheres` and its levels in `Scene::materials`.
    pub spheres: Range<usize>,
    pub materials: Range<usize>,
    /// `None` when the file has no field to colour by (every particle has one material).
    pub legend: Option<Legend>,
}

/// The radius of particles that state none: a third of the mean spacing of `count` points
/// spread evenly over the box `lo..hi`, counting only its sides longer than a millionth of its
/// largest (a plate's points have a spacing over its area, a line's over its length), so that
/// neighbours nearly touch without merging.
pub fn auto_radius(lo: DVec3, hi: DVec3, count: usize) -> f64 {
    let size = (hi - lo).to_array();
    let largest = size.iter().cloned().fold(0.0, f64::max);
    if count == 0 || !(largest > 0.0 && largest.is_finite()) {
        return 0.5;
    }
    let sides: Vec<f64> = size.into_iter().filter(|s| *s > 1e-6 * largest).collect();
    let content: f64 = sides.iter().product();
    let spacing = (content / count as f64).powf(1.0 / sides.len() as f64);
    spacing / 3.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_automatic_radius_follows_the_spacing_in_the_dimensions_the_points_fill() {
        // 1000 points in a unit cube are 0.1 apart; on a 10x10 plate 100 points are 1 apart.
        let r = auto_radius(DVec3::ZERO, DVec3::ONE, 1000);
        assert!((r - 0.1 / 3.0).abs() < 1e-12, "{r}");
        let r = auto_radius(DVec3::ZERO, DVec3::new(10.0, 10.0, 0.0), 100);
        assert!((r - 1.0 / 3.0).abs() < 1e-12, "{r}");
        let r = auto_radius(DVec3::ZERO, DVec3::new(0.0, 0.0, 9.0), 10);
        assert!((r - 0.3).abs() < 1e-12, "{r}");
        // One point, or all in one place: a radius, not a NaN.
        assert_eq!(auto_radius(DVec3::ONE, DVec3::ONE, 1), 0.5);
        assert_eq!(auto_radius(DVec3::ZERO, DVec3::ONE, 0), 0.5);
    }
}
