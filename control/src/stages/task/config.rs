//! The task stage's configuration: which task ([`TaskKind`]) and every setting of the flows
//! ([`TaskConfig`], with the `task.*` scenario keys it reads).

use msgs::{RobotDuration, RobotTime};
use nalgebra::Isometry3;
use robot::RobotModel;

use crate::perception::confidence::ConfidenceThresholds;
use crate::perception::handle::HandleModel;
use crate::perception::panoramic::PanoramicParams;
use crate::perception::wire::WireParams;
use crate::stages::wire_flow::{LookPolicy, WireFlowParams};
use crate::tasks::calibration_views::ViewPattern;
use crate::tasks::lighting::LightingParams;
use crate::tasks::safety::{WIND_LIMIT_MPS, WindGateParams};
use crate::tasks::site::SiteMap;

/// Which task.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TaskKind {
    /// Hang the rod on the wire.
    Hang,
    /// Remove it from the wire and put it back in the rack.
    Remove,
    /// The demo: hang the rod, then remove it again, in one run (one self-maintenance at the
    /// start). Its events carry the task of the phase (`hang`, then `remove`), each with its
    /// own `started` and end.
    Demo,
    /// Only check the hand-eye calibration (no recalibration, no operation): the drift
    /// check's verdict ends the task (`reason_code` = `consistent`, `drifted` or
    /// `cannot_tell`). For the maintenance experiment and for a check on demand.
    Check,
    /// Calibrate the hand-eye at the site on demand (no check first, no operation): drive to
    /// the working spot, visit the recalibration's views planned from the site map's
    /// calibration target, and end `done` (`reason_code` `accepted`) when the calibration
    /// stage accepts the new mount, refused otherwise. A new site or a new camera mount.
    SelfCalibrate,
}

impl TaskKind {
    /// The task's name (`task = ...` in a scenario, and `/task/event`'s task).
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Hang => "hang",
            Self::Remove => "remove",
            Self::Demo => "demo",
            Self::Check => "check",
            Self::SelfCalibrate => "self-calibrate",
        }
    }

    /// Parses a [`TaskKind::name`].
    #[must_use]
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "hang" => Some(Self::Hang),
            "remove" => Some(Self::Remove),
            "check" => Some(Self::Check),
            "demo" => Some(Self::Demo),
            "self-calibrate" => Some(Self::SelfCalibrate),
            _ => None,
        }
    }
}

/// Configuration of the [`TaskStage`]. Every default is documented on its field.
#[derive(Debug, Clone, PartialEq)]
pub struct TaskConfig {
    /// The task. Default hang.
    pub kind: TaskKind,
    /// The task starts at the first `/clock` at or after this. Default 1 s (the drivers'
    /// first samples, the URDF and the camera info are in by then).
    pub start_at: RobotTime,
    /// What the robot knows of the site: the parameters' `survey.*` ([`SiteMap::from_params`]),
    /// default [`SiteMap::default_bay`].
    pub site: SiteMap,
    /// The robot model (nominal). Default [`RobotModel::nominal`].
    pub model: RobotModel,
    /// `tool0_from_camera` until `/tf` carries the camera edge. Default the nominal mount.
    pub nominal_tool0_from_camera: Isometry3<f64>,
    /// Check the calibration before operating and recalibrate on drift. Default true.
    pub self_maintenance: bool,
    /// Recalibration views. Default [`ViewPattern::CALIBRATION_18`].
    pub calibration_views: ViewPattern,
    /// Lift height for the calibration views (m). Default 0.4.
    pub calibration_lift_m: f64,
    /// Wind gate. Default [`WindGateParams::default`].
    pub wind: WindGateParams,
    /// When to light the scene with the wrist light, on a robot that has one. Default
    /// [`LightingParams::default`].
    pub lighting: LightingParams,
    /// Wrist camera standoff from the wire and from the handle (m). Default 0.45.
    pub standoff_m: f64,
    /// Captures of the wire fused. Default 3.
    pub wire_captures: usize,
    /// Captures of a swinging wire in all ([`crate::perception::sway`]): when the first
    /// [`Self::wire_captures`] see the wire swing, more join them up to this. Default 6.
    pub sway_captures: usize,
    /// Widest band (95 % half-width) the wire may swing in for a hang (m): wider is held
    /// for ([`crate::stages::task::judging::SWAY_HOLD_S`]) and then refused (`wire_sway`).
    /// Default 0.04.
    pub max_sway_m: f64,
    /// Captures of the handle fused. Default 2.
    pub handle_captures: usize,
    /// Horizontal distance of the hook's pre-approach from the wire (m). Default 0.12.
    pub approach_m: f64,
    /// Pre-grasp distance of `tool0` behind the grasp along its z (m). Default 0.2.
    pub pregrasp_m: f64,
    /// Lift of the rod out of the rack (m, > `RACK_LIFT_OUT_M` = 0.3). Default 0.35.
    pub rack_lift_out_m: f64,
    /// Slide of the rod out of the rack's holders, along the rack's -y (their open side, m).
    /// Default 0.15.
    pub rack_exit_m: f64,
    /// Back-off of `tool0` along its -z to release the rod (m). Default 0.2 (the gripper
    /// then clears the handle by its margin).
    pub release_m: f64,
    /// Via point spacing of straight-line moves (m). Default 0.02.
    pub line_step_m: f64,
    /// Clamp torque limit (N m). Default 8.
    pub clamp_torque_nm: f64,
    /// Attempts of a perception-and-act cycle (hook, grasp) before failing. Default 2.
    pub attempts: usize,
    /// An operation fails when it lasts longer than this (from its start). Default 300 s.
    pub operation_timeout: RobotDuration,
    /// Wire and handle confidence thresholds. Default [`ConfidenceThresholds::default`].
    pub thresholds: ConfidenceThresholds,
    /// Wire detection. Default [`WireParams::default`].
    pub wire: WireParams,
    /// Panoramic finder. Default [`PanoramicParams::default`].
    pub panoramic: PanoramicParams,
    /// Panoramic frames tried. Default 5.
    pub panoramic_attempts: usize,
    /// Handle model. Default [`HandleModel::default`].
    pub handle: HandleModel,
    /// Largest handle fit RMS residual accepted (m). Default 0.6 mm.
    pub handle_max_rms_m: f64,
    /// Largest disagreement of the handle centres of two captures (m). Default 3 mm.
    pub handle_max_disagreement_m: f64,
    /// Arm stow configuration (rad). Default elbow up, tool forward.
    pub stow_rad: [f64; 6],
    /// Output latency. Default 5 ms.
    pub latency: RobotDuration,
}

