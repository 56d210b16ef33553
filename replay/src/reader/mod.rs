//! The MCAP reader: messages in log-time order, filters, and recovery of crashed files.
//!
//! An MCAP file (<https://mcap.dev/spec>) is `magic | record* | magic`, each record
//! `opcode: u8 | length: u64 LE | body[length]`. Opening a file takes one of two paths:
//!
//! * **Summary** (a finished file): the footer (last 8 + 29 bytes) points at the summary
//!   section; its schemas, channels, statistics, chunk, attachment and metadata indexes
//!   describe everything without touching the data section.
//! * **Scan** (no footer, a truncated or crashed file, an unusable summary): the records are
//!   walked from the start. Every complete chunk is decompressed once to learn its channels,
//!   counts and time range; every complete message record outside chunks is kept. The walk
//!   stops at the first record that is cut off or cannot be parsed, and [`Recovery`] says
//!   where (`valid_until`), how many bytes were lost and why. A complete chunk whose
//!   content is damaged (CRC, decompression) is skipped and listed; the walk goes on.
//!
//! Messages are then yielded in `(log_time, file position)` order by a k-way merge over the
//! chunks sorted by their start time: a chunk is decompressed only once the smallest pending
//! log time reaches its start, so memory holds about one chunk when chunks do not overlap
//! (which is how [`recorder::McapSink`] writes them). Ties keep file order.
//!
//! The parts: `summary` (the finished file's index), `scan` (the walk and its
//! [`Recovery`]), `merge` (the ordered message iterator, [`Messages`]) and `records` (the
//! record-level helpers they share).
//!
//! Decoding goes through the mcap crate's sans-io [`mcap::sans_io::LinearReader`] with a
//! record-length limit, so a hostile length field cannot make it allocate more than
//! [`ReadOptions::max_record_bytes`]. No input can make this module panic (fuzzed:
//! `fuzz/fuzz_targets/mcap_reader.rs`).

use std::cmp::Reverse;
use std::collections::{BTreeMap, BTreeSet, BinaryHeap, VecDeque};
use std::fmt;
use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use mcap::records::{Record, op};
use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};

mod merge;
mod records;
mod scan;
mod summary;

pub use merge::Messages;
use records::*;

/// The 8 magic bytes that open and close an MCAP file.
pub const MAGIC: &[u8; 8] = b"\x89MCAP0\r\n";
/// Bytes of a record's opcode and length prefix.
const RECORD_PREFIX_BYTES: u64 = 9;
/// Bytes of a footer record (prefix + summary_start + summary_offset_start + summary_crc).
const FOOTER_RECORD_BYTES: u64 = RECORD_PREFIX_BYTES + 8 + 8 + 4;
/// Bytes of a message record's fixed header (channel_id u16, sequence u32, log_time u64,
/// publish_time u64).
const MESSAGE_HEADER_BYTES: usize = 2 + 4 + 8 + 8;
/// Default largest record (or decompressed chunk record) accepted: 1 GiB.
pub const DEFAULT_MAX_RECORD_BYTES: u64 = 1 << 30;

