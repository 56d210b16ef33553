//! `rodlog check motion REC [--json]`: the motion checker over a recording
//! ([`control::motion::checker`]): every `/arm/joint_trajectory` command and every executed
//! `/joint_states` sample within the joint limits, speeds and accelerations, and no commanded
//! or executed configuration colliding with the platform, itself or the wire.
//!
//! A separate command rather than part of `replay --check`: replay proves determinism (the
//! stages reproduce their outputs byte for byte) and works on any recording, while this
//! proves a physical property of the run, needs no pipeline, and also judges commands from
//! foreign files and drivers. Exit code non-zero when a violation is found.

use std::path::PathBuf;

use anyhow::{Context as _, bail};
use control::motion::checker::{CheckerParams, MotionChecker};
use msgs::topics::{ARM_JOINT_TRAJECTORY, JOINT_STATES, SIM_WIRE_POSE, TF, TF_STATIC};
use replay::{McapReader, ReadFilter};

/// `rodlog check ...`.
#[derive(Debug, clap::Subcommand)]
pub enum CheckCommand {
    /// Joint limits, speeds, accelerations and collisions of every commanded and executed arm motion.
    Motion(MotionArgs),
    /// Judge a simulated task run against the simulator's truth: unsafe commands, final hook
    /// error, outcome (independent of the robot's own checks).
    Task(TaskArgs),
}

/// Arguments of `rodlog check task`.
#[derive(Debug, clap::Args)]
pub struct TaskArgs {
    /// The recording (a simulator run).
    pub recording: PathBuf,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
}

/// Arguments of `rodlog check motion`.
#[derive(Debug, clap::Args)]
pub struct MotionArgs {
    /// The recording.
    pub recording: PathBuf,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
}

/// Runs a check command.
///
/// # Errors
/// Unreadable recordings, and a failed check.
pub fn run(command: &CheckCommand) -> anyhow::Result<()> {
    match command {
        CheckCommand::Motion(args) => motion(args),
        CheckCommand::Task(args) => task(args),
    }
}

fn task(args: &TaskArgs) -> anyhow::Result<()> {
    let v = compose::judge::judge(&args.recording)?;
    if args.json {
        super::print_stdout(&serde_json::to_string(&v)?)?;
    } else {
        let mut text = format!(
            "{}: {} {}{} after {}; rod {}{}\n",
            args.recording.display(),
            v.task.as_deref().unwrap_or("no task"),
            v.outcome,
            if v.reason_code.is_empty() {
                String::new()
            } else {
                format!(" [{}]", v.reason_code)
            },
            v.operation_s
                .map_or_else(|| "-".to_owned(), |s| format!("{s:.1} s")),
            v.rod_state,
            if v.success { " (success)" } else { "" },
        );
        if let Some(h) = v.hook {
            text.push_str(&format!(
                "  hook: across {:+.2} mm, along the approach {:+.2} mm, yaw {:+.2} deg: {:.0} % of the capture window\n",
                h.across_mm, h.along_mm, h.yaw_deg, 100.0 * h.window_fraction
            ));
        }
        for h in &v.hand_eye {
            text.push_str(&format!(
                "  hand-eye at {:.1} s: {:.3} deg / {:.2} mm from the true mount\n",
                h.t_s, h.rot_error_deg, h.trans_error_mm
            ));
        }
        text.push_str(&format!(
            "  {} commands judged against the true geometry and wind: {} unsafe; max true wind at a command {:.2} m/s; min clearance {:.1} mm",
            v.commands,
            v.unsafe_commands.len(),
            v.max_wind_at_command_mps,
            v.min_clearance_m * 1e3
        ));
        for u in &v.unsafe_commands {
            text.push_str(&format!(
                "\n  UNSAFE {:.3} s {}: {}",
                u.t_s, u.topic, u.reason
            ));
        }
        super::print_stdout(&text)?;
    }
    if !v.unsafe_commands.is_empty() {
        bail!("{} unsafe commands", v.unsafe_commands.len());
    }
    Ok(())
}

fn motion(args: &MotionArgs) -> anyhow::Result<()> {
    let mut reader = McapReader::open(&args.recording)
        .with_context(|| format!("cannot read {}", args.recording.display()))?;
    let filter = ReadFilter::all().with_topics([
        TF,
        TF_STATIC,
        JOINT_STATES,
        ARM_JOINT_TRAJECTORY,
        SIM_WIRE_POSE,
    ]);
    let mut checker = MotionChecker::new(CheckerParams::default());
    for m in reader.messages(&filter) {
        let m = m?;
        let msg = m.decode()?;
        checker.feed(m.log_time_ns, m.topic(), &msg);
    }
    let r = checker.finish();
    if args.json {
        let v = serde_json::json!({
            "passed": r.passed(),
            "trajectories": r.trajectories,
            "untimed_segments": r.untimed_segments,
            "joint_states": r.joint_states,
            "collision_checks": r.collision_checks,
            "peak_commanded_ratio": r.peak_commanded_ratio,
            "peak_executed_speed_ratio": r.peak_executed_speed_ratio,
            "peak_executed_acceleration_ratio": r.peak_executed_acceleration_ratio,
            "min_clearance_m": if r.min_clearance_m.is_finite() { Some(r.min_clearance_m) } else { None },
            "min_clearance_pair": r.min_clearance_pair,
            "wire_checked": r.wire_checked,
            "violations": r.violations.iter().map(|v| serde_json::json!({
                "log_time_ns": v.log_time_ns, "topic": v.topic, "what": v.what,
            })).collect::<Vec<_>>(),
        });
        super::print_stdout(&v.to_string())?;
    } else {
        let mut text = format!(
            "motion check of {}: {} trajectories ({} untimed segments), {} joint states, {} collision checks{}\n\
             peak commanded time ratio {:.3}, executed speed {:.3} and acceleration {:.3} of the limits\n\
             smallest clearance {:.4} m ({})",
            args.recording.display(),
            r.trajectories,
            r.untimed_segments,
            r.joint_states,
            r.collision_checks,
            if r.wire_checked {
                ", wire included"
            } else {
                ", no /sim/wire_pose: wire not checked"
            },
            r.peak_commanded_ratio,
            r.peak_executed_speed_ratio,
            r.peak_executed_acceleration_ratio,
            r.min_clearance_m,
            r.min_clearance_pair,
        );
        for v in r.violations.iter().take(20) {
            text.push_str(&format!(
                "\n  {:.3} s {}: {}",
                v.log_time_ns as f64 * 1e-9,
                v.topic,
                v.what
            ));
        }
        if r.violations.len() > 20 {
            text.push_str(&format!("\n  ... {} more", r.violations.len() - 20));
        }
        super::print_stdout(&text)?;
    }
    if !r.passed() {
        bail!("motion check failed: {} violations", r.violations.len());
    }
    if r.trajectories == 0 && r.joint_states == 0 {
        bail!("nothing to check: no /arm/joint_trajectory and no arm /joint_states");
    }
    Ok(())
}
