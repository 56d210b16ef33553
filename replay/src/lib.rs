//! MCAP reader (time order, filters, recovery of truncated files), replay, divergence check, what-if.
//!
//! So far: [`McapReader`] (see [`reader`]).

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
