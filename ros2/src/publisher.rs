//! [`Publisher`]: writes CDR payloads (encapsulation header included) to one ROS topic.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use rustdds::bytes::Bytes;
use rustdds::no_key::DataWriter;
use rustdds::{RTPSEntity, Timestamp};

use crate::error::Ros2Error;
use crate::graph::LocalEndpoints;
use crate::raw::RawCdr;

/// A DDS writer of raw CDR on one ROS topic. Dropping it removes the writer from the graph.
pub struct Publisher {
    pub(crate) topic: String,
    pub(crate) writer: DataWriter<Bytes, RawCdr>,
    pub(crate) local: LocalEndpoints,
    pub(crate) guid: [u8; 16],
    pub(crate) published: Arc<AtomicU64>,
}

impl std::fmt::Debug for Publisher {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Publisher")
            .field("topic", &self.topic)
            .field("published", &self.published())
            .finish()
    }
}

impl Publisher {
    /// The ROS topic.
    pub fn topic(&self) -> &str {
        &self.topic
    }

    /// Publishes one message: `cdr` is XCDR1 little-endian with its 4-byte encapsulation
    /// header, as `msgs::Msg::encode` writes it. The source timestamp is the wall clock now.
    ///
    /// # Errors
    /// [`Ros2Error::PayloadTooShort`], [`Ros2Error::UnsupportedEncapsulation`] (anything but
    /// `00 01`), [`Ros2Error::Write`] (a reliable writer whose readers did not acknowledge
    /// within `qos::MAX_BLOCKING_TIME_MS`).
    pub fn publish(&self, cdr: &[u8]) -> Result<(), Ros2Error> {
        self.publish_bytes(Bytes::copy_from_slice(cdr), None)
    }

    /// Like [`Publisher::publish`], with an explicit source timestamp (ns since the Unix
    /// epoch), e.g. the simulator's clock.
    ///
    /// # Errors
    /// See [`Publisher::publish`].
    pub fn publish_at(&self, cdr: &[u8], source_timestamp_ns: i64) -> Result<(), Ros2Error> {
        self.publish_bytes(Bytes::copy_from_slice(cdr), Some(source_timestamp_ns))
    }

    /// Like [`Publisher::publish_at`] without copying the payload (`None`: now).
    ///
    /// # Errors
    /// See [`Publisher::publish`].
    pub fn publish_bytes(
        &self,
        cdr: Bytes,
        source_timestamp_ns: Option<i64>,
    ) -> Result<(), Ros2Error> {
        let header = cdr.get(..msgs::cdr::HEADER_LEN);
        let Some(&[b0, b1, _, _]) = header else {
            return Err(Ros2Error::PayloadTooShort {
                topic: self.topic.clone(),
                len: cdr.len(),
            });
        };
        if [b0, b1] != [msgs::cdr::HEADER_CDR_LE[0], msgs::cdr::HEADER_CDR_LE[1]] {
            return Err(Ros2Error::UnsupportedEncapsulation {
                topic: self.topic.clone(),
                b0,
                b1,
            });
        }
        let stamp = source_timestamp_ns.map_or_else(Timestamp::now, timestamp_from_ns);
        self.writer
            .write(cdr, Some(stamp))
            .map_err(|e| Ros2Error::Write {
                topic: self.topic.clone(),
                reason: e.to_string(),
            })?;
        self.published.fetch_add(1, Ordering::Relaxed);
        Ok(())
    }

    /// Messages published so far.
    pub fn published(&self) -> u64 {
        self.published.load(Ordering::Relaxed)
    }

    /// The writer's GUID (as in [`crate::Endpoint::guid`]).
    pub fn guid(&self) -> [u8; 16] {
        self.writer.guid().to_bytes()
    }
}

impl Drop for Publisher {
    fn drop(&mut self) {
        self.local.remove(&self.guid);
    }
}

/// RTPS time (seconds, 2^-32 fractions) of ns since the Unix epoch; before 1970 is clamped
/// to the epoch.
pub(crate) fn timestamp_from_ns(ns: i64) -> Timestamp {
    let ns = u64::try_from(ns).unwrap_or(0);
    let secs = ns / 1_000_000_000;
    let frac = ((ns % 1_000_000_000) << 32) / 1_000_000_000;
    Timestamp::from_ticks((secs << 32) | frac)
}

/// ns since the Unix epoch of an RTPS time, `None` for the reserved invalid/infinite values.
pub(crate) fn ns_from_timestamp(t: Timestamp) -> Option<i64> {
    if t == Timestamp::INVALID || t == Timestamp::INFINITE {
        return None;
    }
    let ticks = t.to_ticks();
    let secs = ticks >> 32;
    // Round to nearest: ns -> ticks truncates, so the way back must round to be exact.
    let frac_ns = ((ticks & 0xffff_ffff) * 1_000_000_000 + (1 << 31)) >> 32;
    i64::try_from(secs * 1_000_000_000 + frac_ns).ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn timestamps_round_trip_to_the_nanosecond() {
        for ns in [
            0_i64,
            1,
            999_999_999,
            1_000_000_000,
            1_796_306_407_563_963_417,
            4_000_000_000_999_999_999,
        ] {
            assert_eq!(ns_from_timestamp(timestamp_from_ns(ns)), Some(ns), "{ns}");
        }
        assert_eq!(ns_from_timestamp(timestamp_from_ns(-5)), Some(0));
        assert_eq!(ns_from_timestamp(Timestamp::INVALID), None);
    }
}