/// Errors of the MCAP reader; each carries the offset, topic or sizes that explain it.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    /// The file could not be opened.
    #[error("cannot open {path}: {source}")]
    Open {
        /// The path given.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// Reading or seeking failed.
    #[error("I/O error at offset {offset}: {source}")]
    Io {
        /// Byte offset being read.
        offset: u64,
        /// The OS error.
        source: std::io::Error,
    },
    /// The file is empty.
    #[error("the file is empty (0 bytes): not an MCAP recording")]
    Empty,
    /// The file does not start with the MCAP magic.
    #[error(
        "not an MCAP file: the first {len} bytes are {found} (expected 89 4d 43 41 50 30 0d 0a)"
    )]
    WrongMagic {
        /// The bytes found, in hex.
        found: String,
        /// How many bytes were compared.
        len: usize,
    },
    /// The record after the magic is not a header record.
    #[error("the first record (offset 8) has opcode {opcode:#04x}, expected a header (0x01)")]
    BadHeader {
        /// Opcode found.
        opcode: u8,
    },
    /// A record of the data or summary section is malformed.
    #[error("bad record (opcode {opcode:#04x}) at offset {offset}: {source}")]
    Record {
        /// Offset of the record.
        offset: u64,
        /// Its opcode.
        opcode: u8,
        /// What the mcap parser said.
        source: mcap::McapError,
    },
    /// A record claims more bytes than allowed or available.
    #[error("record (opcode {opcode:#04x}) at offset {offset} claims {len} bytes; limit {limit}")]
    RecordTooLarge {
        /// Offset of the record.
        offset: u64,
        /// Its opcode.
        opcode: u8,
        /// Declared length.
        len: u64,
        /// Bytes available or allowed.
        limit: u64,
    },
    /// A chunk could not be decompressed or its content is malformed.
    #[error("chunk at offset {offset} ({compression:?}) is damaged: {source}")]
    Chunk {
        /// Offset of the chunk record.
        offset: u64,
        /// Its compression.
        compression: String,
        /// What went wrong.
        source: mcap::McapError,
    },
    /// A message names a channel that no channel record defines.
    #[error(
        "message at log_time {log_time_ns} ns (record at offset {offset}) names unknown channel {channel_id}"
    )]
    UnknownChannel {
        /// The channel id.
        channel_id: u16,
        /// Its log time.
        log_time_ns: u64,
        /// Offset of the enclosing chunk or message record.
        offset: u64,
    },
    /// A message record shorter than its fixed header.
    #[error(
        "message record at offset {offset} has {len} bytes, fewer than the {MESSAGE_HEADER_BYTES}-byte header"
    )]
    ShortMessage {
        /// Offset of the enclosing chunk or message record.
        offset: u64,
        /// Its length.
        len: usize,
    },
    /// The summary section is malformed (the reader then falls back to a scan).
    #[error("summary section at offset {offset} is unusable: {reason}")]
    Summary {
        /// Offset of the summary section.
        offset: u64,
        /// What is wrong.
        reason: String,
    },
    /// A chunk's channel uses a schema encoding other than `ros2msg`.
    #[error("topic {topic}: schema encoding {encoding:?} is not supported (expected \"ros2msg\")")]
    UnknownSchemaEncoding {
        /// Topic of the channel.
        topic: String,
        /// The encoding found.
        encoding: String,
    },
    /// The payload is not a valid CDR encoding of its type (XCDR2, truncated, unknown type...).
    #[error(
        "topic {topic}: cannot decode {type_name:?} at log_time {log_time_ns} ns ({bytes} bytes): {source}"
    )]
    Decode {
        /// Topic of the message.
        topic: String,
        /// Its schema name.
        type_name: String,
        /// Its log time.
        log_time_ns: u64,
        /// Payload size.
        bytes: usize,
        /// What the codec said.
        source: msgs::DecodeError,
    },
    /// A channel uses a message encoding other than `cdr`.
    #[error("topic {topic}: message encoding {encoding:?} is not supported (expected \"cdr\")")]
    UnsupportedMessageEncoding {
        /// Topic of the channel.
        topic: String,
        /// The encoding found.
        encoding: String,
    },
}

/// Options of [`McapReader`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ReadOptions {
    /// Largest record accepted, in bytes (bounds every allocation driven by a length field).
    /// Default: [`DEFAULT_MAX_RECORD_BYTES`].
    pub max_record_bytes: u64,
    /// Ignore the summary and scan the data section (as for a crashed file). Default: false.
    pub force_scan: bool,
}

impl Default for ReadOptions {
    fn default() -> Self {
        Self {
            max_record_bytes: DEFAULT_MAX_RECORD_BYTES,
            force_scan: false,
        }
    }
}

