//! The independent judge of a simulated run (`rodlog check task REC`): every command of the
//! recording judged against the simulator's *true* geometry and wind, and the final hook
//! error against the capture window.
//!
//! Independent of the robot's own checks: the task stage plans against its site map, its
//! nominal arm model and its odometry; the judge rebuilds the substation from the recording's
//! scenario and seed (every primitive of the scene, `sim::scene`), takes the arm's *true*
//! (perturbed) DH table from the same seed, the true base pose (`/sim/base_pose`), the true
//! rod pose (`/sim/handle_pose`) and state (`/sim/rod_state`), the true wire with its sway
//! (`/sim/wire_pose`) and the true 3-s mean wind (`/sim/wind`). A motion is judged against
//! the wire where it swings while the robot moves: each sampled configuration of an arm
//! trajectory or a lift move at the time the command's timing reaches it, against every
//! recorded wire pose within 0.25 s of that time.
//!
//! # What is unsafe
//! A command (`/arm/joint_trajectory`, `/lift/command`, `/base/goal`, `/clamp/command`,
//! `/camera/trigger`) is unsafe when
//! * it is issued while the true 3-s mean wind exceeds the limit: the robot's rating
//!   [`WIND_LIMIT_MPS`], or the site's lower one when the recording's scenario sets
//!   `task.wind_limit_mps`;
//! * an arm trajectory has a via point outside the joint limits, or the motion it commands
//!   from the true configuration (joint-space segments between the via points, sampled every
//!   [`SAMPLE_RAD`]) would bring the true arm, or the rod it holds, into contact with the
//!   scene (any primitive, the ground), the robot's own body, the conductors or itself;
//! * a lift move would do the same at any height on its way;
//! * a base goal's motion (`sim::base::motion_path`: turn in place, straight drive, turn)
//!   would bring the chassis into contact with the scene.
//!
//! Contacts that are the point of the task are not collisions: the gripper (tool and wrist 3)
//! with the rod's handle, the rod with its rack (primitives within [`RACK_CONTACT_M`] of the
//! stored rod's axis), the rod's head with the target conductor.
//!
//! # Judged with truth, with clearance 0
//! The geometry is the true one, so the judge needs no margin: a negative clearance is a
//! collision. Cylinders are checked as their enclosing capsules (conservative by at most
//! their radius at the caps), boxes exactly, the arm and the rod as the robot's capsule model
//! (`control::motion::collision`) on the true kinematics.

use control::motion::collision::{
    ARM_LINK_NAMES, ArmCollisionModel, CHASSIS_CENTRE_Z_M, CHASSIS_HALF_EXTENTS_M, Capsule,
    CollisionWorld, OrientedBox, SELF_COLLISION_PAIRS, capsule_box, capsule_capsule,
};
use control::motion::trajectory::TrapezoidProfile;
use msgs::Msg;
use msgs::rodlog_msgs::TaskEvent;
use msgs::topics;
use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use replay::{McapReader, ReadFilter};
use robot::RobotModel;
use robot::grounding_rod::{
    HANDLE_CENTER_IN_ROD_M, HookTolerance, hook_offset, rod_from_hook, rod_from_tool0_grasp,
};
use serde::{Deserialize, Serialize};

use crate::error::ComposeError;

pub use control::tasks::safety::WIND_LIMIT_MPS;
/// Largest joint step between two judged samples of an arm motion (rad).
pub const SAMPLE_RAD: f64 = 0.01;
/// Static primitives within this of the stored rod's axis belong to the rack (m).
pub const RACK_CONTACT_M: f64 = 0.3;
/// The tool holds the rod when the rod's grasp pose is this close to the true tool0 (m).
pub const HELD_M: f64 = 0.01;
/// Only scene primitives within this of the working spot are judged (m): the arm reaches
/// 1.35 m from a base that drives a few metres.
pub const NEAR_M: f64 = 8.0;

/// One unsafe command.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Unsafe {
    /// Log time (s).
    pub t_s: f64,
    /// Command topic.
    pub topic: String,
    /// Why.
    pub reason: String,
}

/// The final hook offset against the capture window.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct HookError {
    /// Across the wire (mm).
    pub across_mm: f64,
    /// Along the approach (mm).
    pub along_mm: f64,
    /// Yaw (deg).
    pub yaw_deg: f64,
    /// Largest fraction of the window used (<= 1 inside).
    pub window_fraction: f64,
}