impl Default for TaskConfig {
    fn default() -> Self {
        Self {
            kind: TaskKind::Hang,
            start_at: RobotTime::from_millis(1000),
            site: SiteMap::default_bay(),
            model: RobotModel::nominal(),
            nominal_tool0_from_camera: robot::camera_mount::nominal_tool0_from_camera(),
            self_maintenance: true,
            calibration_views: ViewPattern::CALIBRATION_18,
            calibration_lift_m: 0.4,
            wind: WindGateParams::default(),
            lighting: LightingParams::default(),
            standoff_m: 0.45,
            wire_captures: 3,
            sway_captures: 6,
            max_sway_m: 0.04,
            handle_captures: 2,
            approach_m: 0.12,
            pregrasp_m: 0.2,
            rack_lift_out_m: 0.35,
            rack_exit_m: 0.15,
            release_m: 0.2,
            line_step_m: 0.02,
            clamp_torque_nm: 8.0,
            attempts: 2,
            operation_timeout: RobotDuration::from_secs(300),
            thresholds: ConfidenceThresholds::default(),
            wire: WireParams::default(),
            panoramic: PanoramicParams::default(),
            panoramic_attempts: 5,
            handle: HandleModel::default(),
            handle_max_rms_m: 0.000_6,
            handle_max_disagreement_m: 0.003,
            stow_rad: [0.0, 0.3, 1.9, 0.0, std::f64::consts::FRAC_PI_2, 0.0],
            latency: RobotDuration::from_millis(5),
        }
    }
}

