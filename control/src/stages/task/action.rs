//! Actions: what a step queues. Each is the outputs issued when it starts (a command is
//! held while the wind gate is closed), the condition that completes it ([`Until`], judged
//! against the measured robot state) and a timeout (the task fails when it passes).

use msgs::rodlog_msgs::ClampCommand;
use msgs::std_msgs::{Empty, Float64, Header, String as StringMsg};
use msgs::topics::{
    ARM_JOINT_TRAJECTORY, ARM_PLANNED_PATH, CALIBRATION_COMMAND, CAMERA_TRIGGER, CLAMP_COMMAND,
    LIFT_COMMAND,
};
use msgs::{Msg, RobotDuration, RobotTime};
use robot::RobotModel;

use super::inputs::RobotState;
use crate::motion::planner::{self, ArmPlan};
use crate::tasks::site::BasePose;

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
/// The lift is at rest below this speed (m/s).
const LIFT_REST_M_S: f64 = 1e-3;
/// A clamp action completes no earlier than this after it started (the motor must have
/// started moving).
const CLAMP_SETTLE: RobotDuration = RobotDuration::from_millis(500);

/// What completes an action.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Until {
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
pub(crate) struct Action {
    /// Outputs issued when the action starts (commands are wind-gated).
    pub outputs: Vec<(String, Msg)>,
    /// Whether the outputs include a command (the wind gate applies).
    pub command: bool,
    /// What completes it.
    pub until: Until,
    /// The task fails when it has not completed this long after it started.
    pub timeout: RobotDuration,
    /// What it does, for the timeout's message.
    pub label: &'static str,
}

impl Action {
    /// The arm along `plan` (`/arm/joint_trajectory` and `/arm/planned_path`, `header`),
    /// completed at rest at its last waypoint; timeout 1.5 times its duration plus 5 s.
    pub fn arm(plan: &ArmPlan, model: &RobotModel, header: Header, label: &'static str) -> Self {
        let goal = plan.waypoints.last().copied().unwrap_or([0.0; 6]);
        let traj = planner::plan_trajectory_msg(plan, header.clone());
        let path = planner::plan_path_msg(plan, model, header);
        let duration = plan.trajectory.duration_s();
        Self {
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

    /// The lift from `from_m` to `to_m` (clamped to its travel: goals come from measured
    /// heights too, whose noise may step out of it); timeout 1.5 times the move at full
    /// speed (with its ramps) plus 5 s.
    pub fn lift(from_m: f64, to_m: f64, label: &'static str) -> Self {
        let to_m = to_m.clamp(0.0, robot::kinematics::LIFT_TRAVEL_M);
        let seconds = (to_m - from_m).abs() / robot::kinematics::LIFT_SPEED_MAX_M_S
            + 2.0 * robot::kinematics::LIFT_SPEED_MAX_M_S / robot::kinematics::LIFT_ACCEL_MAX_M_S2;
        Self {
            outputs: vec![(LIFT_COMMAND.to_owned(), Float64 { data: to_m }.into())],
            command: true,
            until: Until::Lift(to_m),
            timeout: RobotDuration::from_secs_f64(seconds * 1.5 + 5.0)
                .unwrap_or(RobotDuration::from_secs(60)),
            label,
        }
    }

    /// A clamp command (`ClampCommand::OPEN` / `CLOSE` at `max_torque_nm`), completed when
    /// the clamp rests; timeout 25 s.
    pub fn clamp(header: Header, action: u8, max_torque_nm: f64, label: &'static str) -> Self {
        Self {
            outputs: vec![(
                CLAMP_COMMAND.to_owned(),
                ClampCommand {
                    header,
                    action,
                    max_torque_nm,
                }
                .into(),
            )],
            command: true,
            until: Until::ClampRest,
            timeout: RobotDuration::from_secs(25),
            label,
        }
    }

    /// A wrist capture (`/camera/trigger`), completed by its depth image; timeout 5 s.
    pub fn capture(label: &'static str) -> Self {
        Self {
            outputs: vec![(CAMERA_TRIGGER.to_owned(), Empty.into())],
            command: true,
            until: Until::Capture,
            timeout: RobotDuration::from_secs(5),
            label,
        }
    }

    /// A `/calibration/command` (`check`, `collect`, `solve`: not a motion, so not
    /// wind-gated); timeout 30 s.
    pub fn calibration(data: &str, until: Until, label: &'static str) -> Self {
        Self {
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

    /// Nothing sent: a wait of `hold` (`command`: wind-gated, so that it holds until the
    /// gate opens).
    pub fn wait(
        hold: RobotDuration,
        command: bool,
        timeout: RobotDuration,
        label: &'static str,
    ) -> Self {
        Self {
            outputs: Vec::new(),
            command,
            until: Until::Elapsed(hold),
            timeout,
            label,
        }
    }
}

/// The action being executed.
#[derive(Debug, Clone)]
pub(crate) struct Running {
    /// The action.
    pub action: Action,
    /// When it was issued.
    pub started: RobotTime,
}

impl Running {
    /// Whether the robot state completes the action now. Captures, panoramic frames and
    /// calibration answers are completed by the message that brings them (the driver clears
    /// the running action), never here.
    pub fn done(&self, robot: &RobotState) -> bool {
        let now = robot.now;
        match self.action.until {
            Until::Issued => true,
            Until::Elapsed(d) => now.as_nanos() >= self.started.as_nanos() + d.as_nanos(),
            Until::Arm(goal) => {
                robot.arm_at_rest
                    && robot
                        .q
                        .is_some_and(|q| (0..6).all(|j| (q[j] - goal[j]).abs() < ARRIVED_RAD))
            }
            Until::Lift(h) => {
                robot.lift_m.is_some_and(|l| (l - h).abs() < LIFT_ARRIVED_M)
                    && robot.lift_speed_m_s.abs() < LIFT_REST_M_S
            }
            Until::Base(goal) => {
                robot.odometry.is_some_and(|(_, p)| {
                    (p.x_m - goal.x_m).hypot(p.y_m - goal.y_m) < BASE_ARRIVED_M
                        && robot::se3::wrap_to_pi(p.yaw_rad - goal.yaw_rad).abs() < BASE_ARRIVED_RAD
                }) && robot
                    .base_still_since
                    .is_some_and(|t| now.saturating_duration_since(t) >= BASE_STILL_FOR)
            }
            Until::ClampRest => {
                now.saturating_duration_since(self.started) >= CLAMP_SETTLE
                    && robot
                        .clamp_rest_since
                        .is_some_and(|t| now.saturating_duration_since(t) >= CLAMP_REST_FOR)
            }
            Until::Capture | Until::Panoramic | Until::Calibration => false,
        }
    }
}
