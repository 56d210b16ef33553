//! The deterministic stage runner (ARCHITECTURE.md section 2), shared by recording and replay.
//!
//! All messages, inputs (drivers, `/clock`, or a recording's input channels) and stage
//! outputs alike, go through one priority queue ordered by the merge key
//!
//! ```text
//! (log_time, source rank, sequence)
//!   source rank: 0 = /clock, 1 = every other input, 2 + i = stage i of the pipeline
//!   sequence:    inputs in the order they were pushed; outputs in the order produced
//! ```
//!
//! [`Runner::pop`] takes the smallest entry, hands it to every stage subscribed to its topic
//! (in pipeline order; never back to the stage that produced it) and queues their outputs
//! with `log_time = trigger log_time + stage.latency()`. The popped entry is returned so the
//! caller can write it to sinks and, in simulation, deliver commands to the world.
//!
//! **Feeding rule** (what makes replay reproduce a recording): before popping any entry with
//! log time `t`, every input with log time `<= t` must have been pushed. The simulation
//! scheduler does so by stepping the world to `t` first; replay by pushing the recording's
//! inputs in file order until the next one is later than the queue head. Stage errors are
//! logged as `/rosout` ERROR outputs of that stage (so they are reproduced too); after
//! [`msgs::StageError::Failed`] the stage gets no more input.

use std::cmp::{Ordering, Reverse};
use std::collections::{BTreeMap, BinaryHeap};
use std::sync::Arc;

use msgs::rcl_interfaces::Log;
use msgs::{Msg, RobotTime, Stage, StageError};

use crate::sink::Channel;

/// Source rank of `/clock` inputs.
pub const RANK_CLOCK: u32 = 0;
/// Source rank of every other input.
pub const RANK_INPUT: u32 = 1;
/// Source rank of the first stage; stage `i` has `RANK_FIRST_STAGE + i`.
pub const RANK_FIRST_STAGE: u32 = 2;

/// Errors of the runner.
#[derive(Debug, thiserror::Error)]
pub enum RunnerError {
    /// Two stages of a pipeline have the same name (producers must be unique).
    #[error("two stages are named {name:?} (stages {first} and {second})")]
    DuplicateStage {
        /// The name.
        name: String,
        /// Index of the first.
        first: usize,
        /// Index of the second.
        second: usize,
    },
    /// A stage asks for a simulator ground-truth topic (`/sim/*`): stages see only what a
    /// real robot has, so the same stage runs against hardware and its replay.
    #[error(
        "stage {stage} asks for {topic}: /sim/* topics are the simulator's truth, never a stage input (judge with `rodlog check task` instead)"
    )]
    TruthInput {
        /// Stage name.
        stage: String,
        /// The `/sim/*` topic.
        topic: String,
    },
    /// A stage output could not be encoded.
    #[error("stage {stage}: cannot encode {type_name} on {topic} at {log_time}: {source}")]
    Encode {
        /// Stage name.
        stage: String,
        /// Topic.
        topic: String,
        /// Type.
        type_name: &'static str,
        /// Log time of the output.
        log_time: RobotTime,
        /// Codec error.
        source: msgs::CdrError,
    },
}

/// One message in the runner: channel, times, payload.
#[derive(Debug, Clone)]
pub struct Envelope {
    /// Topic, producer, type.
    pub channel: Arc<Channel>,
    /// Robot-clock log time.
    pub log_time: RobotTime,
    /// Device/driver time (stage outputs: = log_time).
    pub publish_time: RobotTime,
    /// The decoded message; `None` for a payload msgs cannot decode (a foreign type): it is
    /// passed to sinks but to no stage.
    pub msg: Option<Msg>,
    /// CDR payload (with encapsulation header).
    pub cdr: Vec<u8>,
}

