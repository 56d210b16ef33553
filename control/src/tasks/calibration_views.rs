//! Wrist-camera views of the calibration target for hand-eye (re)calibration (the drift
//! check's views are calib's `selfcal::drift::CHECK_MOTION`), and the arm motion through them.
//!
//! # Views
//! A look-at point `c` (the target's centre raised by [`ViewPattern::look_above_m`]) with the
//! face's outward normal `n` and two axes `e1 = n x z`, `e2 = n x e1` across the face. View
//! `i` puts the camera on a cone around the normal,
//! `eye_i = c + d_i (n cos t_i + (e1 cos a_i + e2 sin a_i) sin t_i)`, looking at `c` with the
//! image up towards `+z`, then rolls it by `r_i` about the optical axis. Tilts `t_i` sweep
//! `[tilt_min, tilt_max]` with a golden-ratio-like stride, azimuths `a_i` step by
//! [`ViewPattern::azimuth_step_deg`] (100 deg: consecutive views turn about axes spread all
//! around the normal), distances sweep `[distance_min, distance_max]`, rolls alternate within
//! +-`roll_max` (rotation about the normal). The relative rotations between views then have
//! well-spread axes, which AX=XB needs to fix both the rotation and the translation of the
//! mount (Tsai and Lenz 1989: the solution is unique for two motions with non-parallel axes;
//! the conditioning improves with the spread).
//!
//! # Motion
//! Each camera pose becomes a `tool0` goal through the camera mount the robot believes in
//! (`tool0_from_camera`), then an arm configuration by the closed-form IK nearest the previous
//! view; every segment is collision-checked ([`crate::motion::planner::plan_through`]).

use nalgebra::{Isometry3, Point3, UnitQuaternion, Vector3};
use robot::se3::world_from_camera_looking_at;

/// A pattern of views around a target (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewPattern {
    /// Number of views.
    pub views: usize,
    /// Smallest tilt from the normal (deg).
    pub tilt_min_deg: f64,
    /// Largest tilt from the normal (deg).
    pub tilt_max_deg: f64,
    /// Azimuth step between consecutive views (deg).
    pub azimuth_step_deg: f64,
    /// Nearest camera distance (m).
    pub distance_min_m: f64,
    /// Farthest camera distance (m).
    pub distance_max_m: f64,
    /// Largest roll about the optical axis (deg).
    pub roll_max_deg: f64,
    /// The look-at point above the target's centre (m).
    pub look_above_m: f64,
}

impl ViewPattern {
    /// The 18-view calibration motion (the `calib-18` scenario's pattern): tilts 8-22 deg,
    /// azimuth step 100 deg, distances 0.38-0.52 m, rolls within +-22 deg.
    pub const CALIBRATION_18: Self = Self {
        views: 18,
        tilt_min_deg: 8.0,
        tilt_max_deg: 22.0,
        azimuth_step_deg: 100.0,
        distance_min_m: 0.38,
        distance_max_m: 0.52,
        roll_max_deg: 22.0,
        look_above_m: 0.15,
    };

    /// The camera poses (`frame_from_camera`, OpenCV optical axes) around a target at `centre`
    /// with outward normal `normal`, in the frame of both. `None` for a zero or vertical
    /// normal.
    #[must_use]
    pub fn camera_poses(
        &self,
        centre: &Point3<f64>,
        normal: &Vector3<f64>,
    ) -> Option<Vec<Isometry3<f64>>> {
        let n = normal.try_normalize(1e-12)?;
        let e1 = n.cross(&Vector3::z()).try_normalize(1e-9)?;
        let e2 = n.cross(&e1);
        let target = centre + Vector3::new(0.0, 0.0, self.look_above_m);
        let mut poses = Vec::with_capacity(self.views);
        for i in 0..self.views {
            let fi = i as f64;
            let tilt = (self.tilt_min_deg
                + (self.tilt_max_deg - self.tilt_min_deg) * ((fi * 0.37) % 1.0))
                .to_radians();
            let azimuth = (self.azimuth_step_deg * fi).to_radians();
            let distance = self.distance_min_m
                + (self.distance_max_m - self.distance_min_m) * ((fi * 0.61) % 1.0);
            let roll = (self.roll_max_deg * (fi * 1.3).sin()).to_radians();
            let dir = n * tilt.cos() + (e1 * azimuth.cos() + e2 * azimuth.sin()) * tilt.sin();
            let eye = target + dir * distance;
            let look = world_from_camera_looking_at(&eye, &target, &Vector3::z())?;
            poses.push(look * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), roll));
        }
        Some(poses)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn views_look_at_the_target_from_the_documented_distances_and_tilts() {
        let centre = Point3::new(13.35, -1.3, 1.1);
        let normal = -Vector3::x();
        for p in [ViewPattern::CALIBRATION_18] {
            let poses = p.camera_poses(&centre, &normal).expect("views");
            assert_eq!(poses.len(), p.views);
            let target = centre + Vector3::new(0.0, 0.0, p.look_above_m);
            for pose in &poses {
                let eye = Point3::from(pose.translation.vector);
                let to_target = target - eye;
                let d = to_target.norm();
                assert!(d >= p.distance_min_m - 1e-9 && d <= p.distance_max_m + 1e-9);
                let z = pose.rotation * Vector3::z();
                assert!(
                    (z - to_target / d).norm() < 1e-9,
                    "optical axis at the target"
                );
                let tilt = (-to_target / d).dot(&normal).acos().to_degrees();
                assert!(tilt >= p.tilt_min_deg - 1e-6 && tilt <= p.tilt_max_deg + 1e-6);
            }
            // Consecutive views turn by a useful angle.
            for w in poses.windows(2) {
                let angle = w[0].rotation.angle_to(&w[1].rotation).to_degrees();
                assert!(angle > 5.0, "{angle} deg");
            }
        }
    }
}
