//! Andreff, Horaud & Espiau (1999), "On-line hand-eye calibration", 3DIM'99, pp. 430-436.
//!
//! The rotation and translation equations are stacked into one linear system in the 12
//! unknowns `(vec R_X, t_X)` (eq. 10, written here with the row-major `vec_r`, for which
//! `vec_r(P Y Q) = (P (x) Q^T) vec_r(Y)`):
//!
//! ```text
//! R_X = R_B R_X R_A^T          =>  (I9 - R_B (x) R_A) vec_r(R_X)           = 0
//! R_B t_X + t_B = R_X t_A + t_X =>  (I3 (x) t_A^T) vec_r(R_X) + (I3 - R_B) t_X = t_B
//! ```
//!
//! solved by linear least squares over all motions (the right-hand side `t_B` fixes the
//! scale). The 3x3 block is not exactly a rotation with noise: it is scaled to determinant
//! +1 and projected onto SO(3) (eq. 15, the orthogonal Procrustes projection); `t_X` is the
//! system's own estimate. Needs a metric eye (no unknown scale).

use nalgebra::{DMatrix, DVector, Matrix3, SMatrix, Vector3};

use super::geometry::{isometry, least_squares, nearest_rotation, rot};
use super::{HandEyeError, Method, RelativeMotion};

/// X by Andreff et al. eq. 10 and 15 (module docs).
///
/// # Errors
///
/// [`HandEyeError::NumericalFailure`] when the solve fails or the rotation block is singular.
pub fn solve(motions: &[RelativeMotion]) -> Result<nalgebra::Isometry3<f64>, HandEyeError> {
    let mut a = DMatrix::zeros(12 * motions.len(), 12);
    let mut b = DVector::zeros(12 * motions.len());
    let i3 = Matrix3::<f64>::identity();
    for (k, m) in motions.iter().enumerate() {
        let w = m.weight.sqrt();
        let r_b = rot(&m.b);
        let r_a = rot(&m.a);
        let t_a = m.a.translation.vector;
        let top: SMatrix<f64, 9, 9> = SMatrix::<f64, 9, 9>::identity() - r_b.kronecker(&r_a);
        let bottom_left: SMatrix<f64, 3, 9> = i3.kronecker(&t_a.transpose());
        a.view_mut((12 * k, 0), (9, 9)).copy_from(&(w * top));
        a.view_mut((12 * k + 9, 0), (3, 9))
            .copy_from(&(w * bottom_left));
        a.view_mut((12 * k + 9, 9), (3, 3))
            .copy_from(&(w * (i3 - r_b)));
        b.rows_mut(12 * k + 9, 3)
            .copy_from(&(w * m.b.translation.vector));
    }
    let failure = |what| HandEyeError::NumericalFailure {
        method: Method::Andreff,
        what,
    };
    let x = least_squares(a, &b).ok_or(failure("least squares (eq. 10)"))?;
    let mut r = Matrix3::from_fn(|row, col| x[3 * row + col]);
    let det = r.determinant();
    if det.is_nan() || det.abs() < f64::from(f32::EPSILON) {
        return Err(failure("rotation block is singular"));
    }
    if det < 0.0 {
        r = -r;
    }
    let r = nearest_rotation(&r).ok_or(failure("projection onto SO(3) (eq. 15)"))?;
    let t = Vector3::new(x[9], x[10], x[11]);
    Ok(isometry(&r, &t))
}
