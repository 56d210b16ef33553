//! Small SO(3)/SE(3) helpers shared by the hand-eye solvers.
//!
//! Rotation vectors are `axis * angle_rad`; quaternions are Hamilton, stored by nalgebra
//! as `(x, y, z, w)` and always returned here with `w >= 0` (angle in `[0, pi]`), which is
//! what the quaternion methods (Horaud 1995, Daniilidis 1999) need so that the two sides
//! of `q_B q_X = q_X q_A` carry the same sign.

use nalgebra::{
    DMatrix, DVector, Isometry3, Matrix3, Quaternion, Rotation3, Translation3, UnitQuaternion,
    Vector3,
};

/// `[v]x`, the cross-product matrix: `[v]x w = v x w`.
pub(crate) fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// Unit quaternion of a rotation with non-negative scalar part.
pub(crate) fn quaternion_of(rotation: &Matrix3<f64>) -> Quaternion<f64> {
    let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(*rotation));
    let q = q.into_inner();
    if q.w < 0.0 { -q } else { q }
}

/// `log(R)` as a rotation vector (axis * angle, angle in `[0, pi]`), via the quaternion so
/// that it stays accurate near `pi` (where `acos((tr R - 1) / 2)` loses the axis).
pub(crate) fn rotation_log(rotation: &Matrix3<f64>) -> Vector3<f64> {
    let q = quaternion_of(rotation);
    let v = q.imag();
    let s = v.norm();
    if s < 1e-300 {
        return Vector3::zeros();
    }
    let angle = 2.0 * s.atan2(q.w);
    v * (angle / s)
}

/// Rotation angle of `R` in radians, in `[0, pi]`.
pub(crate) fn rotation_angle(rotation: &Matrix3<f64>) -> f64 {
    rotation_log(rotation).norm()
}

/// `exp([phi]x)` (Rodrigues' formula).
pub(crate) fn rotation_exp(phi: &Vector3<f64>) -> Matrix3<f64> {
    *Rotation3::new(*phi).matrix()
}

/// Inverse of the right Jacobian of SO(3): `log(exp(phi) exp(eps)) ~ phi + Jr^-1(phi) eps`.
///
/// `Jr^-1(phi) = I + [phi]x / 2 + (1/theta^2 - (1 + cos theta) / (2 theta sin theta)) [phi]x^2`
/// (e.g. Chirikjian 2011, vol. 2, eq. 10.86; Barfoot 2017, eq. 7.77a).
pub(crate) fn right_jacobian_inverse(phi: &Vector3<f64>) -> Matrix3<f64> {
    let theta = phi.norm();
    let k = skew(phi);
    let c = if theta < 1e-5 {
        // Series: 1/12 + theta^2/720.
        1.0 / 12.0 + theta * theta / 720.0
    } else {
        1.0 / (theta * theta) - (1.0 + theta.cos()) / (2.0 * theta * theta.sin())
    };
    Matrix3::identity() + 0.5 * k + c * k * k
}

/// Nearest rotation (Frobenius norm) to `m`, with determinant +1:
/// `U diag(1, 1, det(U V^T)) V^T` from `m = U S V^T` (Umeyama 1991, eq. 39-40).
pub(crate) fn nearest_rotation(m: &Matrix3<f64>) -> Option<Matrix3<f64>> {
    if !m.iter().all(|v| v.is_finite()) {
        return None;
    }
    let svd = m.svd(true, true);
    let (u, v_t) = (svd.u?, svd.v_t?);
    let d = (u * v_t).determinant();
    let mut s = Matrix3::identity();
    if d < 0.0 {
        s[(2, 2)] = -1.0;
    }
    Some(u * s * v_t)
}

/// Builds an isometry from a (proper, orthonormal) rotation matrix and a translation.
pub(crate) fn isometry(rotation: &Matrix3<f64>, translation: &Vector3<f64>) -> Isometry3<f64> {
    let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(*rotation));
    Isometry3::from_parts(Translation3::from(*translation), q)
}

/// Rotation matrix of an isometry.
pub(crate) fn rot(x: &Isometry3<f64>) -> Matrix3<f64> {
    *x.rotation.to_rotation_matrix().matrix()
}

/// Linear least squares `min ||a x - b||` by SVD (minimum-norm solution, like OpenCV's
/// `DECOMP_SVD`). Returns `None` when the SVD fails or the result is not finite.
pub(crate) fn least_squares(a: DMatrix<f64>, b: &DVector<f64>) -> Option<DVector<f64>> {
    let svd = a.svd(true, true);
    let max = svd.singular_values.max();
    let x = svd.solve(b, max * 1e-14).ok()?;
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// The `k` right singular vectors of `a` with the smallest singular values, smallest first,
/// plus all singular values in ascending order.
pub(crate) fn smallest_right_singular_vectors(
    a: DMatrix<f64>,
    k: usize,
) -> Option<(Vec<DVector<f64>>, Vec<f64>)> {
    let n = a.ncols();
    if a.nrows() < n || k > n {
        return None;
    }
    let svd = a.svd(false, true);
    let v_t = svd.v_t?;
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&i, &j| svd.singular_values[i].total_cmp(&svd.singular_values[j]));
    let values = order.iter().map(|&i| svd.singular_values[i]).collect();
    let vectors = order
        .iter()
        .take(k)
        .map(|&i| v_t.row(i).transpose())
        .collect::<Vec<_>>();
    Some((vectors, values))
}

/// Whether every entry of an isometry is finite.
pub(crate) fn is_finite_isometry(x: &Isometry3<f64>) -> bool {
    x.translation.vector.iter().all(|v| v.is_finite())
        && x.rotation.coords.iter().all(|v| v.is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_is_accurate_near_pi_and_zero() {
        for angle in [0.0, 1e-9, 0.3, 3.0, std::f64::consts::PI - 1e-7] {
            let phi = Vector3::new(0.6, -0.8, 0.0) * angle;
            let back = rotation_log(&rotation_exp(&phi));
            assert!((back - phi).amax() < 1e-9, "{angle}: {back:?}");
        }
    }

    #[test]
    fn right_jacobian_inverse_matches_finite_differences() {
        let phi = Vector3::new(0.4, -1.1, 0.7);
        let jinv = right_jacobian_inverse(&phi);
        let r = rotation_exp(&phi);
        let h = 1e-6;
        for k in 0..3 {
            let mut e = Vector3::zeros();
            e[k] = h;
            let num = (rotation_log(&(r * rotation_exp(&e)))
                - rotation_log(&(r * rotation_exp(&(-e)))))
                / (2.0 * h);
            assert!((num - jinv.column(k)).amax() < 1e-7, "column {k}");
        }
    }

    #[test]
    fn nearest_rotation_fixes_reflections() {
        let m = Matrix3::new(1.0, 0.01, 0.0, 0.0, 1.0, 0.02, 0.0, 0.0, -1.0);
        let r = nearest_rotation(&m).unwrap_or_else(Matrix3::zeros);
        assert!((r.determinant() - 1.0).abs() < 1e-12);
        assert!((r * r.transpose() - Matrix3::identity()).amax() < 1e-12);
    }
}
