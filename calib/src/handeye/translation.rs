//! Translation of X (and the eye scale) given its rotation, by linear least squares.
//!
//! The translation part of `B X = X A` is (Tsai & Lenz 1989, eq. 15; Park & Martin 1994,
//! eq. 15)
//!
//! ```text
//! (R_B - I) t_X = R_X t_A - t_B                 (metric eye)
//! (R_B - I) t_X - s R_X t_A = -t_B              (scale-free: unknowns t_X and s)
//! ```
//!
//! stacked over all motions (rows weighted by `sqrt(weight)`) and solved by SVD. `R_B - I`
//! has rank 2 (its null space is the rotation axis), so two motions with non-parallel axes
//! are needed, which [`super::degeneracy`] guarantees.

use nalgebra::{DMatrix, DVector, Matrix3, Vector3};

use super::geometry::{least_squares, rot};
use super::{HandEyeError, Method, RelativeMotion};

/// Solves for `t_X` (and `s` when `scale_free`; otherwise `s = 1`) given `R_X`.
///
/// # Errors
///
/// [`HandEyeError::NumericalFailure`] when the least-squares solve fails.
pub fn solve(
    motions: &[RelativeMotion],
    r_x: &Matrix3<f64>,
    scale_free: bool,
    method: Method,
) -> Result<(Vector3<f64>, f64), HandEyeError> {
    let cols = if scale_free { 4 } else { 3 };
    let mut a = DMatrix::zeros(3 * motions.len(), cols);
    let mut b = DVector::zeros(3 * motions.len());
    for (k, m) in motions.iter().enumerate() {
        let w = m.weight.sqrt();
        let lhs = (rot(&m.b) - Matrix3::identity()) * w;
        let rta = r_x * m.a.translation.vector;
        let tb = m.b.translation.vector;
        a.view_mut((3 * k, 0), (3, 3)).copy_from(&lhs);
        if scale_free {
            a.view_mut((3 * k, 3), (3, 1)).copy_from(&(-w * rta));
            b.rows_mut(3 * k, 3).copy_from(&(-w * tb));
        } else {
            b.rows_mut(3 * k, 3).copy_from(&(w * (rta - tb)));
        }
    }
    let x = least_squares(a, &b).ok_or(HandEyeError::NumericalFailure {
        method,
        what: "translation least squares",
    })?;
    let t = Vector3::new(x[0], x[1], x[2]);
    let s = if scale_free { x[3] } else { 1.0 };
    Ok((t, s))
}
