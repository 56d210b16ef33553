//! The simulation scheduler: steps a [`World`] and the [`Runner`] in lockstep on one thread.
//!
//! Each iteration picks the next instant
//!
//! ```text
//! target = min(next /clock tick, queue head, world time + max_world_step, until)
//! ```
//!
//! steps the world to `target` (its messages become inputs, rank 1, in the order the world
//! returns them), queues `/clock` when `target` is a tick (every 100 ms of robot time,
//! producer `scheduler`, rank 0), then pops every queued entry with `log_time <= target`.
//! Stage outputs on command topics ([`COMMAND_TOPICS`]) are delivered to the world at their
//! log_time (the world is never ahead of a queued command, because the queue head bounds
//! `target`); a rejected command becomes a `/rosout` WARN input from `scheduler` 1 us later.
//! Nothing here reads a clock: the same world, seed and stages give the same stream.
//!
//! [`SinkFanout`] writes the stream to sinks and flushes them whenever the log time crosses
//! a whole second of robot clock.

use std::collections::BTreeMap;
use std::sync::Arc;

use msgs::drivers::{DriverError, DriverOutput, World};
use msgs::rcl_interfaces::Log;
use msgs::rosgraph_msgs::Clock;
use msgs::{Msg, RobotDuration, RobotTime};

use crate::mcap_writer::MetadataRecord;
use crate::runner::{Envelope, Popped, Runner, RunnerError, rosout};
use crate::sink::{Channel, Sink, SinkError, SinkMessage};

/// Producer name of `/clock` and of the scheduler's own `/rosout` lines.
pub const SCHEDULER: &str = "scheduler";
/// `/clock` period: 100 ms of robot time.
pub const CLOCK_PERIOD: RobotDuration = RobotDuration::from_millis(100);
/// Sink flush period: 1 s of robot time.
pub const FLUSH_PERIOD: RobotDuration = RobotDuration::from_secs(1);
/// Largest world step between two scheduler iterations.
pub const MAX_WORLD_STEP: RobotDuration = RobotDuration::from_millis(10);
/// Delay of the scheduler's reaction to a rejected command (keeps the feeding rule: a new
/// input is always later than everything already popped).
pub const REACTION_DELAY: RobotDuration = RobotDuration::from_micros(1);
/// Topics whose stage outputs are commands delivered to the world (ARCHITECTURE.md section 3).
pub const COMMAND_TOPICS: [&str; 6] = msgs::topics::COMMANDS;

/// True for command topics.
pub fn is_command_topic(topic: &str) -> bool {
    COMMAND_TOPICS.contains(&topic)
}

/// Errors of the scheduler.
#[derive(Debug, thiserror::Error)]
pub enum SchedulerError {
    /// The world failed (a device fault, time going backwards).
    #[error("world failed stepping to {target}: {source}")]
    World {
        /// Step target.
        target: RobotTime,
        /// Driver error.
        source: DriverError,
    },
    /// A message could not be encoded.
    #[error("cannot encode {type_name} on {topic} from {producer} at {log_time}: {source}")]
    Encode {
        /// Topic.
        topic: String,
        /// Producer.
        producer: String,
        /// Type.
        type_name: &'static str,
        /// Log time.
        log_time: RobotTime,
        /// Codec error.
        source: msgs::CdrError,
    },
    /// The runner failed.
    #[error(transparent)]
    Runner(#[from] RunnerError),
    /// A sink failed.
    #[error(transparent)]
    Sink(#[from] SinkError),
    /// The run was stopped (Ctrl-C) at this robot time.
    #[error("stopped at {at}")]
    Stopped {
        /// Robot time reached.
        at: RobotTime,
    },
}

/// Counters of a scheduler run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SchedulerStats {
    /// Inputs from the world.
    pub world_messages: u64,
    /// `/clock` messages.
    pub clock_messages: u64,
    /// Stage outputs.
    pub stage_outputs: u64,
    /// Commands delivered to the world.
    pub commands: u64,
    /// Commands the world rejected.
    pub rejected_commands: u64,
}

/// Channels of driver outputs, by producer then topic.
#[derive(Debug, Default)]
pub struct ChannelCache {
    by_producer: BTreeMap<String, BTreeMap<String, Arc<Channel>>>,
}

impl ChannelCache {
    /// The channel of (`topic`, `producer`) for a known type.
    pub fn get(&mut self, topic: &str, producer: &str, type_name: &str) -> Arc<Channel> {
        if let Some(c) = self.by_producer.get(producer).and_then(|m| m.get(topic))
            && c.type_name == type_name
        {
            return Arc::clone(c);
        }
        let c = Channel::known(topic, producer, type_name);
        self.by_producer
            .entry(producer.to_owned())
            .or_default()
            .insert(topic.to_owned(), Arc::clone(&c));
        c
    }

