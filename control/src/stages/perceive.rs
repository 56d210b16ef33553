//! The `perceive` stage: the wire-perception flow of the hang task up to the hanging point,
//! as a deterministic stage over the message stream. It drives the
//! [`crate::stages::wire_flow`] component (the task stage's hang drives the same one) with
//! its own timing and motion:
//!
//! 1. **Panoramic fix.** On the first `/panoramic/image_raw` at or after `panoramic_at` (once
//!    `/panoramic/camera_info` came), [`WireFlow::fix_from_panoramic`] with the site map's
//!    prior of the target conductor ([`PerceiveConfig::prior_in_map`]). A refusal is logged
//!    on `/rosout` (WARN) and the next frame is tried, up to
//!    [`PerceiveConfig::panoramic_attempts`] frames (then ERROR).
//! 2. **Look.** On the first `/clock` at or after `look_at` with a fix: the corrected prior in
//!    `base_link`, the wrist camera's look pose ([`LookPolicy::TowardsArmBase`], standoff
//!    [`PerceiveConfig::standoff_m`], from the arm base at the current lift), the tool0 goal
//!    `base_from_camera * camera_from_tool0` (the camera edge from `/tf` when a calibration
//!    stage sends it, else the configured nominal mount), and a checked plan
//!    ([`planner::plan_to_tool0`], the robot's body as the only obstacle) published on
//!    `/arm/joint_trajectory` and `/arm/planned_path`. An unreachable or colliding look pose
//!    is refused on `/rosout`.
//! 3. **Captures.** When the measured arm is within [`ARRIVED_RAD`] of the goal and at rest,
//!    `/camera/trigger`; on each `/camera/depth/image_raw`: `base_from_camera` at its stamp
//!    (`/tf`, no fallback to a later pose), [`WireFlow::observe`] around the fix, confirmed in
//!    the colour image of the same stamp; a capture without the wire is a `/rosout` WARN; the
//!    next trigger until [`PerceiveConfig::captures`] captures.
//! 4. **Estimate.** [`WireFlow::estimate`] over the captures (in `base_link`):
//!    `/perception/roi_cloud` (the inliers, `base_link`), `/perception/target_pose` (the
//!    hanging point: origin on the axis, x along the wire, z against the approach normal) and
//!    a `/rosout` INFO line with the confidence and its limiting factor; or a `/rosout` WARN
//!    with the refusal's reason and no pose.
//!
//! Every output is logged at the trigger's `log_time + latency`; the stage keeps no clock and
//! no randomness beyond its seeded RANSACs, so a replay reproduces it byte for byte.

use msgs::builtin_interfaces::Time;
use msgs::frames::{BASE_LINK, CAMERA_COLOR_OPTICAL_FRAME, MAP, TOOL0};
use msgs::geometry_msgs::PoseStamped;
use msgs::nav_msgs::Path;
use msgs::rcl_interfaces::Log;
use msgs::sensor_msgs::{Image, PointCloud2};
use msgs::std_msgs::{Empty, Header};
use msgs::topics::{
    ARM_JOINT_TRAJECTORY, ARM_PLANNED_PATH, CAMERA_COLOR_IMAGE, CAMERA_COLOR_INFO,
    CAMERA_DEPTH_IMAGE, CAMERA_TRIGGER, CLOCK, JOINT_STATES, PANORAMIC_IMAGE, PANORAMIC_INFO,
    PERCEPTION_ROI_CLOUD, PERCEPTION_TARGET_POSE, ROSOUT, TF, TF_STATIC,
};
use msgs::trajectory_msgs::JointTrajectory;
use msgs::{Msg, RobotDuration, RobotTime, RosMessage, Stage, StageError};
use nalgebra::{Isometry3, Point3};
use robot::{ArmIk, IkSettings, JointKind, RobotModel, TfBuffer};

