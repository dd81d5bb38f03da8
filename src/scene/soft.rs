//! `--shadows soft`: the shadow mode a scene gets when the user asks for soft shadows and not
//! for a method (docs/tradeoff.md, "The soft default"). No method wins on every scene: shells
//! are nearly exact and cost about a hard ray where few shells lie along a shadow ray, and cost
//! many times a hard ray where many do (small occluders under a light much larger than they are,
//! many lights over cheap geometry), and on meshes whose contours overlap from the light less
//! accurate than hard shadows; bundles converge everywhere but cost a ray per sample. The rule
//! below ([`choose_soft`]) picks from estimates of each mode's error and time made on the CPU
//! before anything is traced ([`pilot`]).

use super::shells::{
    capsule, cover, scene_shells, shell_cell, LightShells, Occluders, ShellShape, SHELL_DIRECT_TRIANGLES,
};
use super::{Combine, Scene, ShadowMode};
use crate::reference::{Reference, Stats, RAY_OFFSET_REL};
use crate::ParseError;
use glam::DVec3;
use std::fmt;
use std::str::FromStr;

/// What the user asked for: one method, or `soft` (the method [`choose_soft`] picks).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShadowSetting {
    Mode(ShadowMode),
    Soft,
}

impl FromStr for ShadowSetting {
    type Err = ParseError;
    fn from_str(s: &str) -> Result<Self, ParseError> {
        if s == "soft" {
            return Ok(ShadowSetting::Soft);
        }
        s.parse().map(ShadowSetting::Mode).map_err(|_| {
            ParseError::new(
                "shadow mode",
                format!("unknown shadow mode '{s}': expected soft | {}", super::SHADOW_MODE_SYNTAX),
            )
        })
    }
}

impl fmt::Display for ShadowSetting {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        match self {
            ShadowSetting::Mode(m) => m.fmt(f),
            ShadowSetting::Soft => write!(f, "soft"),
        }
    }
}

impl ShadowSetting {
    /// The mode to render `scene` with, and for `soft` what was picked and why.
    pub fn resolve(self, scene: &Scene) -> (ShadowMode, Option<SoftChoice>) {
        match self {
            ShadowSetting::Mode(m) => (m, None),
            ShadowSetting::Soft => {
                let c = choose_soft(scene);
                (c.mode, Some(c))
            }
        }
    }
}

/// What `soft` picked for a scene, and the measure that decided it.
#[derive(Clone, Debug, PartialEq)]
pub struct SoftChoice {
    pub mode: ShadowMode,
    /// What [`pilot`] estimated for each candidate (none without area lights).
    pub estimates: Vec<Estimate>,
    /// One line for the user: the estimates and the rule's bound.
    pub why: String,
}

impl fmt::Display for SoftChoice {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        write!(f, "soft → {} ({})", self.mode, self.why)
    }
}

/// The most a soft mode may cost: its estimated frame time over hard shadows' (issue #38's
/// bound). Among the modes that fit, `soft` takes the one with the least estimated error.
pub const SOFT_COST_BUDGET: f64 = 1.5;

/// The cost model of [`pilot`], fitted (least squares, weights ≥ 0) to the frame times of 17
/// scenes measured with `irt tradeoff` (docs/tradeoff.md, "The soft default"), in units of one
/// BVH node or primitive visited by a hard shadow ray: a frame's work per pixel, per node or
/// primitive its eye ray visits, per hard shadow ray and per node or primitive it visits
/// (the fit leaves the fixed parts at 0: they hide in the visits).
const FRAME_WEIGHTS: [f64; 4] = [0.0, 0.82, 0.0, 1.0];
/// A shell ray's work ([`shell_ray_counts`]): per ray, per sphere, cone and mesh listed in its
/// cell, per contour edge, per triangle tested, per node or primitive of its walk (fitted with
/// [`FRAME_WEIGHTS`]; the triangles' cost is folded into the meshes').
const SHELL_WEIGHTS: [f64; 7] = [0.0, 1.44, 2.61, 11.74, 0.51, 0.0, 1.35];

/// Pixels across the pilot grid of eye rays ([`pilot`]).
const PILOT: u32 = 96;
/// Ground truth of the pilot: this² stratified rays per light and point.
const PILOT_STRATA: u32 = 8;

