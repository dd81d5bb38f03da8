//! Peers that trace exactly the work `irt bench --workload primary-shadow` gives irt, so that
//! speed ratios compare like with like (issue 11, item 2).
//!
//! The workload is an ordinary scene setting, not a special shader: [`primary_shadow`] rewrites a
//! scene so that irt's own pipeline traces one eye ray per pixel centre and one hard-shadow ray per
//! light facing each hit, shaded by Lambert alone. A peer then only has to trace those same rays.

#[cfg(feature = "embree")]
pub mod embree;
pub mod native;

pub use native::{PeerFrame, PeerRays};

use crate::scene::{Ambient, MaterialKind, Scene, ShadowMode};
use glam::DVec3;

/// Why a peer could not be set up: a scene it does not trace, or (Embree) the library refusing.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum PeerError {
    #[error("the {peer} peer traces the primary-shadow workload only (depth 1, hard shadows)")]
    NotTheWorkload { peer: &'static str },
    #[error("the {peer} peer shades diffuse materials only (use the primary-shadow workload)")]
    NotDiffuse { peer: &'static str },
    #[error("the {peer} peer traces spheres, triangles and cones, not volumes or spline patches")]
    Volumes { peer: &'static str },
    /// An Embree call that returned nothing (`call`: "rtcNewDevice", "rtcNewGeometry(2)").
    #[error("{call}: {error}")]
    Embree { call: String, error: &'static str },
    /// An error code Embree reported after `what`.
    #[error("{what}: Embree reports {error}")]
    EmbreeReports { what: &'static str, error: &'static str },
    #[error("this Embree was built without 8-wide ray packets")]
    NoPackets,
}

/// A peer as `irt bench` times it: one frame of the workload on `threads` threads, with its
/// image and ray counts. Every peer shades through the same code (`native::Shade`) and differs
/// only in how it finds hits, so images and counts compare directly.
pub trait Peer {
    /// Short name for tables and messages ("native", "embree").
    fn name(&self) -> &'static str;
    fn render(&self, threads: usize) -> PeerFrame;
}

impl Peer for native::NativePeer {
    fn name(&self) -> &'static str {
        native::NativePeer::name(self)
    }
    fn render(&self, threads: usize) -> PeerFrame {
        native::NativePeer::render(self, threads)
    }
}

/// `scene` as the peer-comparable workload:
/// - `max_depth = 1` (eye ray = depth 1, SPD's rule): no reflection or refraction rays;
/// - hard shadows: one shadow ray per light whose direction faces the hit's normal;
/// - every material diffuse with its colour (metal and polished keep their colour, a dielectric,
///   which has none, becomes white), no textures: shading is n·l × light colour × colour;
/// - no ambient (both ambient colours black), so a shadowed point is black.
///
/// Camera, lights, background and geometry are unchanged.
pub fn primary_shadow(scene: &Scene) -> Scene {
    let mut s = scene.clone();
    s.trace.max_depth = 1;
    s.trace.shadows = ShadowMode::Hard;
    for m in &mut s.materials {
        let color = match m.kind {
            MaterialKind::Diffuse { color } | MaterialKind::Metal { color, .. } => color,
            MaterialKind::Polished { color, .. } => color,
            MaterialKind::Dielectric { .. } => DVec3::ONE,
        };
        m.kind = MaterialKind::Diffuse { color };
        m.texture = None;
    }
    s.textures.clear();
    s.ambient = Ambient { sky: DVec3::ZERO, ground: DVec3::ZERO, up: s.ambient.up };
    s
}
