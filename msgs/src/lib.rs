//! rodlog message vocabulary: ROS 2 message structs, CDR codec, ros2msg schema texts, topic
//! registry, the Stage and driver traits.
//!
//! The bottom of the workspace: every other crate speaks these types (ARCHITECTURE.md section 3).
//!
//! | module | what |
//! |---|---|
//! | [`builtin_interfaces`], [`std_msgs`], [`geometry_msgs`], [`sensor_msgs`], [`tf2_msgs`], [`rosgraph_msgs`], [`trajectory_msgs`], [`nav_msgs`], [`rcl_interfaces`] | ROS 2 Jazzy message structs, field order = wire order |
//! | [`rodlog_msgs`] | the project's messages (ClampCommand, FeatureMatches, HandEyeCalibration, TaskEvent) |
//! | [`cdr`] | XCDR1 serde codec: [`to_cdr`], [`to_cdr_into`], [`from_cdr`] |
//! | [`schema`] | `ros2msg` schema texts, [`RosMessage`] |
//! | [`msg`] | [`Msg`], the enum over all logged types; decode by type name |
//! | [`topics`], [`frames`] | topic names and registry (QoS YAML), TF frame and joint names |
//! | [`time`] | the robot clock: [`RobotTime`], [`RobotDuration`] |
//! | [`stage`] | the [`Stage`] trait and its determinism contract |
//! | [`drivers`] | driver traits and [`World::step_until`] for lockstep simulation |
#![warn(missing_docs)]

pub mod builtin_interfaces;
pub mod cdr;
pub mod drivers;
pub mod frames;
pub mod geometry_msgs;
pub mod msg;
pub mod nav_msgs;
pub mod rcl_interfaces;
pub mod rodlog_msgs;
pub mod rosgraph_msgs;
pub mod schema;
pub mod sensor_msgs;
pub mod stage;
pub mod std_msgs;
pub mod tf2_msgs;
pub mod time;
pub mod topics;
pub mod trajectory_msgs;

pub use cdr::{CdrError, from_cdr, to_cdr, to_cdr_into};
pub use drivers::{
    ArmDriver, BaseDriver, CameraCapture, CameraDriver, ClampDriver, DriverError, DriverOutput,
    EnvironmentSensors, LiftDriver, World,
};
pub use msg::{DecodeError, Msg, MsgPayload};
pub use schema::{MsgDef, RosMessage};
pub use stage::{Stage, StageError};
pub use time::{RobotDuration, RobotTime, TimeError};
pub use topics::{TopicSpec, registry};
