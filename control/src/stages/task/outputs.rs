//! The stage's outputs besides the commands: stamps (`log_time + latency`), every step
//! change and verdict on `/task/event` with its `/rosout` line, and the re-stamping of a
//! command planned earlier than it is issued.

use msgs::builtin_interfaces::Time;
use msgs::frames::BASE_LINK;
use msgs::geometry_msgs::{Point, Pose, Quaternion};
use msgs::rcl_interfaces::Log;
use msgs::rodlog_msgs::TaskEvent;
use msgs::std_msgs::Header;
use msgs::topics::{ROSOUT, TASK_EVENT};
use msgs::{Msg, RobotDuration, RobotTime};
use nalgebra::Isometry3;

use super::config::TaskKind;
use super::{LOG_FILE, STAGE_NAME};

/// The outputs of the message being handled, in order, and what stamps them.
#[derive(Debug)]
pub(crate) struct Outbox {
    latency: RobotDuration,
    /// The operation under way: the configured task, or hang then remove for the demo.
    phase: TaskKind,
    pending: Vec<(String, Msg)>,
}

impl Outbox {
    /// Empty, for an operation `phase`, stamping `log_time + latency`.
    pub fn new(latency: RobotDuration, phase: TaskKind) -> Self {
        Self {
            latency,
            phase,
            pending: Vec::new(),
        }
    }

    /// The operation under way (the `task` of the events).
    pub fn phase(&self) -> TaskKind {
        self.phase
    }

    /// The demo moves on to its next operation.
    pub fn set_phase(&mut self, phase: TaskKind) {
        self.phase = phase;
    }

    /// The stamp of outputs triggered at `now`.
    pub fn stamp(&self, now: RobotTime) -> Time {
        (now + self.latency).to_ros().unwrap_or_default()
    }

    /// A header stamped for `now` in `frame`.
    pub fn header(&self, now: RobotTime, frame: &str) -> Header {
        Header {
            stamp: self.stamp(now),
            frame_id: frame.to_owned(),
        }
    }

    /// Appends an output.
    pub fn push(&mut self, topic: &str, msg: Msg) {
        self.pending.push((topic.to_owned(), msg));
    }

    /// Appends outputs.
    pub fn extend(&mut self, outputs: impl IntoIterator<Item = (String, Msg)>) {
        self.pending.extend(outputs);
    }

    /// Takes the outputs gathered so far.
    pub fn take(&mut self) -> Vec<(String, Msg)> {
        std::mem::take(&mut self.pending)
    }

    /// Appends a `/task/event` of the operation under way and its `/rosout` line (WARN for
    /// a refusal, ERROR for a failure, else INFO; `"{task} {state} [{reason}]: {text}"`).
    pub fn event(
        &mut self,
        now: RobotTime,
        kind: u8,
        state: &str,
        reason_code: &str,
        text: String,
    ) {
        let level = match kind {
            TaskEvent::REFUSED => Log::WARN,
            TaskEvent::FAILED => Log::ERROR,
            _ => Log::INFO,
        };
        let task = self.phase.name();
        let log = Log {
            stamp: self.stamp(now),
            level,
            name: STAGE_NAME.to_owned(),
            msg: if reason_code.is_empty() {
                format!("{task} {state}: {text}")
            } else {
                format!("{task} {state} [{reason_code}]: {text}")
            },
            file: LOG_FILE.to_owned(),
            function: String::new(),
            line: 0,
        };
        let event = TaskEvent {
            header: self.header(now, BASE_LINK),
            task: task.to_owned(),
            state: state.to_owned(),
            kind,
            reason_code: reason_code.to_owned(),
            text,
        };
        self.pending.push((TASK_EVENT.to_owned(), event.into()));
        self.pending.push((ROSOUT.to_owned(), log.into()));
    }
}

/// Sets the header stamp of a command message (planned earlier, issued now).
pub(crate) fn restamp(msg: &mut Msg, stamp: Time) {
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
pub(crate) fn pose_msg(p: &Isometry3<f64>) -> Pose {
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
