//! Essential matrix from normalised correspondences (RGB only): 5-point RANSAC, cheirality,
//! Sampson refinement; translation up to scale (`|t| = 1`).
//!
//! With `(R, t) = a_from_b` and homogeneous normalised points, `x_a^T E x_b = 0` for
//! `E = [t]x R` (Longuet-Higgins 1981; Hartley & Zisserman 2004, sec. 9.6, with camera `b` as
//! `[I | 0]`).
//!
//! **Minimal solver**: the five-point solver of [`super::five_point`].
//!
//! **Robust estimation** ([`estimate_essential_ransac`]): RANSAC/MSAC on 5-point samples, each
//! candidate scored with the Sampson distance ([`super::refine::sampson_distance`]); optionally
//! the normalised 8-point algorithm on the inliers (Hartley 1997, [`essential_eight_point`])
//! when it lowers the Sampson cost; decomposition `E = U diag(1,1,0) V^T` into
//! `R = U W V^T` or `U W^T V^T`, `t = +-u_3` (H&Z result 9.19) with the candidate chosen by
//! cheirality (most inliers triangulated in front of both cameras,
//! [`super::triangulate::triangulate_midpoint`]); then the Levenberg-Marquardt Sampson
//! refinement on `SO(3) x S^2` ([`super::refine::refine_essential`]) and inlier re-selection.
//!
//! **Degenerate cases.** Fewer than 5 pairs; coincident or collinear image points; a pure
//! rotation (zero baseline): then every `t` satisfies the epipolar constraint, so the
//! estimate would be garbage (the 5-point system then has a continuum of solutions). It is
//! detected by model selection (the idea of Torr's GRIC, 1998): a second RANSAC fits the
//! rotation-only model `f_a = R f_b` (unit bearing vectors, 2-point Kabsch samples, angular
//! residual) and when it explains at least [`EssentialParams::pure_rotation_ratio`] times as
//! many correspondences as the essential matrix, or the median rotation-compensated parallax
//! of the final inliers is below [`EssentialParams::pure_rotation_threshold_rad`], or the
//! refined direction's standard deviation exceeds [`EssentialParams::max_direction_std_rad`]
//! (near-zero baselines), a [`RelPoseError::Degenerate`] is returned.

//! **Rotation-angle prior** ([`EssentialParams::rotation_angle_prior`]). A scene dominated
//! by one plane (a cabinet face filling a narrow field of view) with keypoints a pixel off
//! is nearly degenerate for `E`: the plane's homography is compatible with a family of
//! essential matrices, and with the few off-plane points blurred by keypoint noise, wrong
//! members of that family (typically a near-zero rotation with a sideways translation)
//! collect as much support as the true motion. When the rotation angle of the motion is
//! known (the hand's, on a hand-eye rig: [`RotationAnglePrior`]), every hypothesis, local
//! refit and decomposition must have it; the final estimate is refused when the refinement
//! leaves it. Measured on simulated calibration views of a cabinet at 0.4-0.5 m (640x512,
//! 1 px threshold): without the prior 40% of the pairs came out more than 5 deg wrong.
//!
//! **Planar scenes** ([`EssentialParams::planar_support_ratio`]). When a homography
//! explains nearly as many correspondences as `E` (the model selection of ORB-SLAM's
//! initialisation and COLMAP's two-view geometry), `E` is not determined and the motion is
//! taken from the homography's decomposition ([`super::homography`]) instead: the
//! decomposition with the expected rotation angle and most points in front (blind), or the
//! one nearest the predicted motion (guided); refused when two remain equally good. Its
//! inliers are then classified by the Sampson distance of that motion without refinement.
//!
//! **Local optimisation.** Each new best hypothesis is refitted on its inliers (8-point and
//! a few Sampson LM steps, [`super::ransac::ransac_lo`]) before the stopping rule uses its
//! inlier fraction.

use nalgebra::{
    Isometry3, Matrix3, Point2, Point3, Rotation3, Translation3, UnitQuaternion, Vector3,
};

pub use super::five_point::essential_five_point;
use super::homography::{decompose_homography, estimate_homography_ransac};
use super::ransac::{RansacConfig, ransac, ransac_lo, required_iterations};
use super::refine::{
    MAX_REFINE_ROUNDS, RefineParams, RefineReport, refine_essential, sampson_distance,
};
use super::triangulate::{triangulate_dlt, triangulate_midpoint};
use super::{RelPoseError, check_lengths, skew};

/// Sampson LM iterations of one local optimisation step ([`estimate_essential_ransac`]).
pub const LOCAL_REFINE_ITERATIONS: usize = 5;

/// Minimal sample size of the essential matrix.
pub const ESSENTIAL_SAMPLE_SIZE: usize = 5;
/// Relative bound on the smallest eigenvalue of the 2x2 image-point covariance below which the
/// points count as collinear.
pub const COLLINEAR_IMAGE_RATIO: f64 = 1e-10;

