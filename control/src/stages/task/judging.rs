//! Judging: the verdicts that decide where a flow goes after a step's actions are done.
//!
//! * **Calibration** ([`Task::judge_calibration`]): the calibration stage's answer to the
//!   drift check (`consistent` goes on, `unresolved` looks four more times, `drifted` and
//!   `cannot_tell` recalibrate) and to the
//!   recalibration (`accepted` goes on; otherwise `calibration_failed`, or
//!   `calibration_unverifiable` when the check could not tell either). The check task ends
//!   with the check's verdict.
//! * **Wire** ([`Task::judge_wire`]): the [`crate::stages::wire_flow`] estimate over the
//!   captures gives the hook goal; a refused estimate looks again once, then refuses
//!   (`low_confidence`). Captures that see the wire swing get more captures
//!   (`capture_wire_more`); the hook goes to the sway's centre and the conductors are kept
//!   the sway's band plus [`SWAY_CLEARANCE_M`] clear; a band wider than
//!   [`TaskConfig::max_sway_m`](super::TaskConfig::max_sway_m) holds and looks again
//!   ([`MAX_WIRE_SWAY_HOLDS`] holds of [`WIRE_SWAY_HOLD_S`]), then refuses (`wire_sway`).
//!   The panoramic fix ([`Task::judge_panoramic`]) tries the next frame until
//!   [`TaskConfig::panoramic_attempts`](super::TaskConfig::panoramic_attempts), then
//!   refuses (`no_wire`), unless the wrist light is on: then the wrist camera looks at the
//!   site map's prior (`panoramic_dark`).
//! * **Handle** ([`Task::judge_handle`]): a fit per capture (RMS at most
//!   [`TaskConfig::handle_max_rms_m`](super::TaskConfig::handle_max_rms_m), confirmed in
//!   colour), centres agreeing within
//!   [`TaskConfig::handle_max_disagreement_m`](super::TaskConfig::handle_max_disagreement_m)
//!   (a swaying hung rod is waited out, [`MAX_SWAY_HOLDS`] holds of [`SWAY_HOLD_S`]), the
//!   stored rod's axis within [`RACK_AXIS_TOLERANCE_RAD`] of the vertical; gives the grasp
//!   goal.
//! * **Empty rack** ([`Task::judge_empty_rack`]): the post fit per capture, agreeing within
//!   [`RACK_MAX_DISAGREEMENT_M`], moves the place the rod goes back to; none refuses
//!   (`rack_not_seen`).
//! * **Contact** ([`Task::judge_clamp_closed`], [`Task::judge_grasp`]): the clamp joint's
//!   travel says whether the jaw closed on the wire (hook) or reads the rod's jaw (grasp,
//!   coupled); a miss backs off and looks again, up to
//!   [`TaskConfig::attempts`](super::TaskConfig::attempts) (`grasp_missed` fails; the
//!   hook's last miss backs off the wire too and then refuses, `hook_missed`).

use msgs::RobotDuration;
use msgs::frames::BASE_LINK;
use msgs::rodlog_msgs::{ClampCommand, TaskEvent};
use msgs::std_msgs::Header;
use msgs::topics::{PERCEPTION_ROI_CLOUD, PERCEPTION_TARGET_POSE};
use nalgebra::{Isometry3, Point3, Vector3};
use robot::grounding_rod::{CLAMP_TRAVEL_M, HookTolerance, WIRE_CONTACT_TRAVEL_M};

use super::Task;
use super::action::Action;
use super::config::TaskKind;
use super::flow::{AfterRecovery, Next, Stop};
use super::memory::{HandleSite, Rod};
use super::steps::{
    capture_empty_rack, capture_handle, capture_rack, capture_wire, capture_wire_more, check_more,
    close_clamp, grasp_handle, grasp_rack, look_handle, look_rack, look_wire, recalibrate,
    reposition, to_pre_approach,
};
use crate::perception::PerceptionError;
use crate::perception::handle::{CutEnd, ViewWindow, fit_handle};
use crate::perception::point_cloud::to_point_cloud2;
use crate::perception::rack;
use crate::perception::roi::{PixelRoi, extract_roi};
use crate::perception::sway::SwayTrack;
use crate::perception::wire;
use crate::stages::wire_flow::PanoramicOutcome;
use crate::tasks::poses;
use crate::tasks::site::{CONDUCTOR_SWAY_MARGIN_M, TARGET_WIRE};

