//! A test rig for the task stage: a small deterministic robot and site that answer the
//! stage's commands at the message level, fast.
//!
//! Every [`TICK`] the rig publishes `/clock`, `/joint_states` (arm, lift, clamp, at rest),
//! the robot's `/tf` for them (the `robot_state` stage's edges), the odometry
//! `map -> base_link`, and on whole seconds `/env/wind`, the cameras' `camera_info` and a
//! panoramic frame ([`synthetic::render_wire_rgb`]). Commands are obeyed at once: the arm
//! jumps to a trajectory's last point, the lift and the base to their goals; a camera
//! trigger is answered on the next tick by a synthetic depth image
//! ([`synthetic::render_depth`]) of what the wrist camera sees from where the arm is (the
//! wire, the stored rod's handle, the hung rod's handle); `solve` is answered by the next
//! scripted calibration verdict. The clamp follows the rod: a close at the wire stops at
//! the contact travel when the hook holds the wire, a grasp couples the clamp joint to the
//! rod's jaw, each as scripted in [`Behaviour`].

use std::collections::VecDeque;

use msgs::builtin_interfaces::Time;
use msgs::frames::{BASE_LINK, CLAMP_JOINT, LIFT_JOINT, MAP};
use msgs::rodlog_msgs::{ClampCommand, TaskEvent};
use msgs::rosgraph_msgs::Clock;
use msgs::sensor_msgs::{Image, JointState};
use msgs::std_msgs::{Float64, Header};
use msgs::tf2_msgs::TfMessage;
use msgs::topics::{
    ARM_JOINT_TRAJECTORY, BASE_GOAL, CALIBRATION_COMMAND, CAMERA_COLOR_INFO, CAMERA_DEPTH_IMAGE,
    CAMERA_TRIGGER, CLAMP_COMMAND, CLOCK, ENV_WIND, JOINT_STATES, LIFT_COMMAND, PANORAMIC_IMAGE,
    PANORAMIC_INFO, TASK_EVENT, TF, TF_STATIC,
};
use msgs::{Msg, RobotDuration, RobotTime, Stage};
use nalgebra::{Isometry3, Point3, UnitQuaternion, Vector3};
use robot::RobotModel;
use robot::grounding_rod::{
    HANDLE_CENTER_IN_ROD_M, HANDLE_LENGTH_M, HANDLE_RADIUS_M, WIRE_CONTACT_TRAVEL_M, rod_from_hook,
    rod_from_tool0_grasp,
};
use robot::robot_state::{RobotStateConfig, RobotStateStage};

use crate::perception::WIRE_RADIUS_M;
use crate::perception::point_cloud::{CameraModel, RayTable, wrist_nominal};
use crate::perception::synthetic::{
    self, BoxShape, CylinderShape, NoiseModel, Scene, render_depth, render_wire_rgb,
};
use crate::stages::task::{TaskConfig, TaskKind, TaskStage};
use crate::tasks::poses;
use crate::tasks::site::{BasePose, SiteMap};
use rng::SplitMix64;

/// The rig's period.
pub const TICK: RobotDuration = RobotDuration::from_millis(50);

