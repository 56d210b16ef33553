//! A calibration carried from one run to the next: the self-calibration a recording's
//! calibration stage accepted, as the `calibration.mount_*` parameters of the next run
//! ([`super::stage::CalibrationStageConfig::from_params`]).
//!
//! Every run starts from the camera edge its configuration gives, the robot model's nominal
//! mount by default. A mount that was knocked and then recalibrated stays where the knock
//! put it; unless the calibration is carried over, the next run's drift check finds the same
//! drift against the nominal mount and recalibrates again (18 views, about a minute).
//!
//! [`AcceptedFinder`] reads a run's messages in log order and keeps the last accepted
//! result: a `/calibration/hand_eye` whose `tool0_from_camera` then became the camera edge
//! `tool0 -> camera_color_optical_frame` on `/tf`. A result above the acceptance limits is
//! published too, but never becomes the edge, so it is never carried.
//!
//! The uncertainty carried is per axis: `/calibration/hand_eye` reports the square root of
//! the covariance block's trace (the three axes together), and the carried 1-sigma per axis
//! is that over `sqrt(3)`, the share of each axis when the three are alike.

use nalgebra::Isometry3;

use msgs::Msg;
use msgs::rodlog_msgs::HandEyeCalibration;
use msgs::topics;
use robot::camera_mount::{MOUNT_CHILD_FRAME, MOUNT_PARENT_FRAME};
use robot::conversions::isometry_from_msg;

/// Largest difference between a result and the camera edge for the edge to be that result
/// (deg, m): the stage publishes the very same numbers, so only rounding separates them.
pub const SAME_EDGE: (f64, f64) = (1e-6, 1e-9);

/// A self-calibration the calibration stage accepted (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct AcceptedCalibration {
    /// Log time of its `/calibration/hand_eye` (ns).
    pub log_time_ns: u64,
    /// `tool0_from_camera`.
    pub tool0_from_camera: Isometry3<f64>,
    /// The message itself (method, mode, views, residuals, sigmas).
    pub message: HandEyeCalibration,
}

impl AcceptedCalibration {
    /// The 1-sigma per axis `(deg, mm)` (module docs), or `None` when the message's
    /// uncertainty is not a positive finite figure (a result without one).
    #[must_use]
    pub fn sigma_per_axis(&self) -> Option<(f64, f64)> {
        let (rot, trans) = (self.message.sigma_rot_deg, self.message.sigma_trans_mm);
        (rot.is_finite() && trans.is_finite() && rot > 0.0 && trans > 0.0)
            .then(|| (rot / 3f64.sqrt(), trans / 3f64.sqrt()))
    }

    /// The next run's parameters, as TOML lines under a scenario's `[parameters]` (each also
    /// works as `--set KEY=VALUE`): `calibration.mount_xyz_m`, `calibration.mount_rpy_deg`
    /// (roll-pitch-yaw about the fixed x, y, z axes, as
    /// [`robot::camera_mount::mount_from_xyz_rpy`] reads them) and, when the result has an
    /// uncertainty, `calibration.mount_sigma_rot_deg` and `calibration.mount_sigma_trans_mm`.
    /// Numbers are written in full (shortest round-trip form).
    #[must_use]
    pub fn parameters_toml(&self) -> String {
        let t = self.tool0_from_camera.translation.vector;
        let (roll, pitch, yaw) = self.tool0_from_camera.rotation.euler_angles();
        let mut lines = vec![
            format!(
                "calibration.mount_xyz_m = [{:?}, {:?}, {:?}]",
                t.x, t.y, t.z
            ),
            format!(
                "calibration.mount_rpy_deg = [{:?}, {:?}, {:?}]",
                roll.to_degrees(),
                pitch.to_degrees(),
                yaw.to_degrees()
            ),
        ];
        if let Some((rot, trans)) = self.sigma_per_axis() {
            lines.push(format!("calibration.mount_sigma_rot_deg = {rot:?}"));
            lines.push(format!("calibration.mount_sigma_trans_mm = {trans:?}"));
        }
        lines.join("\n") + "\n"
    }
}

/// Finds the last accepted self-calibration in a message stream (module docs).
#[derive(Debug, Clone, Default)]
pub struct AcceptedFinder {
    /// The last result not yet seen as the camera edge.
    candidate: Option<AcceptedCalibration>,
    accepted: Option<AcceptedCalibration>,
    /// Results read, accepted or not.
    results: usize,
}

impl AcceptedFinder {
    /// A finder that has read nothing.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Topics it reads.
    pub const TOPICS: [&'static str; 2] = [topics::CALIBRATION_HAND_EYE, topics::TF];

    /// Reads one message; other topics and malformed transforms are ignored.
    pub fn feed(&mut self, log_time_ns: u64, topic: &str, msg: &Msg) {
        match (topic, msg) {
            (topics::CALIBRATION_HAND_EYE, Msg::HandEyeCalibration(h)) => {
                self.results += 1;
                self.candidate =
                    isometry_from_msg(&h.tool0_from_camera)
                        .ok()
                        .map(|x| AcceptedCalibration {
                            log_time_ns,
                            tool0_from_camera: x,
                            message: h.clone(),
                        });
            }
            (topics::TF, Msg::TfMessage(tf)) => {
                let Some(candidate) = &self.candidate else {
                    return;
                };
                let became_the_edge = tf.transforms.iter().any(|e| {
                    e.header.frame_id == MOUNT_PARENT_FRAME
                        && e.child_frame_id == MOUNT_CHILD_FRAME
                        && isometry_from_msg(&e.transform)
                            .is_ok_and(|x| same_pose(&x, &candidate.tool0_from_camera))
                });
                if became_the_edge {
                    self.accepted = self.candidate.take();
                }
            }
            _ => {}
        }
    }

    /// `/calibration/hand_eye` results read, accepted or not.
    #[must_use]
    pub fn results(&self) -> usize {
        self.results
    }

    /// The last accepted calibration, if any.
    #[must_use]
    pub fn finish(self) -> Option<AcceptedCalibration> {
        self.accepted
    }
}

fn same_pose(a: &Isometry3<f64>, b: &Isometry3<f64>) -> bool {
    let (rot_deg, trans_m) = crate::handeye::pose_error(a, b);
    rot_deg <= SAME_EDGE.0 && trans_m <= SAME_EDGE.1
}

#[cfg(test)]
mod tests {
    use super::*;
    use msgs::tf2_msgs::TfMessage;
    use nalgebra::{Translation3, UnitQuaternion};
    use robot::conversions::{transform_msg, transform_stamped};

