//! The calibration stage (ARCHITECTURE.md section 3): hand-eye self-calibration over the message
//! stream, and the camera edge `tool0 -> camera_color_optical_frame` on `/tf`.
//!
//! # Inputs and outputs
//!
//! | in | use |
//! |---|---|
//! | `/tf`, `/tf_static` | a [`TfBuffer`]: the hand pose `base_link_from_tool0` at each image stamp |
//! | `/camera/color/camera_info` | the camera model (first message) |
//! | `/camera/color/image_raw`, `/camera/depth/image_raw` | one capture = a colour image and the depth image of the same stamp |
//! | `/joint_states` | the trigger of the camera edge |
//! | `/clock` | time-outs (a capture waiting for its depth or its TF) |
//! | `/calibration/command` | batches requested by the task stages ("Commands" below) |
//!
//! | out | when |
//! |---|---|
//! | `/tf` | with every `/joint_states` of a new stamp: the nominal mount ([`robot::camera_mount`]), or a calibration carried from an earlier run (`calibration.mount_xyz_m`, `mount_rpy_deg`: `rodlog calib carry`), until a calibration is accepted, then the accepted `tool0_from_camera`, stamped with the JointState's stamp |
//! | `/calibration/hand_eye` | each self-calibration that succeeds (quality and 1-sigma uncertainty filled, [`hand_eye_msg`]) |
//! | `/calibration/check_reference` | after each drift check that found the camera edge consistent: the reference later checks compare with (below) |
//! | `/calibration/matches` | with it: one message per candidate view pair, its GMS matches, flagged `inlier` when consistent with the pair's estimated camera motion (RANSAC verdict) |
//! | `/rosout` | every view skipped and every refusal, saying what to do; the acceptance |
//! | `/task/event` | the answer to `solve` (task `calibration`, below) |
//!
//! # Commands
//! `/calibration/command` (std_msgs/String) lets a task stage run self-maintenance through
//! this stage: `check` starts a batch of drift check views, `collect` a batch of calibration
//! views (the captures that follow are the batch's, with the same pairing and filters as
//! below), `solve` ends the batch and answers on `/task/event` with task `calibration`:
//!
//! | batch | state | reason_code (kind) |
//! |---|---|---|
//! | check | `check` | `consistent` (INFO), `drifted` (INFO: recalibrate), `unresolved` (REFUSED: no drift seen, but the views could miss one of the target size; more views help), `cannot_tell` (REFUSED, e.g. too dark) from [`check_drift`] against the camera edge in use, or against the carried reference (below) |
//! | collect | `calibrate` | `accepted` (DONE: now the camera edge), `rejected` (FAILED: residuals above the limits), `refused` (REFUSED) |
//!
//! **The check's reference.** The camera edge carries its calibration's error, and the arm's
//! kinematic error at the check poses differs from that at the calibration poses, so part of
//! both shows as a "drift" of its own (ARCHITECTURE.md section 6). A check that finds the
//! edge consistent publishes the `X` its views support on `/calibration/check_reference`;
//! carried to a later run (`calibration.reference_xyz_m`, `reference_rpy_deg`, written by
//! `rodlog calib carry` with the mount it belongs to), the check there compares with it
//! ([`DriftParams::against_reference`]), so the systematic part cancels. A check against a
//! reference that finds it consistent publishes that same reference again, never its own
//! estimate: a reference that followed each check would let a slow creep pass unseen. Once a
//! calibration is accepted in the run, the reference no longer belongs to the edge, and the
//! check is against the calibration again. A new reference is the estimate of the views the
//! check started with, also when an `extend` added more before it could decide: later checks
//! start with the same poses, and the arm's error at the added ones would not cancel.
//!
//! `extend` starts a batch of drift check views that joins the last check's views (after an
//! `unresolved`: the task adds [`super::drift::CHECK_MOTION_MORE`], and the check of all of
//! them has `n - 1` independent motions instead of three). `cancel` drops the batch.
//! Without a batch, captures are only calibrated when
//! [`CalibrationStageConfig::captures_to_solve`] is non-zero (scripted motions such as
//! `calib-18`).
//!
//! The `robot_state` stage never publishes the camera edge, so it is published exactly once
//! per stamp, here.
//!
//! # Behaviour
//!
//! 1. A colour image waits [`CalibrationStageConfig::depth_wait`] of log time for the depth
//!    image of the same stamp (within [`DEPTH_STAMP_TOLERANCE_NS`]); once depth has been seen
//!    in the stream (mode `rgbd`), a colour image without depth is skipped as a stamp
//!    mismatch, and so is a depth image without a colour image.
//! 2. Its hand pose is looked up in the TF buffer at the image stamp; when TF has not reached
//!    the stamp yet the capture waits up to [`CalibrationStageConfig::tf_wait`], then it is
//!    skipped with the buffer's explanation (missing TF).
//! 3. Informative views only: a view with fewer than [`SelfCalParams::min_features`] ORB
//!    keypoints (dark, washed out, textureless) is skipped with its mean intensity and
//!    contrast, and so is a view whose hand orientation is within
//!    [`CalibrationStageConfig::min_view_rotation_deg`] of an already kept view (it adds no
//!    rotation axis and only repeats the matches).
//! 4. After [`CalibrationStageConfig::captures_to_solve`] captures (kept or skipped), the kept
//!    views go to [`self_calibrate`]. A refusal goes to `/rosout` as an ERROR with its numbers
//!    and what to do; a result is published on `/calibration/hand_eye`, and it is *accepted*
//!    (becomes the camera edge) when its median residuals are within
//!    [`CalibrationStageConfig::max_residual_rot_deg`] and
//!    [`CalibrationStageConfig::max_residual_trans_mm`]. The views are then cleared: a later
//!    batch of captures recalibrates.
//!
//! # Determinism
//!
//! Outputs depend only on the inputs and the configuration: no clock but `log_time`, views
//! in arrival order, and [`self_calibrate`] collects its parallel work in a fixed order, so
//! the bytes are the same whatever the thread count. Outputs are returned in a fixed order;
//! the runner stamps them `trigger log_time + latency`.

use image::GrayImage;
use nalgebra::{Isometry3, Matrix6};

use msgs::builtin_interfaces::Time;
use msgs::geometry_msgs::TransformStamped;
use msgs::rcl_interfaces::Log;
use msgs::rodlog_msgs::{FeatureMatches, HandEyeCalibration, TaskEvent};
use msgs::sensor_msgs::{CameraInfo, Image, JointState};
use msgs::std_msgs::Header;
use msgs::tf2_msgs::TfMessage;
use msgs::{Msg, RobotDuration, RobotTime, RosMessage, Stage, StageError, topics};
use robot::camera_mount::{MOUNT_CHILD_FRAME, MOUNT_PARENT_FRAME};
use robot::conversions::{transform_msg, transform_stamped};
use robot::names::{BASE_LINK, TOOL0};
use robot::tf_buffer::{TfBuffer, TfError};

