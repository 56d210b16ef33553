//! Closed-form alignment of matched 3D point sets (Umeyama 1991; Arun, Huang & Blostein 1987;
//! Horn 1987 gives the same optimum with quaternions; Kabsch 1976).
//!
//! Given weights `w_i >= 0` and pairs `(p_in_a_i, p_in_b_i)`, find `R, t` (and optionally a
//! scale `c`) minimising `sum_i w_i |p_in_a_i - (c R p_in_b_i + t)|^2`. With the weighted
//! means `mu_a`, `mu_b`, the cross-covariance `S = sum_i w_i (p_a_i - mu_a)(p_b_i - mu_b)^T /
//! sum w` and its SVD `S = U D V^T` (Umeyama, IEEE PAMI 13(4), eqs. 38-42):
//!
//! ```text
//! R = U diag(1, 1, sign(det U det V)) V^T
//! c = tr(D diag(1, 1, sign(..))) / sigma_b^2,   sigma_b^2 = sum w |p_b - mu_b|^2 / sum w
//! t = mu_a - c R mu_b                (c = 1 for the rigid case)
//! ```
//!
//! Degenerate: all points coincident (`D = 0`) or collinear (`rank S < 2`, the rotation
//! about the line is free); detected as `d_2 <= DEGENERATE_RATIO * d_1`.

use nalgebra::{
    Isometry3, Matrix3, Point3, Rotation3, Similarity3, Translation3, UnitQuaternion, Vector3,
};

use super::{RelPoseError, check_lengths};

/// Relative bound on the second singular value of the cross-covariance below which the points
/// count as collinear (or coincident).
pub const DEGENERATE_RATIO: f64 = 1e-9;

/// Result of [`umeyama`]: the transform and the figures that qualify it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UmeyamaAlignment {
    /// Rotation part `R` of `a_from_b`.
    pub rotation: Rotation3<f64>,
    /// Translation `t` (includes the scale when estimated).
    pub translation: Vector3<f64>,
    /// Scale `c` (1 for the rigid case).
    pub scale: f64,
    /// Singular values of the weighted cross-covariance, descending.
    pub singular_values: Vector3<f64>,
}

/// Weighted Umeyama/Horn alignment (module equations); the general form behind
/// [`rigid_from_correspondences`] and [`similarity_from_correspondences`].
///
/// # Errors
/// [`RelPoseError::LengthMismatch`], [`RelPoseError::TooFewCorrespondences`] (< 3),
/// [`RelPoseError::NonFinite`], [`RelPoseError::InvalidWeight`] (negative, non-finite or
/// all zero), [`RelPoseError::Degenerate`] (coincident or collinear points),
/// [`RelPoseError::Numerical`] (SVD failure).
pub fn umeyama(
    p_in_a: &[Point3<f64>],
    p_in_b: &[Point3<f64>],
    weights: Option<&[f64]>,
    with_scale: bool,
) -> Result<UmeyamaAlignment, RelPoseError> {
    check_lengths(p_in_a.len(), p_in_b.len(), 3)?;
    if let Some(w) = weights
        && w.len() != p_in_a.len()
    {
        return Err(RelPoseError::LengthMismatch {
            a: p_in_a.len(),
            b: w.len(),
        });
    }
    let weight = |i: usize| weights.and_then(|w| w.get(i).copied()).unwrap_or(1.0);
    let mut w_sum = 0.0;
    let mut mu_a = Vector3::zeros();
    let mut mu_b = Vector3::zeros();
    for (i, (pa, pb)) in p_in_a.iter().zip(p_in_b).enumerate() {
        if !(pa
            .coords
            .iter()
            .chain(pb.coords.iter())
            .all(|c| c.is_finite()))
        {
            return Err(RelPoseError::NonFinite { index: i });
        }
        let w = weight(i);
        if !(w.is_finite() && w >= 0.0) {
            return Err(RelPoseError::InvalidWeight { index: i, value: w });
        }
        w_sum += w;
        mu_a += w * pa.coords;
        mu_b += w * pb.coords;
    }
    if w_sum <= 0.0 {
        return Err(RelPoseError::InvalidWeight {
            index: 0,
            value: w_sum,
        });
    }
    mu_a /= w_sum;
    mu_b /= w_sum;
    let mut cov = Matrix3::zeros();
    let mut var_b = 0.0;
    for (i, (pa, pb)) in p_in_a.iter().zip(p_in_b).enumerate() {
        let w = weight(i);
        let da = pa.coords - mu_a;
        let db = pb.coords - mu_b;
        cov += w * da * db.transpose();
        var_b += w * db.norm_squared();
    }
    cov /= w_sum;
    var_b /= w_sum;
    let svd = nalgebra::SVD::try_new(cov, true, true, f64::EPSILON, 500).ok_or(
        RelPoseError::Numerical {
            step: "umeyama svd",
        },
    )?;
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
        return Err(RelPoseError::Numerical {
            step: "umeyama svd",
        });
    };
    let d = svd.singular_values;
    if d[0] <= 0.0 {
        return Err(RelPoseError::Degenerate {
            reason: "all points coincide (zero cross-covariance)".to_owned(),
        });
    }
    if d[1] <= DEGENERATE_RATIO * d[0] {
        return Err(RelPoseError::Degenerate {
            reason: format!(
                "points collinear: cross-covariance singular values {:.3e}, {:.3e} (ratio {:.3e} <= {:.0e})",
                d[0],
                d[1],
                d[1] / d[0],
                DEGENERATE_RATIO
            ),
        });
    }
    let sign = if u.determinant() * v_t.determinant() < 0.0 {
        -1.0
    } else {
        1.0
    };
    let s = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, sign));
    let r = u * s * v_t;
    let scale = if with_scale {
        if var_b <= 0.0 {
            return Err(RelPoseError::Degenerate {
                reason: "zero spread of the points in b".to_owned(),
            });
        }
        (d[0] + d[1] + sign * d[2]) / var_b
    } else {
        1.0
    };
    let translation = mu_a - scale * r * mu_b;
    Ok(UmeyamaAlignment {
        rotation: Rotation3::from_matrix_unchecked(r),
        translation,
        scale,
        singular_values: d,
    })
}

