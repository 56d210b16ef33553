//! [`run`]: the simulator as its own ROS 2 node, in real time (`rodlog sim --ros2`).
//!
//! The simulated world ([`sim::SimWorld`]) is stepped in chunks of [`SimNodeOptions::clock_period`]
//! of robot time, paced so that robot time runs [`SimNodeOptions::rate`] times faster than
//! wall time. At the end of each chunk the node publishes `/clock` (the chunk's end), then
//! every message the world produced in it, on its rodlog topic: the drivers' sensor topics and
//! the `/sim/*` truth. Commands arriving on the command topics (`msgs::topics::COMMANDS`,
//! from any node: `/camera/trigger` takes a capture) are carried out at the world's current
//! time, before the next chunk; a rejected one is logged on `/rosout`.
//!
//! QoS: images best effort (a RustDDS reliable writer of large samples performs badly,
//! `ros2/MEASUREMENT.md`), latched topics transient local, `/clock` best effort depth 1 (as
//! ROS 2's clock publishers), everything else reliable. Command subscriptions are reliable.
//!
//! Real time is best effort: a chunk that takes longer than its wall slot (a capture being
//! rendered) delays the next ones, and the node catches up without skipping robot time.

use std::collections::BTreeMap;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use msgs::drivers::World as _;
use msgs::rcl_interfaces::Log;
use msgs::rosgraph_msgs::Clock;
use msgs::{Msg, RobotDuration, RobotTime, RosMessage, topics};
use ros2::{Node, NodeOptions, Publisher, Qos, Subscription};

use crate::error::ComposeError;
use crate::plan::Plan;
use crate::world::World;

/// Producer name of the node's own `/rosout` lines.
pub const SIM_NODE: &str = "sim_node";

/// How to run the simulator node.
#[derive(Debug, Clone)]
pub struct SimNodeOptions {
    /// Robot time per wall time (1 = real time).
    pub rate: f64,
    /// Robot time to run.
    pub duration: RobotDuration,
    /// The node.
    pub node: NodeOptions,
    /// Robot time per step, and `/clock` period.
    pub clock_period: RobotDuration,
    /// Wall time to wait for subscribers before the world starts.
    pub settle: Duration,
    /// Wall time to stay on the graph after the end (reliable delivery, late readers).
    pub linger: Duration,
}

impl Default for SimNodeOptions {
    fn default() -> Self {
        Self {
            rate: 1.0,
            duration: RobotDuration::from_secs(60),
            node: NodeOptions {
                name: "rodlog_sim".to_owned(),
                ..NodeOptions::default()
            },
            clock_period: RobotDuration::from_millis(10),
            settle: Duration::from_millis(1500),
            linger: Duration::from_millis(500),
        }
    }
}

/// What the node did.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct SimNodeSummary {
    /// Messages published (`/clock` included).
    pub published: u64,
    /// Messages the writers refused (a reliable writer whose readers lag).
    pub publish_errors: u64,
    /// Commands received.
    pub commands: u64,
    /// Commands the world rejected.
    pub rejected: u64,
    /// Robot time reached.
    pub end: RobotTime,
    /// Stopped by Ctrl-C.
    pub interrupted: bool,
    /// Chunks that started later than their wall slot by more than one period.
    pub late_chunks: u64,
}

fn ros2_err(what: &str) -> impl Fn(ros2::Ros2Error) -> ComposeError + '_ {
    move |source| ComposeError::Ros2 {
        what: what.to_owned(),
        source: Box::new(source),
    }
}

/// The publisher QoS of a rodlog topic on the simulator node (module docs).
#[must_use]
pub fn publisher_qos(spec: &msgs::TopicSpec) -> Qos {
    if spec.type_name == msgs::sensor_msgs::Image::TYPE_NAME {
        Qos::COMMAND.best_effort().with_depth(2)
    } else {
        Qos::for_publisher(spec)
    }
}

struct Publishers<'n> {
    node: &'n Node,
    by_topic: BTreeMap<String, Publisher>,
    summary: SimNodeSummary,
}

impl Publishers<'_> {
    fn publish(&mut self, topic: &str, msg: &Msg, stamp_ns: i64) -> Result<(), ComposeError> {
        if !self.by_topic.contains_key(topic) {
            let qos = msgs::topics::lookup(topic).map_or(Qos::COMMAND, publisher_qos);
            let p = self
                .node
                .publisher_raw(topic, msg.type_name(), qos)
                .map_err(ros2_err(topic))?;
            self.by_topic.insert(topic.to_owned(), p);
        }
        let Some(p) = self.by_topic.get(topic) else {
            return Ok(());
        };
        let cdr = msg.encode().map_err(|e| ComposeError::Decode {
            path: std::path::PathBuf::from(SIM_NODE),
            topic: topic.to_owned(),
            log_time_ns: u64::try_from(stamp_ns).unwrap_or(0),
            reason: e.to_string(),
        })?;
        match p.publish_at(&cdr, stamp_ns) {
            Ok(()) => self.summary.published += 1,
            Err(_) => self.summary.publish_errors += 1,
        }
        Ok(())
    }

    fn log(&mut self, t: RobotTime, level: u8, text: String) -> Result<(), ComposeError> {
        eprintln!("rodlog sim: {text}");
        let log = recorder::runner::rosout(SIM_NODE, t, level, text);
        self.publish(topics::ROSOUT, &log, t.as_nanos() as i64)
    }
}

