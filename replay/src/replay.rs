//! Replay: feed a recording's inputs through the same stages, in the same merge order, and
//! compare (or write) what they regenerate (ARCHITECTURE.md section 2).
//!
//! 1. Channels are classified: a channel is an **output** iff its `producer` metadata names a
//!    stage of the current pipeline; every other channel (drivers, `/clock`, foreign files
//!    without the key) is an **input**.
//! 2. With `--start S`, the latest message before S of every latched input channel
//!    (`/tf_static`, `/robot_description`, camera info; or QoS `transient_local`) is fed
//!    first, at its own log time.
//! 3. Inputs in `[start, end]` are pushed into the [`Runner`] in file order (which is the
//!    recorded merge order); before an input with log time `t` is pushed, every queued entry
//!    earlier than `t` is popped (the runner's feeding rule), so stages see exactly what
//!    they saw when the file was recorded.
//! 4. Regenerated outputs in `[start, end]` (and on `--topics`) are compared with the
//!    recorded ones ([`crate::check`]) and, for a what-if, written with the inputs to a sink.
//!
//! `end` defaults to the recording's last log time: outputs later than that were not
//! recorded either.

use std::collections::{BTreeMap, BTreeSet};
use std::io::{Read, Seek};
use std::sync::Arc;

use msgs::{Msg, RobotTime, Stage};
use recorder::{Channel, Envelope, Popped, Runner, SinkFanout};

use crate::check::{Comparator, Comparison};
use crate::reader::{ChannelInfo, McapReader, ReadError, ReadFilter};

/// Errors of replay.
#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    /// Reading the recording failed.
    #[error(transparent)]
    Read(#[from] ReadError),
    /// The pipeline could not be built or failed.
    #[error(transparent)]
    Runner(#[from] recorder::RunnerError),
    /// Writing the what-if output failed.
    #[error(transparent)]
    Sink(#[from] recorder::SinkError),
    /// `--start`/`--end` are invalid.
    #[error(
        "invalid time window: start {start_s} s, end {end_s} s (recording lasts {duration_s} s)"
    )]
    Window {
        /// Start given.
        start_s: f64,
        /// End given.
        end_s: f64,
        /// Length of the recording.
        duration_s: f64,
    },
}

/// What to replay.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ReplayOptions {
    /// Seconds from the start of the recording (its first log time).
    pub start_s: Option<f64>,
    /// Seconds from the start of the recording (inclusive).
    pub end_s: Option<f64>,
    /// Only these topics are compared and written (stages still get every input).
    pub topics: Option<BTreeSet<String>>,
    /// The producers that were stages when the file was recorded (its `pipeline` record, or
    /// every producer that is not one of its world's drivers). A channel of such a producer
    /// that the current pipeline lacks is an *orphan output*: it is neither fed as an input
    /// (no stage of this version produces it) nor compared, and it is reported. `None`:
    /// every channel of a producer the pipeline lacks is an input.
    pub recorded_stages: Option<BTreeSet<String>>,
}

/// What a replay did.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ReplayReport {
    /// Output channels (topic, producer) found in the recording.
    pub output_channels: Vec<(String, String)>,
    /// Input messages fed (latched ones included).
    pub inputs_fed: u64,
    /// Latched messages fed before `start`.
    pub latched_fed: u64,
    /// Inputs msgs could not decode (written through, given to no stage).
    pub undecodable_inputs: u64,
    /// Regenerated outputs in the window.
    pub regenerated: u64,
    /// Log times of the regenerated outputs in the window (sorted), for open-loop counts.
    pub regenerated_times_ns: Vec<u64>,
    /// Messages written to the sink.
    pub written: u64,
    /// Window `[start, end]`, absolute log times in ns.
    pub window_ns: (u64, u64),
    /// The comparison.
    pub comparison: Comparison,
    /// Recovery note when the file was truncated (crashed recording).
    pub truncated: Option<String>,
    /// Outputs of recorded stages the current pipeline lacks: `(topic, producer)` and the
    /// number of messages in the window ([`ReplayOptions::recorded_stages`]).
    pub orphan_outputs: BTreeMap<(String, String), u64>,
}

