//! The command path to a ROS 2 graph: which stage outputs leave the process, and how.
//!
//! Two halves: [`Outbox`], the [`LiveOutput`] the live runtime hands every popped message to
//! (it only queues, never blocks the runner), and [`CommandThread`], the live source that owns
//! the DDS writers and sends.
//!
//! # Motion is opt-in (`--allow-motion`)
//! Without it no writer exists on any command topic (`msgs::topics::COMMANDS`, or where the
//! remap routes them): the stages compute and the recording holds their commands, and
//! nothing is sent. With it, each command goes out as the remap says, unless
//! [`Safety::hold`] says hold, in which case it is withheld and the withholding is recorded:
//!
//! | command | sent as |
//! |---|---|
//! | `/arm/joint_trajectory` | a `JointTrajectory` on its topic, or a FollowJointTrajectory goal (`ros2::FollowJointTrajectoryClient`): goal acceptance and result recorded on [`ARM_ACTION`] |
//! | `/lift/command`, `/base/goal`, `/clamp/command`, `/wrist_light/command` | the message, on its (remapped) topic |
//! | `/camera/trigger` | an `Empty` on its topic, or the capture service calls the remap lists |
//!
//! Trajectories go out in the driver's joint names and units (the remap's `[joints]`,
//! inverted) with `header.stamp` zero ("start when received", as joint_trajectory_controller
//! reads it: rodlog's robot time is not the driver's clock); everything else is sent as the
//! recorded bytes. A new hold sends a stop: cancel every arm goal (action) or an empty
//! trajectory (topic), and a clamp STOP.
//!
//! # What else goes to the graph
//! `/task/event` and `/rosout` (rodlog's own lines); the calibration's camera edge
//! (`tool0 -> camera_color_optical_frame`, a `/tf` output of the calibration stage) on
//! `/tf_static`, with the remap's `flange -> tool0` when a driver publishes TF; and the
//! robot_state stage's `/tf`, `/tf_static` and `/robot_description` only when no driver
//! publishes `/tf` (never a second robot TF beside the driver's). Latched `/tf_static` is
//! published as the union of every static edge so far, as tf2's static broadcaster does.

use std::collections::BTreeMap;
use std::sync::mpsc::{Receiver, RecvTimeoutError, SyncSender, TrySendError};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::Duration;

use msgs::drivers::DriverError;
use msgs::geometry_msgs::{Quaternion, Transform, TransformStamped, Vector3};
use msgs::rcl_interfaces::Log;
use msgs::rodlog_msgs::{ClampCommand, TaskEvent};
use msgs::std_msgs::Header;
use msgs::tf2_msgs::TfMessage;
use msgs::trajectory_msgs::JointTrajectory;
use msgs::{Msg, RobotTime, topics};
use recorder::{Channel, Envelope, Feed, LiveOutput, LiveSource, MetadataRecord, Popped};
use ros2::remap::{ArmCommand, Remap, TriggerCommand};
use ros2::{ActionEvent, FollowJointTrajectoryClient, Node, Publisher, Qos, ServiceClient};

use super::safety::{Hold, Safety};

/// Where the arm action's events are recorded (`rodlog_msgs/msg/TaskEvent`, task `arm`).
pub const ARM_ACTION: &str = "/arm/action";
/// Producer of the command path's events and lines.
pub const COMMAND_PATH: &str = "command_path";
/// Name of the metadata record with the command path's figures.
pub const MOTION_RECORD: &str = "motion";
/// Capacity of the command queue from the runtime to the command thread (commands and stops;
/// served before any graph output).
pub const COMMAND_QUEUE: usize = 256;
/// Capacity of the graph-output queue (an output that does not fit is dropped and counted).
pub const OUTPUT_QUEUE: usize = 1024;

/// What the command thread is asked to do.
#[derive(Debug)]
pub enum Work {
    /// Send a command (a stage output on a command topic).
    Command(Box<Envelope>),
    /// Publish a graph output.
    Output(Box<Envelope>),
    /// A hold began: stop what was sent.
    Stop(Hold),
}

