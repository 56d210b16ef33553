//! `raise_for_look` (hang): the lift to the height of the look at the wire (the prior, or
//! the panoramic fix once found): the height that puts the wrist camera level with the wire
//! comfortably ([`crate::stages::wire_flow::LookPolicy::Level`]).

use crate::stages::task::Task;
use crate::stages::task::action::Action;
use crate::stages::task::flow::{StepDef, Stop, next_in_flow};

/// The step's event name.
pub(crate) const NAME: &str = "raise_for_look";
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
        .look_pose(&prior, &p.arm_base_point(0.0))
        .map_err(|e| Stop::failed("bad_geometry", e.to_string()))?;
    let (_, look_lift, _) = p.look_goal_for(&camera, &q)?;
    task.memory.look_lift_m = Some(look_lift);
    let p = task.planner();
    p.check_lift_move(&q, lift, look_lift)?;
    Ok(vec![Action::lift(
        lift,
        look_lift,
        "raise the lift to the wire",
    )])
}