/// Parameters of [`estimate_essential_ransac`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EssentialParams {
    /// Inlier threshold on the absolute Sampson distance, normalised image units; default
    /// `1 / 1745` (1 px at the wrist camera's focal length).
    pub inlier_threshold: f64,
    /// Stopping rule; default [`RansacConfig::default`] (p = 0.999, 50..5000 iterations).
    pub ransac: RansacConfig,
    /// Minimum inliers (after cheirality) to accept a motion; default 15.
    pub min_inliers: usize,
    /// Pure-rotation test: inlier threshold of the rotation-only model (angle between `f_a`
    /// and `R f_b`), radians; default `2 / 1745` (2 px at the wrist camera's focal length).
    pub pure_rotation_threshold_rad: f64,
    /// Pure-rotation test: refuse when the rotation-only model has at least this fraction of
    /// the essential matrix's inliers; default 0.5 (on the wrist camera's 0.3-0.6 m scenes with
    /// 0.5 px noise this refuses baselines below ~4 mm, whose translation directions came out
    /// 3-140 deg wrong, and keeps 5 mm and more).
    pub pure_rotation_ratio: f64,
    /// Refuse when the refined translation direction's standard deviation (worst axis,
    /// [`RefineReport::translation_std`]) exceeds this, radians; default 5 deg. Only checked
    /// when [`EssentialParams::refine`] is on.
    pub max_direction_std_rad: f64,
    /// Try the normalised 8-point algorithm on the RANSAC inliers and keep it when its Sampson
    /// cost is lower; default false (the refinement reaches the same optimum).
    pub eight_point_polish: bool,
    /// Run the Sampson Levenberg-Marquardt refinement; default true.
    pub refine: bool,
    /// Stopping rules of the refinement; default [`RefineParams::default`].
    pub refine_params: RefineParams,
    /// Triangulate the final inliers (DLT) into [`EssentialEstimate::points_in_a`]; default
    /// false.
    pub triangulate: bool,
    /// The rotation angle the motion is known to have, when it is known (module docs,
    /// "Rotation-angle prior"); default `None`.
    pub rotation_angle_prior: Option<RotationAnglePrior>,
    /// Planar scenes (module docs, "Planar scenes"): when a homography explains at least
    /// this fraction of the essential matrix's inliers, the motion comes from the
    /// homography's decomposition instead; `None` (default) always uses `E`.
    pub planar_support_ratio: Option<f64>,
}

/// A known rotation angle of the camera motion with its tolerance, radians.
///
/// On a hand-eye rig the camera motion `A` and the hand motion `B = X A X^-1` are conjugate,
/// so they rotate by the same angle (Chen's screw congruence theorem, IEEE CVPR 1991), whatever
/// the unknown mount `X`: the hand's angle, from the encoders, tells which essential
/// matrices are possible before `X` is known.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RotationAnglePrior {
    /// The expected angle of `R`, radians in `[0, pi]`.
    pub angle_rad: f64,
    /// Largest accepted `|angle(R) - angle_rad|`, radians.
    pub tolerance_rad: f64,
}

impl RotationAnglePrior {
    /// Whether rotation `r` has the expected angle.
    pub fn admits(&self, r: &UnitQuaternion<f64>) -> bool {
        (r.angle() - self.angle_rad).abs() <= self.tolerance_rad
    }

    /// Whether one of the two rotations of `E` (the twisted pair `U W V^T`, `U W^T V^T`) has
    /// the expected angle.
    pub fn admits_essential(&self, e: &Matrix3<f64>) -> bool {
        decompose_essential(e).is_ok_and(|c| c.iter().any(|p| self.admits(&p.rotation)))
    }
}

impl Default for EssentialParams {
    fn default() -> Self {
        Self {
            inlier_threshold: 1.0 / 1745.0,
            ransac: RansacConfig::default(),
            min_inliers: 15,
            pure_rotation_threshold_rad: 2.0 / 1745.0,
            pure_rotation_ratio: 0.5,
            max_direction_std_rad: 5f64.to_radians(),
            eight_point_polish: false,
            refine: true,
            refine_params: RefineParams::default(),
            triangulate: false,
            rotation_angle_prior: None,
            planar_support_ratio: None,
        }
    }
}

/// Result of [`estimate_essential_ransac`].
#[derive(Debug, Clone, PartialEq)]
pub struct EssentialEstimate {
    /// The motion `a_from_b` with `|t| = 1` (metric scale unknown).
    pub a_from_b: Isometry3<f64>,
    /// `E = [t]x R` of `a_from_b` (Frobenius norm `sqrt 2`).
    pub essential: Matrix3<f64>,
    /// Inlier flags: Sampson distance within the threshold and in front of both cameras.
    pub inliers: Vec<bool>,
    /// Number of inliers.
    pub inlier_count: usize,
    /// Points (among the RANSAC inliers) in front of both cameras for the four decompositions
    /// `(R1, t), (R1, -t), (R2, t), (R2, -t)` of the RANSAC essential matrix.
    pub cheirality_counts: [usize; 4],
    /// Index of the decomposition chosen (most points in front).
    pub chosen_decomposition: usize,
    /// Root mean square Sampson distance over the inliers, normalised units.
    pub rms_sampson: f64,
    /// Median rotation-compensated parallax over the inliers (angle between `f_a` and `R f_b`
    /// for the best rotation-only `R`), radians.
    pub median_parallax_rad: f64,
    /// RANSAC iterations run.
    pub iterations: usize,
    /// Report of the last refinement (`None` when disabled).
    pub refine: Option<RefineReport>,
    /// Inliers triangulated in camera `a` (units of `|t|`); `None` for outliers. Empty unless
    /// [`EssentialParams::triangulate`].
    pub points_in_a: Vec<Option<Point3<f64>>>,
}

