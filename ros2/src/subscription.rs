//! [`Subscription`]: takes raw CDR samples from one ROS topic, stamps their arrival, counts
//! them and the samples lost on the way.
//!
//! # Lost samples
//!
//! Every DDS writer numbers its samples 1, 2, 3, ... (RTPS sequence numbers). A jump from `n`
//! to `m > n + 1` from the same writer means `m - n - 1` samples were lost: dropped on the
//! wire (best effort), or overwritten in this reader's keep-last history because they were not
//! taken in time. The first sample seen from a writer starts its count (a late joiner has not
//! lost what was sent before it matched). Reliable writers announce samples they no longer
//! have with GAP messages; those show up here as jumps too.

use std::collections::BTreeMap;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use rustdds::mio1::{Events, Interest, Poll, Token};
use rustdds::no_key::DataReader;

use crate::error::Ros2Error;
use crate::graph::LocalEndpoints;
use crate::publisher::ns_from_timestamp;
use crate::raw::RawCdr;

/// Longest single wait inside [`Subscription::recv_timeout`] before the reader is checked
/// again, so a missed wake-up costs at most this much latency.
const POLL_SLICE: Duration = Duration::from_millis(50);

/// One message as it arrived.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Received {
    /// The ROS topic (`/joint_states`).
    pub topic: Arc<str>,
    /// The payload: XCDR1 with its 4-byte encapsulation header (`msgs::Msg::decode` reads it).
    pub cdr: Vec<u8>,
    /// The writer's source timestamp (ns since the Unix epoch), when the sample carried one.
    pub source_timestamp_ns: Option<i64>,
    /// When this process took it from DDS.
    pub received_at: Instant,
}

/// Counters of one subscription, shared with any thread ([`Subscription::counters`]).
#[derive(Debug, Default)]
pub struct TopicCounters {
    received: AtomicU64,
    received_bytes: AtomicU64,
    lost: AtomicU64,
}

impl TopicCounters {
    /// Samples taken.
    pub fn received(&self) -> u64 {
        self.received.load(Ordering::Relaxed)
    }

    /// Payload bytes taken (headers included).
    pub fn received_bytes(&self) -> u64 {
        self.received_bytes.load(Ordering::Relaxed)
    }

    /// Samples detected as lost (sequence-number gaps, see the module docs).
    pub fn lost(&self) -> u64 {
        self.lost.load(Ordering::Relaxed)
    }
}

/// A DDS reader of raw CDR on one ROS topic. Dropping it removes the reader from the graph.
pub struct Subscription {
    pub(crate) topic: Arc<str>,
    pub(crate) reader: DataReader<Vec<u8>, RawCdr>,
    pub(crate) poll: Poll,
    pub(crate) events: Events,
    pub(crate) counters: Arc<TopicCounters>,
    /// Last sequence number seen per writer GUID.
    pub(crate) last_seq: BTreeMap<[u8; 16], i64>,
    pub(crate) local: LocalEndpoints,
    pub(crate) guid: [u8; 16],
    /// The GUID prefix of this node's participant: samples of its own writers are skipped
    /// when `ignore_local` is set.
    pub(crate) participant_prefix: [u8; 12],
    pub(crate) ignore_local: bool,
}

impl std::fmt::Debug for Subscription {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Subscription")
            .field("topic", &self.topic)
            .field("counters", &self.counters)
            .finish()
    }
}

/// The token the reader is registered under in its own poll.
pub(crate) const READER_TOKEN: Token = Token(0);

impl Subscription {
    pub(crate) fn register(
        topic: Arc<str>,
        mut reader: DataReader<Vec<u8>, RawCdr>,
        local: LocalEndpoints,
        guid: [u8; 16],
        participant_prefix: [u8; 12],
    ) -> Result<Subscription, Ros2Error> {
        let poll_err = |source| Ros2Error::Poll {
            topic: topic.to_string(),
            source,
        };
        let poll = Poll::new().map_err(poll_err)?;
        poll.registry()
            .register(&mut reader, READER_TOKEN, Interest::READABLE)
            .map_err(poll_err)?;
        Ok(Subscription {
            topic,
            reader,
            poll,
            events: Events::with_capacity(4),
            counters: Arc::default(),
            last_seq: BTreeMap::new(),
            local,
            guid,
            participant_prefix,
            ignore_local: false,
        })
    }

