//! Depth image -> 3D points with plumb_bob undistortion; surface normals from the organised
//! image; `sensor_msgs/PointCloud2` output.
//!
//! # Camera model
//! The one camera model of `robot::camera` ([`CameraModel`], pinhole + plumb_bob, from
//! `CameraInfo`). Undistortion is solved once per camera and cached in a [`RayTable`] (one
//! normalised ray per pixel), so a capture costs one multiply per pixel:
//! `p = z (x_n, y_n, 1)` with `z` the depth-image value (z, not range).
//!
//! # Normals
//! At a pixel, the normal is the smallest-eigenvalue eigenvector of the covariance of the
//! valid points in a `(2h+1)²` window (PCA plane fit), oriented toward the camera
//! (`n · p < 0`); `h` adapts to depth so the window spans about
//! [`NORMAL_WINDOW_M`] on the surface. Degenerate windows (fewer than [`NORMAL_MIN_POINTS`]
//! points, or a plane-fit eigenvalue ratio showing a line) yield no normal.

use super::PerceptionError;
use msgs::sensor_msgs::{Image, PointCloud2, PointField};
use msgs::std_msgs::Header;
use nalgebra::{Matrix3, Point2, Point3, SymmetricEigen, Vector3};
pub use robot::camera::CameraModel;

/// Physical half-size of the normal window on the surface (m): 2.5 mm.
pub const NORMAL_WINDOW_M: f64 = 0.0025;
/// Minimum valid points in a normal window.
pub const NORMAL_MIN_POINTS: usize = 6;

/// The wrist camera's nominal intrinsics (ARCHITECTURE.md section 6): 1280x1024,
/// fx = fy = 1745 px, centred, small distortion `k1 = -0.05, k2 = 0.02, p1 = 0.0005,
/// p2 = -0.0003, k3 = 0`.
#[must_use]
pub fn wrist_nominal() -> CameraModel {
    CameraModel::pinhole(1280, 1024, 1745.0, 1745.0, 639.5, 511.5)
        .with_distortion([-0.05, 0.02, 0.0005, -0.0003, 0.0])
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
    /// Undistorts every pixel centre of `camera` (Newton from the left neighbour's solution).
    ///
    /// # Errors
    /// [`PerceptionError::Camera`] when the camera is unusable or its distortion cannot be
    /// inverted at a pixel.
    pub fn new(camera: &CameraModel) -> Result<Self, PerceptionError> {
        camera.validate()?;
        let (width, height) = (camera.width as usize, camera.height as usize);
        let mut rays = Vec::with_capacity(width * height);
        for v in 0..height {
            let mut guess = camera.undistort_pixel(&Point2::new(0.0, v as f64))?;
            for u in 0..width {
                guess = camera.undistort_pixel_from(&Point2::new(u as f64, v as f64), &guess)?;
                rays.push([guess.x, guess.y]);
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
    fn ray_table_rays_project_back_to_their_pixels() -> Result<(), PerceptionError> {
        let cam = wrist_nominal().scaled(0.1)?;
        let table = RayTable::new(&cam)?;
        for (u, v) in [(0, 0), (127, 0), (0, 101), (127, 101), (60, 40)] {
            let [x, y] = table.ray(u, v).ok_or(PerceptionError::Camera(
                robot::camera::CameraError::NonFinite { index: u },
            ))?;
            let px = cam.pixel_from_normalised(&Point2::new(x, y));
            assert!(
                (px - Point2::new(u as f64, v as f64)).norm() < 1e-9,
                "{u} {v} -> {px}"
            );
        }
        assert_eq!(table.ray(128, 0), None);
        Ok(())
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
