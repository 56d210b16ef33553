//! Calibration views out of a recording: every wrist colour image paired with the hand pose
//! `base_link -> tool0` interpolated from `/tf` + `/tf_static` at the image's stamp, and the
//! camera model from `/camera/color/camera_info` (DESIGN.md section 3: "Hand pose for
//! calibration = base_link ... tool0 chain from /tf, interpolated at the image stamp").

use std::path::Path;

use anyhow::{Context, Result, bail};
use calib::relpose::CameraModel;
use msgs::Msg;
use msgs::frames::{BASE_LINK, TOOL0};
use msgs::topics;
use nalgebra::Isometry3;
use replay::{McapReader, ReadFilter};
use robot::TfBuffer;

/// One image with the hand pose at its stamp.
pub struct RecordedView {
    /// 8-bit grey image.
    pub gray: image::GrayImage,
    /// `base_from_tool0` at the stamp.
    pub base_from_tool0: Isometry3<f64>,
}

/// TF history kept while reading: a calibration recording is a few minutes long.
const TF_HISTORY_NS: u64 = 3_600_000_000_000;

/// Reads the views and the camera model of a recording.
///
/// # Errors
/// Unreadable file, no camera info, unsupported distortion model or image encoding, an
/// image whose hand pose cannot be looked up (the TF error says which edge or stamp).
pub fn read_views(path: &Path) -> Result<(Vec<RecordedView>, CameraModel)> {
    let mut reader =
        McapReader::open(path).with_context(|| format!("cannot read {}", path.display()))?;
    let filter = ReadFilter::all().with_topics([
        topics::TF.to_owned(),
        topics::TF_STATIC.to_owned(),
        topics::CAMERA_COLOR_INFO.to_owned(),
        topics::CAMERA_COLOR_IMAGE.to_owned(),
    ]);
    let mut tf = TfBuffer::new(TF_HISTORY_NS);
    let mut camera: Option<CameraModel> = None;
    let mut images = Vec::new();
    for message in reader.messages(&filter) {
        let message = message?;
        let topic = message.topic().to_owned();
        let msg = message
            .decode()
            .with_context(|| format!("decoding {topic}"))?;
        match (topic.as_str(), msg) {
            (topics::TF, Msg::TfMessage(m)) => {
                let _ignored_bad_edges = tf.insert_message(&m, false);
            }
            (topics::TF_STATIC, Msg::TfMessage(m)) => {
                let _ignored_bad_edges = tf.insert_message(&m, true);
            }
            (topics::CAMERA_COLOR_INFO, Msg::CameraInfo(info)) if camera.is_none() => {
                camera = Some(camera_model(&info)?);
            }
            (topics::CAMERA_COLOR_IMAGE, Msg::Image(img)) => images.push(img),
            _ => {}
        }
    }
    let Some(camera) = camera else {
        bail!(
            "{} has no {} message: the camera model is unknown",
            path.display(),
            topics::CAMERA_COLOR_INFO
        );
    };
    if images.is_empty() {
        bail!(
            "{} has no images on {}",
            path.display(),
            topics::CAMERA_COLOR_IMAGE
        );
    }
    let mut views = Vec::with_capacity(images.len());
    for (i, img) in images.iter().enumerate() {
        let stamp = msgs::RobotTime::from_ros(img.header.stamp)
            .with_context(|| format!("image {i}: invalid stamp"))?;
        let base_from_tool0 = tf
            .lookup(BASE_LINK, TOOL0, stamp.as_nanos())
            .with_context(|| {
                format!("image {i} at {stamp}: no hand pose {BASE_LINK} -> {TOOL0}")
            })?;
        views.push(RecordedView {
            gray: to_gray(img).with_context(|| format!("image {i}"))?,
            base_from_tool0,
        });
    }
    Ok((views, camera))
}

fn camera_model(info: &msgs::sensor_msgs::CameraInfo) -> Result<CameraModel> {
    let d = &info.d;
    let distortion: [f64; 5] = match (info.distortion_model.as_str(), d.as_slice()) {
        (_, []) => [0.0; 5],
        ("plumb_bob", [k1, k2, p1, p2]) => [*k1, *k2, *p1, *p2, 0.0],
        ("plumb_bob", [k1, k2, p1, p2, k3]) => [*k1, *k2, *p1, *p2, *k3],
        (model, d) => bail!(
            "camera_info distortion model {model:?} with {} coefficients is not supported (plumb_bob expected)",
            d.len()
        ),
    };
    let k = info.k;
    if k[0] <= 0.0 || k[4] <= 0.0 || !k.iter().all(|v| v.is_finite()) {
        bail!("camera_info K is not a valid camera matrix: {k:?}");
    }
    Ok(CameraModel {
        width: info.width,
        height: info.height,
        fx: k[0],
        fy: k[4],
        cx: k[2],
        cy: k[5],
        k1: distortion[0],
        k2: distortion[1],
        p1: distortion[2],
        p2: distortion[3],
        k3: distortion[4],
    })
}

/// `rgb8`, `bgr8` or `mono8` -> grey (BT.601 weights, as OpenCV).
fn to_gray(img: &msgs::sensor_msgs::Image) -> Result<image::GrayImage> {
    let (w, h) = (img.width as usize, img.height as usize);
    let step = img.step as usize;
    let channels = match img.encoding.as_str() {
        "rgb8" | "bgr8" => 3,
        "mono8" => 1,
        other => bail!("image encoding {other:?} is not supported (rgb8, bgr8, mono8)"),
    };
    if step < w * channels || img.data.len() < step * h {
        bail!(
            "image data ({} bytes, step {step}) too short for {w}x{h} {}",
            img.data.len(),
            img.encoding
        );
    }
    let mut gray = Vec::with_capacity(w * h);
    for row in img.data.chunks_exact(step).take(h) {
        let row = &row[..w * channels];
        match img.encoding.as_str() {
            "mono8" => gray.extend_from_slice(row),
            enc => {
                for px in row.chunks_exact(3) {
                    let (r, b) = if enc == "rgb8" {
                        (px[0], px[2])
                    } else {
                        (px[2], px[0])
                    };
                    let y = 0.299 * f64::from(r) + 0.587 * f64::from(px[1]) + 0.114 * f64::from(b);
                    gray.push(y.round().clamp(0.0, 255.0) as u8);
                }
            }
        }
    }
    image::GrayImage::from_raw(img.width, img.height, gray).context("image size overflow")
}

/// Every message self-calibration may read (images, depth, camera info, /tf, /tf_static),
/// decoded, in log-time order. Ground truth (`/sim/...`) is never read.
///
/// # Errors
/// Unreadable file or undecodable message.
pub fn read_calibration_messages(path: &Path) -> Result<Vec<(String, Msg)>> {
    let mut reader =
        McapReader::open(path).with_context(|| format!("cannot read {}", path.display()))?;
    let filter = ReadFilter::all().with_topics([
        topics::TF.to_owned(),
        topics::TF_STATIC.to_owned(),
        topics::CAMERA_COLOR_INFO.to_owned(),
        topics::CAMERA_COLOR_IMAGE.to_owned(),
        topics::CAMERA_DEPTH_IMAGE.to_owned(),
    ]);
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
