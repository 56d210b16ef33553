//! [`run_live`]: live drivers and sources through the runner into the sinks (module docs of
//! [`crate::live`]); [`run_hardware`] is its form with polled drivers only.

use std::collections::BTreeMap;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use msgs::drivers::{DriverError, DriverOutput};
use msgs::rcl_interfaces::Log;
use msgs::rosgraph_msgs::Clock;
use msgs::{Msg, RobotDuration, RobotTime};

use crate::live::clock::LiveClock;
use crate::live::feed::{Feed, Incoming, InputCounts, LiveSource, Pushed, TopicCount};
use crate::live::{LiveError, LiveOptions, RUNTIME, SinkItem, SinkThread, build_runtime, item};
use crate::mcap_writer::MetadataRecord;
use crate::runner::{Envelope, Popped, Runner, StageStats, rosout};
use crate::scheduler::{CLOCK_PERIOD, ChannelCache, SinkFanout};
use crate::session::StopCondition;
use crate::sink::Channel;

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

/// What the runtime hands every popped message to, besides the sinks: the command path to a
/// robot (part of the transport, never a stage). Called on the runner task, so it must not
/// block: queue the work for another thread.
pub trait LiveOutput: Send {
    /// A message was popped at robot time `now`, after the stages subscribed to it ran.
    fn popped(&mut self, popped: &Popped, now: RobotTime);

    /// The run is over (called once, on every exit path).
    fn finish(&mut self) {}

    /// Metadata records to write at the end of the recording (after [`LiveOutput::finish`]).
    fn records(&mut self) -> Vec<MetadataRecord> {
        Vec::new()
    }
}

/// A live run (module docs of [`crate::live`]).
pub struct LiveRun {
    /// Polled drivers.
    pub drivers: Vec<Box<dyn LiveDriver>>,
    /// Pushing sources, each on its own thread.
    pub sources: Vec<Box<dyn LiveSource>>,
    /// The robot clock.
    pub clock: LiveClock,
    /// Robot time to run.
    pub duration: RobotDuration,
    /// End earlier when a message says the run is over (the task's end).
    pub stop: Option<StopCondition>,
    /// The command path, if any.
    pub output: Option<Box<dyn LiveOutput>>,
    /// External clocks: end when the clock has not advanced for this long (wall time) after it
    /// first moved (the graph's `/clock` stopped).
    pub clock_timeout: Option<Duration>,
    /// Runtime options.
    pub options: LiveOptions,
}

impl std::fmt::Debug for LiveRun {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LiveRun")
            .field("drivers", &self.drivers.len())
            .field("sources", &self.sources.len())
            .field("clock", &self.clock)
            .field("duration", &self.duration)
            .finish_non_exhaustive()
    }
}

/// Why a live run ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LiveEnd {
    /// It reached its duration.
    Duration,
    /// The stop condition fired (the task ended), and its grace passed.
    Done,
    /// Ctrl-C (SIGINT).
    Interrupted,
    /// The external clock stopped advancing.
    ClockStopped,
    /// Every input channel closed (no driver or source left).
    InputsClosed,
}

/// What a live run did.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LiveSummary {
    /// Messages written.
    pub messages: u64,
    /// Bytes of CDR payload written.
    pub payload_bytes: u64,
    /// Robot time reached.
    pub end: RobotTime,
    /// Why it ended.
    pub ended: LiveEnd,
    /// Per-topic input counters.
    pub inputs: BTreeMap<String, TopicCount>,
    /// Per-stage counters.
    pub stages: Vec<StageStats>,
    /// Samples dropped per polled driver (name, count), in driver order.
    pub driver_drops: Vec<(String, u64)>,
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

/// Runs live drivers through `runner` into `fanout` for `duration` of robot time (or until
/// Ctrl-C or a driver fault), on the wall clock at `options.speed`. See [`run_live`].
///
/// # Errors
/// [`LiveError`]; the file is finished in every case.
pub fn run_hardware(
    drivers: Vec<Box<dyn LiveDriver>>,
    runner: Runner,
    fanout: SinkFanout,
    duration: RobotDuration,
    options: &LiveOptions,
) -> Result<HardwareSummary, LiveError> {
    let s = run_live(
        LiveRun {
            drivers,
            sources: Vec::new(),
            clock: LiveClock::wall(options.speed),
            duration,
            stop: None,
            output: None,
            clock_timeout: None,
            options: *options,
        },
        runner,
        fanout,
    )?;
    Ok(HardwareSummary {
        messages: s.messages,
        payload_bytes: s.payload_bytes,
        drops: s.driver_drops,
        end: s.end,
        interrupted: s.ended == LiveEnd::Interrupted,
    })
}