    /// Encodes a driver output into an envelope.
    ///
    /// # Errors
    /// [`SchedulerError::Encode`].
    pub fn envelope(&mut self, out: DriverOutput) -> Result<Envelope, SchedulerError> {
        let channel = self.get(&out.topic, &out.producer, out.msg.type_name());
        let type_name = out.msg.type_name();
        Envelope::encode(channel, out.log_time, out.publish_time, out.msg).map_err(|source| {
            SchedulerError::Encode {
                topic: out.topic,
                producer: out.producer,
                type_name,
                log_time: out.log_time,
                source,
            }
        })
    }
}

/// The lockstep scheduler. See the module docs.
pub struct Scheduler<W: World> {
    world: W,
    runner: Runner,
    channels: ChannelCache,
    clock_channel: Arc<Channel>,
    next_clock: RobotTime,
    world_time: Option<RobotTime>,
    stats: SchedulerStats,
}

impl<W: World> std::fmt::Debug for Scheduler<W> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Scheduler")
            .field("runner", &self.runner)
            .field("world_time", &self.world_time)
            .field("stats", &self.stats)
            .finish_non_exhaustive()
    }
}

impl<W: World> Scheduler<W> {
    /// A scheduler at robot time 0.
    pub fn new(world: W, runner: Runner) -> Self {
        let clock_channel = Channel::known(
            msgs::topics::CLOCK,
            SCHEDULER,
            <Clock as msgs::RosMessage>::TYPE_NAME,
        );
        Self {
            world,
            runner,
            channels: ChannelCache::default(),
            clock_channel,
            next_clock: RobotTime::ZERO,
            world_time: None,
            stats: SchedulerStats::default(),
        }
    }

    /// Counters so far.
    pub fn stats(&self) -> SchedulerStats {
        self.stats
    }

    /// The runner (stage statistics).
    pub fn runner(&self) -> &Runner {
        &self.runner
    }

    /// Robot time the world has been stepped to.
    pub fn world_time(&self) -> Option<RobotTime> {
        self.world_time
    }

