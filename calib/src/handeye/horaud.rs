//! Horaud & Dornaika (1995), "Hand-eye calibration", Int. J. Robotics Research
//! 14(3):195-210, sec. 3 (the linear quaternion solution of the rotation).
//!
//! With unit quaternions `q_B`, `q_A` (scalar part >= 0, so both sides carry the same sign)
//! the rotation equation is `q_B * q_X = q_X * q_A`, i.e. `(Q(q_B) - W(q_A)) q_X = 0` where
//! `Q(r) q = r * q` and `W(r) q = q * r` are the left/right multiplication matrices
//! (Appendix A). `q_X` minimises (eq. 31)
//!
//! ```text
//! q^T (sum_k w_k (Q(q_B) - W(q_A))^T (Q(q_B) - W(q_A))) q,   |q| = 1
//! ```
//!
//! i.e. it is the eigenvector of the smallest eigenvalue of that 4x4 matrix. The translation
//! then follows by linear least squares ([`super::translation`]).

use nalgebra::{Matrix4, Quaternion, SymmetricEigen, UnitQuaternion};

use super::geometry::{quaternion_of, rot};
use super::{HandEyeError, Method, RelativeMotion};

/// `Q(r)`: `Q(r) q = r * q`, quaternions as `(w, x, y, z)`.
fn left(r: &Quaternion<f64>) -> Matrix4<f64> {
    let (w, x, y, z) = (r.w, r.i, r.j, r.k);
    Matrix4::new(w, -x, -y, -z, x, w, -z, y, y, z, w, -x, z, -y, x, w)
}

/// `W(r)`: `W(r) q = q * r`, quaternions as `(w, x, y, z)`.
fn right(r: &Quaternion<f64>) -> Matrix4<f64> {
    let (w, x, y, z) = (r.w, r.i, r.j, r.k);
    Matrix4::new(w, -x, -y, -z, x, w, z, -y, y, -z, w, x, z, y, -x, w)
}

/// `R_X` by Horaud & Dornaika sec. 3 (module docs).
///
/// # Errors
///
/// [`HandEyeError::NumericalFailure`] when the eigenvector is not finite.
pub fn rotation(motions: &[RelativeMotion]) -> Result<nalgebra::Matrix3<f64>, HandEyeError> {
    let mut a = Matrix4::zeros();
    for m in motions {
        let d = left(&quaternion_of(&rot(&m.b))) - right(&quaternion_of(&rot(&m.a)));
        a += m.weight * d.transpose() * d;
    }
    let eig = SymmetricEigen::new(a);
    let imin = eig.eigenvalues.imin();
    let v = eig.eigenvectors.column(imin);
    let q = Quaternion::new(v[0], v[1], v[2], v[3]);
    if !q.coords.iter().all(|x| x.is_finite()) || q.norm() < 0.5 {
        return Err(HandEyeError::NumericalFailure {
            method: Method::Horaud,
            what: "eigenvector of the 4x4 quaternion system",
        });
    }
    Ok(*UnitQuaternion::from_quaternion(q)
        .to_rotation_matrix()
        .matrix())
}