use super::drift::{CannotTell, DriftParams, DriftVerdict, check_drift};
use super::messages::{
    DEPTH_STAMP_TOLERANCE_NS, camera_from_info, depth_from_image, gray_from_image,
};
use super::pairs::extract_features;
use super::views::{CalibView, intensity_stats};
use super::{
    MIN_VIEWS, SelfCalError, SelfCalMethod, SelfCalParams, SelfCalResult, SharedHandError,
    ViewHandError, self_calibrate,
};
use crate::features::KeypointDistribution;
use crate::relpose::CameraModel;

/// Producer name of the stage (channel metadata `producer=calibration`).
pub const STAGE_NAME: &str = "calibration";
/// Match method of `/calibration/matches`.
pub const MATCH_METHOD: &str = "orb-gms";
/// Task name of the stage's answers on `/task/event`.
pub const CALIBRATION_TASK: &str = "calibration";

/// Configuration of the [`CalibrationStage`]. Every default is documented on its field.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrationStageConfig {
    /// Output latency added to the trigger's log time. Default 5 ms.
    pub latency: RobotDuration,
    /// The camera edge published until a calibration is accepted. Default the robot model's
    /// nominal mount ([`robot::camera_mount::nominal_tool0_from_camera`]); a calibration
    /// carried from an earlier run (`calibration.mount_xyz_m`, `calibration.mount_rpy_deg`,
    /// written by `rodlog calib carry`) replaces it.
    pub nominal_tool0_from_camera: Isometry3<f64>,
    /// The 1-sigma per axis of [`Self::nominal_tool0_from_camera`] when it is a carried
    /// calibration, `(deg, mm)`: the drift check's `x_sigma` until a calibration is accepted
    /// here. Default `None`: the drift check takes a typical self-calibration's
    /// ([`DriftParams::default`]).
    pub mount_sigma: Option<(f64, f64)>,
    /// The drift check's reference for [`Self::nominal_tool0_from_camera`], carried from an
    /// earlier run (`calibration.reference_xyz_m`, `calibration.reference_rpy_deg`: module
    /// docs). Default `None`: the check compares with the camera edge itself.
    pub check_reference: Option<Isometry3<f64>>,
    /// Parent frame of the hand pose. Default `base_link`.
    pub hand_parent_frame: String,
    /// Child frame of the hand pose. Default `tool0`.
    pub hand_child_frame: String,
    /// Captures (kept or skipped) after which the kept views are calibrated; 0 never
    /// calibrates (the stage then only publishes the camera edge). Default 18 (the `calib-18`
    /// motion).
    pub captures_to_solve: usize,
    /// A view whose hand orientation is within this angle of a kept view's is skipped
    /// (deg). Default 1.
    pub min_view_rotation_deg: f64,
    /// A result is accepted (becomes the camera edge) when its median rotation residual over
    /// the pairs is at most this (deg). Default 0.5.
    pub max_residual_rot_deg: f64,
    /// ... and its median translation residual at most this (mm). Default 5.
    pub max_residual_trans_mm: f64,
    /// Longest wait for the depth image of a colour image's stamp (log time). Default 200 ms.
    pub depth_wait: RobotDuration,
    /// Longest wait for TF to reach an image stamp (log time). Default 2 s.
    pub tf_wait: RobotDuration,
    /// History of the TF buffer (ns). Default 10 s.
    pub tf_history_ns: u64,
    /// Ignore depth images: monocular calibration. Default false.
    pub ignore_depth: bool,
    /// RANSAC seed of [`SelfCalParams`]. Default [`SelfCalParams::default`]'s.
    pub seed: u64,
    /// ORB keypoint selection of the calibration; `None` (default) for the method's own
    /// ([`SelfCalMethod::keypoint_distribution`]).
    pub orb_distribution: Option<KeypointDistribution>,
    /// The self-calibration method (its steps, [`SelfCalMethod::steps`]); its name is the
    /// `method` of `/calibration/hand_eye`. Default ours.
    pub method: SelfCalMethod,
    /// The arm's hand-pose error that every view shares, added to the calibration's
    /// covariance ([`SelfCalParams::shared_hand_error`]). Default
    /// [`SharedHandError::AUBO_I10_NOMINAL`].
    pub shared_hand_error: SharedHandError,
    /// The arm's hand-pose error that varies from view to view, propagated into a
    /// monocular calibration's covariance ([`SelfCalParams::view_hand_error`]). Default
    /// [`ViewHandError::AUBO_I10_NOMINAL`].
    pub view_hand_error: ViewHandError,
}

impl Default for CalibrationStageConfig {
    fn default() -> Self {
        Self {
            latency: RobotDuration::from_millis(5),
            nominal_tool0_from_camera: robot::camera_mount::nominal_tool0_from_camera(),
            mount_sigma: None,
            check_reference: None,
            hand_parent_frame: BASE_LINK.to_owned(),
            hand_child_frame: TOOL0.to_owned(),
            captures_to_solve: 18,
            min_view_rotation_deg: 1.0,
            max_residual_rot_deg: 0.5,
            max_residual_trans_mm: 5.0,
            depth_wait: RobotDuration::from_millis(200),
            tf_wait: RobotDuration::from_secs(2),
            tf_history_ns: 10_000_000_000,
            ignore_depth: false,
            seed: SelfCalParams::default().seed,
            orb_distribution: None,
            method: SelfCalMethod::Ours,
            shared_hand_error: SharedHandError::AUBO_I10_NOMINAL,
            view_hand_error: ViewHandError::AUBO_I10_NOMINAL,
        }
    }
}

impl CalibrationStageConfig {
    /// The configuration read from `key=value` settings (tests of the stage's parameters).
    #[cfg(test)]
    pub(crate) fn from_settings(sets: &[&str]) -> Result<Self, scenario::ParamError> {
        let mut params = scenario::Params::default();
        for s in sets {
            params.set_from_arg(s).expect("key=value");
        }
        Self::from_params(&mut scenario::Reader::new(&params), 0)
    }

