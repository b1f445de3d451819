//! The one seed and hash scheme of radtrace: every random choice (pixel jitter, light
//! points, shooting points) is derived from the user's seed by SplitMix64 hashing of
//! what the choice is for, so an image depends on the seed alone, not on the threads.

/// A 32-bit seed for pixel `(x, y)` of a view, from the user's seed.
pub fn pixel_seed(seed: u64, view: u64, x: u32, y: u32) -> u32 {
    fold32(splitmix64(
        seed ^ splitmix64(view << 48 ^ (y as u64) << 24 ^ x as u64),
    ))
}

/// Folds a 64-bit hash into 32 bits (for sample seeds).
pub fn fold32(h: u64) -> u32 {
    (h ^ (h >> 32)) as u32
}

/// SplitMix64's finaliser: a good 64-bit mixing function.
pub fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Mixes a 32-bit value (for deriving independent sample seeds).
pub fn hash32(x: u32) -> u32 {
    fold32(splitmix64(x as u64))
}