/// Hartley's isotropic normalisation: centroid to the origin, mean distance `sqrt 2`.
fn hartley_normalisation(x: &[Point2<f64>]) -> Matrix3<f64> {
    let n = x.len().max(1) as f64;
    let c = x
        .iter()
        .fold(nalgebra::Vector2::zeros(), |acc, p| acc + p.coords)
        / n;
    let mean_dist = x.iter().map(|p| (p.coords - c).norm()).sum::<f64>() / n;
    let s = if mean_dist > 0.0 {
        std::f64::consts::SQRT_2 / mean_dist
    } else {
        1.0
    };
    Matrix3::new(s, 0.0, -s * c.x, 0.0, s, -s * c.y, 0.0, 0.0, 1.0)
}

/// Projects a 3x3 matrix onto the essential manifold (singular values `(1, 1, 0)`, H&Z
/// sec. 9.6, up to scale), unit Frobenius norm.
///
/// # Errors
/// [`RelPoseError::Numerical`] (SVD failure).
pub fn project_to_essential(m: &Matrix3<f64>) -> Result<Matrix3<f64>, RelPoseError> {
    let svd = nalgebra::SVD::try_new(*m, true, true, f64::EPSILON, 1000).ok_or(
        RelPoseError::Numerical {
            step: "essential projection svd",
        },
    )?;
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
        return Err(RelPoseError::Numerical {
            step: "essential projection svd",
        });
    };
    let e = u * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, 0.0)) * v_t;
    Ok(e / std::f64::consts::SQRT_2)
}

/// Normalised 8-point algorithm (Hartley 1997, "In defense of the eight-point algorithm",
/// PAMI 19(6)) for `x_a^T E x_b = 0` on `n >= 8` correspondences, projected onto the
/// essential manifold; unit Frobenius norm.
///
/// # Errors
/// [`RelPoseError::LengthMismatch`], [`RelPoseError::TooFewCorrespondences`] (< 8),
/// [`RelPoseError::NonFinite`], [`RelPoseError::Numerical`].
pub fn essential_eight_point(
    x_a: &[Point2<f64>],
    x_b: &[Point2<f64>],
) -> Result<Matrix3<f64>, RelPoseError> {
    check_lengths(x_a.len(), x_b.len(), 8)?;
    check_finite(x_a, x_b)?;
    let ta = hartley_normalisation(x_a);
    let tb = hartley_normalisation(x_b);
    let rows = x_a.len().max(9);
    let mut a = nalgebra::DMatrix::<f64>::zeros(rows, 9);
    for (r, (pa, pb)) in x_a.iter().zip(x_b).enumerate() {
        let xa = ta * Vector3::new(pa.x, pa.y, 1.0);
        let xb = tb * Vector3::new(pb.x, pb.y, 1.0);
        for m in 0..3 {
            for n in 0..3 {
                a[(r, 3 * m + n)] = xa[m] * xb[n];
            }
        }
    }
    let svd = nalgebra::SVD::try_new(a, false, true, f64::EPSILON, 1000).ok_or(
        RelPoseError::Numerical {
            step: "eight-point svd",
        },
    )?;
    let Some(v_t) = svd.v_t else {
        return Err(RelPoseError::Numerical {
            step: "eight-point svd",
        });
    };
    let last = v_t.nrows().saturating_sub(1);
    let e_hat = Matrix3::from_fn(|m, n| v_t[(last, 3 * m + n)]);
    project_to_essential(&(ta.transpose() * e_hat * tb))
}

/// The four `(R, t)` of `E = U diag(1,1,0) V^T` (H&Z result 9.19), as `a_from_b` with
/// `|t| = 1`, in the order `(R1, t), (R1, -t), (R2, t), (R2, -t)`, `R1 = U W V^T`,
/// `R2 = U W^T V^T`, `t = u_3`.
///
/// # Errors
/// [`RelPoseError::Numerical`] (SVD failure), [`RelPoseError::NonFinite`].
pub fn decompose_essential(e: &Matrix3<f64>) -> Result<[Isometry3<f64>; 4], RelPoseError> {
    if !e.iter().all(|v| v.is_finite()) {
        return Err(RelPoseError::NonFinite { index: 0 });
    }
    let svd = nalgebra::SVD::try_new(*e, true, true, f64::EPSILON, 1000).ok_or(
        RelPoseError::Numerical {
            step: "essential decomposition svd",
        },
    )?;
    let (Some(mut u), Some(mut v_t)) = (svd.u, svd.v_t) else {
        return Err(RelPoseError::Numerical {
            step: "essential decomposition svd",
        });
    };
    if u.determinant() < 0.0 {
        u = -u;
    }
    if v_t.determinant() < 0.0 {
        v_t = -v_t;
    }
    let w = Matrix3::new(0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0);
    let r1 = u * w * v_t;
    let r2 = u * w.transpose() * v_t;
    let t: Vector3<f64> = u.column(2).into_owned();
    let iso = |r: &Matrix3<f64>, t: Vector3<f64>| {
        Isometry3::from_parts(
            Translation3::from(t),
            UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(*r)),
        )
    };
    Ok([iso(&r1, t), iso(&r1, -t), iso(&r2, t), iso(&r2, -t)])
}

fn check_finite(x_a: &[Point2<f64>], x_b: &[Point2<f64>]) -> Result<(), RelPoseError> {
    for (i, (a, b)) in x_a.iter().zip(x_b).enumerate() {
        if !(a
            .coords
            .iter()
            .chain(b.coords.iter())
            .all(|c| c.is_finite()))
        {
            return Err(RelPoseError::NonFinite { index: i });
        }
    }
    Ok(())
}

