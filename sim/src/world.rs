//! [`SimWorld`]: the deterministic robot-plus-substation that stands exactly where the
//! hardware drivers would ([`msgs::World`]).
//!
//! # Stepping
//! The world advances on a fixed 1 ms tick grid ([`crate::arm::TICK_NS`]); `step_until(t)`
//! runs every tick in `(previous, t]` and returns the messages whose log time is in that
//! interval, sorted by `(log_time, producer, topic)`. Each tick: devices advance (arm, lift,
//! clamp, base), wind and sway integrate, the bump happens when due, the rod updates (every
//! 10 ms), a due wrist exposure is rendered, then the periodic samples are taken. The first
//! call also emits the samples of t = 0. Outputs depend only on the tick grid, never on how
//! the caller splits its steps, and every random number is counter-based
//! ([`crate::rng`]): same scenario and seed, same bytes, for any thread count.
//!
//! # Commands ([`msgs::World::command`])
//! | topic | type | driver |
//! |---|---|---|
//! | `/arm/joint_trajectory` | JointTrajectory | [`ArmSim`] |
//! | `/lift/command` | Float64 (m) | [`LiftSim`] |
//! | `/base/goal` | PoseStamped (`map`) | [`BaseSim`] |
//! | `/clamp/command` | ClampCommand | [`ClampSim`] |
//! | `/camera/trigger` | Empty | [`WristCamera`] |
//! | `/wrist_light/command` | Float64 (0..1) | [`WristLightSim`] (with `camera.light`) |
//!
//! The world never moves by itself: only these commands move the robot.
//!
//! # Outputs (producer, topic, rate)
//! | producer | topic | rate |
//! |---|---|---|
//! | `arm_driver` | `/joint_states` (6 arm joints) | 100 Hz |
//! | `lift_driver` | `/joint_states` (`lift_joint`) | 100 Hz |
//! | `clamp_driver` | `/joint_states` (`clamp_joint`) | 100 Hz |
//! | `base_driver` | `/tf` (`map` -> `base_link`, odometry) | 50 Hz |
//! | `camera_driver` | `/camera/color/image_raw`, `/camera/depth/image_raw`, `/camera/color/camera_info` | on request, ~1 s |
//! | `panoramic_driver` | `/panoramic/image_raw`, `/panoramic/camera_info` | `panoramic.period_s` (1 Hz) |
//! | `anemometer` | `/env/wind` | 1 Hz |
//! | `lux_meter` | `/env/illuminance` | 1 Hz |
//! | `light_driver` | `/wrist_light/state` (with `camera.light`) | 10 Hz |
//! | `sim` | `/sim/...` truth ([`crate::truth`]) | 1-10 Hz |
//!
//! For every driver message `header.stamp` = sampling/exposure time and `publish_time` =
//! delivery time (equal to `log_time`, except camera images whose `publish_time` is the exact
//! ready time and whose `log_time` is the first tick at or after it).

use msgs::drivers::{
    ArmDriver, BaseDriver, CameraDriver, ClampDriver, DriverError, DriverOutput,
    EnvironmentSensors, LiftDriver, World,
};
use msgs::frames::{CAMERA_COLOR_OPTICAL_FRAME, MAP, TOOL0};
use msgs::geometry_msgs::PoseStamped;
use msgs::rodlog_msgs::ClampCommand;
use msgs::sensor_msgs::Illuminance;
use msgs::std_msgs::{Empty, Float64, Header, String as StringMsg};
use msgs::tf2_msgs::TfMessage;
use msgs::topics;
use msgs::trajectory_msgs::JointTrajectory;
use msgs::{Msg, RobotDuration, RobotTime};
use nalgebra::{Isometry3, Point3, Translation3, Unit, UnitQuaternion, Vector3};
use robot::RobotModel;

