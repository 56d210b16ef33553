//! Two small real stages that exercise the runner until the control and calibration stages
//! land: one that commands (periodic work driven by `/clock`), one that watches (latency,
//! `/rosout`).
//!
//! * [`ArmExerciser`] (`arm_exerciser`): every `period_s` of robot time, from `start_s` on,
//!   commands the arm to the next goal of a fixed sequence around the home pose,
//!   `goal_k[j] = center[j] + amplitude_rad * sin(0.9 k + 1.3 j)`, reached in
//!   `0.8 * period_s` (a `/arm/joint_trajectory` with one point).
//! * [`JointLimitMonitor`] (`joint_limit_monitor`): watches the arm joints on `/joint_states`
//!   and logs a `/rosout` WARN when a joint goes beyond `+-soft_limit_rad`, an INFO when it
//!   is back (edges only, so the log stays small).

use msgs::builtin_interfaces::Duration;
use msgs::frames::ARM_JOINT_NAMES;
use msgs::rcl_interfaces::Log;
use msgs::rosgraph_msgs::Clock;
use msgs::sensor_msgs::JointState;
use msgs::std_msgs::Header;
use msgs::trajectory_msgs::{JointTrajectory, JointTrajectoryPoint};
use msgs::{Msg, RobotDuration, RobotTime, Stage, StageError};

use crate::runner::rosout;
use scenario::{ParamError, Reader};

/// Name of [`ArmExerciser`].
pub const ARM_EXERCISER: &str = "arm_exerciser";
/// Name of [`JointLimitMonitor`].
pub const JOINT_LIMIT_MONITOR: &str = "joint_limit_monitor";
/// Centre of the exerciser's goals (the test world's home pose), rad.
pub const EXERCISE_CENTER_RAD: [f64; 6] = [0.0, 0.3, 1.2, 0.0, 1.57, 0.0];

/// Commands a fixed goal sequence on `/clock`. See the module docs.
#[derive(Debug, Clone)]
pub struct ArmExerciser {
    period: RobotDuration,
    latency: RobotDuration,
    amplitude_rad: f64,
    next_goal_at: RobotTime,
    goals_sent: u64,
}

impl ArmExerciser {
    /// From `arm_exerciser.{period_s, start_s, amplitude_rad, latency_ms}`.
    ///
    /// # Errors
    /// [`ParamError::Value`] for invalid values.
    pub fn from_params(r: &mut Reader<'_>) -> Result<Self, ParamError> {
        let mut s = r.section(ARM_EXERCISER);
        let period_s = s.f64("period_s", 2.0, "s", "time between goals (>= 0.1)")?;
        let next_goal_at = s.time_s("start_s", RobotTime::from_millis(500), "first goal")?;
        let amplitude_rad = s.f64(
            "amplitude_rad",
            0.6,
            "rad",
            "goal amplitude around the home pose",
        )?;
        let latency = s.millis(
            "latency_ms",
            RobotDuration::from_millis(10),
            "stage latency",
        )?;
        let period = RobotDuration::from_secs_f64(period_s)
            .ok()
            .filter(|d| *d >= RobotDuration::from_millis(100))
            .ok_or_else(|| ParamError::Value {
                key: "arm_exerciser.period_s".to_owned(),
                value: period_s.to_string(),
                reason: "must be >= 0.1".to_owned(),
            })?;
        Ok(Self {
            period,
            latency,
            amplitude_rad,
            next_goal_at,
            goals_sent: 0,
        })
    }

    fn goal(&self, k: u64) -> [f64; 6] {
        let mut g = EXERCISE_CENTER_RAD;
        for (j, q) in g.iter_mut().enumerate() {
            *q += self.amplitude_rad * (0.9 * k as f64 + 1.3 * j as f64).sin();
        }
        g
    }
}

impl Stage for ArmExerciser {
    fn name(&self) -> &str {
        ARM_EXERCISER
    }

    fn inputs(&self) -> Vec<String> {
        vec![msgs::topics::CLOCK.to_owned()]
    }

    fn outputs(&self) -> Vec<(String, &'static str)> {
        vec![(
            msgs::topics::ARM_JOINT_TRAJECTORY.to_owned(),
            <JointTrajectory as msgs::RosMessage>::TYPE_NAME,
        )]
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
        if msg.get::<Clock>().is_none() {
            return Err(StageError::UnexpectedType {
                stage: ARM_EXERCISER.to_owned(),
                topic: topic.to_owned(),
                log_time,
                expected: <Clock as msgs::RosMessage>::TYPE_NAME,
                got: msg.type_name(),
            });
        }
        if log_time < self.next_goal_at {
            return Ok(Vec::new());
        }
        let goal = self.goal(self.goals_sent);
        self.goals_sent += 1;
        self.next_goal_at += self.period;
        let reach = RobotDuration::from_nanos(self.period.as_nanos() / 10 * 8);
        let out_time = log_time + self.latency;
        let traj = JointTrajectory {
            header: Header {
                stamp: out_time.to_ros().unwrap_or_default(),
                frame_id: String::new(),
            },
            joint_names: ARM_JOINT_NAMES.iter().map(|s| (*s).to_owned()).collect(),
            points: vec![JointTrajectoryPoint {
                positions: goal.to_vec(),
                velocities: Vec::new(),
                accelerations: Vec::new(),
                effort: Vec::new(),
                time_from_start: reach.to_ros().unwrap_or(Duration { sec: 0, nanosec: 0 }),
            }],
        };
        Ok(vec![(
            msgs::topics::ARM_JOINT_TRAJECTORY.to_owned(),
            Msg::JointTrajectory(traj),
        )])
    }
}

