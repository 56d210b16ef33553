//! Arm plans as the stages command them: IK to a tool0 goal (nearest branch to the current
//! configuration), a rest-to-rest synchronised joint trajectory ([`super::trajectory`]), a
//! collision check of every sample ([`super::collision`], including self-collision), and the
//! two messages each plan is published as.
//!
//! # Messages
//! * `/arm/joint_trajectory`: the **via points** of the plan (the start is where the arm is),
//!   each with `time_from_start` = the end of its segment and zero velocities (the arm rests
//!   on each via point). The controller (the simulated AUBO, `sim::arm`) runs each segment as
//!   a synchronised rest-to-rest trapezoid in the requested time, which is exactly the
//!   planned profile; publishing the 10 ms samples instead would make it stop on each.
//! * `/arm/planned_path`: tool0 poses in `base_link` every [`PATH_STRIDE`] samples of the
//!   planned trajectory (and the last), for the viewer.
//!
//! The log checker ([`super::checker`]) re-derives the executed segments from the recorded
//! start state and these via points, so the two must agree on this convention.

use msgs::frames::ARM_JOINT_NAMES;
use msgs::nav_msgs::Path;
use msgs::std_msgs::Header;
use msgs::trajectory_msgs::{JointTrajectory, JointTrajectoryPoint};
use nalgebra::Isometry3;
use robot::{ArmIk, RobotModel};

use super::MotionError;
use super::collision::{ArmCollisionModel, CollisionWorld};
use super::trajectory::{
    SampledTrajectory, duration_from_ns, plan_joint_path, to_path, tool0_path,
};

/// Samples between two poses of `/arm/planned_path` (10 ms samples: every 0.1 s).
pub const PATH_STRIDE: usize = 10;
/// Samples between two collision checks (10 ms samples: every 20 ms; the arm moves at most
/// ~3 cm between checks at full speed, below the 2 cm margin plus the link radii).
pub const COLLISION_STRIDE: usize = 2;

/// A checked plan.
#[derive(Debug, Clone, PartialEq)]
pub struct ArmPlan {
    /// Lift height during the plan (m).
    pub lift_m: f64,
    /// Via points including the start.
    pub waypoints: Vec<[f64; 6]>,
    /// End time of each segment from the start (ns), one per waypoint after the first.
    pub segment_end_ns: Vec<u64>,
    /// The sampled trajectory.
    pub trajectory: SampledTrajectory,
    /// Smallest clearance over the checked samples (m).
    pub min_clearance_m: f64,
}

/// Plans from `q_start` through `waypoints` (rest-to-rest), checking collisions.
///
/// # Errors
/// [`MotionError`] from the trajectory planner or the collision check.
pub fn plan_through(
    collision: &ArmCollisionModel,
    world: &CollisionWorld,
    lift_m: f64,
    q_start: &[f64; 6],
    waypoints: &[[f64; 6]],
    dt_ns: u64,
) -> Result<ArmPlan, MotionError> {
    let mut all = Vec::with_capacity(waypoints.len() + 1);
    all.push(*q_start);
    all.extend_from_slice(waypoints);
    let mut trajectory = SampledTrajectory::at_rest(*q_start, dt_ns);
    let mut segment_end_ns = Vec::with_capacity(waypoints.len());
    for pair in all.windows(2) {
        let segment = plan_joint_path(pair, &collision.model.arm_limits, dt_ns)?;
        trajectory.append(&segment);
        segment_end_ns.push((trajectory.positions.len() as u64 - 1) * dt_ns);
    }
    let min_clearance_m =
        collision.check_samples(world, lift_m, &trajectory.positions, COLLISION_STRIDE)?;
    Ok(ArmPlan {
        lift_m,
        waypoints: all,
        segment_end_ns,
        trajectory,
        min_clearance_m,
    })
}

/// Plans to `base_from_tool0_goal`: the IK solution nearest `q_start` within the limits, then
/// [`plan_through`].
///
/// # Errors
/// [`MotionError::Ik`] when the goal is unreachable, and those of [`plan_through`].
pub fn plan_to_tool0(
    collision: &ArmCollisionModel,
    ik: &ArmIk,
    world: &CollisionWorld,
    lift_m: f64,
    q_start: &[f64; 6],
    base_from_tool0_goal: &Isometry3<f64>,
    dt_ns: u64,
) -> Result<ArmPlan, MotionError> {
    let arm_base_from_tool0 = collision.model.arm_base_from_base(lift_m) * base_from_tool0_goal;
    let goal = ik
        .nearest(&arm_base_from_tool0, q_start)
        .map_err(|source| MotionError::Ik {
            step: 0,
            steps: 1,
            source,
        })?;
    plan_through(collision, world, lift_m, q_start, &[goal.q_rad], dt_ns)
}

/// The `/arm/joint_trajectory` of a plan: its via points after the start (module docs).
#[must_use]
pub fn plan_trajectory_msg(plan: &ArmPlan, header: Header) -> JointTrajectory {
    let points = plan
        .waypoints
        .iter()
        .skip(1)
        .zip(&plan.segment_end_ns)
        .map(|(q, t)| JointTrajectoryPoint {
            positions: q.to_vec(),
            velocities: vec![0.0; 6],
            accelerations: Vec::new(),
            effort: Vec::new(),
            time_from_start: duration_from_ns(*t),
        })
        .collect();
    JointTrajectory {
        header,
        joint_names: ARM_JOINT_NAMES.iter().map(|s| (*s).to_owned()).collect(),
        points,
    }
}

/// The `/arm/planned_path` of a plan (tool0 in `base_link`, header frame set by the caller).
#[must_use]
pub fn plan_path_msg(plan: &ArmPlan, model: &RobotModel, header: Header) -> Path {
    to_path(
        &tool0_path(model, plan.lift_m, &plan.trajectory, PATH_STRIDE),
        header,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use robot::IkSettings;

    #[test]
    fn plans_to_a_reachable_pose_and_publishes_via_points() -> Result<(), Box<dyn std::error::Error>>
    {
        let collision = ArmCollisionModel::nominal();
        let ik = collision.model.arm_ik(IkSettings::default())?;
        let q0 = [0.0, 0.3, 1.6, 0.2, 1.4, 0.0];
        let q1 = [0.4, 0.1, 1.2, 0.3, 1.3, 0.2];
        let goal = collision.model.base_from_tool0(1.0, &q1);
        let plan = plan_to_tool0(
            &collision,
            &ik,
            &CollisionWorld::default(),
            1.0,
            &q0,
            &goal,
            10_000_000,
        )?;
        let last = plan.trajectory.last().ok_or("empty")?;
        let reached = collision.model.base_from_tool0(1.0, &last);
        assert!((reached.translation.vector - goal.translation.vector).norm() < 1e-9);
        let msg = plan_trajectory_msg(&plan, Header::default());
        assert_eq!(msg.points.len(), 1);
        let end_ns = plan.segment_end_ns[0];
        assert_eq!(
            u64::try_from(msg.points[0].time_from_start.sec)? * 1_000_000_000
                + u64::from(msg.points[0].time_from_start.nanosec),
            end_ns
        );
        let path = plan_path_msg(&plan, &collision.model, Header::default());
        assert!(path.poses.len() >= 2);
        Ok(())
    }
}
