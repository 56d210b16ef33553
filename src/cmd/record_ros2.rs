//! `rodlog record --ros2`: the scenario's pipeline run live on a ROS 2 graph and recorded
//! ([`compose::ros2::record`]); prints what was recorded and every topic's input counters.

use anyhow::Context as _;
use compose::ros2::record::{Ros2RunOptions, record};
use recorder::RecordOptions;

use super::record::RecordArgs;

/// Runs `rodlog record --ros2` for `plan` (world `ros2`).
///
/// # Errors
/// `--realtime` (a graph is always live), the recording's errors.
pub fn run(args: &RecordArgs, plan: &compose::Plan) -> anyhow::Result<()> {
    if args.realtime {
        anyhow::bail!("--realtime does not apply to a ROS 2 graph: it always runs live");
    }
    if !plan.remote_keys().is_empty() {
        eprintln!(
            "rodlog: note: not used on a ROS 2 graph (a `rodlog sim --ros2` with this scenario reads them): {}",
            plan.remote_keys().join(", ")
        );
    }
    let super::record::Outputs {
        out,
        sink,
        extra_sinks,
    } = super::record::outputs(args, plan)?;
    let options = RecordOptions {
        out: out.clone(),
        sink,
        realtime: true,
        threads: args.threads,
        stop: None,
    };
    let run = Ros2RunOptions {
        allow_motion: args.allow_motion,
        stop: if args.until_done {
            plan.task_end()
        } else {
            None
        },
        ..Ros2RunOptions::default()
    };
    eprintln!(
        "rodlog: joining the ROS 2 graph (Ctrl-C ends the recording cleanly) -> {}; {}",
        out.display(),
        if args.allow_motion {
            "MOTION ALLOWED: commands go to the robot (software stop: any message on /estop)"
        } else {
            "no motion: commands are recorded, not sent"
        }
    );
    let summary = record(plan, &options, run, extra_sinks)
        .with_context(|| format!("recording the ROS 2 graph to {}", out.display()))?;
    let live = &summary.live;
    let mut text = format!(
        "recorded {} messages ({:.1} MB), {} of robot time (clock: {}), to {} (ended: {:?})\n",
        live.messages,
        live.payload_bytes as f64 / 1e6,
        live.end,
        summary.clock,
        out.display(),
        live.ended,
    );
    text.push_str(&format!(
        "  command writers: {}\n",
        if summary.command_writers.is_empty() {
            "none".to_owned()
        } else {
            summary.command_writers.join(", ")
        }
    ));
    let m = &summary.motion;
    text.push_str(&format!(
        "  commands sent {}, withheld {}, lost in the queue {}, stops {}; graph outputs {} ({} dropped); robot_state TF to the graph: {}\n",
        m.sent, m.withheld, m.queue_full, m.stops, m.outputs, m.outputs_dropped, summary.robot_tf
    ));
    if let Some((gap, checks, holds)) = summary.watchdog {
        text.push_str(&format!(
            "  watchdog: {checks} checks, worst gap {:.1} ms, {holds} holds\n",
            gap.as_secs_f64() * 1e3
        ));
    }
    for s in &summary.subscriptions {
        text.push_str(&format!("  subscribed {s}\n"));
    }
    for (topic, c) in &live.inputs {
        text.push_str(&format!("  input {topic:<28} {}\n", c.text()));
    }
    for s in &live.stages {
        text.push_str(&format!(
            "  stage {:<22} inputs {:>7}  errors {}{}\n",
            s.name,
            s.inputs,
            s.errors,
            if s.disabled { " (stopped)" } else { "" }
        ));
    }
    super::print_stdout(text.trim_end())
}
