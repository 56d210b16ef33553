//! Recording a scenario to an MCAP file: metadata, attachments, the scheduler (as fast as
//! possible, or paced by the wall clock through [`crate::live`]), and `finish()` on every
//! exit path.

use std::path::PathBuf;

use msgs::drivers::World;
use msgs::{RobotTime, Stage};

use crate::live::{LiveError, LiveOptions, run_lockstep};
use crate::mcap_writer::{McapSink, MetadataRecord, SinkOptions, WriteError};
use crate::runner::{Popped, Runner, RunnerError, StageStats};
use crate::scheduler::{FLUSH_PERIOD, Scheduler, SchedulerError, SchedulerStats, SinkFanout};
use crate::sink::{McapStreamSink, Sink, SinkError};

/// Errors of a recording session.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    /// The output could not be created.
    #[error(transparent)]
    Create(#[from] WriteError),
    /// Pipeline construction failed.
    #[error(transparent)]
    Runner(#[from] RunnerError),
    /// The run failed; the file was finished up to that point.
    #[error("recording {path} failed (file finished with what was recorded): {source}")]
    Run {
        /// Output file.
        path: PathBuf,
        /// Cause.
        source: Box<SchedulerError>,
    },
    /// The live runtime failed.
    #[error("recording {path}: {source}")]
    Live {
        /// Output file.
        path: PathBuf,
        /// Cause.
        source: Box<LiveError>,
    },
    /// Writing metadata, attachments or the summary failed.
    #[error(transparent)]
    Sink(#[from] SinkError),
    /// The worker thread pool could not be built.
    #[error("cannot build a pool of {threads} worker threads: {reason}")]
    Threads {
        /// Requested size.
        threads: usize,
        /// Why.
        reason: String,
    },
}

/// How to record.
#[derive(Debug, Clone)]
pub struct RecordOptions {
    /// Output file.
    pub out: PathBuf,
    /// MCAP writer options (lz4 by default).
    pub sink: SinkOptions,
    /// Pace by the wall clock (live runtime) instead of running as fast as possible.
    pub realtime: bool,
    /// Size of the rayon pool stages may use (None: rayon's default).
    pub threads: Option<usize>,
    /// End the run early when a message says it is over (as-fast-as-possible runs only).
    pub stop: Option<StopCondition>,
}

/// Ends a recording before its duration: once a message on `topic` satisfies `is_end`,
/// the run goes on for `grace` of robot time (the last outputs, the robot settling) and
/// stops at the next robot-second boundary. The end is a function of the message stream,
/// so the recording stays deterministic.
#[derive(Clone)]
pub struct StopCondition {
    /// Topic watched.
    pub topic: String,
    /// Whether a message on it ends the run.
    pub is_end: std::sync::Arc<dyn Fn(&msgs::Msg) -> bool + Send + Sync>,
    /// Robot time kept after it.
    pub grace: msgs::RobotDuration,
}

impl std::fmt::Debug for StopCondition {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("StopCondition")
            .field("topic", &self.topic)
            .field("grace", &self.grace)
            .finish_non_exhaustive()
    }
}

/// What a recording holds.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RecordSummary {
    /// Messages written.
    pub messages: u64,
    /// Robot time reached.
    pub end: RobotTime,
    /// Scheduler counters.
    pub scheduler: SchedulerStats,
    /// Per-stage counters.
    pub stages: Vec<StageStats>,
    /// True if the run was stopped early (Ctrl-C).
    pub interrupted: bool,
}

/// Metadata records, attachments and the stream of one recording.
#[derive(Debug, Clone, Default)]
pub struct RecordingHeader {
    /// Metadata records (`robot_info`, `scenario`, `build`, ...), written first.
    pub metadata: Vec<MetadataRecord>,
    /// Attachments `(name, media type, bytes)`, at log time 0.
    pub attachments: Vec<(String, String, Vec<u8>)>,
}

/// Records `duration` of robot time of `world` through `stages` into `options.out`.
///
/// The MCAP file is finished on every exit path: success, a world or stage failure (the
/// error is returned after finishing), and Ctrl-C in realtime mode.
///
/// # Errors
/// See [`RecordError`].
pub fn record<W: World + Send + 'static>(
    world: W,
    stages: Vec<Box<dyn Stage + Send>>,
    header: &RecordingHeader,
    duration: msgs::RobotDuration,
    options: &RecordOptions,
) -> Result<RecordSummary, RecordError> {
    record_with_sinks(world, stages, header, duration, options, Vec::new())
}

