//! Nonlinear refinement of a relative pose on all inliers (Levenberg-Marquardt).
//!
//! **Rigid (RGB-D).** Residuals `r_i = p_in_a_i - (R p_in_b_i + t)`. With independent
//! Gaussian noise on both points, `r_i ~ N(0, C_i)`, `C_i = S_a,i + R S_b,i R^T`, so the
//! maximum-likelihood pose minimises the Mahalanobis cost (as in generalised ICP, Segal, Haehnel
//! & Thrun 2009; the errors-in-variables view of Matei & Meer 1999)
//!
//! ```text
//! F(R, t) = sum_i r_i^T C_i^-1 r_i
//! ```
//!
//! with `C_i` re-evaluated at the current `R` each outer iteration. The per-point covariance of
//! a structured-light point `p = z (x, y, 1)` ([`DepthNoiseModel`]) is
//! `S = s_z(z)^2 m m^T + (s_px z / f)^2 diag(1, 1, 0)` with `m = (x, y, 1)` the viewing ray
//! (depth noise moves the point along its ray), `s_z(z) = s_ref (z / z_ref)^2` (ARCHITECTURE.md section 6:
//! ~0.1 mm at 0.5 m, growing with `z^2`) and the pixel noise `s_px` scaled by `z / f`. Without
//! a noise model `C_i = I` (plain point-to-point least squares, i.e. Umeyama's optimum).
//! Updates: `R <- exp([w]x) R`, `t <- t + dt`; `dr_i/dw = [R p_b,i]x`, `dr_i/dt = -I`.
//!
//! **Essential (RGB).** With `E = [t]x R`, `|t| = 1`, the Sampson distance (Hartley & Zisserman
//! 2004, eq. 11.9) of `(x_a, x_b)` (homogeneous normalised points)
//!
//! ```text
//! e_i = x_a^T E x_b / sqrt((E x_b)_1^2 + (E x_b)_2^2 + (E^T x_a)_1^2 + (E^T x_a)_2^2)
//! ```
//!
//! is minimised over `SO(3) x S^2` (5 degrees of freedom; Ma, Kosecka & Sastry 2001):
//! `R <- exp([w]x) R`, `t <- normalise(t + B d)` with `B` an orthonormal basis of the tangent
//! plane at `t`; `dE/dw_k = [t]x [e_k]x R`, `dE/dd_j = [b_j]x R`, and the analytic
//! `de/dE` of the quotient above. Sampson is the first-order approximation of the
//! reprojection (gold standard) error.

use nalgebra::{
    Isometry3, Matrix3, Point2, Point3, Rotation3, SMatrix, SVector, Translation3, UnitQuaternion,
    Vector3,
};

use super::{RelPoseError, check_lengths, skew};

/// Noise of structured-light depth points (ARCHITECTURE.md section 6 wrist camera).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DepthNoiseModel {
    /// Depth standard deviation at [`DepthNoiseModel::ref_depth_m`], metres; default 1e-4.
    pub sigma_depth_ref_m: f64,
    /// Reference depth of `sigma_depth_ref_m`, metres; default 0.5 (noise grows with
    /// `(z / ref)^2`).
    pub ref_depth_m: f64,
    /// Image-plane standard deviation of the matched keypoints, pixels; default 0.5.
    pub sigma_pixel_px: f64,
    /// Focal length, pixels; default 1745 (the wrist camera).
    pub focal_px: f64,
}

impl Default for DepthNoiseModel {
    fn default() -> Self {
        Self {
            sigma_depth_ref_m: 1e-4,
            ref_depth_m: 0.5,
            sigma_pixel_px: 0.5,
            focal_px: 1745.0,
        }
    }
}

impl DepthNoiseModel {
    /// Depth standard deviation at depth `z_m`: `s_ref (z / z_ref)^2`.
    pub fn sigma_depth_m(&self, z_m: f64) -> f64 {
        let q = z_m / self.ref_depth_m;
        self.sigma_depth_ref_m * q * q
    }

    /// Lateral standard deviation at depth `z_m`: `s_px z / f`.
    pub fn sigma_lateral_m(&self, z_m: f64) -> f64 {
        self.sigma_pixel_px * z_m.abs() / self.focal_px
    }

