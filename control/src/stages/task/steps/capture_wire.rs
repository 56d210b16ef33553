//! `capture_wire` (hang): wrist captures of the wire and the fused estimate
//! ([`crate::stages::wire_flow`], steps 3 and 4): the hook goal, or one more look.

use super::wrist_captures;
use crate::stages::task::Task;
use crate::stages::task::action::Action;
use crate::stages::task::flow::{Next, StepDef, Stop};

/// The step's event name.
pub(crate) const NAME: &str = "capture_wire";
/// The step.
pub(crate) const STEP: StepDef = StepDef {
    name: NAME,
    plan,
    finish,
};

fn plan(task: &mut Task) -> Result<Vec<Action>, Stop> {
    task.memory.wire_extended = false;
    Ok(wrist_captures(task, task.config.wire_captures))
}

fn finish(task: &mut Task) -> Result<Next, Stop> {
    task.judge_wire()
}
