//! `capture_rack` (hang): wrist captures of the stored rod's handle and its fit: the stored
//! rod's position as seen (the base's odometry drifts by millimetres on the way; the
//! gripper's capture range is 5 mm) and the grasp goal, or one more look.

use super::wrist_captures;
use crate::stages::task::Task;
use crate::stages::task::action::Action;
use crate::stages::task::flow::{Next, StepDef, Stop};
use crate::stages::task::memory::HandleSite;

/// The step's event name.
pub(crate) const NAME: &str = "capture_rack";
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
    task.judge_handle(HandleSite::Rack)
}
