//! `stow`: the arm to its stow configuration and the lift down (each only when not there).

use crate::stages::task::Task;
use crate::stages::task::action::Action;
use crate::stages::task::flow::{StepDef, Stop, next_in_flow};

/// The step's event name.
pub(crate) const NAME: &str = "stow";
/// The step.
pub(crate) const STEP: StepDef = StepDef {
    name: NAME,
    plan,
    finish: next_in_flow,
};

fn plan(task: &mut Task) -> Result<Vec<Action>, Stop> {
    task.planner().stow()
}