use crate::SimError;
use crate::arm::{ARM_DRIVER, ArmSim, TICK_NS, TICK_S, perturbed_dh};
use crate::base::{BASE_DRIVER, BaseSim, Planar};
use crate::bump::Bump;
use crate::cameras::{
    CAMERA_DRIVER, PANORAMIC_DRIVER, PANORAMIC_LATENCY, PanoramicCamera, WristCamera,
};
use crate::clamp::{CLAMP_DRIVER, ClampSim, WIRE_CONTACT_TRAVEL_M};
use crate::config::{RodStart, SimConfig};
use crate::environment::{ANEMOMETER, EnvironmentSim, LUX_METER, Wind, light_at};
use crate::lift::{LIFT_DRIVER, LiftSim};
use crate::rod::{Rod, RodInputs, RodState};
use crate::scene::{Scene, SubstationBuilder, SubstationLayout, SubstationParams};
use crate::truth::{HANDLE_CENTER_IN_ROD_M, SIM, hanging_point, pose_stamped};
use crate::wrist_light::{LIGHT_DRIVER, WristLightSim};

/// Joint-state period (100 Hz).
pub const JOINT_STATE_PERIOD_NS: u64 = 10_000_000;
/// Odometry period (50 Hz).
pub const ODOMETRY_PERIOD_NS: u64 = 20_000_000;
/// Environment sensors and slow truth period (1 Hz).
pub const SLOW_PERIOD_NS: u64 = 1_000_000_000;
/// Pose truth period (10 Hz).
pub const POSE_TRUTH_PERIOD_NS: u64 = 100_000_000;

/// `tool0_from_camera` from a translation (m) and roll-pitch-yaw (deg, fixed axes x, y, z).
#[must_use]
pub fn mount_from_config(xyz_m: [f64; 3], rpy_deg: [f64; 3]) -> Isometry3<f64> {
    robot::camera_mount::mount_from_xyz_rpy(xyz_m, rpy_deg)
}

/// `world_from_rod` of a rod clamped on the target conductor at the hanging point (the
/// conductor at the working spot's span position), as the hang flow leaves it: the hook
/// centre on the axis, its `y` along the wire, its `x` (the mouth) horizontal and pointing away
/// from the working spot, the rod upright.
#[must_use]
pub fn hung_rod_pose(layout: &SubstationLayout) -> Option<Isometry3<f64>> {
    let c = layout.target_conductor()?;
    let u = layout.world_from_robot_spot.translation.x - c.start.x;
    let hanging = hanging_point(c, &Isometry3::identity(), u);
    let p = Point3::from(hanging.translation.vector);
    let along = hanging.rotation * Vector3::x();
    let spot = Point3::from(layout.world_from_robot_spot.translation.vector);
    let mut away = p - spot;
    away.z = 0.0;
    let mut along_h = along;
    along_h.z = 0.0;
    let along_h = along_h.try_normalize(1e-9)?;
    let x = (away - along_h * away.dot(&along_h)).try_normalize(1e-9)?;
    let y = (along - x * along.dot(&x)).try_normalize(1e-9)?;
    let z = x.cross(&y);
    let (y, z) = if z.z < 0.0 { (-y, -z) } else { (y, z) };
    let world_from_hook = Isometry3::from_parts(
        Translation3::from(p.coords),
        UnitQuaternion::from_rotation_matrix(&nalgebra::Rotation3::from_basis_unchecked(&[
            x, y, z,
        ])),
    );
    Some(world_from_hook * crate::rod::rod_from_hook().inverse())
}

/// The simulated world. See the module docs.
#[derive(Debug)]
pub struct SimWorld {
    config: SimConfig,
    scene: Scene,
    layout: SubstationLayout,
    model: RobotModel,
    arm: ArmSim,
    lift: LiftSim,
    clamp: ClampSim,
    base: BaseSim,
    wrist: WristCamera,
    /// The wrist light, on a robot that has one (`camera.light`).
    light: Option<WristLightSim>,
    panoramic: PanoramicCamera,
    env: EnvironmentSim,
    wind: Wind,
    mount: Isometry3<f64>,
    bump: Option<Bump>,
    bumped: bool,
    rod: Rod,
    last_wire_sway: Isometry3<f64>,
    ticks: u64,
    started: bool,
    last: RobotTime,
    outbox: Vec<DriverOutput>,
}