    /// Covariance of a point measured at `p_in_camera` (module equation).
    pub fn covariance(&self, p_in_camera: &Point3<f64>) -> Matrix3<f64> {
        let z = p_in_camera.z;
        let ray = if z.abs() > 0.0 {
            p_in_camera.coords / z
        } else {
            Vector3::z()
        };
        let sz = self.sigma_depth_m(z);
        let sl = self.sigma_lateral_m(z);
        sz * sz * ray * ray.transpose()
            + Matrix3::from_diagonal(&Vector3::new(sl * sl, sl * sl, 0.0))
    }
}

/// Stopping rules of the Levenberg-Marquardt refinements.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RefineParams {
    /// Maximum outer iterations; default 50.
    pub max_iterations: usize,
    /// Stop when the step norm (radians / metres or unit-sphere units) is below this;
    /// default 1e-12.
    pub step_tolerance: f64,
    /// Stop when the relative cost decrease is below this; default 1e-14.
    pub relative_cost_tolerance: f64,
}

impl Default for RefineParams {
    fn default() -> Self {
        Self {
            max_iterations: 50,
            step_tolerance: 1e-12,
            relative_cost_tolerance: 1e-14,
        }
    }
}

/// Why a refinement stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RefineTermination {
    /// Step or cost decrease below tolerance.
    Converged,
    /// [`RefineParams::max_iterations`] reached.
    MaxIterations,
    /// No damping gave a decrease (at a minimum to rounding).
    NoDecrease,
}

/// Result of a refinement.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RefineReport {
    /// Refined `a_from_b` (`|t| = 1` for the essential refinement).
    pub a_from_b: Isometry3<f64>,
    /// Cost at the start (module equations).
    pub initial_cost: f64,
    /// Cost at the end.
    pub final_cost: f64,
    /// Outer iterations run.
    pub iterations: usize,
    /// Why it stopped.
    pub termination: RefineTermination,
    /// Standard deviation of the rotation about its worst-determined axis, radians: the
    /// square root of the largest eigenvalue of the rotation block of `s0^2 H^-1` (Gauss-Newton
    /// Hessian `H` at the solution, a-posteriori variance factor `s0^2 = cost / (m - dof)`;
    /// Hartley & Zisserman 2004, sec. 5.2). `NaN` when not computable.
    pub rotation_std_rad: f64,
    /// Same for the translation: metres for the rigid refinement, radians of direction on the
    /// unit sphere for the essential refinement.
    pub translation_std: f64,
}

/// Rounds of (refine on the inliers, re-select the inliers) the robust estimators run before
/// accepting a mask that still changes (boundary points flipping).
pub const MAX_REFINE_ROUNDS: usize = 6;

/// Isotropic variance added to every residual covariance (1 nm^2, negligible against the
/// ~1e-8 m^2 of real points) so that it is always invertible.
pub const COVARIANCE_FLOOR_M2: f64 = 1e-18;

const LAMBDA_INIT: f64 = 1e-4;
const LAMBDA_MAX: f64 = 1e14;

/// Generic Marquardt loop: `eval(x) -> (cost, H, g)` builds the Gauss-Newton system at `x`
/// (with the weights frozen for that iteration), `cost_at(x, frozen)` evaluates a trial, and
/// `retract(x, delta)` applies a step.
/// Result of [`levenberg_marquardt`].
struct LmOutcome<X, const N: usize> {
    x: X,
    initial_cost: f64,
    final_cost: f64,
    iterations: usize,
    termination: RefineTermination,
    /// `s0^2 H^-1` at the solution, `s0^2 = cost / (residuals - N)` (a-posteriori variance
    /// factor times the inverse Gauss-Newton Hessian); `None` when singular or no redundancy.
    covariance: Option<SMatrix<f64, N, N>>,
}

/// Marquardt iterations followed by the covariance at the solution.
fn levenberg_marquardt<X: Clone, const N: usize, W>(
    x0: X,
    params: &RefineParams,
    mut linearise: impl FnMut(&X) -> (f64, SMatrix<f64, N, N>, SVector<f64, N>, W),
    cost_at: impl FnMut(&X, &W) -> f64,
    retract: impl Fn(&X, &SVector<f64, N>) -> X,
    residual_count: usize,
) -> LmOutcome<X, N> {
    let (x, initial_cost, final_cost, iterations, termination) =
        lm_iterate(x0, params, &mut linearise, cost_at, retract);
    let (c, h, _, _) = linearise(&x);
    let dof = residual_count.saturating_sub(N);
    let covariance = if dof > 0 && c.is_finite() {
        h.try_inverse().map(|h_inv| h_inv * (c / dof as f64))
    } else {
        None
    };
    LmOutcome {
        x,
        initial_cost,
        final_cost,
        iterations,
        termination,
        covariance,
    }
}

