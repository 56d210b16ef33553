//! `rodlog log REC [--level L] [--grep TEXT] [--json]`: the recording's text log, in log-time
//! order: every `/rosout` line (stages, drivers, the scheduler) with its robot time, level
//! and producer. Task state changes and refusals are mirrored there by the task stages, so this
//! is the first thing to read when a run went wrong ("what did the robot say, and when?").

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::Context as _;
use msgs::rcl_interfaces::Log;
use msgs::topics::ROSOUT;
use replay::{McapReader, ReadFilter};

/// Arguments of `rodlog log`.
#[derive(Debug, clap::Args)]
pub struct LogArgs {
    /// The recording.
    pub recording: PathBuf,
    /// Lowest level shown: debug, info, warn, error or fatal.
    #[arg(long, default_value = "info")]
    pub level: String,
    /// Only lines containing this text.
    #[arg(long)]
    pub grep: Option<String>,
    /// One JSON object per line.
    #[arg(long)]
    pub json: bool,
}

fn level_of(name: &str) -> anyhow::Result<u8> {
    Ok(match name {
        "debug" => Log::DEBUG,
        "info" => Log::INFO,
        "warn" => Log::WARN,
        "error" => Log::ERROR,
        "fatal" => Log::FATAL,
        other => anyhow::bail!("--level {other:?}: debug, info, warn, error or fatal"),
    })
}

fn level_name(level: u8) -> &'static str {
    match level {
        Log::DEBUG => "DEBUG",
        Log::INFO => "INFO",
        Log::WARN => "WARN",
        Log::ERROR => "ERROR",
        Log::FATAL => "FATAL",
        _ => "?",
    }
}

/// Runs `rodlog log`.
///
/// # Errors
/// Unreadable recordings and undecodable `/rosout` messages.
pub fn run(args: &LogArgs) -> anyhow::Result<()> {
    let min = level_of(&args.level)?;
    let mut reader = McapReader::open(&args.recording)
        .with_context(|| format!("cannot read {}", args.recording.display()))?;
    let start = reader.time_range_ns().map_or(0, |(s, _)| s);
    let mut out = String::new();
    for m in reader.messages(&ReadFilter::all().with_topics([ROSOUT])) {
        let m = m?;
        let Some(log) = m.decode()?.get::<Log>().cloned() else {
            continue;
        };
        if log.level < min
            || args
                .grep
                .as_ref()
                .is_some_and(|g| !log.msg.contains(g.as_str()))
        {
            continue;
        }
        let t_s = (m.log_time_ns.saturating_sub(start)) as f64 * 1e-9;
        if args.json {
            let v = serde_json::json!({
                "t_s": t_s,
                "log_time_ns": m.log_time_ns,
                "level": level_name(log.level),
                "name": log.name,
                "producer": m.channel.producer(),
                "msg": log.msg,
            });
            writeln!(out, "{v}")?;
        } else {
            writeln!(
                out,
                "{t_s:9.3} {:<5} {:<12} {}",
                level_name(log.level),
                log.name,
                log.msg
            )?;
        }
    }
    super::print_stdout(out.trim_end())
}