    /// Reads `calibration.*` through `r`. `scripted_captures` is the scenario's number of
    /// `capture` commands: `calibration.captures` (captures after which the stage
    /// self-calibrates; 0 = never, it then only publishes the camera edge) defaults to it when
    /// it is at least [`MIN_VIEWS`], else to 0. The other keys default to [`Default`]'s.
    ///
    /// # Errors
    /// [`scenario::ParamError::Value`] for a wrong type or an out-of-range value.
    pub fn from_params(
        r: &mut scenario::Reader<'_>,
        scripted_captures: usize,
    ) -> Result<Self, scenario::ParamError> {
        let d = Self::default();
        let default_captures = if scripted_captures >= MIN_VIEWS {
            scripted_captures
        } else {
            0
        };
        let mut s = r.section("calibration");
        const METHODS_OWN: &str = "method";
        let distribution = s.choice(
            "orb_distribution",
            d.orb_distribution.map_or(METHODS_OWN, KeypointDistribution::name),
            &[
                METHODS_OWN,
                KeypointDistribution::Quadtree.name(),
                KeypointDistribution::RetainBest.name(),
            ],
            "ORB keypoint selection: the method's own (ours: retain-best; the paper's: quadtree), or one by name",
        )?;
        let mount_xyz_m = s.f64s_opt::<3>(
            "mount_xyz_m",
            "nominal mount",
            "m",
            "the camera edge tool0 -> camera_color_optical_frame in use at start, a calibration carried from an earlier run (`rodlog calib carry REC.mcap` writes it): translation",
        )?;
        let mount_rpy_deg = s.f64s_opt::<3>(
            "mount_rpy_deg",
            "nominal mount",
            "deg",
            "... its rotation, roll-pitch-yaw about the fixed x, y, z axes",
        )?;
        let reference_xyz_m = s.f64s_opt::<3>(
            "reference_xyz_m",
            "none: the check compares with the camera edge",
            "m",
            "the drift check's reference for the carried mount, the X an earlier check supported at the check poses (`rodlog calib carry` writes it): translation",
        )?;
        let reference_rpy_deg = s.f64s_opt::<3>(
            "reference_rpy_deg",
            "none: the check compares with the camera edge",
            "deg",
            "... its rotation, roll-pitch-yaw about the fixed x, y, z axes",
        )?;
        let typical = DriftParams::default();
        let typical = format!(
            "typical: {} deg / {} mm",
            typical.x_sigma_rot_deg, typical.x_sigma_trans_mm
        );
        let mount_sigma_rot_deg = s.f64_opt(
            "mount_sigma_rot_deg",
            &typical,
            "deg",
            "... its 1-sigma rotation per axis: the drift check's uncertainty of the X in use",
        )?;
        let mount_sigma_trans_mm = s.f64_opt(
            "mount_sigma_trans_mm",
            &typical,
            "mm",
            "... its 1-sigma translation per axis",
        )?;
        let nominal_tool0_from_camera = match (mount_xyz_m, mount_rpy_deg) {
            (Some(xyz), Some(rpy)) => robot::camera_mount::mount_from_xyz_rpy(xyz, rpy),
            (None, None) => d.nominal_tool0_from_camera,
            (xyz, _) => {
                return Err(scenario::ParamError::Value {
                    key: if xyz.is_some() {
                        "calibration.mount_rpy_deg"
                    } else {
                        "calibration.mount_xyz_m"
                    }
                    .to_owned(),
                    value: "(missing)".to_owned(),
                    reason: "calibration.mount_xyz_m and calibration.mount_rpy_deg come together (a carried calibration is a whole pose): give both, or neither for the nominal mount".to_owned(),
                });
            }
        };
        let check_reference = match (reference_xyz_m, reference_rpy_deg) {
            (Some(xyz), Some(rpy)) if mount_xyz_m.is_some() => {
                Some(robot::camera_mount::mount_from_xyz_rpy(xyz, rpy))
            }
            (None, None) => None,
            (xyz, rpy) => {
                return Err(scenario::ParamError::Value {
                    key: "calibration.reference_xyz_m".to_owned(),
                    value: format!("{xyz:?}, with reference_rpy_deg {rpy:?}"),
                    reason: "a drift check reference is a whole pose and belongs to the mount it was taken with: give calibration.reference_xyz_m and calibration.reference_rpy_deg together, with calibration.mount_xyz_m and calibration.mount_rpy_deg (`rodlog calib carry` writes all four)".to_owned(),
                });
            }
        };
        let mount_sigma = match (mount_sigma_rot_deg, mount_sigma_trans_mm) {
            (None, None) => None,
            (Some(rot), Some(trans))
                if mount_xyz_m.is_some()
                    && rot.is_finite()
                    && trans.is_finite()
                    && rot > 0.0
                    && trans > 0.0 =>
            {
                Some((rot, trans))
            }
            (rot, trans) => {
                return Err(scenario::ParamError::Value {
                    key: "calibration.mount_sigma_rot_deg".to_owned(),
                    value: format!("{rot:?} deg, with mount_sigma_trans_mm {trans:?} mm"),
                    reason: "the carried calibration's 1-sigma needs both figures, positive, and the carried mount itself (calibration.mount_xyz_m, calibration.mount_rpy_deg)".to_owned(),
                });
            }
        };
        Ok(Self {
            nominal_tool0_from_camera,
            mount_sigma,
            check_reference,
            latency: s.millis("latency_ms", d.latency, "stage latency")?,
            captures_to_solve: s.count(
                "captures",
                default_captures,
                0,
                "captures after which the stage self-calibrates (0 = never; default the scenario's capture commands when >= 3)",
            )?,
            min_view_rotation_deg: s.non_negative(
                "min_view_rotation_deg",
                d.min_view_rotation_deg,
                "deg",
                "least rotation between two views used as a pair",
            )?,
            max_residual_rot_deg: s.non_negative(
                "max_residual_rot_deg",
                d.max_residual_rot_deg,
                "deg",
                "accept a calibration whose median rotation residual is at most this",
            )?,
            max_residual_trans_mm: s.non_negative(
                "max_residual_trans_mm",
                d.max_residual_trans_mm,
                "mm",
                "... and whose median translation residual is at most this",
            )?,
            depth_wait: s.millis(
                "depth_wait_ms",
                d.depth_wait,
                "longest wait for the depth image of a colour image",
            )?,
            tf_wait: s.seconds("tf_wait_s", d.tf_wait, "longest wait for TF to reach an image stamp")?,
            ignore_depth: s.bool("mono", d.ignore_depth, "ignore depth: monocular calibration")?,
            seed: s.u64("seed", d.seed, "", "RANSAC seed")?,
            shared_hand_error: SharedHandError {
                rot_deg: s.non_negative(
                    "shared_hand_error_rot_deg",
                    d.shared_hand_error.rot_deg,
                    "deg",
                    "the arm's hand-pose error every view shares at the flange (1-sigma per axis; its kinematic model's accuracy), added to the calibration's uncertainty",
                )?,
                trans_mm: s.non_negative(
                    "shared_hand_error_trans_mm",
                    d.shared_hand_error.trans_mm,
                    "mm",
                    "... its translation",
                )?,
            },
            view_hand_error: ViewHandError {
                rot_deg: s.non_negative(
                    "view_hand_error_rot_deg",
                    d.view_hand_error.rot_deg,
                    "deg",
                    "the arm's hand-pose error that varies from view to view (1-sigma per axis at the flange), propagated into a monocular calibration's uncertainty",
                )?,
                trans_mm: s.non_negative(
                    "view_hand_error_trans_mm",
                    d.view_hand_error.trans_mm,
                    "mm",
                    "... its translation",
                )?,
            },
            orb_distribution: [
                KeypointDistribution::Quadtree,
                KeypointDistribution::RetainBest,
            ]
            .into_iter()
            .find(|k| k.name() == distribution),
            ..d
        })
    }
}