/// Largest standard deviation of the `len`-square diagonal block at `start` of a covariance.
fn block_std<const N: usize>(cov: &SMatrix<f64, N, N>, start: usize, len: usize) -> f64 {
    let block = nalgebra::DMatrix::from_fn(len, len, |i, j| cov[(start + i, start + j)]);
    block
        .symmetric_eigenvalues()
        .iter()
        .copied()
        .fold(f64::NAN, f64::max)
        .max(0.0)
        .sqrt()
}

fn lm_iterate<X: Clone, const N: usize, W>(
    x0: X,
    params: &RefineParams,
    mut linearise: impl FnMut(&X) -> (f64, SMatrix<f64, N, N>, SVector<f64, N>, W),
    mut cost_at: impl FnMut(&X, &W) -> f64,
    retract: impl Fn(&X, &SVector<f64, N>) -> X,
) -> (X, f64, f64, usize, RefineTermination) {
    let mut x = x0;
    let mut lambda = LAMBDA_INIT;
    let mut initial_cost = f64::NAN;
    let mut cost = f64::NAN;
    for it in 0..params.max_iterations {
        let (c, h, g, frozen) = linearise(&x);
        cost = c;
        if it == 0 {
            initial_cost = c;
        }
        if !c.is_finite() {
            return (x, initial_cost, c, it, RefineTermination::NoDecrease);
        }
        if c <= 0.0 {
            return (x, initial_cost, c, it, RefineTermination::Converged);
        }
        loop {
            let mut hd = h;
            for k in 0..N {
                hd[(k, k)] += lambda * h[(k, k)].max(1e-30);
            }
            let step = hd.cholesky().map(|ch| -ch.solve(&g));
            if let Some(delta) = step.filter(|d| d.iter().all(|v| v.is_finite())) {
                let trial = retract(&x, &delta);
                let trial_cost = cost_at(&trial, &frozen);
                if trial_cost.is_finite() && trial_cost <= cost {
                    let decrease = cost - trial_cost;
                    x = trial;
                    lambda = (lambda * 0.1).max(1e-12);
                    if delta.norm() <= params.step_tolerance
                        || decrease <= params.relative_cost_tolerance * cost
                    {
                        return (
                            x,
                            initial_cost,
                            trial_cost,
                            it + 1,
                            RefineTermination::Converged,
                        );
                    }
                    cost = trial_cost;
                    break;
                }
            }
            lambda *= 10.0;
            if lambda > LAMBDA_MAX {
                return (x, initial_cost, cost, it + 1, RefineTermination::NoDecrease);
            }
        }
    }
    (
        x,
        initial_cost,
        cost,
        params.max_iterations,
        RefineTermination::MaxIterations,
    )
}

