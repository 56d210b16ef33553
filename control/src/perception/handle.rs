//! The rod's handle pose, for the remove flow.
//!
//! Handle model: the grip of the grounding rod is a straight cylindrical bar of known radius
//! [`HANDLE_RADIUS_M`] (21 mm) and length [`HANDLE_LENGTH_M`] (250 mm): the knurled rubber
//! handle of the rod ([`robot::grounding_rod`], the geometry the simulator renders). The whole
//! handle must be in view: 0.25 m fills the wrist camera's width (0.73 z) at z = 0.34 m,
//! so capture it from >= 0.4 m. It is fitted like the wire (RANSAC
//! cylinder of known radius + LM, [`super::cylinder`]); its extent along the axis is the 2nd-98th
//! percentile of the inliers' axial coordinates (robust to a few stray inliers), and the
//! handle centre is the middle of that extent, on the axis. The visible extent must match the
//! model within [`HandleModel::length_tolerance_m`], otherwise the fit is refused (a partial
//! view cannot place the centre).
//!
//! Pose `frame_from_handle`: origin at the centre on the axis, x = axis (canonical sign),
//! z = approach direction (from the robot toward the axis, perpendicular to it), y = z × x;
//! the same convention as the wire's hanging point.

use super::PerceptionError;
use super::colour::{LumaImage, axis_extent, limb_contrast};
use super::confidence::{ConfidenceThresholds, ramp};
use super::cylinder::{CylinderFit, RansacParams, fit_cylinder};
use super::point_cloud::CameraModel;
use super::wire::{HangingPoint, hanging_point};
use nalgebra::{Point3, Vector3};

pub use robot::grounding_rod::{HANDLE_LENGTH_M, HANDLE_RADIUS_M};

/// The handle's geometric model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HandleModel {
    /// Bar radius (m). Default [`HANDLE_RADIUS_M`].
    pub radius_m: f64,
    /// Bar length (m). Default [`HANDLE_LENGTH_M`].
    pub length_m: f64,
    /// Allowed `|measured - model|` length (m). Default 15 mm.
    pub length_tolerance_m: f64,
}

impl Default for HandleModel {
    fn default() -> Self {
        Self {
            radius_m: HANDLE_RADIUS_M,
            length_m: HANDLE_LENGTH_M,
            length_tolerance_m: 0.015,
        }
    }
}

/// A fitted handle.
#[derive(Debug, Clone, PartialEq)]
pub struct HandleEstimate {
    /// The cylinder fit.
    pub fit: CylinderFit,
    /// Visible length (m), 2nd-98th percentile of the axial coordinates.
    pub measured_length_m: f64,
    /// Centre pose and approach geometry.
    pub pose: HangingPoint,
}

impl HandleEstimate {
    /// Silhouette contrast of the fitted bar in the registered colour image
    /// ([`super::colour`]), over the extent of its inliers among `points` (the points it was
    /// fitted to); 0 when it cannot be measured.
    #[must_use]
    pub fn colour_contrast(
        &self,
        points: &[Point3<f64>],
        colour: &LumaImage,
        camera: &CameraModel,
    ) -> f64 {
        let inliers: Vec<Point3<f64>> = self
            .fit
            .inliers
            .iter()
            .filter_map(|&k| points.get(k))
            .copied()
            .collect();
        let cylinder = &self.fit.cylinder;
        axis_extent(cylinder, &inliers)
            .and_then(|extent| limb_contrast(colour, camera, cylinder, extent))
            .map_or(0.0, |c| c.contrast)
    }

    /// [`Self::colour_contrast`], refused like the wire's factor: the contrast's ramp
    /// `thresholds.colour_contrast` must reach `thresholds.min_score`.
    ///
    /// # Errors
    /// [`PerceptionError::LowConfidence`] (limited by `colour_contrast`).
    pub fn confirm_in_colour(
        &self,
        points: &[Point3<f64>],
        colour: &LumaImage,
        camera: &CameraModel,
        thresholds: &ConfidenceThresholds,
    ) -> Result<f64, PerceptionError> {
        let contrast = self.colour_contrast(points, colour, camera);
        let score = ramp(contrast, thresholds.colour_contrast);
        if score >= thresholds.min_score {
            Ok(contrast)
        } else {
            Err(PerceptionError::LowConfidence {
                score,
                threshold: thresholds.min_score,
                limiting: "colour_contrast",
            })
        }
    }
}

/// Fits the handle to `points` (normals from `normal_of`), approached from `robot_point`.
///
/// # Errors
/// Those of [`fit_cylinder`], [`PerceptionError::HandleLength`] when the extent disagrees
/// with the model, [`PerceptionError::Degenerate`].
pub fn fit_handle<F>(
    points: &[Point3<f64>],
    normal_of: F,
    model: &HandleModel,
    ransac: &RansacParams,
    robot_point: &Point3<f64>,
) -> Result<HandleEstimate, PerceptionError>
where
    F: FnMut(usize) -> Option<Vector3<f64>>,
{
    let params = RansacParams {
        radius_m: model.radius_m,
        ..*ransac
    };
    let fit = fit_cylinder(points, normal_of, &params)?;
    let c = fit.cylinder;
    let mut axial: Vec<f64> = fit
        .inliers
        .iter()
        .filter_map(|&k| points.get(k))
        .map(|p| (p - c.point).dot(&c.direction))
        .collect();
    axial.sort_by(f64::total_cmp);
    let pick = |q: f64| -> f64 {
        let k = ((axial.len().saturating_sub(1)) as f64 * q).round() as usize;
        axial.get(k).copied().unwrap_or(0.0)
    };
    let (lo, hi) = (pick(0.02), pick(0.98));
    // The percentiles cut 4% of a uniform extent; scale back.
    let measured_length_m = (hi - lo) / 0.96;
    if (measured_length_m - model.length_m).abs() > model.length_tolerance_m {
        return Err(PerceptionError::HandleLength {
            measured_m: measured_length_m,
            model_m: model.length_m,
            tolerance_m: model.length_tolerance_m,
        });
    }
    let centre = c.point + c.direction * (0.5 * (lo + hi));
    let pose = hanging_point(&c, &centre, robot_point)?;
    Ok(HandleEstimate {
        fit,
        measured_length_m,
        pose,
    })
}