/// A clamp stopped within this of the wire contact travel pressed on the wire (m); beyond
/// `contact + CLAMP_CONTACT_TOLERANCE_M` it closed on nothing.
pub const CLAMP_CONTACT_TOLERANCE_M: f64 = 1.5e-3;
/// Holds for a swaying handle before a look counts as failed (see [`SWAY_HOLD_S`]).
pub const MAX_SWAY_HOLDS: usize = 8;
/// One hold for a swaying handle (s).
pub const SWAY_HOLD_S: f64 = 1.5;
/// Holds for a wire swinging wider than the task allows before the hang is refused (see
/// [`WIRE_SWAY_HOLD_S`]).
pub const MAX_WIRE_SWAY_HOLDS: usize = 4;
/// One hold for a wire swinging too wide (s): longer than the gusts' 3-s correlation time,
/// so that the next look sees other gusts.
pub const WIRE_SWAY_HOLD_S: f64 = 5.0;
/// The vertical band a hang allows, as a fraction of the hook's window across the wire
/// (+-15 mm): the rest is for the centre's and the hand-eye's error.
pub const MAX_VERTICAL_SWAY_FRACTION: f64 = 0.5;
/// Clearance kept from a swinging conductor beyond its measured band (m): the band's own
/// error and the arm's tracking.
pub const SWAY_CLEARANCE_M: f64 = 0.01;
/// The stored rod's measured handle axis may be this far off the vertical (rad): 3 deg.
pub const RACK_AXIS_TOLERANCE_RAD: f64 = 3.0 * std::f64::consts::PI / 180.0;
/// The handle's ROI spans the handle's length plus this at each end (m): the rack's prior
/// comes from the survey, measured up to 5 cm off at the look; a ROI end inside the handle
/// would leave the other end only to place it ([`ViewWindow`]).
const HANDLE_ROI_END_M: f64 = 0.08;
/// Farthest depth kept for the empty rack's fit (m): the rack is seen from the handle
/// look's 0.45 m stand-off.
const RACK_ROI_DEPTH_M: f64 = 1.5;
/// The empty rack's captures agree within this (m): a fifth of the rod's 1 cm seat.
pub const RACK_MAX_DISAGREEMENT_M: f64 = 0.002;
/// A handle end within this many sampling strides of the ROI's border may be the view's
/// edge, not the handle's ([`ViewWindow`]).
const HANDLE_EDGE_STRIDES: f64 = 3.0;
/// The handle's ROI margin (m at the handle): the bar's radius and the prior's error (see
/// [`HANDLE_ROI_END_M`]).
const HANDLE_ROI_MARGIN_M: f64 = 0.08;
/// The handle's ROI depth margin (m).
const HANDLE_ROI_DEPTH_M: f64 = 0.1;

impl Task {
    /// The calibration stage's answer to the views of `step` (`check_calibration` or
    /// `recalibrate`; module docs).
    ///
    /// # Errors
    /// `calibration_silent`, `calibration_unverifiable`, `calibration_failed`.
    pub fn judge_calibration(&mut self, check: bool) -> Result<Next, Stop> {
        let Some(answer) = self.memory.calibration_answer.take() else {
            return Err(Stop::failed(
                "calibration_silent",
                "the calibration stage did not answer",
            ));
        };
        // Unresolved: no drift seen, but four views could miss one of the target size;
        // eight views resolve about 1.5x finer.
        if check && answer.reason_code == "unresolved" && !self.memory.check_extended {
            return Ok(Next::Goto(check_more::NAME));
        }
        if self.config.kind == TaskKind::Check {
            self.memory.done_reason = match answer.reason_code.as_str() {
                "consistent" => "consistent",
                "drifted" => "drifted",
                _ => "cannot_tell",
            };
            self.memory.done_text = answer.text;
            return Ok(Next::Following);
        }
        match (check, answer.reason_code.as_str()) {
            (true, "consistent") => Ok(Next::After(recalibrate::NAME)),
            (true, "drifted") => Ok(Next::Goto(recalibrate::NAME)),
            // The check could miss a bump that matters: calibrate afresh instead, which
            // verifies itself (the stage accepts only a consistent X).
            (true, _) => {
                self.memory.unverified_check = Some(answer.text);
                Ok(Next::Goto(recalibrate::NAME))
            }
            (_, "accepted") => {
                self.memory.unverified_check = None;
                if self.config.kind == TaskKind::SelfCalibrate {
                    self.memory.done_reason = "accepted";
                    self.memory.done_text = answer.text;
                }
                Ok(Next::After(recalibrate::NAME))
            }
            (_, code) if self.config.kind == TaskKind::SelfCalibrate => Err(Stop::refused(
                "calibration_failed",
                format!(
                    "the self-calibration was not accepted ({code}: {}); check that the site file's calibration target is right and the target lit, or calibrate with a board",
                    answer.text
                ),
            )),
            (_, code) if self.memory.unverified_check.is_some() => Err(Stop::refused(
                "calibration_unverifiable",
                format!(
                    "the hand-eye calibration could not be checked ({}) nor redone ({code}: {}): not operating on an unverified camera; retry in better light or check the camera",
                    self.memory.unverified_check.take().unwrap_or_default(),
                    answer.text
                ),
            )),
            (_, code) => Err(Stop::refused(
                "calibration_failed",
                format!(
                    "the camera mount moved and the recalibration was not accepted ({code}: {}); recalibrate with a board",
                    answer.text
                ),
            )),
        }
    }