/// The header record: profile and writing library.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct HeaderInfo {
    /// MCAP profile, `ros2` for rodlog and ROS 2 files.
    pub profile: String,
    /// The library that wrote the file.
    pub library: String,
}

/// A schema: a ROS type and its definition.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SchemaInfo {
    /// Schema id in the file.
    pub id: u16,
    /// Type name, e.g. `sensor_msgs/msg/Image`.
    pub name: String,
    /// Schema encoding, `ros2msg` for rodlog.
    pub encoding: String,
    /// The definition text (bytes as stored).
    pub data: Vec<u8>,
}

/// A channel: one (topic, producer) stream of one type.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ChannelInfo {
    /// Channel id in the file.
    pub id: u16,
    /// Topic.
    pub topic: String,
    /// Message encoding, `cdr` for rodlog.
    pub message_encoding: String,
    /// Channel metadata (`producer`, `offered_qos_profiles`, ...).
    pub metadata: BTreeMap<String, String>,
    /// The schema, if the channel has one.
    pub schema: Option<Arc<SchemaInfo>>,
}

impl ChannelInfo {
    /// The `producer` metadata (rodlog files); `None` for foreign files (ARCHITECTURE.md section 2: inputs).
    pub fn producer(&self) -> Option<&str> {
        self.metadata.get("producer").map(String::as_str)
    }

    /// The schema's type name, or `""` without a schema.
    pub fn schema_name(&self) -> &str {
        self.schema.as_deref().map_or("", |s| s.name.as_str())
    }

    /// The schema encoding, or `""` without a schema.
    pub fn schema_encoding(&self) -> &str {
        self.schema.as_deref().map_or("", |s| s.encoding.as_str())
    }
}

/// One message as stored: its channel and the raw payload.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct McapMessage {
    /// The channel (topic, schema, encoding, metadata).
    pub channel: Arc<ChannelInfo>,
    /// Robot-clock log time, ns.
    pub log_time_ns: u64,
    /// Publish (device) time, ns.
    pub publish_time_ns: u64,
    /// Per-channel sequence number.
    pub sequence: u32,
    /// The payload (CDR for rodlog).
    pub data: Vec<u8>,
}

impl McapMessage {
    /// Topic of the message.
    pub fn topic(&self) -> &str {
        &self.channel.topic
    }

    /// Type (schema) name.
    pub fn schema_name(&self) -> &str {
        self.channel.schema_name()
    }

    /// Producer (channel metadata), if any.
    pub fn producer(&self) -> Option<&str> {
        self.channel.producer()
    }

    /// Decodes the payload into a typed [`msgs::Msg`] (the typed layer).
    ///
    /// # Errors
    /// [`ReadError::UnsupportedMessageEncoding`] unless the channel is `cdr`,
    /// [`ReadError::UnknownSchemaEncoding`] unless the schema is `ros2msg`,
    /// [`ReadError::Decode`] for an unknown type or bytes that are not its CDR (XCDR2
    /// included).
    pub fn decode(&self) -> Result<msgs::Msg, ReadError> {
        if self.channel.message_encoding != "cdr" {
            return Err(ReadError::UnsupportedMessageEncoding {
                topic: self.channel.topic.clone(),
                encoding: self.channel.message_encoding.clone(),
            });
        }
        if self.channel.schema_encoding() != "ros2msg" {
            return Err(ReadError::UnknownSchemaEncoding {
                topic: self.channel.topic.clone(),
                encoding: self.channel.schema_encoding().to_owned(),
            });
        }
        msgs::Msg::decode(self.schema_name(), &self.data).map_err(|source| ReadError::Decode {
            topic: self.channel.topic.clone(),
            type_name: self.schema_name().to_owned(),
            log_time_ns: self.log_time_ns,
            bytes: self.data.len(),
            source,
        })
    }
}