/// Runs `run`'s drivers and sources through `runner` into `fanout` (module docs of
/// [`crate::live`]), until its duration, its stop condition, Ctrl-C, a stopped external
/// clock, or a driver or source fault. The input counters are written as the
/// [`crate::live::INPUTS_RECORD`] metadata record before the file is finished.
///
/// # Errors
/// [`LiveError`]; the file is finished in every case.
pub fn run_live(
    run: LiveRun,
    mut runner: Runner,
    fanout: SinkFanout,
) -> Result<LiveSummary, LiveError> {
    let LiveRun {
        drivers,
        sources,
        clock,
        duration,
        stop,
        mut output,
        clock_timeout,
        options: opts,
    } = run;
    let runtime = build_runtime()?;
    let sink = SinkThread::spawn(fanout, opts.channel_capacity);
    let tx = sink.tx.clone();
    let names: Vec<String> = drivers.iter().map(|d| d.name().to_owned()).collect();
    let drops: Vec<Arc<AtomicU64>> = names.iter().map(|_| Arc::new(AtomicU64::new(0))).collect();
    let stop_flag = Arc::new(AtomicBool::new(false));
    let counts = InputCounts::default();
    let end = RobotTime::ZERO + duration;
    let (in_tx, mut in_rx) = tokio::sync::mpsc::channel::<Incoming>(opts.input_capacity.max(1));
    let feed = Feed {
        tx: in_tx,
        clock: clock.clone(),
        stop: Arc::clone(&stop_flag),
        counts: counts.clone(),
    };
    let mut threads = Vec::new();
    for source in sources {
        let feed = feed.clone();
        let name = source.name().to_owned();
        let spawned = std::thread::Builder::new()
            .name(format!("src {name}"))
            .spawn(move || {
                if let Err(e) = source.run(feed.clone()) {
                    feed.fail(&name, e);
                }
            });
        match spawned {
            Ok(h) => threads.push(h),
            Err(e) => {
                stop_flag.store(true, Ordering::Relaxed);
                return Err(LiveError::Runtime(e));
            }
        }
    }
    let outcome = runtime.block_on(async {
        let mut tasks = Vec::new();
        for (i, mut driver) in drivers.into_iter().enumerate() {
            let feed = feed.clone();
            let dropped = Arc::clone(&drops[i]);
            let name = names[i].clone();
            tasks.push(tokio::spawn(async move {
                let mut channels = ChannelCache::default();
                let mut interval = tokio::time::interval(driver.period());
                interval.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
                while !feed.stopped() {
                    interval.tick().await;
                    let now = feed.now();
                    if now > end {
                        break;
                    }
                    let outputs = match driver.poll(now) {
                        Ok(o) => o,
                        Err(e) => {
                            feed.fail(&name, e);
                            return;
                        }
                    };
                    for mut o in outputs {
                        o.log_time = now;
                        let env = match channels.envelope(o) {
                            Ok(env) => env,
                            Err(e) => {
                                feed.fail(
                                    &name,
                                    DriverError::Fault {
                                        device: name.clone(),
                                        now,
                                        reason: e.to_string(),
                                    },
                                );
                                return;
                            }
                        };
                        match feed.push(env) {
                            Pushed::Queued => {}
                            Pushed::Dropped => {
                                dropped.fetch_add(1, Ordering::Relaxed);
                            }
                            Pushed::Closed => return,
                        }
                    }
                }
            }));
        }
        drop(feed);
        let mut state = Loop {
            runner: &mut runner,
            tx: &tx,
            counts: &counts,
            clock: &clock,
            output: output.as_deref_mut(),
            stop,
            end,
            opts,
            clock_timeout,
        };
        let result = state.run(&mut in_rx).await;
        stop_flag.store(true, Ordering::Relaxed);
        for t in tasks {
            t.abort();
        }
        result
    });
    stop_flag.store(true, Ordering::Relaxed);
    drop(in_rx);
    for t in threads {
        let _joined = t.join();
    }
    let mut records = Vec::new();
    if let Some(o) = output.as_deref_mut() {
        o.finish();
        records = o.records();
    }
    records.push(counts.record());
    let record_sent = runtime.block_on(async {
        for r in records {
            tx.send(SinkItem::Metadata(r)).await?;
        }
        Ok::<(), tokio::sync::mpsc::error::SendError<SinkItem>>(())
    });
    drop(tx);
    let written = sink.close();
    let (ended, at, payload_bytes) = outcome?;
    if record_sent.is_err() {
        return Err(LiveError::SinkThread { written: 0 });
    }
    Ok(LiveSummary {
        messages: written?,
        payload_bytes,
        end: at,
        ended,
        inputs: counts.snapshot(),
        stages: runner.stats(),
        driver_drops: names
            .into_iter()
            .zip(drops.iter().map(|d| d.load(Ordering::Relaxed)))
            .collect(),
    })
}

