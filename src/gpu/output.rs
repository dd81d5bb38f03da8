//! What a kernel leaves for the host: the output buffer's vec4s and the ray counters, decoded
//! the same way on both device paths.

use super::layout;

/// Rays traced in a frame, by kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayCounts {
    pub eye: u64,
    pub reflection: u64,
    pub refraction: u64,
    pub shadow: u64,
    /// Per loop of `layout::SIMD_LOOPS`, from a `Variant::simd_stats` kernel (zero otherwise).
    pub simd: [SimdCount; layout::SIMD_LOOPS.len()],
}

/// One loop's SIMD counters over a frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SimdCount {
    /// Iterations summed over lanes, each counting those it was active in.
    pub lane_iterations: u64,
    /// Iterations the SIMD groups ran (each once per group, however many lanes were active).
    pub group_iterations: u64,
}

impl SimdCount {
    /// Active lanes per lane slot run, for groups of `subgroup_size` lanes (`None`: the loop
    /// never ran).
    pub fn efficiency(&self, subgroup_size: u32) -> Option<f64> {
        (self.group_iterations > 0)
            .then(|| self.lane_iterations as f64 / (self.group_iterations as f64 * subgroup_size as f64))
    }
}

/// Bytes of the stats buffer (`layout::STATS_WORDS` counters).
pub const STATS_BYTES: u64 = layout::STATS_WORDS as u64 * 4;

impl RayCounts {
    pub fn total(&self) -> u64 {
        self.eye + self.reflection + self.refraction + self.shadow
    }
}

/// `read` of the output buffer's vec4s and the ray counters, from `out_bytes` of output followed
/// by the `STATS_BYTES` of counters (how both device paths read them back), in place.
pub fn decode_output<T>(d: &[u8], out_bytes: u64, read: impl FnOnce(&[[f32; 4]], RayCounts) -> T) -> T {
    let (out, c) = d.split_at(out_bytes as usize);
    let c: [u32; layout::STATS_WORDS as usize] = bytemuck::pod_read_unaligned(&c[..STATS_BYTES as usize]);
    let wide = |at: usize| c[at] as u64 | (c[at + 1] as u64) << 32;
    let counts = RayCounts {
        eye: c[0] as u64,
        reflection: c[1] as u64,
        refraction: c[2] as u64,
        shadow: c[3] as u64,
        simd: std::array::from_fn(|k| {
            let at = layout::STATS_SIMD_AT as usize + 4 * k;
            SimdCount { lane_iterations: wide(at), group_iterations: wide(at + 2) }
        }),
    };
    match bytemuck::try_cast_slice(out) {
        Ok(out) => read(out, counts),
        // Mapped memory is aligned on every device seen; a copy only if one is not.
        Err(_) => read(&bytemuck::pod_collect_to_vec(out), counts),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two vec4s and the counters, read in place where the bytes are aligned and through the
    /// copy where they are not: the same values either way.
    #[test]
    fn output_decodes_aligned_or_not() {
        let out = [[1.0f32, 2.0, 3.0, 4.0], [5.0, 6.0, 7.0, 8.0]];
        // The ray counts, then per loop its two 64-bit counters (low word first).
        let mut counts = vec![9u32, 10, 11, 12];
        for k in 0..layout::SIMD_LOOPS.len() as u32 {
            counts.extend([100 + k, k, 200 + k, 0]);
        }
        let mut bytes = vec![0u8; 1];
        bytes.extend_from_slice(bytemuck::cast_slice(&out));
        bytes.extend_from_slice(bytemuck::cast_slice(&counts));
        let words: Vec<u32> = bytemuck::pod_collect_to_vec(&bytes[1..]);
        let simd = std::array::from_fn(|k| SimdCount {
            lane_iterations: 100 + k as u64 + ((k as u64) << 32),
            group_iterations: 200 + k as u64,
        });
        let expect = RayCounts { eye: 9, reflection: 10, refraction: 11, shadow: 12, simd };
        for d in [bytemuck::cast_slice::<u32, u8>(&words), &bytes[1..]] {
            let (o, c) = decode_output(d, 32, |o, c| (o.to_vec(), c));
            assert_eq!((o.as_slice(), c), (&out[..], expect));
        }
        // The second case really is unaligned (malloc aligns `bytes` to 16), so it took the copy.
        assert_ne!(bytes[1..].as_ptr() as usize % std::mem::align_of::<[f32; 4]>(), 0);
    }
}