/// Ratio of the smaller to the larger eigenvalue of the 2x2 covariance of the points (0 when
/// collinear or coincident).
fn image_spread_ratio(x: &[Point2<f64>]) -> f64 {
    let n = x.len().max(1) as f64;
    let c = x
        .iter()
        .fold(nalgebra::Vector2::zeros(), |acc, p| acc + p.coords)
        / n;
    let cov = x.iter().fold(nalgebra::Matrix2::zeros(), |acc, p| {
        let d = p.coords - c;
        acc + d * d.transpose()
    }) / n;
    let eig = cov.symmetric_eigenvalues();
    let (lo, hi) = (eig.min(), eig.max());
    if hi > 0.0 { lo.max(0.0) / hi } else { 0.0 }
}

fn bearing(x: &Point2<f64>) -> Vector3<f64> {
    Vector3::new(x.x, x.y, 1.0).normalize()
}

/// Rotation `R` maximising `sum f_a^T R f_b` over bearing pairs (Kabsch 1976; the
/// rotation-only model of a zero-baseline motion).
fn rotation_from_bearings<'a>(
    pairs: impl Iterator<Item = (&'a Vector3<f64>, &'a Vector3<f64>)>,
) -> Option<Matrix3<f64>> {
    let mut h = Matrix3::zeros();
    for (fa, fb) in pairs {
        h += fa * fb.transpose();
    }
    let svd = nalgebra::SVD::try_new(h, true, true, f64::EPSILON, 1000)?;
    let (u, v_t) = (svd.u?, svd.v_t?);
    let d = if u.determinant() * v_t.determinant() < 0.0 {
        -1.0
    } else {
        1.0
    };
    Some(u * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * v_t)
}

/// Angle between two unit vectors, accurate near 0 (`atan2(|a x b|, a . b)`).
fn angle_between(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    a.cross(b).norm().atan2(a.dot(b))
}

/// Median angle between `f_a` and `R f_b` for the best rotation-only model `R` (Kabsch on the
/// bearing vectors) over the masked correspondences: the rotation-compensated parallax.
/// `NaN` when the mask is empty.
///
/// # Errors
/// [`RelPoseError::Numerical`] (SVD failure).
pub fn rotation_only_median_residual_rad(
    x_a: &[Point2<f64>],
    x_b: &[Point2<f64>],
    mask: Option<&[bool]>,
) -> Result<f64, RelPoseError> {
    let used = |i: usize| mask.is_none_or(|m| m.get(i).copied().unwrap_or(false));
    let fa: Vec<Vector3<f64>> = x_a.iter().map(bearing).collect();
    let fb: Vec<Vector3<f64>> = x_b.iter().map(bearing).collect();
    let pairs = || {
        fa.iter()
            .zip(&fb)
            .enumerate()
            .filter(|(i, _)| used(*i))
            .map(|(_, p)| p)
    };
    if pairs().next().is_none() {
        return Ok(f64::NAN);
    }
    let r = rotation_from_bearings(pairs()).ok_or(RelPoseError::Numerical {
        step: "rotation-only svd",
    })?;
    let mut angles: Vec<f64> = pairs().map(|(a, b)| angle_between(a, &(r * b))).collect();
    angles.sort_by(f64::total_cmp);
    Ok(angles.get(angles.len() / 2).copied().unwrap_or(f64::NAN))
}

/// Inliers of the best rotation-only model (2-point RANSAC on bearings, module docs).
fn rotation_only_support(
    x_a: &[Point2<f64>],
    x_b: &[Point2<f64>],
    threshold_rad: f64,
    config: &RansacConfig,
    seed: u64,
) -> usize {
    let fa: Vec<Vector3<f64>> = x_a.iter().map(bearing).collect();
    let fb: Vec<Vector3<f64>> = x_b.iter().map(bearing).collect();
    let outcome = ransac(
        fa.len(),
        2,
        threshold_rad * threshold_rad,
        config,
        seed,
        |s, models| {
            let pairs = s.iter().filter_map(|&i| fa.get(i).zip(fb.get(i)));
            if let Some(r) = rotation_from_bearings(pairs) {
                models.push(r);
            }
        },
        |r, i| match (fa.get(i), fb.get(i)) {
            (Some(a), Some(b)) => (a - r * b).norm_squared(),
            _ => f64::INFINITY,
        },
    );
    outcome.inlier_count
}

/// Sampson inliers of `a_from_b` that also triangulate in front of both cameras.
fn classify(
    x_a: &[Point2<f64>],
    x_b: &[Point2<f64>],
    a_from_b: &Isometry3<f64>,
    threshold: f64,
) -> (Vec<bool>, usize, f64) {
    let e = essential_of(a_from_b);
    let mut flags = Vec::with_capacity(x_a.len());
    let mut count = 0;
    let mut sum_sq = 0.0;
    for (a, b) in x_a.iter().zip(x_b) {
        let d = sampson_distance(&e, a, b).unwrap_or(f64::INFINITY);
        let ok = d.abs() <= threshold
            && triangulate_midpoint(a_from_b, a, b).is_ok_and(|t| t.in_front());
        if ok {
            count += 1;
            sum_sq += d * d;
        }
        flags.push(ok);
    }
    let rms = if count > 0 {
        (sum_sq / count as f64).sqrt()
    } else {
        f64::NAN
    };
    (flags, count, rms)
}

/// `E = [t]x R` of a motion.
pub fn essential_of(a_from_b: &Isometry3<f64>) -> Matrix3<f64> {
    skew(&a_from_b.translation.vector) * a_from_b.rotation.to_rotation_matrix().into_inner()
}

