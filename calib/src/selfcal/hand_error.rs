//! The hand poses' error: what the arm's pose readings get wrong, which no image shows.
//!
//! The self-calibration takes each view's hand pose (`base_from_tool0`) as measured. Its
//! error has two parts with different effects on X, each with its own model:
//! [`SharedHandError`], the part every view shares at the flange, which X takes whole; and
//! [`ViewHandError`], the part that varies from view to view, which the monocular epipolar
//! refinement turns into rotation error ([`super::epipolar::hand_error_covariance`]).

use nalgebra::{Matrix6, Vector6};

/// The part of the hand poses' error that every view shares at the flange, 1-sigma per
/// axis: the arm's kinematic model error where the views' configurations are alike.
///
/// With `B_k' = B_k E` for every view, each pair's hand motion becomes `E^-1 B_ij E` and
/// `AX = XB` is solved exactly by `E^-1 X`: X takes the error whole while the pairs agree
/// with it, so neither their residuals nor the jackknife over views can show it (a shared
/// error on the base side, `F B_k`, cancels in the pair motions instead). Its covariance,
/// `diag(sigma_R^2 I_3, sigma_t^2 I_3)` ([`Self::covariance`]), is added to the reported one.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SharedHandError {
    /// Rotation, degrees per axis.
    pub rot_deg: f64,
    /// Translation, millimetres per axis.
    pub trans_mm: f64,
}

impl SharedHandError {
    /// None: hand poses whose errors are independent from view to view.
    pub const NONE: Self = Self {
        rot_deg: 0.0,
        trans_mm: 0.0,
    };
    /// The AUBO i10 with its nominal DH table, each row known to 0.2 mm / 0.02 deg (the
    /// simulated arm's perturbation): 0.025 deg / 0.3 mm. Measured on `rodlog experiment
    /// noise`'s 400 first trials without rendering (exact camera poses, the true arm's
    /// perturbation and encoder noise on the hand poses): X from the pose pairs is off by
    /// 0.0245 deg / 0.293 mm RMS per axis, and the jackknife over views alone holds the
    /// chi-square(3) 95 % test in only 14 % / 22 % of the trials. A real arm's figure comes
    /// from its kinematic calibration (or the maker's accuracy).
    pub const AUBO_I10_NOMINAL: Self = Self {
        rot_deg: 0.025,
        trans_mm: 0.3,
    };

    /// `diag(sigma_R^2 I_3, sigma_t^2 I_3)`, parameters `(theta, t)` in rad and m
    /// ([`per_axis_covariance`]).
    pub fn covariance(&self) -> Matrix6<f64> {
        per_axis_covariance(self.rot_deg, self.trans_mm)
    }
}

/// The covariance of an X known to `rot_deg` / `trans_mm` (1-sigma per axis, the same on
/// each): `diag(sigma_R^2 I_3, sigma_t^2 I_3)`, parameters `(theta, t)` in rad and m.
#[must_use]
pub fn per_axis_covariance(rot_deg: f64, trans_mm: f64) -> Matrix6<f64> {
    let r = rot_deg.to_radians().powi(2);
    let t = (trans_mm * 1e-3).powi(2);
    Matrix6::from_diagonal(&Vector6::new(r, r, r, t, t, t))
}

/// The part of the hand poses' error that varies from view to view, 1-sigma per axis in
/// the flange frame (`B_v' = B_v E_v`, `E_v` independent per view).
///
/// Pose pairs see it as AX=XB residuals and the jackknife over views measures it. The
/// monocular epipolar refinement does not: there X's rotation follows the hand translations
/// through the camera motions' directions, and a kinematic error smooth over the views'
/// configurations moves them alike. The self-calibration propagates it through that
/// refinement ([`super::epipolar::hand_error_covariance`]) and adds the result to the
/// monocular covariance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewHandError {
    /// Rotation, degrees per axis.
    pub rot_deg: f64,
    /// Translation, millimetres per axis.
    pub trans_mm: f64,
}

impl ViewHandError {
    /// None: exact hand poses, or errors that every view shares.
    pub const NONE: Self = Self {
        rot_deg: 0.0,
        trans_mm: 0.0,
    };
    /// The AUBO i10 with its nominal DH table, each row known to 0.2 mm / 0.02 deg (the
    /// simulated arm's perturbation) and encoder noise of 5e-5 rad: 0.01 deg / 0.13 mm.
    /// The calibration sees the hand error only through the pairs' motions `B_ij`, so the
    /// model matches their error: on `rodlog experiment noise`'s 400 first trials (153 pairs
    /// each) `B_ij` is off by 0.012-0.014 deg / 0.17-0.19 mm RMS per axis, and independent
    /// view errors of sigma give pair errors of about `sqrt(2) sigma`. (Each view's own
    /// flange error less its trial's mean is as large as the pairs' error, 0.012-0.015 deg /
    /// 0.15-0.21 mm, not `1 / sqrt(2)` of it: the kinematic error is smooth over the
    /// configurations, so the views of a pair share much of it.)
    pub const AUBO_I10_NOMINAL: Self = Self {
        rot_deg: 0.01,
        trans_mm: 0.13,
    };
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Both models are parameters of the calibration stage, by default the AUBO i10's
    /// nominal figures; a negative one is refused with its key.
    #[test]
    fn the_stage_reads_both_hand_errors() {
        let read = crate::selfcal::CalibrationStageConfig::from_settings;
        let d = read(&[]).expect("defaults");
        assert_eq!(d.shared_hand_error, SharedHandError::AUBO_I10_NOMINAL);
        assert_eq!(d.view_hand_error, ViewHandError::AUBO_I10_NOMINAL);
        let c = read(&[
            "calibration.view_hand_error_rot_deg=0.03",
            "calibration.view_hand_error_trans_mm=0.5",
        ])
        .expect("valid");
        assert_eq!(
            c.view_hand_error,
            ViewHandError {
                rot_deg: 0.03,
                trans_mm: 0.5
            }
        );
        let e = read(&["calibration.view_hand_error_trans_mm=-1"]).expect_err("negative");
        assert!(
            e.to_string()
                .contains("calibration.view_hand_error_trans_mm"),
            "{e}"
        );
    }
}
