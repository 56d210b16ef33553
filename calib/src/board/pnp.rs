//! Pose of a planar target from its projections (planar PnP).
//!
//! 1. **Undistort** the pixels to normalised coordinates `x_i` with the camera's `plumb_bob`
//!    model ([`CameraModel::undistort_pixel`]).
//! 2. **Homography** `x_i ~ H (X_i, Y_i, 1)^T` by the normalised DLT (Hartley & Zisserman
//!    2004, alg. 4.2): both point sets are translated to their centroid and scaled to a mean
//!    distance of `sqrt(2)`, `h` is the eigenvector of the smallest eigenvalue of `A^T A`.
//! 3. **Pose from the homography** (Zhang 2000, sec. 3.1 and app. C): with
//!    `H = [h1 h2 h3] = lambda [r1 r2 t]`, `lambda = 2 / (|h1| + |h2|)` with the sign giving
//!    `t_z > 0`, `R_0 = [lambda h1, lambda h2, lambda^2 h1 x h2]` projected onto SO(3) by SVD.
//! 4. **Levenberg-Marquardt** on the pixel reprojection error
//!    `sum_i |pi(R X_i + t) - u_i|^2` through the distorted projection `pi`
//!    ([`CameraModel::project`]), with the left-multiplicative update
//!    `R <- exp([w]x) R`, `t <- t + dt` and a central-difference Jacobian.
//!
//! The reported RMS is `sqrt(mean_i |pi(R X_i + t) - u_i|^2)` (per point, as OpenCV's
//! `calibrateCamera` reports it).

use nalgebra::{
    Isometry3, Matrix3, Point2, Point3, Rotation3, SMatrix, SVector, Translation3, UnitQuaternion,
    Vector2, Vector3,
};

use super::{BoardError, MIN_POINTS};
use crate::relpose::CameraModel;

/// Parameters of [`solve_planar_pnp`]. Every default is documented on its field.
#[derive(Debug, Clone, PartialEq)]
pub struct PnpParams {
    /// Maximum Levenberg-Marquardt iterations. Default 50.
    pub max_iterations: usize,
    /// Stop when the parameter step is below this (radians / metres). Default 1e-12.
    pub step_tolerance: f64,
    /// Stop when the relative cost decrease is below this. Default 1e-15.
    pub cost_tolerance: f64,
}

impl Default for PnpParams {
    fn default() -> Self {
        Self {
            max_iterations: 50,
            step_tolerance: 1e-12,
            cost_tolerance: 1e-15,
        }
    }
}

/// Result of [`solve_planar_pnp`].
#[derive(Debug, Clone, PartialEq)]
pub struct PnpSolution {
    /// The board (world) frame in camera coordinates.
    pub camera_from_board: Isometry3<f64>,
    /// The homography initialisation, before refinement.
    pub initial_camera_from_board: Isometry3<f64>,
    /// Reprojection RMS, pixels (module docs).
    pub rms_px: f64,
    /// Largest reprojection error, pixels.
    pub max_error_px: f64,
    /// Per-point reprojection errors `pi(R X_i + t) - u_i`, pixels.
    pub residuals_px: Vec<Vector2<f64>>,
    /// Levenberg-Marquardt iterations run.
    pub iterations: usize,
}

/// Normalising similarity of a 2-D point set (centroid to the origin, mean distance
/// `sqrt(2)`).
fn normaliser(pts: &[Vector2<f64>]) -> Result<Matrix3<f64>, BoardError> {
    let n = pts.len() as f64;
    let c = pts.iter().sum::<Vector2<f64>>() / n;
    let mean_dist = pts.iter().map(|p| (p - c).norm()).sum::<f64>() / n;
    if !(mean_dist.is_finite() && mean_dist > 1e-12) {
        return Err(BoardError::Degenerate {
            what: "all points coincide",
        });
    }
    let s = std::f64::consts::SQRT_2 / mean_dist;
    Ok(Matrix3::new(
        s,
        0.0,
        -s * c.x,
        0.0,
        s,
        -s * c.y,
        0.0,
        0.0,
        1.0,
    ))
}

