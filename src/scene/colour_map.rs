//! Colour maps for data: a field's value → a colour, from the `colorous` crate's gradients
//! (matplotlib's perceptual maps, Google's Turbo, ColorBrewer's diverging maps), quantised to
//! [`MAP_LEVELS`] levels so that a particle's colour is one of that many materials.
//!
//! Why levels: the sphere record has room for a material index and nothing else (32 B on the
//! device), and 256 levels are finer than a colour bar can show (8 bits per channel is all the
//! gradients' tables hold). A million spheres then cost no more per sphere than one.

use glam::DVec3;

/// Levels a field is quantised to: level 0 is the map's start, level `MAP_LEVELS - 1` its end.
pub const MAP_LEVELS: usize = 256;

/// A named colour map.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ColourMap {
    #[default]
    Viridis,
    Inferno,
    Magma,
    Plasma,
    Cividis,
    Turbo,
    /// Blue (low) → white → red (high): ColorBrewer's RdBu reversed, for values about a centre.
    Coolwarm,
    Greys,
}

/// Every map with its name, in the order `--help` and the docs list them.
pub const COLOUR_MAPS: [(&str, ColourMap); 8] = [
    ("viridis", ColourMap::Viridis),
    ("inferno", ColourMap::Inferno),
    ("magma", ColourMap::Magma),
    ("plasma", ColourMap::Plasma),
    ("cividis", ColourMap::Cividis),
    ("turbo", ColourMap::Turbo),
    ("coolwarm", ColourMap::Coolwarm),
    ("greys", ColourMap::Greys),
];

impl ColourMap {
    pub fn name(self) -> &'static str {
        COLOUR_MAPS.iter().find(|(_, m)| *m == self).map_or("?", |(n, _)| n)
    }

    /// The map named `name` (case-insensitive), or a message listing the names.
    pub fn parse(name: &str) -> Result<ColourMap, String> {
        COLOUR_MAPS.iter().find(|(n, _)| n.eq_ignore_ascii_case(name)).map(|(_, m)| *m).ok_or_else(|| {
            let names: Vec<&str> = COLOUR_MAPS.iter().map(|(n, _)| *n).collect();
            format!("unknown colour map `{name}`; irt knows {}", names.join(", "))
        })
    }

    /// The map at `t` in [0, 1] (clamped) as 8-bit sRGB, as the crate gives it.
    pub fn srgb8(self, t: f64) -> [u8; 3] {
        let c = match self {
            ColourMap::Viridis => colorous::VIRIDIS.eval_continuous(t),
            ColourMap::Inferno => colorous::INFERNO.eval_continuous(t),
            ColourMap::Magma => colorous::MAGMA.eval_continuous(t),
            ColourMap::Plasma => colorous::PLASMA.eval_continuous(t),
            ColourMap::Cividis => colorous::CIVIDIS.eval_continuous(t),
            ColourMap::Turbo => colorous::TURBO.eval_continuous(t),
            ColourMap::Coolwarm => colorous::RED_BLUE.eval_continuous(1.0 - t),
            ColourMap::Greys => colorous::GREYS.eval_continuous(1.0 - t),
        };
        [c.r, c.g, c.b]
    }

    /// The linear RGB of level `k` (of [`MAP_LEVELS`]): the map at `k / (MAP_LEVELS - 1)`, so the
    /// first and last levels are the map's ends.
    pub fn level_colour(self, k: usize) -> DVec3 {
        let c = self.srgb8(k as f64 / (MAP_LEVELS - 1) as f64);
        DVec3::from_array(c.map(|x| crate::image::srgb_to_linear(x as f64 / 255.0)))
    }
}

/// The level of `value` on the range `[lo, hi]`: the nearest of [`MAP_LEVELS`] evenly spaced
/// values, values outside the range clamped to its ends. A range of one value maps to the middle.
pub fn level(value: f64, lo: f64, hi: f64) -> usize {
    let top = (MAP_LEVELS - 1) as f64;
    let t = if hi > lo { (value - lo) / (hi - lo) } else { 0.5 };
    (t.clamp(0.0, 1.0) * top).round() as usize
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_range_ends_map_to_the_map_ends() {
        for (name, map) in COLOUR_MAPS {
            assert_eq!(level(-3.0, -3.0, 5.0), 0, "{name}");
            assert_eq!(level(5.0, -3.0, 5.0), MAP_LEVELS - 1, "{name}");
            assert_eq!(map.srgb8(0.0), map.srgb8(level(-3.0, -3.0, 5.0) as f64 / 255.0));
            assert_eq!(map.level_colour(MAP_LEVELS - 1), map.level_colour(level(9.0, -3.0, 5.0)));
            assert_ne!(map.level_colour(0), map.level_colour(MAP_LEVELS - 1), "{name}");
        }
        // Viridis runs from its dark purple to its yellow (matplotlib's table: #440154, #fde725).
        assert_eq!(ColourMap::Viridis.srgb8(0.0), [0x44, 0x01, 0x54]);
        assert_eq!(ColourMap::Viridis.srgb8(1.0), [0xfd, 0xe7, 0x25]);
        // Coolwarm is blue at the low end, red at the high end.
        let [r0, _, b0] = ColourMap::Coolwarm.srgb8(0.0);
        let [r1, _, b1] = ColourMap::Coolwarm.srgb8(1.0);
        assert!(b0 > r0 && r1 > b1);
    }

    #[test]
    fn levels_are_nearest_and_clamped() {
        assert_eq!(level(0.5, 0.0, 1.0), 128);
        assert_eq!(level(f64::INFINITY, 0.0, 1.0), MAP_LEVELS - 1);
        assert_eq!(level(-1e300, 0.0, 1.0), 0);
        assert_eq!(level(7.0, 7.0, 7.0), 128);
        assert_eq!(level(1.0 / 255.0 * 0.49, 0.0, 1.0), 0);
        assert_eq!(level(1.0 / 255.0 * 0.51, 0.0, 1.0), 1);
    }

    #[test]
    fn names_round_trip_and_unknown_ones_are_listed() {
        for (name, map) in COLOUR_MAPS {
            assert_eq!(ColourMap::parse(name), Ok(map));
            assert_eq!(map.name(), name);
        }
        assert_eq!(ColourMap::parse("VIRIDIS"), Ok(ColourMap::Viridis));
        let e = ColourMap::parse("jet").unwrap_err();
        assert!(e.contains("jet") && e.contains("viridis, inferno"), "{e}");
    }
}