fn sampson_cost(e: &Matrix3<f64>, x_a: &[Point2<f64>], x_b: &[Point2<f64>], mask: &[bool]) -> f64 {
    x_a.iter()
        .zip(x_b)
        .zip(mask)
        .filter(|(_, m)| **m)
        .map(|((a, b), _)| sampson_distance(e, a, b).map_or(f64::INFINITY, |d| d * d))
        .sum()
}

/// Estimates `a_from_b` (rotation, translation direction) from normalised undistorted
/// correspondences (`x_a[i]` in camera `a` and `x_b[i]` in camera `b` see the same point), as
/// described in the module docs. Deterministic for a given `seed`.
///
/// # Errors
/// [`RelPoseError::LengthMismatch`], [`RelPoseError::TooFewCorrespondences`] (< 5),
/// [`RelPoseError::NonFinite`], [`RelPoseError::InvalidParameter`],
/// [`RelPoseError::Degenerate`] (collinear/coincident points, pure rotation, ambiguous
/// cheirality), [`RelPoseError::NoConsensus`].
pub fn estimate_essential_ransac(
    x_a: &[Point2<f64>],
    x_b: &[Point2<f64>],
    params: &EssentialParams,
    seed: u64,
) -> Result<EssentialEstimate, RelPoseError> {
    check_lengths(x_a.len(), x_b.len(), ESSENTIAL_SAMPLE_SIZE)?;
    check_finite(x_a, x_b)?;
    let thr = params.inlier_threshold;
    if !(thr.is_finite() && thr > 0.0) {
        return Err(RelPoseError::InvalidParameter {
            name: "inlier_threshold",
            value: thr,
        });
    }
    for (name, value) in [
        (
            "pure_rotation_threshold_rad",
            params.pure_rotation_threshold_rad,
        ),
        ("pure_rotation_ratio", params.pure_rotation_ratio),
        ("max_direction_std_rad", params.max_direction_std_rad),
    ] {
        if !(value.is_finite() && value > 0.0) {
            return Err(RelPoseError::InvalidParameter { name, value });
        }
    }
    for x in [x_a, x_b] {
        let ratio = image_spread_ratio(x);
        if ratio.is_nan() || ratio <= COLLINEAR_IMAGE_RATIO {
            return Err(RelPoseError::Degenerate {
                reason: format!(
                    "image points coincident or collinear (covariance eigenvalue ratio {ratio:.3e})"
                ),
            });
        }
    }
    let n = x_a.len();
    let needed = params.min_inliers.max(ESSENTIAL_SAMPLE_SIZE);
    // Local optimisation of each new best E (module docs): the 8-point algorithm on its
    // inliers and a few Sampson LM steps from it.
    let prior = params.rotation_angle_prior;
    let admits = |e: &Matrix3<f64>| prior.is_none_or(|p| p.admits_essential(e));
    let lo_params = RefineParams {
        max_iterations: LOCAL_REFINE_ITERATIONS,
        ..params.refine_params
    };
    let outcome = ransac_lo(
        n,
        ESSENTIAL_SAMPLE_SIZE,
        thr * thr,
        &params.ransac,
        seed,
        |s, models| {
            let mut sa = [Point2::origin(); ESSENTIAL_SAMPLE_SIZE];
            let mut sb = [Point2::origin(); ESSENTIAL_SAMPLE_SIZE];
            for ((pa, pb), &q) in sa.iter_mut().zip(sb.iter_mut()).zip(s) {
                let (Some(a), Some(b)) = (x_a.get(q), x_b.get(q)) else {
                    return;
                };
                *pa = *a;
                *pb = *b;
            }
            if let Ok(es) = essential_five_point(&sa, &sb) {
                models.extend(es.into_iter().filter(|e| admits(e)));
            }
        },
        |e, i| match (x_a.get(i), x_b.get(i)) {
            (Some(a), Some(b)) => sampson_distance(e, a, b).map_or(f64::INFINITY, |d| d * d),
            _ => f64::INFINITY,
        },
        |e, mask, models| {
            let sa = select(x_a, mask);
            let sb = select(x_b, mask);
            if let Ok(e8) = essential_eight_point(&sa, &sb)
                && admits(&e8)
            {
                models.push(e8);
            }
            // Any of the four decompositions gives the same E, hence the same Sampson cost.
            if let Ok([pose, ..]) = decompose_essential(e)
                && let Ok(r) = refine_essential(&sa, &sb, &pose, &lo_params)
                && admits(&essential_of(&r.a_from_b))
            {
                models.push(essential_of(&r.a_from_b));
            }
        },
    );
    // Pure rotation: the rotation-only model explains (nearly) as much as E. Only a rotation
    // with at least `ratio * |E inliers|` support matters, so the iterations that find such a
    // model with the configured confidence suffice.
    let min_fraction =
        params.pure_rotation_ratio * outcome.inlier_count.max(needed) as f64 / n as f64;
    let rotation_config = RansacConfig {
        max_iterations: required_iterations(&params.ransac, min_fraction, 2),
        ..params.ransac
    };
    let rotation_support = rotation_only_support(
        x_a,
        x_b,
        params.pure_rotation_threshold_rad,
        &rotation_config,
        seed ^ 0x5EED_0FA0_7A7E,
    );
    if rotation_support >= needed
        && rotation_support as f64 >= params.pure_rotation_ratio * outcome.inlier_count as f64
    {
        return Err(RelPoseError::Degenerate {
            reason: format!(
                "pure rotation: a rotation-only model explains {rotation_support} \
                 correspondences, the essential matrix {}; translation direction undefined",
                outcome.inlier_count
            ),
        });
    }
    let Some(mut e_best) = outcome.model else {
        return Err(RelPoseError::NoConsensus {
            best_inliers: 0,
            needed,
        });
    };
    if outcome.inlier_count < needed {
        return Err(RelPoseError::NoConsensus {
            best_inliers: outcome.inlier_count,
            needed,
        });
    }
    let ransac_mask = outcome.inliers;
    if params.eight_point_polish && outcome.inlier_count >= 8 {
        let sa: Vec<_> = select(x_a, &ransac_mask);
        let sb: Vec<_> = select(x_b, &ransac_mask);
        if let Ok(e8) = essential_eight_point(&sa, &sb)
            && sampson_cost(&e8, x_a, x_b, &ransac_mask)
                < sampson_cost(&e_best, x_a, x_b, &ransac_mask)
        {
            e_best = e8;
        }
    }
    if let Some(planar) = planar_motion(x_a, x_b, params, outcome.inlier_count, None, seed)? {
        return Ok(planar);
    }
    // Cheirality: pick the decomposition with the most points in front of both cameras.
    let candidates = decompose_essential(&e_best)?;
    let mut cheirality_counts = [0usize; 4];
    for (count, cand) in cheirality_counts.iter_mut().zip(&candidates) {
        if prior.is_some_and(|p| !p.admits(&cand.rotation)) {
            continue; // the other rotation of the twisted pair has the hand's angle
        }
        *count = x_a
            .iter()
            .zip(x_b)
            .zip(&ransac_mask)
            .filter(|(_, m)| **m)
            .filter(|((a, b), _)| triangulate_midpoint(cand, a, b).is_ok_and(|t| t.in_front()))
            .count();
    }
    let (chosen_decomposition, &best_count) = cheirality_counts
        .iter()
        .enumerate()
        .max_by_key(|(_, c)| **c)
        .unwrap_or((0, &0));
    let Some(&chosen) = candidates.get(chosen_decomposition) else {
        return Err(RelPoseError::Numerical {
            step: "decomposition",
        });
    };
    if best_count < needed || 2 * best_count < outcome.inlier_count {
        return Err(RelPoseError::Degenerate {
            reason: format!(
                "cheirality: best decomposition has {best_count} of {} inliers in front \
                 (counts {cheirality_counts:?})",
                outcome.inlier_count
            ),
        });
    }
    finish(
        x_a,
        x_b,
        params,
        chosen,
        Search {
            cheirality_counts,
            chosen_decomposition,
            iterations: outcome.iterations,
        },
    )
}

