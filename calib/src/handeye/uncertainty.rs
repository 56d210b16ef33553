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
//! **Per-motion scales** ([`evaluate_per_motion_scale`], the monocular self-calibration): each
//! eye translation carries its own fitted scale, a nuisance parameter. Holding them fixed
//! would count the translation along each `t_A` as measured; instead they are eliminated by
//! the Schur complement ([`super::refine::normal_equations_x`]) and
//! `chi^2 / (6 P - 6 - P)` is the reduced chi-square.

use nalgebra::Isometry3;

use super::refine::{
    MIN_RESIDUAL_SCALE, linearise, median, normal_equations_x, pair_residual, residual_scales,
};
use super::{HandEyeOptions, RelativeMotion};

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
    let (sigma_rot_deg, sigma_trans_mm) = match lin.h.try_inverse() {
        Some(cov) => sigma_figures(|i| cov[(i, i)], lin.chi2 / dof * inflation),
        None => (f64::NAN, f64::NAN),
    };
    Stats {
        residual_rot_deg: median(&mut rot_deg),
        residual_trans_mm: median(&mut trans_mm),
        sigma_rot_deg,
        sigma_trans_mm,
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
    (stats.sigma_rot_deg, stats.sigma_trans_mm) = match n.h.try_inverse() {
        Some(cov) => sigma_figures(|i| cov[(i, i)], n.chi2 / dof * inflation),
        None => (f64::NAN, f64::NAN),
    };
    stats
}

/// `(sqrt(trace Sigma_theta) deg, sqrt(trace Sigma_t) mm)` of `Sigma = k C`, `C_ii` given by
/// `diag(i)` for the parameter order `(theta, t)`.
fn sigma_figures(diag: impl Fn(usize) -> f64, k: f64) -> (f64, f64) {
    let tr_rot = (diag(0) + diag(1) + diag(2)) * k;
    let tr_t = (diag(3) + diag(4) + diag(5)) * k;
    (
        tr_rot.max(0.0).sqrt().to_degrees(),
        tr_t.max(0.0).sqrt() * 1e3,
    )
}
