//! The live runtime (tokio): wall-clock pacing, driver tasks, bounded channels, a sink
//! thread, Ctrl-C.
//!
//! The one place of the recorder that reads the wall clock: it converts it to robot time
//! once, at the edge, and stages only ever see the robot time it hands them.
#![allow(clippy::disallowed_methods)]
//!
//! Two shapes share the sink side (a dedicated thread owning the [`SinkFanout`], fed by a
//! bounded channel; `finish()` runs on every exit path, including errors and Ctrl-C):
//!
//! * [`run_lockstep`]: a simulated world in realtime (`record --realtime`). The runner task
//!   advances the [`Scheduler`] to the robot time that corresponds to the elapsed wall time,
//!   every [`LiveOptions::tick`]. The scheduler's stream does not depend on how the run is
//!   split, so the file is byte-identical to the as-fast-as-possible run.
//! * [`run_live`] (and [`run_hardware`], its polled-drivers-only form): inputs that cannot be
//!   back-pressured. Each [`LiveDriver`] runs as a task polled at its period; each
//!   [`LiveSource`] (a DDS reader, say) blocks on its own thread and pushes what arrives. Both
//!   stamp arrivals with the [`LiveClock`] (wall time since the start, or the graph's
//!   `/clock`) and `try_send` into one bounded channel; when it is full the message is
//!   dropped and counted for its topic ([`InputCounts`]). The runner task merges arrivals
//!   behind a watermark ([`LiveOptions::merge_delay`]), feeds `/clock` every 100 ms of robot
//!   time (producer `runtime`), logs new problems of each topic on `/rosout` once per second,
//!   hands every popped message to an optional [`LiveOutput`] (the command path to the
//!   graph) and writes the counters as the [`INPUTS_RECORD`] metadata record at the end.
//!
//! # Live is replay
//!
//! The runner's feeding rule (every input with log time `<= t` is pushed before anything at
//! `t` is popped) is what replay relies on. A live input can arrive after the runtime already
//! popped past its robot time (a stalled thread, a slow stage); it is then recorded *late*:
//! stamped 1 ns after the last message popped, so that its place in the file is the place it
//! had in the run, and counted. The recording is the truth; replay follows it.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use msgs::drivers::{DriverError, World};
use msgs::{RobotDuration, RobotTime};

use crate::mcap_writer::MetadataRecord;
use crate::runner::{Envelope, Popped, RunnerError};
use crate::scheduler::{Scheduler, SchedulerError, SinkFanout};
use crate::session::RecordSummary;
use crate::sink::{Channel, SinkError};

pub mod clock;
pub mod feed;
mod hardware;

pub use clock::LiveClock;
pub use feed::{Feed, INPUTS_RECORD, InputCounts, LiveSource, Pushed, TopicCount};
pub use hardware::{
    HardwareSummary, LiveDriver, LiveEnd, LiveOutput, LiveRun, LiveSummary, run_hardware, run_live,
};

/// Producer of `/clock` in the live hardware runtime.
pub const RUNTIME: &str = "runtime";

