//! [`FollowJointTrajectoryClient`]: a raw ROS 2 action client of
//! `control_msgs/action/FollowJointTrajectory`, the interface of ros2_control's
//! joint_trajectory_controller (and the AUBO ROS 2 driver's).
//!
//! A ROS 2 action `/a` is three services and two topics (ROS 2 design, "Actions"):
//!
//! | part | name | type |
//! |---|---|---|
//! | send goal | `/a/_action/send_goal` | `…/FollowJointTrajectory_SendGoal` (`{UUID goal_id, Goal goal}` -> `{bool accepted, Time stamp}`) |
//! | cancel | `/a/_action/cancel_goal` | `action_msgs/srv/CancelGoal` (`{GoalInfo}` -> `{int8 return_code, GoalInfo[]}`) |
//! | result | `/a/_action/get_result` | `…/FollowJointTrajectory_GetResult` (`{UUID}` -> `{int8 status, Result}`) |
//! | status | `/a/_action/status` | `action_msgs/msg/GoalStatusArray` (reliable, transient local) |
//! | feedback | `/a/_action/feedback` | not subscribed |
//!
//! The goal's wire layout is control_msgs' (Humble and later): `trajectory`,
//! `multi_dof_trajectory`, `path_tolerance`, `component_path_tolerance`, `goal_tolerance`,
//! `component_goal_tolerance`, `goal_time_tolerance`; rodlog sends the joint trajectory with
//! every other field empty (the controller's default tolerances).
//!
//! Nothing here blocks: [`FollowJointTrajectoryClient::send_goal`] and
//! [`FollowJointTrajectoryClient::cancel_all`] send requests; [`FollowJointTrajectoryClient::poll`]
//! returns what came back ([`ActionEvent`]), asking for each accepted goal's result.

use std::collections::BTreeMap;

use msgs::builtin_interfaces::{Duration as RosDuration, Time};
use msgs::geometry_msgs::{Transform, Vector3};
use msgs::std_msgs::Header;
use msgs::trajectory_msgs::JointTrajectory;
use serde::{Deserialize, Serialize};

use crate::error::Ros2Error;
use crate::node::Node;
use crate::service::{ServiceClient, ServiceMapping};

/// `unique_identifier_msgs/UUID`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Default, Serialize, Deserialize)]
pub struct Uuid {
    /// The 16 bytes.
    pub uuid: [u8; 16],
}

/// `geometry_msgs/Twist`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Twist {
    /// Linear (m/s).
    pub linear: Vector3,
    /// Angular (rad/s).
    pub angular: Vector3,
}

/// `trajectory_msgs/MultiDOFJointTrajectoryPoint`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct MultiDofPoint {
    /// Poses.
    pub transforms: Vec<Transform>,
    /// Velocities.
    pub velocities: Vec<Twist>,
    /// Accelerations.
    pub accelerations: Vec<Twist>,
    /// Time from the trajectory's start.
    pub time_from_start: RosDuration,
}

/// `trajectory_msgs/MultiDOFJointTrajectory`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct MultiDofJointTrajectory {
    /// Header.
    pub header: Header,
    /// Joint names.
    pub joint_names: Vec<String>,
    /// Points.
    pub points: Vec<MultiDofPoint>,
}

/// `control_msgs/JointTolerance`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct JointTolerance {
    /// Joint.
    pub name: String,
    /// Position tolerance.
    pub position: f64,
    /// Velocity tolerance.
    pub velocity: f64,
    /// Acceleration tolerance.
    pub acceleration: f64,
}

/// `control_msgs/JointComponentTolerance`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct JointComponentTolerance {
    /// Joint.
    pub joint_name: String,
    /// Component (`X_AXIS` = 1 .. `ROTATION` = 5).
    pub component: u16,
    /// Position tolerance.
    pub position: f64,
    /// Velocity tolerance.
    pub velocity: f64,
    /// Acceleration tolerance.
    pub acceleration: f64,
}

