//! Software safety of the command path on a ROS 2 graph: when motion must hold, and the
//! watchdog that says so.
//!
//! **A software stop, not a replacement for the hardware e-stop.** It stops what rodlog
//! sends and asks the drivers to stop what it sent (cancel the arm's goals, an empty
//! trajectory, a clamp STOP); the robot's own safety chain (the controller's e-stop circuit,
//! protective stops, the lift's and the base's brakes) stays the authority.
//!
//! [`Safety::hold`] says whether motion must hold now, for the first reason that applies:
//!
//! | hold | when | ends |
//! |---|---|---|
//! | `estop` | any message on [`ESTOP`] (`std_msgs/msg/Empty`) | never in this run (restart rodlog) |
//! | `status` | a driver status topic (remap `[[status]]`: robot mode, safety mode) has a value that is not OK, or none yet | the value is OK again |
//! | `no_joint_states` | no `/joint_states` yet | the first one |
//! | `joint_states_stale` | no `/joint_states` for more than [`JOINT_STATES_DEADLINE`] of robot time (`ros2.joint_states_deadline_ms`) | the next one |
//! | `camera_stale` | a capture was requested (a perception step) and no colour image came within [`CAPTURE_DEADLINE`] of robot time (`ros2.capture_deadline_s`) | the image |
//!
//! The [`Watchdog`] checks every [`WATCHDOG_PERIOD`] on its own thread: on entering a hold it
//! asks the command path to stop (`Work::Stop`), and it records every change on
//! [`SAFETY_EVENT`] (`rodlog_msgs/TaskEvent`, task `safety`) and `/rosout`, as inputs of the
//! recording. The command path also asks [`Safety::hold`] itself before every command, so a
//! command never slips through between two checks. It measures its own worst gap between
//! two checks in wall time (what the 100 ms deadline depends on).
//!
//! Staleness is judged in robot time: on a robot that is the wall clock since the start; under
//! a simulator's `/clock` a simulator that stalls (rendering a capture) stops its clock too, and
//! is not stale for it.

use std::collections::BTreeMap;
use std::sync::mpsc::SyncSender;
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};

use msgs::drivers::DriverError;
use msgs::rcl_interfaces::Log;
use msgs::rodlog_msgs::TaskEvent;
use msgs::std_msgs::Header;
use msgs::{Msg, RobotDuration, RobotTime};
use recorder::{Channel, Envelope, Feed, LiveSource};
use ros2::remap::StatusTopic;
use ros2::{Qos, Subscription};

use super::motion::Work;

/// The e-stop topic: any message holds motion for the rest of the run.
pub const ESTOP: &str = "/estop";
/// Where safety events are recorded (`rodlog_msgs/msg/TaskEvent`, task `safety`).
pub const SAFETY_EVENT: &str = "/safety/event";
/// Producer of the safety events and lines.
pub const SAFETY: &str = "safety";
/// No `/joint_states` for longer than this (robot time: the wall clock on a robot, the
/// graph's `/clock` under a simulator) holds.
pub const JOINT_STATES_DEADLINE: RobotDuration = RobotDuration::from_millis(100);
/// The watchdog's period.
pub const WATCHDOG_PERIOD: Duration = Duration::from_millis(10);
/// A capture whose colour image has not come after this much robot time holds.
pub const CAPTURE_DEADLINE: RobotDuration = RobotDuration::from_secs(5);

/// Why motion holds.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Hold {
    /// The e-stop topic fired.
    EStop,
    /// A driver status is not OK (or not known yet).
    Status {
        /// The topic.
        topic: String,
        /// Its value, `None` before the first message.
        value: Option<i64>,
    },
    /// No joint states yet.
    NoJointStates,
    /// Joint states stopped.
    JointStatesStale {
        /// Since the last one (ms).
        ms: u64,
    },
    /// A capture's image did not come.
    CameraStale {
        /// Since the request (ms of robot time).
        ms: u64,
    },
}