impl ReplayReport {
    /// Regenerated outputs strictly after `t_ns` (open-loop ones in a what-if).
    pub fn outputs_after(&self, t_ns: u64) -> u64 {
        let i = self.regenerated_times_ns.partition_point(|&t| t <= t_ns);
        (self.regenerated_times_ns.len() - i) as u64
    }
}

fn channel_of(info: &ChannelInfo) -> Arc<Channel> {
    let schema_text = info
        .schema
        .as_ref()
        .map(|s| String::from_utf8_lossy(&s.data).into_owned())
        .unwrap_or_default();
    Arc::new(Channel {
        topic: info.topic.clone(),
        producer: info.producer().unwrap_or_default().to_owned(),
        type_name: info.schema_name().to_owned(),
        schema_text,
        qos_yaml: info
            .metadata
            .get(recorder::mcap_writer::QOS_KEY)
            .cloned()
            .unwrap_or_default(),
    })
}

fn is_latched(info: &ChannelInfo) -> bool {
    msgs::topics::is_latched(&info.topic)
        || info
            .metadata
            .get(recorder::mcap_writer::QOS_KEY)
            .is_some_and(|q| q.contains("transient_local"))
}

struct Feeder<'a> {
    runner: Runner,
    comparator: Comparator,
    sink: Option<&'a mut SinkFanout>,
    topics: Option<BTreeSet<String>>,
    window: (RobotTime, RobotTime),
    report: ReplayReport,
}

impl Feeder<'_> {
    fn wanted(&self, topic: &str) -> bool {
        self.topics.as_ref().is_none_or(|t| t.contains(topic))
    }

    fn handle(&mut self, p: Popped) -> Result<(), ReplayError> {
        let is_output = p.is_output();
        let env = p.envelope;
        let t = env.log_time;
        let in_window = t >= self.window.0 && t <= self.window.1;
        if is_output {
            if !in_window || !self.wanted(env.topic()) {
                return Ok(());
            }
            self.report.regenerated += 1;
            self.report.regenerated_times_ns.push(t.as_nanos());
            if let Some(sink) = self.sink.as_deref_mut() {
                sink.write_envelope(&env)?;
                self.report.written += 1;
            }
            let ch = &env.channel;
            self.comparator.regenerated(
                &ch.topic,
                &ch.producer,
                &ch.type_name,
                t.as_nanos(),
                env.cdr,
            );
        } else if self.wanted(env.topic())
            && let Some(sink) = self.sink.as_deref_mut()
        {
            sink.write_envelope(&env)?;
            self.report.written += 1;
        }
        Ok(())
    }

    /// Pops every entry strictly before `t` (or up to and including `t` if `inclusive`).
    fn drain(&mut self, t: RobotTime, inclusive: bool) -> Result<(), ReplayError> {
        while self
            .runner
            .peek_time()
            .is_some_and(|q| q < t || (inclusive && q == t))
        {
            let Some(p) = self.runner.pop()? else {
                break;
            };
            self.handle(p)?;
        }
        Ok(())
    }

    fn feed(&mut self, env: Envelope) -> Result<(), ReplayError> {
        self.drain(env.log_time, false)?;
        if env.msg.is_none() {
            self.report.undecodable_inputs += 1;
        }
        self.report.inputs_fed += 1;
        self.runner.push_input(env);
        Ok(())
    }
}