/// [`record`] with more sinks beside the MCAP writer (e.g. the Rerun sink of
/// `rodlog record --viz`): each gets the header and the whole stream, in the same order.
///
/// # Errors
/// See [`RecordError`].
pub fn record_with_sinks<W: World + Send + 'static>(
    world: W,
    stages: Vec<Box<dyn Stage + Send>>,
    header: &RecordingHeader,
    duration: msgs::RobotDuration,
    options: &RecordOptions,
    extra_sinks: Vec<Box<dyn Sink>>,
) -> Result<RecordSummary, RecordError> {
    let runner = Runner::new(stages)?;
    let scheduler = Scheduler::new(world, runner);
    let mcap = McapSink::create(&options.out, &options.sink)?;
    let sink: Box<dyn Sink> = Box::new(McapStreamSink::new(mcap));
    let mut fanout = SinkFanout::new(std::iter::once(sink).chain(extra_sinks).collect());
    if let Err(e) = write_header(&mut fanout, header) {
        let _finished = fanout.finish();
        return Err(e.into());
    }
    let end = RobotTime::ZERO + duration;
    let pool = match options.threads {
        Some(threads) => Some(
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads.max(1))
                .build()
                .map_err(|e| RecordError::Threads {
                    threads,
                    reason: e.to_string(),
                })?,
        ),
        None => None,
    };
    let path = options.out.clone();
    if options.realtime {
        let live = LiveOptions::default();
        let result = match &pool {
            Some(p) => p.install(|| run_lockstep(scheduler, fanout, end, &live)),
            None => run_lockstep(scheduler, fanout, end, &live),
        };
        return result.map_err(|source| RecordError::Live {
            path,
            source: Box::new(source),
        });
    }
    let mut scheduler = scheduler;
    let stop = crate::live::ctrl_c_flag();
    let stop_condition = options.stop.clone();
    let run = |scheduler: &mut Scheduler<W>, fanout: &mut SinkFanout| {
        // One robot second at a time, so Ctrl-C stops at a second boundary.
        let mut t = RobotTime::ZERO;
        let mut end_at: Option<RobotTime> = None;
        loop {
            t = (t + FLUSH_PERIOD).min(end);
            scheduler.advance(t, &mut |p: Popped| {
                if end_at.is_none()
                    && let Some(c) = &stop_condition
                    && p.envelope.topic() == c.topic
                    && p.envelope.msg.as_ref().is_some_and(|m| (c.is_end)(m))
                {
                    end_at = Some(p.envelope.log_time + c.grace);
                }
                fanout.write_envelope(&p.envelope)?;
                Ok(())
            })?;
            if t >= end || end_at.is_some_and(|e| t >= e) {
                return Ok(false);
            }
            if stop
                .as_ref()
                .is_some_and(|s| s.load(std::sync::atomic::Ordering::SeqCst))
            {
                return Ok(true);
            }
        }
    };
    let result = match &pool {
        Some(p) => p.install(|| run(&mut scheduler, &mut fanout)),
        None => run(&mut scheduler, &mut fanout),
    };
    let messages = fanout.written();
    let finished = fanout.finish();
    let interrupted = result.map_err(|source| RecordError::Run {
        path: path.clone(),
        source: Box::new(source),
    })?;
    finished?;
    Ok(RecordSummary {
        messages,
        end: scheduler.world_time().unwrap_or(RobotTime::ZERO),
        scheduler: scheduler.stats(),
        stages: scheduler.runner().stats(),
        interrupted,
    })
}

/// Writes the metadata records and attachments of `header`.
///
/// # Errors
/// The first sink error.
pub fn write_header(fanout: &mut SinkFanout, header: &RecordingHeader) -> Result<(), SinkError> {
    for m in &header.metadata {
        fanout.write_metadata(m)?;
    }
    for (name, media, data) in &header.attachments {
        fanout.attach(name, media, 0, data)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stages::ArmExerciser;
    use crate::test_world::{TestWorld, TestWorldConfig};
    use msgs::drivers::{DriverError, DriverOutput};
    use msgs::{Msg, RobotDuration};
    use scenario::{Params, Reader};

    /// The test world, failing once stepped past `fail_at`.
    struct Failing {
        inner: TestWorld,
        fail_at: RobotTime,
    }
    impl World for Failing {
        fn step_until(&mut self, t: RobotTime) -> Result<Vec<DriverOutput>, DriverError> {
            if t > self.fail_at {
                return Err(DriverError::Fault {
                    device: "arm_driver".into(),
                    now: t,
                    reason: "encoder cable".into(),
                });
            }
            self.inner.step_until(t)
        }
        fn command(&mut self, t: RobotTime, topic: &str, msg: &Msg) -> Result<(), DriverError> {
            self.inner.command(t, topic, msg)
        }
    }

    const MAGIC: &[u8; 8] = b"\x89MCAP0\r\n";

    #[test]
    fn a_failing_world_still_finishes_the_file() -> Result<(), Box<dyn std::error::Error>> {
        let dir = tempfile::tempdir()?;
        let out = dir.path().join("fail.mcap");
        let p = Params::new();
        let world = Failing {
            inner: TestWorld::new(TestWorldConfig::from_params(1, &mut Reader::new(&p))?),
            fail_at: RobotTime::from_millis(1500),
        };
        let options = RecordOptions {
            stop: None,
            out: out.clone(),
            sink: SinkOptions::default(),
            realtime: false,
            threads: Some(1),
        };
        let header = RecordingHeader::default();
        let r = record(
            world,
            vec![Box::new(ArmExerciser::from_params(&mut Reader::new(&p))?)],
            &header,
            RobotDuration::from_secs(5),
            &options,
        );
        let err = r.err().ok_or("the failure was not reported")?;
        assert!(err.to_string().contains("encoder cable"), "{err}");
        let bytes = std::fs::read(&out)?;
        assert!(bytes.len() > 1000);
        assert!(bytes.ends_with(MAGIC), "the file was not finished");
        Ok(())
    }
}
