//! How a volume is drawn (PAPER.md §10): as isosurfaces, as a maximum-intensity projection, or
//! by direct volume rendering (emission and absorption), and the transfer function the last two
//! map samples through. The transfer function is a table of [`TRANSFER_ENTRIES`] colours and
//! opacities read linearly between entries, made once here: the shader and the f64 tracer read
//! the same table, so they differ only in how they integrate it.

use super::colour_map::ColourMap;

/// Entries of a transfer function's table (one texel each on the device).
pub const TRANSFER_ENTRIES: usize = 64;
/// Distance between DVR's samples along a ray, in cells (index units).
pub const DVR_STEP: f64 = 0.5;
/// DVR samples one cell can hold along a ray: its diagonal, √3 cells, over [`DVR_STEP`], and
/// one more for where the lattice falls.
pub const DVR_CELL_SAMPLES: u32 = 5;
const _: () = assert!(DVR_STEP == 0.5);
/// DVR stops once less than this fraction of the light behind a sample would reach the eye.
pub const DVR_EARLY_OUT: f64 = 1.0 / 256.0;

/// A volume's look.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Look {
    /// Its isosurfaces, as surfaces of the scene with their materials.
    #[default]
    Iso,
    /// The greatest value along each ray, through the transfer function, over what lies behind.
    Mip,
    /// Emission and absorption along each ray through the transfer function, over what lies
    /// behind, stopped once nearly opaque.
    Dvr,
}

/// Every look with its name, in the order the window cycles them.
pub const LOOKS: [(&str, Look); 3] = [("iso", Look::Iso), ("mip", Look::Mip), ("dvr", Look::Dvr)];

impl Look {
    pub fn name(self) -> &'static str {
        LOOKS.iter().find(|(_, l)| *l == self).map_or("?", |(n, _)| n)
    }

    /// The look named `name`, or a message naming the three.
    pub fn parse(name: &str) -> Result<Look, String> {
        LOOKS.iter().find(|(n, _)| n.eq_ignore_ascii_case(name)).map(|(_, l)| *l).ok_or_else(|| {
            format!("unknown volume mode `{name}`: give iso (isosurfaces), mip (maximum intensity) or dvr (direct volume rendering)")
        })
    }

    /// The shader's code (`LOOK_*` in the prelude).
    pub fn code(self) -> u32 {
        self as u32
    }

    /// The next look in [`LOOKS`] (the window's key).
    pub fn next(self) -> Look {
        let i = LOOKS.iter().position(|(_, l)| *l == self).unwrap_or(0);
        LOOKS[(i + 1) % LOOKS.len()].1
    }
}

/// Samples from `window[0]` to `window[1]` run through the colour map, their opacity rising
/// linearly from 0 at `window[0]` to `opacity` at `window[1]`; below the window a sample is
/// transparent, above it the last entry. For DVR the opacity is that of one cell's length of
/// material (each sample's is corrected for [`DVR_STEP`]); for MIP it is the greatest value's.
#[derive(Clone, Debug, PartialEq)]
pub struct Transfer {
    pub window: [f64; 2],
    pub map: ColourMap,
    pub opacity: f64,
}

impl Transfer {
    /// The default for a look over samples in `[lo, hi]`: greys at full opacity for MIP (the
    /// radiologist's picture), inferno at a tenth a cell for DVR.
    /// Samples all of one value get a window of width 1 above it.
    pub fn default_for(look: Look, (lo, hi): (f32, f32)) -> Transfer {
        let window = [lo as f64, if hi > lo { hi as f64 } else { lo as f64 + 1.0 }];
        match look {
            Look::Dvr => Transfer { window, map: ColourMap::Inferno, opacity: 0.1 },
            _ => Transfer { window, map: ColourMap::Greys, opacity: 1.0 },
        }
    }