    /// The stamp of the step's last capture (the perception outputs carry it).
    fn last_capture_stamp(&self) -> msgs::builtin_interfaces::Time {
        self.memory
            .captures
            .last()
            .map(|c| c.stamp)
            .unwrap_or_default()
    }

    /// Publishes `cloud` (`base_link`) on the ROI cloud topic, stamped with the last
    /// capture's stamp, which it returns.
    fn publish_capture_cloud(&mut self, cloud: &[Point3<f64>]) -> msgs::builtin_interfaces::Time {
        let stamp = self.last_capture_stamp();
        self.out.push(
            PERCEPTION_ROI_CLOUD,
            to_point_cloud2(
                cloud,
                Header {
                    stamp,
                    frame_id: BASE_LINK.to_owned(),
                },
            )
            .into(),
        );
        stamp
    }

    /// The empty rack measured by its post ([`crate::perception::rack`]) in each capture:
    /// the fits' mean shift from the survey moves the place the rod goes back to. Captures
    /// must agree within [`RACK_MAX_DISAGREEMENT_M`]; none measured refuses
    /// (`rack_not_seen`): the rod seats only within 1 cm, which a survey does not give.
    ///
    /// # Errors
    /// `no_camera_info`, `rack_not_seen`.
    pub fn judge_empty_rack(&mut self) -> Result<Next, Stop> {
        let Some((camera, rays)) = self.robot.wrist.clone() else {
            return Err(Stop::failed(
                "no_camera_info",
                "no /camera/color/camera_info",
            ));
        };
        let base_from_map = self.robot.base_from_map()?;
        let prior = base_from_map * self.config.site.map_from_rack;
        let model = crate::tasks::survey::rack_post_model();
        // What is published as the ROI cloud: the points around the rack's post and plate.
        let rack_from_base = prior.inverse();
        let near_rack = |p: &Point3<f64>| {
            let q = rack_from_base * p;
            (q.xy().coords - nalgebra::Vector2::from(model.centre_xy_m)).norm()
                <= 2.0 * rack::SEARCH_RADIUS_M
                && q.z >= model.plate_centre_m[2] - 0.05
                && q.z <= model.band_z_m[1] + 0.05
        };
        let mut shifts = Vec::new();
        let mut reasons = Vec::new();
        let mut cloud = Vec::new();
        for (k, c) in self.memory.captures.iter().enumerate() {
            // The whole image: the fit keeps the points near the post and over the plate
            // (a pixel box around the post's axis cuts an obliquely seen face).
            let roi = PixelRoi::full(&camera, 0.0, RACK_ROI_DEPTH_M);
            let points: Vec<Point3<f64>> =
                extract_roi(&c.depth, &rays, &roi, self.config.wire.stride_px)
                    .points
                    .iter()
                    .map(|p| c.base_from_camera * p)
                    .collect();
            let eye = Point3::from(c.base_from_camera.translation.vector);
            let fit = rack::fit_rack(&points, &prior, &eye, &model)
                .map(|f| (f, points))
                .map_err(|e| e.to_string());
            match fit {
                Ok((f, points)) => {
                    shifts.push((f.shift_m, f.rms_m));
                    cloud.extend(points.into_iter().filter(near_rack));
                }
                Err(e) => reasons.push(format!("capture {k}: {e}")),
            }
        }
        let disagreement = shifts
            .iter()
            .flat_map(|a| shifts.iter().map(move |b| (a.0 - b.0).norm()))
            .fold(0.0, f64::max);
        if shifts.is_empty() || disagreement > RACK_MAX_DISAGREEMENT_M {
            if !shifts.is_empty() {
                reasons.push(format!(
                    "the captures disagree by {:.1} mm",
                    disagreement * 1e3
                ));
            }
            return Err(Stop::refused(
                "rack_not_seen",
                format!(
                    "the empty rack was not measured ({}): the rod seats within 1 cm, more than the survey gives; check the site file's rack pose and that nothing hides the rack",
                    reasons.join("; ")
                ),
            ));
        }
        self.publish_capture_cloud(&cloud);
        let n = shifts.len() as f64;
        let shift = shifts.iter().map(|s| s.0).sum::<Vector3<f64>>() / n;
        let rms = shifts.iter().map(|s| s.1).fold(0.0, f64::max);
        let map_from_rack = self.config.site.map_from_rack * nalgebra::Translation3::from(shift);
        self.memory.stored_rod_seen = Some(map_from_rack * robot::grounding_rod::rack_from_rod());
        self.memory.rack_seen = Some(map_from_rack);
        let at = map_from_rack.translation.vector;
        self.event(
            TaskEvent::INFO,
            capture_empty_rack::NAME,
            "rack_measured",
            format!(
                "rack at ({:.4}, {:.4}, {:.4}) m in map from {} captures, {:.1} mm from the site map (post fit rms {:.2} mm, captures within {:.1} mm)",
                at.x,
                at.y,
                at.z,
                shifts.len(),
                shift.norm() * 1e3,
                rms * 1e3,
                disagreement * 1e3
            ),
        );
        Ok(Next::Following)
    }