impl Envelope {
    /// An envelope for a message of a known type, encoding it.
    ///
    /// # Errors
    /// The CDR codec's errors.
    pub fn encode(
        channel: Arc<Channel>,
        log_time: RobotTime,
        publish_time: RobotTime,
        msg: Msg,
    ) -> Result<Self, msgs::CdrError> {
        let cdr = msg.encode()?;
        Ok(Self {
            channel,
            log_time,
            publish_time,
            msg: Some(msg),
            cdr,
        })
    }

    /// Topic of the message.
    pub fn topic(&self) -> &str {
        &self.channel.topic
    }

    /// Producer of the message.
    pub fn producer(&self) -> &str {
        &self.channel.producer
    }
}

/// Where a popped message came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Source {
    /// An input (driver, `/clock`, recorded input channel).
    Input,
    /// Output of stage `i` of the pipeline.
    Stage(usize),
}

/// A message taken from the queue, after the stages subscribed to it ran.
#[derive(Debug, Clone)]
pub struct Popped {
    /// The message.
    pub envelope: Envelope,
    /// Its source.
    pub source: Source,
}

impl Popped {
    /// True for stage outputs.
    pub fn is_output(&self) -> bool {
        matches!(self.source, Source::Stage(_))
    }
}

struct Queued {
    key: (RobotTime, u32, u64),
    source: Source,
    envelope: Envelope,
}

impl PartialEq for Queued {
    fn eq(&self, other: &Self) -> bool {
        self.key == other.key
    }
}
impl Eq for Queued {}
impl PartialOrd for Queued {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Queued {
    fn cmp(&self, other: &Self) -> Ordering {
        self.key.cmp(&other.key)
    }
}

struct Slot {
    stage: Box<dyn Stage + Send>,
    name: String,
    /// Output channels by topic.
    channels: BTreeMap<String, Arc<Channel>>,
    disabled: bool,
    errors: u64,
    inputs_seen: u64,
}

impl Slot {
    fn channel(&mut self, topic: &str, type_name: &str) -> Arc<Channel> {
        if let Some(c) = self.channels.get(topic)
            && c.type_name == type_name
        {
            return Arc::clone(c);
        }
        let c = Channel::known(topic, &self.name, type_name);
        self.channels.insert(topic.to_owned(), Arc::clone(&c));
        c
    }
}

/// Per-stage counters, for summaries.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StageStats {
    /// Stage name.
    pub name: String,
    /// Inputs delivered.
    pub inputs: u64,
    /// Errors logged to `/rosout`.
    pub errors: u64,
    /// True once the stage failed and was stopped.
    pub disabled: bool,
}

/// The runner: stages, subscriptions and the merge queue. See the module docs.
pub struct Runner {
    slots: Vec<Slot>,
    subscribers: BTreeMap<String, Vec<usize>>,
    queue: BinaryHeap<Reverse<Queued>>,
    next_input_seq: u64,
    next_output_seq: u64,
}

impl std::fmt::Debug for Runner {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Runner")
            .field(
                "stages",
                &self.slots.iter().map(|s| &s.name).collect::<Vec<_>>(),
            )
            .field("queued", &self.queue.len())
            .finish_non_exhaustive()
    }
}

impl Runner {
    /// A runner over `stages` (pipeline order = rank order).
    ///
    /// # Errors
    /// [`RunnerError::DuplicateStage`] when two stages share a name.
    pub fn new(stages: Vec<Box<dyn Stage + Send>>) -> Result<Self, RunnerError> {
        let mut slots: Vec<Slot> = Vec::with_capacity(stages.len());
        let mut subscribers: BTreeMap<String, Vec<usize>> = BTreeMap::new();
        for (i, stage) in stages.into_iter().enumerate() {
            let name = stage.name().to_owned();
            if let Some(first) = slots.iter().position(|s| s.name == name) {
                return Err(RunnerError::DuplicateStage {
                    name,
                    first,
                    second: i,
                });
            }
            for topic in stage.inputs() {
                if topic.starts_with(msgs::topics::SIM_PREFIX) {
                    return Err(RunnerError::TruthInput { stage: name, topic });
                }
                let subs = subscribers.entry(topic).or_default();
                if !subs.contains(&i) {
                    subs.push(i);
                }
            }
            let mut slot = Slot {
                stage,
                name,
                channels: BTreeMap::new(),
                disabled: false,
                errors: 0,
                inputs_seen: 0,
            };
            for (topic, type_name) in slot.stage.outputs() {
                let c = Channel::known(&topic, &slot.name, type_name);
                slot.channels.insert(topic, c);
            }
            slots.push(slot);
        }
        Ok(Self {
            slots,
            subscribers,
            queue: BinaryHeap::new(),
            next_input_seq: 0,
            next_output_seq: 0,
        })
    }

