//! `unhook` (remove): the held rod backs across the wire (rod -x = tool0 -z), then the lift
//! takes it down.

use crate::stages::task::Task;
use crate::stages::task::action::Action;
use crate::stages::task::flow::{StepDef, Stop, next_in_flow};
use crate::stages::task::memory::Rod;
use crate::tasks::site::TARGET_WIRE;

/// The step's event name.
pub(crate) const NAME: &str = "unhook";
/// The step.
pub(crate) const STEP: StepDef = StepDef {
    name: NAME,
    plan,
    finish: next_in_flow,
};

fn plan(task: &mut Task) -> Result<Vec<Action>, Stop> {
    task.memory.rod = Rod::Held;
    let p = task.planner();
    let (plan, q_back) = p.back_off(
        task.config.approach_m,
        &[("rod_head", TARGET_WIRE)],
        "unhook",
    )?;
    let lift = p.lift()?;
    p.check_lift_move(&q_back, lift, 0.0)?;
    Ok(vec![
        p.arm_action(&plan, "unhook"),
        Action::lift(lift, 0.0, "lower the rod"),
    ])
}
