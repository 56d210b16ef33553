//! [`record`]: a plan's pipeline run live on a ROS 2 graph and recorded (`rodlog record
//! --ros2`).
//!
//! 1. One node joins the domain. Robot time is wall time since the start, or the graph's
//!    `/clock` when the graph publishes one (`ros2.use_sim_time`, [`super::SimTime`]; `auto`
//!    waits [`Ros2RunOptions::settle`] for discovery to tell).
//! 2. Every graph input ([`GRAPH_INPUTS`], under its vendor name where a remap file routes
//!    it) gets a subscription (sensors best effort, `/tf_static` transient local) whose
//!    samples of this node's own writers are skipped; the run starts right away.
//! 3. Every arrival is stamped with the robot time on arrival (`header.stamp` is kept, for TF
//!    lookups), converted through the remap, and run through the pipeline by the live
//!    runtime ([`recorder::run_live`]): the same [`recorder::Runner`] replay uses. Inputs
//!    and outputs are recorded with their producer.
//! 4. The run ends at the scenario's duration, at the task's end (`--until-done`), on SIGINT,
//!    or when the graph's `/clock` stops; dropped, lost and late inputs are counted per topic,
//!    reported on `/rosout` and written as the `live_inputs` metadata record.
//!
//! `/sim/*` topics are recorded when the graph has them (the judge reads them), and handed to
//! no stage: the runner refuses any stage that asks for one.

use std::sync::Arc;
use std::time::{Duration, Instant};

use msgs::topics;
use recorder::{
    LiveClock, LiveOptions, LiveOutput, LiveRun, LiveSource, LiveSummary, McapSink, McapStreamSink,
    MetadataRecord, RecordOptions, Runner, Sink, SinkFanout, StopCondition,
};
use ros2::{Node, Qos, Route};

use super::motion::{MotionCounts, command_path};
use super::safety::{ESTOP, Safety, StatusSource, Watchdog};
use super::source::{ClockSource, Hook, TopicSource};
use super::{Ros2World, SimTime};
use crate::error::ComposeError;
use crate::plan::Plan;
use crate::world::World;

/// The rodlog topics `record --ros2` subscribes to (under their vendor names where a remap
/// routes them): what drivers publish, and the simulator's truth.
pub const GRAPH_INPUTS: [&str; 20] = [
    topics::JOINT_STATES,
    topics::TF,
    topics::TF_STATIC,
    topics::CAMERA_COLOR_IMAGE,
    topics::CAMERA_DEPTH_IMAGE,
    topics::CAMERA_COLOR_INFO,
    topics::PANORAMIC_IMAGE,
    topics::PANORAMIC_INFO,
    topics::ENV_WIND,
    topics::ENV_ILLUMINANCE,
    topics::WRIST_LIGHT_STATE,
    topics::SIM_CAMERA_MOUNT,
    topics::SIM_CAMERA_INFO,
    topics::SIM_PANORAMIC_INFO,
    topics::SIM_WIRE_POSE,
    topics::SIM_HANDLE_POSE,
    topics::SIM_WIND,
    topics::SIM_ILLUMINANCE,
    topics::SIM_ROD_STATE,
    topics::SIM_BASE_POSE,
];

/// Producer of graph inputs recorded under rodlog's own names (no remap file routes them).
pub const GRAPH_PRODUCER: &str = ros2::remap::DEFAULT_PRODUCER;
/// Name of the metadata record describing the ROS 2 side of a recording.
pub const ROS2_RECORD: &str = "ros2";

/// How to run on the graph, beyond the plan.
pub struct Ros2RunOptions {
    /// Send the stages' commands to the graph (`--allow-motion`; module docs of
    /// [`super::motion`]). Without it no writer exists on any command topic.
    pub allow_motion: bool,
    /// End when the task ends (the plan's [`Plan::task_end`]).
    pub stop: Option<StopCondition>,
    /// Sees every popped message after the command path (benchmarks, tests).
    pub observer: Option<Box<dyn LiveOutput>>,
    /// How long to wait for discovery before the run starts (and before deciding whether
    /// the graph publishes `/clock`).
    pub settle: Duration,
    /// Under `/clock`: end when it has not advanced for this long.
    pub clock_timeout: Duration,
}

