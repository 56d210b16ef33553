//! The AUBO i10 arm: its standard DH table (ARCHITECTURE.md section 6) and joint limits.
//!
//! | i | theta offset | d (m) | a (m) | alpha |
//! |---|---|---|---|---|
//! | 1 | 0 | 0.1632 | 0 | pi/2 |
//! | 2 | pi/2 | 0 | 0.647 | pi |
//! | 3 | 0 | 0 | 0.6005 | pi |
//! | 4 | -pi/2 | 0.2013 | 0 | -pi/2 |
//! | 5 | 0 | 0.1025 | 0 | pi/2 |
//! | 6 | 0 | 0.094 | 0 | 0 |
//!
//! At q = 0 the arm stands straight up: the flange is at (0, -0.2953, 1.5132) m in
//! `arm_base_link` (x = 0, y = -(d4 + d6), z = d1 + a2 + a3 + d5) with its z axis along
//! `-y`; the vendor's reach figure is a2 + a3 + d5 = 1.35 m.
//!
//! Limits (vendor data sheet): every joint +-175 deg, speed 3.14 rad/s (joint 3: 2.57 rad/s).
//! The vendor does not publish acceleration limits; we use **5 rad/s^2 for joints 1-3** (the
//! big reducers carrying the arm and a 10 kg payload reach full speed in ~0.6 s) and
//! **8 rad/s^2 for the wrist joints 4-6** (small inertia). These are conservative planning
//! limits, not the hardware's peaks.

use crate::dh::{DhRow, DhTable};
use crate::limits::JointLimit;
use std::f64::consts::FRAC_PI_2;
use std::f64::consts::PI;

/// The AUBO i10 DH table of ARCHITECTURE.md section 6 (metres, radians).
pub const AUBO_I10_DH: DhTable = DhTable {
    rows: [
        DhRow {
            theta_offset_rad: 0.0,
            d_m: 0.1632,
            a_m: 0.0,
            alpha_rad: FRAC_PI_2,
        },
        DhRow {
            theta_offset_rad: FRAC_PI_2,
            d_m: 0.0,
            a_m: 0.647,
            alpha_rad: PI,
        },
        DhRow {
            theta_offset_rad: 0.0,
            d_m: 0.0,
            a_m: 0.6005,
            alpha_rad: PI,
        },
        DhRow {
            theta_offset_rad: -FRAC_PI_2,
            d_m: 0.2013,
            a_m: 0.0,
            alpha_rad: -FRAC_PI_2,
        },
        DhRow {
            theta_offset_rad: 0.0,
            d_m: 0.1025,
            a_m: 0.0,
            alpha_rad: FRAC_PI_2,
        },
        DhRow {
            theta_offset_rad: 0.0,
            d_m: 0.094,
            a_m: 0.0,
            alpha_rad: 0.0,
        },
    ],
};

/// Joint position limit of every AUBO i10 joint: +-175 deg.
pub const AUBO_I10_POSITION_LIMIT_RAD: f64 = 175.0 * PI / 180.0;
/// Maximum speed of joints 1, 2, 4, 5, 6 (rad/s).
#[allow(clippy::approx_constant)] // the vendor's figure 3.14 rad/s, not pi
pub const AUBO_I10_SPEED_MAX_RAD_S: f64 = 3.14;
/// Maximum speed of joint 3 (rad/s).
pub const AUBO_I10_J3_SPEED_MAX_RAD_S: f64 = 2.57;
/// Planning acceleration limit of joints 1-3 (rad/s^2), chosen (see the module docs).
pub const AUBO_I10_BASE_ACCEL_MAX_RAD_S2: f64 = 5.0;
/// Planning acceleration limit of joints 4-6 (rad/s^2), chosen (see the module docs).
pub const AUBO_I10_WRIST_ACCEL_MAX_RAD_S2: f64 = 8.0;
/// Rated payload (kg), vendor data.
pub const AUBO_I10_PAYLOAD_KG: f64 = 10.0;

/// The vendor's reach figure, a2 + a3 + d5 (m).
#[must_use]
pub fn aubo_i10_reach_m() -> f64 {
    let r = &AUBO_I10_DH.rows;
    r[1].a_m + r[2].a_m + r[4].d_m
}

/// Limits of the six AUBO i10 joints (index 0 = joint 1).
#[must_use]
pub fn aubo_i10_limits() -> [JointLimit; 6] {
    let joint = |velocity_max: f64, acceleration_max: f64| JointLimit {
        position_min: -AUBO_I10_POSITION_LIMIT_RAD,
        position_max: AUBO_I10_POSITION_LIMIT_RAD,
        velocity_max,
        acceleration_max,
    };
    [
        joint(AUBO_I10_SPEED_MAX_RAD_S, AUBO_I10_BASE_ACCEL_MAX_RAD_S2),
        joint(AUBO_I10_SPEED_MAX_RAD_S, AUBO_I10_BASE_ACCEL_MAX_RAD_S2),
        joint(AUBO_I10_J3_SPEED_MAX_RAD_S, AUBO_I10_BASE_ACCEL_MAX_RAD_S2),
        joint(AUBO_I10_SPEED_MAX_RAD_S, AUBO_I10_WRIST_ACCEL_MAX_RAD_S2),
        joint(AUBO_I10_SPEED_MAX_RAD_S, AUBO_I10_WRIST_ACCEL_MAX_RAD_S2),
        joint(AUBO_I10_SPEED_MAX_RAD_S, AUBO_I10_WRIST_ACCEL_MAX_RAD_S2),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use nalgebra::Vector3;

    #[test]
    fn zero_pose_flange_position_and_reach() {
        let flange = AUBO_I10_DH.forward(&[0.0; 6]);
        let p = flange.translation.vector;
        assert_relative_eq!(p, Vector3::new(0.0, -0.2953, 1.5132), epsilon = 1e-12);
        assert_relative_eq!(aubo_i10_reach_m(), 1.35, epsilon = 1e-12);
        // Flange z axis points along -y at the zero pose.
        let z = flange.rotation * Vector3::z();
        assert_relative_eq!(z, -Vector3::y(), epsilon = 1e-12);
    }

    #[test]
    fn limits_are_the_vendor_figures() {
        let l = aubo_i10_limits();
        assert_relative_eq!(l[0].position_max.to_degrees(), 175.0, epsilon = 1e-12);
        assert_relative_eq!(l[2].velocity_max, 2.57);
        assert!(
            l.iter()
                .enumerate()
                .all(|(i, j)| i == 2 || j.velocity_max == AUBO_I10_SPEED_MAX_RAD_S)
        );
    }
}
