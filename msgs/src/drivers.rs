//! Driver traits: the seam a simulator or real hardware (AUBO SDK, Mech-Eye API, lift and
//! base controllers, anemometer, lux meter) fills, in robot-clock terms.
//!
//! # Conventions
//!
//! - Every call takes `now: RobotTime`, the robot clock at which the call happens; drivers
//!   never read a wall clock themselves (the live runtime converts its clock to `RobotTime`
//!   once and passes it in), so a simulator can be stepped in lockstep.
//! - Stamps: `header.stamp` = time the physical quantity was sampled (image exposure,
//!   encoder read); `publish_time` of a [`DriverOutput`] = when the driver delivered it
//!   (device time); `log_time` = when the runtime logged it (robot clock). For hardware
//!   `header.stamp <= publish_time <= log_time`.
//! - Units: SI and radians (`m`, `rad`, `m/s`, `N m`, `lx`); joint order and names from
//!   [`crate::frames`].
//! - Errors: [`DriverError`]; a device that drops samples (live hardware cannot be
//!   back-pressured) counts them and reports the count, it never blocks the caller.
//!
//! Rates (ARCHITECTURE.md section 6): wrist camera on request, about 1 s per capture; panoramic
//! camera <= 1 Hz; joint states of arm, lift and clamp typically 100 Hz; odometry 50 Hz;
//! environment sensors 1 Hz.

use thiserror::Error;

use crate::geometry_msgs::{PoseStamped, TransformStamped};
use crate::msg::Msg;
use crate::rodlog_msgs::ClampCommand;
use crate::sensor_msgs::{CameraInfo, Illuminance, Image, JointState};
use crate::std_msgs::Float64;
use crate::time::RobotTime;
use crate::trajectory_msgs::JointTrajectory;

/// Errors of drivers and of [`World`].
#[derive(Debug, Clone, PartialEq, Error)]
pub enum DriverError {
    /// The device is busy with a previous request (e.g. a capture in progress).
    #[error("{device} busy until {busy_until} (request at {now})")]
    Busy {
        /// Device name.
        device: String,
        /// Request time.
        now: RobotTime,
        /// When it will accept the next request.
        busy_until: RobotTime,
    },
    /// A command was rejected (out of limits, wrong joint names, unreachable goal...).
    #[error("{device} rejected command at {now}: {reason}")]
    Rejected {
        /// Device name.
        device: String,
        /// Request time.
        now: RobotTime,
        /// Why.
        reason: String,
    },
    /// A command arrived on a topic nobody handles, or with the wrong type.
    #[error("no driver handles {type_name} on {topic}")]
    UnroutableCommand {
        /// Topic.
        topic: String,
        /// Type name.
        type_name: &'static str,
    },
    /// Time went backwards: a call with `now` earlier than a previous one.
    #[error("{device}: time went backwards from {last} to {now}")]
    TimeWentBackwards {
        /// Device name.
        device: String,
        /// Previous time.
        last: RobotTime,
        /// This call's time.
        now: RobotTime,
    },
    /// A device fault (communication loss, emergency stop, hardware error).
    #[error("{device} fault at {now}: {reason}")]
    Fault {
        /// Device name.
        device: String,
        /// Time of detection.
        now: RobotTime,
        /// Vendor error text.
        reason: String,
    },
}

/// One message a driver delivers.
#[derive(Debug, Clone, PartialEq)]
pub struct DriverOutput {
    /// Producer name for channel metadata (`producer=<name>`), e.g. `camera_driver`.
    pub producer: String,
    /// Topic.
    pub topic: String,
    /// The message.
    pub msg: Msg,
    /// Robot-clock time the runtime logs it at.
    pub log_time: RobotTime,
    /// Device/driver delivery time.
    pub publish_time: RobotTime,
}

/// The result of one wrist-camera capture (structured light: colour and registered depth
/// share one stamp, the exposure time).
#[derive(Debug, Clone, PartialEq)]
pub struct CameraCapture {
    /// Colour image (`rgb8`), frame `camera_color_optical_frame`.
    pub color: Image,
    /// Registered depth (`32FC1` m or `16UC1` mm), same stamp and frame; `None` when the
    /// device delivers colour only.
    pub depth: Option<Image>,
    /// Intrinsics at the image size.
    pub camera_info: CameraInfo,
    /// When the capture finished and became available (>= the images' stamp).
    pub ready_at: RobotTime,
}