    /// Why it cannot be used, if it cannot.
    pub fn check(&self) -> Result<(), String> {
        let [lo, hi] = self.window;
        if !(lo.is_finite() && hi.is_finite() && lo < hi) {
            return Err(format!("transfer window [{lo}, {hi}]: give two finite values, the lower first"));
        }
        if !(0.0..=1.0).contains(&self.opacity) {
            return Err(format!("opacity {}: give a value from 0 to 1", self.opacity));
        }
        Ok(())
    }

    /// The table: entry `k` is the colour map's linear RGB at `k / (N - 1)` and the opacity
    /// there.
    pub fn table(&self) -> Vec<[f32; 4]> {
        (0..TRANSFER_ENTRIES)
            .map(|k| {
                let s = k as f64 / (TRANSFER_ENTRIES - 1) as f64;
                let c = self.map.srgb8(s).map(|x| crate::image::srgb_to_linear(x as f64 / 255.0));
                [c[0] as f32, c[1] as f32, c[2] as f32, (self.opacity * s) as f32]
            })
            .collect()
    }

    /// The table read at sample value `v` (f64, for the reference): linear between entries,
    /// transparent below the window.
    pub fn lookup(&self, table: &[[f32; 4]], v: f64) -> [f64; 4] {
        let [lo, hi] = self.window;
        let s = (v - lo) / (hi - lo);
        if s <= 0.0 {
            let c = table[0];
            return [c[0] as f64, c[1] as f64, c[2] as f64, 0.0];
        }
        let x = s.min(1.0) * (TRANSFER_ENTRIES - 1) as f64;
        let i = (x.floor() as usize).min(TRANSFER_ENTRIES - 2);
        let f = x - i as f64;
        std::array::from_fn(|c| table[i][c] as f64 * (1.0 - f) + table[i + 1][c] as f64 * f)
    }
}

/// A sample's opacity over one DVR step from its opacity over one cell's length.
pub fn step_opacity(per_cell: f64) -> f64 {
    1.0 - (1.0 - per_cell.clamp(0.0, 1.0)).powf(DVR_STEP)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_table_ramps_opacity_and_reads_linearly() {
        let t = Transfer { window: [10.0, 20.0], map: ColourMap::Greys, opacity: 0.5 };
        let table = t.table();
        assert_eq!(table.len(), TRANSFER_ENTRIES);
        assert_eq!(table[0][3], 0.0);
        assert_eq!(table[TRANSFER_ENTRIES - 1][3], 0.5);
        assert_eq!(t.lookup(&table, 5.0)[3], 0.0);
        assert_eq!(t.lookup(&table, 10.0)[3], 0.0);
        assert!((t.lookup(&table, 15.0)[3] - 0.25).abs() < 1e-6);
        assert_eq!(t.lookup(&table, 99.0)[3], 0.5);
        // Greys run black to white.
        assert!(t.lookup(&table, 10.0)[0] < 1e-3 && t.lookup(&table, 20.0)[0] > 0.99);
    }

    #[test]
    fn looks_round_trip_and_cycle() {
        for (name, look) in LOOKS {
            assert_eq!(Look::parse(name), Ok(look));
            assert_eq!(look.name(), name);
        }
        assert!(Look::parse("volume").unwrap_err().contains("mip"));
        assert_eq!(Look::Iso.next().next().next(), Look::Iso);
    }

    #[test]
    fn bad_windows_and_opacities_are_refused() {
        let ok = Transfer::default_for(Look::Dvr, (0.0, 1.0));
        assert!(ok.check().is_ok());
        assert!(Transfer { window: [1.0, 1.0], ..ok.clone() }.check().is_err());
        assert!(Transfer { window: [0.0, f64::NAN], ..ok.clone() }.check().is_err());
        assert!(Transfer { opacity: 1.5, ..ok }.check().is_err());
    }

    #[test]
    fn step_opacity_composes_to_a_cell() {
        let a = step_opacity(0.36);
        let steps = (1.0 / DVR_STEP) as i32;
        assert!(((1.0 - (1.0 - a).powi(steps)) - 0.36).abs() < 1e-12);
    }
}
