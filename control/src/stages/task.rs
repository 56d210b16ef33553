//! The `task` stage: the hang and remove task machines of DESIGN.md s6 over the message
//! stream, with their safety gates and the self-maintenance of the hand-eye calibration.
//!
//! # Flows
//! A task is a list of steps; each step, when it starts, plans its motions from what the robot
//! has measured so far (joint states, odometry, the camera edge on `/tf`, perception results)
//! and queues *actions* (a command and the condition that completes it). The next step starts
//! when the queue is empty and the step's result is accepted.
//!
//! | hang | remove |
//! |---|---|
//! | drive to the working spot, stow the arm | same |
//! | check the calibration (drift check views), recalibrate on drift | same |
//! | grasp the rod on the rack, lift it out, carry it upright | raise to the handle, look at it, capture, fit it |
//! | raise the lift, panoramic fix of the wire, look level with it, capture 3x, fit the wire | pre-grasp, approach, grasp (the clamp joint reads the rod's jaw: coupled) |
//! | lower to the hook height behind the wire, approach across it | open the clamp (the wire is free in the hook) |
//! | close the clamp: stops at the wire contact = clamped, runs to full travel = missed (retry) | unhook (back across the wire), lower |
//! | release (back off), stow, lower | put the rod in the rack, release, stow |
//!
//! The rod stays upright throughout ([`crate::tasks::poses`]): captures are level with their
//! target and the hook reaches the wire by lowering the lift and a horizontal approach.
//!
//! # Safety
//! * **Wind** ([`WindGate`]): checked before every command; a closed gate, at the start or
//!   during the task, holds (no command) and refuses (`wind_above_limit`) after
//!   [`WindGateParams::hold_timeout`].
//! * **Perception**: a wire or handle estimate below its confidence threshold refuses
//!   (`low_confidence`), after one more look when the first was refused.
//! * **Motion**: every arm plan is IK within the joint limits, within speed and acceleration
//!   limits ([`crate::motion::trajectory`]) and collision-checked (arm, held rod, robot body,
//!   the site's obstacles and conductors, [`SiteMap::collision_world`]); every lift move is
//!   checked at 5 cm steps. An unplannable motion refuses (`unreachable`, `collision`): no
//!   unsafe command is ever issued.
//! * **Calibration**: with self-maintenance on, the task does not operate on a calibration it
//!   could not verify (`calibration_unverifiable`, e.g. too dark for features) or repair
//!   (`calibration_failed`).
//!
//! # Self-maintenance
//! Before operating, the stage asks the calibration stage for a drift check
//! (`/calibration/command` `check`, calib's [`calib::selfcal::CHECK_MOTION`] views of the site's
//! calibration target, `solve`) and waits for its verdict on `/task/event` (task
//! `calibration`, state `check`, reason `consistent` / `drifted` / `cannot_tell`). On drift,
//! and when the check cannot tell (it could miss a bump that matters), it runs the 18-view
//! calibration motion (`collect`, views, `solve`) and continues when the calibration stage
//! reports `accepted`; the new camera edge arrives on `/tf` and every later plan uses it. A
//! check that cannot tell followed by a recalibration that is not accepted refuses
//! (`calibration_unverifiable`).
//!
//! # Outputs
//! Commands (`/arm/joint_trajectory` with `/arm/planned_path`, `/lift/command`,
//! `/base/goal`, `/clamp/command`, `/camera/trigger`), `/calibration/command`,
//! `/perception/roi_cloud` and `/perception/target_pose`, and every step change on
//! `/task/event` (task `hang` or `remove`) and `/rosout`. Outputs are stamped
//! `trigger log_time + latency`; timeouts come from `/clock`. No clock, no randomness but the
//! perception's seeded RANSAC: a replay reproduces the stage byte for byte.

use msgs::builtin_interfaces::Time;
use msgs::frames::{BASE_LINK, CAMERA_COLOR_OPTICAL_FRAME, MAP, PANORAMIC_OPTICAL_FRAME, TOOL0};
use msgs::geometry_msgs::{Point, Pose, PoseStamped, Quaternion};
use msgs::nav_msgs::Path;
use msgs::rcl_interfaces::Log;
use msgs::rodlog_msgs::{ClampCommand, TaskEvent};
use msgs::sensor_msgs::{Image, JointState, PointCloud2};
use msgs::std_msgs::{Empty, Float64, Header, String as StringMsg};
use msgs::topics::{
    ARM_JOINT_TRAJECTORY, ARM_PLANNED_PATH, BASE_GOAL, CALIBRATION_COMMAND, CAMERA_COLOR_IMAGE,
    CAMERA_COLOR_INFO, CAMERA_DEPTH_IMAGE, CAMERA_TRIGGER, CLAMP_COMMAND, CLOCK, ENV_WIND,
    JOINT_STATES, LIFT_COMMAND, PANORAMIC_IMAGE, PANORAMIC_INFO, PERCEPTION_ROI_CLOUD,
    PERCEPTION_TARGET_POSE, ROSOUT, TASK_EVENT, TF, TF_STATIC,
};
use msgs::trajectory_msgs::JointTrajectory;
use msgs::{Msg, RobotDuration, RobotTime, RosMessage, Stage, StageError};
use nalgebra::{Isometry3, Point3, Vector3};
use robot::grounding_rod::{CLAMP_TRAVEL_M, WIRE_CONTACT_TRAVEL_M, rod_from_hook};
use robot::{ArmIk, IkSettings, JointKind, RobotModel, TfBuffer};

use crate::motion::collision::{ArmCollisionModel, CollisionWorld, Payload};
use crate::motion::lift::{LiftParams, choose_lift};
use crate::motion::planner::{self, ArmPlan};
use crate::motion::trajectory::DEFAULT_DT_NS;
use crate::perception::colour::{LumaImage, PendingColour};
use crate::perception::confidence::ConfidenceThresholds;
use crate::perception::handle::{HandleModel, fit_handle};
use crate::perception::panoramic::{self, PanoramicParams, RgbView};
use crate::perception::point_cloud::{DepthImage, PinholeCamera, RayTable, to_point_cloud2};
use crate::perception::roi::{PixelRoi, extract_roi};
use crate::perception::wire::{self, WireObservation, WireParams};
use crate::perception::{PerceptionError, WIRE_RADIUS_M};
use crate::tasks::calibration_views::ViewPattern;
use crate::tasks::poses;
use crate::tasks::safety::{WindGate, WindGateParams, WindVerdict};
use crate::tasks::site::{BasePose, RACK_HOLDERS, SiteMap, TARGET_WIRE, rod_capsules};

/// Stage name (channel metadata `producer=task`).
pub const STAGE_NAME: &str = "task";
/// Task name of the calibration stage's answers on `/task/event`.
pub const CALIBRATION_TASK: &str = "calibration";
/// The arm has arrived when every joint is within this of the goal (rad) and at rest.
pub const ARRIVED_RAD: f64 = 2e-3;
/// At rest: every reported joint speed below this (rad/s).
pub const AT_REST_RAD_S: f64 = 1e-3;
/// The lift has arrived within this (m) and at rest.
pub const LIFT_ARRIVED_M: f64 = 2e-3;
/// The base has arrived within this (m) and is still ([`BASE_STILL_M`]) ...
pub const BASE_ARRIVED_M: f64 = 0.02;
/// ... and this (rad).
pub const BASE_ARRIVED_RAD: f64 = 0.02;
/// The base is still when consecutive odometry samples differ by less than this (m) ...
pub const BASE_STILL_M: f64 = 1e-4;
/// ... and this (rad) ...
pub const BASE_STILL_RAD: f64 = 1e-5;
/// ... for this long.
pub const BASE_STILL_FOR: RobotDuration = RobotDuration::from_millis(300);
/// The clamp is at rest below this speed (m/s) ...
pub const CLAMP_REST_M_S: f64 = 1e-4;
/// ... for this long.
pub const CLAMP_REST_FOR: RobotDuration = RobotDuration::from_millis(300);
/// A clamp stopped within this of the wire contact travel pressed on the wire (m); beyond
/// `contact + CLAMP_CONTACT_TOLERANCE_M` it closed on nothing.
pub const CLAMP_CONTACT_TOLERANCE_M: f64 = 1.5e-3;
/// The drift check looks at this point above the calibration target's centre (m).
pub const CHECK_LOOK_ABOVE_M: f64 = 0.15;
/// Holds for a swaying handle before a look counts as failed (see [`SWAY_HOLD_S`]).
pub const MAX_SWAY_HOLDS: usize = 8;
/// One hold for a swaying handle (s).
pub const SWAY_HOLD_S: f64 = 1.5;
/// Elevations of the view of the stored rod's handle, lowest first (deg).
pub const RACK_LOOK_ELEVATIONS_DEG: [f64; 4] = [0.0, 20.0, 35.0, 50.0];
/// The stored rod's measured handle axis may be this far off the vertical (rad): 3 deg.
pub const RACK_AXIS_TOLERANCE_RAD: f64 = 3.0 * std::f64::consts::PI / 180.0;
/// Via point spacing of a move replanned as a straight tool line (m).
pub const DETOUR_LINE_STEP_M: f64 = 0.05;
/// Preferred height of `tool0` above the arm base when the lift can choose (m): the arm
/// half bent, far from the stretched and folded singularities.
pub const COMFORT_HEIGHT_M: f64 = 0.5;
/// Rise of a detour's via points above a blocked move's start and goal (m).
pub const DETOUR_RISE_M: f64 = 0.25;
/// Lift moves are collision-checked at this step (m).
pub const LIFT_CHECK_STEP_M: f64 = 0.05;

/// Which task.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TaskKind {
    /// Hang the rod on the wire.
    Hang,
    /// Remove it from the wire and put it back in the rack.
    Remove,
    /// The demo: hang the rod, then remove it again, in one run (one self-maintenance at the
    /// start). Its events carry the task of the phase (`hang`, then `remove`), each with its
    /// own `started` and end.
    Demo,
    /// Only check the hand-eye calibration (no recalibration, no operation): the drift
    /// check's verdict ends the task (`reason_code` = `consistent`, `drifted` or
    /// `cannot_tell`). For the maintenance experiment and for a check on demand.
    Check,
}

impl TaskKind {
    /// `hang` or `remove`.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Hang => "hang",
            Self::Remove => "remove",
            Self::Demo => "demo",
            Self::Check => "check",
        }
    }

    /// Parses `hang` / `remove`.
    #[must_use]
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "hang" => Some(Self::Hang),
            "remove" => Some(Self::Remove),
            "check" => Some(Self::Check),
            "demo" => Some(Self::Demo),
            _ => None,
        }
    }
}

/// Configuration of the [`TaskStage`]. Every default is documented on its field.
#[derive(Debug, Clone, PartialEq)]
pub struct TaskConfig {
    /// The task. Default hang.
    pub kind: TaskKind,
    /// The task starts at the first `/clock` at or after this. Default 1 s (the drivers'
    /// first samples, the URDF and the camera info are in by then).
    pub start_at: RobotTime,
    /// What the robot knows of the site. Default [`SiteMap::default_bay`].
    pub site: SiteMap,
    /// The robot model (nominal). Default [`RobotModel::nominal`].
    pub model: RobotModel,
    /// `tool0_from_camera` until `/tf` carries the camera edge. Default the nominal mount.
    pub nominal_tool0_from_camera: Isometry3<f64>,
    /// Check the calibration before operating and recalibrate on drift. Default true.
    pub self_maintenance: bool,
    /// Recalibration views. Default [`ViewPattern::CALIBRATION_18`].
    pub calibration_views: ViewPattern,
    /// Lift height for the calibration views (m). Default 0.4.
    pub calibration_lift_m: f64,
    /// Wind gate. Default [`WindGateParams::default`].
    pub wind: WindGateParams,
    /// Wrist camera standoff from the wire and from the handle (m). Default 0.45.
    pub standoff_m: f64,
    /// Captures of the wire fused. Default 3.
    pub wire_captures: usize,
    /// Captures of the handle fused. Default 2.
    pub handle_captures: usize,
    /// Horizontal distance of the hook's pre-approach from the wire (m). Default 0.12.
    pub approach_m: f64,
    /// Pre-grasp distance of `tool0` behind the grasp along its z (m). Default 0.2.
    pub pregrasp_m: f64,
    /// Lift of the rod out of the rack (m, > `RACK_LIFT_OUT_M` = 0.3). Default 0.35.
    pub rack_lift_out_m: f64,
    /// Slide of the rod out of the rack's holders, along the rack's -y (their open side, m).
    /// Default 0.15.
    pub rack_exit_m: f64,
    /// Back-off of `tool0` along its -z to release the rod (m). Default 0.2 (the gripper
    /// then clears the handle by its margin).
    pub release_m: f64,
    /// Via point spacing of straight-line moves (m). Default 0.02.
    pub line_step_m: f64,
    /// Clamp torque limit (N m). Default 8.
    pub clamp_torque_nm: f64,
    /// Attempts of a perception-and-act cycle (hook, grasp) before failing. Default 2.
    pub attempts: usize,
    /// An operation fails when it lasts longer than this (from its start). Default 300 s.
    pub operation_timeout: RobotDuration,
    /// Wire and handle confidence thresholds. Default [`ConfidenceThresholds::default`].
    pub thresholds: ConfidenceThresholds,
    /// Wire detection. Default [`WireParams::default`].
    pub wire: WireParams,
    /// Panoramic finder. Default [`PanoramicParams::default`].
    pub panoramic: PanoramicParams,
    /// Panoramic frames tried. Default 5.
    pub panoramic_attempts: usize,
    /// Handle model. Default [`HandleModel::default`].
    pub handle: HandleModel,
    /// Largest handle fit RMS residual accepted (m). Default 0.6 mm.
    pub handle_max_rms_m: f64,
    /// Largest disagreement of the handle centres of two captures (m). Default 3 mm.
    pub handle_max_disagreement_m: f64,
    /// Arm stow configuration (rad). Default elbow up, tool forward.
    pub stow_rad: [f64; 6],
    /// Output latency. Default 5 ms.
    pub latency: RobotDuration,
}

