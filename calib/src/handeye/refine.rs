//! `ours`: robust Levenberg-Marquardt refinement of X (and the eye scale) on the pose
//! residuals of all pairs, started from the Kronecker solution.
//!
//! # Residuals
//!
//! For a pair with hand motion `B` and eye motion `A` (module [`super`]), the residual of
//! `B X = X A` is split into a rotation part (radians) and a translation part (metres):
//!
//! ```text
//! r_R = log(R_B R_X R_A^T R_X^T)                 (rotation of (B X)(X A)^-1)
//! r_t = (R_B - I) t_X + t_B - s R_X t_A          (= -(B X) * translation of (B X)^-1 (X A))
//! ```
//!
//! `|r_R|` and `|r_t|` are exactly the rotation angle and translation norm of
//! `(B X)^-1 (X A)` (the reported residuals).
//!
//! **Lever decorrelation.** An eye pose measured against a board (PnP) errs mostly by a
//! small rotation `d` about the camera; for the motion `A = cam_i_from_cam_j` this moves
//! `t_A` by `l x d_A` where `l` is the board origin seen from `cam_i` (the motion's
//! `eye_lever_m`) and `d_A` the motion's rotation error. To first order
//! `dr_R = -R_X d_A` and `dr_t = [s R_X l]x dr_R - s R_X e_A`, so the fit uses
//!
//! ```text
//! r_t' = r_t - (s R_X l) x r_R
//! ```
//!
//! whose noise is only the eye's translation noise: a unit-triangular (hence consistent,
//! unbiased) whitening of the pair's 6-vector. With `l = 0` it is `r_t`. Each block is
//! normalised by its scale (`sigma_R`, `sigma_t`: given in
//! the options, or the median block norm of the initial residuals / 1.5382, the median of
//! the norm of a 3-D standard normal vector), and the cost is
//!
//! ```text
//! C(X, s) = sum_pairs w_k (rho(|r_R| / sigma_R) + rho(|r_t| / sigma_t))
//! ```
//!
//! with the robust loss `rho` ([`RobustLoss`]) minimised by iteratively reweighted
//! Levenberg-Marquardt (Marquardt 1963; Triggs et al. 2000, sec. 3.3 for the IRLS form).
//!
//! # Parameters and analytic Jacobians
//!
//! `R_X <- exp([d_theta]x) R_X` (left so(3) perturbation), `t_X <- t_X + d_t`,
//! `s <- s exp(d_rho)` (scale-free only). With `C = R_X R_A^T R_X^T`, `v = R_X t_A` and
//! `Jr^-1` the inverse right Jacobian of SO(3):
//!
//! ```text
//! d r_R / d theta = Jr^-1(r_R) (C^T - I)      d r_R / d t = 0         d r_R / d rho = 0
//! d r_t / d theta = s [v]x                    d r_t / d t = R_B - I   d r_t / d rho = -s v
//! ```
//!
//! # Damping and termination
//!
//! Steps solve `(H + lambda diag(H)) d = -g` (Marquardt's scaling), `lambda_0 = 1e-3`,
//! divided by 3 after an accepted step and multiplied by 4 after a rejected one. The loop
//! stops when `|g|_inf` < [`GRADIENT_TOLERANCE`], when the step is below
//! [`STEP_TOLERANCE`] (relative), when the relative cost decrease is below
//! [`COST_TOLERANCE`], when no damped step decreases the cost, or at `max_iterations`.

use nalgebra::{Isometry3, Matrix3, SMatrix, SVector, Vector3};

use super::geometry::{isometry, right_jacobian_inverse, rot, rotation_exp, rotation_log, skew};
use super::{HandEyeError, HandEyeOptions, Method, RelativeMotion};

/// Floor of the residual scales (radians, metres): noise-free data keeps a sane weighting.
pub const MIN_RESIDUAL_SCALE: f64 = 1e-9;
/// Median of the norm of a 3-D standard normal vector (`sqrt` of the chi^2_3 median).
pub const CHI3_MEDIAN: f64 = 1.5382;
/// Gradient tolerance (normalised cost units).
pub const GRADIENT_TOLERANCE: f64 = 1e-10;
/// Relative step tolerance.
pub const STEP_TOLERANCE: f64 = 1e-12;
/// Relative cost-decrease tolerance.
pub const COST_TOLERANCE: f64 = 1e-14;
/// Relative change of an automatic residual scale that triggers a second LM run.
pub const RESCALE_TOLERANCE: f64 = 0.1;

