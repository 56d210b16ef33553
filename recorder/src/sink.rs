//! The [`Sink`] trait: where the runner's merged message stream goes (MCAP file, Rerun, ...).
//!
//! A sink receives every message, inputs and stage outputs alike, in merge order, with its
//! channel identity ([`Channel`]: topic, producer, type) and its times. The runner calls
//! [`Sink::flush`] every second of robot clock (so a crash loses at most that much) and
//! [`Sink::finish`] on every exit path.

use std::collections::BTreeMap;
use std::io::{Seek, Write};
use std::sync::Arc;

use crate::mcap_writer::{McapSink, MetadataRecord, WriteError};

/// The identity of one channel: one producer writing one topic with one type.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub struct Channel {
    /// Topic, e.g. `/joint_states`.
    pub topic: String,
    /// Stage or driver name (channel metadata `producer`).
    pub producer: String,
    /// Full ROS type name, e.g. `sensor_msgs/msg/JointState`.
    pub type_name: String,
    /// The `ros2msg` schema text.
    pub schema_text: String,
    /// `offered_qos_profiles` YAML (empty: none).
    pub qos_yaml: String,
}

impl Channel {
    /// A channel of a type msgs knows: schema text from [`msgs::Msg::schema_text`], QoS from
    /// the topic registry (volatile for unknown topics).
    pub fn known(topic: &str, producer: &str, type_name: &str) -> Arc<Self> {
        let qos = msgs::topics::lookup(topic)
            .map_or(msgs::topics::QOS_VOLATILE_YAML, |t| t.offered_qos_profiles);
        Arc::new(Self {
            topic: topic.to_owned(),
            producer: producer.to_owned(),
            type_name: type_name.to_owned(),
            schema_text: msgs::Msg::schema_text(type_name).unwrap_or_default(),
            qos_yaml: qos.to_owned(),
        })
    }
}

/// One message as a sink sees it.
#[derive(Debug, Clone, Copy)]
pub struct SinkMessage<'a> {
    /// Its channel.
    pub channel: &'a Channel,
    /// Robot-clock log time, ns.
    pub log_time_ns: u64,
    /// Device/driver time, ns.
    pub publish_time_ns: u64,
    /// CDR payload (with encapsulation header).
    pub cdr: &'a [u8],
}

/// Errors of sinks.
#[derive(Debug, thiserror::Error)]
pub enum SinkError {
    /// The MCAP writer failed.
    #[error(transparent)]
    Mcap(#[from] WriteError),
    /// Another sink failed.
    #[error("sink {sink} failed at log_time {log_time_ns} ns: {reason}")]
    Other {
        /// Sink name.
        sink: String,
        /// Log time of the message being written.
        log_time_ns: u64,
        /// What happened.
        reason: String,
    },
}

/// A consumer of the merged message stream.
pub trait Sink: Send {
    /// Writes one message.
    ///
    /// # Errors
    /// The sink's I/O errors.
    fn write(&mut self, msg: &SinkMessage<'_>) -> Result<(), SinkError>;

    /// Writes a metadata record (default: ignored).
    ///
    /// # Errors
    /// The sink's I/O errors.
    fn write_metadata(&mut self, _record: &MetadataRecord) -> Result<(), SinkError> {
        Ok(())
    }

    /// Stores an attachment (default: ignored).
    ///
    /// # Errors
    /// The sink's I/O errors.
    fn attach(
        &mut self,
        _name: &str,
        _media_type: &str,
        _log_time_ns: u64,
        _data: &[u8],
    ) -> Result<(), SinkError> {
        Ok(())
    }

    /// Makes everything written so far durable; called every second of robot clock.
    ///
    /// # Errors
    /// The sink's I/O errors.
    fn flush(&mut self) -> Result<(), SinkError>;

    /// Ends the output (MCAP: summary and footer). Called on every exit path.
    ///
    /// # Errors
    /// The sink's I/O errors.
    fn finish(self: Box<Self>) -> Result<(), SinkError>;
}

/// [`McapSink`] as a [`Sink`]: channels added on first use, per-channel sequence numbers
/// 0, 1, 2, ... in write order.
pub struct McapStreamSink<W: Write + Seek + Send> {
    inner: McapSink<W>,
    /// topic -> producer -> (channel id, next sequence).
    ids: BTreeMap<String, BTreeMap<String, (u16, u32)>>,
}

impl<W: Write + Seek + Send> McapStreamSink<W> {
    /// Wraps an MCAP writer.
    pub fn new(inner: McapSink<W>) -> Self {
        Self {
            inner,
            ids: BTreeMap::new(),
        }
    }

