//! SIFT (Lowe, "Distinctive image features from scale-invariant keypoints", IJCV 60(2),
//! 2004), the float-descriptor baseline of the matchers experiment and of the ZHI pipeline.
//!
//! # Pipeline (section numbers of Lowe 2004)
//! 1. [`scale_space`] (sec. 3): the input, assumed blurred by `sigma_n = 0.5`, is doubled by
//!    bilinear interpolation (blur `2 sigma_n = 1`) and blurred to `sigma = 1.6` by
//!    `sqrt(sigma^2 - (2 sigma_n)^2)`; each octave has `s + 3` Gaussian images
//!    `L(x, y, k^i sigma)`, `k = 2^(1/s)` (eq. 1), each blurred from the previous one by
//!    `sigma_i = sqrt((k^i sigma)^2 - (k^(i-1) sigma)^2)`; the next octave starts from image
//!    `s` subsampled by 2. `D = L(k sigma) - L(sigma)` (eq. 1, the DoG).
//! 2. [`detect`] (sec. 3.1-4.1): extrema of `D` among their 26 neighbours in 3x3x3, then up to
//!    5 Newton steps of the quadratic fit `x_hat = -(d2D/dx2)^-1 dD/dx` (eq. 3), moving the
//!    sample while an offset exceeds 0.5; rejected when `|D(x_hat)| * s < contrast_threshold`
//!    (eq. 3, with `D` in [0, 1] grey units) or when the 2x2 Hessian has
//!    `Tr^2 / Det >= (r + 1)^2 / r`, `r = edge_threshold` (eq. 4).
//! 3. Orientation (sec. 5): a 36-bin histogram of gradient directions within radius
//!    `3 * 1.5 sigma_oct` of the point, weighted by magnitude and a Gaussian of
//!    `1.5 sigma_oct`, smoothed by `[1 4 6 4 1] / 16`; every local peak >= 0.8 of the maximum
//!    makes a keypoint, its angle refined by a parabola through the three bins.
//! 4. [`descriptor`] (sec. 6.1): 4x4 cells of 8 orientation bins over a rotated window of
//!    cell width `3 sigma_oct`, samples weighted by a Gaussian of half the window width and
//!    spread by trilinear interpolation; normalised, clamped at 0.2, renormalised, then
//!    scaled by 512 and rounded to 0..=255 (OpenCV's integer convention, so squared L2
//!    distances are exact integers in `f32`).
//! 5. [`l2match`]: brute-force squared L2 with Lowe's ratio test (sec. 7.1, ratio 0.8).
//!
//! The fine details (border of 5 pixels, the prelim threshold `floor(0.5 * ct / s * 255)`,
//! the histogram extent, the descriptor window radius) follow OpenCV's `sift.simd.hpp`
//! (4.x), so that counts and repeatability can be compared with `cv2.SIFT_create`.
//!
//! # Conventions
//! Keypoint coordinates in pixels of the input image (origin at the centre of the top-left
//! pixel), `size` the diameter (`2 sigma` in input pixels, as OpenCV), `angle_rad` the
//! dominant gradient direction in image axes (x right, y down) in `(-pi, pi]`.
//!
//! # Determinism
//! Work is spread over rayon by image rows, by (octave, layer) and by keypoint; every
//! result is computed by the same sequential arithmetic whatever the split and gathered in
//! a fixed order, so the output does not depend on the thread count.

pub mod descriptor;
pub mod detect;
pub mod l2match;
pub mod scale_space;

use rayon::prelude::*;

use super::{FeatureError, GrayView, Keypoint};

pub use l2match::{SiftMatchParams, match_l2_ratio};

/// `atan2(y, x)` in degrees in `[0, 360)` by OpenCV's `fastAtan2` polynomial (odd, degree 7
/// in `min(|x|, |y|) / max(|x|, |y|)`, error below 0.01 degree), the angle function of
/// OpenCV's SIFT histograms.
#[inline]
pub fn fast_atan2_deg(y: f32, x: f32) -> f32 {
    const R2D: f32 = 180.0 / std::f32::consts::PI;
    const P1: f32 = 0.999_787_9 * R2D;
    const P3: f32 = -0.325_808_4 * R2D;
    const P5: f32 = 0.155_578_65 * R2D;
    const P7: f32 = -0.044_326_556 * R2D;
    let (ax, ay) = (x.abs(), y.abs());
    let (num, den, swap) = if ax >= ay {
        (ay, ax, false)
    } else {
        (ax, ay, true)
    };
    let c = num / (den + f32::EPSILON * f32::EPSILON);
    let c2 = c * c;
    let mut a = (((P7 * c2 + P5) * c2 + P3) * c2 + P1) * c;
    if swap {
        a = 90.0 - a;
    }
    if x < 0.0 {
        a = 180.0 - a;
    }
    if y < 0.0 {
        a = 360.0 - a;
    }
    if a >= 360.0 { a - 360.0 } else { a }
}

/// Length of a SIFT descriptor (4 x 4 cells x 8 orientations).
pub const SIFT_DESCRIPTOR_LEN: usize = 128;