/// The bay of a configuration: its scene and layout (`site.layout`, the seed).
///
/// # Errors
/// Scene errors.
pub fn site(config: &SimConfig) -> Result<(Scene, SubstationLayout), SimError> {
    let params = match config.site_layout {
        crate::config::SiteLayout::Fixed => SubstationParams::default(),
        crate::config::SiteLayout::Seeded => SubstationParams::seeded(config.seed),
    };
    Ok(SubstationBuilder::new(config.seed).params(params).build()?)
}

impl SimWorld {
    /// Builds the world of a configuration ([`SimConfig::from_params`]).
    ///
    /// # Errors
    /// Scene, camera or scenario errors.
    pub fn new(scenario: &SimConfig) -> Result<Self, SimError> {
        let seed = scenario.seed;
        let noise = scenario.noise_seed;
        let (scene, layout) = site(scenario)?;
        let model = RobotModel::nominal();
        let r = &scenario.robot;
        let true_dh = perturbed_dh(&model.dh, seed, r.perturbation);
        let sigma = if r.encoder_noise {
            r.encoder_noise_rad
        } else {
            0.0
        };
        let spot = layout.world_from_robot_spot;
        let (_, _, yaw) = spot.rotation.euler_angles();
        let start = match r.base_start {
            Some([x_m, y_m, yaw_rad]) => Planar { x_m, y_m, yaw_rad },
            None => Planar {
                x_m: spot.translation.x,
                y_m: spot.translation.y,
                yaw_rad: yaw,
            },
        };
        let bump = scenario
            .bump
            .as_ref()
            .map(|b| Bump::resolve(b, seed, scenario.duration_s))
            .transpose()?;
        let rod = match r.rod {
            RodStart::Rack => Rod::on_rack(layout.world_from_rod_stored),
            RodStart::Hung => Rod::clamped(
                layout.world_from_rod_stored,
                hung_rod_pose(&layout).ok_or(SimError::Layout {
                    reason: "the bay has no target conductor to hang the rod on".to_owned(),
                })?,
            ),
        };
        let wind = Wind::new(
            noise,
            scenario.wind,
            layout.params.sag_m,
            r.lift_m / robot::kinematics::LIFT_TRAVEL_M,
        );
        Ok(Self {
            arm: ArmSim::new(noise, true_dh, r.home_rad, sigma),
            lift: LiftSim::new(noise, r.lift_m, r.encoder_noise),
            clamp: ClampSim::new(noise, r.encoder_noise),
            base: BaseSim::new(noise, start, r.odometry_drift).on_ground(layout.ground),
            wrist: WristCamera::new(&scenario.camera, seed, noise)?,
            light: scenario.camera.light.then(WristLightSim::new),
            panoramic: PanoramicCamera::new(&scenario.panoramic, seed, noise)?,
            env: EnvironmentSim::new(noise, scenario.hour),
            wind,
            mount: mount_from_config(scenario.camera.mount_xyz_m, scenario.camera.mount_rpy_deg),
            bump,
            bumped: false,
            rod,
            last_wire_sway: Isometry3::identity(),
            scene,
            layout,
            model,
            ticks: 0,
            started: false,
            last: RobotTime::ZERO,
            outbox: Vec::new(),
            config: scenario.clone(),
        })
    }

    /// The configuration it runs.
    #[must_use]
    pub fn config(&self) -> &SimConfig {
        &self.config
    }

    /// The substation layout (truth).
    #[must_use]
    pub fn layout(&self) -> &SubstationLayout {
        &self.layout
    }

    /// The scene (with the movable objects where they were last rendered).
    #[must_use]
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The robot's nominal model.
    #[must_use]
    pub fn model(&self) -> &RobotModel {
        &self.model
    }

    /// The resolved bump, if any.
    #[must_use]
    pub fn bump(&self) -> Option<&Bump> {
        self.bump.as_ref()
    }

    /// True `tool0_from_camera` now.
    #[must_use]
    pub fn true_mount(&self) -> Isometry3<f64> {
        self.mount
    }

    /// The arm (true joints, true table).
    #[must_use]
    pub fn arm(&self) -> &ArmSim {
        &self.arm
    }

