//! Two-view triangulation of normalised image points, with depth signs for cheirality.
//!
//! Camera `b` is the reference: `P_b = [I | 0]`, `P_a = [R | t]` with `(R, t) = a_from_b`, so a
//! point `X` in `b` images at `x_b ~ X`, `x_a ~ R X + t`.
//!
//! * Linear DLT (Hartley & Zisserman 2004, sec. 12.2): the right null vector of
//!   `[x_b P_b^3 - P_b^1; y_b P_b^3 - P_b^2; x_a P_a^3 - P_a^1; y_a P_a^3 - P_a^2]` (rows `P^k`);
//!   invariant to the sign of the homogeneous solution once divided by its last coordinate.
//! * Midpoint (Beardsley, Zisserman & Murray 1994): the middle of the
//!   shortest segment between the rays `s d_b` and `c_a + u d_a` (`c_a = -R^T t`,
//!   `d_a = R^T x_a`), from the 2x2 normal equations.
//!
//! Depths are the `Z` coordinates in each camera; a point satisfies cheirality when both are
//! positive. Degenerate: parallel rays (zero parallax, e.g. zero baseline) or a DLT solution
//! at infinity.

use nalgebra::{Isometry3, Matrix2, Matrix4, Point2, Point3, Vector2, Vector3};

use super::RelPoseError;

/// Rays closer to parallel than this (sine of the angle between them) are refused.
pub const MIN_RAY_SINE: f64 = 1e-12;

/// A triangulated point with its depths in both cameras.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Triangulation {
    /// The point in camera `b` coordinates.
    pub p_in_b: Point3<f64>,
    /// The point in camera `a` coordinates.
    pub p_in_a: Point3<f64>,
    /// `Z` in camera `a` (in the units of `t`).
    pub depth_a: f64,
    /// `Z` in camera `b` (in the units of `t`).
    pub depth_b: f64,
    /// Angle between the two viewing rays at the point, radians.
    pub parallax_rad: f64,
}

impl Triangulation {
    /// Cheirality: in front of both cameras.
    pub fn in_front(&self) -> bool {
        self.depth_a > 0.0 && self.depth_b > 0.0
    }

    fn from_p_in_b(a_from_b: &Isometry3<f64>, p_in_b: Point3<f64>) -> Self {
        let p_in_a = a_from_b * p_in_b;
        let c_a_in_b = a_from_b.inverse_transform_point(&Point3::origin());
        let ray_b = p_in_b.coords;
        let ray_a = p_in_b - c_a_in_b;
        let parallax_rad = ray_b.angle(&ray_a);
        Self {
            p_in_b,
            p_in_a,
            depth_a: p_in_a.z,
            depth_b: p_in_b.z,
            parallax_rad,
        }
    }
}

fn check_finite(x_a: &Point2<f64>, x_b: &Point2<f64>) -> Result<(), RelPoseError> {
    if x_a
        .coords
        .iter()
        .chain(x_b.coords.iter())
        .all(|c| c.is_finite())
    {
        Ok(())
    } else {
        Err(RelPoseError::NonFinite { index: 0 })
    }
}

/// Linear (DLT) triangulation of one correspondence (module equation).
///
/// # Errors
/// [`RelPoseError::NonFinite`], [`RelPoseError::Degenerate`] (solution at infinity),
/// [`RelPoseError::Numerical`].
pub fn triangulate_dlt(
    a_from_b: &Isometry3<f64>,
    x_a: &Point2<f64>,
    x_b: &Point2<f64>,
) -> Result<Triangulation, RelPoseError> {
    check_finite(x_a, x_b)?;
    let r = a_from_b.rotation.to_rotation_matrix().into_inner();
    let t = a_from_b.translation.vector;
    let mut m = Matrix4::zeros();
    // Camera b: P_b = [I | 0].
    m[(0, 0)] = -1.0;
    m[(0, 2)] = x_b.x;
    m[(1, 1)] = -1.0;
    m[(1, 2)] = x_b.y;
    for c in 0..3 {
        m[(2, c)] = x_a.x * r[(2, c)] - r[(0, c)];
        m[(3, c)] = x_a.y * r[(2, c)] - r[(1, c)];
    }
    m[(2, 3)] = x_a.x * t.z - t.x;
    m[(3, 3)] = x_a.y * t.z - t.y;
    let svd = nalgebra::SVD::try_new(m, false, true, f64::EPSILON, 500).ok_or(
        RelPoseError::Numerical {
            step: "triangulation svd",
        },
    )?;
    let Some(v_t) = svd.v_t else {
        return Err(RelPoseError::Numerical {
            step: "triangulation svd",
        });
    };
    let h = v_t.row(3);
    let w = h[3];
    if w.abs() <= f64::EPSILON * h.norm() {
        return Err(RelPoseError::Degenerate {
            reason: format!("triangulated point at infinity (w = {w:.3e})"),
        });
    }
    let p_in_b = Point3::new(h[0] / w, h[1] / w, h[2] / w);
    Ok(Triangulation::from_p_in_b(a_from_b, p_in_b))
}

/// Midpoint triangulation of one correspondence (module equation). The depths carry the sign
/// of the ray parameters, so points behind a camera come out with a negative depth.
///
/// # Errors
/// [`RelPoseError::NonFinite`], [`RelPoseError::Degenerate`] (parallel rays).
pub fn triangulate_midpoint(
    a_from_b: &Isometry3<f64>,
    x_a: &Point2<f64>,
    x_b: &Point2<f64>,
) -> Result<Triangulation, RelPoseError> {
    check_finite(x_a, x_b)?;
    let c_a = a_from_b.inverse_transform_point(&Point3::origin()).coords;
    let d_b = Vector3::new(x_b.x, x_b.y, 1.0);
    let d_a = a_from_b
        .rotation
        .inverse_transform_vector(&Vector3::new(x_a.x, x_a.y, 1.0));
    let bb = d_b.dot(&d_b);
    let ba = d_b.dot(&d_a);
    let aa = d_a.dot(&d_a);
    let det = ba * ba - bb * aa;
    if det.abs() <= MIN_RAY_SINE * MIN_RAY_SINE * bb * aa {
        return Err(RelPoseError::Degenerate {
            reason: format!("parallel rays (sin^2 of angle {:.3e})", -det / (bb * aa)),
        });
    }
    let m = Matrix2::new(bb, -ba, ba, -aa);
    let rhs = Vector2::new(d_b.dot(&c_a), d_a.dot(&c_a));
    let Some(sol) = m.try_inverse().map(|inv| inv * rhs) else {
        return Err(RelPoseError::Degenerate {
            reason: "parallel rays".to_owned(),
        });
    };
    let on_b = sol.x * d_b;
    let on_a = c_a + sol.y * d_a;
    let p_in_b = Point3::from((on_b + on_a) * 0.5);
    let mut tri = Triangulation::from_p_in_b(a_from_b, p_in_b);
    // Signs from the ray parameters (robust when the midpoint straddles a camera plane).
    tri.depth_b = tri.depth_b.abs() * sol.x.signum();
    tri.depth_a = tri.depth_a.abs() * sol.y.signum();
    Ok(tri)
}
