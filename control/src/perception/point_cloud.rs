//! Depth image -> 3D points with plumb_bob undistortion; surface normals from the organised
//! image; `sensor_msgs/PointCloud2` output.
//!
//! # Camera model (plumb_bob = OpenCV's 5-parameter Brown-Conrady)
//! A point `(X, Y, Z)` in the optical frame projects to normalised `x = X/Z, y = Y/Z`,
//! `r² = x² + y²`, then
//! `x_d = x (1 + k1 r² + k2 r⁴ + k3 r⁶) + 2 p1 x y + p2 (r² + 2 x²)`,
//! `y_d = y (1 + k1 r² + k2 r⁴ + k3 r⁶) + p1 (r² + 2 y²) + 2 p2 x y`,
//! `u = fx x_d + cx`, `v = fy y_d + cy` (ROS `CameraInfo.D = [k1, k2, p1, p2, k3]`,
//! `K = [fx 0 cx; 0 fy cy; 0 0 1]`). Undistortion inverts this per pixel by the fixed-point
//! iteration OpenCV's `undistortPoints` uses (`x <- (x_d - tangential(x)) / radial(x)`),
//! converging for the small distortion of the wrist camera; the result is cached in a
//! [`RayTable`] (one normalised ray per pixel), so a capture costs one multiply per pixel:
//! `p = z (x_n, y_n, 1)` with `z` the depth-image value (z, not range).
//!
//! # Normals
//! At a pixel, the normal is the smallest-eigenvalue eigenvector of the covariance of the
//! valid points in a `(2h+1)²` window (PCA plane fit), oriented toward the camera
//! (`n · p < 0`); `h` adapts to depth so the window spans about
//! [`NORMAL_WINDOW_M`] on the surface. Degenerate windows (fewer than [`NORMAL_MIN_POINTS`]
//! points, or a plane-fit eigenvalue ratio showing a line) yield no normal.

use super::PerceptionError;
use msgs::sensor_msgs::{CameraInfo, Image, PointCloud2, PointField};
use msgs::std_msgs::Header;
use nalgebra::{Matrix3, Point3, SymmetricEigen, Vector3};

/// Fixed-point iterations of the undistortion (OpenCV uses 5 by default; 10 reaches 1e-10 px
/// for |k1| < 0.2 at the image corners).
pub const UNDISTORT_ITERATIONS: usize = 10;
/// Physical half-size of the normal window on the surface (m): 2.5 mm.
pub const NORMAL_WINDOW_M: f64 = 0.0025;
/// Minimum valid points in a normal window.
pub const NORMAL_MIN_POINTS: usize = 6;

/// Pinhole camera with plumb_bob distortion.
#[derive(Debug, Clone, PartialEq)]
pub struct PinholeCamera {
    /// Image width (px).
    pub width: u32,
    /// Image height (px).
    pub height: u32,
    /// Focal length x (px).
    pub fx: f64,
    /// Focal length y (px).
    pub fy: f64,
    /// Principal point x (px).
    pub cx: f64,
    /// Principal point y (px).
    pub cy: f64,
    /// `[k1, k2, p1, p2, k3]`.
    pub distortion: [f64; 5],
}

impl PinholeCamera {
    /// The wrist camera of ARCHITECTURE.md section 6: 1280x1024, fx = fy = 1745 px, centred, small
    /// distortion `k1 = -0.05, k2 = 0.02, p1 = 0.0005, p2 = -0.0003, k3 = 0`.
    #[must_use]
    pub fn wrist_nominal() -> Self {
        Self {
            width: 1280,
            height: 1024,
            fx: 1745.0,
            fy: 1745.0,
            cx: 639.5,
            cy: 511.5,
            distortion: [-0.05, 0.02, 0.0005, -0.0003, 0.0],
        }
    }

    /// From a `CameraInfo` (`plumb_bob`, or empty D = no distortion).
    ///
    /// # Errors
    /// [`PerceptionError::BadCamera`] for a zero size, non-positive or non-finite focal
    /// lengths, or another distortion model.
    pub fn from_camera_info(info: &CameraInfo) -> Result<Self, PerceptionError> {
        let [fx, _, cx, _, fy, cy, ..] = info.k;
        let bad = |reason| PerceptionError::BadCamera {
            reason,
            width: info.width,
            height: info.height,
            fx,
            fy,
        };
        let mut distortion = [0.0; 5];
        match info.distortion_model.as_str() {
            "plumb_bob" | "rational_polynomial" | "" => {
                if info.distortion_model == "rational_polynomial"
                    && info.d.iter().skip(5).any(|k| *k != 0.0)
                {
                    return Err(bad("rational_polynomial with k4..k6 != 0 is not supported"));
                }
                for (slot, value) in distortion.iter_mut().zip(&info.d) {
                    *slot = *value;
                }
            }
            _ => return Err(bad("unsupported distortion model")),
        }
        let camera = Self {
            width: info.width,
            height: info.height,
            fx,
            fy,
            cx,
            cy,
            distortion,
        };
        camera.validate()?;
        Ok(camera)
    }