/// A colour image waiting for its depth or its TF.
#[derive(Debug, Clone)]
struct Pending {
    log_time: RobotTime,
    stamp_ns: u64,
    gray: GrayImage,
    depth_m: Option<Vec<f32>>,
}

/// The calibration stage (module docs).
#[derive(Debug, Clone)]
pub struct CalibrationStage {
    config: CalibrationStageConfig,
    tf: TfBuffer,
    camera: Option<CameraModel>,
    pending: Vec<Pending>,
    /// Depth images not yet paired: `(log_time, stamp_ns, depth)`.
    depth: Vec<(RobotTime, u64, Vec<f32>)>,
    /// Depth has been seen in the stream (mode rgbd).
    depth_seen: bool,
    views: Vec<CalibView>,
    captures: usize,
    tool0_from_camera: Isometry3<f64>,
    /// The covariance the calibration of `tool0_from_camera` reported (`None` for the
    /// configured mount, or a calibration without one): the drift check's `x_sigma`.
    x_covariance: Option<Matrix6<f64>>,
    last_edge_stamp: Option<u64>,
    accepted: usize,
    batch: Option<Batch>,
    /// The views of the last drift check, for an `extend`.
    last_check: Vec<CalibView>,
    /// The `check` batch the current drift check started with (before any `extend`): its
    /// views and the `X` they supported. A new reference is that `X`, taken at the poses
    /// every later check repeats.
    first_check: Option<(usize, Option<Isometry3<f64>>)>,
}

/// A batch of captures requested on `/calibration/command`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Batch {
    /// Drift check views (`check`).
    Check,
    /// Calibration views (`collect`).
    Calibrate,
}

/// How a calibration ended, for the `/task/event` answer.
#[derive(Debug, Clone, PartialEq)]
enum Outcome {
    /// Accepted: now the camera edge.
    Accepted(String),
    /// Computed but above the acceptance limits.
    NotAccepted(String),
    /// Refused (too few views, degenerate motion, ...).
    Refused(String),
}

impl CalibrationStage {
    /// A stage with `config`.
    #[must_use]
    pub fn new(config: CalibrationStageConfig) -> Self {
        Self {
            tf: TfBuffer::new(config.tf_history_ns),
            tool0_from_camera: config.nominal_tool0_from_camera,
            x_covariance: config.mount_sigma.map(|(rot_deg, trans_mm)| {
                super::hand_error::per_axis_covariance(rot_deg, trans_mm)
            }),
            config,
            camera: None,
            pending: Vec::new(),
            depth: Vec::new(),
            depth_seen: false,
            views: Vec::new(),
            captures: 0,
            last_edge_stamp: None,
            last_check: Vec::new(),
            first_check: None,
            accepted: 0,
            batch: None,
        }
    }

    /// The camera edge it publishes now (nominal until a calibration is accepted).
    #[must_use]
    pub fn tool0_from_camera(&self) -> &Isometry3<f64> {
        &self.tool0_from_camera
    }

    /// Calibrations accepted so far.
    #[must_use]
    pub fn accepted(&self) -> usize {
        self.accepted
    }

    /// Views kept for the next calibration.
    #[must_use]
    pub fn views(&self) -> usize {
        self.views.len()
    }