/// A chunk of the data section.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ChunkInfo {
    /// Offset of the chunk record.
    pub offset: u64,
    /// Length of the whole record (prefix included).
    pub record_bytes: u64,
    /// Earliest message log time, ns.
    pub start_ns: u64,
    /// Latest message log time, ns.
    pub end_ns: u64,
    /// Compression (`lz4`, `zstd`, `""`).
    pub compression: String,
    /// Compressed payload bytes.
    pub compressed_bytes: u64,
    /// Uncompressed payload bytes.
    pub uncompressed_bytes: u64,
    /// Channels with messages in it, when known (summary message indexes, or the scan).
    pub channel_ids: Option<BTreeSet<u16>>,
}

/// A metadata record.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MetadataInfo {
    /// Record name (`robot_info`, `scenario`, `build`, ...).
    pub name: String,
    /// Its key/value pairs.
    pub entries: BTreeMap<String, String>,
}

/// An attachment (data read on request with [`McapReader::read_attachment`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AttachmentInfo {
    /// Name.
    pub name: String,
    /// Media type.
    pub media_type: String,
    /// Log time, ns.
    pub log_time_ns: u64,
    /// Creation time, ns.
    pub create_time_ns: u64,
    /// Offset of the attachment record.
    pub offset: u64,
    /// Length of the attachment record (prefix included).
    pub record_bytes: u64,
    /// Size of the data, bytes.
    pub data_bytes: u64,
}

/// How the reader learnt what the file holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum IndexSource {
    /// From the summary section of a finished file.
    Summary,
    /// From a linear scan of the data section.
    Scan,
}

/// Why the scan stopped before the end of the file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LossReason {
    /// The file ends at a record boundary but has no footer: the writer stopped (crashed or
    /// killed) after a flush.
    NoFooter,
    /// Fewer bytes than a record prefix remain.
    TruncatedPrefix {
        /// Offset of the cut prefix.
        offset: u64,
        /// Bytes left.
        available: u64,
    },
    /// A chunk whose writer never came back to fill in its length (crash mid-chunk).
    UnfinishedChunk {
        /// Offset of the chunk record.
        offset: u64,
    },
    /// A record longer than the rest of the file.
    TruncatedRecord {
        /// Offset of the record.
        offset: u64,
        /// Its opcode.
        opcode: u8,
        /// Declared length of its body.
        declared_bytes: u64,
        /// Bytes left after its prefix.
        available: u64,
    },
    /// A record that cannot be parsed.
    BadRecord {
        /// Offset of the record.
        offset: u64,
        /// Its opcode.
        opcode: u8,
        /// The parser's message.
        detail: String,
    },
    /// The footer is not followed by the end magic.
    BadEndMagic {
        /// Offset where the magic should be.
        offset: u64,
    },
}

impl fmt::Display for LossReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NoFooter => write!(f, "file ends without footer (writer did not finish)"),
            Self::TruncatedPrefix { offset, available } => write!(
                f,
                "record prefix at offset {offset} cut off ({available} of 9 bytes)"
            ),
            Self::UnfinishedChunk { offset } => {
                write!(
                    f,
                    "unfinished chunk at offset {offset} (writer stopped mid-chunk)"
                )
            }
            Self::TruncatedRecord {
                offset,
                opcode,
                declared_bytes,
                available,
            } => write!(
                f,
                "record (opcode {opcode:#04x}) at offset {offset} declares {declared_bytes} bytes, only {available} remain"
            ),
            Self::BadRecord {
                offset,
                opcode,
                detail,
            } => write!(
                f,
                "unparseable record (opcode {opcode:#04x}) at offset {offset}: {detail}"
            ),
            Self::BadEndMagic { offset } => write!(f, "no end magic at offset {offset}"),
        }
    }
}

/// Where the data of a truncated file stops.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Truncation {
    /// Offset just past the last complete record kept.
    pub valid_until: u64,
    /// Bytes after it, lost.
    pub lost_bytes: u64,
    /// Why the scan stopped.
    pub reason: LossReason,
}

