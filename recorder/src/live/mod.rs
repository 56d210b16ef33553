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
//! * [`run_hardware`]: live drivers that cannot be back-pressured. Each [`LiveDriver`] runs as
//!   its own task, polled at its period with the robot clock (= wall time since start), and
//!   `try_send`s into one bounded channel; when it is full the sample is dropped and counted
//!   per driver, and the runner logs new drops on `/rosout` (producer = the driver) once per
//!   second. The runner task merges arrivals behind a watermark ([`LiveOptions::merge_delay`])
//!   and feeds `/clock` every 100 ms (producer `runtime`).

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use msgs::drivers::{DriverError, DriverOutput, World};
use msgs::rcl_interfaces::Log;
use msgs::rosgraph_msgs::Clock;
use msgs::{Msg, RobotDuration, RobotTime};

use crate::runner::{Envelope, Popped, Runner, RunnerError, rosout};
use crate::scheduler::{CLOCK_PERIOD, ChannelCache, Scheduler, SchedulerError, SinkFanout};
use crate::session::RecordSummary;
use crate::sink::{Channel, SinkError};

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
    /// A driver failed.
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
    /// Capacity of the driver and sink channels (messages). Default 64.
    pub channel_capacity: usize,
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
            merge_delay: RobotDuration::from_millis(20),
            speed: 1,
        }
    }
}

/// One message (or metadata record) on its way to the sink thread.
#[derive(Debug)]
enum SinkItem {
    Message {
        channel: Arc<Channel>,
        log_time: RobotTime,
        publish_time: RobotTime,
        cdr: Vec<u8>,
    },
}

/// The sink thread: owns the fanout, writes what arrives, finishes on every exit path.
struct SinkThread {
    tx: tokio::sync::mpsc::Sender<SinkItem>,
    handle: std::thread::JoinHandle<(u64, Result<(), SinkError>)>,
}

