//! `open_clamp` (remove): the clamp opens; the wire is free in the hook.

use msgs::rodlog_msgs::ClampCommand;

use crate::stages::task::Task;
use crate::stages::task::action::Action;
use crate::stages::task::flow::{StepDef, Stop, next_in_flow};

/// The step's event name.
pub(crate) const NAME: &str = "open_clamp";
/// The step.
pub(crate) const STEP: StepDef = StepDef {
    name: NAME,
    plan,
    finish: next_in_flow,
};

fn plan(task: &mut Task) -> Result<Vec<Action>, Stop> {
    Ok(vec![
        task.planner()
            .clamp_action(ClampCommand::OPEN, "open the clamp"),
    ])
}
