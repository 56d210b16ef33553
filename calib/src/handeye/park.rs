//! Park & Martin (1994), "Robot sensor calibration: solving AX = XB on the Euclidean group",
//! IEEE Trans. Robotics and Automation 10(5):717-721.
//!
//! With `alpha = log R_B` (hand) and `beta = log R_A` (eye), `R_B R_X = R_X R_A` gives
//! `alpha = R_X beta`. The least-squares rotation is (eq. 13-14)
//!
//! ```text
//! M = sum_k w_k beta_k alpha_k^T,    R_X = (M^T M)^(-1/2) M^T
//! ```
//!
//! computed here as `V diag(1, 1, det(V U^T)) U^T` from `M = U S V^T`, which is the same
//! matrix when `M` has full rank and `det M > 0`, and stays a proper rotation when it has
//! rank 2 (two motions, where eq. 14 is singular). The translation follows by eq. 15
//! ([`super::translation`]).

use nalgebra::Matrix3;

use super::geometry::{rot, rotation_log};
use super::{HandEyeError, Method, RelativeMotion};

/// `R_X` by Park & Martin eq. 13-14 (module docs).
///
/// # Errors
///
/// [`HandEyeError::NumericalFailure`] when the SVD fails.
pub fn rotation(motions: &[RelativeMotion]) -> Result<Matrix3<f64>, HandEyeError> {
    let mut m = Matrix3::zeros();
    for motion in motions {
        let alpha = rotation_log(&rot(&motion.b));
        let beta = rotation_log(&rot(&motion.a));
        m += motion.weight * beta * alpha.transpose();
    }
    let failure = HandEyeError::NumericalFailure {
        method: Method::Park,
        what: "SVD of M",
    };
    let svd = m.svd(true, true);
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
        return Err(failure);
    };
    let v = v_t.transpose();
    let mut d = Matrix3::identity();
    if (v * u.transpose()).determinant() < 0.0 {
        d[(2, 2)] = -1.0;
    }
    let r = v * d * u.transpose();
    if r.iter().all(|x| x.is_finite()) {
        Ok(r)
    } else {
        Err(failure)
    }
}
