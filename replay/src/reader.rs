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
    /// The `producer` metadata (rodlog files); `None` for foreign files (DESIGN.md s2: inputs).
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

/// Reads `len` bytes at `offset`.
fn read_at<R: Read + Seek>(src: &mut R, offset: u64, len: u64) -> Result<Vec<u8>, ReadError> {
    let io = |source| ReadError::Io { offset, source };
    src.seek(SeekFrom::Start(offset)).map_err(io)?;
    let len_usize = usize::try_from(len).map_err(|_| ReadError::RecordTooLarge {
        offset,
        opcode: 0,
        len,
        limit: usize::MAX as u64,
    })?;
    let mut buf = vec![0_u8; len_usize];
    src.read_exact(&mut buf).map_err(io)?;
    Ok(buf)
}

/// Splits the record prefix `opcode | len` off `buf`.
fn prefix(buf: &[u8]) -> Option<(u8, u64)> {
    let (&opcode, rest) = buf.split_first()?;
    let len_bytes: [u8; 8] = rest.get(..8)?.try_into().ok()?;
    Some((opcode, u64::from_le_bytes(len_bytes)))
}

fn hex(bytes: &[u8]) -> String {
    bytes
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect::<Vec<_>>()
        .join(" ")
}

/// Parses the fixed header of a message record body: (channel, sequence, log, publish).
fn message_header(body: &[u8]) -> Option<(u16, u32, u64, u64)> {
    let channel = u16::from_le_bytes(body.get(0..2)?.try_into().ok()?);
    let sequence = u32::from_le_bytes(body.get(2..6)?.try_into().ok()?);
    let log = u64::from_le_bytes(body.get(6..14)?.try_into().ok()?);
    let publish = u64::from_le_bytes(body.get(14..22)?.try_into().ok()?);
    Some((channel, sequence, log, publish))
}

/// Parts of a record body, for [`strings_fit`].
#[derive(Debug, Clone, Copy)]
enum Part {
    /// A fixed-size field of this many bytes.
    Fixed(usize),
    /// `u32` length + UTF-8 bytes.
    Str,
    /// `u32` byte length + (string, string) pairs.
    StrMap,
    /// `u32` byte length + fixed-size entries.
    IntMap,
}

/// Layout of the records whose bodies hold strings (MCAP spec), up to their last string.
fn string_layout(opcode: u8) -> &'static [Part] {
    use Part::{Fixed, IntMap, Str, StrMap};
    match opcode {
        op::HEADER => &[Str, Str],
        op::SCHEMA => &[Fixed(2), Str, Str],
        op::CHANNEL => &[Fixed(4), Str, Str, StrMap],
        op::CHUNK => &[Fixed(8 + 8 + 8 + 4), Str],
        op::CHUNK_INDEX => &[Fixed(8 * 4), IntMap, Fixed(8), Str],
        op::ATTACHMENT => &[Fixed(16), Str, Str],
        op::ATTACHMENT_INDEX => &[Fixed(8 * 5), Str, Str],
        op::METADATA => &[Str, StrMap],
        op::METADATA_INDEX => &[Fixed(16), Str],
        _ => &[],
    }
}

/// Checks that every string length prefix of a record body fits in the body. The mcap crate's
/// parser reserves a string's declared length before reading it, so an unchecked corrupt
/// prefix would allocate up to 4 GiB (found by fuzzing: `replay/tests/regressions.rs`).
/// Returns the first offending length.
fn strings_fit(opcode: u8, body: &[u8]) -> Result<(), u64> {
    fn u32_at(body: &[u8], pos: usize) -> Option<usize> {
        let b: [u8; 4] = body.get(pos..pos.checked_add(4)?)?.try_into().ok()?;
        usize::try_from(u32::from_le_bytes(b)).ok()
    }
    // Skips a string at `pos`; `None` when the body ends first (the parser reports that).
    fn string(body: &[u8], pos: usize) -> Result<Option<usize>, u64> {
        let Some(len) = u32_at(body, pos) else {
            return Ok(None);
        };
        let start = pos + 4;
        if len > body.len().saturating_sub(start) {
            return Err(len as u64);
        }
        Ok(Some(start + len))
    }
    let mut pos = 0_usize;
    for part in string_layout(opcode) {
        let next = match *part {
            Part::Fixed(n) => pos.checked_add(n).filter(|&p| p <= body.len()),
            Part::Str => string(body, pos)?,
            Part::IntMap => u32_at(body, pos).and_then(|n| (pos + 4).checked_add(n)),
            Part::StrMap => {
                let Some(len) = u32_at(body, pos) else {
                    return Ok(());
                };
                let end = (pos + 4).saturating_add(len).min(body.len());
                let mut p = pos + 4;
                while p < end {
                    let Some(after_key) = string(body, p)? else {
                        return Ok(());
                    };
                    let Some(after_value) = string(body, after_key)? else {
                        return Ok(());
                    };
                    p = after_value;
                }
                Some(end)
            }
        };
        match next {
            Some(p) => pos = p,
            None => return Ok(()),
        }
    }
    Ok(())
}

