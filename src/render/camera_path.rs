//! `irt replay`'s scripted camera: a TOML file of `[[key]]` tables (time, eye, look_at, up,
//! fov), interpolated linearly between keys and held after the last; errors name the file,
//! line and column.

use crate::io::LoadError;
use crate::scene::Camera;
use glam::DVec3;
use serde::Deserialize;
use std::path::Path;
use toml::Spanned;

/// Camera path files above this size are refused.
pub const MAX_PATH_FILE_BYTES: u64 = 1 << 20;

/// One timed camera of a path; `line` is where its `[[key]]` table starts in the file.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraKey {
    pub t: f64,
    pub eye: DVec3,
    pub look_at: DVec3,
    pub up: DVec3,
    pub fov: f64,
    pub line: usize,
}

/// A scripted camera: keys at increasing times from t = 0, eye, look_at, up and fov linearly
/// interpolated between them, the last key held after the end.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraPath {
    pub keys: Vec<CameraKey>,
    /// The file the path came from, for messages.
    pub origin: String,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PathDoc {
    #[serde(default)]
    key: Vec<Spanned<KeyDoc>>,
}

/// The scene TOML's `[camera]` keys, plus the time.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct KeyDoc {
    t: Option<Spanned<f64>>,
    eye: Option<Spanned<Vec<f64>>>,
    look_at: Option<Spanned<Vec<f64>>>,
    up: Option<Spanned<Vec<f64>>>,
    fov: Option<Spanned<f64>>,
    width: Option<Spanned<toml::Value>>,
    height: Option<Spanned<toml::Value>>,
}

type Located = (std::ops::Range<usize>, String);

fn vec3(v: &Spanned<Vec<f64>>, key: &str) -> Result<DVec3, Located> {
    let bad = |m: String| (v.span(), m);
    let a = <[f64; 3]>::try_from(v.get_ref().as_slice())
        .map_err(|_| bad(format!("`{key}` needs 3 numbers, found {}", v.get_ref().len())))?;
    match a.iter().find(|x| !x.is_finite()) {
        Some(x) => Err(bad(format!("`{key}` contains {x}; numbers must be finite"))),
        None => Ok(DVec3::from_array(a)),
    }
}

/// Why `eye`/`look_at`/`up`/`fov` make no view (the criteria of `Scene::validate`, with a
/// tolerance: an interpolated view that is nearly degenerate is as useless as one that is).
fn degenerate(eye: DVec3, look_at: DVec3, up: DVec3, fov: f64) -> Option<&'static str> {
    let w = look_at - eye;
    if !(fov > 0.0 && fov < 180.0) {
        Some("`fov` must be between 0 and 180 degrees")
    } else if w.length_squared() <= 1e-18 * (eye.length_squared() + look_at.length_squared()).max(1.0) {
        Some("`look_at` equals `eye`: the view direction is undefined")
    } else if w.cross(up).length_squared() <= 1e-12 * w.length_squared() * up.length_squared() {
        Some("`up` is zero or parallel to the view direction")
    } else {
        None
    }
}

impl CameraPath {
    /// Reads and checks a path file.
    pub fn load(path: &Path) -> Result<Self, LoadError> {
        let origin = path.display().to_string();
        let bytes = crate::io::read_limited(path, MAX_PATH_FILE_BYTES, "camera path file")
            .map_err(|m| LoadError::new(&origin, m))?;
        let src = std::str::from_utf8(&bytes).map_err(|e| {
            let valid = std::str::from_utf8(&bytes[..e.valid_up_to()]).unwrap_or_default();
            LoadError::at(&origin, valid, valid.len(), "the file is not valid UTF-8 text")
        })?;
        Self::parse_str(src, &origin)
    }