impl SinkThread {
    fn spawn(mut fanout: SinkFanout, capacity: usize) -> Self {
        let (tx, mut rx) = tokio::sync::mpsc::channel::<SinkItem>(capacity.max(1));
        let handle = std::thread::spawn(move || {
            let mut result = Ok(());
            while let Some(item) = rx.blocking_recv() {
                let SinkItem::Message {
                    channel,
                    log_time,
                    publish_time,
                    cdr,
                } = item;
                if let Err(e) = fanout.write(&channel, log_time, publish_time, &cdr) {
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
    fn close(self) -> Result<u64, LiveError> {
        drop(self.tx);
        match self.handle.join() {
            Ok((written, Ok(()))) => Ok(written),
            Ok((_, Err(e))) => Err(LiveError::Sink(e)),
            Err(_) => Err(LiveError::SinkThread { written: 0 }),
        }
    }
}

fn item(env: Envelope) -> SinkItem {
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

fn build_runtime() -> Result<tokio::runtime::Runtime, LiveError> {
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .map_err(LiveError::Runtime)
}

fn robot_now(start: Instant, speed: u32) -> RobotTime {
    let elapsed = RobotDuration::from(start.elapsed());
    RobotTime::ZERO
        + RobotDuration::from_nanos(elapsed.as_nanos().saturating_mul(u64::from(speed.max(1))))
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
    let start = Instant::now();
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
        let target = robot_now(start, opts.speed).min(end);
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

/// A live device polled by its own task (hardware-style: it cannot be back-pressured).
pub trait LiveDriver: Send + 'static {
    /// Producer name (channel metadata), e.g. `camera_driver`.
    fn name(&self) -> &str;

    /// Wall-clock polling period.
    fn period(&self) -> Duration;

    /// Messages available at robot time `now` (their `log_time` is set by the runtime to
    /// `now`).
    ///
    /// # Errors
    /// Device faults; the runtime stops and finishes the file.
    fn poll(&mut self, now: RobotTime) -> Result<Vec<DriverOutput>, DriverError>;
}

/// Counters of a hardware run.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct HardwareSummary {
    /// Messages written.
    pub messages: u64,
    /// Bytes of CDR payload written.
    pub payload_bytes: u64,
    /// Samples dropped, per driver (name, count), in driver order.
    pub drops: Vec<(String, u64)>,
    /// Robot time reached.
    pub end: RobotTime,
    /// True if stopped by Ctrl-C.
    pub interrupted: bool,
}

struct Arrival {
    output: DriverOutput,
}

/// Runs live drivers through `runner` into `fanout` for `duration` of robot time (or until
/// Ctrl-C or a driver fault). See the module docs.
///
/// # Errors
/// [`LiveError`]; the file is finished in every case.
pub fn run_hardware(
    drivers: Vec<Box<dyn LiveDriver>>,
    mut runner: Runner,
    fanout: SinkFanout,
    duration: RobotDuration,
    options: &LiveOptions,
) -> Result<HardwareSummary, LiveError> {
    let runtime = build_runtime()?;
    let sink = SinkThread::spawn(fanout, options.channel_capacity);
    let tx = sink.tx.clone();
    let names: Vec<String> = drivers.iter().map(|d| d.name().to_owned()).collect();
    let drops: Vec<Arc<AtomicU64>> = names.iter().map(|_| Arc::new(AtomicU64::new(0))).collect();
    let stop = Arc::new(AtomicBool::new(false));
    let opts = *options;
    let end = RobotTime::ZERO + duration;
    let drops_for_run = drops.clone();
    let stop_for_run = Arc::clone(&stop);
    let outcome = runtime.block_on(async {
        let start = Instant::now();
        let (arrive_tx, mut arrive_rx) = tokio::sync::mpsc::channel::<
            Result<Arrival, (usize, DriverError)>,
        >(opts.channel_capacity.max(1));
        let mut tasks = Vec::new();
        for (i, mut driver) in drivers.into_iter().enumerate() {
            let tx = arrive_tx.clone();
            let dropped = Arc::clone(&drops_for_run[i]);
            let stop = Arc::clone(&stop_for_run);
            tasks.push(tokio::spawn(async move {
                let mut interval = tokio::time::interval(driver.period());
                interval.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
                while !stop.load(Ordering::Relaxed) {
                    interval.tick().await;
                    let now = robot_now(start, opts.speed);
                    if now > end {
                        break;
                    }
                    match driver.poll(now) {
                        Ok(outputs) => {
                            for mut output in outputs {
                                output.log_time = now;
                                match tx.try_send(Ok(Arrival { output })) {
                                    Ok(()) => {}
                                    Err(tokio::sync::mpsc::error::TrySendError::Full(_)) => {
                                        dropped.fetch_add(1, Ordering::Relaxed);
                                    }
                                    Err(tokio::sync::mpsc::error::TrySendError::Closed(_)) => {
                                        return;
                                    }
                                }
                            }
                        }
                        Err(e) => {
                            let _closed = tx.send(Err((i, e))).await;
                            return;
                        }
                    }
                }
            }));
        }
        drop(arrive_tx);
        let result = hardware_runner(
            &mut runner,
            &mut arrive_rx,
            &tx,
            &names,
            &drops_for_run,
            start,
            end,
            &opts,
        )
        .await;
        stop_for_run.store(true, Ordering::Relaxed);
        for t in tasks {
            t.abort();
        }
        result
    });
    drop(tx);
    let written = sink.close();
    let (interrupted, at, payload_bytes) = outcome?;
    Ok(HardwareSummary {
        messages: written?,
        payload_bytes,
        drops: names
            .into_iter()
            .zip(drops.iter().map(|d| d.load(Ordering::Relaxed)))
            .collect(),
        end: at,
        interrupted,
    })
}

/// The runner task of [`run_hardware`]: `(interrupted, robot time reached, payload bytes)`.
#[allow(clippy::too_many_arguments)] // one call site; the parts of one runtime
async fn hardware_runner(
    runner: &mut Runner,
    arrivals: &mut tokio::sync::mpsc::Receiver<Result<Arrival, (usize, DriverError)>>,
    tx: &tokio::sync::mpsc::Sender<SinkItem>,
    names: &[String],
    drops: &[Arc<AtomicU64>],
    start: Instant,
    end: RobotTime,
    opts: &LiveOptions,
) -> Result<(bool, RobotTime, u64), LiveError> {
    let mut channels = ChannelCache::default();
    let clock_channel = Channel::known(
        msgs::topics::CLOCK,
        RUNTIME,
        <Clock as msgs::RosMessage>::TYPE_NAME,
    );
    let mut next_clock = RobotTime::ZERO;
    let mut next_drop_report = RobotTime::ZERO + RobotDuration::from_secs(1);
    let mut reported: Vec<u64> = vec![0; names.len()];
    // Everything up to here has been popped; later arrivals are clamped to it.
    let mut popped_until = RobotTime::ZERO;
    let mut payload_bytes = 0u64;
    let mut interval = tokio::time::interval(opts.tick);
    interval.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let ctrl_c = tokio::signal::ctrl_c();
    tokio::pin!(ctrl_c);
    let mut interrupted = false;
    let mut open = true;
    loop {
        tokio::select! {
            arrival = arrivals.recv(), if open => match arrival {
                Some(Ok(a)) => {
                    // Inputs are queued in arrival order, never before what was popped.
                    let mut out = a.output;
                    out.log_time = out.log_time.max(popped_until);
                    let env = channels.envelope(out).map_err(LiveError::Scheduler)?;
                    runner.push_input(env);
                }
                Some(Err((i, source))) => {
                    return Err(LiveError::Driver {
                        driver: names.get(i).cloned().unwrap_or_default(),
                        source,
                    });
                }
                None => open = false,
            },
            _ = interval.tick() => {}
            _ = &mut ctrl_c => { interrupted = true; }
        }
        let now = robot_now(start, opts.speed);
        let done = interrupted || now >= end + opts.merge_delay;
        // Runtime inputs: /clock every 100 ms and drop reports every second, up to `now`.
        let horizon = if done {
            now
        } else {
            now.checked_sub(opts.merge_delay).unwrap_or(RobotTime::ZERO)
        };
        while next_clock <= horizon.min(end) {
            let msg = Msg::Clock(Clock {
                clock: next_clock.to_ros().unwrap_or_default(),
            });
            if let Ok(env) =
                Envelope::encode(Arc::clone(&clock_channel), next_clock, next_clock, msg)
            {
                runner.push_input(env);
            }
            next_clock += CLOCK_PERIOD;
        }
        if horizon >= next_drop_report || done {
            for (i, name) in names.iter().enumerate() {
                let total = drops.get(i).map_or(0, |d| d.load(Ordering::Relaxed));
                let Some(seen) = reported.get_mut(i) else {
                    continue;
                };
                if total > *seen {
                    let t = horizon.max(popped_until);
                    let text = format!("dropped {} samples (total {total})", total - *seen);
                    *seen = total;
                    let log = rosout(name, t, Log::WARN, text);
                    let channel = channels.get(msgs::topics::ROSOUT, name, log.type_name());
                    if let Ok(env) = Envelope::encode(channel, t, t, log) {
                        runner.push_input(env);
                    }
                }
            }
            next_drop_report += RobotDuration::from_secs(1);
        }
        popped_until = popped_until.max(horizon);
        while runner.peek_time().is_some_and(|t| t <= horizon) {
            let Some(p) = runner.pop()? else { break };
            payload_bytes += p.envelope.cdr.len() as u64;
            if tx.send(item(p.envelope)).await.is_err() {
                return Err(LiveError::SinkThread { written: 0 });
            }
        }
        if done || (!open && runner.queued() == 0) {
            return Ok((interrupted, horizon.min(end), payload_bytes));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sink::MemorySink;
    use msgs::std_msgs::Float64;

    /// Emits `burst` samples per 10 ms poll.
    struct Burst {
        burst: usize,
    }
    impl LiveDriver for Burst {
        fn name(&self) -> &str {
            "burst_driver"
        }
        fn period(&self) -> Duration {
            Duration::from_millis(10)
        }
        fn poll(&mut self, now: RobotTime) -> Result<Vec<DriverOutput>, DriverError> {
            Ok((0..self.burst)
                .map(|i| DriverOutput {
                    producer: "burst_driver".into(),
                    topic: "/env/wind".into(),
                    msg: Msg::Float64(Float64 { data: i as f64 }),
                    log_time: now,
                    publish_time: now,
                })
                .collect())
        }
    }

    fn run(burst: usize, capacity: usize) -> Result<(HardwareSummary, MemorySink), LiveError> {
        let mem = MemorySink::new();
        let fan = SinkFanout::new(vec![Box::new(mem.clone())]);
        let options = LiveOptions {
            channel_capacity: capacity,
            ..LiveOptions::default()
        };
        let summary = run_hardware(
            vec![Box::new(Burst { burst })],
            Runner::new(Vec::new())?,
            fan,
            RobotDuration::from_millis(1300),
            &options,
        )?;
        Ok((summary, mem))
    }

    #[test]
    fn hardware_run_feeds_clock_and_keeps_log_order() -> Result<(), LiveError> {
        let (summary, mem) = run(1, 64)?;
        assert_eq!(summary.drops, vec![("burst_driver".to_owned(), 0)]);
        let msgs = mem.messages();
        let clocks = msgs.iter().filter(|m| m.channel.topic == "/clock").count();
        assert!((12..=14).contains(&clocks), "{clocks} clocks in 1.3 s");
        assert!(
            msgs.iter()
                .filter(|m| m.channel.topic == "/env/wind")
                .count()
                > 50
        );
        assert!(
            msgs.windows(2)
                .all(|w| w[0].log_time_ns <= w[1].log_time_ns)
        );
        assert_eq!(summary.messages, msgs.len() as u64);
        Ok(())
    }

    #[test]
    fn a_full_channel_drops_samples_counts_and_logs_them() -> Result<(), LiveError> {
        let (summary, mem) = run(200, 4)?;
        let dropped = summary.drops.first().map_or(0, |d| d.1);
        assert!(
            dropped > 0,
            "no drops with 200 samples per poll into 4 slots"
        );
        let warnings: Vec<_> = mem
            .messages()
            .into_iter()
            .filter(|m| m.channel.topic == "/rosout" && m.channel.producer == "burst_driver")
            .collect();
        assert!(!warnings.is_empty(), "drops were not logged on /rosout");
        Ok(())
    }
}
