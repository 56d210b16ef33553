//! The camera model: pinhole plus OpenCV's `plumb_bob` distortion (Brown-Conrady, five
//! coefficients), built from and written to `sensor_msgs/CameraInfo`. Calibration, perception
//! and the simulator's renderer all use this one model.
//!
//! Camera frame: OpenCV optical axes (x right, y down, z forward). For a point
//! `p_in_camera = (X, Y, Z)`, `Z > 0`, with `x = X/Z`, `y = Y/Z`, `r^2 = x^2 + y^2`
//! (OpenCV `projectPoints`, Brown 1966; ROS `CameraInfo.D = [k1, k2, p1, p2, k3]`,
//! `K = [fx 0 cx; 0 fy cy; 0 0 1]`):
//!
//! ```text
//! x_d = x (1 + k1 r^2 + k2 r^4 + k3 r^6) + 2 p1 x y + p2 (r^2 + 2 x^2)
//! y_d = y (1 + k1 r^2 + k2 r^4 + k3 r^6) + p1 (r^2 + 2 y^2) + 2 p2 x y
//! u = fx x_d + cx,   v = fy y_d + cy        (integer pixel coordinates at pixel centres)
//! ```
//!
//! Undistortion inverts the distortion map by Newton's method with its analytic 2x2 Jacobian.
//! OpenCV's `undistortPoints` runs 5 fixed-point iterations by default; Newton converges
//! quadratically, to rounding, in 3-6 steps for camera-grade distortion, and a root beyond
//! the fold of a strong barrel distortion (no physical preimage) is refused rather than
//! returned.

use msgs::sensor_msgs::CameraInfo;
use msgs::std_msgs::Header;
use nalgebra::{Matrix2, Point2, Point3, Vector2};

/// Maximum Newton iterations of [`CameraModel::undistort_normalised`].
pub const UNDISTORT_MAX_ITERATIONS: usize = 50;
/// Convergence bound of the undistortion: `|distort(x) - x_d| <= UNDISTORT_TOLERANCE` in
/// normalised coordinates (about 2e-9 px at f = 1745 px).
pub const UNDISTORT_TOLERANCE: f64 = 1e-12;

/// Errors of the camera model.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CameraError {
    /// A parameter or an input is non-finite or out of range.
    #[error("camera parameter {name} = {value} is invalid")]
    InvalidParameter {
        /// Field or argument name.
        name: &'static str,
        /// Its value.
        value: f64,
    },
    /// A non-finite pixel (its index in a batch; 0 for a single pixel).
    #[error("pixel {index} is not finite")]
    NonFinite {
        /// Index of the pixel.
        index: usize,
    },
    /// A `CameraInfo` this model cannot represent.
    #[error("unusable camera_info: {reason}")]
    BadCameraInfo {
        /// What is wrong, with the values.
        reason: String,
    },
    /// Newton's method did not converge (distortion too strong or pixel far outside).
    #[error(
        "undistortion of pixel ({u}, {v}) did not converge: residual {residual} after {iterations} iterations"
    )]
    UndistortNotConverged {
        /// Pixel column (normalised distorted x when raised by `undistort_normalised`).
        u: f64,
        /// Pixel row (normalised distorted y when raised by `undistort_normalised`).
        v: f64,
        /// Final residual in normalised coordinates.
        residual: f64,
        /// Iterations run.
        iterations: usize,
    },
    /// The undistortion root lies beyond the fold of the distortion map (non-positive radial
    /// factor or Jacobian determinant): the pixel has no physical preimage.
    #[error(
        "undistortion of ({u}, {v}) out of the distortion's domain: radial factor {radial_factor}, Jacobian determinant {jacobian_det}"
    )]
    UndistortOutOfDomain {
        /// Pixel column (normalised distorted x when raised by `undistort_normalised`).
        u: f64,
        /// Pixel row (normalised distorted y when raised by `undistort_normalised`).
        v: f64,
        /// `1 + k1 r^2 + k2 r^4 + k3 r^6` at the root.
        radial_factor: f64,
        /// Determinant of the distortion Jacobian at the root.
        jacobian_det: f64,
    },
}