/// Replays `reader` through `stages`; compares regenerated outputs with the recorded ones
/// and, when `sink` is given, writes inputs + regenerated outputs to it (what-if).
///
/// # Errors
/// See [`ReplayError`]; damaged chunks in the recording are errors.
pub fn replay<R: Read + Seek>(
    reader: &mut McapReader<R>,
    stages: Vec<Box<dyn Stage + Send>>,
    options: &ReplayOptions,
    sink: Option<&mut SinkFanout>,
) -> Result<ReplayReport, ReplayError> {
    let runner = Runner::new(stages)?;
    let mut report = ReplayReport {
        truncated: reader
            .recovery()
            .and_then(|r| r.truncation.as_ref())
            .map(|t| {
                format!(
                    "truncated at byte {} ({} bytes lost: {})",
                    t.valid_until, t.lost_bytes, t.reason
                )
            }),
        ..ReplayReport::default()
    };
    let Some((first_ns, last_ns)) = reader.time_range_ns() else {
        return Ok(report);
    };
    let secs = |s: f64| RobotTime::from_secs_f64(s).map(|t| t.as_nanos());
    let bad_window = || ReplayError::Window {
        start_s: options.start_s.unwrap_or(0.0),
        end_s: options.end_s.unwrap_or(f64::INFINITY),
        duration_s: (last_ns - first_ns) as f64 * 1e-9,
    };
    let start_ns = match options.start_s {
        Some(s) => first_ns.saturating_add(secs(s).map_err(|_| bad_window())?),
        None => first_ns,
    };
    let end_ns = match options.end_s {
        Some(s) => first_ns
            .saturating_add(secs(s).map_err(|_| bad_window())?)
            .min(last_ns),
        None => last_ns,
    };
    if start_ns > end_ns {
        return Err(bad_window());
    }
    report.window_ns = (start_ns, end_ns);

    // Channel classification.
    let mut channels: BTreeMap<u16, (Arc<Channel>, bool, bool)> = BTreeMap::new();
    let mut orphans: BTreeMap<u16, (String, String)> = BTreeMap::new();
    for (id, info) in reader.channels() {
        let producer = info.producer().unwrap_or_default();
        let output = runner.is_stage(producer);
        if output {
            report
                .output_channels
                .push((info.topic.clone(), producer.to_owned()));
        } else if options
            .recorded_stages
            .as_ref()
            .is_some_and(|stages| stages.contains(producer))
        {
            orphans.insert(*id, (info.topic.clone(), producer.to_owned()));
            continue;
        }
        channels.insert(*id, (channel_of(info), output, is_latched(info)));
    }

    let mut feeder = Feeder {
        runner,
        comparator: Comparator::new(),
        sink,
        topics: options.topics.clone(),
        window: (
            RobotTime::from_nanos(start_ns),
            RobotTime::from_nanos(end_ns),
        ),
        report,
    };

    // Latched inputs from before the window, latest per channel.
    if start_ns > first_ns {
        let mut latest: BTreeMap<u16, crate::reader::McapMessage> = BTreeMap::new();
        let filter = ReadFilter::all().with_time_range(Some(first_ns), Some(start_ns));
        for m in reader.messages(&filter) {
            let m = m?;
            if channels
                .get(&m.channel.id)
                .is_some_and(|(_, output, latched)| !output && *latched)
            {
                latest.insert(m.channel.id, m);
            }
        }
        let mut latched: Vec<_> = latest.into_values().collect();
        latched.sort_by_key(|m| m.log_time_ns);
        for m in latched {
            let Some((ch, _, _)) = channels.get(&m.channel.id) else {
                continue;
            };
            feeder.report.latched_fed += 1;
            feeder.feed(envelope(
                Arc::clone(ch),
                m.log_time_ns,
                m.publish_time_ns,
                m.data,
            ))?;
        }
    }

    // The window.
    let filter = ReadFilter::all().with_time_range(Some(start_ns), Some(end_ns.saturating_add(1)));
    for m in reader.messages(&filter) {
        let m = m?;
        if let Some(key) = orphans.get(&m.channel.id) {
            *feeder.report.orphan_outputs.entry(key.clone()).or_default() += 1;
            continue;
        }
        let Some((ch, output, _)) = channels.get(&m.channel.id) else {
            continue;
        };
        if *output {
            if feeder.wanted(&ch.topic) {
                feeder.comparator.recorded(
                    &ch.topic,
                    &ch.producer,
                    &ch.type_name,
                    m.log_time_ns,
                    m.data,
                );
            }
        } else {
            feeder.feed(envelope(
                Arc::clone(ch),
                m.log_time_ns,
                m.publish_time_ns,
                m.data,
            ))?;
        }
    }
    feeder.drain(RobotTime::from_nanos(end_ns), true)?;
    let Feeder {
        comparator,
        mut report,
        ..
    } = feeder;
    report.comparison = comparator.finish();
    Ok(report)
}

