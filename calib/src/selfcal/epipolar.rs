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

use crate::relpose::essential::essential_of;
use crate::relpose::refine::sampson_distance;

/// One pair of views: its hand motion and its inlier correspondences.
#[derive(Debug, Clone, PartialEq)]
pub struct EpipolarPair {
    /// `B = tool_i_from_tool_j` (metric).
    pub hand: Isometry3<f64>,
    /// Normalised undistorted points in view `i`.
    pub x_i: Vec<Point2<f64>>,
    /// The same points in view `j`.
    pub x_j: Vec<Point2<f64>>,
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
                .zip(&p.x_j)
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
                EpipolarPair { hand: *b, x_i, x_j }
            })
            .collect();
        let start = x * iso([1.0, 1.0, 1.0], 2.0, [0.02, 0.0, -0.01]);
        let rep = refine_epipolar(&pairs, &start, &EpipolarParams::default()).expect("solved");
        let (deg, m) = crate::handeye::pose_error(&rep.tool0_from_camera, &x);
        assert!(deg < 1e-5 && m < 1e-6, "{deg} deg, {m} m");
        assert!(rep.rms_final < 1e-9 && rep.rms_initial > 1e-3, "{rep:?}");
    }
}
