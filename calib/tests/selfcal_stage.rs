//! The calibration stage over a message stream (ARCHITECTURE.md section 3): synthetic RGB-D captures with
//! their /tf, the camera edge on /tf with every /joint_states (nominal, then the accepted
//! calibration), `/calibration/hand_eye` and `/calibration/matches`, and the refusals on
//! `/rosout` (dark view, near-duplicate view, missing TF, depth/colour stamp mismatch, too
//! few views, degenerate motion).

mod selfcal_support;

use calib::handeye::pose_error;
use calib::relpose::CameraModel;
use calib::selfcal::{
    CalibView, CalibrationStage, CalibrationStageConfig, SelfCalParams, self_calibrate,
};
use image::GrayImage;
use msgs::builtin_interfaces::Time;
use msgs::frames::{BASE_LINK, CAMERA_COLOR_OPTICAL_FRAME, TOOL0};
use msgs::rcl_interfaces::Log;
use msgs::rosgraph_msgs::Clock;
use msgs::sensor_msgs::{CameraInfo, Image, JointState, image_encodings};
use msgs::std_msgs::Header;
use msgs::tf2_msgs::TfMessage;
use msgs::{Msg, RobotTime, Stage, topics};
use nalgebra::{Isometry3, UnitQuaternion, Vector3};
use selfcal_support as sup;

fn ros(stamp_ns: u64) -> Time {
    RobotTime::from_nanos(stamp_ns).to_ros().expect("stamp")
}

fn header(stamp_ns: u64) -> Header {
    Header {
        stamp: ros(stamp_ns),
        frame_id: CAMERA_COLOR_OPTICAL_FRAME.to_owned(),
    }
}

fn camera_info(cam: &CameraModel) -> Msg {
    Msg::from(CameraInfo {
        header: header(1),
        width: cam.width,
        height: cam.height,
        distortion_model: "plumb_bob".to_owned(),
        d: vec![cam.k1, cam.k2, cam.p1, cam.p2, cam.k3],
        k: [cam.fx, 0.0, cam.cx, 0.0, cam.fy, cam.cy, 0.0, 0.0, 1.0],
        ..CameraInfo::default()
    })
}

fn tf(pose: &Isometry3<f64>, stamp_ns: u64) -> Msg {
    Msg::from(TfMessage {
        transforms: vec![robot::conversions::transform_stamped(
            BASE_LINK,
            TOOL0,
            ros(stamp_ns),
            pose,
        )],
    })
}

fn mono8(gray: &GrayImage, stamp_ns: u64) -> Msg {
    let (w, h) = gray.dimensions();
    Msg::from(Image {
        header: header(stamp_ns),
        width: w,
        height: h,
        encoding: image_encodings::MONO8.to_owned(),
        is_bigendian: 0,
        step: w,
        data: gray.as_raw().clone(),
    })
}

fn depth32(v: &CalibView, stamp_ns: u64) -> Msg {
    let (w, h) = v.gray.dimensions();
    let d = v.depth_m.as_deref().unwrap_or(&[]);
    Msg::from(Image {
        header: header(stamp_ns),
        width: w,
        height: h,
        encoding: image_encodings::TYPE_32FC1.to_owned(),
        is_bigendian: 0,
        step: 4 * w,
        data: d.iter().flat_map(|m| m.to_le_bytes()).collect(),
    })
}

fn joint_states(stamp_ns: u64) -> Msg {
    Msg::from(JointState {
        header: Header {
            stamp: ros(stamp_ns),
            frame_id: String::new(),
        },
        name: vec!["arm_shoulder_joint".to_owned()],
        position: vec![0.1],
        ..JointState::default()
    })
}

fn clock(t_ns: u64) -> Msg {
    Msg::from(Clock { clock: ros(t_ns) })
}

/// Feeds one message; collects the outputs with their topics.
struct Harness {
    stage: CalibrationStage,
    out: Vec<(String, Msg)>,
}

impl Harness {
    fn new(config: CalibrationStageConfig) -> Self {
        Self {
            stage: CalibrationStage::new(config),
            out: Vec::new(),
        }
    }