    /// Runs until robot time `until` (inclusive), handing every popped message to `out` in
    /// merge order. Can be called repeatedly with increasing `until` (the live runtime paces
    /// it this way); the stream does not depend on how the run is split.
    ///
    /// # Errors
    /// World, encoding, runner errors and whatever `out` returns.
    pub fn advance<F>(&mut self, until: RobotTime, out: &mut F) -> Result<(), SchedulerError>
    where
        F: FnMut(Popped) -> Result<(), SchedulerError>,
    {
        loop {
            let mut target = self.next_clock.min(until);
            if let Some(w) = self.world_time {
                target = target.min(w + MAX_WORLD_STEP);
            }
            if let Some(q) = self.runner.peek_time() {
                target = target.min(q);
            }
            if let Some(w) = self.world_time
                && target < w
            {
                // Everything up to the world's time is already processed.
                target = w;
            }
            if self.world_time.is_none_or(|w| target > w) {
                let outputs = self
                    .world
                    .step_until(target)
                    .map_err(|source| SchedulerError::World { target, source })?;
                for o in outputs {
                    let env = self.channels.envelope(o)?;
                    self.stats.world_messages += 1;
                    self.runner.push_input(env);
                }
                self.world_time = Some(target);
            }
            if self.next_clock <= target {
                let t = self.next_clock;
                let msg = Msg::Clock(Clock {
                    clock: t.to_ros().unwrap_or_default(),
                });
                let env = Envelope::encode(Arc::clone(&self.clock_channel), t, t, msg).map_err(
                    |source| SchedulerError::Encode {
                        topic: msgs::topics::CLOCK.to_owned(),
                        producer: SCHEDULER.to_owned(),
                        type_name: <Clock as msgs::RosMessage>::TYPE_NAME,
                        log_time: t,
                        source,
                    },
                )?;
                self.runner.push_input(env);
                self.stats.clock_messages += 1;
                self.next_clock = t + CLOCK_PERIOD;
            }
            while self.runner.peek_time().is_some_and(|t| t <= target) {
                let Some(popped) = self.runner.pop()? else {
                    break;
                };
                if popped.is_output() {
                    self.stats.stage_outputs += 1;
                    if is_command_topic(popped.envelope.topic()) {
                        self.deliver_command(&popped)?;
                    }
                }
                out(popped)?;
            }
            if target >= until {
                return Ok(());
            }
        }
    }

    fn deliver_command(&mut self, popped: &Popped) -> Result<(), SchedulerError> {
        let env = &popped.envelope;
        let Some(msg) = &env.msg else {
            return Ok(());
        };
        self.stats.commands += 1;
        if let Err(err) = self.world.command(env.log_time, env.topic(), msg) {
            self.stats.rejected_commands += 1;
            let t = env.log_time + REACTION_DELAY;
            let text = format!(
                "command on {} from {} not executed: {err}",
                env.topic(),
                env.producer()
            );
            let log = rosout(SCHEDULER, t, Log::WARN, text);
            let channel = self
                .channels
                .get(msgs::topics::ROSOUT, SCHEDULER, log.type_name());
            let env =
                Envelope::encode(channel, t, t, log).map_err(|source| SchedulerError::Encode {
                    topic: msgs::topics::ROSOUT.to_owned(),
                    producer: SCHEDULER.to_owned(),
                    type_name: <Log as msgs::RosMessage>::TYPE_NAME,
                    log_time: t,
                    source,
                })?;
            self.runner.push_input(env);
        }
        Ok(())
    }
}

/// Writes the stream to several sinks, flushing them every [`FLUSH_PERIOD`] of robot time
/// (before the first message at or after each whole second).
pub struct SinkFanout {
    sinks: Vec<Box<dyn Sink>>,
    next_flush: RobotTime,
    written: u64,
}

impl std::fmt::Debug for SinkFanout {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SinkFanout")
            .field("sinks", &self.sinks.len())
            .field("next_flush", &self.next_flush)
            .field("written", &self.written)
            .finish()
    }
}

impl SinkFanout {
    /// Over `sinks`.
    pub fn new(sinks: Vec<Box<dyn Sink>>) -> Self {
        Self {
            sinks,
            next_flush: RobotTime::ZERO + FLUSH_PERIOD,
            written: 0,
        }
    }

    /// Messages written.
    pub fn written(&self) -> u64 {
        self.written
    }

    /// Writes one message to every sink (flushing first when a second boundary was crossed).
    ///
    /// # Errors
    /// The first sink error.
    pub fn write(
        &mut self,
        channel: &Channel,
        log_time: RobotTime,
        publish_time: RobotTime,
        cdr: &[u8],
    ) -> Result<(), SinkError> {
        if log_time >= self.next_flush {
            for s in &mut self.sinks {
                s.flush()?;
            }
            let period = FLUSH_PERIOD.as_nanos();
            self.next_flush = RobotTime::from_nanos((log_time.as_nanos() / period + 1) * period);
        }
        let m = SinkMessage {
            channel,
            log_time_ns: log_time.as_nanos(),
            publish_time_ns: publish_time.as_nanos(),
            cdr,
        };
        for s in &mut self.sinks {
            s.write(&m)?;
        }
        self.written += 1;
        Ok(())
    }