/// Figures of the command path.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct MotionCounts {
    /// Commands sent.
    pub sent: u64,
    /// Commands withheld by a hold.
    pub withheld: u64,
    /// Commands lost because the command queue was full.
    pub queue_full: u64,
    /// Graph outputs dropped because the output queue was full.
    pub outputs_dropped: u64,
    /// Stops sent.
    pub stops: u64,
    /// Graph outputs published.
    pub outputs: u64,
    /// Sends the transport refused.
    pub errors: u64,
}

/// Counters shared by both halves.
pub type SharedCounts = Arc<Mutex<MotionCounts>>;

fn bump(c: &SharedCounts, f: impl FnOnce(&mut MotionCounts)) {
    f(&mut c.lock().unwrap_or_else(PoisonError::into_inner));
}

/// The runtime's half (module docs).
pub struct Outbox {
    tx: SyncSender<Work>,
    outputs: SyncSender<Work>,
    allow_motion: bool,
    robot_tf: bool,
    counts: SharedCounts,
    safety: Option<Arc<Safety>>,
    observer: Option<Box<dyn LiveOutput>>,
    command_writers: Vec<String>,
}

impl std::fmt::Debug for Outbox {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Outbox")
            .field("allow_motion", &self.allow_motion)
            .field("robot_tf", &self.robot_tf)
            .finish_non_exhaustive()
    }
}

impl Outbox {
    /// The command path's counters.
    #[must_use]
    pub fn counts(&self) -> SharedCounts {
        Arc::clone(&self.counts)
    }

    /// A sender of work to the command thread (the watchdog's stops).
    #[must_use]
    pub fn sender(&self) -> SyncSender<Work> {
        self.tx.clone()
    }

    /// Adds an observer that sees every popped message after the command path.
    pub fn set_observer(&mut self, observer: Option<Box<dyn LiveOutput>>) {
        self.observer = observer;
    }

    /// Whether a popped stage output goes to the graph (module docs).
    fn is_graph_output(&self, env: &Envelope) -> bool {
        let producer = env.producer();
        match env.topic() {
            topics::TASK_EVENT | topics::ROSOUT => true,
            topics::TF => {
                producer == robot::robot_state::STAGE_NAME && self.robot_tf
                    || producer == calib::selfcal::stage::STAGE_NAME
            }
            topics::TF_STATIC | topics::ROBOT_DESCRIPTION => {
                producer == robot::robot_state::STAGE_NAME && self.robot_tf
            }
            _ => false,
        }
    }
}

impl LiveOutput for Outbox {
    fn popped(&mut self, popped: &Popped, now: RobotTime) {
        let env = &popped.envelope;
        let work = if popped.is_output() && topics::is_command(env.topic()) {
            self.allow_motion
                .then(|| Work::Command(Box::new(env.clone())))
        } else if popped.is_output() && self.is_graph_output(env)
            || !popped.is_output() && env.topic() == topics::ROSOUT
        {
            // Inputs on /rosout are rodlog's own lines (the runtime's, the sources', safety's):
            // rodlog does not subscribe to the graph's /rosout.
            Some(Work::Output(Box::new(env.clone())))
        } else {
            None
        };
        if let Some(w) = work {
            let is_command = matches!(w, Work::Command(_));
            let queue = if is_command { &self.tx } else { &self.outputs };
            if let Err(TrySendError::Full(_) | TrySendError::Disconnected(_)) = queue.try_send(w) {
                bump(&self.counts, |c| {
                    if is_command {
                        c.queue_full += 1;
                    } else {
                        c.outputs_dropped += 1;
                    }
                });
            }
        }
        if let Some(o) = self.observer.as_deref_mut() {
            o.popped(popped, now);
        }
    }

    fn finish(&mut self) {
        if let Some(o) = self.observer.as_deref_mut() {
            o.finish();
        }
    }