    /// Messages written so far.
    pub fn message_count(&self) -> u64 {
        self.inner.message_count()
    }

    /// Ends the file and returns the output (e.g. an in-memory `Cursor`).
    ///
    /// # Errors
    /// See [`McapSink::finish_into_inner`].
    pub fn finish_into_inner(self) -> Result<W, WriteError> {
        self.inner.finish_into_inner().map(|(_, out)| out)
    }
}

impl<W: Write + Seek + Send> std::fmt::Debug for McapStreamSink<W> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("McapStreamSink")
            .field("inner", &self.inner)
            .finish_non_exhaustive()
    }
}

impl<W: Write + Seek + Send> Sink for McapStreamSink<W> {
    fn write(&mut self, msg: &SinkMessage<'_>) -> Result<(), SinkError> {
        let ch = msg.channel;
        let entry = self
            .ids
            .get_mut(ch.topic.as_str())
            .and_then(|m| m.get_mut(ch.producer.as_str()));
        let (id, seq) = match entry {
            Some(e) => {
                let out = *e;
                e.1 = e.1.wrapping_add(1);
                out
            }
            None => {
                let id = self.inner.channel_id(
                    &ch.topic,
                    &ch.producer,
                    &ch.type_name,
                    &ch.schema_text,
                    &ch.qos_yaml,
                )?;
                self.ids
                    .entry(ch.topic.clone())
                    .or_default()
                    .insert(ch.producer.clone(), (id, 1));
                (id, 0)
            }
        };
        self.inner
            .write_to_channel(id, msg.log_time_ns, msg.publish_time_ns, seq, msg.cdr)?;
        Ok(())
    }

    fn write_metadata(&mut self, record: &MetadataRecord) -> Result<(), SinkError> {
        Ok(self.inner.write_metadata(record)?)
    }

    fn attach(
        &mut self,
        name: &str,
        media_type: &str,
        log_time_ns: u64,
        data: &[u8],
    ) -> Result<(), SinkError> {
        Ok(self.inner.attach(name, media_type, log_time_ns, data)?)
    }

    fn flush(&mut self) -> Result<(), SinkError> {
        Ok(self.inner.flush()?)
    }

    fn finish(self: Box<Self>) -> Result<(), SinkError> {
        self.inner.finish()?;
        Ok(())
    }
}

/// One message kept by a [`MemorySink`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StoredMessage {
    /// Its channel.
    pub channel: Arc<Channel>,
    /// Log time, ns.
    pub log_time_ns: u64,
    /// Publish time, ns.
    pub publish_time_ns: u64,
    /// CDR payload.
    pub cdr: Vec<u8>,
}

/// A sink keeping every message in memory (tests, small what-if runs). Shares its store, so a
/// clone kept by the caller sees what the runner wrote.
#[derive(Debug, Clone, Default)]
pub struct MemorySink {
    store: Arc<std::sync::Mutex<Vec<StoredMessage>>>,
    flushes: Arc<std::sync::atomic::AtomicU64>,
}

impl MemorySink {
    /// An empty store.
    pub fn new() -> Self {
        Self::default()
    }

    /// A copy of everything written so far.
    pub fn messages(&self) -> Vec<StoredMessage> {
        match self.store.lock() {
            Ok(g) => g.clone(),
            Err(poisoned) => poisoned.into_inner().clone(),
        }
    }

    /// How many times [`Sink::flush`] was called.
    pub fn flush_count(&self) -> u64 {
        self.flushes.load(std::sync::atomic::Ordering::Relaxed)
    }
}

impl Sink for MemorySink {
    fn write(&mut self, msg: &SinkMessage<'_>) -> Result<(), SinkError> {
        let stored = StoredMessage {
            channel: Arc::new(msg.channel.clone()),
            log_time_ns: msg.log_time_ns,
            publish_time_ns: msg.publish_time_ns,
            cdr: msg.cdr.to_vec(),
        };
        match self.store.lock() {
            Ok(mut g) => g.push(stored),
            Err(poisoned) => poisoned.into_inner().push(stored),
        }
        Ok(())
    }

    fn flush(&mut self) -> Result<(), SinkError> {
        self.flushes
            .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        Ok(())
    }

    fn finish(self: Box<Self>) -> Result<(), SinkError> {
        Ok(())
    }
}
