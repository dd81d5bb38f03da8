//! What the accelerators hold of a scene's patches: each patch's Bezier pieces, elevated to the
//! scene's highest degree (so the shader's loops have one constant trip count), and each piece's
//! parameter square cut into leaves until a leaf's control net is nearly flat. A leaf is a
//! primitive of irt's BVH and grid, boxed by its own refined control net; a ray that reaches it
//! is solved by Newton from the leaf's middle (`shaders/patch.wgsl`).
//!
//! **The depth rule.** A piece is split, along the parameter whose rows bend most, until every
//! row and column of its control net lies within [`FLATNESS`] of its box's diagonal from the
//! chord of its ends and its weights vary by less than [`WEIGHT_SPREAD`]. A row's bend from its
//! chord grows as curvature × length², its box as length, so a leaf's relative bend is about
//! curvature × size / 8 and halving a side halves it: the depth a piece gets is log2 of its
//! curvature times its size, per piece and per direction, not one number for the scene. A flat
//! piece (a plane, a cylinder along its axis) stays one leaf that way.

use super::bezier::{piece_count, pieces, Piece};
use super::Patch;
use glam::DVec3;

/// A leaf is cut no further when its rows and columns bend less than this fraction of its
/// diagonal: Newton from its middle then meets the surface in a few steps.
pub const FLATNESS: f64 = 0.08;
/// ... and when its weights differ by less than this factor (a fast change of weights is a
/// fast change of speed along the surface, which a linear step reads wrongly).
pub const WEIGHT_SPREAD: f64 = 2.0;
/// Halvings per parameter of one piece, at most: a leaf's `(i, j)` fit 8 bits each.
pub const MAX_DEPTH: u8 = 8;
/// Leaves of one scene cut by the depth rule, at most (each is a primitive reference and a
/// texel); past it pieces are cut no further.
pub const MAX_LEAVES: usize = 1 << 22;
/// Bezier pieces of one scene, at most (checked before any is made).
pub const MAX_PIECES: usize = 1 << 20;
/// A leaf's parameter square is grown by this fraction of its side on every side, for its box
/// and for the hits its solve accepts: neighbours overlap, so a ray along a shared edge, whose
/// Newton ends a rounding error outside both, is still met by one of them.
pub const OVERLAP: f64 = 1.0 / 32.0;

/// One leaf: the parameter square `[i, i + 1] / 2^depth_u × [j, j + 1] / 2^depth_v` of piece
/// `piece` (in fractions of the piece's spans), and the box of its grown square's control net.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Leaf {
    pub piece: u32,
    /// `[i, j, depth_u, depth_v]`.
    pub cell: [u8; 4],
    pub lo: DVec3,
    pub hi: DVec3,
}

impl Leaf {
    /// The leaf's square in fractions of its piece's spans, grown by `grow` of its side.
    pub fn range(&self, grow: f64) -> [[f64; 2]; 2] {
        std::array::from_fn(|a| {
            let side = 1.0 / (1u32 << self.cell[2 + a]) as f64;
            let lo = self.cell[a] as f64 * side;
            [(lo - grow * side).max(0.0), (lo + side + grow * side).min(1.0)]
        })
    }
}

/// The leaves of a scene's patches.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Leaves {
    /// Every patch's pieces in scene order, elevated to `degree`.
    pub pieces: Vec<Piece>,
    /// The patch of each piece.
    pub patch: Vec<u32>,
    pub degree: usize,
    pub leaves: Vec<Leaf>,
}

/// The pieces a set of patches makes, or why they are too many.
pub fn check_size(patches: &[Patch]) -> Result<usize, String> {
    let n: usize = patches.iter().map(piece_count).sum();
    if n > MAX_PIECES {
        return Err(format!("the patches make {n} Bezier pieces; irt's limit is {MAX_PIECES}"));
    }
    Ok(n)
}

impl Leaves {
    /// Cuts `patches` (valid, within [`check_size`]) into leaves by the depth rule. Past
    /// [`MAX_LEAVES`] the rest are cut no further (a coarser leaf is still exact, its Newton
    /// only slower to meet it), with a warning.
    pub fn build(patches: &[Patch]) -> Leaves {
        let degree = patches.iter().flat_map(|p| p.degree).max().unwrap_or(0);
        let mut out = Leaves { degree, ..Default::default() };
        for (k, patch) in patches.iter().enumerate() {
            for piece in pieces(patch) {
                let index = out.pieces.len() as u32;
                let piece = piece.elevated(degree);
                let first = out.leaves.len();
                refine(&piece, index, [0, 0, 0, 0], &mut out.leaves);
                for leaf in &mut out.leaves[first..] {
                    (leaf.lo, leaf.hi) = piece.sub(leaf.range(OVERLAP)).bounds();
                }
                if out.leaves.len() >= MAX_LEAVES && first < MAX_LEAVES {
                    log::warn!(
                        "the patches reach {MAX_LEAVES} leaves at patch {k}; the rest are cut no further"
                    );
                }
                out.pieces.push(piece);
                out.patch.push(k as u32);
            }
        }
        out
    }
}