    fn records(&mut self) -> Vec<MetadataRecord> {
        let c = *self.counts.lock().unwrap_or_else(PoisonError::into_inner);
        let mut r = MetadataRecord::new(MOTION_RECORD)
            .with("allow_motion", self.allow_motion)
            .with("command_writers", self.command_writers.join(","))
            .with("robot_tf_to_graph", self.robot_tf)
            .with("sent", c.sent)
            .with("withheld", c.withheld)
            .with("queue_full", c.queue_full)
            .with("outputs_dropped", c.outputs_dropped)
            .with("stops", c.stops)
            .with("graph_outputs", c.outputs)
            .with("transport_errors", c.errors);
        if let Some(s) = &self.safety {
            let (gap, checks, holds) = s.watchdog_figures();
            r = r
                .with(
                    "watchdog_worst_gap_ms",
                    format!("{:.1}", gap.as_secs_f64() * 1e3),
                )
                .with("watchdog_checks", checks)
                .with("holds", holds);
        }
        let mut out = vec![r];
        if let Some(o) = self.observer.as_deref_mut() {
            out.extend(o.records());
        }
        out
    }
}

/// The command writers of a motion-enabled run.
struct Commands {
    arm_topic: Option<Publisher>,
    arm_action: Option<FollowJointTrajectoryClient>,
    lift: Option<Publisher>,
    base: Option<Publisher>,
    clamp: Option<Publisher>,
    light: Option<Publisher>,
    trigger_topic: Option<Publisher>,
    trigger_services: Vec<ServiceClient>,
}

/// The command thread (module docs).
pub struct CommandThread {
    rx: Receiver<Work>,
    outputs: Receiver<Work>,
    remap: Arc<Remap>,
    commands: Option<Commands>,
    task_event: Publisher,
    rosout: Publisher,
    tf_static: Publisher,
    tf: Option<Publisher>,
    robot_description: Option<Publisher>,
    statics: BTreeMap<String, TransformStamped>,
    safety: Option<Arc<Safety>>,
    counts: SharedCounts,
    goal_seed: u64,
    /// A command went out since the last stop (a stop with nothing to stop sends nothing).
    sent_since_stop: bool,
}

impl std::fmt::Debug for CommandThread {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CommandThread")
            .field("motion", &self.commands.is_some())
            .finish_non_exhaustive()
    }
}

fn err(what: &str) -> impl Fn(ros2::Ros2Error) -> crate::ComposeError + '_ {
    move |source| crate::ComposeError::Ros2 {
        what: what.to_owned(),
        source: Box::new(source),
    }
}

/// The name a command topic has on the graph (the remap's, else rodlog's).
fn route<'a>(remapped: Option<&'a String>, rodlog: &'a str) -> &'a str {
    remapped.map_or(rodlog, String::as_str)
}

