//! Calibration views from a recording's decoded messages (ARCHITECTURE.md section 3 topics): colour images
//! on [`topics::CAMERA_COLOR_IMAGE`], registered depth on [`topics::CAMERA_DEPTH_IMAGE`],
//! intrinsics on [`topics::CAMERA_COLOR_INFO`] (plumb_bob) and the hand poses on
//! [`topics::TF`] / [`topics::TF_STATIC`] (`base_link` -> `tool0`). Nothing else is read
//! (in particular no `/sim/...` ground truth).
//!
//! Each colour image is a view; its hand pose is the TF `base_link_from_tool0` interpolated at
//! the image stamp; its depth is the depth image whose stamp is within
//! [`DEPTH_STAMP_TOLERANCE_NS`].

use image::GrayImage;
use msgs::frames::{BASE_LINK, TOOL0};
use msgs::sensor_msgs::{CameraInfo, Image, image_encodings};
use msgs::{Msg, RobotTime, topics};
use robot::tf_buffer::TfBuffer;

use super::SelfCalError;
use super::views::{CalibView, hand_pose_at};
use crate::relpose::CameraModel;

/// Largest stamp difference between a colour image and its registered depth, ns (1 ms: the
/// structured-light camera stamps both with the capture time).
pub const DEPTH_STAMP_TOLERANCE_NS: u64 = 1_000_000;

fn stamp_ns(topic: &str, img_stamp: msgs::builtin_interfaces::Time) -> Result<u64, SelfCalError> {
    RobotTime::from_ros(img_stamp)
        .map(RobotTime::as_nanos)
        .map_err(|e| SelfCalError::BadStamp {
            topic: topic.to_owned(),
            reason: e.to_string(),
        })
}

fn check_buffer(topic: &str, stamp: u64, img: &Image, bpp: usize) -> Result<(), SelfCalError> {
    let (w, h, step) = (img.width as usize, img.height as usize, img.step as usize);
    let needed = if h == 0 { 0 } else { step * (h - 1) + w * bpp };
    if step < w * bpp || img.data.len() < needed {
        return Err(SelfCalError::BadImageBuffer {
            topic: topic.to_owned(),
            stamp_ns: stamp,
            width: img.width,
            height: img.height,
            step: img.step,
            needed,
            len: img.data.len(),
        });
    }
    Ok(())
}

/// Grey image of a colour message (`rgb8`, `bgr8`, `mono8`), ITU-R BT.601 luma.
///
/// # Errors
/// [`SelfCalError::UnsupportedEncoding`], [`SelfCalError::BadImageBuffer`].
pub fn gray_from_image(topic: &str, stamp: u64, img: &Image) -> Result<GrayImage, SelfCalError> {
    let bpp = match img.encoding.as_str() {
        image_encodings::RGB8 | image_encodings::BGR8 => 3,
        image_encodings::MONO8 => 1,
        other => {
            return Err(SelfCalError::UnsupportedEncoding {
                topic: topic.to_owned(),
                encoding: other.to_owned(),
            });
        }
    };
    check_buffer(topic, stamp, img, bpp)?;
    let (w, h, step) = (img.width as usize, img.height as usize, img.step as usize);
    let bgr = img.encoding == image_encodings::BGR8;
    let mut out = Vec::with_capacity(w * h);
    for row in img.data.chunks(step.max(1)).take(h) {
        let Some(row) = row.get(..w * bpp) else {
            break;
        };
        if bpp == 1 {
            out.extend_from_slice(row);
        } else {
            out.extend(row.chunks_exact(3).map(|p| {
                let (r, g, b) = if bgr {
                    (p[2], p[1], p[0])
                } else {
                    (p[0], p[1], p[2])
                };
                let y = 299 * u32::from(r) + 587 * u32::from(g) + 114 * u32::from(b);
                ((y + 500) / 1000) as u8
            }));
        }
    }
    GrayImage::from_raw(img.width, img.height, out).ok_or(SelfCalError::BadImageBuffer {
        topic: topic.to_owned(),
        stamp_ns: stamp,
        width: img.width,
        height: img.height,
        step: img.step,
        needed: w * h * bpp,
        len: img.data.len(),
    })
}

/// Depth in metres of a depth message (`32FC1` metres, `16UC1` millimetres; 0 = no data).
///
/// # Errors
/// [`SelfCalError::UnsupportedEncoding`], [`SelfCalError::BadImageBuffer`].
pub fn depth_from_image(topic: &str, stamp: u64, img: &Image) -> Result<Vec<f32>, SelfCalError> {
    let bpp = match img.encoding.as_str() {
        image_encodings::TYPE_32FC1 => 4,
        image_encodings::TYPE_16UC1 => 2,
        other => {
            return Err(SelfCalError::UnsupportedEncoding {
                topic: topic.to_owned(),
                encoding: other.to_owned(),
            });
        }
    };
    check_buffer(topic, stamp, img, bpp)?;
    let (w, h, step) = (img.width as usize, img.height as usize, img.step as usize);
    let big = img.is_bigendian != 0;
    let mut out = Vec::with_capacity(w * h);
    for row in img.data.chunks(step.max(1)).take(h) {
        let Some(row) = row.get(..w * bpp) else {
            break;
        };
        if bpp == 4 {
            out.extend(row.chunks_exact(4).map(|b| {
                let a = [b[0], b[1], b[2], b[3]];
                if big {
                    f32::from_be_bytes(a)
                } else {
                    f32::from_le_bytes(a)
                }
            }));
        } else {
            out.extend(row.chunks_exact(2).map(|b| {
                let a = [b[0], b[1]];
                let mm = if big {
                    u16::from_be_bytes(a)
                } else {
                    u16::from_le_bytes(a)
                };
                f32::from(mm) * 1e-3
            }));
        }
    }
    Ok(out)
}