    /// The panoramic frame the step waited for: a fix goes on, a miss tries the next frame.
    ///
    /// # Errors
    /// `no_wire` after [`TaskConfig::panoramic_attempts`](super::TaskConfig::panoramic_attempts) frames.
    pub fn judge_panoramic(&mut self, again: &'static str) -> Result<Next, Stop> {
        let image = self.memory.panoramic_image.take();
        let robot = &self.robot;
        match self.wire.fix_from_panoramic(
            &robot.tf,
            robot.panoramic_camera.as_ref(),
            image.as_ref(),
        ) {
            PanoramicOutcome::Fixed(_) => Ok(Next::Following),
            PanoramicOutcome::Retry { .. } => Ok(Next::Goto(again)),
            // The wrist light lights the wrist camera's scene, not the bay the panoramic
            // camera sees: look for the wire at the survey's prior with the lit wrist camera
            // (its captures are checked in depth and colour as always).
            PanoramicOutcome::GaveUp { attempts, reason } if self.robot.lighting.lit() => {
                self.event(
                    TaskEvent::INFO,
                    again,
                    "panoramic_dark",
                    format!(
                        "the panoramic camera did not find the wire in {attempts} frames ({reason}); the wrist light is on: looking at the site map's prior with the wrist camera"
                    ),
                );
                Ok(Next::Following)
            }
            PanoramicOutcome::GaveUp { attempts, reason } => Err(Stop::refused(
                "no_wire",
                format!(
                    "the panoramic camera did not find the wire in {attempts} frames: {reason}"
                ),
            )),
        }
    }

    /// The wire in the captures: `/perception/roi_cloud`, then the hook goal
    /// (`/perception/target_pose`, an event with the estimate and its confidence) or one
    /// more look.
    ///
    /// # Errors
    /// `no_camera_info`, `no_odometry`, `bad_geometry`, `low_confidence`.
    pub fn judge_wire(&mut self) -> Result<Next, Stop> {
        let prior = self.planner().wire_prior_in_base()?;
        let lift = self.robot.lift()?;
        let Some((camera, rays)) = self.robot.wrist.clone() else {
            return Err(Stop::failed(
                "no_camera_info",
                "no /camera/color/camera_info",
            ));
        };
        self.wire.clear_observations();
        let mut reasons = Vec::new();
        for c in &self.memory.captures {
            let camera_from_base = c.base_from_camera.inverse();
            if let Err(e) = self
                .wire
                .observe(c, &camera, &rays, &camera_from_base, &prior)
            {
                reasons.push(e);
            }
        }
        let robot_point = self.planner().arm_base_point(lift);
        let estimate = self.wire.estimate(&prior.0, &robot_point);
        let stamp = self.last_capture_stamp();
        let cloud = self.wire.roi_cloud(stamp);
        self.out.push(PERCEPTION_ROI_CLOUD, cloud.into());
        match estimate {
            Ok(est) => {
                if let Some(next) = self.judge_sway(&est.sway)? {
                    return Ok(next);
                }
                let axis = est.axis_in_base;
                let hook = poses::hook_goal(
                    &est.hanging.point,
                    &axis.direction,
                    &self.planner().arm_base_point(0.0),
                )
                .map_err(|e| Stop::failed("bad_geometry", e.to_string()))?;
                self.out.push(
                    PERCEPTION_TARGET_POSE,
                    wire::to_pose_stamped(
                        &hook,
                        Header {
                            stamp,
                            frame_id: BASE_LINK.to_owned(),
                        },
                    )
                    .into(),
                );
                self.event(
                    TaskEvent::INFO,
                    capture_wire::NAME,
                    "",
                    format!(
                        "wire at ({:.4}, {:.4}, {:.4}) m in base_link from {} captures; confidence {:.3} (limited by {})",
                        est.hanging.point.x, est.hanging.point.y, est.hanging.point.z,
                        est.metrics.captures, est.confidence.score, est.confidence.limiting
                    ),
                );
                if let Some(next) = reposition::toward_reach(self, &hook)? {
                    return Ok(next);
                }
                self.memory.wire_in_base = Some((est.hanging.point, axis.direction));
                self.memory.hook_goal = Some(hook);
                Ok(Next::Following)
            }
            Err(e) => self.perception_refusal(look_wire::NAME, &e, &reasons),
        }
    }

