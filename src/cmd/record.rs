//! `rodlog record --scenario NAME|FILE|REC.mcap [--seed N] [--set k=v]... [--out rec.mcap]
//! [--realtime] [--threads N] [--viz rec.rrd] [--until-done]`: run a scenario through its
//! pipeline in its world ([`compose::Plan`]) and record it.

use std::path::PathBuf;

use anyhow::{Context as _, bail};
use recorder::{ChunkCompression, RecordOptions, SinkOptions};

/// Arguments of `rodlog record`.
#[derive(Debug, clap::Args)]
pub struct RecordArgs {
    /// Scenario name (recordings/scenarios/NAME.toml), scenario file, or a recording (.mcap):
    /// its scenario, seed and parameters (closed-loop what-if with --set).
    #[arg(long)]
    pub scenario: String,
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

/// The scenario of `--scenario` with `--seed`, `--duration` and `--set` applied, composed.
///
/// # Errors
/// A scenario that cannot be found or read, a mistyped or unknown parameter.
pub fn plan(
    scenario: &str,
    seed: Option<u64>,
    duration: Option<f64>,
    sets: &[String],
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
    Ok(compose::Plan::new(&scenario)?)
}

/// Runs `rodlog record`.
pub fn run(args: &RecordArgs) -> anyhow::Result<()> {
    let plan = plan(&args.scenario, args.seed, args.duration, &args.set)?;
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from(format!("{}.mcap", plan.scenario().name)));
    let mut extra_sinks: Vec<Box<dyn recorder::Sink>> = Vec::new();
    if let Some(rrd) = &args.viz {
        extra_sinks.push(Box::new(super::view::VizSink::create(
            rrd,
            &plan.header()?.metadata,
        )?));
    }
    let options = RecordOptions {
        out: out.clone(),
        sink: SinkOptions {
            compression: compression(&args.compression)?,
            ..SinkOptions::default()
        },
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