    fn feed(&mut self, log_ns: u64, topic: &str, msg: &Msg) -> Vec<(String, Msg)> {
        let got = self
            .stage
            .on_message(RobotTime::from_nanos(log_ns), topic, msg)
            .expect("stage accepts its inputs");
        self.out.extend(got.iter().cloned());
        got
    }

    /// TF around the capture, the images one second later (as the camera delivers them),
    /// then /clock ticks past the depth wait.
    fn capture(
        &mut self,
        v: &CalibView,
        tf_pose: Option<&Isometry3<f64>>,
        depth_stamp: Option<u64>,
    ) {
        let s = v.stamp_ns;
        if let Some(p) = tf_pose {
            for d in [s - 20_000_000, s + 20_000_000] {
                self.feed(d, topics::TF, &tf(p, d));
            }
        }
        let log = s + 1_000_000_000;
        self.feed(log, topics::CAMERA_COLOR_IMAGE, &mono8(&v.gray, s));
        if let Some(ds) = depth_stamp {
            self.feed(log, topics::CAMERA_DEPTH_IMAGE, &depth32(v, ds));
        }
        for k in 1..=3 {
            self.feed(
                log + k * 100_000_000,
                topics::CLOCK,
                &clock(log + k * 100_000_000),
            );
        }
    }

    fn logs(&self, level: u8) -> Vec<String> {
        self.out
            .iter()
            .filter_map(|(t, m)| match m {
                Msg::Log(l) if t == topics::ROSOUT && l.level == level => Some(l.msg.clone()),
                _ => None,
            })
            .collect()
    }
}

/// The edges equal `expected` up to the message round trip (quaternion renormalisation).
fn assert_edges(got: &[Isometry3<f64>], expected: &[Isometry3<f64>]) {
    assert_eq!(got.len(), expected.len(), "{got:?}");
    for (g, e) in got.iter().zip(expected) {
        let (r, t) = pose_error(g, e);
        assert!(r < 1e-9 && t < 1e-12, "{g:?} vs {e:?}");
    }
}

fn edge_of(out: &[(String, Msg)]) -> Vec<Isometry3<f64>> {
    out.iter()
        .filter_map(|(t, m)| match m {
            Msg::TfMessage(tf) if t == topics::TF => Some(tf),
            _ => None,
        })
        .map(|tf| {
            assert_eq!(tf.transforms.len(), 1);
            let e = &tf.transforms[0];
            assert_eq!(e.header.frame_id, TOOL0);
            assert_eq!(e.child_frame_id, CAMERA_COLOR_OPTICAL_FRAME);
            robot::conversions::isometry_from_msg(&e.transform).expect("finite")
        })
        .collect()
}