    fn x(mm: f64) -> Isometry3<f64> {
        Isometry3::from_parts(
            Translation3::new(0.06 + mm * 1e-3, -0.04, 0.09),
            UnitQuaternion::from_euler_angles(0.01, -0.02, 1.57),
        )
    }

    fn result(x: &Isometry3<f64>) -> Msg {
        Msg::HandEyeCalibration(HandEyeCalibration {
            tool0_from_camera: transform_msg(x),
            sigma_rot_deg: 0.0842,
            sigma_trans_mm: 0.773,
            ..HandEyeCalibration::default()
        })
    }

    fn edge(x: &Isometry3<f64>) -> Msg {
        Msg::TfMessage(TfMessage {
            transforms: vec![transform_stamped(
                MOUNT_PARENT_FRAME,
                MOUNT_CHILD_FRAME,
                msgs::builtin_interfaces::Time::default(),
                x,
            )],
        })
    }

    #[test]
    fn only_a_result_that_became_the_camera_edge_is_carried() {
        let mut f = AcceptedFinder::new();
        f.feed(1, topics::TF, &edge(&x(0.0)));
        f.feed(2, topics::CALIBRATION_HAND_EYE, &result(&x(3.0)));
        f.feed(3, topics::TF, &edge(&x(3.0)));
        // A later result above the limits: published, never the edge.
        f.feed(4, topics::CALIBRATION_HAND_EYE, &result(&x(9.0)));
        f.feed(5, topics::TF, &edge(&x(3.0)));
        assert_eq!(f.results(), 2);
        let a = f.finish().expect("the first result was accepted");
        assert_eq!(a.log_time_ns, 2);
        assert!(same_pose(&a.tool0_from_camera, &x(3.0)));

        let mut none = AcceptedFinder::new();
        none.feed(1, topics::CALIBRATION_HAND_EYE, &result(&x(3.0)));
        none.feed(2, topics::TF, &edge(&x(0.0)));
        assert_eq!(none.finish(), None);
    }

    #[test]
    fn the_parameters_read_back_as_the_same_mount_and_a_per_axis_sigma() {
        let mut f = AcceptedFinder::new();
        f.feed(2, topics::CALIBRATION_HAND_EYE, &result(&x(3.0)));
        f.feed(3, topics::TF, &edge(&x(3.0)));
        let a = f.finish().expect("accepted");
        // Each line as `--set KEY=VALUE`, read by the stage's own parameter reader.
        let mut params = scenario::Params::default();
        for line in a.parameters_toml().lines() {
            params
                .set_from_arg(&line.replacen(" = ", "=", 1))
                .expect("a key=value line");
        }
        let mut r = scenario::Reader::new(&params);
        let c = crate::selfcal::CalibrationStageConfig::from_params(&mut r, 0).expect("valid");
        assert!(
            same_pose(&c.nominal_tool0_from_camera, &x(3.0)),
            "{:?}",
            c.nominal_tool0_from_camera
        );
        let (rot, trans) = c.mount_sigma.expect("carried sigma");
        assert!((rot * 3f64.sqrt() - 0.0842).abs() < 1e-12, "{rot}");
        assert!((trans * 3f64.sqrt() - 0.773).abs() < 1e-12, "{trans}");
    }

    #[test]
    fn a_carried_mount_comes_whole_or_not_at_all() {
        let read = |sets: &[&str]| {
            let mut params = scenario::Params::default();
            for s in sets {
                params.set_from_arg(s).expect("key=value");
            }
            let mut r = scenario::Reader::new(&params);
            crate::selfcal::CalibrationStageConfig::from_params(&mut r, 0)
        };
        let nominal = read(&[]).expect("defaults");
        assert_eq!(
            nominal.nominal_tool0_from_camera,
            robot::camera_mount::nominal_tool0_from_camera()
        );
        assert_eq!(nominal.mount_sigma, None);
        let half = read(&["calibration.mount_xyz_m=[0.06, -0.04, 0.09]"])
            .expect_err("a translation without its rotation");
        assert!(
            half.to_string().contains("calibration.mount_rpy_deg"),
            "{half}"
        );
        let sigma_alone = read(&[
            "calibration.mount_sigma_rot_deg=0.05",
            "calibration.mount_sigma_trans_mm=0.4",
        ])
        .expect_err("a sigma without the mount it belongs to");
        assert!(
            sigma_alone.to_string().contains("carried mount"),
            "{sigma_alone}"
        );
        let one_sigma = read(&[
            "calibration.mount_xyz_m=[0.06, -0.04, 0.09]",
            "calibration.mount_rpy_deg=[0.5, -1.1, 90.0]",
            "calibration.mount_sigma_rot_deg=0.05",
        ])
        .expect_err("half a sigma");
        assert!(
            one_sigma.to_string().contains("both figures"),
            "{one_sigma}"
        );
    }
}
