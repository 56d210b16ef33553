//! `capture_empty_rack` (remove): wrist captures of the empty rack and the fit of its post
//! ([`crate::perception::rack`]): the rack's place as measured, where the rod goes back
//! (the survey's few cm are more than the rack's 1 cm seat). Nothing when the stored rod was
//! seen earlier in the run.

use super::wrist_captures;
use crate::stages::task::Task;
use crate::stages::task::action::Action;
use crate::stages::task::flow::{Next, StepDef, Stop};

/// The step's event name.
pub(crate) const NAME: &str = "capture_empty_rack";
/// The step.
pub(crate) const STEP: StepDef = StepDef {
    name: NAME,
    plan,
    finish,
};

fn plan(task: &mut Task) -> Result<Vec<Action>, Stop> {
    if task.memory.stored_rod_seen.is_some() {
        return Ok(Vec::new());
    }
    Ok(wrist_captures(task, task.config.handle_captures))
}

fn finish(task: &mut Task) -> Result<Next, Stop> {
    if task.memory.stored_rod_seen.is_some() {
        return Ok(Next::Following);
    }
    task.judge_empty_rack()
}
