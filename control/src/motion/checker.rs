//! The motion checker over a log: proves from the recorded messages alone that no commanded
//! arm trajectory exceeds the joint limits, speeds or accelerations, that the executed motion
//! (the arm driver's `/joint_states`) stays within them too, and that no configuration,
//! commanded or executed, collides with the robot's platform, with itself, or with the wire.
//!
//! Fed messages in log order ([`MotionChecker::feed`]); pure (no I/O); `rodlog check motion
//! REC` runs it on a recording.
//!
//! # Commanded (`/arm/joint_trajectory`)
//! The start of a command is the last measured arm configuration before it (the controller
//! starts from where the arm is). Two conventions, both in ARCHITECTURE.md's vocabulary:
//! * **via points** (every point's `velocities` empty or zero, as the planner and the
//!   `script` stage publish): the controller runs each segment `q_{i-1} -> q_i` as a
//!   synchronised rest-to-rest trapezoid in `Δt_i = t_i - t_{i-1}` (`sim::arm`). The segment
//!   is within the limits iff every joint's minimum rest-to-rest time
//!   `T_j = 2 sqrt(|Δq_j| / a_j)` (triangular, `|Δq_j| <= v_j² / a_j`) or
//!   `|Δq_j| / v_j + v_j / a_j` (trapezoid) is at most `Δt_i (1 + tolerance)`. `Δt_i = 0`
//!   means "as fast as the limits allow" (the controller takes `max_j T_j`): within the
//!   limits by definition, counted as untimed.
//! * **sampled** (non-zero velocities): [`super::trajectory::check_trajectory_with`]'s
//!   finite differences, and the first point must be the measured start (a jump is a
//!   violation).
//!
//! Positions of every point must be inside the limits. Collisions: each segment is sampled
//! in joint space every [`COLLISION_STEP_RAD`] of the largest joint change and every sample
//! is checked with [`ArmCollisionModel::clearance`] at the lift height of the command.
//!
//! # Executed (`/joint_states` with the arm joints)
//! Positions within limits (plus [`CheckerParams::encoder_tolerance_rad`]); reported speeds
//! `|v| <= v_max (1 + tolerance)`; accelerations by the difference of consecutive reported
//! speeds over their stamps' interval, `<= a_max (1 + tolerance)` (the simulator reports the
//! true joint speed; a real driver's noisy speeds would need the tolerance widened);
//! clearance of every [`CheckerParams::executed_stride`]-th sample.
//!
//! # Obstacles
//! [`CollisionWorld::robot_body`] at the current lift, plus the wire when the log has it:
//! `/sim/wire_pose` (truth, allowed here: the checker scores a run, it does not steer it) as
//! a capsule of the conductor's radius, ±[`WIRE_HALF_LENGTH_M`] along the pose's x, moved into
//! `base_link` with the odometry `map -> base_link` from `/tf`.

use msgs::Msg;
use msgs::frames::{BASE_LINK, MAP};
use msgs::topics::{ARM_JOINT_TRAJECTORY, JOINT_STATES, SIM_WIRE_POSE, TF, TF_STATIC};
use msgs::trajectory_msgs::JointTrajectory;
use nalgebra::{Point3, Quaternion, UnitQuaternion, Vector3};
use robot::{JointKind, JointLimit, TfBuffer};

use super::collision::{ArmCollisionModel, Capsule, CollisionWorld};
use super::trajectory::{CheckTolerance, check_trajectory_with, limits_for_names};

/// Joint-space step between collision samples of a commanded segment (rad).
pub const COLLISION_STEP_RAD: f64 = 0.01;
/// Half-length of the wire capsule around `/sim/wire_pose` (m).
pub const WIRE_HALF_LENGTH_M: f64 = 3.0;