/// Pinhole intrinsics plus `plumb_bob` distortion (pixels; coefficients unitless).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraModel {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Focal length along x, pixels.
    pub fx: f64,
    /// Focal length along y, pixels.
    pub fy: f64,
    /// Principal point column, pixels (pixel centres at integers).
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
    #[must_use]
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

    /// The same intrinsics with the distortion `[k1, k2, p1, p2, k3]` (`CameraInfo.D` order).
    #[must_use]
    pub fn with_distortion(self, [k1, k2, p1, p2, k3]: [f64; 5]) -> Self {
        Self {
            k1,
            k2,
            p1,
            p2,
            k3,
            ..self
        }
    }

    /// The distortion `[k1, k2, p1, p2, k3]` (`CameraInfo.D` order).
    #[must_use]
    pub fn distortion(&self) -> [f64; 5] {
        [self.k1, self.k2, self.p1, self.p2, self.k3]
    }

    /// The model of a `CameraInfo`: K row-major without skew; D `plumb_bob`
    /// `[k1, k2, p1, p2, k3]` (shorter lists padded with zeros), or `rational_polynomial` whose
    /// `k4..k6` are zero (the same map). Any model with all-zero D is a pinhole.
    ///
    /// # Errors
    /// [`CameraError::BadCameraInfo`] naming the values: a zero size, non-positive or
    /// non-finite focal lengths, a non-finite principal point, a skew, another distortion
    /// model with non-zero coefficients, or non-finite coefficients.
    pub fn from_camera_info(info: &CameraInfo) -> Result<Self, CameraError> {
        let k = &info.k;
        let (fx, skew, cx, fy, cy) = (k[0], k[1], k[2], k[4], k[5]);
        let bad = |reason: String| Err(CameraError::BadCameraInfo { reason });
        if info.width == 0 || info.height == 0 {
            return bad(format!("image size {}x{}", info.width, info.height));
        }
        if !(fx.is_finite()
            && fy.is_finite()
            && fx > 0.0
            && fy > 0.0
            && cx.is_finite()
            && cy.is_finite())
        {
            return bad(format!("K has fx = {fx}, fy = {fy}, cx = {cx}, cy = {cy}"));
        }
        if skew != 0.0 {
            return bad(format!(
                "K has a skew of {skew} px; the plumb_bob model has none"
            ));
        }
        if info.d.iter().any(|v| !v.is_finite()) {
            return bad("non-finite distortion coefficient".to_owned());
        }
        let model = info.distortion_model.as_str();
        let any_distortion = info.d.iter().any(|&v| v != 0.0);
        let five = matches!(model, "plumb_bob" | "rational_polynomial");
        if any_distortion && !five || info.d.iter().skip(5).any(|&v| v != 0.0) {
            return bad(format!(
                "distortion model {model:?} with coefficients {:?}: only plumb_bob [k1 k2 p1 p2 k3] is supported",
                info.d
            ));
        }
        let d = |i: usize| info.d.get(i).copied().unwrap_or(0.0);
        Ok(
            Self::pinhole(info.width, info.height, fx, fy, cx, cy).with_distortion([
                d(0),
                d(1),
                d(2),
                d(3),
                d(4),
            ]),
        )
    }

    /// The `CameraInfo` of this camera (`plumb_bob`, `R = I`, `P = [K | 0]`).
    #[must_use]
    pub fn to_camera_info(&self, header: Header) -> CameraInfo {
        let (fx, fy, cx, cy) = (self.fx, self.fy, self.cx, self.cy);
        CameraInfo {
            header,
            height: self.height,
            width: self.width,
            distortion_model: "plumb_bob".to_owned(),
            d: self.distortion().to_vec(),
            k: [fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0],
            r: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
            p: [fx, 0.0, cx, 0.0, 0.0, fy, cy, 0.0, 0.0, 0.0, 1.0, 0.0],
            ..CameraInfo::default()
        }
    }

    /// Checks sizes and finiteness.
    ///
    /// # Errors
    /// [`CameraError::InvalidParameter`] naming the first bad field.
    pub fn validate(&self) -> Result<(), CameraError> {
        let bad = |name, value: f64| Err(CameraError::InvalidParameter { name, value });
        if self.width == 0 {
            return bad("width", 0.0);
        }
        if self.height == 0 {
            return bad("height", 0.0);
        }
        for (name, v) in [("fx", self.fx), ("fy", self.fy)] {
            if !(v.is_finite() && v > 0.0) {
                return bad(name, v);
            }
        }
        for (name, v) in [
            ("cx", self.cx),
            ("cy", self.cy),
            ("k1", self.k1),
            ("k2", self.k2),
            ("p1", self.p1),
            ("p2", self.p2),
            ("k3", self.k3),
        ] {
            if !v.is_finite() {
                return bad(name, v);
            }
        }
        Ok(())
    }

    /// The same lens on a sensor resampled by `factor` (e.g. 0.25: 1280x1024 -> 320x256):
    /// focal lengths scale by `factor`, the principal point by `(c + 0.5) factor - 0.5`
    /// (pixel-centre convention); the distortion is unchanged.
    ///
    /// # Errors
    /// [`CameraError::InvalidParameter`] if `factor` is not positive or the size rounds to 0.
    pub fn scaled(&self, factor: f64) -> Result<Self, CameraError> {
        let w = (f64::from(self.width) * factor).round();
        let h = (f64::from(self.height) * factor).round();
        if !(factor > 0.0 && factor.is_finite() && w >= 1.0 && h >= 1.0) {
            return Err(CameraError::InvalidParameter {
                name: "factor",
                value: factor,
            });
        }
        Ok(Self {
            width: w as u32,
            height: h as u32,
            fx: self.fx * factor,
            fy: self.fy * factor,
            cx: (self.cx + 0.5) * factor - 0.5,
            cy: (self.cy + 0.5) * factor - 0.5,
            ..*self
        })
    }

    /// Number of pixels.
    #[must_use]
    pub fn pixel_count(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// Applies the distortion to normalised coordinates (module equation).
    #[inline]
    #[must_use]
    pub fn distort_normalised(&self, x: &Point2<f64>) -> Point2<f64> {
        let (xd, yd) = self.distort(x.x, x.y);
        Point2::new(xd, yd)
    }

    /// The distortion map on `(x, y)`.
    #[inline]
    fn distort(&self, x: f64, y: f64) -> (f64, f64) {
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3));
        (
            x * radial + 2.0 * self.p1 * x * y + self.p2 * (r2 + 2.0 * x * x),
            y * radial + self.p1 * (r2 + 2.0 * y * y) + 2.0 * self.p2 * x * y,
        )
    }

    /// Distortion and its Jacobian `d(x_d, y_d) / d(x, y)`.
    fn distort_with_jacobian(&self, x: f64, y: f64) -> (f64, f64, Matrix2<f64>) {
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3));
        let d_radial = self.k1 + r2 * (2.0 * self.k2 + 3.0 * self.k3 * r2);
        let (xd, yd) = self.distort(x, y);
        let off = 2.0 * x * y * d_radial + 2.0 * self.p1 * x + 2.0 * self.p2 * y;
        let j = Matrix2::new(
            radial + 2.0 * x * x * d_radial + 2.0 * self.p1 * y + 6.0 * self.p2 * x,
            off,
            off,
            radial + 2.0 * y * y * d_radial + 6.0 * self.p1 * y + 2.0 * self.p2 * x,
        );
        (xd, yd, j)
    }

    /// Projects a point given in camera coordinates to a (distorted) pixel.
    ///
    /// Returns `None` when the point is not in front of the camera (`Z <= 0`) or not finite.
    /// The pixel is not clipped to the image; see [`CameraModel::contains`].
    #[must_use]
    pub fn project(&self, p_in_camera: &Point3<f64>) -> Option<Point2<f64>> {
        if p_in_camera.z <= 0.0 || !p_in_camera.coords.iter().all(|c| c.is_finite()) {
            return None;
        }
        let xn = Point2::new(p_in_camera.x / p_in_camera.z, p_in_camera.y / p_in_camera.z);
        Some(self.pixel_from_normalised(&xn))
    }

    /// Distorts normalised coordinates and applies the intrinsics.
    #[must_use]
    pub fn pixel_from_normalised(&self, x: &Point2<f64>) -> Point2<f64> {
        let (xd, yd) = self.distort(x.x, x.y);
        Point2::new(self.fx * xd + self.cx, self.fy * yd + self.cy)
    }

    /// Whether a pixel lies inside the image (`0 <= u < width`, `0 <= v < height`).
    #[must_use]
    pub fn contains(&self, px: &Point2<f64>) -> bool {
        px.x >= 0.0 && px.y >= 0.0 && px.x < f64::from(self.width) && px.y < f64::from(self.height)
    }

    /// Distorted normalised coordinates `((u - cx) / fx, (v - cy) / fy)` of a pixel.
    ///
    /// # Errors
    /// [`CameraError::NonFinite`] for a non-finite pixel, [`CameraError::InvalidParameter`]
    /// for a zero or non-finite focal length.
    fn distorted_normalised(&self, px: &Point2<f64>) -> Result<Point2<f64>, CameraError> {
        if !(px.x.is_finite() && px.y.is_finite()) {
            return Err(CameraError::NonFinite { index: 0 });
        }
        for (name, value) in [("fx", self.fx), ("fy", self.fy)] {
            if !(value.is_finite() && value != 0.0) {
                return Err(CameraError::InvalidParameter { name, value });
            }
        }
        Ok(Point2::new(
            (px.x - self.cx) / self.fx,
            (px.y - self.cy) / self.fy,
        ))
    }

    /// Undistorts a pixel to normalised coordinates `(X/Z, Y/Z)`.
    ///
    /// # Errors
    /// [`CameraError::NonFinite`] for a non-finite pixel, [`CameraError::InvalidParameter`]
    /// for a zero focal length, [`CameraError::UndistortNotConverged`] when Newton's method
    /// does not reach [`UNDISTORT_TOLERANCE`], [`CameraError::UndistortOutOfDomain`] when
    /// the only root found is beyond the fold of the distortion (no physical preimage).
    pub fn undistort_pixel(&self, px: &Point2<f64>) -> Result<Point2<f64>, CameraError> {
        let xd = self.distorted_normalised(px)?;
        self.undistort_normalised(&xd).map_err(|e| at_pixel(e, px))
    }

    /// As [`CameraModel::undistort_pixel`], with Newton started from `guess` (normalised
    /// coordinates, e.g. the neighbouring pixel's solution when undistorting a whole image).
    ///
    /// # Errors
    /// As [`CameraModel::undistort_pixel`].
    pub fn undistort_pixel_from(
        &self,
        px: &Point2<f64>,
        guess: &Point2<f64>,
    ) -> Result<Point2<f64>, CameraError> {
        let xd = self.distorted_normalised(px)?;
        self.newton(&xd, guess.coords).map_err(|e| at_pixel(e, px))
    }

    /// Undistorts a batch of pixels ([`CameraModel::undistort_pixel`] on each).
    ///
    /// # Errors
    /// As [`CameraModel::undistort_pixel`]; [`CameraError::NonFinite`] carries the index of
    /// the offending pixel.
    pub fn undistort_pixels(&self, px: &[Point2<f64>]) -> Result<Vec<Point2<f64>>, CameraError> {
        px.iter()
            .enumerate()
            .map(|(index, p)| {
                self.undistort_pixel(p).map_err(|e| match e {
                    CameraError::NonFinite { .. } => CameraError::NonFinite { index },
                    other => other,
                })
            })
            .collect()
    }

    /// Inverts the distortion map on normalised coordinates by Newton's method, started at
    /// `xd` itself.
    ///
    /// # Errors
    /// [`CameraError::UndistortNotConverged`] when the residual stays above
    /// [`UNDISTORT_TOLERANCE`] (singular Jacobian or divergence),
    /// [`CameraError::UndistortOutOfDomain`] for a root on the non-physical branch.
    pub fn undistort_normalised(&self, xd: &Point2<f64>) -> Result<Point2<f64>, CameraError> {
        self.newton(xd, xd.coords)
    }

    /// Newton's method on `distort(x) = xd` from `start`, stopping at rounding level.
    fn newton(&self, xd: &Point2<f64>, start: Vector2<f64>) -> Result<Point2<f64>, CameraError> {
        let target = xd.coords;
        let mut x = start;
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
        let (dx, dy) = self.distort(x.x, x.y);
        let final_residual = (Vector2::new(dx, dy) - target).norm();
        if final_residual <= UNDISTORT_TOLERANCE {
            return self.check_branch(xd, x);
        }
        Err(CameraError::UndistortNotConverged {
            u: xd.x,
            v: xd.y,
            residual: final_residual,
            iterations: UNDISTORT_MAX_ITERATIONS,
        })
    }

    /// Accepts a root of the distortion equation only on the physical branch: positive radial
    /// factor and orientation-preserving Jacobian (the distortion map is locally invertible
    /// there); a root beyond the fold of a strong barrel distortion is refused.
    fn check_branch(&self, xd: &Point2<f64>, x: Vector2<f64>) -> Result<Point2<f64>, CameraError> {
        let r2 = x.norm_squared();
        let radial = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3));
        let (_, _, j) = self.distort_with_jacobian(x.x, x.y);
        let det = j.determinant();
        if radial > 0.0 && det > 0.0 {
            Ok(Point2::from(x))
        } else {
            Err(CameraError::UndistortOutOfDomain {
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
    /// As [`CameraModel::undistort_pixel`]; [`CameraError::InvalidParameter`] for a
    /// non-finite or non-positive depth.
    pub fn backproject(&self, px: &Point2<f64>, depth_m: f64) -> Result<Point3<f64>, CameraError> {
        if !(depth_m.is_finite() && depth_m > 0.0) {
            return Err(CameraError::InvalidParameter {
                name: "depth_m",
                value: depth_m,
            });
        }
        let x = self.undistort_pixel(px)?;
        Ok(Point3::new(x.x * depth_m, x.y * depth_m, depth_m))
    }
}

/// An undistortion error of normalised coordinates, restated at the pixel it came from.
fn at_pixel(e: CameraError, px: &Point2<f64>) -> CameraError {
    match e {
        CameraError::UndistortNotConverged {
            residual,
            iterations,
            ..
        } => CameraError::UndistortNotConverged {
            u: px.x,
            v: px.y,
            residual,
            iterations,
        },
        CameraError::UndistortOutOfDomain {
            radial_factor,
            jacobian_det,
            ..
        } => CameraError::UndistortOutOfDomain {
            u: px.x,
            v: px.y,
            radial_factor,
            jacobian_det,
        },
        other => other,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera() -> CameraModel {
        CameraModel::pinhole(1280, 1024, 1745.0, 1745.0, 640.0, 512.0)
            .with_distortion([-0.08, 0.12, 4e-4, -3e-4, -0.05])
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

    /// Every pixel of the image, corners included, undistorts and projects back to itself,
    /// from scratch and from a neighbour's solution alike.
    #[test]
    fn undistort_inverts_distort_over_the_image() -> Result<(), CameraError> {
        let cam = camera();
        let mut guess = cam.undistort_pixel(&Point2::new(0.0, 0.0))?;
        for (u, v) in [
            (0.0, 0.0),
            (1279.0, 0.0),
            (0.0, 1023.0),
            (1279.0, 1023.0),
            (5.5, 700.2),
        ] {
            let px = Point2::new(u, v);
            let x = cam.undistort_pixel(&px)?;
            let back = cam.pixel_from_normalised(&x);
            assert!((back - px).norm() < 1e-9, "{back} vs {px}");
            guess = cam.undistort_pixel_from(&px, &guess)?;
            assert!((guess - x).norm() < 1e-13);
        }
        Ok(())
    }

    #[test]
    fn camera_info_round_trips_and_bad_infos_are_named() {
        let cam = camera();
        let info = cam.to_camera_info(Header::default());
        assert_eq!(CameraModel::from_camera_info(&info), Ok(cam));
        let reason = |info: &CameraInfo| match CameraModel::from_camera_info(info) {
            Err(CameraError::BadCameraInfo { reason }) => reason,
            other => panic!("{other:?}"),
        };
        let mut skewed = info.clone();
        skewed.k[1] = 0.5;
        assert!(reason(&skewed).contains("skew"));
        let mut fisheye = info.clone();
        fisheye.distortion_model = "equidistant".to_owned();
        assert!(reason(&fisheye).contains("equidistant"));
        let mut zero_f = info.clone();
        zero_f.k[0] = 0.0;
        assert!(reason(&zero_f).contains("fx = 0"));
        let mut rational = info.clone();
        rational.distortion_model = "rational_polynomial".to_owned();
        rational.d.extend([0.0, 0.0, 0.0]);
        assert_eq!(CameraModel::from_camera_info(&rational), Ok(cam));
        rational.d[6] = 0.01;
        assert!(reason(&rational).contains("only plumb_bob"));
        let mut pinhole = info;
        pinhole.distortion_model = String::new();
        pinhole.d.clear();
        assert_eq!(
            CameraModel::from_camera_info(&pinhole),
            Ok(cam.with_distortion([0.0; 5]))
        );
    }

    #[test]
    fn scaled_keeps_the_field_of_view() -> Result<(), CameraError> {
        let c = camera();
        let s = c.scaled(0.25)?;
        assert_eq!((s.width, s.height), (320, 256));
        // The image corner sees the same normalised direction.
        let a = c.undistort_pixel(&Point2::new(-0.5, -0.5))?;
        let b = s.undistort_pixel(&Point2::new(-0.5, -0.5))?;
        assert!((a - b).norm() < 1e-12);
        assert!(c.scaled(0.0).is_err());
        Ok(())
    }

    #[test]
    fn bad_inputs_are_errors() {
        let cam = camera();
        assert!(cam.project(&Point3::new(0.1, 0.1, -0.5)).is_none());
        assert!(cam.project(&Point3::new(f64::NAN, 0.1, 0.5)).is_none());
        assert_eq!(
            cam.undistort_pixels(&[Point2::new(3.0, 4.0), Point2::new(f64::NAN, 4.0)]),
            Err(CameraError::NonFinite { index: 1 })
        );
        assert!(matches!(
            cam.backproject(&Point2::new(10.0, 3.0), -1.0),
            Err(CameraError::InvalidParameter {
                name: "depth_m",
                ..
            })
        ));
        let mut broken = cam;
        broken.fy = f64::NAN;
        assert!(matches!(
            broken.validate(),
            Err(CameraError::InvalidParameter { name: "fy", .. })
        ));
    }
}