/// Homography `dst ~ H src` by the normalised DLT (module step 2), scaled to `|H|_F = 1`.
///
/// # Errors
/// [`BoardError::LengthMismatch`], [`BoardError::TooFewPoints`] (< 4),
/// [`BoardError::Degenerate`] for coincident, collinear or non-finite points.
pub fn homography_dlt(
    src: &[Point2<f64>],
    dst: &[Point2<f64>],
) -> Result<Matrix3<f64>, BoardError> {
    if src.len() != dst.len() {
        return Err(BoardError::LengthMismatch {
            object: src.len(),
            image: dst.len(),
        });
    }
    if src.len() < MIN_POINTS {
        return Err(BoardError::TooFewPoints {
            got: src.len(),
            need: MIN_POINTS,
        });
    }
    if !src
        .iter()
        .chain(dst)
        .all(|p| p.x.is_finite() && p.y.is_finite())
    {
        return Err(BoardError::Degenerate {
            what: "non-finite point",
        });
    }
    let s: Vec<Vector2<f64>> = src.iter().map(|p| p.coords).collect();
    let d: Vec<Vector2<f64>> = dst.iter().map(|p| p.coords).collect();
    let ts = normaliser(&s)?;
    let td = normaliser(&d)?;
    let mut ata = SMatrix::<f64, 9, 9>::zeros();
    for (a, b) in s.iter().zip(&d) {
        let pa = ts * a.push(1.0);
        let pb = td * b.push(1.0);
        let (x, y) = (pa.x, pa.y);
        let (u, v) = (pb.x, pb.y);
        let r1 =
            SVector::<f64, 9>::from_column_slice(&[-x, -y, -1.0, 0.0, 0.0, 0.0, u * x, u * y, u]);
        let r2 =
            SVector::<f64, 9>::from_column_slice(&[0.0, 0.0, 0.0, -x, -y, -1.0, v * x, v * y, v]);
        ata += r1 * r1.transpose() + r2 * r2.transpose();
    }
    let eig = ata.symmetric_eigen();
    let (mut imin, mut emin) = (0, f64::INFINITY);
    let mut sorted: Vec<f64> = eig.eigenvalues.iter().copied().collect();
    for (i, &e) in eig.eigenvalues.iter().enumerate() {
        if e < emin {
            emin = e;
            imin = i;
        }
    }
    sorted.sort_by(f64::total_cmp);
    // A unique homography needs a one-dimensional null space: the second-smallest eigenvalue
    // must stand clear of the smallest (collinear points leave a larger null space).
    if sorted
        .get(1)
        .is_none_or(|&e2| e2 <= 1e-10 * sorted.last().copied().unwrap_or(1.0))
    {
        return Err(BoardError::Degenerate {
            what: "collinear points: the homography is not unique",
        });
    }
    let h = eig.eigenvectors.column(imin);
    let hn = Matrix3::new(h[0], h[1], h[2], h[3], h[4], h[5], h[6], h[7], h[8]);
    let Some(td_inv) = td.try_inverse() else {
        return Err(BoardError::Degenerate {
            what: "singular normalisation",
        });
    };
    let hm = td_inv * hn * ts;
    let norm = hm.norm();
    if !(norm.is_finite() && norm > 0.0) {
        return Err(BoardError::Degenerate {
            what: "zero homography",
        });
    }
    Ok(hm / norm)
}

/// Nearest rotation (Frobenius) to a 3x3 matrix, `U diag(1, 1, det(U V^T)) V^T`.
fn nearest_rotation(m: &Matrix3<f64>) -> Option<Rotation3<f64>> {
    let svd = m.svd(true, true);
    let (u, v_t) = (svd.u?, svd.v_t?);
    let d = (u * v_t).determinant().signum();
    let r = u * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * v_t;
    Some(Rotation3::from_matrix_unchecked(r))
}

/// Pose `camera_from_board` from a homography mapping board `(X, Y, 1)` to normalised image
/// coordinates (module step 3).
///
/// # Errors
/// [`BoardError::Degenerate`] for a homography with a zero column or a failed SVD.
pub fn pose_from_homography(h: &Matrix3<f64>) -> Result<Isometry3<f64>, BoardError> {
    let h1: Vector3<f64> = h.column(0).into_owned();
    let h2: Vector3<f64> = h.column(1).into_owned();
    let h3: Vector3<f64> = h.column(2).into_owned();
    let denom = h1.norm() + h2.norm();
    if !(denom.is_finite() && denom > 1e-15) {
        return Err(BoardError::Degenerate {
            what: "homography with zero columns",
        });
    }
    let mut lambda = 2.0 / denom;
    if h3.z * lambda < 0.0 {
        lambda = -lambda;
    }
    let r1 = h1 * lambda;
    let r2 = h2 * lambda;
    let r3 = r1.cross(&r2);
    let m = Matrix3::from_columns(&[r1, r2, r3]);
    let Some(r) = nearest_rotation(&m) else {
        return Err(BoardError::Degenerate {
            what: "SVD of the homography rotation failed",
        });
    };
    let t = h3 * lambda;
    Ok(Isometry3::from_parts(
        Translation3::from(t),
        UnitQuaternion::from_rotation_matrix(&r),
    ))
}

