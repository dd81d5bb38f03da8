//! The order in which the frameless mode visits pixels: a fixed permutation of every pixel index,
//! cut into slices of S pixels per dispatch. Either a host-built table (uploaded once) or an order
//! computed in the shader (the dissolve, which needs no table).

use super::adaptive::DEFAULT_REVISIT_PASSES;
use crate::ParseError;
use std::fmt;
use std::str::FromStr;

/// RTRT's default: the image is cut into about this many chunks (at 512², 4 pixels each).
pub const RTRT_CHUNKS: u64 = 65536;

/// How the frameless mode orders pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PixelOrder {
    /// The paper's: a Hilbert curve over the image padded to a 2^k square, cut into chunks of
    /// `chunk` pixels (a power of 4, so a chunk is a square block; 0 = RTRT's 65 536 chunks),
    /// dealt round-robin to `procs` virtual processors, each processor's list shuffled with a
    /// fixed seed, the lists interleaved.
    Hilbert { chunk: u32, procs: u32 },
    /// A uniformly random permutation (Fisher–Yates, fixed seed).
    Random,
    /// A maximal-length linear-feedback shift register over the pixel index bits (the
    /// "digital dissolve", Graphics Gems I), computed in the shader: no table.
    Dissolve,
    /// Slices dealt where the picture changes (`render::adaptive`), every pixel revisited within
    /// `revisit` passes' positions; the host writes each slice's pixels.
    Adaptive { revisit: u32 },
}

/// The default chunk: 8×8 pixels. RTRT's 65 536 chunks (2×2 at 512²) put neighbouring SIMD
/// lanes on far-apart pixels; 8×8 chunks keep a lane group on one compact run of the curve and
/// trace about twice as fast on lavapipe (docs/interactive.md).
pub const DEFAULT_CHUNK: u32 = 64;

impl Default for PixelOrder {
    fn default() -> Self {
        PixelOrder::Hilbert { chunk: DEFAULT_CHUNK, procs: 16 }
    }
}

/// Seed of every shuffle: orders are fixed, so runs and tests repeat exactly.
const SEED: u64 = 0x1999_0426_0001;

impl PixelOrder {
    pub const ALL: [PixelOrder; 3] =
        [PixelOrder::Hilbert { chunk: DEFAULT_CHUNK, procs: 16 }, PixelOrder::Random, PixelOrder::Dissolve];

    /// The visiting order as a table of pixel indices (y·width + x), every pixel exactly once;
    /// `None` for orders computed in the shader or dealt slice by slice (adaptive).
    pub fn table(self, width: u32, height: u32) -> Option<Vec<u32>> {
        let n = width as usize * height as usize;
        match self {
            PixelOrder::Hilbert { chunk, procs } => Some(hilbert_order(width, height, chunk, procs)),
            PixelOrder::Random => {
                let mut t: Vec<u32> = (0..n as u32).collect();
                shuffle(&mut t, SEED);
                Some(t)
            }
            PixelOrder::Dissolve | PixelOrder::Adaptive { .. } => None,
        }
    }

    /// Positions in one pass: the pixel count, or the dissolve's period (some of whose values
    /// fall outside the image and are skipped).
    pub fn pass_len(self, width: u32, height: u32) -> u64 {
        match self {
            PixelOrder::Dissolve => Dissolve::new(width as u64 * height as u64).period(),
            _ => width as u64 * height as u64,
        }
    }
}

impl fmt::Display for PixelOrder {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PixelOrder::Hilbert { chunk: 0, procs } => write!(f, "hilbert:auto:{procs}"),
            PixelOrder::Hilbert { chunk, procs } => write!(f, "hilbert:{chunk}:{procs}"),
            PixelOrder::Random => write!(f, "random"),
            PixelOrder::Dissolve => write!(f, "dissolve"),
            PixelOrder::Adaptive { revisit: DEFAULT_REVISIT_PASSES } => write!(f, "adaptive"),
            PixelOrder::Adaptive { revisit } => write!(f, "adaptive:{revisit}"),
        }
    }
}

