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
    /// Whether the depth around pixel `(x, y)` is one continuous surface: the pixel itself
    /// has depth, and along every row and every column of the square of half side
    /// `radius_px` about it no two successive pixels with depth differ by more than
    /// `max_rel_step` (relative). Pixels without depth are skipped, not counted as a step:
    /// sun wash-out and dark surfaces make holes inside a surface, while a contour's gap (the
    /// flying pixels the sensor drops, a projector shadow) still separates two depths that
    /// differ. `false` without depth.
    ///
    /// A keypoint whose support reaches across a depth discontinuity (an occluding contour)
    /// is not the image of one 3D point: where the contour cuts the background it moves with
    /// the viewpoint (a T-junction), and its depth belongs to whichever surface its pixel
    /// happens to fall on. Successive steps, not the window's range, are tested so that a
    /// steeply slanted surface still passes (at 0.45 m, 2 % between neighbours is a 9 mm
    /// step over a 0.26 mm pixel).
    pub fn depth_support(&self, x: f32, y: f32, radius_px: usize, max_rel_step: f32) -> bool {
        let Some(depth) = self.depth_m.as_ref() else {
            return false;
        };
        let (w, h) = (self.gray.width() as usize, self.gray.height() as usize);
        if !(x.is_finite() && y.is_finite()) {
            return false;
        }
        let (cu, cv) = (x.round(), y.round());
        let r = radius_px as f32;
        if cu < r || cv < r || cu + r >= w as f32 || cv + r >= h as f32 {
            return false;
        }
        let (cu, cv) = (cu as usize, cv as usize);
        if !depth.get(cv * w + cu).copied().is_some_and(has_depth) {
            return false;
        }
        let (u0, v0, side) = (cu - radius_px, cv - radius_px, 2 * radius_px + 1);
        let at = |u: usize, v: usize| depth.get(v * w + u).copied().unwrap_or(f32::NAN);
        (v0..v0 + side).all(|v| one_surface((u0..u0 + side).map(|u| at(u, v)), max_rel_step))
            && (u0..u0 + side).all(|u| one_surface((v0..v0 + side).map(|v| at(u, v)), max_rel_step))
    }

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
        if !z.iter().copied().all(has_depth) {
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

/// Whether a depth sample is a measurement (0 or non-finite = no data).
fn has_depth(d: f32) -> bool {
    d.is_finite() && d > 0.0
}

/// One surface along a run of depths: successive measured depths (holes skipped) differ by
/// at most `max_rel_step` (relative).
fn one_surface(run: impl Iterator<Item = f32>, max_rel_step: f32) -> bool {
    let mut last: Option<f32> = None;
    for d in run.filter(|&d| has_depth(d)) {
        if last.is_some_and(|l| (d - l).abs() > max_rel_step * d.min(l)) {
            return false;
        }
        last = Some(d);
    }
    true
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A 40 x 30 view whose depth is `depth(u, v)`.
    fn view(depth: impl Fn(usize, usize) -> f32) -> CalibView {
        let (w, h) = (40_usize, 30_usize);
        CalibView {
            stamp_ns: 0,
            gray: GrayImage::new(w as u32, h as u32),
            depth_m: Some((0..w * h).map(|i| depth(i % w, i / w)).collect()),
            base_from_tool0: Isometry3::identity(),
        }
    }

    #[test]
    fn depth_support_passes_slants_and_holes_and_stops_at_a_contour() {
        // 0.45 m, rising 1 mm per pixel to the right (a surface at about 75 deg).
        let slanted = view(|u, _| 0.45 + 0.001 * u as f32);
        // An occluding contour at u = 25: the background 0.3 m behind.
        let step = view(|u, _| if u < 25 { 0.45 } else { 0.75 });
        // The same contour with a 3 px gap without depth (flying pixels, a projector shadow).
        let gap = view(|u, _| match u {
            0..25 => 0.45,
            25..28 => f32::NAN,
            _ => 0.75,
        });
        // Holes inside one surface (wash-out) are no contour.
        let holes = view(|u, v| if (u + 2 * v) % 5 == 0 { 0.0 } else { 0.45 });
        // A contour along a row (a horizontal edge) is caught by the columns.
        let ledge = view(|_, v| if v < 18 { 0.45 } else { 0.6 });
        let cases = [
            (&slanted, 20.0, 15.0, true, "a slanted plane"),
            (&step, 17.4, 15.0, true, "7.6 px from the contour"),
            (&step, 19.6, 15.0, false, "the window reaches u = 26"),
            (&step, 30.0, 15.0, false, "the window reaches u = 24"),
            (&gap, 17.4, 15.0, true, "short of the gap"),
            (&gap, 22.0, 15.0, false, "across the gap to u = 28"),
            (&gap, 26.0, 15.0, false, "no depth at the keypoint"),
            (&holes, 21.0, 15.0, true, "holes inside one surface"),
            (&ledge, 20.0, 14.0, false, "the window reaches v = 18"),
            (&ledge, 20.0, 11.0, true, "above the ledge"),
        ];
        for (v, x, y, want, why) in cases {
            assert_eq!(v.depth_support(x, y, 6, 0.02), want, "({x}, {y}): {why}");
        }
        // Windows leaving the image, non-finite positions, no depth at all.
        assert!(!slanted.depth_support(3.0, 15.0, 6, 0.02));
        assert!(!slanted.depth_support(20.0, 25.0, 6, 0.02));
        assert!(!slanted.depth_support(f32::NAN, 15.0, 6, 0.02));
        let mono = CalibView {
            depth_m: None,
            ..slanted
        };
        assert!(!mono.depth_support(20.0, 15.0, 6, 0.02));
    }
}