    /// Parses and checks a path; errors name `origin`, line and column.
    pub fn parse_str(src: &str, origin: &str) -> Result<Self, LoadError> {
        let doc: PathDoc = toml::from_str(src).map_err(|e| match e.span() {
            Some(span) => LoadError::at(origin, src, span.start, e.message().trim_end()),
            None => LoadError::new(origin, e.message().trim_end()),
        })?;
        let at = |(span, m): Located| LoadError::at(origin, src, span.start, m);
        let mut keys: Vec<CameraKey> = Vec::with_capacity(doc.key.len());
        for table in &doc.key {
            let k = table.get_ref();
            let span = table.span();
            let line = crate::io::line_column(src, span.start).0;
            if let Some(v) = k.width.as_ref().or(k.height.as_ref()) {
                return Err(at((
                    v.span(),
                    "a path key takes no image size: it comes from the scene or --size".into(),
                )));
            }
            let need = |name: &str| at((span.clone(), format!("a [[key]] needs `{name}`")));
            let t = k.t.as_ref().ok_or_else(|| need("t"))?;
            let eye = vec3(k.eye.as_ref().ok_or_else(|| need("eye"))?, "eye").map_err(at)?;
            let look_at = vec3(k.look_at.as_ref().ok_or_else(|| need("look_at"))?, "look_at").map_err(at)?;
            let up = k.up.as_ref().map_or(Ok(DVec3::Y), |u| vec3(u, "up")).map_err(at)?;
            let fov = k.fov.as_ref().map_or(crate::io::toml::DEFAULT_FOV_DEG, |f| *f.get_ref());
            let tv = *t.get_ref();
            match keys.last() {
                _ if !tv.is_finite() => return Err(at((t.span(), format!("`t` = {tv} must be finite")))),
                None if tv != 0.0 => {
                    return Err(at((t.span(), format!("the first key must be at t = 0, not {tv}"))))
                }
                Some(prev) if tv <= prev.t => {
                    return Err(at((
                        t.span(),
                        format!(
                            "key times must increase: t = {tv} is not after {} (line {})",
                            prev.t, prev.line
                        ),
                    )))
                }
                _ => {}
            }
            if let Some(m) = degenerate(eye, look_at, up, fov) {
                let place = match (m.starts_with("`fov`"), &k.fov) {
                    (true, Some(f)) => f.span(),
                    _ => span.clone(),
                };
                return Err(at((place, m.into())));
            }
            let key = CameraKey { t: tv, eye, look_at, up, fov, line };
            // Between two valid keys the interpolated view can still degenerate (eye passing
            // through look_at, up turning through the view direction): sample the segment.
            if let Some(prev) = keys.last() {
                for i in 1..64 {
                    let s = i as f64 / 64.0;
                    let c = lerp_key(prev, &key, s);
                    if let Some(m) = degenerate(c.eye, c.look_at, c.up, c.fov) {
                        return Err(at((
                            span.clone(),
                            format!(
                                "between this key and the one on line {} the view degenerates near t = {}: {m}",
                                prev.line,
                                prev.t + s * (tv - prev.t)
                            ),
                        )));
                    }
                }
            }
            keys.push(key);
        }
        if keys.len() < 2 {
            return Err(LoadError::new(
                origin,
                format!(
                    "a camera path needs at least 2 [[key]] tables (t, eye, look_at), found {}",
                    keys.len()
                ),
            ));
        }
        Ok(CameraPath { keys, origin: origin.into() })
    }

    /// Seconds from the first key to the last.
    pub fn duration(&self) -> f64 {
        self.keys.last().map_or(0.0, |k| k.t)
    }

    /// The camera at time `t` (clamped to the path), for an image of `width` × `height`.
    pub fn camera_at(&self, t: f64, width: u32, height: u32) -> Camera {
        let i = self.keys.partition_point(|k| k.t <= t).clamp(1, self.keys.len() - 1);
        let (a, b) = (&self.keys[i - 1], &self.keys[i]);
        let s = ((t - a.t) / (b.t - a.t)).clamp(0.0, 1.0);
        let k = lerp_key(a, b, s);
        Camera { eye: k.eye, look_at: k.look_at, up: k.up, vfov_deg: k.fov, width, height }
    }
}

