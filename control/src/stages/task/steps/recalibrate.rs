//! `recalibrate`: the 18 calibration views and the calibration stage's answer: `accepted`
//! goes on with the new camera edge (it arrives on `/tf`); anything else refuses.

use crate::stages::task::Task;
use crate::stages::task::action::Action;
use crate::stages::task::flow::{Next, StepDef, Stop};
use crate::stages::task::planning::ViewBatch;

/// The step's event name.
pub(crate) const NAME: &str = "recalibrate";
/// The step.
pub(crate) const STEP: StepDef = StepDef {
    name: NAME,
    plan,
    finish,
};

fn plan(task: &mut Task) -> Result<Vec<Action>, Stop> {
    let actions = task.planner().views(ViewBatch::Calibrate)?;
    task.memory.calibration_answer = None;
    Ok(actions)
}

fn finish(task: &mut Task) -> Result<Next, Stop> {
    task.judge_calibration(false)
}