/// `control_msgs/action/FollowJointTrajectory` goal.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct FollowJointTrajectoryGoal {
    /// The joint trajectory.
    pub trajectory: JointTrajectory,
    /// Planar and floating joints (empty).
    pub multi_dof_trajectory: MultiDofJointTrajectory,
    /// Path tolerances (empty: the controller's).
    pub path_tolerance: Vec<JointTolerance>,
    /// Component path tolerances (empty).
    pub component_path_tolerance: Vec<JointComponentTolerance>,
    /// Goal tolerances (empty: the controller's).
    pub goal_tolerance: Vec<JointTolerance>,
    /// Component goal tolerances (empty).
    pub component_goal_tolerance: Vec<JointComponentTolerance>,
    /// Extra time allowed to reach the goal.
    pub goal_time_tolerance: RosDuration,
}

/// `…/FollowJointTrajectory_SendGoal_Request`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct SendGoalRequest {
    /// The goal's id.
    pub goal_id: Uuid,
    /// The goal.
    pub goal: FollowJointTrajectoryGoal,
}

/// `…/FollowJointTrajectory_SendGoal_Response`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct SendGoalResponse {
    /// Whether the server accepted the goal.
    pub accepted: bool,
    /// When.
    pub stamp: Time,
}

/// `…/FollowJointTrajectory_GetResult_Request`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct GetResultRequest {
    /// The goal.
    pub goal_id: Uuid,
}

/// `control_msgs/action/FollowJointTrajectory` result.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct FollowJointTrajectoryResult {
    /// `SUCCESSFUL` = 0, `INVALID_GOAL` = -1, `INVALID_JOINTS` = -2,
    /// `OLD_HEADER_TIMESTAMP` = -3, `PATH_TOLERANCE_VIOLATED` = -4,
    /// `GOAL_TOLERANCE_VIOLATED` = -5.
    pub error_code: i32,
    /// Human-readable.
    pub error_string: String,
}

/// `…/FollowJointTrajectory_GetResult_Response`.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct GetResultResponse {
    /// The goal's final status ([`GoalStatus`] values).
    pub status: i8,
    /// The result.
    pub result: FollowJointTrajectoryResult,
}

/// `action_msgs/GoalInfo`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct GoalInfo {
    /// The goal (all zeros: every goal).
    pub goal_id: Uuid,
    /// Accepted at (zero: any time).
    pub stamp: Time,
}

/// `action_msgs/srv/CancelGoal_Request`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct CancelGoalRequest {
    /// Which goals: a zero id and stamp cancel every goal.
    pub goal_info: GoalInfo,
}

/// `action_msgs/srv/CancelGoal_Response`.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct CancelGoalResponse {
    /// `ERROR_NONE` = 0, `ERROR_REJECTED` = 1, `ERROR_UNKNOWN_GOAL_ID` = 2,
    /// `ERROR_GOAL_TERMINATED` = 3.
    pub return_code: i8,
    /// The goals now canceling.
    pub goals_canceling: Vec<GoalInfo>,
}

/// `action_msgs/GoalStatus` values.
pub struct GoalStatus;

impl GoalStatus {
    /// Accepted, not executing yet.
    pub const ACCEPTED: i8 = 1;
    /// Executing.
    pub const EXECUTING: i8 = 2;
    /// Canceling.
    pub const CANCELING: i8 = 3;
    /// Succeeded.
    pub const SUCCEEDED: i8 = 4;
    /// Canceled.
    pub const CANCELED: i8 = 5;
    /// Aborted.
    pub const ABORTED: i8 = 6;

    /// A status's name.
    #[must_use]
    pub fn name(status: i8) -> &'static str {
        match status {
            Self::ACCEPTED => "accepted",
            Self::EXECUTING => "executing",
            Self::CANCELING => "canceling",
            Self::SUCCEEDED => "succeeded",
            Self::CANCELED => "canceled",
            Self::ABORTED => "aborted",
            _ => "unknown",
        }
    }
}