/// Rigid `a_from_b` minimising `sum_i w_i |p_in_a_i - a_from_b * p_in_b_i|^2` in closed
/// form (Umeyama 1991 eqs. 39-40 with `c = 1`; Horn 1987). `weights = None` means all 1.
///
/// # Errors
/// As [`umeyama`].
pub fn rigid_from_correspondences(
    p_in_a: &[Point3<f64>],
    p_in_b: &[Point3<f64>],
    weights: Option<&[f64]>,
) -> Result<Isometry3<f64>, RelPoseError> {
    let al = umeyama(p_in_a, p_in_b, weights, false)?;
    Ok(Isometry3::from_parts(
        Translation3::from(al.translation),
        UnitQuaternion::from_rotation_matrix(&al.rotation),
    ))
}

/// Similarity `a_from_b` (rotation, translation, scale) minimising the weighted squared
/// residuals in closed form (Umeyama 1991 eqs. 40-42).
///
/// # Errors
/// As [`umeyama`].
pub fn similarity_from_correspondences(
    p_in_a: &[Point3<f64>],
    p_in_b: &[Point3<f64>],
    weights: Option<&[f64]>,
) -> Result<Similarity3<f64>, RelPoseError> {
    let al = umeyama(p_in_a, p_in_b, weights, true)?;
    Ok(Similarity3::from_parts(
        Translation3::from(al.translation),
        UnitQuaternion::from_rotation_matrix(&al.rotation),
        al.scale,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zero_weights_remove_outliers_exactly() {
        let a_from_b = Isometry3::from_parts(
            Translation3::new(0.08, -0.03, 0.02),
            UnitQuaternion::from_scaled_axis(Vector3::new(-0.1, -0.15, 0.3)),
        );
        let p_in_b: Vec<Point3<f64>> = (0..12)
            .map(|i| {
                let f = f64::from(i);
                Point3::new(
                    (f * 0.7).sin() * 0.2,
                    (f * 1.3).cos() * 0.15,
                    0.3 + 0.02 * f,
                )
            })
            .collect();
        let mut p_in_a: Vec<Point3<f64>> = p_in_b.iter().map(|p| a_from_b * p).collect();
        p_in_a[4] += Vector3::new(0.5, 0.0, 0.0);
        let mut w = vec![1.0; 12];
        w[4] = 0.0;
        let est = rigid_from_correspondences(&p_in_a, &p_in_b, Some(&w)).expect("umeyama");
        assert!(est.rotation.angle_to(&a_from_b.rotation) < 1e-12);
        assert!((est.translation.vector - a_from_b.translation.vector).norm() < 1e-12);
        w[3] = -1.0;
        assert_eq!(
            rigid_from_correspondences(&p_in_a, &p_in_b, Some(&w)),
            Err(RelPoseError::InvalidWeight {
                index: 3,
                value: -1.0
            })
        );
    }

    #[test]
    fn reflection_is_never_returned() {
        // Planar points: the SVD sign correction must give det R = +1.
        let p_in_b: Vec<Point3<f64>> = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)]
            .iter()
            .map(|&(x, y)| Point3::new(x, y, 0.0))
            .collect();
        let p_in_a: Vec<Point3<f64>> = p_in_b.iter().map(|p| Point3::new(p.x, -p.y, 0.0)).collect();
        let al = umeyama(&p_in_a, &p_in_b, None, false).expect("umeyama");
        assert!((al.rotation.matrix().determinant() - 1.0).abs() < 1e-12);
    }
}
