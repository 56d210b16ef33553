//! The wire's hanging point: the point **on the fitted axis** nearest a requested location,
//! with the approach normal, in `base_link`.
//!
//! Why the axis: the camera sees only the camera-facing arc of the conductor (holes at
//! grazing angles), so the centroid of the visible points sits toward the camera by
//! `r sin θ / θ` for a visible half-arc `θ` (11 mm for r = 13.4 mm and θ = 60°), almost the
//! whole ±15 mm capture tolerance. The cylinder fit recovers the axis itself.
//!
//! Given the axis `(c, a)` in `base_link`, a requested location `q` (e.g. the ROI centre's
//! ray, or a span fraction from the panoramic prior) and a point `o` on the robot's side (the
//! camera origin at capture, or the arm base):
//! - hanging point `h = c + ((q - c)·a) a`;
//! - approach normal `n = normalize((o - h) - ((o - h)·a) a)`: from the axis toward the robot,
//!   perpendicular to the axis; the hook moves along `-n`;
//! - pose `base_from_hanging`: origin `h`, x = `a` with a deterministic sign
//!   ([`super::roi::canonical_axis_sign`]), z = `-n` (the approach direction), y = z × x.
//!
//! The conductor is a catenary, modelled as straight over the view: for a span with radius of
//! curvature `R` (e.g. 30 m span, 1 m sag: `R = L²/(8 sag) ≈ 112 m`) the deviation over the
//! ±0.18 m seen at 0.5 m is `0.18² / (2 R) ≈ 0.15 mm`, far below the tolerance.
//!
//! Several captures (3-5, the camera still) are fused by averaging the sign-aligned axis
//! directions and the axis points nearest `q`; their disagreement feeds the confidence
//! ([`super::confidence`]). A conductor swinging in the wind (and a robot tilting in it)
//! moves between captures ([`super::sway`]): then their positions are the sway's track,
//! returned with the estimate for the task to bound, and only their directions must agree.

use super::PerceptionError;
use super::colour::{LumaImage, axis_extent, limb_contrast};
use super::confidence::{Confidence, ConfidenceThresholds, QualityMetrics, assess};
use super::cylinder::{Cylinder, CylinderFit, RansacParams, fit_cylinder};
use super::point_cloud::{CameraModel, DepthImage, RayTable};
use super::roi::{PixelRoi, canonical_axis_sign, extract_roi};
use super::sway::{SwayTrack, track_sway};
use msgs::geometry_msgs::PoseStamped;
use msgs::std_msgs::Header;
use nalgebra::{Isometry3, Point3, Rotation3, Translation3, UnitQuaternion, Vector3};

/// Width of the band around the surface whose points count as "near the wire" for the
/// support ratio (m): points with axis distance `< r + 5 mm`.
pub const SUPPORT_BAND_M: f64 = 0.005;

/// Tolerance between a pixel's measured depth and the fitted cylinder's predicted depth for
/// the pixel to count as valid in [`WireObservation::valid_depth_fraction`] (m).
pub const SILHOUETTE_DEPTH_TOLERANCE_M: f64 = 0.003;

/// Fraction of ROI grid pixels inside the fitted cylinder's silhouette with a depth near the
/// predicted front surface (ray `d = (x_n, y_n, 1)`, nearest root of
/// `|d⊥ t - c⊥|² = r²`, the ray parameter being the depth).
#[must_use]
pub fn silhouette_valid_fraction(
    depth: &DepthImage,
    rays: &RayTable,
    roi: &PixelRoi,
    stride_px: usize,
    cylinder: &Cylinder,
) -> f64 {
    let a = cylinder.direction;
    let w = -cylinder.point.coords;
    let wp = w - a * w.dot(&a);
    let qc = wp.norm_squared() - cylinder.radius_m * cylinder.radius_m;
    let (mut inside, mut valid) = (0usize, 0usize);
    let (u_max, v_max) = (roi.u_max.min(depth.width), roi.v_max.min(depth.height));
    for v in (roi.v_min..v_max).step_by(stride_px.max(1)) {
        for u in (roi.u_min..u_max).step_by(stride_px.max(1)) {
            let Some([x, y]) = rays.ray(u, v) else {
                continue;
            };
            let d = Vector3::new(x, y, 1.0);
            let dp = d - a * d.dot(&a);
            let (qa, qb) = (dp.norm_squared(), 2.0 * dp.dot(&wp));
            let disc = qb * qb - 4.0 * qa * qc;
            if qa <= 0.0 || disc < 0.0 {
                continue;
            }
            let t = (-qb - disc.sqrt()) / (2.0 * qa);
            if t <= 0.0 {
                continue;
            }
            inside += 1;
            if depth
                .at(u, v)
                .is_some_and(|z| (z - t).abs() < SILHOUETTE_DEPTH_TOLERANCE_M)
            {
                valid += 1;
            }
        }
    }
    if inside == 0 {
        0.0
    } else {
        valid as f64 / inside as f64
    }
}

