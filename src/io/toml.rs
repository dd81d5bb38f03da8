use crate::scene::Scene;
pub fn parse_str(_src: &str, _origin: &str) -> Result<Scene, String> {
    Err("not yet".into())
}
