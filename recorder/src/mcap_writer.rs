//! The MCAP sink: writes rodlog's log (ARCHITECTURE.md section 3) with the ROS 2 profile.
//!
//! Layout of a file written here (MCAP spec, <https://mcap.dev/spec>):
//!
//! ```text
//! magic | Header(profile "ros2", library "rodlog/<ver> mcap-rust/<ver>")
//!       | Chunk(lz4 | zstd){Schema, Channel, Message...} MessageIndex...   <- one per flush/size
//!       | Metadata | Attachment | ...                                     <- outside chunks
//!       | DataEnd | summary (schemas, channels, statistics, indexes) | Footer | magic
//! ```
//!
//! * one Schema per ROS type: encoding `ros2msg`, data = the `.msg` text with its dependencies;
//! * one Channel per (topic, producer): message encoding `cdr`, metadata
//!   `offered_qos_profiles` (ROS 2 QoS YAML) and `producer=<stage or driver name>`
//!   (ARCHITECTURE.md section 2: inputs and outputs are told apart per channel);
//! * [`McapSink::flush`] ends the open chunk and flushes the OS buffers, so a crash after it loses
//!   nothing written before it (the runner calls it every second of robot clock);
//! * [`McapSink::finish`] writes the summary; it must be called on every exit path. A sink that
//!   is dropped unfinished ends its open chunk and stops without a summary: the file is then
//!   "crashed but recoverable" for `replay`'s linear scan, and no panic happens.
//!
//! Determinism: compression runs single-threaded (zstd's multithreaded frames depend on the
//! worker count) and attachment `create_time` = `log_time` (robot clock), so the same calls give
//! the same bytes.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufWriter, Seek, Write};
use std::path::{Path, PathBuf};

/// MCAP profile of every file rodlog writes.
pub const PROFILE: &str = "ros2";
/// Schema encoding of ROS 2 message definitions (`.msg` text).
pub const SCHEMA_ENCODING: &str = "ros2msg";
/// Message encoding: OMG CDR (XCDR1) with the 4-byte encapsulation header.
pub const MESSAGE_ENCODING: &str = "cdr";
/// Channel-metadata key holding the offered QoS profiles (YAML), as ROS 2 rosbag2 writes it.
pub const QOS_KEY: &str = "offered_qos_profiles";
/// Channel-metadata key naming the stage or driver that wrote the channel (ARCHITECTURE.md section 2).
pub const PRODUCER_KEY: &str = "producer";
/// Default target size of a chunk before compression, in bytes (4 MiB: a few camera frames).
pub const DEFAULT_CHUNK_SIZE_BYTES: u64 = 4 * 1024 * 1024;
/// Names of the metadata records ARCHITECTURE.md section 3 defines.
pub const METADATA_NAMES: [&str; 3] = ["robot_info", "scenario", "build"];

/// The `library` string of the MCAP header: rodlog's and the mcap crate's versions.
pub fn library_string() -> String {
    format!(
        "rodlog/{} {}",
        env!("CARGO_PKG_VERSION"),
        mcap::LIBRARY_IDENTIFIER
    )
}