/// Builds both halves of the command path on `node`. Command writers are created only when
/// `allow_motion`; `robot_tf` says whether robot_state's TF goes to the graph (no driver
/// publishes `/tf`).
///
/// # Errors
/// The transport's errors.
pub fn command_path(
    node: &Node,
    remap: Arc<Remap>,
    allow_motion: bool,
    robot_tf: bool,
    safety: Option<Arc<Safety>>,
) -> Result<(Outbox, CommandThread), crate::ComposeError> {
    let (tx, rx) = std::sync::mpsc::sync_channel(COMMAND_QUEUE);
    let (outputs_tx, outputs_rx) = std::sync::mpsc::sync_channel(OUTPUT_QUEUE);
    let counts = SharedCounts::default();
    let spec = |t: &str| topics::lookup(t).map_or("", |s| s.type_name);
    let rosout_qos = Qos {
        reliability: ros2::Reliability::Reliable,
        durability: ros2::Durability::TransientLocal,
        depth: 100,
    };
    let task_event = node
        .publisher_raw(topics::TASK_EVENT, spec(topics::TASK_EVENT), Qos::COMMAND)
        .map_err(err(topics::TASK_EVENT))?;
    let rosout = node
        .publisher_raw(topics::ROSOUT, spec(topics::ROSOUT), rosout_qos)
        .map_err(err(topics::ROSOUT))?;
    let tf_static = node
        .publisher_raw(topics::TF_STATIC, spec(topics::TF_STATIC), Qos::LATCHED)
        .map_err(err(topics::TF_STATIC))?;
    let (tf, robot_description) = if robot_tf {
        (
            Some(
                node.publisher_raw(topics::TF, spec(topics::TF), Qos::COMMAND.with_depth(100))
                    .map_err(err(topics::TF))?,
            ),
            Some(
                node.publisher_raw(
                    topics::ROBOT_DESCRIPTION,
                    spec(topics::ROBOT_DESCRIPTION),
                    Qos::LATCHED,
                )
                .map_err(err(topics::ROBOT_DESCRIPTION))?,
            ),
        )
    } else {
        (None, None)
    };
    let writers = std::cell::RefCell::new(Vec::new());
    let commands = if allow_motion {
        let c = &remap.commands;
        let publisher = |name: &str, rodlog: &str| -> Result<Publisher, crate::ComposeError> {
            writers.borrow_mut().push(name.to_owned());
            node.publisher_raw(name, spec(rodlog), Qos::COMMAND)
                .map_err(err(name))
        };
        let (arm_topic, arm_action) = match &c.arm {
            Some(ArmCommand::Action(a)) => (
                None,
                Some(
                    FollowJointTrajectoryClient::new(node, a, ros2::ServiceMapping::Cyclone)
                        .map_err(err(a))?,
                ),
            ),
            Some(ArmCommand::Topic(t)) => (Some(publisher(t, topics::ARM_JOINT_TRAJECTORY)?), None),
            None => (
                Some(publisher(
                    topics::ARM_JOINT_TRAJECTORY,
                    topics::ARM_JOINT_TRAJECTORY,
                )?),
                None,
            ),
        };
        if let Some(ArmCommand::Action(a)) = &c.arm {
            writers.borrow_mut().push(format!("{a} (action)"));
        }
        let lift = Some(publisher(
            route(c.lift.as_ref(), topics::LIFT_COMMAND),
            topics::LIFT_COMMAND,
        )?);
        let base = Some(publisher(
            route(c.base.as_ref(), topics::BASE_GOAL),
            topics::BASE_GOAL,
        )?);
        let clamp = Some(publisher(
            route(c.clamp.as_ref(), topics::CLAMP_COMMAND),
            topics::CLAMP_COMMAND,
        )?);
        let light = Some(publisher(
            route(c.light.as_ref(), topics::WRIST_LIGHT_COMMAND),
            topics::WRIST_LIGHT_COMMAND,
        )?);
        let (trigger_topic, trigger_services) = match &c.camera_trigger {
            Some(TriggerCommand::Services { calls, mapping }) => {
                let mut clients = Vec::new();
                for (service, ty) in calls {
                    writers.borrow_mut().push(format!("{service} (service)"));
                    clients.push(
                        node.service_client_raw(service, ty, *mapping)
                            .map_err(err(service))?,
                    );
                }
                (None, clients)
            }
            Some(TriggerCommand::Topic(t)) => {
                (Some(publisher(t, topics::CAMERA_TRIGGER)?), Vec::new())
            }
            None => (
                Some(publisher(topics::CAMERA_TRIGGER, topics::CAMERA_TRIGGER)?),
                Vec::new(),
            ),
        };
        Some(Commands {
            arm_topic,
            arm_action,
            lift,
            base,
            clamp,
            light,
            trigger_topic,
            trigger_services,
        })
    } else {
        None
    };
    let command_writers = writers.into_inner();
    let mut seed = [0_u8; 8];
    seed.copy_from_slice(&node.guid_prefix()[4..12]);
    let thread = CommandThread {
        rx,
        outputs: outputs_rx,
        remap,
        commands,
        task_event,
        rosout,
        tf_static,
        tf,
        robot_description,
        statics: BTreeMap::new(),
        safety: safety.clone(),
        counts: Arc::clone(&counts),
        goal_seed: u64::from_le_bytes(seed),
        sent_since_stop: false,
    };
    let outbox = Outbox {
        tx,
        outputs: outputs_tx,
        allow_motion,
        robot_tf,
        counts,
        safety,
        observer: None,
        command_writers,
    };
    Ok((outbox, thread))
}