/// A SIFT descriptor: 128 values, integers in `0..=255` stored as `f32` (see module docs).
pub type SiftDescriptor = [f32; SIFT_DESCRIPTOR_LEN];

/// Parameters of [`detect_and_describe`] (defaults are Lowe's and OpenCV's).
#[derive(Clone, Debug, PartialEq)]
pub struct SiftParams {
    /// Keep the `n_features` strongest keypoints by response (0 = all; default 0).
    pub n_features: usize,
    /// Layers `s` per octave (default 3).
    pub n_octave_layers: usize,
    /// Contrast threshold on `|D(x_hat)| * s`, `D` in [0, 1] grey units (default 0.04,
    /// OpenCV's; Lowe's `|D| >= 0.03` is 0.09 with `s = 3`).
    pub contrast_threshold: f32,
    /// Edge threshold `r` of the principal-curvature ratio test (default 10).
    pub edge_threshold: f32,
    /// Blur `sigma` of the base of each octave (default 1.6).
    pub sigma: f32,
    /// Double the image first (octave -1; default true, Lowe sec. 3.3).
    pub upsample: bool,
    /// Spread work over the rayon pool (default true; results do not depend on it).
    pub parallel: bool,
}

impl Default for SiftParams {
    fn default() -> Self {
        Self {
            n_features: 0,
            n_octave_layers: 3,
            contrast_threshold: 0.04,
            edge_threshold: 10.0,
            sigma: 1.6,
            upsample: true,
            parallel: true,
        }
    }
}

impl SiftParams {
    fn validate(&self) -> Result<(), FeatureError> {
        let bad = |name: &'static str, value: f64| Err(FeatureError::InvalidParam { name, value });
        if self.n_octave_layers == 0 || self.n_octave_layers > 16 {
            return bad("n_octave_layers", self.n_octave_layers as f64);
        }
        if !(self.contrast_threshold.is_finite() && self.contrast_threshold >= 0.0) {
            return bad("contrast_threshold", f64::from(self.contrast_threshold));
        }
        if !(self.edge_threshold.is_finite() && self.edge_threshold > 0.0) {
            return bad("edge_threshold", f64::from(self.edge_threshold));
        }
        if !(self.sigma.is_finite() && self.sigma > 0.0) {
            return bad("sigma", f64::from(self.sigma));
        }
        Ok(())
    }
}

/// A SIFT keypoint.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SiftKeypoint {
    /// Column in input pixels.
    pub x: f32,
    /// Row in input pixels.
    pub y: f32,
    /// Diameter `2 sigma` in input pixels (OpenCV's `KeyPoint::size`).
    pub size: f32,
    /// Dominant gradient direction, radians in `(-pi, pi]`, image axes (x right, y down).
    pub angle_rad: f32,
    /// `|D(x_hat)|` in [0, 1] grey units (higher is stronger).
    pub response: f32,
    /// Octave: -1 for the doubled image, 0 for the input resolution, ...
    pub octave: i8,
    /// Layer `1..=s` of the DoG in its octave.
    pub layer: u8,
}

impl SiftKeypoint {
    /// The generic [`Keypoint`] of match pictures and reports (`level` = octave + 1).
    pub fn to_keypoint(&self) -> Keypoint {
        Keypoint {
            x: self.x,
            y: self.y,
            level: u8::try_from(i16::from(self.octave) + 1).unwrap_or(0),
            angle_rad: self.angle_rad,
            response: self.response,
            size: self.size,
        }
    }
}

/// Keypoints and descriptors (`keypoints[i]` <-> `descriptors[i]`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SiftFeatures {
    /// Keypoints in detection order (octave, layer, row, column, orientation peak).
    pub keypoints: Vec<SiftKeypoint>,
    /// One descriptor per keypoint.
    pub descriptors: Vec<SiftDescriptor>,
}

/// Detects SIFT keypoints in `img` and describes them (module docs).
///
/// # Errors
/// [`FeatureError::InvalidParam`] for bad parameters; [`FeatureError::ImageTooSmall`] when a
/// side is shorter than 16 pixels.
pub fn detect_and_describe(
    img: &GrayView<'_>,
    params: &SiftParams,
) -> Result<SiftFeatures, FeatureError> {
    params.validate()?;
    const MIN_SIDE: usize = 16;
    if img.width() < MIN_SIDE || img.height() < MIN_SIDE {
        return Err(FeatureError::ImageTooSmall {
            width: img.width(),
            height: img.height(),
            min: MIN_SIDE,
        });
    }
    let pyr = scale_space::Pyramid::build(img, params);
    let mut kps = detect::detect_keypoints(&pyr, params);
    kps = detect::remove_duplicates(kps);
    if params.n_features > 0 && kps.len() > params.n_features {
        kps = detect::retain_best(kps, params.n_features);
    }
    let describe = |k: &SiftKeypoint| descriptor::describe(&pyr, k, params);
    let descriptors: Vec<SiftDescriptor> = if params.parallel {
        kps.par_iter().map(describe).collect()
    } else {
        kps.iter().map(describe).collect()
    };
    Ok(SiftFeatures {
        keypoints: kps,
        descriptors,
    })
}

#[cfg(test)]
mod tests;