impl FromStr for PixelOrder {
    type Err = ParseError;
    fn from_str(s: &str) -> Result<Self, ParseError> {
        let parts: Vec<&str> = s.split(':').collect();
        let bad = || {
            ParseError::unknown(
                "pixel order",
                s,
                "hilbert[:CHUNK|auto[:PROCS]], random, dissolve or adaptive[:PASSES] (CHUNK a power \
                 of 4; PASSES ≥ 1, the revisit bound)",
            )
        };
        match parts.as_slice() {
            ["random"] => Ok(PixelOrder::Random),
            ["dissolve"] => Ok(PixelOrder::Dissolve),
            ["adaptive"] => Ok(PixelOrder::Adaptive { revisit: DEFAULT_REVISIT_PASSES }),
            ["adaptive", p] => match p.parse::<u32>() {
                Ok(revisit) if revisit >= 1 => Ok(PixelOrder::Adaptive { revisit }),
                _ => Err(bad()),
            },
            ["hilbert", rest @ ..] if rest.len() <= 2 => {
                let chunk = match rest.first() {
                    None | Some(&"auto") => 0,
                    Some(c) => match c.parse::<u32>() {
                        Ok(c) if c.is_power_of_two() && c.trailing_zeros() % 2 == 0 => c,
                        _ => return Err(bad()),
                    },
                };
                let procs = match rest.get(1) {
                    None => 16,
                    Some(p) => p.parse::<u32>().ok().filter(|&p| p >= 1).ok_or_else(bad)?,
                };
                Ok(PixelOrder::Hilbert { chunk, procs })
            }
            _ => Err(bad()),
        }
    }
}

/// (x, y) of Hilbert index `d` on a `side`×`side` square (`side` a power of 2).
pub fn hilbert_d2xy(side: u32, d: u64) -> (u32, u32) {
    let (mut x, mut y) = (0u64, 0u64);
    let mut t = d;
    let mut s = 1u64;
    while s < side as u64 {
        let rx = 1 & (t / 2);
        let ry = 1 & (t ^ rx);
        if ry == 0 {
            if rx == 1 {
                x = s - 1 - x;
                y = s - 1 - y;
            }
            std::mem::swap(&mut x, &mut y);
        }
        x += s * rx;
        y += s * ry;
        t /= 4;
        s *= 2;
    }
    (x as u32, y as u32)
}

/// The chunk size RTRT's default gives for an image of `pixels` pixels: the smallest power of 4
/// that cuts it into at most [`RTRT_CHUNKS`] chunks. (RTRT's images were power-of-2 squares;
/// counting the image, not its padded square, keeps chunks small on wide images: 4×4 at
/// 1280×720 rather than 8×8.)
pub fn auto_chunk(pixels: u64) -> u32 {
    let mut c = 1u64;
    while pixels.div_ceil(c) > RTRT_CHUNKS {
        c *= 4;
    }
    c as u32
}

fn hilbert_order(width: u32, height: u32, chunk: u32, procs: u32) -> Vec<u32> {
    let side = width.max(height).max(1).next_power_of_two();
    let cells = side as u64 * side as u64;
    let chunk = if chunk == 0 { auto_chunk(width as u64 * height as u64) } else { chunk } as u64;
    let chunk = chunk.min(cells);
    let chunks = cells / chunk;
    let procs = (procs.max(1) as u64).min(chunks);
    // Processor p gets chunks p, p + P, p + 2P, …, each list shuffled with its own seed.
    let lists: Vec<Vec<u64>> = (0..procs)
        .map(|p| {
            let mut l: Vec<u64> = (p..chunks).step_by(procs as usize).collect();
            shuffle(&mut l, SEED ^ p.wrapping_mul(0x9E37_79B9_7F4A_7C15));
            l
        })
        .collect();
    let mut out = Vec::with_capacity(width as usize * height as usize);
    let longest = lists.iter().map(Vec::len).max().unwrap_or(0);
    for round in 0..longest {
        for l in &lists {
            let Some(&c) = l.get(round) else { continue };
            for d in c * chunk..(c + 1) * chunk {
                let (x, y) = hilbert_d2xy(side, d);
                if x < width && y < height {
                    out.push(y * width + x);
                }
            }
        }
    }
    out
}

