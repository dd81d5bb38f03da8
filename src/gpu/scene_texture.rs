//! The scene texture on any device: its extent (rows, layers), the bands it is uploaded in, and
//! how it grows when an updated scene no longer fits.

use super::layout::{self, PackedScene, SCENE_LAYER_ROWS, SCENE_TEX_WIDTH};
use super::GpuError;

/// How a scene texture is allocated: rows per layer, layers, whether it is an array of layers,
/// and the largest side the device (or a test) allows. What every backend allocates, and what
/// decides whether an updated scene fits the texture in place.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SceneExtent {
    /// Rows per layer (the texture's height).
    pub height: u32,
    pub layers: u32,
    pub layered: bool,
    /// The largest side a layer may have: the device's, or less where a test asks
    /// (`Settings::max_scene_rows`), so that small scenes trace the layered path.
    max_side: u32,
}

impl SceneExtent {
    /// The extent for `packed` (at least `reserve_rows` rows) on a device whose largest 2D side
    /// is `max_dim` and which holds `max_layers` array layers, layered past `max_rows` if given.
    pub fn of(
        packed: &PackedScene,
        reserve_rows: u32,
        max_rows: Option<u32>,
        max_dim: u32,
        max_layers: u32,
    ) -> Result<Self, GpuError> {
        let max_side = max_rows.map_or(max_dim, |m| m.min(max_dim));
        let (height, layers, layered) = layout::scene_extent(packed.rows().max(reserve_rows), max_side);
        if layers > max_layers {
            let most = max_layers as u64 * (SCENE_LAYER_ROWS * SCENE_TEX_WIDTH) as u64;
            return Err(GpuError::SceneTooLarge {
                needed_mib: packed.texels.len() as u64 >> 16,
                texels: packed.texels.len() as u64,
                most_mib: most >> 16,
                layers: max_layers,
            });
        }
        Ok(SceneExtent { height, layers, layered, max_side })
    }

    /// Rows the texture holds, all layers together.
    pub fn capacity_rows(&self) -> u32 {
        self.height * self.layers
    }

    /// Whether `rows` rows fit the texture as it is, and would be layered as it is (a texture
    /// that would change between 2D and an array needs a recompiled kernel).
    pub fn fits(&self, rows: u32) -> bool {
        rows <= self.capacity_rows() && layout::scene_extent(rows, self.max_side).2 == self.layered
    }

    /// The `max_rows` to allocate a replacement with (what [`SceneExtent::of`] was given).
    pub fn max_rows(&self) -> Option<u32> {
        Some(self.max_side)
    }
}

/// Rows to reserve for a scene of `rows` rows that outgrew its texture: a quarter more, so that
/// an animation whose grid lists grow frame by frame does not reallocate every frame.
pub fn grown_rows(rows: u32) -> u32 {
    rows.saturating_add(rows / 4)
}

/// Pads `texels` to whole rows of the scene texture; returns the rows.
pub fn pad_rows(texels: &mut Vec<[u32; 4]>) -> u32 {
    let rows = layout::rows_of(texels.len());
    texels.resize((rows * SCENE_TEX_WIDTH) as usize, [0; 4]);
    rows
}

/// One upload band of the scene texture: `rows` rows from row `first` of the texels handed
/// over, at row `y` of layer `layer`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SceneBand {
    pub first: u32,
    pub rows: u32,
    pub y: u32,
    pub layer: u32,
}

/// The upload bands of the packed scene's rows `from..rows`, handed over as texels that start
/// at row `from` (`SceneBand::first` counts from there), from the last band to the first (so
/// each band's host texels can be freed once it is on the device): at most
/// [`SCENE_LAYER_ROWS`] rows each, none across a layer's end if layered.
pub fn scene_bands(from: u32, rows: u32, layered: bool) -> impl Iterator<Item = SceneBand> {
    (from / SCENE_LAYER_ROWS..rows.div_ceil(SCENE_LAYER_ROWS)).rev().map(move |band| {
        let start = (band * SCENE_LAYER_ROWS).max(from);
        let count = ((band + 1) * SCENE_LAYER_ROWS).min(rows) - start;
        let first = start - from;
        if layered {
            SceneBand { first, rows: count, y: start - band * SCENE_LAYER_ROWS, layer: band }
        } else {
            SceneBand { first, rows: count, y: start, layer: 0 }
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bands of rows `from..rows` cover each of them once, last band first, none across a
    /// layer's end when layered; each band's `first` counts from `from`, and its `y` and
    /// `layer` place it where the whole scene's row would go.
    #[test]
    fn scene_bands_cover_the_rows_from_any_row_once() {
        let l = SCENE_LAYER_ROWS;
        for (from, rows) in
            [(0, 1), (0, l), (0, 2 * l + 5), (3, 4), (l - 1, l + 1), (l, 3 * l), (l + 7, 3 * l - 2)]
        {
            for layered in [false, true] {
                let bands: Vec<SceneBand> = scene_bands(from, rows, layered).collect();
                let mut covered: Vec<u32> =
                    bands.iter().flat_map(|b| from + b.first..from + b.first + b.rows).collect();
                assert!(bands.windows(2).all(|w| w[0].first > w[1].first), "last band first");
                covered.sort_unstable();
                assert_eq!(covered, (from..rows).collect::<Vec<_>>(), "{from}..{rows} layered {layered}");
                for b in &bands {
                    let row = from + b.first;
                    let (y, layer) = if layered { (row % l, row / l) } else { (row, 0) };
                    assert_eq!((b.y, b.layer), (y, layer), "{b:?} from {from}");
                    assert!(b.rows <= l && (!layered || b.y + b.rows <= l), "{b:?}");
                }
            }
        }
    }
}
