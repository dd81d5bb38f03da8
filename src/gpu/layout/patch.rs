//! The patches' part of the scene texture (`shaders/patch.wgsl` reads it): the leaves first,
//! one texel each, so leaf `i` (a [`PrimKind::Patch`](crate::accel::PrimKind) reference's
//! index) is at `base + i`, then the Bezier pieces.
//!
//! - Leaf: `[piece texel, i | j << 8 | depth_u << 16 | depth_v << 24, 0, 0]`: the square
//!   `[i, i + 1] / 2^depth_u × [j, j + 1] / 2^depth_v` of the piece (`scene::patch::leaves`).
//! - Piece, [`piece_texels`] of them: `[material, patch, bits(size), trim]`, with `size` the
//!   largest coordinate of its control points (what its f32 numbers are relative to) and `trim`
//!   its patch's trim record's texel (0: untrimmed); then
//!   `[u0, u1, v0, v1]` (f32), its part of its patch's domain in fractions of that domain (the
//!   texture coordinates); then its `(n + 1)²` control points, u fastest, homogeneous and
//!   relative to the origin: `[w (x - o), w (y - o), w (z - o), w]` (f32).
//! - Trim record, one per trimmed patch, after the pieces: `[edges, 0, 0, 0]`, then each edge of
//!   its loops `[u0, v0, u1, v1]` (f32, in fractions of the patch's domain, as the pieces'
//!   spans are): what `patch_kept` counts crossings of (`scene::patch::trim`).
//!
//! Every piece has the scene's highest degree `n` (`Leaves::degree`): the shader's loops then
//! have one trip count, a constant in a specialised pipeline (`Variant::patches`).

use crate::scene::patch::leaves::Leaves;
use crate::scene::patch::Patch;
use crate::scene::Scene;
use glam::DVec3;

/// Texels of a leaf record.
pub const LEAF_TEXELS: u32 = 1;
/// Texels of a piece's header (before its points).
pub const PIECE_HEADER_TEXELS: u32 = 2;

/// `Variant::patches` of a pipeline for any degree (the uber-shader): the degree is read from
/// `Params::patch` at run time, and the loops over control points do not unroll.
pub const PATCH_ANY: u32 = 255;
/// Newton steps of one solve at a leaf, at most (the paper: under three per hit on average). A
/// ray that has not met the surface by then misses this leaf; its neighbours overlap it. Near
/// a pole, where du × dv vanishes, Newton converges only linearly and needs this many.
pub const NEWTON_STEPS: u32 = 16;
/// A Newton solve has met the surface when the ray passes within this fraction of the piece's
/// size (`[material, patch, bits(size), 0]`) of the point: a few f32 ulps of its coordinates,
/// and well under the 256 ulps a secondary ray starts off the surface (`offset_origin`), so a
/// ray leaving a patch does not meet it again where it starts.
pub const TOLERANCE: f64 = 2e-6;

/// Texels of one piece of degree `n`.
pub fn piece_texels(n: usize) -> usize {
    PIECE_HEADER_TEXELS as usize + (n + 1) * (n + 1)
}

/// The scene's leaves and the texels their section takes.
pub fn patch_texels(scene: &Scene) -> (usize, Leaves) {
    let leaves = Leaves::build(&scene.patches);
    let trims: usize =
        scene.patches.iter().filter(|p| !p.trim.is_empty()).map(|p| 1 + edges(p).count()).sum();
    let n = leaves.leaves.len() * LEAF_TEXELS as usize
        + leaves.pieces.len() * piece_texels(leaves.degree)
        + trims;
    (n, leaves)
}

/// Appends the section; returns its first texel (the leaves').
pub fn push_patches(t: &mut Vec<[u32; 4]>, scene: &Scene, leaves: &Leaves, origin: DVec3) -> u32 {
    let base = t.len() as u32;
    let pieces = base + leaves.leaves.len() as u32 * LEAF_TEXELS;
    let stride = piece_texels(leaves.degree) as u32;
    // Trim records follow the pieces: each trimmed patch's first texel.
    let mut at = pieces + leaves.pieces.len() as u32 * stride;
    let records: Vec<u32> = scene
        .patches
        .iter()
        .map(|p| match p.trim.is_empty() {
            true => 0,
            false => {
                let r = at;
                at += 1 + edges(p).count() as u32;
                r
            }
        })
        .collect();
    for leaf in &leaves.leaves {
        let [i, j, du, dv] = leaf.cell.map(u32::from);
        t.push([pieces + leaf.piece * stride, i | j << 8 | du << 16 | dv << 24, 0, 0]);
    }
    for (piece, &k) in leaves.pieces.iter().zip(&leaves.patch) {
        let patch = &scene.patches[k as usize];
        let points: Vec<[f32; 4]> = piece
            .points
            .iter()
            .map(|h| {
                let p = (h.truncate() / h.w - origin) * h.w;
                [p.x as f32, p.y as f32, p.z as f32, h.w as f32]
            })
            .collect();
        let size = piece
            .points
            .iter()
            .map(|h| (h.truncate() / h.w - origin).abs().max_element())
            .fold(0.0, f64::max);
        t.push([patch.material, k, (size as f32).to_bits(), records[k as usize]]);
        let d = patch.domain();
        let frac = |a: usize, x: f64| ((x - d[a][0]) / (d[a][1] - d[a][0])) as f32;
        let [[u0, u1], [v0, v1]] = piece.domain;
        t.push([frac(0, u0), frac(0, u1), frac(1, v0), frac(1, v1)].map(f32::to_bits));
        t.extend(points.iter().map(|p| p.map(f32::to_bits)));
    }
    for p in scene.patches.iter().filter(|p| !p.trim.is_empty()) {
        t.push([edges(p).count() as u32, 0, 0, 0]);
        t.extend(edges(p).map(|e| e.map(f32::to_bits)));
    }
    debug_assert_eq!(t.len() as u32, at);
    base
}

/// A patch's trim edges in fractions of its domain, `[u0, v0, u1, v1]`.
fn edges(p: &Patch) -> impl Iterator<Item = [f32; 4]> + '_ {
    let d = p.domain();
    let frac = move |a: usize, x: f64| ((x - d[a][0]) / (d[a][1] - d[a][0])) as f32;
    p.trim.iter().flat_map(move |l| {
        l.windows(2).map(move |e| [frac(0, e[0].x), frac(1, e[0].y), frac(0, e[1].x), frac(1, e[1].y)])
    })
}