/// Robust loss on a residual block's normalised norm `u = |r| / sigma`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RobustLoss {
    /// `rho(u) = u^2 / 2` (plain least squares).
    None,
    /// `rho(u) = u^2 / 2` for `u <= k`, `k u - k^2 / 2` beyond (Huber 1964).
    Huber {
        /// Threshold in units of the residual scale.
        k: f64,
    },
    /// `rho(u) = c^2 / 2 ln(1 + (u / c)^2)` (Cauchy / Lorentzian).
    Cauchy {
        /// Scale in units of the residual scale.
        c: f64,
    },
}

impl Default for RobustLoss {
    /// `Huber { k: 2.0 }`: quadratic up to two residual scales (~95% efficiency on
    /// Gaussian noise, bounded influence of a bad pair).
    fn default() -> Self {
        RobustLoss::Huber { k: 2.0 }
    }
}

impl RobustLoss {
    /// `rho(u)`.
    pub fn rho(self, u: f64) -> f64 {
        match self {
            RobustLoss::None => 0.5 * u * u,
            RobustLoss::Huber { k } => {
                if u <= k {
                    0.5 * u * u
                } else {
                    k * u - 0.5 * k * k
                }
            }
            RobustLoss::Cauchy { c } => 0.5 * c * c * (u / c).mul_add(u / c, 1.0).ln(),
        }
    }

    /// IRLS weight `rho'(u) / u`.
    pub fn weight(self, u: f64) -> f64 {
        match self {
            RobustLoss::None => 1.0,
            RobustLoss::Huber { k } => {
                if u <= k {
                    1.0
                } else {
                    k / u
                }
            }
            RobustLoss::Cauchy { c } => 1.0 / (u / c).mul_add(u / c, 1.0),
        }
    }
}

/// Why the refinement stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Termination {
    /// No refinement (a linear method).
    #[default]
    Linear,
    /// The gradient vanished.
    GradientSmall,
    /// The step became negligible.
    StepSmall,
    /// The cost stopped decreasing (relative decrease below tolerance).
    CostConverged,
    /// No damped step decreased the cost.
    NoDecrease,
    /// `max_iterations` reached.
    MaxIterations,
}

/// Result of [`refine`].
#[derive(Debug, Clone, PartialEq)]
pub struct Refinement {
    /// Refined `tool0_from_camera`.
    pub tool0_from_camera: Isometry3<f64>,
    /// Refined eye scale (1 unless scale-free).
    pub scale: f64,
    /// Accepted iterations.
    pub iterations: usize,
    /// Why it stopped.
    pub termination: Termination,
    /// Final robust cost.
    pub cost: f64,
    /// Rotation residual scale used, radians.
    pub rot_scale_rad: f64,
    /// Translation residual scale used, metres.
    pub trans_scale_m: f64,
}

/// The raw residual blocks `(r_R, r_t)` of one pair (module docs).
pub fn pair_residual(
    m: &RelativeMotion,
    x: &Isometry3<f64>,
    scale: f64,
) -> (Vector3<f64>, Vector3<f64>) {
    let r_x = rot(x);
    let r_b = rot(&m.b);
    let e = r_b * r_x * rot(&m.a).transpose() * r_x.transpose();
    let r_rot = rotation_log(&e);
    let r_t = (r_b - Matrix3::identity()) * x.translation.vector + m.b.translation.vector
        - scale * (r_x * m.a.translation.vector);
    (r_rot, r_t)
}

/// The residual blocks the fit uses: `(r_R, r_t - (s R_X l) x r_R)` with `l` the motion's
/// eye lever arm (module docs; equal to [`pair_residual`] when `l = 0`).
pub fn fit_residual(
    m: &RelativeMotion,
    x: &Isometry3<f64>,
    scale: f64,
) -> (Vector3<f64>, Vector3<f64>) {
    let (r_rot, r_t) = pair_residual(m, x, scale);
    let u = scale * (rot(x) * m.eye_lever_m);
    (r_rot, r_t - u.cross(&r_rot))
}