/// Reprojection residuals (pixels), or the index and depth of a point behind the camera.
fn residuals(
    camera: &CameraModel,
    pose: &Isometry3<f64>,
    object: &[Point3<f64>],
    image_px: &[Point2<f64>],
) -> Result<Vec<Vector2<f64>>, BoardError> {
    object
        .iter()
        .zip(image_px)
        .enumerate()
        .map(|(index, (x, u))| {
            let pc = pose * x;
            match camera.project(&pc) {
                Some(p) => Ok(p - u),
                None => Err(BoardError::BehindCamera { index, z_m: pc.z }),
            }
        })
        .collect()
}

/// Applies the 6-vector update `(w, dt)` (module step 4).
fn apply(pose: &Isometry3<f64>, delta: &SVector<f64, 6>) -> Isometry3<f64> {
    let w = Vector3::new(delta[0], delta[1], delta[2]);
    let dt = Vector3::new(delta[3], delta[4], delta[5]);
    let rot = UnitQuaternion::from_scaled_axis(w) * pose.rotation;
    Isometry3::from_parts(
        Translation3::from(pose.translation.vector + dt),
        UnitQuaternion::new_normalize(rot.into_inner()),
    )
}

fn cost(r: &[Vector2<f64>]) -> f64 {
    r.iter().map(Vector2::norm_squared).sum()
}

