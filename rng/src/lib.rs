//! rodlog's one source of randomness: SplitMix64 (Steele, Lea & Flood, "Fast splittable
//! pseudorandom number generators", OOPSLA 2014), always seeded explicitly.
//!
//! ```text
//! splitmix64(x): z = x + 0x9E3779B97F4A7C15
//!                z = (z ^ z >> 30) * 0xBF58476D1CE4E5B9
//!                z = (z ^ z >> 27) * 0x94D049BB133111EB
//!                return z ^ z >> 31
//! ```
//!
//! Two ways to use it:
//! - [`SplitMix64`], a sequential generator (`state += gamma; return mix(state)`): RANSAC
//!   samples, synthetic test data, a driver's noise stream;
//! - [`counter`], counter-based keys `key(seed, stream, index)`: a pure function of its
//!   arguments, so a value never depends on the order or the thread in which it is drawn
//!   (the simulator draws every pixel's noise this way).
//!
//! There is no global state and no entropy source: same seed, same numbers.

pub mod counter;

/// The golden-ratio increment of SplitMix64.
pub const GAMMA: u64 = 0x9E37_79B9_7F4A_7C15;

/// The SplitMix64 finaliser of `x + GAMMA` (a bijection of `u64`).
#[inline]
#[must_use]
pub fn splitmix64(x: u64) -> u64 {
    let mut z = x.wrapping_add(GAMMA);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A sequential SplitMix64 generator (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SplitMix64 {
    state: u64,
}

impl SplitMix64 {
    /// A generator whose stream is fully determined by `seed`.
    #[must_use]
    pub fn new(seed: u64) -> Self {
        Self { state: seed }
    }

    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        let z = splitmix64(self.state);
        self.state = self.state.wrapping_add(GAMMA);
        z
    }

    /// Uniform in `[0, 1)` (53 random bits).
    pub fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in `[lo, hi)`.
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next_f64()
    }

    /// Uniform index in `[0, n)` by Lemire's multiply-shift (bias below `n / 2^64`); `n = 0`
    /// gives 0.
    pub fn below(&mut self, n: usize) -> usize {
        ((u128::from(self.next_u64()) * n as u128) >> 64) as usize
    }

    /// Standard normal deviate: Box-Muller, `sqrt(-2 ln u1) cos(2 pi u2)` with `u1` in
    /// `(0, 1]`.
    pub fn normal(&mut self) -> f64 {
        let u1 = 1.0 - self.next_f64();
        let u2 = self.next_f64();
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }

    /// Fills `out` with `out.len()` distinct indices in `[0, n)` (rejection: `out` is a small
    /// minimal sample). Returns false, drawing nothing, when `n < out.len()`.
    pub fn distinct(&mut self, n: usize, out: &mut [usize]) -> bool {
        let k = out.len();
        if n < k {
            return false;
        }
        let mut filled = 0;
        while filled < k {
            let c = self.below(n);
            if !out[..filled].contains(&c) {
                out[filled] = c;
                filled += 1;
            }
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_reference_stream() {
        // Vigna's reference implementation, seed 0: first outputs.
        let mut r = SplitMix64::new(0);
        assert_eq!(r.next_u64(), 0xE220_A839_7B1D_CDAF);
        assert_eq!(r.next_u64(), 0x6E78_9E6A_A1B9_65F4);
        assert_eq!(splitmix64(0), 0xE220_A839_7B1D_CDAF);
    }

    #[test]
    fn ranges_and_distinct_samples() {
        let mut r = SplitMix64::new(7);
        for _ in 0..1000 {
            let x = r.next_f64();
            assert!((0.0..1.0).contains(&x));
            assert!(r.below(5) < 5);
            assert!(r.normal().is_finite());
        }
        let mut out = [0; 4];
        assert!(r.distinct(10, &mut out));
        for (i, a) in out.iter().enumerate() {
            assert!(out[i + 1..].iter().all(|b| b != a));
        }
        assert!(!r.distinct(3, &mut out));
    }
}