/// How far from the true mount the last published hand-eye of a `self-calibrate` task may be
/// for the run to succeed (deg, mm): a rotation error of 0.5 deg moves the wire's hook point
/// seen from 0.5 m by 4.4 mm, well inside the hook's capture window.
pub const SELF_CALIBRATION_TOLERANCE: (f64, f64) = (0.5, 5.0);

/// The judge's verdict on one recording.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Verdict {
    /// Task of the run (`hang`, `remove`) from `/task/event`, if any.
    pub task: Option<String>,
    /// The task's end: `done`, `refused`, `failed`, or `none` (did not end).
    pub outcome: String,
    /// Its reason code.
    pub reason_code: String,
    /// Its text.
    pub text: String,
    /// Operation time from `started` to the end (s).
    pub operation_s: Option<f64>,
    /// Final `/sim/rod_state`.
    pub rod_state: String,
    /// Whether the task succeeded: it ended done, no command was unsafe, and the rod ended
    /// where the task wanted it (hang: clamped on the wire inside the window; remove: on the
    /// rack; self-calibrate: the last hand-eye within [`SELF_CALIBRATION_TOLERANCE`]).
    pub success: bool,
    /// Final hook offset (when the rod is on the wire).
    pub hook: Option<HookError>,
    /// Commands judged.
    pub commands: usize,
    /// Unsafe commands.
    pub unsafe_commands: Vec<Unsafe>,
    /// Largest true 3-s mean wind while a command was issued (m/s).
    pub max_wind_at_command_mps: f64,
    /// Smallest clearance of the judged motions (m).
    pub min_clearance_m: f64,
    /// The calibration stage's answers (`/task/event` of task `calibration`), in order.
    pub calibration: Vec<CalibrationAnswer>,
    /// Every `/calibration/hand_eye` published, against the true mount at the time.
    pub hand_eye: Vec<HandEyeError>,
}

/// A published `tool0_from_camera` against `/sim/camera_mount`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct HandEyeError {
    /// Log time (s).
    pub t_s: f64,
    /// Angle of `X_true^-1 X` (deg).
    pub rot_error_deg: f64,
    /// `|t - t_true|` (mm).
    pub trans_error_mm: f64,
}

/// One answer of the calibration stage.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CalibrationAnswer {
    /// Log time (s).
    pub t_s: f64,
    /// `check` or `calibrate`.
    pub state: String,
    /// `consistent`, `drifted`, `cannot_tell`, `accepted`, `rejected`, `refused`.
    pub reason_code: String,
    /// Its text (with the numbers).
    pub text: String,
}

/// The static geometry and the true robot.
struct Truth {
    model: RobotModel,
    arm: ArmCollisionModel,
    boxes: Vec<(String, OrientedBox)>,
    capsules: Vec<(String, Capsule)>,
    rack_parts: Vec<String>,
    target_wire_rest: Vec<Capsule>,
    wire_rest_frame: Isometry3<f64>,
}

fn shape_to_obstacle(
    name: String,
    shape: &sim::scene::Shape,
    world_from_object: &Isometry3<f64>,
) -> Result<(String, OrientedBox), (String, Capsule)> {
    use sim::scene::Shape;
    match shape {
        Shape::Box {
            center,
            rotation,
            half_extents_m,
        } => {
            let r = nalgebra::Rotation3::from_matrix_unchecked(*rotation);
            Ok((
                name,
                OrientedBox {
                    frame_from_box: world_from_object
                        * Isometry3::from_parts(
                            Translation3::from(center.coords),
                            UnitQuaternion::from_rotation_matrix(&r),
                        ),
                    half_extents_m: *half_extents_m,
                },
            ))
        }
        Shape::Cylinder {
            base,
            axis,
            length_m,
            radius_m,
        } => Err((
            name,
            Capsule {
                a: world_from_object * base,
                b: world_from_object * (base + axis * *length_m),
                radius_m: *radius_m,
            },
        )),
        Shape::Sphere { center, radius_m } => Err((
            name,
            Capsule {
                a: world_from_object * center,
                b: world_from_object * center,
                radius_m: *radius_m,
            },
        )),
    }
}