    /// The wire's sway across the captures: more captures when they see it swing and have
    /// not had them yet; a hold and a new look when its band is wider than
    /// [`TaskConfig::max_sway_m`](super::TaskConfig::max_sway_m), refused (`wire_sway`)
    /// after [`MAX_WIRE_SWAY_HOLDS`]; `None` to go on with the estimate, the conductors'
    /// clearance then set to the band plus [`SWAY_CLEARANCE_M`].
    ///
    /// # Errors
    /// `wire_sway`.
    fn judge_sway(&mut self, sway: &SwayTrack) -> Result<Option<Next>, Stop> {
        let captures = sway.offsets_m.len();
        let seen = format!(
            "the wire swings across {captures} captures: spread {:.1} mm, band +-{:.1} mm (95 %), centre +-{:.1} mm; vertically band +-{:.1} mm",
            sway.spread_m * 1e3,
            sway.envelope_m * 1e3,
            sway.centre_sigma_m * 1e3,
            sway.vertical_envelope_m * 1e3
        );
        if sway.is_swaying() && !self.memory.wire_extended && captures < self.config.sway_captures {
            self.event(
                TaskEvent::INFO,
                capture_wire::NAME,
                "wire_sway",
                format!(
                    "{seen}: {} more captures to track it",
                    self.config.sway_captures - captures
                ),
            );
            return Ok(Some(Next::Goto(capture_wire_more::NAME)));
        }
        let max_vertical_m = MAX_VERTICAL_SWAY_FRACTION * HookTolerance::DESIGN.across_m;
        if sway.envelope_m <= self.config.max_sway_m && sway.vertical_envelope_m <= max_vertical_m {
            let margin_m = CONDUCTOR_SWAY_MARGIN_M.max(sway.envelope_m + SWAY_CLEARANCE_M);
            self.memory.conductor_sway_margin_m = margin_m;
            if sway.is_swaying() {
                self.event(
                    TaskEvent::INFO,
                    capture_wire::NAME,
                    "wire_sway",
                    format!(
                        "{seen}: the hook goes to the centre and the conductors are kept {:.0} mm clear",
                        1e3 * margin_m
                    ),
                );
            }
            return Ok(None);
        }
        let why = format!(
            "{seen}, wider than the +-{:.0} mm (vertically +-{:.1} mm) a hang allows",
            self.config.max_sway_m * 1e3,
            max_vertical_m * 1e3
        );
        if self.memory.wire_sway_holds < MAX_WIRE_SWAY_HOLDS {
            self.memory.wire_sway_holds += 1;
            self.event(
                TaskEvent::INFO,
                capture_wire::NAME,
                "holding_for_sway",
                format!("{why}: holding {WIRE_SWAY_HOLD_S} s and looking again"),
            );
            return Ok(Some(Next::Recover {
                actions: vec![Action::wait(
                    RobotDuration::from_secs_f64(WIRE_SWAY_HOLD_S)
                        .unwrap_or(RobotDuration::from_secs(5)),
                    false,
                    RobotDuration::from_secs(20),
                    "hold for the wire's sway",
                )],
                then: AfterRecovery::Step(capture_wire::NAME),
            }));
        }
        Err(Stop::refused(
            "wire_sway",
            format!(
                "{why}, after {MAX_WIRE_SWAY_HOLDS} holds: the wind swings the wire too far to hang the rod safely; wait for calmer air"
            ),
        ))
    }

    /// One more look (at `again`) after a refused estimate; then refuse.
    ///
    /// # Errors
    /// `low_confidence` after [`TaskConfig::attempts`](super::TaskConfig::attempts).
    pub fn perception_refusal(
        &mut self,
        again: &'static str,
        e: &PerceptionError,
        reasons: &[String],
    ) -> Result<Next, Stop> {
        self.memory.attempts += 1;
        let text = if reasons.is_empty() {
            e.to_string()
        } else {
            format!("{e} ({})", reasons.join("; "))
        };
        if self.memory.attempts < self.config.attempts.max(1) {
            self.event(
                TaskEvent::INFO,
                again,
                "retry",
                format!("perception refused, looking again: {text}"),
            );
            Ok(Next::Goto(again))
        } else {
            Err(Stop::refused(
                "low_confidence",
                format!("perception refused {} times: {text}", self.memory.attempts),
            ))
        }
    }

