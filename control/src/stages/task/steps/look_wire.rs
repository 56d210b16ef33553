//! `look_wire` (hang): the wrist camera level with the wire at the lift's height
//! ([`crate::stages::wire_flow`], step 2, from the panoramic fix).

use crate::stages::task::Task;
use crate::stages::task::action::Action;
use crate::stages::task::flow::{StepDef, Stop, next_in_flow};

/// The step's event name.
pub(crate) const NAME: &str = "look_wire";
/// The step.
pub(crate) const STEP: StepDef = StepDef {
    name: NAME,
    plan,
    finish: next_in_flow,
};

fn plan(task: &mut Task) -> Result<Vec<Action>, Stop> {
    let p = task.planner();
    let q = p.q()?;
    let lift = p.lift()?;
    let prior = p.wire_prior_in_base()?;
    let camera = task
        .wire
        .look_pose(&prior, &p.arm_base_point(lift))
        .map_err(|e| Stop::failed("bad_geometry", e.to_string()))?;
    let tool = camera * task.robot.tool0_from_camera_now().inverse();
    let goal = p.ik_goal(lift, &tool, &q)?;
    let world = p.world(lift)?;
    let plan = p.plan_move(&world, lift, &q, &goal, "look at the wire")?;
    Ok(vec![p.arm_action(&plan, "camera level with the wire")])
}
