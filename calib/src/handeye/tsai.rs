//! Tsai & Lenz (1989), "A new technique for fully autonomous and efficient 3D robotics
//! hand/eye calibration", IEEE Trans. Robotics and Automation 5(3):345-358.
//!
//! Each rotation is written as its modified Rodrigues vector `P = 2 sin(theta / 2) n`
//! (eq. 9). For every motion, with `P_B` of the hand and `P_A` of the eye,
//!
//! ```text
//! [P_B + P_A]x P'_X = P_A - P_B           (eq. 12, least squares over all motions)
//! P_X = 2 P'_X / sqrt(1 + |P'_X|^2)       (eq. 14; P'_X = tan(theta_X / 2) n_X)
//! R_X = (1 - |P_X|^2 / 2) I + (P_X P_X^T + sqrt(4 - |P_X|^2) [P_X]x) / 2     (eq. 10)
//! ```
//!
//! then the translation by eq. 15 ([`super::translation`]). Degenerate when `theta_X = pi`
//! (`P'_X` infinite) and, like every method, with parallel rotation axes.
//!
//! Eq. 12 is ill-conditioned for motions whose rotation is small (the axis is noise) or
//! close to `pi` (`P_B + P_A` nearly vanishes for opposite-signed vectors): as in OpenCV
//! since 4.10 (fix of issue 24871), only motions with [`MIN_P_NORM`] `<= |P| <=`
//! [`MAX_P_NORM`] on both sides (about 17.2 to 116.4 deg) are used, for the rotation and the
//! translation; fewer than two such motions are refused.

use nalgebra::{DMatrix, DVector, Matrix3, Vector3};

use super::geometry::{least_squares, quaternion_of, rot, skew};
use super::{HandEyeError, Method, RelativeMotion};

/// Smallest `|P| = 2 sin(theta / 2)` used (theta ~ 17.2 deg).
pub const MIN_P_NORM: f64 = 0.3;
/// Largest `|P| = 2 sin(theta / 2)` used (theta ~ 116.4 deg).
pub const MAX_P_NORM: f64 = 1.7;

/// The motions Tsai's equations use (module docs): rotation angle within
/// [`MIN_P_NORM`]..=[`MAX_P_NORM`] (as `2 sin(theta / 2)`) for both hand and eye.
pub fn informative_motions(motions: &[RelativeMotion]) -> Vec<RelativeMotion> {
    let ok = |p: Vector3<f64>| (MIN_P_NORM..=MAX_P_NORM).contains(&p.norm());
    motions
        .iter()
        .filter(|m| ok(modified_rodrigues(&rot(&m.b))) && ok(modified_rodrigues(&rot(&m.a))))
        .copied()
        .collect()
}

/// Modified Rodrigues vector `2 sin(theta / 2) n` (the quaternion's vector part times 2,
/// with a non-negative scalar part).
fn modified_rodrigues(r: &Matrix3<f64>) -> Vector3<f64> {
    2.0 * quaternion_of(r).imag()
}

/// `R_X` by Tsai & Lenz eq. 12-14 (module docs), from motions already filtered by
/// [`informative_motions`].
///
/// # Errors
///
/// [`HandEyeError::TooFewMotions`] with fewer than two motions,
/// [`HandEyeError::NumericalFailure`] when the least-squares solve fails.
pub fn rotation(motions: &[RelativeMotion]) -> Result<Matrix3<f64>, HandEyeError> {
    if motions.len() < 2 {
        return Err(HandEyeError::TooFewMotions {
            got: motions.len(),
            need: 2,
        });
    }
    let mut a = DMatrix::zeros(3 * motions.len(), 3);
    let mut b = DVector::zeros(3 * motions.len());
    for (k, m) in motions.iter().enumerate() {
        let w = m.weight.sqrt();
        let p_b = modified_rodrigues(&rot(&m.b));
        let p_a = modified_rodrigues(&rot(&m.a));
        a.view_mut((3 * k, 0), (3, 3))
            .copy_from(&(w * skew(&(p_b + p_a))));
        b.rows_mut(3 * k, 3).copy_from(&(w * (p_a - p_b)));
    }
    let failure = HandEyeError::NumericalFailure {
        method: Method::Tsai,
        what: "rotation least squares (eq. 12)",
    };
    let x = least_squares(a, &b).ok_or(failure.clone())?;
    let p_prime = Vector3::new(x[0], x[1], x[2]);
    let p = 2.0 * p_prime / (1.0 + p_prime.norm_squared()).sqrt();
    let p2 = p.norm_squared();
    let r = (1.0 - 0.5 * p2) * Matrix3::identity()
        + 0.5 * (p * p.transpose() + (4.0 - p2).max(0.0).sqrt() * skew(&p));
    if r.iter().all(|v| v.is_finite()) {
        Ok(r)
    } else {
        Err(failure)
    }
}
