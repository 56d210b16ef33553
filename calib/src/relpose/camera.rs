//! Pinhole camera with OpenCV's `plumb_bob` distortion (Brown-Conrady, 5 coefficients).
//!
//! For a point `p_in_camera = (X, Y, Z)`, `Z > 0`, with `x = X/Z`, `y = Y/Z`, `r^2 = x^2 + y^2`
//! (OpenCV `projectPoints`, Brown 1966):
//!
//! ```text
//! x_d = x (1 + k1 r^2 + k2 r^4 + k3 r^6) + 2 p1 x y + p2 (r^2 + 2 x^2)
//! y_d = y (1 + k1 r^2 + k2 r^4 + k3 r^6) + p1 (r^2 + 2 y^2) + 2 p2 x y
//! u = fx x_d + cx,   v = fy y_d + cy
//! ```
//!
//! Undistortion inverts the distortion map by Newton's method with its analytic 2x2 Jacobian
//! (OpenCV's `undistortPoints` runs 5 fixed-point iterations by default; Newton converges
//! quadratically, to rounding, in 3-6 steps for camera-grade distortion).

use nalgebra::{Matrix2, Point2, Point3, Vector2};
use serde::{Deserialize, Serialize};

use super::RelPoseError;

/// Maximum Newton iterations of [`CameraModel::undistort_normalised`].
pub const UNDISTORT_MAX_ITERATIONS: usize = 50;
/// Convergence bound of the undistortion: `|distort(x) - x_d| <= UNDISTORT_TOLERANCE` in
/// normalised coordinates (about 2e-9 px at f = 1745 px).
pub const UNDISTORT_TOLERANCE: f64 = 1e-12;

/// Pinhole intrinsics plus `plumb_bob` distortion, as in `camera.yaml` (ARCHITECTURE.md section 5).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CameraModel {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Focal length along x, pixels.
    pub fx: f64,
    /// Focal length along y, pixels.
    pub fy: f64,
    /// Principal point column, pixels.
    pub cx: f64,
    /// Principal point row, pixels.
    pub cy: f64,
    /// Radial coefficient of `r^2`.
    pub k1: f64,
    /// Radial coefficient of `r^4`.
    pub k2: f64,
    /// First tangential coefficient.
    pub p1: f64,
    /// Second tangential coefficient.
    pub p2: f64,
    /// Radial coefficient of `r^6`.
    pub k3: f64,
}

impl CameraModel {
    /// A distortion-free pinhole camera.
    pub fn pinhole(width: u32, height: u32, fx: f64, fy: f64, cx: f64, cy: f64) -> Self {
        Self {
            width,
            height,
            fx,
            fy,
            cx,
            cy,
            k1: 0.0,
            k2: 0.0,
            p1: 0.0,
            p2: 0.0,
            k3: 0.0,
        }
    }

    /// Applies the distortion to normalised coordinates (module equation).
    pub fn distort_normalised(&self, x: &Point2<f64>) -> Point2<f64> {
        let (xd, yd, _) = self.distort_with_jacobian(x.x, x.y);
        Point2::new(xd, yd)
    }

