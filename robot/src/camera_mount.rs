//! The wrist camera's nominal mount: `tool0_from_camera`, the TF edge
//! `tool0` -> `camera_color_optical_frame` (ARCHITECTURE.md section 3).
//!
//! The nominal mount is the design (CAD) value of the bracket that holds the camera on the
//! flange. It belongs to the robot model: the calibration stage publishes it on `/tf` until a
//! hand-eye calibration is accepted, and the simulator uses it as the default *true* mount
//! (a scenario may move it, and a camera-mount bump moves it at run time).
//!
//! # Conventions
//!
//! `tool0_from_camera` maps points in camera coordinates (OpenCV optical axes: x right, y
//! down, z forward) to flange coordinates. The rotation is given as roll, pitch, yaw about the
//! fixed axes x, y, z (degrees, applied in that order: `R = Rz(yaw) Ry(pitch) Rx(roll)`, as
//! nalgebra's `UnitQuaternion::from_euler_angles` and URDF's `rpy`).

use nalgebra::{Isometry3, Translation3, UnitQuaternion};

use crate::names::{CAMERA_COLOR_OPTICAL_FRAME, TOOL0};

/// Parent frame of the camera edge.
pub const MOUNT_PARENT_FRAME: &str = TOOL0;
/// Child frame of the camera edge.
pub const MOUNT_CHILD_FRAME: &str = CAMERA_COLOR_OPTICAL_FRAME;
/// Nominal mount translation `tool0_from_camera` (m): the camera sits 60 mm beside, 35 mm
/// below and 90 mm in front of the flange centre.
pub const NOMINAL_MOUNT_XYZ_M: [f64; 3] = [0.06, -0.035, 0.09];
/// Nominal mount rotation, roll-pitch-yaw about fixed x, y, z (deg). Deliberately
/// asymmetric, so an inverted transform is never close to the right one.
pub const NOMINAL_MOUNT_RPY_DEG: [f64; 3] = [2.0, -5.0, 90.0];

/// `tool0_from_camera` from a translation (m) and roll-pitch-yaw (deg, fixed axes x, y, z).
#[must_use]
pub fn mount_from_xyz_rpy(xyz_m: [f64; 3], rpy_deg: [f64; 3]) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::new(xyz_m[0], xyz_m[1], xyz_m[2]),
        UnitQuaternion::from_euler_angles(
            rpy_deg[0].to_radians(),
            rpy_deg[1].to_radians(),
            rpy_deg[2].to_radians(),
        ),
    )
}

/// The nominal `tool0_from_camera` ([`NOMINAL_MOUNT_XYZ_M`], [`NOMINAL_MOUNT_RPY_DEG`]).
#[must_use]
pub fn nominal_tool0_from_camera() -> Isometry3<f64> {
    mount_from_xyz_rpy(NOMINAL_MOUNT_XYZ_M, NOMINAL_MOUNT_RPY_DEG)
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use nalgebra::{Point3, Vector3};

    #[test]
    fn rpy_is_fixed_axes_xyz() {
        // 90 deg yaw only: camera x maps to tool0 y.
        let m = mount_from_xyz_rpy([0.0; 3], [0.0, 0.0, 90.0]);
        let v = m * Vector3::x();
        assert_relative_eq!(v, Vector3::y(), epsilon = 1e-12);
        // R = Rz Ry Rx: roll is applied first.
        let m = mount_from_xyz_rpy([0.0; 3], [90.0, 0.0, 90.0]);
        let v = m * Vector3::y();
        // Rx(90) y = z; Rz(90) z = z.
        assert_relative_eq!(v, Vector3::z(), epsilon = 1e-12);
    }

    #[test]
    fn nominal_mount_maps_the_camera_origin_to_its_translation() {
        let m = nominal_tool0_from_camera();
        let p = m * Point3::origin();
        assert_relative_eq!(
            p.coords,
            Vector3::from(NOMINAL_MOUNT_XYZ_M),
            epsilon = 1e-15
        );
        // Asymmetric: the inverse moves the origin somewhere else.
        let q = m.inverse() * Point3::origin();
        assert!((q.coords - p.coords).norm() > 0.05);
        assert_eq!(MOUNT_PARENT_FRAME, "tool0");
        assert_eq!(MOUNT_CHILD_FRAME, "camera_color_optical_frame");
    }
}
