//! `rodlog demo [--out DIR] [--seed N] [--set k=v]... [--no-viz]`: the simulator runs the
//! whole job once (scenario `demo`): the base drives to its working spot, the robot checks its
//! hand-eye calibration, finds that the camera mount was knocked and recalibrates itself from
//! natural features, hangs the grounding rod on the wire, then removes it and puts it back in
//! the rack. Writes `DIR/demo.mcap` (the log) and `DIR/demo.rrd` (Rerun), judges the run with
//! the simulator's truth ([`crate::judge`]) and prints a short summary with the times.

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::{Context as _, bail};
use msgs::rodlog_msgs::TaskEvent;
use msgs::topics::TASK_EVENT;
use recorder::{ChunkCompression, RecordOptions, SinkOptions};
use replay::{McapReader, ReadFilter};

/// Arguments of `rodlog demo`.
#[derive(Debug, clap::Args)]
pub struct DemoArgs {
    /// Output folder (created): demo.mcap, demo.rrd.
    #[arg(long, default_value = "demo")]
    pub out: PathBuf,
    /// Override the demo scenario's seed.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Override a parameter, `stage.key=value` or a world key (repeatable), as `record`.
    #[arg(long = "set", value_name = "K=V")]
    pub set: Vec<String>,
    /// The crew's survey of the bay, a site file (`config/sites/*.toml`, ARCHITECTURE.md
    /// section 5): what the robot plans with instead of the built-in fixed bay.
    #[arg(long, value_name = "FILE")]
    pub site: Option<PathBuf>,
    /// Skip the Rerun recording (faster).
    #[arg(long)]
    pub no_viz: bool,
}

/// Runs `rodlog demo`.
///
/// # Errors
/// Scenario, simulation, recording and judging errors; a run that did not succeed.
pub fn run(args: &DemoArgs) -> anyhow::Result<()> {
    let plan = super::record::plan("demo", args.seed, None, &args.set, args.site.as_deref())?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let mcap = args.out.join("demo.mcap");
    let rrd = args.out.join("demo.rrd");
    let mut extra: Vec<Box<dyn recorder::Sink>> = Vec::new();
    if !args.no_viz {
        extra.push(Box::new(super::view::VizSink::create(
            &rrd,
            &plan.header()?.metadata,
        )?));
    }
    let options = RecordOptions {
        out: mcap.clone(),
        sink: SinkOptions {
            compression: ChunkCompression::Lz4,
            ..SinkOptions::default()
        },
        realtime: false,
        threads: None,
        stop: plan.task_end(),
    };
    let wall = std::time::Instant::now();
    let summary = compose::record(&plan, &options, extra)?;
    let wall_s = wall.elapsed().as_secs_f64();
    let verdict = compose::judge::judge(&mcap)?;

    // The phases' ends from the task events.
    let mut reader = McapReader::open(&mcap)?;
    let mut phases: Vec<(String, f64, TaskEvent)> = Vec::new();
    let mut started: Vec<(String, f64)> = Vec::new();
    for m in reader.messages(&ReadFilter::all().with_topics([TASK_EVENT])) {
        let m = m?;
        let t_s = m.log_time_ns as f64 * 1e-9;
        if let Some(e) = m.decode()?.get::<TaskEvent>().cloned() {
            if e.state == "started" {
                started.push((e.task.clone(), t_s));
            }
            if e.kind != TaskEvent::INFO && e.task != "calibration" {
                phases.push((e.task.clone(), t_s, e));
            }
        }
    }
    let mut text = format!(
        "rodlog demo: {:.1} s of robot time simulated in {wall_s:.1} s wall ({} messages)\n",
        summary.end.as_secs_f64(),
        summary.messages
    );
    for a in &verdict.calibration {
        writeln!(
            text,
            "  {:7.1} s  calibration {}: {} ({})",
            a.t_s, a.state, a.reason_code, a.text
        )?;
    }
    for (task, t_s, e) in &phases {
        let began = started
            .iter()
            .find(|(n, _)| n == task)
            .map_or(f64::NAN, |(_, s)| *s);
        let kind = match e.kind {
            TaskEvent::DONE => "done",
            TaskEvent::REFUSED => "REFUSED",
            _ => "FAILED",
        };
        writeln!(
            text,
            "  {t_s:7.1} s  {task} {kind} in {:.1} s{}",
            t_s - began,
            if e.kind == TaskEvent::DONE {
                String::new()
            } else {
                format!(" [{}]: {}", e.reason_code, e.text)
            }
        )?;
    }
    writeln!(
        text,
        "  judged with the simulator's truth: rod {} ({}), {} commands, {} unsafe",
        verdict.rod_state,
        if verdict.success {
            "success"
        } else {
            "not where the task wanted it"
        },
        verdict.commands,
        verdict.unsafe_commands.len()
    )?;
    write!(text, "  log: {}", mcap.display())?;
    if !args.no_viz {
        write!(text, "\n  view: rerun {}", rrd.display())?;
    }
    super::print_stdout(&text)?;
    if !verdict.success || !verdict.unsafe_commands.is_empty() {
        bail!(
            "the demo did not succeed (rod {}, {} unsafe commands): see rodlog log {}",
            verdict.rod_state,
            verdict.unsafe_commands.len(),
            mcap.display()
        );
    }
    Ok(())
}
