//! A small deterministic generator (SplitMix64): the same sequence on every machine, for the
//! supermesh's random walks and rotations and for the tests' random cases.

/// The next 64 random bits; advances `state`.
pub(crate) fn next_random(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// A number below `bound` (at least 1), uniform up to a bias under `bound / 2^64`.
pub(crate) fn next_below(state: &mut u64, bound: u32) -> u32 {
    (next_random(state) % u64::from(bound)) as u32
}

/// Uniform in `[0, 1)`.
pub(crate) fn next_unit(state: &mut u64) -> f64 {
    (next_random(state) >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}