impl Hold {
    /// A short code (`TaskEvent::reason_code`).
    #[must_use]
    pub fn code(&self) -> &'static str {
        match self {
            Self::EStop => "estop",
            Self::Status { .. } => "status",
            Self::NoJointStates => "no_joint_states",
            Self::JointStatesStale { .. } => "joint_states_stale",
            Self::CameraStale { .. } => "camera_stale",
        }
    }

    /// One line of explanation.
    #[must_use]
    pub fn text(&self) -> String {
        match self {
            Self::EStop => format!(
                "software e-stop: a message on {ESTOP}; motion holds for the rest of the run"
            ),
            Self::Status {
                topic,
                value: Some(v),
            } => {
                format!("{topic} = {v}: the driver does not allow motion")
            }
            Self::Status { topic, value: None } => {
                format!("{topic}: no status yet: motion waits for the driver's status")
            }
            Self::NoJointStates => "no /joint_states yet".to_owned(),
            Self::JointStatesStale { ms } => format!("no /joint_states for {ms} ms"),
            Self::CameraStale { ms } => {
                format!("no colour image {ms} ms after the capture request")
            }
        }
    }
}

#[derive(Debug, Default)]
struct Inner {
    estop: bool,
    joint_states_at: Option<RobotTime>,
    capture_since: Option<RobotTime>,
    status: BTreeMap<String, i64>,
    worst_gap: Duration,
    checks: u64,
    holds: u64,
}

/// What motion depends on (module docs). Shared by the sources that update it, the
/// watchdog and the command path.
#[derive(Debug)]
pub struct Safety {
    inner: Mutex<Inner>,
    statuses: Vec<StatusTopic>,
    joint_states_deadline: RobotDuration,
    capture_deadline: RobotDuration,
}

impl Safety {
    /// Safety over the driver status topics `statuses`, with the default deadlines.
    #[must_use]
    pub fn new(statuses: Vec<StatusTopic>) -> Arc<Self> {
        Self::with_deadlines(statuses, JOINT_STATES_DEADLINE, CAPTURE_DEADLINE)
    }

    /// Safety with other deadlines (`ros2.joint_states_deadline_ms`, `ros2.capture_deadline_s`).
    #[must_use]
    pub fn with_deadlines(
        statuses: Vec<StatusTopic>,
        joint_states_deadline: RobotDuration,
        capture_deadline: RobotDuration,
    ) -> Arc<Self> {
        Arc::new(Self {
            inner: Mutex::new(Inner::default()),
            statuses,
            joint_states_deadline,
            capture_deadline,
        })
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Inner> {
        self.inner.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// A `/joint_states` message arrived at robot time `t`.
    pub fn joint_states(&self, t: RobotTime) {
        let mut i = self.lock();
        i.joint_states_at = Some(i.joint_states_at.map_or(t, |a| a.max(t)));
    }

    /// A capture was requested at robot time `t` (the perception step waits for its image).
    pub fn capture_requested(&self, t: RobotTime) {
        let mut i = self.lock();
        i.capture_since.get_or_insert(t);
    }

    /// A colour image arrived.
    pub fn image(&self) {
        self.lock().capture_since = None;
    }

    /// A status topic's value.
    pub fn status(&self, topic: &str, value: i64) {
        self.lock().status.insert(topic.to_owned(), value);
    }

    /// The e-stop fired (latched).
    pub fn estop(&self) {
        self.lock().estop = true;
    }

    /// Whether motion must hold at robot time `now`, and why (module docs).
    #[must_use]
    pub fn hold(&self, now: RobotTime) -> Option<Hold> {
        let i = self.lock();
        if i.estop {
            return Some(Hold::EStop);
        }
        for s in &self.statuses {
            let value = i.status.get(&s.topic).copied();
            if !value.is_some_and(|v| s.allows(v)) {
                return Some(Hold::Status {
                    topic: s.topic.clone(),
                    value,
                });
            }
        }
        match i.joint_states_at {
            None => return Some(Hold::NoJointStates),
            Some(at) if now.saturating_duration_since(at) > self.joint_states_deadline => {
                return Some(Hold::JointStatesStale {
                    ms: now.saturating_duration_since(at).as_nanos() / 1_000_000,
                });
            }
            Some(_) => {}
        }
        if let Some(since) = i.capture_since
            && now.saturating_duration_since(since) > self.capture_deadline
        {
            return Some(Hold::CameraStale {
                ms: now.saturating_duration_since(since).as_nanos() / 1_000_000,
            });
        }
        None
    }

    /// The watchdog's worst gap between two checks, the number of checks, and the holds
    /// entered.
    #[must_use]
    pub fn watchdog_figures(&self) -> (Duration, u64, u64) {
        let i = self.lock();
        (i.worst_gap, i.checks, i.holds)
    }
}

/// A `rodlog_msgs/TaskEvent` of task `safety` and its `/rosout` line, as inputs at `t`.
pub fn safety_event(t: RobotTime, hold: Option<&Hold>, released: Option<&Hold>) -> Vec<Envelope> {
    let (state, kind, code, text, level) = match (hold, released) {
        (Some(h), _) => ("hold", TaskEvent::REFUSED, h.code(), h.text(), Log::ERROR),
        (None, Some(r)) => (
            "released",
            TaskEvent::INFO,
            r.code(),
            format!("motion allowed again (was: {})", r.text()),
            Log::INFO,
        ),
        (None, None) => return Vec::new(),
    };
    let event = Msg::TaskEvent(TaskEvent {
        header: Header {
            stamp: t.to_ros().unwrap_or_default(),
            frame_id: String::new(),
        },
        task: SAFETY.to_owned(),
        state: state.to_owned(),
        kind,
        reason_code: code.to_owned(),
        text: text.clone(),
    });
    let log = recorder::runner::rosout(SAFETY, t, level, format!("{state}: {text}"));
    let mut out = Vec::new();
    for (topic, msg) in [(SAFETY_EVENT, event), (msgs::topics::ROSOUT, log)] {
        let channel = Channel::known(topic, SAFETY, msg.type_name());
        if let Ok(env) = Envelope::encode(channel, t, t, msg) {
            out.push(env);
        }
    }
    out
}

/// The watchdog (module docs): a live source that pushes only safety events.
pub struct Watchdog {
    safety: Arc<Safety>,
    commands: SyncSender<Work>,
}

impl std::fmt::Debug for Watchdog {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Watchdog").finish_non_exhaustive()
    }
}

impl Watchdog {
    /// A watchdog over `safety` that sends `Work::Stop` to `commands` on every new hold.
    #[must_use]
    pub fn new(safety: Arc<Safety>, commands: SyncSender<Work>) -> Self {
        Self { safety, commands }
    }
}

impl LiveSource for Watchdog {
    fn name(&self) -> &str {
        "watchdog"
    }

