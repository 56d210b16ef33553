//! Relative camera motion between two views from matched points.
//!
//! # Conventions
//!
//! Transforms are named `a_from_b`: `p_in_a = a_from_b * p_in_b` (ARCHITECTURE.md section 6). For views
//! `i`, `j` the pipeline calls these estimators with `a = cam_i`, `b = cam_j`, so the result
//! is `A_ij = cam_i_from_cam_j`. Camera frames use OpenCV optical axes (x right, y down,
//! z forward); f64; metres and radians inside. Normalised image coordinates are
//! `x = (X/Z, Y/Z)` after undistortion ([`CameraModel::undistort_pixel`], the one camera model of `robot::camera`).
//!
//! # Estimators
//!
//! | input | function | method |
//! |---|---|---|
//! | RGB-D: matched 3D points | [`rigid3d::estimate_rigid_ransac`] | 3-point RANSAC (MSAC) + Umeyama/Horn, then anisotropic (depth-noise weighted) Gauss-Newton/LM ([`refine::refine_rigid`]) |
//! | RGB: matched normalised points | [`essential::estimate_essential_ransac`] | 5-point solver (Stewénius, Engels & Nistér 2006) in RANSAC with the Sampson error, cheirality by triangulation, Sampson LM on `SO(3) x S^2` ([`refine::refine_essential`]); `|t| = 1` |
//! | 3D point sets | [`umeyama::rigid_from_correspondences`] | closed form (Umeyama 1991, Arun et al. 1987, Horn 1987) |
//! | matched pixels (match verification) | [`fundamental::estimate_fundamental_ransac`] | normalised 8-point (Hartley 1997) in RANSAC with the Sampson distance, least-squares refit on the inliers |
//!
//! # Degenerate cases (refused with a [`RelPoseError`], never a garbage pose)
//!
//! Fewer points than the minimal sample, non-finite inputs, coincident or collinear points,
//! no consensus, and for the essential matrix a pure rotation (zero baseline: the translation
//! direction is undefined), detected by a rotation-only model explaining the inliers.
//!
//! # Accuracy (synthetic, ARCHITECTURE.md section 6, the wrist camera: 0.5 px keypoints, 0.1 mm depth at 0.5 m
//! growing with `z^2`, 20 deg / (0.08, -0.03, 0.02) m, ~300 inliers, 30-50% outliers)
//!
//! Noise-free: both estimators exact to 1e-9. Rigid: 0.008-0.014 deg, 0.02-0.07 mm, at the
//! weighted maximum-likelihood optimum of the true inliers; the anisotropic refinement beats
//! plain Umeyama (by 3x in rotation, 5x in translation when depth noise dominates, 0.3-1.5 m).
//! Essential: median 0.053 deg rotation, 0.039 deg translation direction, on par with OpenCV's
//! `USAC_ACCURATE` and 8-10x better than its `RANSAC` (`tests/relpose_opencv.rs`); a narrow
//! field of view couples rotation and translation, so RGB-D is the accurate path.
//!
//! # Determinism
//!
//! RANSAC draws its samples from a counter-based SplitMix64 stream of the given seed
//! ([`ransac::SplitMix64`]); no threads, no clock: the same input and seed give the same bits.

pub mod essential;
pub mod five_point;
pub mod fundamental;
pub mod homography;
pub mod ransac;
pub mod refine;
pub mod rigid3d;
pub mod triangulate;
pub mod umeyama;

pub use essential::{EssentialEstimate, EssentialParams, estimate_essential_ransac};
pub use refine::{DepthNoiseModel, RefineParams, RefineReport, RefineTermination};
pub use rigid3d::{RigidEstimate, RigidRansacParams, estimate_rigid_ransac};
pub use robot::camera::{CameraError, CameraModel};
pub use umeyama::{rigid_from_correspondences, similarity_from_correspondences};

/// Errors of the relative pose estimators; every variant carries the numbers that explain it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RelPoseError {
    /// Fewer correspondences than the method needs.
    #[error("too few correspondences: got {got}, need at least {need}")]
    TooFewCorrespondences {
        /// Number of correspondences given (or left after filtering).
        got: usize,
        /// Minimum the method needs.
        need: usize,
    },
    /// The two point lists (or the weights) have different lengths.
    #[error("length mismatch: {a} points in a, {b} in b")]
    LengthMismatch {
        /// Length of the first list.
        a: usize,
        /// Length of the second list (or of the weights).
        b: usize,
    },
    /// A coordinate, weight or depth is NaN or infinite.
    #[error("non-finite input at index {index}")]
    NonFinite {
        /// Index of the first offending correspondence.
        index: usize,
    },
    /// A weight is negative, or all weights are zero.
    #[error("invalid weight {value} at index {index}")]
    InvalidWeight {
        /// Index of the offending weight.
        index: usize,
        /// Its value.
        value: f64,
    },
    /// The configuration does not determine the motion (coincident/collinear points, pure
    /// rotation for the essential matrix, ...).
    #[error("degenerate configuration: {reason}")]
    Degenerate {
        /// What is degenerate, with the measured figure.
        reason: String,
    },
    /// RANSAC found no model supported by enough inliers.
    #[error("no consensus: best model has {best_inliers} inliers, {needed} needed")]
    NoConsensus {
        /// Inliers of the best hypothesis.
        best_inliers: usize,
        /// Inliers required.
        needed: usize,
    },
    /// A parameter is out of its valid range.
    #[error("invalid parameter {name} = {value}")]
    InvalidParameter {
        /// Parameter name.
        name: &'static str,
        /// Its value.
        value: f64,
    },
    /// The camera model refused a pixel or a depth (non-finite, out of the distortion's
    /// domain, undistortion not converged).
    #[error(transparent)]
    Camera(#[from] CameraError),
    /// A linear-algebra step (SVD, Schur) failed to converge.
    #[error("numerical failure in {step}")]
    Numerical {
        /// Which step failed.
        step: &'static str,
    },
}

/// Checks that two slices have the same length and at least `need` entries.
pub(crate) fn check_lengths(a: usize, b: usize, need: usize) -> Result<(), RelPoseError> {
    if a != b {
        return Err(RelPoseError::LengthMismatch { a, b });
    }
    if a < need {
        return Err(RelPoseError::TooFewCorrespondences { got: a, need });
    }
    Ok(())
}

/// Skew-symmetric matrix `[v]x` with `[v]x w = v x w`.
pub(crate) fn skew(v: &nalgebra::Vector3<f64>) -> nalgebra::Matrix3<f64> {
    nalgebra::Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}
