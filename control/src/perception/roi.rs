//! Regions of interest: where in the wrist image to look, which points to keep, and where to
//! put the wrist camera so the wire fills its view.
//!
//! The panoramic camera gives a coarse wire estimate (a segment in `base_link`, a few cm off);
//! [`wrist_look_pose`] turns it into a camera pose at the working distance looking at the wire;
//! after the capture, [`PixelRoi::around_segment`] projects the same prior into the wrist
//! image (bounding box plus margin, depth window around it) and [`extract_roi`] keeps the
//! valid points inside, subsampled on a pixel grid. The ROI only bounds the search: the wire
//! itself is then found geometrically ([`super::cylinder`]), which replaces the paper's LA-Net.

use super::PerceptionError;
use super::point_cloud::{CameraModel, DepthImage, RayTable};
use nalgebra::{Isometry3, Point3, Rotation3, Translation3, UnitQuaternion, Vector3};

/// A pixel rectangle `[u_min, u_max) x [v_min, v_max)` and a depth window `[z_min, z_max]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PixelRoi {
    /// First column.
    pub u_min: usize,
    /// First row.
    pub v_min: usize,
    /// One past the last column.
    pub u_max: usize,
    /// One past the last row.
    pub v_max: usize,
    /// Nearest kept depth (m).
    pub z_min_m: f64,
    /// Farthest kept depth (m).
    pub z_max_m: f64,
}

impl PixelRoi {
    /// The whole image with a depth window.
    #[must_use]
    pub fn full(camera: &CameraModel, z_min_m: f64, z_max_m: f64) -> Self {
        Self {
            u_min: 0,
            v_min: 0,
            u_max: camera.width as usize,
            v_max: camera.height as usize,
            z_min_m,
            z_max_m,
        }
    }

    /// Bounding box of the projection of the prior segment `p0..p1` (camera frame, sampled at
    /// 33 points, points behind the camera ignored) grown by `margin_px`, clamped to the image;
    /// depth window = the segment's depth range grown by `margin_m`.
    ///
    /// # Errors
    /// [`PerceptionError::Degenerate`] when no part of the segment projects into the image.
    pub fn around_segment(
        camera: &CameraModel,
        p0_in_camera: &Point3<f64>,
        p1_in_camera: &Point3<f64>,
        margin_px: f64,
        margin_m: f64,
    ) -> Result<Self, PerceptionError> {
        let (w, h) = (f64::from(camera.width), f64::from(camera.height));
        let (mut u0, mut v0, mut u1, mut v1) = (f64::MAX, f64::MAX, f64::MIN, f64::MIN);
        let (mut z0, mut z1) = (f64::MAX, f64::MIN);
        for k in 0..=32 {
            let p = p0_in_camera + (p1_in_camera - p0_in_camera) * (f64::from(k) / 32.0);
            let Some(px) = camera.project(&p) else {
                continue;
            };
            let (u, v) = (px.x, px.y);
            if !(u > -margin_px && u < w + margin_px && v > -margin_px && v < h + margin_px) {
                continue;
            }
            u0 = u0.min(u);
            v0 = v0.min(v);
            u1 = u1.max(u);
            v1 = v1.max(v);
            z0 = z0.min(p.z);
            z1 = z1.max(p.z);
        }
        if u0 > u1 {
            return Err(PerceptionError::Degenerate {
                what: "prior segment does not project into the image",
            });
        }
        let clamp = |x: f64, hi: f64| x.clamp(0.0, hi) as usize;
        Ok(Self {
            u_min: clamp((u0 - margin_px).floor(), w),
            v_min: clamp((v0 - margin_px).floor(), h),
            u_max: clamp((u1 + margin_px).ceil(), w),
            v_max: clamp((v1 + margin_px).ceil(), h),
            z_min_m: (z0 - margin_m).max(0.0),
            z_max_m: z1 + margin_m,
        })
    }

    /// The centre pixel `(u, v)`.
    #[must_use]
    pub fn centre_px(&self) -> (f64, f64) {
        (
            0.5 * (self.u_min + self.u_max) as f64,
            0.5 * (self.v_min + self.v_max) as f64,
        )
    }
}

