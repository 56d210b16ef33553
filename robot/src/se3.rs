//! Small SE(3) helpers shared by the kinematics and the TF buffer: planar poses, shortest-path
//! slerp and isometry interpolation.
//!
//! Interpolation of a rigid transform between two samples `a_from_b(t0)` and `a_from_b(t1)` at
//! the fraction `s in [0, 1]` is done per part, as tf2 does (`tf2::BufferCore`, `lerp` +
//! `slerp`):
//!
//! ```text
//! t(s) = (1 - s) t0 + s t1
//! q(s) = q0 (q0^-1 q1)^s          (shortest arc: q0^-1 q1 taken with w >= 0)
//! ```
//!
//! `(q0^-1 q1)^s` is evaluated as a rotation about the relative axis by `s` times the relative
//! angle, with the angle computed by `2 atan2(|v|, w)` (accurate for small and large angles,
//! unlike `acos(w)`). Degenerate case: identical rotations (|v| = 0) give `q0` exactly.

use nalgebra::{Isometry3, Translation3, Unit, UnitQuaternion, Vector3};

/// Pose of a body moving in the plane (x, y, yaw), as a 3D isometry: `Tz(0) Txy(x, y) Rz(yaw)`.
///
/// Used for `map_from_base_link` (the mobile base's odometry pose, ARCHITECTURE.md section 3).
#[must_use]
pub fn planar_pose(x_m: f64, y_m: f64, yaw_rad: f64) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::new(x_m, y_m, 0.0),
        UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw_rad),
    )
}

/// Spherical linear interpolation along the shortest arc: `q0 (q0^-1 q1)^s`.
///
/// `s = 0` returns `q0` and `s = 1` returns `q1` up to rounding (the same rotation, possibly as
/// the antipodal quaternion `-q1`). Never panics: the relative angle is computed with `atan2`,
/// and a zero relative rotation returns `q0`.
#[must_use]
pub fn slerp(q0: &UnitQuaternion<f64>, q1: &UnitQuaternion<f64>, s: f64) -> UnitQuaternion<f64> {
    let mut rel = (q0.inverse() * q1).into_inner();
    if rel.w < 0.0 {
        rel = -rel;
    }
    let v = rel.imag();
    let v_norm = v.norm();
    if v_norm == 0.0 {
        return *q0;
    }
    let angle_rad = 2.0 * v_norm.atan2(rel.w);
    let axis = Unit::new_unchecked(v / v_norm);
    q0 * UnitQuaternion::from_axis_angle(&axis, s * angle_rad)
}

/// Interpolates between two isometries: translation linearly, rotation by [`slerp`].
///
/// `s` is the fraction from `a` (`s = 0`) to `b` (`s = 1`); values outside `[0, 1]` extrapolate
/// (callers that must not extrapolate check the range first, as the TF buffer does).
#[must_use]
pub fn interpolate(a: &Isometry3<f64>, b: &Isometry3<f64>, s: f64) -> Isometry3<f64> {
    let t = a.translation.vector.lerp(&b.translation.vector, s);
    Isometry3::from_parts(Translation3::from(t), slerp(&a.rotation, &b.rotation, s))
}

/// Angle of the relative rotation between two orientations, in `[0, pi]` rad, computed as
/// `2 atan2(|v|, |w|)` of `q0^-1 q1` (accurate near 0 and pi).
#[must_use]
pub fn rotation_angle_between_rad(q0: &UnitQuaternion<f64>, q1: &UnitQuaternion<f64>) -> f64 {
    let rel = (q0.inverse() * q1).into_inner();
    2.0 * rel.imag().norm().atan2(rel.w.abs())
}

/// Wraps an angle into `(-pi, pi]`.
#[must_use]
pub fn wrap_to_pi(angle_rad: f64) -> f64 {
    use std::f64::consts::{PI, TAU};
    let mut a = angle_rad.rem_euclid(TAU);
    if a > PI {
        a -= TAU;
    }
    a
}

