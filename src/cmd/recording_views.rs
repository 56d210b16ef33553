//! Calibration views out of a recording: every wrist colour image paired with the hand pose
//! `base_link -> tool0` interpolated from `/tf` + `/tf_static` at the image's stamp, and the
//! camera model from `/camera/color/camera_info` (ARCHITECTURE.md section 3).

use std::path::Path;

use anyhow::{Context, Result};
use calib::relpose::CameraModel;
use calib::selfcal::CalibView;
use msgs::Msg;
use msgs::topics;
use replay::{McapReader, ReadFilter};

/// Reads the colour views (each with the hand pose at its stamp) and the camera model of a
/// recording: calib's own reading of the calibration messages
/// ([`calib::selfcal::views_from_messages`]); depth is not read (a board needs none).
///
/// # Errors
/// Unreadable file, no camera info, unsupported distortion model or image encoding, an
/// image whose hand pose cannot be looked up (the TF error says which edge or stamp).
pub fn read_views(path: &Path) -> Result<(Vec<CalibView>, CameraModel)> {
    let messages = read_messages(path, &COLOUR_TOPICS)?;
    calib::selfcal::views_from_messages(&messages)
        .with_context(|| format!("{}: no calibration views", path.display()))
}

/// What a colour calibration reads: poses and colour images with their camera model.
const COLOUR_TOPICS: [&str; 4] = [
    topics::TF,
    topics::TF_STATIC,
    topics::CAMERA_COLOR_INFO,
    topics::CAMERA_COLOR_IMAGE,
];

/// Every message self-calibration may read (images, depth, camera info, /tf, /tf_static),
/// decoded, in log-time order. Ground truth (`/sim/...`) is never read.
///
/// # Errors
/// Unreadable file or undecodable message.
pub fn read_calibration_messages(path: &Path) -> Result<Vec<(String, Msg)>> {
    let mut all = COLOUR_TOPICS.to_vec();
    all.push(topics::CAMERA_DEPTH_IMAGE);
    read_messages(path, &all)
}

/// The messages of `topics`, decoded, in log-time order.
fn read_messages(path: &Path, topics: &[&str]) -> Result<Vec<(String, Msg)>> {
    let mut reader =
        McapReader::open(path).with_context(|| format!("cannot read {}", path.display()))?;
    let filter = ReadFilter::all().with_topics(topics.iter().map(|t| (*t).to_owned()));
    let mut out = Vec::new();
    for message in reader.messages(&filter) {
        let message = message?;
        let topic = message.topic().to_owned();
        let msg = message
            .decode()
            .with_context(|| format!("decoding {topic}"))?;
        out.push((topic, msg));
    }
    Ok(out)
}