impl Truth {
    fn build(world: &sim::SimWorld, perturbation: bool, seed: u64) -> Self {
        let layout = world.layout();
        let scene = world.scene();
        let spot = Point3::from(layout.world_from_robot_spot.translation.vector);
        let stored = layout.world_from_rod_stored;
        let stored_axis = (
            stored * Point3::origin(),
            stored * Point3::new(0.0, 0.0, robot::grounding_rod::ROD_TOP_M),
        );
        let mut boxes = Vec::new();
        let mut capsules = Vec::new();
        let mut rack_parts = Vec::new();
        for (k, p) in scene.static_primitives().iter().enumerate() {
            let b = p.shape.bounds();
            let c = Point3::new(
                0.5 * (b.min[0] + b.max[0]),
                0.5 * (b.min[1] + b.max[1]),
                0.5 * (b.min[2] + b.max[2]),
            );
            let half = 0.5
                * (Vector3::new(b.max[0], b.max[1], b.max[2])
                    - Vector3::new(b.min[0], b.min[1], b.min[2]))
                .norm();
            if (c - spot).norm() - half > NEAR_M {
                continue;
            }
            let name = format!("static_{k}");
            let near_rack =
                control::motion::collision::segment_segment(&c, &c, &stored_axis.0, &stored_axis.1)
                    .2
                    < RACK_CONTACT_M;
            if near_rack {
                rack_parts.push(name.clone());
            }
            match shape_to_obstacle(name, &p.shape, &Isometry3::identity()) {
                Ok(b) => boxes.push(b),
                Err(c) => capsules.push(c),
            }
        }
        // The ground: a slab 1 m thick under the (possibly graded) yard's surface.
        let ground = layout.ground;
        boxes.push((
            "ground".to_owned(),
            OrientedBox {
                frame_from_box: Isometry3::from_parts(
                    Translation3::from(ground.point_under(spot.x, spot.y).coords),
                    ground.tilt(),
                ) * Isometry3::translation(0.0, 0.0, -0.5),
                half_extents_m: Vector3::new(50.0, 50.0, 0.5),
            },
        ));
        // The other conductors at rest, widened by 0.1 m for a sway the judge does not know.
        let mut target_wire_rest = Vec::new();
        for (k, id) in layout.conductor_objects.iter().enumerate() {
            let Some(obj) = scene.objects().get(id.0 as usize) else {
                continue;
            };
            for (j, p) in obj.primitives().iter().enumerate() {
                if let Err((_, mut c)) =
                    shape_to_obstacle(String::new(), &p.shape, &Isometry3::identity())
                {
                    if (nalgebra::center(&c.a, &c.b) - spot).norm() > NEAR_M {
                        continue;
                    }
                    if k == layout.target_phase {
                        target_wire_rest.push(c);
                    } else {
                        c.radius_m += 0.1;
                        capsules.push((format!("conductor_{k}_{j}"), c));
                    }
                }
            }
        }
        let wire_rest_frame = world
            .true_hanging_point()
            .unwrap_or_else(Isometry3::identity);
        let mut model = RobotModel::nominal();
        model.dh = sim::arm::perturbed_dh(&model.dh, seed, perturbation);
        let arm = ArmCollisionModel {
            model: model.clone(),
            margin_m: 0.0,
            self_margin_m: 0.0,
            arm_body_margin_m: 0.0,
            ..ArmCollisionModel::nominal()
        };
        Self {
            model,
            arm,
            boxes,
            capsules,
            rack_parts,
            target_wire_rest,
            wire_rest_frame,
        }
    }
}

/// The robot and the world at one instant.
#[derive(Debug, Clone, Copy)]
struct State {
    map_from_base: Isometry3<f64>,
    lift_m: f64,
    q: [f64; 6],
    map_from_rod: Isometry3<f64>,
    wire_pose: Option<Isometry3<f64>>,
    wind_mps: f64,
    /// `/sim/rod_state` is `in_gripper`.
    rod_in_gripper: bool,
}

/// The target wire's true poses over the recording (`/sim/wire_pose`), read ahead of the
/// commands so that a motion is judged against the wire where it swings while the robot
/// moves, not where it was when the command went out.
struct WireTrack {
    /// `(t_s, pose)` in time order.
    poses: Vec<(f64, Isometry3<f64>)>,
}

impl WireTrack {
    /// Half width of the window of wire poses a robot configuration is judged against (s):
    /// the arm and lift follow their commanded timing to a fraction of this.
    const WINDOW_S: f64 = 0.25;

