//! `capture_wire_more` (hang): when the wire captures see the conductor swing, more captures
//! join them ([`TaskConfig::sway_captures`](crate::stages::task::TaskConfig::sway_captures)
//! in all), so that the sway's centre, where the hook goes, and the band it swings in
//! ([`crate::perception::sway`]) rest on enough samples; then the estimate is judged again
//! on all of them.

use crate::stages::task::Task;
use crate::stages::task::action::Action;
use crate::stages::task::flow::{Next, StepDef, Stop};

/// The step's event name.
pub(crate) const NAME: &str = "capture_wire_more";
/// The step.
pub(crate) const STEP: StepDef = StepDef {
    name: NAME,
    plan,
    finish,
};

fn plan(task: &mut Task) -> Result<Vec<Action>, Stop> {
    task.memory.wire_extended = true;
    let more = task
        .config
        .sway_captures
        .saturating_sub(task.memory.captures.len())
        .max(1);
    Ok((0..more)
        .map(|_| Action::capture("wrist capture (sway)"))
        .collect())
}

fn finish(task: &mut Task) -> Result<Next, Stop> {
    task.judge_wire()
}