    /// Skips samples written by this node's own writers (rclcpp's
    /// `ignore_local_publications`): a node that subscribes to a topic it also publishes,
    /// such as `/tf`, then receives only the others' messages. Off by default.
    pub fn set_ignore_local(&mut self, ignore: bool) {
        self.ignore_local = ignore;
    }

    /// The ROS topic.
    pub fn topic(&self) -> &str {
        &self.topic
    }

    /// The counters, to read from another thread while this one receives.
    pub fn counters(&self) -> Arc<TopicCounters> {
        Arc::clone(&self.counters)
    }

    /// The reader's GUID (as in [`crate::Endpoint::guid`]).
    pub fn guid(&self) -> [u8; 16] {
        self.guid
    }

    /// The next sample if one is waiting; never blocks.
    ///
    /// # Errors
    /// [`Ros2Error::Read`] when RustDDS fails to take a sample.
    pub fn try_recv(&mut self) -> Result<Option<Received>, Ros2Error> {
        let (sample, identity) = loop {
            let sample = self
                .reader
                .take_next_sample()
                .map_err(|e| Ros2Error::Read {
                    topic: self.topic.to_string(),
                    reason: e.to_string(),
                })?;
            let Some(sample) = sample else {
                return Ok(None);
            };
            let identity = sample.sample_info().sample_identity();
            let own = identity.writer_guid.to_bytes()[..12] == self.participant_prefix;
            if !(self.ignore_local && own) {
                break (sample, identity);
            }
        };
        let received_at = Instant::now();
        let info = sample.sample_info();
        let source_timestamp_ns = info.source_timestamp().and_then(ns_from_timestamp);
        self.count_gap(
            identity.writer_guid.to_bytes(),
            i64::from(identity.sequence_number),
        );
        let cdr = sample.into_value();
        self.counters.received.fetch_add(1, Ordering::Relaxed);
        self.counters
            .received_bytes
            .fetch_add(cdr.len() as u64, Ordering::Relaxed);
        Ok(Some(Received {
            topic: Arc::clone(&self.topic),
            cdr,
            source_timestamp_ns,
            received_at,
        }))
    }

    /// The next sample, waiting up to `timeout`; `None` when none arrived in time.
    ///
    /// # Errors
    /// [`Ros2Error::Read`], [`Ros2Error::Poll`].
    pub fn recv_timeout(&mut self, timeout: Duration) -> Result<Option<Received>, Ros2Error> {
        let deadline = Instant::now() + timeout;
        loop {
            if let Some(r) = self.try_recv()? {
                return Ok(Some(r));
            }
            let now = Instant::now();
            if now >= deadline {
                return Ok(None);
            }
            let wait = (deadline - now).min(POLL_SLICE);
            match self.poll.poll(&mut self.events, Some(wait)) {
                Ok(()) => {}
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(source) => {
                    return Err(Ros2Error::Poll {
                        topic: self.topic.to_string(),
                        source,
                    });
                }
            }
        }
    }

    /// Updates the lost count with the sequence number `seq` from `writer`.
    fn count_gap(&mut self, writer: [u8; 16], seq: i64) {
        let lost = gap(self.last_seq.get(&writer).copied(), seq);
        if lost > 0 {
            self.counters.lost.fetch_add(lost, Ordering::Relaxed);
        }
        let last = self.last_seq.entry(writer).or_insert(seq);
        *last = (*last).max(seq);
    }
}

/// Samples missing between the last sequence number seen and `seq` (0 for the first sample,
/// a repeat or an older one).
fn gap(last: Option<i64>, seq: i64) -> u64 {
    match last {
        Some(last) if seq > last + 1 => u64::try_from(seq - last - 1).unwrap_or(0),
        _ => 0,
    }
}

impl Drop for Subscription {
    fn drop(&mut self) {
        self.local.remove(&self.guid);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gaps_count_the_missing_sequence_numbers() {
        assert_eq!(gap(None, 17), 0);
        assert_eq!(gap(Some(1), 2), 0);
        assert_eq!(gap(Some(1), 5), 3);
        assert_eq!(gap(Some(5), 5), 0);
        assert_eq!(gap(Some(5), 3), 0);
    }
}