impl Default for TaskConfig {
    fn default() -> Self {
        Self {
            kind: TaskKind::Hang,
            start_at: RobotTime::from_millis(1000),
            site: SiteMap::default_bay(),
            model: RobotModel::nominal(),
            nominal_tool0_from_camera: robot::camera_mount::nominal_tool0_from_camera(),
            self_maintenance: true,
            calibration_views: ViewPattern::CALIBRATION_18,
            calibration_lift_m: 0.4,
            wind: WindGateParams::default(),
            standoff_m: 0.45,
            wire_captures: 3,
            handle_captures: 2,
            approach_m: 0.12,
            pregrasp_m: 0.2,
            rack_lift_out_m: 0.35,
            rack_exit_m: 0.15,
            release_m: 0.2,
            line_step_m: 0.02,
            clamp_torque_nm: 8.0,
            attempts: 2,
            operation_timeout: RobotDuration::from_secs(300),
            thresholds: ConfidenceThresholds::default(),
            wire: WireParams::default(),
            panoramic: PanoramicParams::default(),
            panoramic_attempts: 5,
            handle: HandleModel::default(),
            handle_max_rms_m: 0.000_6,
            handle_max_disagreement_m: 0.003,
            stow_rad: [0.0, 0.3, 1.9, 0.0, std::f64::consts::FRAC_PI_2, 0.0],
            latency: RobotDuration::from_millis(5),
        }
    }
}

impl TaskConfig {
    /// Reads `task.*` through `r` for a task of `kind` (`start_s`, `self_maintenance`,
    /// `standoff_m`, `wire_captures`, `handle_captures`, `approach_m`, `attempts`,
    /// `clamp_torque_nm`, `operation_timeout_s`, `wind_sigmas`, `wind_hold_timeout_s`,
    /// `min_confidence`, `latency_ms`); other fields keep [`Default`]'s.
    ///
    /// # Errors
    /// [`scenario::ParamError::Value`] for a wrong type or an out-of-range value.
    pub fn from_params(
        r: &mut scenario::Reader<'_>,
        kind: TaskKind,
    ) -> Result<Self, scenario::ParamError> {
        let d = Self::default();
        let mut s = r.section("task");
        let mut wind = d.wind;
        wind.sigmas = s.f64(
            "wind_sigmas",
            wind.sigmas,
            "",
            "hold while the wind reading plus this many sigmas of its error exceeds the limit",
        )?;
        wind.hold_timeout = s.seconds(
            "wind_hold_timeout_s",
            wind.hold_timeout,
            "refuse after holding for the wind this long",
        )?;
        let mut thresholds = d.thresholds;
        thresholds.min_score = s.f64(
            "min_confidence",
            thresholds.min_score,
            "",
            "least perception confidence acted upon",
        )?;
        Ok(Self {
            kind,
            start_at: s.time_s(
                "start_s",
                d.start_at,
                "the task starts at the first clock at or after this",
            )?,
            self_maintenance: s.bool(
                "self_maintenance",
                d.self_maintenance,
                "check the calibration before operating and recalibrate on drift",
            )?,
            standoff_m: s.f64(
                "standoff_m",
                d.standoff_m,
                "m",
                "wrist camera standoff from the wire and the handle",
            )?,
            wire_captures: s.count("wire_captures", d.wire_captures, 1, "wire captures fused")?,
            handle_captures: s.count(
                "handle_captures",
                d.handle_captures,
                1,
                "handle captures fused",
            )?,
            approach_m: s.f64(
                "approach_m",
                d.approach_m,
                "m",
                "horizontal distance of the hook's pre-approach from the wire",
            )?,
            attempts: s.count(
                "attempts",
                d.attempts,
                1,
                "attempts of a perception-and-act cycle before failing",
            )?,
            clamp_torque_nm: s.f64(
                "clamp_torque_nm",
                d.clamp_torque_nm,
                "N m",
                "clamp torque limit",
            )?,
            operation_timeout: s.seconds(
                "operation_timeout_s",
                d.operation_timeout,
                "an operation fails when it lasts longer than this",
            )?,
            latency: s.millis("latency_ms", d.latency, "stage latency")?,
            wind,
            thresholds,
            ..d
        })
    }
}

/// The steps of the flows (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Step {
    /// Before `start_at`.
    Waiting,
    /// Wind gate and announcement.
    Begin,
    /// Base to the working spot.
    Drive,
    /// Arm to the stow configuration, lift down.
    Stow,
    /// Drift check views and verdict.
    CheckCalibration,
    /// 18 calibration views and the new calibration.
    Recalibrate,
    /// Hang: the wrist camera level with the stored rod's handle.
    LookRack,
    /// Hang: handle captures and the stored rod's pose (the base's odometry drifts by
    /// millimetres on the way; the gripper's capture is 5 mm).
    CaptureRack,
    /// Hang: pre-grasp and grasp at the rack.
    GraspRack,
    /// Hang: lift the rod out of the rack and slide it out of the holders.
    LiftOut,
    /// Hang: raise the lift to the look height.
    RaiseForLook,
    /// Hang: panoramic fix of the wire.
    Panoramic,
    /// Hang: the wrist camera level with the wire.
    LookWire,
    /// Hang: wire captures and the estimate.
    CaptureWire,
    /// Hang: arm to the pre-approach, lift down to the hook height.
    ToPreApproach,
    /// Hang: straight approach across the wire.
    Approach,
    /// Hang: close the clamp and judge contact.
    CloseClamp,
    /// Hang: back off the handle.
    Release,
    /// Remove: the wrist camera level with the handle.
    LookHandle,
    /// Remove: handle captures and the estimate.
    CaptureHandle,
    /// Remove: pre-grasp, grasp, coupling check.
    GraspHandle,
    /// Remove: open the clamp.
    OpenClamp,
    /// Remove: back the hook off the wire and lower.
    Unhook,
    /// Remove: into the rack and release.
    Rack,
    /// Back off after a miss, then retry from an earlier step.
    Recover,
    /// Arm stowed, lift down.
    Retreat,
    /// Ended (done, refused or failed).
    Finished,
}

impl Step {
    /// The `/task/event` state name.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Waiting => "waiting",
            Self::Begin => "begin",
            Self::Drive => "drive",
            Self::Stow => "stow",
            Self::CheckCalibration => "check_calibration",
            Self::Recalibrate => "recalibrate",
            Self::LookRack => "look_rack",
            Self::CaptureRack => "capture_rack",
            Self::GraspRack => "grasp_rack",
            Self::LiftOut => "lift_out",
            Self::RaiseForLook => "raise_for_look",
            Self::Panoramic => "panoramic",
            Self::LookWire => "look_wire",
            Self::CaptureWire => "capture_wire",
            Self::ToPreApproach => "to_pre_approach",
            Self::Approach => "approach",
            Self::CloseClamp => "close_clamp",
            Self::Release => "release",
            Self::LookHandle => "look_handle",
            Self::CaptureHandle => "capture_handle",
            Self::GraspHandle => "grasp_handle",
            Self::OpenClamp => "open_clamp",
            Self::Unhook => "unhook",
            Self::Rack => "rack",
            Self::Recover => "recover",
            Self::Retreat => "retreat",
            Self::Finished => "finished",
        }
    }
}

/// How a task ends early.
#[derive(Debug, Clone, PartialEq)]
pub struct Stop {
    /// [`TaskEvent::REFUSED`] or [`TaskEvent::FAILED`].
    pub kind: u8,
    /// Machine-readable reason.
    pub reason_code: &'static str,
    /// What happened and what to do.
    pub text: String,
}

impl Stop {
    fn refused(reason_code: &'static str, text: impl Into<String>) -> Self {
        Self {
            kind: TaskEvent::REFUSED,
            reason_code,
            text: text.into(),
        }
    }

    fn failed(reason_code: &'static str, text: impl Into<String>) -> Self {
        Self {
            kind: TaskEvent::FAILED,
            reason_code,
            text: text.into(),
        }
    }
}

/// What completes an action.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Until {
    /// Nothing: done when issued.
    Issued,
    /// The arm at rest at this configuration.
    Arm([f64; 6]),
    /// The lift at rest at this height.
    Lift(f64),
    /// The base at this pose (odometry).
    Base(BasePose),
    /// The clamp at rest after moving.
    ClampRest,
    /// A wrist capture (colour and depth) stamped after the trigger.
    Capture,
    /// A panoramic frame after the action started.
    Panoramic,
    /// The calibration stage's answer.
    Calibration,
    /// This long after the action started (a hold).
    Elapsed(RobotDuration),
}

/// One queued action.
#[derive(Debug, Clone)]
struct Action {
    /// Outputs issued when the action starts (commands are wind-gated).
    outputs: Vec<(String, Msg)>,
    /// Whether the outputs include a command (the wind gate applies).
    command: bool,
    until: Until,
    timeout: RobotDuration,
    label: &'static str,
}

/// The action being executed.
#[derive(Debug, Clone)]
struct Running {
    action: Action,
    started: RobotTime,
}

/// A wrist capture taken during a step.
#[derive(Debug, Clone)]
struct Capture {
    depth: DepthImage,
    /// The registered colour image of the same stamp, when one came.
    colour: Option<LumaImage>,
    base_from_camera: Isometry3<f64>,
    stamp: Time,
}

/// Where a handle is looked for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum HandleSite {
    /// The stored rod in the rack (hang).
    Rack,
    /// The rod hung on the wire (remove).
    Wire,
}

/// What the robot believes about the rod.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Rod {
    /// In the rack.
    OnRack,
    /// In the gripper.
    Held,
    /// On the wire at this `base_from_rod` (estimated).
    OnWire(Isometry3<f64>),
    /// Not known yet (remove: before the handle is measured).
    Unknown,
}

/// The `task` stage (module docs).
#[derive(Debug)]
pub struct TaskStage {
    config: TaskConfig,
    ik: ArmIk,
    arm: ArmCollisionModel,
    tf: TfBuffer,
    gate: WindGate,
    wrist: Option<(PinholeCamera, RayTable)>,
    panoramic_camera: Option<PinholeCamera>,
    q: Option<[f64; 6]>,
    arm_at_rest: bool,
    lift_m: Option<f64>,
    lift_speed_m_s: f64,
    clamp_m: Option<f64>,
    clamp_speed_m_s: f64,
    clamp_rest_since: Option<RobotTime>,
    odometry: Option<(RobotTime, BasePose)>,
    odometry_stamp_ns: Option<u64>,
    base_still_since: Option<RobotTime>,
    step: Step,
    queue: Vec<Action>,
    running: Option<Running>,
    holding_since: Option<RobotTime>,
    /// Time spent in finished wind holds this operation.
    held_for_wind: RobotDuration,
    began: Option<RobotTime>,
    rod: Rod,
    attempts: usize,
    captures: Vec<Capture>,
    colour: PendingColour,
    panoramic_image: Option<Image>,
    calibration_answer: Option<TaskEvent>,
    /// Why the drift check could not tell, while the recalibration that answers it runs.
    unverified_check: Option<String>,
    wire_fix_in_map: Option<(Point3<f64>, Vector3<f64>)>,
    wire_in_base: Option<(Point3<f64>, Vector3<f64>)>,
    hook_goal: Option<Isometry3<f64>>,
    grasp_goal: Option<Isometry3<f64>>,
    /// `map_from_rod` of the stored rod as the wrist camera saw it.
    stored_rod_seen: Option<Isometry3<f64>>,
    /// Holds for a swaying handle so far.
    sway_holds: usize,
    look_lift_m: Option<f64>,
    panoramic_tries: usize,
    recovery: Option<(Vec<Action>, Step)>,
    pending: Vec<(String, Msg)>,
    done_reason: &'static str,
    done_text: String,
    /// The operation under way: the configured task, or hang then remove for the demo.
    phase: TaskKind,
    now: RobotTime,
}

fn time_ns(t: &Time) -> u64 {
    u64::try_from(t.sec).unwrap_or(0) * 1_000_000_000 + u64::from(t.nanosec)
}

fn base_pose_of(map_from_base: &Isometry3<f64>) -> BasePose {
    BasePose {
        x_m: map_from_base.translation.x,
        y_m: map_from_base.translation.y,
        yaw_rad: map_from_base.rotation.euler_angles().2,
    }
}

impl TaskStage {
    /// A stage with `config`.
    ///
    /// # Errors
    /// [`StageError::Failed`] when the model's IK cannot be built.
    pub fn new(config: TaskConfig) -> Result<Self, StageError> {
        let ik = config
            .model
            .arm_ik(IkSettings::default())
            .map_err(|e| StageError::Failed {
                stage: STAGE_NAME.to_owned(),
                log_time: RobotTime::ZERO,
                reason: e.to_string(),
            })?;
        let arm = ArmCollisionModel {
            model: config.model.clone(),
            ..ArmCollisionModel::nominal()
        };
        let rod = match config.kind {
            TaskKind::Hang | TaskKind::Demo => Rod::OnRack,
            TaskKind::Remove | TaskKind::Check => Rod::Unknown,
        };
        let phase = if config.kind == TaskKind::Demo {
            TaskKind::Hang
        } else {
            config.kind
        };
        Ok(Self {
            gate: WindGate::new(config.wind),
            config,
            ik,
            arm,
            tf: TfBuffer::default(),
            wrist: None,
            panoramic_camera: None,
            q: None,
            arm_at_rest: false,
            lift_m: None,
            lift_speed_m_s: 0.0,
            clamp_m: None,
            clamp_speed_m_s: 0.0,
            clamp_rest_since: None,
            odometry: None,
            odometry_stamp_ns: None,
            base_still_since: None,
            step: Step::Waiting,
            queue: Vec::new(),
            running: None,
            holding_since: None,
            held_for_wind: RobotDuration::ZERO,
            began: None,
            rod,
            attempts: 0,
            captures: Vec::new(),
            colour: PendingColour::default(),
            panoramic_image: None,
            calibration_answer: None,
            unverified_check: None,
            wire_fix_in_map: None,
            wire_in_base: None,
            hook_goal: None,
            grasp_goal: None,
            stored_rod_seen: None,
            sway_holds: 0,
            look_lift_m: None,
            panoramic_tries: 0,
            recovery: None,
            pending: Vec::new(),
            done_reason: "done",
            done_text: String::new(),
            phase,
            now: RobotTime::ZERO,
        })
    }