    /// The lift.
    #[must_use]
    pub fn lift(&self) -> &LiftSim {
        &self.lift
    }

    /// The base.
    #[must_use]
    pub fn base(&self) -> &BaseSim {
        &self.base
    }

    /// The rod.
    #[must_use]
    pub fn rod(&self) -> &Rod {
        &self.rod
    }

    /// True clamp travel (m) and whether the jaw presses on a contact.
    #[must_use]
    pub fn clamp_travel_m(&self) -> (f64, bool) {
        (self.clamp.travel_m(), self.clamp.pressing())
    }

    /// The wind process.
    #[must_use]
    pub fn wind(&self) -> &Wind {
        &self.wind
    }

    /// The wrist camera.
    #[must_use]
    pub fn wrist_camera(&self) -> &WristCamera {
        &self.wrist
    }

    /// Whether arm, lift, clamp and base are all at rest with nothing queued.
    #[must_use]
    pub fn robot_idle(&self) -> bool {
        self.arm.idle() && self.lift.idle() && self.clamp.idle() && self.base.idle()
    }

    /// True `base_from_lift` including the wind tilt of the column (about its foot).
    #[must_use]
    pub fn true_base_from_lift(&self) -> Isometry3<f64> {
        let map_from_base = self.base.map_from_base();
        let axis_map = Vector3::z().cross(&self.wind.direction());
        let axis_base = map_from_base.rotation.inverse() * axis_map;
        let tilt = Unit::try_new(axis_base, 1e-12).map_or_else(UnitQuaternion::identity, |a| {
            UnitQuaternion::from_axis_angle(&a, self.wind.platform_tilt_rad())
        });
        Isometry3::from_parts(Translation3::identity(), tilt)
            * self.model.base_from_lift(self.lift.height_m())
    }

    /// True `map_from_tool0`.
    #[must_use]
    pub fn true_map_from_tool0(&self) -> Isometry3<f64> {
        self.base.map_from_base()
            * self.true_base_from_lift()
            * self.model.lift_from_arm_base
            * self.arm.arm_base_from_tool0()
    }

    /// True `map_from_camera` (wrist camera, optical frame).
    #[must_use]
    pub fn true_map_from_camera(&self) -> Isometry3<f64> {
        self.true_map_from_tool0() * self.mount
    }

    /// `world_from_wire` of the target conductor's sway now.
    #[must_use]
    pub fn wire_sway_pose(&self) -> Isometry3<f64> {
        self.layout
            .target_conductor()
            .map_or_else(Isometry3::identity, |c| {
                c.sway_pose(self.wind.wire_sway_rad())
            })
    }

    /// Hanging point truth (see [`crate::truth`]).
    #[must_use]
    pub fn true_hanging_point(&self) -> Option<Isometry3<f64>> {
        let c = self.layout.target_conductor()?;
        let u = self.layout.world_from_robot_spot.translation.x - c.start.x;
        Some(hanging_point(c, &self.wire_sway_pose(), u))
    }

    fn push(
        &mut self,
        producer: &str,
        topic: &str,
        msg: Msg,
        log_time: RobotTime,
        publish_time: RobotTime,
    ) {
        self.outbox.push(DriverOutput {
            producer: producer.to_owned(),
            topic: topic.to_owned(),
            msg,
            log_time,
            publish_time,
        });
    }

    fn stamp(now: RobotTime) -> Result<msgs::builtin_interfaces::Time, DriverError> {
        now.to_ros().map_err(|e| DriverError::Fault {
            device: SIM.to_owned(),
            now,
            reason: e.to_string(),
        })
    }

    fn sync_scene(&mut self) -> Result<(), SimError> {
        for (k, c) in self.layout.conductors.iter().enumerate() {
            if let Some(id) = self.layout.conductor_objects.get(k) {
                self.scene
                    .set_object_pose(*id, c.sway_pose(self.wind.wire_sway_rad()))?;
            }
        }
        self.scene
            .set_object_pose(self.layout.rod_object, self.rod.world_from_rod)?;
        Ok(())
    }