    /// The `CameraInfo` of this camera (plumb_bob, R = I, P = [K | 0]).
    #[must_use]
    pub fn to_camera_info(&self, header: Header) -> CameraInfo {
        CameraInfo {
            header,
            height: self.height,
            width: self.width,
            distortion_model: "plumb_bob".to_owned(),
            d: self.distortion.to_vec(),
            k: [self.fx, 0.0, self.cx, 0.0, self.fy, self.cy, 0.0, 0.0, 1.0],
            r: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
            p: [
                self.fx, 0.0, self.cx, 0.0, 0.0, self.fy, self.cy, 0.0, 0.0, 0.0, 1.0, 0.0,
            ],
            ..CameraInfo::default()
        }
    }

    /// # Errors
    /// [`PerceptionError::BadCamera`] when unusable.
    fn validate(&self) -> Result<(), PerceptionError> {
        let bad = |reason| PerceptionError::BadCamera {
            reason,
            width: self.width,
            height: self.height,
            fx: self.fx,
            fy: self.fy,
        };
        if self.width == 0 || self.height == 0 {
            return Err(bad("zero image size"));
        }
        if !(self.fx > 0.0 && self.fy > 0.0 && self.fx.is_finite() && self.fy.is_finite()) {
            return Err(bad("focal lengths must be positive and finite"));
        }
        if !(self.cx.is_finite()
            && self.cy.is_finite()
            && self.distortion.iter().all(|k| k.is_finite()))
        {
            return Err(bad("non-finite principal point or distortion"));
        }
        Ok(())
    }

    /// Applies the plumb_bob distortion to normalised coordinates.
    #[must_use]
    pub fn distort(&self, x: f64, y: f64) -> (f64, f64) {
        let [k1, k2, p1, p2, k3] = self.distortion;
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
        (
            x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x),
            y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y,
        )
    }

    /// Normalised undistorted coordinates `(x, y)` of pixel `(u, v)` (fixed-point inversion,
    /// [`UNDISTORT_ITERATIONS`] steps).
    #[must_use]
    pub fn undistort_pixel(&self, u: f64, v: f64) -> (f64, f64) {
        let [k1, k2, p1, p2, k3] = self.distortion;
        let xd = (u - self.cx) / self.fx;
        let yd = (v - self.cy) / self.fy;
        let (mut x, mut y) = (xd, yd);
        for _ in 0..UNDISTORT_ITERATIONS {
            let r2 = x * x + y * y;
            let radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
            let dx = 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
            let dy = p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
            x = (xd - dx) / radial;
            y = (yd - dy) / radial;
        }
        (x, y)
    }

    /// Pixel `(u, v)` of a camera-frame point, `None` behind the camera (z <= 0).
    #[must_use]
    pub fn project(&self, p_in_camera: &Point3<f64>) -> Option<(f64, f64)> {
        if p_in_camera.z <= 0.0 {
            return None;
        }
        let (xd, yd) = self.distort(p_in_camera.x / p_in_camera.z, p_in_camera.y / p_in_camera.z);
        Some((self.fx * xd + self.cx, self.fy * yd + self.cy))
    }
}

/// The pixel rows of `image` (each `width * bytes_per_pixel` bytes), once its step and
/// buffer are checked to hold them; the reason otherwise.
pub(crate) fn image_rows(
    image: &Image,
    bytes_per_pixel: usize,
) -> Result<impl Iterator<Item = &[u8]>, &'static str> {
    let (width, height, step) = (
        image.width as usize,
        image.height as usize,
        image.step as usize,
    );
    let row_bytes = width * bytes_per_pixel;
    if step < row_bytes {
        return Err("step shorter than a row");
    }
    let needed = if height == 0 {
        0
    } else {
        step * (height - 1) + row_bytes
    };
    if image.data.len() < needed {
        return Err("data shorter than height * step");
    }
    Ok((0..height).filter_map(move |v| image.data.get(v * step..v * step + row_bytes)))
}

/// Per-pixel normalised rays `(x_n, y_n)` of a camera (row-major), computed once per camera.
#[derive(Debug, Clone, PartialEq)]
pub struct RayTable {
    width: usize,
    height: usize,
    rays: Vec<[f64; 2]>,
}