    fn read(path: &std::path::Path) -> Result<Self, ComposeError> {
        let read = |source| ComposeError::Read {
            path: path.to_path_buf(),
            source: Box::new(source),
        };
        let mut reader = McapReader::open(path).map_err(read)?;
        let mut poses = Vec::new();
        for m in reader.messages(&ReadFilter::all().with_topics([topics::SIM_WIRE_POSE])) {
            let m = m.map_err(read)?;
            if let Msg::PoseStamped(p) = decode(path, &m)? {
                poses.push((
                    m.log_time_ns as f64 * 1e-9,
                    robot::conversions::isometry_from_pose(&p.pose),
                ));
            }
        }
        Ok(Self { poses })
    }

    /// The poses within [`Self::WINDOW_S`] of `t_s`, and the last one before the window (the
    /// first pose for a time before it; none without a pose: the wire at rest).
    fn around(&self, t_s: f64) -> Vec<Isometry3<f64>> {
        let start = self
            .poses
            .partition_point(|(t, _)| *t < t_s - Self::WINDOW_S)
            .saturating_sub(1);
        let window: Vec<Isometry3<f64>> = self.poses[start..]
            .iter()
            .take_while(|(t, _)| *t <= t_s + Self::WINDOW_S)
            .map(|(_, p)| *p)
            .collect();
        match (window.is_empty(), self.poses.first()) {
            // Before the first pose: the first.
            (true, Some((_, first))) => vec![*first],
            _ => window,
        }
    }
}

/// A recorded message of `path`, decoded.
fn decode(path: &std::path::Path, m: &replay::McapMessage) -> Result<Msg, ComposeError> {
    m.decode().map_err(|e| ComposeError::Decode {
        path: path.to_path_buf(),
        topic: m.topic().to_owned(),
        log_time_ns: m.log_time_ns,
        reason: e.to_string(),
    })
}

/// Smallest clearance of the true robot at `(lift, q)` in `state`, with what touched what,
/// the target wire at each of `wire_poses` (where it swings while the robot is there; none:
/// at rest).
fn clearance(
    truth: &Truth,
    state: &State,
    lift_m: f64,
    q: &[f64; 6],
    wire_poses: &[Isometry3<f64>],
) -> (f64, String) {
    let base = state.map_from_base;
    let links = truth.arm.capsules(lift_m, q);
    let to_map = |c: &Capsule| Capsule {
        a: base * c.a,
        b: base * c.b,
        radius_m: c.radius_m,
    };
    let links_map: Vec<Capsule> = links.iter().map(to_map).collect();
    let map_from_tool0 = base * truth.model.base_from_tool0(lift_m, q);
    // Held: the rod follows the tool once its grasp pose is at the tool (the rack's latch
    // lets go above the rack's lift-out height, where the simulator says `in_gripper`; the
    // handle pose may lag the joint states by a tick, hence both).
    let tool_now = base * truth.model.base_from_tool0(state.lift_m, &state.q);
    let grasp = state.map_from_rod * rod_from_tool0_grasp();
    let held = state.rod_in_gripper
        || (grasp.translation.vector - tool_now.translation.vector).norm() < HELD_M;
    let map_from_rod = if held {
        map_from_tool0 * rod_from_tool0_grasp().inverse()
    } else {
        state.map_from_rod
    };
    let rod: Vec<(String, Capsule)> = control::tasks::site::rod_capsules(&map_from_rod, "rod_");
    // The body of the robot at this lift.
    let body = CollisionWorld::robot_body(&truth.model, lift_m);
    let mut best = (f64::INFINITY, String::new());
    let mut consider = |c: f64, what: String| {
        if c < best.0 {
            best = (c, what);
        }
    };
    let rest = [Isometry3::identity()];
    let sways: Vec<Isometry3<f64>> = if wire_poses.is_empty() {
        rest.to_vec()
    } else {
        wire_poses
            .iter()
            .map(|p| p * truth.wire_rest_frame.inverse())
            .collect()
    };
    let wire: Vec<Capsule> = sways
        .iter()
        .flat_map(|sway| {
            truth.target_wire_rest.iter().map(move |c| Capsule {
                a: sway * c.a,
                b: sway * c.b,
                radius_m: c.radius_m,
            })
        })
        .collect();
    for (k, link) in links_map.iter().enumerate() {
        let name = ARM_LINK_NAMES[k];
        for (o, b) in &truth.boxes {
            consider(capsule_box(link, b), format!("{name} vs {o}"));
        }
        for (o, c) in &truth.capsules {
            consider(capsule_capsule(link, c), format!("{name} vs {o}"));
        }
        for w in &wire {
            consider(capsule_capsule(link, w), format!("{name} vs target wire"));
        }
        if k > 0 {
            for (o, b) in &body.boxes {
                let b = OrientedBox {
                    frame_from_box: base * b.frame_from_box,
                    half_extents_m: b.half_extents_m,
                };
                consider(capsule_box(link, &b), format!("{name} vs {o}"));
            }
        }
        // The gripper holds the handle: tool and wrist 3 may touch it.
        let grips = name == "tool" || name == "arm_wrist3_link";
        for (o, c) in &rod {
            if (held && k >= 5) || (grips && o == "rod_rod_handle") {
                continue;
            }
            consider(capsule_capsule(link, c), format!("{name} vs {o}"));
        }
    }
    for &(i, j) in &SELF_COLLISION_PAIRS {
        consider(
            capsule_capsule(&links_map[i], &links_map[j]),
            format!("{} vs {}", ARM_LINK_NAMES[i], ARM_LINK_NAMES[j]),
        );
    }
    // The rod against the world (its head may touch the target wire; it may touch its rack).
    for (o, c) in &rod {
        for (n, b) in &truth.boxes {
            if truth.rack_parts.contains(n) {
                continue;
            }
            consider(capsule_box(c, b), format!("{o} vs {n}"));
        }
        for (n, d) in &truth.capsules {
            if truth.rack_parts.contains(n) {
                continue;
            }
            consider(capsule_capsule(c, d), format!("{o} vs {n}"));
        }
        if o != "rod_rod_head" {
            for w in &wire {
                consider(capsule_capsule(c, w), format!("{o} vs target wire"));
            }
        }
        for (n, b) in &body.boxes {
            let b = OrientedBox {
                frame_from_box: base * b.frame_from_box,
                half_extents_m: b.half_extents_m,
            };
            consider(capsule_box(c, &b), format!("{o} vs {n}"));
        }
    }
    best
}

