//! How primitives are found: the flattened uniform grid with macro-cells, or a bounding-volume
//! hierarchy beside it, chosen per scene ([`AccelChoice`]).
pub mod bvh;
pub mod grid;
pub mod macrocells;
pub use bvh::Bvh;
pub use grid::{Grid, PrimKind, PrimRef};

use crate::scene::Scene;
use std::fmt;

/// The accelerator a scene is traced with, as built.
#[derive(Clone, Debug, PartialEq)]
pub enum Accel {
    Grid(Grid),
    /// The BVH and whether the shader walks it without a stack (by its escape links).
    Bvh(Bvh, BvhWalk),
}

/// How the shader walks a BVH (`shaders/bvh.wgsl`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum BvhWalk {
    /// No stack: the fixed depth-first order, a missed node's subtree skipped by its escape
    /// link. What pays on lavapipe (docs/performance.md, "Grid vs BVH").
    #[default]
    Stackless,
    /// A stack of node indices, the child nearer along the split axis first: fewer nodes per
    /// ray, but on lavapipe the run-time-indexed stack costs more than that saves.
    Stack,
}

/// A borrowed [`Accel`] (what the packing reads): `&Grid`, `&Bvh` (walked the default way) and
/// `&Accel` all convert.
#[derive(Clone, Copy, Debug)]
pub enum AccelRef<'a> {
    Grid(&'a Grid),
    Bvh(&'a Bvh, BvhWalk),
}

impl<'a> From<&'a Grid> for AccelRef<'a> {
    fn from(g: &'a Grid) -> Self {
        AccelRef::Grid(g)
    }
}

impl<'a> From<&'a Bvh> for AccelRef<'a> {
    fn from(b: &'a Bvh) -> Self {
        AccelRef::Bvh(b, BvhWalk::default())
    }
}

impl<'a> From<&'a Accel> for AccelRef<'a> {
    fn from(a: &'a Accel) -> Self {
        match a {
            Accel::Grid(g) => AccelRef::Grid(g),
            Accel::Bvh(b, w) => AccelRef::Bvh(b, *w),
        }
    }
}

impl Accel {
    /// Builds the accelerator `kind` for `scene` (valid); `progress(done, total)` as the grid
    /// inserts primitives or the BVH places them in leaves.
    pub fn build(scene: &Scene, kind: AccelKind, progress: &(dyn Fn(usize, usize) + Sync)) -> Accel {
        match kind {
            AccelKind::Grid => Accel::Grid(Grid::build_with_progress(scene, progress)),
            AccelKind::Bvh(walk) => Accel::Bvh(bvh_with_progress(scene, walk, progress), walk),
        }
    }

    /// The BVH of `scene` walked by `walk` ([`bvh_for`]).
    pub fn bvh(scene: &Scene, walk: BvhWalk) -> Accel {
        Accel::Bvh(bvh_for(scene, walk), walk)
    }

    /// Builds what `choice` asks for.
    pub fn choose(scene: &Scene, choice: AccelChoice, progress: &(dyn Fn(usize, usize) + Sync)) -> Accel {
        Self::build(scene, choice.resolve(scene), progress)
    }

    pub fn kind(&self) -> AccelKind {
        match self {
            Accel::Grid(_) => AccelKind::Grid,
            Accel::Bvh(_, w) => AccelKind::Bvh(*w),
        }
    }

    /// The grid, if this is one (the native peer walks irt's grid).
    pub fn grid(&self) -> Option<&Grid> {
        match self {
            Accel::Grid(g) => Some(g),
            Accel::Bvh(..) => None,
        }
    }

    /// Primitive references stored (a grid lists a primitive in every cell it overlaps, a BVH
    /// once).
    pub fn refs(&self) -> usize {
        match self {
            Accel::Grid(g) => g.prim_refs.len(),
            Accel::Bvh(b, _) => b.refs.len(),
        }
    }

    /// A one-line summary for logs and `irt bench`.
    pub fn summary(&self) -> String {
        match self {
            Accel::Grid(g) => g.stats().to_string(),
            Accel::Bvh(b, w) => format!("{} ({w:?} walk)", b.stats()),
        }
    }
}

/// The BVH of `scene` as `walk` needs it. The stackless walk visits children in their stored
/// order, so its tree is ordered towards the camera's eye ([`Bvh::ordered_towards`]); the stack
/// walk orders them per ray and keeps the builder's order.
pub fn bvh_for(scene: &Scene, walk: BvhWalk) -> Bvh {
    bvh_with_progress(scene, walk, &|_, _| {})
}

/// [`bvh_for`], calling `progress(done, total)` as the build places primitives in leaves.
pub fn bvh_with_progress(scene: &Scene, walk: BvhWalk, progress: &(dyn Fn(usize, usize) + Sync)) -> Bvh {
    let bvh = Bvh::build_with_progress(scene, progress);
    match walk {
        BvhWalk::Stackless => bvh.ordered_towards(scene.camera.eye),
        BvhWalk::Stack => bvh,
    }
}