    /// Names of the pipeline's stages, in order.
    pub fn stage_names(&self) -> Vec<String> {
        self.slots.iter().map(|s| s.name.clone()).collect()
    }

    /// True if `producer` is a stage of this pipeline (its channels are outputs).
    pub fn is_stage(&self, producer: &str) -> bool {
        self.slots.iter().any(|s| s.name == producer)
    }

    /// Per-stage counters.
    pub fn stats(&self) -> Vec<StageStats> {
        self.slots
            .iter()
            .map(|s| StageStats {
                name: s.name.clone(),
                inputs: s.inputs_seen,
                errors: s.errors,
                disabled: s.disabled,
            })
            .collect()
    }

    /// Queues an input (rank 0 for `/clock`, else 1; sequence = push order).
    pub fn push_input(&mut self, envelope: Envelope) {
        let rank = if envelope.channel.topic == msgs::topics::CLOCK {
            RANK_CLOCK
        } else {
            RANK_INPUT
        };
        let seq = self.next_input_seq;
        self.next_input_seq += 1;
        self.queue.push(Reverse(Queued {
            key: (envelope.log_time, rank, seq),
            source: Source::Input,
            envelope,
        }));
    }

    /// Log time of the next entry, if any.
    pub fn peek_time(&self) -> Option<RobotTime> {
        self.queue.peek().map(|Reverse(q)| q.key.0)
    }

    /// Number of queued entries.
    pub fn queued(&self) -> usize {
        self.queue.len()
    }

    /// Drops every queued entry later than `t` (the end of a run).
    pub fn discard_after(&mut self, t: RobotTime) -> usize {
        let before = self.queue.len();
        let kept: Vec<_> = std::mem::take(&mut self.queue)
            .into_iter()
            .filter(|Reverse(q)| q.key.0 <= t)
            .collect();
        self.queue = kept.into_iter().collect();
        before - self.queue.len()
    }

    /// Pops the next entry, runs the stages subscribed to its topic and queues their
    /// outputs. `None` when the queue is empty.
    ///
    /// # Errors
    /// [`RunnerError::Encode`] when an output cannot be encoded.
    pub fn pop(&mut self) -> Result<Option<Popped>, RunnerError> {
        let Some(Reverse(q)) = self.queue.pop() else {
            return Ok(None);
        };
        let producer_idx = match q.source {
            Source::Stage(i) => Some(i),
            Source::Input => None,
        };
        if let Some(msg) = &q.envelope.msg {
            let subs = self
                .subscribers
                .get(q.envelope.channel.topic.as_str())
                .cloned()
                .unwrap_or_default();
            for idx in subs {
                if Some(idx) == producer_idx {
                    continue;
                }
                self.deliver(idx, q.envelope.log_time, &q.envelope.channel.topic, msg)?;
            }
        }
        Ok(Some(Popped {
            envelope: q.envelope,
            source: q.source,
        }))
    }