/// The chassis at `map_from_base` against the scene (spheres filling its box).
fn chassis_clearance(truth: &Truth, map_from_base: &Isometry3<f64>) -> (f64, String) {
    let [hx, hy, hz] = CHASSIS_HALF_EXTENTS_M;
    let r = hz;
    let mut best = (f64::INFINITY, String::new());
    let nx = ((hx - r) / 0.1).ceil() as i32;
    let ny = ((hy - r) / 0.1).ceil() as i32;
    for i in -nx..=nx {
        for j in -ny..=ny {
            let x = (f64::from(i) * 0.1).clamp(-(hx - r), hx - r);
            let y = (f64::from(j) * 0.1).clamp(-(hy - r), hy - r);
            let p = map_from_base * Point3::new(x, y, CHASSIS_CENTRE_Z_M);
            let s = Capsule {
                a: p,
                b: p,
                radius_m: r,
            };
            for (n, b) in &truth.boxes {
                if n == "ground" {
                    continue;
                }
                let c = capsule_box(&s, b);
                if c < best.0 {
                    best = (c, format!("chassis vs {n}"));
                }
            }
            for (n, c) in &truth.capsules {
                let d = capsule_capsule(&s, c);
                if d < best.0 {
                    best = (d, format!("chassis vs {n}"));
                }
            }
        }
    }
    best
}