/// A camera that captures on request (Mech-Eye NANO class; about 1 s per capture).
pub trait CameraDriver {
    /// Starts a capture at `now`; returns when its result will be ready.
    ///
    /// # Errors
    /// [`DriverError::Busy`] while a capture is in progress; [`DriverError::Fault`].
    fn request_capture(&mut self, now: RobotTime) -> Result<RobotTime, DriverError>;

    /// The finished capture, if one became ready at or before `now` (each returned once).
    ///
    /// # Errors
    /// [`DriverError::Fault`].
    fn poll_capture(&mut self, now: RobotTime) -> Result<Option<CameraCapture>, DriverError>;
}

/// The 6-axis arm (AUBO i10): trajectory in, joint states out.
pub trait ArmDriver {
    /// Starts executing `trajectory` (joint names of [`crate::frames::ARM_JOINT_NAMES`];
    /// `time_from_start` relative to `now`), replacing any running one.
    ///
    /// # Errors
    /// [`DriverError::Rejected`] for unknown joints, limits or speeds beyond the arm's.
    fn execute(&mut self, now: RobotTime, trajectory: &JointTrajectory) -> Result<(), DriverError>;

    /// Measured arm joint state at `now` (rad, rad/s, N m).
    ///
    /// # Errors
    /// [`DriverError::Fault`].
    fn joint_state(&mut self, now: RobotTime) -> Result<JointState, DriverError>;
}

/// The lift platform: height command (m) in, `lift_joint` state out.
pub trait LiftDriver {
    /// Commands the lift height (`lift_joint`, m).
    ///
    /// # Errors
    /// [`DriverError::Rejected`] outside the travel range.
    fn command_height(&mut self, now: RobotTime, height_m: &Float64) -> Result<(), DriverError>;

    /// Measured `lift_joint` state (m, m/s).
    ///
    /// # Errors
    /// [`DriverError::Fault`].
    fn joint_state(&mut self, now: RobotTime) -> Result<JointState, DriverError>;
}

/// The mobile base: goal pose in `map`, odometry `map -> base_link` out.
pub trait BaseDriver {
    /// Drives to `goal` (frame `map`).
    ///
    /// # Errors
    /// [`DriverError::Rejected`] for unreachable goals or other frames.
    fn command_goal(&mut self, now: RobotTime, goal: &PoseStamped) -> Result<(), DriverError>;

    /// Odometry `map_from_base_link` at `now`.
    ///
    /// # Errors
    /// [`DriverError::Fault`].
    fn odometry(&mut self, now: RobotTime) -> Result<TransformStamped, DriverError>;
}

/// The lead-screw clamp: command in, `clamp_joint` (m of travel) state out.
pub trait ClampDriver {
    /// Opens, closes (up to `max_torque_nm`) or stops the clamp.
    ///
    /// # Errors
    /// [`DriverError::Rejected`] for an unknown action.
    fn command(&mut self, now: RobotTime, command: &ClampCommand) -> Result<(), DriverError>;

    /// Measured `clamp_joint` state (m, m/s, N m motor torque as effort).
    ///
    /// # Errors
    /// [`DriverError::Fault`].
    fn joint_state(&mut self, now: RobotTime) -> Result<JointState, DriverError>;
}

/// Anemometer and lux meter: noisy, lagged robot sensors.
pub trait EnvironmentSensors {
    /// Wind speed, 3-s mean (m/s), as the anemometer reports it.
    ///
    /// # Errors
    /// [`DriverError::Fault`].
    fn wind_mps(&mut self, now: RobotTime) -> Result<Float64, DriverError>;

    /// Illuminance (lx) as the lux meter reports it.
    ///
    /// # Errors
    /// [`DriverError::Fault`].
    fn illuminance(&mut self, now: RobotTime) -> Result<Illuminance, DriverError>;
}

/// The whole robot-plus-environment as the scheduler sees it: stepped in lockstep with the
/// stages (simulation) or polled (hardware).
pub trait World {
    /// Advances to `log_time` and returns every message the drivers produced in
    /// `(previous step, log_time]`, sorted by `(log_time, producer, topic)`.
    ///
    /// # Errors
    /// [`DriverError::TimeWentBackwards`] if `log_time` is earlier than the last step;
    /// device faults.
    fn step_until(&mut self, log_time: RobotTime) -> Result<Vec<DriverOutput>, DriverError>;

    /// Routes a command a stage published (e.g. `/arm/joint_trajectory`,
    /// `/camera/trigger`) to its driver, effective at `log_time`.
    ///
    /// # Errors
    /// [`DriverError::UnroutableCommand`] for topics/types no driver handles; the driver's
    /// own rejection.
    fn command(&mut self, log_time: RobotTime, topic: &str, msg: &Msg) -> Result<(), DriverError>;
}
