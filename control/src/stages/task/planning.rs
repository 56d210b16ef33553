//! Planning: the motions the steps command, every one checked before it is queued.
//!
//! [`Planner`] is a read-only view of the task ([`Task::planner`]): the robot model and its
//! IK, the measured robot state, where the rod is believed to be and the wire's prior. It
//! gives IK goals within the joint limits, joint-space plans checked for limits, speeds,
//! accelerations and collisions ([`planner::plan_through`]) with detours when the direct
//! move collides, straight tool lines, lift moves checked at [`LIFT_CHECK_STEP_M`] steps,
//! the collision world of the site with the robot's body and the rod, the look poses of the
//! captures with the lift height that suits them, and the motions shared by several steps
//! (stow, the calibration views, the looks at a handle).
//!
//! An unplannable motion is a [`Stop`]: `unreachable` (no IK solution, a branch jump on a
//! line), `collision`, or a failure for a degenerate site map or geometry.

use msgs::frames::BASE_LINK;
use msgs::rodlog_msgs::ClampCommand;
use msgs::std_msgs::Header;
use nalgebra::{Isometry3, Point3, Vector3};
use robot::ArmIk;
use robot::grounding_rod::{CLAMP_TRAVEL_M, rod_from_hook};

use super::Task;
use super::action::{ARRIVED_RAD, Action, LIFT_ARRIVED_M, Until};
use super::flow::Stop;
use super::judging::CLAMP_CONTACT_TOLERANCE_M;
use super::memory::{HandleSite, Rod};
use crate::motion::collision::{ArmCollisionModel, Capsule, CollisionWorld, Payload};
use crate::motion::lift::{LiftParams, choose_lift};
use crate::motion::planner::{self, ArmPlan};
use crate::motion::roadmap::{self, RoadmapParams};
use crate::motion::trajectory::DEFAULT_DT_NS;
use crate::tasks::poses;
use crate::tasks::site::rod_capsules;

/// Which views of the calibration target ([`Planner::views`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum ViewBatch {
    /// The drift check's.
    Check,
    /// Four more for a check that could not resolve a bump of the target size.
    CheckMore,
    /// The recalibration's.
    Calibrate,
}

/// The drift check looks at this point above the calibration target's centre (m).
pub const CHECK_LOOK_ABOVE_M: f64 = 0.15;
/// Elevations of the view of the stored rod's handle, lowest first (deg).
pub const RACK_LOOK_ELEVATIONS_DEG: [f64; 4] = [0.0, 20.0, 35.0, 50.0];
/// Elevations of the look at the empty rack, in order of preference (deg): from above
/// first, where the rack's base plate faces the camera.
pub const EMPTY_RACK_LOOK_ELEVATIONS_DEG: [f64; 4] = [35.0, 50.0, 20.0, 0.0];
/// Via point spacing of a move replanned as a straight tool line (m).
pub const DETOUR_LINE_STEP_M: f64 = 0.05;
/// Preferred height of `tool0` above the arm base when the lift can choose (m): the arm
/// half bent, far from the stretched and folded singularities.
pub const COMFORT_HEIGHT_M: f64 = 0.5;
/// A look at the stored rod after a view cut its handle at both ends stands this many times
/// farther back ([`Planner::handle_standoff_m`]): the image then spans a quarter more, the
/// 4-8 cm by which the surveyed rack and an untracked tilt of the base bring the camera nearer
/// than planned. (The hung rod's look stays where it is: there a farther look measured worse,
/// one remove refused in 100 that the same look again had hung.)
pub const HANDLE_LOOK_FARTHER: f64 = 1.25;
/// Rise of a detour's via points above a blocked move's start and goal (m).
pub const DETOUR_RISE_M: f64 = 0.25;
/// How far out from the arm's axis the outward detours of
/// [`Planner::plan_move`] carry the tool (m).
pub const DETOUR_OUT_M: [f64; 2] = [0.15, 0.3];
/// Lift moves are collision-checked at this step (m).
pub const LIFT_CHECK_STEP_M: f64 = 0.05;
/// A bent release ([`Planner::release_back_off`]) first goes this far straight along the
/// tool's -z: the gripper is off the handle after `RELEASE_DISTANCE_M` (2 cm).
pub const BACK_OFF_STRAIGHT_M: f64 = 0.06;
/// Elevations of a bent back-off's remainder above the tool's -z (deg), tried in turn: the
/// straight line down and back brings the upper arm towards the lift plate.
pub const BACK_OFF_BENDS_DEG: [f64; 2] = [30.0, 60.0];
/// A straight line refuses when consecutive via points jump by more than this in a joint
/// (rad): the IK changed branch.
const LINE_BRANCH_JUMP_RAD: f64 = 0.3;
/// A straight-line detour must end this close to the move's goal configuration in every
/// joint (rad): the same IK branch, not merely the same tool pose.
const LINE_END_TOLERANCE_RAD: f64 = 1e-3;

/// The arm's IK and collision model (built once with the stage).
#[derive(Debug)]
pub(crate) struct Arm {
    /// Closed-form IK of the model.
    pub ik: ArmIk,
    /// The empty arm's collision model.
    pub collision: ArmCollisionModel,
}

/// A read-only view of the task for planning (module docs).
pub(crate) struct Planner<'a> {
    task: &'a Task,
}

impl Task {
    /// The planner over the task as it is now.
    pub fn planner(&self) -> Planner<'_> {
        Planner { task: self }
    }
}