/// Refines a rigid `a_from_b` on matched 3D points by minimising the Mahalanobis cost of the
/// module equations (anisotropic depth-noise weights when `noise` is given, plain
/// point-to-point least squares otherwise).
///
/// # Errors
/// [`RelPoseError::LengthMismatch`], [`RelPoseError::TooFewCorrespondences`] (< 3),
/// [`RelPoseError::NonFinite`].
pub fn refine_rigid(
    p_in_a: &[Point3<f64>],
    p_in_b: &[Point3<f64>],
    a_from_b: &Isometry3<f64>,
    noise: Option<&DepthNoiseModel>,
    params: &RefineParams,
) -> Result<RefineReport, RelPoseError> {
    check_lengths(p_in_a.len(), p_in_b.len(), 3)?;
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
    let cov_a: Vec<Matrix3<f64>> = match noise {
        Some(m) => p_in_a.iter().map(|p| m.covariance(p)).collect(),
        None => Vec::new(),
    };
    let cov_b: Vec<Matrix3<f64>> = match noise {
        Some(m) => p_in_b.iter().map(|p| m.covariance(p)).collect(),
        None => Vec::new(),
    };
    // Information matrices at rotation `r`.
    let weights = |r: &Matrix3<f64>| -> Vec<Matrix3<f64>> {
        if noise.is_none() {
            return Vec::new();
        }
        cov_a
            .iter()
            .zip(&cov_b)
            .map(|(ca, cb)| {
                let c = ca + r * cb * r.transpose() + Matrix3::identity() * COVARIANCE_FLOOR_M2;
                c.try_inverse()
                    .unwrap_or_else(|| Matrix3::identity() / COVARIANCE_FLOOR_M2)
            })
            .collect()
    };
    let x0 = (
        a_from_b.rotation.to_rotation_matrix().into_inner(),
        a_from_b.translation.vector,
    );
    let cost_at = |x: &(Matrix3<f64>, Vector3<f64>), w: &Vec<Matrix3<f64>>| -> f64 {
        let mut cost = 0.0;
        for (i, (pa, pb)) in p_in_a.iter().zip(p_in_b).enumerate() {
            let r = pa.coords - (x.0 * pb.coords + x.1);
            cost += match w.get(i) {
                Some(wi) => r.dot(&(wi * r)),
                None => r.norm_squared(),
            };
        }
        cost
    };
    let linearise = |x: &(Matrix3<f64>, Vector3<f64>)| {
        let w = weights(&x.0);
        let mut h = SMatrix::<f64, 6, 6>::zeros();
        let mut g = SVector::<f64, 6>::zeros();
        let mut cost = 0.0;
        for (i, (pa, pb)) in p_in_a.iter().zip(p_in_b).enumerate() {
            let rp = x.0 * pb.coords;
            let r = pa.coords - (rp + x.1);
            let mut j = SMatrix::<f64, 3, 6>::zeros();
            j.fixed_view_mut::<3, 3>(0, 0).copy_from(&skew(&rp));
            j.fixed_view_mut::<3, 3>(0, 3)
                .copy_from(&(-Matrix3::identity()));
            let wi = w.get(i).copied().unwrap_or_else(Matrix3::identity);
            let jt_w = j.transpose() * wi;
            h += jt_w * j;
            g += jt_w * r;
            cost += r.dot(&(wi * r));
        }
        (cost, h, g, w)
    };
    let retract = |x: &(Matrix3<f64>, Vector3<f64>), d: &SVector<f64, 6>| {
        let dr = Rotation3::new(Vector3::new(d[0], d[1], d[2])).into_inner();
        (dr * x.0, x.1 + Vector3::new(d[3], d[4], d[5]))
    };
    let lm = levenberg_marquardt(x0, params, linearise, cost_at, retract, 3 * p_in_a.len());
    Ok(report(lm, 3))
}

fn report<const N: usize>(
    lm: LmOutcome<(Matrix3<f64>, Vector3<f64>), N>,
    t_dims: usize,
) -> RefineReport {
    let (rotation_std_rad, translation_std) =
        lm.covariance.as_ref().map_or((f64::NAN, f64::NAN), |c| {
            (block_std(c, 0, 3), block_std(c, 3, t_dims))
        });
    RefineReport {
        a_from_b: isometry(&lm.x.0, &lm.x.1),
        initial_cost: lm.initial_cost,
        final_cost: lm.final_cost,
        iterations: lm.iterations,
        termination: lm.termination,
        rotation_std_rad,
        translation_std,
    }
}

fn isometry(r: &Matrix3<f64>, t: &Vector3<f64>) -> Isometry3<f64> {
    let rot = Rotation3::from_matrix(r);
    Isometry3::from_parts(
        Translation3::from(*t),
        UnitQuaternion::from_rotation_matrix(&rot),
    )
}

/// Signed Sampson distance of one correspondence for `E` (module equation); `None` when the
/// denominator vanishes.
pub fn sampson_distance(e: &Matrix3<f64>, x_a: &Point2<f64>, x_b: &Point2<f64>) -> Option<f64> {
    let xa = Vector3::new(x_a.x, x_a.y, 1.0);
    let xb = Vector3::new(x_b.x, x_b.y, 1.0);
    let la = e * xb;
    let lb = e.transpose() * xa;
    let d2 = la.x * la.x + la.y * la.y + lb.x * lb.x + lb.y * lb.y;
    (d2 > 0.0).then(|| xa.dot(&la) / d2.sqrt())
}

