//! Rigid motion from matched depth points (RGB-D): RANSAC + Umeyama/Horn + weighted refinement.
//!
//! 1. Validation: equal lengths, `>= 3` finite pairs, points in `b` not all collinear.
//! 2. RANSAC/MSAC ([`super::ransac`]) on minimal samples of 3 pairs; a sample is rejected
//!    before fitting when it is (near-)collinear or when a rigid motion cannot map it (the
//!    pairwise distances differ by more than `2 T`: distances are invariant under rigid
//!    motions, Chen, Hung & Cheng 1999's "RANSAC-based DARCES" pre-check). Model: closed-form
//!    Umeyama ([`super::umeyama`]); residual `|p_in_a - a_from_b p_in_b|`, threshold `T`.
//! 3. Umeyama on the inliers, then the Mahalanobis refinement of [`super::refine::refine_rigid`]
//!    with the depth-noise covariances ([`DepthNoiseModel`]), inliers re-selected with the
//!    refined motion and the refinement repeated until the inlier set is stable (at most
//!    [`MAX_REFINE_ROUNDS`] rounds).

use nalgebra::{Isometry3, Point3};

use super::ransac::{RansacConfig, ransac};
use super::refine::{DepthNoiseModel, MAX_REFINE_ROUNDS, RefineParams, RefineReport, refine_rigid};
use super::umeyama::{rigid_from_correspondences, umeyama};
use super::{RelPoseError, check_lengths};

/// Minimal sample size of the rigid model.
pub const RIGID_SAMPLE_SIZE: usize = 3;

/// Minimal samples whose triangle is flatter than this (twice its area over its longest side
/// squared; 0.87 for an equilateral triangle) are skipped.
pub const MIN_SAMPLE_FLATNESS: f64 = 1e-3;

/// Parameters of [`estimate_rigid_ransac`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RigidRansacParams {
    /// Inlier threshold `T` on `|p_in_a - a_from_b p_in_b|`, metres; default 0.003 (about 10
    /// sigma of the lateral noise of a 1-px keypoint error at 0.6 m, far below gross
    /// mismatches).
    pub inlier_threshold_m: f64,
    /// Stopping rule; default [`RansacConfig::default`] (p = 0.999, 50..5000 iterations).
    pub ransac: RansacConfig,
    /// Minimum inliers to accept a motion; default 6.
    pub min_inliers: usize,
    /// Depth-noise model of the refinement; default `Some(DepthNoiseModel::default())` (the
    /// wrist camera). `None` refines with plain point-to-point least squares.
    pub noise: Option<DepthNoiseModel>,
    /// Whether to run the nonlinear refinement at all; default true.
    pub refine: bool,
    /// Stopping rules of the refinement; default [`RefineParams::default`].
    pub refine_params: RefineParams,
}

impl Default for RigidRansacParams {
    fn default() -> Self {
        Self {
            inlier_threshold_m: 0.003,
            ransac: RansacConfig::default(),
            min_inliers: 6,
            noise: Some(DepthNoiseModel::default()),
            refine: true,
            refine_params: RefineParams::default(),
        }
    }
}

/// Result of [`estimate_rigid_ransac`].
#[derive(Debug, Clone, PartialEq)]
pub struct RigidEstimate {
    /// The motion `a_from_b` (`p_in_a = a_from_b * p_in_b`).
    pub a_from_b: Isometry3<f64>,
    /// Inlier flag per correspondence (final motion, threshold `T`).
    pub inliers: Vec<bool>,
    /// Number of inliers.
    pub inlier_count: usize,
    /// Root mean square of `|p_in_a - a_from_b p_in_b|` over the inliers, metres.
    pub rms_m: f64,
    /// RANSAC iterations run.
    pub iterations: usize,
    /// The closed-form Umeyama motion on the RANSAC inliers (before refinement).
    pub umeyama_a_from_b: Isometry3<f64>,
    /// Report of the last refinement (`None` when disabled).
    pub refine: Option<RefineReport>,
}

fn validate(p_in_a: &[Point3<f64>], p_in_b: &[Point3<f64>]) -> Result<(), RelPoseError> {
    check_lengths(p_in_a.len(), p_in_b.len(), RIGID_SAMPLE_SIZE)?;
    for (i, (pa, pb)) in p_in_a.iter().zip(p_in_b).enumerate() {
        if !(pa
            .coords
            .iter()
            .chain(pb.coords.iter())
            .all(|c| c.is_finite()))
        {
            return Err(RelPoseError::NonFinite { index: i });
        }
    }
    Ok(())
}

/// Twice the area of the triangle, relative to its squared longest side (0 when collinear).
fn triangle_flatness(p: &[Point3<f64>; 3]) -> f64 {
    let e1 = p[1] - p[0];
    let e2 = p[2] - p[0];
    let e3 = p[2] - p[1];
    let longest = e1
        .norm_squared()
        .max(e2.norm_squared())
        .max(e3.norm_squared());
    if longest > 0.0 {
        e1.cross(&e2).norm() / longest
    } else {
        0.0
    }
}

fn select<T: Copy>(v: &[T], mask: &[bool]) -> Vec<T> {
    v.iter()
        .zip(mask)
        .filter_map(|(x, &m)| m.then_some(*x))
        .collect()
}