/// Runs `plan` (world `sim`) as a ROS 2 node (module docs) until `options.duration` or Ctrl-C.
///
/// # Errors
/// A plan of another world, the simulator's and DDS errors.
pub fn run(plan: &Plan, options: &SimNodeOptions) -> Result<SimNodeSummary, ComposeError> {
    let World::Sim(mut world) = plan.world()? else {
        return Err(ComposeError::WrongWorld {
            wanted: "sim",
            world: plan.world_kind().name().to_owned(),
        });
    };
    let node = Node::new(options.node.clone()).map_err(ros2_err("joining the domain"))?;
    let mut commands: Vec<(&'static str, Subscription)> = Vec::new();
    for topic in topics::COMMANDS {
        let Some(spec) = topics::lookup(topic) else {
            continue;
        };
        let sub = node
            .subscribe_raw(topic, spec.type_name, Qos::COMMAND)
            .map_err(ros2_err(topic))?;
        commands.push((spec.name, sub));
    }
    let mut out = Publishers {
        node: &node,
        by_topic: BTreeMap::new(),
        summary: SimNodeSummary::default(),
    };
    // The clock and the sensor topics exist from the start, so readers can match them
    // during the settle time.
    let clock_pub = node
        .publisher_raw(
            topics::CLOCK,
            Clock::TYPE_NAME,
            Qos::COMMAND.best_effort().with_depth(1),
        )
        .map_err(ros2_err(topics::CLOCK))?;
    for spec in msgs::registry() {
        let sensor = crate::ros2::record::GRAPH_INPUTS.contains(&spec.name)
            && spec.name != topics::TF_STATIC;
        if sensor {
            let p = node
                .publisher_raw(spec.name, spec.type_name, publisher_qos(spec))
                .map_err(ros2_err(spec.name))?;
            out.by_topic.insert(spec.name.to_owned(), p);
        }
    }
    let stop = recorder::live::ctrl_c_flag();
    let interrupted = || stop.as_ref().is_some_and(|s| s.load(Ordering::SeqCst));
    let settle_until = Instant::now() + options.settle;
    while Instant::now() < settle_until && !interrupted() {
        std::thread::sleep(Duration::from_millis(20));
    }
    let end = RobotTime::ZERO + options.duration;
    let period = options.clock_period.max(RobotDuration::from_millis(1));
    let rate = if options.rate.is_finite() && options.rate > 0.0 {
        options.rate
    } else {
        1.0
    };
    let start = Instant::now();
    let mut now = RobotTime::ZERO;
    let mut first = true;
    loop {
        if interrupted() {
            out.summary.interrupted = true;
            break;
        }
        // Commands first, at the world's current time.
        for (topic, sub) in &mut commands {
            while let Some(r) = sub.try_recv().map_err(ros2_err(topic))? {
                out.summary.commands += 1;
                let Some(spec) = topics::lookup(topic) else {
                    continue;
                };
                let result = Msg::decode(spec.type_name, &r.cdr)
                    .map_err(|e| e.to_string())
                    .and_then(|msg| world.command(now, topic, &msg).map_err(|e| e.to_string()));
                if let Err(e) = result {
                    out.summary.rejected += 1;
                    out.log(
                        now,
                        Log::WARN,
                        format!("command on {topic} not executed: {e}"),
                    )?;
                }
            }
        }
        let target = if first { RobotTime::ZERO } else { now + period };
        if target > end {
            break;
        }
        // Pace: the chunk ending at `target` is due at wall time target / rate.
        let due = start + Duration::from_secs_f64(target.as_secs_f64() / rate);
        let wall = Instant::now();
        if due > wall {
            std::thread::sleep(due - wall);
        } else if wall - due > Duration::from_secs_f64(period.as_secs_f64() / rate) {
            out.summary.late_chunks += 1;
        }
        let outputs = world
            .step_until(target)
            .map_err(|e| ComposeError::Driver(Box::new(e)))?;
        first = false;
        now = target;
        let stamp = now.as_nanos() as i64;
        let clock = Msg::Clock(Clock {
            clock: now.to_ros().unwrap_or_default(),
        });
        let cdr = clock.encode().unwrap_or_default();
        match clock_pub.publish_at(&cdr, stamp) {
            Ok(()) => out.summary.published += 1,
            Err(_) => out.summary.publish_errors += 1,
        }
        for o in outputs {
            out.publish(&o.topic, &o.msg, o.log_time.as_nanos() as i64)?;
        }
    }
    out.summary.end = now;
    let linger_until = Instant::now() + options.linger;
    while Instant::now() < linger_until && !interrupted() {
        std::thread::sleep(Duration::from_millis(20));
    }
    Ok(out.summary)
}