impl Planner<'_> {
    fn model(&self) -> &robot::RobotModel {
        &self.task.config.model
    }

    /// A header stamped for outputs triggered now.
    pub fn header(&self, frame: &str) -> Header {
        self.task.out.header(self.task.robot.now, frame)
    }

    /// The arm's joints.
    ///
    /// # Errors
    /// `no_joint_states` before the arm reported.
    pub fn q(&self) -> Result<[f64; 6], Stop> {
        self.task.robot.q()
    }

    /// The lift's height (m).
    ///
    /// # Errors
    /// `no_joint_states` before the lift reported.
    pub fn lift(&self) -> Result<f64, Stop> {
        self.task.robot.lift()
    }

    /// `base_link -> map` now.
    ///
    /// # Errors
    /// `no_odometry` before the odometry reported.
    pub fn base_from_map(&self) -> Result<Isometry3<f64>, Stop> {
        self.task.robot.base_from_map()
    }

    /// `base_from_tool0` with the lift at `lift_m` and the arm at `q`.
    pub fn base_from_tool0(&self, lift_m: f64, q: &[f64; 6]) -> Isometry3<f64> {
        self.model().base_from_tool0(lift_m, q)
    }

    /// The arm base's origin in `base_link` with the lift at `lift_m`.
    pub fn arm_base_point(&self, lift_m: f64) -> Point3<f64> {
        self.model().base_from_arm_base(lift_m) * Point3::origin()
    }

    /// The arm's collision model, carrying the rod when it is held.
    pub fn arm_model(&self) -> ArmCollisionModel {
        if self.task.memory.rod == Rod::Held {
            self.task.arm.collision.carrying(Payload::grounding_rod())
        } else {
            self.task.arm.collision.clone()
        }
    }

    /// The empty arm's collision model.
    pub fn empty_arm(&self) -> &ArmCollisionModel {
        &self.task.arm.collision
    }

    // ------------------------------------------------------------ actions

    /// The arm along `plan`.
    pub fn arm_action(&self, plan: &ArmPlan, label: &'static str) -> Action {
        Action::arm(plan, self.model(), self.header(BASE_LINK), label)
    }

    /// A clamp command at the configured torque.
    pub fn clamp_action(&self, action: u8, label: &'static str) -> Action {
        Action::clamp(
            self.header(""),
            action,
            self.task.config.clamp_torque_nm,
            label,
        )
    }

    // ------------------------------------------------------------ collision worlds

    /// The collision world in `base_link` at lift `lift_m`: site, robot body, the rod where
    /// the robot believes it is (when not held).
    ///
    /// # Errors
    /// `no_odometry`.
    pub fn world(&self, lift_m: f64) -> Result<CollisionWorld, Stop> {
        self.world_for(lift_m, self.task.memory.rod)
    }

    /// [`Self::world`] with the rod at `rod`.
    ///
    /// # Errors
    /// `no_odometry`.
    pub fn world_for(&self, lift_m: f64, rod: Rod) -> Result<CollisionWorld, Stop> {
        let base_from_map = self.base_from_map()?;
        let wire = self.task.memory.wire_in_base.map(|(p, d)| {
            let map_from_base = base_from_map.inverse();
            let half = d.normalize() * 3.0;
            (map_from_base * (p - half), map_from_base * (p + half))
        });
        // The rack where the remove measured it, or where the hang saw its stored rod (the
        // rack's parts stand where the measured handle says, not where the survey put them),
        // else where the site map has it.
        let measured = self.task.memory.rack_seen.or_else(|| {
            self.task
                .memory
                .stored_rod_seen
                .map(|map_from_rod| map_from_rod * robot::grounding_rod::rack_from_rod().inverse())
        });
        let moved;
        let site = match measured {
            Some(map_from_rack) => {
                moved = self.task.config.site.with_rack_at(map_from_rack);
                &moved
            }
            None => &self.task.config.site,
        };
        let mut world = site.collision_world(
            &base_from_map,
            wire,
            self.task.memory.conductor_sway_margin_m,
        );
        world.extend(&CollisionWorld::robot_body(self.model(), lift_m));
        match rod {
            Rod::OnRack => {
                for (name, c) in site.stored_rod_capsules() {
                    world.capsules.push((
                        name,
                        Capsule {
                            a: base_from_map * c.a,
                            b: base_from_map * c.b,
                            radius_m: c.radius_m,
                        },
                    ));
                }
            }
            Rod::OnWire(base_from_rod) => {
                world.capsules.extend(rod_capsules(&base_from_rod, "hung_"));
            }
            Rod::Held | Rod::Unknown => {}
        }
        Ok(world)
    }

    // ------------------------------------------------------------ IK and plans

    /// The configuration nearest `seed` that puts `tool0` at `base_from_tool0` with the lift
    /// at `lift_m`.
    ///
    /// # Errors
    /// `unreachable`.
    pub fn ik_goal(
        &self,
        lift_m: f64,
        base_from_tool0: &Isometry3<f64>,
        seed: &[f64; 6],
    ) -> Result<[f64; 6], Stop> {
        let target = self.model().arm_base_from_base(lift_m) * base_from_tool0;
        self.task
            .arm
            .ik
            .nearest(&target, seed)
            .map(|s| s.q_rad)
            .map_err(|e| {
                Stop::refused(
                    "unreachable",
                    format!("tool0 goal not reachable at lift {lift_m:.3} m: {e}"),
                )
            })
    }

    /// Every IK solution within the joint limits for `base_from_tool0` at `lift_m`, nearest
    /// `seed` first (the arm's branches: shoulder, elbow, wrist).
    ///
    /// # Errors
    /// `unreachable` when no branch reaches the pose within the limits.
    pub fn ik_goals(
        &self,
        lift_m: f64,
        base_from_tool0: &Isometry3<f64>,
        seed: &[f64; 6],
    ) -> Result<Vec<[f64; 6]>, Stop> {
        let target = self.model().arm_base_from_base(lift_m) * base_from_tool0;
        let solutions = self.task.arm.ik.solve(&target, Some(seed)).map_err(|e| {
            Stop::refused(
                "unreachable",
                format!("tool0 goal not reachable at lift {lift_m:.3} m: {e}"),
            )
        })?;
        if solutions.within_limits.is_empty() {
            // The nearest's error says which joint is out of its limits.
            return self.ik_goal(lift_m, base_from_tool0, seed).map(|q| vec![q]);
        }
        Ok(solutions.within_limits.iter().map(|s| s.q_rad).collect())
    }

    /// The first of `attempt`'s plans for the tool0 `goals` in turn, each in the arm's IK
    /// branches nearest `seed` first ([`Self::ik_goals`]): a goal configuration whose
    /// motion collides gives way to another branch, then to the next goal.
    ///
    /// # Errors
    /// The first refusal when no goal and branch gives a plan (`unreachable` without goals).
    pub fn first_plannable<T>(
        &self,
        lift_m: f64,
        goals: &[Isometry3<f64>],
        seed: &[f64; 6],
        mut attempt: impl FnMut(&[f64; 6]) -> Result<T, Stop>,
    ) -> Result<T, Stop> {
        let mut first_refusal = None;
        for goal in goals {
            let branches = match self.ik_goals(lift_m, goal, seed) {
                Ok(b) => b,
                Err(stop) => {
                    first_refusal.get_or_insert(stop);
                    continue;
                }
            };
            for q in &branches {
                match attempt(q) {
                    Ok(plan) => return Ok(plan),
                    Err(stop) => {
                        first_refusal.get_or_insert(stop);
                    }
                }
            }
        }
        Err(first_refusal.unwrap_or_else(|| Stop::refused("unreachable", "no goal to plan for")))
    }

    /// A checked joint-space plan from `q0` through `waypoints` at `lift_m`, with the arm
    /// model of [`Self::arm_model`].
    ///
    /// # Errors
    /// `collision` or `unreachable`, the text prefixed with `what`.
    pub fn plan(
        &self,
        world: &CollisionWorld,
        lift_m: f64,
        q0: &[f64; 6],
        waypoints: &[[f64; 6]],
        what: &str,
    ) -> Result<ArmPlan, Stop> {
        planner::plan_through(
            &self.arm_model(),
            world,
            lift_m,
            q0,
            waypoints,
            DEFAULT_DT_NS,
        )
        .map_err(|e| {
            let code = if matches!(e, crate::motion::MotionError::Collision { .. }) {
                "collision"
            } else {
                "unreachable"
            };
            Stop::refused(code, format!("{what}: {e}"))
        })
    }

    /// A checked joint-space move from `q0` to the configuration `goal_q`: directly when that
    /// is collision-free, else along the straight tool line (every [`DETOUR_LINE_STEP_M`],
    /// when it ends in `goal_q`'s branch),
    /// else through detours lifted above the goal, or the start and the goal
    /// ([`DETOUR_RISE_M`] and twice that), else through detours that carry the tool out
    /// from the arm's axis at the start and the goal ([`DETOUR_OUT_M`], so that a held rod
    /// swings around the lift mast rather than through it), the first that is free.
    ///
    /// # Errors
    /// The direct move's refusal when no detour is free either.
    pub fn plan_move(
        &self,
        world: &CollisionWorld,
        lift_m: f64,
        q0: &[f64; 6],
        goal_q: &[f64; 6],
        what: &str,
    ) -> Result<ArmPlan, Stop> {
        let direct = match self.plan(world, lift_m, q0, &[*goal_q], what) {
            Ok(plan) => return Ok(plan),
            Err(stop) if stop.reason_code == "collision" => stop,
            Err(stop) => return Err(stop),
        };
        let start = self.base_from_tool0(lift_m, q0);
        let goal = self.base_from_tool0(lift_m, goal_q);
        // The tool along the straight line (the held rod keeps its attitude), when the line
        // ends in the goal's configuration: another branch at the same pose would leave the
        // arm where the next step's plan does not start.
        if let Ok(line) = self.line_waypoints_every(lift_m, q0, &goal, DETOUR_LINE_STEP_M)
            && line.last().is_some_and(|end| {
                (0..6)
                    .map(|j| (end[j] - goal_q[j]).abs())
                    .fold(0.0, f64::max)
                    <= LINE_END_TOLERANCE_RAD
            })
            && let Ok(plan) = self.plan(world, lift_m, q0, &line, what)
        {
            return Ok(plan);
        }
        let up = |pose: &Isometry3<f64>, rise: f64| Isometry3::translation(0.0, 0.0, rise) * *pose;
        let axis = self.arm_base_point(lift_m);
        let out = |pose: &Isometry3<f64>, d: f64| {
            let radial = Vector3::new(
                pose.translation.x - axis.x,
                pose.translation.y - axis.y,
                0.0,
            )
            .try_normalize(1e-6)
            .unwrap_or_else(Vector3::x);
            Isometry3::from_parts((pose.translation.vector + radial * d).into(), pose.rotation)
        };
        let lifted = [DETOUR_RISE_M, 2.0 * DETOUR_RISE_M].map(|rise| {
            vec![
                vec![up(&goal, rise)],
                vec![up(&start, rise), up(&goal, rise)],
            ]
        });
        let outward = DETOUR_OUT_M.map(|d| vec![vec![out(&start, d), out(&goal, d)]]);
        for candidates in lifted.into_iter().chain(outward) {
            for poses in candidates {
                let mut seed = *q0;
                let mut via = Vec::with_capacity(poses.len() + 1);
                let mut ok = true;
                for p in &poses {
                    match self.ik_goal(lift_m, p, &seed) {
                        Ok(q) => {
                            via.push(q);
                            seed = q;
                        }
                        Err(_) => {
                            ok = false;
                            break;
                        }
                    }
                }
                if !ok {
                    continue;
                }
                via.push(*goal_q);
                if let Ok(plan) = self.plan(world, lift_m, q0, &via, what) {
                    return Ok(plan);
                }
            }
        }
        Err(direct)
    }

    /// A checked joint-space move from `q0` to `goal_q` by a path searched around the
    /// obstacles ([`roadmap::plan_around`]): for a move that [`Self::plan_move`]'s fixed
    /// detours cannot make.
    ///
    /// # Errors
    /// `collision` when no path was found; those of [`Self::plan`].
    pub fn plan_move_around(
        &self,
        world: &CollisionWorld,
        lift_m: f64,
        q0: &[f64; 6],
        goal_q: &[f64; 6],
        what: &str,
    ) -> Result<ArmPlan, Stop> {
        let via = roadmap::plan_around(
            &self.arm_model(),
            world,
            lift_m,
            q0,
            goal_q,
            &RoadmapParams::default(),
        )
        .ok_or_else(|| {
            Stop::refused(
                "collision",
                format!("{what}: no collision-free path found around the obstacles"),
            )
        })?;
        self.plan(world, lift_m, q0, &via, what)
    }

    /// Via points of the straight line from `q0`'s pose to `goal` (tool0 in `base_link`),
    /// every [`TaskConfig::line_step_m`](super::TaskConfig::line_step_m), each the IK
    /// solution nearest the previous.
    ///
    /// # Errors
    /// `unreachable`: a via point out of reach, or a branch jump.
    pub fn line_waypoints(
        &self,
        lift_m: f64,
        q0: &[f64; 6],
        goal: &Isometry3<f64>,
    ) -> Result<Vec<[f64; 6]>, Stop> {
        self.line_waypoints_every(lift_m, q0, goal, self.task.config.line_step_m)
    }

    /// [`Self::line_waypoints`] with via points every `step_m` (and 2.5 deg per 0.02 m).
    ///
    /// # Errors
    /// As [`Self::line_waypoints`].
    pub fn line_waypoints_every(
        &self,
        lift_m: f64,
        q0: &[f64; 6],
        goal: &Isometry3<f64>,
        step_m: f64,
    ) -> Result<Vec<[f64; 6]>, Stop> {
        let start = self.base_from_tool0(lift_m, q0);
        let length = (goal.translation.vector - start.translation.vector).norm();
        let angle = start.rotation.angle_to(&goal.rotation);
        let step_rad = (2.5f64 * step_m / 0.02).to_radians();
        let n = ((length / step_m.max(1e-3)).ceil())
            .max((angle / step_rad).ceil())
            .max(1.0) as usize;
        let mut out = Vec::with_capacity(n);
        let mut seed = *q0;
        for k in 1..=n {
            let pose = robot::se3::interpolate(&start, goal, k as f64 / n as f64);
            let q = self.ik_goal(lift_m, &pose, &seed)?;
            let jump = (0..6).map(|j| (q[j] - seed[j]).abs()).fold(0.0, f64::max);
            if jump > LINE_BRANCH_JUMP_RAD {
                return Err(Stop::refused(
                    "unreachable",
                    format!(
                        "straight line: branch jump of {jump:.3} rad at via point {k}/{n} (from {} to {} rad): the line leaves the arm's branch, at the edge of its reach or at a singularity",
                        fmt_q(&seed),
                        fmt_q(&q)
                    ),
                ));
            }
            out.push(q);
            seed = q;
        }
        Ok(out)
    }

    /// The lift move from `from_m` to `to_m` with the arm at `q` is collision-free (checked
    /// every [`LIFT_CHECK_STEP_M`]).
    ///
    /// # Errors
    /// `collision` naming the link, the obstacle and the height.
    pub fn check_lift_move(&self, q: &[f64; 6], from_m: f64, to_m: f64) -> Result<(), Stop> {
        let steps = ((to_m - from_m).abs() / LIFT_CHECK_STEP_M).ceil().max(1.0) as usize;
        let arm = self.arm_model();
        for k in 0..=steps {
            let lift = from_m + (to_m - from_m) * k as f64 / steps as f64;
            let world = self.world(lift)?;
            if let Some((clearance, link, obstacle)) = arm.shortfall(&world, lift, q) {
                return Err(Stop::refused(
                    "collision",
                    format!(
                        "lift move {from_m:.3} -> {to_m:.3} m: {link} vs {obstacle} at lift {lift:.3} m, clearance {clearance:.3} m"
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The lift height that puts `base_from_tool0` [`COMFORT_HEIGHT_M`] above the arm base
    /// (within the lift's travel) when the arm reaches it there away from singularities,
    /// otherwise the most dexterous height ([`choose_lift`]); with its configuration.
    ///
    /// # Errors
    /// `unreachable` at every height.
    pub fn comfortable_lift(
        &self,
        base_from_tool0: &Isometry3<f64>,
        seed: &[f64; 6],
        what: &str,
    ) -> Result<(f64, [f64; 6]), Stop> {
        if let Ok(found) = self.lift_for_height(base_from_tool0, COMFORT_HEIGHT_M, seed, what) {
            return Ok(found);
        }
        let choice = choose_lift(
            self.model(),
            &self.task.arm.ik,
            base_from_tool0,
            seed,
            &LiftParams::default(),
        )
        .map_err(|e| Stop::refused("unreachable", format!("{what}: {e}")))?;
        Ok((choice.lift_m, choice.q_rad))
    }

    /// The lift that puts `base_from_tool0` `height_m` above the arm base (within the lift's
    /// travel), with the arm's configuration there nearest `seed`.
    ///
    /// # Errors
    /// `unreachable` when the arm does not reach it there, or only near a singularity.
    pub fn lift_for_height(
        &self,
        base_from_tool0: &Isometry3<f64>,
        height_m: f64,
        seed: &[f64; 6],
        what: &str,
    ) -> Result<(f64, [f64; 6]), Stop> {
        let model = self.model();
        let limit = &model.lift_limit;
        let lift = (base_from_tool0.translation.z - self.arm_base_point(0.0).z - height_m)
            .clamp(limit.position_min, limit.position_max);
        let target = model.arm_base_from_base(lift) * base_from_tool0;
        match self.task.arm.ik.nearest(&target, seed) {
            Ok(solution) if !solution.near_singular => Ok((lift, solution.q_rad)),
            Ok(_) => Err(Stop::refused(
                "unreachable",
                format!("{what}: near a singularity at lift {lift:.3} m"),
            )),
            Err(e) => Err(Stop::refused(
                "unreachable",
                format!("{what} at lift {lift:.3} m: {e}"),
            )),
        }
    }

    // ------------------------------------------------------------ priors and look poses

    /// The wire's prior in `base_link`: the panoramic fix once found, else the site map's.
    ///
    /// # Errors
    /// `no_odometry`.
    pub fn wire_prior_in_base(&self) -> Result<(Point3<f64>, Vector3<f64>), Stop> {
        Ok(self.task.wire.prior_in_base(&self.base_from_map()?))
    }

    /// `tool0` putting the camera at `base_from_camera` with the camera edge now, with the
    /// lift height and configuration of [`Self::comfortable_lift`].
    ///
    /// # Errors
    /// `unreachable`.
    pub fn look_goal_for(
        &self,
        base_from_camera: &Isometry3<f64>,
        seed: &[f64; 6],
    ) -> Result<(Isometry3<f64>, f64, [f64; 6]), Stop> {
        let tool = base_from_camera * self.task.robot.tool0_from_camera_now().inverse();
        let (lift, q) = self.comfortable_lift(&tool, seed, "look pose")?;
        Ok((tool, lift, q))
    }

    /// `tool0` with the camera level with `target` on a line along `line_dir`
    /// ([`poses::level_look_pose`] from the arm base at lift 0, the image's up towards
    /// `up_hint`), its lift and configuration.
    ///
    /// # Errors
    /// `bad_geometry`, `unreachable`.
    pub fn look_goal(
        &self,
        target: &Point3<f64>,
        line_dir: &Vector3<f64>,
        up_hint: &Vector3<f64>,
        seed: &[f64; 6],
    ) -> Result<(Isometry3<f64>, f64, [f64; 6]), Stop> {
        let robot_point = self.arm_base_point(0.0);
        let camera = poses::level_look_pose(
            target,
            line_dir,
            &robot_point,
            self.task.config.standoff_m,
            up_hint,
        )
        .map_err(|e| Stop::failed("bad_geometry", e.to_string()))?;
        self.look_goal_for(&camera, seed)
    }

    /// The distance of a look at the stored rod (m): [`TaskConfig::standoff_m`](super::TaskConfig::standoff_m),
    /// [`HANDLE_LOOK_FARTHER`] times that once a view cut its handle at both ends.
    pub fn handle_standoff_m(&self) -> f64 {
        let standoff_m = self.task.config.standoff_m;
        if self.task.memory.look_farther {
            standoff_m * HANDLE_LOOK_FARTHER
        } else {
            standoff_m
        }
    }

    /// The stored rod: as seen by the wrist camera when it was, otherwise the site map's.
    ///
    /// # Errors
    /// `no_odometry`.
    pub fn stored_rod_in_base(&self) -> Result<Isometry3<f64>, Stop> {
        let map_from_rod = self
            .task
            .memory
            .stored_rod_seen
            .unwrap_or_else(|| self.task.config.site.map_from_stored_rod());
        Ok(self.base_from_map()? * map_from_rod)
    }

    /// The prior of the handle's centre and axis at `site`: the site map's stored rod, the
    /// measured hung rod, or a rod hung on the prior wire by the hang flow.
    ///
    /// # Errors
    /// `no_odometry`, `bad_geometry`.
    pub fn handle_prior_in_base(
        &self,
        site: HandleSite,
    ) -> Result<(Point3<f64>, Vector3<f64>), Stop> {
        let [hx, hy, hz] = robot::grounding_rod::HANDLE_CENTER_IN_ROD_M;
        if site == HandleSite::Rack {
            let rod = self.base_from_map()? * self.task.config.site.map_from_stored_rod();
            return Ok((rod * Point3::new(hx, hy, hz), rod.rotation * Vector3::z()));
        }
        if let Rod::OnWire(rod) = self.task.memory.rod {
            return Ok((rod * Point3::new(hx, hy, hz), rod.rotation * Vector3::z()));
        }
        // A rod hung on the prior wire by the hang flow.
        let (point, dir) = self.wire_prior_in_base()?;
        let hook = poses::hook_goal(&point, &dir, &self.arm_base_point(0.0))
            .map_err(|e| Stop::failed("bad_geometry", e.to_string()))?;
        let rod = hook * rod_from_hook().inverse();
        Ok((rod * Point3::new(hx, hy, hz), rod.rotation * Vector3::z()))
    }

    /// Image up for a look at the handle at `site`: along the wire for the hung rod, across
    /// the line of sight from the arm for the stored one (a vertical handle spans the image's
    /// width).
    ///
    /// # Errors
    /// `no_odometry`, `bad_site_map`.
    pub fn handle_image_up(
        &self,
        site: HandleSite,
        centre: &Point3<f64>,
    ) -> Result<Vector3<f64>, Stop> {
        match site {
            HandleSite::Wire => Ok(self.wire_prior_in_base()?.1),
            HandleSite::Rack => {
                let mut sight = centre - self.arm_base_point(0.0);
                sight.z = 0.0;
                Vector3::z()
                    .cross(&sight)
                    .try_normalize(1e-9)
                    .ok_or_else(|| Stop::failed("bad_site_map", "the rack is above the arm's base"))
            }
        }
    }

    // ------------------------------------------------------------ shared motions

    /// Arm to the stow configuration (when not there), lift down (when not down).
    ///
    /// # Errors
    /// As the plans.
    pub fn stow(&self) -> Result<Vec<Action>, Stop> {
        let q = self.q()?;
        let lift = self.lift()?;
        let mut actions = Vec::new();
        let world = self.world(lift)?;
        let stow = self.task.config.stow_rad;
        if (0..6).any(|j| (q[j] - stow[j]).abs() > ARRIVED_RAD) {
            let plan = self.plan_move(&world, lift, &q, &stow, "stow")?;
            actions.push(self.arm_action(&plan, "arm to stow"));
        }
        if lift > LIFT_ARRIVED_M {
            self.check_lift_move(&stow, lift, 0.0)?;
            actions.push(Action::lift(lift, 0.0, "lift down"));
        }
        Ok(actions)
    }

    /// The views of the site's calibration target: the drift check's ([`ViewBatch::Check`]:
    /// calib's [`calib::selfcal::CHECK_MOTION`] around a point [`CHECK_LOOK_ABOVE_M`] above
    /// the target's centre), the check's four more ([`ViewBatch::CheckMore`]:
    /// [`calib::selfcal::drift::CHECK_MOTION_MORE`] around the same point) or the
    /// recalibration's ([`TaskConfig::calibration_views`](super::TaskConfig::calibration_views)).
    /// The lift goes to the calibration height, `/calibration/command` `check`, `extend` or
    /// `collect`,
    /// the arm visits every view and captures, returns to stow and the lift to where it was,
    /// then `solve` and the wait for the answer.
    ///
    /// # Errors
    /// `bad_site_map` for a vertical or zero target normal; as the plans (the text names
    /// the view).
    pub fn views(&self, batch: ViewBatch) -> Result<Vec<Action>, Stop> {
        let check = batch != ViewBatch::Calibrate;
        let config = &self.task.config;
        let base_from_map = self.base_from_map()?;
        let centre = base_from_map * config.site.calibration_target;
        let normal = base_from_map.rotation * config.site.calibration_normal;
        let cameras = if check {
            // The target frame: origin on the face, z the outward normal, x horizontal so
            // that the images are upright (camera y towards the ground).
            let look_at = centre + Vector3::new(0.0, 0.0, CHECK_LOOK_ABOVE_M);
            let x = Vector3::z()
                .cross(&normal)
                .try_normalize(1e-9)
                .ok_or_else(|| {
                    Stop::failed(
                        "bad_site_map",
                        "the calibration target's normal is vertical",
                    )
                })?;
            let target = Isometry3::from_parts(
                nalgebra::Translation3::from(look_at.coords),
                nalgebra::UnitQuaternion::from_rotation_matrix(
                    &nalgebra::Rotation3::from_basis_unchecked(&[x, normal.cross(&x), normal]),
                ),
            );
            let poses: &[calib::selfcal::drift::CheckPose] = if batch == ViewBatch::CheckMore {
                &calib::selfcal::drift::CHECK_MOTION_MORE
            } else {
                &calib::selfcal::CHECK_MOTION
            };
            calib::selfcal::drift::check_camera_poses(&target, poses)
        } else {
            config
                .calibration_views
                .camera_poses(&centre, &normal)
                .ok_or_else(|| {
                    Stop::failed(
                        "bad_site_map",
                        "the calibration target's normal is vertical or zero",
                    )
                })?
        };
        let lift = config.calibration_lift_m;
        let q0 = self.q()?;
        let lift0 = self.lift()?;
        let mut actions = Vec::new();
        if (lift0 - lift).abs() > LIFT_ARRIVED_M {
            self.check_lift_move(&q0, lift0, lift)?;
            actions.push(Action::lift(lift0, lift, "lift to the calibration height"));
        }
        actions.push(Action::calibration(
            match batch {
                ViewBatch::Check => "check",
                ViewBatch::CheckMore => "extend",
                ViewBatch::Calibrate => "collect",
            },
            Until::Issued,
            "calibration batch",
        ));
        let world = self.world(lift)?;
        let mount = self.task.robot.tool0_from_camera_now();
        let mut q = q0;
        for (k, base_from_camera) in cameras.iter().enumerate() {
            let goal = base_from_camera * mount.inverse();
            let qk = self.ik_goal(lift, &goal, &q)?;
            let plan = self
                .plan(
                    &world,
                    lift,
                    &q,
                    &[qk],
                    if check {
                        "drift check view"
                    } else {
                        "calibration view"
                    },
                )
                .map_err(|mut s| {
                    s.text = format!("view {k}: {}", s.text);
                    s
                })?;
            actions.push(self.arm_action(&plan, "arm to a view"));
            actions.push(Action::capture("view capture"));
            q = qk;
        }
        // Back to stow and the lift height the step began at, so that the next step plans
        // from the pose it would have started from without self-maintenance.
        let stow = config.stow_rad;
        let plan = self.plan_move(&world, lift, &q, &stow, "stow after the views")?;
        actions.push(self.arm_action(&plan, "arm to stow"));
        if (lift0 - lift).abs() > LIFT_ARRIVED_M {
            self.check_lift_move(&stow, lift, lift0)?;
            actions.push(Action::lift(lift, lift0, "lift back"));
        }
        actions.push(Action::calibration(
            "solve",
            Until::Calibration,
            "calibration answer",
        ));
        Ok(actions)
    }

    /// The camera looking at the handle at `site` ([`Self::handle_prior_in_base`]): level
    /// with the hung rod's handle (the lift first when it must move), or the stored rod's
    /// view of [`Self::look_at_stored_rod`].
    ///
    /// # Errors
    /// As the plans and priors.
    pub fn look_at_handle(&self, site: HandleSite) -> Result<Vec<Action>, Stop> {
        let q = self.q()?;
        let lift = self.lift()?;
        let (centre, axis) = self.handle_prior_in_base(site)?;
        let up = self.handle_image_up(site, &centre)?;
        if site == HandleSite::Rack {
            return self.look_at_stored_rod(
                &centre,
                &up,
                &q,
                lift,
                &RACK_LOOK_ELEVATIONS_DEG,
                true,
            );
        }
        let (tool, look_lift, q_look) = self.look_goal(&centre, &axis, &up, &q)?;
        let mut actions = Vec::new();
        if (look_lift - lift).abs() > LIFT_ARRIVED_M {
            self.check_lift_move(&q, lift, look_lift)?;
            actions.push(Action::lift(lift, look_lift, "lift to the handle"));
        }
        // The arm's other branches where the nearest would swing the upper arm onto the
        // lift plate.
        let world = self.world(look_lift)?;
        let plan = self.first_plannable(look_lift, &[tool], &q_look, |goal| {
            self.plan_move(&world, look_lift, &q, goal, "look at the handle")
        })?;
        actions.push(self.arm_action(&plan, "camera level with the handle"));
        Ok(actions)
    }

    /// The camera on the empty rack (its post and base plate, beside where the stored rod's
    /// handle would be), as [`Self::look_at_stored_rod`] from the elevations of
    /// [`EMPTY_RACK_LOOK_ELEVATIONS_DEG`] and without the coupling probe.
    ///
    /// # Errors
    /// As [`Self::look_at_stored_rod`].
    pub fn look_at_empty_rack(&self) -> Result<Vec<Action>, Stop> {
        let q = self.q()?;
        let lift = self.lift()?;
        let (handle, _) = self.handle_prior_in_base(HandleSite::Rack)?;
        // Aimed between the handle's place and the post, so that the post's faces are whole
        // in the image (at the handle alone the post is near the image's edge).
        let model = crate::tasks::survey::rack_post_model();
        let [px, py] = model.centre_xy_m;
        let handle_z_in_rack = robot::grounding_rod::RACK_STORE_HEIGHT_M
            + robot::grounding_rod::HANDLE_CENTER_IN_ROD_M[2];
        let post = self.base_from_map()?
            * self.task.config.site.map_from_rack
            * Point3::new(px, py, handle_z_in_rack);
        let centre = Point3::from((handle.coords + post.coords) * 0.5);
        let up = self.handle_image_up(HandleSite::Rack, &centre)?;
        self.look_at_stored_rod(
            &centre,
            &up,
            &q,
            lift,
            &EMPTY_RACK_LOOK_ELEVATIONS_DEG,
            false,
        )
    }

    /// The stored rod stands beside the arm, below its base: the camera looks at its handle
    /// from [`TaskConfig::standoff_m`](super::TaskConfig::standoff_m) on the arm's side, from
    /// the first of `elevations_deg` the arm reaches without collision at the current lift
    /// (the handle's look: the lowest of [`RACK_LOOK_ELEVATIONS_DEG`]). Before it, the coupling probe: the empty clamp closes to full
    /// travel (it jumps to the rod's open jaw when the end effector engages the stored rod),
    /// when `probe`.
    ///
    /// # Errors
    /// The last elevation's refusal; `bad_site_map` for a rack below the arm's base.
    pub fn look_at_stored_rod(
        &self,
        centre: &Point3<f64>,
        up: &Vector3<f64>,
        q: &[f64; 6],
        lift: f64,
        elevations_deg: &[f64],
        probe: bool,
    ) -> Result<Vec<Action>, Stop> {
        let mut towards_arm = self.arm_base_point(lift) - centre;
        towards_arm.z = 0.0;
        let towards_arm = towards_arm
            .try_normalize(1e-9)
            .ok_or_else(|| Stop::failed("bad_site_map", "the rack is below the arm's base"))?;
        let mount = self.task.robot.tool0_from_camera_now();
        let world = self.world(lift)?;
        let mut last = None;
        for &elevation_deg in elevations_deg {
            let e = elevation_deg.to_radians();
            let eye = centre
                + (towards_arm * e.cos() + Vector3::z() * e.sin()) * self.handle_standoff_m();
            let Some(camera) = robot::se3::world_from_camera_looking_at(&eye, centre, up) else {
                continue;
            };
            let attempt = self
                .ik_goal(lift, &(camera * mount.inverse()), q)
                .and_then(|goal| self.plan_move(&world, lift, q, &goal, "look at the stored rod"));
            match attempt {
                Ok(plan) => {
                    let mut actions = Vec::new();
                    if probe
                        && self.task.robot.clamp_m.unwrap_or(0.0)
                            < CLAMP_TRAVEL_M - CLAMP_CONTACT_TOLERANCE_M
                    {
                        actions.push(self.clamp_action(
                            ClampCommand::CLOSE,
                            "close the empty clamp (coupling probe)",
                        ));
                    }
                    actions.push(self.arm_action(&plan, "camera on the stored rod"));
                    return Ok(actions);
                }
                Err(stop) => last = Some(stop),
            }
        }
        Err(last
            .unwrap_or_else(|| Stop::failed("bad_site_map", "no view of the stored rod's handle")))
    }

    /// Back along the tool's -z by `distance_m` at the current lift, with `allowed` contacts
    /// (body, obstacle) ignored: the moves after a miss, the unhook. Straight only: a rod's
    /// hook must leave the wire along the line it came in by, and its contact with the wire
    /// is one of the ignored ones.
    ///
    /// # Errors
    /// As the plans.
    pub fn back_off(
        &self,
        distance_m: f64,
        allowed: &[(&'static str, &str)],
        what: &str,
    ) -> Result<(ArmPlan, [f64; 6]), Stop> {
        self.back_off_bending(distance_m, allowed, what, false)
    }

    /// [`Self::back_off`] for the release (the gripper leaving the handle of the rod on the
    /// wire): when the straight line collides, [`BACK_OFF_STRAIGHT_M`] along -z, then the
    /// rest of `distance_m` along -z turned up by each of [`BACK_OFF_BENDS_DEG`] in turn,
    /// the tool's attitude kept. A refused release would leave the gripper on a rod clamped
    /// to the wire.
    ///
    /// # Errors
    /// As the plans; the straight line's refusal when no bend plans either.
    pub fn release_back_off(
        &self,
        distance_m: f64,
        allowed: &[(&'static str, &str)],
        what: &str,
    ) -> Result<(ArmPlan, [f64; 6]), Stop> {
        self.back_off_bending(distance_m, allowed, what, true)
    }

    fn back_off_bending(
        &self,
        distance_m: f64,
        allowed: &[(&'static str, &str)],
        what: &str,
        bend: bool,
    ) -> Result<(ArmPlan, [f64; 6]), Stop> {
        let q = self.q()?;
        let lift = self.lift()?;
        let tool = self.base_from_tool0(lift, &q);
        let mut world = self.world(lift)?;
        for (body, obstacle) in allowed {
            world = world.allowing(body, obstacle);
        }
        let back = poses::along_own_z(&tool, -distance_m);
        let line = self.line_waypoints(lift, &q, &back)?;
        let straight = match self.plan(&world, lift, &q, &line, what) {
            Ok(plan) => return Ok((plan, line.last().copied().unwrap_or(q))),
            Err(stop) if bend && stop.reason_code == "collision" => stop,
            Err(stop) => return Err(stop),
        };
        let first = BACK_OFF_STRAIGHT_M.min(distance_m);
        let down = tool.rotation * -Vector3::z();
        // The vertical plane of -z; a tool pointing straight up or down has no "up" to turn to.
        let up = Vector3::z() - down * down.z;
        if distance_m <= first || up.norm() < 1e-6 {
            return Err(straight);
        }
        let up = up.normalize();
        let mid = poses::along_own_z(&tool, -first);
        let Ok(to_mid) = self.line_waypoints(lift, &q, &mid) else {
            return Err(straight);
        };
        let q_mid = to_mid.last().copied().unwrap_or(q);
        for bend_deg in BACK_OFF_BENDS_DEG {
            let b = bend_deg.to_radians();
            let dir = down * b.cos() + up * b.sin();
            let end = Isometry3::from_parts(
                (mid.translation.vector + dir * (distance_m - first)).into(),
                mid.rotation,
            );
            let Ok(rest) = self.line_waypoints(lift, &q_mid, &end) else {
                continue;
            };
            let bent: Vec<[f64; 6]> = to_mid.iter().chain(&rest).copied().collect();
            if let Ok(plan) = self.plan(&world, lift, &q, &bent, what) {
                return Ok((plan, bent.last().copied().unwrap_or(q)));
            }
        }
        Err(straight)
    }
}

/// Joint angles for a message, `[a, b, ...]` to 3 decimals.
fn fmt_q(q: &[f64; 6]) -> String {
    let parts: Vec<String> = q.iter().map(|v| format!("{v:.3}")).collect();
    format!("[{}]", parts.join(", "))
}
