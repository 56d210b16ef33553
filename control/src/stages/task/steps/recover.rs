//! `recover`: not in any flow's table; a verdict enters it ([`Next::Recover`]) with the
//! actions that undo a miss (open the clamp and back off the wire, back off a handle) or
//! wait out a swaying rod, then goes back to the step it names.

use crate::stages::task::Task;
use crate::stages::task::action::Action;
use crate::stages::task::flow::{Next, StepDef, Stop};

/// The step's event name.
pub(crate) const NAME: &str = "recover";
/// The step.
pub(crate) const STEP: StepDef = StepDef {
    name: NAME,
    plan,
    finish,
};

fn plan(task: &mut Task) -> Result<Vec<Action>, Stop> {
    Ok(task
        .memory
        .recovery
        .as_ref()
        .map(|(actions, _)| actions.clone())
        .unwrap_or_default())
}

fn finish(task: &mut Task) -> Result<Next, Stop> {
    Ok(task
        .memory
        .recovery
        .take()
        .map_or(Next::Finished, |(_, then)| Next::Goto(then)))
}
