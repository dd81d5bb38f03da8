//! How primitives are found: the flattened uniform grid with macro-cells, or a bounding-volume
//! hierarchy beside it (chosen per scene: [`AccelChoice`]).
pub mod bvh;
pub mod grid;
pub use bvh::Bvh;
pub use grid::{Grid, PrimKind, PrimRef};
