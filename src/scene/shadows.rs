//! Shadow modes (docs/shadows.md): what a renderer does to find a light's visibility `s`.

use crate::ParseError;
use std::f64::consts::PI;
use std::fmt;
use std::str::FromStr;

/// Largest shadow-ray bundle.
pub const MAX_BUNDLE: u32 = 256;

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ShadowMode {
    /// One ray to the light's centre.
    #[default]
    Hard,
    /// `samples` rays towards a precomputed point set on the light's disc; `rotate` turns the set
    /// by a fixed per-pixel angle (noise instead of banding).
    Bundle { samples: u32, rotate: bool },
    /// One ray to the centre through translucent shells around every occluder.
    Shell { falloff: Falloff, combine: Combine },
}

/// How a shell's transparency rises from 0 at the inner object to 1 at the shell's boundary
/// (τ from 0 to 1 across the shell, ½ on the hard shadow's edge; docs/shadows.md).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(u32)]
pub enum Falloff {
    /// 3τ² − 2τ³, the paper's: the disc profile's cubic stand-in.
    Smoothstep = 0,
    /// τ.
    Linear = 1,
    /// The default: the visible fraction of a disc light behind a straight occluder edge, the
    /// true penumbra profile; the lowest error of the three against the ground truth on the
    /// three scenes of docs/tradeoff.md (within 4% of smoothstep's on SPD balls_s2).
    #[default]
    Disc = 2,
}

/// How the transparencies of several shells along one shadow ray combine.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(u32)]
pub enum Combine {
    #[default]
    Min = 0,
    Product = 1,
}

impl Falloff {
    pub const ALL: [Falloff; 3] = [Falloff::Smoothstep, Falloff::Linear, Falloff::Disc];
    fn name(self) -> &'static str {
        match self {
            Falloff::Smoothstep => "smoothstep",
            Falloff::Linear => "linear",
            Falloff::Disc => "disc",
        }
    }
}

impl Combine {
    fn name(self) -> &'static str {
        match self {
            Combine::Min => "min",
            Combine::Product => "product",
        }
    }
}

impl ShadowMode {
    /// The shader variant this mode needs (0 hard, 1 bundle, 2 shell).
    pub fn kind_index(self) -> u32 {
        match self {
            ShadowMode::Hard => 0,
            ShadowMode::Bundle { .. } => 1,
            ShadowMode::Shell { .. } => 2,
        }
    }
}

/// Accepted spellings, for error messages and `--help`.
pub const SHADOW_MODE_SYNTAX: &str =
    "hard | bundle:K[:fixed] (K in 1..=256) | shell[:smoothstep|linear|disc][:min|product]";

impl FromStr for ShadowMode {
    type Err = ParseError;
    fn from_str(s: &str) -> Result<Self, ParseError> {
        let bad = || {
            ParseError::new(
                "shadow mode",
                format!("unknown shadow mode '{s}': expected {SHADOW_MODE_SYNTAX}"),
            )
        };
        let mut parts = s.split(':');
        let mode = match parts.next().unwrap_or("") {
            "hard" => ShadowMode::Hard,
            "bundle" => {
                let k = parts.next().ok_or_else(bad)?;
                let samples: u32 = k.parse().map_err(|_| bad())?;
                if !(1..=MAX_BUNDLE).contains(&samples) {
                    return Err(ParseError::new(
                        "shadow mode",
                        format!("bundle size {samples} must be between 1 and {MAX_BUNDLE}"),
                    ));
                }
                let rotate = match parts.next() {
                    None => true,
                    Some("fixed") => false,
                    Some(_) => return Err(bad()),
                };
                ShadowMode::Bundle { samples, rotate }
            }
            "shell" => {
                let (mut falloff, mut combine) = (Falloff::default(), Combine::default());
                for p in parts.by_ref() {
                    if let Some(f) = Falloff::ALL.into_iter().find(|f| f.name() == p) {
                        falloff = f;
                    } else if let Some(c) =
                        [Combine::Min, Combine::Product].into_iter().find(|c| c.name() == p)
                    {
                        combine = c;
                    } else {
                        return Err(bad());
                    }
                }
                ShadowMode::Shell { falloff, combine }
            }
            _ => return Err(bad()),
        };
        match parts.next() {
            None => Ok(mode),
            Some(_) => Err(bad()),
        }
    }
}

impl fmt::Display for ShadowMode {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        match *self {
            ShadowMode::Hard => write!(f, "hard"),
            ShadowMode::Bundle { samples, rotate: true } => write!(f, "bundle:{samples}"),
            ShadowMode::Bundle { samples, rotate: false } => write!(f, "bundle:{samples}:fixed"),
            ShadowMode::Shell { falloff, combine } => {
                write!(f, "shell:{}:{}", falloff.name(), combine.name())
            }
        }
    }
}

/// The bundle's points on the unit disc: Vogel's golden-angle spiral, evenly spread for any
/// count. Input data shared by both tracers (like the scene itself), not tracing code.
pub fn bundle_samples(samples: u32) -> Vec<[f64; 2]> {
    let golden = PI * (3.0 - 5f64.sqrt());
    (0..samples)
        .map(|k| {
            let rho = ((k as f64 + 0.5) / samples as f64).sqrt();
            let phi = k as f64 * golden;
            [rho * phi.cos(), rho * phi.sin()]
        })
        .collect()
}

/// A fixed per-pixel hash (PCG, Jarzynski & Olano 2020) that turns a bundle; both tracers use
/// it so they rotate pixel `i`'s bundle by the same angle.
pub fn pixel_hash(i: u32) -> u32 {
    let state = i.wrapping_mul(747796405).wrapping_add(2891336453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277803737);
    (word >> 22) ^ word
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn modes_round_trip_through_text() {
        for s in ["hard", "bundle:1", "bundle:64:fixed", "shell:disc:product", "shell:smoothstep:min"] {
            let m: ShadowMode = s.parse().unwrap();
            assert_eq!(m.to_string(), s);
        }
        assert_eq!("shell".parse::<ShadowMode>().unwrap().to_string(), "shell:disc:min");
        for bad in ["", "soft", "bundle", "bundle:0", "bundle:257", "bundle:4:x", "shell:cubic", "hard:1"] {
            assert!(bad.parse::<ShadowMode>().is_err(), "{bad}");
        }
    }

    #[test]
    fn bundle_points_cover_the_disc_evenly() {
        let s = bundle_samples(256);
        assert!(s.iter().all(|p| p[0].hypot(p[1]) < 1.0));
        // Each quadrant and each annulus of equal area gets its share (±10%).
        for q in 0..4 {
            let n =
                s.iter().filter(|p| (p[0] >= 0.0) == (q & 1 == 0) && (p[1] >= 0.0) == (q & 2 == 0)).count();
            assert!((58..=70).contains(&n), "quadrant {q}: {n}");
        }
        let inner = s.iter().filter(|p| p[0].hypot(p[1]) < 0.5f64.sqrt()).count();
        assert_eq!(inner, 128);
    }
}
