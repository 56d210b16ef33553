//! `close_clamp` (hang): the clamp closes; it stops at the wire's contact travel when the
//! hook holds the wire (clamped), it runs to full travel when the hook missed (open, back
//! off, look again; `hook_missed` after the attempts).

use msgs::rodlog_msgs::ClampCommand;

use crate::stages::task::Task;
use crate::stages::task::action::Action;
use crate::stages::task::flow::{Next, StepDef, Stop};

/// The step's event name.
pub(crate) const NAME: &str = "close_clamp";
/// The step.
pub(crate) const STEP: StepDef = StepDef {
    name: NAME,
    plan,
    finish,
};

fn plan(task: &mut Task) -> Result<Vec<Action>, Stop> {
    Ok(vec![
        task.planner()
            .clamp_action(ClampCommand::CLOSE, "close the clamp"),
    ])
}

fn finish(task: &mut Task) -> Result<Next, Stop> {
    task.judge_clamp_closed()
}
