//! Mono: X refined on the epipolar constraints of every used pair at once.
//!
//! A rigid mount makes each pair's camera motion a function of X and the (metric) hand
//! motion, `A_ij(X) = X^-1 B_ij X`, translation included, so its essential matrix
//! `E_ij(X) = [t_A(X)]x R_A(X)` is too. This refinement minimises, over the six parameters of
//! X alone,
//!
//! ```text
//! sum_ij sum_k rho( d_S(E_ij(X); x_i^k, x_j^k) )
//! ```
//!
//! with `d_S` the Sampson distance ([`crate::relpose::refine::sampson_distance`]) of the
//! pair's motion inliers (normalised, undistorted) and `rho` Huber's loss, by
//! Levenberg-Marquardt (iteratively reweighted, central-difference Jacobian, the update
//! `X <- X exp(delta)` on the right). It is the monocular counterpart of the paper's eq. 15
//! point refinement ([`super::refine`]): the per-pair scales of the linear mono solution
//! ([`super::motion::mono_translation`]) are free and so discard what the hand's metric
//! translations say about `t_X` (`|t_A|` depends on `t_X`); here they are not free, and the
//! image evidence of all pairs is weighed together instead of through each pair's own
//! `(R_A, t_A / |t_A|)`.

use nalgebra::{Isometry3, Matrix6, Point2, Translation3, UnitQuaternion, Vector3, Vector6};
use rayon::prelude::*;
use std::sync::Arc;

use crate::relpose::essential::essential_of;
use crate::relpose::refine::sampson_distance;

/// One pair of views: its hand motion and its inlier correspondences.
#[derive(Debug, Clone, PartialEq)]
pub struct EpipolarPair {
    /// `B = tool_i_from_tool_j` (metric).
    pub hand: Isometry3<f64>,
    /// Normalised undistorted points in view `i` (shared: the jackknife's subsets and the
    /// hand-error replicates copy the pair, not its points).
    pub x_i: Arc<[Point2<f64>]>,
    /// The same points in view `j`.
    pub x_j: Arc<[Point2<f64>]>,
}

/// Parameters of [`refine_epipolar`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EpipolarParams {
    /// Levenberg-Marquardt iterations at most; default 30.
    pub max_iterations: usize,
    /// Huber threshold on the Sampson distance, normalised image units (the pipeline sets
    /// its essential inlier threshold); default `1 / 1745` (1 px on the wrist camera).
    pub huber: f64,
}

impl Default for EpipolarParams {
    fn default() -> Self {
        Self {
            max_iterations: 30,
            huber: 1.0 / 1745.0,
        }
    }
}

/// Result of [`refine_epipolar`].
#[derive(Debug, Clone, PartialEq)]
pub struct EpipolarReport {
    /// Refined `X = tool0_from_camera`.
    pub tool0_from_camera: Isometry3<f64>,
    /// Correspondences used.
    pub residuals: usize,
    /// RMS Sampson distance before and after, normalised units.
    pub rms_initial: f64,
    /// See `rms_initial`.
    pub rms_final: f64,
    /// Iterations run.
    pub iterations: usize,
    /// 1-sigma of X from the Gauss-Newton covariance `s^2 (J^T W J)^-1` at the optimum
    /// (`s^2` the weighted residual variance), largest rotation axis, degrees. It treats the
    /// residuals as independent: callers whose correspondences share keypoints across pairs
    /// inflate it.
    pub sigma_rot_deg: f64,
    /// As `sigma_rot_deg` for the translation, millimetres.
    pub sigma_trans_mm: f64,
}

/// `X exp(delta)`: rotation vector `delta[0..3]`, translation `delta[3..6]` (tool0 units).
fn retract(x: &Isometry3<f64>, delta: &Vector6<f64>) -> Isometry3<f64> {
    let w = Vector3::new(delta[0], delta[1], delta[2]);
    let v = Vector3::new(delta[3], delta[4], delta[5]);
    Isometry3::from_parts(
        Translation3::from(x.translation.vector + v),
        UnitQuaternion::from_scaled_axis(w) * x.rotation,
    )
}

