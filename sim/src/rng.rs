//! Counter-based randomness: every random number of the world is a pure function of
//! `(seed, stream, index)`.
//!
//! `key = splitmix64(splitmix64(seed ^ splitmix64(stream)) ^ index)` (SplitMix64 finaliser,
//! Steele, Lea & Flood, OOPSLA 2014); uniforms take the top 53 bits, normals use Box-Muller
//! on two derived keys. No generator state is carried between calls, so the values do not
//! depend on the order or the thread in which they are drawn, nor on how the scheduler
//! splits its steps.

/// SplitMix64 finaliser of `x + golden gamma`.
#[inline]
#[must_use]
pub fn splitmix64(x: u64) -> u64 {
    let mut z = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// 64 random bits for `(seed, stream, index)`.
#[inline]
#[must_use]
pub fn key(seed: u64, stream: u64, index: u64) -> u64 {
    splitmix64(splitmix64(seed ^ splitmix64(stream)) ^ index)
}

/// Uniform in `[0, 1)`.
#[inline]
#[must_use]
pub fn uniform(seed: u64, stream: u64, index: u64) -> f64 {
    (key(seed, stream, index) >> 11) as f64 / (1u64 << 53) as f64
}

/// Uniform in `[lo, hi)`.
#[inline]
#[must_use]
pub fn uniform_in(seed: u64, stream: u64, index: u64, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * uniform(seed, stream, index)
}

/// Standard normal (Box-Muller on two derived uniforms).
#[inline]
#[must_use]
pub fn normal(seed: u64, stream: u64, index: u64) -> f64 {
    let k = key(seed, stream, index);
    let u1 = ((splitmix64(k) >> 11) as f64 + 1.0) / ((1u64 << 53) as f64 + 1.0);
    let u2 = (splitmix64(k ^ 0xD1B5_4A32_D192_ED03) >> 11) as f64 / (1u64 << 53) as f64;
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// Random streams of the world (one per physical process).
pub mod streams {
    /// Arm DH perturbation.
    pub const ARM_PERTURBATION: u64 = 1;
    /// Arm encoder noise.
    pub const ARM_ENCODER: u64 = 2;
    /// Lift encoder noise.
    pub const LIFT_ENCODER: u64 = 3;
    /// Clamp encoder noise.
    pub const CLAMP_ENCODER: u64 = 4;
    /// Base odometry drift.
    pub const ODOMETRY: u64 = 5;
    /// Wind turbulence.
    pub const WIND: u64 = 6;
    /// Anemometer noise.
    pub const ANEMOMETER: u64 = 7;
    /// Lux meter noise.
    pub const LUX_METER: u64 = 8;
    /// Camera-mount bump (time, size, axes).
    pub const BUMP: u64 = 9;
    /// Wrist camera render seeds.
    pub const WRIST_CAMERA: u64 = 10;
    /// Panoramic camera render seeds.
    pub const PANORAMIC_CAMERA: u64 = 11;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normals_have_unit_variance_and_streams_differ() {
        let n = 20_000;
        let xs: Vec<f64> = (0..n).map(|i| normal(7, 3, i)).collect();
        let mean = xs.iter().sum::<f64>() / n as f64;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
        assert!(mean.abs() < 0.03, "{mean}");
        assert!((var - 1.0).abs() < 0.04, "{var}");
        assert_ne!(key(7, 3, 0), key(7, 4, 0));
        assert_ne!(key(7, 3, 0), key(8, 3, 0));
        assert_eq!(key(7, 3, 5), key(7, 3, 5));
        assert!((0..1000).all(|i| (0.0..1.0).contains(&uniform(1, 1, i))));
    }
}