/// An accelerator as built: the grid or a BVH (and how it is walked).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum AccelKind {
    Grid,
    Bvh(BvhWalk),
}

/// What `--accel` asks for: one of the two, or a choice per scene ([`AccelChoice::resolve`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum AccelChoice {
    Grid,
    /// The BVH walked without a stack ([`BvhWalk::Stackless`]).
    Bvh,
    /// The BVH walked with a stack ([`BvhWalk::Stack`]; for measuring, docs/performance.md).
    BvhStack,
    /// The default: the BVH, unless a large scene's primitives move ([`auto`]).
    #[default]
    Auto,
}

impl AccelChoice {
    pub const NAMES: [(&'static str, AccelChoice); 4] = [
        ("grid", AccelChoice::Grid),
        ("bvh", AccelChoice::Bvh),
        ("bvh-stack", AccelChoice::BvhStack),
        ("auto", AccelChoice::Auto),
    ];

    /// The accelerator to build for `scene`.
    pub fn resolve(self, scene: &Scene) -> AccelKind {
        match self {
            AccelChoice::Grid => AccelKind::Grid,
            AccelChoice::Bvh => AccelKind::Bvh(BvhWalk::Stackless),
            AccelChoice::BvhStack => AccelKind::Bvh(BvhWalk::Stack),
            AccelChoice::Auto => auto(scene),
        }
    }
}

/// Past this many primitives `--accel auto` keeps the grid for scenes whose primitives move: a
/// BVH is rebuilt whole at every frame (0.6 s a million triangles on two cores, 1.25 s a million
/// spheres of SPD balls), where the grid re-inserts only the moving ones.
pub const AUTO_GRID_ABOVE: usize = 1 << 21;

/// `--accel auto`'s rule (docs/performance.md, "Grid vs BVH" and "Large scenes: the BVH"): the
/// BVH, which traced every scene measured faster than the grid, by 1.06x (SPD jacks) to 9.6x
/// (the stadium) and 30x on SPD balls at size 7 (5.4M spheres), unless the scene has more than
/// [`AUTO_GRID_ABOVE`] primitives and some of them move. Its build costs more than the grid's
/// (a one-off picture of a 3M-triangle terrain waits 1.3 s longer), but a grid's frame has no
/// such bound: the one picture of balls size 7 takes 22 s with the grid, 11 with the BVH.
pub fn auto(scene: &Scene) -> AccelKind {
    let moving = scene.motions.iter().any(|m| !matches!(m.target, crate::scene::Target::Light(_)));
    let n = scene.primitive_count();
    let kind = auto_for(n, moving);
    if kind == AccelKind::Grid && n > AUTO_GRID_PRIMITIVES {
        log::info!(
            "--accel auto: the grid for this scene of {n} primitives: a BVH's scene texture would pass what \
             one device allocation may hold (--accel bvh to try one anyway)"
        );
    } else if kind == AccelKind::Grid {
        log::info!(
            "--accel auto: the grid for this scene of {n} primitives, since some of them move: a BVH \
             would be rebuilt whole at every frame (--accel bvh to build one anyway)"
        );
    }
    kind
}

/// Past this many primitives (only particle files reach it) `--accel auto` takes the grid
/// whether or not anything moves: with a BVH (up to 3 texels a primitive beside a sphere's 2) the
/// scene texture of the paper's 35M spheres is 2.7 GiB, past the 2 GiB one Vulkan allocation may
/// take on lavapipe (its `maxMemoryAllocationSize`): the set-up failed after 65 s of building.
/// The grid's texture is 1.55 GiB, built in 4.5–5 s, and traces the stress plate's evenly
/// spread spheres at 512² in 0.5–0.84 s (docs/large-models.md, "Particles").
pub const AUTO_GRID_PRIMITIVES: usize = 1 << 24;

/// [`auto`] for a scene of `primitives`, some of them `moving` or not.
pub fn auto_for(primitives: usize, moving: bool) -> AccelKind {
    if primitives > AUTO_GRID_ABOVE && moving || primitives > AUTO_GRID_PRIMITIVES {
        AccelKind::Grid
    } else {
        AccelKind::Bvh(BvhWalk::default())
    }
}

impl std::str::FromStr for AccelChoice {
    type Err = crate::ParseError;
    fn from_str(s: &str) -> Result<Self, crate::ParseError> {
        Self::NAMES.iter().find(|(n, _)| *n == s).map(|(_, c)| *c).ok_or_else(|| {
            let names: Vec<&str> = Self::NAMES.iter().map(|(n, _)| *n).collect();
            crate::ParseError::unknown("accelerator", s, names.join(", "))
        })
    }
}

impl fmt::Display for AccelChoice {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        let name = Self::NAMES.iter().find(|(_, c)| c == self).map(|(n, _)| *n).expect("named");
        f.write_str(name)
    }
}