/// Errors of the MCAP sink. Each names what was being written when it failed.
#[derive(Debug, thiserror::Error)]
pub enum WriteError {
    /// The output file could not be created.
    #[error("cannot create {path}: {source}")]
    Create {
        /// The file that was being created.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// Registering the schema or channel of a topic failed.
    #[error("cannot add channel {topic} (producer {producer}, type {type_name}): {source}")]
    Channel {
        /// Topic of the channel.
        topic: String,
        /// Producer of the channel.
        producer: String,
        /// ROS type name, e.g. `sensor_msgs/msg/Image`.
        type_name: String,
        /// The mcap error.
        source: mcap::McapError,
    },
    /// A message could not be written.
    #[error(
        "cannot write message on {topic} at log_time {log_time_ns} ns ({bytes} bytes): {source}"
    )]
    Message {
        /// Topic of the message.
        topic: String,
        /// Its log time.
        log_time_ns: u64,
        /// Size of its CDR payload.
        bytes: usize,
        /// The mcap error.
        source: mcap::McapError,
    },
    /// A channel id that this sink did not hand out.
    #[error("unknown channel id {channel_id} ({known} channels added)")]
    UnknownChannel {
        /// The id given.
        channel_id: u16,
        /// How many channels exist.
        known: usize,
    },
    /// A metadata record could not be written.
    #[error("cannot write metadata record {name:?}: {source}")]
    Metadata {
        /// Record name.
        name: String,
        /// The mcap error.
        source: mcap::McapError,
    },
    /// An attachment could not be written.
    #[error("cannot write attachment {name:?} ({bytes} bytes): {source}")]
    Attachment {
        /// Attachment name.
        name: String,
        /// Its size.
        bytes: usize,
        /// The mcap error.
        source: mcap::McapError,
    },
    /// Ending the open chunk or flushing the file failed.
    #[error("flush failed after {messages} messages: {source}")]
    Flush {
        /// Messages written so far.
        messages: u64,
        /// The mcap error.
        source: mcap::McapError,
    },
    /// Writing the summary or closing the file failed.
    #[error("finish failed after {messages} messages: {source}")]
    Finish {
        /// Messages written.
        messages: u64,
        /// The mcap error.
        source: mcap::McapError,
    },
    /// A typed message could not be CDR-encoded.
    #[error("cannot encode {type_name} for {topic} at log_time {log_time_ns} ns: {source}")]
    Encode {
        /// Topic of the message.
        topic: String,
        /// Its type.
        type_name: &'static str,
        /// Its log time.
        log_time_ns: u64,
        /// The codec error.
        source: msgs::CdrError,
    },
    /// A (topic, producer) channel already carries another type.
    #[error("channel {topic} (producer {producer}) carries {existing}, cannot write {got} on it")]
    TypeMismatch {
        /// Topic.
        topic: String,
        /// Producer.
        producer: String,
        /// Type of the channel.
        existing: String,
        /// Type of the message.
        got: String,
    },
    /// The buffered output could not be flushed to the file at the end.
    #[error("closing the output failed: {0}")]
    Close(std::io::Error),
}

/// Chunk compression of the sink.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ChunkCompression {
    /// LZ4 frames: fast, the default (and the one the determinism tests use).
    #[default]
    Lz4,
    /// Zstandard: smaller files, slower.
    Zstd,
    /// Chunks stored uncompressed.
    None,
}

impl ChunkCompression {
    /// The chunk `compression` string of the MCAP spec (`""` for none).
    pub fn mcap_name(self) -> &'static str {
        match self {
            Self::Lz4 => "lz4",
            Self::Zstd => "zstd",
            Self::None => "",
        }
    }
}

/// Options of an [`McapSink`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SinkOptions {
    /// Chunk compression. Default: [`ChunkCompression::Lz4`].
    pub compression: ChunkCompression,
    /// Target uncompressed chunk size in bytes: a chunk is closed before the message that
    /// would start past it. Default: [`DEFAULT_CHUNK_SIZE_BYTES`].
    pub chunk_size_bytes: u64,
    /// Compression level (0 = the codec's default). Default: 0.
    pub compression_level: u32,
}

impl Default for SinkOptions {
    fn default() -> Self {
        Self {
            compression: ChunkCompression::Lz4,
            chunk_size_bytes: DEFAULT_CHUNK_SIZE_BYTES,
            compression_level: 0,
        }
    }
}

