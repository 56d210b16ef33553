//! Recording: the MCAP writer, the deterministic stage runner, the simulation scheduler, the
//! live runtime, and the test world with its two small stages.
//!
//! - [`mcap_writer`]: [`McapSink`], the MCAP writer (ROS 2 profile, one channel per topic and
//!   producer, chunked, indexed, finished on every exit path).
//! - [`sink`]: the [`Sink`] trait the stream goes to (MCAP, memory, the Rerun sink elsewhere).
//! - [`runner`]: [`Runner`], the deterministic merge of inputs and stage outputs that record
//!   and replay share.
//! - [`scheduler`]: [`Scheduler`], a world stepped in lockstep with the runner.
//! - [`live`]: wall-clock pacing and hardware drivers (tokio).
//! - [`session`]: [`record`], one recording from a world, stages and a header.
//! - [`test_world`], [`stages`]: a small deterministic world and two stages that exercise the
//!   runner (`arm_sweep`).

pub mod live;
pub mod mcap_writer;
pub mod runner;
pub mod scheduler;
pub mod session;
pub mod sink;
pub mod stages;
pub mod test_world;

pub use live::{
    Feed, LiveClock, LiveDriver, LiveEnd, LiveError, LiveOptions, LiveOutput, LiveRun, LiveSource,
    LiveSummary, Pushed, run_hardware, run_live, run_lockstep,
};
pub use mcap_writer::{
    ChunkCompression, McapSink, MetadataRecord, RawRecord, SinkOptions, WriteError, WriteSummary,
    library_string,
};
pub use runner::{Envelope, Popped, Runner, RunnerError, Source};
pub use scheduler::{Scheduler, SchedulerError, SinkFanout, is_command_topic};
pub use session::{
    RecordError, RecordOptions, RecordSummary, RecordingHeader, StopCondition, record,
    record_with_sinks,
};
pub use sink::{Channel, McapStreamSink, MemorySink, Sink, SinkError, SinkMessage};