    fn deliver(
        &mut self,
        idx: usize,
        log_time: RobotTime,
        topic: &str,
        msg: &Msg,
    ) -> Result<(), RunnerError> {
        let Some(slot) = self.slots.get_mut(idx) else {
            return Ok(());
        };
        if slot.disabled {
            return Ok(());
        }
        slot.inputs_seen += 1;
        let out_time = log_time + slot.stage.latency();
        let outputs = match slot.stage.on_message(log_time, topic, msg) {
            Ok(outputs) => outputs,
            Err(err) => {
                slot.errors += 1;
                if matches!(err, StageError::Failed { .. }) {
                    slot.disabled = true;
                }
                vec![(
                    msgs::topics::ROSOUT.to_owned(),
                    stage_error_log(&slot.name, out_time, &err),
                )]
            }
        };
        let rank = RANK_FIRST_STAGE.saturating_add(u32::try_from(idx).unwrap_or(u32::MAX - 2));
        for (out_topic, out_msg) in outputs {
            let channel = slot.channel(&out_topic, out_msg.type_name());
            let type_name = out_msg.type_name();
            let env = Envelope::encode(channel, out_time, out_time, out_msg).map_err(|source| {
                RunnerError::Encode {
                    stage: slot.name.clone(),
                    topic: out_topic.clone(),
                    type_name,
                    log_time: out_time,
                    source,
                }
            })?;
            let seq = self.next_output_seq;
            self.next_output_seq += 1;
            self.queue.push(Reverse(Queued {
                key: (out_time, rank, seq),
                source: Source::Stage(idx),
                envelope: env,
            }));
        }
        Ok(())
    }
}

/// A `/rosout` line at `log_time` from `name`.
pub fn rosout(name: &str, log_time: RobotTime, level: u8, text: String) -> Msg {
    Msg::Log(Log::line(
        name,
        log_time.to_ros().unwrap_or_default(),
        level,
        text,
    ))
}

