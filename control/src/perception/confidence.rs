//! Confidence of a wire (or handle) estimate from measured quality only: never from the
//! illuminance reading (a dark scene that still yields a clean cylinder is fine; a bright one
//! that does not is not).
//!
//! Each metric `m` maps to a factor `f = clamp((m - bad) / (good - bad), 0, 1)` (for metrics
//! where smaller is better, `good < bad` and the same formula applies). The score is the
//! **minimum** factor (the weakest link, reported as [`Confidence::limiting`]), so no good
//! metric can hide a bad one. The estimate is refused below
//! [`ConfidenceThresholds::min_score`] (default 0.5: every metric at least halfway from bad to
//! good). A single capture has no agreement measurement; its agreement factor is
//! [`ConfidenceThresholds::single_capture_factor`] (default 0.6: accepted, but with less
//! confidence than 2-3 agreeing captures).
//!
//! | metric | good | bad | why |
//! |---|---|---|---|
//! | support ratio (inliers / points within r + 5 mm of the axis) | 0.9 | 0.7 | a true cylinder explains nearly all points around it |
//! | RMS residual of the inliers | 0.2 mm | 0.4 mm | depth noise is 0.1 mm at 0.5 m, 0.14 mm at 0.6 m; inliers are cut at 0.6 mm |
//! | free-radius error | 1 mm | 3 mm | a fit of the wrong object has the wrong curvature |
//! | inlier count | 1000 | 200 | enough surface seen |
//! | valid depth fraction in the fitted silhouette | 0.75 | 0.4 | sun wash-out, holes, occlusion (clean: ~0.9, edges are always missing) |
//! | capture agreement, offset of the axes near the target | 2 mm | 8 mm | a jitter or a wrong fit shows between captures |
//! | capture agreement, axis angle | 1° | 4° | same |
//! | colour contrast of the silhouette, step over background spread ([`super::colour`]) | 4 | 1.5 | the colour image confirms the depth fit (daylight 70-110, 400 lx ~45, 3 lx ~1.2: the gain's noise buries the edge) |
//!
//! Without a colour image (a depth-only caller) the colour factor is 1 and cannot limit;
//! with one, a silhouette that cannot be measured in it counts as contrast 0.

use super::PerceptionError;

/// Measured quality of an estimate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct QualityMetrics {
    /// Inliers / points within `r + 5 mm` of the axis (worst capture).
    pub support_ratio: f64,
    /// RMS residual of the inliers (m, worst capture).
    pub rms_residual_m: f64,
    /// `|free radius - known radius|` (m, worst capture).
    pub radius_error_m: f64,
    /// Inlier count (smallest over captures).
    pub inlier_count: usize,
    /// Fraction of the fitted silhouette with valid depth (worst capture).
    pub valid_depth_fraction: f64,
    /// Number of captures fused.
    pub captures: usize,
    /// Largest pairwise offset between the captures' axes near the target (m); 0 for one.
    pub agreement_offset_m: f64,
    /// Largest pairwise angle between the captures' axes (rad); 0 for one.
    pub agreement_angle_rad: f64,
    /// Silhouette contrast (step over spread) in the registered colour image (smallest over captures);
    /// `None` when no colour image was given.
    pub colour_contrast: Option<f64>,
}

/// Good/bad ends of each factor's ramp and the acceptance threshold (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConfidenceThresholds {
    /// Support ratio `(good, bad)`. Default (0.9, 0.7).
    pub support_ratio: (f64, f64),
    /// RMS residual `(good, bad)` (m). Default (0.2 mm, 0.4 mm).
    pub rms_residual_m: (f64, f64),
    /// Radius error `(good, bad)` (m). Default (1 mm, 3 mm).
    pub radius_error_m: (f64, f64),
    /// Inlier count `(good, bad)`. Default (1000, 200).
    pub inlier_count: (f64, f64),
    /// Valid depth fraction in the silhouette `(good, bad)`. Default (0.75, 0.4).
    pub valid_depth_fraction: (f64, f64),
    /// Agreement offset `(good, bad)` (m). Default (2 mm, 8 mm).
    pub agreement_offset_m: (f64, f64),
    /// Agreement angle `(good, bad)` (rad). Default (1°, 4°).
    pub agreement_angle_rad: (f64, f64),
    /// Colour contrast `(good, bad)`. Default (4, 1.5).
    pub colour_contrast: (f64, f64),
    /// Agreement factor of a single capture. Default 0.6.
    pub single_capture_factor: f64,
    /// Refuse below this score. Default 0.5.
    pub min_score: f64,
}

impl Default for ConfidenceThresholds {
    fn default() -> Self {
        Self {
            support_ratio: (0.9, 0.7),
            rms_residual_m: (0.000_2, 0.000_4),
            radius_error_m: (0.001, 0.003),
            inlier_count: (1000.0, 200.0),
            valid_depth_fraction: (0.75, 0.4),
            agreement_offset_m: (0.002, 0.008),
            agreement_angle_rad: (1f64.to_radians(), 4f64.to_radians()),
            colour_contrast: (4.0, 1.5),
            single_capture_factor: 0.6,
            min_score: 0.5,
        }
    }
}

