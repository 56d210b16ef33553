//! The robot as the task stage's inputs report it: arm, lift and clamp from
//! `/joint_states`, odometry (`map -> base_link`) and every other edge from `/tf` and
//! `/tf_static`, the wrist and panoramic cameras from their `camera_info`, the wind from
//! `/env/wind` (the [`WindGate`]), the daylight from `/env/illuminance` and the wrist light
//! from `/wrist_light/state` ([`Lighting`]), and the wrist colour image waiting for its depth
//! image.
//! The log time of the latest input is the stage's only clock.

use msgs::RobotTime;
use msgs::frames::{BASE_LINK, CAMERA_COLOR_OPTICAL_FRAME, MAP, TOOL0};
use msgs::sensor_msgs::{CameraInfo, JointState};
use msgs::tf2_msgs::TfMessage;
use nalgebra::Isometry3;
use robot::{JointKind, TfBuffer, TfError};

use super::action::{AT_REST_RAD_S, BASE_STILL_M, BASE_STILL_RAD, CLAMP_REST_M_S};
use super::config::TaskConfig;
use super::flow::Stop;
use crate::perception::colour::PendingColour;
use crate::perception::point_cloud::{CameraModel, RayTable};
use crate::tasks::lighting::Lighting;
use crate::tasks::safety::WindGate;
use crate::tasks::site::BasePose;

/// The robot as measured (module docs).
#[derive(Debug)]
pub(crate) struct RobotState {
    /// Log time of the input being handled.
    pub now: RobotTime,
    /// Every transform received.
    pub tf: TfBuffer,
    /// The wind gate, fed by `/env/wind`.
    pub gate: WindGate,
    /// The wrist camera and its ray table.
    pub wrist: Option<(CameraModel, RayTable)>,
    /// The panoramic camera.
    pub panoramic_camera: Option<CameraModel>,
    /// Arm joints (rad), once all six were reported finite.
    pub q: Option<[f64; 6]>,
    /// Every arm joint slower than [`AT_REST_RAD_S`] in the latest arm state.
    pub arm_at_rest: bool,
    /// Lift height (m).
    pub lift_m: Option<f64>,
    /// Lift speed (m/s).
    pub lift_speed_m_s: f64,
    /// Clamp travel (m).
    pub clamp_m: Option<f64>,
    /// Since when the clamp has been slower than [`CLAMP_REST_M_S`] (reset when a clamp
    /// action starts).
    pub clamp_rest_since: Option<RobotTime>,
    /// The travel at which the clamp last pressed on something (effort at half the torque
    /// limit or more) since a clamp action started.
    pub clamp_pressed_m: Option<f64>,
    /// The effort that counts as pressing (N m): half the clamp's torque limit.
    clamp_press_nm: f64,
    /// The latest odometry sample (its log time, the base pose in `map`).
    pub odometry: Option<(RobotTime, BasePose)>,
    /// Stamp of the latest odometry sample.
    odometry_stamp_ns: Option<u64>,
    /// Since when consecutive odometry samples have been still.
    pub base_still_since: Option<RobotTime>,
    /// The wrist colour image of the capture in progress.
    pub colour: PendingColour,
    /// The wrist light's state and the lux meter.
    pub lighting: Lighting,
    /// `tool0_from_camera` until `/tf` carries the camera edge.
    nominal_tool0_from_camera: Isometry3<f64>,
}

/// The planar base pose of `map_from_base`.
pub(crate) fn base_pose_of(map_from_base: &Isometry3<f64>) -> BasePose {
    BasePose {
        x_m: map_from_base.translation.x,
        y_m: map_from_base.translation.y,
        yaw_rad: map_from_base.rotation.euler_angles().2,
    }
}

impl RobotState {
    /// Nothing measured yet.
    pub fn new(config: &TaskConfig) -> Self {
        Self {
            now: RobotTime::ZERO,
            tf: TfBuffer::default(),
            gate: WindGate::new(config.wind),
            wrist: None,
            panoramic_camera: None,
            q: None,
            arm_at_rest: false,
            lift_m: None,
            lift_speed_m_s: 0.0,
            clamp_m: None,
            clamp_rest_since: None,
            clamp_pressed_m: None,
            clamp_press_nm: 0.5 * config.clamp_torque_nm,
            odometry: None,
            odometry_stamp_ns: None,
            base_still_since: None,
            colour: PendingColour::default(),
            lighting: Lighting::default(),
            nominal_tool0_from_camera: config.nominal_tool0_from_camera,
        }
    }

    /// `/tf`: every edge; a new `map -> base_link` sample updates the odometry and whether
    /// the base is still.
    pub fn on_tf(&mut self, m: &TfMessage) {
        let _rejected = self.tf.insert_message(m, false);
        if let Ok((stamp_ns, base_from_map)) = self.tf.lookup_latest(BASE_LINK, MAP)
            && self.odometry_stamp_ns != Some(stamp_ns)
        {
            let pose = base_pose_of(&base_from_map.inverse());
            let still = self.odometry.is_some_and(|(_, p)| {
                (p.x_m - pose.x_m).hypot(p.y_m - pose.y_m) < BASE_STILL_M
                    && robot::se3::wrap_to_pi(p.yaw_rad - pose.yaw_rad).abs() < BASE_STILL_RAD
            });
            if still {
                self.base_still_since.get_or_insert(self.now);
            } else {
                self.base_still_since = None;
            }
            self.odometry_stamp_ns = Some(stamp_ns);
            self.odometry = Some((self.now, pose));
        }
    }