/// Settings of wire detection in one capture.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WireParams {
    /// Cylinder RANSAC/LM settings (radius = the conductor's).
    pub ransac: RansacParams,
    /// ROI sampling grid (px). Default 2 (a quarter of the pixels: ~30k wire points at 0.5 m).
    pub stride_px: usize,
}

impl Default for WireParams {
    fn default() -> Self {
        Self {
            ransac: RansacParams::default(),
            stride_px: 2,
        }
    }
}

/// The wire as seen in one capture (camera frame).
#[derive(Debug, Clone, PartialEq)]
pub struct WireObservation {
    /// The cylinder fit.
    pub fit: CylinderFit,
    /// Inliers / points within `r + SUPPORT_BAND_M` of the axis.
    pub support_ratio: f64,
    /// Fraction of the ROI grid pixels whose ray meets the fitted cylinder that have a depth
    /// within [`SILHOUETTE_DEPTH_TOLERANCE_M`] of the predicted surface (depth and feature
    /// validity: low under sun wash-out, occlusion, or a wrong fit). About `sin 65° ≈ 0.9` for
    /// a clean capture, since grazing edges are always missing.
    pub valid_depth_fraction: f64,
    /// Inlier points (camera frame), for `/perception/roi_cloud`.
    pub inlier_points: Vec<Point3<f64>>,
    /// Silhouette contrast in the registered colour image ([`super::colour`]), set by
    /// [`WireObservation::confirm_in_colour`]; `None` when no colour image was given, 0 when
    /// one was given and the silhouette could not be measured in it.
    pub colour_contrast: Option<f64>,
}

impl WireObservation {
    /// This capture's quality (one capture: no agreement terms).
    #[must_use]
    pub fn metrics(&self, radius_m: f64) -> QualityMetrics {
        QualityMetrics {
            support_ratio: self.support_ratio,
            rms_residual_m: self.fit.rms_residual_m,
            radius_error_m: (self.fit.free_radius_m - radius_m).abs(),
            inlier_count: self.fit.inliers.len(),
            valid_depth_fraction: self.valid_depth_fraction,
            captures: 1,
            agreement_offset_m: 0.0,
            agreement_angle_rad: 0.0,
            colour_contrast: self.colour_contrast,
        }
    }

    /// Measures how well `colour` (registered to the depth image, model `camera`) shows the
    /// fitted silhouette over the inliers' extent ([`super::colour::limb_contrast`]).
    #[must_use]
    pub fn confirm_in_colour(mut self, colour: &LumaImage, camera: &CameraModel) -> Self {
        let cylinder = &self.fit.cylinder;
        let contrast = axis_extent(cylinder, &self.inlier_points)
            .and_then(|extent| limb_contrast(colour, camera, cylinder, extent))
            .map_or(0.0, |c| c.contrast);
        self.colour_contrast = Some(contrast);
        self
    }
}

/// Finds the wire in one depth capture inside `roi`.
///
/// # Errors
/// Those of [`fit_cylinder`].
pub fn detect_wire(
    depth: &DepthImage,
    rays: &RayTable,
    fx: f64,
    roi: &PixelRoi,
    params: &WireParams,
) -> Result<WireObservation, PerceptionError> {
    let cloud = extract_roi(depth, rays, roi, params.stride_px);
    let normal_of = |k: usize| {
        let (u, v) = *cloud.pixels.get(k)?;
        depth.normal(rays, fx, u as usize, v as usize)
    };
    let fit = fit_cylinder(&cloud.points, normal_of, &params.ransac)?;
    let band = fit.cylinder.radius_m + SUPPORT_BAND_M;
    let near = cloud
        .points
        .iter()
        .filter(|p| fit.cylinder.axis_distance(p) < band)
        .count();
    let support_ratio = fit.inliers.len() as f64 / near.max(1) as f64;
    let valid_depth_fraction =
        silhouette_valid_fraction(depth, rays, roi, params.stride_px, &fit.cylinder);
    let inlier_points = fit
        .inliers
        .iter()
        .filter_map(|&k| cloud.points.get(k))
        .copied()
        .collect();
    Ok(WireObservation {
        support_ratio,
        valid_depth_fraction,
        inlier_points,
        fit,
        colour_contrast: None,
    })
}