    /// Distortion and its Jacobian `d(x_d, y_d) / d(x, y)`.
    fn distort_with_jacobian(&self, x: f64, y: f64) -> (f64, f64, Matrix2<f64>) {
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3));
        let d_radial = self.k1 + r2 * (2.0 * self.k2 + 3.0 * self.k3 * r2);
        let xd = x * radial + 2.0 * self.p1 * x * y + self.p2 * (r2 + 2.0 * x * x);
        let yd = y * radial + self.p1 * (r2 + 2.0 * y * y) + 2.0 * self.p2 * x * y;
        let j = Matrix2::new(
            radial + 2.0 * x * x * d_radial + 2.0 * self.p1 * y + 6.0 * self.p2 * x,
            2.0 * x * y * d_radial + 2.0 * self.p1 * x + 2.0 * self.p2 * y,
            2.0 * x * y * d_radial + 2.0 * self.p1 * x + 2.0 * self.p2 * y,
            radial + 2.0 * y * y * d_radial + 6.0 * self.p1 * y + 2.0 * self.p2 * x,
        );
        (xd, yd, j)
    }

    /// Projects a point given in camera coordinates to a (distorted) pixel.
    ///
    /// Returns `None` when the point is not in front of the camera (`Z <= 0`) or not finite.
    /// The pixel is not clipped to the image; see [`CameraModel::contains`].
    pub fn project(&self, p_in_camera: &Point3<f64>) -> Option<Point2<f64>> {
        if p_in_camera.z <= 0.0 || !p_in_camera.coords.iter().all(|c| c.is_finite()) {
            return None;
        }
        let xn = Point2::new(p_in_camera.x / p_in_camera.z, p_in_camera.y / p_in_camera.z);
        Some(self.pixel_from_normalised(&xn))
    }

    /// Distorts normalised coordinates and applies the intrinsics.
    pub fn pixel_from_normalised(&self, x: &Point2<f64>) -> Point2<f64> {
        let d = self.distort_normalised(x);
        Point2::new(self.fx * d.x + self.cx, self.fy * d.y + self.cy)
    }

    /// Whether a pixel lies inside the image (`0 <= u < width`, `0 <= v < height`).
    pub fn contains(&self, px: &Point2<f64>) -> bool {
        px.x >= 0.0 && px.y >= 0.0 && px.x < f64::from(self.width) && px.y < f64::from(self.height)
    }

    /// Undistorts a pixel to normalised coordinates `(X/Z, Y/Z)`.
    ///
    /// # Errors
    /// [`RelPoseError::NonFinite`] for a non-finite pixel, [`RelPoseError::InvalidParameter`]
    /// for a zero focal length, [`RelPoseError::UndistortNotConverged`] when Newton's method
    /// does not reach [`UNDISTORT_TOLERANCE`], [`RelPoseError::UndistortOutOfDomain`] when
    /// the only root found is beyond the fold of the distortion (no physical preimage).
    pub fn undistort_pixel(&self, px: &Point2<f64>) -> Result<Point2<f64>, RelPoseError> {
        if !(px.x.is_finite() && px.y.is_finite()) {
            return Err(RelPoseError::NonFinite { index: 0 });
        }
        if !(self.fx.is_finite() && self.fx != 0.0) {
            return Err(RelPoseError::InvalidParameter {
                name: "fx",
                value: self.fx,
            });
        }
        if !(self.fy.is_finite() && self.fy != 0.0) {
            return Err(RelPoseError::InvalidParameter {
                name: "fy",
                value: self.fy,
            });
        }
        let xd = Point2::new((px.x - self.cx) / self.fx, (px.y - self.cy) / self.fy);
        self.undistort_normalised(&xd).map_err(|e| match e {
            RelPoseError::UndistortNotConverged {
                residual,
                iterations,
                ..
            } => RelPoseError::UndistortNotConverged {
                u: px.x,
                v: px.y,
                residual,
                iterations,
            },
            RelPoseError::UndistortOutOfDomain {
                radial_factor,
                jacobian_det,
                ..
            } => RelPoseError::UndistortOutOfDomain {
                u: px.x,
                v: px.y,
                radial_factor,
                jacobian_det,
            },
            other => other,
        })
    }

    /// Undistorts a batch of pixels ([`CameraModel::undistort_pixel`] on each).
    ///
    /// # Errors
    /// As [`CameraModel::undistort_pixel`]; [`RelPoseError::NonFinite`] carries the index of
    /// the offending pixel.
    pub fn undistort_pixels(&self, px: &[Point2<f64>]) -> Result<Vec<Point2<f64>>, RelPoseError> {
        px.iter()
            .enumerate()
            .map(|(index, p)| {
                self.undistort_pixel(p).map_err(|e| match e {
                    RelPoseError::NonFinite { .. } => RelPoseError::NonFinite { index },
                    other => other,
                })
            })
            .collect()
    }

    /// Inverts the distortion map on normalised coordinates by Newton's method.
    ///
    /// # Errors
    /// [`RelPoseError::UndistortNotConverged`] when the residual stays above
    /// [`UNDISTORT_TOLERANCE`] (singular Jacobian or divergence),
    /// [`RelPoseError::UndistortOutOfDomain`] for a root on the non-physical branch.
    pub fn undistort_normalised(&self, xd: &Point2<f64>) -> Result<Point2<f64>, RelPoseError> {
        let target = Vector2::new(xd.x, xd.y);
        let mut x = target;
        let mut residual = f64::INFINITY;
        for it in 0..UNDISTORT_MAX_ITERATIONS {
            let (dx, dy, j) = self.distort_with_jacobian(x.x, x.y);
            let r = Vector2::new(dx, dy) - target;
            let norm = r.norm();
            if !norm.is_finite() {
                break;
            }
            // Stop at rounding level: once converged, further steps only dither.
            if norm <= UNDISTORT_TOLERANCE * 1e-3
                || (norm <= UNDISTORT_TOLERANCE && norm >= residual)
            {
                return self.check_branch(xd, x);
            }
            residual = residual.min(norm);
            let Some(j_inv) = j.try_inverse() else {
                break;
            };
            x -= j_inv * r;
            if it + 1 == UNDISTORT_MAX_ITERATIONS {
                break;
            }
        }
        let (dx, dy, _) = self.distort_with_jacobian(x.x, x.y);
        let final_residual = (Vector2::new(dx, dy) - target).norm();
        if final_residual <= UNDISTORT_TOLERANCE {
            return self.check_branch(xd, x);
        }
        Err(RelPoseError::UndistortNotConverged {
            u: xd.x,
            v: xd.y,
            residual: final_residual,
            iterations: UNDISTORT_MAX_ITERATIONS,
        })
    }

    /// Accepts a root of the distortion equation only on the physical branch: positive radial
    /// factor and orientation-preserving Jacobian (the distortion map is locally invertible
    /// there); a root beyond the fold of a strong barrel distortion is refused.
    fn check_branch(&self, xd: &Point2<f64>, x: Vector2<f64>) -> Result<Point2<f64>, RelPoseError> {
        let r2 = x.norm_squared();
        let radial = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3));
        let (_, _, j) = self.distort_with_jacobian(x.x, x.y);
        let det = j.determinant();
        if radial > 0.0 && det > 0.0 {
            Ok(Point2::from(x))
        } else {
            Err(RelPoseError::UndistortOutOfDomain {
                u: xd.x,
                v: xd.y,
                radial_factor: radial,
                jacobian_det: det,
            })
        }
    }

    /// Back-projects a pixel with its depth (the `Z` coordinate, metres, as a registered
    /// depth image stores it) to a point in camera coordinates: `Z * (x, y, 1)` with `(x, y)`
    /// the undistorted normalised coordinates.
    ///
    /// # Errors
    /// As [`CameraModel::undistort_pixel`]; [`RelPoseError::InvalidParameter`] for a
    /// non-finite or non-positive depth.
    pub fn backproject(&self, px: &Point2<f64>, depth_m: f64) -> Result<Point3<f64>, RelPoseError> {
        if !(depth_m.is_finite() && depth_m > 0.0) {
            return Err(RelPoseError::InvalidParameter {
                name: "depth_m",
                value: depth_m,
            });
        }
        let x = self.undistort_pixel(px)?;
        Ok(Point3::new(x.x * depth_m, x.y * depth_m, depth_m))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera() -> CameraModel {
        CameraModel {
            k1: -0.08,
            k2: 0.12,
            p1: 4e-4,
            p2: -3e-4,
            k3: -0.05,
            ..CameraModel::pinhole(1280, 1024, 1745.0, 1745.0, 640.0, 512.0)
        }
    }

    #[test]
    fn distortion_jacobian_matches_finite_differences() {
        let cam = camera();
        let h = 1e-7;
        for (x, y) in [(0.1, -0.2), (-0.35, 0.28), (0.0, 0.0), (0.37, 0.29)] {
            let (_, _, j) = cam.distort_with_jacobian(x, y);
            let d = |dx: f64, dy: f64| cam.distort_normalised(&Point2::new(x + dx, y + dy));
            let col_x = (d(h, 0.0) - d(-h, 0.0)) / (2.0 * h);
            let col_y = (d(0.0, h) - d(0.0, -h)) / (2.0 * h);
            assert!((j.column(0) - col_x).norm() < 1e-8, "{j} vs {col_x}");
            assert!((j.column(1) - col_y).norm() < 1e-8, "{j} vs {col_y}");
        }
    }

    #[test]
    fn pinhole_has_identity_distortion() {
        let cam = CameraModel::pinhole(640, 480, 500.0, 500.0, 320.0, 240.0);
        let x = Point2::new(0.3, -0.2);
        assert_eq!(cam.distort_normalised(&x), x);
        let px = cam.pixel_from_normalised(&x);
        assert_eq!(px, Point2::new(470.0, 140.0));
        let back = cam.undistort_pixel(&px).expect("undistort");
        assert!((back - x).norm() < 1e-15);
    }
}