/// One message for the low-level API: everything MCAP stores about it, payload borrowed.
#[derive(Debug, Clone, Copy)]
pub struct RawRecord<'a> {
    /// Topic, e.g. `/camera/color/image_raw`.
    pub topic: &'a str,
    /// Producer (stage or driver name), stored as channel metadata `producer`.
    pub producer: &'a str,
    /// ROS type name, e.g. `sensor_msgs/msg/Image`.
    pub type_name: &'a str,
    /// The `ros2msg` schema text of the type.
    pub schema_text: &'a str,
    /// QoS YAML for `offered_qos_profiles`; empty = key omitted.
    pub qos_yaml: &'a str,
    /// Robot-clock time the message was logged, ns.
    pub log_time_ns: u64,
    /// Device/driver time, ns.
    pub publish_time_ns: u64,
    /// Per-channel sequence number.
    pub sequence: u32,
    /// The CDR payload (with its encapsulation header).
    pub cdr: &'a [u8],
}

/// What a finished file holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct WriteSummary {
    /// Messages written.
    pub messages: u64,
    /// Chunks written.
    pub chunks: u32,
    /// Channels (topic, producer pairs).
    pub channels: u32,
    /// Schemas (ROS types).
    pub schemas: u16,
    /// Metadata records.
    pub metadata: u32,
    /// Attachments.
    pub attachments: u32,
}

/// Builder of a metadata record (`robot_info`, `scenario`, `build`, ...): name + string map.
///
/// ```
/// let rec = recorder::MetadataRecord::new("scenario").with("seed", 7).with("name", "hang");
/// assert_eq!(rec.entries["seed"], "7");
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct MetadataRecord {
    /// Record name.
    pub name: String,
    /// Key/value pairs (sorted, so files are deterministic).
    pub entries: BTreeMap<String, String>,
}

impl MetadataRecord {
    /// An empty record named `name`.
    pub fn new(name: impl Into<String>) -> Self {
        Self {
            name: name.into(),
            entries: BTreeMap::new(),
        }
    }

    /// Adds (or replaces) `key = value` (value formatted with `Display`).
    #[must_use]
    pub fn with(mut self, key: impl Into<String>, value: impl std::fmt::Display) -> Self {
        self.entries.insert(key.into(), value.to_string());
        self
    }

    /// Adds (or replaces) `key = value` in place.
    pub fn insert(&mut self, key: impl Into<String>, value: impl std::fmt::Display) {
        self.entries.insert(key.into(), value.to_string());
    }
}

/// Channels added so far, found by topic then producer without allocating.
#[derive(Debug, Default)]
struct ChannelTable {
    by_topic: BTreeMap<String, BTreeMap<String, u16>>,
    topics_by_id: BTreeMap<u16, String>,
    types_by_id: BTreeMap<u16, String>,
    /// Next sequence number of each channel (typed API).
    next_sequence: BTreeMap<u16, u32>,
}

impl ChannelTable {
    fn get(&self, topic: &str, producer: &str) -> Option<u16> {
        self.by_topic.get(topic)?.get(producer).copied()
    }
}

/// The MCAP writer of rodlog over any seekable output (a file, or a `Cursor<Vec<u8>>` in
/// tests). See the module docs for the file layout.
///
/// Must be ended with [`McapSink::finish`]; see the module docs for what happens otherwise.
pub struct McapSink<W: Write + Seek = BufWriter<File>> {
    /// `None` only after `finish` took it.
    writer: Option<mcap::Writer<W>>,
    channels: ChannelTable,
    schemas: BTreeMap<String, u16>,
    summary: WriteSummary,
    /// Reused CDR buffer of the typed API (no allocation per message once grown).
    scratch: Vec<u8>,
}

impl McapSink<BufWriter<File>> {
    /// Creates (truncates) `path` and writes the MCAP header.
    ///
    /// # Errors
    /// [`WriteError::Create`] when the file cannot be created, [`WriteError::Finish`] when
    /// the header cannot be written.
    pub fn create(path: impl AsRef<Path>, options: &SinkOptions) -> Result<Self, WriteError> {
        let path = path.as_ref();
        let file = File::create(path).map_err(|source| WriteError::Create {
            path: path.to_path_buf(),
            source,
        })?;
        // 1 MiB buffer: camera frames go to the OS in few large writes.
        Self::new(BufWriter::with_capacity(1 << 20, file), options)
    }
}