/// Orthonormal basis of the plane orthogonal to the unit vector `t`.
pub(crate) fn tangent_basis(t: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let a = if t.x.abs() <= t.y.abs() && t.x.abs() <= t.z.abs() {
        Vector3::x()
    } else if t.y.abs() <= t.z.abs() {
        Vector3::y()
    } else {
        Vector3::z()
    };
    let b1 = t.cross(&a).normalize();
    let b2 = t.cross(&b1);
    (b1, b2)
}

/// `E = [t]x R` and its derivatives with respect to the 5 local parameters `(w, d)` of
/// [`refine_essential`] (module equations).
fn essential_and_derivatives(
    r: &Matrix3<f64>,
    t: &Vector3<f64>,
) -> (Matrix3<f64>, [Matrix3<f64>; 5]) {
    let tx = skew(t);
    let (b1, b2) = tangent_basis(t);
    (
        tx * r,
        [
            tx * skew(&Vector3::x()) * r,
            tx * skew(&Vector3::y()) * r,
            tx * skew(&Vector3::z()) * r,
            skew(&b1) * r,
            skew(&b2) * r,
        ],
    )
}

/// Signed Sampson distance of one pair and its gradient with respect to `(w, d)`, given `E`
/// and `dE` from [`essential_and_derivatives`]; `None` when the denominator vanishes.
fn sampson_with_gradient(
    e: &Matrix3<f64>,
    de: &[Matrix3<f64>; 5],
    x_a: &Point2<f64>,
    x_b: &Point2<f64>,
) -> Option<(f64, SVector<f64, 5>)> {
    let xa = Vector3::new(x_a.x, x_a.y, 1.0);
    let xb = Vector3::new(x_b.x, x_b.y, 1.0);
    let la = e * xb;
    let lb = e.transpose() * xa;
    let d2 = la.x * la.x + la.y * la.y + lb.x * lb.x + lb.y * lb.y;
    if d2.is_nan() || d2 <= 0.0 {
        return None;
    }
    let d = d2.sqrt();
    let n = xa.dot(&la);
    // d(d2)/dE_mk = 2 [m<2] la_m xb_k + 2 [k<2] lb_k xa_m.
    let mut dd2 = Matrix3::zeros();
    for m in 0..3 {
        for k in 0..3 {
            let mut v = 0.0;
            if m < 2 {
                v += 2.0 * la[m] * xb[k];
            }
            if k < 2 {
                v += 2.0 * lb[k] * xa[m];
            }
            dd2[(m, k)] = v;
        }
    }
    let grad_e = xa * xb.transpose() / d - dd2 * (n / (2.0 * d2 * d));
    let grad = SVector::<f64, 5>::from_fn(|k, _| {
        de.get(k).map_or(0.0, |dek| grad_e.component_mul(dek).sum())
    });
    Some((n / d, grad))
}

