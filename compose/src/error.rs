//! Errors of the composition root.

use std::path::PathBuf;

/// Errors of loading a scenario, composing a pipeline and a world, recording and judging.
#[derive(Debug, thiserror::Error)]
pub enum ComposeError {
    /// A scenario file or record is malformed or missing.
    #[error(transparent)]
    Scenario(#[from] scenario::ScenarioError),
    /// A parameter is mistyped, out of range, or not consumed by any part.
    #[error(transparent)]
    Param(#[from] scenario::ParamError),
    /// A stage rejected its configuration.
    #[error(transparent)]
    Stage(Box<msgs::StageError>),
    /// The script stage rejected a command.
    #[error(transparent)]
    Script(Box<control::script::ScriptError>),
    /// The simulator could not be built.
    #[error(transparent)]
    Sim(Box<sim::SimError>),
    /// Recording failed.
    #[error(transparent)]
    Record(Box<recorder::RecordError>),
    /// A recording could not be read.
    #[error("{path}: {source}")]
    Read {
        /// The recording.
        path: PathBuf,
        /// Why.
        source: Box<replay::ReadError>,
    },
    /// A recording has no `scenario` metadata record: it was not made by `rodlog record`.
    #[error("{path} has no scenario metadata record (not made by rodlog record)")]
    NoScenario {
        /// The recording.
        path: PathBuf,
    },
    /// A recorded message could not be decoded.
    #[error("{path}: cannot decode {topic} at {log_time_ns} ns: {reason}")]
    Decode {
        /// The recording.
        path: PathBuf,
        /// Topic.
        topic: String,
        /// Log time.
        log_time_ns: u64,
        /// Codec message.
        reason: String,
    },
    /// The attached scenario file is not UTF-8.
    #[error("{path}: the attached scenario is not UTF-8")]
    AttachmentText {
        /// The recording.
        path: PathBuf,
    },
    /// A world's driver failed (the simulator node stepping its world).
    #[error(transparent)]
    Driver(Box<msgs::DriverError>),
    /// A remap file is missing, malformed, or in conflict with another.
    #[error(transparent)]
    Remap(Box<ros2::RemapError>),
    /// The ROS 2 transport failed.
    #[error("ROS 2 ({what}): {source}")]
    Ros2 {
        /// What was being done (a topic, joining the domain).
        what: String,
        /// Why.
        source: Box<ros2::Ros2Error>,
    },
    /// The pipeline could not be built into a runner.
    #[error(transparent)]
    Runner(Box<recorder::RunnerError>),
    /// A live run failed (the file was finished up to there).
    #[error("recording {path}: {source}")]
    Live {
        /// The output file.
        path: PathBuf,
        /// Why.
        source: Box<recorder::LiveError>,
    },
    /// An operation needs another world than the scenario's.
    #[error("this needs a scenario with world = {wanted:?}, not {world:?}")]
    WrongWorld {
        /// The world needed.
        wanted: &'static str,
        /// The scenario's world.
        world: String,
    },
    /// A recording cannot be judged: it is not a simulator run.
    #[error("{path}: not a simulator recording (world = {world}): nothing to judge against")]
    NotJudgeable {
        /// The recording.
        path: PathBuf,
        /// Its world.
        world: String,
    },
}

macro_rules! boxed_from {
    ($($variant:ident($t:ty)),*) => {
        $(impl From<$t> for ComposeError {
            fn from(e: $t) -> Self {
                Self::$variant(Box::new(e))
            }
        })*
    };
}

boxed_from!(
    Stage(msgs::StageError),
    Script(control::script::ScriptError),
    Sim(sim::SimError),
    Record(recorder::RecordError),
    Driver(msgs::DriverError),
    Remap(ros2::RemapError),
    Runner(recorder::RunnerError)
);
