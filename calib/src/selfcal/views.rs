//! Calibration views: one wrist-camera capture (grey image, optional registered depth) and the
//! hand pose `base_from_tool0` at its stamp, plus their validation and the TF pairing.

use image::GrayImage;
use nalgebra::Isometry3;
use robot::tf_buffer::TfBuffer;

use super::{MIN_VIEWS, Mode, SelfCalError};
use crate::relpose::CameraModel;

/// One capture of the wrist camera with the hand pose at its stamp.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibView {
    /// Capture stamp, robot-clock nanoseconds.
    pub stamp_ns: u64,
    /// Grey image (colour is converted with [`crate::features::gray::rgb_to_gray`]).
    pub gray: GrayImage,
    /// Registered depth, metres, row-major, same size as `gray`; 0 or non-finite = no data.
    pub depth_m: Option<Vec<f32>>,
    /// Hand pose `B = base_from_tool0` at `stamp_ns`.
    pub base_from_tool0: Isometry3<f64>,
}

impl CalibView {
    /// Depth (metres) at the sub-pixel position `(x, y)`, bilinear over the four
    /// surrounding pixels when all are valid and agree within `max_rel_step` (relative):
    /// points on depth discontinuities (where registration mixes surfaces) are skipped.
    pub fn depth_at(&self, x: f32, y: f32, max_rel_step: f32) -> Option<f64> {
        let depth = self.depth_m.as_ref()?;
        let (w, h) = (self.gray.width() as usize, self.gray.height() as usize);
        if !(x.is_finite() && y.is_finite() && x >= 0.0 && y >= 0.0) {
            return None;
        }
        let (u0, v0) = (x.floor() as usize, y.floor() as usize);
        if u0 + 1 >= w || v0 + 1 >= h {
            return None;
        }
        let at = |u: usize, v: usize| depth.get(v * w + u).copied();
        let z = [
            at(u0, v0)?,
            at(u0 + 1, v0)?,
            at(u0, v0 + 1)?,
            at(u0 + 1, v0 + 1)?,
        ];
        if z.iter().any(|d| !(d.is_finite() && *d > 0.0)) {
            return None;
        }
        let (lo, hi) = z
            .iter()
            .fold((f32::MAX, 0.0f32), |(l, h), &d| (l.min(d), h.max(d)));
        if hi - lo > max_rel_step * lo {
            return None;
        }
        let (fx, fy) = (f64::from(x) - u0 as f64, f64::from(y) - v0 as f64);
        let z = z.map(f64::from);
        Some((1.0 - fy) * ((1.0 - fx) * z[0] + fx * z[1]) + fy * ((1.0 - fx) * z[2] + fx * z[3]))
    }
}

/// Checks the views against the camera and decides the mode: [`Mode::Rgbd`] when every view
/// has depth, [`Mode::Mono`] when none has.
///
/// # Errors
/// [`SelfCalError::TooFewViews`], [`SelfCalError::ImageSize`], [`SelfCalError::DepthSize`],
/// [`SelfCalError::MixedDepth`], [`SelfCalError::NonFinitePose`].
pub fn validate_views(views: &[CalibView], camera: &CameraModel) -> Result<Mode, SelfCalError> {
    if views.len() < MIN_VIEWS {
        return Err(SelfCalError::TooFewViews {
            got: views.len(),
            need: MIN_VIEWS,
        });
    }
    let mut with_depth = 0;
    for (index, v) in views.iter().enumerate() {
        let (width, height) = v.gray.dimensions();
        if (width, height) != (camera.width, camera.height) {
            return Err(SelfCalError::ImageSize {
                index,
                width,
                height,
                expected_width: camera.width,
                expected_height: camera.height,
            });
        }
        if let Some(d) = &v.depth_m {
            let expected = width as usize * height as usize;
            if d.len() != expected {
                return Err(SelfCalError::DepthSize {
                    index,
                    got: d.len(),
                    expected,
                });
            }
            with_depth += 1;
        }
        let p = &v.base_from_tool0;
        if !(p.translation.vector.iter().all(|c| c.is_finite())
            && p.rotation.coords.iter().all(|c| c.is_finite()))
        {
            return Err(SelfCalError::NonFinitePose { index });
        }
    }
    match with_depth {
        0 => Ok(Mode::Mono),
        n if n == views.len() => Ok(Mode::Rgbd),
        n => Err(SelfCalError::MixedDepth {
            with_depth: n,
            without_depth: views.len() - n,
        }),
    }
}

/// The hand pose `parent_from_child` (normally `base_link` -> `tool0`) at an image stamp,
/// interpolated by the TF buffer.
///
/// # Errors
/// [`SelfCalError::MissingTf`] naming the view, the stamp, the frames and the buffer's reason
/// (unknown frame, not connected, stamp outside the buffered range).
pub fn hand_pose_at(
    tf: &TfBuffer,
    parent: &str,
    child: &str,
    index: usize,
    stamp_ns: u64,
) -> Result<Isometry3<f64>, SelfCalError> {
    tf.lookup(parent, child, stamp_ns)
        .map_err(|e| SelfCalError::MissingTf {
            index,
            stamp_ns,
            parent: parent.to_owned(),
            child: child.to_owned(),
            reason: e.to_string(),
        })
}

/// Mean and standard deviation of the grey levels (for the dark/textureless refusal).
pub fn intensity_stats(img: &GrayImage) -> (f64, f64) {
    let n = img.as_raw().len().max(1) as f64;
    let (mut s, mut s2) = (0.0f64, 0.0f64);
    for &p in img.as_raw() {
        let v = f64::from(p);
        s += v;
        s2 += v * v;
    }
    let mean = s / n;
    (mean, (s2 / n - mean * mean).max(0.0).sqrt())
}