/// The trajectory as the driver takes it: its joint names and units, stamp zero.
#[must_use]
pub fn to_driver(remap: &Remap, t: &JointTrajectory) -> JointTrajectory {
    let mut out = t.clone();
    out.header.stamp = msgs::builtin_interfaces::Time::default();
    for (j, name) in out.joint_names.iter_mut().enumerate() {
        let Some((vendor, map)) = remap.joints.iter().find(|(_, m)| m.name == *name) else {
            continue;
        };
        name.clone_from(vendor);
        for p in &mut out.points {
            if let Some(x) = p.positions.get_mut(j) {
                *x = (*x - map.offset) / map.scale;
            }
            for v in [&mut p.velocities, &mut p.accelerations, &mut p.effort] {
                if let Some(x) = v.get_mut(j) {
                    *x /= map.scale;
                }
            }
        }
    }
    out
}

/// Records an event of the command path (`/rosout`, and [`ARM_ACTION`] for the arm) as
/// inputs at the robot time now.
fn note(feed: &Feed, level: u8, text: String, arm: Option<(&str, u8, String)>) {
    let t = feed.now();
    let log = recorder::runner::rosout(COMMAND_PATH, t, level, text.clone());
    let mut out = vec![(topics::ROSOUT, log)];
    if let Some((state, kind, code)) = arm {
        out.push((
            ARM_ACTION,
            Msg::TaskEvent(TaskEvent {
                header: Header {
                    stamp: t.to_ros().unwrap_or_default(),
                    frame_id: String::new(),
                },
                task: "arm".to_owned(),
                state: state.to_owned(),
                kind,
                reason_code: code,
                text,
            }),
        ));
    }
    for (topic, m) in out {
        let channel = Channel::known(topic, COMMAND_PATH, m.type_name());
        if let Ok(env) = Envelope::encode(channel, t, t, m) {
            let _ = feed.push(env);
        }
    }
}

/// Publishes `cdr` on `p`; a refusal is counted and logged.
fn publish(p: &Publisher, cdr: &[u8], counts: &SharedCounts, feed: &Feed) -> bool {
    match p.publish(cdr) {
        Ok(()) => true,
        Err(e) => {
            bump(counts, |c| c.errors += 1);
            note(feed, Log::ERROR, format!("{}: {e}", p.topic()), None);
            false
        }
    }
}

