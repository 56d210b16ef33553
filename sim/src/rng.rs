//! Counter-based randomness: every random number of the world is a pure function of
//! `(seed, stream, index)` ([`rng::counter`]), one stream per physical process ([`streams`]).
//! No generator state is carried between calls, so the values do not depend on the order or
//! the thread in which they are drawn, nor on how the scheduler splits its steps.

pub use rng::counter::{key, normal, uniform, uniform_in};

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
    /// The wrist camera's intrinsic calibration error (the published `camera_info`).
    pub const WRIST_CALIBRATION: u64 = 12;
    /// The panoramic camera's intrinsic calibration error.
    pub const PANORAMIC_CALIBRATION: u64 = 13;
    /// The seeded site's geometry (`site.layout = "seeded"`).
    pub const SITE: u64 = 14;
    /// The crew's survey error (`crate::survey`).
    pub const SURVEY: u64 = 15;
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