impl TaskConfig {
    /// Reads `task.*` through `r` for a task of `kind` (`start_s`, `self_maintenance`,
    /// `standoff_m`, `wire_captures`, `sway_captures`, `max_sway_m`, `handle_captures`,
    /// `approach_m`, `attempts`, `clamp_torque_nm`, `operation_timeout_s`,
    /// `wind_limit_mps`, `wind_sigmas`, `wind_hold_timeout_s`, `wind_hold_budget_s`,
    /// `wind_settle_s`,
    /// `min_confidence`, `latency_ms`, `light_on_below_lux`, `light_off_above_lux`,
    /// `light_brightness`); other fields keep [`Default`]'s.
    ///
    /// # Errors
    /// [`scenario::ParamError::Value`] for a wrong type or an out-of-range value.
    pub fn from_params(
        r: &mut scenario::Reader<'_>,
        kind: TaskKind,
    ) -> Result<Self, scenario::ParamError> {
        let d = Self::default();
        let site = SiteMap::from_params(r)?;
        let mut s = r.section("task");
        let mut wind = d.wind;
        wind.limit_mps = s.f64_in(
            "wind_limit_mps",
            wind.limit_mps,
            0.5..=WIND_LIMIT_MPS,
            "m/s",
            "the site's limit on the 3-s mean wind for operating (at most the robot's rating)",
        )?;
        wind.sigmas = s.f64(
            "wind_sigmas",
            wind.sigmas,
            "",
            "hold while the wind reading plus this many sigmas of its error exceeds the limit",
        )?;
        wind.hold_timeout = s.seconds(
            "wind_hold_timeout_s",
            wind.hold_timeout,
            "refuse after holding for the wind this long",
        )?;
        wind.hold_budget = s.seconds(
            "wind_hold_budget_s",
            wind.hold_budget,
            "refuse when the holds for the wind in one operation add up to this",
        )?;
        wind.settle_on_wire = s.seconds(
            "wind_settle_s",
            wind.settle_on_wire,
            "after a hold for the wind, while the tool works at the handle of the rod on the wire, wait this long with the gate open before moving (the conductor's swing settles)",
        )?;
        let lighting = LightingParams {
            on_below_lux: s.f64_in(
                "light_on_below_lux",
                d.lighting.on_below_lux,
                0.0..=200_000.0,
                "lx",
                "light the scene with the wrist light (where the robot has one) while the lux meter reads below this",
            )?,
            off_above_lux: s.f64_in(
                "light_off_above_lux",
                d.lighting.off_above_lux,
                0.0..=200_000.0,
                "lx",
                "switch the wrist light off above this (>= light_on_below_lux)",
            )?,
            brightness: s.f64_in(
                "light_brightness",
                d.lighting.brightness,
                0.0..=1.0,
                "",
                "wrist light brightness when on (0..1)",
            )?,
        };
        if lighting.off_above_lux < lighting.on_below_lux {
            return Err(scenario::ParamError::Value {
                key: "task.light_off_above_lux".to_owned(),
                value: lighting.off_above_lux.to_string(),
                reason: format!(
                    "below task.light_on_below_lux = {} lx: the light would flicker",
                    lighting.on_below_lux
                ),
            });
        }
        let mut thresholds = d.thresholds;
        thresholds.min_score = s.f64(
            "min_confidence",
            thresholds.min_score,
            "",
            "least perception confidence acted upon",
        )?;
        Ok(Self {
            kind,
            site,
            start_at: s.time_s(
                "start_s",
                d.start_at,
                "the task starts at the first clock at or after this",
            )?,
            self_maintenance: s.bool(
                "self_maintenance",
                d.self_maintenance,
                "check the calibration before operating and recalibrate on drift",
            )?,
            standoff_m: s.f64(
                "standoff_m",
                d.standoff_m,
                "m",
                "wrist camera standoff from the wire and the handle",
            )?,
            wire_captures: s.count("wire_captures", d.wire_captures, 1, "wire captures fused")?,
            sway_captures: s.count(
                "sway_captures",
                d.sway_captures,
                2,
                "wire captures in all when the first ones see the wire swing",
            )?,
            max_sway_m: s.f64_in(
                "max_sway_m",
                d.max_sway_m,
                0.0..=0.5,
                "m",
                "widest band (95 % half-width) the wire may swing in for a hang",
            )?,
            handle_captures: s.count(
                "handle_captures",
                d.handle_captures,
                1,
                "handle captures fused",
            )?,
            approach_m: s.f64(
                "approach_m",
                d.approach_m,
                "m",
                "horizontal distance of the hook's pre-approach from the wire",
            )?,
            attempts: s.count(
                "attempts",
                d.attempts,
                1,
                "attempts of a perception-and-act cycle before failing",
            )?,
            clamp_torque_nm: s.f64(
                "clamp_torque_nm",
                d.clamp_torque_nm,
                "N m",
                "clamp torque limit",
            )?,
            operation_timeout: s.seconds(
                "operation_timeout_s",
                d.operation_timeout,
                "an operation fails when it lasts longer than this",
            )?,
            latency: s.millis("latency_ms", d.latency, "stage latency")?,
            wind,
            lighting,
            thresholds,
            ..d
        })
    }
}

impl TaskConfig {
    /// The wire-perception flow's settings: the site map's wire prior, the panoramic finder
    /// and its attempts, the level look at [`Self::standoff_m`], the wire detection and the
    /// confidence thresholds; the ROI around the prior 0.25 m either side, 0.15 m margin.
    #[must_use]
    pub fn wire_flow_params(&self) -> WireFlowParams {
        WireFlowParams {
            prior_in_map: self.site.wire,
            panoramic: self.panoramic,
            panoramic_attempts: self.panoramic_attempts,
            look: LookPolicy::Level,
            standoff_m: self.standoff_m,
            roi_half_length_m: 0.25,
            roi_margin_m: 0.15,
            wire: self.wire,
            thresholds: self.thresholds,
        }
    }
}
