//! The built-in default scene, shipped as TOML so it also documents the format.

use super::Scene;

/// Source of the default scene (also in `scenes/default.toml`).
pub const DEFAULT_SCENE_TOML: &str = include_str!("../../scenes/default.toml");

/// The scene `irt render` draws when no file is given.
pub fn default_scene() -> Scene {
    crate::io::toml::parse_str(DEFAULT_SCENE_TOML, "<built-in default scene>")
        .expect("the built-in default scene is valid (checked by a test)")
}