/// Refines `a_from_b` (rotation and translation direction) on normalised correspondences by
/// minimising the sum of squared Sampson distances on `SO(3) x S^2` (module equations). The
/// returned translation has unit norm.
///
/// # Errors
/// [`RelPoseError::LengthMismatch`], [`RelPoseError::TooFewCorrespondences`] (< 5),
/// [`RelPoseError::NonFinite`], [`RelPoseError::Degenerate`] (zero initial translation).
pub fn refine_essential(
    x_a: &[Point2<f64>],
    x_b: &[Point2<f64>],
    a_from_b: &Isometry3<f64>,
    params: &RefineParams,
) -> Result<RefineReport, RelPoseError> {
    check_lengths(x_a.len(), x_b.len(), 5)?;
    for (i, (pa, pb)) in x_a.iter().zip(x_b).enumerate() {
        if !(pa
            .coords
            .iter()
            .chain(pb.coords.iter())
            .all(|c| c.is_finite()))
        {
            return Err(RelPoseError::NonFinite { index: i });
        }
    }
    let t0 = a_from_b.translation.vector;
    let t_norm = t0.norm();
    if !(t_norm > 0.0 && t_norm.is_finite()) {
        return Err(RelPoseError::Degenerate {
            reason: format!("initial translation norm {t_norm:.3e}: direction undefined"),
        });
    }
    let x0 = (
        a_from_b.rotation.to_rotation_matrix().into_inner(),
        t0 / t_norm,
    );
    let cost_at = |x: &(Matrix3<f64>, Vector3<f64>), _: &()| -> f64 {
        let e = skew(&x.1) * x.0;
        x_a.iter()
            .zip(x_b)
            .map(|(a, b)| sampson_distance(&e, a, b).map_or(0.0, |d| d * d))
            .sum()
    };
    let linearise = |x: &(Matrix3<f64>, Vector3<f64>)| {
        let (e, de) = essential_and_derivatives(&x.0, &x.1);
        let mut h = SMatrix::<f64, 5, 5>::zeros();
        let mut g = SVector::<f64, 5>::zeros();
        let mut cost = 0.0;
        for (pa, pb) in x_a.iter().zip(x_b) {
            let Some((res, j)) = sampson_with_gradient(&e, &de, pa, pb) else {
                continue;
            };
            h += j * j.transpose();
            g += j * res;
            cost += res * res;
        }
        (cost, h, g, ())
    };
    let retract = |x: &(Matrix3<f64>, Vector3<f64>), d: &SVector<f64, 5>| {
        let dr = Rotation3::new(Vector3::new(d[0], d[1], d[2])).into_inner();
        let (b1, b2) = tangent_basis(&x.1);
        let t = (x.1 + b1 * d[3] + b2 * d[4]).normalize();
        (dr * x.0, t)
    };
    let lm = levenberg_marquardt(x0, params, linearise, cost_at, retract, x_a.len());
    Ok(report(lm, 2))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The analytic Sampson Jacobian of `refine_essential` agrees with central differences.
    #[test]
    fn sampson_gradient_matches_finite_differences() {
        let r = Rotation3::new(Vector3::new(0.1, -0.2, 0.3)).into_inner();
        let t = Vector3::new(0.3, -0.5, 0.8).normalize();
        let xa = Point2::new(0.11, -0.07);
        let xb = Point2::new(0.02, 0.13);
        let e_of = |r: &Matrix3<f64>, t: &Vector3<f64>| skew(t) * r;
        let f = |w: Vector3<f64>, d: [f64; 2]| {
            let (b1, b2) = tangent_basis(&t);
            let rr = Rotation3::new(w).into_inner() * r;
            let tt = (t + b1 * d[0] + b2 * d[1]).normalize();
            sampson_distance(&e_of(&rr, &tt), &xa, &xb).unwrap_or(f64::NAN)
        };
        let pts_a = [xa];
        let pts_b = [xb];
        let h = 1e-6;
        let numeric = [
            (f(Vector3::new(h, 0.0, 0.0), [0.0; 2]) - f(Vector3::new(-h, 0.0, 0.0), [0.0; 2]))
                / (2.0 * h),
            (f(Vector3::new(0.0, h, 0.0), [0.0; 2]) - f(Vector3::new(0.0, -h, 0.0), [0.0; 2]))
                / (2.0 * h),
            (f(Vector3::new(0.0, 0.0, h), [0.0; 2]) - f(Vector3::new(0.0, 0.0, -h), [0.0; 2]))
                / (2.0 * h),
            (f(Vector3::zeros(), [h, 0.0]) - f(Vector3::zeros(), [-h, 0.0])) / (2.0 * h),
            (f(Vector3::zeros(), [0.0, h]) - f(Vector3::zeros(), [0.0, -h])) / (2.0 * h),
        ];
        let (e, de) = essential_and_derivatives(&r, &t);
        let (res, g) = sampson_with_gradient(&e, &de, &pts_a[0], &pts_b[0]).expect("gradient");
        assert!((res - f(Vector3::zeros(), [0.0; 2])).abs() < 1e-15);
        for k in 0..5 {
            assert!(
                (g[k] - numeric[k]).abs() < 1e-7,
                "component {k}: {} vs {}",
                g[k],
                numeric[k]
            );
        }
        assert_eq!(pts_a.len(), pts_b.len());
    }

    #[test]
    fn depth_noise_grows_with_z_squared_along_the_ray() {
        let m = DepthNoiseModel::default();
        assert!((m.sigma_depth_m(0.5) - 1e-4).abs() < 1e-18);
        assert!((m.sigma_depth_m(1.0) - 4e-4).abs() < 1e-18);
        let p = Point3::new(0.1, -0.05, 0.5);
        let c = m.covariance(&p);
        let ray = p.coords / p.z;
        // Depth noise moves the point along its ray: the z-variance is exactly sigma_z^2.
        assert!((c[(2, 2)] - m.sigma_depth_m(0.5).powi(2)).abs() < 1e-20);
        assert!((c * Vector3::z()).dot(&ray) > 0.0);
    }
}