    /// The current step.
    #[must_use]
    pub fn step(&self) -> Step {
        self.step
    }

    // ---------------------------------------------------------------- messages out

    fn stamp(&self) -> Time {
        (self.now + self.config.latency)
            .to_ros()
            .unwrap_or_default()
    }

    fn header(&self, frame: &str) -> Header {
        Header {
            stamp: self.stamp(),
            frame_id: frame.to_owned(),
        }
    }

    fn event(&self, kind: u8, state: &str, reason_code: &str, text: String) -> Vec<(String, Msg)> {
        let level = match kind {
            TaskEvent::REFUSED => Log::WARN,
            TaskEvent::FAILED => Log::ERROR,
            _ => Log::INFO,
        };
        let task = self.phase.name();
        let log = Log {
            stamp: self.stamp(),
            level,
            name: STAGE_NAME.to_owned(),
            msg: if reason_code.is_empty() {
                format!("{task} {state}: {text}")
            } else {
                format!("{task} {state} [{reason_code}]: {text}")
            },
            file: file!().to_owned(),
            function: String::new(),
            line: 0,
        };
        let event = TaskEvent {
            header: self.header(BASE_LINK),
            task: task.to_owned(),
            state: state.to_owned(),
            kind,
            reason_code: reason_code.to_owned(),
            text,
        };
        vec![
            (TASK_EVENT.to_owned(), event.into()),
            (ROSOUT.to_owned(), log.into()),
        ]
    }

    fn elapsed_s(&self) -> f64 {
        self.began
            .map_or(0.0, |b| self.now.saturating_duration_since(b).as_secs_f64())
    }

    // ---------------------------------------------------------------- robot state

    fn q(&self) -> Result<[f64; 6], Stop> {
        self.q
            .ok_or_else(|| Stop::failed("no_joint_states", "no arm /joint_states yet"))
    }

    fn lift(&self) -> Result<f64, Stop> {
        self.lift_m
            .ok_or_else(|| Stop::failed("no_joint_states", "no lift /joint_states yet"))
    }

    fn base_from_map(&self) -> Result<Isometry3<f64>, Stop> {
        self.tf
            .lookup_latest(BASE_LINK, MAP)
            .map(|(_, t)| t)
            .map_err(|e| Stop::failed("no_odometry", format!("no map -> base_link: {e}")))
    }

    fn tool0_from_camera(&self, stamp_ns: u64) -> Isometry3<f64> {
        self.tf
            .lookup(TOOL0, CAMERA_COLOR_OPTICAL_FRAME, stamp_ns)
            .or_else(|_| {
                self.tf
                    .lookup_latest(TOOL0, CAMERA_COLOR_OPTICAL_FRAME)
                    .map(|(_, t)| t)
            })
            .unwrap_or(self.config.nominal_tool0_from_camera)
    }

    fn arm_base_point(&self, lift_m: f64) -> Point3<f64> {
        self.config.model.base_from_arm_base(lift_m) * Point3::origin()
    }

    fn arm_model(&self) -> ArmCollisionModel {
        if self.rod == Rod::Held {
            self.arm.carrying(Payload::grounding_rod())
        } else {
            self.arm.clone()
        }
    }

    /// The collision world in `base_link` at lift `lift_m`: site, robot body, the rod where
    /// the robot believes it is (when not held).
    fn world(&self, lift_m: f64) -> Result<CollisionWorld, Stop> {
        self.world_for(lift_m, self.rod)
    }

    /// [`Self::world`] with the rod at `rod`.
    fn world_for(&self, lift_m: f64, rod: Rod) -> Result<CollisionWorld, Stop> {
        let base_from_map = self.base_from_map()?;
        let wire = self.wire_in_base.map(|(p, d)| {
            let map_from_base = base_from_map.inverse();
            let half = d.normalize() * 3.0;
            (map_from_base * (p - half), map_from_base * (p + half))
        });
        let mut world = self.config.site.collision_world(&base_from_map, wire);
        world.extend(&CollisionWorld::robot_body(&self.config.model, lift_m));
        match rod {
            Rod::OnRack => {
                for (name, c) in self.config.site.stored_rod_capsules() {
                    world.capsules.push((
                        name,
                        crate::motion::collision::Capsule {
                            a: base_from_map * c.a,
                            b: base_from_map * c.b,
                            radius_m: c.radius_m,
                        },
                    ));
                }
            }
            Rod::OnWire(base_from_rod) => {
                world.capsules.extend(rod_capsules(&base_from_rod, "hung_"));
            }
            Rod::Held | Rod::Unknown => {}
        }
        Ok(world)
    }

    // ---------------------------------------------------------------- planning

    fn ik_goal(
        &self,
        lift_m: f64,
        base_from_tool0: &Isometry3<f64>,
        seed: &[f64; 6],
    ) -> Result<[f64; 6], Stop> {
        let target = self.config.model.arm_base_from_base(lift_m) * base_from_tool0;
        self.ik
            .nearest(&target, seed)
            .map(|s| s.q_rad)
            .map_err(|e| {
                Stop::refused(
                    "unreachable",
                    format!("tool0 goal not reachable at lift {lift_m:.3} m: {e}"),
                )
            })
    }

    /// A checked joint-space plan from `q0` through `waypoints` at `lift_m`.
    fn plan(
        &self,
        world: &CollisionWorld,
        lift_m: f64,
        q0: &[f64; 6],
        waypoints: &[[f64; 6]],
        what: &str,
    ) -> Result<ArmPlan, Stop> {
        planner::plan_through(
            &self.arm_model(),
            world,
            lift_m,
            q0,
            waypoints,
            DEFAULT_DT_NS,
        )
        .map_err(|e| {
            let code = if matches!(e, crate::motion::MotionError::Collision { .. }) {
                "collision"
            } else {
                "unreachable"
            };
            Stop::refused(code, format!("{what}: {e}"))
        })
    }

    /// A checked joint-space move from `q0` to the configuration `goal_q` (whose tool pose
    /// is `goal`): directly when that is collision-free, else through detours lifted above
    /// the start and the goal ([`DETOUR_RISE_M`] and twice that), the first that is free.
    fn plan_move(
        &self,
        world: &CollisionWorld,
        lift_m: f64,
        q0: &[f64; 6],
        goal_q: &[f64; 6],
        what: &str,
    ) -> Result<ArmPlan, Stop> {
        let direct = match self.plan(world, lift_m, q0, &[*goal_q], what) {
            Ok(plan) => return Ok(plan),
            Err(stop) if stop.reason_code == "collision" => stop,
            Err(stop) => return Err(stop),
        };
        let start = self.config.model.base_from_tool0(lift_m, q0);
        let goal = self.config.model.base_from_tool0(lift_m, goal_q);
        // The tool along the straight line (the held rod keeps its attitude).
        if let Ok(line) = self.line_waypoints_every(lift_m, q0, &goal, DETOUR_LINE_STEP_M)
            && let Ok(plan) = self.plan(world, lift_m, q0, &line, what)
        {
            return Ok(plan);
        }
        let up = |pose: &Isometry3<f64>, rise: f64| Isometry3::translation(0.0, 0.0, rise) * *pose;
        for rise in [DETOUR_RISE_M, 2.0 * DETOUR_RISE_M] {
            let candidates = [
                vec![up(&goal, rise)],
                vec![up(&start, rise), up(&goal, rise)],
            ];
            for poses in candidates {
                let mut seed = *q0;
                let mut via = Vec::with_capacity(poses.len() + 1);
                let mut ok = true;
                for p in &poses {
                    match self.ik_goal(lift_m, p, &seed) {
                        Ok(q) => {
                            via.push(q);
                            seed = q;
                        }
                        Err(_) => {
                            ok = false;
                            break;
                        }
                    }
                }
                if !ok {
                    continue;
                }
                via.push(*goal_q);
                if let Ok(plan) = self.plan(world, lift_m, q0, &via, what) {
                    return Ok(plan);
                }
            }
        }
        Err(direct)
    }

    /// Via points of the straight line from `q0`'s pose to `goal` (tool0 in `base_link`),
    /// every [`TaskConfig::line_step_m`], each the IK solution nearest the previous.
    fn line_waypoints(
        &self,
        lift_m: f64,
        q0: &[f64; 6],
        goal: &Isometry3<f64>,
    ) -> Result<Vec<[f64; 6]>, Stop> {
        self.line_waypoints_every(lift_m, q0, goal, self.config.line_step_m)
    }

    /// [`Self::line_waypoints`] with via points every `step_m` (and 2.5 deg per 0.02 m).
    fn line_waypoints_every(
        &self,
        lift_m: f64,
        q0: &[f64; 6],
        goal: &Isometry3<f64>,
        step_m: f64,
    ) -> Result<Vec<[f64; 6]>, Stop> {
        let start = self.config.model.base_from_tool0(lift_m, q0);
        let length = (goal.translation.vector - start.translation.vector).norm();
        let angle = start.rotation.angle_to(&goal.rotation);
        let step_rad = (2.5f64 * step_m / 0.02).to_radians();
        let n = ((length / step_m.max(1e-3)).ceil())
            .max((angle / step_rad).ceil())
            .max(1.0) as usize;
        let mut out = Vec::with_capacity(n);
        let mut seed = *q0;
        for k in 1..=n {
            let pose = robot::se3::interpolate(&start, goal, k as f64 / n as f64);
            let q = self.ik_goal(lift_m, &pose, &seed)?;
            let jump = (0..6).map(|j| (q[j] - seed[j]).abs()).fold(0.0, f64::max);
            if jump > 0.3 {
                return Err(Stop::refused(
                    "unreachable",
                    format!("straight line: branch jump of {jump:.3} rad at via point {k}/{n}"),
                ));
            }
            out.push(q);
            seed = q;
        }
        Ok(out)
    }