/// Planar PnP: the pose of a board (points with `Z = 0` in the board frame) from its distorted
/// pixel projections (module steps 1-4).
///
/// # Errors
/// [`BoardError::LengthMismatch`], [`BoardError::TooFewPoints`], [`BoardError::Degenerate`]
/// (points not planar at `Z = 0`, collinear, non-finite), [`BoardError::Undistort`] for a
/// pixel outside the camera model's domain, [`BoardError::BehindCamera`] when the
/// initialisation puts a point behind the camera.
pub fn solve_planar_pnp(
    object: &[Point3<f64>],
    image_px: &[Point2<f64>],
    camera: &CameraModel,
    params: &PnpParams,
) -> Result<PnpSolution, BoardError> {
    if object.len() != image_px.len() {
        return Err(BoardError::LengthMismatch {
            object: object.len(),
            image: image_px.len(),
        });
    }
    if object.len() < MIN_POINTS {
        return Err(BoardError::TooFewPoints {
            got: object.len(),
            need: MIN_POINTS,
        });
    }
    if object
        .iter()
        .any(|p| p.z.abs() > 1e-12 || !p.coords.iter().all(|c| c.is_finite()))
    {
        return Err(BoardError::Degenerate {
            what: "board points must be finite with Z = 0",
        });
    }
    let normalised = image_px
        .iter()
        .enumerate()
        .map(|(index, u)| {
            camera
                .undistort_pixel(u)
                .map_err(|_| BoardError::Undistort {
                    index,
                    u: u.x,
                    v: u.y,
                })
        })
        .collect::<Result<Vec<_>, _>>()?;
    let board_xy: Vec<Point2<f64>> = object.iter().map(|p| Point2::new(p.x, p.y)).collect();
    let h = homography_dlt(&board_xy, &normalised)?;
    let initial = pose_from_homography(&h)?;
    let mut pose = initial;
    let mut r = residuals(camera, &pose, object, image_px)?;
    let mut c = cost(&r);
    let mut lambda = 1e-3;
    let mut iterations = 0;
    let n = r.len();
    while iterations < params.max_iterations {
        iterations += 1;
        // Central-difference Jacobian of the 2n residuals with respect to (w, dt).
        let mut jtj = SMatrix::<f64, 6, 6>::zeros();
        let mut jtr = SVector::<f64, 6>::zeros();
        let mut jac = vec![SMatrix::<f64, 2, 6>::zeros(); n];
        let scale_t = pose.translation.vector.norm().max(1e-3);
        for k in 0..6 {
            let step = if k < 3 { 1e-7 } else { 1e-7 * scale_t };
            let mut d = SVector::<f64, 6>::zeros();
            d[k] = step;
            let rp = residuals(camera, &apply(&pose, &d), object, image_px)?;
            let rm = residuals(camera, &apply(&pose, &(-d)), object, image_px)?;
            for ((j, a), b) in jac.iter_mut().zip(&rp).zip(&rm) {
                let col = (a - b) / (2.0 * step);
                j[(0, k)] = col.x;
                j[(1, k)] = col.y;
            }
        }
        for (j, ri) in jac.iter().zip(&r) {
            jtj += j.transpose() * j;
            jtr += j.transpose() * ri;
        }
        let mut improved = false;
        let mut small_step = false;
        for _ in 0..10 {
            let mut a = jtj;
            for i in 0..6 {
                a[(i, i)] += lambda * jtj[(i, i)].max(1e-12);
            }
            let Some(delta) = a.cholesky().map(|ch| ch.solve(&(-jtr))) else {
                lambda *= 10.0;
                continue;
            };
            let candidate = apply(&pose, &delta);
            let Ok(rc) = residuals(camera, &candidate, object, image_px) else {
                lambda *= 10.0;
                continue;
            };
            let cc = cost(&rc);
            if cc <= c {
                let rel = (c - cc) / c.max(1e-300);
                small_step = delta.norm() < params.step_tolerance || rel < params.cost_tolerance;
                pose = candidate;
                r = rc;
                c = cc;
                lambda = (lambda * 0.1).max(1e-12);
                improved = true;
                break;
            }
            lambda *= 10.0;
        }
        if !improved || small_step {
            break;
        }
    }
    let rms_px = (c / n as f64).sqrt();
    let max_error_px = r.iter().map(Vector2::norm).fold(0.0, f64::max);
    Ok(PnpSolution {
        camera_from_board: pose,
        initial_camera_from_board: initial,
        rms_px,
        max_error_px,
        residuals_px: r,
        iterations,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::board::BoardSpec;

    fn camera() -> CameraModel {
        CameraModel {
            k1: 0.18436,
            k2: -0.32515,
            ..CameraModel::pinhole(3264, 1836, 2439.5, 2439.5, 1615.6, 867.0)
        }
    }

    fn truth() -> Isometry3<f64> {
        Isometry3::from_parts(
            Translation3::new(0.03, -0.02, 0.55),
            UnitQuaternion::from_scaled_axis(Vector3::new(0.3, -0.4, 0.2)),
        )
    }

    #[test]
    fn recovers_an_exact_pose_with_distortion() {
        let board = BoardSpec::new(6, 8, 0.0283).expect("board");
        let obj = board.object_points();
        let cam = camera();
        let px: Vec<Point2<f64>> = obj
            .iter()
            .map(|p| cam.project(&(truth() * p)).expect("in front"))
            .collect();
        let sol = solve_planar_pnp(&obj, &px, &cam, &PnpParams::default()).expect("pnp");
        let d = sol.camera_from_board.inverse() * truth();
        assert!(d.rotation.angle() < 1e-9, "{}", d.rotation.angle());
        assert!(d.translation.vector.norm() < 1e-9);
        assert!(sol.rms_px < 1e-6);
    }

    #[test]
    fn homography_maps_points() {
        let h = Matrix3::new(1.2, 0.1, 3.0, -0.2, 0.9, 1.0, 0.01, 0.02, 1.0);
        let src: Vec<Point2<f64>> = (0..12)
            .map(|i| Point2::new(f64::from(i % 4), f64::from(i / 4)))
            .collect();
        let dst: Vec<Point2<f64>> = src
            .iter()
            .map(|p| {
                let q = h * p.coords.push(1.0);
                Point2::new(q.x / q.z, q.y / q.z)
            })
            .collect();
        let e = homography_dlt(&src, &dst).expect("dlt");
        let e = e / e[(2, 2)];
        assert!((e - h).norm() < 1e-9, "{e}");
    }

    #[test]
    fn collinear_points_are_refused() {
        let src: Vec<Point2<f64>> = (0..6).map(|i| Point2::new(f64::from(i), 0.0)).collect();
        let dst = src.clone();
        assert!(matches!(
            homography_dlt(&src, &dst),
            Err(BoardError::Degenerate { .. })
        ));
    }

    #[test]
    fn mismatched_lengths_are_refused() {
        let obj = vec![Point3::origin(); 5];
        let px = vec![Point2::origin(); 4];
        assert!(matches!(
            solve_planar_pnp(&obj, &px, &camera(), &PnpParams::default()),
            Err(BoardError::LengthMismatch {
                object: 5,
                image: 4
            })
        ));
    }
}