/// The runner task's state.
struct Loop<'a> {
    runner: &'a mut Runner,
    tx: &'a tokio::sync::mpsc::Sender<SinkItem>,
    counts: &'a InputCounts,
    clock: &'a LiveClock,
    output: Option<&'a mut (dyn LiveOutput + 'static)>,
    stop: Option<StopCondition>,
    end: RobotTime,
    opts: LiveOptions,
    clock_timeout: Option<Duration>,
}

/// The last message popped: its log time and whether it was a stage output.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct LastPopped {
    time: RobotTime,
    output: bool,
}

impl Loop<'_> {
    /// Runs until the end: `(why, robot time reached, payload bytes)`.
    async fn run(
        &mut self,
        arrivals: &mut tokio::sync::mpsc::Receiver<Incoming>,
    ) -> Result<(LiveEnd, RobotTime, u64), LiveError> {
        let mut channels = ChannelCache::default();
        let clock_channel = Channel::known(
            msgs::topics::CLOCK,
            RUNTIME,
            <Clock as msgs::RosMessage>::TYPE_NAME,
        );
        let mut next_clock = RobotTime::ZERO;
        let mut next_report = RobotTime::ZERO + RobotDuration::from_secs(1);
        let mut reported: BTreeMap<String, u64> = BTreeMap::new();
        let mut producers: BTreeMap<String, String> = BTreeMap::new();
        let mut last: Option<LastPopped> = None;
        let mut payload_bytes = 0u64;
        let mut end_at = self.end;
        let mut interval = tokio::time::interval(self.opts.tick);
        interval.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        let ctrl_c = tokio::signal::ctrl_c();
        tokio::pin!(ctrl_c);
        let mut interrupted = false;
        let mut open = true;
        let mut clock_moved = (self.clock.now(), Instant::now());
        loop {
            tokio::select! {
                arrival = arrivals.recv(), if open => match arrival {
                    Some(Incoming::Input(mut env)) => {
                        if let Some(l) = last
                            && (env.log_time < l.time || (env.log_time == l.time && l.output))
                        {
                            // Arrived after its robot time was processed (module docs).
                            env.log_time = l.time + RobotDuration::from_nanos(1);
                            self.counts.update(&env.channel.topic, |c| c.late += 1);
                        }
                        producers
                            .entry(env.channel.topic.clone())
                            .or_insert_with(|| env.channel.producer.clone());
                        self.runner.push_input(*env);
                    }
                    Some(Incoming::Failed { source, error }) => {
                        return Err(LiveError::Driver { driver: source, source: error });
                    }
                    None => open = false,
                },
                _ = interval.tick() => {}
                _ = &mut ctrl_c => { interrupted = true; }
            }
            let now = self.clock.now();
            let mut ended = None;
            if interrupted {
                ended = Some(LiveEnd::Interrupted);
            } else if now >= end_at + self.opts.merge_delay {
                ended = Some(if end_at < self.end {
                    LiveEnd::Done
                } else {
                    LiveEnd::Duration
                });
            } else if let Some(timeout) = self.clock_timeout
                && self.clock.is_external()
            {
                if now > clock_moved.0 {
                    clock_moved = (now, Instant::now());
                } else if now > RobotTime::ZERO && clock_moved.1.elapsed() > timeout {
                    ended = Some(LiveEnd::ClockStopped);
                }
            }
            if ended.is_none() && !open && self.runner.queued() == 0 {
                ended = Some(LiveEnd::InputsClosed);
            }
            let horizon = if ended.is_some() {
                now.min(end_at)
            } else {
                now.checked_sub(self.opts.merge_delay)
                    .unwrap_or(RobotTime::ZERO)
                    .min(end_at)
            };
            while next_clock <= horizon {
                let msg = Msg::Clock(Clock {
                    clock: next_clock.to_ros().unwrap_or_default(),
                });
                if let Ok(env) =
                    Envelope::encode(Arc::clone(&clock_channel), next_clock, next_clock, msg)
                {
                    self.runner.push_input(env);
                }
                next_clock += CLOCK_PERIOD;
            }
            if horizon >= next_report || ended.is_some() {
                self.report(horizon, last, &mut reported, &producers, &mut channels);
                next_report = horizon + RobotDuration::from_secs(1);
            }
            while self.runner.peek_time().is_some_and(|t| t <= horizon) {
                let Some(p) = self.runner.pop()? else { break };
                last = Some(LastPopped {
                    time: p.envelope.log_time,
                    output: p.is_output(),
                });
                if end_at == self.end
                    && let Some(c) = &self.stop
                    && p.envelope.topic() == c.topic
                    && p.envelope.msg.as_ref().is_some_and(|m| (c.is_end)(m))
                {
                    end_at = (p.envelope.log_time + c.grace).min(self.end);
                }
                if let Some(o) = self.output.as_deref_mut() {
                    o.popped(&p, now);
                }
                payload_bytes += p.envelope.cdr.len() as u64;
                if self.tx.send(item(p.envelope)).await.is_err() {
                    return Err(LiveError::SinkThread { written: 0 });
                }
            }
            if let Some(why) = ended {
                return Ok((why, horizon, payload_bytes));
            }
        }
    }

    /// Logs, once per second, every topic whose problems grew (producer: the topic's
    /// producer), as `/rosout` WARN inputs after everything popped so far.
    fn report(
        &mut self,
        horizon: RobotTime,
        last: Option<LastPopped>,
        reported: &mut BTreeMap<String, u64>,
        producers: &BTreeMap<String, String>,
        channels: &mut ChannelCache,
    ) {
        let t = match last {
            Some(l) if l.time >= horizon => l.time + RobotDuration::from_nanos(1),
            _ => horizon,
        };
        for (topic, c) in self.counts.snapshot() {
            let seen = reported.entry(topic.clone()).or_insert(0);
            let total = c.problems();
            if total <= *seen {
                continue;
            }
            let text = format!(
                "{topic}: {} new input problems ({})",
                total - *seen,
                c.text()
            );
            *seen = total;
            let producer = producers.get(&topic).map_or(RUNTIME, String::as_str);
            let log = rosout(producer, t, Log::WARN, text);
            let channel = channels.get(msgs::topics::ROSOUT, producer, log.type_name());
            if let Ok(env) = Envelope::encode(channel, t, t, log) {
                self.runner.push_input(env);
            }
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
            input_capacity: capacity,
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

    /// Pushes one message stamped long before now (as a thread stalled for 300 ms would),
    /// then a few on time.
    struct Stalled {
        sent: bool,
    }
    impl LiveSource for Stalled {
        fn name(&self) -> &str {
            "stalled"
        }
        fn run(mut self: Box<Self>, feed: Feed) -> Result<(), DriverError> {
            let channel = Channel::known("/env/wind", "stalled", "std_msgs/msg/Float64");
            while !feed.stopped() {
                std::thread::sleep(Duration::from_millis(50));
                let now = feed.now();
                let t = if !self.sent && now > RobotTime::from_millis(400) {
                    self.sent = true;
                    now.checked_sub(RobotDuration::from_millis(300))
                        .unwrap_or(RobotTime::ZERO)
                } else {
                    now
                };
                let msg = Msg::Float64(Float64 { data: 1.0 });
                let Ok(env) = Envelope::encode(Arc::clone(&channel), t, t, msg) else {
                    continue;
                };
                if feed.push(env) == Pushed::Closed {
                    break;
                }
            }
            Ok(())
        }
    }

    #[test]
    fn a_late_arrival_is_recorded_after_what_was_processed_and_counted()
    -> Result<(), Box<dyn std::error::Error>> {
        let mem = MemorySink::new();
        let fan = SinkFanout::new(vec![Box::new(mem.clone())]);
        let summary = run_live(
            LiveRun {
                drivers: Vec::new(),
                sources: vec![Box::new(Stalled { sent: false })],
                clock: LiveClock::wall(1),
                duration: RobotDuration::from_millis(900),
                stop: None,
                output: None,
                clock_timeout: None,
                options: LiveOptions::default(),
            },
            Runner::new(Vec::new())?,
            fan,
        )?;
        let late = summary.inputs.get("/env/wind").map_or(0, |c| c.late);
        assert_eq!(late, 1, "{:?}", summary.inputs);
        let msgs = mem.messages();
        assert!(
            msgs.windows(2)
                .all(|w| w[0].log_time_ns <= w[1].log_time_ns)
        );
        assert!(
            msgs.iter()
                .any(|m| m.channel.topic == "/rosout" && m.channel.producer == "stalled")
        );
        assert_eq!(summary.ended, LiveEnd::Duration);
        Ok(())
    }
}
