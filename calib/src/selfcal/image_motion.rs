//! RGB-D pair motion refined in the image ([`super::Steps::image_motion`]): each frame's
//! depth points reprojected onto the other frame's keypoints, both ways.
//!
//! A structured-light point `p = z m` (`m = (x, y, 1)` the undistorted ray of its keypoint)
//! is precise across the ray (the keypoint's localisation, `sigma_px s^level z / f`) but noisy
//! along it (`sigma_z(z) = s_ref (z / z_ref)^2`). A 3D-3D fit weighs both the same; the image
//! does not see the depth error head on: reprojected into the other camera it moves the point
//! only by the ray's apparent direction there. With `A = cam_i_from_cam_j`, for a match
//! `(u_i, u_j)` with depth in view `j`,
//!
//! ```text
//! r_i = f (pi(A p_j) - x_i)        (pixels; pi(q) = (q_x / q_z, q_y / q_z), x_i undistorted)
//! C_i = (sigma_i^2 + sigma_j^2 (z_j / z_i)^2) I + d d^T,   d = f J_pi(A p_j) R_A m_j sigma_z(z_j)
//! ```
//!
//! (`sigma_k = sigma_px s^level_k`, the keypoint's localisation; the second term the other
//! keypoint's error carried by `p_j`; `d` the depth error of `p_j` as it appears in image
//! `i`), and symmetrically `r_j = f (pi(A^-1 p_i) - x_j)` with depth in view `i`. A match
//! with depth in one view only still gives one residual. The motion minimises
//!
//! ```text
//! F(A) = sum_k rho(r_i,k^T C_i,k^-1 r_i,k) + rho(r_j,k^T C_j,k^-1 r_j,k)
//! ```
//!
//! with `rho` Huber on the normalised residual (`k = HUBER_K` robust scales, the scale
//! `s = median(sqrt(e)) / 1.1774`, the median norm of a 2-D standard normal), by
//! Levenberg-Marquardt on `A <- exp(delta) A` (analytic Jacobians:
//! `d(A p)/d(omega, v) = [-[A p]x, I]`, `d(A^-1 p)/d(omega, v) = [R_A^T [p]x, -R_A^T]`), the
//! covariances re-evaluated at each round's motion. Start: the 3D-3D estimate and its inliers;
//! after each round every match is classified again (inlier when each of its residuals has
//! `e / s^2 <= INLIER_CHI2` and lies in front of the camera), at most [`ROUNDS`] rounds.
//!
//! This is maximum likelihood for independent keypoint and depth noise to first order (the
//! depth of the *observed* keypoint enters only through the other residual), the 2D-3D
//! reprojection of a depth-PnP pipeline done in both directions at once.

use nalgebra::{Isometry3, Matrix2, Matrix3, Matrix6, Point2, Point3, SMatrix, Vector2, Vector6};

use crate::relpose::refine::DepthNoiseModel;

/// Huber threshold on the normalised residual, in robust scales.
pub const HUBER_K: f64 = 2.0;
/// Median of the norm of a 2-D standard normal vector (`sqrt(2 ln 2)`).
pub const MEDIAN_NORM_2D: f64 = 1.177_410_022_515_474_7;
/// Inlier bound on `e / s^2` per residual: chi-square with 2 dof at 99.9%.
pub const INLIER_CHI2: f64 = 13.82;
/// Re-classification rounds at most.
pub const ROUNDS: usize = 3;
/// LM iterations per round at most.
pub const MAX_ITERATIONS: usize = 15;

/// One match with what each view measured.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImageMatch {
    /// Undistorted normalised keypoint in view `i`.
    pub x_i: Point2<f64>,
    /// Undistorted normalised keypoint in view `j`.
    pub x_j: Point2<f64>,
    /// The point by view `i`'s depth, camera `i` coordinates.
    pub p_i: Option<Point3<f64>>,
    /// The point by view `j`'s depth, camera `j` coordinates.
    pub p_j: Option<Point3<f64>>,
    /// Keypoint localisation 1-sigma in view `i`, pixels (`sigma_px s^level`).
    pub sigma_i_px: f64,
    /// ... in view `j`.
    pub sigma_j_px: f64,
}