impl RayTable {
    /// Undistorts every pixel centre of `camera`.
    ///
    /// # Errors
    /// [`PerceptionError::BadCamera`] when the camera is unusable.
    pub fn new(camera: &PinholeCamera) -> Result<Self, PerceptionError> {
        camera.validate()?;
        let (width, height) = (camera.width as usize, camera.height as usize);
        let mut rays = Vec::with_capacity(width * height);
        for v in 0..height {
            for u in 0..width {
                let (x, y) = camera.undistort_pixel(u as f64, v as f64);
                rays.push([x, y]);
            }
        }
        Ok(Self {
            width,
            height,
            rays,
        })
    }

    /// Width (px).
    #[must_use]
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height (px).
    #[must_use]
    pub fn height(&self) -> usize {
        self.height
    }

    /// The normalised ray of pixel `(u, v)`, `None` outside the image.
    #[must_use]
    pub fn ray(&self, u: usize, v: usize) -> Option<[f64; 2]> {
        if u >= self.width {
            return None;
        }
        self.rays.get(v * self.width + u).copied()
    }
}

/// A depth image in metres (z coordinate), row-major; `0` or non-finite = no depth.
#[derive(Debug, Clone, PartialEq)]
pub struct DepthImage {
    /// Width (px).
    pub width: usize,
    /// Height (px).
    pub height: usize,
    /// `width * height` depths (m).
    pub depth_m: Vec<f32>,
}

impl DepthImage {
    /// From a `sensor_msgs/Image` with encoding `32FC1` (metres) or `16UC1` (millimetres),
    /// either endianness.
    ///
    /// # Errors
    /// [`PerceptionError::BadImage`] for another encoding or a short buffer.
    pub fn from_image(image: &Image) -> Result<Self, PerceptionError> {
        let bad = |reason| PerceptionError::bad_image("depth", image, reason);
        let (width, height) = (image.width as usize, image.height as usize);
        let bytes_per_pixel = match image.encoding.as_str() {
            "32FC1" => 4,
            "16UC1" | "mono16" => 2,
            _ => return Err(bad("encoding must be 32FC1 (m) or 16UC1 (mm)")),
        };
        let big = image.is_bigendian != 0;
        let mut depth_m = Vec::with_capacity(width * height);
        for row in image_rows(image, bytes_per_pixel).map_err(bad)? {
            if bytes_per_pixel == 4 {
                depth_m.extend(row.chunks_exact(4).map(|c| {
                    let b = [c[0], c[1], c[2], c[3]];
                    if big {
                        f32::from_be_bytes(b)
                    } else {
                        f32::from_le_bytes(b)
                    }
                }));
            } else {
                depth_m.extend(row.chunks_exact(2).map(|c| {
                    let b = [c[0], c[1]];
                    let mm = if big {
                        u16::from_be_bytes(b)
                    } else {
                        u16::from_le_bytes(b)
                    };
                    f32::from(mm) * 1e-3
                }));
            }
        }
        Ok(Self {
            width,
            height,
            depth_m,
        })
    }

    /// As a `32FC1` little-endian `Image` (metres).
    #[must_use]
    pub fn to_image(&self, header: Header) -> Image {
        let mut data = Vec::with_capacity(self.depth_m.len() * 4);
        for d in &self.depth_m {
            data.extend_from_slice(&d.to_le_bytes());
        }
        Image {
            header,
            height: self.height as u32,
            width: self.width as u32,
            encoding: "32FC1".to_owned(),
            is_bigendian: 0,
            step: (self.width * 4) as u32,
            data,
        }
    }

    /// Depth at `(u, v)` when valid (finite, > 0).
    #[must_use]
    pub fn at(&self, u: usize, v: usize) -> Option<f64> {
        if u >= self.width {
            return None;
        }
        let d = *self.depth_m.get(v * self.width + u)?;
        (d.is_finite() && d > 0.0).then_some(f64::from(d))
    }

    /// The camera-frame point of pixel `(u, v)`, `p = z (x_n, y_n, 1)`.
    #[must_use]
    pub fn point(&self, rays: &RayTable, u: usize, v: usize) -> Option<Point3<f64>> {
        let z = self.at(u, v)?;
        let [x, y] = rays.ray(u, v)?;
        Some(Point3::new(x * z, y * z, z))
    }

    /// Fraction of valid pixels in the rectangle `[u0, u1) x [v0, v1)` (clamped to the image).
    #[must_use]
    pub fn valid_fraction(&self, u0: usize, v0: usize, u1: usize, v1: usize) -> f64 {
        let (u1, v1) = (u1.min(self.width), v1.min(self.height));
        if u1 <= u0 || v1 <= v0 {
            return 0.0;
        }
        let mut valid = 0usize;
        for v in v0..v1 {
            for u in u0..u1 {
                if self.at(u, v).is_some() {
                    valid += 1;
                }
            }
        }
        valid as f64 / ((u1 - u0) * (v1 - v0)) as f64
    }