/// Settings of the checker.
#[derive(Debug, Clone, PartialEq)]
pub struct CheckerParams {
    /// The arm's capsules and the clearance margin.
    pub collision: ArmCollisionModel,
    /// Relative excess allowed over speed and acceleration limits. Default 0.01.
    pub relative_tolerance: f64,
    /// Position excess allowed on measured joints (rad). Default 5e-4 (10 sigma of the
    /// simulated encoder noise).
    pub encoder_tolerance_rad: f64,
    /// Check every n-th executed sample for collisions. Default 10 (10 Hz at 100 Hz).
    pub executed_stride: usize,
    /// Clearance below which a configuration is reported (m). Default 0: contact; the
    /// planner's own margin is stricter.
    pub min_clearance_m: f64,
}

impl Default for CheckerParams {
    fn default() -> Self {
        Self {
            collision: ArmCollisionModel::nominal(),
            relative_tolerance: 0.01,
            encoder_tolerance_rad: 5e-4,
            executed_stride: 10,
            min_clearance_m: 0.0,
        }
    }
}

/// One finding.
#[derive(Debug, Clone, PartialEq)]
pub struct MotionViolation {
    /// Log time of the message (ns).
    pub log_time_ns: u64,
    /// `/arm/joint_trajectory` or `/joint_states`.
    pub topic: &'static str,
    /// What was exceeded.
    pub what: String,
}

/// Totals of a check.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct MotionReport {
    /// Commands checked.
    pub trajectories: usize,
    /// Commands with `time_from_start = 0` segments (as fast as allowed).
    pub untimed_segments: usize,
    /// Executed samples checked.
    pub joint_states: usize,
    /// Configurations checked for collisions.
    pub collision_checks: usize,
    /// Largest commanded `T_min / Δt` or sampled speed ratio.
    pub peak_commanded_ratio: f64,
    /// Largest executed `|v| / v_max`.
    pub peak_executed_speed_ratio: f64,
    /// Largest executed `|a| / a_max`.
    pub peak_executed_acceleration_ratio: f64,
    /// Smallest clearance seen (m), with the pair.
    pub min_clearance_m: f64,
    /// The pair at the smallest clearance.
    pub min_clearance_pair: String,
    /// Whether the wire was known (from `/sim/wire_pose`).
    pub wire_checked: bool,
    /// Violations, in log order.
    pub violations: Vec<MotionViolation>,
}

impl MotionReport {
    /// No violations.
    #[must_use]
    pub fn passed(&self) -> bool {
        self.violations.is_empty()
    }
}

/// Minimum time (s) of a rest-to-rest move of `distance` with `v_max`, `a_max` (module docs).
#[must_use]
pub fn min_rest_to_rest_s(distance: f64, v_max: f64, a_max: f64) -> f64 {
    let d = distance.abs();
    if d == 0.0 {
        return 0.0;
    }
    if d <= v_max * v_max / a_max {
        2.0 * (d / a_max).sqrt()
    } else {
        d / v_max + v_max / a_max
    }
}

/// The log checker (module docs).
#[derive(Debug, Clone)]
pub struct MotionChecker {
    params: CheckerParams,
    arm_limits: [JointLimit; 6],
    tf: TfBuffer,
    q: Option<[f64; 6]>,
    v: Option<(u64, [f64; 6])>,
    lift_m: f64,
    wire_in_map: Option<Capsule>,
    executed_count: usize,
    report: MotionReport,
}

impl MotionChecker {
    /// A checker with `params`.
    #[must_use]
    pub fn new(params: CheckerParams) -> Self {
        let arm_limits = params.collision.model.arm_limits;
        Self {
            params,
            arm_limits,
            tf: TfBuffer::default(),
            q: None,
            v: None,
            lift_m: 0.0,
            wire_in_map: None,
            executed_count: 0,
            report: MotionReport {
                min_clearance_m: f64::INFINITY,
                ..MotionReport::default()
            },
        }
    }

    /// The report so far.
    #[must_use]
    pub fn report(&self) -> &MotionReport {
        &self.report
    }

    /// Ends the check.
    #[must_use]
    pub fn finish(self) -> MotionReport {
        self.report
    }