/// Names of the factors, in [`Confidence::factors`] order.
pub const FACTOR_NAMES: [&str; 8] = [
    "support_ratio",
    "rms_residual",
    "radius_error",
    "inlier_count",
    "valid_depth",
    "agreement_offset",
    "agreement_angle",
    "colour_contrast",
];

/// A score in `[0, 1]` with its factors.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Confidence {
    /// `min` of the factors.
    pub score: f64,
    /// Each factor in `[0, 1]`, [`FACTOR_NAMES`] order.
    pub factors: [f64; 8],
    /// Name of the smallest factor.
    pub limiting: &'static str,
}

impl Confidence {
    /// `Ok` when `score >= min_score`.
    ///
    /// # Errors
    /// [`PerceptionError::LowConfidence`] otherwise.
    pub fn require(&self, min_score: f64) -> Result<(), PerceptionError> {
        if self.score >= min_score {
            Ok(())
        } else {
            Err(PerceptionError::LowConfidence {
                score: self.score,
                threshold: min_score,
                limiting: self.limiting,
            })
        }
    }
}

/// `clamp((m - bad) / (good - bad), 0, 1)`; NaN maps to 0.
#[must_use]
pub fn ramp(m: f64, (good, bad): (f64, f64)) -> f64 {
    let f = (m - bad) / (good - bad);
    if f.is_nan() { 0.0 } else { f.clamp(0.0, 1.0) }
}

/// Scores `metrics` (module docs).
#[must_use]
pub fn assess(metrics: &QualityMetrics, thresholds: &ConfidenceThresholds) -> Confidence {
    let (offset, angle) = if metrics.captures >= 2 {
        (
            ramp(metrics.agreement_offset_m, thresholds.agreement_offset_m),
            ramp(metrics.agreement_angle_rad, thresholds.agreement_angle_rad),
        )
    } else {
        (
            thresholds.single_capture_factor,
            thresholds.single_capture_factor,
        )
    };
    let factors = [
        ramp(metrics.support_ratio, thresholds.support_ratio),
        ramp(metrics.rms_residual_m, thresholds.rms_residual_m),
        ramp(metrics.radius_error_m, thresholds.radius_error_m),
        ramp(metrics.inlier_count as f64, thresholds.inlier_count),
        ramp(
            metrics.valid_depth_fraction,
            thresholds.valid_depth_fraction,
        ),
        offset,
        angle,
        metrics
            .colour_contrast
            .map_or(1.0, |c| ramp(c, thresholds.colour_contrast)),
    ];
    let mut k_min = 0;
    for (k, f) in factors.iter().enumerate() {
        if *f < factors[k_min] {
            k_min = k;
        }
    }
    let score = if metrics.captures == 0 {
        0.0
    } else {
        factors[k_min]
    };
    Confidence {
        score,
        factors,
        limiting: FACTOR_NAMES[k_min],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn good() -> QualityMetrics {
        QualityMetrics {
            support_ratio: 0.95,
            rms_residual_m: 0.0001,
            radius_error_m: 0.0002,
            inlier_count: 20_000,
            valid_depth_fraction: 0.9,
            captures: 3,
            agreement_offset_m: 0.0005,
            agreement_angle_rad: 0.002,
            colour_contrast: Some(9.0),
        }
    }

    #[test]
    fn weakest_link_and_refusal() {
        let t = ConfidenceThresholds::default();
        let c = assess(&good(), &t);
        assert!((c.score - 1.0).abs() < 1e-12);
        assert!(c.require(t.min_score).is_ok());
        let single = assess(
            &QualityMetrics {
                captures: 1,
                ..good()
            },
            &t,
        );
        assert!((single.score - 0.6).abs() < 1e-12 && single.require(t.min_score).is_ok());
        let noisy = assess(
            &QualityMetrics {
                rms_residual_m: 0.00035,
                ..good()
            },
            &t,
        );
        assert_eq!(noisy.limiting, "rms_residual");
        assert!(matches!(
            noisy.require(t.min_score),
            Err(PerceptionError::LowConfidence {
                limiting: "rms_residual",
                ..
            })
        ));
        let disagree = assess(
            &QualityMetrics {
                agreement_offset_m: 0.01,
                ..good()
            },
            &t,
        );
        assert_eq!(
            (disagree.score, disagree.limiting),
            (0.0, "agreement_offset")
        );
        let nan = assess(
            &QualityMetrics {
                support_ratio: f64::NAN,
                ..good()
            },
            &t,
        );
        assert_eq!(nan.score, 0.0);
    }

    #[test]
    fn an_unconfirmed_silhouette_limits_and_no_colour_image_does_not() {
        let t = ConfidenceThresholds::default();
        let dark = assess(
            &QualityMetrics {
                colour_contrast: Some(1.0),
                ..good()
            },
            &t,
        );
        assert_eq!((dark.score, dark.limiting), (0.0, "colour_contrast"));
        let depth_only = assess(
            &QualityMetrics {
                colour_contrast: None,
                ..good()
            },
            &t,
        );
        assert!((depth_only.score - 1.0).abs() < 1e-12);
    }
}