    /// Fits the handle in the captures (`site`: the rack's stored rod or the hung rod):
    /// `/perception/roi_cloud`, then the grasp goal (`/perception/target_pose`, an event with
    /// the estimate), a hold for a swaying rod, or one more look.
    ///
    /// # Errors
    /// `no_camera_info`, `no_odometry`, `bad_geometry`, `low_confidence`.
    pub fn judge_handle(&mut self, site: HandleSite) -> Result<Next, Stop> {
        let (centre_prior, axis_prior) = self.planner().handle_prior_in_base(site)?;
        let (step, look_again) = match site {
            HandleSite::Wire => (capture_handle::NAME, look_handle::NAME),
            HandleSite::Rack => (capture_rack::NAME, look_rack::NAME),
        };
        let lift = self.robot.lift()?;
        let Some((camera, rays)) = self.robot.wrist.clone() else {
            return Err(Stop::failed(
                "no_camera_info",
                "no /camera/color/camera_info",
            ));
        };
        let config = &self.config;
        let robot_point = self.planner().arm_base_point(lift);
        let half = robot::grounding_rod::HANDLE_LENGTH_M * 0.5;
        // (centre, axis, placed from one end because the view cut the other)
        let mut fits: Vec<(Point3<f64>, Vector3<f64>, bool)> = Vec::new();
        let mut reasons = Vec::new();
        let mut cloud = Vec::new();
        let mut cut_both = false;
        for c in &self.memory.captures {
            let camera_from_base = c.base_from_camera.inverse();
            let a = axis_prior.normalize() * (half + HANDLE_ROI_END_M);
            let p0 = camera_from_base * (centre_prior - a);
            let p1 = camera_from_base * (centre_prior + a);
            let distance = 0.5 * (p0.coords.norm() + p1.coords.norm());
            let margin_px = HANDLE_ROI_MARGIN_M * camera.fx / distance.max(0.1);
            let result = PixelRoi::around_segment(&camera, &p0, &p1, margin_px, HANDLE_ROI_DEPTH_M)
                .map_err(|e| e.to_string())
                .and_then(|roi| {
                    let points = extract_roi(&c.depth, &rays, &roi, config.wire.stride_px);
                    let depth = &c.depth;
                    let normal_of = |k: usize| {
                        let (u, v) = *points.pixels.get(k)?;
                        depth.normal(&rays, camera.fx, u as usize, v as usize)
                    };
                    let window = ViewWindow {
                        camera: &camera,
                        roi: &roi,
                        edge_px: HANDLE_EDGE_STRIDES * config.wire.stride_px.max(1) as f64,
                    };
                    fit_handle(
                        &points.points,
                        normal_of,
                        &config.handle,
                        &config.wire.ransac,
                        &(camera_from_base * robot_point),
                        &window,
                    )
                    .map_err(|e| {
                        cut_both |= matches!(e, PerceptionError::HandleCut { .. });
                        e.to_string()
                    })
                    .map(|h| (h, points))
                })
                .and_then(|(h, points)| match &c.colour {
                    // Confirmed in the registered colour image like the wire (dusk refuses).
                    Some(colour) => h
                        .confirm_in_colour(&points.points, colour, &camera, &config.thresholds)
                        .map(|_| (h, points))
                        .map_err(|e| format!("handle {e}")),
                    None => Ok((h, points)),
                });
            match result {
                Ok((h, points)) if h.fit.rms_residual_m <= config.handle_max_rms_m => {
                    let t = c.base_from_camera;
                    fits.push((
                        t * h.pose.point,
                        t.rotation * h.pose.axis,
                        h.cut != CutEnd::None,
                    ));
                    cloud.extend(
                        h.fit
                            .inliers
                            .iter()
                            .filter_map(|&k| points.points.get(k))
                            .map(|p| t * p),
                    );
                }
                Ok((h, _)) => reasons.push(format!(
                    "handle fit rms {:.2} mm > {:.2} mm",
                    h.fit.rms_residual_m * 1e3,
                    config.handle_max_rms_m * 1e3
                )),
                Err(e) => reasons.push(e),
            }
        }
        let stamp = self.publish_capture_cloud(&cloud);
        // The view cut the stored rod's handle at both ends: the camera stood nearer than
        // planned (the surveyed prior a few cm off); the next look stands farther back.
        self.memory.look_farther |= cut_both && site == HandleSite::Rack;
        let wanted = self.config.handle_captures.max(1);
        let max_disagreement = self.config.handle_max_disagreement_m;
        let disagreement = fits
            .iter()
            .flat_map(|a| fits.iter().map(move |b| (a.0 - b.0).norm()))
            .fold(0.0, f64::max);
        if fits.len() < wanted || disagreement > max_disagreement {
            let e = PerceptionError::LowConfidence {
                score: fits.len() as f64 / wanted as f64,
                threshold: 1.0,
                limiting: if disagreement > max_disagreement {
                    "agreement_offset"
                } else {
                    "handle_fit"
                },
            };
            let mut reasons = reasons;
            if disagreement > max_disagreement {
                let why = format!(
                    "the captures' handle centres disagree by {:.1} mm > {:.1} mm",
                    disagreement * 1e3,
                    max_disagreement * 1e3
                );
                // A rod swaying with the wire: hold still and look again, a few times,
                // before counting it as a failed look.
                if fits.len() >= wanted && self.memory.sway_holds < MAX_SWAY_HOLDS {
                    self.memory.sway_holds += 1;
                    self.event(
                        TaskEvent::INFO,
                        look_again,
                        "holding_for_sway",
                        format!("{why}: the rod sways; holding {SWAY_HOLD_S} s and looking again"),
                    );
                    return Ok(Next::Recover {
                        actions: vec![Action::wait(
                            RobotDuration::from_secs_f64(SWAY_HOLD_S)
                                .unwrap_or(RobotDuration::from_secs(2)),
                            false,
                            RobotDuration::from_secs(10),
                            "hold for the sway",
                        )],
                        then: AfterRecovery::Step(look_again),
                    });
                }
                reasons.push(why);
            }
            return self.perception_refusal(look_again, &e, &reasons);
        }
        let n = fits.len() as f64;
        let centre = Point3::from(fits.iter().map(|f| f.0.coords).sum::<Vector3<f64>>() / n);
        let reference = fits.first().map_or(Vector3::z(), |f| f.1);
        let axis = fits
            .iter()
            .map(|f| if f.1.dot(&reference) < 0.0 { -f.1 } else { f.1 })
            .sum::<Vector3<f64>>()
            .normalize();
        let rod = match site {
            HandleSite::Wire => {
                let (_, wire_dir) = self.planner().wire_prior_in_base()?;
                let rod = poses::hung_rod_from_handle(
                    &centre,
                    &axis,
                    &wire_dir,
                    &self.planner().arm_base_point(0.0),
                )
                .map_err(|e| Stop::failed("bad_geometry", e.to_string()))?;
                self.memory.rod = Rod::OnWire(rod);
                // The wire runs through the measured rod's hook: unless a capture measured
                // the wire itself, plans keep clear of that wire, not of the survey's (which
                // can be centimetres off where the rod hangs).
                if self.memory.wire_in_base.is_none() {
                    let hook = rod * robot::grounding_rod::rod_from_hook();
                    self.memory.wire_in_base =
                        Some((Point3::from(hook.translation.vector), wire_dir));
                }
                rod
            }
            HandleSite::Rack => {
                // The rack holds the rod upright at its yaw: only the position is measured.
                let tilt = axis.z.abs().clamp(-1.0, 1.0).acos();
                if tilt > RACK_AXIS_TOLERANCE_RAD {
                    let e = PerceptionError::LowConfidence {
                        score: 0.0,
                        threshold: 1.0,
                        limiting: "handle_axis",
                    };
                    let why = format!(
                        "the stored rod's handle axis is {:.1} deg off the vertical",
                        tilt.to_degrees()
                    );
                    return self.perception_refusal(look_again, &e, &[why]);
                }
                let base_from_map = self.robot.base_from_map()?;
                let prior = base_from_map * self.config.site.map_from_stored_rod();
                let rod = Isometry3::from_parts(
                    nalgebra::Translation3::from(
                        prior.translation.vector + (centre - centre_prior),
                    ),
                    prior.rotation,
                );
                self.memory.stored_rod_seen = Some(self.robot.base_from_map()?.inverse() * rod);
                rod
            }
        };
        let grasp = poses::grasp_tool0(&rod);
        self.memory.grasp_goal = Some(grasp);
        self.out.push(
            PERCEPTION_TARGET_POSE,
            wire::to_pose_stamped(
                &grasp,
                Header {
                    stamp,
                    frame_id: BASE_LINK.to_owned(),
                },
            )
            .into(),
        );
        self.event(
            TaskEvent::INFO,
            step,
            "",
            format!(
                "handle at ({:.4}, {:.4}, {:.4}) m in base_link from {} captures{}, disagreement {:.2} mm, {:.1} mm from the prior",
                centre.x, centre.y, centre.z, fits.len(),
                match fits.iter().filter(|f| f.2).count() {
                    0 => String::new(),
                    k => format!(" ({k} placed from the end they saw: the view cut the other)"),
                },
                disagreement * 1e3,
                (centre - centre_prior).norm() * 1e3
            ),
        );
        if site == HandleSite::Wire
            && let Some(next) = reposition::toward_handle(self, &grasp)?
        {
            return Ok(next);
        }
        Ok(Next::Following)
    }