    /// `/tf_static`.
    pub fn on_tf_static(&mut self, m: &TfMessage) {
        let _rejected = self.tf.insert_message(m, true);
    }

    /// `/joint_states`: the lift, the clamp, and the arm when all six joints are finite.
    pub fn on_joint_state(&mut self, js: &JointState) {
        let mut q = self.q.unwrap_or([f64::NAN; 6]);
        let mut arm = 0;
        let mut at_rest = true;
        for (k, name) in js.name.iter().enumerate() {
            let position = js.position.get(k).copied();
            let velocity = js.velocity.get(k).copied().unwrap_or(0.0);
            match JointKind::from_name(name) {
                Some(JointKind::Lift) => {
                    self.lift_m = position.or(self.lift_m);
                    self.lift_speed_m_s = velocity;
                }
                Some(JointKind::Arm(i)) if i < 6 => {
                    q[i] = position.unwrap_or(f64::NAN);
                    at_rest &= velocity.abs() < AT_REST_RAD_S;
                    arm += 1;
                }
                _ if name == msgs::frames::CLAMP_JOINT => {
                    self.clamp_m = position.or(self.clamp_m);
                    let effort = js.effort.get(k).copied().unwrap_or(0.0);
                    if effort.abs() >= self.clamp_press_nm {
                        self.clamp_pressed_m = position.or(self.clamp_pressed_m);
                    }
                    if velocity.abs() < CLAMP_REST_M_S {
                        self.clamp_rest_since.get_or_insert(self.now);
                    } else {
                        self.clamp_rest_since = None;
                    }
                }
                _ => {}
            }
        }
        if arm == 6 && q.iter().all(|v| v.is_finite()) {
            self.q = Some(q);
            self.arm_at_rest = at_rest;
        }
    }

    /// `/panoramic/camera_info`.
    pub fn on_panoramic_info(&mut self, info: &CameraInfo) {
        self.panoramic_camera = CameraModel::from_camera_info(info).ok();
    }

    /// `/camera/color/camera_info`: the ray table is rebuilt only when the camera changes.
    pub fn on_wrist_info(&mut self, info: &CameraInfo) {
        let camera = CameraModel::from_camera_info(info).ok();
        let same = matches!((&self.wrist, &camera), (Some((a, _)), Some(b)) if a == b);
        if !same {
            self.wrist = camera.and_then(|c| RayTable::new(&c).ok().map(|r| (c, r)));
        }
    }

    /// The arm's joints.
    ///
    /// # Errors
    /// `no_joint_states` before the arm reported.
    pub fn q(&self) -> Result<[f64; 6], Stop> {
        self.q
            .ok_or_else(|| Stop::failed("no_joint_states", "no arm /joint_states yet"))
    }

    /// The lift's height (m).
    ///
    /// # Errors
    /// `no_joint_states` before the lift reported.
    pub fn lift(&self) -> Result<f64, Stop> {
        self.lift_m
            .ok_or_else(|| Stop::failed("no_joint_states", "no lift /joint_states yet"))
    }

    /// The latest `base_link -> map`.
    ///
    /// # Errors
    /// `no_odometry` before the odometry reported.
    pub fn base_from_map(&self) -> Result<Isometry3<f64>, Stop> {
        self.tf
            .lookup_latest(BASE_LINK, MAP)
            .map(|(_, t)| t)
            .map_err(|e| Stop::failed("no_odometry", format!("no map -> base_link: {e}")))
    }

    /// `base_link -> tool0` at `stamp_ns`, else the latest.
    ///
    /// # Errors
    /// When `/tf` has no such chain.
    pub fn base_from_tool0_at(&self, stamp_ns: u64) -> Result<Isometry3<f64>, TfError> {
        self.tf
            .lookup(BASE_LINK, TOOL0, stamp_ns)
            .or_else(|_| self.tf.lookup_latest(BASE_LINK, TOOL0).map(|(_, t)| t))
    }

    /// The camera edge at `stamp_ns` (else the latest, else the nominal mount).
    pub fn tool0_from_camera(&self, stamp_ns: u64) -> Isometry3<f64> {
        self.tf
            .lookup(TOOL0, CAMERA_COLOR_OPTICAL_FRAME, stamp_ns)
            .or_else(|_| {
                self.tf
                    .lookup_latest(TOOL0, CAMERA_COLOR_OPTICAL_FRAME)
                    .map(|(_, t)| t)
            })
            .unwrap_or(self.nominal_tool0_from_camera)
    }

    /// The camera edge now.
    pub fn tool0_from_camera_now(&self) -> Isometry3<f64> {
        self.tool0_from_camera(self.now.as_nanos())
    }
}