/// A complete chunk whose content could not be decoded (skipped by the scan).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SkippedChunk {
    /// Offset of the chunk record.
    pub offset: u64,
    /// Length of the record.
    pub record_bytes: u64,
    /// The decoder's message.
    pub detail: String,
}

/// What the scan of a damaged file recovered and lost.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Recovery {
    /// Set when the file ends early (crash, truncation, garbage).
    pub truncation: Option<Truncation>,
    /// Complete chunks skipped because their content is damaged.
    pub skipped_chunks: Vec<SkippedChunk>,
}

/// Which messages [`McapReader::messages`] yields.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct ReadFilter {
    /// Only these topics (`None` = all).
    pub topics: Option<BTreeSet<String>>,
    /// Only log times `>= start_ns`.
    pub start_ns: Option<u64>,
    /// Only log times `< end_ns`.
    pub end_ns: Option<u64>,
}

impl ReadFilter {
    /// Everything.
    pub fn all() -> Self {
        Self::default()
    }

    /// Restricts to `topics`.
    #[must_use]
    pub fn with_topics<I, S>(mut self, topics: I) -> Self
    where
        I: IntoIterator<Item = S>,
        S: Into<String>,
    {
        self.topics = Some(topics.into_iter().map(Into::into).collect());
        self
    }

    /// Restricts to log times in `[start_ns, end_ns)`.
    #[must_use]
    pub fn with_time_range(mut self, start_ns: Option<u64>, end_ns: Option<u64>) -> Self {
        self.start_ns = start_ns;
        self.end_ns = end_ns;
        self
    }

    fn admits_time(&self, log_time_ns: u64) -> bool {
        self.start_ns.is_none_or(|s| log_time_ns >= s)
            && self.end_ns.is_none_or(|e| log_time_ns < e)
    }

    /// Whether `[start, end]` may hold admitted times.
    fn overlaps(&self, start_ns: u64, end_ns: u64) -> bool {
        self.start_ns.is_none_or(|s| end_ns >= s) && self.end_ns.is_none_or(|e| start_ns < e)
    }
}

/// A message record outside any chunk (unchunked files).
#[derive(Debug, Clone, Copy)]
struct LooseMessage {
    offset: u64,
    record_bytes: u64,
    log_time_ns: u64,
    channel_id: u16,
}

/// An MCAP recording opened for reading. See the module docs.
pub struct McapReader<R: Read + Seek = BufReader<File>> {
    src: R,
    options: ReadOptions,
    file_bytes: u64,
    header: HeaderInfo,
    schemas: BTreeMap<u16, Arc<SchemaInfo>>,
    channels: BTreeMap<u16, Arc<ChannelInfo>>,
    chunks: Vec<ChunkInfo>,
    loose: Vec<LooseMessage>,
    metadata: Vec<MetadataInfo>,
    attachments: Vec<AttachmentInfo>,
    channel_counts: BTreeMap<u16, u64>,
    time_range_ns: Option<(u64, u64)>,
    index_source: IndexSource,
    recovery: Option<Recovery>,
    /// Why a summary present in the file was not used.
    summary_problem: Option<String>,
}

impl<R: Read + Seek> fmt::Debug for McapReader<R> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("McapReader")
            .field("file_bytes", &self.file_bytes)
            .field("index_source", &self.index_source)
            .field("channels", &self.channels.len())
            .field("chunks", &self.chunks.len())
            .finish_non_exhaustive()
    }
}

impl McapReader<BufReader<File>> {
    /// Opens the recording at `path` with default options.
    ///
    /// # Errors
    /// [`ReadError::Open`] when the file cannot be opened, and the errors of
    /// [`McapReader::from_reader`].
    pub fn open(path: impl AsRef<Path>) -> Result<Self, ReadError> {
        Self::open_with(path, ReadOptions::default())
    }