    /// What the camera edge in use is, for the log.
    fn edge_in_use(&self) -> &'static str {
        if self.accepted > 0 {
            "the last accepted calibration"
        } else if self.config.nominal_tool0_from_camera
            == robot::camera_mount::nominal_tool0_from_camera()
        {
            "the nominal mount"
        } else {
            "the calibration carried from an earlier run"
        }
    }

    fn log(level: u8, log_time: RobotTime, text: String) -> (String, Msg) {
        (
            topics::ROSOUT.to_owned(),
            Msg::Log(Log::line(
                STAGE_NAME,
                log_time.to_ros().unwrap_or_default(),
                level,
                text,
            )),
        )
    }

    fn invalid(topic: &str, log_time: RobotTime, reason: String) -> StageError {
        StageError::InvalidInput {
            stage: STAGE_NAME.to_owned(),
            topic: topic.to_owned(),
            log_time,
            reason,
        }
    }

    fn stamp_of(topic: &str, log_time: RobotTime, t: Time) -> Result<u64, StageError> {
        RobotTime::from_ros(t)
            .map(RobotTime::as_nanos)
            .map_err(|e| Self::invalid(topic, log_time, format!("invalid stamp: {e}")))
    }

    fn on_joint_states(
        &mut self,
        log_time: RobotTime,
        js: &JointState,
        out: &mut Vec<(String, Msg)>,
    ) -> Result<(), StageError> {
        let stamp = Self::stamp_of(topics::JOINT_STATES, log_time, js.header.stamp)?;
        if self.last_edge_stamp.is_some_and(|s| s >= stamp) {
            return Ok(());
        }
        self.last_edge_stamp = Some(stamp);
        let edge = transform_stamped(
            MOUNT_PARENT_FRAME,
            MOUNT_CHILD_FRAME,
            js.header.stamp,
            &self.tool0_from_camera,
        );
        out.push((
            topics::TF.to_owned(),
            Msg::TfMessage(TfMessage {
                transforms: vec![edge],
            }),
        ));
        Ok(())
    }

    fn on_colour(
        &mut self,
        log_time: RobotTime,
        img: &Image,
        out: &mut Vec<(String, Msg)>,
    ) -> Result<(), StageError> {
        if self.config.captures_to_solve == 0 && self.batch.is_none() {
            return Ok(());
        }
        let topic = topics::CAMERA_COLOR_IMAGE;
        let stamp_ns = Self::stamp_of(topic, log_time, img.header.stamp)?;
        let gray = match gray_from_image(topic, stamp_ns, img) {
            Ok(g) => g,
            Err(e) => {
                self.captures += 1;
                out.push(Self::log(
                    Log::WARN,
                    log_time,
                    format!("capture at {stamp_ns} ns skipped: {e}"),
                ));
                return Ok(());
            }
        };
        self.pending.push(Pending {
            log_time,
            stamp_ns,
            gray,
            depth_m: None,
        });
        Ok(())
    }

    fn on_depth(
        &mut self,
        log_time: RobotTime,
        img: &Image,
        out: &mut Vec<(String, Msg)>,
    ) -> Result<(), StageError> {
        if self.config.ignore_depth || (self.config.captures_to_solve == 0 && self.batch.is_none())
        {
            return Ok(());
        }
        let topic = topics::CAMERA_DEPTH_IMAGE;
        let stamp_ns = Self::stamp_of(topic, log_time, img.header.stamp)?;
        self.depth_seen = true;
        match depth_from_image(topic, stamp_ns, img) {
            Ok(d) => self.depth.push((log_time, stamp_ns, d)),
            Err(e) => out.push(Self::log(
                Log::WARN,
                log_time,
                format!("depth image at {stamp_ns} ns ignored: {e}"),
            )),
        }
        Ok(())
    }

    /// Pairs pending colour images with depth, resolves their hand poses, keeps or skips
    /// them (steps 1-3 of the module docs).
    fn advance(&mut self, log_time: RobotTime, out: &mut Vec<(String, Msg)>) {
        // 1. Depth pairing.
        for p in &mut self.pending {
            if p.depth_m.is_some() {
                continue;
            }
            let best = self
                .depth
                .iter()
                .enumerate()
                .filter(|(_, d)| d.1.abs_diff(p.stamp_ns) <= DEPTH_STAMP_TOLERANCE_NS)
                .min_by_key(|(k, d)| (d.1.abs_diff(p.stamp_ns), *k))
                .map(|(k, _)| k);
            if let Some(k) = best {
                p.depth_m = Some(self.depth.remove(k).2);
            }
        }
        // Depth images nobody claimed within the wait: a stamp mismatch.
        let wait = self.config.depth_wait;
        let mut kept_depth = Vec::with_capacity(self.depth.len());
        for d in std::mem::take(&mut self.depth) {
            if log_time.saturating_duration_since(d.0) > wait {
                let nearest = self
                    .pending
                    .iter()
                    .map(|p| p.stamp_ns)
                    .chain(self.views.iter().map(|v| v.stamp_ns))
                    .min_by_key(|s| s.abs_diff(d.1));
                out.push(Self::log(
                    Log::WARN,
                    log_time,
                    format!(
                        "depth image at {} ns has no colour image within {} ns (nearest colour stamp {:?} ns): ignored; the camera driver must stamp colour and registered depth with the same capture time",
                        d.1, DEPTH_STAMP_TOLERANCE_NS, nearest
                    ),
                ));
            } else {
                kept_depth.push(d);
            }
        }
        self.depth = kept_depth;

        // 2. Finalise the captures whose depth is in (or whose wait is over).
        let mut still = Vec::with_capacity(self.pending.len());
        for p in std::mem::take(&mut self.pending) {
            let waited = log_time.saturating_duration_since(p.log_time);
            let depth_ready = p.depth_m.is_some() || waited > wait;
            if !depth_ready {
                still.push(p);
                continue;
            }
            if p.depth_m.is_none() && self.depth_seen {
                self.captures += 1;
                out.push(Self::log(
                    Log::WARN,
                    log_time,
                    format!(
                        "capture at {} ns skipped: no depth image within {} ns of its stamp (the stream has depth): colour and depth must carry the same capture stamp",
                        p.stamp_ns, DEPTH_STAMP_TOLERANCE_NS
                    ),
                ));
                continue;
            }
            match self.hand_pose(p.stamp_ns) {
                Ok(pose) => {
                    self.captures += 1;
                    self.keep_or_skip(log_time, p, pose, out);
                }
                Err(e) => {
                    let tf_ahead = matches!(&e, TfError::Extrapolation { newest_ns, .. } if *newest_ns < p.stamp_ns)
                        || matches!(&e, TfError::UnknownFrame { .. });
                    if tf_ahead && waited <= self.config.tf_wait {
                        still.push(p);
                        continue;
                    }
                    self.captures += 1;
                    out.push(Self::log(
                        Log::WARN,
                        log_time,
                        format!(
                            "capture at {} ns skipped: no hand pose {} -> {} at its stamp: {e}; check that the arm's /joint_states and /tf cover the capture time",
                            p.stamp_ns, self.config.hand_parent_frame, self.config.hand_child_frame
                        ),
                    ));
                }
            }
        }
        self.pending = still;
    }

    /// Step 4 of the module docs: enough captures and none still waiting -> calibrate, then
    /// start a new batch.
    fn maybe_calibrate(&mut self, log_time: RobotTime, out: &mut Vec<(String, Msg)>) {
        let n = self.config.captures_to_solve;
        if n > 0 && self.captures >= n && self.pending.is_empty() {
            let _outcome = self.calibrate(log_time, out);
            self.captures = 0;
            self.views.clear();
        }
    }

    fn hand_pose(&self, stamp_ns: u64) -> Result<Isometry3<f64>, TfError> {
        self.tf.lookup(
            &self.config.hand_parent_frame,
            &self.config.hand_child_frame,
            stamp_ns,
        )
    }

    fn selfcal_params(&self, camera: &CameraModel) -> SelfCalParams {
        let mut p = SelfCalParams::for_method(camera, self.config.method);
        p.seed = self.config.seed;
        p.shared_hand_error = self.config.shared_hand_error;
        p.view_hand_error = self.config.view_hand_error;
        if let Some(d) = self.config.orb_distribution {
            p.orb.distribution = d;
        }
        p
    }

    fn keep_or_skip(
        &mut self,
        log_time: RobotTime,
        p: Pending,
        base_from_tool0: Isometry3<f64>,
        out: &mut Vec<(String, Msg)>,
    ) {
        let stamp_ns = p.stamp_ns;
        let Some(camera) = self.camera else {
            out.push(Self::log(
                Log::WARN,
                log_time,
                format!(
                    "capture at {stamp_ns} ns skipped: no camera_info on {} yet (the camera driver publishes it with the images)",
                    topics::CAMERA_COLOR_INFO
                ),
            ));
            return;
        };
        if p.gray.dimensions() != (camera.width, camera.height) {
            out.push(Self::log(
                Log::WARN,
                log_time,
                format!(
                    "capture at {stamp_ns} ns skipped: image {}x{}, camera_info says {}x{}",
                    p.gray.width(),
                    p.gray.height(),
                    camera.width,
                    camera.height
                ),
            ));
            return;
        }
        // Rotation spread: the nearest kept orientation.
        let nearest = self
            .views
            .iter()
            .enumerate()
            .map(|(k, v)| {
                (
                    k,
                    v.base_from_tool0
                        .rotation
                        .angle_to(&base_from_tool0.rotation)
                        .to_degrees(),
                )
            })
            .min_by(|a, b| a.1.total_cmp(&b.1));
        if let Some((k, deg)) = nearest
            && deg < self.config.min_view_rotation_deg
        {
            out.push(Self::log(
                Log::WARN,
                log_time,
                format!(
                    "capture at {stamp_ns} ns skipped: hand orientation only {deg:.3} deg from kept view {k} (< {} deg), it adds no rotation axis; rotate the wrist more between captures",
                    self.config.min_view_rotation_deg
                ),
            ));
            return;
        }
        let view = CalibView {
            stamp_ns,
            gray: p.gray,
            depth_m: p.depth_m,
            base_from_tool0,
        };
        // Enough features (dark, washed out, textureless views are useless).
        let params = self.selfcal_params(&camera);
        match extract_features(std::slice::from_ref(&view), &params) {
            Ok(_) => {}
            Err(SelfCalError::TooFewFeatures { features, need, .. }) => {
                let (mean, contrast) = intensity_stats(&view.gray);
                out.push(Self::log(
                    Log::WARN,
                    log_time,
                    format!(
                        "capture at {stamp_ns} ns skipped: only {features} ORB features (need {need}); mean intensity {mean:.1}/255, contrast {contrast:.1}: too dark, washed out or textureless; add light or point the camera at a textured surface"
                    ),
                ));
                return;
            }
            Err(e) => {
                out.push(Self::log(
                    Log::WARN,
                    log_time,
                    format!("capture at {stamp_ns} ns skipped: {e}"),
                ));
                return;
            }
        }
        self.views.push(view);
    }

    fn calibrate(&mut self, log_time: RobotTime, out: &mut Vec<(String, Msg)>) -> Outcome {
        let kept = self.views.len();
        let captures = self.captures;
        let Some(camera) = self.camera else {
            let text = format!(
                "self-calibration refused: no camera_info on {} (intrinsics are needed)",
                topics::CAMERA_COLOR_INFO
            );
            out.push(Self::log(Log::ERROR, log_time, text.clone()));
            return Outcome::Refused(text);
        };
        if kept < MIN_VIEWS {
            let text = format!(
                "self-calibration refused: too few views: {kept} of {captures} captures kept, need at least {MIN_VIEWS}; capture more views with varied wrist rotations of a textured, lit scene (see the skipped captures above)"
            );
            out.push(Self::log(Log::ERROR, log_time, text.clone()));
            return Outcome::Refused(text);
        }
        let params = self.selfcal_params(&camera);
        let result = match self_calibrate(&self.views, &camera, &params) {
            Ok(r) => r,
            Err(e) => {
                let text = format!(
                    "self-calibration refused ({kept} views of {captures} captures): {e}; the camera edge stays {}",
                    self.edge_in_use()
                );
                out.push(Self::log(Log::ERROR, log_time, text.clone()));
                return Outcome::Refused(text);
            }
        };
        let stamp = (log_time + self.config.latency)
            .to_ros()
            .unwrap_or_default();
        for m in matches_msgs(&result, &self.views, stamp) {
            out.push((
                topics::CALIBRATION_MATCHES.to_owned(),
                Msg::FeatureMatches(m),
            ));
        }
        out.push((
            topics::CALIBRATION_HAND_EYE.to_owned(),
            Msg::HandEyeCalibration(hand_eye_msg(&result, self.config.method.name(), stamp)),
        ));
        let s = &result.solution;
        let ok = s.residual_rot_deg <= self.config.max_residual_rot_deg
            && s.residual_trans_mm <= self.config.max_residual_trans_mm;
        let t = s.tool0_from_camera.translation.vector * 1e3;
        if ok {
            self.tool0_from_camera = s.tool0_from_camera;
            self.x_covariance = s.covariance;
            self.accepted += 1;
            let text = format!(
                "self-calibration accepted ({}, {} views, {} pairs): tool0_from_camera t = [{:.2}, {:.2}, {:.2}] mm, {:.3} deg; residual {:.4} deg / {:.3} mm, sigma {:.4} deg / {:.3} mm; now the camera edge",
                result.mode.name(),
                s.views,
                s.pairs,
                t.x,
                t.y,
                t.z,
                s.tool0_from_camera.rotation.angle().to_degrees(),
                s.residual_rot_deg,
                s.residual_trans_mm,
                s.sigma_rot_deg,
                s.sigma_trans_mm
            );
            out.push(Self::log(Log::INFO, log_time, text.clone()));
            Outcome::Accepted(text)
        } else {
            let text = format!(
                "self-calibration not accepted: median residual {:.4} deg / {:.3} mm above the limits {} deg / {} mm (the hand poses and the images disagree: a mount that moved during the captures, a bad scene); the camera edge is unchanged; recapture",
                s.residual_rot_deg,
                s.residual_trans_mm,
                self.config.max_residual_rot_deg,
                self.config.max_residual_trans_mm
            );
            out.push(Self::log(Log::WARN, log_time, text.clone()));
            Outcome::NotAccepted(text)
        }
    }
}

