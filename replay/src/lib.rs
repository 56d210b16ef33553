//! Reading and replaying recordings.
//!
//! - [`reader`]: [`McapReader`], messages in log-time order, filters, and the recovery of
//!   crashed or truncated files.
//! - [`replay`](mod@replay): [`replay()`], a recording's inputs fed through a pipeline in the
//!   recorded merge order, its regenerated outputs compared or written.
//! - [`check`]: the byte comparison of recorded and regenerated outputs, and the first
//!   divergence explained field by field.
//! - [`whatif`]: the summary and metadata of a replay with changed parameters (open-loop).

pub mod check;
pub mod reader;
pub mod replay;
pub mod whatif;

pub use check::{ChannelComparison, Comparator, Comparison, Divergence, DivergenceKind};
pub use reader::{
    AttachmentInfo, ChannelInfo, ChunkInfo, HeaderInfo, IndexSource, LossReason, McapMessage,
    McapReader, Messages, MetadataInfo, ReadError, ReadFilter, ReadOptions, Recovery, SchemaInfo,
    SkippedChunk, Truncation,
};
pub use replay::{ReplayError, ReplayOptions, ReplayReport, replay};
