//! `capture_handle` (remove): wrist captures of the hung rod's handle and its fit: the
//! hung rod's pose and the grasp goal, a hold while the rod sways, or one more look.

use super::wrist_captures;
use crate::stages::task::Task;
use crate::stages::task::action::Action;
use crate::stages::task::flow::{Next, StepDef, Stop};
use crate::stages::task::memory::HandleSite;

/// The step's event name.
pub(crate) const NAME: &str = "capture_handle";
/// The step.
pub(crate) const STEP: StepDef = StepDef {
    name: NAME,
    plan,
    finish,
};

fn plan(task: &mut Task) -> Result<Vec<Action>, Stop> {
    Ok(wrist_captures(task, task.config.handle_captures))
}

fn finish(task: &mut Task) -> Result<Next, Stop> {
    task.judge_handle(HandleSite::Wire)
}
