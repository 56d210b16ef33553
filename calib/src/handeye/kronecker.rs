//! The paper's linear solution: Kronecker form of `A X_p = X_p B`, solved by SVD
//! (ARCHITECTURE.md section 6).
//!
//! The paper writes the unknown as **`X_p = camera_from_tool0 = X^-1`**, with `A` the camera
//! motion and `B` the hand motion of a pair (`A X_p = X_p B` is `B X = X A` multiplied by
//! `X^-1` on both sides). With the paper's row-major `vec_r` (for which
//! `vec_r(P Y Q) = (P (x) Q^T) vec_r(Y)`; nalgebra's column-major `vec` instead obeys
//! `vec(P Y Q) = (Q^T (x) P) vec(Y)`, and `vec_r(Y) = vec(Y^T)`):
//!
//! ```text
//! R_p = R_A R_p R_B^T                   =>  (I9 - R_A (x) R_B) vec_r(R_p) = 0
//! R_p t_B + (I3 - R_A) t_p = t_A        =>  multiplied by [t_A]x, which cancels t_A's scale:
//!                                           ([t_A]x (x) t_B^T) vec_r(R_p) + [t_A]x (I3 - R_A) t_p = 0
//!
//! [ I9 - R_A (x) R_B      0                 ] [vec_r R_p]
//! [ [t_A]x (x) t_B^T      [t_A]x (I3 - R_A) ] [   t_p   ] = 0        (12 rows per pair)
//! ```
//!
//! stacked over all pairs (rows weighted by `sqrt(weight)`; the translation rows divided by
//! `mean|t_A| mean|t_B|` so that both blocks are dimensionless whatever the eye's unit) and
//! solved by SVD: the right singular vector of the smallest singular value. Its first nine
//! entries are `vec_r(R_p)` up to an unknown factor and sign; dividing by
//! `cbrt(det)` fixes both, and the nearest rotation with determinant +1 (Umeyama) removes
//! the noise. The translation is then recovered by linear least squares over all pairs from
//! `R_p t_B + (I3 - R_A) t_p = s t_A` (unknowns `t_p`, and `s` when scale-free, else
//! `s = 1`), and the result is returned as `X = X_p^-1`.

use nalgebra::{DMatrix, DVector, Isometry3, Matrix3, SMatrix, Vector3};

use super::geometry::smallest_right_singular_vectors;
use super::geometry::{isometry, least_squares, nearest_rotation, rot, skew};
use super::{HandEyeError, Method, RelativeMotion};

/// The 12 x 12 block of one pair (unweighted, translation rows scaled by `t_scale`).
fn pair_block(m: &RelativeMotion, t_scale: f64) -> SMatrix<f64, 12, 12> {
    let r_a = rot(&m.a);
    let r_b = rot(&m.b);
    let t_a = m.a.translation.vector;
    let t_b = m.b.translation.vector;
    let mut block = SMatrix::<f64, 12, 12>::zeros();
    let top = SMatrix::<f64, 9, 9>::identity() - r_a.kronecker(&r_b);
    block.fixed_view_mut::<9, 9>(0, 0).copy_from(&top);
    let ta_x = skew(&t_a);
    let bottom_left: SMatrix<f64, 3, 9> = ta_x.kronecker(&t_b.transpose());
    block
        .fixed_view_mut::<3, 9>(9, 0)
        .copy_from(&(bottom_left / t_scale));
    block
        .fixed_view_mut::<3, 3>(9, 9)
        .copy_from(&(ta_x * (Matrix3::identity() - r_a) / t_scale));
    block
}

/// `R_p = camera_from_tool0` rotation from the SVD of the stacked system (module docs).
///
/// # Errors
///
/// [`HandEyeError::NumericalFailure`] when the SVD fails or the null vector's rotation block
/// is singular.
pub fn rotation_camera_from_tool0(
    motions: &[RelativeMotion],
) -> Result<Matrix3<f64>, HandEyeError> {
    let failure = |what| HandEyeError::NumericalFailure {
        method: Method::Kronecker,
        what,
    };
    let n = motions.len().max(1) as f64;
    let mean_ta = motions
        .iter()
        .map(|m| m.a.translation.vector.norm())
        .sum::<f64>()
        / n;
    let mean_tb = motions
        .iter()
        .map(|m| m.b.translation.vector.norm())
        .sum::<f64>()
        / n;
    let t_scale = if mean_ta * mean_tb > 1e-300 {
        mean_ta * mean_tb
    } else {
        1.0
    };
    let mut a = DMatrix::zeros(12 * motions.len(), 12);
    for (k, m) in motions.iter().enumerate() {
        let block = pair_block(m, t_scale) * m.weight.sqrt();
        a.view_mut((12 * k, 0), (12, 12)).copy_from(&block);
    }
    let (vectors, _) = smallest_right_singular_vectors(a, 1).ok_or(failure("SVD"))?;
    let v = vectors.first().ok_or(failure("SVD"))?;
    let r = Matrix3::from_fn(|row, col| v[3 * row + col]);
    let det = r.determinant();
    let c = det.cbrt();
    if !c.is_finite() || c.abs() <= 1e-8 {
        return Err(failure("null vector has a singular rotation block"));
    }
    nearest_rotation(&(r / c)).ok_or(failure("projection onto SO(3)"))
}

/// `X = tool0_from_camera` and the eye scale (1 unless `scale_free`) by the Kronecker/SVD
/// form (module docs).
///
/// # Errors
///
/// [`HandEyeError::NumericalFailure`] when a linear solve fails.
pub fn solve(
    motions: &[RelativeMotion],
    scale_free: bool,
) -> Result<(Isometry3<f64>, f64), HandEyeError> {
    let r_p = rotation_camera_from_tool0(motions)?;
    // Translation: R_p t_B + (I - R_A) t_p = s t_A, least squares over all pairs.
    let cols = if scale_free { 4 } else { 3 };
    let mut a = DMatrix::zeros(3 * motions.len(), cols);
    let mut b = DVector::zeros(3 * motions.len());
    for (k, m) in motions.iter().enumerate() {
        let w = m.weight.sqrt();
        let t_a = m.a.translation.vector;
        let rp_tb = r_p * m.b.translation.vector;
        a.view_mut((3 * k, 0), (3, 3))
            .copy_from(&(w * (Matrix3::identity() - rot(&m.a))));
        if scale_free {
            a.view_mut((3 * k, 3), (3, 1)).copy_from(&(-w * t_a));
            b.rows_mut(3 * k, 3).copy_from(&(-w * rp_tb));
        } else {
            b.rows_mut(3 * k, 3).copy_from(&(w * (t_a - rp_tb)));
        }
    }
    let x = least_squares(a, &b).ok_or(HandEyeError::NumericalFailure {
        method: Method::Kronecker,
        what: "translation least squares",
    })?;
    let t_p = Vector3::new(x[0], x[1], x[2]);
    let scale = if scale_free { x[3] } else { 1.0 };
    // X = X_p^-1.
    let r_x = r_p.transpose();
    Ok((isometry(&r_x, &(-(r_x * t_p))), scale))
}