/// Robust scales `(sigma_R, sigma_t)` of the fit residuals ([`fit_residual`]): median
/// block norms / [`CHI3_MEDIAN`], floored.
pub fn residual_scales(motions: &[RelativeMotion], x: &Isometry3<f64>, scale: f64) -> (f64, f64) {
    let mut rot_norms = Vec::with_capacity(motions.len());
    let mut trans_norms = Vec::with_capacity(motions.len());
    for m in motions {
        let (r, t) = fit_residual(m, x, scale);
        rot_norms.push(r.norm());
        trans_norms.push(t.norm());
    }
    (
        (median(&mut rot_norms) / CHI3_MEDIAN).max(MIN_RESIDUAL_SCALE),
        (median(&mut trans_norms) / CHI3_MEDIAN).max(MIN_RESIDUAL_SCALE),
    )
}

/// Median (NaN for an empty slice); sorts in place.
pub(crate) fn median(values: &mut [f64]) -> f64 {
    if values.is_empty() {
        return f64::NAN;
    }
    values.sort_by(f64::total_cmp);
    let n = values.len();
    let (lo, hi) = (values.get((n - 1) / 2), values.get(n / 2));
    match (lo, hi) {
        (Some(a), Some(b)) => 0.5 * (a + b),
        _ => f64::NAN,
    }
}

/// Normal equations of the IRLS problem at `(x, s)`: `(H, g, cost, weighted chi^2)`.
/// Parameter order `(theta, t, rho)`; without `scale_free` row/column 6 is pinned
/// (`H_66 = 1`, `g_6 = 0`).
pub(crate) struct Linearisation {
    pub h: SMatrix<f64, 7, 7>,
    pub g: SVector<f64, 7>,
    pub cost: f64,
    pub chi2: f64,
}

/// Fit residual blocks of one pair ([`fit_residual`]) and their analytic Jacobians with
/// respect to `(theta, t, rho)` (module docs), unnormalised. Without `scale_free` the `rho`
/// column is zero.
pub(crate) fn pair_jacobian(
    m: &RelativeMotion,
    x: &Isometry3<f64>,
    scale: f64,
    scale_free: bool,
) -> (
    Vector3<f64>,
    Vector3<f64>,
    SMatrix<f64, 3, 7>,
    SMatrix<f64, 3, 7>,
) {
    let r_x = rot(x);
    let (r_rot, r_t) = fit_residual(m, x, scale);
    let c = r_x * rot(&m.a).transpose() * r_x.transpose();
    let v = r_x * m.a.translation.vector;
    let u = scale * (r_x * m.eye_lever_m);

    // d r_R / d theta = Jr^-1(r_R) (C^T - I).
    let j_rot_theta = right_jacobian_inverse(&r_rot) * (c.transpose() - Matrix3::identity());
    let mut j_rot = SMatrix::<f64, 3, 7>::zeros();
    j_rot.fixed_view_mut::<3, 3>(0, 0).copy_from(&j_rot_theta);

    // Raw r_t: d/dtheta = s [v]x, d/dt = R_B - I, d/drho = -s v. The lever term
    // -(u x r_R): d/dtheta (u x r_R) = [r_R]x [u]x + [u]x J_R, d/drho (u x r_R) = u x r_R.
    let mut j_t = SMatrix::<f64, 3, 7>::zeros();
    j_t.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&(scale * skew(&v) - skew(&r_rot) * skew(&u) - skew(&u) * j_rot_theta));
    j_t.fixed_view_mut::<3, 3>(0, 3)
        .copy_from(&(rot(&m.b) - Matrix3::identity()));
    if scale_free {
        j_t.fixed_view_mut::<3, 1>(0, 6)
            .copy_from(&(-scale * v - u.cross(&r_rot)));
    }
    (r_rot, r_t, j_rot, j_t)
}