fn lerp_key(a: &CameraKey, b: &CameraKey, s: f64) -> CameraKey {
    // Exact at the ends, so a key's own camera (and a rest between equal keys) is bit-exact.
    let l = |x: DVec3, y: DVec3| if s == 1.0 { y } else { x + (y - x) * s };
    CameraKey {
        t: a.t + (b.t - a.t) * s,
        eye: l(a.eye, b.eye),
        look_at: l(a.look_at, b.look_at),
        up: l(a.up, b.up),
        fov: if s == 1.0 { b.fov } else { a.fov + (b.fov - a.fov) * s },
        line: b.line,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TWO_KEYS: &str = "[[key]]\nt = 0\neye = [0, 1, 5]\nlook_at = [0, 0, 0]\n\n[[key]]\nt = 2.0\neye = [5, 1, 0]\nlook_at = [0, 0, 0]\nfov = 60\n";

    fn err(src: &str) -> String {
        CameraPath::parse_str(src, "p.toml").unwrap_err().to_string()
    }

    #[test]
    fn paths_interpolate_between_keys() {
        let p = CameraPath::parse_str(TWO_KEYS, "p.toml").unwrap();
        assert_eq!(p.duration(), 2.0);
        assert_eq!(p.keys[0].line, 1);
        assert_eq!(p.keys[1].line, 6);
        let c = p.camera_at(1.0, 64, 48);
        assert_eq!((c.eye, c.vfov_deg, c.up), (DVec3::new(2.5, 1.0, 2.5), 52.5, DVec3::Y));
        assert_eq!((c.width, c.height), (64, 48));
        assert_eq!(p.camera_at(-1.0, 1, 1).eye, p.keys[0].eye);
        assert_eq!(p.camera_at(9.0, 1, 1).eye, p.keys[1].eye);
        assert_eq!(p.camera_at(2.0, 1, 1).vfov_deg, 60.0);
    }

    #[test]
    fn bad_paths_name_file_line_and_column() {
        let cases = [
            ("[[key]]\nt = 0\neye = [0, 1]\nlook_at = [0, 0, 0]\n", "p.toml:3:7: `eye` needs 3 numbers, found 2"),
            ("[[key]]\nt = 0.5\neye = [0, 1, 5]\nlook_at = [0, 0, 0]\n", "p.toml:2:5: the first key must be at t = 0"),
            (
                "[[key]]\nt = 0\neye = [0, 1, 5]\nlook_at = [0, 0, 0]\n[[key]]\nt = 0\neye = [1, 1, 5]\nlook_at = [0, 0, 0]\n",
                "p.toml:6:5: key times must increase: t = 0 is not after 0 (line 1)",
            ),
            ("[[key]]\nt = 0\neye = [0, 1, 5]\n", "p.toml:1:1: a [[key]] needs `look_at`"),
            ("[[key]]\nt = 0\neye = [0, 1, 5]\nlook_at = [0, 1, 5]\n", "p.toml:1:1: `look_at` equals `eye`"),
            ("[[key]]\nt = 0\neye = [0, 5, 0]\nlook_at = [0, 0, 0]\n", "p.toml:1:1: `up` is zero or parallel"),
            ("[[key]]\nt = 0\neye = [0, 1, 5]\nlook_at = [0, 0, 0]\nfov = 180\n", "p.toml:5:7: `fov` must be between"),
            ("[[key]]\nt = 0\neye = [0, 1, 5]\nlook_at = [0, 0, 0]\nwidth = 3\n", "p.toml:5:9: a path key takes no image size"),
            ("[[key]]\nt = 0\neye = [0, 1, 5]\nlook_at = [0, 0, 0]\nzoom = 3\n", "p.toml:5:1: unknown field `zoom`"),
            ("[[key]]\nt = 0\neye = [0, 1, 5]\nlook_at = [0, 0, 0]\n", "p.toml: a camera path needs at least 2 [[key]] tables"),
            ("[[key]\n", "p.toml:1:"),
            (
                // The eye passes through look_at half way.
                "[[key]]\nt = 0\neye = [0, 0, 5]\nlook_at = [0, 0, 0]\n[[key]]\nt = 1\neye = [0, 0, -5]\nlook_at = [0, 0, 0]\n",
                "p.toml:5:1: between this key and the one on line 1 the view degenerates near t = 0.5",
            ),
        ];
        for (src, want) in cases {
            let got = err(src);
            assert!(got.starts_with(want), "{src:?}:\n got  {got}\n want {want}…");
        }
    }

    #[test]
    fn the_shipped_paths_load() {
        for p in ["scenes/paths/orbit.toml", "scenes/paths/balls.toml"] {
            let path = CameraPath::load(Path::new(env!("CARGO_MANIFEST_DIR")).join(p).as_path()).unwrap();
            assert!(path.duration() >= 2.0, "{p}");
        }
    }
}