    /// Unit surface normal at `(u, v)` by PCA over a depth-adaptive window (module docs),
    /// oriented toward the camera; `None` when degenerate.
    #[must_use]
    pub fn normal(&self, rays: &RayTable, fx: f64, u: usize, v: usize) -> Option<Vector3<f64>> {
        let centre = self.point(rays, u, v)?;
        let half = ((NORMAL_WINDOW_M * fx / centre.z).round() as usize).clamp(2, 12);
        // Subsample large windows to at most 7x7 samples.
        let stride = (half / 3).max(1);
        let (u0, u1) = (u.saturating_sub(half), (u + half).min(self.width - 1));
        let (v0, v1) = (v.saturating_sub(half), (v + half).min(self.height - 1));
        let mut sum = Vector3::zeros();
        let mut sum_sq = Matrix3::zeros();
        let mut count = 0usize;
        let max_dz = 4.0 * NORMAL_WINDOW_M;
        let mut vv = v0;
        while vv <= v1 {
            let mut uu = u0;
            while uu <= u1 {
                if let Some(p) = self.point(rays, uu, vv)
                    && (p.z - centre.z).abs() < max_dz
                {
                    let d = p - centre;
                    sum += d;
                    sum_sq += d * d.transpose();
                    count += 1;
                }
                uu += stride;
            }
            vv += stride;
        }
        if count < NORMAL_MIN_POINTS {
            return None;
        }
        let n = count as f64;
        let mean = sum / n;
        let cov = sum_sq / n - mean * mean.transpose();
        let eig = SymmetricEigen::new(cov);
        let mut order = [0usize, 1, 2];
        order.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
        let (l0, l1) = (eig.eigenvalues[order[0]], eig.eigenvalues[order[1]]);
        if l1.is_nan() || l1 <= 0.0 || l0 > 0.5 * l1 {
            return None; // a line or a blob, not a surface patch
        }
        let mut normal: Vector3<f64> = eig.eigenvectors.column(order[0]).into_owned();
        if normal.dot(&centre.coords) > 0.0 {
            normal = -normal;
        }
        let norm = normal.norm();
        (norm > 0.0 && norm.is_finite()).then(|| normal / norm)
    }
}

/// Serialises points as an unorganised `PointCloud2` (`x, y, z` float32, little-endian,
/// `height = 1`, dense).
#[must_use]
pub fn to_point_cloud2(points: &[Point3<f64>], header: Header) -> PointCloud2 {
    let field = |name: &str, offset| PointField {
        name: name.to_owned(),
        offset,
        datatype: PointField::FLOAT32,
        count: 1,
    };
    let mut data = Vec::with_capacity(points.len() * 12);
    for p in points {
        for c in [p.x, p.y, p.z] {
            data.extend_from_slice(&(c as f32).to_le_bytes());
        }
    }
    PointCloud2 {
        header,
        height: 1,
        width: points.len() as u32,
        fields: vec![field("x", 0), field("y", 4), field("z", 8)],
        is_bigendian: false,
        point_step: 12,
        row_step: (points.len() * 12) as u32,
        data,
        is_dense: true,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn undistort_inverts_distort() {
        let cam = PinholeCamera::wrist_nominal();
        for &(x, y) in &[(0.0, 0.0), (0.35, -0.28), (-0.36, 0.29), (0.1, 0.2)] {
            let (xd, yd) = cam.distort(x, y);
            let (u, v) = (cam.fx * xd + cam.cx, cam.fy * yd + cam.cy);
            let (xu, yu) = cam.undistort_pixel(u, v);
            assert!(
                (xu - x).abs() < 1e-10 && (yu - y).abs() < 1e-10,
                "{x} {y} -> {xu} {yu}"
            );
        }
    }

    #[test]
    fn depth_16uc1_big_endian_and_bad_step() {
        let image = Image {
            height: 1,
            width: 2,
            encoding: "16UC1".into(),
            is_bigendian: 1,
            step: 4,
            data: vec![0x01, 0xF4, 0, 0],
            ..Image::default()
        };
        let depth = DepthImage::from_image(&image);
        assert!(
            matches!(&depth, Ok(d) if (d.depth_m[0] - 0.5).abs() < 1e-6 && d.at(1, 0).is_none())
        );
        let short = Image { step: 3, ..image };
        assert!(matches!(
            DepthImage::from_image(&short),
            Err(PerceptionError::BadImage {
                image: "depth",
                step: 3,
                ..
            })
        ));
    }
}