use crate::motion::collision::{ArmCollisionModel, CollisionWorld};
use crate::motion::planner;
use crate::motion::trajectory::DEFAULT_DT_NS;
use crate::perception::PerceptionError;
use crate::perception::colour::PendingColour;
use crate::perception::confidence::ConfidenceThresholds;
use crate::perception::panoramic::{PanoramicParams, WirePrior};
use crate::perception::point_cloud::{CameraModel, DepthImage, RayTable};
use crate::perception::wire::{self, WireParams};
use crate::stages::wire_flow::{
    LookPolicy, PanoramicOutcome, WireFlow, WireFlowParams, WristCapture, time_ns,
};

/// Stage name (channel metadata `producer=perceive`).
pub const STAGE_NAME: &str = "perceive";
/// The arm has arrived when every joint is within this of the goal (rad) and at rest.
pub const ARRIVED_RAD: f64 = 2e-3;
/// At rest: every reported joint speed below this (rad/s).
pub const AT_REST_RAD_S: f64 = 1e-3;

/// Configuration (from the scenario's `perceive.*` parameters in the CLI).
#[derive(Debug, Clone, PartialEq)]
pub struct PerceiveConfig {
    /// The robot model (nominal).
    pub model: RobotModel,
    /// The site map's prior of the target conductor, in `map`. Default
    /// [`crate::tasks::site::SiteMap::default_bay`]'s.
    pub prior_in_map: WirePrior,
    /// Use the first panoramic frame at or after this time.
    pub panoramic_at: RobotTime,
    /// Panoramic frames tried before giving up.
    pub panoramic_attempts: usize,
    /// Plan the look motion at the first clock at or after this time.
    pub look_at: RobotTime,
    /// Wrist camera standoff from the wire (m).
    pub standoff_m: f64,
    /// Captures fused (2-3).
    pub captures: usize,
    /// Nominal `tool0_from_camera`, used until `/tf` carries the camera edge.
    pub nominal_tool0_from_camera: Isometry3<f64>,
    /// Half-length of the prior segment projected into the wrist image (m).
    pub roi_half_length_m: f64,
    /// ROI margin around the projected prior (m at the wire).
    pub roi_margin_m: f64,
    /// Panoramic finder settings.
    pub panoramic: PanoramicParams,
    /// Wire detection settings.
    pub wire: WireParams,
    /// Confidence thresholds.
    pub thresholds: ConfidenceThresholds,
    /// Output latency.
    pub latency: RobotDuration,
}

impl Default for PerceiveConfig {
    fn default() -> Self {
        Self {
            model: RobotModel::nominal(),
            prior_in_map: crate::tasks::site::SiteMap::default_bay().wire,
            panoramic_at: RobotTime::ZERO,
            panoramic_attempts: 5,
            look_at: RobotTime::ZERO,
            standoff_m: 0.45,
            captures: 3,
            nominal_tool0_from_camera: robot::camera_mount::nominal_tool0_from_camera(),
            roi_half_length_m: 0.25,
            roi_margin_m: 0.15,
            panoramic: PanoramicParams::default(),
            wire: WireParams::default(),
            thresholds: ConfidenceThresholds::default(),
            latency: RobotDuration::from_millis(5),
        }
    }
}

impl PerceiveConfig {
    /// Reads `perceive.*` through `r` (`panoramic_at_s`, `look_at_s`, `standoff_m`,
    /// `captures`, `latency_ms`); other fields keep [`Default`]'s. The wire prior is the
    /// site map's (`survey.*`, [`crate::tasks::site::SiteMap::from_params`]), never a
    /// scenario's.
    ///
    /// # Errors
    /// [`scenario::ParamError::Value`] for a wrong type or an out-of-range value.
    pub fn from_params(r: &mut scenario::Reader<'_>) -> Result<Self, scenario::ParamError> {
        let d = Self::default();
        let prior_in_map = crate::tasks::site::SiteMap::from_params(r)?.wire;
        let mut s = r.section("perceive");
        Ok(Self {
            prior_in_map,
            panoramic_at: s.time_s(
                "panoramic_at_s",
                RobotTime::ZERO,
                "use the first panoramic frame from this time",
            )?,
            look_at: s.time_s(
                "look_at_s",
                RobotTime::ZERO,
                "plan the wrist look motion from this time",
            )?,
            standoff_m: s.f64(
                "standoff_m",
                d.standoff_m,
                "m",
                "wrist camera standoff from the wire",
            )?,
            captures: s.count("captures", d.captures, 1, "wrist captures fused")?,
            latency: s.millis("latency_ms", d.latency, "stage latency")?,
            ..d
        })
    }
}