    /// Writes an envelope.
    ///
    /// # Errors
    /// The first sink error.
    pub fn write_envelope(&mut self, env: &Envelope) -> Result<(), SinkError> {
        self.write(&env.channel, env.log_time, env.publish_time, &env.cdr)
    }

    /// Writes a metadata record to every sink.
    ///
    /// # Errors
    /// The first sink error.
    pub fn write_metadata(&mut self, record: &MetadataRecord) -> Result<(), SinkError> {
        self.sinks
            .iter_mut()
            .try_for_each(|s| s.write_metadata(record))
    }

    /// Stores an attachment in every sink.
    ///
    /// # Errors
    /// The first sink error.
    pub fn attach(
        &mut self,
        name: &str,
        media_type: &str,
        log_time_ns: u64,
        data: &[u8],
    ) -> Result<(), SinkError> {
        self.sinks
            .iter_mut()
            .try_for_each(|s| s.attach(name, media_type, log_time_ns, data))
    }

    /// Flushes every sink now.
    ///
    /// # Errors
    /// The first sink error.
    pub fn flush(&mut self) -> Result<(), SinkError> {
        self.sinks.iter_mut().try_for_each(|s| s.flush())
    }

    /// Finishes every sink (all of them, even after an error); returns the first error.
    ///
    /// # Errors
    /// The first sink error.
    pub fn finish(self) -> Result<(), SinkError> {
        let mut first = Ok(());
        for s in self.sinks {
            let r = s.finish();
            if first.is_ok() {
                first = r;
            }
        }
        first
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sink::MemorySink;
    use crate::stages::{ArmExerciser, JointLimitMonitor};
    use crate::test_world::{TestWorld, TestWorldConfig};
    use scenario::{Params, Reader};

    fn run(
        split_ms: &[u64],
    ) -> Result<(Vec<crate::sink::StoredMessage>, u64), Box<dyn std::error::Error>> {
        let p = Params::new();
        let runner = Runner::new(vec![
            Box::new(ArmExerciser::from_params(&mut Reader::new(&p))?),
            Box::new(JointLimitMonitor::from_params(&mut Reader::new(&p))?),
        ])?;
        let world = TestWorld::new(TestWorldConfig::from_params(3, &mut Reader::new(&p))?);
        let mut sched = Scheduler::new(world, runner);
        let mem = MemorySink::new();
        let mut fan = SinkFanout::new(vec![Box::new(mem.clone())]);
        for &ms in split_ms {
            sched.advance(RobotTime::from_millis(ms), &mut |p: Popped| {
                fan.write_envelope(&p.envelope)?;
                Ok(())
            })?;
        }
        assert!(sched.stats().commands > 0);
        let flushes = mem.flush_count();
        fan.finish()?;
        Ok((mem.messages(), flushes))
    }

    #[test]
    fn split_runs_give_the_same_stream() -> Result<(), Box<dyn std::error::Error>> {
        let (a, fa) = run(&[5000])?;
        let (b, fb) = run(&[7, 1000, 1001, 2500, 4999, 5000])?;
        assert_eq!(a, b);
        assert_eq!(fa, 5);
        assert_eq!(fb, 5);
        // Clock every 100 ms, 0..=5 s.
        let clocks = a.iter().filter(|m| m.channel.topic == "/clock").count();
        assert_eq!(clocks, 51);
        // Merge order: log times never decrease.
        assert!(a.windows(2).all(|w| w[0].log_time_ns <= w[1].log_time_ns));
        // Commands every 2 s from 0.5 s, 10 ms after the clock tick.
        let cmds: Vec<u64> = a
            .iter()
            .filter(|m| m.channel.topic == msgs::topics::ARM_JOINT_TRAJECTORY)
            .map(|m| m.log_time_ns)
            .collect();
        assert_eq!(cmds, vec![510_000_000, 2_510_000_000, 4_510_000_000]);
        Ok(())
    }
}
