//! `check_calibration`: the drift check's views of the site's calibration target and the
//! calibration stage's verdict: `consistent` goes past the recalibration, `unresolved` adds
//! four views ([`super::check_more`]), `drifted` and `cannot_tell` recalibrate; in the check
//! task the verdict ends the task.

use crate::stages::task::Task;
use crate::stages::task::action::Action;
use crate::stages::task::flow::{Next, StepDef, Stop};
use crate::stages::task::planning::ViewBatch;

/// The step's event name.
pub(crate) const NAME: &str = "check_calibration";
/// The step.
pub(crate) const STEP: StepDef = StepDef {
    name: NAME,
    plan,
    finish,
};

fn plan(task: &mut Task) -> Result<Vec<Action>, Stop> {
    let actions = task.planner().views(ViewBatch::Check)?;
    task.memory.calibration_answer = None;
    Ok(actions)
}

fn finish(task: &mut Task) -> Result<Next, Stop> {
    task.judge_calibration(true)
}