/// How far a net's rows (`a` = 0) or columns (1) bend from their chords, over its diagonal.
fn bend(piece: &Piece, a: usize) -> f64 {
    let (lo, hi) = piece.bounds();
    let size = (hi - lo).length();
    if size.is_nan() || size <= 0.0 {
        return 0.0;
    }
    let [n, m] = piece.degree;
    let (along, across) = if a == 0 { (n, m) } else { (m, n) };
    let at = |k: usize, line: usize| if a == 0 { piece.point(k, line) } else { piece.point(line, k) };
    let mut worst: f64 = 0.0;
    for line in 0..=across {
        let (p0, p1) = (at(0, line), at(along, line));
        let chord = p1 - p0;
        let len2 = chord.length_squared();
        for k in 1..along {
            let q = at(k, line) - p0;
            let off = if len2 > 0.0 { q - chord * (q.dot(chord) / len2).clamp(0.0, 1.0) } else { q };
            worst = worst.max(off.length());
        }
    }
    worst / size
}

/// Splits `piece` (the square `cell` of piece `index`) by the depth rule, pushing its leaves.
fn refine(piece: &Piece, index: u32, cell: [u8; 4], out: &mut Vec<Leaf>) {
    let bends = [bend(piece, 0), bend(piece, 1)];
    let (wlo, whi) = piece.points.iter().fold((f64::INFINITY, 0.0f64), |(a, b), h| (a.min(h.w), b.max(h.w)));
    let flat = bends[0] <= FLATNESS && bends[1] <= FLATNESS && whi <= WEIGHT_SPREAD * wlo;
    let room = [cell[2] < MAX_DEPTH, cell[3] < MAX_DEPTH];
    if out.len() >= MAX_LEAVES || flat || !(room[0] || room[1]) {
        // Boxed by `Leaves::build`, from the grown square (this piece is the exact one).
        out.push(Leaf { piece: index, cell, lo: DVec3::ZERO, hi: DVec3::ZERO });
        return;
    }
    let a = if !room[1] || (room[0] && bends[0] >= bends[1]) { 0 } else { 1 };
    for (half, part) in piece.split(a).iter().enumerate() {
        let mut c = cell;
        c[a] = cell[a] * 2 + half as u8;
        c[2 + a] += 1;
        refine(part, index, c, out);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec4;

    fn teapot() -> Vec<Patch> {
        let bytes = std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/teapot-patches.obj")).unwrap();
        crate::io::obj::parse_model(&bytes, "teapot-patches.obj").unwrap().patches
    }

    /// The depth follows the surface: a plane is one leaf, the sphere's pieces a few, the
    /// teapot's curved patches more than its flat bottom's; every leaf is flat by the rule or
    /// at the depth limit, and its box holds its square of the surface.
    #[test]
    fn the_depth_rule_cuts_where_the_surface_bends() {
        let plane = Patch::bezier(
            [3, 3],
            (0..16).map(|k| DVec4::new((k % 4) as f64, (k / 4) as f64, 0.0, 1.0)).collect(),
            0,
        )
        .unwrap();
        assert_eq!(Leaves::build(&[plane]).leaves.len(), 1);
        let sphere = Leaves::build(&[Patch::sphere(DVec3::ZERO, 1.0, 0)]);
        let pot = teapot();
        let leaves = Leaves::build(&pot);
        println!(
            "sphere: {} pieces, {} leaves; teapot: {} pieces, {} leaves, degree {}",
            sphere.pieces.len(),
            sphere.leaves.len(),
            leaves.pieces.len(),
            leaves.leaves.len(),
            leaves.degree
        );
        let per_patch = |k: u32| leaves.leaves.iter().filter(|l| leaves.patch[l.piece as usize] == k).count();
        println!("leaves per teapot patch: {:?}", (0..32).map(per_patch).collect::<Vec<_>>());
        assert_eq!(leaves.pieces.len(), 32);
        for l in leaves.leaves.iter().chain(&sphere.leaves) {
            let set = if l.piece < 32 && leaves.leaves.contains(l) { &leaves } else { &sphere };
            let piece = &set.pieces[l.piece as usize];
            let exact = piece.sub(l.range(0.0));
            let flat = bend(&exact, 0) <= FLATNESS && bend(&exact, 1) <= FLATNESS;
            assert!(flat || l.cell[2] == MAX_DEPTH || l.cell[3] == MAX_DEPTH, "{l:?}");
            let [[u0, u1], [v0, v1]] = l.range(OVERLAP);
            let [[a0, a1], [b0, b1]] = piece.domain;
            let patch = if std::ptr::eq(set, &leaves) {
                &pot[set.patch[l.piece as usize] as usize]
            } else {
                &Patch::sphere(DVec3::ZERO, 1.0, 0)
            };
            for (fu, fv) in [(u0, v0), (u1, v1), (0.5 * (u0 + u1), 0.5 * (v0 + v1)), (u0, v1)] {
                let p = patch.eval(a0 + fu * (a1 - a0), b0 + fv * (b1 - b0)).p;
                let slack = 1e-9 * (1.0 + p.abs().max_element());
                assert!(p.cmpge(l.lo - slack).all() && p.cmple(l.hi + slack).all(), "{p} outside {l:?}");
            }
        }
        // The bottom (patches 29-32) is nearly flat, the spout (17-20) bends.
        assert!(per_patch(29) < per_patch(17), "bottom {} spout {}", per_patch(29), per_patch(17));
    }
}