/// How [`finish`]'s starting motion was found (reported in [`EssentialEstimate`]).
struct Search {
    cheirality_counts: [usize; 4],
    chosen_decomposition: usize,
    iterations: usize,
}

/// From a starting motion to the estimate: inlier selection and Sampson refinement
/// (alternated), then the acceptance checks (inlier count, rotation-angle prior, direction
/// conditioning, parallax) and the optional triangulation.
fn finish(
    x_a: &[Point2<f64>],
    x_b: &[Point2<f64>],
    params: &EssentialParams,
    start: Isometry3<f64>,
    search: Search,
) -> Result<EssentialEstimate, RelPoseError> {
    let thr = params.inlier_threshold;
    let prior = params.rotation_angle_prior;
    let needed = params.min_inliers.max(ESSENTIAL_SAMPLE_SIZE);
    let Search {
        cheirality_counts,
        chosen_decomposition,
        iterations,
    } = search;
    let mut a_from_b = start;
    let (mut mask, mut count, _) = classify(x_a, x_b, &a_from_b, thr);
    let mut report = None;
    if params.refine {
        for _round in 0..MAX_REFINE_ROUNDS {
            if count < needed {
                break;
            }
            let r = refine_essential(
                &select(x_a, &mask),
                &select(x_b, &mask),
                &a_from_b,
                &params.refine_params,
            )?;
            a_from_b = r.a_from_b;
            report = Some(r);
            let (m, c, _) = classify(x_a, x_b, &a_from_b, thr);
            let unchanged = m == mask;
            mask = m;
            count = c;
            if unchanged {
                break;
            }
        }
    }
    let (inliers, inlier_count, rms_sampson) = classify(x_a, x_b, &a_from_b, thr);
    if inlier_count < needed {
        return Err(RelPoseError::NoConsensus {
            best_inliers: inlier_count,
            needed,
        });
    }
    if let Some(r) = &report
        && r.translation_std > params.max_direction_std_rad
    {
        return Err(RelPoseError::Degenerate {
            reason: format!(
                "translation direction ill-conditioned: standard deviation {:.2} deg > {:.2} deg \
                 ({inlier_count} inliers; baseline too small for the parallax)",
                r.translation_std.to_degrees(),
                params.max_direction_std_rad.to_degrees()
            ),
        });
    }
    if let Some(p) = prior
        && !p.admits(&a_from_b.rotation)
    {
        return Err(RelPoseError::Degenerate {
            reason: format!(
                "rotation angle {:.2} deg drifted away from the expected {:.2} +- {:.2} deg \
                 during refinement ({inlier_count} inliers)",
                a_from_b.rotation.angle().to_degrees(),
                p.angle_rad.to_degrees(),
                p.tolerance_rad.to_degrees()
            ),
        });
    }
    let median_parallax_rad = rotation_only_median_residual_rad(x_a, x_b, Some(&inliers))?;
    if median_parallax_rad.is_nan() || median_parallax_rad < params.pure_rotation_threshold_rad {
        return Err(RelPoseError::Degenerate {
            reason: format!(
                "pure rotation: median rotation-compensated parallax {median_parallax_rad:.3e} \
                 rad < {:.3e} rad over {inlier_count} inliers; translation direction undefined",
                params.pure_rotation_threshold_rad
            ),
        });
    }
    let points_in_a = if params.triangulate {
        x_a.iter()
            .zip(x_b)
            .zip(&inliers)
            .map(|((a, b), &m)| {
                if m {
                    triangulate_dlt(&a_from_b, a, b).ok().map(|t| t.p_in_a)
                } else {
                    None
                }
            })
            .collect()
    } else {
        Vec::new()
    };
    Ok(EssentialEstimate {
        essential: essential_of(&a_from_b),
        a_from_b,
        inliers,
        inlier_count,
        cheirality_counts,
        chosen_decomposition,
        rms_sampson,
        median_parallax_rad,
        iterations,
        refine: report,
        points_in_a,
    })
}