/// Sampson distances of every correspondence at `x` (pairs without camera translation at
/// `x` give none).
fn residuals(pairs: &[EpipolarPair], x: &Isometry3<f64>, out: &mut Vec<f64>) {
    out.clear();
    let x_inv = x.inverse();
    for p in pairs {
        let a = x_inv * p.hand * x;
        if a.translation.vector.norm() <= 1e-9 {
            out.extend(std::iter::repeat_n(0.0, p.x_i.len()));
            continue;
        }
        let e = essential_of(&a);
        out.extend(
            p.x_i
                .iter()
                .zip(p.x_j.iter())
                .map(|(xi, xj)| sampson_distance(&e, xi, xj).unwrap_or(0.0)),
        );
    }
}

/// Central-difference Jacobian of [`residuals`] at `x` (step 1e-6 rad / m) into `jac`;
/// `rp`, `rm` are scratch.
fn jacobian(
    pairs: &[EpipolarPair],
    x: &Isometry3<f64>,
    jac: &mut [Vector6<f64>],
    rp: &mut Vec<f64>,
    rm: &mut Vec<f64>,
) {
    for c in 0..6 {
        let mut d = Vector6::zeros();
        d[c] = 1e-6;
        residuals(pairs, &retract(x, &d), rp);
        residuals(pairs, &retract(x, &(-d)), rm);
        for ((j, a), b) in jac.iter_mut().zip(rp.iter()).zip(rm.iter()) {
            j[c] = (a - b) / 2e-6;
        }
    }
}

/// Huber weight of a residual.
fn huber_weight(r: f64, k: f64) -> f64 {
    if r.abs() <= k { 1.0 } else { k / r.abs() }
}

fn robust_cost(r: &[f64], k: f64) -> f64 {
    r.iter()
        .map(|&r| {
            let a = r.abs();
            if a <= k {
                0.5 * r * r
            } else {
                k * (a - 0.5 * k)
            }
        })
        .sum()
}