/// The soft modes `soft` chooses among, besides hard shadows. Shells combine by `min` or by
/// `product`: the same rays, and `product` is the nearer where many small occluders' penumbrae
/// overlap (SPD rings_s2: 0.46x hard shadows' RMSE against min's 0.70x; equal where one
/// occluder casts each penumbra).
fn candidates() -> [ShadowMode; 5] {
    [
        ShadowMode::Shell { falloff: Default::default(), combine: Combine::Min },
        ShadowMode::Shell { falloff: Default::default(), combine: Combine::Product },
        ShadowMode::Bundle { samples: 2, rotate: true },
        ShadowMode::Bundle { samples: 3, rotate: true },
        ShadowMode::Bundle { samples: 4, rotate: true },
    ]
}

/// One mode's estimate: its error and frame time, each over hard shadows'.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    pub mode: ShadowMode,
    pub error: f64,
    pub cost: f64,
}

/// Estimates, before anything is traced on the GPU, how wrong and how costly each of
/// [`candidates`] is on `scene` against hard shadows. On the CPU (f64 reference): eye rays
/// through a pilot grid of pixels find shading points; from each, towards each light it faces:
/// - **error**: the visibility each mode gives against the ground truth's
///   ([`PILOT_STRATA`]² rays), weighted by the light's diffuse term there; each mode's RMS over
///   hard shadows';
/// - **cost**: the work of the pilot frame in BVH nodes and primitives visited (the eye ray's
///   closest-hit walk and each hard shadow ray's any-hit walk, plus their fixed parts); a bundle
///   of K adds K − 1 hard rays' work; a shell ray costs its light-buffer cell's work instead
///   (spheres, cones, each listed mesh's contour edges in the cell and, for a small mesh, its
///   triangles; for a mesh the GPU walks, the hard ray's walk again).
///
/// Shells are estimated only where `shells` are given ([`crowded`] scenes skip building them).
pub fn pilot(scene: &Scene, shells: Option<&[LightShells]>) -> Vec<Estimate> {
    let mut hard_scene = scene.clone();
    hard_scene.trace.shadows = ShadowMode::Hard;
    let truth = Reference::new(&hard_scene).with_ground_truth(PILOT_STRATA);
    let with_mode = |m: ShadowMode| {
        let mut s = scene.clone();
        s.trace.shadows = m;
        s
    };
    let modes: Vec<ShadowMode> = candidates()
        .into_iter()
        .filter(|m| shells.is_some() || !matches!(m, ShadowMode::Shell { .. }))
        .collect();
    let scenes: Vec<Scene> = modes.iter().map(|&m| with_mode(m)).collect();
    let refs: Vec<Reference> = scenes
        .iter()
        .map(|s| match (s.trace.shadows, shells) {
            (ShadowMode::Shell { .. }, Some(sh)) => Reference::with_shells(s, sh.to_vec()),
            _ => Reference::new(s),
        })
        .collect();
    let occ = Occluders::new(scene);
    let cam = &scene.camera;
    let basis = cam.basis();
    let (w, h) = (PILOT, (PILOT * cam.height / cam.width.max(1)).max(1));
    let mut stats = Stats::default();
    // Σ w² (v − truth)² per mode and for hard shadows; work: frame, hard shadow rays, shell rays.
    let (mut err, mut err_hard) = (vec![0.0; modes.len()], 0.0);
    // Pixels, eye walk, hard rays, hard walk, then shell_ray_counts' seven.
    let mut counts = [0.0f64; 11];
    for y in 0..h {
        for x in 0..w {
            let px = (x as f64 + 0.5) * cam.width as f64 / w as f64;
            let py = (y as f64 + 0.5) * cam.height as f64 / h as f64;
            let pixel = py as u32 * cam.width + px as u32;
            let d = cam.direction(&basis, px, py).normalize();
            counts[0] += 1.0;
            counts[1] += occ.walk(cam.eye, d, f64::INFINITY, false).1 as f64;
            let Some(hit) = truth.intersect(cam.eye, d, f64::INFINITY) else { continue };
            let eps = RAY_OFFSET_REL * hit.scale.max(1.0);
            let so = hit.p + eps * hit.n_g;
            for (i, light) in scene.lights.iter().enumerate() {
                let to = light.position - so;
                let dist = to.length();
                let l = to / dist;
                if dist <= 2.0 * eps || hit.n.dot(l) <= 0.0 {
                    continue;
                }
                let weight = light.color.dot(DVec3::splat(1.0 / 3.0)) * hit.n.dot(l);
                let walk = occ.walk(so, l, dist - eps, true);
                let v_hard = if walk.0.is_some() { 0.0 } else { 1.0 };
                let vs: Vec<f64> =
                    refs.iter().map(|r| r.visibility(so, light, eps, pixel, &mut stats)).collect();
                // The ground truth only where some mode sees a penumbra (where all agree with
                // the hard ray, it is taken to be the truth: the pilot's time goes to penumbrae).
                let v = if vs.iter().all(|&x| x == v_hard) {
                    v_hard
                } else {
                    truth.visibility(so, light, eps, pixel, &mut stats)
                };
                err_hard += (weight * (v_hard - v)).powi(2);
                for (e, x) in err.iter_mut().zip(&vs) {
                    *e += (weight * (x - v)).powi(2);
                }
                let walk = walk.1 as f64;
                counts[2] += 1.0;
                counts[3] += walk;
                if let Some(sh) = shells {
                    for (a, b) in counts[4..].iter_mut().zip(shell_ray_counts(&sh[i], so, l, dist, walk)) {
                        *a += b;
                    }
                }
            }
        }
    }
    let dot = |w: &[f64], n: &[f64]| w.iter().zip(n).map(|(w, n)| w * n).sum::<f64>();
    let hard = dot(&FRAME_WEIGHTS[2..], &counts[2..4]);
    let frame = dot(&FRAME_WEIGHTS, &counts[..4]);
    let shell = dot(&SHELL_WEIGHTS, &counts[4..]);
    if std::env::var_os("IRT_SOFT_COUNTS").is_some() {
        eprintln!("soft counts {counts:?}");
    }
    modes
        .iter()
        .zip(err)
        .map(|(&mode, e)| Estimate {
            mode,
            error: if err_hard > 0.0 { (e / err_hard).sqrt() } else { 1.0 },
            cost: match mode {
                ShadowMode::Bundle { samples, .. } => (frame + (samples - 1) as f64 * hard) / frame,
                _ => (frame - hard + shell) / frame,
            },
        })
        .collect()
}

