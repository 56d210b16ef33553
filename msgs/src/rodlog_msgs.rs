//! `rodlog_msgs`: the project's own messages (ARCHITECTURE.md section 3). Field order is the wire
//! order; constants live in the schema text and as Rust consts, not on the wire.

use serde::{Deserialize, Serialize};

use crate::builtin_interfaces::Time;
use crate::geometry_msgs::Transform;
use crate::schema::{
    CLAMP_COMMAND, FEATURE_MATCHES, HAND_EYE_CALIBRATION, TASK_EVENT, impl_ros_message,
};
use crate::std_msgs::Header;

/// `rodlog_msgs/msg/ClampCommand`: command to the lead-screw clamp.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct ClampCommand {
    /// Stamp of the command.
    pub header: Header,
    /// [`ClampCommand::OPEN`], [`ClampCommand::CLOSE`] or [`ClampCommand::STOP`].
    pub action: u8,
    /// Motor torque limit (N m).
    pub max_torque_nm: f64,
}
impl_ros_message!(ClampCommand, "rodlog_msgs", "ClampCommand", CLAMP_COMMAND);

impl ClampCommand {
    /// Open the clamp.
    pub const OPEN: u8 = 0;
    /// Close the clamp until the torque limit.
    pub const CLOSE: u8 = 1;
    /// Stop the motor.
    pub const STOP: u8 = 2;
}

/// `rodlog_msgs/msg/FeatureMatches`: matches between two images, for the viewer.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct FeatureMatches {
    /// Stamp of the output and frame (camera optical frame).
    pub header: Header,
    /// Capture stamp of image a.
    pub stamp_a: Time,
    /// Capture stamp of image b.
    pub stamp_b: Time,
    /// Method name, e.g. `orb-gms`.
    pub method: String,
    /// Keypoints of image a, `x0, y0, x1, y1, ...` (pixels).
    pub keypoints_a: Vec<f32>,
    /// Keypoints of image b, `x0, y0, x1, y1, ...` (pixels).
    pub keypoints_b: Vec<f32>,
    /// Match pairs `ia0, ib0, ia1, ib1, ...` (keypoint indices).
    pub pairs: Vec<u32>,
    /// One flag per pair: inlier of the geometric check.
    pub inlier: Vec<bool>,
}
impl_ros_message!(
    FeatureMatches,
    "rodlog_msgs",
    "FeatureMatches",
    FEATURE_MATCHES
);

/// `rodlog_msgs/msg/HandEyeCalibration`: the estimated `tool0_from_camera` and its quality.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct HandEyeCalibration {
    /// Stamp; `frame_id` is `tool0`.
    pub header: Header,
    /// `camera_color_optical_frame`.
    pub child_frame_id: String,
    /// Maps camera coordinates to tool0 coordinates.
    pub tool0_from_camera: Transform,
    /// Solver, e.g. `ours`, `tsai`.
    pub method: String,
    /// `rgbd`, `mono` or `poses`.
    pub mode: String,
    /// Views used.
    pub views: u32,
    /// Motion pairs used.
    pub pairs: u32,
    /// Median AX=XB rotation residual over pairs (deg).
    pub residual_rot_deg: f64,
    /// Median AX=XB translation residual over pairs (mm).
    pub residual_trans_mm: f64,
    /// 1-sigma rotation uncertainty (deg).
    pub sigma_rot_deg: f64,
    /// 1-sigma translation uncertainty (mm).
    pub sigma_trans_mm: f64,
    /// Rotation-axis conditioning of the motions.
    pub condition: f64,
    /// Mono: metres per reconstruction unit; otherwise 1.
    pub scale: f64,
}
impl_ros_message!(
    HandEyeCalibration,
    "rodlog_msgs",
    "HandEyeCalibration",
    HAND_EYE_CALIBRATION
);

/// `rodlog_msgs/msg/TaskEvent`: state change, refusal or failure of a task/safety stage.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct TaskEvent {
    /// Stamp of the event.
    pub header: Header,
    /// Task name, e.g. `hang`.
    pub task: String,
    /// State-machine state.
    pub state: String,
    /// [`TaskEvent::INFO`], [`TaskEvent::REFUSED`], [`TaskEvent::FAILED`] or [`TaskEvent::DONE`].
    pub kind: u8,
    /// Machine-readable reason, e.g. `wind_above_limit`.
    pub reason_code: String,
    /// Human-readable text.
    pub text: String,
}
impl_ros_message!(TaskEvent, "rodlog_msgs", "TaskEvent", TASK_EVENT);

impl TaskEvent {
    /// Informational state change.
    pub const INFO: u8 = 0;
    /// The task refused to start or continue (safety gate).
    pub const REFUSED: u8 = 1;
    /// The task failed.
    pub const FAILED: u8 = 2;
    /// The task finished successfully.
    pub const DONE: u8 = 3;
}