    fn run(self: Box<Self>, feed: Feed) -> Result<(), DriverError> {
        let mut last: Option<Hold> = None;
        let mut last_check = Instant::now();
        while !feed.stopped() {
            std::thread::sleep(WATCHDOG_PERIOD);
            let now_wall = Instant::now();
            let gap = now_wall - last_check;
            last_check = now_wall;
            let t = feed.now();
            let hold = self.safety.hold(t);
            {
                let mut i = self.safety.lock();
                i.worst_gap = i.worst_gap.max(gap);
                i.checks += 1;
            }
            let changed = match (&last, &hold) {
                (None, None) => false,
                (Some(a), Some(b)) => a.code() != b.code(),
                _ => true,
            };
            if !changed {
                continue;
            }
            if let Some(h) = &hold {
                self.safety.lock().holds += 1;
                // The stop goes out first; the record follows.
                let _full = self.commands.try_send(Work::Stop(h.clone()));
            }
            for env in safety_event(t, hold.as_ref(), last.as_ref()) {
                let _ = feed.push(env);
            }
            last = hold;
        }
        Ok(())
    }
}

/// A driver status topic (remap `[[status]]`) read into [`Safety`]; every change of value is
/// logged on `/rosout` (recorded).
pub struct StatusSource {
    topic: StatusTopic,
    subscription: Subscription,
    safety: Arc<Safety>,
}

impl std::fmt::Debug for StatusSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("StatusSource")
            .field("topic", &self.topic)
            .finish_non_exhaustive()
    }
}

impl StatusSource {
    /// Subscribes to `topic` on `node` (best effort: matches any publisher).
    ///
    /// # Errors
    /// The transport's errors.
    pub fn new(
        node: &ros2::Node,
        topic: StatusTopic,
        safety: Arc<Safety>,
    ) -> Result<Self, ros2::Ros2Error> {
        let subscription =
            node.subscribe_raw(&topic.topic, &topic.type_name, Qos::SENSOR_SUBSCRIPTION)?;
        Ok(Self {
            topic,
            subscription,
            safety,
        })
    }
}

