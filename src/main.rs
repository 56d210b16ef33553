//! `rodlog`: the command line of the substation grounding-rod robot (ARCHITECTURE.md section 4).
//!
//! `main` only parses and dispatches; each subcommand lives in its own module under `cmd/`.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod cmd;
mod experiment;
mod import;

/// Substation grounding-rod robot: log-centric hand-eye self-calibration and tasks.
#[derive(Debug, Parser)]
#[command(name = "rodlog", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// The simulator does the whole job once: self-calibrate, hang, remove (DIR/demo.mcap, DIR/demo.rrd, summary).
    Demo(cmd::demo::DemoArgs),
    /// Summarise a recording: channels, time span, chunks, compression, metadata, recovery.
    Info(cmd::info::InfoArgs),
    /// Run a scenario through the pipeline and record it (MCAP).
    Record(cmd::record::RecordArgs),
    /// The simulator as a ROS 2 node in real time (`--ros2`): sensors, /clock, /sim truth; commands from any node.
    Sim(cmd::sim::SimArgs),
    /// Replay a recording through the current pipeline: check, what-if.
    Replay(cmd::replay::ReplayArgs),
    /// Calibration tools: hand-eye from pose files, image matching.
    #[command(subcommand)]
    Calib(cmd::calib::CalibCommand),
    /// Import a dataset on disk as a recording.
    #[command(subcommand)]
    Import(cmd::import::ImportCommand),
    /// Run an experiment of ARCHITECTURE.md section 7: report.md, results.json, plots.
    Experiment(cmd::experiment::ExperimentArgs),
    /// Show a recording in Rerun: write an .rrd, spawn a viewer or stream to one.
    View(cmd::view::ViewArgs),
    /// Check a recording: `motion` (limits, speeds, accelerations, collisions).
    #[command(subcommand)]
    Check(cmd::check::CheckCommand),
    /// List every parameter a scenario's pipeline and world read: key, default, unit, value.
    Params(cmd::params::ParamsArgs),
    /// The simulated crew's survey of a scenario's bay: a site file for `record --site`.
    Survey(cmd::survey::SurveyArgs),
    /// Print a recording's text log (`/rosout`: stages, drivers, task events) in time order.
    Log(cmd::log::LogArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Demo(args) => cmd::demo::run(&args),
        Command::Info(args) => cmd::info::run(&args),
        Command::Record(args) => cmd::record::run(&args),
        Command::Replay(args) => cmd::replay::run(&args),
        Command::Sim(args) => cmd::sim::run(&args),
        Command::Calib(command) => cmd::calib::run(&command),
        Command::Import(command) => cmd::import::run(&command),
        Command::Experiment(args) => cmd::experiment::run(&args),
        Command::View(args) => cmd::view::run(&args),
        Command::Check(command) => cmd::check::run(&command),
        Command::Log(args) => cmd::log::run(&args),
        Command::Params(args) => cmd::params::run(&args),
        Command::Survey(args) => cmd::survey::run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("rodlog: error: {}", error_chain(&e));
            ExitCode::FAILURE
        }
    }
}

/// The error and its causes joined by ": ", skipping a cause whose text the message already
/// holds (library errors often print their source in their own message).
fn error_chain(e: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in e.chain() {
        let s = cause.to_string();
        if text.contains(&s) {
            continue;
        }
        if !text.is_empty() {
            text.push_str(": ");
        }
        text.push_str(&s);
    }
    text
}