impl<W: Write + Seek> McapSink<W> {
    /// Starts an MCAP file on `out` (magic + header record).
    ///
    /// # Errors
    /// [`WriteError::Finish`] when the header cannot be written.
    pub fn new(out: W, options: &SinkOptions) -> Result<Self, WriteError> {
        let compression = match options.compression {
            ChunkCompression::Lz4 => Some(mcap::Compression::Lz4),
            ChunkCompression::Zstd => Some(mcap::Compression::Zstd),
            ChunkCompression::None => None,
        };
        let writer = mcap::WriteOptions::new()
            .profile(PROFILE)
            .library(library_string())
            .compression(compression)
            .compression_level(options.compression_level)
            // 0 workers = single-threaded zstd: output independent of the machine's core count.
            .compression_threads(0)
            .chunk_size(Some(options.chunk_size_bytes.max(1)))
            .create(out)
            .map_err(|source| WriteError::Finish {
                messages: 0,
                source,
            })?;
        Ok(Self {
            writer: Some(writer),
            channels: ChannelTable::default(),
            schemas: BTreeMap::new(),
            summary: WriteSummary::default(),
            scratch: Vec::new(),
        })
    }

    fn writer(&mut self) -> &mut mcap::Writer<W> {
        // `writer` is `None` only inside `finish`, which consumes `self`.
        match &mut self.writer {
            Some(w) => w,
            None => unreachable!("McapSink used after finish"),
        }
    }

    /// Id of the channel of (`topic`, `producer`), adding its schema and channel records on
    /// first use. Use with [`McapSink::write_to_channel`] on hot paths.
    ///
    /// # Errors
    /// [`WriteError::Channel`] when the records cannot be written (I/O, > 65535 channels).
    pub fn channel_id(
        &mut self,
        topic: &str,
        producer: &str,
        type_name: &str,
        schema_text: &str,
        qos_yaml: &str,
    ) -> Result<u16, WriteError> {
        if let Some(id) = self.channels.get(topic, producer) {
            let existing = self
                .channels
                .types_by_id
                .get(&id)
                .map_or("", String::as_str);
            if existing != type_name {
                return Err(WriteError::TypeMismatch {
                    topic: topic.to_owned(),
                    producer: producer.to_owned(),
                    existing: existing.to_owned(),
                    got: type_name.to_owned(),
                });
            }
            return Ok(id);
        }
        let err = |source| WriteError::Channel {
            topic: topic.to_owned(),
            producer: producer.to_owned(),
            type_name: type_name.to_owned(),
            source,
        };
        let schema_id = match self.schemas.get(type_name) {
            Some(&id) => id,
            None => {
                let id = self
                    .writer()
                    .add_schema(type_name, SCHEMA_ENCODING, schema_text.as_bytes())
                    .map_err(err)?;
                self.schemas.insert(type_name.to_owned(), id);
                self.summary.schemas = self.summary.schemas.saturating_add(1);
                id
            }
        };
        let mut metadata = BTreeMap::new();
        if !qos_yaml.is_empty() {
            metadata.insert(QOS_KEY.to_owned(), qos_yaml.to_owned());
        }
        metadata.insert(PRODUCER_KEY.to_owned(), producer.to_owned());
        let id = self
            .writer()
            .add_channel(schema_id, topic, MESSAGE_ENCODING, &metadata)
            .map_err(err)?;
        self.channels
            .by_topic
            .entry(topic.to_owned())
            .or_default()
            .insert(producer.to_owned(), id);
        self.channels.topics_by_id.insert(id, topic.to_owned());
        self.channels.types_by_id.insert(id, type_name.to_owned());
        self.summary.channels = self.summary.channels.saturating_add(1);
        Ok(id)
    }