/// One pair's contribution to the IRLS normal equations at `(x, scale)`: `(J^T W J,
/// J^T W r, rho, w(u) u^2)` with parameter order `(theta, t, rho)` (the `rho` column zero
/// without `scale_free`).
fn pair_normal(
    m: &RelativeMotion,
    x: &Isometry3<f64>,
    scale: f64,
    sigmas: (f64, f64),
    loss: RobustLoss,
    scale_free: bool,
) -> (SMatrix<f64, 7, 7>, SVector<f64, 7>, f64, f64) {
    let (sr, st) = sigmas;
    let (r_rot, r_t, j_rot, j_t) = pair_jacobian(m, x, scale, scale_free);
    let u_r = r_rot.norm() / sr;
    let u_t = r_t.norm() / st;
    let w_r = m.weight * loss.weight(u_r) / (sr * sr);
    let w_t = m.weight * loss.weight(u_t) / (st * st);
    (
        w_r * j_rot.transpose() * j_rot + w_t * j_t.transpose() * j_t,
        w_r * j_rot.transpose() * r_rot + w_t * j_t.transpose() * r_t,
        m.weight * (loss.rho(u_r) + loss.rho(u_t)),
        m.weight * (loss.weight(u_r) * u_r * u_r + loss.weight(u_t) * u_t * u_t),
    )
}

pub(crate) fn linearise(
    motions: &[RelativeMotion],
    x: &Isometry3<f64>,
    scale: f64,
    sigmas: (f64, f64),
    loss: RobustLoss,
    scale_free: bool,
) -> Linearisation {
    let mut h = SMatrix::<f64, 7, 7>::zeros();
    let mut g = SVector::<f64, 7>::zeros();
    let mut cost = 0.0;
    let mut chi2 = 0.0;
    for m in motions {
        let (info, grad, rho, chi) = pair_normal(m, x, scale, sigmas, loss, scale_free);
        h += info;
        g += grad;
        cost += rho;
        chi2 += chi;
    }
    if !scale_free {
        h.fixed_view_mut::<1, 7>(6, 0).fill(0.0);
        h.fixed_view_mut::<7, 1>(0, 6).fill(0.0);
        h[(6, 6)] = 1.0;
        g[6] = 0.0;
    }
    Linearisation { h, g, cost, chi2 }
}

/// Normal equations in the 6 parameters of X only, `(theta, t)` of the module docs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Normal6 {
    /// `H = sum J^T W J` (Gauss-Newton information, residuals normalised by their scales).
    pub h: SMatrix<f64, 6, 6>,
    /// `g = sum J^T W r`.
    pub g: SVector<f64, 6>,
    /// Robust cost `sum rho`.
    pub cost: f64,
    /// Weighted chi^2 `sum w(u) u^2` of the normalised residual blocks.
    pub chi2: f64,
}

/// The normal equations of X at `x` over `motions` (metric eye translations, residual scales
/// `sigmas`, robust loss `loss` with its IRLS weights at `x`). With `per_motion_scale` every
/// motion has its own free eye scale (the monocular case: each `t_A` known only up to its
/// own scale), which is eliminated per motion by the Schur complement of its row:
///
/// ```text
/// I_k = J_k^T W_k J_k (7x7, parameters (theta, t, rho_k)),   rho_k = log s_k
/// H  += I_k[x,x] - I_k[x,rho] I_k[rho,rho]^-1 I_k[rho,x]
/// g  += g_k[x]   - I_k[x,rho] I_k[rho,rho]^-1 g_k[rho]
/// ```
///
/// which is the exact X block of the Gauss-Newton step of the joint problem over X and all
/// the scales (variable projection; Golub & Pereyra 1973). `(H, g)` give the step
/// `delta = -H^-1 g` and, at the optimum, the covariance `H^-1` of X in units of the scales.
pub fn normal_equations_x(
    motions: &[RelativeMotion],
    x: &Isometry3<f64>,
    sigmas: (f64, f64),
    loss: RobustLoss,
    per_motion_scale: bool,
) -> Normal6 {
    let mut h = SMatrix::<f64, 6, 6>::zeros();
    let mut g = SVector::<f64, 6>::zeros();
    let mut cost = 0.0;
    let mut chi2 = 0.0;
    for m in motions {
        let (info, grad, rho, chi) = pair_normal(m, x, 1.0, sigmas, loss, per_motion_scale);
        let mut h_k = info.fixed_view::<6, 6>(0, 0).into_owned();
        let mut g_k = grad.fixed_rows::<6>(0).into_owned();
        let i_ss = info[(6, 6)];
        if per_motion_scale && i_ss > 0.0 {
            let i_xs = info.fixed_view::<6, 1>(0, 6).into_owned();
            h_k -= i_xs * i_xs.transpose() / i_ss;
            g_k -= i_xs * (grad[6] / i_ss);
        }
        h += h_k;
        g += g_k;
        cost += rho;
        chi2 += chi;
    }
    Normal6 { h, g, cost, chi2 }
}