/// Refines a motion known approximately (`guess`, e.g. `X^-1 B X` from a first hand-eye
/// estimate) on all correspondences without RANSAC: inliers are the correspondences within
/// the threshold of the current motion and in front of both cameras, alternated with the
/// Sampson refinement as in [`estimate_essential_ransac`], with the same acceptance checks.
/// Guided estimation avoids the wrong members of a near-planar scene's essential family
/// (module docs) that a blind search can prefer; the refinement itself is free, so a guess a
/// few degrees off still converges to the data's optimum.
///
/// # Errors
/// As [`estimate_essential_ransac`]; [`RelPoseError::Degenerate`] for a guess without
/// translation.
pub fn refine_essential_guided(
    x_a: &[Point2<f64>],
    x_b: &[Point2<f64>],
    guess: &Isometry3<f64>,
    params: &EssentialParams,
    seed: u64,
) -> Result<EssentialEstimate, RelPoseError> {
    check_lengths(x_a.len(), x_b.len(), ESSENTIAL_SAMPLE_SIZE)?;
    check_finite(x_a, x_b)?;
    let t = guess.translation.vector;
    let norm = t.norm();
    if !(norm.is_finite() && norm > 0.0) {
        return Err(RelPoseError::Degenerate {
            reason: "guided estimate: the guessed motion has no translation".into(),
        });
    }
    let start = Isometry3::from_parts(Translation3::from(t / norm), guess.rotation);
    let (_, in_front, _) = classify(x_a, x_b, &start, params.inlier_threshold);
    if let Some(planar) = planar_motion(x_a, x_b, params, in_front, Some(&start), seed)? {
        return Ok(planar);
    }
    finish(
        x_a,
        x_b,
        params,
        start,
        Search {
            cheirality_counts: [in_front, 0, 0, 0],
            chosen_decomposition: 0,
            iterations: 0,
        },
    )
}

/// The planar-scene path (module docs, "Planar scenes"): `Ok(None)` when the scene is not
/// planar enough (or the path is off), the estimate from the homography otherwise.
///
/// `e_support`: the essential model's inlier count; `guess`: the predicted motion of a
/// guided estimate, which then picks the decomposition (the nearest rotation) instead of
/// cheirality.
fn planar_motion(
    x_a: &[Point2<f64>],
    x_b: &[Point2<f64>],
    params: &EssentialParams,
    e_support: usize,
    guess: Option<&Isometry3<f64>>,
    seed: u64,
) -> Result<Option<EssentialEstimate>, RelPoseError> {
    let Some(ratio) = params.planar_support_ratio else {
        return Ok(None);
    };
    let thr = params.inlier_threshold;
    let h = estimate_homography_ransac(x_a, x_b, thr, &params.ransac, seed ^ 0x9A1A_4A2E);
    let Some(hm) = h.model else {
        return Ok(None);
    };
    if (h.inlier_count as f64) < ratio * e_support as f64 {
        return Ok(None);
    }
    let Some(cands) = decompose_homography(&hm) else {
        return Err(RelPoseError::Degenerate {
            reason: format!(
                "planar scene ({} of the correspondences on one homography) seen without \
                 translation: the motion is not recoverable",
                h.inlier_count
            ),
        });
    };
    let prior = params.rotation_angle_prior;
    let in_front = |m: &Isometry3<f64>| {
        x_a.iter()
            .zip(x_b)
            .zip(&h.inliers)
            .filter(|(_, k)| **k)
            .filter(|((a, b), _)| triangulate_midpoint(m, a, b).is_ok_and(|t| t.in_front()))
            .count()
    };
    let mut scored: Vec<(usize, f64, Isometry3<f64>)> = cands
        .iter()
        .map(|c| c.a_from_b)
        .filter(|m| prior.is_none_or(|p| p.admits(&m.rotation)))
        .map(|m| {
            let off = guess.map_or(0.0, |g| (g.rotation.inverse() * m.rotation).angle());
            (in_front(&m), off, m)
        })
        .collect();
    let needed = params.min_inliers.max(ESSENTIAL_SAMPLE_SIZE);
    scored.retain(|(count, _, _)| *count >= needed && 2 * *count >= h.inlier_count);
    // Guided: the nearest rotation; blind: the most points in front, unambiguously.
    if guess.is_some() {
        scored.sort_by(|a, b| a.1.total_cmp(&b.1));
    } else {
        scored.sort_by_key(|s| std::cmp::Reverse(s.0));
    }
    let Some(&(best_count, _, chosen)) = scored.first() else {
        return Err(RelPoseError::Degenerate {
            reason: format!(
                "planar scene: no decomposition of the homography ({} inliers) has the \
                 correspondences in front of both cameras{}",
                h.inlier_count,
                if prior.is_some() {
                    " and the expected rotation angle"
                } else {
                    ""
                }
            ),
        });
    };
    if guess.is_none()
        && let Some(&(second, _, other)) = scored.get(1)
        && 4 * second > 3 * best_count
        && (other.rotation.inverse() * chosen.rotation).angle() > 1e-6
    {
        return Err(RelPoseError::Degenerate {
            reason: format!(
                "planar scene: two motions explain the homography ({best_count} and {second} \
                 points in front); add a known rotation angle or a view with depth relief"
            ),
        });
    }
    // The Sampson refinement would drift along the plane's family of E: not run.
    let fixed = EssentialParams {
        refine: false,
        ..*params
    };
    finish(
        x_a,
        x_b,
        &fixed,
        chosen,
        Search {
            cheirality_counts: [best_count, 0, 0, 0],
            chosen_decomposition: 0,
            iterations: h.iterations,
        },
    )
    .map(Some)
}