    /// Whether the clamp closed on the wire: stopped at the contact travel (clamped, on to
    /// the release) or ran on (the hook missed: open, back off across the wire, raise to the
    /// look height and look again). The last of
    /// [`TaskConfig::attempts`](super::TaskConfig::attempts) misses backs off the same way
    /// and then refuses (`hook_missed`): a rod left hooked but unclamped on the wire, the
    /// gripper still on its handle, is what a crew must never find.
    ///
    /// # Errors
    /// As the back-off's plans (a refusal).
    pub fn judge_clamp_closed(&mut self) -> Result<Next, Stop> {
        let travel = self.robot.clamp_m.unwrap_or(0.0);
        if (travel - WIRE_CONTACT_TRAVEL_M).abs() <= CLAMP_CONTACT_TOLERANCE_M {
            self.event(
                TaskEvent::INFO,
                close_clamp::NAME,
                "",
                format!(
                    "clamped: the jaw stopped on the wire at {:.1} mm",
                    travel * 1e3
                ),
            );
            return Ok(Next::Following);
        }
        // The jaw pressed on the wire, then ran on unloaded: the swinging wire pulled the
        // clamped rod out of the gripper. The rod is on the wire (its screw self-locks);
        // the release backs the gripper away from where it was.
        if let Some(pressed) = self.robot.clamp_pressed_m
            && (pressed - WIRE_CONTACT_TRAVEL_M).abs() <= CLAMP_CONTACT_TOLERANCE_M
        {
            self.event(
                TaskEvent::INFO,
                close_clamp::NAME,
                "rod_pulled",
                format!(
                    "clamped: the jaw pressed on the wire at {:.1} mm, then ran on to {:.1} mm: the swinging wire pulled the clamped rod out of the gripper; the rod stays on the wire, the gripper backs away",
                    pressed * 1e3,
                    travel * 1e3
                ),
            );
            return Ok(Next::Following);
        }
        self.memory.attempts += 1;
        let text = format!(
            "the clamp closed to {:.1} mm (wire contact at {:.1} mm, full travel {:.1} mm): the hook missed the wire",
            travel * 1e3,
            WIRE_CONTACT_TRAVEL_M * 1e3,
            CLAMP_TRAVEL_M * 1e3
        );
        // Open and back off across the wire; then raise to look again, or stop there: after
        // the last miss, or when the raise is refused (the rod stays clear of the wire).
        // As far as the approach came from: in a swinging wire's band a shorter back-off
        // leaves the rod too close to the wire to raise it.
        let back_m = to_pre_approach::approach_distance_m(self);
        let p = self.planner();
        let (plan, q_back) = p.back_off(
            back_m,
            &[("rod_head", TARGET_WIRE)],
            "back off after a miss",
        )?;
        let mut actions = vec![
            p.clamp_action(ClampCommand::OPEN, "open the clamp"),
            p.arm_action(&plan, "back off the wire"),
        ];
        let backed_off = "the clamp is open and the rod backed off the wire";
        let then = if self.memory.attempts >= self.config.attempts.max(1) {
            AfterRecovery::Stop(Stop::refused(
                "hook_missed",
                format!(
                    "{text}; {} attempts: {backed_off}; try again when the wire swings less",
                    self.memory.attempts
                ),
            ))
        } else {
            let lift = p.lift()?;
            let look_lift = self.memory.look_lift_m.unwrap_or(lift);
            match p.check_lift_move(&q_back, lift, look_lift) {
                Ok(()) => {
                    actions.push(Action::lift(lift, look_lift, "raise to look again"));
                    self.event(TaskEvent::INFO, close_clamp::NAME, "retry", text);
                    AfterRecovery::Step(look_wire::NAME)
                }
                Err(stop) => AfterRecovery::Stop(Stop {
                    text: format!(
                        "{text}; {backed_off}, but cannot raise it to look again: {}",
                        stop.text
                    ),
                    ..stop
                }),
            }
        };
        Ok(Next::Recover { actions, then })
    }

