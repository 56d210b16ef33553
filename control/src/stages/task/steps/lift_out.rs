//! `lift_out` (hang): the rod, coupled at the grasp, lifted out of the rack and slid out of
//! its holders (along the rack's -y, their open side), then carried upright in front of the
//! robot, clear of the rack.

use nalgebra::{Isometry3, Vector3};

use crate::stages::task::Task;
use crate::stages::task::action::Action;
use crate::stages::task::flow::{StepDef, Stop, next_in_flow};
use crate::stages::task::memory::Rod;
use crate::stages::task::planning::Planner;
use crate::tasks::poses;
use crate::tasks::site::RACK_HOLDERS;

/// The step's event name.
pub(crate) const NAME: &str = "lift_out";
/// The step.
pub(crate) const STEP: StepDef = StepDef {
    name: NAME,
    plan,
    finish: next_in_flow,
};

fn plan(task: &mut Task) -> Result<Vec<Action>, Stop> {
    // The passive latch has coupled at the grasp pose: the rod moves with the tool now.
    task.memory.rod = Rod::Held;
    let p = task.planner();
    let config = &task.config;
    let q0 = p.q()?;
    let lift = p.lift()?;
    let rack = p.base_from_map()? * config.site.map_from_rack;
    let tool = p.base_from_tool0(lift, &q0);
    let up = poses::shifted(
        &tool,
        &rack,
        &Vector3::new(0.0, 0.0, config.rack_lift_out_m),
    );
    let out = poses::shifted(&up, &rack, &Vector3::new(0.0, -config.rack_exit_m, 0.0));
    let mut world = p.world(lift)?;
    for holder in RACK_HOLDERS {
        for part in ["rod_handle", "rod_shaft", "rod_head"] {
            world = world.allowing(part, holder);
        }
    }
    let mut via = p.line_waypoints(lift, &q0, &up)?;
    let last = via.last().copied().unwrap_or(q0);
    via.extend(p.line_waypoints(lift, &last, &out)?);
    let lift_out = p.plan(&world, lift, &q0, &via, "lift the rod out of the rack")?;
    let carry_pose = carry_pose(&p, lift);
    let q_out = via.last().copied().unwrap_or(q0);
    let q_carry = p.ik_goal(lift, &carry_pose, &q_out)?;
    let world = p.world(lift)?;
    let carry = p.plan_move(&world, lift, &q_out, &q_carry, "carry the rod")?;
    Ok(vec![
        p.arm_action(&lift_out, "lift the rod out"),
        p.arm_action(&carry, "carry the rod"),
    ])
}

/// `base_from_tool0` carrying the rod at lift `lift_m`: the rod upright in front of the
/// robot (0.61 m ahead, 0.25 m left, its origin 0.35 - 0.125 m above the arm base), where it
/// clears the platform and stays ~0.7 m from the wire.
pub(crate) fn carry_pose(p: &Planner<'_>, lift_m: f64) -> Isometry3<f64> {
    let arm_base = p.arm_base_point(lift_m);
    let carried_rod = Isometry3::from_parts(
        nalgebra::Translation3::new(0.61, 0.25, arm_base.z + 0.35 - 0.125),
        nalgebra::UnitQuaternion::identity(),
    );
    poses::grasp_tool0(&carried_rod)
}