    /// The lift move from `from_m` to `to_m` with the arm at `q` is collision-free.
    fn check_lift_move(
        &self,
        q: &[f64; 6],
        from_m: f64,
        to_m: f64,
        allowed: &[(&'static str, &str)],
    ) -> Result<(), Stop> {
        let steps = ((to_m - from_m).abs() / LIFT_CHECK_STEP_M).ceil().max(1.0) as usize;
        let arm = self.arm_model();
        for k in 0..=steps {
            let lift = from_m + (to_m - from_m) * k as f64 / steps as f64;
            let mut world = self.world(lift)?;
            for (b, o) in allowed {
                world = world.allowing(b, o);
            }
            let (clearance, link, obstacle) = arm.clearance(&world, lift, q);
            if clearance < arm.margin_m {
                return Err(Stop::refused(
                    "collision",
                    format!(
                        "lift move {from_m:.3} -> {to_m:.3} m: {link} vs {obstacle} at lift {lift:.3} m, clearance {clearance:.3} m"
                    ),
                ));
            }
        }
        Ok(())
    }

    fn arm_action(&self, plan: &ArmPlan, label: &'static str) -> Action {
        let header = self.header(BASE_LINK);
        let goal = plan.waypoints.last().copied().unwrap_or([0.0; 6]);
        let traj = planner::plan_trajectory_msg(plan, header.clone());
        let path = planner::plan_path_msg(plan, &self.config.model, header);
        let duration = plan.trajectory.duration_s();
        Action {
            outputs: vec![
                (ARM_JOINT_TRAJECTORY.to_owned(), traj.into()),
                (ARM_PLANNED_PATH.to_owned(), path.into()),
            ],
            command: true,
            until: Until::Arm(goal),
            timeout: RobotDuration::from_secs_f64(duration * 1.5 + 5.0)
                .unwrap_or(RobotDuration::from_secs(60)),
            label,
        }
    }

    fn lift_action(&self, from_m: f64, to_m: f64, label: &'static str) -> Action {
        // Goals come from measured heights too, whose noise may step out of the travel.
        let to_m = to_m.clamp(0.0, robot::kinematics::LIFT_TRAVEL_M);
        let seconds = (to_m - from_m).abs() / robot::kinematics::LIFT_SPEED_MAX_M_S
            + 2.0 * robot::kinematics::LIFT_SPEED_MAX_M_S / robot::kinematics::LIFT_ACCEL_MAX_M_S2;
        Action {
            outputs: vec![(LIFT_COMMAND.to_owned(), Float64 { data: to_m }.into())],
            command: true,
            until: Until::Lift(to_m),
            timeout: RobotDuration::from_secs_f64(seconds * 1.5 + 5.0)
                .unwrap_or(RobotDuration::from_secs(60)),
            label,
        }
    }

    fn clamp_action(&self, action: u8, label: &'static str) -> Action {
        Action {
            outputs: vec![(
                CLAMP_COMMAND.to_owned(),
                ClampCommand {
                    header: self.header(""),
                    action,
                    max_torque_nm: self.config.clamp_torque_nm,
                }
                .into(),
            )],
            command: true,
            until: Until::ClampRest,
            timeout: RobotDuration::from_secs(25),
            label,
        }
    }

    fn capture_action(&self, label: &'static str) -> Action {
        Action {
            outputs: vec![(CAMERA_TRIGGER.to_owned(), Empty.into())],
            command: true,
            until: Until::Capture,
            timeout: RobotDuration::from_secs(5),
            label,
        }
    }

    fn calibration_command(&self, data: &str, until: Until, label: &'static str) -> Action {
        Action {
            outputs: vec![(
                CALIBRATION_COMMAND.to_owned(),
                StringMsg {
                    data: data.to_owned(),
                }
                .into(),
            )],
            command: false,
            until,
            timeout: RobotDuration::from_secs(30),
            label,
        }
    }

    // ---------------------------------------------------------------- steps

    /// The step after `step` in the task's flow.
    fn next_step(&self, step: Step) -> Step {
        use Step::*;
        let maintenance = self.config.self_maintenance;
        match (self.phase, step) {
            (_, Waiting) => Begin,
            (_, Begin) => Drive,
            (_, Drive) => Stow,
            (TaskKind::Check, Stow) => CheckCalibration,
            (TaskKind::Check, CheckCalibration) => Retreat,
            (_, Stow) if maintenance => CheckCalibration,
            (TaskKind::Hang, Stow | CheckCalibration | Recalibrate) => LookRack,
            (TaskKind::Hang, LookRack) => CaptureRack,
            (TaskKind::Hang, CaptureRack) => GraspRack,
            (TaskKind::Remove, Stow | CheckCalibration | Recalibrate) => LookHandle,
            (TaskKind::Hang, GraspRack) => LiftOut,
            (TaskKind::Hang, LiftOut) => RaiseForLook,
            (TaskKind::Hang, RaiseForLook) => Panoramic,
            (TaskKind::Hang, Panoramic) => LookWire,
            (TaskKind::Hang, LookWire) => CaptureWire,
            (TaskKind::Hang, CaptureWire) => ToPreApproach,
            (TaskKind::Hang, ToPreApproach) => Approach,
            (TaskKind::Hang, Approach) => CloseClamp,
            (TaskKind::Hang, CloseClamp) => Release,
            (TaskKind::Hang, Release) => Retreat,
            // The demo: the hang's retreat hands over to the remove.
            (TaskKind::Hang, Retreat) if self.config.kind == TaskKind::Demo => LookHandle,
            (TaskKind::Remove, LookHandle) => CaptureHandle,
            (TaskKind::Remove, CaptureHandle) => GraspHandle,
            (TaskKind::Remove, GraspHandle) => OpenClamp,
            (TaskKind::Remove, OpenClamp) => Unhook,
            (TaskKind::Remove, Unhook) => Rack,
            (TaskKind::Remove, Rack) => Retreat,
            _ => Finished,
        }
    }

    /// Plans the step's actions.
    fn plan_step(&mut self, step: Step) -> Result<Vec<Action>, Stop> {
        match step {
            Step::Waiting | Step::Finished => Ok(Vec::new()),
            Step::Begin => {
                let verdict = self.gate.verdict(self.now);
                match verdict {
                    WindVerdict::Open { .. } => Ok(Vec::new()),
                    // A gust at the start is waited out like one during the task: a
                    // wind-gated action that sends nothing holds until the gate opens and
                    // refuses (`wind_above_limit`) after the hold timeout.
                    WindVerdict::TooWindy { .. } => Ok(vec![Action {
                        outputs: Vec::new(),
                        command: true,
                        until: Until::Elapsed(RobotDuration::ZERO),
                        timeout: RobotDuration::from_secs(5),
                        label: "wait for the wind to drop",
                    }]),
                    WindVerdict::NoReading { .. } => Err(Stop::refused(
                        "no_wind_reading",
                        format!(
                            "{}: the anemometer must report before operating",
                            verdict.describe()
                        ),
                    )),
                }
            }
            Step::Drive => {
                let spot = self.config.site.work_spot;
                let map_from_base = self.base_from_map()?.inverse();
                let here = base_pose_of(&map_from_base);
                let distance = (spot.x_m - here.x_m).hypot(spot.y_m - here.y_m);
                if distance < BASE_ARRIVED_M
                    && robot::se3::wrap_to_pi(spot.yaw_rad - here.yaw_rad).abs() < BASE_ARRIVED_RAD
                {
                    return Ok(Vec::new());
                }
                let goal = PoseStamped {
                    header: self.header(MAP),
                    pose: pose_msg(&spot.isometry()),
                };
                let seconds = distance / 0.5 + std::f64::consts::TAU / 0.6;
                Ok(vec![Action {
                    outputs: vec![(BASE_GOAL.to_owned(), goal.into())],
                    command: true,
                    until: Until::Base(spot),
                    timeout: RobotDuration::from_secs_f64(seconds * 1.5 + 10.0)
                        .unwrap_or(RobotDuration::from_secs(120)),
                    label: "base to the working spot",
                }])
            }
            Step::Stow => self.plan_stow(),
            Step::CheckCalibration => self.plan_views(true),
            Step::Recalibrate => self.plan_views(false),
            Step::GraspRack => self.plan_grasp_rack(),
            Step::LiftOut => self.plan_lift_out(),
            Step::RaiseForLook => self.plan_raise_for_look(),
            Step::Panoramic => Ok(vec![Action {
                outputs: Vec::new(),
                command: false,
                until: Until::Panoramic,
                timeout: RobotDuration::from_secs(5),
                label: "panoramic frame",
            }]),
            Step::LookWire => self.plan_look_wire(),
            Step::LookRack => self.plan_look_handle(HandleSite::Rack),
            Step::CaptureWire | Step::CaptureHandle | Step::CaptureRack => {
                self.captures.clear();
                let n = if step == Step::CaptureWire {
                    self.config.wire_captures
                } else {
                    self.config.handle_captures
                };
                Ok((0..n.max(1))
                    .map(|_| self.capture_action("wrist capture"))
                    .collect())
            }
            Step::ToPreApproach => self.plan_to_pre_approach(),
            Step::Approach => self.plan_approach(),
            Step::CloseClamp => Ok(vec![
                self.clamp_action(ClampCommand::CLOSE, "close the clamp"),
            ]),
            Step::Release => self.plan_release(),
            Step::LookHandle => self.plan_look_handle(HandleSite::Wire),
            Step::GraspHandle => self.plan_grasp_handle(),
            Step::OpenClamp => Ok(vec![
                self.clamp_action(ClampCommand::OPEN, "open the clamp"),
            ]),
            Step::Unhook => self.plan_unhook(),
            Step::Rack => self.plan_rack(),
            Step::Retreat => self.plan_retreat(),
            Step::Recover => Ok(self
                .recovery
                .as_ref()
                .map(|(a, _)| a.clone())
                .unwrap_or_default()),
        }
    }

    fn plan_stow(&mut self) -> Result<Vec<Action>, Stop> {
        let q = self.q()?;
        let lift = self.lift()?;
        let mut actions = Vec::new();
        let world = self.world(lift)?;
        let stow = self.config.stow_rad;
        if (0..6).any(|j| (q[j] - stow[j]).abs() > ARRIVED_RAD) {
            let plan = self.plan_move(&world, lift, &q, &stow, "stow")?;
            actions.push(self.arm_action(&plan, "arm to stow"));
        }
        if lift > LIFT_ARRIVED_M {
            self.check_lift_move(&stow, lift, 0.0, &[])?;
            actions.push(self.lift_action(lift, 0.0, "lift down"));
        }
        Ok(actions)
    }

    /// Drift check (`check = true`: calib's [`calib::selfcal::CHECK_MOTION`]) or calibration
    /// views ([`TaskConfig::calibration_views`]) of the site's calibration target.
    fn plan_views(&mut self, check: bool) -> Result<Vec<Action>, Stop> {
        let base_from_map = self.base_from_map()?;
        let centre = base_from_map * self.config.site.calibration_target;
        let normal = base_from_map.rotation * self.config.site.calibration_normal;
        let cameras = if check {
            // The target frame: origin on the face, z the outward normal, x horizontal so
            // that the images are upright (camera y towards the ground).
            let look_at = centre + Vector3::new(0.0, 0.0, CHECK_LOOK_ABOVE_M);
            let x = Vector3::z()
                .cross(&normal)
                .try_normalize(1e-9)
                .ok_or_else(|| {
                    Stop::failed(
                        "bad_site_map",
                        "the calibration target's normal is vertical",
                    )
                })?;
            let target = Isometry3::from_parts(
                nalgebra::Translation3::from(look_at.coords),
                nalgebra::UnitQuaternion::from_rotation_matrix(
                    &nalgebra::Rotation3::from_basis_unchecked(&[x, normal.cross(&x), normal]),
                ),
            );
            calib::selfcal::drift::check_camera_poses(&target, &calib::selfcal::CHECK_MOTION)
        } else {
            self.config
                .calibration_views
                .camera_poses(&centre, &normal)
                .ok_or_else(|| {
                    Stop::failed(
                        "bad_site_map",
                        "the calibration target's normal is vertical or zero",
                    )
                })?
        };
        let lift = self.config.calibration_lift_m;
        let q0 = self.q()?;
        let lift0 = self.lift()?;
        let mut actions = Vec::new();
        if (lift0 - lift).abs() > LIFT_ARRIVED_M {
            self.check_lift_move(&q0, lift0, lift, &[])?;
            actions.push(self.lift_action(lift0, lift, "lift to the calibration height"));
        }
        actions.push(self.calibration_command(
            if check { "check" } else { "collect" },
            Until::Issued,
            "calibration batch",
        ));
        let world = self.world(lift)?;
        let mount = self.tool0_from_camera(self.now.as_nanos());
        let mut q = q0;
        for (k, base_from_camera) in cameras.iter().enumerate() {
            let goal = base_from_camera * mount.inverse();
            let qk = self.ik_goal(lift, &goal, &q)?;
            let plan = self
                .plan(
                    &world,
                    lift,
                    &q,
                    &[qk],
                    if check {
                        "drift check view"
                    } else {
                        "calibration view"
                    },
                )
                .map_err(|mut s| {
                    s.text = format!("view {k}: {}", s.text);
                    s
                })?;
            actions.push(self.arm_action(&plan, "arm to a view"));
            actions.push(self.capture_action("view capture"));
            q = qk;
        }
        // Back to stow and the lift height the step began at, so that the next step plans
        // from the pose it would have started from without self-maintenance.
        let stow = self.config.stow_rad;
        let plan = self.plan_move(&world, lift, &q, &stow, "stow after the views")?;
        actions.push(self.arm_action(&plan, "arm to stow"));
        if (lift0 - lift).abs() > LIFT_ARRIVED_M {
            self.check_lift_move(&stow, lift, lift0, &[])?;
            actions.push(self.lift_action(lift, lift0, "lift back"));
        }
        self.calibration_answer = None;
        actions.push(self.calibration_command("solve", Until::Calibration, "calibration answer"));
        Ok(actions)
    }

    /// The stored rod: as seen by the wrist camera when it was, otherwise the site map's.
    fn stored_rod_in_base(&self) -> Result<Isometry3<f64>, Stop> {
        let map_from_rod = self
            .stored_rod_seen
            .unwrap_or_else(|| self.config.site.map_from_stored_rod());
        Ok(self.base_from_map()? * map_from_rod)
    }

    fn plan_grasp_rack(&mut self) -> Result<Vec<Action>, Stop> {
        let q0 = self.q()?;
        let lift = self.lift()?;
        let grasp = poses::grasp_tool0(&self.stored_rod_in_base()?);
        let pre = poses::along_own_z(&grasp, -self.config.pregrasp_m);
        let world = self.world(lift)?;
        let q_pre = self.ik_goal(lift, &pre, &q0)?;
        let to_pre = self.plan_move(&world, lift, &q0, &q_pre, "rack pre-grasp")?;
        let line = self.line_waypoints(lift, &q_pre, &grasp)?;
        let world = world
            .allowing("tool", "stored_rod_handle")
            .allowing("arm_wrist3_link", "stored_rod_handle");
        let approach = self.plan(&world, lift, &q_pre, &line, "rack grasp approach")?;
        Ok(vec![
            self.arm_action(&to_pre, "arm to the rack pre-grasp"),
            self.arm_action(&approach, "grasp the rod"),
        ])
    }

    fn plan_lift_out(&mut self) -> Result<Vec<Action>, Stop> {
        // The passive latch has coupled at the grasp pose: the rod moves with the tool now.
        self.rod = Rod::Held;
        let q0 = self.q()?;
        let lift = self.lift()?;
        let map_from_rack = self.config.site.map_from_rack;
        let rack = self.base_from_map()? * map_from_rack;
        let tool = self.config.model.base_from_tool0(lift, &q0);
        let up = poses::shifted(
            &tool,
            &rack,
            &Vector3::new(0.0, 0.0, self.config.rack_lift_out_m),
        );
        let out = poses::shifted(
            &up,
            &rack,
            &Vector3::new(0.0, -self.config.rack_exit_m, 0.0),
        );
        let mut world = self.world(lift)?;
        for holder in RACK_HOLDERS {
            for part in ["rod_handle", "rod_shaft", "rod_head"] {
                world = world.allowing(part, holder);
            }
        }
        let mut via = self.line_waypoints(lift, &q0, &up)?;
        let last = via.last().copied().unwrap_or(q0);
        via.extend(self.line_waypoints(lift, &last, &out)?);
        let lift_out = self.plan(&world, lift, &q0, &via, "lift the rod out of the rack")?;
        // Carry: the rod upright in front of the robot, clear of the rack.
        let carry_pose = self.carry_pose(lift)?;
        let q_out = via.last().copied().unwrap_or(q0);
        let q_carry = self.ik_goal(lift, &carry_pose, &q_out)?;
        let world = self.world(lift)?;
        let carry = self.plan_move(&world, lift, &q_out, &q_carry, "carry the rod")?;
        Ok(vec![
            self.arm_action(&lift_out, "lift the rod out"),
            self.arm_action(&carry, "carry the rod"),
        ])
    }

    /// `tool0` carrying the rod upright in front of the robot (0.55 m ahead, 0.25 m left,
    /// 0.35 m above the arm base): the rod clears the platform and stays ~0.7 m from the wire.
    fn carry_pose(&self, lift_m: f64) -> Result<Isometry3<f64>, Stop> {
        let arm_base = self.arm_base_point(lift_m);
        let rod = Isometry3::from_parts(
            nalgebra::Translation3::new(0.61, 0.25, arm_base.z + 0.35 - 0.125),
            nalgebra::UnitQuaternion::identity(),
        );
        Ok(poses::grasp_tool0(&rod))
    }

    fn wire_prior_in_base(&self) -> Result<(Point3<f64>, Vector3<f64>), Stop> {
        let base_from_map = self.base_from_map()?;
        let (p, d) = self
            .wire_fix_in_map
            .unwrap_or((self.config.site.wire.point, self.config.site.wire.direction));
        Ok((base_from_map * p, base_from_map.rotation * d))
    }

    /// `tool0` with the camera level with the wire (or the handle) and its lift.
    fn look_goal(
        &self,
        target: &Point3<f64>,
        line_dir: &Vector3<f64>,
        up_hint: &Vector3<f64>,
        seed: &[f64; 6],
    ) -> Result<(Isometry3<f64>, f64, [f64; 6]), Stop> {
        let robot_point = self.arm_base_point(0.0);
        let camera = poses::level_look_pose(
            target,
            line_dir,
            &robot_point,
            self.config.standoff_m,
            up_hint,
        )
        .map_err(|e| Stop::failed("bad_geometry", e.to_string()))?;
        let tool = camera * self.tool0_from_camera(self.now.as_nanos()).inverse();
        let (lift, q) = self.comfortable_lift(&tool, seed, "look pose")?;
        Ok((tool, lift, q))
    }

    /// The lift height that puts `base_from_tool0` [`COMFORT_HEIGHT_M`] above the arm base
    /// (within the lift's travel) when the arm reaches it there away from singularities,
    /// otherwise the most dexterous height ([`choose_lift`]); with its configuration.
    fn comfortable_lift(
        &self,
        base_from_tool0: &Isometry3<f64>,
        seed: &[f64; 6],
        what: &str,
    ) -> Result<(f64, [f64; 6]), Stop> {
        let limit = &self.config.model.lift_limit;
        let arm_base_at_zero = self.arm_base_point(0.0).z;
        let lift = (base_from_tool0.translation.z - arm_base_at_zero - COMFORT_HEIGHT_M)
            .clamp(limit.position_min, limit.position_max);
        let target = self.config.model.arm_base_from_base(lift) * base_from_tool0;
        if let Ok(solution) = self.ik.nearest(&target, seed)
            && !solution.near_singular
        {
            return Ok((lift, solution.q_rad));
        }
        let choice = choose_lift(
            &self.config.model,
            &self.ik,
            base_from_tool0,
            seed,
            &LiftParams::default(),
        )
        .map_err(|e| Stop::refused("unreachable", format!("{what}: {e}")))?;
        Ok((choice.lift_m, choice.q_rad))
    }

    fn plan_raise_for_look(&mut self) -> Result<Vec<Action>, Stop> {
        let q = self.q()?;
        let lift = self.lift()?;
        let (point, dir) = self.wire_prior_in_base()?;
        let (_, look_lift, _) = self.look_goal(&point, &dir, &Vector3::z(), &q)?;
        self.look_lift_m = Some(look_lift);
        self.check_lift_move(&q, lift, look_lift, &[])?;
        Ok(vec![self.lift_action(
            lift,
            look_lift,
            "raise the lift to the wire",
        )])
    }

    fn plan_look_wire(&mut self) -> Result<Vec<Action>, Stop> {
        let q = self.q()?;
        let lift = self.lift()?;
        let (point, dir) = self.wire_prior_in_base()?;
        let camera = poses::level_look_pose(
            &point,
            &dir,
            &self.arm_base_point(lift),
            self.config.standoff_m,
            &Vector3::z(),
        )
        .map_err(|e| Stop::failed("bad_geometry", e.to_string()))?;
        let tool = camera * self.tool0_from_camera(self.now.as_nanos()).inverse();
        let goal = self.ik_goal(lift, &tool, &q)?;
        let world = self.world(lift)?;
        let plan = self.plan_move(&world, lift, &q, &goal, "look at the wire")?;
        Ok(vec![self.arm_action(&plan, "camera level with the wire")])
    }

    fn plan_to_pre_approach(&mut self) -> Result<Vec<Action>, Stop> {
        let q = self.q()?;
        let lift = self.lift()?;
        let hook = self
            .hook_goal
            .ok_or_else(|| Stop::failed("no_target", "no hook goal"))?;
        let tool_hang = poses::tool0_for_hook(&hook);
        let pre_hook = hook * Isometry3::translation(-self.config.approach_m, 0.0, 0.0);
        let tool_pre = poses::tool0_for_hook(&pre_hook);
        let (hang_lift, q_hang) = self.comfortable_lift(&tool_hang, &q, "hang pose")?;
        // The pre-approach configuration for the hang lift, executed first at the look lift
        // (the hook is then approach_m behind the wire and above it) ...
        let q_pre = self.ik_goal(hang_lift, &tool_pre, &q_hang)?;
        let world = self.world(lift)?;
        let to_pre = self.plan_move(&world, lift, &q, &q_pre, "arm to the pre-approach")?;
        // ... then the lift lowers the hook to the wire's height.
        self.check_lift_move(&q_pre, lift, hang_lift, &[])?;
        // The approach itself must be plannable before committing.
        let line = self.line_waypoints(hang_lift, &q_pre, &tool_hang)?;
        let world_hang = self.world(hang_lift)?.allowing("rod_head", TARGET_WIRE);
        self.plan(&world_hang, hang_lift, &q_pre, &line, "hook approach")?;
        Ok(vec![
            self.arm_action(&to_pre, "arm to the pre-approach"),
            self.lift_action(lift, hang_lift, "lower to the hook height"),
        ])
    }

    fn plan_approach(&mut self) -> Result<Vec<Action>, Stop> {
        let q = self.q()?;
        let lift = self.lift()?;
        let hook = self
            .hook_goal
            .ok_or_else(|| Stop::failed("no_target", "no hook goal"))?;
        let line = self.line_waypoints(lift, &q, &poses::tool0_for_hook(&hook))?;
        let world = self.world(lift)?.allowing("rod_head", TARGET_WIRE);
        let plan = self.plan(&world, lift, &q, &line, "hook approach")?;
        Ok(vec![self.arm_action(&plan, "hook onto the wire")])
    }

    fn plan_release(&mut self) -> Result<Vec<Action>, Stop> {
        let q = self.q()?;
        let lift = self.lift()?;
        let tool = self.config.model.base_from_tool0(lift, &q);
        // The rod is clamped on the wire where the tool holds it.
        self.rod = Rod::OnWire(tool * robot::grounding_rod::rod_from_tool0_grasp().inverse());
        let back = poses::along_own_z(&tool, -self.config.release_m);
        let line = self.line_waypoints(lift, &q, &back)?;
        let world = self
            .world(lift)?
            .allowing("tool", "hung_rod_handle")
            .allowing("arm_wrist3_link", "hung_rod_handle");
        let plan = self.plan(&world, lift, &q, &line, "release the rod")?;
        Ok(vec![self.arm_action(&plan, "back off the rod")])
    }

    fn handle_prior_in_base(&self, site: HandleSite) -> Result<(Point3<f64>, Vector3<f64>), Stop> {
        let [hx, hy, hz] = robot::grounding_rod::HANDLE_CENTER_IN_ROD_M;
        if site == HandleSite::Rack {
            let rod = self.base_from_map()? * self.config.site.map_from_stored_rod();
            return Ok((rod * Point3::new(hx, hy, hz), rod.rotation * Vector3::z()));
        }
        if let Rod::OnWire(rod) = self.rod {
            return Ok((rod * Point3::new(hx, hy, hz), rod.rotation * Vector3::z()));
        }
        // A rod hung on the prior wire by the hang flow.
        let (point, dir) = self.wire_prior_in_base()?;
        let hook = poses::hook_goal(&point, &dir, &self.arm_base_point(0.0))
            .map_err(|e| Stop::failed("bad_geometry", e.to_string()))?;
        let rod = hook * rod_from_hook().inverse();
        Ok((rod * Point3::new(hx, hy, hz), rod.rotation * Vector3::z()))
    }

    /// Image up along `side`: a vertical handle spans the image's width.
    fn handle_image_up(
        &self,
        site: HandleSite,
        centre: &Point3<f64>,
    ) -> Result<Vector3<f64>, Stop> {
        match site {
            HandleSite::Wire => Ok(self.wire_prior_in_base()?.1),
            // Across the line of sight from the arm.
            HandleSite::Rack => {
                let mut sight = centre - self.arm_base_point(0.0);
                sight.z = 0.0;
                Vector3::z()
                    .cross(&sight)
                    .try_normalize(1e-9)
                    .ok_or_else(|| Stop::failed("bad_site_map", "the rack is above the arm's base"))
            }
        }
    }

    fn plan_look_handle(&mut self, site: HandleSite) -> Result<Vec<Action>, Stop> {
        let q = self.q()?;
        let lift = self.lift()?;
        let (centre, axis) = self.handle_prior_in_base(site)?;
        let up = self.handle_image_up(site, &centre)?;
        if site == HandleSite::Rack {
            return self.plan_look_rack(&centre, &up, &q, lift);
        }
        let (tool, look_lift, q_look) = self.look_goal(&centre, &axis, &up, &q)?;
        let mut actions = Vec::new();
        if (look_lift - lift).abs() > LIFT_ARRIVED_M {
            self.check_lift_move(&q, lift, look_lift, &[])?;
            actions.push(self.lift_action(lift, look_lift, "lift to the handle"));
        }
        let goal = self.ik_goal(look_lift, &tool, &q_look)?;
        let world = self.world(look_lift)?;
        let plan = self.plan_move(&world, look_lift, &q, &goal, "look at the handle")?;
        actions.push(self.arm_action(&plan, "camera level with the handle"));
        Ok(actions)
    }

    /// The stored rod stands beside the arm, below its base: the camera looks at its handle
    /// from [`TaskConfig::standoff_m`] on the arm's side, from the lowest elevation of
    /// [`RACK_LOOK_ELEVATIONS_DEG`] the arm reaches without collision at the current lift.
    fn plan_look_rack(
        &mut self,
        centre: &Point3<f64>,
        up: &Vector3<f64>,
        q: &[f64; 6],
        lift: f64,
    ) -> Result<Vec<Action>, Stop> {
        let mut towards_arm = self.arm_base_point(lift) - centre;
        towards_arm.z = 0.0;
        let towards_arm = towards_arm
            .try_normalize(1e-9)
            .ok_or_else(|| Stop::failed("bad_site_map", "the rack is below the arm's base"))?;
        let mount = self.tool0_from_camera(self.now.as_nanos());
        let world = self.world(lift)?;
        let mut last = None;
        for elevation_deg in RACK_LOOK_ELEVATIONS_DEG {
            let e = elevation_deg.to_radians();
            let eye =
                centre + (towards_arm * e.cos() + Vector3::z() * e.sin()) * self.config.standoff_m;
            let Some(camera) = robot::se3::world_from_camera_looking_at(&eye, centre, up) else {
                continue;
            };
            let attempt = self
                .ik_goal(lift, &(camera * mount.inverse()), q)
                .and_then(|goal| self.plan_move(&world, lift, q, &goal, "look at the stored rod"));
            match attempt {
                Ok(plan) => {
                    let mut actions = Vec::new();
                    // The coupling probe: the empty clamp at full travel jumps to the rod's
                    // open jaw when the end effector engages the stored rod.
                    if self.clamp_m.unwrap_or(0.0) < CLAMP_TRAVEL_M - CLAMP_CONTACT_TOLERANCE_M {
                        actions.push(self.clamp_action(
                            ClampCommand::CLOSE,
                            "close the empty clamp (coupling probe)",
                        ));
                    }
                    actions.push(self.arm_action(&plan, "camera on the stored rod"));
                    return Ok(actions);
                }
                Err(stop) => last = Some(stop),
            }
        }
        Err(last
            .unwrap_or_else(|| Stop::failed("bad_site_map", "no view of the stored rod's handle")))
    }

    fn plan_grasp_handle(&mut self) -> Result<Vec<Action>, Stop> {
        let q = self.q()?;
        let lift = self.lift()?;
        let grasp = self
            .grasp_goal
            .ok_or_else(|| Stop::failed("no_target", "no grasp goal"))?;
        let (grasp_lift, q_grasp) = self.comfortable_lift(&grasp, &q, "grasp pose")?;
        let pre = poses::along_own_z(&grasp, -self.config.pregrasp_m);
        let mut actions = Vec::new();
        let q_pre = self.ik_goal(grasp_lift, &pre, &q_grasp)?;
        // Pre-grasp at the current lift first when the lift has to move (the tool then
        // moves vertically behind the handle).
        let world = self.world(lift)?;
        let to_pre = self.plan_move(&world, lift, &q, &q_pre, "arm to the handle pre-grasp")?;
        actions.push(self.arm_action(&to_pre, "arm to the pre-grasp"));
        if (grasp_lift - lift).abs() > LIFT_ARRIVED_M {
            self.check_lift_move(&q_pre, lift, grasp_lift, &[])?;
            actions.push(self.lift_action(lift, grasp_lift, "lift to the grasp height"));
        }
        let line = self.line_waypoints(grasp_lift, &q_pre, &grasp)?;
        let world = self
            .world(grasp_lift)?
            .allowing("tool", "hung_rod_handle")
            .allowing("arm_wrist3_link", "hung_rod_handle");
        let approach = self.plan(&world, grasp_lift, &q_pre, &line, "grasp approach")?;
        actions.push(self.arm_action(&approach, "grasp the handle"));
        Ok(actions)
    }

    fn plan_unhook(&mut self) -> Result<Vec<Action>, Stop> {
        self.rod = Rod::Held;
        let q = self.q()?;
        let lift = self.lift()?;
        let tool = self.config.model.base_from_tool0(lift, &q);
        // Back across the wire (rod -x = tool0 -z), then the lift takes the rod down.
        let back = poses::along_own_z(&tool, -self.config.approach_m);
        let line = self.line_waypoints(lift, &q, &back)?;
        let world = self.world(lift)?.allowing("rod_head", TARGET_WIRE);
        let plan = self.plan(&world, lift, &q, &line, "unhook")?;
        let q_back = line.last().copied().unwrap_or(q);
        self.check_lift_move(&q_back, lift, 0.0, &[])?;
        Ok(vec![
            self.arm_action(&plan, "unhook"),
            self.lift_action(lift, 0.0, "lower the rod"),
        ])
    }

    fn plan_rack(&mut self) -> Result<Vec<Action>, Stop> {
        let q = self.q()?;
        let lift = self.lift()?;
        let stored = self.stored_rod_in_base()?;
        let rack = self.base_from_map()? * self.config.site.map_from_rack;
        let grasp = poses::grasp_tool0(&stored);
        let above = poses::shifted(
            &grasp,
            &rack,
            &Vector3::new(0.0, 0.0, self.config.rack_lift_out_m),
        );
        let outside = poses::shifted(
            &above,
            &rack,
            &Vector3::new(0.0, -self.config.rack_exit_m, 0.0),
        );
        let world = self.world(lift)?;
        let q_out = self.ik_goal(lift, &outside, &q)?;
        let to_outside = self.plan_move(&world, lift, &q, &q_out, "rod over the rack")?;
        let mut via = self.line_waypoints(lift, &q_out, &above)?;
        let last = via.last().copied().unwrap_or(q_out);
        via.extend(self.line_waypoints(lift, &last, &grasp)?);
        let mut world_in = world.clone();
        for holder in RACK_HOLDERS {
            for part in ["rod_handle", "rod_shaft", "rod_head"] {
                world_in = world_in.allowing(part, holder);
            }
        }
        let into = self.plan(&world_in, lift, &q_out, &via, "rod into the rack")?;
        // Release: the tool backs off the handle; the rod stays in the rack.
        let q_in = via.last().copied().unwrap_or(q_out);
        let back = poses::along_own_z(&grasp, -self.config.pregrasp_m);
        let line = self.line_waypoints(lift, &q_in, &back)?;
        let world_rack = self
            .world_for(lift, Rod::OnRack)?
            .allowing("tool", "stored_rod_handle")
            .allowing("arm_wrist3_link", "stored_rod_handle");
        // The released rod stays in the rack: the empty arm backs off.
        let release =
            planner::plan_through(&self.arm, &world_rack, lift, &q_in, &line, DEFAULT_DT_NS)
                .map_err(|e| Stop::refused("collision", format!("release at the rack: {e}")))?;
        Ok(vec![
            self.arm_action(&to_outside, "rod over the rack"),
            self.arm_action(&into, "rod into the rack"),
            self.arm_action(&release, "release the rod"),
        ])
    }

    // ---------------------------------------------------------------- step results

    /// Judges the finished step: `Ok(next)` or a stop.
    fn finish_step(&mut self, step: Step) -> Result<Step, Stop> {
        if step == Step::Retreat
            && self.config.kind == TaskKind::Demo
            && self.phase == TaskKind::Hang
        {
            // The demo's hang is done: report it and start the remove from here.
            let next = self.next_step(step);
            let text = format!("hang done in {:.1} s", self.elapsed_s());
            let out = self.event(TaskEvent::DONE, Step::Finished.name(), "done", text);
            self.pending.extend(out);
            self.phase = TaskKind::Remove;
            self.began = Some(self.now);
            self.held_for_wind = RobotDuration::ZERO;
            self.attempts = 0;
            self.sway_holds = 0;
            let out = self.event(
                TaskEvent::INFO,
                "started",
                "",
                "remove started; the rod hangs where the hang left it".to_owned(),
            );
            self.pending.extend(out);
            return Ok(next);
        }
        match step {
            Step::CheckCalibration | Step::Recalibrate => self.judge_calibration(step),
            Step::Panoramic => self.judge_panoramic(),
            Step::CaptureWire => self.judge_wire(),
            Step::CaptureHandle => self.judge_handle(HandleSite::Wire),
            Step::CaptureRack => self.judge_handle(HandleSite::Rack),
            Step::CloseClamp => self.judge_clamp_closed(),
            Step::GraspHandle => self.judge_grasp(HandleSite::Wire),
            Step::GraspRack => self.judge_grasp(HandleSite::Rack),
            Step::Rack => {
                self.rod = Rod::OnRack;
                Ok(self.next_step(step))
            }
            Step::Recover => Ok(self
                .recovery
                .take()
                .map_or(Step::Finished, |(_, next)| next)),
            _ => Ok(self.next_step(step)),
        }
    }

    fn judge_calibration(&mut self, step: Step) -> Result<Step, Stop> {
        let Some(answer) = self.calibration_answer.take() else {
            return Err(Stop::failed(
                "calibration_silent",
                "the calibration stage did not answer",
            ));
        };
        if self.config.kind == TaskKind::Check {
            self.done_reason = match answer.reason_code.as_str() {
                "consistent" => "consistent",
                "drifted" => "drifted",
                _ => "cannot_tell",
            };
            self.done_text = answer.text;
            return Ok(self.next_step(step));
        }
        match (step, answer.reason_code.as_str()) {
            (Step::CheckCalibration, "consistent") => Ok(self.next_step(Step::Recalibrate)),
            (Step::CheckCalibration, "drifted") => Ok(Step::Recalibrate),
            // The check could miss a bump that matters: calibrate afresh instead, which
            // verifies itself (the stage accepts only a consistent X).
            (Step::CheckCalibration, _) => {
                self.unverified_check = Some(answer.text);
                Ok(Step::Recalibrate)
            }
            (_, "accepted") => {
                self.unverified_check = None;
                Ok(self.next_step(Step::Recalibrate))
            }
            (_, code) if self.unverified_check.is_some() => Err(Stop::refused(
                "calibration_unverifiable",
                format!(
                    "the hand-eye calibration could not be checked ({}) nor redone ({code}: {}): not operating on an unverified camera; retry in better light or check the camera",
                    self.unverified_check.take().unwrap_or_default(),
                    answer.text
                ),
            )),
            (_, code) => Err(Stop::refused(
                "calibration_failed",
                format!(
                    "the camera mount moved and the recalibration was not accepted ({code}: {}); recalibrate with a board",
                    answer.text
                ),
            )),
        }
    }

    fn judge_panoramic(&mut self) -> Result<Step, Stop> {
        let image = self.panoramic_image.take();
        let result = (|| -> Result<panoramic::PanoramicWire, String> {
            let image = image.ok_or("no panoramic frame")?;
            let camera = self
                .panoramic_camera
                .clone()
                .ok_or("no /panoramic/camera_info")?;
            let stamp_ns = time_ns(&image.header.stamp);
            let map_from_base = self
                .tf
                .lookup(BASE_LINK, MAP, stamp_ns)
                .or_else(|_| self.tf.lookup_latest(BASE_LINK, MAP).map(|(_, t)| t))
                .map_err(|e| format!("no map -> base_link: {e}"))?
                .inverse();
            let base_from_pano = self
                .tf
                .lookup(BASE_LINK, PANORAMIC_OPTICAL_FRAME, stamp_ns)
                .map_err(|e| format!("no base_link -> panoramic: {e}"))?;
            let bgr = match image.encoding.as_str() {
                "rgb8" => false,
                "bgr8" => true,
                other => return Err(format!("panoramic encoding {other} (rgb8 or bgr8)")),
            };
            let view = RgbView::new(
                image.width as usize,
                image.height as usize,
                image.step as usize,
                &image.data,
            )
            .map_err(|e| e.to_string())?;
            panoramic::find_wire_region(
                &view,
                &RgbView::luminance_weights(bgr),
                &camera,
                &(map_from_base * base_from_pano),
                &self.config.site.wire,
                &self.config.panoramic,
            )
            .map_err(|e| e.to_string())
        })();
        match result {
            Ok(found) => {
                self.wire_fix_in_map = Some((found.point, found.direction));
                Ok(Step::LookWire)
            }
            Err(reason) => {
                self.panoramic_tries += 1;
                if self.panoramic_tries >= self.config.panoramic_attempts.max(1) {
                    Err(Stop::refused(
                        "no_wire",
                        format!(
                            "the panoramic camera did not find the wire in {} frames: {reason}",
                            self.panoramic_tries
                        ),
                    ))
                } else {
                    Ok(Step::Panoramic)
                }
            }
        }
    }

    fn judge_wire(&mut self) -> Result<Step, Stop> {
        let (point, dir) = self.wire_prior_in_base()?;
        let lift = self.lift()?;
        let Some((camera, rays)) = self.wrist.clone() else {
            return Err(Stop::failed(
                "no_camera_info",
                "no /camera/color/camera_info",
            ));
        };
        let mut observations: Vec<(WireObservation, Isometry3<f64>)> = Vec::new();
        let mut reasons = Vec::new();
        for c in &self.captures {
            let camera_from_base = c.base_from_camera.inverse();
            let half = dir.normalize() * 0.25;
            let p0 = camera_from_base * (point - half);
            let p1 = camera_from_base * (point + half);
            let distance = 0.5 * (p0.coords.norm() + p1.coords.norm());
            let margin_px = 0.15 * camera.fx / distance.max(0.1);
            let detected = PixelRoi::around_segment(&camera, &p0, &p1, margin_px, 0.15)
                .map_err(|e| e.to_string())
                .and_then(|roi| {
                    wire::detect_wire(&c.depth, &rays, camera.fx, &roi, &self.config.wire)
                        .map_err(|e| e.to_string())
                });
            match detected {
                Ok(o) => {
                    let o = match &c.colour {
                        Some(colour) => o.confirm_in_colour(colour, &camera),
                        None => o,
                    };
                    observations.push((o, c.base_from_camera));
                }
                Err(e) => reasons.push(e),
            }
        }
        let robot_point = self.arm_base_point(lift);
        let estimate = wire::estimate_wire(
            &observations,
            &point,
            &robot_point,
            WIRE_RADIUS_M,
            &self.config.thresholds,
        );
        let cloud: Vec<Point3<f64>> = observations
            .iter()
            .flat_map(|(o, t)| o.inlier_points.iter().map(move |p| t * p))
            .collect();
        let stamp = self.captures.last().map(|c| c.stamp).unwrap_or_default();
        self.pending.push((
            PERCEPTION_ROI_CLOUD.to_owned(),
            to_point_cloud2(
                &cloud,
                Header {
                    stamp,
                    frame_id: BASE_LINK.to_owned(),
                },
            )
            .into(),
        ));
        match estimate {
            Ok(est) => {
                let axis = est.axis_in_base;
                let hook = poses::hook_goal(
                    &est.hanging.point,
                    &axis.direction,
                    &self.arm_base_point(0.0),
                )
                .map_err(|e| Stop::failed("bad_geometry", e.to_string()))?;
                self.pending.push((
                    PERCEPTION_TARGET_POSE.to_owned(),
                    wire::to_pose_stamped(
                        &hook,
                        Header {
                            stamp,
                            frame_id: BASE_LINK.to_owned(),
                        },
                    )
                    .into(),
                ));
                self.pending.extend(self.event(
                    TaskEvent::INFO,
                    Step::CaptureWire.name(),
                    "",
                    format!(
                        "wire at ({:.4}, {:.4}, {:.4}) m in base_link from {} captures; confidence {:.3} (limited by {})",
                        est.hanging.point.x, est.hanging.point.y, est.hanging.point.z,
                        est.metrics.captures, est.confidence.score, est.confidence.limiting
                    ),
                ));
                self.wire_in_base = Some((est.hanging.point, axis.direction));
                self.hook_goal = Some(hook);
                Ok(Step::ToPreApproach)
            }
            Err(e) => self.perception_refusal(Step::LookWire, &e, &reasons),
        }
    }

    /// One more look after a refused estimate; then refuse.
    fn perception_refusal(
        &mut self,
        again: Step,
        e: &PerceptionError,
        reasons: &[String],
    ) -> Result<Step, Stop> {
        self.attempts += 1;
        let text = if reasons.is_empty() {
            e.to_string()
        } else {
            format!("{e} ({})", reasons.join("; "))
        };
        if self.attempts < self.config.attempts.max(1) {
            self.pending.extend(self.event(
                TaskEvent::INFO,
                again.name(),
                "retry",
                format!("perception refused, looking again: {text}"),
            ));
            Ok(again)
        } else {
            Err(Stop::refused(
                "low_confidence",
                format!("perception refused {} times: {text}", self.attempts),
            ))
        }
    }

    /// Fits the handle in the captures (`site`: the rack's stored rod or the hung rod).
    fn judge_handle(&mut self, site: HandleSite) -> Result<Step, Stop> {
        let (centre_prior, axis_prior) = self.handle_prior_in_base(site)?;
        let look_again = match site {
            HandleSite::Wire => Step::LookHandle,
            HandleSite::Rack => Step::LookRack,
        };
        let lift = self.lift()?;
        let Some((camera, rays)) = self.wrist.clone() else {
            return Err(Stop::failed(
                "no_camera_info",
                "no /camera/color/camera_info",
            ));
        };
        let robot_point = self.arm_base_point(lift);
        let half = robot::grounding_rod::HANDLE_LENGTH_M * 0.5;
        let mut fits: Vec<(Point3<f64>, Vector3<f64>, f64)> = Vec::new();
        let mut reasons = Vec::new();
        let mut cloud = Vec::new();
        for c in &self.captures {
            let camera_from_base = c.base_from_camera.inverse();
            let a = axis_prior.normalize() * (half + 0.03);
            let p0 = camera_from_base * (centre_prior - a);
            let p1 = camera_from_base * (centre_prior + a);
            let distance = 0.5 * (p0.coords.norm() + p1.coords.norm());
            let margin_px = 0.05 * camera.fx / distance.max(0.1);
            let result = PixelRoi::around_segment(&camera, &p0, &p1, margin_px, 0.1)
                .map_err(|e| e.to_string())
                .and_then(|roi| {
                    let points = extract_roi(&c.depth, &rays, &roi, self.config.wire.stride_px);
                    let depth = &c.depth;
                    let normal_of = |k: usize| {
                        let (u, v) = *points.pixels.get(k)?;
                        depth.normal(&rays, camera.fx, u as usize, v as usize)
                    };
                    fit_handle(
                        &points.points,
                        normal_of,
                        &self.config.handle,
                        &self.config.wire.ransac,
                        &(camera_from_base * robot_point),
                    )
                    .map_err(|e| e.to_string())
                    .map(|h| (h, points))
                })
                .and_then(|(h, points)| match &c.colour {
                    // Confirmed in the registered colour image like the wire (dusk refuses).
                    Some(colour) => h
                        .confirm_in_colour(&points.points, colour, &camera, &self.config.thresholds)
                        .map(|_| (h, points))
                        .map_err(|e| format!("handle {e}")),
                    None => Ok((h, points)),
                });
            match result {
                Ok((h, points)) if h.fit.rms_residual_m <= self.config.handle_max_rms_m => {
                    let t = c.base_from_camera;
                    fits.push((
                        t * h.pose.point,
                        t.rotation * h.pose.axis,
                        h.fit.rms_residual_m,
                    ));
                    cloud.extend(
                        h.fit
                            .inliers
                            .iter()
                            .filter_map(|&k| points.points.get(k))
                            .map(|p| t * p),
                    );
                }
                Ok((h, _)) => reasons.push(format!(
                    "handle fit rms {:.2} mm > {:.2} mm",
                    h.fit.rms_residual_m * 1e3,
                    self.config.handle_max_rms_m * 1e3
                )),
                Err(e) => reasons.push(e),
            }
        }
        let stamp = self.captures.last().map(|c| c.stamp).unwrap_or_default();
        self.pending.push((
            PERCEPTION_ROI_CLOUD.to_owned(),
            to_point_cloud2(
                &cloud,
                Header {
                    stamp,
                    frame_id: BASE_LINK.to_owned(),
                },
            )
            .into(),
        ));
        let disagreement = fits
            .iter()
            .flat_map(|a| fits.iter().map(move |b| (a.0 - b.0).norm()))
            .fold(0.0, f64::max);
        if fits.len() < self.config.handle_captures.max(1)
            || disagreement > self.config.handle_max_disagreement_m
        {
            let e = PerceptionError::LowConfidence {
                score: fits.len() as f64 / self.config.handle_captures.max(1) as f64,
                threshold: 1.0,
                limiting: if disagreement > self.config.handle_max_disagreement_m {
                    "agreement_offset"
                } else {
                    "handle_fit"
                },
            };
            let mut reasons = reasons;
            if disagreement > self.config.handle_max_disagreement_m {
                let why = format!(
                    "the captures' handle centres disagree by {:.1} mm > {:.1} mm",
                    disagreement * 1e3,
                    self.config.handle_max_disagreement_m * 1e3
                );
                // A rod swaying with the wire: hold still and look again, a few times,
                // before counting it as a failed look.
                if fits.len() >= self.config.handle_captures.max(1)
                    && self.sway_holds < MAX_SWAY_HOLDS
                {
                    self.sway_holds += 1;
                    self.pending.extend(self.event(
                        TaskEvent::INFO,
                        look_again.name(),
                        "holding_for_sway",
                        format!("{why}: the rod sways; holding {SWAY_HOLD_S} s and looking again"),
                    ));
                    self.recovery = Some((
                        vec![Action {
                            outputs: Vec::new(),
                            command: false,
                            until: Until::Elapsed(
                                RobotDuration::from_secs_f64(SWAY_HOLD_S)
                                    .unwrap_or(RobotDuration::from_secs(2)),
                            ),
                            timeout: RobotDuration::from_secs(10),
                            label: "hold for the sway",
                        }],
                        look_again,
                    ));
                    return Ok(Step::Recover);
                }
                reasons.push(why);
            }
            return self.perception_refusal(look_again, &e, &reasons);
        }
        let n = fits.len() as f64;
        let centre = Point3::from(fits.iter().map(|f| f.0.coords).sum::<Vector3<f64>>() / n);
        let reference = fits.first().map_or(Vector3::z(), |f| f.1);
        let axis = fits
            .iter()
            .map(|f| if f.1.dot(&reference) < 0.0 { -f.1 } else { f.1 })
            .sum::<Vector3<f64>>()
            .normalize();
        let (rod, step, next) = match site {
            HandleSite::Wire => {
                let (_, wire_dir) = self.wire_prior_in_base()?;
                let rod = poses::hung_rod_from_handle(
                    &centre,
                    &axis,
                    &wire_dir,
                    &self.arm_base_point(0.0),
                )
                .map_err(|e| Stop::failed("bad_geometry", e.to_string()))?;
                self.rod = Rod::OnWire(rod);
                (rod, Step::CaptureHandle, Step::GraspHandle)
            }
            HandleSite::Rack => {
                // The rack holds the rod upright at its yaw: only the position is measured.
                let tilt = axis.z.abs().clamp(-1.0, 1.0).acos();
                if tilt > RACK_AXIS_TOLERANCE_RAD {
                    let e = PerceptionError::LowConfidence {
                        score: 0.0,
                        threshold: 1.0,
                        limiting: "handle_axis",
                    };
                    let why = format!(
                        "the stored rod's handle axis is {:.1} deg off the vertical",
                        tilt.to_degrees()
                    );
                    return self.perception_refusal(look_again, &e, &[why]);
                }
                let prior = self.base_from_map()? * self.config.site.map_from_stored_rod();
                let rod = Isometry3::from_parts(
                    nalgebra::Translation3::from(
                        prior.translation.vector + (centre - centre_prior),
                    ),
                    prior.rotation,
                );
                self.stored_rod_seen = Some(self.base_from_map()?.inverse() * rod);
                (rod, Step::CaptureRack, Step::GraspRack)
            }
        };
        let grasp = poses::grasp_tool0(&rod);
        self.grasp_goal = Some(grasp);
        self.pending.push((
            PERCEPTION_TARGET_POSE.to_owned(),
            wire::to_pose_stamped(
                &grasp,
                Header {
                    stamp,
                    frame_id: BASE_LINK.to_owned(),
                },
            )
            .into(),
        ));
        self.pending.extend(self.event(
            TaskEvent::INFO,
            step.name(),
            "",
            format!(
                "handle at ({:.4}, {:.4}, {:.4}) m in base_link from {} captures, disagreement {:.2} mm, {:.1} mm from the prior",
                centre.x, centre.y, centre.z, fits.len(), disagreement * 1e3,
                (centre - centre_prior).norm() * 1e3
            ),
        ));
        Ok(next)
    }

    fn judge_clamp_closed(&mut self) -> Result<Step, Stop> {
        let travel = self.clamp_m.unwrap_or(0.0);
        if (travel - WIRE_CONTACT_TRAVEL_M).abs() <= CLAMP_CONTACT_TOLERANCE_M {
            self.pending.extend(self.event(
                TaskEvent::INFO,
                Step::CloseClamp.name(),
                "",
                format!(
                    "clamped: the jaw stopped on the wire at {:.1} mm",
                    travel * 1e3
                ),
            ));
            return Ok(Step::Release);
        }
        self.attempts += 1;
        let text = format!(
            "the clamp closed to {:.1} mm (wire contact at {:.1} mm, full travel {:.1} mm): the hook missed the wire",
            travel * 1e3,
            WIRE_CONTACT_TRAVEL_M * 1e3,
            CLAMP_TRAVEL_M * 1e3
        );
        if self.attempts >= self.config.attempts.max(1) {
            return Err(Stop::failed(
                "hook_missed",
                format!("{text}; {} attempts", self.attempts),
            ));
        }
        // Open, back off across the wire, and look again.
        self.pending
            .extend(self.event(TaskEvent::INFO, Step::CloseClamp.name(), "retry", text));
        let q = self.q()?;
        let lift = self.lift()?;
        let tool = self.config.model.base_from_tool0(lift, &q);
        let back = poses::along_own_z(&tool, -self.config.approach_m);
        let line = self.line_waypoints(lift, &q, &back)?;
        let world = self.world(lift)?.allowing("rod_head", TARGET_WIRE);
        let plan = self.plan(&world, lift, &q, &line, "back off after a miss")?;
        let look_lift = self.look_lift_m.unwrap_or(lift);
        let q_back = line.last().copied().unwrap_or(q);
        self.check_lift_move(&q_back, lift, look_lift, &[])?;
        self.recovery = Some((
            vec![
                self.clamp_action(ClampCommand::OPEN, "open the clamp"),
                self.arm_action(&plan, "back off the wire"),
                self.lift_action(lift, look_lift, "raise to look again"),
            ],
            Step::LookWire,
        ));
        Ok(Step::Recover)
    }

    /// Whether the end effector coupled the rod at `site`: the clamp joint then reads the
    /// rod's jaw (the stored rod's open jaw; for the hung rod, its jaw on the wire; the
    /// empty clamp was closed to full travel before the rack grasp). A miss backs off along
    /// the tool's -z and looks again, up to [`TaskConfig::attempts`].
    fn judge_grasp(&mut self, site: HandleSite) -> Result<Step, Stop> {
        let (step, jaw_m, jaw, handle, look_again) = match site {
            HandleSite::Rack => (
                Step::GraspRack,
                0.0,
                "the stored rod's open jaw",
                "stored_rod_handle",
                Step::LookRack,
            ),
            HandleSite::Wire => (
                Step::GraspHandle,
                WIRE_CONTACT_TRAVEL_M,
                "the rod's jaw on the wire",
                "hung_rod_handle",
                Step::LookHandle,
            ),
        };
        if let Some(travel) = self
            .clamp_m
            .filter(|t| (t - jaw_m).abs() <= CLAMP_CONTACT_TOLERANCE_M)
        {
            self.pending.extend(self.event(
                TaskEvent::INFO,
                step.name(),
                "",
                format!(
                    "coupled: the clamp joint reads {jaw} at {:.1} mm",
                    travel * 1e3
                ),
            ));
            // The hung rod stays clamped on the wire (Rod::OnWire) until it is unhooked.
            return Ok(self.next_step(step));
        }
        self.attempts += 1;
        let reading = self.clamp_m.map_or_else(
            || "has no reading".to_owned(),
            |t| format!("reads {:.1} mm", t * 1e3),
        );
        let text = format!(
            "the clamp joint {reading} after the grasp, not {jaw} at {:.1} mm: the gripper missed the handle",
            jaw_m * 1e3
        );
        if self.attempts >= self.config.attempts.max(1) {
            return Err(Stop::failed(
                "grasp_missed",
                format!("{text}; {} attempts", self.attempts),
            ));
        }
        self.pending
            .extend(self.event(TaskEvent::INFO, step.name(), "retry", text));
        let q = self.q()?;
        let lift = self.lift()?;
        let tool = self.config.model.base_from_tool0(lift, &q);
        let back = poses::along_own_z(&tool, -self.config.pregrasp_m);
        let line = self.line_waypoints(lift, &q, &back)?;
        let world = self
            .world(lift)?
            .allowing("tool", handle)
            .allowing("arm_wrist3_link", handle);
        let plan = self.plan(&world, lift, &q, &line, "back off after a missed grasp")?;
        self.recovery = Some((
            vec![self.arm_action(&plan, "back off the handle")],
            look_again,
        ));
        Ok(Step::Recover)
    }
}

// -------------------------------------------------------------------- retreat and driver

impl TaskStage {
    /// Stow and lower; when the direct move to the stow configuration collides (the hung
    /// rod in front of the tool), back off further along the tool's -z first.
    fn plan_retreat(&mut self) -> Result<Vec<Action>, Stop> {
        match self.plan_stow() {
            Ok(actions) => Ok(actions),
            Err(direct) => {
                let q = self.q()?;
                let lift = self.lift()?;
                let tool = self.config.model.base_from_tool0(lift, &q);
                let back = poses::along_own_z(&tool, -0.3);
                let q_back = self.ik_goal(lift, &back, &q)?;
                let world = self.world(lift)?;
                let plan = self
                    .plan_move(&world, lift, &q, &q_back, "back off before stowing")
                    .map_err(|s| Stop {
                        text: format!("{}; direct stow: {}", s.text, direct.text),
                        ..s
                    })?;
                let stow = self.config.stow_rad;
                let plan2 = self.plan_move(&world, lift, &q_back, &stow, "stow")?;
                let mut actions = vec![
                    self.arm_action(&plan, "back off"),
                    self.arm_action(&plan2, "arm to stow"),
                ];
                if lift > LIFT_ARRIVED_M {
                    self.check_lift_move(&stow, lift, 0.0, &[])?;
                    actions.push(self.lift_action(lift, 0.0, "lift down"));
                }
                Ok(actions)
            }
        }
    }

    /// Enters `step`: announces it and queues its actions (or ends the task).
    fn enter(&mut self, step: Step) {
        self.step = step;
        if step == Step::Finished {
            let mut text = format!("{} done in {:.1} s", self.phase.name(), self.elapsed_s());
            if !self.done_text.is_empty() {
                text = format!("{text}: {}", self.done_text);
            }
            let out = self.event(
                TaskEvent::DONE,
                Step::Finished.name(),
                self.done_reason,
                text,
            );
            self.pending.extend(out);
            return;
        }
        match self.plan_step(step) {
            Ok(actions) => {
                let text = format!(
                    "{} ({} actions) at {:.1} s",
                    step.name(),
                    actions.len(),
                    self.elapsed_s()
                );
                let out = self.event(TaskEvent::INFO, step.name(), "", text);
                self.pending.extend(out);
                self.queue = actions;
                self.running = None;
            }
            Err(stop) => self.end(&stop),
        }
    }

    /// Ends the task early.
    fn end(&mut self, stop: &Stop) {
        let out = self.event(
            stop.kind,
            self.step.name(),
            stop.reason_code,
            format!("{} (after {:.1} s)", stop.text, self.elapsed_s()),
        );
        self.pending.extend(out);
        self.step = Step::Finished;
        self.queue.clear();
        self.running = None;
    }

    fn action_done(&self, running: &Running) -> bool {
        match running.action.until {
            Until::Issued => true,
            Until::Elapsed(d) => self.now.as_nanos() >= running.started.as_nanos() + d.as_nanos(),
            Until::Arm(goal) => {
                self.arm_at_rest
                    && self
                        .q
                        .is_some_and(|q| (0..6).all(|j| (q[j] - goal[j]).abs() < ARRIVED_RAD))
            }
            Until::Lift(h) => {
                self.lift_m.is_some_and(|l| (l - h).abs() < LIFT_ARRIVED_M)
                    && self.lift_speed_m_s.abs() < 1e-3
            }
            Until::Base(goal) => {
                self.odometry.is_some_and(|(_, p)| {
                    (p.x_m - goal.x_m).hypot(p.y_m - goal.y_m) < BASE_ARRIVED_M
                        && robot::se3::wrap_to_pi(p.yaw_rad - goal.yaw_rad).abs() < BASE_ARRIVED_RAD
                }) && self
                    .base_still_since
                    .is_some_and(|t| self.now.saturating_duration_since(t) >= BASE_STILL_FOR)
            }
            Until::ClampRest => {
                self.now.saturating_duration_since(running.started)
                    >= RobotDuration::from_millis(500)
                    && self
                        .clamp_rest_since
                        .is_some_and(|t| self.now.saturating_duration_since(t) >= CLAMP_REST_FOR)
            }
            // Completed by the message handlers (they clear `running`).
            Until::Capture | Until::Panoramic | Until::Calibration => false,
        }
    }

    /// Runs the machine after every input.
    fn advance(&mut self) -> Vec<(String, Msg)> {
        if self.step == Step::Waiting {
            if self.now >= self.config.start_at && self.q.is_some() && self.lift_m.is_some() {
                self.began = Some(self.now);
                let text = format!(
                    "{} started; self-maintenance {}",
                    self.phase.name(),
                    if self.config.self_maintenance {
                        "on"
                    } else {
                        "off"
                    }
                );
                let out = self.event(TaskEvent::INFO, "started", "", text);
                self.pending.extend(out);
                self.enter(Step::Begin);
            }
            return std::mem::take(&mut self.pending);
        }
        // Bounded: each pass either waits or makes progress.
        for _ in 0..64 {
            if self.step == Step::Finished {
                break;
            }
            if let Some(b) = self.began
                && self.now.saturating_duration_since(b) > self.config.operation_timeout
            {
                let holding = self.holding_since.map_or(RobotDuration::ZERO, |h| {
                    self.now.saturating_duration_since(h)
                });
                let held = self.held_for_wind + holding;
                let limit_s = self.config.operation_timeout.as_secs_f64();
                // Out of time because gusts kept stopping the work: the wind gate's refusal,
                // not a fault of the robot's.
                let stop = if held > RobotDuration::ZERO {
                    Stop::refused(
                        "wind_above_limit",
                        format!(
                            "the operation could not finish within {limit_s:.0} s: held {:.0} s for the wind in gusts",
                            held.as_secs_f64()
                        ),
                    )
                } else {
                    Stop::failed(
                        "timeout",
                        format!("the operation took longer than {limit_s:.0} s"),
                    )
                };
                self.end(&stop);
                break;
            }
            if let Some(running) = &self.running {
                if self.action_done(running) {
                    self.running = None;
                    continue;
                }
                if self.now.saturating_duration_since(running.started) > running.action.timeout {
                    let stop = Stop::failed(
                        "timeout",
                        format!(
                            "{} did not complete within {:.1} s",
                            running.action.label,
                            running.action.timeout.as_secs_f64()
                        ),
                    );
                    self.end(&stop);
                }
                break;
            }
            if !self.queue.is_empty() {
                let command = self.queue[0].command;
                if command {
                    let verdict = self.gate.verdict(self.now);
                    if !verdict.is_open() {
                        // Announced once per hold: `advance` runs for every message of a
                        // tick, so "since == now" would repeat it within the first tick.
                        let announce = self.holding_since.is_none();
                        let since = *self.holding_since.get_or_insert(self.now);
                        if announce {
                            let out = self.event(
                                TaskEvent::INFO,
                                self.step.name(),
                                "holding_for_wind",
                                format!("holding: {}", verdict.describe()),
                            );
                            self.pending.extend(out);
                        }
                        if self.now.saturating_duration_since(since) > self.config.wind.hold_timeout
                        {
                            let stop = Stop::refused(
                                "wind_above_limit",
                                format!(
                                    "held {:.0} s for the wind: {}",
                                    self.now.saturating_duration_since(since).as_secs_f64(),
                                    verdict.describe()
                                ),
                            );
                            self.end(&stop);
                        }
                        break;
                    }
                    if let Some(since) = self.holding_since.take() {
                        self.held_for_wind =
                            self.held_for_wind + self.now.saturating_duration_since(since);
                    }
                }
                let mut action = self.queue.remove(0);
                // Re-stamp the outputs: the action may have been planned earlier.
                for (_, msg) in &mut action.outputs {
                    restamp(msg, self.stamp());
                }
                self.pending.extend(action.outputs.iter().cloned());
                if action.until == Until::ClampRest {
                    self.clamp_rest_since = None;
                }
                self.running = Some(Running {
                    action,
                    started: self.now,
                });
                continue;
            }
            let step = self.step;
            match self.finish_step(step) {
                Ok(next) => self.enter(next),
                Err(stop) => self.end(&stop),
            }
        }
        std::mem::take(&mut self.pending)
    }

    fn on_joint_state(&mut self, js: &JointState) {
        let mut q = self.q.unwrap_or([f64::NAN; 6]);
        let mut arm = 0;
        let mut at_rest = true;
        for (k, name) in js.name.iter().enumerate() {
            let position = js.position.get(k).copied();
            let velocity = js.velocity.get(k).copied().unwrap_or(0.0);
            match JointKind::from_name(name) {
                Some(JointKind::Lift) => {
                    self.lift_m = position.or(self.lift_m);
                    self.lift_speed_m_s = velocity;
                }
                Some(JointKind::Arm(i)) if i < 6 => {
                    q[i] = position.unwrap_or(f64::NAN);
                    at_rest &= velocity.abs() < AT_REST_RAD_S;
                    arm += 1;
                }
                _ if name == msgs::frames::CLAMP_JOINT => {
                    self.clamp_m = position.or(self.clamp_m);
                    self.clamp_speed_m_s = velocity;
                    if velocity.abs() < CLAMP_REST_M_S {
                        self.clamp_rest_since.get_or_insert(self.now);
                    } else {
                        self.clamp_rest_since = None;
                    }
                }
                _ => {}
            }
        }
        if arm == 6 && q.iter().all(|v| v.is_finite()) {
            self.q = Some(q);
            self.arm_at_rest = at_rest;
        }
    }

    fn on_colour(&mut self, image: &Image) {
        if self
            .running
            .as_ref()
            .is_none_or(|r| r.action.until != Until::Capture)
        {
            return;
        }
        self.colour.keep(time_ns(&image.header.stamp), image);
    }

    fn on_depth(&mut self, image: &Image) {
        let Some(running) = &self.running else {
            return;
        };
        if running.action.until != Until::Capture {
            return;
        }
        let stamp_ns = time_ns(&image.header.stamp);
        if stamp_ns < running.started.as_nanos() {
            return; // an earlier capture's images
        }
        let Ok(depth) = DepthImage::from_image(image) else {
            let stop = Stop::failed(
                "bad_depth",
                format!("depth image {} is not 32FC1 or 16UC1", image.encoding),
            );
            self.end(&stop);
            return;
        };
        let base_from_tool0 = self
            .tf
            .lookup(BASE_LINK, TOOL0, stamp_ns)
            .or_else(|_| self.tf.lookup_latest(BASE_LINK, TOOL0).map(|(_, t)| t));
        let Ok(base_from_tool0) = base_from_tool0 else {
            let stop = Stop::failed("no_tf", "no base_link -> tool0 at the capture");
            self.end(&stop);
            return;
        };
        self.captures.push(Capture {
            depth,
            colour: self.colour.take_for(stamp_ns),
            base_from_camera: base_from_tool0 * self.tool0_from_camera(stamp_ns),
            stamp: image.header.stamp,
        });
        self.running = None;
    }
}

/// Sets the header stamp of a command message (planned earlier, issued now).
fn restamp(msg: &mut Msg, stamp: Time) {
    match msg {
        Msg::JointTrajectory(t) => t.header.stamp = stamp,
        Msg::Path(p) => {
            p.header.stamp = stamp;
            for pose in &mut p.poses {
                pose.header.stamp = stamp;
            }
        }
        Msg::PoseStamped(p) => p.header.stamp = stamp,
        Msg::ClampCommand(c) => c.header.stamp = stamp,
        _ => {}
    }
}

/// `geometry_msgs/Pose` of an isometry.
fn pose_msg(p: &Isometry3<f64>) -> Pose {
    let t = p.translation.vector;
    let q = p.rotation;
    Pose {
        position: Point {
            x: t.x,
            y: t.y,
            z: t.z,
        },
        orientation: Quaternion {
            x: q.i,
            y: q.j,
            z: q.k,
            w: q.w,
        },
    }
}

impl Stage for TaskStage {
    fn name(&self) -> &str {
        STAGE_NAME
    }

    fn inputs(&self) -> Vec<String> {
        [
            CLOCK,
            TF,
            TF_STATIC,
            JOINT_STATES,
            ENV_WIND,
            PANORAMIC_IMAGE,
            PANORAMIC_INFO,
            CAMERA_COLOR_INFO,
            CAMERA_COLOR_IMAGE,
            CAMERA_DEPTH_IMAGE,
            TASK_EVENT,
        ]
        .iter()
        .map(|s| (*s).to_owned())
        .collect()
    }

    fn outputs(&self) -> Vec<(String, &'static str)> {
        vec![
            (ARM_JOINT_TRAJECTORY.to_owned(), JointTrajectory::TYPE_NAME),
            (ARM_PLANNED_PATH.to_owned(), Path::TYPE_NAME),
            (LIFT_COMMAND.to_owned(), Float64::TYPE_NAME),
            (BASE_GOAL.to_owned(), PoseStamped::TYPE_NAME),
            (CLAMP_COMMAND.to_owned(), ClampCommand::TYPE_NAME),
            (CAMERA_TRIGGER.to_owned(), Empty::TYPE_NAME),
            (CALIBRATION_COMMAND.to_owned(), StringMsg::TYPE_NAME),
            (PERCEPTION_ROI_CLOUD.to_owned(), PointCloud2::TYPE_NAME),
            (PERCEPTION_TARGET_POSE.to_owned(), PoseStamped::TYPE_NAME),
            (TASK_EVENT.to_owned(), TaskEvent::TYPE_NAME),
            (ROSOUT.to_owned(), Log::TYPE_NAME),
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
        self.now = log_time;
        match (topic, msg) {
            (TF, Msg::TfMessage(m)) => {
                let _rejected = self.tf.insert_message(m, false);
                if let Ok((stamp_ns, base_from_map)) = self.tf.lookup_latest(BASE_LINK, MAP)
                    && self.odometry_stamp_ns != Some(stamp_ns)
                {
                    let pose = base_pose_of(&base_from_map.inverse());
                    let still = self.odometry.is_some_and(|(_, p)| {
                        (p.x_m - pose.x_m).hypot(p.y_m - pose.y_m) < BASE_STILL_M
                            && robot::se3::wrap_to_pi(p.yaw_rad - pose.yaw_rad).abs()
                                < BASE_STILL_RAD
                    });
                    if still {
                        self.base_still_since.get_or_insert(log_time);
                    } else {
                        self.base_still_since = None;
                    }
                    self.odometry_stamp_ns = Some(stamp_ns);
                    self.odometry = Some((log_time, pose));
                }
            }
            (TF_STATIC, Msg::TfMessage(m)) => {
                let _rejected = self.tf.insert_message(m, true);
            }
            (JOINT_STATES, Msg::JointState(js)) => self.on_joint_state(js),
            (ENV_WIND, Msg::Float64(w)) => self.gate.on_reading(log_time, w.data),
            (PANORAMIC_INFO, Msg::CameraInfo(info)) => {
                self.panoramic_camera = PinholeCamera::from_camera_info(info).ok();
            }
            (CAMERA_COLOR_INFO, Msg::CameraInfo(info)) => {
                let camera = PinholeCamera::from_camera_info(info).ok();
                let same = matches!((&self.wrist, &camera), (Some((a, _)), Some(b)) if a == b);
                if !same {
                    self.wrist = camera.and_then(|c| RayTable::new(&c).ok().map(|r| (c, r)));
                }
            }
            (PANORAMIC_IMAGE, Msg::Image(image))
                if self.running.as_ref().is_some_and(|r| {
                    r.action.until == Until::Panoramic && log_time >= r.started
                }) =>
            {
                self.panoramic_image = Some(image.clone());
                self.running = None;
            }
            (CAMERA_COLOR_IMAGE, Msg::Image(image)) => self.on_colour(image),
            (CAMERA_DEPTH_IMAGE, Msg::Image(image)) => self.on_depth(image),
            (TASK_EVENT, Msg::TaskEvent(e))
                if e.task == CALIBRATION_TASK
                    && self
                        .running
                        .as_ref()
                        .is_some_and(|r| r.action.until == Until::Calibration) =>
            {
                self.calibration_answer = Some(e.clone());
                self.running = None;
            }
            _ => {}
        }
        Ok(self.advance())
    }
}