/// What the simulated robot and site do.
#[derive(Debug, Clone)]
pub struct Behaviour {
    /// The anemometer's 3-s mean (m/s) at time `t` (s), or silence.
    pub wind: fn(f64) -> Option<f64>,
    /// The base's odometry on `/tf`.
    pub odometry: bool,
    /// The base obeys `/base/goal`.
    pub base_moves: bool,
    /// The arm's edges on `/tf` (`robot_state`).
    pub arm_tf: bool,
    /// The wrist camera's `camera_info`.
    pub wrist_info: bool,
    /// Depth images in an encoding the stage cannot read.
    pub bad_depth: bool,
    /// The wrist depth noise at 0.5 m (m, 1 sigma; growing with the square of the depth).
    pub depth_noise_m: f64,
    /// The wire `(point, direction)` in `map`, seen by both cameras.
    pub wire: Option<(Point3<f64>, Vector3<f64>)>,
    /// The panoramic frames show the wire.
    pub panoramic_wire: bool,
    /// The wrist captures show the wire.
    pub wrist_wire: bool,
    /// `map_from_rod` of the stored rod (its handle is seen), if in the rack.
    pub stored_rod: Option<Isometry3<f64>>,
    /// `map_from_rack` of the rack whose parts the wrist camera sees (the remove's empty
    /// rack), if any.
    pub rack: Option<Isometry3<f64>>,
    /// `map_from_rod` of the rod on the wire, if hung.
    pub hung_rod: Option<Isometry3<f64>>,
    /// The hung rod sways: its handle is this far along the wire (m), alternately either side,
    /// in consecutive captures.
    pub sway_m: f64,
    /// The wire swings: in capture `k` it is `wire_sway_m sin(1.3 k)` across itself,
    /// horizontally (m).
    pub wire_sway_m: f64,
    /// A clamp that lands on the wire presses on it for a tick, then runs on to full travel
    /// unloaded (the swinging wire pulled the clamped rod out of the gripper).
    pub rod_pulled: bool,
    /// Whether each close of the clamp at the wire lands on it, in order (the last repeats).
    pub hook_hits: Vec<bool>,
    /// Whether each grasp couples the rod, in order (the last repeats).
    pub grasp_couples: Vec<bool>,
    /// The calibration stage's verdicts (`reason_code`), in order; none: it stays silent.
    pub calibration: VecDeque<&'static str>,
}

impl Behaviour {
    /// A calm, well-behaved bay: the wire and the stored rod where the site map says, every
    /// hook and grasp lands, the check finds the calibration consistent.
    pub fn nominal(site: &SiteMap) -> Self {
        Self {
            wind: |_| Some(0.5),
            odometry: true,
            base_moves: true,
            arm_tf: true,
            wrist_info: true,
            bad_depth: false,
            depth_noise_m: synthetic::NOISE_AT_HALF_METRE_M,
            wire: Some((site.wire.point, site.wire.direction)),
            panoramic_wire: true,
            wrist_wire: true,
            stored_rod: Some(site.map_from_stored_rod()),
            rack: None,
            hung_rod: None,
            sway_m: 0.0,
            wire_sway_m: 0.0,
            rod_pulled: false,
            hook_hits: vec![true],
            grasp_couples: vec![true],
            calibration: VecDeque::from(["consistent"]),
        }
    }
}

/// One output of the stage with its log time.
#[derive(Debug, Clone)]
pub struct Output {
    /// Log time of the input that triggered it.
    pub at: RobotTime,
    /// Topic.
    pub topic: String,
    /// Message.
    pub msg: Msg,
}

/// A `/task/event` in short.
#[derive(Debug, Clone, PartialEq)]
pub struct Event {
    /// `task` (`hang`, `remove`, `check`).
    pub task: String,
    /// `state` (the step).
    pub state: String,
    /// `kind` ([`TaskEvent::INFO`], ...).
    pub kind: u8,
    /// `reason_code`.
    pub reason: String,
    /// `text`.
    pub text: String,
}

/// The rig (module docs).
pub struct Rig {
    /// The stage under test.
    pub stage: TaskStage,
    /// What the world does.
    pub behaviour: Behaviour,
    /// Every output so far.
    pub outputs: Vec<Output>,
    now: RobotTime,
    model: RobotModel,
    state_pub: RobotStateStage,
    q: [f64; 6],
    lift_m: f64,
    clamp_m: f64,
    /// The clamp's effort in the next joint state (N m).
    clamp_effort_nm: f64,
    /// The base's pose in `map` (a test may place it before the drive).
    pub base: BasePose,
    wrist: CameraModel,
    rays: RayTable,
    panoramic: CameraModel,
    trigger: bool,
    /// `check` or `calibrate` once a batch began.
    calibration_mode: Option<&'static str>,
    answer_due: bool,
    closes_at_wire: usize,
    grasps: usize,
    captures: usize,
    tool0_from_camera: Isometry3<f64>,
}

/// The wrist camera at a quarter of its resolution (320x256), as the tests' simulator runs.
fn small_wrist() -> CameraModel {
    let c = wrist_nominal();
    CameraModel::pinhole(
        320,
        256,
        c.fx * 0.25,
        c.fy * 0.25,
        (c.cx + 0.5) * 0.25 - 0.5,
        (c.cy + 0.5) * 0.25 - 0.5,
    )
    .with_distortion(c.distortion())
}