/// A hanging point with its approach geometry (frame of the inputs, normally `base_link`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HangingPoint {
    /// The point on the axis.
    pub point: Point3<f64>,
    /// Unit axis direction (canonical sign).
    pub axis: Vector3<f64>,
    /// Unit approach normal: from the axis toward the robot, perpendicular to the axis.
    pub approach_normal: Vector3<f64>,
    /// `frame_from_hanging`: origin at the point, x = axis, z = `-approach_normal`.
    pub frame_from_hanging: Isometry3<f64>,
}

/// The hanging point on `cylinder`'s axis nearest `near`, approached from `robot_point`
/// (module docs).
///
/// # Errors
/// [`PerceptionError::Degenerate`] when `robot_point` lies on the axis or inputs are not
/// finite.
pub fn hanging_point(
    cylinder: &Cylinder,
    near: &Point3<f64>,
    robot_point: &Point3<f64>,
) -> Result<HangingPoint, PerceptionError> {
    let axis = cylinder
        .direction
        .try_normalize(1e-12)
        .map(canonical_axis_sign)
        .ok_or(PerceptionError::Degenerate {
            what: "axis direction",
        })?;
    let point = cylinder.point + axis * (near - cylinder.point).dot(&axis);
    let to_robot = robot_point - point;
    let approach_normal = (to_robot - axis * to_robot.dot(&axis))
        .try_normalize(1e-9)
        .ok_or(PerceptionError::Degenerate {
            what: "robot point on the wire axis",
        })?;
    if !point.coords.iter().all(|c| c.is_finite()) {
        return Err(PerceptionError::Degenerate {
            what: "non-finite hanging point",
        });
    }
    let z = -approach_normal;
    let y = z.cross(&axis);
    let rotation = Rotation3::from_basis_unchecked(&[axis, y, z]);
    Ok(HangingPoint {
        point,
        axis,
        approach_normal,
        frame_from_hanging: Isometry3::from_parts(
            Translation3::from(point.coords),
            UnitQuaternion::from_rotation_matrix(&rotation),
        ),
    })
}

/// The point of the axis nearest the ray `origin + t direction` (e.g. the ray of the ROI
/// centre pixel, whose origin is the camera): for the axis `c + s a` and the ray, with
/// `w = c - o`, `b = a·d`, `s = (b (d·w) - (d·d)(a·w)) / ((a·a)(d·d) - b²)`.
///
/// # Errors
/// [`PerceptionError::Degenerate`] when the ray is parallel to the axis or zero.
pub fn axis_point_nearest_ray(
    cylinder: &Cylinder,
    origin: &Point3<f64>,
    direction: &Vector3<f64>,
) -> Result<Point3<f64>, PerceptionError> {
    let a = cylinder.direction;
    let d = *direction;
    let w = cylinder.point - origin;
    let b = a.dot(&d);
    let denom = a.norm_squared() * d.norm_squared() - b * b;
    if denom.is_nan() || denom <= 1e-12 * a.norm_squared() * d.norm_squared() {
        return Err(PerceptionError::Degenerate {
            what: "ray parallel to the axis",
        });
    }
    let s = (b * d.dot(&w) - d.norm_squared() * a.dot(&w)) / denom;
    Ok(cylinder.point + a * s)
}

/// `cylinder` expressed in another frame: `a_from_b * cylinder_in_b`.
#[must_use]
pub fn transform_cylinder(a_from_b: &Isometry3<f64>, cylinder: &Cylinder) -> Cylinder {
    Cylinder {
        point: a_from_b * cylinder.point,
        direction: a_from_b.rotation * cylinder.direction,
        radius_m: cylinder.radius_m,
    }
}

