//! Pushing sources of the live runtime: [`LiveSource`] (a device or transport that blocks on
//! its own thread and pushes what arrives), [`Feed`] (its handle: the robot clock, the
//! bounded channel into the runtime, the per-topic counters) and [`InputCounts`].
//!
//! A source never blocks the runtime: [`Feed::push`] is a `try_send`; when the channel is
//! full the message is dropped and counted for its topic (live inputs cannot be
//! back-pressured). The runtime reports every counter on `/rosout` once per second and in the
//! recording's [`INPUTS_RECORD`] metadata record at the end.

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, PoisonError};

use msgs::RobotTime;
use msgs::drivers::DriverError;

use crate::live::clock::LiveClock;
use crate::mcap_writer::MetadataRecord;
use crate::runner::Envelope;

/// Name of the metadata record with the per-topic input counters of a live run.
pub const INPUTS_RECORD: &str = "live_inputs";

/// What happened to one topic's inputs in a live run.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct TopicCount {
    /// Messages handed to the runtime.
    pub received: u64,
    /// Messages the transport reports lost before they arrived (sequence gaps).
    pub lost: u64,
    /// Messages dropped because the runtime's input channel was full.
    pub dropped: u64,
    /// Messages that arrived after the runtime had already processed their robot time:
    /// recorded, stamped just after the last message processed (the recording is the truth).
    pub late: u64,
    /// Messages that could not be decoded or converted (recorded undecoded, given to no
    /// stage).
    pub undecodable: u64,
}

impl TopicCount {
    /// The problems only (everything but `received`).
    #[must_use]
    pub fn problems(&self) -> u64 {
        self.lost + self.dropped + self.late + self.undecodable
    }

    /// `received=.. lost=.. dropped=.. late=.. undecodable=..`.
    #[must_use]
    pub fn text(&self) -> String {
        format!(
            "received={} lost={} dropped={} late={} undecodable={}",
            self.received, self.lost, self.dropped, self.late, self.undecodable
        )
    }
}

/// Per-topic input counters, shared by the sources and the runtime.
#[derive(Debug, Clone, Default)]
pub struct InputCounts(Arc<Mutex<BTreeMap<String, TopicCount>>>);

impl InputCounts {
    /// Applies `f` to `topic`'s counters.
    pub fn update(&self, topic: &str, f: impl FnOnce(&mut TopicCount)) {
        let mut map = self.0.lock().unwrap_or_else(PoisonError::into_inner);
        match map.get_mut(topic) {
            Some(c) => f(c),
            None => {
                let mut c = TopicCount::default();
                f(&mut c);
                map.insert(topic.to_owned(), c);
            }
        }
    }

    /// A copy of every topic's counters, by topic.
    #[must_use]
    pub fn snapshot(&self) -> BTreeMap<String, TopicCount> {
        self.0
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .clone()
    }

    /// The [`INPUTS_RECORD`] metadata record: one entry per topic.
    #[must_use]
    pub fn record(&self) -> MetadataRecord {
        let mut r = MetadataRecord::new(INPUTS_RECORD);
        for (topic, c) in self.snapshot() {
            r.entries.insert(topic, c.text());
        }
        r
    }
}

/// Items on the runtime's input channel.
#[derive(Debug)]
pub(crate) enum Incoming {
    /// A message; its `log_time` is the robot time of arrival ([`Feed::now`]) and its bytes
    /// are exactly what will be recorded.
    Input(Box<Envelope>),
    /// A source failed.
    Failed {
        /// Source name.
        source: String,
        /// Why.
        error: DriverError,
    },
}

/// What became of a pushed message.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pushed {
    /// Queued for the runner.
    Queued,
    /// Dropped: the input channel was full (counted).
    Dropped,
    /// The runtime is gone: the source should return.
    Closed,
}

/// A source's handle on the runtime (module docs).
#[derive(Debug, Clone)]
pub struct Feed {
    pub(crate) tx: tokio::sync::mpsc::Sender<Incoming>,
    pub(crate) clock: LiveClock,
    pub(crate) stop: Arc<AtomicBool>,
    pub(crate) counts: InputCounts,
}

impl Feed {
    /// The robot time now (stamp arrivals with it).
    #[must_use]
    pub fn now(&self) -> RobotTime {
        self.clock.now()
    }

    /// The run's clock (a source of the graph's `/clock` advances it).
    #[must_use]
    pub fn clock(&self) -> &LiveClock {
        &self.clock
    }

    /// True once the run is over: the source should return.
    #[must_use]
    pub fn stopped(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }

    /// Hands a message (`log_time` = its arrival, [`Feed::now`]) to the runtime without
    /// blocking; a full channel drops it (counted for its topic).
    pub fn push(&self, envelope: Envelope) -> Pushed {
        let topic = envelope.channel.topic.clone();
        match self.tx.try_send(Incoming::Input(Box::new(envelope))) {
            Ok(()) => {
                self.counts.update(&topic, |c| c.received += 1);
                Pushed::Queued
            }
            Err(tokio::sync::mpsc::error::TrySendError::Full(_)) => {
                self.counts.update(&topic, |c| c.dropped += 1);
                Pushed::Dropped
            }
            Err(tokio::sync::mpsc::error::TrySendError::Closed(_)) => Pushed::Closed,
        }
    }

    /// The counters sources update (lost, undecodable).
    #[must_use]
    pub fn counts(&self) -> &InputCounts {
        &self.counts
    }

    /// Reports a failure of source `source`: the runtime stops and finishes the file.
    pub fn fail(&self, source: &str, error: DriverError) {
        let _closed = self.tx.try_send(Incoming::Failed {
            source: source.to_owned(),
            error,
        });
    }
}

/// A source that blocks on its own thread (a DDS reader, a socket) and pushes what arrives.
pub trait LiveSource: Send + 'static {
    /// Name (thread name, error messages).
    fn name(&self) -> &str;

    /// Runs until [`Feed::stopped`], pushing every arrival through `feed`.
    ///
    /// # Errors
    /// A device or transport fault; the runtime stops and finishes the file.
    fn run(self: Box<Self>, feed: Feed) -> Result<(), DriverError>;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counters_accumulate_per_topic_and_make_a_record() {
        let c = InputCounts::default();
        c.update("/a", |t| t.received += 2);
        c.update("/a", |t| t.late += 1);
        c.update("/b", |t| t.lost += 3);
        let snap = c.snapshot();
        assert_eq!(snap.get("/a").map(TopicCount::problems), Some(1));
        assert_eq!(snap.get("/b").map(|t| t.lost), Some(3));
        let r = c.record();
        assert_eq!(r.name, INPUTS_RECORD);
        assert_eq!(
            r.entries.get("/a").map(String::as_str),
            Some("received=2 lost=0 dropped=0 late=1 undecodable=0")
        );
    }
}
