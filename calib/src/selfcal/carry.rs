//! A calibration carried from one run to the next: the camera edge a recording's calibration
//! stage ended with, the self-calibration that made it and the drift check reference taken
//! with it, as the `calibration.mount_*` and `calibration.reference_*` parameters of the next
//! run ([`super::stage::CalibrationStageConfig::from_params`]).
//!
//! Every run starts from the camera edge its configuration gives, the robot model's nominal
//! mount by default. A mount that was knocked and then recalibrated stays where the knock
//! put it; unless the calibration is carried over, the next run's drift check finds the same
//! drift against the nominal mount and recalibrates again (18 views, about a minute).
//!
//! [`CarryFinder`] reads a run's messages in log order and keeps the last accepted
//! result: a `/calibration/hand_eye` whose `tool0_from_camera` then became the camera edge
//! `tool0 -> camera_color_optical_frame` on `/tf`. A result above the acceptance limits is
//! published too, but never becomes the edge, so it is never carried. It keeps the last
//! `/calibration/check_reference` too, with the edge in use when it came: a reference is
//! carried only with the edge it was taken with (a later accepted calibration makes it
//! another mount's).
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
}

/// A drift check's reference ([`super::stage`] module docs: `/calibration/check_reference`)
/// and the camera edge it was taken with.
#[derive(Debug, Clone, PartialEq)]
pub struct CheckReference {
    /// Log time of its message (ns).
    pub log_time_ns: u64,
    /// The `X` the check's views supported (`tool0_from_camera`).
    pub tool0_from_camera: Isometry3<f64>,
    /// The camera edge in use when it was taken.
    pub edge: Isometry3<f64>,
}

/// What a run leaves for the next one (module docs): its final camera edge, with the accepted
/// calibration that made it and the drift check reference taken with it, when there are.
#[derive(Debug, Clone, PartialEq)]
pub struct Carried {
    /// The camera edge `tool0 -> camera_color_optical_frame` at the end of the run.
    pub edge: Isometry3<f64>,
    /// The accepted self-calibration that is [`Self::edge`], if the run accepted one.
    pub accepted: Option<AcceptedCalibration>,
    /// The last drift check reference taken with [`Self::edge`], if any.
    pub reference: Option<CheckReference>,
}

impl Carried {
    /// The next run's parameters, as TOML lines under a scenario's `[parameters]` (each also
    /// works as `--set KEY=VALUE`): `calibration.mount_xyz_m`, `calibration.mount_rpy_deg`
    /// (roll-pitch-yaw about the fixed x, y, z axes, as
    /// [`robot::camera_mount::mount_from_xyz_rpy`] reads them); with an accepted calibration
    /// that has an uncertainty, `calibration.mount_sigma_rot_deg` and
    /// `calibration.mount_sigma_trans_mm`; with a reference, `calibration.reference_xyz_m`
    /// and `calibration.reference_rpy_deg`. Numbers are written in full (shortest round-trip
    /// form).
    #[must_use]
    pub fn parameters_toml(&self) -> String {
        let mut lines = pose_lines("mount", &self.edge).to_vec();
        if let Some((rot, trans)) = self
            .accepted
            .as_ref()
            .and_then(AcceptedCalibration::sigma_per_axis)
        {
            lines.push(format!("calibration.mount_sigma_rot_deg = {rot:?}"));
            lines.push(format!("calibration.mount_sigma_trans_mm = {trans:?}"));
        }
        if let Some(r) = &self.reference {
            lines.extend(pose_lines("reference", &r.tool0_from_camera));
        }
        lines.join("\n") + "\n"
    }
}

/// `calibration.{name}_xyz_m` and `calibration.{name}_rpy_deg` of `x`.
fn pose_lines(name: &str, x: &Isometry3<f64>) -> [String; 2] {
    let t = x.translation.vector;
    let (roll, pitch, yaw) = x.rotation.euler_angles();
    [
        format!(
            "calibration.{name}_xyz_m = [{:?}, {:?}, {:?}]",
            t.x, t.y, t.z
        ),
        format!(
            "calibration.{name}_rpy_deg = [{:?}, {:?}, {:?}]",
            roll.to_degrees(),
            pitch.to_degrees(),
            yaw.to_degrees()
        ),
    ]
}

/// Finds what a run leaves for the next one in its message stream (module docs).
#[derive(Debug, Clone, Default)]
pub struct CarryFinder {
    /// The last result not yet seen as the camera edge.
    candidate: Option<AcceptedCalibration>,
    accepted: Option<AcceptedCalibration>,
    /// Results read, accepted or not.
    results: usize,
    /// The last camera edge on `/tf`.
    edge: Option<Isometry3<f64>>,
    reference: Option<CheckReference>,
}