/// What came back from the action server.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ActionEvent {
    /// A goal was accepted or rejected.
    Goal {
        /// The goal.
        goal_id: Uuid,
        /// Accepted?
        accepted: bool,
    },
    /// A goal ended.
    Result {
        /// The goal.
        goal_id: Uuid,
        /// Its final status ([`GoalStatus`]).
        status: i8,
        /// The controller's result.
        result: FollowJointTrajectoryResult,
    },
    /// A cancel request was answered.
    Canceled {
        /// `return_code` (0: none refused).
        return_code: i8,
        /// How many goals are now canceling.
        goals: usize,
    },
}

/// The type name of the action's parts.
const ACTION_TYPE: &str = "control_msgs/action/FollowJointTrajectory";

/// Which request a pending sequence number belongs to.
#[derive(Debug, Clone, Copy)]
enum Pending {
    Goal(Uuid),
    Result(Uuid),
}

/// A raw client of one FollowJointTrajectory action (module docs).
pub struct FollowJointTrajectoryClient {
    action: String,
    send_goal: ServiceClient,
    cancel: ServiceClient,
    get_result: ServiceClient,
    pending: BTreeMap<i64, Pending>,
    next_id: u64,
}

impl std::fmt::Debug for FollowJointTrajectoryClient {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FollowJointTrajectoryClient")
            .field("action", &self.action)
            .finish_non_exhaustive()
    }
}

fn encode<T: Serialize>(action: &str, v: &T) -> Result<Vec<u8>, Ros2Error> {
    msgs::to_cdr(v).map_err(|e| Ros2Error::Write {
        topic: action.to_owned(),
        reason: e.to_string(),
    })
}

fn decode<T: serde::de::DeserializeOwned>(action: &str, cdr: &[u8]) -> Result<T, Ros2Error> {
    msgs::from_cdr(cdr).map_err(|e| Ros2Error::Read {
        topic: action.to_owned(),
        reason: e.to_string(),
    })
}

impl FollowJointTrajectoryClient {
    /// A client of `action` (e.g. `/joint_trajectory_controller/follow_joint_trajectory`);
    /// creates the request writers and reply readers of its three services.
    ///
    /// # Errors
    /// [`Ros2Error::InvalidName`], [`Ros2Error::CreateEndpoint`], [`Ros2Error::Poll`].
    pub fn new(
        node: &Node,
        action: &str,
        mapping: ServiceMapping,
    ) -> Result<FollowJointTrajectoryClient, Ros2Error> {
        let part = |p: &str| format!("{action}/_action/{p}");
        Ok(FollowJointTrajectoryClient {
            action: action.to_owned(),
            send_goal: node.service_client_raw(
                &part("send_goal"),
                &format!("{ACTION_TYPE}_SendGoal"),
                mapping,
            )?,
            cancel: node.service_client_raw(
                &part("cancel_goal"),
                "action_msgs/srv/CancelGoal",
                mapping,
            )?,
            get_result: node.service_client_raw(
                &part("get_result"),
                &format!("{ACTION_TYPE}_GetResult"),
                mapping,
            )?,
            pending: BTreeMap::new(),
            next_id: 1,
        })
    }

    /// The action's name.
    pub fn action(&self) -> &str {
        &self.action
    }

    /// Whether the server's three services are discovered.
    ///
    /// # Errors
    /// [`Ros2Error::InvalidName`].
    pub fn server_available(&self, node: &Node) -> Result<bool, Ros2Error> {
        for p in ["send_goal", "cancel_goal", "get_result"] {
            if !node.service_available(&format!("{}/_action/{p}", self.action))? {
                return Ok(false);
            }
        }
        Ok(true)
    }