/// The camera model of a `sensor_msgs/CameraInfo` (K row-major; D plumb_bob
/// `[k1, k2, p1, p2, k3]`, shorter lists padded with zeros).
///
/// # Errors
/// [`SelfCalError::BadCameraInfo`] for a non-positive focal length, a zero size, or a
/// distortion model other than plumb_bob with non-zero coefficients.
pub fn camera_from_info(info: &CameraInfo) -> Result<CameraModel, SelfCalError> {
    CameraModel::from_camera_info(info).map_err(|e| SelfCalError::BadCameraInfo {
        reason: e.to_string(),
    })
}

/// Views and camera model from decoded messages `(topic, message)` in log order.
///
/// # Errors
/// [`SelfCalError::NoImages`], [`SelfCalError::NoCameraInfo`], [`SelfCalError::BadCameraInfo`],
/// [`SelfCalError::UnsupportedEncoding`], [`SelfCalError::BadImageBuffer`],
/// [`SelfCalError::BadStamp`], [`SelfCalError::StampMismatch`] (a depth image without a
/// colour image at its stamp, or, when any depth is present, a colour image without depth),
/// [`SelfCalError::MissingTf`] (no `base_link -> tool0` at an image stamp).
pub fn views_from_messages(
    msgs: &[(String, Msg)],
) -> Result<(Vec<CalibView>, CameraModel), SelfCalError> {
    let mut tf = TfBuffer::new(u64::MAX);
    let mut info: Option<&CameraInfo> = None;
    let mut colour: Vec<(u64, GrayImage)> = Vec::new();
    let mut depth: Vec<(u64, Vec<f32>)> = Vec::new();
    for (topic, msg) in msgs {
        match (topic.as_str(), msg) {
            (topics::TF, Msg::TfMessage(m)) => {
                // Rejected transforms (e.g. duplicates) surface as lookup errors later.
                let _rejected = tf.insert_message(m, false);
            }
            (topics::TF_STATIC, Msg::TfMessage(m)) => {
                let _rejected = tf.insert_message(m, true);
            }
            (topics::CAMERA_COLOR_INFO, Msg::CameraInfo(m)) if info.is_none() => {
                info = Some(m);
            }
            (topics::CAMERA_COLOR_IMAGE, Msg::Image(m)) => {
                let s = stamp_ns(topic, m.header.stamp)?;
                colour.push((s, gray_from_image(topic, s, m)?));
            }
            (topics::CAMERA_DEPTH_IMAGE, Msg::Image(m)) => {
                let s = stamp_ns(topic, m.header.stamp)?;
                depth.push((s, depth_from_image(topic, s, m)?));
            }
            _ => {}
        }
    }
    if colour.is_empty() {
        return Err(SelfCalError::NoImages {
            topic: topics::CAMERA_COLOR_IMAGE.to_owned(),
            messages: msgs.len(),
        });
    }
    let Some(info) = info else {
        return Err(SelfCalError::NoCameraInfo {
            topic: topics::CAMERA_COLOR_INFO.to_owned(),
        });
    };
    let camera = camera_from_info(info)?;
    let nearest = |list: &[u64], s: u64| list.iter().copied().min_by_key(|&t| t.abs_diff(s));
    let colour_stamps: Vec<u64> = colour.iter().map(|c| c.0).collect();
    let depth_stamps: Vec<u64> = depth.iter().map(|d| d.0).collect();
    for &s in &depth_stamps {
        let n = nearest(&colour_stamps, s);
        if n.is_none_or(|n| n.abs_diff(s) > DEPTH_STAMP_TOLERANCE_NS) {
            return Err(SelfCalError::StampMismatch {
                what: "depth image",
                stamp_ns: s,
                nearest_ns: n,
                tolerance_ns: DEPTH_STAMP_TOLERANCE_NS,
            });
        }
    }
    let mut depth: Vec<Option<(u64, Vec<f32>)>> = depth.into_iter().map(Some).collect();
    let mut views = Vec::with_capacity(colour.len());
    for (index, (s, gray)) in colour.into_iter().enumerate() {
        let depth_m = if depth_stamps.is_empty() {
            None
        } else {
            let slot = depth
                .iter_mut()
                .filter(|d| {
                    d.as_ref()
                        .is_some_and(|d| d.0.abs_diff(s) <= DEPTH_STAMP_TOLERANCE_NS)
                })
                .min_by_key(|d| d.as_ref().map_or(u64::MAX, |d| d.0.abs_diff(s)));
            match slot.and_then(Option::take) {
                Some((_, d)) => Some(d),
                None => {
                    return Err(SelfCalError::StampMismatch {
                        what: "colour image",
                        stamp_ns: s,
                        nearest_ns: nearest(&depth_stamps, s),
                        tolerance_ns: DEPTH_STAMP_TOLERANCE_NS,
                    });
                }
            }
        };
        let base_from_tool0 = hand_pose_at(&tf, BASE_LINK, TOOL0, index, s)?;
        views.push(CalibView {
            stamp_ns: s,
            gray,
            depth_m,
            base_from_tool0,
        });
    }
    Ok((views, camera))
}
