//! Daniilidis (1999), "Hand-eye calibration using dual quaternions", Int. J. Robotics
//! Research 18(3):286-298.
//!
//! A rigid motion `(R, t)` is the unit dual quaternion `q + eps q'` with `q` the rotation
//! quaternion (scalar part >= 0 here) and `q' = (0, t) q / 2` (eq. 5-6). `B X = X A` is
//! `q_B q_X = q_X q_A` and the dual part likewise. With `a, a'` the vector parts of the hand
//! motion's `q_B, q'_B` and `b, b'` those of the eye's, each motion gives six equations in
//! the eight unknowns `(q_X, q'_X)` (eq. 31):
//!
//! ```text
//! [ a - b    [a + b]x    0        0       ] [q_X ]
//! [ a' - b'  [a' + b']x  a - b   [a + b]x ] [q'_X] = 0
//! ```
//!
//! The stacked `6K x 8` matrix has (noise-free) a 2-D null space spanned by the right
//! singular vectors `v7 = (u1, v1)`, `v8 = (u2, v2)` of its two smallest singular values.
//! `(q_X, q'_X) = l1 v7 + l2 v8` with `|q_X| = 1` and `q_X . q'_X = 0` (eq. 34-35):
//!
//! ```text
//! l1^2 u1.v1 + l1 l2 (u1.v2 + u2.v1) + l2^2 u2.v2 = 0,     |l1 u1 + l2 u2| = 1
//! ```
//!
//! The quadratic has two directions `(l1 : l2)`; one is the spurious null vector `(0, q_X)`
//! of the dual equations (vanishing rotation part), so the one with the larger
//! `|l1 u1 + l2 u2|` (at unit `(l1, l2)`) is kept. Solving it homogeneously (dividing by the
//! larger of the outer coefficients) avoids the blow-up of `s = l1 / l2` when `l2 ~ 0`.
//! A negative discriminant (inconsistent motions, where OpenCV returns NaN) is refused.
//! Needs a metric eye.

use nalgebra::{DMatrix, DVector, Isometry3, Matrix3, Quaternion, UnitQuaternion, Vector3};

use super::geometry::{quaternion_of, rot, skew, smallest_right_singular_vectors};
use super::{HandEyeError, Method, RelativeMotion};

/// `(q, q')` of a motion.
fn dual_quaternion(x: &Isometry3<f64>) -> (Quaternion<f64>, Quaternion<f64>) {
    let q = quaternion_of(&rot(x));
    let q_dual = Quaternion::from_imag(x.translation.vector) * q * 0.5;
    (q, q_dual)
}

/// X by Daniilidis eq. 31-35 (module docs).
///
/// # Errors
///
/// [`HandEyeError::NumericalFailure`] when the SVD fails or eq. 35 has no real root.
pub fn solve(motions: &[RelativeMotion]) -> Result<Isometry3<f64>, HandEyeError> {
    let failure = |what| HandEyeError::NumericalFailure {
        method: Method::Daniilidis,
        what,
    };
    let mut t = DMatrix::zeros(6 * motions.len(), 8);
    for (k, m) in motions.iter().enumerate() {
        let w = m.weight.sqrt();
        let (qb, qb_dual) = dual_quaternion(&m.b);
        let (qa, qa_dual) = dual_quaternion(&m.a);
        let (a, a_dual) = (qb.imag(), qb_dual.imag());
        let (b, b_dual) = (qa.imag(), qa_dual.imag());
        let r = 6 * k;
        t.view_mut((r, 0), (3, 1)).copy_from(&(w * (a - b)));
        t.view_mut((r, 1), (3, 3)).copy_from(&(w * skew(&(a + b))));
        t.view_mut((r + 3, 0), (3, 1))
            .copy_from(&(w * (a_dual - b_dual)));
        t.view_mut((r + 3, 1), (3, 3))
            .copy_from(&(w * skew(&(a_dual + b_dual))));
        t.view_mut((r + 3, 4), (3, 1)).copy_from(&(w * (a - b)));
        t.view_mut((r + 3, 5), (3, 3))
            .copy_from(&(w * skew(&(a + b))));
    }
    let (vectors, _) = smallest_right_singular_vectors(t, 2).ok_or(failure("SVD (eq. 31)"))?;
    // v7: second smallest singular value, v8: smallest (the paper's and OpenCV's order).
    let [v8, v7] = vectors.as_slice() else {
        return Err(failure("SVD (eq. 31)"));
    };
    let split = |v: &DVector<f64>| (v.rows(0, 4).into_owned(), v.rows(4, 4).into_owned());
    let (u1, v1) = split(v7);
    let (u2, v2) = split(v8);
    // Eq. 35 as a homogeneous quadratic a l1^2 + b l1 l2 + c l2^2 = 0 in (l1, l2): its two
    // directions, found without dividing by a small leading coefficient.
    let qa = u1.dot(&v1);
    let qb = u1.dot(&v2) + u2.dot(&v1);
    let qc = u2.dot(&v2);
    let mut disc = qb * qb - 4.0 * qa * qc;
    if disc < 0.0 && disc > -1e-12 * (qb * qb + (4.0 * qa * qc).abs()) {
        disc = 0.0;
    }
    if disc.is_nan() || disc < 0.0 {
        return Err(failure("eq. 35 has no real root"));
    }
    let q = -0.5 * (qb + qb.signum() * disc.sqrt());
    let directions: Vec<(f64, f64)> = if qa.abs() >= qc.abs() {
        // Roots s = l1 / l2 of a s^2 + b s + c: q / a and c / q.
        [q / qa, if q != 0.0 { qc / q } else { 0.0 }]
            .into_iter()
            .map(|s| (s, 1.0))
            .collect()
    } else {
        // Roots r = l2 / l1 of c r^2 + b r + a: q / c and a / q.
        [q / qc, if q != 0.0 { qa / q } else { 0.0 }]
            .into_iter()
            .map(|r| (1.0, r))
            .collect()
    };
    // Eq. 34: |l1 u1 + l2 u2| = 1. One direction is the spurious null vector (0, q_X)
    // (vanishing rotation part); keep the one with the larger rotation part.
    let mut best: Option<((f64, f64), f64)> = None;
    for (l1, l2) in directions {
        let norm = (l1 * l1 + l2 * l2).sqrt();
        if !norm.is_finite() || norm <= 0.0 {
            continue;
        }
        let d = (l1 / norm, l2 / norm);
        let val = (&u1 * d.0 + &u2 * d.1).norm_squared();
        if val.is_finite() && best.is_none_or(|(_, v)| val > v) {
            best = Some((d, val));
        }
    }
    let Some(((d1, d2), val)) = best.filter(|(_, v)| *v > 1e-12) else {
        return Err(failure("eq. 34 normalisation"));
    };
    let scale = 1.0 / val.sqrt();
    let dq = v7 * (d1 * scale) + v8 * (d2 * scale);
    let q = Quaternion::new(dq[0], dq[1], dq[2], dq[3]);
    let q_dual = Quaternion::new(dq[4], dq[5], dq[6], dq[7]);
    if !dq.iter().all(|x| x.is_finite()) || q.norm() <= 0.5 {
        return Err(failure("non-finite dual quaternion"));
    }
    let unit = UnitQuaternion::from_quaternion(q);
    // t = 2 q' q^* (eq. 6), with q normalised.
    let t_q = q_dual * unit.into_inner().conjugate() * (2.0 / q.norm());
    let translation: Vector3<f64> = t_q.imag();
    let rotation: Matrix3<f64> = *unit.to_rotation_matrix().matrix();
    Ok(super::geometry::isometry(&rotation, &translation))
}
