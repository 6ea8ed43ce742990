//! Seeded, deterministic random numbers for tests, fitting and Monte Carlo.
//!
//! PCG32 (O'Neill 2014, XSH-RR variant): small, fast, reproducible across platforms.
//! The shaders do not use it: the GPU reference (shaders-glsl/shade/reference/integrate.glsl) hashes its seeds
//! with its own 32-bit PCG hash (Jarzynski & Olano 2020), which no CPU code needs to reproduce.

/// A PCG32 generator: 64-bit state, 32-bit output.
#[derive(Clone, Debug)]
pub struct Pcg32 {
    state: u64,
    inc: u64,
}

impl Pcg32 {
    const MULT: u64 = 6364136223846793005;

    /// A generator for `seed` on stream `stream` (different streams never overlap).
    pub fn new(seed: u64, stream: u64) -> Self {
        let mut rng = Self { state: 0, inc: (stream << 1) | 1 };
        rng.next_u32();
        rng.state = rng.state.wrapping_add(seed);
        rng.next_u32();
        rng
    }

    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(Self::MULT).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// Uniform in [0, 1) with 53 random bits.
    pub fn next_f64(&mut self) -> f64 {
        let hi = (self.next_u32() as u64) << 21;
        let lo = (self.next_u32() as u64) >> 11;
        ((hi | lo) as f64) * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in [lo, hi).
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next_f64()
    }

    /// A uniformly distributed unit vector.
    pub fn unit_vector(&mut self) -> [f64; 3] {
        let z = self.uniform(-1.0, 1.0);
        let phi = self.uniform(0.0, 2.0 * std::f64::consts::PI);
        let r = (1.0 - z * z).max(0.0).sqrt();
        [r * phi.cos(), r * phi.sin(), z]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn deterministic_and_uniform() {
        let mut a = Pcg32::new(42, 7);
        let mut b = Pcg32::new(42, 7);
        let n = 100_000;
        let mut mean = 0.0;
        for _ in 0..n {
            let x = a.next_f64();
            assert_eq!(x, b.next_f64());
            assert!((0.0..1.0).contains(&x));
            mean += x;
        }
        mean /= n as f64;
        // Standard error of the mean of U(0,1) is 1/sqrt(12 n) ≈ 9e-4: 5 sigma.
        assert!((mean - 0.5).abs() < 5e-3, "mean {mean}");
        let mut c = Pcg32::new(43, 7);
        assert_ne!(Pcg32::new(42, 7).next_u32(), c.next_u32());
    }
}