#[test]
fn stage_calibrates_and_switches_the_camera_edge_from_nominal_to_the_estimate() {
    let x_true = sup::true_x();
    let (views, cam) = sup::views(&sup::camera_poses(8), &x_true, true);
    let config = CalibrationStageConfig {
        captures_to_solve: views.len(),
        ..CalibrationStageConfig::default()
    };
    let nominal = config.nominal_tool0_from_camera;
    let mut h = Harness::new(config);
    h.feed(500_000_000, topics::CAMERA_COLOR_INFO, &camera_info(&cam));

    // Before any calibration: the nominal edge, once per JointState stamp.
    let first = h.feed(
        600_000_000,
        topics::JOINT_STATES,
        &joint_states(600_000_000),
    );
    let again = h.feed(
        600_000_000,
        topics::JOINT_STATES,
        &joint_states(600_000_000),
    );
    assert_edges(&edge_of(&first), &[nominal]);
    assert!(again.is_empty(), "the edge is sent once per stamp");

    for v in &views {
        h.capture(v, Some(&v.base_from_tool0), Some(v.stamp_ns));
    }
    assert_eq!(h.stage.accepted(), 1, "warnings: {:?}", h.logs(Log::WARN));
    assert!(h.logs(Log::WARN).is_empty(), "{:?}", h.logs(Log::WARN));
    let he: Vec<_> = h
        .out
        .iter()
        .filter_map(|(t, m)| match m {
            Msg::HandEyeCalibration(c) if t == topics::CALIBRATION_HAND_EYE => Some(c.clone()),
            _ => None,
        })
        .collect();
    assert_eq!(he.len(), 1);
    let c = &he[0];
    assert_eq!(c.header.frame_id, TOOL0);
    assert_eq!(c.child_frame_id, CAMERA_COLOR_OPTICAL_FRAME);
    assert_eq!((c.mode.as_str(), c.views), ("rgbd", 8));
    assert!(c.pairs >= 2 && c.sigma_rot_deg.is_finite() && c.sigma_trans_mm.is_finite());
    assert!(c.residual_rot_deg.is_finite() && c.condition.is_finite());
    let x = robot::conversions::isometry_from_msg(&c.tool0_from_camera).expect("finite");
    let (r, t) = pose_error(&x, &x_true);
    assert!(r < 0.1 && t < 1e-3, "{r} deg {t} m");
    // Not the inverse (the asymmetric mount).
    let (ri, ti) = pose_error(&x.inverse(), &x_true);
    assert!(ri > 1.0 || ti > 0.01);

    let matches: Vec<_> = h
        .out
        .iter()
        .filter_map(|(t, m)| match m {
            Msg::FeatureMatches(f) if t == topics::CALIBRATION_MATCHES => Some(f.clone()),
            _ => None,
        })
        .collect();
    assert!(
        matches.len() >= c.pairs as usize,
        "{} match messages",
        matches.len()
    );
    // `inlier` is the pair motion's RANSAC verdict, not GMS's: the same flags as the
    // pipeline's on the same views.
    let direct = self_calibrate(&views, &cam, &SelfCalParams::default()).expect("calibrates");
    assert_eq!(matches.len(), direct.matches.len());
    for (msg, m) in matches.iter().zip(&direct.matches) {
        assert_eq!(msg.inlier, m.motion_inliers, "pair ({}, {})", m.i, m.j);
        assert_eq!(msg.inlier.len() * 2, msg.pairs.len());
    }

    // After acceptance: the calibrated edge.
    let late = 100_000_000_000;
    let after = h.feed(late, topics::JOINT_STATES, &joint_states(late));
    assert_edges(&edge_of(&after), &[x]);
}

#[test]
fn stage_skips_bad_captures_with_reasons_and_refuses_too_few_views() {
    let (views, cam) = sup::views(&sup::camera_poses(3), &sup::true_x(), true);
    let mut h = Harness::new(CalibrationStageConfig {
        captures_to_solve: 5,
        ..CalibrationStageConfig::default()
    });
    h.feed(500_000_000, topics::CAMERA_COLOR_INFO, &camera_info(&cam));
    // 1. A good view.
    h.capture(
        &views[0],
        Some(&views[0].base_from_tool0),
        Some(views[0].stamp_ns),
    );
    assert_eq!(h.stage.views(), 1);
    // 2. A dark view (all black, no features).
    let mut dark = views[1].clone();
    dark.gray = GrayImage::new(cam.width, cam.height);
    h.capture(&dark, Some(&dark.base_from_tool0), Some(dark.stamp_ns));
    // 3. The same hand orientation as view 0 (moved 5 cm): no new rotation axis.
    let mut dup = views[2].clone();
    dup.base_from_tool0 = Isometry3::from_parts(
        (views[0].base_from_tool0.translation.vector + Vector3::new(0.05, 0.0, 0.0)).into(),
        views[0].base_from_tool0.rotation * UnitQuaternion::from_euler_angles(0.0, 0.0, 1e-3),
    );
    h.capture(&dup, Some(&dup.base_from_tool0), Some(dup.stamp_ns));
    // 4. No TF at its stamp (the arm's /tf stopped).
    let mut no_tf = views[2].clone();
    no_tf.stamp_ns = 20_000_000_000;
    h.capture(&no_tf, None, Some(no_tf.stamp_ns));
    // Give the TF wait its time.
    for k in 0..30 {
        let t = 21_500_000_000 + k * 100_000_000;
        h.feed(t, topics::CLOCK, &clock(t));
    }
    // 5. Depth 5 ms off the colour stamp.
    let mut late_depth = views[2].clone();
    late_depth.stamp_ns = 30_000_000_000;
    h.capture(
        &late_depth,
        Some(&late_depth.base_from_tool0),
        Some(late_depth.stamp_ns + 5_000_000),
    );

    let warn = h.logs(Log::WARN);
    let has = |needle: &str| warn.iter().any(|w| w.contains(needle));
    assert!(has("too dark, washed out or textureless"), "{warn:?}");
    assert!(has("rotate the wrist more"), "{warn:?}");
    assert!(has("no hand pose base_link -> tool0"), "{warn:?}");
    assert!(has("no depth image within"), "{warn:?}");
    assert!(has("has no colour image within"), "{warn:?}");
    let err = h.logs(Log::ERROR);
    assert_eq!(err.len(), 1, "{err:?}");
    assert!(
        err[0].contains("too few views: 1 of 5 captures kept"),
        "{}",
        err[0]
    );
    assert!(
        h.out.iter().all(|(t, _)| t != topics::CALIBRATION_HAND_EYE),
        "a refusal publishes no calibration"
    );
    assert_eq!(h.stage.accepted(), 0);
    assert_eq!(h.stage.views(), 0, "a new batch starts after a refusal");
}