impl LiveSource for StatusSource {
    fn name(&self) -> &str {
        &self.topic.topic
    }

    fn run(mut self: Box<Self>, feed: Feed) -> Result<(), DriverError> {
        let mut last: Option<i64> = None;
        while !feed.stopped() {
            let received = self
                .subscription
                .recv_timeout(super::source::POLL)
                .map_err(|e| DriverError::Fault {
                    device: self.topic.topic.clone(),
                    now: feed.now(),
                    reason: e.to_string(),
                })?;
            let Some(r) = received else {
                continue;
            };
            let Ok(value) = self.topic.value(&r.cdr) else {
                feed.counts()
                    .update(&self.topic.topic, |c| c.undecodable += 1);
                continue;
            };
            self.safety.status(&self.topic.topic, value);
            feed.counts().update(&self.topic.topic, |c| c.received += 1);
            if last != Some(value) {
                last = Some(value);
                let t = feed.now();
                let ok = self.topic.allows(value);
                let log = recorder::runner::rosout(
                    SAFETY,
                    t,
                    if ok { Log::INFO } else { Log::WARN },
                    format!(
                        "{} = {value} ({})",
                        self.topic.topic,
                        if ok { "allows motion" } else { "holds motion" }
                    ),
                );
                let channel = Channel::known(msgs::topics::ROSOUT, SAFETY, log.type_name());
                if let Ok(env) = Envelope::encode(channel, t, t, log) {
                    let _ = feed.push(env);
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ros2::remap::StatusField;

    #[test]
    fn holds_come_in_order_of_severity_and_lift() {
        let s = Safety::new(vec![StatusTopic {
            topic: "/safety_mode".into(),
            type_name: "p/msg/SafetyMode".into(),
            field: StatusField::Uint8,
            ok: vec![1],
        }]);
        let t = RobotTime::from_millis(1000);
        assert!(matches!(s.hold(t), Some(Hold::Status { value: None, .. })));
        s.status("/safety_mode", 3);
        assert!(matches!(
            s.hold(t),
            Some(Hold::Status { value: Some(3), .. })
        ));
        s.status("/safety_mode", 1);
        assert_eq!(s.hold(t), Some(Hold::NoJointStates));
        s.joint_states(t);
        assert_eq!(s.hold(t), None);
        s.capture_requested(t);
        s.joint_states(t + RobotDuration::from_secs(6));
        assert_eq!(s.hold(t + RobotDuration::from_secs(4)), None);
        assert!(matches!(
            s.hold(t + RobotDuration::from_secs(6)),
            Some(Hold::CameraStale { .. })
        ));
        s.image();
        let later = t + RobotDuration::from_secs(12);
        assert_eq!(
            s.hold(later),
            Some(Hold::JointStatesStale { ms: 6000 }),
            "6 s without joint states"
        );
        s.joint_states(later);
        assert_eq!(s.hold(later), None);
        assert_eq!(s.hold(later + JOINT_STATES_DEADLINE), None);
        assert!(
            s.hold(later + JOINT_STATES_DEADLINE + RobotDuration::from_millis(1))
                .is_some()
        );
        s.estop();
        s.joint_states(later);
        assert_eq!(s.hold(later), Some(Hold::EStop));
    }

    #[test]
    fn events_are_recorded_as_a_task_event_and_a_log_line() {
        let t = RobotTime::from_millis(5);
        let envs = safety_event(t, Some(&Hold::EStop), None);
        assert_eq!(envs.len(), 2);
        assert_eq!(envs[0].channel.topic, SAFETY_EVENT);
        let Some(Msg::TaskEvent(e)) = &envs[0].msg else {
            panic!("not a task event");
        };
        assert_eq!(
            (e.state.as_str(), e.reason_code.as_str()),
            ("hold", "estop")
        );
        let released = safety_event(t, None, Some(&Hold::NoJointStates));
        let Some(Msg::TaskEvent(e)) = &released[0].msg else {
            panic!("not a task event");
        };
        assert_eq!(e.state, "released");
    }
}