/// The fused wire estimate of 2-3 captures, in `base_link`.
#[derive(Debug, Clone, PartialEq)]
pub struct WireEstimate {
    /// The fused axis.
    pub axis_in_base: Cylinder,
    /// The hanging point on it.
    pub hanging: HangingPoint,
    /// Worst-case quality over the captures plus their agreement.
    pub metrics: QualityMetrics,
    /// The score (already checked against the threshold).
    pub confidence: Confidence,
    /// The wire's swing across the captures.
    pub sway: SwayTrack,
}

/// Fuses observations (each with its `base_from_camera` at capture), picks the hanging point
/// nearest `near_in_base`, approached from `robot_point_in_base`, and refuses when the
/// confidence is below `thresholds.min_score`.
///
/// # Errors
/// [`PerceptionError::NoCaptures`], [`PerceptionError::Degenerate`],
/// [`PerceptionError::LowConfidence`].
pub fn estimate_wire(
    observations: &[(WireObservation, Isometry3<f64>)],
    near_in_base: &Point3<f64>,
    robot_point_in_base: &Point3<f64>,
    radius_m: f64,
    thresholds: &ConfidenceThresholds,
) -> Result<WireEstimate, PerceptionError> {
    let Some((first, _)) = observations.first() else {
        return Err(PerceptionError::NoCaptures);
    };
    let axes: Vec<Cylinder> = observations
        .iter()
        .map(|(o, base_from_camera)| transform_cylinder(base_from_camera, &o.fit.cylinder))
        .collect();
    let mut metrics = first.metrics(radius_m);
    for (o, _) in observations.iter().skip(1) {
        let m = o.metrics(radius_m);
        metrics.support_ratio = metrics.support_ratio.min(m.support_ratio);
        metrics.rms_residual_m = metrics.rms_residual_m.max(m.rms_residual_m);
        metrics.radius_error_m = metrics.radius_error_m.max(m.radius_error_m);
        metrics.inlier_count = metrics.inlier_count.min(m.inlier_count);
        metrics.valid_depth_fraction = metrics.valid_depth_fraction.min(m.valid_depth_fraction);
        metrics.colour_contrast = match (metrics.colour_contrast, m.colour_contrast) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        };
    }
    metrics.captures = observations.len();
    let sway = track_sway(&axes, near_in_base).ok_or(PerceptionError::Degenerate {
        what: "vertical wire axis",
    })?;
    for (i, a) in axes.iter().enumerate() {
        for b in axes.iter().skip(i + 1) {
            // Captures of a swinging wire disagree in position by the sway, which `sway`
            // tracks and the task bounds; only captures of a still one are held to agree.
            if !sway.is_swaying() {
                metrics.agreement_offset_m = metrics
                    .agreement_offset_m
                    .max(a.axis_offset_near(b, near_in_base));
            }
            metrics.agreement_angle_rad = metrics.agreement_angle_rad.max(a.axis_angle_to(b));
        }
    }
    let reference = axes.first().map_or(Vector3::x(), |a| a.direction);
    let mut direction_sum = Vector3::zeros();
    let mut point_sum = Vector3::zeros();
    for a in &axes {
        let sign = if a.direction.dot(&reference) < 0.0 {
            -1.0
        } else {
            1.0
        };
        direction_sum += a.direction * sign;
        point_sum += a.axis_point_nearest(near_in_base).coords;
    }
    let axis_in_base = Cylinder {
        point: Point3::from(point_sum / axes.len() as f64),
        direction: direction_sum
            .try_normalize(1e-12)
            .ok_or(PerceptionError::Degenerate { what: "fused axis" })?,
        radius_m,
    };
    let confidence = assess(&metrics, thresholds);
    confidence.require(thresholds.min_score)?;
    let hanging = hanging_point(&axis_in_base, near_in_base, robot_point_in_base)?;
    Ok(WireEstimate {
        axis_in_base,
        hanging,
        metrics,
        confidence,
        sway,
    })
}

/// `geometry_msgs/PoseStamped` of a pose (for `/perception/target_pose`).
#[must_use]
pub fn to_pose_stamped(frame_from_target: &Isometry3<f64>, header: Header) -> PoseStamped {
    PoseStamped {
        header,
        pose: robot::conversions::pose_msg(frame_from_target),
    }
}
