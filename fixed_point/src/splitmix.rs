//! [`SplitMix64`]: a tiny seeded generator (Steele, Lea and Flood 2014) for the tests' random
//! inputs and the host's tools (model initialisation, random networks). The controller never
//! draws a random number: nothing on its decision path uses this.

/// splitmix64: the state is the seed; the same seed gives the same stream on every target.
#[derive(Clone, Debug)]
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `0..n` (`0` when `n` is 0; the modulo's small bias is of no matter to a test).
    pub fn below(&mut self, n: u64) -> u64 {
        self.next_u64() % n.max(1)
    }

    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in [−a, a), as `f32`.
    pub fn symmetric(&mut self, a: f64) -> f32 {
        ((self.unit() * 2.0 - 1.0) * a) as f32
    }
}
