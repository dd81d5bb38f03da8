//! How primitives are found: the flattened uniform grid with macro-cells.
pub mod grid;
pub use grid::{Grid, PrimKind, PrimRef};