/// [`mcap::parse_record`] after [`strings_fit`]: never allocates more than the body holds.
fn parse_record(opcode: u8, body: &[u8]) -> Result<Record<'_>, mcap::McapError> {
    strings_fit(opcode, body).map_err(|len| mcap::McapError::RecordTooLarge { opcode, len })?;
    mcap::parse_record(opcode, body)
}

/// Runs the sans-io reader over one chunk record, calling `on_record(opcode, body)` for each
/// record inside it.
fn for_each_in_chunk(
    record: &[u8],
    max_record_bytes: u64,
    mut on_record: impl FnMut(u8, &[u8]) -> Result<(), ReadError>,
    offset: u64,
) -> Result<(), ReadError> {
    let compression = || match parse_record(op::CHUNK, record.get(9..).unwrap_or_default()) {
        Ok(Record::Chunk { header, .. }) => header.compression,
        _ => String::new(),
    };
    // The sans-io reader parses the chunk header itself: check its string first.
    if let Err(len) = strings_fit(op::CHUNK, record.get(9..).unwrap_or_default()) {
        return Err(ReadError::Chunk {
            offset,
            compression: String::new(),
            source: mcap::McapError::RecordTooLarge {
                opcode: op::CHUNK,
                len,
            },
        });
    }
    let limit = usize::try_from(max_record_bytes).unwrap_or(usize::MAX);
    let mut reader = LinearReader::new_with_options(
        LinearReaderOptions::default()
            .with_skip_start_magic(true)
            .with_skip_end_magic(true)
            .with_emit_chunks(false)
            .with_validate_chunk_crcs(true)
            .with_record_length_limit(limit),
    );
    let mut rest = record;
    while let Some(event) = reader.next_event() {
        match event {
            Ok(LinearReadEvent::ReadRequest(need)) => {
                let n = need.min(rest.len());
                let (now, later) = rest.split_at(n);
                reader.insert(n).copy_from_slice(now);
                reader.notify_read(n);
                rest = later;
            }
            Ok(LinearReadEvent::Record { data, opcode }) => on_record(opcode, data)?,
            Err(source) => {
                return Err(ReadError::Chunk {
                    offset,
                    compression: compression(),
                    source,
                });
            }
        }
    }
    Ok(())
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

    /// Uses the summary if the file has a usable one. `Ok(false)`: no summary (scan).
    fn try_summary(&mut self) -> Result<bool, ReadError> {
        if self.file_bytes < 8 + FOOTER_RECORD_BYTES + 8 {
            return Ok(false);
        }
        let footer_at = self.file_bytes - 8 - FOOTER_RECORD_BYTES;
        let tail = read_at(&mut self.src, footer_at, FOOTER_RECORD_BYTES + 8)?;
        let (Some(footer_bytes), Some(end_magic)) = (
            tail.get(..FOOTER_RECORD_BYTES as usize),
            tail.get(FOOTER_RECORD_BYTES as usize..),
        ) else {
            return Ok(false);
        };
        if end_magic != MAGIC || prefix(footer_bytes) != Some((op::FOOTER, 20)) {
            return Ok(false);
        }
        let Ok(Record::Footer(footer)) =
            parse_record(op::FOOTER, footer_bytes.get(9..).unwrap_or_default())
        else {
            return Ok(false);
        };
        if footer.summary_start == 0 {
            return Ok(false);
        }
        let bad = |reason: String| ReadError::Summary {
            offset: footer.summary_start,
            reason,
        };
        if footer.summary_start < 8 || footer.summary_start > footer_at {
            return Err(bad(format!(
                "summary_start {} outside the file (footer at {footer_at})",
                footer.summary_start
            )));
        }
        let summary = read_at(
            &mut self.src,
            footer.summary_start,
            footer_at - footer.summary_start,
        )?;
        let mut stats = None;
        let mut chunk_indexes = Vec::new();
        let mut attachment_indexes = Vec::new();
        let mut metadata_indexes = Vec::new();
        let mut pos = 0_usize;
        while pos < summary.len() {
            let rec_offset = footer.summary_start + pos as u64;
            let Some((opcode, len)) = summary.get(pos..).and_then(prefix) else {
                return Err(bad(format!("record prefix cut at offset {rec_offset}")));
            };
            let body_start = pos + RECORD_PREFIX_BYTES as usize;
            let Some(body) = usize::try_from(len)
                .ok()
                .and_then(|l| body_start.checked_add(l))
                .and_then(|end| summary.get(body_start..end))
            else {
                return Err(bad(format!(
                    "record at offset {rec_offset} declares {len} bytes past the footer"
                )));
            };
            pos = body_start + body.len();
            let rec = parse_record(opcode, body).map_err(|e| {
                bad(format!(
                    "record (opcode {opcode:#04x}) at offset {rec_offset}: {e}"
                ))
            })?;
            match rec {
                Record::Schema { header, data } => {
                    self.add_schema(header.id, header.name, header.encoding, data.into_owned());
                }
                Record::Channel(c) => self.add_channel(c),
                Record::Statistics(s) => stats = Some(s),
                Record::ChunkIndex(c) => chunk_indexes.push(c),
                Record::AttachmentIndex(a) => attachment_indexes.push(a),
                Record::MetadataIndex(m) => metadata_indexes.push(m),
                _ => {}
            }
        }
        let Some(stats) = stats else {
            return Err(bad("no statistics record".into()));
        };
        if stats.chunk_count as usize != chunk_indexes.len() {
            return Err(bad(format!(
                "statistics count {} chunks, {} chunk indexes",
                stats.chunk_count,
                chunk_indexes.len()
            )));
        }
        let indexed: u64 = stats.channel_message_counts.values().sum();
        if stats.message_count > 0 && (chunk_indexes.is_empty() || indexed != stats.message_count) {
            // Messages outside chunks, or counts that do not add up: scan instead.
            return Ok(false);
        }
        for c in chunk_indexes {
            let in_file = c
                .chunk_start_offset
                .checked_add(c.chunk_length)
                .is_some_and(|end| end <= footer.summary_start);
            if !in_file {
                return Err(bad(format!(
                    "chunk index points at {}+{} beyond the data section",
                    c.chunk_start_offset, c.chunk_length
                )));
            }
            self.chunks.push(ChunkInfo {
                offset: c.chunk_start_offset,
                record_bytes: c.chunk_length,
                start_ns: c.message_start_time,
                end_ns: c.message_end_time,
                compression: c.compression,
                compressed_bytes: c.compressed_size,
                uncompressed_bytes: c.uncompressed_size,
                channel_ids: if c.message_index_offsets.is_empty() {
                    None
                } else {
                    Some(c.message_index_offsets.keys().copied().collect())
                },
            });
        }
        for m in metadata_indexes {
            if m.length > self.options.max_record_bytes
                || m.offset.saturating_add(m.length) > footer.summary_start
            {
                return Err(bad(format!("metadata index {:?} out of range", m.name)));
            }
            let rec = read_at(&mut self.src, m.offset, m.length)?;
            match rec.get(9..).map(|b| parse_record(op::METADATA, b)) {
                Some(Ok(Record::Metadata(md))) => self.metadata.push(MetadataInfo {
                    name: md.name,
                    entries: md.metadata,
                }),
                _ => return Err(bad(format!("metadata record {:?} unreadable", m.name))),
            }
        }
        for a in attachment_indexes {
            self.attachments.push(AttachmentInfo {
                name: a.name,
                media_type: a.media_type,
                log_time_ns: a.log_time,
                create_time_ns: a.create_time,
                offset: a.offset,
                record_bytes: a.length,
                data_bytes: a.data_size,
            });
        }
        self.channel_counts = stats.channel_message_counts;
        if stats.message_count > 0 {
            self.time_range_ns = Some((stats.message_start_time, stats.message_end_time));
        }
        Ok(true)
    }

    /// Walks the data section from offset 8, keeping every complete record.
    fn scan(&mut self) -> Result<(), ReadError> {
        let mut recovery = Recovery::default();
        let mut offset = 8_u64;
        let stop = |offset: u64, reason: LossReason, file_bytes: u64| Truncation {
            valid_until: offset,
            lost_bytes: file_bytes - offset,
            reason,
        };
        loop {
            let remaining = self.file_bytes - offset;
            if remaining == 0 {
                recovery.truncation = Some(stop(offset, LossReason::NoFooter, self.file_bytes));
                break;
            }
            if remaining < RECORD_PREFIX_BYTES {
                let reason = LossReason::TruncatedPrefix {
                    offset,
                    available: remaining,
                };
                recovery.truncation = Some(stop(offset, reason, self.file_bytes));
                break;
            }
            let pre = read_at(&mut self.src, offset, RECORD_PREFIX_BYTES)?;
            let Some((opcode, len)) = prefix(&pre) else {
                break;
            };
            let available = remaining - RECORD_PREFIX_BYTES;
            if opcode == op::CHUNK && len == u64::MAX {
                let reason = LossReason::UnfinishedChunk { offset };
                recovery.truncation = Some(stop(offset, reason, self.file_bytes));
                break;
            }
            if len > available {
                let reason = LossReason::TruncatedRecord {
                    offset,
                    opcode,
                    declared_bytes: len,
                    available,
                };
                recovery.truncation = Some(stop(offset, reason, self.file_bytes));
                break;
            }
            if len > self.options.max_record_bytes {
                let reason = LossReason::BadRecord {
                    offset,
                    opcode,
                    detail: format!(
                        "length {len} exceeds the limit {}",
                        self.options.max_record_bytes
                    ),
                };
                recovery.truncation = Some(stop(offset, reason, self.file_bytes));
                break;
            }
            let body_at = offset + RECORD_PREFIX_BYTES;
            let next = body_at + len;
            let outcome = match opcode {
                op::FOOTER => {
                    // The footer ends the file: the end magic must follow.
                    let tail = read_at(&mut self.src, next, (self.file_bytes - next).min(8))?;
                    if tail.as_slice() != MAGIC.as_slice() {
                        let reason = LossReason::BadEndMagic { offset: next };
                        recovery.truncation = Some(stop(next, reason, self.file_bytes));
                    }
                    break;
                }
                op::MESSAGE => self.scan_message(offset, len),
                op::CHUNK => {
                    let record = read_at(&mut self.src, offset, RECORD_PREFIX_BYTES + len)?;
                    match self.scan_chunk(offset, &record) {
                        Ok(()) => Ok(()),
                        Err(ReadError::Chunk { source, .. }) => {
                            recovery.skipped_chunks.push(SkippedChunk {
                                offset,
                                record_bytes: RECORD_PREFIX_BYTES + len,
                                detail: source.to_string(),
                            });
                            Ok(())
                        }
                        Err(e) => Err(e),
                    }
                }
                op::SCHEMA | op::CHANNEL | op::METADATA | op::ATTACHMENT => {
                    let body = read_at(&mut self.src, body_at, len)?;
                    self.scan_small_record(offset, opcode, &body)
                }
                // Indexes, statistics, data end, header repeats and unknown opcodes: skipped.
                _ => Ok(()),
            };
            if let Err(e) = outcome {
                let reason = LossReason::BadRecord {
                    offset,
                    opcode,
                    detail: e.to_string(),
                };
                recovery.truncation = Some(stop(offset, reason, self.file_bytes));
                break;
            }
            offset = next;
        }
        if recovery.truncation.is_some() || !recovery.skipped_chunks.is_empty() {
            self.recovery = Some(recovery);
        }
        Ok(())
    }

    fn scan_message(&mut self, offset: u64, len: u64) -> Result<(), ReadError> {
        let head = read_at(
            &mut self.src,
            offset + RECORD_PREFIX_BYTES,
            len.min(MESSAGE_HEADER_BYTES as u64),
        )?;
        let Some((channel_id, _, log_time_ns, _)) = message_header(&head) else {
            return Err(ReadError::ShortMessage {
                offset,
                len: head.len(),
            });
        };
        self.loose.push(LooseMessage {
            offset,
            record_bytes: RECORD_PREFIX_BYTES + len,
            log_time_ns,
            channel_id,
        });
        *self.channel_counts.entry(channel_id).or_default() += 1;
        self.note_time(log_time_ns);
        Ok(())
    }

    /// Decodes a whole chunk once: its schemas, channels, counts and real time range. The
    /// index is only updated when the whole chunk decodes.
    fn scan_chunk(&mut self, offset: u64, record: &[u8]) -> Result<(), ReadError> {
        let header = match parse_record(op::CHUNK, record.get(9..).unwrap_or_default()) {
            Ok(Record::Chunk { header, .. }) => header,
            Ok(_) => {
                return Err(ReadError::Record {
                    offset,
                    opcode: op::CHUNK,
                    source: mcap::McapError::BadIndex,
                });
            }
            Err(source) => {
                return Err(ReadError::Record {
                    offset,
                    opcode: op::CHUNK,
                    source,
                });
            }
        };
        let mut schemas = Vec::new();
        let mut channels = Vec::new();
        let mut counts: BTreeMap<u16, u64> = BTreeMap::new();
        let mut range: Option<(u64, u64)> = None;
        let limit = self.options.max_record_bytes;
        for_each_in_chunk(
            record,
            limit,
            |opcode, body| {
                let rec = parse_record(opcode, body).map_err(|source| ReadError::Chunk {
                    offset,
                    compression: header.compression.clone(),
                    source,
                })?;
                match rec {
                    Record::Schema { header, data } => schemas.push((header, data.into_owned())),
                    Record::Channel(c) => channels.push(c),
                    Record::Message { header: m, .. } => {
                        *counts.entry(m.channel_id).or_default() += 1;
                        range = Some(match range {
                            None => (m.log_time, m.log_time),
                            Some((a, b)) => (a.min(m.log_time), b.max(m.log_time)),
                        });
                    }
                    _ => {}
                }
                Ok(())
            },
            offset,
        )?;
        for (h, data) in schemas {
            self.add_schema(h.id, h.name, h.encoding, data);
        }
        for c in channels {
            self.add_channel(c);
        }
        for (&id, &n) in &counts {
            *self.channel_counts.entry(id).or_default() += n;
        }
        let (start_ns, end_ns) =
            range.unwrap_or((header.message_start_time, header.message_end_time));
        if range.is_some() {
            self.note_time(start_ns);
            self.note_time(end_ns);
        }
        self.chunks.push(ChunkInfo {
            offset,
            record_bytes: record.len() as u64,
            start_ns,
            end_ns,
            compression: header.compression,
            compressed_bytes: header.compressed_size,
            uncompressed_bytes: header.uncompressed_size,
            channel_ids: Some(counts.keys().copied().collect()),
        });
        Ok(())
    }

    fn scan_small_record(&mut self, offset: u64, opcode: u8, body: &[u8]) -> Result<(), ReadError> {
        let rec = parse_record(opcode, body).map_err(|source| ReadError::Record {
            offset,
            opcode,
            source,
        })?;
        match rec {
            Record::Schema { header, data } => {
                self.add_schema(header.id, header.name, header.encoding, data.into_owned());
            }
            Record::Channel(c) => self.add_channel(c),
            Record::Metadata(m) => self.metadata.push(MetadataInfo {
                name: m.name,
                entries: m.metadata,
            }),
            Record::Attachment { header, data, .. } => self.attachments.push(AttachmentInfo {
                name: header.name,
                media_type: header.media_type,
                log_time_ns: header.log_time,
                create_time_ns: header.create_time,
                offset,
                record_bytes: RECORD_PREFIX_BYTES + body.len() as u64,
                data_bytes: data.len() as u64,
            }),
            _ => {}
        }
        Ok(())
    }

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

    /// Channel ids whose topic passes `filter`.
    fn wanted_channels(&self, filter: &ReadFilter) -> Option<BTreeSet<u16>> {
        let topics = filter.topics.as_ref()?;
        Some(
            self.channels
                .values()
                .filter(|c| topics.contains(&c.topic))
                .map(|c| c.id)
                .collect(),
        )
    }

    /// Messages passing `filter`, in `(log_time, file position)` order. Errors (a damaged
    /// chunk found while reading) are yielded in place; the iteration goes on after them.
    pub fn messages(&mut self, filter: &ReadFilter) -> Messages<'_, R> {
        let wanted = self.wanted_channels(filter);
        let mut sources: Vec<Source> = Vec::new();
        for c in &self.chunks {
            let has_wanted = match (&wanted, &c.channel_ids) {
                (Some(w), Some(ids)) => !w.is_disjoint(ids),
                (Some(w), None) => !w.is_empty(),
                (None, _) => true,
            };
            if has_wanted && filter.overlaps(c.start_ns, c.end_ns) {
                sources.push(Source {
                    start_ns: c.start_ns,
                    offset: c.offset,
                    record_bytes: c.record_bytes,
                    is_chunk: true,
                });
            }
        }
        for m in &self.loose {
            let ok = wanted.as_ref().is_none_or(|w| w.contains(&m.channel_id));
            if ok && filter.admits_time(m.log_time_ns) {
                sources.push(Source {
                    start_ns: m.log_time_ns,
                    offset: m.offset,
                    record_bytes: m.record_bytes,
                    is_chunk: false,
                });
            }
        }
        sources.sort_by_key(|s| (s.start_ns, s.offset));
        Messages {
            reader: self,
            sources: sources.into(),
            heap: BinaryHeap::new(),
            errors: VecDeque::new(),
            wanted,
            filter: filter.clone(),
        }
    }

    /// All messages passing `filter`, collected; stops at the first error.
    ///
    /// # Errors
    /// The first [`ReadError`] met.
    pub fn read_all(&mut self, filter: &ReadFilter) -> Result<Vec<McapMessage>, ReadError> {
        self.messages(filter).collect()
    }
}