    /// Whether the end effector coupled the rod at `site`: the clamp joint then reads the
    /// rod's jaw (the stored rod's open jaw; for the hung rod, its jaw on the wire; the
    /// empty clamp was closed to full travel before the rack grasp). A miss backs off along
    /// the tool's -z and looks again, up to [`TaskConfig::attempts`](super::TaskConfig::attempts).
    ///
    /// # Errors
    /// `grasp_missed`; as the back-off's plans.
    pub fn judge_grasp(&mut self, site: HandleSite) -> Result<Next, Stop> {
        let (step, jaw_m, jaw, handle, look_again) = match site {
            HandleSite::Rack => (
                grasp_rack::NAME,
                0.0,
                "the stored rod's open jaw",
                "stored_rod_handle",
                look_rack::NAME,
            ),
            HandleSite::Wire => (
                grasp_handle::NAME,
                WIRE_CONTACT_TRAVEL_M,
                "the rod's jaw on the wire",
                "hung_rod_handle",
                look_handle::NAME,
            ),
        };
        if let Some(travel) = self
            .robot
            .clamp_m
            .filter(|t| (t - jaw_m).abs() <= CLAMP_CONTACT_TOLERANCE_M)
        {
            self.event(
                TaskEvent::INFO,
                step,
                "",
                format!(
                    "coupled: the clamp joint reads {jaw} at {:.1} mm",
                    travel * 1e3
                ),
            );
            // The hung rod stays clamped on the wire (Rod::OnWire) until it is unhooked.
            return Ok(Next::Following);
        }
        self.memory.attempts += 1;
        let reading = self.robot.clamp_m.map_or_else(
            || "has no reading".to_owned(),
            |t| format!("reads {:.1} mm", t * 1e3),
        );
        let text = format!(
            "the clamp joint {reading} after the grasp, not {jaw} at {:.1} mm: the gripper missed the handle",
            jaw_m * 1e3
        );
        if self.memory.attempts >= self.config.attempts.max(1) {
            return Err(Stop::failed(
                "grasp_missed",
                format!("{text}; {} attempts", self.memory.attempts),
            ));
        }
        self.event(TaskEvent::INFO, step, "retry", text);
        let p = self.planner();
        let (plan, _) = p.back_off(
            self.config.pregrasp_m,
            &[("tool", handle), ("arm_wrist3_link", handle)],
            "back off after a missed grasp",
        )?;
        Ok(Next::Recover {
            actions: vec![p.arm_action(&plan, "back off the handle")],
            then: AfterRecovery::Step(look_again),
        })
    }
}
