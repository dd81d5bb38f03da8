//! How the conventional mode hands out tiles: a schedule is a boundary array over the frame's
//! tiles, built on the host. Workgroups take chunk `c` = tiles `[b[c], b[c+1])` with one atomic
//! fetch-and-increment, so every schedule costs the same on the device; only the sizes differ.

use crate::ParseError;
use std::fmt;
use std::str::FromStr;

pub use crate::gpu::layout::{TILE_H, TILE_W};

/// Chunk sizes of a frame's tile queue.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Schedule {
    /// RTRT's trapezoid: `rounds` rounds of one chunk per worker, the first chunk
    /// 2N/(P(G+1)) tiles, each round smaller by max(1, size0/G), never below 1 tile.
    Rtrt { rounds: u32 },
    /// Guided self-scheduling (Polychronopoulos & Kuck 1987): each chunk ⌈R/P⌉ of the R left.
    Guided,
    /// Factoring (Hummel et al. 1992): batches of P chunks of ⌈R/2P⌉ tiles.
    Factoring,
    /// Every chunk the same number of tiles.
    Fixed { tiles: u32 },
    /// No queue: one plain dispatch of the whole frame, which lavapipe splits statically between
    /// its threads (one contiguous half each). What the queue has to beat.
    Plain,
}

impl Default for Schedule {
    fn default() -> Self {
        Schedule::Rtrt { rounds: 40 }
    }
}

impl Schedule {
    /// Every schedule (with default parameters), for tables, benches and the HUD.
    pub const ALL: [Schedule; 5] = [
        Schedule::Rtrt { rounds: 40 },
        Schedule::Guided,
        Schedule::Factoring,
        Schedule::Fixed { tiles: 16 },
        Schedule::Plain,
    ];

    /// The boundary array for `tiles` tiles and `workers` workers: b[0] = 0, strictly
    /// increasing, last = `tiles`; chunk c is `[b[c], b[c+1])`. ([`Schedule::Plain`]: one
    /// chunk, the whole frame.)
    pub fn boundaries(self, tiles: u32, workers: u32) -> Vec<u32> {
        let p = workers.max(1) as u64;
        let n = tiles as u64;
        let mut b = vec![0u32];
        let mut done = 0u64;
        let mut push = |size: u64, done: &mut u64| {
            let size = size.clamp(1, n - *done);
            *done += size;
            b.push(*done as u32);
        };
        match self {
            Schedule::Rtrt { rounds } => {
                let g = rounds.max(1) as u64;
                let mut size = (2 * n / (p * (g + 1))).max(1);
                let dec = (size / g).max(1);
                while done < n {
                    for _ in 0..p {
                        if done < n {
                            push(size, &mut done);
                        }
                    }
                    size = size.saturating_sub(dec).max(1);
                }
            }
            Schedule::Guided => {
                while done < n {
                    push((n - done).div_ceil(p), &mut done);
                }
            }
            Schedule::Factoring => {
                while done < n {
                    let size = (n - done).div_ceil(2 * p);
                    for _ in 0..p {
                        if done < n {
                            push(size, &mut done);
                        }
                    }
                }
            }
            Schedule::Fixed { tiles } => {
                while done < n {
                    push(tiles.max(1) as u64, &mut done);
                }
            }
            Schedule::Plain => push(n, &mut done),
        }
        b
    }
}

impl fmt::Display for Schedule {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Schedule::Rtrt { rounds } => write!(f, "rtrt:{rounds}"),
            Schedule::Guided => write!(f, "guided"),
            Schedule::Factoring => write!(f, "factoring"),
            Schedule::Fixed { tiles } => write!(f, "fixed:{tiles}"),
            Schedule::Plain => write!(f, "plain"),
        }
    }
}