#[test]
fn stage_refuses_degenerate_motion_and_keeps_the_nominal_edge() {
    // Every view rotates about the same axis (the optical axis of one pose): the hand motions
    // share one rotation axis, so X is not observable.
    let base = sup::camera_poses(1)[0];
    let poses: Vec<Isometry3<f64>> = (0..5)
        .map(|k| base * Isometry3::rotation(Vector3::z() * (k as f64 * 12f64).to_radians()))
        .collect();
    let (views, cam) = sup::views(&poses, &sup::true_x(), true);
    let config = CalibrationStageConfig {
        captures_to_solve: views.len(),
        ..CalibrationStageConfig::default()
    };
    let nominal = config.nominal_tool0_from_camera;
    let mut h = Harness::new(config);
    h.feed(500_000_000, topics::CAMERA_COLOR_INFO, &camera_info(&cam));
    for v in &views {
        h.capture(v, Some(&v.base_from_tool0), Some(v.stamp_ns));
    }
    let err = h.logs(Log::ERROR);
    assert_eq!(err.len(), 1, "{err:?} / {:?}", h.logs(Log::INFO));
    assert!(err[0].starts_with("self-calibration refused"), "{}", err[0]);
    assert!(
        err[0].contains("the camera edge stays the nominal mount"),
        "{}",
        err[0]
    );
    let t = 90_000_000_000;
    assert_edges(
        &edge_of(&h.feed(t, topics::JOINT_STATES, &joint_states(t))),
        &[nominal],
    );
}