/// Logs soft-limit crossings of the arm joints. See the module docs.
#[derive(Debug, Clone)]
pub struct JointLimitMonitor {
    soft_limit_rad: f64,
    latency: RobotDuration,
    beyond: [bool; 6],
}

impl JointLimitMonitor {
    /// From `joint_limit_monitor.{soft_limit_rad, latency_ms}`.
    ///
    /// # Errors
    /// [`ParamError::Value`] for invalid values.
    pub fn from_params(r: &mut Reader<'_>) -> Result<Self, ParamError> {
        let mut s = r.section(JOINT_LIMIT_MONITOR);
        let soft_limit_rad = s.f64(
            "soft_limit_rad",
            2.0,
            "rad",
            "warn beyond +-this joint angle (> 0)",
        )?;
        let latency = s.millis("latency_ms", RobotDuration::from_millis(2), "stage latency")?;
        if soft_limit_rad <= 0.0 {
            return Err(ParamError::Value {
                key: "joint_limit_monitor.soft_limit_rad".to_owned(),
                value: soft_limit_rad.to_string(),
                reason: "must be > 0".to_owned(),
            });
        }
        Ok(Self {
            soft_limit_rad,
            latency,
            beyond: [false; 6],
        })
    }
}

impl Stage for JointLimitMonitor {
    fn name(&self) -> &str {
        JOINT_LIMIT_MONITOR
    }

    fn inputs(&self) -> Vec<String> {
        vec![msgs::topics::JOINT_STATES.to_owned()]
    }

    fn outputs(&self) -> Vec<(String, &'static str)> {
        vec![(
            msgs::topics::ROSOUT.to_owned(),
            <Log as msgs::RosMessage>::TYPE_NAME,
        )]
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
        let Some(js) = msg.get::<JointState>() else {
            return Err(StageError::UnexpectedType {
                stage: JOINT_LIMIT_MONITOR.to_owned(),
                topic: topic.to_owned(),
                log_time,
                expected: <JointState as msgs::RosMessage>::TYPE_NAME,
                got: msg.type_name(),
            });
        };
        if js.position.len() != js.name.len() {
            return Err(StageError::InvalidInput {
                stage: JOINT_LIMIT_MONITOR.to_owned(),
                topic: topic.to_owned(),
                log_time,
                reason: format!("{} names, {} positions", js.name.len(), js.position.len()),
            });
        }
        let out_time = log_time + self.latency;
        let mut out = Vec::new();
        for (name, &q) in js.name.iter().zip(&js.position) {
            let Some(j) = ARM_JOINT_NAMES.iter().position(|n| n == name) else {
                continue;
            };
            let now_beyond = q.abs() > self.soft_limit_rad;
            let Some(was) = self.beyond.get_mut(j) else {
                continue;
            };
            if now_beyond != *was {
                *was = now_beyond;
                let (level, text) = if now_beyond {
                    (
                        Log::WARN,
                        format!(
                            "{name} at {q:.4} rad, beyond soft limit {:.4} rad",
                            self.soft_limit_rad
                        ),
                    )
                } else {
                    (
                        Log::INFO,
                        format!("{name} back within soft limit at {q:.4} rad"),
                    )
                };
                out.push((
                    msgs::topics::ROSOUT.to_owned(),
                    rosout(JOINT_LIMIT_MONITOR, out_time, level, text),
                ));
            }
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn clock(ms: u64) -> Msg {
        Msg::Clock(Clock {
            clock: RobotTime::from_millis(ms).to_ros().unwrap_or_default(),
        })
    }

    #[test]
    fn exerciser_sends_one_goal_per_period() -> Result<(), Box<dyn std::error::Error>> {
        let mut s = ArmExerciser::from_params(&mut Reader::new(&scenario::Params::new()))?;
        let mut sent = 0;
        for k in 0..=50u64 {
            let t = RobotTime::from_millis(k * 100);
            sent += s.on_message(t, "/clock", &clock(k * 100))?.len();
        }
        // Goals at 0.5, 2.5, 4.5 s.
        assert_eq!(sent, 3);
        assert!(
            s.on_message(RobotTime::ZERO, "/x", &Msg::Float64(Default::default()))
                .is_err()
        );
        Ok(())
    }

    #[test]
    fn monitor_logs_edges_only() -> Result<(), Box<dyn std::error::Error>> {
        let mut m = JointLimitMonitor::from_params(&mut Reader::new(&scenario::Params::new()))?;
        let js = |q: f64| {
            Msg::JointState(JointState {
                name: vec![ARM_JOINT_NAMES[4].to_owned()],
                position: vec![q],
                ..Default::default()
            })
        };
        let t = RobotTime::from_millis(1);
        assert!(m.on_message(t, "/joint_states", &js(1.9))?.is_empty());
        assert_eq!(m.on_message(t, "/joint_states", &js(2.1))?.len(), 1);
        assert!(m.on_message(t, "/joint_states", &js(2.2))?.is_empty());
        let back = m.on_message(t, "/joint_states", &js(1.0))?;
        assert!(matches!(&back[0].1, Msg::Log(l) if l.level == Log::INFO));
        Ok(())
    }
}
