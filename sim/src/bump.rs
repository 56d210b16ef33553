//! The camera-mount bump: at one instant the true `tool0_from_camera` jumps by a rotation of
//! `rot_deg` about a seeded axis and a translation of `trans_mm` along a seeded direction
//! (both axes uniform on the sphere, in `tool0` coordinates). Unset sizes are drawn from the
//! ARCHITECTURE.md section 6 distribution, uniform in 1-3 deg and 3-10 mm; an unset time uniformly in
//! `[0.2, 0.8]` of the scenario duration.
//!
//! `tool0_from_camera_after = (t_before + dt, R_delta R_before)`: the camera origin moves by
//! exactly `trans_mm` and its orientation by exactly `rot_deg`.

use msgs::RobotTime;
use nalgebra::{Isometry3, Translation3, Unit, UnitQuaternion, Vector3};

use crate::SimError;
use crate::config::BumpConfig;
use crate::rng::{self, streams};

/// Smallest seeded rotation (deg).
pub const BUMP_ROT_MIN_DEG: f64 = 1.0;
/// Largest seeded rotation (deg).
pub const BUMP_ROT_MAX_DEG: f64 = 3.0;
/// Smallest seeded translation (mm).
pub const BUMP_TRANS_MIN_MM: f64 = 3.0;
/// Largest seeded translation (mm).
pub const BUMP_TRANS_MAX_MM: f64 = 10.0;

/// A resolved bump.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bump {
    /// When it happens.
    pub time: RobotTime,
    /// Rotation (deg).
    pub rot_deg: f64,
    /// Translation (mm).
    pub trans_mm: f64,
    /// Rotation axis (tool0).
    pub axis: Unit<Vector3<f64>>,
    /// Translation direction (tool0).
    pub direction: Unit<Vector3<f64>>,
}

fn unit_on_sphere(seed: u64, index: u64) -> Unit<Vector3<f64>> {
    let z = rng::uniform_in(seed, streams::BUMP, index, -1.0, 1.0);
    let phi = rng::uniform_in(seed, streams::BUMP, index + 1, 0.0, std::f64::consts::TAU);
    let r = (1.0 - z * z).max(0.0).sqrt();
    Unit::new_normalize(Vector3::new(r * phi.cos(), r * phi.sin(), z))
}

impl Bump {
    /// Resolves `config` with the seed and the scenario duration.
    ///
    /// # Errors
    /// [`SimError::Config`] if the time does not fit the robot clock.
    pub fn resolve(config: &BumpConfig, seed: u64, duration_s: f64) -> Result<Self, SimError> {
        let time_s = config
            .time_s
            .unwrap_or_else(|| duration_s * rng::uniform_in(seed, streams::BUMP, 0, 0.2, 0.8));
        let time = RobotTime::from_secs_f64(time_s).map_err(|e| SimError::Config {
            key: "bump.time_s".to_owned(),
            reason: e.to_string(),
        })?;
        Ok(Self {
            time,
            rot_deg: config.rot_deg.unwrap_or_else(|| {
                rng::uniform_in(seed, streams::BUMP, 1, BUMP_ROT_MIN_DEG, BUMP_ROT_MAX_DEG)
            }),
            trans_mm: config.trans_mm.unwrap_or_else(|| {
                rng::uniform_in(seed, streams::BUMP, 2, BUMP_TRANS_MIN_MM, BUMP_TRANS_MAX_MM)
            }),
            axis: unit_on_sphere(seed, 10),
            direction: unit_on_sphere(seed, 20),
        })
    }

    /// The mount after the bump.
    #[must_use]
    pub fn apply(&self, tool0_from_camera: &Isometry3<f64>) -> Isometry3<f64> {
        let r = UnitQuaternion::from_axis_angle(&self.axis, self.rot_deg.to_radians());
        let t = tool0_from_camera.translation.vector
            + self.direction.into_inner() * (self.trans_mm * 1e-3);
        Isometry3::from_parts(Translation3::from(t), r * tool0_from_camera.rotation)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seeded_sizes_follow_the_design_distribution() -> Result<(), SimError> {
        for seed in 0..200 {
            let b = Bump::resolve(
                &BumpConfig {
                    time_s: None,
                    rot_deg: None,
                    trans_mm: None,
                },
                seed,
                100.0,
            )?;
            assert!((BUMP_ROT_MIN_DEG..=BUMP_ROT_MAX_DEG).contains(&b.rot_deg));
            assert!((BUMP_TRANS_MIN_MM..=BUMP_TRANS_MAX_MM).contains(&b.trans_mm));
            assert!((20.0..=80.0).contains(&b.time.as_secs_f64()));
        }
        Ok(())
    }
}