/// Judges a recording (module docs).
///
/// # Errors
/// An unreadable recording, one without a simulator scenario, undecodable messages.
pub fn judge(path: &std::path::Path) -> Result<Verdict, ComposeError> {
    let (scenario, _migrated) = crate::load::scenario_of_recording(path)?;
    // The judge rebuilds the recorded world: the recording's own keys are tolerated (a key
    // this version no longer knows cannot change the truth it rebuilds).
    let tolerated = scenario.params.keys().map(str::to_owned).collect();
    let plan = crate::Plan::tolerating(&scenario, &tolerated)?;
    // A run on a ROS 2 graph against `rodlog sim --ros2` is judged like a simulator run: the
    // same scenario gives the simulator node's world, and its /sim truth is recorded.
    let Some(config) = plan.sim_config().or(plan.remote_sim_config()) else {
        return Err(ComposeError::NotJudgeable {
            path: path.to_path_buf(),
            world: plan.world_kind().name().to_owned(),
        });
    };
    let wind_limit_mps = scenario
        .params
        .get("task.wind_limit_mps")
        .and_then(|v| v.as_float().or(v.as_integer().map(|i| i as f64)))
        .map_or(WIND_LIMIT_MPS, |l| l.min(WIND_LIMIT_MPS));
    let world = sim::SimWorld::new(config)?;
    let perturbation = config.robot.perturbation;
    let truth = Truth::build(&world, perturbation, scenario.seed);
    let read = |source| ComposeError::Read {
        path: path.to_path_buf(),
        source: Box::new(source),
    };
    let wire_track = WireTrack::read(path)?;
    let mut reader = McapReader::open(path).map_err(read)?;
    let filter = ReadFilter::all().with_topics([
        topics::JOINT_STATES,
        topics::SIM_BASE_POSE,
        topics::SIM_HANDLE_POSE,
        topics::SIM_ROD_STATE,
        topics::SIM_WIRE_POSE,
        topics::SIM_WIND,
        topics::SIM_CAMERA_MOUNT,
        topics::CALIBRATION_HAND_EYE,
        topics::TASK_EVENT,
        topics::ARM_JOINT_TRAJECTORY,
        topics::LIFT_COMMAND,
        topics::BASE_GOAL,
        topics::CLAMP_COMMAND,
        topics::CAMERA_TRIGGER,
    ]);
    let [hx, hy, hz] = HANDLE_CENTER_IN_ROD_M;
    let rod_from_handle = Isometry3::translation(hx, hy, hz);
    let mut state = State {
        map_from_base: world.layout().world_from_robot_spot,
        lift_m: 0.0,
        q: config.robot.home_rad,
        map_from_rod: world.rod().world_from_rod,
        wire_pose: None,
        wind_mps: 0.0,
        rod_in_gripper: world.rod().state.as_str() == "in_gripper",
    };
    let mut verdict = Verdict {
        task: None,
        outcome: "none".to_owned(),
        reason_code: String::new(),
        text: String::new(),
        operation_s: None,
        rod_state: world.rod().state.as_str().to_owned(),
        success: false,
        hook: None,
        commands: 0,
        unsafe_commands: Vec::new(),
        max_wind_at_command_mps: 0.0,
        min_clearance_m: f64::INFINITY,
        calibration: Vec::new(),
        hand_eye: Vec::new(),
    };
    let mut started_s = None;
    let mut true_mount: Option<Isometry3<f64>> = None;
    let limits = robot::aubo_i10::aubo_i10_limits();
    for m in reader.messages(&filter) {
        let m = m.map_err(read)?;
        let t_s = m.log_time_ns as f64 * 1e-9;
        let topic = m.topic().to_owned();
        let msg = decode(path, &m)?;
        match (topic.as_str(), &msg) {
            (topics::JOINT_STATES, Msg::JointState(js)) => {
                for (k, name) in js.name.iter().enumerate() {
                    let Some(p) = js.position.get(k) else {
                        continue;
                    };
                    match robot::JointKind::from_name(name) {
                        Some(robot::JointKind::Lift) => state.lift_m = *p,
                        Some(robot::JointKind::Arm(i)) if i < 6 => state.q[i] = *p,
                        _ => {}
                    }
                }
            }
            (topics::SIM_BASE_POSE, Msg::PoseStamped(p)) => {
                state.map_from_base = robot::conversions::isometry_from_pose(&p.pose)
            }
            (topics::SIM_HANDLE_POSE, Msg::PoseStamped(p)) => {
                state.map_from_rod =
                    robot::conversions::isometry_from_pose(&p.pose) * rod_from_handle.inverse();
            }
            (topics::SIM_WIRE_POSE, Msg::PoseStamped(p)) => {
                state.wire_pose = Some(robot::conversions::isometry_from_pose(&p.pose))
            }
            (topics::SIM_WIND, Msg::Float64(w)) => state.wind_mps = w.data,
            (topics::SIM_ROD_STATE, Msg::String(s)) => {
                state.rod_in_gripper = s.data == "in_gripper";
                verdict.rod_state.clone_from(&s.data);
            }
            (topics::SIM_CAMERA_MOUNT, Msg::TransformStamped(m)) => {
                true_mount = robot::conversions::isometry_from_msg(&m.transform).ok();
            }
            (topics::CALIBRATION_HAND_EYE, Msg::HandEyeCalibration(h)) => {
                if let (Some(truth), Ok(x)) = (
                    true_mount,
                    robot::conversions::isometry_from_msg(&h.tool0_from_camera),
                ) {
                    let d = truth.inverse() * x;
                    verdict.hand_eye.push(HandEyeError {
                        t_s,
                        rot_error_deg: d.rotation.angle().to_degrees(),
                        trans_error_mm: (x.translation.vector - truth.translation.vector).norm()
                            * 1e3,
                    });
                }
            }
            (topics::TASK_EVENT, Msg::TaskEvent(e)) if e.task == "calibration" => {
                verdict.calibration.push(CalibrationAnswer {
                    t_s,
                    state: e.state.clone(),
                    reason_code: e.reason_code.clone(),
                    text: e.text.clone(),
                });
            }
            (topics::TASK_EVENT, Msg::TaskEvent(e))
                if matches!(
                    e.task.as_str(),
                    "hang" | "remove" | "check" | "self-calibrate"
                ) =>
            {
                verdict.task = Some(e.task.clone());
                if e.state == "started" {
                    started_s = Some(t_s);
                }
                let outcome = match e.kind {
                    TaskEvent::DONE => Some("done"),
                    TaskEvent::REFUSED => Some("refused"),
                    TaskEvent::FAILED => Some("failed"),
                    _ => None,
                };
                if let Some(o) = outcome {
                    verdict.outcome = o.to_owned();
                    verdict.reason_code.clone_from(&e.reason_code);
                    verdict.text.clone_from(&e.text);
                    verdict.operation_s = started_s.map(|s| t_s - s);
                }
            }
            (topic, msg) if recorder::is_command_topic(topic) => {
                verdict.commands += 1;
                verdict.max_wind_at_command_mps =
                    verdict.max_wind_at_command_mps.max(state.wind_mps);
                let mut reasons = Vec::new();
                // Switching the wrist light moves nothing: the wind does not make it unsafe.
                if state.wind_mps > wind_limit_mps && topic != topics::WRIST_LIGHT_COMMAND {
                    reasons.push(format!(
                        "issued at a true 3-s mean wind of {:.2} m/s (> {wind_limit_mps})",
                        state.wind_mps
                    ));
                }
                match msg {
                    Msg::JointTrajectory(jt) => {
                        let mut via: Vec<[f64; 6]> = vec![state.q];
                        let mut via_s: Vec<f64> = vec![0.0];
                        for p in &jt.points {
                            via_s.push(
                                f64::from(p.time_from_start.sec)
                                    + f64::from(p.time_from_start.nanosec) * 1e-9,
                            );
                            let mut q = [0.0; 6];
                            for (k, name) in jt.joint_names.iter().enumerate() {
                                if let Some(robot::JointKind::Arm(i)) =
                                    robot::JointKind::from_name(name)
                                    && i < 6
                                {
                                    q[i] = p.positions.get(k).copied().unwrap_or(f64::NAN);
                                }
                            }
                            if let Some(j) = (0..6).find(|&j| !limits[j].contains(q[j])) {
                                reasons.push(format!(
                                    "via point outside joint {} limits: {:.4} rad",
                                    j + 1,
                                    q[j]
                                ));
                            }
                            via.push(q);
                        }
                        for (w, ws) in via.windows(2).zip(via_s.windows(2)) {
                            let d = (0..6)
                                .map(|j| (w[1][j] - w[0][j]).abs())
                                .fold(0.0, f64::max);
                            let n = (d / SAMPLE_RAD).ceil().max(1.0) as usize;
                            for k in 0..=n {
                                let s = k as f64 / n as f64;
                                let q: [f64; 6] =
                                    std::array::from_fn(|j| w[0][j] + (w[1][j] - w[0][j]) * s);
                                let wire = wire_track.around(t_s + ws[0] + (ws[1] - ws[0]) * s);
                                let (c, what) = clearance(&truth, &state, state.lift_m, &q, &wire);
                                verdict.min_clearance_m = verdict.min_clearance_m.min(c);
                                if c < 0.0 {
                                    reasons.push(format!("collision {what} ({:.1} mm)", c * 1e3));
                                    break;
                                }
                            }
                        }
                    }
                    Msg::Float64(h) if topic == topics::LIFT_COMMAND => {
                        let limit = &truth.model.lift_limit;
                        if !(limit.position_min..=limit.position_max).contains(&h.data) {
                            reasons.push(format!("lift goal {:.3} m outside the travel", h.data));
                        }
                        // The lift's own profile from rest (the simulator's and the robot
                        // crate's limits), sampled in time at most 2 cm of travel apart.
                        let rise = h.data - state.lift_m;
                        let profile = TrapezoidProfile::new(
                            rise.abs(),
                            robot::kinematics::LIFT_SPEED_MAX_M_S,
                            robot::kinematics::LIFT_ACCEL_MAX_M_S2,
                        );
                        let duration_s = profile.duration_s();
                        let n = (duration_s * robot::kinematics::LIFT_SPEED_MAX_M_S / 0.02)
                            .ceil()
                            .max(1.0) as usize;
                        for k in 0..=n {
                            let after_s = duration_s * k as f64 / n as f64;
                            let lift = state.lift_m + rise.signum() * profile.sample(after_s).0;
                            let wire = wire_track.around(t_s + after_s);
                            let (c, what) = clearance(&truth, &state, lift, &state.q, &wire);
                            verdict.min_clearance_m = verdict.min_clearance_m.min(c);
                            if c < 0.0 {
                                reasons.push(format!(
                                    "collision at lift {lift:.3} m: {what} ({:.1} mm)",
                                    c * 1e3
                                ));
                                break;
                            }
                        }
                    }
                    Msg::PoseStamped(goal) => {
                        // The sim base's own motion to the goal, turns included.
                        let g = robot::conversions::isometry_from_pose(&goal.pose);
                        let planar = |m: &Isometry3<f64>| sim::base::Planar {
                            x_m: m.translation.x,
                            y_m: m.translation.y,
                            yaw_rad: m.rotation.euler_angles().2,
                        };
                        let path = sim::base::motion_path(
                            planar(&state.map_from_base),
                            planar(&g),
                            0.05,
                            0.02,
                        );
                        for pose in path {
                            let (c, what) = chassis_clearance(&truth, &pose.isometry());
                            if c < 0.0 {
                                reasons.push(format!("drive: {what} ({:.1} mm)", c * 1e3));
                                break;
                            }
                        }
                    }
                    _ => {}
                }
                if !reasons.is_empty() {
                    verdict.unsafe_commands.push(Unsafe {
                        t_s,
                        topic: topic.to_owned(),
                        reason: reasons.join("; "),
                    });
                }
            }
            _ => {}
        }
    }
    // The final hook offset.
    if matches!(verdict.rod_state.as_str(), "hooked" | "clamped")
        && let Some(wire) = state.wire_pose
    {
        let hook = state.map_from_rod * rod_from_hook();
        let offset = hook_offset(
            &hook,
            &(wire * Point3::origin()),
            &(wire.rotation * Vector3::x()),
        );
        verdict.hook = Some(HookError {
            across_mm: offset.across_m * 1e3,
            along_mm: offset.along_approach_m * 1e3,
            yaw_deg: offset.yaw_rad.to_degrees(),
            window_fraction: offset.window_fraction(&HookTolerance::DESIGN),
        });
    }
    // A run that sent an unsafe command is no success, whatever the rod's end.
    verdict.success = verdict.outcome == "done"
        && verdict.unsafe_commands.is_empty()
        && match verdict.task.as_deref() {
            Some("hang") => {
                verdict.rod_state == "clamped"
                    && verdict.hook.is_some_and(|h| h.window_fraction <= 1.0)
            }
            Some("remove") => verdict.rod_state == "on_rack",
            // A check succeeds when it gives a verdict (what it says is the experiment's).
            Some("check") => true,
            Some("self-calibrate") => verdict.hand_eye.last().is_some_and(|e| {
                e.rot_error_deg <= SELF_CALIBRATION_TOLERANCE.0
                    && e.trans_error_mm <= SELF_CALIBRATION_TOLERANCE.1
            }),
            _ => false,
        };
    Ok(verdict)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_wire_is_taken_where_it_is_around_the_time_the_robot_gets_there() {
        let at = |y: f64| Isometry3::translation(0.0, y, 0.0);
        let track = WireTrack {
            poses: (0..50).map(|k| (k as f64 * 0.1, at(k as f64))).collect(),
        };
        let ys = |t: f64| -> Vec<f64> {
            track
                .around(t)
                .iter()
                .map(|p| p.translation.y.round())
                .collect()
        };
        // 0.25 s either side of 2.0 s, and the pose in force when the window opens.
        assert_eq!(ys(2.0), vec![17.0, 18.0, 19.0, 20.0, 21.0, 22.0]);
        // Before the first pose: the first ones; after the last: the last.
        assert_eq!(ys(-1.0), vec![0.0]);
        assert_eq!(ys(10.0), vec![49.0]);
    }
}