/// A chunk or a loose message still to load.
#[derive(Debug, Clone, Copy)]
struct Source {
    start_ns: u64,
    offset: u64,
    record_bytes: u64,
    is_chunk: bool,
}

/// A decoded message waiting in the merge, ordered by (log_time, source offset, index).
#[derive(Debug)]
struct Pending {
    key: (u64, u64, u32),
    message: McapMessage,
}

impl PartialEq for Pending {
    fn eq(&self, other: &Self) -> bool {
        self.key == other.key
    }
}
impl Eq for Pending {}
impl PartialOrd for Pending {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Pending {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.key.cmp(&other.key)
    }
}

/// Iterator of [`McapReader::messages`].
pub struct Messages<'r, R: Read + Seek> {
    reader: &'r mut McapReader<R>,
    sources: VecDeque<Source>,
    heap: BinaryHeap<Reverse<Pending>>,
    errors: VecDeque<ReadError>,
    wanted: Option<BTreeSet<u16>>,
    filter: ReadFilter,
}

impl<R: Read + Seek> Messages<'_, R> {
    /// Queues a decoded message (its channel must be known by now).
    fn push_message(
        &mut self,
        source: Source,
        index: u32,
        raw: RawMessage,
    ) -> Result<(), ReadError> {
        let Some(channel) = self.reader.channels.get(&raw.channel_id).cloned() else {
            return Err(ReadError::UnknownChannel {
                channel_id: raw.channel_id,
                log_time_ns: raw.log_time_ns,
                offset: source.offset,
            });
        };
        self.heap.push(Reverse(Pending {
            key: (raw.log_time_ns, source.offset, index),
            message: McapMessage {
                channel,
                log_time_ns: raw.log_time_ns,
                publish_time_ns: raw.publish_time_ns,
                sequence: raw.sequence,
                data: raw.data,
            },
        }));
        Ok(())
    }

    fn load(&mut self, source: Source) -> Result<(), ReadError> {
        let limit = self.reader.file_bytes.saturating_sub(source.offset).min(
            self.reader
                .options
                .max_record_bytes
                .saturating_add(RECORD_PREFIX_BYTES),
        );
        if source.record_bytes > limit || source.record_bytes < RECORD_PREFIX_BYTES {
            return Err(ReadError::RecordTooLarge {
                offset: source.offset,
                opcode: if source.is_chunk {
                    op::CHUNK
                } else {
                    op::MESSAGE
                },
                len: source.record_bytes,
                limit,
            });
        }
        let record = read_at(&mut self.reader.src, source.offset, source.record_bytes)?;
        let wanted = &self.wanted;
        let filter = &self.filter;
        // Decodes a message body, keeping it only if the filter admits it (one payload copy).
        let decode = |body: &[u8]| -> Result<Option<RawMessage>, ReadError> {
            let Some((channel_id, sequence, log_time_ns, publish_time_ns)) = message_header(body)
            else {
                return Err(ReadError::ShortMessage {
                    offset: source.offset,
                    len: body.len(),
                });
            };
            let admitted = wanted.as_ref().is_none_or(|w| w.contains(&channel_id))
                && filter.admits_time(log_time_ns);
            Ok(admitted.then(|| RawMessage {
                channel_id,
                sequence,
                log_time_ns,
                publish_time_ns,
                data: body
                    .get(MESSAGE_HEADER_BYTES..)
                    .unwrap_or_default()
                    .to_vec(),
            }))
        };
        if !source.is_chunk {
            return match decode(record.get(9..).unwrap_or_default())? {
                Some(raw) => self.push_message(source, 0, raw),
                None => Ok(()),
            };
        }
        let mut index = 0_u32;
        let mut first_error = None;
        let mut new_schemas = Vec::new();
        let mut new_channels = Vec::new();
        let mut messages: Vec<(u32, RawMessage)> = Vec::new();
        let result = for_each_in_chunk(
            &record,
            self.reader.options.max_record_bytes,
            |opcode, body| {
                match opcode {
                    op::MESSAGE => {
                        if let Some(raw) = decode(body)? {
                            messages.push((index, raw));
                        }
                        index = index.saturating_add(1);
                    }
                    op::SCHEMA | op::CHANNEL => match parse_record(opcode, body) {
                        Ok(Record::Schema { header, data }) => {
                            new_schemas.push((header, data.into_owned()));
                        }
                        Ok(Record::Channel(c)) => new_channels.push(c),
                        Ok(_) => {}
                        Err(source_err) => {
                            first_error.get_or_insert(ReadError::Record {
                                offset: source.offset,
                                opcode,
                                source: source_err,
                            });
                        }
                    },
                    _ => {}
                }
                Ok(())
            },
            source.offset,
        );
        for (h, data) in new_schemas {
            self.reader.add_schema(h.id, h.name, h.encoding, data);
        }
        for c in new_channels {
            self.reader.add_channel(c);
        }
        for (i, raw) in messages {
            if let Err(e) = self.push_message(source, i, raw) {
                first_error.get_or_insert(e);
            }
        }
        result?;
        match first_error {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }
}

/// A message record's fields before its channel is resolved.
#[derive(Debug)]
struct RawMessage {
    channel_id: u16,
    sequence: u32,
    log_time_ns: u64,
    publish_time_ns: u64,
    data: Vec<u8>,
}

impl<R: Read + Seek> Iterator for Messages<'_, R> {
    type Item = Result<McapMessage, ReadError>;

    fn next(&mut self) -> Option<Self::Item> {
        loop {
            if let Some(e) = self.errors.pop_front() {
                return Some(Err(e));
            }
            let min_pending = self.heap.peek().map(|p| p.0.key.0);
            let due = self
                .sources
                .front()
                .is_some_and(|s| min_pending.is_none_or(|m| s.start_ns <= m));
            if due {
                if let Some(source) = self.sources.pop_front()
                    && let Err(e) = self.load(source)
                {
                    self.errors.push_back(e);
                }
                continue;
            }
            return self.heap.pop().map(|p| Ok(p.0.message));
        }
    }
}
