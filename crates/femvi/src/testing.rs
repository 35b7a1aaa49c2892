//! Helpers shared by the unit tests: a seeded xorshift generator of uniform numbers, so that
//! random-input tests are reproducible without a dependency.

/// Uniform numbers in [0, 1) from `seed` (xorshift64, the top 53 bits).
pub(crate) fn uniform(mut seed: u64) -> impl FnMut() -> f64 {
    move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64
    }
}
