//! AKAZE features (Alcantarilla, Nuevo & Bartoli, "Fast Explicit Diffusion for Accelerated
//! Features in Nonlinear Scale Spaces", BMVC 2013), written from the paper and the authors'
//! reference implementation as shipped in OpenCV (`AKAZEFeatures.cpp`); the baseline
//! "AKAZE + RANSAC" matching baseline.
//!
//! - [`nonlinear_scale_space`]: Perona-Malik (g2) diffusion with Fast Explicit Diffusion
//!   cycles ([`fed`]), contrast factor from the 70th gradient percentile, 4 octaves x 4
//!   sublevels, scale-normalised derivatives and Hessian determinant.
//! - [`detector`]: Hessian extrema (threshold 0.001, suppression across neighbours and
//!   scales), sub-pixel refinement, dominant orientation (sliding `pi/3` window).
//! - [`mldb`]: the rotated 486-bit M-LDB descriptor (2x2/3x3/4x4 grids of mean intensity,
//!   dx, dy). [`matching`]: brute-force Hamming with the ratio test.
//! - [`match_akaze_ransac`]: the whole baseline, verified by the fundamental matrix
//!   ([`crate::relpose::fundamental`]).
//!
//! Keypoints use the [`Keypoint`] of the ORB front end: `level` is the index of the scale
//! space level (`octave * sublevels + sublevel`), `size` the diameter `2 * 1.5 sigma`
//! (OpenCV's `KeyPoint::size`), `response` the Hessian response, `angle_rad` in image axes.
//!
//! Deterministic: with `parallel` the work is split over levels, rows and keypoints whose
//! results do not depend on each other, so the output is the same for any thread count.

pub mod detector;
pub mod fed;
pub mod image;
pub mod matching;
pub mod mldb;
pub mod nonlinear_scale_space;

pub use matching::{MldbMatchParams, match_mldb};
pub use mldb::{MLDB_BITS, MldbDescriptor, hamming486};

use nalgebra::Point2;

use crate::features::{FeatureError, GrayView, Keypoint, Match};
use crate::relpose::RelPoseError;
use crate::relpose::fundamental::{
    FundamentalEstimate, FundamentalParams, estimate_fundamental_ransac,
};

/// Parameters of [`detect_and_describe_akaze`] (defaults: OpenCV's `AKAZE_create()`).
#[derive(Clone, Debug, PartialEq)]
pub struct AkazeParams {
    /// Octaves; default 4.
    pub octaves: usize,
    /// Sublevels per octave; default 4.
    pub sublevels: usize,
    /// Base scale `sigma_0`, pixels; default 1.6.
    pub sigma0: f32,
    /// Derivative scale over `sigma`; default 1.5.
    pub derivative_factor: f32,
    /// Hessian response threshold (image in `[0, 1]`); default 0.001.
    pub threshold: f32,
    /// Percentile of the gradient histogram giving the contrast factor; default 0.7.
    pub kcontrast_percentile: f32,
    /// Bins of that histogram; default 300.
    pub kcontrast_bins: usize,
    /// Keep only the strongest keypoints (by response) when set; default `None` (all).
    pub max_keypoints: Option<usize>,
    /// Use the rayon pool (default true; results do not depend on it).
    pub parallel: bool,
}

impl Default for AkazeParams {
    fn default() -> Self {
        Self {
            octaves: 4,
            sublevels: 4,
            sigma0: 1.6,
            derivative_factor: 1.5,
            threshold: 0.001,
            kcontrast_percentile: 0.7,
            kcontrast_bins: 300,
            max_keypoints: None,
            parallel: true,
        }
    }
}

impl AkazeParams {
    fn validate(&self) -> Result<(), FeatureError> {
        let bad = |name: &'static str, value: f64| Err(FeatureError::InvalidParam { name, value });
        if self.octaves == 0 || self.octaves > 8 {
            return bad("octaves", self.octaves as f64);
        }
        if self.sublevels == 0 || self.sublevels > 16 {
            return bad("sublevels", self.sublevels as f64);
        }
        if !(self.sigma0.is_finite() && self.sigma0 > 0.0) {
            return bad("sigma0", f64::from(self.sigma0));
        }
        if !(self.derivative_factor.is_finite() && self.derivative_factor > 0.0) {
            return bad("derivative_factor", f64::from(self.derivative_factor));
        }
        if !self.threshold.is_finite() {
            return bad("threshold", f64::from(self.threshold));
        }
        if !(self.kcontrast_percentile > 0.0 && self.kcontrast_percentile < 1.0) {
            return bad("kcontrast_percentile", f64::from(self.kcontrast_percentile));
        }
        if self.kcontrast_bins < 3 {
            return bad("kcontrast_bins", self.kcontrast_bins as f64);
        }
        Ok(())
    }
}

/// AKAZE keypoints and their M-LDB descriptors (`keypoints[i]` <-> `descriptors[i]`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AkazeFeatures {
    /// Keypoints, by scale level (finest first), then raster order.
    pub keypoints: Vec<Keypoint>,
    /// One descriptor per keypoint.
    pub descriptors: Vec<MldbDescriptor>,
}

/// Smallest side AKAZE accepts (the first level's detection border is 29 pixels).
pub const AKAZE_MIN_SIDE: usize = 64;