    fn violation(&mut self, log_time_ns: u64, topic: &'static str, what: String) {
        self.report.violations.push(MotionViolation {
            log_time_ns,
            topic,
            what,
        });
    }

    /// Feeds one message (log order).
    pub fn feed(&mut self, log_time_ns: u64, topic: &str, msg: &Msg) {
        match (topic, msg) {
            (TF, Msg::TfMessage(m)) => {
                // Errors (a foreign tree) only mean the wire cannot be placed.
                let _ = self.tf.insert_message(m, false);
            }
            (TF_STATIC, Msg::TfMessage(m)) => {
                let _ = self.tf.insert_message(m, true);
            }
            (SIM_WIRE_POSE, Msg::PoseStamped(p)) => {
                let o = &p.pose.orientation;
                let r = UnitQuaternion::from_quaternion(Quaternion::new(o.w, o.x, o.y, o.z));
                let c = Point3::new(p.pose.position.x, p.pose.position.y, p.pose.position.z);
                let axis = r * Vector3::x();
                self.wire_in_map = Some(Capsule {
                    a: c - axis * WIRE_HALF_LENGTH_M,
                    b: c + axis * WIRE_HALF_LENGTH_M,
                    radius_m: crate::perception::WIRE_RADIUS_M,
                });
            }
            (JOINT_STATES, Msg::JointState(js)) => self.on_joint_state(log_time_ns, js),
            (ARM_JOINT_TRAJECTORY, Msg::JointTrajectory(t)) => self.on_trajectory(log_time_ns, t),
            _ => {}
        }
    }

    fn world(&self, log_time_ns: u64) -> CollisionWorld {
        let mut world = CollisionWorld::robot_body(&self.params.collision.model, self.lift_m);
        if let Some(wire) = &self.wire_in_map {
            let base_from_map = self
                .tf
                .lookup(BASE_LINK, MAP, log_time_ns)
                .or_else(|_| self.tf.lookup_latest(BASE_LINK, MAP).map(|(_, t)| t));
            if let Ok(t) = base_from_map {
                world.capsules.push((
                    "wire".to_owned(),
                    Capsule {
                        a: t * wire.a,
                        b: t * wire.b,
                        radius_m: wire.radius_m,
                    },
                ));
            }
        }
        world
    }

    fn check_configuration(
        &mut self,
        world: &CollisionWorld,
        q: &[f64; 6],
        log_time_ns: u64,
        topic: &'static str,
    ) -> bool {
        let (c, link, obstacle) = self.params.collision.clearance(world, self.lift_m, q);
        self.report.collision_checks += 1;
        if world.capsules.iter().any(|(n, _)| n == "wire") {
            self.report.wire_checked = true;
        }
        if c < self.report.min_clearance_m {
            self.report.min_clearance_m = c;
            self.report.min_clearance_pair = format!("{link} vs {obstacle}");
        }
        if c < self.params.min_clearance_m {
            self.violation(
                log_time_ns,
                topic,
                format!(
                    "collision: {link} vs {obstacle}, clearance {:.4} m at q {q:?}",
                    c
                ),
            );
            return false;
        }
        true
    }