    /// Opens the recording at `path` with `options`.
    ///
    /// # Errors
    /// As [`McapReader::open`].
    pub fn open_with(path: impl AsRef<Path>, options: ReadOptions) -> Result<Self, ReadError> {
        let path = path.as_ref();
        let file = File::open(path).map_err(|source| ReadError::Open {
            path: path.to_path_buf(),
            source,
        })?;
        Self::from_reader(BufReader::with_capacity(1 << 16, file), options)
    }
}

impl<R: Read + Seek> McapReader<R> {
    /// Opens a recording from any seekable byte source (a file, or a `Cursor` of bytes).
    ///
    /// # Errors
    /// [`ReadError::Empty`], [`ReadError::WrongMagic`], [`ReadError::BadHeader`] and
    /// [`ReadError::Io`]. A truncated or damaged data section is not an error: see
    /// [`McapReader::recovery`].
    pub fn from_reader(mut src: R, options: ReadOptions) -> Result<Self, ReadError> {
        let file_bytes = src
            .seek(SeekFrom::End(0))
            .map_err(|source| ReadError::Io { offset: 0, source })?;
        if file_bytes == 0 {
            return Err(ReadError::Empty);
        }
        let magic = read_at(&mut src, 0, file_bytes.min(8))?;
        if magic.as_slice() != MAGIC.get(..magic.len()).unwrap_or_default() || magic.len() < 8 {
            return Err(ReadError::WrongMagic {
                found: hex(&magic),
                len: magic.len(),
            });
        }
        let mut reader = Self {
            src,
            options,
            file_bytes,
            header: HeaderInfo::default(),
            schemas: BTreeMap::new(),
            channels: BTreeMap::new(),
            chunks: Vec::new(),
            loose: Vec::new(),
            metadata: Vec::new(),
            attachments: Vec::new(),
            channel_counts: BTreeMap::new(),
            time_range_ns: None,
            index_source: IndexSource::Scan,
            recovery: None,
            summary_problem: None,
        };
        reader.read_header()?;
        if !options.force_scan {
            match reader.try_summary() {
                Ok(true) => {
                    reader.index_source = IndexSource::Summary;
                    return Ok(reader);
                }
                Ok(false) => {}
                Err(e) => reader.summary_problem = Some(e.to_string()),
            }
            reader.reset_index();
        }
        reader.scan()?;
        Ok(reader)
    }

    fn reset_index(&mut self) {
        self.schemas.clear();
        self.channels.clear();
        self.chunks.clear();
        self.loose.clear();
        self.metadata.clear();
        self.attachments.clear();
        self.channel_counts.clear();
        self.time_range_ns = None;
    }

    /// Reads the header record at offset 8 (a file cut inside it is left to the scan).
    fn read_header(&mut self) -> Result<(), ReadError> {
        let avail = self.file_bytes.saturating_sub(8);
        let pre = read_at(&mut self.src, 8, avail.min(RECORD_PREFIX_BYTES))?;
        let Some((opcode, len)) = prefix(&pre) else {
            return Ok(());
        };
        if opcode != op::HEADER {
            return Err(ReadError::BadHeader { opcode });
        }
        if len > avail.saturating_sub(RECORD_PREFIX_BYTES) || len > self.options.max_record_bytes {
            return Ok(());
        }
        let body = read_at(&mut self.src, 8 + RECORD_PREFIX_BYTES, len)?;
        if let Ok(Record::Header(h)) = parse_record(op::HEADER, &body) {
            self.header = HeaderInfo {
                profile: h.profile,
                library: h.library,
            };
        }
        Ok(())
    }

    fn add_schema(&mut self, id: u16, name: String, encoding: String, data: Vec<u8>) {
        self.schemas.entry(id).or_insert_with(|| {
            Arc::new(SchemaInfo {
                id,
                name,
                encoding,
                data,
            })
        });
    }