/// Errors of the live runtime.
#[derive(Debug, thiserror::Error)]
pub enum LiveError {
    /// The tokio runtime could not start.
    #[error("cannot start the tokio runtime: {0}")]
    Runtime(std::io::Error),
    /// The scheduler failed (file finished up to there).
    #[error(transparent)]
    Scheduler(#[from] SchedulerError),
    /// The runner failed (file finished up to there).
    #[error(transparent)]
    Runner(#[from] RunnerError),
    /// A sink failed.
    #[error(transparent)]
    Sink(#[from] SinkError),
    /// The sink thread ended unexpectedly (after writing `written` messages).
    #[error("the sink thread stopped unexpectedly after {written} messages")]
    SinkThread {
        /// Messages written by then.
        written: u64,
    },
    /// A driver or source failed.
    #[error("driver {driver} failed: {source}")]
    Driver {
        /// Driver name.
        driver: String,
        /// Cause.
        source: DriverError,
    },
}

/// Options of the live runtime.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LiveOptions {
    /// Wall-clock period of the runner task. Default 10 ms.
    pub tick: Duration,
    /// Capacity of the sink channel (messages). Default 64.
    pub channel_capacity: usize,
    /// Capacity of the input channel of drivers and sources (messages): what the runner may
    /// fall behind by before inputs are dropped. Default 64.
    pub input_capacity: usize,
    /// Hardware mode: how long the runner waits for late arrivals before popping. Default
    /// 20 ms.
    pub merge_delay: RobotDuration,
    /// Robot seconds per wall second (1 = realtime). Default 1.
    pub speed: u32,
}

impl Default for LiveOptions {
    fn default() -> Self {
        Self {
            tick: Duration::from_millis(10),
            channel_capacity: 64,
            input_capacity: 64,
            merge_delay: RobotDuration::from_millis(20),
            speed: 1,
        }
    }
}

/// One message (or metadata record) on its way to the sink thread.
#[derive(Debug)]
pub(crate) enum SinkItem {
    Message {
        channel: Arc<Channel>,
        log_time: RobotTime,
        publish_time: RobotTime,
        cdr: Vec<u8>,
    },
    Metadata(MetadataRecord),
}

/// The sink thread: owns the fanout, writes what arrives, finishes on every exit path.
pub(crate) struct SinkThread {
    pub(crate) tx: tokio::sync::mpsc::Sender<SinkItem>,
    handle: std::thread::JoinHandle<(u64, Result<(), SinkError>)>,
}

impl SinkThread {
    pub(crate) fn spawn(mut fanout: SinkFanout, capacity: usize) -> Self {
        let (tx, mut rx) = tokio::sync::mpsc::channel::<SinkItem>(capacity.max(1));
        let handle = std::thread::spawn(move || {
            let mut result = Ok(());
            while let Some(item) = rx.blocking_recv() {
                let written = match item {
                    SinkItem::Message {
                        channel,
                        log_time,
                        publish_time,
                        cdr,
                    } => fanout.write(&channel, log_time, publish_time, &cdr),
                    SinkItem::Metadata(record) => fanout.write_metadata(&record),
                };
                if let Err(e) = written {
                    result = Err(e);
                    break;
                }
            }
            let written = fanout.written();
            let finished = fanout.finish();
            (written, result.and(finished))
        });
        Self { tx, handle }
    }

    /// Closes the channel and waits for the thread (which finishes the file).
    pub(crate) fn close(self) -> Result<u64, LiveError> {
        drop(self.tx);
        match self.handle.join() {
            Ok((written, Ok(()))) => Ok(written),
            Ok((_, Err(e))) => Err(LiveError::Sink(e)),
            Err(_) => Err(LiveError::SinkThread { written: 0 }),
        }
    }
}

pub(crate) fn item(env: Envelope) -> SinkItem {
    SinkItem::Message {
        channel: env.channel,
        log_time: env.log_time,
        publish_time: env.publish_time,
        cdr: env.cdr,
    }
}

/// A flag set when Ctrl-C arrives, for loops that do not run on tokio (the as-fast-as-possible
/// recording): one background thread per process, with a small runtime, waits for the signal;
/// every caller shares its flag (an experiment records hundreds of runs in one process, and a
/// listener per recording would leave a parked thread behind each). Once set it stays set:
/// Ctrl-C stops this recording and every later one in the process. `None` if that runtime
/// cannot start (Ctrl-C then ends the process; the file stays recoverable).
pub fn ctrl_c_flag() -> Option<Arc<AtomicBool>> {
    static FLAG: std::sync::OnceLock<Option<Arc<AtomicBool>>> = std::sync::OnceLock::new();
    FLAG.get_or_init(spawn_ctrl_c_listener).clone()
}

fn spawn_ctrl_c_listener() -> Option<Arc<AtomicBool>> {
    let flag = Arc::new(AtomicBool::new(false));
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .ok()?;
    let set = Arc::clone(&flag);
    std::thread::Builder::new()
        .name("ctrl-c".into())
        .spawn(move || {
            runtime.block_on(async {
                if tokio::signal::ctrl_c().await.is_ok() {
                    set.store(true, Ordering::SeqCst);
                }
            });
        })
        .ok()?;
    Some(flag)
}

pub(crate) fn build_runtime() -> Result<tokio::runtime::Runtime, LiveError> {
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .map_err(LiveError::Runtime)
}

/// Runs a simulated world in realtime until `end` (or Ctrl-C), writing to `fanout`. See the
/// module docs.
///
/// # Errors
/// [`LiveError`]; the file is finished in every case.
pub fn run_lockstep<W: World + Send + 'static>(
    mut scheduler: Scheduler<W>,
    fanout: SinkFanout,
    end: RobotTime,
    options: &LiveOptions,
) -> Result<RecordSummary, LiveError> {
    let runtime = build_runtime()?;
    let sink = SinkThread::spawn(fanout, options.channel_capacity);
    let tx = sink.tx.clone();
    let outcome = runtime.block_on(drive_lockstep(&mut scheduler, &tx, end, options));
    drop(tx);
    let written = sink.close();
    let (interrupted, at) = outcome?;
    Ok(RecordSummary {
        messages: written?,
        end: at,
        scheduler: scheduler.stats(),
        stages: scheduler.runner().stats(),
        interrupted,
    })
}

/// The runner task of [`run_lockstep`]: `(interrupted, robot time reached)`.
async fn drive_lockstep<W: World>(
    scheduler: &mut Scheduler<W>,
    tx: &tokio::sync::mpsc::Sender<SinkItem>,
    end: RobotTime,
    opts: &LiveOptions,
) -> Result<(bool, RobotTime), LiveError> {
    let clock = LiveClock::wall(opts.speed);
    let mut interval = tokio::time::interval(opts.tick);
    interval.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let ctrl_c = tokio::signal::ctrl_c();
    tokio::pin!(ctrl_c);
    let mut reached = RobotTime::ZERO;
    loop {
        tokio::select! {
            _ = interval.tick() => {}
            _ = &mut ctrl_c => return Ok((true, reached)),
        }
        let target = clock.now().min(end);
        let mut batch: Vec<SinkItem> = Vec::new();
        scheduler.advance(target, &mut |p: Popped| {
            batch.push(item(p.envelope));
            Ok(())
        })?;
        for it in batch {
            if tx.send(it).await.is_err() {
                return Err(LiveError::SinkThread { written: 0 });
            }
        }
        reached = target;
        if target >= end {
            return Ok((false, reached));
        }
    }
}