    /// Writes one message to a channel from [`McapSink::channel_id`]. The payload is copied
    /// once, into the chunk compressor.
    ///
    /// # Errors
    /// [`WriteError::UnknownChannel`] for an id not handed out here, [`WriteError::Message`]
    /// on I/O or compression failure.
    pub fn write_to_channel(
        &mut self,
        channel_id: u16,
        log_time_ns: u64,
        publish_time_ns: u64,
        sequence: u32,
        cdr: &[u8],
    ) -> Result<(), WriteError> {
        if !self.channels.topics_by_id.contains_key(&channel_id) {
            return Err(WriteError::UnknownChannel {
                channel_id,
                known: self.channels.topics_by_id.len(),
            });
        }
        let header = mcap::records::MessageHeader {
            channel_id,
            sequence,
            log_time: log_time_ns,
            publish_time: publish_time_ns,
        };
        if let Err(source) = self.writer().write_to_known_channel(&header, cdr) {
            let topic = self
                .channels
                .topics_by_id
                .get(&channel_id)
                .cloned()
                .unwrap_or_default();
            return Err(WriteError::Message {
                topic,
                log_time_ns,
                bytes: cdr.len(),
                source,
            });
        }
        self.summary.messages += 1;
        Ok(())
    }

    /// Writes one message, adding its schema and channel on first use (low-level API).
    ///
    /// # Errors
    /// See [`McapSink::channel_id`] and [`McapSink::write_to_channel`].
    pub fn write_raw(&mut self, record: &RawRecord<'_>) -> Result<(), WriteError> {
        let id = self.channel_id(
            record.topic,
            record.producer,
            record.type_name,
            record.schema_text,
            record.qos_yaml,
        )?;
        self.write_to_channel(
            id,
            record.log_time_ns,
            record.publish_time_ns,
            record.sequence,
            record.cdr,
        )
    }

    /// Writes a typed message on (`topic`, `producer`): schema text from
    /// [`msgs::Msg::schema_text`], QoS from the topic registry ([`msgs::topics::lookup`];
    /// volatile for unregistered topics), sequence numbers counted per channel from 0.
    /// The CDR buffer is reused between calls.
    ///
    /// # Errors
    /// [`WriteError::Encode`], [`WriteError::TypeMismatch`], and those of
    /// [`McapSink::write_to_channel`].
    pub fn write_msg(
        &mut self,
        topic: &str,
        producer: &str,
        log_time: msgs::RobotTime,
        publish_time: msgs::RobotTime,
        msg: &msgs::Msg,
    ) -> Result<(), WriteError> {
        let type_name = msg.type_name();
        let id = match self.channels.get(topic, producer) {
            // Known channel: only the type check runs (schema and QoS are not needed).
            Some(_) => self.channel_id(topic, producer, type_name, "", "")?,
            None => {
                let schema = msgs::Msg::schema_text(type_name).unwrap_or_default();
                let qos = msgs::topics::lookup(topic)
                    .map_or(msgs::topics::QOS_VOLATILE_YAML, |t| t.offered_qos_profiles);
                self.channel_id(topic, producer, type_name, &schema, qos)?
            }
        };
        let log_time_ns = log_time.as_nanos();
        let mut cdr = std::mem::take(&mut self.scratch);
        let encoded = msg
            .encode_into(&mut cdr)
            .map_err(|source| WriteError::Encode {
                topic: topic.to_owned(),
                type_name,
                log_time_ns,
                source,
            });
        let written = encoded.and_then(|()| {
            let sequence = self.channels.next_sequence.entry(id).or_insert(0);
            let seq = *sequence;
            *sequence = sequence.wrapping_add(1);
            self.write_to_channel(id, log_time_ns, publish_time.as_nanos(), seq, &cdr)
        });
        self.scratch = cdr;
        written
    }

    /// Writes a metadata record (ends the open chunk first, as MCAP requires).
    ///
    /// # Errors
    /// [`WriteError::Metadata`] on I/O failure.
    pub fn write_metadata(&mut self, record: &MetadataRecord) -> Result<(), WriteError> {
        let meta = mcap::records::Metadata {
            name: record.name.clone(),
            metadata: record.entries.clone(),
        };
        self.writer()
            .write_metadata(&meta)
            .map_err(|source| WriteError::Metadata {
                name: record.name.clone(),
                source,
            })?;
        self.summary.metadata += 1;
        Ok(())
    }

