//! Scene files → [`crate::scene::Scene`]. Errors name the file, line and column.
pub mod toml;
