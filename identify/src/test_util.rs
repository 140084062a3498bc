//! Helpers shared by the unit tests.

/// Seeded uniform numbers in [-0.5, 0.5) from a 64-bit LCG (Knuth's MMIX constants): the
/// same sequence on every platform.
pub(crate) struct Lcg(pub(crate) u64);

impl Lcg {
    pub(crate) fn uniform(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64 / (1u64 << 53) as f64) - 0.5
    }
}