/// Detects AKAZE keypoints in `img` and computes their M-LDB descriptors.
///
/// # Errors
/// [`FeatureError::InvalidParam`], [`FeatureError::ImageTooSmall`] (a side below
/// [`AKAZE_MIN_SIDE`]).
pub fn detect_and_describe_akaze(
    img: &GrayView<'_>,
    params: &AkazeParams,
) -> Result<AkazeFeatures, FeatureError> {
    params.validate()?;
    if img.width() < AKAZE_MIN_SIDE || img.height() < AKAZE_MIN_SIDE {
        return Err(FeatureError::ImageTooSmall {
            width: img.width(),
            height: img.height(),
            min: AKAZE_MIN_SIDE,
        });
    }
    let space = nonlinear_scale_space::build_scale_space(img, params);
    let masks = detector::find_extrema(&space, params);
    let mut keypoints = detector::refine(&space, &masks, params);
    if let Some(max) = params.max_keypoints
        && keypoints.len() > max
    {
        // Strongest first; ties by position for a total, reproducible order; then back to
        // level / raster order.
        let mut order: Vec<usize> = (0..keypoints.len()).collect();
        order.sort_by(|&i, &j| {
            keypoints[j]
                .response
                .total_cmp(&keypoints[i].response)
                .then(i.cmp(&j))
        });
        order.truncate(max);
        order.sort_unstable();
        keypoints = order.iter().map(|&i| keypoints[i]).collect();
    }
    detector::orientations(&space, &mut keypoints, params.parallel);
    let descriptors = mldb::describe_all(&space, &keypoints, params.parallel);
    Ok(AkazeFeatures {
        keypoints,
        descriptors,
    })
}

/// Parameters of [`match_akaze_ransac`] (defaults of each part; RANSAC seed 0).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AkazeRansacParams {
    /// AKAZE for both images.
    pub akaze: AkazeParams,
    /// Hamming matching (ratio 0.8 by default).
    pub matching: MldbMatchParams,
    /// Fundamental-matrix RANSAC (1 px Sampson threshold by default).
    pub fundamental: FundamentalParams,
    /// RANSAC seed.
    pub seed: u64,
}

/// Result of [`match_akaze_ransac`].
#[derive(Clone, Debug, PartialEq)]
pub struct AkazeRansacResult {
    /// Features of A.
    pub features_a: AkazeFeatures,
    /// Features of B.
    pub features_b: AkazeFeatures,
    /// Ratio-test matches (query in A, train in B).
    pub matches: Vec<Match>,
    /// `inliers[i]`: `matches[i]` fits the fundamental matrix (all false when RANSAC found
    /// no consensus).
    pub inliers: Vec<bool>,
    /// The fundamental matrix (`x_a^T F x_b = 0`), or why there is none.
    pub fundamental: Result<FundamentalEstimate, RelPoseError>,
}

/// Pixel coordinates of the matched keypoints, `(a, b)`.
pub fn match_points(
    ka: &[Keypoint],
    kb: &[Keypoint],
    matches: &[Match],
) -> (Vec<Point2<f64>>, Vec<Point2<f64>>) {
    matches
        .iter()
        .filter_map(|m| {
            let a = ka.get(m.query as usize)?;
            let b = kb.get(m.train as usize)?;
            Some((
                Point2::new(f64::from(a.x), f64::from(a.y)),
                Point2::new(f64::from(b.x), f64::from(b.y)),
            ))
        })
        .unzip()
}

/// Verifies `matches` by a fundamental-matrix RANSAC: the inlier mask and the estimate.
pub fn verify_fundamental(
    ka: &[Keypoint],
    kb: &[Keypoint],
    matches: &[Match],
    params: &FundamentalParams,
    seed: u64,
) -> (Vec<bool>, Result<FundamentalEstimate, RelPoseError>) {
    let (xa, xb) = match_points(ka, kb, matches);
    if xa.len() != matches.len() {
        return (
            vec![false; matches.len()],
            Err(RelPoseError::LengthMismatch {
                a: xa.len(),
                b: matches.len(),
            }),
        );
    }
    let est = estimate_fundamental_ransac(&xa, &xb, params, seed);
    let inliers = match &est {
        Ok(e) => e.inliers.clone(),
        Err(_) => vec![false; matches.len()],
    };
    (inliers, est)
}

/// "AKAZE + RANSAC": AKAZE on both images, brute-force Hamming with the ratio test, then the
/// fundamental-matrix RANSAC keeps the matches consistent with one epipolar geometry.
///
/// # Errors
/// Those of [`detect_and_describe_akaze`]; a failed RANSAC is not an error (see
/// [`AkazeRansacResult::fundamental`]).
pub fn match_akaze_ransac(
    a: &GrayView<'_>,
    b: &GrayView<'_>,
    params: &AkazeRansacParams,
) -> Result<AkazeRansacResult, FeatureError> {
    let run = |img: &GrayView<'_>| detect_and_describe_akaze(img, &params.akaze);
    let (fa, fb) = if params.akaze.parallel {
        rayon::join(|| run(a), || run(b))
    } else {
        (run(a), run(b))
    };
    let (fa, fb) = (fa?, fb?);
    let matches = match_mldb(&fa.descriptors, &fb.descriptors, &params.matching);
    let (inliers, fundamental) = verify_fundamental(
        &fa.keypoints,
        &fb.keypoints,
        &matches,
        &params.fundamental,
        params.seed,
    );
    Ok(AkazeRansacResult {
        features_a: fa,
        features_b: fb,
        matches,
        inliers,
        fundamental,
    })
}

#[cfg(test)]
mod tests;