/// SplitMix64 (Steele, Lea & Flood 2014): small, seedable, good enough to shuffle with.
fn splitmix(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Fisher–Yates with a fixed seed.
pub fn shuffle<T>(v: &mut [T], seed: u64) {
    let mut s = seed;
    for i in (1..v.len()).rev() {
        let j = (splitmix(&mut s) % (i as u64 + 1)) as usize;
        v.swap(i, j);
    }
}

/// Tap positions (1-based, the polynomial's exponents) of maximal-length LFSRs of 2…26 bits
/// (Xilinx XAPP052, table 3); each is checked to run its full period by a test.
const TAPS: [&[u32]; 25] = [
    &[2, 1],
    &[3, 2],
    &[4, 3],
    &[5, 3],
    &[6, 5],
    &[7, 6],
    &[8, 6, 5, 4],
    &[9, 5],
    &[10, 7],
    &[11, 9],
    &[12, 6, 4, 1],
    &[13, 4, 3, 1],
    &[14, 5, 3, 1],
    &[15, 14],
    &[16, 15, 13, 4],
    &[17, 14],
    &[18, 11],
    &[19, 6, 2, 1],
    &[20, 17],
    &[21, 19],
    &[22, 21],
    &[23, 18],
    &[24, 23, 22, 17],
    &[25, 22],
    &[26, 6, 2, 1],
];

/// The largest image the dissolve can order: 2^26 − 1 pixels.
pub const DISSOLVE_MAX_BITS: u32 = 26;

/// A Galois LFSR of `bits` bits: state' = (state >> 1) ^ (taps if state is odd). Its nonzero
/// states form one cycle of 2^bits − 1; state v visits pixel v − 1, so every pixel of an image of
/// at most 2^bits − 1 pixels is visited once per period, and values past the image are skipped.
/// The step is linear over GF(2), so the state k steps ahead is a matrix product: the shader
/// jumps from a slice's first state to its invocation's with the matrices T^(2^j) (`jumps`),
/// O(bits²) operations and no per-pixel table.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Dissolve {
    pub bits: u32,
    pub taps: u32,
}

impl Dissolve {
    /// The smallest register whose period covers `pixels` (at least 2 bits); `pixels` must be
    /// below 2^[`DISSOLVE_MAX_BITS`] (checked by the caller with [`Dissolve::fits`]).
    pub fn new(pixels: u64) -> Self {
        let mut bits = 2;
        while (1u64 << bits) - 1 < pixels && bits < DISSOLVE_MAX_BITS {
            bits += 1;
        }
        let taps = TAPS[bits as usize - 2].iter().fold(0u32, |m, &t| m | 1 << (t - 1));
        Dissolve { bits, taps }
    }

    pub fn fits(pixels: u64) -> bool {
        pixels < 1u64 << DISSOLVE_MAX_BITS
    }

    pub fn period(&self) -> u64 {
        (1u64 << self.bits) - 1
    }

    pub fn step(&self, s: u32) -> u32 {
        (s >> 1) ^ if s & 1 == 1 { self.taps } else { 0 }
    }

    /// The state at position `k` of the sequence that starts at state 1.
    pub fn state_at(&self, k: u64) -> u32 {
        let jumps = self.jumps();
        let k = k % self.period();
        let mut s = 1u32;
        for (j, m) in jumps.chunks(self.bits as usize).enumerate() {
            if k >> j & 1 == 1 {
                s = apply(m, s);
            }
        }
        s
    }

    /// `bits` matrices T^(2^j), j = 0 … bits−1, each as `bits` columns (column i = the image of
    /// state bit i), laid out one after another: what the shader's jump reads.
    pub fn jumps(&self) -> Vec<u32> {
        let n = self.bits as usize;
        let mut m: Vec<u32> = (0..n).map(|i| self.step(1 << i)).collect();
        let mut out = Vec::with_capacity(n * n);
        for _ in 0..n {
            out.extend_from_slice(&m);
            // Square: column i of M² = M applied to column i of M.
            m = m.iter().map(|&c| apply(&m, c)).collect();
        }
        out
    }
}

/// A GF(2) matrix (as columns) applied to a state vector.
fn apply(cols: &[u32], s: u32) -> u32 {
    cols.iter().enumerate().filter(|(i, _)| s >> i & 1 == 1).fold(0, |acc, (_, &c)| acc ^ c)
}

