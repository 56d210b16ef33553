//! Rerun sink over the rodlog message stream: draws messages, never computes robot logic.
//!
//! | module | what |
//! |---|---|
//! | [`sink`] | [`Viz`]: every topic of DESIGN.md section 3 to a Rerun recording stream |
//! | [`convert`] | pure conversions: pixels, point clouds, pinholes, poses, the match canvas |
//! | [`tf`] | latest-edge TF tree for the executed tool0 path |
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
pub mod sink;
pub mod tf;

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
    /// The Rerun SDK refused a call (sink creation, logging, the URDF importer).
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
    /// A viewer started from the `rerun` executable (`None`: found on `PATH`).
    Spawn(Option<PathBuf>),
    /// A running viewer or server, by its gRPC proxy URL (`rerun+http://HOST:PORT/proxy`).
    Connect(String),
}

/// Application id of rodlog's recordings in the viewer.
pub const APPLICATION_ID: &str = "rodlog";

/// A recording stream to `target` with the recording id `recording_id` (see
/// [`convert::recording_id`]), the name `name` and the [`blueprint::default_blueprint`];
/// enabled whatever the `RERUN` environment variable says.
///
/// # Errors
/// [`VizError::Rerun`]: the file cannot be created, the viewer cannot be spawned.
pub fn stream(
    target: &Target,
    recording_id: &str,
    name: &str,
) -> Result<rerun::RecordingStream, VizError> {
    let builder = rerun::RecordingStreamBuilder::new(APPLICATION_ID)
        .recording_id(recording_id)
        .recording_name(name)
        .enabled(true)
        .with_blueprint(blueprint::default_blueprint());
    Ok(match target {
        Target::Rrd(path) => builder.save(path)?,
        Target::Spawn(exe) => {
            let opts = rerun::SpawnOptions {
                executable_path: exe.as_ref().map(|p| p.display().to_string()),
                ..rerun::SpawnOptions::default()
            };
            builder.spawn_opts(&opts)?
        }
        Target::Connect(url) => builder.connect_grpc_opts(url.clone())?,
    })
}