/// `world_from_camera` of a camera at `eye` looking at `target` with the image's up side
/// towards `up` (OpenCV optical axes: z = forward, x = forward x up (right), y = z x x
/// (down)). `None` if `eye == target` or the view direction is parallel to `up`.
#[must_use]
pub fn world_from_camera_looking_at(
    eye: &nalgebra::Point3<f64>,
    target: &nalgebra::Point3<f64>,
    up: &nalgebra::Vector3<f64>,
) -> Option<Isometry3<f64>> {
    let z = (target - eye).try_normalize(1e-12)?;
    let x = z.cross(up).try_normalize(1e-12)?;
    let y = z.cross(&x);
    let r = nalgebra::Rotation3::from_matrix_unchecked(nalgebra::Matrix3::from_columns(&[x, y, z]));
    Some(Isometry3::from_parts(
        nalgebra::Translation3::from(eye.coords),
        UnitQuaternion::from_rotation_matrix(&r),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use proptest::prelude::*;
    use std::f64::consts::PI;

    fn iso_strategy() -> impl Strategy<Value = Isometry3<f64>> {
        (
            prop::array::uniform3(-5.0f64..5.0),
            prop::array::uniform3(-1.0f64..1.0),
            0.0f64..PI,
        )
            .prop_map(|(t, axis, angle)| {
                let axis = Vector3::from(axis);
                let rot = Unit::try_new(axis, 1e-6).map_or_else(UnitQuaternion::identity, |a| {
                    UnitQuaternion::from_axis_angle(&a, angle)
                });
                Isometry3::from_parts(Translation3::from(Vector3::from(t)), rot)
            })
    }

    fn assert_iso_eq(a: &Isometry3<f64>, b: &Isometry3<f64>, tol: f64) {
        let dt = (a.translation.vector - b.translation.vector).norm();
        let dr = rotation_angle_between_rad(&a.rotation, &b.rotation);
        assert!(
            dt <= tol && dr <= tol,
            "dt = {dt:e} m, dr = {dr:e} rad\n{a}\n{b}"
        );
    }

    proptest! {
        #[test]
        fn composition_is_associative(a in iso_strategy(), b in iso_strategy(), c in iso_strategy()) {
            assert_iso_eq(&((a * b) * c), &(a * (b * c)), 1e-12);
        }

        #[test]
        fn inverse_composes_to_identity(a in iso_strategy(), b in iso_strategy()) {
            assert_iso_eq(&(a * a.inverse()), &Isometry3::identity(), 1e-12);
            assert_iso_eq(&((a * b).inverse()), &(b.inverse() * a.inverse()), 1e-12);
            // A point mapped by a_from_b then back by its inverse is unchanged.
            let p = nalgebra::Point3::new(0.3, -1.2, 2.5);
            let back = a.inverse_transform_point(&a.transform_point(&p));
            prop_assert!((back - p).norm() < 1e-12);
        }

        #[test]
        fn interpolation_endpoints_are_exact(a in iso_strategy(), b in iso_strategy()) {
            assert_iso_eq(&interpolate(&a, &b, 0.0), &a, 1e-15);
            assert_iso_eq(&interpolate(&a, &b, 1.0), &b, 1e-12);
        }

        #[test]
        fn midpoint_halves_the_rotation(a in iso_strategy(), b in iso_strategy()) {
            let total = rotation_angle_between_rad(&a.rotation, &b.rotation);
            let mid = interpolate(&a, &b, 0.5);
            let first = rotation_angle_between_rad(&a.rotation, &mid.rotation);
            let second = rotation_angle_between_rad(&mid.rotation, &b.rotation);
            prop_assert!((first - 0.5 * total).abs() < 1e-12, "{first} vs {total}");
            prop_assert!((second - 0.5 * total).abs() < 1e-12, "{second} vs {total}");
            let t_mid = 0.5 * (a.translation.vector + b.translation.vector);
            prop_assert!((mid.translation.vector - t_mid).norm() < 1e-12);
        }

        #[test]
        fn interpolation_is_monotone(a in iso_strategy(), b in iso_strategy(), s1 in 0.0f64..1.0, s2 in 0.0f64..1.0) {
            let (lo, hi) = if s1 <= s2 { (s1, s2) } else { (s2, s1) };
            let total = rotation_angle_between_rad(&a.rotation, &b.rotation);
            let angle_lo = rotation_angle_between_rad(&a.rotation, &interpolate(&a, &b, lo).rotation);
            let angle_hi = rotation_angle_between_rad(&a.rotation, &interpolate(&a, &b, hi).rotation);
            // The angle travelled grows linearly with s (constant angular velocity).
            prop_assert!(angle_lo <= angle_hi + 1e-12);
            prop_assert!((angle_hi - hi * total).abs() < 1e-9);
            let d_lo = (interpolate(&a, &b, lo).translation.vector - a.translation.vector).norm();
            let d_hi = (interpolate(&a, &b, hi).translation.vector - a.translation.vector).norm();
            prop_assert!(d_lo <= d_hi + 1e-12);
        }
    }

    #[test]
    fn slerp_takes_the_shortest_arc_for_antipodal_input() {
        let q0 = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.2);
        let q1 = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.6);
        let q1_neg = UnitQuaternion::new_unchecked(-q1.into_inner());
        let mid = slerp(&q0, &q1_neg, 0.5);
        assert_relative_eq!(mid.angle(), 0.4, epsilon = 1e-14);
    }

    #[test]
    fn wrap_to_pi_range() {
        assert_relative_eq!(wrap_to_pi(3.0 * PI), PI, epsilon = 1e-15);
        assert_relative_eq!(wrap_to_pi(-PI), PI, epsilon = 1e-15);
        assert_relative_eq!(wrap_to_pi(-0.5), -0.5, epsilon = 1e-15);
        assert_relative_eq!(wrap_to_pi(2.0 * PI + 0.25), 0.25, epsilon = 1e-14);
    }
}