/// What a shell ray from `p`, `dist` long in direction `l` to the light (from the light: `-l`)
/// visits in `sh`'s light buffer: [rays, spheres, cones, meshes, contour edges, triangles tested
/// (a small mesh's, where the ray crosses its box), walk]; `walk` is what the hard ray's walk
/// visited (a mesh the GPU walks costs that), its weight 1.
fn shell_ray_counts(sh: &LightShells, p: DVec3, l: DVec3, dist: f64, walk: f64) -> [f64; 7] {
    let c = shell_cell(-l, sh.res) as usize;
    let mut n = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    let mut walks = false;
    let slab = &sh.slab_cells[c * sh.slabs.count as usize + sh.slabs.of(dist) as usize];
    for &k in sh.cells[c].iter().chain(slab) {
        match sh.objects[k as usize].shape {
            ShellShape::Sphere(_) => n[1] += 1.0,
            ShellShape::Cone(_) => n[2] += 1.0,
            ShellShape::Mesh { triangles: [a, b], edges: [e0, e1] } => {
                n[3] += 1.0;
                n[4] += sh.cell_edges[c].iter().filter(|&&e| e >= e0 && e < e1).count() as f64;
                let direct = b - a <= SHELL_DIRECT_TRIANGLES;
                walks |= !direct;
                if direct && sh.objects[k as usize].crosses_box(p, l, dist) {
                    n[5] += (b - a) as f64;
                }
            }
        }
    }
    if walks {
        n[6] = walk;
    }
    n
}

