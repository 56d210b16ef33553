//! `look_rack` (hang): the coupling probe (the empty clamp closed to full travel) and the
//! wrist camera on the stored rod's handle, from the lowest elevation the arm reaches.

use crate::stages::task::Task;
use crate::stages::task::action::Action;
use crate::stages::task::flow::{StepDef, Stop, next_in_flow};
use crate::stages::task::memory::HandleSite;

/// The step's event name.
pub(crate) const NAME: &str = "look_rack";
/// The step.
pub(crate) const STEP: StepDef = StepDef {
    name: NAME,
    plan,
    finish: next_in_flow,
};

fn plan(task: &mut Task) -> Result<Vec<Action>, Stop> {
    task.planner().look_at_handle(HandleSite::Rack)
}
