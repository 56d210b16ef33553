//! The `script` stage: plays a scenario's timed command list onto the command topics, so
//! recordings that need motion exist before the task stages do (the world never moves by
//! itself).
//!
//! Input: `/clock` (every 100 ms of robot time). On each clock message at `log_time` it
//! publishes, in list order, every command whose time is `<= log_time` and that has not been
//! played yet; outputs are logged at `log_time + latency` ([`DEFAULT_LATENCY`], 1 ms). A
//! command's time is therefore honoured to the clock period (100 ms): scenario times on the
//! 0.1 s grid are played exactly at their time (+ latency). Deterministic: no state but the
//! index of the next command; commands with equal times keep their list order.
//!
//! | kind | values | topic | message |
//! |---|---|---|---|
//! | `joints` | 6 angles J1..J6 (rad) [+ `duration_s`] | `/arm/joint_trajectory` | one point, `time_from_start = duration_s` (0 = as fast as the arm's limits allow) |
//! | `lift` | height (m) | `/lift/command` | Float64 |
//! | `base` | `x_m, y_m, yaw_rad` | `/base/goal` | PoseStamped in `map` |
//! | `clamp` | action (0 open, 1 close, 2 stop) [, `max_torque_nm`, default 5] | `/clamp/command` | ClampCommand |
//! | `capture` | none | `/camera/trigger` | Empty |
//!
//! The command list comes from the scenario file (the CLI converts the simulator's plain
//! command records with [`ScriptCommand::from_parts`]; control never depends on sim).
//! Malformed commands (unknown kind, wrong number of values, non-finite values, joints
//! outside +-175 deg, lift outside its travel, unknown clamp action) are rejected when the
//! stage is built, with the command's index.

use msgs::builtin_interfaces::Time;
use msgs::frames::{ARM_JOINT_NAMES, MAP};
use msgs::geometry_msgs::{Point, Pose, PoseStamped, Quaternion};
use msgs::rodlog_msgs::ClampCommand;
use msgs::std_msgs::{Empty, Float64, Header};
use msgs::topics::{
    ARM_JOINT_TRAJECTORY, BASE_GOAL, CAMERA_TRIGGER, CLAMP_COMMAND, CLOCK, LIFT_COMMAND,
};
use msgs::trajectory_msgs::{JointTrajectory, JointTrajectoryPoint};
use msgs::{Msg, RobotDuration, RobotTime, RosMessage, Stage, StageError};
use thiserror::Error;

/// Stage name (channel metadata `producer=script`).
pub const STAGE_NAME: &str = "script";
/// Output latency.
pub const DEFAULT_LATENCY: RobotDuration = RobotDuration::from_millis(1);
/// Clamp torque limit when a `clamp` command gives none (N m).
pub const DEFAULT_CLAMP_TORQUE_NM: f64 = 5.0;

/// A malformed command.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ScriptError {
    /// The time is negative, non-finite or too large.
    #[error("command {index}: time {t_s} s is not a valid robot time")]
    Time {
        /// Index in the list.
        index: usize,
        /// The time given.
        t_s: f64,
    },
    /// Unknown kind.
    #[error("command {index}: unknown kind {kind:?} (joints, lift, base, clamp, capture)")]
    UnknownKind {
        /// Index in the list.
        index: usize,
        /// The kind given.
        kind: String,
    },
    /// Wrong number of values.
    #[error("command {index}: {kind} takes {min}..={max} values, got {got}")]
    Arity {
        /// Index in the list.
        index: usize,
        /// Kind.
        kind: String,
        /// Fewest values.
        min: usize,
        /// Most values.
        max: usize,
        /// Values given.
        got: usize,
    },
    /// A value is NaN or infinite.
    #[error("command {index}: value {value_index} is not finite ({value})")]
    NonFinite {
        /// Index in the list.
        index: usize,
        /// Which value.
        value_index: usize,
        /// The value.
        value: f64,
    },
    /// A value is outside its range.
    #[error("command {index}: {what} = {value} outside [{min}, {max}]")]
    OutOfRange {
        /// Index in the list.
        index: usize,
        /// What (joint name, `lift height_m`, `duration_s`, `clamp action`...).
        what: String,
        /// The value.
        value: f64,
        /// Lower bound.
        min: f64,
        /// Upper bound.
        max: f64,
    },
}