impl PerceiveConfig {
    /// The wire-perception flow's settings: the prior, the panoramic finder and its
    /// attempts, the look towards the arm base at [`Self::standoff_m`], the ROI, the wire
    /// detection and the confidence thresholds.
    #[must_use]
    pub fn wire_flow_params(&self) -> WireFlowParams {
        WireFlowParams {
            prior_in_map: self.prior_in_map,
            panoramic: self.panoramic,
            panoramic_attempts: self.panoramic_attempts,
            look: LookPolicy::TowardsArmBase,
            standoff_m: self.standoff_m,
            roi_half_length_m: self.roi_half_length_m,
            roi_margin_m: self.roi_margin_m,
            wire: self.wire,
            thresholds: self.thresholds,
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
enum Phase {
    Panoramic,
    Look,
    Moving { goal: [f64; 6] },
    Capturing,
    Done,
}

/// The `perceive` stage (module docs).
#[derive(Debug)]
pub struct PerceiveStage {
    config: PerceiveConfig,
    collision: ArmCollisionModel,
    ik: ArmIk,
    tf: TfBuffer,
    panoramic_camera: Option<CameraModel>,
    wrist_camera: Option<(CameraModel, RayTable)>,
    flow: WireFlow,
    q: Option<([f64; 6], bool)>,
    lift_m: f64,
    phase: Phase,
    colour: PendingColour,
    captures_seen: usize,
}

impl PerceiveStage {
    /// A stage with `config`.
    ///
    /// # Errors
    /// [`StageError::Failed`] when the model's IK cannot be built.
    pub fn new(config: PerceiveConfig) -> Result<Self, StageError> {
        let ik = config
            .model
            .arm_ik(IkSettings::default())
            .map_err(|e| StageError::Failed {
                stage: STAGE_NAME.to_owned(),
                log_time: RobotTime::ZERO,
                reason: e.to_string(),
            })?;
        let collision = ArmCollisionModel {
            model: config.model.clone(),
            ..ArmCollisionModel::nominal()
        };
        Ok(Self {
            flow: WireFlow::new(config.wire_flow_params()),
            config,
            collision,
            ik,
            tf: TfBuffer::default(),
            panoramic_camera: None,
            wrist_camera: None,
            q: None,
            lift_m: 0.0,
            phase: Phase::Panoramic,
            colour: PendingColour::default(),
            captures_seen: 0,
        })
    }

    fn stamp(&self, log_time: RobotTime) -> Time {
        (log_time + self.config.latency)
            .to_ros()
            .unwrap_or_default()
    }

    fn log(&self, log_time: RobotTime, level: u8, text: String) -> (String, Msg) {
        let msg = Log::line(STAGE_NAME, self.stamp(log_time), level, text).in_file(file!());
        (ROSOUT.to_owned(), msg.into())
    }

    fn tool0_from_camera(&self, stamp_ns: u64) -> Isometry3<f64> {
        self.tf
            .lookup(TOOL0, CAMERA_COLOR_OPTICAL_FRAME, stamp_ns)
            .or_else(|_| {
                self.tf
                    .lookup_latest(TOOL0, CAMERA_COLOR_OPTICAL_FRAME)
                    .map(|(_, t)| t)
            })
            .unwrap_or(self.config.nominal_tool0_from_camera)
    }

    fn base_from_map(&self, stamp_ns: u64) -> Result<Isometry3<f64>, robot::TfError> {
        self.tf
            .lookup(BASE_LINK, MAP, stamp_ns)
            .or_else(|_| self.tf.lookup_latest(BASE_LINK, MAP).map(|(_, t)| t))
    }

    fn on_panoramic(&mut self, log_time: RobotTime, image: &Image) -> Vec<(String, Msg)> {
        if self.phase != Phase::Panoramic || log_time < self.config.panoramic_at {
            return Vec::new();
        }
        let Some(camera) = self.panoramic_camera else {
            return Vec::new();
        };
        let (level, text) = match self
            .flow
            .fix_from_panoramic(&self.tf, Some(&camera), Some(image))
        {
            PanoramicOutcome::Fixed(found) => {
                self.phase = Phase::Look;
                (
                    Log::INFO,
                    format!(
                        "panoramic: wire at ({:.3}, {:.3}, {:.3}) m in map, prior moved {:.3} m; {} of {} samples on the line, rms {:.2} px, contrast {:.1}",
                        found.point.x,
                        found.point.y,
                        found.point.z,
                        found.correction_m,
                        found.inliers_px.len(),
                        found.samples_in_view,
                        found.rms_px,
                        found.median_contrast
                    ),
                )
            }
            PanoramicOutcome::Retry { attempt, reason } => (
                Log::WARN,
                format!("panoramic refused (attempt {attempt}): {reason}"),
            ),
            PanoramicOutcome::GaveUp { attempts, reason } => {
                self.phase = Phase::Done;
                (
                    Log::ERROR,
                    format!("panoramic refused (attempt {attempts}): {reason}; giving up"),
                )
            }
        };
        vec![self.log(log_time, level, text)]
    }

    fn on_clock(&mut self, log_time: RobotTime) -> Vec<(String, Msg)> {
        if self.phase != Phase::Look || log_time < self.config.look_at {
            return Vec::new();
        }
        let (Some(_), Some((q, _))) = (self.flow.fix_in_map(), self.q) else {
            return Vec::new();
        };
        let now_ns = log_time.as_nanos();
        let result = (|| -> Result<planner::ArmPlan, String> {
            let base_from_map = self
                .base_from_map(now_ns)
                .map_err(|e| format!("no map -> base_link: {e}"))?;
            let prior = self.flow.prior_in_base(&base_from_map);
            let robot_point = self.config.model.base_from_arm_base(self.lift_m) * Point3::origin();
            let base_from_camera = self
                .flow
                .look_pose(&prior, &robot_point)
                .map_err(|e| e.to_string())?;
            let goal = base_from_camera * self.tool0_from_camera(now_ns).inverse();
            let world = CollisionWorld::robot_body(&self.config.model, self.lift_m);
            planner::plan_to_tool0(
                &self.collision,
                &self.ik,
                &world,
                self.lift_m,
                &q,
                &goal,
                DEFAULT_DT_NS,
            )
            .map_err(|e| format!("look pose not reachable: {e}"))
        })();
        match result {
            Ok(plan) => {
                let header = Header {
                    stamp: self.stamp(log_time),
                    frame_id: BASE_LINK.to_owned(),
                };
                let goal = plan.waypoints.last().copied().unwrap_or(q);
                let traj = planner::plan_trajectory_msg(&plan, header.clone());
                let path = planner::plan_path_msg(&plan, &self.config.model, header);
                self.phase = Phase::Moving { goal };
                vec![
                    (ARM_JOINT_TRAJECTORY.to_owned(), traj.into()),
                    (ARM_PLANNED_PATH.to_owned(), path.into()),
                    self.log(
                        log_time,
                        Log::INFO,
                        format!(
                            "look: {:.2} s to the wrist look pose, clearance {:.3} m",
                            plan.trajectory.duration_s(),
                            plan.min_clearance_m
                        ),
                    ),
                ]
            }
            Err(reason) => {
                self.phase = Phase::Done;
                vec![self.log(log_time, Log::ERROR, format!("look refused: {reason}"))]
            }
        }
    }

    fn on_joint_state(&mut self, js: &msgs::sensor_msgs::JointState) -> Vec<(String, Msg)> {
        let mut q = [f64::NAN; 6];
        let mut at_rest = true;
        let mut arm = 0;
        for (k, name) in js.name.iter().enumerate() {
            match JointKind::from_name(name) {
                Some(JointKind::Lift) => {
                    if let Some(p) = js.position.get(k) {
                        self.lift_m = *p;
                    }
                }
                Some(JointKind::Arm(i)) if i < 6 => {
                    q[i] = js.position.get(k).copied().unwrap_or(f64::NAN);
                    at_rest &= js.velocity.get(k).is_none_or(|v| v.abs() < AT_REST_RAD_S);
                    arm += 1;
                }
                _ => {}
            }
        }
        if arm != 6 {
            return Vec::new();
        }
        self.q = Some((q, at_rest));
        if let Phase::Moving { goal } = self.phase
            && at_rest
            && (0..6).all(|j| (q[j] - goal[j]).abs() < ARRIVED_RAD)
        {
            self.phase = Phase::Capturing;
            return vec![(CAMERA_TRIGGER.to_owned(), Empty.into())];
        }
        Vec::new()
    }

    /// Looks for the wire in the capture of `image` (module docs, step 3).
    fn observe(&mut self, image: &Image) -> Result<(), String> {
        let Some(fix) = self.flow.fix_in_map() else {
            return Ok(());
        };
        let Some((camera, rays)) = &self.wrist_camera else {
            return Err("no /camera/color/camera_info yet".to_owned());
        };
        let stamp_ns = time_ns(&image.header.stamp);
        let base_from_tool0 = self
            .tf
            .lookup(BASE_LINK, TOOL0, stamp_ns)
            .map_err(|e| format!("no base_link -> tool0 at the capture: {e}"))?;
        let base_from_camera = base_from_tool0 * self.tool0_from_camera(stamp_ns);
        let base_from_map = self
            .base_from_map(stamp_ns)
            .map_err(|e| format!("no map -> base_link: {e}"))?;
        let camera_from_map = base_from_camera.inverse() * base_from_map;
        let depth = DepthImage::from_image(image).map_err(|e| e.to_string())?;
        let capture = WristCapture {
            depth,
            colour: self.colour.take_for(stamp_ns),
            base_from_camera,
            stamp: image.header.stamp,
        };
        self.flow
            .observe(&capture, camera, rays, &camera_from_map, &fix)
    }

    fn on_depth(&mut self, log_time: RobotTime, image: &Image) -> Vec<(String, Msg)> {
        if self.phase != Phase::Capturing {
            return Vec::new();
        }
        let Some((point_map, _)) = self.flow.fix_in_map() else {
            return Vec::new();
        };
        self.captures_seen += 1;
        let stamp_ns = time_ns(&image.header.stamp);
        let mut out = Vec::new();
        if let Err(reason) = self.observe(image) {
            out.push(self.log(
                log_time,
                Log::WARN,
                format!("capture {}: no wire: {reason}", self.captures_seen),
            ));
        }
        if self.captures_seen < self.config.captures.max(1) {
            out.push((CAMERA_TRIGGER.to_owned(), Empty.into()));
            return out;
        }
        self.phase = Phase::Done;
        let header = Header {
            stamp: image.header.stamp,
            frame_id: BASE_LINK.to_owned(),
        };
        out.push((
            PERCEPTION_ROI_CLOUD.to_owned(),
            self.flow.roi_cloud(image.header.stamp).into(),
        ));
        let near = self
            .base_from_map(stamp_ns)
            .map(|t| self.flow.prior_in_base(&t).0)
            .unwrap_or(point_map);
        let robot_point = self.config.model.base_from_arm_base(self.lift_m) * Point3::origin();
        match self.flow.estimate(&near, &robot_point) {
            Ok(est) => {
                let h = est.hanging.point;
                out.push((
                    PERCEPTION_TARGET_POSE.to_owned(),
                    wire::to_pose_stamped(&est.hanging.frame_from_hanging, header).into(),
                ));
                out.push(self.log(
                    log_time,
                    Log::INFO,
                    format!(
                        "wire: hanging point ({:.4}, {:.4}, {:.4}) m in base_link from {} captures; confidence {:.3} (limited by {})",
                        h.x,
                        h.y,
                        h.z,
                        est.metrics.captures,
                        est.confidence.score,
                        est.confidence.limiting
                    ),
                ));
            }
            Err(e) => {
                let reason = match &e {
                    PerceptionError::NoCaptures => format!(
                        "no capture showed the wire ({} captures)",
                        self.captures_seen
                    ),
                    other => other.to_string(),
                };
                out.push(self.log(log_time, Log::WARN, format!("wire refused: {reason}")));
            }
        }
        out
    }
}

impl Stage for PerceiveStage {
    fn name(&self) -> &str {
        STAGE_NAME
    }

    fn inputs(&self) -> Vec<String> {
        [
            CLOCK,
            TF,
            TF_STATIC,
            JOINT_STATES,
            PANORAMIC_IMAGE,
            PANORAMIC_INFO,
            CAMERA_COLOR_INFO,
            CAMERA_COLOR_IMAGE,
            CAMERA_DEPTH_IMAGE,
        ]
        .iter()
        .map(|s| (*s).to_owned())
        .collect()
    }

    fn outputs(&self) -> Vec<(String, &'static str)> {
        vec![
            (ARM_JOINT_TRAJECTORY.to_owned(), JointTrajectory::TYPE_NAME),
            (ARM_PLANNED_PATH.to_owned(), Path::TYPE_NAME),
            (CAMERA_TRIGGER.to_owned(), Empty::TYPE_NAME),
            (PERCEPTION_ROI_CLOUD.to_owned(), PointCloud2::TYPE_NAME),
            (PERCEPTION_TARGET_POSE.to_owned(), PoseStamped::TYPE_NAME),
            (ROSOUT.to_owned(), Log::TYPE_NAME),
        ]
    }

    fn latency(&self) -> RobotDuration {
        self.config.latency
    }

    fn on_message(
        &mut self,
        log_time: RobotTime,
        topic: &str,
        msg: &Msg,
    ) -> Result<Vec<(String, Msg)>, StageError> {
        Ok(match (topic, msg) {
            (TF, Msg::TfMessage(m)) => {
                let _rejected = self.tf.insert_message(m, false);
                Vec::new()
            }
            (TF_STATIC, Msg::TfMessage(m)) => {
                let _rejected = self.tf.insert_message(m, true);
                Vec::new()
            }
            (PANORAMIC_INFO, Msg::CameraInfo(info)) => {
                self.panoramic_camera = CameraModel::from_camera_info(info).ok();
                Vec::new()
            }
            (CAMERA_COLOR_INFO, Msg::CameraInfo(info)) => {
                let camera = CameraModel::from_camera_info(info).ok();
                let same =
                    matches!((&self.wrist_camera, &camera), (Some((a, _)), Some(b)) if a == b);
                if !same {
                    self.wrist_camera = camera.and_then(|c| RayTable::new(&c).ok().map(|r| (c, r)));
                }
                Vec::new()
            }
            (PANORAMIC_IMAGE, Msg::Image(image)) => self.on_panoramic(log_time, image),
            (CAMERA_COLOR_IMAGE, Msg::Image(image)) => {
                if self.phase == Phase::Capturing {
                    self.colour.keep(time_ns(&image.header.stamp), image);
                }
                Vec::new()
            }
            (CAMERA_DEPTH_IMAGE, Msg::Image(image)) => self.on_depth(log_time, image),
            (JOINT_STATES, Msg::JointState(js)) => self.on_joint_state(js),
            (CLOCK, Msg::Clock(_)) => self.on_clock(log_time),
            _ => Vec::new(),
        })
    }
}
