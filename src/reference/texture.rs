//! Texture sampling in f64: the twin of `shaders/texture.wgsl` (docs/scene-format.md, textures).
//! Written from the definitions (texel centres at half-integers, GL's wrap modes), not from the
//! shader: the fold-then-wrap split is the shader's trick for small integers, so it is not
//! repeated here; each wrap mode is one formula over any integer texel index. Texture
//! coordinates of spheres and cones (`sphere_uv`, `cone_uv`) are conventions, and follow the
//! shader's definitions.

use super::shadows::basis;
use crate::image::srgb_to_linear;
use crate::scene::{Filter, MaterialKind, Scene, Texture, Wrap};
use glam::{DVec2, DVec3};

/// Texel `i` (any integer) wrapped into `[0, n)`.
pub fn wrap_index(i: i64, n: i64, wrap: Wrap) -> i64 {
    match wrap {
        Wrap::Clamp => i.clamp(0, n - 1),
        Wrap::Repeat => i.rem_euclid(n),
        // GL's mirrored repeat: the image, then its mirror image, every 2n texels.
        Wrap::Mirror => {
            let k = i.rem_euclid(2 * n);
            if k < n {
                k
            } else {
                2 * n - 1 - k
            }
        }
    }
}

fn texel(t: &Texture, x: i64, y: i64) -> DVec3 {
    let x = wrap_index(x, t.width as i64, t.wrap[0]);
    let y = wrap_index(y, t.height as i64, t.wrap[1]);
    let p = t.texels[(y * t.width as i64 + x) as usize];
    DVec3::from_array([p[0], p[1], p[2]].map(|c| srgb_to_linear(c as f64 / 255.0)))
}

/// Index of the texel row/column at coordinate `u` (in texture sizes) for a texture `n` wide,
/// as a float: clamping happens on the integer, so a huge `u` saturates harmlessly.
fn scaled(u: f64, n: u32, wrap: Wrap) -> f64 {
    // Clamp-to-edge reads the edge texel everywhere outside [0, 1]: clamping u first is the same
    // and keeps the numbers small. Repeat and mirror are periodic: reduce u by whole periods.
    let u = match wrap {
        Wrap::Clamp => u.clamp(0.0, 1.0),
        Wrap::Repeat => u.rem_euclid(1.0),
        Wrap::Mirror => u.rem_euclid(2.0),
    };
    u * n as f64
}

/// Linear RGB of `t` at `uv` (u right, v down, (0, 0) the top-left corner of the image).
pub fn sample_texture(t: &Texture, uv: DVec2) -> DVec3 {
    let x = scaled(uv.x, t.width, t.wrap[0]);
    let y = scaled(uv.y, t.height, t.wrap[1]);
    match t.filter {
        Filter::Nearest => texel(t, x.floor() as i64, y.floor() as i64),
        Filter::Linear => {
            let (x, y) = (x - 0.5, y - 0.5);
            let (x0, y0) = (x.floor(), y.floor());
            let (fx, fy) = (x - x0, y - y0);
            let (i, j) = (x0 as i64, y0 as i64);
            let top = texel(t, i, j).lerp(texel(t, i + 1, j), fx);
            let bottom = texel(t, i, j + 1).lerp(texel(t, i + 1, j + 1), fx);
            top.lerp(bottom, fy)
        }
    }
}

/// Material `index` of `scene` as seen at texture coordinates `uv`: its colour multiplied by its
/// texture there.
pub fn material_at(scene: &Scene, index: u32, uv: DVec2) -> MaterialKind {
    let m = &scene.materials[index as usize];
    let mut kind = m.kind.clone();
    if let Some(t) = m.texture {
        let c = sample_texture(&scene.textures[t as usize], uv);
        match &mut kind {
            MaterialKind::Diffuse { color }
            | MaterialKind::Metal { color, .. }
            | MaterialKind::Polished { color, .. } => *color *= c,
            MaterialKind::Dielectric { .. } => {}
        }
    }
    kind
}

/// u of direction `q` around the unit axis `a`: its angle in the frame around `a` that light
/// discs use too ([`frame`]), in [0, 1].
fn angle_u(q: DVec3, a: DVec3) -> f64 {
    let (e1, e2) = basis(a);
    0.5 + q.dot(e2).atan2(q.dot(e1)) / std::f64::consts::TAU
}

/// Texture coordinates on a sphere at the outward unit normal `n`: longitude around +y, latitude
/// from the +y pole (v = 0) to the -y pole (v = 1).
pub fn sphere_uv(n: DVec3) -> DVec2 {
    DVec2::new(angle_u(n, DVec3::Y), n.y.clamp(-1.0, 1.0).acos() / std::f64::consts::PI)
}

/// Texture coordinates on a cone at `p`: the angle around the axis `base → apex` and the position
/// along it, v = 1 at the base and 0 at the apex.
pub fn cone_uv(p: DVec3, base: DVec3, apex: DVec3) -> DVec2 {
    let axis = apex - base;
    let q = p - base;
    DVec2::new(angle_u(q, axis.normalize()), 1.0 - q.dot(axis) / axis.length_squared())
}