/// Result of [`refine_image_motion`].
#[derive(Debug, Clone, PartialEq)]
pub struct ImageMotion {
    /// `A = cam_i_from_cam_j`.
    pub cam_i_from_cam_j: Isometry3<f64>,
    /// Per match: an inlier of the final round.
    pub inliers: Vec<bool>,
    /// Inlier count.
    pub inlier_count: usize,
    /// Robust scale of the normalised residuals (about 1 when the noise model fits).
    pub scale: f64,
    /// RMS reprojection residual over the inliers, pixels.
    pub rms_px: f64,
    /// Gauss-Newton information of `delta` (left perturbation of `A`, frame `i`), already
    /// divided by `scale^2`: its inverse is the covariance of the motion.
    pub information: Matrix6<f64>,
}

type Matrix2x6 = SMatrix<f64, 2, 6>;
type Matrix2x3 = SMatrix<f64, 2, 3>;

fn skew(v: &nalgebra::Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// `d pi / d q` at `q` (normalised image coordinates).
fn proj_jacobian(q: &Point3<f64>) -> Matrix2x3 {
    let iz = 1.0 / q.z;
    Matrix2x3::new(iz, 0.0, -q.x * iz * iz, 0.0, iz, -q.y * iz * iz)
}

/// One residual of a match: the reprojection in pixels, its 2x2 covariance, its Jacobian in
/// pixels per `delta`, or `None` behind the camera.
struct Residual {
    r: Vector2<f64>,
    cov: Matrix2<f64>,
    jac: Matrix2x6,
}

fn residuals_of(
    m: &ImageMatch,
    a: &Isometry3<f64>,
    f: f64,
    noise: &DepthNoiseModel,
) -> [Option<Residual>; 2] {
    let r_a = a.rotation.to_rotation_matrix().into_inner();
    // Depth in j, observed in i.
    let ri = m.p_j.and_then(|p_j| {
        let q = a * p_j;
        if q.z <= 0.0 || p_j.z <= 0.0 {
            return None;
        }
        let pj = proj_jacobian(&q);
        let r = f * (Vector2::new(q.x / q.z, q.y / q.z) - m.x_i.coords);
        let ray = p_j.coords / p_j.z;
        let d = f * pj * (r_a * ray) * noise.sigma_depth_m(p_j.z);
        let s2 = m.sigma_i_px.powi(2) + (m.sigma_j_px * p_j.z / q.z).powi(2);
        let mut dq = SMatrix::<f64, 3, 6>::zeros();
        dq.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&(-skew(&q.coords)));
        dq.fixed_view_mut::<3, 3>(0, 3)
            .copy_from(&Matrix3::identity());
        Some(Residual {
            r,
            cov: Matrix2::identity() * s2 + d * d.transpose(),
            jac: f * pj * dq,
        })
    });
    // Depth in i, observed in j.
    let rj = m.p_i.and_then(|p_i| {
        let q = a.inverse_transform_point(&p_i);
        if q.z <= 0.0 || p_i.z <= 0.0 {
            return None;
        }
        let pj = proj_jacobian(&q);
        let r = f * (Vector2::new(q.x / q.z, q.y / q.z) - m.x_j.coords);
        let ray = p_i.coords / p_i.z;
        let d = f * pj * (r_a.transpose() * ray) * noise.sigma_depth_m(p_i.z);
        let s2 = m.sigma_j_px.powi(2) + (m.sigma_i_px * p_i.z / q.z).powi(2);
        let mut dq = SMatrix::<f64, 3, 6>::zeros();
        dq.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&(r_a.transpose() * skew(&p_i.coords)));
        dq.fixed_view_mut::<3, 3>(0, 3)
            .copy_from(&(-r_a.transpose()));
        Some(Residual {
            r,
            cov: Matrix2::identity() * s2 + d * d.transpose(),
            jac: f * pj * dq,
        })
    });
    [ri, rj]
}

/// `r^T C^-1 r` (infinite for a singular covariance).
fn mahalanobis(res: &Residual) -> f64 {
    res.cov
        .try_inverse()
        .map_or(f64::INFINITY, |w| (res.r.transpose() * w * res.r)[(0, 0)])
}

fn huber_weight(e: f64, k: f64) -> f64 {
    let n = e.sqrt();
    if n <= k { 1.0 } else { k / n }
}