    /// Writes an attachment (scenario file, URDF, ...), `create_time` = `log_time_ns` (robot
    /// clock, for determinism). Ends the open chunk first.
    ///
    /// # Errors
    /// [`WriteError::Attachment`] on I/O failure.
    pub fn attach(
        &mut self,
        name: &str,
        media_type: &str,
        log_time_ns: u64,
        data: &[u8],
    ) -> Result<(), WriteError> {
        let err = |source| WriteError::Attachment {
            name: name.to_owned(),
            bytes: data.len(),
            source,
        };
        let header = mcap::records::AttachmentHeader {
            log_time: log_time_ns,
            create_time: log_time_ns,
            name: name.to_owned(),
            media_type: media_type.to_owned(),
        };
        let w = self.writer();
        w.start_attachment(data.len() as u64, header).map_err(err)?;
        w.put_attachment_bytes(data).map_err(err)?;
        w.finish_attachment().map_err(err)?;
        self.summary.attachments += 1;
        Ok(())
    }

    /// Ends the open chunk and flushes everything to the OS: after this returns, a crash loses
    /// nothing written so far (the linear scan of `replay` recovers it).
    ///
    /// # Errors
    /// [`WriteError::Flush`] on I/O failure.
    pub fn flush(&mut self) -> Result<(), WriteError> {
        let messages = self.summary.messages;
        self.writer()
            .flush()
            .map_err(|source| WriteError::Flush { messages, source })
    }

    /// Messages written so far.
    pub fn message_count(&self) -> u64 {
        self.summary.messages
    }

    /// Writes the summary, footer and end magic, and flushes. Returns what the file holds and
    /// the output (e.g. the `Cursor<Vec<u8>>` of an in-memory file).
    ///
    /// # Errors
    /// [`WriteError::Finish`] when the summary cannot be written, [`WriteError::Close`] when
    /// the output cannot be flushed.
    pub fn finish_into_inner(mut self) -> Result<(WriteSummary, W), WriteError> {
        let messages = self.summary.messages;
        let Some(mut writer) = self.writer.take() else {
            unreachable!("McapSink::writer is only taken here, and this consumes self")
        };
        let stats = writer
            .finish()
            .map_err(|source| WriteError::Finish { messages, source })?;
        let mut summary = self.summary;
        summary.chunks = stats.stats.as_ref().map_or(0, |s| s.chunk_count);
        let mut out = writer.into_inner();
        out.flush().map_err(WriteError::Close)?;
        Ok((summary, out))
    }

    /// Like [`McapSink::finish_into_inner`], dropping the output.
    ///
    /// # Errors
    /// See [`McapSink::finish_into_inner`].
    pub fn finish(self) -> Result<WriteSummary, WriteError> {
        self.finish_into_inner().map(|(summary, _)| summary)
    }
}

impl<W: Write + Seek> Drop for McapSink<W> {
    /// Dropped without `finish` (an error path or a panic): end the open chunk and stop without
    /// a summary, so the file stays recoverable and is recognisably unfinished. Never panics.
    fn drop(&mut self) {
        if let Some(mut writer) = self.writer.take() {
            let _ignored = writer.flush();
            // `into_inner` marks the mcap writer finished so its own Drop does not write a
            // summary; the buffered output flushes on drop.
            let mut out = writer.into_inner();
            let _ignored = out.flush();
        }
    }
}

impl<W: Write + Seek> std::fmt::Debug for McapSink<W> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("McapSink")
            .field("summary", &self.summary)
            .field("channels", &self.channels.topics_by_id)
            .finish_non_exhaustive()
    }
}

#[cfg(test)]
mod tests {
    use std::io::Cursor;

    use super::*;

