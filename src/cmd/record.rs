//! `rodlog record --scenario NAME|FILE|REC.mcap [--seed N] [--set k=v]... [--out rec.mcap]
//! [--realtime] [--threads N] [--viz rec.rrd] [--until-done]`: run a scenario through its
//! pipeline in its world ([`compose::Plan`]) and record it.
//!
//! `rodlog record --ros2 [--scenario S] [--duration S] [--remap FILE]... [--domain N] --out F`:
//! the same on a ROS 2 graph (`world = "ros2"`, [`compose::ros2::record`]); without
//! `--scenario` the `ros2` scenario (robot_state only).

use std::path::PathBuf;

use anyhow::{Context as _, bail};
use recorder::{ChunkCompression, RecordOptions, SinkOptions};

/// Arguments of `rodlog record`.
#[derive(Debug, clap::Args)]
pub struct RecordArgs {
    /// Scenario name (recordings/scenarios/NAME.toml), scenario file, or a recording (.mcap):
    /// its scenario, seed and parameters (closed-loop what-if with --set). Required unless
    /// --ros2 (which defaults to the `ros2` scenario: record, robot_state only).
    #[arg(long)]
    pub scenario: Option<String>,
    /// Join a ROS 2 graph (world = "ros2"): subscribe to the drivers' topics, stamp them on
    /// the robot clock, run the scenario's stages live and record inputs and outputs.
    #[arg(long)]
    pub ros2: bool,
    /// With --ros2: a remap file (vendor topics, frames, joints, units to rodlog's), a path or
    /// a name in config/remap/ (aubo_i10, mecheye_nano); repeatable.
    #[arg(long, value_name = "FILE")]
    pub remap: Vec<String>,
    /// With --ros2: the ROS 2 domain (default: ROS_DOMAIN_ID, else 0).
    #[arg(long)]
    pub domain: Option<u16>,
    /// With --ros2: send the stages' commands to the robot (arm, lift, base, clamp, camera
    /// trigger). Without it rodlog records and computes, and has no writer on any command
    /// topic. Software stop on /estop, holds on stale joint states, a stale camera or a driver
    /// status that does not allow motion (README, "Running on the real robot").
    #[arg(long)]
    pub allow_motion: bool,
    /// Override the scenario's seed.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Override the scenario's duration, seconds of robot time.
    #[arg(long)]
    pub duration: Option<f64>,
    /// Override a parameter, `stage.key=value` (repeatable; `rodlog params SCENARIO` lists
    /// the keys).
    #[arg(long = "set", value_name = "K=V")]
    pub set: Vec<String>,
    /// The crew's survey of the bay, a site file (`config/sites/*.toml`, ARCHITECTURE.md
    /// section 5): what the robot plans with instead of the built-in fixed bay.
    #[arg(long, value_name = "FILE")]
    pub site: Option<PathBuf>,
    /// Output file (default: NAME.mcap in the current directory).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Pace by the wall clock (live runtime); without it the run is as fast as possible with
    /// identical output.
    #[arg(long)]
    pub realtime: bool,
    /// Worker threads stages may use (rayon pool size); output is identical for any N.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Chunk compression: lz4 (default), zstd or none.
    #[arg(long, default_value = "lz4")]
    pub compression: String,
    /// Also draw the run in Rerun: write this .rrd beside the MCAP (the viz sink).
    #[arg(long, value_name = "REC.rrd")]
    pub viz: Option<PathBuf>,
    /// End the recording a few seconds after the scenario's task has ended (done, refused
    /// or failed) instead of at its duration.
    #[arg(long)]
    pub until_done: bool,
}

/// Parses `--compression`.
///
/// # Errors
/// Unknown names.
pub fn compression(name: &str) -> anyhow::Result<ChunkCompression> {
    Ok(match name {
        "lz4" => ChunkCompression::Lz4,
        "zstd" => ChunkCompression::Zstd,
        "none" => ChunkCompression::None,
        other => bail!("unknown --compression {other:?} (lz4, zstd or none)"),
    })
}