impl CarryFinder {
    /// A finder that has read nothing.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Topics it reads.
    pub const TOPICS: [&'static str; 3] = [
        topics::CALIBRATION_HAND_EYE,
        topics::TF,
        topics::CALIBRATION_CHECK_REFERENCE,
    ];

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
                let edges = tf.transforms.iter().filter(|e| {
                    e.header.frame_id == MOUNT_PARENT_FRAME && e.child_frame_id == MOUNT_CHILD_FRAME
                });
                for e in edges {
                    let Ok(x) = isometry_from_msg(&e.transform) else {
                        continue;
                    };
                    if self
                        .candidate
                        .as_ref()
                        .is_some_and(|c| same_pose(&x, &c.tool0_from_camera))
                    {
                        self.accepted = self.candidate.take();
                    }
                    self.edge = Some(x);
                }
            }
            (topics::CALIBRATION_CHECK_REFERENCE, Msg::TransformStamped(t))
                if t.header.frame_id == MOUNT_PARENT_FRAME
                    && t.child_frame_id == MOUNT_CHILD_FRAME =>
            {
                if let (Some(edge), Ok(x)) = (self.edge, isometry_from_msg(&t.transform)) {
                    self.reference = Some(CheckReference {
                        log_time_ns,
                        tool0_from_camera: x,
                        edge,
                    });
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

    /// What there is to carry: `None` when the run neither accepted a calibration nor took
    /// a reference with its final camera edge (it kept the edge it started with, and the
    /// next run may as well start from the same parameters).
    #[must_use]
    pub fn finish(self) -> Option<Carried> {
        let edge = self.edge?;
        let accepted = self
            .accepted
            .filter(|a| same_pose(&a.tool0_from_camera, &edge));
        let reference = self.reference.filter(|r| same_pose(&r.edge, &edge));
        (accepted.is_some() || reference.is_some()).then_some(Carried {
            edge,
            accepted,
            reference,
        })
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

    fn reference(x: &Isometry3<f64>) -> Msg {
        Msg::TransformStamped(transform_stamped(
            MOUNT_PARENT_FRAME,
            MOUNT_CHILD_FRAME,
            msgs::builtin_interfaces::Time::default(),
            x,
        ))
    }

    #[test]
    fn only_a_result_that_became_the_camera_edge_is_carried() {
        let mut f = CarryFinder::new();
        f.feed(1, topics::TF, &edge(&x(0.0)));
        f.feed(2, topics::CALIBRATION_HAND_EYE, &result(&x(3.0)));
        f.feed(3, topics::TF, &edge(&x(3.0)));
        // A later result above the limits: published, never the edge.
        f.feed(4, topics::CALIBRATION_HAND_EYE, &result(&x(9.0)));
        f.feed(5, topics::TF, &edge(&x(3.0)));
        assert_eq!(f.results(), 2);
        let c = f.finish().expect("the first result was accepted");
        let a = c.accepted.expect("accepted");
        assert_eq!(a.log_time_ns, 2);
        assert!(same_pose(&a.tool0_from_camera, &x(3.0)));
        assert!(same_pose(&c.edge, &x(3.0)));
        assert_eq!(c.reference, None);

        let mut none = CarryFinder::new();
        none.feed(1, topics::CALIBRATION_HAND_EYE, &result(&x(3.0)));
        none.feed(2, topics::TF, &edge(&x(0.0)));
        assert_eq!(none.finish(), None);
    }

    #[test]
    fn a_reference_is_carried_with_its_edge_only() {
        // A run that kept its edge and took a reference: the edge and the reference.
        let mut kept = CarryFinder::new();
        kept.feed(1, topics::TF, &edge(&x(0.0)));
        kept.feed(2, topics::CALIBRATION_CHECK_REFERENCE, &reference(&x(0.7)));
        kept.feed(3, topics::TF, &edge(&x(0.0)));
        let c = kept.finish().expect("a reference");
        assert!(same_pose(&c.edge, &x(0.0)));
        assert_eq!(c.accepted, None);
        let r = c.reference.expect("reference");
        assert_eq!(r.log_time_ns, 2);
        assert!(same_pose(&r.tool0_from_camera, &x(0.7)));

        // A calibration accepted after the reference: the reference was the old mount's.
        let mut later = CarryFinder::new();
        later.feed(1, topics::TF, &edge(&x(0.0)));
        later.feed(2, topics::CALIBRATION_CHECK_REFERENCE, &reference(&x(0.7)));
        later.feed(3, topics::CALIBRATION_HAND_EYE, &result(&x(3.0)));
        later.feed(4, topics::TF, &edge(&x(3.0)));
        let c = later.clone().finish().expect("the calibration");
        assert!(c.accepted.is_some());
        assert_eq!(c.reference, None);

        // A reference taken after the calibration is carried with it.
        let mut after = later.clone();
        after.feed(5, topics::CALIBRATION_CHECK_REFERENCE, &reference(&x(3.4)));
        let c = after.finish().expect("both");
        assert!(c.accepted.is_some());
        assert!(same_pose(
            &c.reference.expect("ref").tool0_from_camera,
            &x(3.4)
        ));
    }

    #[test]
    fn the_parameters_read_back_as_the_same_mount_and_a_per_axis_sigma() {
        let mut f = CarryFinder::new();
        f.feed(2, topics::CALIBRATION_HAND_EYE, &result(&x(3.0)));
        f.feed(3, topics::TF, &edge(&x(3.0)));
        f.feed(4, topics::CALIBRATION_CHECK_REFERENCE, &reference(&x(3.6)));
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
        let r = c.check_reference.expect("carried reference");
        assert!(same_pose(&r, &x(3.6)), "{r:?}");
    }

    #[test]
    fn a_carried_mount_comes_whole_or_not_at_all() {
        let read = crate::selfcal::CalibrationStageConfig::from_settings;
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
        let reference_alone = read(&[
            "calibration.reference_xyz_m=[0.06, -0.04, 0.09]",
            "calibration.reference_rpy_deg=[0.5, -1.1, 90.0]",
        ])
        .expect_err("a reference without the mount it belongs to");
        assert!(
            reference_alone.to_string().contains("belongs to the mount"),
            "{reference_alone}"
        );
        assert_eq!(nominal.check_reference, None);
    }
}