/// The drift check takes the X in use to be as good as its calibration said: before any
/// calibration (the configured mount) a typical self-calibration's figure, after one the
/// accepted calibration's own covariance, and the check's log says which.
#[test]
fn the_drift_check_uses_the_covariance_of_the_calibration_it_checks() {
    let x_true = sup::true_x();
    let (views, cam) = sup::views(&sup::camera_poses(8), &x_true, true);
    // Batches on command, as the task drives them.
    let config = CalibrationStageConfig {
        captures_to_solve: 0,
        ..CalibrationStageConfig::default()
    };
    let mut h = Harness::new(config);
    h.feed(500_000_000, topics::CAMERA_COLOR_INFO, &camera_info(&cam));
    let command = |c: &str| Msg::String(msgs::std_msgs::String { data: c.to_owned() });
    // A batch (`check` or `collect`) of the same views `shift_ns` later, solved; the last
    // drift check log line.
    let batch = |h: &mut Harness, kind: &str, shift_ns: u64| -> String {
        h.feed(shift_ns, topics::CALIBRATION_COMMAND, &command(kind));
        for v in &views {
            let mut later = v.clone();
            later.stamp_ns += shift_ns;
            h.capture(&later, Some(&later.base_from_tool0), Some(later.stamp_ns));
        }
        let end = shift_ns + 100_000_000_000;
        h.feed(end, topics::CALIBRATION_COMMAND, &command("solve"));
        h.out
            .iter()
            .filter_map(|(t, m)| match m {
                Msg::Log(l) if t == topics::ROSOUT && l.msg.starts_with("drift check") => {
                    Some(l.msg.clone())
                }
                _ => None,
            })
            .next_back()
            .unwrap_or_default()
    };
    let before = batch(&mut h, "check", 1_000_000_000_000);
    assert!(
        before.contains("came with no covariance") && before.contains("0.030 deg / 0.40 mm"),
        "{before}"
    );
    batch(&mut h, "collect", 2_000_000_000_000);
    assert_eq!(h.stage.accepted(), 1, "warnings: {:?}", h.logs(Log::WARN));
    let after = batch(&mut h, "check", 3_000_000_000_000);
    assert!(
        after.contains("from its calibration's covariance"),
        "{after}"
    );
    assert!(after.contains("where the calibration says"), "{after}");
}

/// A `check` batch of `views` `shift_ns` later, solved; the stage's outputs of the batch.
fn check_batch(h: &mut Harness, views: &[CalibView], shift_ns: u64) -> Vec<(String, Msg)> {
    batch(h, "check", views, shift_ns)
}

/// A batch `kind` (`check`, `extend`, `collect`) of `views` `shift_ns` later, solved; the
/// stage's outputs of the batch.
fn batch(h: &mut Harness, kind: &str, views: &[CalibView], shift_ns: u64) -> Vec<(String, Msg)> {
    let command = |c: &str| Msg::String(msgs::std_msgs::String { data: c.to_owned() });
    let before = h.out.len();
    h.feed(shift_ns, topics::CALIBRATION_COMMAND, &command(kind));
    for v in views {
        let mut later = v.clone();
        later.stamp_ns += shift_ns;
        h.capture(&later, Some(&later.base_from_tool0), Some(later.stamp_ns));
    }
    h.feed(
        shift_ns + 100_000_000_000,
        topics::CALIBRATION_COMMAND,
        &command("solve"),
    );
    h.out[before..].to_vec()
}

/// The check's answer (`reason_code`) and the references it published.
fn check_answer(out: &[(String, Msg)]) -> (String, String, Vec<Isometry3<f64>>) {
    let answer = out
        .iter()
        .find_map(|(t, m)| match m {
            Msg::TaskEvent(e) if t == topics::TASK_EVENT => {
                Some((e.reason_code.clone(), e.text.clone()))
            }
            _ => None,
        })
        .expect("an answer");
    let references = out
        .iter()
        .filter_map(|(t, m)| match m {
            Msg::TransformStamped(r) if t == topics::CALIBRATION_CHECK_REFERENCE => {
                assert_eq!(r.header.frame_id, TOOL0);
                assert_eq!(r.child_frame_id, CAMERA_COLOR_OPTICAL_FRAME);
                Some(robot::conversions::isometry_from_msg(&r.transform).expect("finite"))
            }
            _ => None,
        })
        .collect();
    (answer.0, answer.1, references)
}

