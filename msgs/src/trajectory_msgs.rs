//! `trajectory_msgs`: JointTrajectory, JointTrajectoryPoint.

use serde::{Deserialize, Serialize};

use crate::builtin_interfaces::Duration;
use crate::schema::{JOINT_TRAJECTORY, JOINT_TRAJECTORY_POINT, impl_ros_message};
use crate::std_msgs::Header;

/// `trajectory_msgs/msg/JointTrajectory`: timed joint-space waypoints.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct JointTrajectory {
    /// Reference time (`time_from_start` is relative to `header.stamp`).
    pub header: Header,
    /// Joint names, the order of every point's arrays.
    pub joint_names: Vec<String>,
    /// Waypoints.
    pub points: Vec<JointTrajectoryPoint>,
}
impl_ros_message!(
    JointTrajectory,
    "trajectory_msgs",
    "JointTrajectory",
    JOINT_TRAJECTORY
);

/// `trajectory_msgs/msg/JointTrajectoryPoint`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct JointTrajectoryPoint {
    /// Positions (rad or m).
    pub positions: Vec<f64>,
    /// Velocities (rad/s or m/s), or empty.
    pub velocities: Vec<f64>,
    /// Accelerations (rad/s^2 or m/s^2), or empty.
    pub accelerations: Vec<f64>,
    /// Efforts (N m or N), or empty.
    pub effort: Vec<f64>,
    /// Time from the trajectory's `header.stamp`.
    pub time_from_start: Duration,
}
impl_ros_message!(
    JointTrajectoryPoint,
    "trajectory_msgs",
    "JointTrajectoryPoint",
    JOINT_TRAJECTORY_POINT
);
