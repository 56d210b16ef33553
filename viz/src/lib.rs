//! Rerun sink over the rodlog message stream: draws messages, never computes robot logic.
//!
//! | module | what |
//! |---|---|
//! | [`sink`] | [`Viz`]: every topic of ARCHITECTURE.md section 3 to a Rerun recording stream |
//! | [`convert`] | pure conversions: pixels, point clouds, pinholes, poses, the match canvas |
//! | [`encode`] | JPEG colour, 16-bit PNG depth, depth captures as points |
//! | [`urdf`] | the visual shapes of a URDF, drawn per link in the link's TF frame |
//! | [`site`] | the site as the robot knows it, the rod's believed pose |
//! | [`tf`] | latest-edge TF tree for the executed tool0 path and the captures' poses |
//! | [`blueprint`] | the default viewer layout |
//! | [`plots`] | static report plots |
//!
//! The sink is fed the same merged stream as the MCAP writer (`rodlog record --viz`) or a
//! recording read back (`rodlog view`); [`stream`] makes the Rerun stream for a [`Target`]
//! (.rrd file, spawned viewer, gRPC proxy) with a deterministic recording id.

/// Static report plots (box, line, bar) as PNG and SVG, for `rodlog experiment`.
pub mod plots;

pub mod blueprint;
pub mod convert;
pub mod encode;
pub mod sink;
pub mod site;
pub mod tf;
pub mod urdf;

pub use sink::{Viz, VizStats};

use std::path::PathBuf;

/// Errors of the viz crate.
#[derive(Debug, thiserror::Error)]
pub enum VizError {
    /// An image message that cannot be drawn.
    #[error("image {width}x{height} {encoding:?}: {reason}")]
    Image {
        /// `Image.encoding`.
        encoding: String,
        /// Columns.
        width: u32,
        /// Rows.
        height: u32,
        /// What is wrong.
        reason: String,
    },
    /// A camera info without a usable pinhole.
    #[error("camera info of {frame:?}: {reason}")]
    CameraInfo {
        /// `header.frame_id`.
        frame: String,
        /// What is wrong.
        reason: String,
    },
    /// A point cloud that cannot be read.
    #[error("point cloud in {frame:?}: {reason}")]
    PointCloud {
        /// `header.frame_id`.
        frame: String,
        /// What is wrong.
        reason: String,
    },
    /// Feature matches that are inconsistent.
    #[error("feature matches ({method}): {reason}")]
    Matches {
        /// `method`.
        method: String,
        /// What is wrong.
        reason: String,
    },
    /// A transform without a parent or child frame name.
    #[error("transform {parent:?} -> {child:?} lacks a frame name")]
    Transform {
        /// `header.frame_id`.
        parent: String,
        /// `child_frame_id`.
        child: String,
    },
    /// CDR bytes that do not decode as their type.
    #[error("{topic} at log_time {log_time_ns} ns: {source}")]
    Decode {
        /// Topic.
        topic: String,
        /// Log time, ns.
        log_time_ns: u64,
        /// Codec error.
        #[source]
        source: msgs::DecodeError,
    },
    /// A robot description that is not a URDF.
    #[error("URDF: {reason}")]
    Urdf {
        /// The parser's message.
        reason: String,
    },
    /// The Rerun SDK refused a call (sink creation, logging).
    #[error("rerun: {0}")]
    Rerun(#[from] rerun::RecordingStreamError),
    /// Flushing the stream failed (e.g. the viewer went away).
    #[error("rerun flush: {0}")]
    Flush(String),
}

/// Where a recording stream goes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Target {
    /// An .rrd file.
    Rrd(PathBuf),
    /// A viewer started from the `rerun` executable (`None`: found on `PATH`), listening for
    /// the stream on gRPC port `port` (an already running viewer there is reused).
    Spawn {
        /// The executable.
        exe: Option<PathBuf>,
        /// Its gRPC port (Rerun's default: 9876).
        port: u16,
    },
    /// A running viewer or server, by its gRPC proxy URL (`rerun+http://HOST:PORT/proxy`).
    Connect(String),
}

/// Application id of rodlog's recordings in the viewer.
pub const APPLICATION_ID: &str = "rodlog";

/// How the stream batches rows into chunks: every 10 s of wall time or 64 MiB, not the SDK's
/// 200 ms / 2 MiB. The viewer ingests a recording chunk by chunk, a few per frame; the demo
/// in the SDK's default chunks (8 000 of them) took minutes to load on a software renderer,
/// in these (a few hundred) it loads in the first frames. `RERUN_FLUSH_TICK_SECS`,
/// `RERUN_FLUSH_NUM_BYTES` and `RERUN_FLUSH_NUM_ROWS` still override it.
pub const BATCHER: rerun::log::ChunkBatcherConfig = rerun::log::ChunkBatcherConfig {
    flush_tick: std::time::Duration::from_secs(10),
    flush_num_bytes: 64 * 1024 * 1024,
    flush_num_rows: u64::MAX,
    ..rerun::log::ChunkBatcherConfig::DEFAULT
};

/// A recording stream to `target` with the recording id `recording_id` (see
/// [`convert::recording_id`]), the name `name` and the default blueprint
/// ([`blueprint::send`]: the 3D eye at `framing`, the time cursor following the newest data);
/// enabled whatever the `RERUN` environment variable says.
///
/// # Errors
/// [`VizError::Rerun`]: the file cannot be created, the viewer cannot be spawned.
pub fn stream(
    target: &Target,
    recording_id: &str,
    name: &str,
    framing: Option<&blueprint::Framing>,
) -> Result<rerun::RecordingStream, VizError> {
    let builder = rerun::RecordingStreamBuilder::new(APPLICATION_ID)
        .recording_id(recording_id)
        .recording_name(name)
        .batcher_config(BATCHER.apply_env().unwrap_or(BATCHER))
        .enabled(true);
    let rec = match target {
        Target::Rrd(path) => builder.save(path)?,
        Target::Spawn { exe, port } => {
            let opts = rerun::SpawnOptions {
                executable_path: exe.as_ref().map(|p| p.display().to_string()),
                port: *port,
                ..rerun::SpawnOptions::default()
            };
            builder.spawn_opts(&opts)?
        }
        Target::Connect(url) => builder.connect_grpc_opts(url.clone())?,
    };
    blueprint::send(&rec, recording_id, framing, true)?;
    Ok(rec)
}
