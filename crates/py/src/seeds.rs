//! Seeds for batched worlds: world `b` starts from `seed + b`, and a world whose
//! episode ended starts its next from a seed drawn from its last, so a batch is
//! reproducible from its first seeds alone, whatever the order worlds end in.

/// The most worlds one batch holds: far past what memory allows for real scenes,
/// there only so that a typo cannot ask for a billion.
pub const MAX_WORLDS: usize = 65_536;

/// The seed after `seed` (SplitMix64's mix of `seed` plus its increment): well
/// spread, so consecutive worlds' follow-on seeds do not collide.
pub fn next_seed(seed: u64) -> u64 {
    let mut z = seed.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}