    fn update_rod(&mut self, now: RobotTime) {
        let sway = self.wire_sway_pose();
        let wire_motion = sway * self.last_wire_sway.inverse();
        self.last_wire_sway = sway;
        let world_from_tool0 = self.true_map_from_tool0();
        let hook = self.rod.world_from_hook();
        let wire_near_hook = match self.layout.target_conductor() {
            Some(c) => {
                let local = sway.inverse() * Point3::from(hook.translation.vector);
                let cp = c.closest_point(&local);
                (sway * cp.point, sway.rotation * c.tangent_at(cp.u_m))
            }
            None => (Point3::new(f64::INFINITY, 0.0, 0.0), Vector3::x()),
        };
        let inputs = RodInputs {
            world_from_tool0,
            wire_near_hook,
            wire_motion,
            clamp_pressing: self.clamp.pressing(),
            clamp_travel_m: self.clamp.travel_m(),
        };
        let was_held = self.rod.held;
        let changed = self.rod.update(now, &inputs);
        if self.rod.held && !was_held {
            // The coupling engages the rod's screw where the rod's jaw is.
            let jaw = if self.rod.state == RodState::Clamped {
                WIRE_CONTACT_TRAVEL_M
            } else {
                0.0
            };
            self.clamp.couple(jaw);
        }
        if changed {
            let data = self.rod.state.as_str().to_owned();
            self.push(
                SIM,
                topics::SIM_ROD_STATE,
                StringMsg { data }.into(),
                now,
                now,
            );
        }
        // The clamp jaw meets the wire only when the rod is held on it.
        let contact = (self.rod.held
            && matches!(self.rod.state, RodState::Hooked | RodState::Clamped))
        .then_some(WIRE_CONTACT_TRAVEL_M);
        self.clamp.set_contact(contact);
    }