/// The elements of `v` whose `mask` entry is set.
pub(crate) fn select<T: Copy>(v: &[T], mask: &[bool]) -> Vec<T> {
    v.iter()
        .zip(mask)
        .filter_map(|(x, &m)| m.then_some(*x))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Exact correspondences of a 3D cloud for `a_from_b`.
    fn cloud_views(a_from_b: &Isometry3<f64>) -> (Vec<Point2<f64>>, Vec<Point2<f64>>) {
        let (mut xa, mut xb) = (Vec::new(), Vec::new());
        for i in 0..10 {
            for j in 0..8 {
                let p_b = Point3::new(
                    -0.2 + 0.045 * f64::from(i),
                    -0.15 + 0.04 * f64::from(j),
                    0.5 + 0.07 * f64::from((i * 3 + j * 5) % 7),
                );
                let p_a = a_from_b * p_b;
                xb.push(Point2::new(p_b.x / p_b.z, p_b.y / p_b.z));
                xa.push(Point2::new(p_a.x / p_a.z, p_a.y / p_a.z));
            }
        }
        (xa, xb)
    }

    /// The rotation-angle prior admits the true motion and is enforced when it contradicts
    /// it; the guided estimate from a guess a little off converges to the data.
    #[test]
    fn rotation_angle_prior_and_guided_estimate() {
        let a_from_b = Isometry3::from_parts(
            Translation3::new(0.1, -0.02, 0.03),
            UnitQuaternion::from_scaled_axis(Vector3::new(0.05, 0.3, -0.1)),
        );
        let angle = a_from_b.rotation.angle();
        let (xa, xb) = cloud_views(&a_from_b);
        let prior = |deg: f64| RotationAnglePrior {
            angle_rad: angle + deg.to_radians(),
            tolerance_rad: 2f64.to_radians(),
        };
        assert!(prior(0.0).admits_essential(&essential_of(&a_from_b)));
        assert!(!prior(10.0).admits_essential(&essential_of(&a_from_b)));
        let mut p = EssentialParams {
            inlier_threshold: 1e-4,
            pure_rotation_threshold_rad: 2e-4,
            rotation_angle_prior: Some(prior(0.5)),
            ..EssentialParams::default()
        };
        let est = estimate_essential_ransac(&xa, &xb, &p, 1).expect("with a true prior");
        assert!((est.a_from_b.rotation.inverse() * a_from_b.rotation).angle() < 1e-6);
        p.rotation_angle_prior = Some(prior(10.0));
        // A contradicting prior never yields the true motion: at best a model of a minority
        // that has the prescribed angle (the hand-eye consistency checks refuse those).
        if let Ok(e) = estimate_essential_ransac(&xa, &xb, &p, 1) {
            assert!(prior(10.0).admits(&e.a_from_b.rotation), "{e:?}");
            assert!(2 * e.inlier_count < xa.len(), "{e:?}");
        }
        // Guided from a guess 0.2 deg / 0.01 off (a first X's error) with a 2 px-like threshold.
        p.rotation_angle_prior = None;
        p.inlier_threshold = 2e-3;
        let guess = a_from_b
            * Isometry3::rotation(Vector3::new(0.0, 0.2f64.to_radians(), 0.0))
            * Isometry3::translation(0.01, 0.0, 0.0);
        let g = refine_essential_guided(&xa, &xb, &guess, &p, 1).expect("guided");
        assert!((g.a_from_b.rotation.inverse() * a_from_b.rotation).angle() < 1e-6);
    }

    #[test]
    fn decomposition_candidates_reproduce_the_essential_matrix() {
        let a_from_b = Isometry3::from_parts(
            Translation3::from(Vector3::new(0.08, -0.03, 0.02).normalize()),
            UnitQuaternion::from_scaled_axis(Vector3::new(-0.1, -0.15, 0.3)),
        );
        let e = essential_of(&a_from_b);
        for c in decompose_essential(&e).expect("decompose") {
            let ec = essential_of(&c);
            // Each candidate has the same E up to sign.
            assert!((ec - e).norm().min((ec + e).norm()) < 1e-12);
        }
    }
}
