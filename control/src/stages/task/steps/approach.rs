//! `approach` (hang): the straight horizontal approach that brings the hook across the
//! wire (the rod's head may touch the target conductor).

use crate::stages::task::Task;
use crate::stages::task::action::Action;
use crate::stages::task::flow::{StepDef, Stop, next_in_flow};
use crate::tasks::poses;
use crate::tasks::site::TARGET_WIRE;

/// The step's event name.
pub(crate) const NAME: &str = "approach";
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
    let hook = task
        .memory
        .hook_goal
        .ok_or_else(|| Stop::failed("no_target", "no hook goal"))?;
    let line = p.line_waypoints(lift, &q, &poses::tool0_for_hook(&hook))?;
    let world = p.world(lift)?.allowing("rod_head", TARGET_WIRE);
    let plan = p.plan(&world, lift, &q, &line, "hook approach")?;
    Ok(vec![p.arm_action(&plan, "hook onto the wire")])
}
