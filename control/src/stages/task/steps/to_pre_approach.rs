//! `to_pre_approach` (hang): the arm to the pre-approach configuration of the hang lift,
//! executed at the look lift (the hook [`TaskConfig::approach_m`](crate::stages::task::TaskConfig::approach_m)
//! behind the wire and above it), then the lift lowers the hook to the wire's height. The
//! approach itself must be plannable before committing. A swinging wire's band widens the
//! conductors' clearance; the pre-approach stands back by as much more.

use nalgebra::Isometry3;

use crate::stages::task::Task;
use crate::stages::task::action::Action;
use crate::stages::task::flow::{StepDef, Stop, next_in_flow};
use crate::tasks::poses;
use crate::tasks::site::{CONDUCTOR_SWAY_MARGIN_M, TARGET_WIRE};

/// The step's event name.
pub(crate) const NAME: &str = "to_pre_approach";
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
    let tool_hang = poses::tool0_for_hook(&hook);
    // Back by the sway's band beyond the still-air margin, so that the hook is lowered
    // clear of the swinging wire.
    let approach_m = task.config.approach_m
        + (task.memory.conductor_sway_margin_m - CONDUCTOR_SWAY_MARGIN_M).max(0.0);
    let pre_hook = hook * Isometry3::translation(-approach_m, 0.0, 0.0);
    let tool_pre = poses::tool0_for_hook(&pre_hook);
    let (hang_lift, q_hang) = p.comfortable_lift(&tool_hang, &q, "hang pose")?;
    // The pre-approach configuration for the hang lift, executed first at the look lift ...
    let q_pre = p.ik_goal(hang_lift, &tool_pre, &q_hang)?;
    let world = p.world(lift)?;
    let to_pre = p.plan_move(&world, lift, &q, &q_pre, "arm to the pre-approach")?;
    // ... then the lift lowers the hook to the wire's height.
    p.check_lift_move(&q_pre, lift, hang_lift)?;
    let line = p.line_waypoints(hang_lift, &q_pre, &tool_hang)?;
    let world_hang = p.world(hang_lift)?.allowing("rod_head", TARGET_WIRE);
    p.plan(&world_hang, hang_lift, &q_pre, &line, "hook approach")?;
    Ok(vec![
        p.arm_action(&to_pre, "arm to the pre-approach"),
        Action::lift(lift, hang_lift, "lower to the hook height"),
    ])
}