    fn on_joint_state(&mut self, log_time_ns: u64, js: &msgs::sensor_msgs::JointState) {
        let mut q = [f64::NAN; 6];
        let mut v = [f64::NAN; 6];
        let mut arm_joints = 0;
        for (k, name) in js.name.iter().enumerate() {
            match JointKind::from_name(name) {
                Some(JointKind::Lift) => {
                    if let Some(p) = js.position.get(k) {
                        self.lift_m = *p;
                    }
                }
                Some(JointKind::Arm(i)) if i < 6 => {
                    q[i] = js.position.get(k).copied().unwrap_or(f64::NAN);
                    v[i] = js.velocity.get(k).copied().unwrap_or(f64::NAN);
                    arm_joints += 1;
                }
                _ => {}
            }
        }
        if arm_joints != 6 {
            return;
        }
        let stamp_ns = u64::try_from(js.header.stamp.sec).unwrap_or(0) * 1_000_000_000
            + u64::from(js.header.stamp.nanosec);
        self.report.joint_states += 1;
        let tol = self.params.relative_tolerance;
        for j in 0..6 {
            let l = self.arm_limits[j];
            let e = self.params.encoder_tolerance_rad;
            if !(q[j] >= l.position_min - e && q[j] <= l.position_max + e) {
                self.violation(
                    log_time_ns,
                    JOINT_STATES,
                    format!(
                        "executed: joint {} at {} outside [{}, {}]",
                        j + 1,
                        q[j],
                        l.position_min,
                        l.position_max
                    ),
                );
            }
            if v[j].is_finite() {
                let ratio = v[j].abs() / l.velocity_max;
                self.report.peak_executed_speed_ratio =
                    self.report.peak_executed_speed_ratio.max(ratio);
                if ratio > 1.0 + tol {
                    self.violation(
                        log_time_ns,
                        JOINT_STATES,
                        format!(
                            "executed: joint {} speed {:.4} rad/s above {:.4}",
                            j + 1,
                            v[j].abs(),
                            l.velocity_max
                        ),
                    );
                }
            }
        }
        if let Some((t0, v0)) = self.v
            && stamp_ns > t0
        {
            let dt = (stamp_ns - t0) as f64 * 1e-9;
            for j in 0..6 {
                let a = (v[j] - v0[j]) / dt;
                if !a.is_finite() {
                    continue;
                }
                let l = self.arm_limits[j];
                let ratio = a.abs() / l.acceleration_max;
                self.report.peak_executed_acceleration_ratio =
                    self.report.peak_executed_acceleration_ratio.max(ratio);
                if ratio > 1.0 + tol {
                    self.violation(
                        log_time_ns,
                        JOINT_STATES,
                        format!(
                            "executed: joint {} acceleration {:.3} rad/s² above {:.3}",
                            j + 1,
                            a.abs(),
                            l.acceleration_max
                        ),
                    );
                }
            }
        }
        self.v = Some((stamp_ns, v));
        self.q = Some(q);
        if self
            .executed_count
            .is_multiple_of(self.params.executed_stride.max(1))
        {
            let world = self.world(log_time_ns);
            self.check_configuration(&world, &q, log_time_ns, JOINT_STATES);
        }
        self.executed_count += 1;
    }