impl CalibrationStage {
    /// A `/calibration/command` (module docs, "Commands").
    fn on_command(&mut self, log_time: RobotTime, command: &str, out: &mut Vec<(String, Msg)>) {
        match command.trim() {
            c @ ("check" | "collect" | "extend") => {
                self.batch = Some(if c == "collect" {
                    Batch::Calibrate
                } else {
                    Batch::Check
                });
                self.views.clear();
                if c == "extend" {
                    self.views = std::mem::take(&mut self.last_check);
                } else {
                    self.first_check = None;
                }
                self.pending.clear();
                self.depth.clear();
                self.captures = self.views.len();
                let text = match c {
                    "check" => "check: the next captures are drift check views".to_owned(),
                    "collect" => "collect: the next captures are calibration views".to_owned(),
                    _ => format!(
                        "extend: the next captures join the last drift check's {} views",
                        self.views.len()
                    ),
                };
                out.push(Self::log(Log::INFO, log_time, text));
            }
            "solve" => {
                // Everything captured so far is in (colour and depth arrive together).
                self.advance(log_time, out);
                let batch = self.batch.take();
                let (state, kind, reason, text) = match batch {
                    Some(Batch::Check) => {
                        let (kind, reason, text) = self.check(log_time, out);
                        ("check", kind, reason, text)
                    }
                    Some(Batch::Calibrate) => {
                        let (kind, reason, text) = match self.calibrate(log_time, out) {
                            Outcome::Accepted(t) => (TaskEvent::DONE, "accepted", t),
                            Outcome::NotAccepted(t) => (TaskEvent::FAILED, "rejected", t),
                            Outcome::Refused(t) => (TaskEvent::REFUSED, "refused", t),
                        };
                        ("calibrate", kind, reason, text)
                    }
                    None => (
                        "solve",
                        TaskEvent::REFUSED,
                        "no_batch",
                        "solve without check or collect: nothing to solve".to_owned(),
                    ),
                };
                if batch == Some(Batch::Check) {
                    self.last_check = std::mem::take(&mut self.views);
                } else {
                    self.last_check.clear();
                }
                self.views.clear();
                self.captures = 0;
                out.push(self.answer(log_time, state, kind, reason, text));
            }
            "cancel" => {
                self.batch = None;
                self.views.clear();
                self.pending.clear();
                self.depth.clear();
                self.captures = 0;
            }
            other => out.push(Self::log(
                Log::WARN,
                log_time,
                format!(
                    "unknown {} {other:?}: check, collect, solve or cancel",
                    topics::CALIBRATION_COMMAND
                ),
            )),
        }
    }