/// The soft default for `scene` (lights' radii as given): of [`candidates`] whose estimated
/// frame time ([`pilot`]) is at most [`SOFT_COST_BUDGET`] times hard shadows', the one with the
/// least estimated error, if it is below hard shadows'; else hard shadows. Hard shadows too where
/// no light has a radius.
pub fn choose_soft(scene: &Scene) -> SoftChoice {
    if scene.lights.iter().all(|l| l.radius == 0.0) {
        return SoftChoice { mode: ShadowMode::Hard, estimates: vec![], why: "point lights only".into() };
    }
    // Where even the finest light buffer would list scores of shells per cell, skip building
    // it (balls_s5's would take a minute; a shell frame there costs 101x a hard one, depth
    // slabs and all).
    let crowd = crowded(scene);
    // Shells hold spheres, cones and meshes only: a patch would cast no shell shadow at all,
    // so a scene with patches picks among the bundles (which trace patches like hard rays).
    let patches = !scene.patches.is_empty();
    let shells = if crowd.is_none() && !patches { Some(scene_shells(scene)) } else { None };
    let estimates = pilot(scene, shells.as_deref());
    let best = estimates
        .iter()
        .filter(|e| e.cost <= SOFT_COST_BUDGET && e.error < 1.0)
        .min_by(|a, b| a.error.total_cmp(&b.error));
    let mut why: Vec<String> =
        estimates.iter().map(|e| format!("{} {:.2}x error {:.2}x time", e.mode, e.error, e.cost)).collect();
    if let Some(load) = crowd {
        why.push(format!("no shells: {load:.0} per light-buffer cell at the finest resolution"));
    } else if patches {
        why.push("no shells: patches cast no shell shadow".into());
    }
    let why = format!("estimated {}; budget {SOFT_COST_BUDGET}x", why.join(", "));
    SoftChoice { mode: best.map_or(ShadowMode::Hard, |e| e.mode), estimates, why }
}

/// The mean (Σ n² / Σ n) number of sphere and cone shells per cell of the coarsest light buffer
/// of the most crowded light, divided by the most the finest buffer can divide it (64x the
/// cells), where that is still over 64; `None` otherwise.
fn crowded(scene: &Scene) -> Option<f64> {
    let res = super::shells::SHELL_CELL_RES_MIN;
    let refine = (super::shells::SHELL_CELL_RES_MAX / res).pow(2) as f64;
    let mut worst: f64 = 0.0;
    for l in scene.lights.iter().filter(|l| l.radius > 0.0) {
        let mut n = vec![0.0f64; 6 * (res * res) as usize];
        for s in &scene.spheres {
            cover(l.position, &[(s.center, s.radius + l.radius)], res, &mut |c| n[c as usize] += 1.0);
        }
        for c in &scene.cones {
            let pieces = capsule(c.base, c.apex, c.base_radius.max(c.apex_radius) + l.radius);
            cover(l.position, &pieces, res, &mut |k| n[k as usize] += 1.0);
        }
        let sum: f64 = n.iter().sum();
        if sum > 0.0 {
            worst = worst.max(n.iter().map(|x| x * x).sum::<f64>() / sum / refine);
        }
    }
    (worst > 64.0).then_some(worst)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{default_scene, Sphere};

    #[test]
    fn soft_parses_beside_the_modes() {
        assert_eq!("soft".parse::<ShadowSetting>().unwrap(), ShadowSetting::Soft);
        assert_eq!(
            "bundle:4".parse::<ShadowSetting>().unwrap(),
            ShadowSetting::Mode(ShadowMode::Bundle { samples: 4, rotate: true })
        );
        assert_eq!("soft".parse::<ShadowSetting>().unwrap().to_string(), "soft");
        let err = "sfot".parse::<ShadowSetting>().unwrap_err().to_string();
        assert!(err.contains("soft | hard"), "{err}");
    }

    /// Point lights: nothing to soften. The default scene (few large occluders): shells. A
    /// crowd of small spheres under a large light (every cell lists hundreds of shells): two rays.
    #[test]
    fn soft_picks_by_what_a_shell_ray_would_visit() {
        let mut s = default_scene();
        s.lights.iter_mut().for_each(|l| l.radius = 0.0);
        assert_eq!(choose_soft(&s).mode, ShadowMode::Hard);
        s.lights.iter_mut().for_each(|l| l.radius = 0.8);
        let c = choose_soft(&s);
        assert!(matches!(c.mode, ShadowMode::Shell { .. }), "{c}");
        let mut crowd = default_scene();
        crowd.spheres = (0..4000)
            .map(|i| {
                let (x, z) = ((i % 64) as f64 * 0.03, (i / 64) as f64 * 0.03);
                Sphere { center: DVec3::new(x, 1.0 + (i % 7) as f64 * 0.03, z), radius: 0.01, material: 0 }
            })
            .collect();
        crowd.lights.iter_mut().for_each(|l| l.radius = 1.0);
        let c = choose_soft(&crowd);
        assert_eq!(c.mode, ShadowMode::Bundle { samples: 2, rotate: true }, "{c}");
    }
}