fn classify(
    p_in_a: &[Point3<f64>],
    p_in_b: &[Point3<f64>],
    a_from_b: &Isometry3<f64>,
    threshold_m: f64,
) -> (Vec<bool>, usize, f64) {
    let mut flags = Vec::with_capacity(p_in_a.len());
    let mut count = 0;
    let mut sum_sq = 0.0;
    for (pa, pb) in p_in_a.iter().zip(p_in_b) {
        let r2 = (pa - a_from_b * pb).norm_squared();
        let inlier = r2 <= threshold_m * threshold_m;
        if inlier {
            count += 1;
            sum_sq += r2;
        }
        flags.push(inlier);
    }
    let rms = if count > 0 {
        (sum_sq / count as f64).sqrt()
    } else {
        f64::NAN
    };
    (flags, count, rms)
}

/// Estimates `a_from_b` from matched 3D points (`p_in_a[i]` and `p_in_b[i]` are the same
/// physical point seen by cameras `a` and `b`) robustly, as described in the module docs.
///
/// # Errors
/// [`RelPoseError::LengthMismatch`], [`RelPoseError::TooFewCorrespondences`] (< 3),
/// [`RelPoseError::NonFinite`], [`RelPoseError::InvalidParameter`] (threshold),
/// [`RelPoseError::Degenerate`] (all points coincident or collinear),
/// [`RelPoseError::NoConsensus`] (fewer than `min_inliers` inliers).
pub fn estimate_rigid_ransac(
    p_in_a: &[Point3<f64>],
    p_in_b: &[Point3<f64>],
    params: &RigidRansacParams,
    seed: u64,
) -> Result<RigidEstimate, RelPoseError> {
    validate(p_in_a, p_in_b)?;
    let thr = params.inlier_threshold_m;
    if !(thr.is_finite() && thr > 0.0) {
        return Err(RelPoseError::InvalidParameter {
            name: "inlier_threshold_m",
            value: thr,
        });
    }
    // Whole-set degeneracy (coincident / collinear): Umeyama on everything tells.
    umeyama(p_in_a, p_in_b, None, false)?;

    let n = p_in_a.len();
    let outcome = ransac(
        n,
        RIGID_SAMPLE_SIZE,
        thr * thr,
        &params.ransac,
        seed,
        |s, models| {
            let mut a = [Point3::origin(); RIGID_SAMPLE_SIZE];
            let mut b = [Point3::origin(); RIGID_SAMPLE_SIZE];
            for ((sa, sb), &q) in a.iter_mut().zip(b.iter_mut()).zip(s) {
                let (Some(pa), Some(pb)) = (p_in_a.get(q), p_in_b.get(q)) else {
                    return;
                };
                *sa = *pa;
                *sb = *pb;
            }
            for (u, v) in [(0, 1), (0, 2), (1, 2)] {
                let da = (a[u] - a[v]).norm();
                let db = (b[u] - b[v]).norm();
                if (da - db).abs() > 2.0 * thr {
                    return;
                }
            }
            if triangle_flatness(&a) < MIN_SAMPLE_FLATNESS
                || triangle_flatness(&b) < MIN_SAMPLE_FLATNESS
            {
                return;
            }
            if let Ok(m) = rigid_from_correspondences(&a, &b, None) {
                models.push(m);
            }
        },
        |m, i| match (p_in_a.get(i), p_in_b.get(i)) {
            (Some(pa), Some(pb)) => (pa - m * pb).norm_squared(),
            _ => f64::INFINITY,
        },
    );
    let needed = params.min_inliers.max(RIGID_SAMPLE_SIZE);
    if outcome.model.is_none() || outcome.inlier_count < needed {
        return Err(RelPoseError::NoConsensus {
            best_inliers: outcome.inlier_count,
            needed,
        });
    }
    // Closed form on the RANSAC inliers, re-select, closed form again.
    let mut mask = outcome.inliers.clone();
    let mut umeyama_a_from_b =
        rigid_from_correspondences(&select(p_in_a, &mask), &select(p_in_b, &mask), None)?;
    let (m2, c2, _) = classify(p_in_a, p_in_b, &umeyama_a_from_b, thr);
    if c2 >= needed {
        mask = m2;
        umeyama_a_from_b =
            rigid_from_correspondences(&select(p_in_a, &mask), &select(p_in_b, &mask), None)?;
    }
    let mut a_from_b = umeyama_a_from_b;
    let mut report = None;
    if params.refine {
        for _round in 0..MAX_REFINE_ROUNDS {
            let sa = select(p_in_a, &mask);
            let sb = select(p_in_b, &mask);
            if sa.len() < needed {
                break;
            }
            let r = refine_rigid(
                &sa,
                &sb,
                &a_from_b,
                params.noise.as_ref(),
                &params.refine_params,
            )?;
            a_from_b = r.a_from_b;
            report = Some(r);
            let (m, c, _) = classify(p_in_a, p_in_b, &a_from_b, thr);
            if m == mask || c < needed {
                break;
            }
            mask = m;
        }
    }
    let (inliers, inlier_count, rms_m) = classify(p_in_a, p_in_b, &a_from_b, thr);
    if inlier_count < needed {
        return Err(RelPoseError::NoConsensus {
            best_inliers: inlier_count,
            needed,
        });
    }
    Ok(RigidEstimate {
        a_from_b,
        inliers,
        inlier_count,
        rms_m,
        iterations: outcome.iterations,
        umeyama_a_from_b,
        refine: report,
    })
}
