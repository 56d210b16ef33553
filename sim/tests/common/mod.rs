//! Test support: plays a scenario's commands into a world the way the `script` stage does
//! (sim cannot depend on control), stepping like the scheduler (10 ms steps).

#![allow(dead_code)] // each test binary uses a subset

use msgs::drivers::{DriverOutput, World};
use msgs::frames::{ARM_JOINT_NAMES, MAP};
use msgs::geometry_msgs::{Point, Pose, PoseStamped, Quaternion};
use msgs::rodlog_msgs::ClampCommand;
use msgs::std_msgs::{Empty, Float64, Header};
use msgs::topics;
use msgs::trajectory_msgs::{JointTrajectory, JointTrajectoryPoint};
use msgs::{Msg, RobotDuration, RobotTime};
use scenario::Scenario;
use scenario::{Command, CommandKind};
use sim::{SimConfig, SimWorld};

/// The command's topic and message.
pub fn command_msg(c: &Command) -> (&'static str, Msg) {
    let v = |i: usize| c.values.get(i).copied().unwrap_or(0.0);
    match c.kind {
        CommandKind::Joints => (
            topics::ARM_JOINT_TRAJECTORY,
            JointTrajectory {
                header: Header::default(),
                joint_names: ARM_JOINT_NAMES.iter().map(|s| (*s).to_owned()).collect(),
                points: vec![JointTrajectoryPoint {
                    positions: c.values.clone(),
                    time_from_start: RobotDuration::from_secs_f64(c.duration_s)
                        .and_then(RobotDuration::to_ros)
                        .unwrap_or_default(),
                    ..Default::default()
                }],
            }
            .into(),
        ),
        CommandKind::Lift => (topics::LIFT_COMMAND, Float64 { data: v(0) }.into()),
        CommandKind::Base => {
            let (s, co) = (0.5 * v(2)).sin_cos();
            (
                topics::BASE_GOAL,
                PoseStamped {
                    header: Header {
                        frame_id: MAP.to_owned(),
                        ..Default::default()
                    },
                    pose: Pose {
                        position: Point {
                            x: v(0),
                            y: v(1),
                            z: 0.0,
                        },
                        orientation: Quaternion {
                            x: 0.0,
                            y: 0.0,
                            z: s,
                            w: co,
                        },
                    },
                }
                .into(),
            )
        }
        CommandKind::Clamp => (
            topics::CLAMP_COMMAND,
            ClampCommand {
                header: Header::default(),
                action: v(0) as u8,
                max_torque_nm: if c.values.len() > 1 { v(1) } else { 5.0 },
            }
            .into(),
        ),
        CommandKind::Capture => (topics::CAMERA_TRIGGER, Empty.into()),
    }
}

/// Runs `scenario` for `until` of robot time in 10 ms steps, delivering each command at the
/// first step at or after its time; returns every output.
pub fn run(
    scenario: &Scenario,
    until: RobotTime,
) -> Result<(SimWorld, Vec<DriverOutput>), Box<dyn std::error::Error>> {
    let mut world = SimWorld::new(&SimConfig::of_scenario(scenario)?)?;
    let mut commands: Vec<(RobotTime, &Command)> = scenario
        .commands
        .iter()
        .map(|c| RobotTime::from_secs_f64(c.t_s).map(|t| (t, c)))
        .collect::<Result<_, _>>()?;
    commands.sort_by_key(|(t, _)| *t);
    let mut next = 0;
    let mut out = Vec::new();
    let mut t = RobotTime::ZERO;
    loop {
        out.extend(world.step_until(t)?);
        while let Some((at, c)) = commands.get(next) {
            if *at > t {
                break;
            }
            let (topic, msg) = command_msg(c);
            world.command(t, topic, &msg)?;
            next += 1;
        }
        if t >= until {
            break;
        }
        t = (t + RobotDuration::from_millis(10)).min(until);
    }
    Ok((world, out))
}

/// One output as `(log_time, publish_time, producer, topic, CDR)`.
pub type OutputBytes = (u64, u64, String, String, Vec<u8>);

/// All outputs as bytes.
pub fn bytes(out: &[DriverOutput]) -> Result<Vec<OutputBytes>, msgs::CdrError> {
    out.iter()
        .map(|o| {
            Ok((
                o.log_time.as_nanos(),
                o.publish_time.as_nanos(),
                o.producer.clone(),
                o.topic.clone(),
                o.msg.encode()?,
            ))
        })
        .collect()
}