/// The scenario of `--scenario` with `--seed`, `--duration`, `--set` and `--site` (the
/// survey, applied last) applied, composed.
///
/// # Errors
/// A scenario that cannot be found or read, a mistyped or unknown parameter.
pub fn plan(
    scenario: &str,
    seed: Option<u64>,
    duration: Option<f64>,
    sets: &[String],
    site: Option<&std::path::Path>,
) -> anyhow::Result<compose::Plan> {
    let (mut scenario, migrated) = compose::load_scenario(scenario)?;
    for m in &migrated {
        eprintln!("rodlog: note: {m}");
    }
    if let Some(seed) = seed {
        scenario.seed = seed;
    }
    if let Some(d) = duration {
        scenario.duration = msgs::RobotDuration::from_secs_f64(d).context("--duration")?;
    }
    for s in sets {
        scenario.set_from_arg(s)?;
    }
    if let Some(site) = site {
        scenario.apply_site_file(site)?;
    }
    Ok(compose::Plan::new(&scenario)?)
}

/// The plan of `rodlog record`'s flags.
///
/// # Errors
/// No scenario without --ros2; ROS 2 flags without --ros2; whatever [`plan`] refuses.
pub fn record_plan(args: &RecordArgs) -> anyhow::Result<compose::Plan> {
    let scenario = match (&args.scenario, args.ros2) {
        (Some(s), _) => s.as_str(),
        (None, true) => "ros2",
        (None, false) => bail!("--scenario is required (or --ros2 to record a ROS 2 graph)"),
    };
    if !args.ros2 && (!args.remap.is_empty() || args.domain.is_some() || args.allow_motion) {
        bail!("--remap, --domain and --allow-motion need --ros2");
    }
    let mut sets = Vec::new();
    if args.ros2 {
        sets.push("world=\"ros2\"".to_owned());
        if !args.remap.is_empty() {
            sets.push(format!("ros2.remap={:?}", args.remap.join(",")));
        }
        if let Some(d) = args.domain {
            sets.push(format!("ros2.domain_id={d}"));
        }
    }
    sets.extend(args.set.iter().cloned());
    plan(
        scenario,
        args.seed,
        args.duration,
        &sets,
        args.site.as_deref(),
    )
}

/// Where a recording goes, the same for every world.
pub(super) struct Outputs {
    /// The file (`--out`, or `SCENARIO.mcap`).
    pub out: PathBuf,
    /// Its sink options (`--compression`).
    pub sink: SinkOptions,
    /// The extra sinks (`--viz`).
    pub extra_sinks: Vec<Box<dyn recorder::Sink>>,
}

/// The [`Outputs`] of `args`.
///
/// # Errors
/// An unknown compression; the Rerun file cannot be created.
pub(super) fn outputs(args: &RecordArgs, plan: &compose::Plan) -> anyhow::Result<Outputs> {
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from(format!("{}.mcap", plan.scenario().name)));
    let sink = SinkOptions {
        compression: compression(&args.compression)?,
        ..SinkOptions::default()
    };
    let mut extra_sinks: Vec<Box<dyn recorder::Sink>> = Vec::new();
    if let Some(rrd) = &args.viz {
        extra_sinks.push(Box::new(super::view::VizSink::create(
            rrd,
            &plan.header()?.metadata,
        )?));
    }
    Ok(Outputs {
        out,
        sink,
        extra_sinks,
    })
}

/// Runs `rodlog record`.
pub fn run(args: &RecordArgs) -> anyhow::Result<()> {
    let plan = record_plan(args)?;
    if plan.world_kind() == compose::WorldKind::Ros2 {
        return super::record_ros2::run(args, &plan);
    }
    let Outputs {
        out,
        sink,
        extra_sinks,
    } = outputs(args, &plan)?;
    let options = RecordOptions {
        out: out.clone(),
        sink,
        realtime: args.realtime,
        threads: args.threads,
        stop: if args.until_done {
            plan.task_end()
        } else {
            None
        },
    };
    let summary = compose::record(&plan, &options, extra_sinks).with_context(|| {
        format!(
            "recording scenario {} to {}",
            plan.scenario().name,
            out.display()
        )
    })?;
    let mut text = format!(
        "recorded {} messages, {} of robot time, to {}{}\n",
        summary.messages,
        summary.end,
        out.display(),
        if summary.interrupted {
            " (interrupted)"
        } else {
            ""
        }
    );
    text.push_str(&format!(
        "  world {} msgs, /clock {}, stage outputs {}, commands {} ({} rejected)",
        summary.scheduler.world_messages,
        summary.scheduler.clock_messages,
        summary.scheduler.stage_outputs,
        summary.scheduler.commands,
        summary.scheduler.rejected_commands
    ));
    for s in &summary.stages {
        text.push_str(&format!(
            "\n  stage {:<22} inputs {:>7}  errors {}{}",
            s.name,
            s.inputs,
            s.errors,
            if s.disabled { " (stopped)" } else { "" }
        ));
    }
    super::print_stdout(&text)
}