impl std::fmt::Debug for Ros2RunOptions {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Ros2RunOptions")
            .field("allow_motion", &self.allow_motion)
            .field("stop", &self.stop)
            .field("settle", &self.settle)
            .field("clock_timeout", &self.clock_timeout)
            .finish_non_exhaustive()
    }
}

impl Default for Ros2RunOptions {
    fn default() -> Self {
        Self {
            allow_motion: false,
            stop: None,
            observer: None,
            settle: Duration::from_millis(1500),
            clock_timeout: Duration::from_secs(5),
        }
    }
}

/// What a run on the graph did.
#[derive(Debug, Clone)]
pub struct Ros2Summary {
    /// The live runtime's summary (messages, per-topic input counters, stages).
    pub live: LiveSummary,
    /// `wall` or `graph /clock`.
    pub clock: &'static str,
    /// The subscriptions, `vendor topic -> rodlog topic (producer)`.
    pub subscriptions: Vec<String>,
    /// This node's writers on command topics, as the graph API saw them before the run
    /// (empty without `--allow-motion`).
    pub command_writers: Vec<String>,
    /// Whether robot_state's TF went to the graph (no driver published `/tf`).
    pub robot_tf: bool,
    /// The command path's counters.
    pub motion: MotionCounts,
    /// The watchdog's worst gap between two checks, its checks and the holds entered
    /// (with `--allow-motion`).
    pub watchdog: Option<(Duration, u64, u64)>,
}

/// This node's own writers on the command topics, under rodlog's and the remap's names
/// (requests of action and service clients included), from the graph API.
///
/// # Errors
/// An invalid remapped name.
pub fn local_command_writers(
    node: &Node,
    remap: &ros2::Remap,
) -> Result<Vec<String>, ComposeError> {
    let mut names: Vec<String> = topics::COMMANDS.iter().map(|t| (*t).to_owned()).collect();
    let c = &remap.commands;
    match &c.arm {
        Some(ros2::remap::ArmCommand::Topic(t)) => names.push(t.clone()),
        Some(ros2::remap::ArmCommand::Action(a)) => {
            names.push(format!("{a}/_action/send_goal"));
            names.push(format!("{a}/_action/cancel_goal"));
        }
        None => {}
    }
    if let Some(ros2::remap::TriggerCommand::Topic(t)) = &c.camera_trigger {
        names.push(t.clone());
    }
    for t in [&c.lift, &c.base, &c.clamp, &c.light].into_iter().flatten() {
        names.push(t.clone());
    }
    let services: Vec<String> = match &c.camera_trigger {
        Some(ros2::remap::TriggerCommand::Services { calls, .. }) => {
            calls.iter().map(|(s, _)| s.clone()).collect()
        }
        _ => Vec::new(),
    };
    let mut found = Vec::new();
    let all = node.endpoints();
    for name in names.iter().chain(&services) {
        let dds = ros2::names::dds_topic(name).map_err(ros2_err(name))?;
        let (rq, _) = ros2::names::dds_service_topics(name).map_err(ros2_err(name))?;
        let mine = all.iter().any(|e| {
            e.local
                && e.kind == ros2::EndpointKind::Writer
                && (e.dds_topic == dds || e.dds_topic == rq)
        });
        if mine && !found.contains(name) {
            found.push(name.clone());
        }
    }
    Ok(found)
}

fn ros2_err(what: &str) -> impl Fn(ros2::Ros2Error) -> ComposeError + '_ {
    move |source| ComposeError::Ros2 {
        what: what.to_owned(),
        source: Box::new(source),
    }
}

