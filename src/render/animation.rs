//! A moving scene's accelerator over time: the primitives that move, the grid lattice that holds
//! them over the whole animation, and the grid of a new time (only the moving primitives
//! re-inserted while they stay inside it).

use crate::accel::grid::Lattice;
use crate::accel::{Accel, AccelKind, Grid};
use crate::scene::Scene;
use glam::DVec3;
use std::ops::Range;

/// Times at which an animation is posed to find the box its moving objects sweep (plus its
/// ends); a cubic that overshoots between them makes the lattice grow when it happens.
const LATTICE_SAMPLES: u32 = 64;

/// What a session keeps of its scene's motions.
pub(super) struct Animation {
    /// The primitives that move.
    pub moving: Vec<Range<usize>>,
    /// The grid lattice for the whole animation, with the box it was fitted to; `None` for a
    /// still scene (its grid is fitted to it as always).
    lattice: Option<(Lattice, DVec3, DVec3)>,
}

impl Animation {
    /// `base`'s moving primitives and, if any, the lattice holding them: the box of its still
    /// primitives and of its moving ones at [`LATTICE_SAMPLES`] times, grown by 2% so that small
    /// overshoots still fit.
    pub fn of(base: &Scene) -> Self {
        let moving = Grid::moving_prims(base);
        let lattice = Self::lattice_of(base, &moving);
        Animation { moving, lattice }
    }

    fn lattice_of(base: &Scene, moving: &[Range<usize>]) -> Option<(Lattice, DVec3, DVec3)> {
        if moving.is_empty() {
            return None;
        }
        let end = base.duration();
        let mut lo = DVec3::INFINITY;
        let mut hi = DVec3::NEG_INFINITY;
        let n = base.primitive_count();
        for k in 0..=LATTICE_SAMPLES {
            let posed = base.at(end * k as f64 / LATTICE_SAMPLES as f64);
            // The still primitives once; the moving ones at every sample.
            let ranges: Vec<Range<usize>> =
                if k == 0 { std::iter::once(0..n).collect() } else { moving.to_vec() };
            if let Some((a, b)) = Grid::bounds_of(&posed, &ranges) {
                (lo, hi) = (lo.min(a), hi.max(b));
            }
        }
        if !(lo.is_finite() && hi.is_finite()) {
            return None;
        }
        let grow = (hi - lo).max_element() * 0.02;
        let (lo, hi) = (lo - grow, hi + grow);
        Some((Lattice::around(lo, hi, n), lo, hi))
    }

    /// The first accelerator of `scene` (posed from the animation): a grid in the animation's
    /// lattice ([`Grid::update`] then moves only what moves) or fitted to a still scene; a BVH
    /// fitted either way. `progress(done, total)` as it builds.
    pub fn first_accel(
        &self,
        scene: &Scene,
        kind: AccelKind,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Accel {
        match (kind, &self.lattice) {
            (AccelKind::Grid, Some((l, ..))) => Accel::Grid(Grid::build_in(scene, *l)),
            (kind, _) => Accel::build(scene, kind, progress),
        }
    }

    /// The grid of `scene`: the moving primitives re-inserted into `current` when only they
    /// moved (`motion`), `incremental` is on and the lattice still holds them; else a build in
    /// the animation's lattice (grown to hold the scene if it must) or, for a still scene, a
    /// fitted build.
    pub fn regrid(&mut self, current: Option<&Grid>, scene: &Scene, motion: bool, incremental: bool) -> Grid {
        let Some((lattice, lo, hi)) = self.lattice else { return Grid::build(scene) };
        let swept = Grid::bounds_of(scene, &self.moving);
        let inside = swept.is_none_or(|(a, b)| a.cmpge(lo).all() && b.cmple(hi).all());
        if !inside {
            // An overshoot the samples missed: a lattice holding it too, from now on.
            let (a, b) = swept.expect("outside means something moved");
            let (lo, hi) = (lo.min(a), hi.max(b));
            let lattice = Lattice::around(lo, hi, scene.primitive_count());
            self.lattice = Some((lattice, lo, hi));
            return Grid::build_in(scene, lattice);
        }
        match current {
            Some(grid) if motion && incremental && grid.lattice() == lattice => {
                grid.update(scene, &self.moving)
            }
            _ => Grid::build_in(scene, lattice),
        }
    }
}
