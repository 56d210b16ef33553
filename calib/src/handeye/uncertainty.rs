//! Residual statistics and 1-sigma uncertainty of a hand-eye estimate.
//!
//! **Residuals**: for each used pair, the rotation angle (degrees) and translation norm
//! (millimetres, eye translations times the estimated scale) of `(B X)^-1 (X A)`; the
//! reported figures are their medians.
//!
//! **Uncertainty**: the Gauss-Newton covariance at the estimate, with the residual blocks of
//! [`super::refine`] (normalised by their robust scales, robust weights at the estimate):
//!
//! ```text
//! Sigma = (J^T W J)^-1 * chi^2 / (6 P - p) * P / M
//! sigma_rot = sqrt(trace Sigma_theta)   (degrees),   sigma_trans = sqrt(trace Sigma_t)   (mm)
//! ```
//!
//! with `P` pairs, `p` parameters (6, or 7 with the scale) and `chi^2 / (6P - p)` the
//! reduced chi-square (the data's own noise level). All `P = n(n-1)/2` pairs of `n` views
//! are built from only `M = n - 1` independent motions, so their residuals are correlated;
//! the factor `P / M` inflates the covariance to what `M` independent motions would give
//! (for relative motions given directly, `M = P`). The same figures are computed for every
//! method, at its own estimate.
//!
//! **Over views** ([`jackknife_over_views`]). The linearised covariance assumes independent
//! pair residuals; the `P / M` factor only approximates how a view's error enters all its
//! pairs. On 400 synthetic calibrations of 18 views with per-view hand and eye pose error
//! (`calib/tests/handeye.rs`) the 95 % Mahalanobis test of the rotation error against it
//! holds in only 72-74 % of the trials (translation 93-98 %). The jackknife measures the
//! spread instead: each view `k` in turn is left out and X solved again from the other
//! views (`X_(k)`, deviations `d_k = (log(R_(k) R^T), t_(k) - t)`), and
//!
//! ```text
//! Sigma_jack = (n - 1) / n sum_k (d_k - d_bar)(d_k - d_bar)^T          (Efron & Stein 1981)
//! Sigma = Sigma_jack * T^2_{3, n}(0.95) / chi^2_3(0.95)
//! ```
//!
//! `Sigma_jack` is itself estimated from `n` replicates, so a Mahalanobis test against it
//! follows Hotelling's `T^2` rather than `chi^2_3` ([`crate::quantiles::hotelling_t2_quantile`]);
//! the factor (1.43 for 18 views, 2.9 for 8) makes the reported covariance hold the
//! `chi^2_3` 95 % test at its level. Used from [`MIN_JACKKNIFE_VIEWS`] views on (with fewer
//! the factor grows without bound).
//!
//! Neither figure sees an error that every view shares at the flange (the arm's kinematic
//! model error where the views' configurations are alike): X takes it whole and the pairs
//! agree. The self-calibration adds it ([`crate::selfcal::SharedHandError`]), and in mono
//! also the hand error that varies from view to view, which the epipolar refinement turns
//! into error of X, its rotation most ([`crate::selfcal::ViewHandError`]).
//!
//! **Per-motion scales** ([`evaluate_per_motion_scale`], the monocular self-calibration): each
//! eye translation carries its own fitted scale, a nuisance parameter. Holding them fixed
//! would count the translation along each `t_A` as measured; instead they are eliminated by
//! the Schur complement ([`super::refine::normal_equations_x`]) and
//! `chi^2 / (6 P - 6 - P)` is the reduced chi-square.

use nalgebra::{Isometry3, Matrix3, Matrix6, Vector3, Vector6};
use rayon::prelude::*;

use super::refine::{
    MIN_RESIDUAL_SCALE, linearise, median, normal_equations_x, pair_residual, residual_scales,
};
use super::{HandEyeOptions, HandEyeSolution, RelativeMotion};

/// Figures of [`evaluate`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stats {
    /// Median pair rotation residual, degrees.
    pub residual_rot_deg: f64,
    /// Median pair translation residual, millimetres.
    pub residual_trans_mm: f64,
    /// 1-sigma rotation uncertainty, degrees.
    pub sigma_rot_deg: f64,
    /// 1-sigma translation uncertainty, millimetres.
    pub sigma_trans_mm: f64,
    /// The covariance behind the sigmas, parameters `(theta, t)` in rad and m.
    pub covariance: Option<Matrix6<f64>>,
}

/// Residual medians and 1-sigma uncertainty of `(x, scale)` (module docs).
/// `independent_motions` is `M`; uncertainties are NaN when the system is singular.
pub fn evaluate(
    motions: &[RelativeMotion],
    x: &Isometry3<f64>,
    scale: f64,
    opts: &HandEyeOptions,
    independent_motions: usize,
) -> Stats {
    let mut rot_deg: Vec<f64> = Vec::with_capacity(motions.len());
    let mut trans_mm: Vec<f64> = Vec::with_capacity(motions.len());
    for m in motions {
        let (r, t) = pair_residual(m, x, scale);
        rot_deg.push(r.norm().to_degrees());
        trans_mm.push(t.norm() * 1e3);
    }
    let (auto_r, auto_t) = residual_scales(motions, x, scale);
    let sigmas = (
        opts.rot_scale_rad
            .map_or(auto_r, |s| s.max(MIN_RESIDUAL_SCALE)),
        opts.trans_scale_m
            .map_or(auto_t, |s| s.max(MIN_RESIDUAL_SCALE)),
    );
    let lin = linearise(motions, x, scale, sigmas, opts.loss, opts.scale_free);
    let params = if opts.scale_free { 7 } else { 6 };
    let pairs = motions.len();
    let dof = (6 * pairs).saturating_sub(params).max(1) as f64;
    let inflation = pairs as f64 / independent_motions.clamp(1, pairs.max(1)) as f64;
    let covariance = lin
        .h
        .try_inverse()
        .map(|cov| cov.fixed_view::<6, 6>(0, 0) * (lin.chi2 / dof * inflation));
    let (sigma_rot_deg, sigma_trans_mm) = covariance.map_or((f64::NAN, f64::NAN), |c| sigma_of(&c));
    Stats {
        residual_rot_deg: median(&mut rot_deg),
        residual_trans_mm: median(&mut trans_mm),
        sigma_rot_deg,
        sigma_trans_mm,
        covariance,
    }
}

