//! Scene files → [`crate::scene::Scene`]. Errors name the file, line and column.
pub mod toml;
pub fn load(p: &std::path::Path) -> Result<crate::scene::Scene, std::io::Error> {
    Err(std::io::Error::other(format!("stub {}", p.display())))
}