    fn tick(&mut self, now: RobotTime, physics: bool) -> Result<(), SimError> {
        let ns = now.as_nanos();
        if physics {
            self.arm.advance(now)?;
            self.lift.advance(now)?;
            self.clamp.advance(now)?;
            self.base.advance(now)?;
            let frac = self.lift.height_m() / robot::kinematics::LIFT_TRAVEL_M;
            self.wind.tick(TICK_S, ns, frac);
        }
        if let Some(b) = self.bump.filter(|b| !self.bumped && now >= b.time) {
            self.mount = b.apply(&self.mount);
            self.bumped = true;
            self.push_mount(now)?;
        }
        if ns.is_multiple_of(JOINT_STATE_PERIOD_NS) {
            self.update_rod(now);
        }
        if let Some(exposure) = self.wrist.exposure_due().filter(|e| *e <= now) {
            self.sync_scene()?;
            let pose = self.true_map_from_camera();
            let lamp = self.light.as_mut().and_then(|l| {
                l.advance(exposure);
                l.lamp()
            });
            let light = light_at(self.config.hour, exposure).with_lamp(lamp);
            self.wrist.expose(&self.scene, &pose, &light)?;
        }
        if let Some(c) = self.wrist.poll_capture(now)? {
            let ready = c.ready_at;
            self.push(
                CAMERA_DRIVER,
                topics::CAMERA_COLOR_IMAGE,
                c.color.into(),
                now,
                ready,
            );
            if let Some(d) = c.depth {
                self.push(
                    CAMERA_DRIVER,
                    topics::CAMERA_DEPTH_IMAGE,
                    d.into(),
                    now,
                    ready,
                );
            }
            let truth = self
                .wrist
                .intrinsics()
                .to_camera_info(c.camera_info.header.clone());
            self.push(
                CAMERA_DRIVER,
                topics::CAMERA_COLOR_INFO,
                c.camera_info.into(),
                now,
                ready,
            );
            self.push(SIM, topics::SIM_CAMERA_INFO, truth.into(), now, ready);
        }
        if ns.is_multiple_of(JOINT_STATE_PERIOD_NS) {
            let a = self.arm.joint_state(now)?;
            self.push(ARM_DRIVER, topics::JOINT_STATES, a.into(), now, now);
            let l = self.lift.joint_state(now)?;
            self.push(LIFT_DRIVER, topics::JOINT_STATES, l.into(), now, now);
            let c = self.clamp.joint_state(now)?;
            self.push(CLAMP_DRIVER, topics::JOINT_STATES, c.into(), now, now);
        }
        if ns.is_multiple_of(crate::wrist_light::STATE_PERIOD.as_nanos())
            && let Some(l) = self.light.as_mut()
        {
            l.advance(now);
            let state = l.state();
            self.push(
                LIGHT_DRIVER,
                topics::WRIST_LIGHT_STATE,
                state.into(),
                now,
                now,
            );
        }
        if ns.is_multiple_of(ODOMETRY_PERIOD_NS) {
            let odom = self.base.odometry(now)?;
            self.push(
                BASE_DRIVER,
                topics::TF,
                TfMessage {
                    transforms: vec![odom],
                }
                .into(),
                now,
                now,
            );
        }
        if ns.is_multiple_of(POSE_TRUTH_PERIOD_NS) {
            let stamp = Self::stamp(now)?;
            if let Some(hp) = self.true_hanging_point() {
                self.push(
                    SIM,
                    topics::SIM_WIRE_POSE,
                    pose_stamped(MAP, stamp, &hp).into(),
                    now,
                    now,
                );
            }
            self.push(
                SIM,
                topics::SIM_BASE_POSE,
                pose_stamped(MAP, stamp, &self.base.map_from_base()).into(),
                now,
                now,
            );
            let [hx, hy, hz] = HANDLE_CENTER_IN_ROD_M;
            let handle = self.rod.world_from_rod * Isometry3::translation(hx, hy, hz);
            self.push(
                SIM,
                topics::SIM_HANDLE_POSE,
                pose_stamped(MAP, stamp, &handle).into(),
                now,
                now,
            );
        }
        if ns.is_multiple_of(SLOW_PERIOD_NS) {
            self.env.wind_mean_3s_mps = self.wind.mean_3s_mps();
            let w = self.env.wind_mps(now)?;
            self.push(ANEMOMETER, topics::ENV_WIND, w.into(), now, now);
            let lx = self.env.illuminance(now)?;
            self.push(LUX_METER, topics::ENV_ILLUMINANCE, lx.into(), now, now);
            self.push(
                SIM,
                topics::SIM_WIND,
                Float64 {
                    data: self.wind.mean_3s_mps(),
                }
                .into(),
                now,
                now,
            );
            let truth = Illuminance {
                header: Header {
                    stamp: Self::stamp(now)?,
                    frame_id: msgs::frames::BASE_LINK.to_owned(),
                },
                illuminance: self.env.true_lux(now),
                variance: 0.0,
            };
            self.push(SIM, topics::SIM_ILLUMINANCE, truth.into(), now, now);
            self.push_mount(now)?;
            let data = self.rod.state.as_str().to_owned();
            self.push(
                SIM,
                topics::SIM_ROD_STATE,
                StringMsg { data }.into(),
                now,
                now,
            );
        }
        if self.panoramic.due(now) {
            self.sync_scene()?;
            let pose = self.base.map_from_base() * self.model.base_from_panoramic_optical;
            let light = light_at(self.config.hour, now);
            let (img, info) = self.panoramic.capture(&self.scene, &pose, &light, now)?;
            let truth = self
                .panoramic
                .intrinsics()
                .to_camera_info(info.header.clone());
            let at = now + PANORAMIC_LATENCY;
            self.push(
                PANORAMIC_DRIVER,
                topics::PANORAMIC_IMAGE,
                img.into(),
                at,
                at,
            );
            self.push(
                PANORAMIC_DRIVER,
                topics::PANORAMIC_INFO,
                info.into(),
                at,
                at,
            );
            self.push(SIM, topics::SIM_PANORAMIC_INFO, truth.into(), at, at);
        }
        Ok(())
    }

    fn push_mount(&mut self, now: RobotTime) -> Result<(), DriverError> {
        let m = robot::conversions::transform_stamped(
            TOOL0,
            CAMERA_COLOR_OPTICAL_FRAME,
            Self::stamp(now)?,
            &self.mount,
        );
        self.push(SIM, topics::SIM_CAMERA_MOUNT, m.into(), now, now);
        Ok(())
    }