fn stage_error_log(name: &str, log_time: RobotTime, err: &StageError) -> Msg {
    rosout(name, log_time, Log::ERROR, err.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;
    use msgs::RobotDuration;
    use msgs::std_msgs::Float64;

    /// Doubles `/a` onto `/b` after 5 ms; errors on negative input.
    struct Doubler;
    impl Stage for Doubler {
        fn name(&self) -> &str {
            "doubler"
        }
        fn inputs(&self) -> Vec<String> {
            vec!["/a".into()]
        }
        fn outputs(&self) -> Vec<(String, &'static str)> {
            vec![("/b".into(), "std_msgs/msg/Float64")]
        }
        fn latency(&self) -> RobotDuration {
            RobotDuration::from_millis(5)
        }
        fn on_message(
            &mut self,
            log_time: RobotTime,
            topic: &str,
            msg: &Msg,
        ) -> Result<Vec<(String, Msg)>, StageError> {
            let Some(v) = msg.get::<Float64>() else {
                return Ok(vec![]);
            };
            if v.data < 0.0 {
                return Err(StageError::InvalidInput {
                    stage: "doubler".into(),
                    topic: topic.into(),
                    log_time,
                    reason: "negative".into(),
                });
            }
            Ok(vec![(
                "/b".into(),
                Msg::Float64(Float64 { data: 2.0 * v.data }),
            )])
        }
    }

    /// Adds one to `/b` onto `/c` with no latency.
    struct PlusOne;
    impl Stage for PlusOne {
        fn name(&self) -> &str {
            "plus_one"
        }
        fn inputs(&self) -> Vec<String> {
            vec!["/b".into()]
        }
        fn outputs(&self) -> Vec<(String, &'static str)> {
            vec![("/c".into(), "std_msgs/msg/Float64")]
        }
        fn latency(&self) -> RobotDuration {
            RobotDuration::ZERO
        }
        fn on_message(
            &mut self,
            _log_time: RobotTime,
            _topic: &str,
            msg: &Msg,
        ) -> Result<Vec<(String, Msg)>, StageError> {
            let v = msg.get::<Float64>().map_or(0.0, |v| v.data);
            Ok(vec![("/c".into(), Msg::Float64(Float64 { data: v + 1.0 }))])
        }
    }

    fn input(t_ms: u64, v: f64) -> Result<Envelope, msgs::CdrError> {
        Envelope::encode(
            Channel::known("/a", "driver", "std_msgs/msg/Float64"),
            RobotTime::from_millis(t_ms),
            RobotTime::from_millis(t_ms),
            Msg::Float64(Float64 { data: v }),
        )
    }

    #[test]
    fn merge_order_latency_and_chaining() -> Result<(), Box<dyn std::error::Error>> {
        let mut r = Runner::new(vec![Box::new(Doubler), Box::new(PlusOne)])?;
        r.push_input(input(10, 1.0)?);
        r.push_input(input(12, 3.0)?);
        r.push_input(input(20, -1.0)?);
        let mut seen = Vec::new();
        while let Some(p) = r.pop()? {
            seen.push((
                p.envelope.log_time.as_nanos() / 1_000_000,
                p.envelope.channel.topic.clone(),
                p.envelope.producer().to_owned(),
            ));
        }
        let topics: Vec<(u64, &str)> = seen.iter().map(|(t, s, _)| (*t, s.as_str())).collect();
        assert_eq!(
            topics,
            vec![
                (10, "/a"),
                (12, "/a"),
                (15, "/b"),
                (15, "/c"),
                (17, "/b"),
                (17, "/c"),
                (20, "/a"),
                (25, "/rosout"),
            ]
        );
        assert_eq!(seen[7].2, "doubler");
        assert_eq!(r.stats()[0].errors, 1);
        Ok(())
    }

    /// A stage that would peek at the simulator's truth.
    struct Peeker;
    impl Stage for Peeker {
        fn name(&self) -> &str {
            "peeker"
        }
        fn inputs(&self) -> Vec<String> {
            vec![
                msgs::topics::JOINT_STATES.into(),
                msgs::topics::SIM_CAMERA_MOUNT.into(),
            ]
        }
        fn outputs(&self) -> Vec<(String, &'static str)> {
            Vec::new()
        }
        fn latency(&self) -> RobotDuration {
            RobotDuration::ZERO
        }
        fn on_message(
            &mut self,
            _log_time: RobotTime,
            _topic: &str,
            _msg: &Msg,
        ) -> Result<Vec<(String, Msg)>, StageError> {
            Ok(Vec::new())
        }
    }

    #[test]
    fn a_stage_asking_for_sim_truth_is_refused() {
        let err = Runner::new(vec![Box::new(Doubler), Box::new(Peeker)]).err();
        assert!(
            matches!(&err, Some(RunnerError::TruthInput { stage, topic })
                if stage == "peeker" && topic == msgs::topics::SIM_CAMERA_MOUNT),
            "{err:?}"
        );
        let text = err.map(|e| e.to_string()).unwrap_or_default();
        assert!(text.contains("/sim/camera_mount"), "{text}");
    }

    #[test]
    fn duplicate_names_are_rejected() {
        let err = Runner::new(vec![Box::new(Doubler), Box::new(Doubler)]);
        assert!(matches!(
            err,
            Err(RunnerError::DuplicateStage {
                first: 0,
                second: 1,
                ..
            })
        ));
    }

    #[test]
    fn inputs_before_outputs_at_equal_time() -> Result<(), Box<dyn std::error::Error>> {
        let mut r = Runner::new(vec![Box::new(Doubler)])?;
        r.push_input(input(0, 1.0)?);
        let first = r.pop()?;
        assert!(first.is_some_and(|p| !p.is_output()));
        // The /b output is queued at 5 ms; an input at 5 ms pushed later still comes first.
        r.push_input(input(5, 2.0)?);
        let second = r.pop()?;
        assert!(second.is_some_and(|p| p.envelope.channel.topic == "/a"));
        let third = r.pop()?;
        assert!(third.is_some_and(|p| p.is_output()));
        Ok(())
    }
}
