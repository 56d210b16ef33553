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
//! An end that lies at the edge of what the points could show (the ROI's or the image's
//! border, [`ViewWindow`]) is not the handle's end but the view's: the centre is then placed
//! from the other end and the model length, `c = e_seen ± (L/2) a`, and the visible part
//! need only be no longer than the model and at least [`MIN_VISIBLE_FRACTION`] of it. (A
//! midpoint of a cut extent is off by half the cut: a survey's 4-5 cm error at the look put
//! grasps 6-8 mm off along the axis, beyond the gripper's 5 mm.) Both ends cut refuse
//! ([`PerceptionError::HandleCut`]).
//!
//! Pose `frame_from_handle`: origin at the centre on the axis, x = axis (canonical sign),
//! z = approach direction (from the robot toward the axis, perpendicular to it), y = z × x;
//! the same convention as the wire's hanging point.

use super::PerceptionError;
use super::colour::{LumaImage, axis_extent, limb_contrast};
use super::confidence::{ConfidenceThresholds, ramp};
use super::cylinder::{CylinderFit, RansacParams, fit_cylinder};
use super::point_cloud::CameraModel;
use super::roi::PixelRoi;
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

/// With one end cut by the view, at least this fraction of the model length must be seen
/// for the axis (and the seen end) to be trusted.
pub const MIN_VISIBLE_FRACTION: f64 = 0.5;

/// Where the fitted points came from: the pixels of `roi` (already inside the image) of
/// `camera`. A handle end projecting within `edge_px` of the ROI's border it runs toward may
/// be the view's edge rather than the handle's.
#[derive(Debug, Clone, Copy)]
pub struct ViewWindow<'a> {
    /// The camera the points are in.
    pub camera: &'a CameraModel,
    /// The pixels the points were taken from.
    pub roi: &'a PixelRoi,
    /// How near the border an end counts as cut (px): a few sampling strides.
    pub edge_px: f64,
}

impl ViewWindow<'_> {
    /// Whether the view ends at `p_in_camera` going along `outward` (camera frame): `p`
    /// projects within `edge_px` of the border that a step along `outward` heads for, or
    /// outside the window. The borders the step runs along do not count: a ROI that grazes
    /// the bar's side does not cut its end.
    #[must_use]
    pub fn ends_at(&self, p_in_camera: &Point3<f64>, outward: &Vector3<f64>) -> bool {
        const STEP_M: f64 = 0.005;
        // A border counts when the step's pixel direction heads for it at more than 30 deg.
        const MIN_HEADING: f64 = 0.5;
        let Some(px) = self.camera.project(p_in_camera) else {
            return true;
        };
        let Some(next) = self.camera.project(&(p_in_camera + outward * STEP_M)) else {
            return true;
        };
        let (u_min, v_min) = (self.roi.u_min as f64, self.roi.v_min as f64);
        let (u_max, v_max) = (self.roi.u_max as f64, self.roi.v_max as f64);
        if px.x < u_min || px.x >= u_max || px.y < v_min || px.y >= v_max {
            return true;
        }
        let d = next - px;
        let n = d.norm();
        if n <= f64::EPSILON {
            // Along the line of sight: the end is its own silhouette.
            return false;
        }
        let (du, dv) = (d.x / n, d.y / n);
        let m = self.edge_px;
        (du <= -MIN_HEADING && px.x < u_min + m)
            || (du >= MIN_HEADING && px.x > u_max - m)
            || (dv <= -MIN_HEADING && px.y < v_min + m)
            || (dv >= MIN_HEADING && px.y > v_max - m)
    }
}

/// Which of the handle's ends the view cut (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CutEnd {
    /// Both ends seen: the centre is the extent's middle.
    #[default]
    None,
    /// The end at the low axial coordinate was cut: the centre is placed from the high one.
    Low,
    /// The end at the high axial coordinate was cut: the centre is placed from the low one.
    High,
}

/// A fitted handle.
#[derive(Debug, Clone, PartialEq)]
pub struct HandleEstimate {
    /// The cylinder fit.
    pub fit: CylinderFit,
    /// Visible length (m), 2nd-98th percentile of the axial coordinates.
    pub measured_length_m: f64,
    /// The end the view cut, if any.
    pub cut: CutEnd,
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

/// Fits the handle to `points` (normals from `normal_of`) seen through `window`, approached
/// from `robot_point`.
///
/// # Errors
/// Those of [`fit_cylinder`], [`PerceptionError::HandleLength`] when the extent disagrees
/// with the model, [`PerceptionError::HandleCut`] when the view cuts both ends,
/// [`PerceptionError::Degenerate`].
pub fn fit_handle<F>(
    points: &[Point3<f64>],
    normal_of: F,
    model: &HandleModel,
    ransac: &RansacParams,
    robot_point: &Point3<f64>,
    window: &ViewWindow<'_>,
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
    let mut axial: Vec<(f64, Point3<f64>)> = fit
        .inliers
        .iter()
        .filter_map(|&k| points.get(k))
        .map(|p| ((p - c.point).dot(&c.direction), *p))
        .collect();
    axial.sort_by(|a, b| a.0.total_cmp(&b.0));
    let last = axial.len().saturating_sub(1);
    let index = |q: f64| ((last as f64) * q).round() as usize;
    let pick = |q: f64| -> f64 { axial.get(index(q)).map_or(0.0, |a| a.0) };
    let (lo, hi) = (pick(0.02), pick(0.98));
    // The percentiles cut 4% of a uniform extent; scale back.
    let measured_length_m = (hi - lo) / 0.96;
    let middle = 0.5 * (lo + hi);
    let (end_lo, end_hi) = (
        middle - 0.5 * measured_length_m,
        middle + 0.5 * measured_length_m,
    );
    // An end is cut when the surface points beyond its percentile touch the window's edge
    // (the axis itself projects a radius' parallax away from the silhouette).
    let touches = |range: &[(f64, Point3<f64>)], outward: Vector3<f64>| {
        range.iter().any(|(_, p)| window.ends_at(p, &outward))
    };
    let cut_lo = touches(axial.get(..=index(0.02)).unwrap_or_default(), -c.direction);
    let cut_hi = touches(axial.get(index(0.98)..).unwrap_or_default(), c.direction);
    let length_error = || PerceptionError::HandleLength {
        measured_m: measured_length_m,
        model_m: model.length_m,
        tolerance_m: model.length_tolerance_m,
    };
    let (cut, axial_centre) = match (cut_lo, cut_hi) {
        (true, true) => {
            return Err(PerceptionError::HandleCut {
                measured_m: measured_length_m,
                model_m: model.length_m,
            });
        }
        (false, false) => {
            if (measured_length_m - model.length_m).abs() > model.length_tolerance_m {
                return Err(length_error());
            }
            (CutEnd::None, middle)
        }
        (cut_lo, _) => {
            if measured_length_m > model.length_m + model.length_tolerance_m
                || measured_length_m < MIN_VISIBLE_FRACTION * model.length_m
            {
                return Err(length_error());
            }
            if cut_lo {
                (CutEnd::Low, end_hi - 0.5 * model.length_m)
            } else {
                (CutEnd::High, end_lo + 0.5 * model.length_m)
            }
        }
    };
    let centre = c.point + c.direction * axial_centre;
    let pose = hanging_point(&c, &centre, robot_point)?;
    Ok(HandleEstimate {
        fit,
        measured_length_m,
        cut,
        pose,
    })
}
