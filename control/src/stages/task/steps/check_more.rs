//! `check_more`: four more drift check views when the first four could not resolve a bump
//! of the target size (the calibration stage's `unresolved`): `extend` joins them to the
//! first four, and the verdict on all eight is judged as the check's (`consistent` goes past
//! the recalibration, anything but `consistent` recalibrates; in the check task it ends the
//! task). Four views cost about a quarter of the 18-view recalibration that a check which
//! cannot tell would otherwise run.

use crate::stages::task::Task;
use crate::stages::task::action::Action;
use crate::stages::task::flow::{Next, StepDef, Stop};
use crate::stages::task::planning::ViewBatch;

/// The step's event name.
pub(crate) const NAME: &str = "check_more";
/// The step.
pub(crate) const STEP: StepDef = StepDef {
    name: NAME,
    plan,
    finish,
};

fn plan(task: &mut Task) -> Result<Vec<Action>, Stop> {
    let actions = task.planner().views(ViewBatch::CheckMore)?;
    task.memory.calibration_answer = None;
    task.memory.check_extended = true;
    Ok(actions)
}

fn finish(task: &mut Task) -> Result<Next, Stop> {
    task.judge_calibration(true)
}