impl CommandThread {
    fn command(&mut self, env: &Envelope, feed: &Feed) {
        let now = feed.now();
        let counts = Arc::clone(&self.counts);
        if let Some(h) = self.safety.as_ref().and_then(|s| s.hold(now)) {
            bump(&self.counts, |c| c.withheld += 1);
            note(
                feed,
                Log::WARN,
                format!(
                    "withheld {} from {} (logged at {}): hold: {}",
                    env.topic(),
                    env.producer(),
                    env.log_time,
                    h.text()
                ),
                None,
            );
            return;
        }
        let Some(c) = self.commands.as_mut() else {
            return;
        };
        let mut sent = false;
        match env.topic() {
            topics::ARM_JOINT_TRAJECTORY => {
                let Some(Msg::JointTrajectory(t)) = &env.msg else {
                    return;
                };
                let driver = to_driver(&self.remap, t);
                if let Some(a) = c.arm_action.as_mut() {
                    match a.send_goal(&driver, self.goal_seed) {
                        Ok(id) => {
                            sent = true;
                            let text = format!("goal {} sent to {}", hex(&id.uuid), a.action());
                            note(
                                feed,
                                Log::INFO,
                                text,
                                Some(("sent", TaskEvent::INFO, String::new())),
                            );
                        }
                        Err(e) => {
                            bump(&self.counts, |c| c.errors += 1);
                            note(feed, Log::ERROR, format!("{}: {e}", a.action()), None);
                        }
                    }
                } else if let Some(p) = &c.arm_topic {
                    let cdr = Msg::JointTrajectory(driver).encode().unwrap_or_default();
                    sent = publish(p, &cdr, &counts, feed);
                }
            }
            topics::LIFT_COMMAND
            | topics::BASE_GOAL
            | topics::CLAMP_COMMAND
            | topics::WRIST_LIGHT_COMMAND => {
                let p = match env.topic() {
                    topics::LIFT_COMMAND => &c.lift,
                    topics::BASE_GOAL => &c.base,
                    topics::WRIST_LIGHT_COMMAND => &c.light,
                    _ => &c.clamp,
                };
                if let Some(p) = p {
                    sent = publish(p, &env.cdr, &counts, feed);
                }
            }
            topics::CAMERA_TRIGGER => {
                if let Some(s) = &self.safety {
                    s.capture_requested(now);
                }
                if let Some(p) = &c.trigger_topic {
                    sent = publish(p, &env.cdr, &counts, feed);
                }
                // The capture services take empty requests (one placeholder byte in CDR).
                let empty = [0_u8, 1, 0, 0, 0];
                for s in &mut c.trigger_services {
                    match s.send(&empty) {
                        Ok(_) => sent = true,
                        Err(e) => {
                            bump(&self.counts, |c| c.errors += 1);
                            note(feed, Log::ERROR, format!("{}: {e}", s.service()), None);
                        }
                    }
                }
            }
            _ => {}
        }
        if sent {
            self.sent_since_stop = true;
            bump(&self.counts, |c| c.sent += 1);
        }
    }

    fn stop(&mut self, hold: &Hold, feed: &Feed) {
        if !self.sent_since_stop {
            return;
        }
        self.sent_since_stop = false;
        let Some(c) = self.commands.as_mut() else {
            return;
        };
        bump(&self.counts, |c| c.stops += 1);
        let mut what = Vec::new();
        if let Some(a) = c.arm_action.as_mut()
            && a.cancel_all().is_ok()
        {
            what.push(format!("cancel every goal of {}", a.action()));
        }
        if let Some(p) = &c.arm_topic {
            let stop = to_driver(
                &self.remap,
                &JointTrajectory {
                    header: Header::default(),
                    joint_names: msgs::frames::ARM_JOINT_NAMES
                        .iter()
                        .map(|s| (*s).to_owned())
                        .collect(),
                    points: Vec::new(),
                },
            );
            if p.publish(&Msg::JointTrajectory(stop).encode().unwrap_or_default())
                .is_ok()
            {
                what.push(format!("empty trajectory on {}", p.topic()));
            }
        }
        if let Some(p) = &c.clamp {
            let stop = Msg::ClampCommand(ClampCommand {
                header: Header::default(),
                action: ClampCommand::STOP,
                max_torque_nm: 0.0,
            });
            if p.publish(&stop.encode().unwrap_or_default()).is_ok() {
                what.push(format!("clamp STOP on {}", p.topic()));
            }
        }
        note(
            feed,
            Log::WARN,
            format!("stop ({}): {}", hold.code(), what.join(", ")),
            c.arm_action
                .is_some()
                .then(|| ("stop", TaskEvent::REFUSED, hold.code().to_owned())),
        );
    }