    /// The drift check of the batch's views against the camera edge in use, or against the
    /// carried reference (module docs).
    fn check(
        &mut self,
        log_time: RobotTime,
        out: &mut Vec<(String, Msg)>,
    ) -> (u8, &'static str, String) {
        let Some(camera) = self.camera else {
            let text = format!(
                "drift check refused: no camera_info on {}",
                topics::CAMERA_COLOR_INFO
            );
            out.push(Self::log(Log::ERROR, log_time, text.clone()));
            return (TaskEvent::REFUSED, "cannot_tell", text);
        };
        let mut params = DriftParams {
            selfcal: super::drift::drift_front_end(self.selfcal_params(&camera)),
            ..DriftParams::default()
        };
        let reference = self.config.check_reference.filter(|_| self.accepted == 0);
        let x_source = match (&self.x_covariance, self.accepted) {
            _ if reference.is_some() => {
                params = params.against_reference();
                "a reference check at these poses carried from an earlier run: calibration.reference_*"
            }
            (Some(cov), 0) => {
                params = params.with_x_covariance(cov);
                "carried with it: calibration.mount_sigma_*"
            }
            (Some(cov), _) => {
                params = params.with_x_covariance(cov);
                "from its calibration's covariance"
            }
            (None, _) => "a typical self-calibration's: this X came with no covariance",
        };
        let compared_with = reference.unwrap_or(self.tool0_from_camera);
        let report = check_drift(&self.views, &camera, &compared_with, &params);
        let numbers = report.estimate.as_ref().map_or_else(String::new, |e| {
            format!(
                "; change {:.3} deg / {:.2} mm (at most {:.3} deg / {:.2} mm), thresholds {:.3} deg / {:.2} mm, detectable {:.3} deg / {:.2} mm",
                e.rotation_deg,
                e.translation_mm,
                e.bound_rot_deg,
                e.bound_trans_mm,
                e.threshold_rot_deg,
                e.threshold_trans_mm,
                e.detectable_rot_deg,
                e.detectable_trans_mm
            ) + &format!(
                "; the X in use is taken to be within {:.3} deg / {:.2} mm (1-sigma per axis, {x_source})",
                params.x_sigma_rot_deg, params.x_sigma_trans_mm
            )
        });
        let views = self.views.len();
        // The first batch's estimate, kept from its own solve when an `extend` followed.
        let (first, first_x) = *self
            .first_check
            .get_or_insert((views, report.estimate.as_ref().map(|e| e.tool0_from_camera)));
        let against = if reference.is_some() {
            "against the reference carried from an earlier run"
        } else {
            "against the camera edge"
        };
        let (level, kind, reason, text) = match &report.verdict {
            DriftVerdict::Consistent => {
                // Module docs: a carried reference is kept, never replaced by this estimate.
                // A new one is the estimate of the views the check started with, the poses
                // every later check repeats (not of the views an `extend` added).
                let kept = reference.or(first_x);
                if let Some(x) = kept {
                    out.push((
                        topics::CALIBRATION_CHECK_REFERENCE.to_owned(),
                        Msg::TransformStamped(transform_stamped(
                            MOUNT_PARENT_FRAME,
                            MOUNT_CHILD_FRAME,
                            (log_time + self.config.latency)
                                .to_ros()
                                .unwrap_or_default(),
                            &x,
                        )),
                    ));
                }
                (
                    Log::INFO,
                    TaskEvent::INFO,
                    "consistent",
                    format!(
                        "drift check {against}: the camera mount is where the calibration says ({views} views){numbers}; {}",
                        match (reference, kept) {
                            (Some(_), _) => {
                                "the reference stays the check's reference (rodlog calib carry)"
                                    .to_owned()
                            }
                            (None, Some(_)) if first < views => format!(
                                "the X its first {first} views support is now the check's reference (rodlog calib carry)"
                            ),
                            (None, Some(_)) => {
                                "the X these views support is now the check's reference (rodlog calib carry)"
                                    .to_owned()
                            }
                            (None, None) => format!(
                                "no reference taken: its first {first} views alone give no estimate"
                            ),
                        }
                    ),
                )
            }
            DriftVerdict::Drifted {
                rotation_deg,
                translation_mm,
            } => (
                Log::WARN,
                TaskEvent::INFO,
                "drifted",
                format!(
                    "drift check {against}: the camera mount has moved by about {rotation_deg:.2} deg / {translation_mm:.1} mm ({views} views){numbers}: recalibrate"
                ),
            ),
            DriftVerdict::CannotTell(why @ CannotTell::Unobservable { .. }) => (
                Log::WARN,
                TaskEvent::REFUSED,
                "unresolved",
                format!("drift check cannot tell ({views} views): {why}{numbers}"),
            ),
            DriftVerdict::CannotTell(why) => (
                Log::WARN,
                TaskEvent::REFUSED,
                "cannot_tell",
                format!("drift check cannot tell ({views} views): {why}{numbers}"),
            ),
        };
        out.push(Self::log(level, log_time, text.clone()));
        (kind, reason, text)
    }

    /// The answer on `/task/event` (task `calibration`).
    fn answer(
        &self,
        log_time: RobotTime,
        state: &str,
        kind: u8,
        reason: &str,
        text: String,
    ) -> (String, Msg) {
        (
            topics::TASK_EVENT.to_owned(),
            Msg::TaskEvent(TaskEvent {
                header: Header {
                    stamp: (log_time + self.config.latency)
                        .to_ros()
                        .unwrap_or_default(),
                    frame_id: MOUNT_PARENT_FRAME.to_owned(),
                },
                task: CALIBRATION_TASK.to_owned(),
                state: state.to_owned(),
                kind,
                reason_code: reason.to_owned(),
                text,
            }),
        )
    }
}