    /// Sends `trajectory` as a new goal; returns its id. `seed` makes the ids unique across
    /// runs (the goal's UUID is `seed` then a counter).
    ///
    /// # Errors
    /// [`Ros2Error::Write`].
    pub fn send_goal(
        &mut self,
        trajectory: &JointTrajectory,
        seed: u64,
    ) -> Result<Uuid, Ros2Error> {
        let mut uuid = [0_u8; 16];
        uuid[..8].copy_from_slice(&seed.to_le_bytes());
        uuid[8..].copy_from_slice(&self.next_id.to_le_bytes());
        self.next_id += 1;
        let goal_id = Uuid { uuid };
        let request = SendGoalRequest {
            goal_id,
            goal: FollowJointTrajectoryGoal {
                trajectory: trajectory.clone(),
                ..FollowJointTrajectoryGoal::default()
            },
        };
        let seq = self.send_goal.send(&encode(&self.action, &request)?)?;
        self.pending.insert(seq, Pending::Goal(goal_id));
        Ok(goal_id)
    }

    /// Asks the server to cancel every goal (a zero goal id and stamp).
    ///
    /// # Errors
    /// [`Ros2Error::Write`].
    pub fn cancel_all(&mut self) -> Result<(), Ros2Error> {
        let request = CancelGoalRequest::default();
        self.cancel.send(&encode(&self.action, &request)?)?;
        Ok(())
    }

    /// What came back since the last call, without blocking; asks for the result of every
    /// goal the server accepted.
    ///
    /// # Errors
    /// [`Ros2Error::Read`] (a reply that does not decode), [`Ros2Error::Write`].
    pub fn poll(&mut self) -> Result<Vec<ActionEvent>, Ros2Error> {
        let mut events = Vec::new();
        while let Some((seq, reply)) = self.send_goal.try_reply()? {
            let Some(Pending::Goal(goal_id)) = self.pending.remove(&seq) else {
                continue;
            };
            let r: SendGoalResponse = decode(&self.action, &reply)?;
            events.push(ActionEvent::Goal {
                goal_id,
                accepted: r.accepted,
            });
            if r.accepted {
                let req = GetResultRequest { goal_id };
                let seq = self.get_result.send(&encode(&self.action, &req)?)?;
                self.pending.insert(seq, Pending::Result(goal_id));
            }
        }
        while let Some((seq, reply)) = self.get_result.try_reply()? {
            let Some(Pending::Result(goal_id)) = self.pending.remove(&seq) else {
                continue;
            };
            let r: GetResultResponse = decode(&self.action, &reply)?;
            events.push(ActionEvent::Result {
                goal_id,
                status: r.status,
                result: r.result,
            });
        }
        while let Some((_, reply)) = self.cancel.try_reply()? {
            let r: CancelGoalResponse = decode(&self.action, &reply)?;
            events.push(ActionEvent::Canceled {
                return_code: r.return_code,
                goals: r.goals_canceling.len(),
            });
        }
        Ok(events)
    }

    /// Goals sent whose acceptance or result has not come back.
    pub fn outstanding(&self) -> usize {
        self.pending.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_goal_request_lays_out_as_control_msgs_declares_it() -> Result<(), Ros2Error> {
        let request = SendGoalRequest {
            goal_id: Uuid { uuid: [7; 16] },
            goal: FollowJointTrajectoryGoal::default(),
        };
        let cdr = encode("/a", &request)?;
        // header, 16-byte uuid, JointTrajectory {Header{Time 8, "" 5 -> pad}, names 4, points 4},
        // MultiDOF {Header, names, points}, four empty sequences, Duration 8.
        assert_eq!(&cdr[..4], &[0, 1, 0, 0]);
        assert_eq!(&cdr[4..20], &[7; 16]);
        let back: SendGoalRequest = decode("/a", &cdr)?;
        assert_eq!(back, request);
        let expected_len = 4 + 16 + (8 + 5 + 3 + 4 + 4) + (8 + 5 + 3 + 4 + 4) + 4 * 4 + 8;
        assert_eq!(cdr.len(), expected_len);
        Ok(())
    }
}