/// The panoramic camera: 640x360, ~115 deg wide, barrel distortion.
fn panoramic_camera() -> CameraModel {
    CameraModel::pinhole(640, 360, 260.0, 260.0, 319.5, 179.5)
        .with_distortion([-0.12, 0.01, 0.0, 0.0, 0.0])
}

/// `map_from_rod` of a rod hung by the hang flow on the site's prior wire, the base at its
/// working spot: where the remove finds it.
pub fn rod_hung_on_prior(site: &SiteMap, model: &RobotModel) -> Option<Isometry3<f64>> {
    let map_from_base = site.work_spot.isometry();
    let base_from_map = map_from_base.inverse();
    let point = base_from_map * site.wire.point;
    let dir = base_from_map.rotation * site.wire.direction;
    let arm_base = model.base_from_arm_base(0.0) * Point3::origin();
    let hook = poses::hook_goal(&point, &dir, &arm_base).ok()?;
    Some(map_from_base * hook * rod_from_hook().inverse())
}

fn stamp(t: RobotTime) -> Time {
    t.to_ros().unwrap_or_default()
}

impl Rig {
    /// A rig for `config`, the base parked 1 m short of the working spot (so that the drive
    /// step moves it), the arm stowed, the lift down, the clamp open.
    pub fn new(config: TaskConfig, behaviour: Behaviour) -> Self {
        let model = config.model.clone();
        let spot = config.site.work_spot;
        let stow = config.stow_rad;
        let tool0_from_camera = config.nominal_tool0_from_camera;
        let wrist = small_wrist();
        let rays = match RayTable::new(&wrist) {
            Ok(r) => r,
            Err(e) => panic!("ray table: {e}"),
        };
        let stage = match TaskStage::new(config) {
            Ok(s) => s,
            Err(e) => panic!("stage: {e}"),
        };
        Self {
            stage,
            behaviour,
            outputs: Vec::new(),
            now: RobotTime::ZERO,
            state_pub: RobotStateStage::new(model.clone(), RobotStateConfig::default()),
            model,
            q: stow,
            lift_m: 0.0,
            clamp_m: 0.0,
            clamp_effort_nm: 0.0,
            base: BasePose {
                x_m: spot.x_m,
                y_m: spot.y_m - 1.0,
                yaw_rad: spot.yaw_rad,
            },
            wrist,
            rays,
            panoramic: panoramic_camera(),
            trigger: false,
            calibration_mode: None,
            answer_due: false,
            closes_at_wire: 0,
            grasps: 0,
            captures: 0,
            tool0_from_camera,
        }
    }

    /// A rig for a task of `kind` with the default configuration changed by `edit`.
    pub fn with(kind: TaskKind, edit: impl FnOnce(&mut TaskConfig, &mut Behaviour)) -> Self {
        let mut config = TaskConfig {
            kind,
            ..TaskConfig::default()
        };
        let mut behaviour = Behaviour::nominal(&config.site);
        if matches!(kind, TaskKind::Remove) {
            behaviour.hung_rod = rod_hung_on_prior(&config.site, &config.model);
            behaviour.stored_rod = None;
            behaviour.rack = Some(config.site.map_from_rack);
        }
        edit(&mut config, &mut behaviour);
        Self::new(config, behaviour)
    }

    /// Feeds one message to the stage and obeys its commands.
    pub fn feed(&mut self, topic: &str, msg: Msg) {
        let out = match self.stage.on_message(self.now, topic, &msg) {
            Ok(out) => out,
            Err(e) => panic!("the stage failed on {topic}: {e}"),
        };
        for (topic, msg) in out {
            self.obey(&topic, &msg);
            self.outputs.push(Output {
                at: self.now,
                topic,
                msg,
            });
        }
    }