/// Robust cost of the matches in `mask` at `a` with the Huber threshold `k` (normalised).
fn cost(
    matches: &[ImageMatch],
    mask: &[bool],
    a: &Isometry3<f64>,
    f: f64,
    noise: &DepthNoiseModel,
    k: f64,
) -> f64 {
    let mut c = 0.0;
    for (m, _) in matches.iter().zip(mask).filter(|(_, on)| **on) {
        for res in residuals_of(m, a, f, noise).iter().flatten() {
            let e = mahalanobis(res);
            let n = e.sqrt();
            c += if n <= k { e } else { 2.0 * k * n - k * k };
        }
    }
    c
}

/// Normal equations of the matches in `mask` at `a` (Huber weights with threshold `k`).
fn normal(
    matches: &[ImageMatch],
    mask: &[bool],
    a: &Isometry3<f64>,
    f: f64,
    noise: &DepthNoiseModel,
    k: f64,
) -> (Matrix6<f64>, Vector6<f64>) {
    let mut h = Matrix6::zeros();
    let mut g = Vector6::zeros();
    for (m, _) in matches.iter().zip(mask).filter(|(_, on)| **on) {
        for res in residuals_of(m, a, f, noise).iter().flatten() {
            let Some(w) = res.cov.try_inverse() else {
                continue;
            };
            let e = (res.r.transpose() * w * res.r)[(0, 0)];
            let w = w * huber_weight(e, k);
            h += res.jac.transpose() * w * res.jac;
            g += res.jac.transpose() * w * res.r;
        }
    }
    (h, g)
}

/// Robust scale of the normalised residuals of the matches in `mask` (module docs).
fn robust_scale(
    matches: &[ImageMatch],
    mask: &[bool],
    a: &Isometry3<f64>,
    f: f64,
    noise: &DepthNoiseModel,
) -> f64 {
    let mut n: Vec<f64> = matches
        .iter()
        .zip(mask)
        .filter(|(_, on)| **on)
        .flat_map(|(m, _)| residuals_of(m, a, f, noise))
        .flatten()
        .map(|r| mahalanobis(&r).sqrt())
        .collect();
    if n.is_empty() {
        return 1.0;
    }
    n.sort_by(f64::total_cmp);
    let med = n.get(n.len() / 2).copied().unwrap_or(1.0);
    (med / MEDIAN_NORM_2D).max(0.1)
}

fn exp_left(d: &Vector6<f64>, a: &Isometry3<f64>) -> Isometry3<f64> {
    super::eq15::exp_se3(d) * a
}