impl FromStr for Schedule {
    type Err = ParseError;
    fn from_str(s: &str) -> Result<Self, ParseError> {
        let (name, arg) = s.split_once(':').map_or((s, None), |(a, b)| (a, Some(b)));
        let num = |default: u32| -> Result<u32, ParseError> {
            match arg {
                None => Ok(default),
                Some(a) => match a.parse::<u32>() {
                    Ok(v) if v >= 1 => Ok(v),
                    _ => Err(ParseError::new(
                        "schedule",
                        format!("`{s}`: expected a whole number >= 1 after `{name}:`"),
                    )),
                },
            }
        };
        match name {
            "rtrt" => Ok(Schedule::Rtrt { rounds: num(40)? }),
            "guided" if arg.is_none() => Ok(Schedule::Guided),
            "factoring" if arg.is_none() => Ok(Schedule::Factoring),
            "fixed" => Ok(Schedule::Fixed { tiles: num(16)? }),
            "plain" if arg.is_none() => Ok(Schedule::Plain),
            _ => Err(ParseError::unknown(
                "schedule",
                s,
                "rtrt[:ROUNDS], guided, factoring, fixed[:TILES] or plain",
            )),
        }
    }
}

/// Tiles of an image of `width` × `height` pixels: (columns, rows) of [`TILE_W`]×[`TILE_H`].
pub fn tile_grid(width: u32, height: u32) -> [u32; 2] {
    [width.div_ceil(TILE_W), height.div_ceil(TILE_H)]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(b: &[u32], n: u32) {
        assert_eq!(b[0], 0);
        assert_eq!(*b.last().unwrap(), n);
        assert!(b.windows(2).all(|w| w[0] < w[1]), "boundaries must strictly increase: {b:?}");
    }

    #[test]
    fn every_schedule_covers_every_tile_once() {
        for n in [1, 2, 3, 7, 64, 100, 1000, 4096, 14400, 65537] {
            for p in [1, 2, 3, 8, 64, 1000] {
                for s in Schedule::ALL
                    .into_iter()
                    .chain([Schedule::Rtrt { rounds: 1 }, Schedule::Fixed { tiles: 1 }])
                {
                    check(&s.boundaries(n, p), n);
                }
            }
        }
    }

    #[test]
    fn rtrt_matches_its_formula() {
        // N = 4096 tiles (512² in 32×2 tiles), P = 2, G = 40: size0 = 2·4096/(2·41) = 99,
        // dec = max(1, 99/40) = 2; each round two chunks, shrinking by 2 down to 1.
        let b = Schedule::Rtrt { rounds: 40 }.boundaries(4096, 2);
        let sizes: Vec<u32> = b.windows(2).map(|w| w[1] - w[0]).collect();
        assert_eq!(&sizes[..6], &[99, 99, 97, 97, 95, 95]);
        assert!(sizes.windows(2).all(|w| w[1] <= w[0]), "chunks never grow");
        // The rounds 99, 97, …, 1 would hold 2·2500 = 5000 > 4096 tiles: the queue runs out
        // before the chunks reach 1 tile, and the last chunk is what is left.
        let total: u32 = sizes.iter().sum();
        assert_eq!(total, 4096);
        // N = 100, P = 4, G = 40: size0 = 200/164 = 1: every chunk is one tile.
        let b = Schedule::Rtrt { rounds: 40 }.boundaries(100, 4);
        assert_eq!(b, (0..=100).collect::<Vec<_>>());
    }

    #[test]
    fn guided_and_factoring_match_their_formulas() {
        let sizes = |b: Vec<u32>| b.windows(2).map(|w| w[1] - w[0]).collect::<Vec<u32>>();
        // Guided, R = 10, P = 3: ⌈10/3⌉ = 4, ⌈6/3⌉ = 2, ⌈4/3⌉ = 2, ⌈2/3⌉ = 1, 1.
        assert_eq!(sizes(Schedule::Guided.boundaries(10, 3)), vec![4, 2, 2, 1, 1]);
        // Factoring, R = 20, P = 2: batch of 2×⌈20/4⌉ = 5, 5; R = 10: 3, 3; R = 4: 1, 1; R = 2: 1, 1.
        assert_eq!(sizes(Schedule::Factoring.boundaries(20, 2)), vec![5, 5, 3, 3, 1, 1, 1, 1]);
        assert_eq!(sizes(Schedule::Fixed { tiles: 4 }.boundaries(10, 3)), vec![4, 4, 2]);
    }

    #[test]
    fn schedules_parse_and_print() {
        for s in Schedule::ALL {
            assert_eq!(s.to_string().parse::<Schedule>().unwrap(), s);
        }
        assert!("fixed:0".parse::<Schedule>().is_err());
        assert!("nope".parse::<Schedule>().unwrap_err().to_string().contains("rtrt"));
    }
}