    fn obey(&mut self, topic: &str, msg: &Msg) {
        let step = self.stage.step();
        match (topic, msg) {
            (ARM_JOINT_TRAJECTORY, Msg::JointTrajectory(t)) => {
                if let Some(last) = t.points.last() {
                    for (k, name) in t.joint_names.iter().enumerate() {
                        if let (Some(robot::JointKind::Arm(i)), Some(p)) =
                            (robot::JointKind::from_name(name), last.positions.get(k))
                            && let Some(q) = self.q.get_mut(i)
                        {
                            *q = *p;
                        }
                    }
                }
                self.after_arm_move(step);
            }
            (LIFT_COMMAND, Msg::Float64(f)) => self.lift_m = f.data,
            (BASE_GOAL, Msg::PoseStamped(p)) if self.behaviour.base_moves => {
                let q = p.pose.orientation;
                let yaw =
                    UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(q.w, q.x, q.y, q.z))
                        .euler_angles()
                        .2;
                self.base = BasePose {
                    x_m: p.pose.position.x,
                    y_m: p.pose.position.y,
                    yaw_rad: yaw,
                };
            }
            (CLAMP_COMMAND, Msg::ClampCommand(c)) => self.clamp(step, c.action),
            (CAMERA_TRIGGER, _) => self.trigger = true,
            (CALIBRATION_COMMAND, Msg::String(s)) => match s.data.as_str() {
                "check" => self.calibration_mode = Some("check"),
                "collect" => self.calibration_mode = Some("calibrate"),
                "solve" => self.answer_due = true,
                _ => {}
            },
            _ => {}
        }
    }

    /// The grasp steps' approach ends at the handle: the rod couples when it does.
    fn after_arm_move(&mut self, step: &str) {
        let jaw = match step {
            "grasp_rack" => 0.0,
            "grasp_handle" => WIRE_CONTACT_TRAVEL_M,
            _ => return,
        };
        let couples = nth_or_last(&self.behaviour.grasp_couples, self.grasps);
        self.grasps += 1;
        if couples {
            self.clamp_m = jaw;
            // The rod moves with the tool now.
            if step == "grasp_rack" {
                self.behaviour.stored_rod = None;
            } else {
                self.behaviour.hung_rod = None;
            }
        }
    }

    fn clamp(&mut self, step: &str, action: u8) {
        self.clamp_effort_nm = 0.0;
        if action == ClampCommand::OPEN {
            self.clamp_m = 0.0;
            return;
        }
        if step != "close_clamp" {
            // Empty (the coupling probe): full travel.
            self.clamp_m = robot::grounding_rod::CLAMP_TRAVEL_M;
            return;
        }
        let hit = nth_or_last(&self.behaviour.hook_hits, self.closes_at_wire);
        self.closes_at_wire += 1;
        if hit {
            self.clamp_m = WIRE_CONTACT_TRAVEL_M;
            self.clamp_effort_nm = 8.0;
            let map_from_tool0 = self.map_from_base() * self.base_from_tool0();
            self.behaviour.hung_rod = Some(map_from_tool0 * rod_from_tool0_grasp().inverse());
        } else {
            self.clamp_m = robot::grounding_rod::CLAMP_TRAVEL_M;
        }
    }

    fn map_from_base(&self) -> Isometry3<f64> {
        self.base.isometry()
    }

    fn base_from_tool0(&self) -> Isometry3<f64> {
        self.model.base_from_tool0(self.lift_m, &self.q)
    }

    /// One tick of the world (module docs).
    pub fn tick(&mut self) {
        self.now += TICK;
        let now = self.now;
        // Once a second, and at the first tick.
        let periodic =
            now.as_nanos().is_multiple_of(1_000_000_000) || now.as_nanos() == TICK.as_nanos();
        self.feed(CLOCK, Clock { clock: stamp(now) }.into());
        if now.as_nanos() == TICK.as_nanos() {
            let statics = self.state_pub.static_transforms(stamp(now));
            self.feed(TF_STATIC, statics.into());
        }
        let mut names: Vec<String> = vec![LIFT_JOINT.to_owned()];
        names.extend(robot::names::ARM_JOINTS.iter().map(|s| (*s).to_owned()));
        names.push(CLAMP_JOINT.to_owned());
        let mut position = vec![self.lift_m];
        position.extend(self.q);
        position.push(self.clamp_m);
        let mut effort = vec![0.0; names.len()];
        if let Some(e) = effort.last_mut() {
            *e = self.clamp_effort_nm;
        }
        if self.behaviour.rod_pulled && self.clamp_effort_nm > 0.0 {
            // Pressed for this tick; then pulled out of the gripper, the jaw runs on.
            self.clamp_m = robot::grounding_rod::CLAMP_TRAVEL_M;
            self.clamp_effort_nm = 0.0;
        }
        let js = JointState {
            header: Header {
                stamp: stamp(now),
                frame_id: String::new(),
            },
            velocity: vec![0.0; names.len()],
            effort,
            name: names,
            position,
        };
        if self.behaviour.arm_tf
            && let Ok(tf) = self.state_pub.transforms_for(&js)
        {
            self.feed(TF, tf.into());
        }
        self.feed(JOINT_STATES, js.into());
        if self.behaviour.odometry {
            let odometry = TfMessage {
                transforms: vec![robot::conversions::transform_stamped(
                    MAP,
                    BASE_LINK,
                    stamp(now),
                    &self.map_from_base(),
                )],
            };
            self.feed(TF, odometry.into());
        }
        if periodic {
            if let Some(w) = (self.behaviour.wind)(now.as_secs_f64()) {
                self.feed(ENV_WIND, Float64 { data: w }.into());
            }
            let header = Header {
                stamp: stamp(now),
                frame_id: String::new(),
            };
            if self.behaviour.wrist_info {
                let info = self.wrist.to_camera_info(header.clone());
                self.feed(CAMERA_COLOR_INFO, info.into());
            }
            self.feed(
                PANORAMIC_INFO,
                self.panoramic.to_camera_info(header.clone()).into(),
            );
            let image = self.panoramic_image(header);
            self.feed(PANORAMIC_IMAGE, image.into());
        }
        if std::mem::take(&mut self.trigger) {
            let image = self.depth_image();
            self.feed(CAMERA_DEPTH_IMAGE, image.into());
        }
        if std::mem::take(&mut self.answer_due)
            && let Some(reason) = self.behaviour.calibration.pop_front()
        {
            let event = TaskEvent {
                header: Header {
                    stamp: stamp(now),
                    frame_id: String::new(),
                },
                task: "calibration".to_owned(),
                state: self.calibration_mode.unwrap_or("check").to_owned(),
                kind: TaskEvent::DONE,
                reason_code: reason.to_owned(),
                text: format!("the calibration stage says {reason}"),
            };
            self.feed(TASK_EVENT, event.into());
        }
    }

    fn panoramic_image(&self, header: Header) -> Image {
        let map_from_camera = self.map_from_base() * self.model.base_from_panoramic_optical;
        let wire = self
            .behaviour
            .wire
            .filter(|_| self.behaviour.panoramic_wire);
        let data = render_wire_rgb(&self.panoramic, &map_from_camera, wire, WIRE_RADIUS_M);
        Image {
            header,
            height: self.panoramic.height,
            width: self.panoramic.width,
            encoding: "rgb8".to_owned(),
            is_bigendian: 0,
            step: self.panoramic.width * 3,
            data,
        }
    }

    /// What the wrist camera sees now, as a depth image stamped now.
    fn depth_image(&mut self) -> Image {
        let map_from_camera =
            self.map_from_base() * self.base_from_tool0() * self.tool0_from_camera;
        let camera_from_map = map_from_camera.inverse();
        let mut scene = Scene::default();
        if let Some((point, direction)) = self.behaviour.wire.filter(|_| self.behaviour.wrist_wire)
        {
            let across = Vector3::z().cross(&direction).normalize();
            let swing = self.behaviour.wire_sway_m * (1.3 * self.captures as f64).sin();
            scene.cylinders.push(CylinderShape {
                centre: camera_from_map * (point + across * swing),
                direction: (camera_from_map.rotation * direction).normalize(),
                radius_m: WIRE_RADIUS_M,
                half_length_m: 5.0,
            });
        }
        let sway = if self.captures.is_multiple_of(2) {
            1.0
        } else {
            -1.0
        } * self.behaviour.sway_m;
        let wire_dir = self
            .behaviour
            .wire
            .map_or(Vector3::x(), |(_, d)| d.normalize());
        let handles = [
            (self.behaviour.stored_rod, Vector3::zeros()),
            (self.behaviour.hung_rod, wire_dir * sway),
        ];
        for (rod, shift) in handles {
            let Some(map_from_rod) = rod else {
                continue;
            };
            let [hx, hy, hz] = HANDLE_CENTER_IN_ROD_M;
            let centre = map_from_rod * Point3::new(hx, hy, hz) + shift;
            scene.cylinders.push(CylinderShape {
                centre: camera_from_map * centre,
                direction: camera_from_map.rotation * (map_from_rod.rotation * Vector3::z()),
                radius_m: HANDLE_RADIUS_M,
                half_length_m: HANDLE_LENGTH_M * 0.5,
            });
        }
        if let Some(map_from_rack) = self.behaviour.rack {
            for (_, centre, half) in crate::tasks::survey::RACK_PARTS {
                scene.boxes.push(BoxShape {
                    camera_from_box: camera_from_map
                        * map_from_rack
                        * Isometry3::translation(centre[0], centre[1], centre[2]),
                    half_extents_m: Vector3::from(half),
                });
            }
        }
        self.captures += 1;
        let mut rng = SplitMix64::new(0x5EED + self.captures as u64);
        let noise = NoiseModel {
            sigma_at_half_metre_m: self.behaviour.depth_noise_m,
            ..NoiseModel::default()
        };
        let depth = render_depth(&scene, &self.rays, &noise, &mut rng);
        let mut image = depth.to_image(Header {
            stamp: stamp(self.now),
            frame_id: msgs::frames::CAMERA_COLOR_OPTICAL_FRAME.to_owned(),
        });
        if self.behaviour.bad_depth {
            image.encoding = "mono8".to_owned();
        }
        image
    }

    /// Ticks until the task ends or `limit_s` of log time passed.
    pub fn run(&mut self, limit_s: f64) {
        while self.stage.step() != "finished" && self.now.as_secs_f64() < limit_s {
            self.tick();
        }
    }

    /// Ticks until `stop` holds or `limit_s` of log time passed.
    pub fn run_until(&mut self, limit_s: f64, stop: impl Fn(&Self) -> bool) {
        while !stop(self) && self.now.as_secs_f64() < limit_s {
            self.tick();
        }
    }

    /// Every `/task/event` so far.
    pub fn events(&self) -> Vec<Event> {
        self.outputs
            .iter()
            .filter_map(|o| match (&*o.topic, &o.msg) {
                (TASK_EVENT, Msg::TaskEvent(e)) => Some(Event {
                    task: e.task.clone(),
                    state: e.state.clone(),
                    kind: e.kind,
                    reason: e.reason_code.clone(),
                    text: e.text.clone(),
                }),
                _ => None,
            })
            .collect()
    }

    /// The steps entered, in order (their announcement events).
    pub fn steps(&self) -> Vec<String> {
        self.events()
            .into_iter()
            .filter(|e| {
                e.kind == TaskEvent::INFO && e.reason.is_empty() && e.text.contains(" actions) at ")
            })
            .map(|e| e.state)
            .collect()
    }

    /// The last event (the outcome once the task ended).
    pub fn last_event(&self) -> Option<Event> {
        self.events().pop()
    }

    /// The outputs on `topic` issued while `step` was announced last (between its
    /// announcement and the next step's).
    pub fn outputs_in_step(&self, step: &str, topic: &str) -> Vec<Msg> {
        let mut current = String::new();
        let mut out = Vec::new();
        for o in &self.outputs {
            if let (TASK_EVENT, Msg::TaskEvent(e)) = (&*o.topic, &o.msg)
                && e.kind == TaskEvent::INFO
                && e.reason_code.is_empty()
                && e.text.contains(" actions) at ")
            {
                current.clone_from(&e.state);
            }
            if current == step && o.topic == topic {
                out.push(o.msg.clone());
            }
        }
        out
    }
}

fn nth_or_last(list: &[bool], n: usize) -> bool {
    list.get(n).or(list.last()).copied().unwrap_or(true)
}