/// Refines `a0 = cam_i_from_cam_j` on the image residuals of `matches` (module docs),
/// starting from the inlier flags `mask0`; `f` is the focal length in pixels. `None` when
/// fewer than `min_inliers` matches remain or the normal equations are singular.
pub fn refine_image_motion(
    matches: &[ImageMatch],
    mask0: &[bool],
    a0: &Isometry3<f64>,
    f: f64,
    noise: &DepthNoiseModel,
    min_inliers: usize,
) -> Option<ImageMotion> {
    let mut a = *a0;
    let mut mask: Vec<bool> = (0..matches.len())
        .map(|k| mask0.get(k).copied().unwrap_or(false))
        .collect();
    let mut scale = robust_scale(matches, &mask, &a, f, noise);
    for _round in 0..ROUNDS {
        let k = HUBER_K * scale;
        let mut c = cost(matches, &mask, &a, f, noise, k);
        let mut lambda = 1e-3;
        for _ in 0..MAX_ITERATIONS {
            let (h, g) = normal(matches, &mask, &a, f, noise, k);
            let mut accepted = false;
            let mut small = false;
            for _ in 0..8 {
                let mut damped = h;
                for i in 0..6 {
                    damped[(i, i)] += lambda * h[(i, i)].max(1e-12);
                }
                let Some(step) = damped.cholesky().map(|ch| ch.solve(&(-g))) else {
                    lambda *= 10.0;
                    continue;
                };
                let a_new = exp_left(&step, &a);
                let c_new = cost(matches, &mask, &a_new, f, noise, k);
                if c_new <= c {
                    small = step.norm() < 1e-12 || (c - c_new) <= 1e-12 * c;
                    a = a_new;
                    c = c_new;
                    lambda = (lambda / 3.0).max(1e-12);
                    accepted = true;
                    break;
                }
                lambda *= 10.0;
            }
            if !accepted || small {
                break;
            }
        }
        scale = robust_scale(matches, &mask, &a, f, noise);
        let bound = INLIER_CHI2 * scale * scale;
        let new_mask: Vec<bool> = matches
            .iter()
            .map(|m| {
                let rs = residuals_of(m, &a, f, noise);
                let any = rs.iter().any(Option::is_some);
                let has_depth = m.p_i.is_some() || m.p_j.is_some();
                // Behind a camera (a residual that should exist is missing) or too far.
                let complete =
                    (m.p_j.is_none() || rs[0].is_some()) && (m.p_i.is_none() || rs[1].is_some());
                has_depth && any && complete && rs.iter().flatten().all(|r| mahalanobis(r) <= bound)
            })
            .collect();
        if new_mask == mask {
            break;
        }
        mask = new_mask;
        if mask.iter().filter(|b| **b).count() < min_inliers {
            return None;
        }
    }
    let inlier_count = mask.iter().filter(|b| **b).count();
    if inlier_count < min_inliers {
        return None;
    }
    let (h, _) = normal(matches, &mask, &a, f, noise, f64::INFINITY);
    let (mut sum, mut n) = (0.0, 0usize);
    for (m, _) in matches.iter().zip(&mask).filter(|(_, on)| **on) {
        for r in residuals_of(m, &a, f, noise).iter().flatten() {
            sum += r.r.norm_squared();
            n += 1;
        }
    }
    Some(ImageMotion {
        cam_i_from_cam_j: a,
        inliers: mask,
        inlier_count,
        scale,
        rms_px: (sum / n.max(1) as f64).sqrt(),
        information: h / (scale * scale),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::selfcal::eq15::tests::iso;

    /// Matches of a random cloud seen from two cameras related by `a`, with exact depth.
    fn matches(a: &Isometry3<f64>) -> Vec<ImageMatch> {
        (0..200)
            .map(|k| {
                let t = k as f64;
                let p_j = Point3::new(
                    0.15 * (t * 0.77).sin(),
                    0.12 * (t * 1.31).cos(),
                    0.45 + 0.08 * (t * 0.53).sin(),
                );
                let p_i = a * p_j;
                ImageMatch {
                    x_i: Point2::new(p_i.x / p_i.z, p_i.y / p_i.z),
                    x_j: Point2::new(p_j.x / p_j.z, p_j.y / p_j.z),
                    p_i: Some(p_i),
                    p_j: (k % 7 != 0).then_some(p_j),
                    sigma_i_px: 0.5,
                    sigma_j_px: 0.5,
                }
            })
            .collect()
    }

    #[test]
    fn image_motion_recovers_the_motion_and_rejects_outliers() {
        let a = iso([0.2, 1.0, 0.1], 25.0, [0.12, -0.03, 0.05]);
        let mut ms = matches(&a);
        // 10% gross outliers (wrong keypoints in both views).
        for m in ms.iter_mut().step_by(10) {
            m.x_i.x += 0.02;
            m.x_j.y -= 0.02;
        }
        let start = iso([1.0, 0.0, 0.0], 0.3, [0.002, 0.0, -0.001]) * a;
        let mask = vec![true; ms.len()];
        let noise = DepthNoiseModel::default();
        let r = refine_image_motion(&ms, &mask, &start, 1745.0, &noise, 10).expect("motion");
        let d = a.inverse() * r.cam_i_from_cam_j;
        assert!(d.rotation.angle() < 1e-9 && d.translation.vector.norm() < 1e-9);
        for (k, inl) in r.inliers.iter().enumerate() {
            assert_eq!(*inl, k % 10 != 0, "match {k}");
        }
        assert_eq!(r.inlier_count, 180);
        // Without depth anywhere there is nothing to reproject.
        let none: Vec<ImageMatch> = ms
            .iter()
            .map(|m| ImageMatch {
                p_i: None,
                p_j: None,
                ..*m
            })
            .collect();
        assert!(refine_image_motion(&none, &mask, &start, 1745.0, &noise, 10).is_none());
    }
}