/// Runs `plan` (world `ros2`) on the graph and records it to `options.out` (module docs).
///
/// # Errors
/// A plan of another world, remap files that do not load, DDS failures, and the live
/// runtime's errors (the file is finished in every case once it was created).
pub fn record(
    plan: &Plan,
    options: &RecordOptions,
    run: Ros2RunOptions,
    extra_sinks: Vec<Box<dyn Sink>>,
) -> Result<Ros2Summary, ComposeError> {
    let World::Ros2(world) = plan.world()? else {
        return Err(ComposeError::WrongWorld {
            wanted: "ros2",
            world: plan.world_kind().name().to_owned(),
        });
    };
    let world: Ros2World = *world;
    let runner = Runner::new(plan.pipeline()?).map_err(|e| ComposeError::Runner(Box::new(e)))?;
    let node = Node::new(world.config.node_options()).map_err(ros2_err("joining the domain"))?;
    let remap = Arc::new(world.remap.clone());
    // The clock first: whether the graph publishes /clock is known once discovery settled.
    let clock_sub = node
        .subscribe_raw(
            topics::CLOCK,
            <msgs::rosgraph_msgs::Clock as msgs::RosMessage>::TYPE_NAME,
            Qos::SENSOR_SUBSCRIPTION.with_depth(1),
        )
        .map_err(ros2_err(topics::CLOCK))?;
    // Discovery settles: whether the graph has /clock and /tf writers is known after it.
    let settle_until = Instant::now() + run.settle;
    while Instant::now() < settle_until {
        std::thread::sleep(Duration::from_millis(20));
    }
    let graph_clock = match world.config.use_sim_time {
        SimTime::On => true,
        SimTime::Off => false,
        SimTime::Auto => node
            .writers_on(topics::CLOCK)
            .map_err(ros2_err(topics::CLOCK))?
            .iter()
            .any(|e| !e.local),
    };
    let mut sources: Vec<Box<dyn LiveSource>> = Vec::new();
    let clock = if graph_clock {
        sources.push(Box::new(ClockSource::new(clock_sub)));
        LiveClock::external()
    } else {
        drop(clock_sub);
        LiveClock::wall(1)
    };
    let driver_tf = node
        .writers_on(topics::TF)
        .map_err(ros2_err(topics::TF))?
        .iter()
        .any(|e| !e.local);
    let safety = run.allow_motion.then(|| {
        Safety::with_deadlines(
            remap.status.clone(),
            world.config.joint_states_deadline,
            world.config.capture_deadline,
        )
    });
    // Then the inputs; their sources start reading as soon as the run starts, right after.
    let mut routes: Vec<Route> = remap.routes_with_identity(&GRAPH_INPUTS, GRAPH_PRODUCER);
    if safety.is_some() {
        routes.push(Route {
            vendor: ESTOP.to_owned(),
            rodlog: ESTOP,
            type_name: <msgs::std_msgs::Empty as msgs::RosMessage>::TYPE_NAME,
            producer: "estop".to_owned(),
            qos: ros2::remap::QosClass::Sensor,
            encoding: None,
            depth_scale: None,
            origin: ros2::remap::IDENTITY_ORIGIN.to_owned(),
            frames: std::collections::BTreeMap::new(),
        });
    }
    let mut subscriptions = Vec::new();
    for route in routes {
        let mut sub = node
            .subscribe_raw(&route.vendor, route.type_name, route.qos.qos())
            .map_err(ros2_err(&route.vendor))?;
        sub.set_ignore_local(true);
        subscriptions.push(format!(
            "{} -> {} ({})",
            route.vendor, route.rodlog, route.producer
        ));
        let mut source = TopicSource::new(sub, route.clone(), Arc::clone(&remap));
        if let Some(s) = &safety {
            let s = Arc::clone(s);
            let hook: Option<Hook> = match route.rodlog {
                topics::JOINT_STATES => Some(Arc::new(move |_: &msgs::Msg, t: msgs::RobotTime| {
                    s.joint_states(t)
                })),
                topics::CAMERA_COLOR_IMAGE => {
                    Some(Arc::new(move |_: &msgs::Msg, _: msgs::RobotTime| s.image()))
                }
                ESTOP => Some(Arc::new(move |_: &msgs::Msg, _: msgs::RobotTime| s.estop())),
                _ => None,
            };
            if let Some(h) = hook {
                source = source.with_hook(h);
            }
        }
        sources.push(Box::new(source));
    }
    if let Some(s) = &safety {
        for status in &remap.status {
            sources.push(Box::new(
                StatusSource::new(&node, status.clone(), Arc::clone(s))
                    .map_err(ros2_err(&status.topic))?,
            ));
        }
    }
    // The command path: writers on command topics only with --allow-motion.
    let (mut outbox, commands) = command_path(
        &node,
        Arc::clone(&remap),
        run.allow_motion,
        !driver_tf,
        safety.clone(),
    )?;
    let motion_counts = outbox.counts();
    outbox.set_observer(run.observer);
    let command_writers = local_command_writers(&node, &remap)?;
    if !run.allow_motion && !command_writers.is_empty() {
        return Err(ComposeError::Ros2 {
            what: "the command path".to_owned(),
            source: Box::new(ros2::Ros2Error::CreateEndpoint {
                topic: command_writers.join(","),
                what: "writer",
                reason: "a command writer exists without --allow-motion (a bug: refusing to run)"
                    .to_owned(),
            }),
        });
    }
    sources.push(Box::new(commands));
    if let Some(s) = &safety {
        sources.push(Box::new(Watchdog::new(Arc::clone(s), outbox.sender())));
    }
    let clock_name = if graph_clock { "graph /clock" } else { "wall" };

    let mut header = plan.header()?;
    let mut ros = MetadataRecord::new(ROS2_RECORD)
        .with("domain_id", node.domain_id().to_string())
        .with("discovery", format!("{:?}", node.discovery_range()))
        .with("node", node.name())
        .with("clock", clock_name)
        .with("pipeline", world.config.pipeline.name())
        .with("subscriptions", subscriptions.join("; "))
        .with("allow_motion", run.allow_motion)
        .with("command_writers", command_writers.join(","))
        .with("robot_tf_to_graph", !driver_tf);
    ros = ros.with(
        "remap",
        remap
            .files
            .iter()
            .map(|f| f.0.clone())
            .collect::<Vec<_>>()
            .join(","),
    );
    header.metadata.push(ros);
    for (name, text) in &remap.files {
        header.attachments.push((
            format!("remap/{name}"),
            "application/toml".to_owned(),
            text.clone().into_bytes(),
        ));
    }
    // With motion, the watchdog and the command path keep a core: stages (the calibration's
    // rayon work) get the others.
    let threads = options.threads.or_else(|| {
        run.allow_motion.then(|| {
            std::thread::available_parallelism()
                .map_or(1, std::num::NonZeroUsize::get)
                .saturating_sub(1)
                .max(1)
        })
    });
    let pool = threads
        .map(|threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads.max(1))
                .build()
                .map_err(|e| {
                    ComposeError::Record(Box::new(recorder::RecordError::Threads {
                        threads,
                        reason: e.to_string(),
                    }))
                })
        })
        .transpose()?;
    let mcap = McapSink::create(&options.out, &options.sink)
        .map_err(|e| ComposeError::Record(Box::new(e.into())))?;
    let sink: Box<dyn Sink> = Box::new(McapStreamSink::new(mcap));
    let mut fanout = SinkFanout::new(std::iter::once(sink).chain(extra_sinks).collect());
    if let Err(e) = recorder::session::write_header(&mut fanout, &header) {
        let _finished = fanout.finish();
        return Err(ComposeError::Record(Box::new(e.into())));
    }
    let live = LiveRun {
        drivers: Vec::new(),
        sources,
        clock,
        duration: plan.scenario().duration,
        stop: run.stop,
        output: Some(Box::new(outbox)),
        clock_timeout: graph_clock.then_some(run.clock_timeout),
        options: LiveOptions {
            tick: Duration::from_millis(5),
            channel_capacity: 256,
            input_capacity: world.config.input_capacity,
            merge_delay: world.config.merge_delay,
            speed: 1,
        },
    };
    let go = || recorder::run_live(live, runner, fanout);
    let result = match &pool {
        Some(p) => p.install(go),
        None => go(),
    };
    let live = result.map_err(|source| ComposeError::Live {
        path: options.out.clone(),
        source: Box::new(source),
    })?;
    drop(node);
    let motion = *motion_counts
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    Ok(Ros2Summary {
        live,
        clock: clock_name,
        subscriptions,
        command_writers,
        robot_tf: !driver_tf,
        motion,
        watchdog: safety.map(|s| s.watchdog_figures()),
    })
}