/// Refines X from `x0` (module docs). `None` without correspondences or when the normal
/// matrix is singular (motions that do not determine X).
pub fn refine_epipolar(
    pairs: &[EpipolarPair],
    x0: &Isometry3<f64>,
    params: &EpipolarParams,
) -> Option<EpipolarReport> {
    let k = params.huber;
    let mut r = Vec::new();
    residuals(pairs, x0, &mut r);
    let n = r.len();
    if n < 6 {
        return None;
    }
    let rms = |r: &[f64]| (r.iter().map(|v| v * v).sum::<f64>() / r.len().max(1) as f64).sqrt();
    let rms_initial = rms(&r);
    let mut x = *x0;
    let mut cost = robust_cost(&r, k);
    let mut lambda = 1e-3;
    let mut iterations = 0;
    let (mut rp, mut rm) = (Vec::with_capacity(n), Vec::with_capacity(n));
    let mut jac = vec![Vector6::<f64>::zeros(); n];
    for _ in 0..params.max_iterations {
        iterations += 1;
        jacobian(pairs, &x, &mut jac, &mut rp, &mut rm);
        let mut h = Matrix6::<f64>::zeros();
        let mut g = Vector6::<f64>::zeros();
        for (j, &ri) in jac.iter().zip(&r) {
            let w = huber_weight(ri, k);
            h += w * j * j.transpose();
            g += w * ri * j;
        }
        let mut improved = false;
        for _ in 0..10 {
            let mut damped = h;
            for d in 0..6 {
                damped[(d, d)] += lambda * h[(d, d)].max(1e-12);
            }
            let step = damped.cholesky()?.solve(&(-g));
            let candidate = retract(&x, &step);
            residuals(pairs, &candidate, &mut rp);
            let c = robust_cost(&rp, k);
            if c < cost {
                let small = step.norm() < 1e-10 || (cost - c) < 1e-12 * cost;
                x = candidate;
                std::mem::swap(&mut r, &mut rp);
                cost = c;
                lambda = (lambda * 0.3).max(1e-9);
                improved = !small;
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    // Covariance at the optimum.
    jacobian(pairs, &x, &mut jac, &mut rp, &mut rm);
    let mut h = Matrix6::<f64>::zeros();
    let mut wrr = 0.0;
    for (j, &ri) in jac.iter().zip(&r) {
        let w = huber_weight(ri, k);
        h += w * j * j.transpose();
        wrr += w * ri * ri;
    }
    let s2 = wrr / (n - 6) as f64;
    let (sigma_rot_deg, sigma_trans_mm) = match h.try_inverse() {
        Some(cov) => {
            let cov = cov * s2;
            let block_max = |o: usize| {
                cov.fixed_view::<3, 3>(o, o)
                    .into_owned()
                    .symmetric_eigenvalues()
                    .max()
                    .max(0.0)
                    .sqrt()
            };
            (block_max(0).to_degrees(), block_max(3) * 1e3)
        }
        None => (f64::INFINITY, f64::INFINITY),
    };
    Some(EpipolarReport {
        tool0_from_camera: x,
        residuals: n,
        rms_initial,
        rms_final: rms(&r),
        iterations,
        sigma_rot_deg,
        sigma_trans_mm,
    })
}

/// Replicates of [`hand_error_covariance`].
pub const HAND_ERROR_REPLICATES: usize = 24;

/// The covariance of the epipolar X that hand-pose error varying from view to view makes
/// (parameters `(theta, t)` in rad and m, as [`crate::handeye::uncertainty`]'s), propagated
/// by Monte Carlo: in replicate `r` each view `v` of `views` gets its own flange error
/// `E_v = (exp(w_v), u_v)`, `w_v ~ N(0, sigma_rot_rad^2 I)`, `u_v ~ N(0, sigma_trans_m^2 I)`
/// (counter-based normals of `seed`, so the result does not depend on the thread count),
/// each pair's hand motion becomes `E_i^-1 B_ij E_j` (the views' poses `B_v E_v`), X is
/// refined again from `x` on the pairs' unchanged correspondences, and
///
/// ```text
/// Sigma_hand = 1/R sum_r d_r d_r^T,   d_r = (log(R_r R^T), t_r - t)
/// ```
///
/// Why mono needs it: the epipolar constraint takes the camera translation's direction
/// from `X^-1 B X`, so a hand translation error of `e` over a baseline `b` turns the
/// predicted direction by about `e / b`, and the images measure that direction well: X's
/// rotation follows the hand error far more than it does from pose pairs, where only
/// rotations carry it. A smooth kinematic error (one DH table, nearby configurations) moves
/// the views alike, so leaving a view out (the jackknife) does not show it. Independent
/// draws per view stand in for that correlated error, with the pairs' error matched
/// ([`super::ViewHandError`]); the part of the error that is truly independent per view
/// (encoder noise) the jackknife sees as well, so it is counted twice, on the safe side.
/// The spread is taken about `x` (a bias of the replicates counts too) and without a
/// small-sample factor. `views[k]` is the `(i, j)` of `pairs[k]`; `None` without pairs or
/// when a replicate fails.
pub fn hand_error_covariance(
    pairs: &[EpipolarPair],
    views: &[(usize, usize)],
    x: &Isometry3<f64>,
    params: &EpipolarParams,
    sigma_rot_rad: f64,
    sigma_trans_m: f64,
    seed: u64,
) -> Option<Matrix6<f64>> {
    const STREAM: u64 = 0x4841_4e44; // "HAND"
    if pairs.len() != views.len() || pairs.is_empty() {
        return None;
    }
    if sigma_rot_rad == 0.0 && sigma_trans_m == 0.0 {
        return Some(Matrix6::zeros());
    }
    let flange_error = |r: usize, v: usize| {
        let n = |c: usize| rng::counter::normal(seed, STREAM + r as u64, (6 * v + c) as u64);
        Isometry3::from_parts(
            Translation3::from(Vector3::new(n(3), n(4), n(5)) * sigma_trans_m),
            UnitQuaternion::from_scaled_axis(Vector3::new(n(0), n(1), n(2)) * sigma_rot_rad),
        )
    };
    let n_views = views.iter().map(|&(i, j)| i.max(j) + 1).max().unwrap_or(0);
    let replicates: Vec<Option<Vector6<f64>>> = (0..HAND_ERROR_REPLICATES)
        .into_par_iter()
        .map(|r| {
            // Each view's error once per replicate (a view is in many pairs).
            let errors: Vec<Isometry3<f64>> = (0..n_views).map(|v| flange_error(r, v)).collect();
            let perturbed: Vec<EpipolarPair> = pairs
                .iter()
                .zip(views)
                .map(|(p, &(i, j))| EpipolarPair {
                    hand: errors[i].inverse() * p.hand * errors[j],
                    ..p.clone()
                })
                .collect();
            let xr = refine_epipolar(&perturbed, x, params)?.tool0_from_camera;
            let w = (xr.rotation * x.rotation.inverse()).scaled_axis();
            let t = xr.translation.vector - x.translation.vector;
            Some(Vector6::new(w.x, w.y, w.z, t.x, t.y, t.z))
        })
        .collect();
    let d: Vec<Vector6<f64>> = replicates.into_iter().collect::<Option<_>>()?;
    let cov = d
        .iter()
        .fold(Matrix6::zeros(), |a, v| a + v * v.transpose())
        / d.len() as f64;
    cov.iter().all(|v| v.is_finite()).then_some(cov)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Point3, Unit};

    fn iso(axis: [f64; 3], deg: f64, t: [f64; 3]) -> Isometry3<f64> {
        Isometry3::from_parts(
            Translation3::new(t[0], t[1], t[2]),
            UnitQuaternion::from_axis_angle(
                &Unit::new_normalize(Vector3::new(axis[0], axis[1], axis[2])),
                deg.to_radians(),
            ),
        )
    }

    /// Exact correspondences of a 3D point cloud for hand motions and a true X: the
    /// refinement returns X from a start 2 deg / 20 mm off, translation included (which
    /// per-pair scales could not pin down better than the directions allow).
    #[test]
    fn recovers_x_from_exact_epipolar_data() {
        let x = iso([0.2, -1.0, 0.4], 12.0, [0.03, -0.06, 0.09]);
        let hands = [
            iso([1.0, 0.0, 0.2], 25.0, [0.10, -0.05, 0.02]),
            iso([0.0, 1.0, -0.3], 30.0, [-0.04, 0.12, 0.03]),
            iso([0.2, 0.1, 1.0], 20.0, [0.07, 0.01, -0.09]),
            iso([1.0, 1.0, 0.0], 18.0, [0.00, 0.05, 0.11]),
        ];
        let pairs: Vec<EpipolarPair> = hands
            .iter()
            .map(|b| {
                let a = x.inverse() * b * x; // cam_i_from_cam_j
                let mut x_i = Vec::new();
                let mut x_j = Vec::new();
                for u in 0..8 {
                    for v in 0..6 {
                        let p_j = Point3::new(
                            -0.2 + 0.05 * f64::from(u),
                            -0.15 + 0.05 * f64::from(v),
                            0.4 + 0.03 * f64::from((u * v) % 5),
                        );
                        let p_i = a * p_j;
                        x_j.push(Point2::new(p_j.x / p_j.z, p_j.y / p_j.z));
                        x_i.push(Point2::new(p_i.x / p_i.z, p_i.y / p_i.z));
                    }
                }
                EpipolarPair {
                    hand: *b,
                    x_i: x_i.into(),
                    x_j: x_j.into(),
                }
            })
            .collect();
        let start = x * iso([1.0, 1.0, 1.0], 2.0, [0.02, 0.0, -0.01]);
        let rep = refine_epipolar(&pairs, &start, &EpipolarParams::default()).expect("solved");
        let (deg, m) = crate::handeye::pose_error(&rep.tool0_from_camera, &x);
        assert!(deg < 1e-5 && m < 1e-6, "{deg} deg, {m} m");
        assert!(rep.rms_final < 1e-9 && rep.rms_initial > 1e-3, "{rep:?}");
    }

    /// The Monte Carlo hand-error covariance covers the error it models: views whose
    /// measured hand poses carry independent flange errors of 0.05 deg / 0.5 mm per axis,
    /// exact correspondences (the true motions), X refined on the measured hands. Over 200
    /// calibrations the squared Mahalanobis distance of X's rotation and translation error
    /// against the covariance is under chi-square(3)'s 95 % point in 88-99 % of them; the
    /// result is the same on every call (counter-based draws).
    #[test]
    fn the_hand_error_covariance_covers_the_error_it_models() {
        let n = |seed: u64, stream: u64, k: u64| rng::counter::normal(seed, stream, k);
        // A mount turned by 90 deg and hand motions of up to ~1 m, so that a perturbation on
        // the wrong side or a rotation error in the wrong frame would show.
        let x = iso([0.2, -1.0, 0.4], 90.0, [0.03, -0.06, 0.09]);
        let (sigma_rot, sigma_t) = (0.05_f64.to_radians(), 0.5e-3);
        let params = EpipolarParams::default();
        let trials = 200;
        let mut within = [0usize; 2];
        for t in 0..trials {
            let draw = |stream: u64, k: u64, s: f64| {
                Vector3::new(
                    n(t, stream, 3 * k),
                    n(t, stream, 3 * k + 1),
                    n(t, stream, 3 * k + 2),
                ) * s
            };
            let views = 8u64;
            let hands: Vec<Isometry3<f64>> = (0..views)
                .map(|v| {
                    Isometry3::from_parts(
                        Translation3::from(draw(1, v, 0.4)),
                        UnitQuaternion::from_scaled_axis(draw(2, v, 0.3)),
                    )
                })
                .collect();
            let measured: Vec<Isometry3<f64>> = (0..views)
                .map(|v| {
                    hands[v as usize]
                        * Isometry3::from_parts(
                            Translation3::from(draw(3, v, sigma_t)),
                            UnitQuaternion::from_scaled_axis(draw(4, v, sigma_rot)),
                        )
                })
                .collect();
            let (mut pairs, mut ij) = (Vec::new(), Vec::new());
            for i in 0..views as usize {
                for j in i + 1..views as usize {
                    let a = x.inverse() * hands[i].inverse() * hands[j] * x;
                    let (mut x_i, mut x_j) = (Vec::new(), Vec::new());
                    for k in 0..24u64 {
                        let u =
                            |c: u64| rng::counter::uniform(t, 5 + c, (i * 64 + j) as u64 * 64 + k);
                        let p_j = Point3::new(u(0) - 0.5, u(1) - 0.5, 0.8 + 0.4 * u(2)) * 0.6;
                        let p_i = a * p_j;
                        if p_i.z > 0.1 {
                            x_j.push(Point2::new(p_j.x / p_j.z, p_j.y / p_j.z));
                            x_i.push(Point2::new(p_i.x / p_i.z, p_i.y / p_i.z));
                        }
                    }
                    let hand = measured[i].inverse() * measured[j];
                    pairs.push(EpipolarPair {
                        hand,
                        x_i: x_i.into(),
                        x_j: x_j.into(),
                    });
                    ij.push((i, j));
                }
            }
            let estimate = refine_epipolar(&pairs, &x, &params).expect("refined");
            let x_hat = estimate.tool0_from_camera;
            let cov =
                hand_error_covariance(&pairs, &ij, &x_hat, &params, sigma_rot, sigma_t, 1000 + t)
                    .expect("a covariance");
            if t == 0 {
                let again = hand_error_covariance(
                    &pairs,
                    &ij,
                    &x_hat,
                    &params,
                    sigma_rot,
                    sigma_t,
                    1000 + t,
                );
                assert_eq!(again, Some(cov));
                let none = hand_error_covariance(&pairs, &ij, &x_hat, &params, 0.0, 0.0, 7);
                assert_eq!(none, Some(Matrix6::zeros()));
            }
            // As `handeye::uncertainty::mahalanobis`: each error against its 3x3 block.
            let r = (x_hat.rotation * x.rotation.inverse()).scaled_axis();
            let d = x_hat.translation.vector - x.translation.vector;
            let m2 = |o: usize, v: &Vector3<f64>| {
                let b = cov.fixed_view::<3, 3>(o, o).into_owned();
                b.try_inverse().map_or(f64::INFINITY, |bi| v.dot(&(bi * v)))
            };
            let (r2, t2) = (m2(0, &r), m2(3, &d));
            within[0] += usize::from(r2 <= 7.81);
            within[1] += usize::from(t2 <= 7.81);
        }
        let share = within.map(|k| k as f64 / trials as f64);
        eprintln!("rotation, translation within chi2(3) 95%: {share:?}");
        for s in share {
            assert!((0.88..=0.99).contains(&s), "{share:?}");
        }
    }
}
