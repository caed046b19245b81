//! A tiny deterministic generator (SplitMix64), so scenes and point sets are the same on every
//! machine and run without extra dependencies.

pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Rng {
        Rng(seed)
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in [lo, hi), from the top 24 bits (exactly representable in f32).
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        let u = (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32;
        lo + (hi - lo) * u
    }

    /// Uniform in [lo, hi], rounded to a multiple of 1/256, so generated scenes print in few
    /// digits.
    pub fn param(&mut self, lo: f32, hi: f32) -> f32 {
        (self.range(lo, hi) * 256.0).round() / 256.0
    }

    pub fn param4(&mut self, lo: f32, hi: f32) -> [f32; 4] {
        std::array::from_fn(|_| self.param(lo, hi))
    }
}
