//! `look_empty_rack` (remove): the wrist camera on the empty rack's holders and post, where
//! the rod will go back; nothing when the stored rod was seen earlier in the run (the demo's
//! hang measured it).

use crate::stages::task::Task;
use crate::stages::task::action::Action;
use crate::stages::task::flow::{StepDef, Stop, next_in_flow};

/// The step's event name.
pub(crate) const NAME: &str = "look_empty_rack";
/// The step.
pub(crate) const STEP: StepDef = StepDef {
    name: NAME,
    plan,
    finish: next_in_flow,
};

fn plan(task: &mut Task) -> Result<Vec<Action>, Stop> {
    if task.memory.stored_rod_seen.is_some() {
        return Ok(Vec::new());
    }
    task.planner().look_at_empty_rack()
}