/// `X <- (exp([d_theta]x) R_X, t_X + d_t)`, the update of the module docs.
pub fn apply_x_step(x: &Isometry3<f64>, d: &SVector<f64, 6>) -> Isometry3<f64> {
    let r = rotation_exp(&Vector3::new(d[0], d[1], d[2])) * rot(x);
    isometry(&r, &(x.translation.vector + Vector3::new(d[3], d[4], d[5])))
}

fn robust_cost(
    motions: &[RelativeMotion],
    x: &Isometry3<f64>,
    scale: f64,
    sigmas: (f64, f64),
    loss: RobustLoss,
) -> f64 {
    motions
        .iter()
        .map(|m| {
            let (r, t) = fit_residual(m, x, scale);
            m.weight * (loss.rho(r.norm() / sigmas.0) + loss.rho(t.norm() / sigmas.1))
        })
        .sum()
}

fn apply(x: &Isometry3<f64>, scale: f64, d: &SVector<f64, 7>) -> (Isometry3<f64>, f64) {
    (
        apply_x_step(x, &d.fixed_rows::<6>(0).into_owned()),
        scale * d[6].exp(),
    )
}

/// Refines `(x0, s0)` (module docs). With automatic residual scales the refinement runs
/// twice at most: the scales are re-estimated at the first solution (the initial linear
/// estimate inflates them) and, when one changed by more than [`RESCALE_TOLERANCE`], LM runs
/// again from there.
///
/// # Errors
///
/// [`HandEyeError::NumericalFailure`] when the cost is not finite at the start.
pub fn refine(
    motions: &[RelativeMotion],
    x0: &Isometry3<f64>,
    s0: f64,
    opts: &HandEyeOptions,
) -> Result<Refinement, HandEyeError> {
    let scales_at = |x: &Isometry3<f64>, s: f64| {
        let (auto_r, auto_t) = residual_scales(motions, x, s);
        (
            opts.rot_scale_rad
                .map_or(auto_r, |v| v.max(MIN_RESIDUAL_SCALE)),
            opts.trans_scale_m
                .map_or(auto_t, |v| v.max(MIN_RESIDUAL_SCALE)),
        )
    };
    let mut sigmas = scales_at(x0, s0);
    let mut result = run_lm(motions, x0, s0, sigmas, opts, opts.max_iterations)?;
    let new_sigmas = scales_at(&result.tool0_from_camera, result.scale);
    let changed = |a: f64, b: f64| (a - b).abs() > RESCALE_TOLERANCE * b;
    if changed(new_sigmas.0, sigmas.0) || changed(new_sigmas.1, sigmas.1) {
        sigmas = new_sigmas;
        let budget = opts.max_iterations.saturating_sub(result.iterations);
        let second = run_lm(
            motions,
            &result.tool0_from_camera,
            result.scale,
            sigmas,
            opts,
            budget,
        )?;
        result = Refinement {
            iterations: result.iterations + second.iterations,
            ..second
        };
    }
    Ok(result)
}