/// The pixels of positions `[first, first + len)` of the order (its table, or the dissolve over
/// `pixels` pixels): `None` for the dissolve's values past the image.
pub fn order_pixels(
    table: Option<&[u32]>,
    first: u64,
    len: u64,
    pixels: u64,
) -> Box<dyn Iterator<Item = Option<u32>> + '_> {
    match table {
        Some(t) => Box::new(t[first as usize..(first + len) as usize].iter().map(|&p| Some(p))),
        None => {
            let d = Dissolve::new(pixels);
            let mut s = d.state_at(first);
            Box::new((0..len).map(move |_| {
                let v = s;
                s = d.step(s);
                (v as u64 <= pixels).then(|| v - 1)
            }))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn assert_bijection(t: &[u32], n: usize) {
        assert_eq!(t.len(), n);
        let mut seen = vec![false; n];
        for &p in t {
            assert!(!seen[p as usize], "pixel {p} twice");
            seen[p as usize] = true;
        }
    }

    #[test]
    fn tables_are_bijections_for_awkward_sizes() {
        for (w, h) in [(1, 1), (1, 37), (37, 1), (513, 257), (64, 64), (3, 1000), (1280, 720)] {
            for order in [
                PixelOrder::default(),
                PixelOrder::Random,
                PixelOrder::Hilbert { chunk: 1, procs: 1 },
                PixelOrder::Hilbert { chunk: 64, procs: 7 },
                PixelOrder::Hilbert { chunk: 1 << 20, procs: 3 },
            ] {
                assert_bijection(&order.table(w, h).unwrap(), (w * h) as usize);
            }
        }
    }

    #[test]
    fn hilbert_neighbours_are_neighbours() {
        for side in [1u32, 2, 4, 32, 256] {
            let n = side as u64 * side as u64;
            let mut seen = std::collections::HashSet::new();
            let mut prev = hilbert_d2xy(side, 0);
            seen.insert(prev);
            for d in 1..n {
                let p = hilbert_d2xy(side, d);
                assert_eq!(prev.0.abs_diff(p.0) + prev.1.abs_diff(p.1), 1, "step {d} at side {side}");
                assert!(seen.insert(p));
                prev = p;
            }
        }
    }

    #[test]
    fn chunks_are_square_blocks() {
        // 512², the default: 65 536 chunks of 4 pixels, each a 2×2 block.
        assert_eq!(auto_chunk(512 * 512), 4);
        assert_eq!(auto_chunk(1280 * 720), 16);
        assert_eq!(auto_chunk(2048 * 2048), 64);
        let t = PixelOrder::Hilbert { chunk: 16, procs: 4 }.table(64, 64).unwrap();
        for c in t.chunks(16) {
            let xs: Vec<u32> = c.iter().map(|p| p % 64).collect();
            let ys: Vec<u32> = c.iter().map(|p| p / 64).collect();
            assert_eq!(xs.iter().max().unwrap() - xs.iter().min().unwrap(), 3);
            assert_eq!(ys.iter().max().unwrap() - ys.iter().min().unwrap(), 3);
        }
    }

    #[test]
    fn every_lfsr_runs_its_full_period() {
        for bits in 2..=DISSOLVE_MAX_BITS {
            let d = Dissolve { bits, ..Dissolve::new((1u64 << (bits - 1)) + 1) };
            assert_eq!(d.bits, bits);
            let mut s = 1u32;
            let mut k = 0u64;
            loop {
                s = d.step(s);
                k += 1;
                assert!(s != 0 && s < 1 << bits);
                if s == 1 {
                    break;
                }
                assert!(k < d.period(), "{bits} bits: period too long");
            }
            assert_eq!(k, d.period(), "{bits} bits: not maximal");
        }
    }

    #[test]
    fn dissolve_jumps_match_stepping() {
        let d = Dissolve::new(513 * 257);
        let mut s = 1u32;
        for k in 0..5000u64 {
            assert_eq!(d.state_at(k), s, "position {k}");
            s = d.step(s);
        }
        assert_eq!(d.state_at(d.period()), 1);
        assert_eq!(d.state_at(d.period() + 7), d.state_at(7));
    }

    #[test]
    fn orders_parse_and_print() {
        let more = [
            PixelOrder::Hilbert { chunk: 16, procs: 3 },
            PixelOrder::Adaptive { revisit: DEFAULT_REVISIT_PASSES },
            PixelOrder::Adaptive { revisit: 5 },
        ];
        for o in PixelOrder::ALL.into_iter().chain(more) {
            assert_eq!(o.to_string().parse::<PixelOrder>().unwrap(), o);
        }
        assert_eq!("adaptive".parse::<PixelOrder>().unwrap().to_string(), "adaptive");
        assert!("adaptive:0".parse::<PixelOrder>().is_err());
        assert!("hilbert:8".parse::<PixelOrder>().is_err(), "8 is not a power of 4");
        assert!("hilbert:4:0".parse::<PixelOrder>().is_err());
    }
}