fn envelope(
    channel: Arc<Channel>,
    log_time_ns: u64,
    publish_time_ns: u64,
    cdr: Vec<u8>,
) -> Envelope {
    let msg = Msg::decode(&channel.type_name, &cdr).ok();
    Envelope {
        channel,
        log_time: RobotTime::from_nanos(log_time_ns),
        publish_time: RobotTime::from_nanos(publish_time_ns),
        msg,
        cdr,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use msgs::rcl_interfaces::Log;
    use msgs::rosgraph_msgs::Clock;
    use msgs::std_msgs::String as StringMsg;
    use msgs::{RobotDuration, StageError};
    use recorder::{McapSink, McapStreamSink, MemorySink, Sink, SinkMessage, SinkOptions};
    use std::io::Cursor;

    /// Says on every `/clock` whether it has seen `/robot_description`.
    struct Echo {
        have: bool,
    }
    impl Stage for Echo {
        fn name(&self) -> &str {
            "echo"
        }
        fn inputs(&self) -> Vec<String> {
            vec!["/robot_description".into(), "/clock".into()]
        }
        fn outputs(&self) -> Vec<(String, &'static str)> {
            vec![("/rosout".into(), "rcl_interfaces/msg/Log")]
        }
        fn latency(&self) -> RobotDuration {
            RobotDuration::ZERO
        }
        fn on_message(
            &mut self,
            t: RobotTime,
            topic: &str,
            _msg: &Msg,
        ) -> Result<Vec<(String, Msg)>, StageError> {
            if topic == "/robot_description" {
                self.have = true;
                return Ok(vec![]);
            }
            Ok(vec![(
                "/rosout".into(),
                recorder::runner::rosout("echo", t, Log::INFO, format!("have={}", self.have)),
            )])
        }
    }

    /// A file with /robot_description at 0 s and /clock at 0..=9 s (inputs only).
    fn file() -> Result<Vec<u8>, Box<dyn std::error::Error>> {
        let mut sink = McapStreamSink::new(McapSink::new(
            Cursor::new(Vec::new()),
            &SinkOptions::default(),
        )?);
        let desc = recorder::Channel::known(
            "/robot_description",
            "description_publisher",
            "std_msgs/msg/String",
        );
        let clock = recorder::Channel::known("/clock", "scheduler", "rosgraph_msgs/msg/Clock");
        let cdr = Msg::String(StringMsg {
            data: "urdf".into(),
        })
        .encode()?;
        sink.write(&SinkMessage {
            channel: &desc,
            log_time_ns: 0,
            publish_time_ns: 0,
            cdr: &cdr,
        })?;
        for s in 0..10u64 {
            let t = RobotTime::from_millis(s * 1000);
            let cdr = Msg::Clock(Clock { clock: t.to_ros()? }).encode()?;
            sink.write(&SinkMessage {
                channel: &clock,
                log_time_ns: t.as_nanos(),
                publish_time_ns: t.as_nanos(),
                cdr: &cdr,
            })?;
        }
        Ok(sink.finish_into_inner()?.into_inner())
    }

    fn texts(mem: &MemorySink) -> Vec<String> {
        mem.messages()
            .iter()
            .filter(|m| m.channel.topic == "/rosout")
            .filter_map(|m| match Msg::decode("rcl_interfaces/msg/Log", &m.cdr) {
                Ok(Msg::Log(l)) => Some(l.msg),
                _ => None,
            })
            .collect()
    }

    #[test]
    fn start_mid_file_refeeds_latched_inputs_first() -> Result<(), Box<dyn std::error::Error>> {
        let bytes = file()?;
        let mut reader =
            McapReader::from_reader(Cursor::new(bytes), crate::ReadOptions::default())?;
        let mem = MemorySink::new();
        let mut fan = SinkFanout::new(vec![Box::new(mem.clone())]);
        let options = ReplayOptions {
            start_s: Some(5.0),
            end_s: Some(8.0),
            ..ReplayOptions::default()
        };
        let report = replay(
            &mut reader,
            vec![Box::new(Echo { have: false })],
            &options,
            Some(&mut fan),
        )?;
        fan.finish()?;
        assert_eq!(report.latched_fed, 1);
        assert_eq!(report.window_ns, (5_000_000_000, 8_000_000_000));
        // Clock 5, 6, 7, 8 s, each answered with the description known.
        assert_eq!(texts(&mem), vec!["have=true"; 4]);
        // Nothing recorded to compare with (the file has no `echo` channel).
        assert_eq!(report.comparison.compared(), 0);
        assert_eq!(report.regenerated, 4);
        Ok(())
    }

    #[test]
    fn topic_filter_limits_what_is_written() -> Result<(), Box<dyn std::error::Error>> {
        let mut reader =
            McapReader::from_reader(Cursor::new(file()?), crate::ReadOptions::default())?;
        let mem = MemorySink::new();
        let mut fan = SinkFanout::new(vec![Box::new(mem.clone())]);
        let options = ReplayOptions {
            topics: Some(["/clock".to_owned()].into()),
            ..ReplayOptions::default()
        };
        let report = replay(
            &mut reader,
            vec![Box::new(Echo { have: false })],
            &options,
            Some(&mut fan),
        )?;
        fan.finish()?;
        assert_eq!(report.inputs_fed, 11);
        assert!(mem.messages().iter().all(|m| m.channel.topic == "/clock"));
        assert_eq!(mem.messages().len(), 10);
        let bad = ReplayOptions {
            start_s: Some(8.0),
            end_s: Some(2.0),
            ..ReplayOptions::default()
        };
        let mut reader =
            McapReader::from_reader(Cursor::new(file()?), crate::ReadOptions::default())?;
        assert!(matches!(
            replay(&mut reader, vec![], &bad, None),
            Err(ReplayError::Window { .. })
        ));
        Ok(())
    }

    #[test]
    fn outputs_of_a_recorded_stage_the_pipeline_lacks_are_reported_not_fed()
    -> Result<(), Box<dyn std::error::Error>> {
        // `description_publisher` was a stage when the file was recorded; this pipeline has
        // only `echo`, so its /robot_description is an orphan output, not an input.
        let mut reader =
            McapReader::from_reader(Cursor::new(file()?), crate::ReadOptions::default())?;
        let mem = MemorySink::new();
        let mut fan = SinkFanout::new(vec![Box::new(mem.clone())]);
        let options = ReplayOptions {
            recorded_stages: Some(["description_publisher".to_owned()].into()),
            ..ReplayOptions::default()
        };
        let report = replay(
            &mut reader,
            vec![Box::new(Echo { have: false })],
            &options,
            Some(&mut fan),
        )?;
        fan.finish()?;
        assert_eq!(
            report.orphan_outputs.get(&(
                "/robot_description".to_owned(),
                "description_publisher".to_owned()
            )),
            Some(&1)
        );
        assert_eq!(report.inputs_fed, 10);
        assert_eq!(texts(&mem), vec!["have=false"; 10]);
        let text = crate::whatif::summary(&report, &[]);
        assert!(text.contains("NOT CHECKED"), "{text}");
        Ok(())
    }
}