/// The `/calibration/hand_eye` message of a result, stamped `stamp`: `frame_id` `tool0`,
/// child `camera_color_optical_frame`, X = `tool0_from_camera`, the medians of the pair
/// residuals, the 1-sigma uncertainty, the conditioning and the scale; `method` names the
/// self-calibration method (`ours`, `paper`, `paper+ba`).
#[must_use]
pub fn hand_eye_msg(result: &SelfCalResult, method: &str, stamp: Time) -> HandEyeCalibration {
    let s = &result.solution;
    HandEyeCalibration {
        header: Header {
            stamp,
            frame_id: MOUNT_PARENT_FRAME.to_owned(),
        },
        child_frame_id: MOUNT_CHILD_FRAME.to_owned(),
        tool0_from_camera: transform_msg(&s.tool0_from_camera),
        method: method.to_owned(),
        mode: result.mode.name().to_owned(),
        views: u32::try_from(s.views).unwrap_or(u32::MAX),
        pairs: u32::try_from(s.pairs).unwrap_or(u32::MAX),
        residual_rot_deg: s.residual_rot_deg,
        residual_trans_mm: s.residual_trans_mm,
        sigma_rot_deg: s.sigma_rot_deg,
        sigma_trans_mm: s.sigma_trans_mm,
        condition: s.condition,
        scale: s.scale,
    }
}

/// One `/calibration/matches` message per candidate pair of `result` (in pair order): the GMS
/// inliers as keypoints `a` (view `i`) and `b` (view `j`) in full-size pixels, pairs
/// `(k, k)`; `inlier[k]` is the relative-pose RANSAC verdict (3D-3D in RGB-D, essential
/// matrix in mono): `true` only for a match consistent with the pair's estimated camera
/// motion ([`crate::selfcal::pairs::PairMatches::motion_inliers`]), all `false` for a pair
/// whose motion could not be estimated.
#[must_use]
pub fn matches_msgs(
    result: &SelfCalResult,
    views: &[CalibView],
    stamp: Time,
) -> Vec<FeatureMatches> {
    let view_stamp = |i: usize| {
        views
            .get(i)
            .and_then(|v| RobotTime::from_nanos(v.stamp_ns).to_ros().ok())
            .unwrap_or_default()
    };
    result
        .matches
        .iter()
        .map(|m| {
            let n = m.coords.len();
            let mut keypoints_a = Vec::with_capacity(2 * n);
            let mut keypoints_b = Vec::with_capacity(2 * n);
            let mut pairs = Vec::with_capacity(2 * n);
            for (k, c) in m.coords.iter().enumerate() {
                keypoints_a.extend_from_slice(&[c[0], c[1]]);
                keypoints_b.extend_from_slice(&[c[2], c[3]]);
                let k = u32::try_from(k).unwrap_or(u32::MAX);
                pairs.extend_from_slice(&[k, k]);
            }
            FeatureMatches {
                header: Header {
                    stamp,
                    frame_id: MOUNT_CHILD_FRAME.to_owned(),
                },
                stamp_a: view_stamp(m.i),
                stamp_b: view_stamp(m.j),
                method: MATCH_METHOD.to_owned(),
                keypoints_a,
                keypoints_b,
                pairs,
                inlier: (0..n)
                    .map(|k| m.motion_inliers.get(k).copied().unwrap_or(false))
                    .collect(),
            }
        })
        .collect()
}

impl Stage for CalibrationStage {
    fn name(&self) -> &str {
        STAGE_NAME
    }

    fn inputs(&self) -> Vec<String> {
        [
            topics::TF,
            topics::TF_STATIC,
            topics::JOINT_STATES,
            topics::CAMERA_COLOR_INFO,
            topics::CAMERA_COLOR_IMAGE,
            topics::CAMERA_DEPTH_IMAGE,
            topics::CLOCK,
            topics::CALIBRATION_COMMAND,
        ]
        .iter()
        .map(|t| (*t).to_owned())
        .collect()
    }

    fn outputs(&self) -> Vec<(String, &'static str)> {
        vec![
            (topics::TF.to_owned(), TfMessage::TYPE_NAME),
            (
                topics::CALIBRATION_MATCHES.to_owned(),
                FeatureMatches::TYPE_NAME,
            ),
            (
                topics::CALIBRATION_HAND_EYE.to_owned(),
                HandEyeCalibration::TYPE_NAME,
            ),
            (
                topics::CALIBRATION_CHECK_REFERENCE.to_owned(),
                TransformStamped::TYPE_NAME,
            ),
            (topics::ROSOUT.to_owned(), Log::TYPE_NAME),
            (topics::TASK_EVENT.to_owned(), TaskEvent::TYPE_NAME),
        ]
    }

    fn latency(&self) -> RobotDuration {
        self.config.latency
    }

    fn on_message(
        &mut self,
        log_time: RobotTime,
        topic: &str,
        msg: &Msg,
    ) -> Result<Vec<(String, Msg)>, StageError> {
        let mut out = Vec::new();
        let unexpected = |expected: &'static str| StageError::UnexpectedType {
            stage: STAGE_NAME.to_owned(),
            topic: topic.to_owned(),
            log_time,
            expected,
            got: msg.type_name(),
        };
        match topic {
            topics::TF | topics::TF_STATIC => {
                let Msg::TfMessage(m) = msg else {
                    return Err(unexpected(TfMessage::TYPE_NAME));
                };
                // Our own camera edge is never fed back; rejected samples (duplicates, too
                // old) only matter if a capture needs them, and then its lookup explains.
                let _rejected = self.tf.insert_message(m, topic == topics::TF_STATIC);
            }
            topics::JOINT_STATES => {
                let Msg::JointState(js) = msg else {
                    return Err(unexpected(JointState::TYPE_NAME));
                };
                self.on_joint_states(log_time, js, &mut out)?;
            }
            topics::CAMERA_COLOR_INFO => {
                let Msg::CameraInfo(info) = msg else {
                    return Err(unexpected(CameraInfo::TYPE_NAME));
                };
                if self.camera.is_none() {
                    match camera_from_info(info) {
                        Ok(c) => self.camera = Some(c),
                        Err(e) => out.push(Self::log(
                            Log::WARN,
                            log_time,
                            format!("{}: {e}", topics::CAMERA_COLOR_INFO),
                        )),
                    }
                }
            }
            topics::CAMERA_COLOR_IMAGE => {
                let Msg::Image(img) = msg else {
                    return Err(unexpected(Image::TYPE_NAME));
                };
                self.on_colour(log_time, img, &mut out)?;
            }
            topics::CAMERA_DEPTH_IMAGE => {
                let Msg::Image(img) = msg else {
                    return Err(unexpected(Image::TYPE_NAME));
                };
                self.on_depth(log_time, img, &mut out)?;
            }
            topics::CALIBRATION_COMMAND => {
                let Msg::String(c) = msg else {
                    return Err(unexpected(msgs::std_msgs::String::TYPE_NAME));
                };
                self.on_command(log_time, &c.data, &mut out);
            }
            _ => {}
        }
        if !(self.pending.is_empty() && self.depth.is_empty()) {
            self.advance(log_time, &mut out);
        }
        self.maybe_calibrate(log_time, &mut out);
        Ok(out)
    }
}