    fn on_trajectory(&mut self, log_time_ns: u64, t: &JointTrajectory) {
        self.report.trajectories += 1;
        let limits = match limits_for_names(&self.params.collision.model, &t.joint_names) {
            Ok(l) => l,
            Err(e) => {
                self.violation(log_time_ns, ARM_JOINT_TRAJECTORY, format!("command: {e}"));
                return;
            }
        };
        // Map each point into J1..J6 order (the command may list the joints in any order).
        let mut order = [usize::MAX; 6];
        for (k, name) in t.joint_names.iter().enumerate() {
            if let Some(JointKind::Arm(i)) = JointKind::from_name(name)
                && i < 6
            {
                order[i] = k;
            }
        }
        if order.contains(&usize::MAX) {
            self.violation(
                log_time_ns,
                ARM_JOINT_TRAJECTORY,
                format!(
                    "command: joints {:?} are not the six arm joints",
                    t.joint_names
                ),
            );
            return;
        }
        let tolerance = CheckTolerance {
            relative: self.params.relative_tolerance,
            ..CheckTolerance::default()
        };
        let sampled = t
            .points
            .iter()
            .any(|p| p.velocities.iter().any(|v| *v != 0.0));
        if sampled {
            match check_trajectory_with(t, &limits, &tolerance) {
                Ok(r) => {
                    self.report.peak_commanded_ratio = self
                        .report
                        .peak_commanded_ratio
                        .max(r.peak_velocity_ratio)
                        .max(r.peak_acceleration_ratio);
                }
                Err(e) => {
                    self.violation(log_time_ns, ARM_JOINT_TRAJECTORY, format!("command: {e}"));
                }
            }
        }
        let mut points: Vec<([f64; 6], f64)> = Vec::with_capacity(t.points.len());
        for (k, p) in t.points.iter().enumerate() {
            let mut q = [0.0; 6];
            for j in 0..6 {
                q[j] = p.positions.get(order[j]).copied().unwrap_or(f64::NAN);
                let l = self.arm_limits[j];
                if !(q[j] >= l.position_min && q[j] <= l.position_max) {
                    self.violation(
                        log_time_ns,
                        ARM_JOINT_TRAJECTORY,
                        format!(
                            "command: point {k} joint {} at {} outside [{}, {}]",
                            j + 1,
                            q[j],
                            l.position_min,
                            l.position_max
                        ),
                    );
                    return;
                }
            }
            let ts = f64::from(p.time_from_start.sec) + f64::from(p.time_from_start.nanosec) * 1e-9;
            points.push((q, ts));
        }
        let start = self.q.or_else(|| points.first().map(|p| p.0));
        let Some(start) = start else {
            return;
        };
        if sampled {
            if let Some((q0, _)) = points.first() {
                let jump = (0..6).map(|j| (q0[j] - start[j]).abs()).fold(0.0, f64::max);
                if jump > 0.01 {
                    self.violation(
                        log_time_ns,
                        ARM_JOINT_TRAJECTORY,
                        format!("command: first sample {jump:.4} rad from the measured start"),
                    );
                }
            }
        } else {
            let mut previous = (start, 0.0);
            for (k, (q, ts)) in points.iter().enumerate() {
                let dt = ts - previous.1;
                if dt <= 0.0 {
                    self.report.untimed_segments += 1;
                } else {
                    let limits = self.arm_limits;
                    for (j, l) in limits.iter().enumerate() {
                        let need = min_rest_to_rest_s(
                            q[j] - previous.0[j],
                            l.velocity_max,
                            l.acceleration_max,
                        );
                        let ratio = need / dt;
                        self.report.peak_commanded_ratio =
                            self.report.peak_commanded_ratio.max(ratio);
                        if ratio > 1.0 + self.params.relative_tolerance {
                            self.violation(
                                log_time_ns,
                                ARM_JOINT_TRAJECTORY,
                                format!(
                                    "command: segment {k} joint {} needs {need:.3} s within its speed/acceleration limits, given {dt:.3} s",
                                    j + 1
                                ),
                            );
                        }
                    }
                }
                previous = (*q, *ts);
            }
        }
        // Collisions along the commanded joint-space segments.
        let world = self.world(log_time_ns);
        let mut from = start;
        for (q, _) in &points {
            let span = (0..6).map(|j| (q[j] - from[j]).abs()).fold(0.0, f64::max);
            let steps = ((span / COLLISION_STEP_RAD).ceil() as usize).max(1);
            for s in 0..=steps {
                let f = s as f64 / steps as f64;
                let qs: [f64; 6] = std::array::from_fn(|j| from[j] + (q[j] - from[j]) * f);
                if !self.check_configuration(&world, &qs, log_time_ns, ARM_JOINT_TRAJECTORY) {
                    return;
                }
            }
            from = *q;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::collision::ArmCollisionModel;
    use crate::motion::planner::{plan_through, plan_trajectory_msg};
    use msgs::builtin_interfaces::Time;
    use msgs::frames::ARM_JOINT_NAMES;
    use msgs::sensor_msgs::JointState;
    use msgs::std_msgs::Header;

    fn state(t_ns: u64, q: [f64; 6], v: [f64; 6], lift_m: f64) -> Msg {
        let mut name: Vec<String> = ARM_JOINT_NAMES.iter().map(|s| (*s).to_owned()).collect();
        name.push(msgs::frames::LIFT_JOINT.to_owned());
        let mut position = q.to_vec();
        position.push(lift_m);
        let mut velocity = v.to_vec();
        velocity.push(0.0);
        JointState {
            header: Header {
                stamp: Time {
                    sec: (t_ns / 1_000_000_000) as i32,
                    nanosec: (t_ns % 1_000_000_000) as u32,
                },
                frame_id: String::new(),
            },
            name,
            position,
            velocity,
            effort: Vec::new(),
        }
        .into()
    }

    const Q0: [f64; 6] = [0.0, 0.3, 1.6, 0.2, 1.4, 0.0];
    const Q1: [f64; 6] = [0.6, 0.2, 1.4, 0.3, 1.3, 0.4];

    #[test]
    fn a_planned_command_passes_and_a_too_fast_one_is_caught()
    -> Result<(), Box<dyn std::error::Error>> {
        let arm = ArmCollisionModel::nominal();
        let plan = plan_through(
            &arm,
            &CollisionWorld::robot_body(&arm.model, 1.0),
            1.0,
            &Q0,
            &[Q1],
            10_000_000,
        )?;
        let msg = plan_trajectory_msg(&plan, Header::default());
        let mut checker = MotionChecker::new(CheckerParams::default());
        checker.feed(0, JOINT_STATES, &state(0, Q0, [0.0; 6], 1.0));
        checker.feed(1_000, ARM_JOINT_TRAJECTORY, &msg.clone().into());
        let report = checker.report().clone();
        assert!(report.passed(), "{:?}", report.violations);
        assert!(report.peak_commanded_ratio > 0.9 && report.peak_commanded_ratio <= 1.0);
        // The same via point in half the time: beyond the limits.
        let mut fast = msg;
        let t = &mut fast.points[0].time_from_start;
        let half_ns = (u64::try_from(t.sec)? * 1_000_000_000 + u64::from(t.nanosec)) / 2;
        t.sec = i32::try_from(half_ns / 1_000_000_000)?;
        t.nanosec = u32::try_from(half_ns % 1_000_000_000)?;
        checker.feed(2_000, ARM_JOINT_TRAJECTORY, &fast.into());
        let report = checker.finish();
        assert!(!report.violations.is_empty());
        assert!(
            report.violations.iter().all(|v| v.what.contains("needs")),
            "{:?}",
            report.violations
        );
        Ok(())
    }

    #[test]
    fn limits_and_collisions_are_caught_in_commands_and_execution() {
        let mut checker = MotionChecker::new(CheckerParams::default());
        checker.feed(0, JOINT_STATES, &state(0, Q0, [0.0; 6], 0.0));
        // A command outside the joint limits.
        let mut bad = JointTrajectory {
            joint_names: ARM_JOINT_NAMES.iter().map(|s| (*s).to_owned()).collect(),
            ..JointTrajectory::default()
        };
        bad.points
            .push(msgs::trajectory_msgs::JointTrajectoryPoint {
                positions: vec![0.0, 0.3, 3.1, 0.2, 1.4, 0.0],
                ..Default::default()
            });
        checker.feed(1, ARM_JOINT_TRAJECTORY, &bad.clone().into());
        // A command into the chassis with the lift down (forearm beside the platform).
        let half_pi = std::f64::consts::FRAC_PI_2;
        bad.points[0].positions = vec![0.0, -half_pi, half_pi, 0.0, 0.0, 0.0];
        checker.feed(2, ARM_JOINT_TRAJECTORY, &bad.into());
        // Executed: too fast, then a jump in speed (acceleration).
        checker.feed(
            10_000_000,
            JOINT_STATES,
            &state(10_000_000, Q0, [0.0, 0.0, 2.7, 0.0, 0.0, 0.0], 0.0),
        );
        let report = checker.finish();
        let text: Vec<&str> = report.violations.iter().map(|v| v.what.as_str()).collect();
        assert!(text.iter().any(|t| t.contains("outside")), "{text:?}");
        assert!(
            text.iter()
                .any(|t| t.contains("collision") && t.contains("chassis")),
            "{text:?}"
        );
        assert!(text.iter().any(|t| t.contains("speed")), "{text:?}");
        assert!(text.iter().any(|t| t.contains("acceleration")), "{text:?}");
    }
}