    /// Runs to `log_time`; see [`World::step_until`].
    ///
    /// # Errors
    /// [`SimError::Driver`] (time going backwards, faults) and scene errors.
    pub fn run_until(&mut self, log_time: RobotTime) -> Result<Vec<DriverOutput>, SimError> {
        if log_time < self.last {
            return Err(DriverError::TimeWentBackwards {
                device: SIM.to_owned(),
                last: self.last,
                now: log_time,
            }
            .into());
        }
        if !self.started {
            self.started = true;
            self.tick(RobotTime::ZERO, false)?;
        }
        let target = log_time.as_nanos() / TICK_NS;
        while self.ticks < target {
            self.ticks += 1;
            self.tick(RobotTime::from_nanos(self.ticks * TICK_NS), true)?;
        }
        self.last = log_time;
        let mut ready = Vec::new();
        let mut keep = Vec::new();
        for o in self.outbox.drain(..) {
            if o.log_time <= log_time {
                ready.push(o)
            } else {
                keep.push(o)
            }
        }
        self.outbox = keep;
        ready.sort_by(|a, b| {
            (a.log_time, &a.producer, &a.topic).cmp(&(b.log_time, &b.producer, &b.topic))
        });
        Ok(ready)
    }

    fn unroutable(topic: &str, msg: &Msg) -> DriverError {
        DriverError::UnroutableCommand {
            topic: topic.to_owned(),
            type_name: msg.type_name(),
        }
    }
}

impl World for SimWorld {
    fn step_until(&mut self, log_time: RobotTime) -> Result<Vec<DriverOutput>, DriverError> {
        self.run_until(log_time).map_err(|e| match e {
            SimError::Driver(d) => d,
            other => DriverError::Fault {
                device: SIM.to_owned(),
                now: log_time,
                reason: other.to_string(),
            },
        })
    }

    fn command(&mut self, log_time: RobotTime, topic: &str, msg: &Msg) -> Result<(), DriverError> {
        if log_time < self.last {
            return Err(DriverError::TimeWentBackwards {
                device: SIM.to_owned(),
                last: self.last,
                now: log_time,
            });
        }
        match topic {
            topics::ARM_JOINT_TRAJECTORY => {
                let t = msg
                    .get::<JointTrajectory>()
                    .ok_or_else(|| Self::unroutable(topic, msg))?;
                self.arm.execute(log_time, t)
            }
            topics::LIFT_COMMAND => {
                let h = msg
                    .get::<Float64>()
                    .ok_or_else(|| Self::unroutable(topic, msg))?;
                self.lift.command_height(log_time, h)
            }
            topics::BASE_GOAL => {
                let g = msg
                    .get::<PoseStamped>()
                    .ok_or_else(|| Self::unroutable(topic, msg))?;
                self.base.command_goal(log_time, g)
            }
            topics::CLAMP_COMMAND => {
                let c = msg
                    .get::<ClampCommand>()
                    .ok_or_else(|| Self::unroutable(topic, msg))?;
                self.clamp.command(log_time, c)
            }
            topics::CAMERA_TRIGGER => {
                msg.get::<Empty>()
                    .ok_or_else(|| Self::unroutable(topic, msg))?;
                self.wrist.request_capture(log_time).map(|_| ())
            }
            topics::WRIST_LIGHT_COMMAND => {
                let b = msg
                    .get::<Float64>()
                    .ok_or_else(|| Self::unroutable(topic, msg))?;
                match self.light.as_mut() {
                    Some(l) => l.command(log_time, b),
                    None => Err(DriverError::Rejected {
                        device: LIGHT_DRIVER.to_owned(),
                        now: log_time,
                        reason: "this robot has no wrist light (scenario camera.light = false)"
                            .to_owned(),
                    }),
                }
            }
            _ => Err(Self::unroutable(topic, msg)),
        }
    }
}

/// Duration of one world tick.
pub const TICK: RobotDuration = RobotDuration::from_nanos(TICK_NS);