/// A consistent check publishes the X its views support as the reference; a run given that
/// reference compares with it, publishes the very same reference again (never its own
/// estimate), and a reference from before a 3 mm knock makes the check say `drifted`.
#[test]
fn a_check_reference_is_taken_then_kept_and_a_knock_since_it_shows() {
    let x_true = sup::true_x();
    let (views, cam) = sup::views(&sup::camera_poses(8), &x_true, true);
    let stage = |reference: Option<Isometry3<f64>>| {
        let mut h = Harness::new(CalibrationStageConfig {
            captures_to_solve: 0,
            nominal_tool0_from_camera: x_true,
            check_reference: reference,
            ..CalibrationStageConfig::default()
        });
        h.feed(500_000_000, topics::CAMERA_COLOR_INFO, &camera_info(&cam));
        h
    };

    let (code, text, taken) =
        check_answer(&check_batch(&mut stage(None), &views, 1_000_000_000_000));
    assert_eq!(code, "consistent", "{text}");
    assert!(text.contains("is now the check's reference"), "{text}");
    assert_eq!(taken.len(), 1, "{text}");
    let (rot_deg, trans_m) = pose_error(&taken[0], &x_true);
    assert!(
        rot_deg < 0.1 && trans_m < 1e-3,
        "{rot_deg} deg, {trans_m} m"
    );
    assert!(
        rot_deg > 0.0 || trans_m > 0.0,
        "the views' own estimate, not the edge"
    );

    // Later, against a reference 0.3 mm from it (within the check's noise): that same
    // reference again, not these views' estimate.
    let reference = Isometry3::from_parts(
        (taken[0].translation.vector + Vector3::new(0.0003, 0.0, 0.0)).into(),
        taken[0].rotation,
    );
    let (code, text, kept) = check_answer(&check_batch(
        &mut stage(Some(reference)),
        &views,
        1_000_000_000_000,
    ));
    assert_eq!(code, "consistent", "{text}");
    assert!(text.contains("against the reference carried"), "{text}");
    assert!(text.contains("calibration.reference_*"), "{text}");
    assert_edges(&kept, &[reference]);

    // A reference taken before the mount moved by 3 mm: the views now disagree with it.
    let before_knock = Isometry3::from_parts(
        (x_true.translation.vector + Vector3::new(0.0021, -0.0015, 0.0015)).into(),
        x_true.rotation,
    );
    let (code, text, none) = check_answer(&check_batch(
        &mut stage(Some(before_knock)),
        &views,
        1_000_000_000_000,
    ));
    assert_eq!(code, "drifted", "{text}");
    assert!(none.is_empty(), "no reference after a drift: {text}");

    // Once a calibration is accepted in the run, the reference is another mount's: the
    // check is against the new camera edge.
    let mut h = stage(Some(before_knock));
    batch(&mut h, "collect", &views, 1_000_000_000_000);
    assert_eq!(h.stage.accepted(), 1, "warnings: {:?}", h.logs(Log::WARN));
    let (code, text, _) = check_answer(&check_batch(&mut h, &views, 2_000_000_000_000));
    assert_eq!(code, "consistent", "{text}");
    assert!(text.contains("against the camera edge"), "{text}");
}

/// A check that an `extend` completed takes as its reference the estimate of the views it
/// started with (the poses later checks repeat), not that of all its views.
#[test]
fn an_extended_check_takes_its_reference_from_the_views_it_started_with() {
    let x_true = sup::true_x();
    let (views, cam) = sup::views(&sup::camera_poses(8), &x_true, true);
    let mut h = Harness::new(CalibrationStageConfig {
        captures_to_solve: 0,
        nominal_tool0_from_camera: x_true,
        ..CalibrationStageConfig::default()
    });
    h.feed(500_000_000, topics::CAMERA_COLOR_INFO, &camera_info(&cam));
    let (code, text, first) = check_answer(&batch(&mut h, "check", &views[..4], 1_000_000_000_000));
    assert_eq!(code, "consistent", "{text}");
    assert_eq!(first.len(), 1, "{text}");
    let (code, text, extended) =
        check_answer(&batch(&mut h, "extend", &views[4..], 2_000_000_000_000));
    assert_eq!(code, "consistent", "{text}");
    assert!(text.contains("(8 views)"), "{text}");
    assert!(text.contains("its first 4 views"), "{text}");
    assert_edges(&extended, &first);
    // ... which is not what all eight views support.
    let (_, _, all) = check_answer(&batch(&mut h, "check", &views, 3_000_000_000_000));
    let (rot_deg, trans_m) = pose_error(&all[0], &first[0]);
    assert!(
        rot_deg > 1e-6 || trans_m > 1e-9,
        "{rot_deg} deg, {trans_m} m"
    );
}