/// What a command does.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ScriptAction {
    /// Arm joint goal.
    Joints {
        /// J1..J6 (rad).
        positions_rad: [f64; 6],
        /// Requested duration (0 = as fast as allowed).
        duration: RobotDuration,
    },
    /// Lift height.
    Lift {
        /// Height (m).
        height_m: f64,
    },
    /// Base goal in `map`.
    Base {
        /// x (m).
        x_m: f64,
        /// y (m).
        y_m: f64,
        /// Yaw (rad).
        yaw_rad: f64,
    },
    /// Clamp command.
    Clamp {
        /// [`ClampCommand::OPEN`], [`ClampCommand::CLOSE`] or [`ClampCommand::STOP`].
        action: u8,
        /// Torque limit (N m).
        max_torque_nm: f64,
    },
    /// Wrist camera capture request.
    Capture,
}

/// One timed command.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScriptCommand {
    /// When to publish it.
    pub at: RobotTime,
    /// What.
    pub action: ScriptAction,
}

impl ScriptCommand {
    /// Builds and validates command `index` from its plain parts (a scenario's `[[command]]`:
    /// `t_s`, `kind`, `values`, `duration_s`).
    ///
    /// # Errors
    /// [`ScriptError`] naming the index and the problem.
    pub fn from_parts(
        index: usize,
        t_s: f64,
        kind: &str,
        values: &[f64],
        duration_s: f64,
    ) -> Result<Self, ScriptError> {
        let at = RobotTime::from_secs_f64(t_s).map_err(|_| ScriptError::Time { index, t_s })?;
        let Some((min, max)) = scenario::CommandKind::parse(kind).map(scenario::CommandKind::arity)
        else {
            return Err(ScriptError::UnknownKind {
                index,
                kind: kind.to_owned(),
            });
        };
        if values.len() < min || values.len() > max {
            return Err(ScriptError::Arity {
                index,
                kind: kind.to_owned(),
                min,
                max,
                got: values.len(),
            });
        }
        if let Some((value_index, &value)) = values.iter().enumerate().find(|(_, v)| !v.is_finite())
        {
            return Err(ScriptError::NonFinite {
                index,
                value_index,
                value,
            });
        }
        let range = |what: &str, value: f64, min: f64, max: f64| {
            if (min..=max).contains(&value) {
                Ok(value)
            } else {
                Err(ScriptError::OutOfRange {
                    index,
                    what: what.to_owned(),
                    value,
                    min,
                    max,
                })
            }
        };
        let duration = RobotDuration::from_secs_f64(range("duration_s", duration_s, 0.0, 3600.0)?)
            .map_err(|_| ScriptError::OutOfRange {
                index,
                what: "duration_s".to_owned(),
                value: duration_s,
                min: 0.0,
                max: 3600.0,
            })?;
        let v = |i: usize| values.get(i).copied().unwrap_or(0.0);
        let action = match kind {
            "joints" => {
                let limits = robot::aubo_i10::aubo_i10_limits();
                let mut positions_rad = [0.0; 6];
                for (j, (q, l)) in positions_rad.iter_mut().zip(&limits).enumerate() {
                    *q = range(ARM_JOINT_NAMES[j], v(j), l.position_min, l.position_max)?;
                }
                ScriptAction::Joints {
                    positions_rad,
                    duration,
                }
            }
            "lift" => ScriptAction::Lift {
                height_m: range("lift height_m", v(0), 0.0, robot::kinematics::LIFT_TRAVEL_M)?,
            },
            "base" => ScriptAction::Base {
                x_m: v(0),
                y_m: v(1),
                yaw_rad: v(2),
            },
            "clamp" => {
                let a = range("clamp action", v(0), 0.0, 2.0)?;
                if a.fract() != 0.0 {
                    return Err(ScriptError::OutOfRange {
                        index,
                        what: "clamp action (0, 1 or 2)".to_owned(),
                        value: a,
                        min: 0.0,
                        max: 2.0,
                    });
                }
                let max_torque_nm = if values.len() > 1 {
                    range("clamp max_torque_nm", v(1), 0.0, 20.0)?
                } else {
                    DEFAULT_CLAMP_TORQUE_NM
                };
                ScriptAction::Clamp {
                    action: a as u8,
                    max_torque_nm,
                }
            }
            _ => ScriptAction::Capture,
        };
        Ok(Self { at, action })
    }

