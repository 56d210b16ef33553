//! `recover`: not in any flow's table; a verdict enters it ([`Next::Recover`]) with the
//! actions that undo a miss (open the clamp and back off the wire, back off a handle) or
//! wait out a swaying rod, then goes back to the step it names, or ends the task with the
//! stop it carries.

use crate::stages::task::Task;
use crate::stages::task::action::Action;
use crate::stages::task::flow::{AfterRecovery, Next, StepDef, Stop};

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
    match task.memory.recovery.take() {
        Some((_, AfterRecovery::Step(then))) => Ok(Next::Goto(then)),
        Some((_, AfterRecovery::Stop(stop))) => Err(stop),
        None => Ok(Next::Finished),
    }
}
