//! `look_handle` (remove): the wrist camera level with the hung rod's handle (the lift to
//! its height first when it must move).

use crate::stages::task::Task;
use crate::stages::task::action::Action;
use crate::stages::task::flow::{StepDef, Stop, next_in_flow};
use crate::stages::task::memory::HandleSite;

/// The step's event name.
pub(crate) const NAME: &str = "look_handle";
/// The step.
pub(crate) const STEP: StepDef = StepDef {
    name: NAME,
    plan,
    finish: next_in_flow,
};

fn plan(task: &mut Task) -> Result<Vec<Action>, Stop> {
    task.planner().look_at_handle(HandleSite::Wire)
}