    /// The `(topic, message)` this command publishes, stamped `stamp`.
    #[must_use]
    pub fn message(&self, stamp: Time) -> (String, Msg) {
        let header = Header {
            stamp,
            frame_id: String::new(),
        };
        match self.action {
            ScriptAction::Joints {
                positions_rad,
                duration,
            } => {
                let traj = JointTrajectory {
                    header,
                    joint_names: ARM_JOINT_NAMES.iter().map(|s| (*s).to_owned()).collect(),
                    points: vec![JointTrajectoryPoint {
                        positions: positions_rad.to_vec(),
                        time_from_start: duration.to_ros().unwrap_or_default(),
                        ..Default::default()
                    }],
                };
                (ARM_JOINT_TRAJECTORY.to_owned(), traj.into())
            }
            ScriptAction::Lift { height_m } => {
                (LIFT_COMMAND.to_owned(), Float64 { data: height_m }.into())
            }
            ScriptAction::Base { x_m, y_m, yaw_rad } => {
                let (s, c) = (0.5 * yaw_rad).sin_cos();
                let goal = PoseStamped {
                    header: Header {
                        stamp,
                        frame_id: MAP.to_owned(),
                    },
                    pose: Pose {
                        position: Point {
                            x: x_m,
                            y: y_m,
                            z: 0.0,
                        },
                        orientation: Quaternion {
                            x: 0.0,
                            y: 0.0,
                            z: s,
                            w: c,
                        },
                    },
                };
                (BASE_GOAL.to_owned(), goal.into())
            }
            ScriptAction::Clamp {
                action,
                max_torque_nm,
            } => (
                CLAMP_COMMAND.to_owned(),
                ClampCommand {
                    header,
                    action,
                    max_torque_nm,
                }
                .into(),
            ),
            ScriptAction::Capture => (CAMERA_TRIGGER.to_owned(), Empty.into()),
        }
    }
}

/// The `script` stage. See the module docs.
#[derive(Debug, Clone, PartialEq)]
pub struct ScriptStage {
    commands: Vec<ScriptCommand>,
    next: usize,
    latency: RobotDuration,
}

impl ScriptStage {
    /// A stage playing `commands` (stably sorted by time).
    #[must_use]
    pub fn new(mut commands: Vec<ScriptCommand>) -> Self {
        commands.sort_by_key(|c| c.at);
        Self {
            commands,
            next: 0,
            latency: DEFAULT_LATENCY,
        }
    }

    /// The stage of a scenario's `[[command]]` list.
    ///
    /// # Errors
    /// The first [`ScriptError`] (a time beyond the robot clock, a value out of range).
    pub fn from_commands(commands: &[scenario::Command]) -> Result<Self, ScriptError> {
        Self::from_parts(
            commands
                .iter()
                .map(|c| (c.t_s, c.kind.as_str(), c.values.as_slice(), c.duration_s)),
        )
    }

    /// Builds the list from plain parts `(t_s, kind, values, duration_s)`, indexed in order.
    ///
    /// # Errors
    /// The first [`ScriptError`].
    pub fn from_parts<'a, I>(parts: I) -> Result<Self, ScriptError>
    where
        I: IntoIterator<Item = (f64, &'a str, &'a [f64], f64)>,
    {
        let commands = parts
            .into_iter()
            .enumerate()
            .map(|(i, (t, kind, values, duration))| {
                ScriptCommand::from_parts(i, t, kind, values, duration)
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Self::new(commands))
    }

    /// The commands, sorted by time.
    #[must_use]
    pub fn commands(&self) -> &[ScriptCommand] {
        &self.commands
    }

    /// Commands not played yet.
    #[must_use]
    pub fn remaining(&self) -> usize {
        self.commands.len() - self.next.min(self.commands.len())
    }
}

impl Stage for ScriptStage {
    fn name(&self) -> &str {
        STAGE_NAME
    }

    fn inputs(&self) -> Vec<String> {
        vec![CLOCK.to_owned()]
    }

    fn outputs(&self) -> Vec<(String, &'static str)> {
        vec![
            (ARM_JOINT_TRAJECTORY.to_owned(), JointTrajectory::TYPE_NAME),
            (LIFT_COMMAND.to_owned(), Float64::TYPE_NAME),
            (BASE_GOAL.to_owned(), PoseStamped::TYPE_NAME),
            (CLAMP_COMMAND.to_owned(), ClampCommand::TYPE_NAME),
            (CAMERA_TRIGGER.to_owned(), Empty::TYPE_NAME),
        ]
    }