    fn record<'a>(topic: &'a str, producer: &'a str, t: u64, cdr: &'a [u8]) -> RawRecord<'a> {
        RawRecord {
            topic,
            producer,
            type_name: "std_msgs/msg/Float64",
            schema_text: "float64 data\n",
            qos_yaml: "- history: keep_last\n",
            log_time_ns: t,
            publish_time_ns: t + 1,
            sequence: 3,
            cdr,
        }
    }

    #[test]
    fn header_channels_and_chunks_follow_the_ros2_profile() -> Result<(), Box<dyn std::error::Error>>
    {
        let mut sink = McapSink::new(Cursor::new(Vec::new()), &SinkOptions::default())?;
        sink.write_raw(&record("/tf", "robot_state", 10, &[0, 1, 0, 0, 1]))?;
        sink.write_raw(&record("/tf", "base", 20, &[0, 1, 0, 0, 2]))?;
        sink.flush()?;
        sink.write_raw(&record("/tf", "base", 30, &[0, 1, 0, 0, 3]))?;
        let (summary, out) = sink.finish_into_inner()?;
        assert_eq!(
            (
                summary.messages,
                summary.channels,
                summary.schemas,
                summary.chunks
            ),
            (3, 2, 1, 2)
        );
        let bytes = out.into_inner();
        let header = mcap::read::LinearReader::new(&bytes)?
            .find_map(|r| match r {
                Ok(mcap::records::Record::Header(h)) => Some(h),
                _ => None,
            })
            .ok_or("no header")?;
        assert_eq!(header.profile, "ros2");
        assert_eq!(header.library, library_string());
        let stats = mcap::Summary::read(&bytes)?.ok_or("no summary")?;
        assert_eq!(stats.chunk_indexes.len(), 2, "flush ends a chunk");
        assert!(stats.chunk_indexes.iter().all(|c| c.compression == "lz4"));
        let mut producers = Vec::new();
        for m in mcap::MessageStream::new(&bytes)? {
            let m = m?;
            assert_eq!(m.channel.message_encoding, "cdr");
            let schema = m.channel.schema.as_ref().ok_or("schema")?;
            assert_eq!(
                (schema.encoding.as_str(), schema.name.as_str()),
                ("ros2msg", "std_msgs/msg/Float64")
            );
            assert_eq!(
                m.channel.metadata["offered_qos_profiles"],
                "- history: keep_last\n"
            );
            assert_eq!((m.publish_time, m.sequence), (m.log_time + 1, 3));
            producers.push(m.channel.metadata["producer"].clone());
        }
        assert_eq!(producers, ["robot_state", "base", "base"]);
        Ok(())
    }

    #[test]
    fn unknown_channel_ids_are_refused() -> Result<(), Box<dyn std::error::Error>> {
        let mut sink = McapSink::new(Cursor::new(Vec::new()), &SinkOptions::default())?;
        let e = sink
            .write_to_channel(7, 0, 0, 0, &[1])
            .err()
            .ok_or("accepted")?;
        assert!(
            matches!(
                e,
                WriteError::UnknownChannel {
                    channel_id: 7,
                    known: 0
                }
            ),
            "{e}"
        );
        sink.finish()?;
        Ok(())
    }

    #[test]
    fn chunk_size_option_splits_chunks() -> Result<(), Box<dyn std::error::Error>> {
        let options = SinkOptions {
            chunk_size_bytes: 1000,
            compression: ChunkCompression::Zstd,
            ..SinkOptions::default()
        };
        let mut sink = McapSink::new(Cursor::new(Vec::new()), &options)?;
        let payload = vec![7_u8; 600];
        for t in 0..10 {
            sink.write_raw(&record("/camera/color/image_raw", "camera", t, &payload))?;
        }
        let (summary, _) = sink.finish_into_inner()?;
        assert!(
            summary.chunks >= 5,
            "600-byte messages, 1000-byte chunks: {} chunks",
            summary.chunks
        );
        Ok(())
    }
}