/// Points of one ROI.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RoiCloud {
    /// Valid points inside the ROI (camera frame, m).
    pub points: Vec<Point3<f64>>,
    /// Their pixels `(u, v)`, same order.
    pub pixels: Vec<(u32, u32)>,
    /// Grid samples looked at (valid or not).
    pub samples: usize,
}

impl RoiCloud {
    /// Fraction of grid samples with valid depth inside the window.
    #[must_use]
    pub fn valid_fraction(&self) -> f64 {
        if self.samples == 0 {
            0.0
        } else {
            self.points.len() as f64 / self.samples as f64
        }
    }
}

/// Keeps the valid points of `roi` on a `stride_px` grid (1 = every pixel).
#[must_use]
pub fn extract_roi(
    depth: &DepthImage,
    rays: &RayTable,
    roi: &PixelRoi,
    stride_px: usize,
) -> RoiCloud {
    let stride = stride_px.max(1);
    let (u_max, v_max) = (roi.u_max.min(depth.width), roi.v_max.min(depth.height));
    let grid = u_max.saturating_sub(roi.u_min).div_ceil(stride)
        * v_max.saturating_sub(roi.v_min).div_ceil(stride);
    let mut out = RoiCloud {
        points: Vec::with_capacity(grid),
        pixels: Vec::with_capacity(grid),
        samples: 0,
    };
    for v in (roi.v_min..v_max).step_by(stride) {
        for u in (roi.u_min..u_max).step_by(stride) {
            out.samples += 1;
            if let Some(p) = depth.point(rays, u, v)
                && p.z >= roi.z_min_m
                && p.z <= roi.z_max_m
            {
                out.points.push(p);
                out.pixels.push((u as u32, v as u32));
            }
        }
    }
    out
}

/// Where the wrist camera should be to capture the wire: on the approach side, `standoff_m`
/// from the wire point along the approach normal, optical axis (z) pointing at the point, x
/// along the wire (so the wire crosses the image horizontally, its longest extent).
///
/// `approach_normal = normalize((robot - w) - ((robot - w)·a) a)` for wire point `w` and axis
/// `a`; camera origin `w + standoff n`; `z_cam = -n`, `x_cam = a` (sign: `x_cam · x_base >= 0`,
/// else `· y_base >= 0`), `y_cam = z_cam × x_cam`.
///
/// # Errors
/// [`PerceptionError::Degenerate`] for a zero axis or a robot point on the axis.
pub fn wrist_look_pose(
    wire_point_in_base: &Point3<f64>,
    wire_direction_in_base: &Vector3<f64>,
    robot_point_in_base: &Point3<f64>,
    standoff_m: f64,
) -> Result<Isometry3<f64>, PerceptionError> {
    let axis = wire_direction_in_base
        .try_normalize(1e-12)
        .ok_or(PerceptionError::Degenerate {
            what: "wire direction",
        })?;
    let to_robot = robot_point_in_base - wire_point_in_base;
    let normal = (to_robot - axis * to_robot.dot(&axis))
        .try_normalize(1e-9)
        .ok_or(PerceptionError::Degenerate {
            what: "robot point on the wire axis",
        })?;
    let x = canonical_axis_sign(axis);
    let z = -normal;
    let y = z.cross(&x);
    let rotation = Rotation3::from_basis_unchecked(&[x, y, z]);
    Ok(Isometry3::from_parts(
        Translation3::from(wire_point_in_base.coords + normal * standoff_m),
        UnitQuaternion::from_rotation_matrix(&rotation),
    ))
}

/// `a` or `-a`, whichever has `x >= 0` (or, when `x ≈ 0`, `y >= 0`, then `z >= 0`): a
/// deterministic sign for a line direction.
#[must_use]
pub fn canonical_axis_sign(a: Vector3<f64>) -> Vector3<f64> {
    let key = if a.x.abs() > 1e-9 {
        a.x
    } else if a.y.abs() > 1e-9 {
        a.y
    } else {
        a.z
    };
    if key < 0.0 { -a } else { a }
}
