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
    }
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