    fn add_channel(&mut self, c: mcap::records::Channel) {
        if self.channels.contains_key(&c.id) {
            return;
        }
        let schema = self.schemas.get(&c.schema_id).cloned();
        self.channels.insert(
            c.id,
            Arc::new(ChannelInfo {
                id: c.id,
                topic: c.topic,
                message_encoding: c.message_encoding,
                metadata: c.metadata,
                schema,
            }),
        );
    }

    fn note_time(&mut self, log_time_ns: u64) {
        self.time_range_ns = Some(match self.time_range_ns {
            None => (log_time_ns, log_time_ns),
            Some((a, b)) => (a.min(log_time_ns), b.max(log_time_ns)),
        });
    }
}

impl<R: Read + Seek> McapReader<R> {
    /// Size of the file in bytes.
    pub fn file_bytes(&self) -> u64 {
        self.file_bytes
    }

    /// The header record (profile, library).
    pub fn header(&self) -> &HeaderInfo {
        &self.header
    }

    /// Whether the summary or a scan described the file.
    pub fn index_source(&self) -> IndexSource {
        self.index_source
    }

    /// What a scan of a damaged file lost; `None` for an intact file.
    pub fn recovery(&self) -> Option<&Recovery> {
        self.recovery.as_ref()
    }

    /// Why a summary present in the file was not used, if so.
    pub fn summary_problem(&self) -> Option<&str> {
        self.summary_problem.as_deref()
    }

    /// The schemas, by id.
    pub fn schemas(&self) -> &BTreeMap<u16, Arc<SchemaInfo>> {
        &self.schemas
    }

    /// The channels, by id.
    pub fn channels(&self) -> &BTreeMap<u16, Arc<ChannelInfo>> {
        &self.channels
    }

    /// Messages per channel id.
    pub fn channel_message_counts(&self) -> &BTreeMap<u16, u64> {
        &self.channel_counts
    }

    /// Total messages (readable ones, for a recovered file).
    pub fn message_count(&self) -> u64 {
        self.channel_counts.values().sum()
    }

    /// Earliest and latest message log time, ns; `None` without messages.
    pub fn time_range_ns(&self) -> Option<(u64, u64)> {
        self.time_range_ns
    }

    /// The chunks, in file order.
    pub fn chunks(&self) -> &[ChunkInfo] {
        &self.chunks
    }

    /// The metadata records, in file order.
    pub fn metadata(&self) -> &[MetadataInfo] {
        &self.metadata
    }

    /// The first metadata record named `name`.
    pub fn metadata_named(&self, name: &str) -> Option<&MetadataInfo> {
        self.metadata.iter().find(|m| m.name == name)
    }

    /// The attachments, in file order.
    pub fn attachments(&self) -> &[AttachmentInfo] {
        &self.attachments
    }

    /// Reads the data of an attachment (CRC checked when present).
    ///
    /// # Errors
    /// [`ReadError::Io`], [`ReadError::RecordTooLarge`] or [`ReadError::Record`] (bad CRC).
    pub fn read_attachment(&mut self, info: &AttachmentInfo) -> Result<Vec<u8>, ReadError> {
        let limit = self
            .file_bytes
            .saturating_sub(info.offset)
            .min(self.options.max_record_bytes);
        if info.record_bytes > limit || info.record_bytes < RECORD_PREFIX_BYTES {
            return Err(ReadError::RecordTooLarge {
                offset: info.offset,
                opcode: op::ATTACHMENT,
                len: info.record_bytes,
                limit,
            });
        }
        let rec = read_at(&mut self.src, info.offset, info.record_bytes)?;
        let err = |source| ReadError::Record {
            offset: info.offset,
            opcode: op::ATTACHMENT,
            source,
        };
        match parse_record(op::ATTACHMENT, rec.get(9..).unwrap_or_default()) {
            Ok(Record::Attachment { data, .. }) => Ok(data.into_owned()),
            Ok(_) => Err(err(mcap::McapError::BadIndex)),
            Err(e) => Err(err(e)),
        }
    }
}