    fn output(&mut self, env: &Envelope, feed: &Feed) {
        let ok = match env.topic() {
            topics::TASK_EVENT => publish(&self.task_event, &env.cdr, &self.counts, feed),
            topics::ROSOUT => publish(&self.rosout, &env.cdr, &self.counts, feed),
            topics::ROBOT_DESCRIPTION => match &self.robot_description {
                Some(p) => publish(p, &env.cdr, &self.counts, feed),
                None => false,
            },
            topics::TF_STATIC => self.statics(env, feed),
            topics::TF if env.producer() == calib::selfcal::stage::STAGE_NAME => {
                self.statics(env, feed)
            }
            topics::TF => match &self.tf {
                Some(p) => publish(p, &env.cdr, &self.counts, feed),
                None => false,
            },
            _ => false,
        };
        if ok {
            bump(&self.counts, |c| c.outputs += 1);
        }
    }

    /// Adds the static edges of `env` (the camera edge, robot_state's fixed edges) and, when
    /// one is new or moved (the calibration stage repeats its edge with every joint state),
    /// publishes the union on `/tf_static`.
    fn statics(&mut self, env: &Envelope, feed: &Feed) -> bool {
        let Some(Msg::TfMessage(tf)) = &env.msg else {
            return false;
        };
        let mut changed = false;
        for t in &tf.transforms {
            let same = self.statics.get(&t.child_frame_id).is_some_and(|old| {
                old.header.frame_id == t.header.frame_id && old.transform == t.transform
            });
            if !same {
                self.statics.insert(t.child_frame_id.clone(), t.clone());
                changed = true;
            }
        }
        changed && self.publish_statics(feed)
    }

    fn publish_statics(&self, feed: &Feed) -> bool {
        let all = Msg::TfMessage(TfMessage {
            transforms: self.statics.values().cloned().collect(),
        });
        publish(
            &self.tf_static,
            &all.encode().unwrap_or_default(),
            &self.counts,
            feed,
        )
    }

    fn handle(&mut self, work: Work, feed: &Feed) {
        match work {
            Work::Command(env) => self.command(&env, feed),
            Work::Output(env) => self.output(&env, feed),
            Work::Stop(h) => self.stop(&h, feed),
        }
    }

    fn poll_action(&mut self, feed: &Feed) {
        let Some(a) = self.commands.as_mut().and_then(|c| c.arm_action.as_mut()) else {
            return;
        };
        let events = match a.poll() {
            Ok(e) => e,
            Err(e) => {
                let text = format!("{}: {e}", a.action());
                bump(&self.counts, |c| c.errors += 1);
                note(feed, Log::ERROR, text, None);
                return;
            }
        };
        for e in events {
            let (level, text, arm) = match e {
                ActionEvent::Goal { goal_id, accepted } => (
                    if accepted { Log::INFO } else { Log::ERROR },
                    format!(
                        "goal {} {}",
                        hex(&goal_id.uuid),
                        if accepted { "accepted" } else { "rejected" }
                    ),
                    (
                        if accepted { "accepted" } else { "rejected" },
                        if accepted {
                            TaskEvent::INFO
                        } else {
                            TaskEvent::FAILED
                        },
                        String::new(),
                    ),
                ),
                ActionEvent::Result {
                    goal_id,
                    status,
                    result,
                } => {
                    let name = ros2::action::GoalStatus::name(status);
                    let ok = status == ros2::action::GoalStatus::SUCCEEDED;
                    (
                        if ok { Log::INFO } else { Log::WARN },
                        format!(
                            "goal {} {name}: error_code {} {}",
                            hex(&goal_id.uuid),
                            result.error_code,
                            result.error_string
                        ),
                        (
                            name,
                            if ok {
                                TaskEvent::DONE
                            } else {
                                TaskEvent::FAILED
                            },
                            result.error_code.to_string(),
                        ),
                    )
                }
                ActionEvent::Canceled { return_code, goals } => (
                    Log::INFO,
                    format!("cancel answered: return_code {return_code}, {goals} goals canceling"),
                    ("cancel", TaskEvent::INFO, return_code.to_string()),
                ),
            };
            note(feed, level, text, Some(arm));
        }
    }