    fn latency(&self) -> RobotDuration {
        self.latency
    }

    fn on_message(
        &mut self,
        log_time: RobotTime,
        topic: &str,
        msg: &Msg,
    ) -> Result<Vec<(String, Msg)>, StageError> {
        if topic != CLOCK {
            return Ok(Vec::new());
        }
        if !matches!(msg, Msg::Clock(_)) {
            return Err(StageError::UnexpectedType {
                stage: STAGE_NAME.to_owned(),
                topic: topic.to_owned(),
                log_time,
                expected: msgs::rosgraph_msgs::Clock::TYPE_NAME,
                got: msg.type_name(),
            });
        }
        let stamp = (log_time + self.latency)
            .to_ros()
            .map_err(|e| StageError::Failed {
                stage: STAGE_NAME.to_owned(),
                log_time,
                reason: e.to_string(),
            })?;
        let mut out = Vec::new();
        while let Some(c) = self.commands.get(self.next) {
            if c.at > log_time {
                break;
            }
            out.push(c.message(stamp));
            self.next += 1;
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use msgs::rosgraph_msgs::Clock;

    fn run(stage: &mut ScriptStage, until_ms: u64) -> Result<Vec<(u64, String)>, StageError> {
        let mut out = Vec::new();
        for k in 0..=until_ms / 100 {
            let t = RobotTime::from_millis(100 * k);
            for (topic, _) in stage.on_message(t, CLOCK, &Clock::default().into())? {
                out.push((100 * k, topic));
            }
        }
        Ok(out)
    }

    #[test]
    fn plays_each_command_once_when_the_clock_passes_its_time()
    -> Result<(), Box<dyn std::error::Error>> {
        let q = [0.0, 0.3, 1.2, 0.0, 1.5, 0.0];
        let mut stage = ScriptStage::from_parts([
            (1.0, "joints", &q[..], 2.0),
            (0.25, "lift", &[0.4][..], 0.0),
            (1.0, "capture", &[][..], 0.0),
            (2.0, "clamp", &[1.0, 8.0][..], 0.0),
            (2.0, "base", &[1.0, 2.0, 0.5][..], 0.0),
        ])?;
        let out = run(&mut stage, 3000)?;
        assert_eq!(
            out,
            vec![
                (300, LIFT_COMMAND.to_owned()),
                (1000, ARM_JOINT_TRAJECTORY.to_owned()),
                (1000, CAMERA_TRIGGER.to_owned()),
                (2000, CLAMP_COMMAND.to_owned()),
                (2000, BASE_GOAL.to_owned()),
            ]
        );
        assert_eq!(stage.remaining(), 0);
        let (_, msg) = stage.commands()[1].message(Time::default());
        let traj = msg.get::<JointTrajectory>().ok_or("not a trajectory")?;
        assert_eq!(traj.points[0].positions, q.to_vec());
        assert_eq!(traj.points[0].time_from_start.sec, 2);
        Ok(())
    }

    #[test]
    fn malformed_commands_are_errors_with_their_index() {
        let e = |parts: Vec<(f64, &'static str, &'static [f64], f64)>| {
            ScriptStage::from_parts(parts).err()
        };
        assert!(matches!(
            e(vec![(0.0, "grab", &[], 0.0)]),
            Some(ScriptError::UnknownKind { index: 0, .. })
        ));
        assert!(matches!(
            e(vec![(0.0, "capture", &[], 0.0), (1.0, "lift", &[], 0.0)]),
            Some(ScriptError::Arity { index: 1, .. })
        ));
        assert!(matches!(
            e(vec![(0.0, "lift", &[f64::NAN], 0.0)]),
            Some(ScriptError::NonFinite { index: 0, .. })
        ));
        assert!(matches!(
            e(vec![(0.0, "lift", &[3.0], 0.0)]),
            Some(ScriptError::OutOfRange { .. })
        ));
        assert!(matches!(
            e(vec![(0.0, "joints", &[0.0, 0.0, 4.0, 0.0, 0.0, 0.0], 0.0)]),
            Some(ScriptError::OutOfRange { .. })
        ));
        assert!(matches!(
            e(vec![(0.0, "clamp", &[1.5], 0.0)]),
            Some(ScriptError::OutOfRange { .. })
        ));
        assert!(matches!(
            e(vec![(-1.0, "capture", &[], 0.0)]),
            Some(ScriptError::Time { index: 0, .. })
        ));
    }
}