/// As [`evaluate`] (scale 1) for metric motions whose eye translations each carry their own
/// fitted scale (module docs): the scales are marginalised, so the translation uncertainty
/// includes the directions they leave undetermined.
pub fn evaluate_per_motion_scale(
    motions: &[RelativeMotion],
    x: &Isometry3<f64>,
    opts: &HandEyeOptions,
    independent_motions: usize,
) -> Stats {
    let mut stats = evaluate(motions, x, 1.0, opts, independent_motions);
    let (auto_r, auto_t) = residual_scales(motions, x, 1.0);
    let sigmas = (
        opts.rot_scale_rad
            .map_or(auto_r, |s| s.max(MIN_RESIDUAL_SCALE)),
        opts.trans_scale_m
            .map_or(auto_t, |s| s.max(MIN_RESIDUAL_SCALE)),
    );
    let n = normal_equations_x(motions, x, sigmas, opts.loss, true);
    let pairs = motions.len();
    let dof = (5 * pairs).saturating_sub(6).max(1) as f64;
    let inflation = pairs as f64 / independent_motions.clamp(1, pairs.max(1)) as f64;
    stats.covariance =
        n.h.try_inverse()
            .map(|cov| cov * (n.chi2 / dof * inflation));
    (stats.sigma_rot_deg, stats.sigma_trans_mm) = stats
        .covariance
        .map_or((f64::NAN, f64::NAN), |c| sigma_of(&c));
    stats
}

/// The squared Mahalanobis distances `(rotation, translation)` of `solution`'s error against
/// `truth`, each against its 3x3 block of the solution's covariance (rotation vector of
/// `R R_truth^T` in rad, translation in m): what a chi-square(3) test of the reported
/// uncertainty takes. `None` without a covariance; infinite for a singular block.
pub fn mahalanobis(solution: &HandEyeSolution, truth: &Isometry3<f64>) -> Option<(f64, f64)> {
    let cov = solution.covariance?;
    let x = &solution.tool0_from_camera;
    let r = (x.rotation * truth.rotation.inverse()).scaled_axis();
    let t = x.translation.vector - truth.translation.vector;
    let block = |o: usize, v: &Vector3<f64>| {
        let b: Matrix3<f64> = cov.fixed_view::<3, 3>(o, o).into_owned();
        b.try_inverse().map_or(f64::INFINITY, |bi| v.dot(&(bi * v)))
    };
    Some((block(0, &r), block(3, &t)))
}

/// Fewest views for [`jackknife_over_views`].
pub const MIN_JACKKNIFE_VIEWS: usize = 8;

/// The covariance of X over views (module docs): `resolve(k)` is X solved again without
/// view `k` (`None` when it cannot be), for each of the `views` views; `x` the estimate from
/// all of them. `None` with fewer than [`MIN_JACKKNIFE_VIEWS`] views or when a replicate
/// fails. Deterministic for any thread count (replicates are summed in view order).
pub fn jackknife_over_views(
    views: usize,
    x: &Isometry3<f64>,
    resolve: impl Fn(usize) -> Option<Isometry3<f64>> + Sync,
) -> Option<Matrix6<f64>> {
    if views < MIN_JACKKNIFE_VIEWS {
        return None;
    }
    let replicates: Vec<Option<Vector6<f64>>> = (0..views)
        .into_par_iter()
        .map(|k| {
            resolve(k).map(|xk| {
                let r = (xk.rotation * x.rotation.inverse()).scaled_axis();
                let t = xk.translation.vector - x.translation.vector;
                Vector6::new(r.x, r.y, r.z, t.x, t.y, t.z)
            })
        })
        .collect();
    let d: Vec<Vector6<f64>> = replicates.into_iter().collect::<Option<_>>()?;
    let n = d.len() as f64;
    let mean = d.iter().fold(Vector6::zeros(), |a, v| a + v) / n;
    let spread = d.iter().fold(Matrix6::zeros(), |a, v| {
        a + (v - mean) * (v - mean).transpose()
    });
    let level = 0.95;
    let factor = crate::quantiles::hotelling_t2_quantile(level, 3, d.len())
        / crate::quantiles::chi2_3_quantile(level);
    let cov = spread * ((n - 1.0) / n * factor);
    cov.iter().all(|v| v.is_finite()).then_some(cov)
}

/// `(sqrt(trace Sigma_theta) deg, sqrt(trace Sigma_t) mm)` of a covariance of `(theta, t)`.
pub fn sigma_of(c: &Matrix6<f64>) -> (f64, f64) {
    let tr_rot = c[(0, 0)] + c[(1, 1)] + c[(2, 2)];
    let tr_t = c[(3, 3)] + c[(4, 4)] + c[(5, 5)];
    (
        tr_rot.max(0.0).sqrt().to_degrees(),
        tr_t.max(0.0).sqrt() * 1e3,
    )
}