    fn poll_services(&mut self, feed: &Feed) {
        let Some(c) = self.commands.as_mut() else {
            return;
        };
        let mut replies = Vec::new();
        for s in &mut c.trigger_services {
            while let Ok(Some((_, reply))) = s.try_reply() {
                // Mech-Eye's capture services answer {int32 error_code, string error_description}.
                let code = reply
                    .get(4..8)
                    .and_then(|b| b.try_into().ok())
                    .map_or(i32::MIN, i32::from_le_bytes);
                replies.push((s.service().to_owned(), code));
            }
        }
        for (service, code) in replies {
            let level = if code == 0 { Log::INFO } else { Log::ERROR };
            note(
                feed,
                level,
                format!("{service} answered error_code {code}"),
                None,
            );
        }
    }
}

fn hex(b: &[u8]) -> String {
    b.iter().map(|x| format!("{x:02x}")).collect()
}

impl LiveSource for CommandThread {
    fn name(&self) -> &str {
        COMMAND_PATH
    }

    fn run(mut self: Box<Self>, feed: Feed) -> Result<(), DriverError> {
        // The remap's flange -> tool0 under a driver's TF tree, before anything else.
        if self.tf.is_none()
            && let Some(t0) = &self.remap.tool0
        {
            let [x, y, z] = t0.xyz_m;
            let [qx, qy, qz, qw] = t0.quaternion_xyzw;
            self.statics.insert(
                msgs::frames::TOOL0.to_owned(),
                TransformStamped {
                    header: Header {
                        stamp: msgs::builtin_interfaces::Time::default(),
                        frame_id: t0.flange.clone(),
                    },
                    child_frame_id: msgs::frames::TOOL0.to_owned(),
                    transform: Transform {
                        translation: Vector3 { x, y, z },
                        rotation: Quaternion {
                            x: qx,
                            y: qy,
                            z: qz,
                            w: qw,
                        },
                    },
                },
            );
            self.publish_statics(&feed);
        }
        while !feed.stopped() {
            // Commands and stops first, always; then one graph output at a time.
            while let Ok(w) = self.rx.try_recv() {
                self.handle(w, &feed);
            }
            match self.outputs.recv_timeout(Duration::from_millis(2)) {
                Ok(w) => self.handle(w, &feed),
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => break,
            }
            self.poll_action(&feed);
            self.poll_services(&feed);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use msgs::trajectory_msgs::JointTrajectoryPoint;

    #[test]
    fn trajectories_go_out_in_the_drivers_names_and_units_starting_when_received()
    -> Result<(), Box<dyn std::error::Error>> {
        let remap = Remap::parse(
            "[joints]\nshoulder_joint = \"arm_shoulder_joint\"\nlift_mm = { name = \"lift_joint\", scale = 0.001 }\n",
            "t.toml",
        )?;
        let t = JointTrajectory {
            header: Header {
                stamp: msgs::builtin_interfaces::Time {
                    sec: 12,
                    nanosec: 5,
                },
                frame_id: String::new(),
            },
            joint_names: vec!["arm_shoulder_joint".into(), "lift_joint".into(), "x".into()],
            points: vec![JointTrajectoryPoint {
                positions: vec![0.5, 0.3, 1.0],
                velocities: vec![0.1, 0.01, 0.0],
                ..JointTrajectoryPoint::default()
            }],
        };
        let d = to_driver(&remap, &t);
        assert_eq!(d.joint_names, ["shoulder_joint", "lift_mm", "x"]);
        assert_eq!(d.header.stamp, msgs::builtin_interfaces::Time::default());
        assert!((d.points[0].positions[1] - 300.0).abs() < 1e-9);
        assert!((d.points[0].velocities[1] - 10.0).abs() < 1e-9);
        assert_eq!(d.points[0].positions[0], 0.5);
        Ok(())
    }
}
