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

use super::source::{ClockSource, TopicSource};
use super::{Ros2World, SimTime};
use crate::error::ComposeError;
use crate::plan::Plan;
use crate::world::World;

/// The rodlog topics `record --ros2` subscribes to (under their vendor names where a remap
/// routes them): what drivers publish, and the simulator's truth.
pub const GRAPH_INPUTS: [&str; 17] = [
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
    topics::SIM_CAMERA_MOUNT,
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
            .field("stop", &self.stop)
            .field("settle", &self.settle)
            .field("clock_timeout", &self.clock_timeout)
            .finish_non_exhaustive()
    }
}

impl Default for Ros2RunOptions {
    fn default() -> Self {
        Self {
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
    if world.config.use_sim_time == SimTime::Auto {
        let settle_until = Instant::now() + run.settle;
        while Instant::now() < settle_until {
            std::thread::sleep(Duration::from_millis(20));
        }
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
    // Then the inputs; their sources start reading as soon as the run starts, right after.
    let routes: Vec<Route> = remap.routes_with_identity(&GRAPH_INPUTS, GRAPH_PRODUCER);
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
        sources.push(Box::new(TopicSource::new(sub, route, Arc::clone(&remap))));
    }
    let clock_name = if graph_clock { "graph /clock" } else { "wall" };

    let mut header = plan.header()?;
    let mut ros = MetadataRecord::new(ROS2_RECORD)
        .with("domain_id", node.domain_id().to_string())
        .with("discovery", format!("{:?}", node.discovery_range()))
        .with("node", node.name())
        .with("clock", clock_name)
        .with("pipeline", world.config.pipeline.name())
        .with("subscriptions", subscriptions.join("; "));
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
    let pool = options
        .threads
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
        output: run.observer,
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
    Ok(Ros2Summary {
        live,
        clock: clock_name,
        subscriptions,
    })
}
