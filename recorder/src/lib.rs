//! MCAP writer, the deterministic stage runner and the live runtime.
//!
//! So far: [`McapSink`], the MCAP writer of rodlog's log (DESIGN.md section 3).

pub mod live;
pub mod mcap_writer;
pub mod runner;
pub mod scenario;
pub mod scheduler;
pub mod session;
pub mod sink;
pub mod stages;
pub mod test_world;

pub use live::{LiveDriver, LiveError, LiveOptions, run_hardware, run_lockstep};
pub use mcap_writer::{
    ChunkCompression, McapSink, MetadataRecord, RawRecord, SinkOptions, WriteError, WriteSummary,
    library_string,
};
pub use runner::{Envelope, Popped, Runner, RunnerError, Source};
pub use scenario::{Params, Scenario, ScenarioError};
pub use scheduler::{Scheduler, SchedulerError, SinkFanout, is_command_topic};
pub use session::{
    RecordError, RecordOptions, RecordSummary, RecordingHeader, StopCondition, record,
    record_with_sinks,
};
pub use sink::{Channel, McapStreamSink, MemorySink, Sink, SinkError, SinkMessage};