fn run_lm(
    motions: &[RelativeMotion],
    x0: &Isometry3<f64>,
    s0: f64,
    sigmas: (f64, f64),
    opts: &HandEyeOptions,
    max_iterations: usize,
) -> Result<Refinement, HandEyeError> {
    let scale_free = opts.scale_free;
    let loss = opts.loss;
    let mut x = *x0;
    let mut s = s0;
    let mut lin = linearise(motions, &x, s, sigmas, loss, scale_free);
    if !lin.cost.is_finite() {
        return Err(HandEyeError::NumericalFailure {
            method: Method::Ours,
            what: "non-finite initial cost",
        });
    }
    let mut lambda = 1e-3;
    let mut iterations = 0;
    let termination = loop {
        if iterations >= max_iterations {
            break Termination::MaxIterations;
        }
        if lin.g.amax() < GRADIENT_TOLERANCE {
            break Termination::GradientSmall;
        }
        let mut accepted = None;
        while lambda < 1e16 {
            let mut damped = lin.h;
            for i in 0..7 {
                damped[(i, i)] += lambda * lin.h[(i, i)].max(1e-12);
            }
            let Some(step) = damped.cholesky().map(|c| -c.solve(&lin.g)) else {
                lambda *= 4.0;
                continue;
            };
            let (x_new, s_new) = apply(&x, s, &step);
            let cost_new = robust_cost(motions, &x_new, s_new, sigmas, loss);
            if cost_new.is_finite() && cost_new < lin.cost {
                lambda = (lambda / 3.0).max(1e-12);
                accepted = Some((x_new, s_new, cost_new, step));
                break;
            }
            lambda *= 4.0;
        }
        let Some((x_new, s_new, cost_new, step)) = accepted else {
            break Termination::NoDecrease;
        };
        iterations += 1;
        let old_cost = lin.cost;
        x = x_new;
        s = s_new;
        lin = linearise(motions, &x, s, sigmas, loss, scale_free);
        let rel_step = step.fixed_rows::<3>(0).norm()
            + step.fixed_rows::<3>(3).norm() / (1.0 + x.translation.vector.norm())
            + step[6].abs();
        if rel_step < STEP_TOLERANCE {
            break Termination::StepSmall;
        }
        if old_cost - cost_new <= COST_TOLERANCE * old_cost {
            break Termination::CostConverged;
        }
    };
    Ok(Refinement {
        tool0_from_camera: x,
        scale: s,
        iterations,
        termination,
        cost: lin.cost,
        rot_scale_rad: sigmas.0,
        trans_scale_m: sigmas.1,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Translation3, UnitQuaternion};

    fn motion(seed: f64) -> RelativeMotion {
        let pose = |a: f64| {
            Isometry3::from_parts(
                Translation3::new(0.3 * a, -0.2, 0.1 + a),
                UnitQuaternion::from_scaled_axis(Vector3::new(0.4 * a, -0.3, 0.2 + a)),
            )
        };
        RelativeMotion {
            a: pose(seed),
            b: pose(0.7 * seed + 0.1),
            weight: 1.0,
            eye_lever_m: Vector3::new(0.2, -0.5, 1.4),
        }
    }

    /// The analytic Jacobians match central finite differences of the residual through the
    /// parameter update (inconsistent motions, so the residuals are far from zero).
    #[test]
    fn analytic_jacobians_match_finite_differences() {
        let x = Isometry3::from_parts(
            Translation3::new(0.05, 0.02, -0.08),
            UnitQuaternion::from_scaled_axis(Vector3::new(0.3, -0.5, 0.1)),
        );
        let scale = 1.3;
        for seed in [0.2, 0.5, 0.9] {
            let m = motion(seed);
            let (_, _, j_rot, j_t) = pair_jacobian(&m, &x, scale, true);
            let h = 1e-6;
            for k in 0..7 {
                let mut d = SVector::<f64, 7>::zeros();
                d[k] = h;
                let (xp, sp) = apply(&x, scale, &d);
                let (xm, sm) = apply(&x, scale, &(-d));
                let (rp, tp) = fit_residual(&m, &xp, sp);
                let (rm, tm) = fit_residual(&m, &xm, sm);
                let num_r = (rp - rm) / (2.0 * h);
                let num_t = (tp - tm) / (2.0 * h);
                let err_r = (num_r - j_rot.column(k)).amax();
                let err_t = (num_t - j_t.column(k)).amax();
                assert!(err_r < 1e-6, "seed {seed} column {k}: rotation {err_r:e}");
                assert!(
                    err_t < 1e-6,
                    "seed {seed} column {k}: translation {err_t:e}"
                );
            }
        }
    }

    #[test]
    fn robust_losses_are_consistent() {
        for loss in [
            RobustLoss::None,
            RobustLoss::Huber { k: 2.0 },
            RobustLoss::Cauchy { c: 2.0 },
        ] {
            for u in [0.1, 1.0, 3.0, 10.0] {
                // weight = rho'(u) / u
                let h = 1e-6;
                let d = (loss.rho(u + h) - loss.rho(u - h)) / (2.0 * h);
                assert!((d / u - loss.weight(u)).abs() < 1e-6, "{loss:?} at {u}");
            }
        }
    }
}
