//! `panoramic` (hang): waits for the next panoramic frame and looks for the wire in it
//! ([`crate::stages::wire_flow`], step 1); a miss tries the next frame, up to
//! [`TaskConfig::panoramic_attempts`](crate::stages::task::TaskConfig::panoramic_attempts)
//! (`no_wire`).

use msgs::RobotDuration;

use crate::stages::task::Task;
use crate::stages::task::action::{Action, Until};
use crate::stages::task::flow::{Next, StepDef, Stop};

/// The step's event name.
pub(crate) const NAME: &str = "panoramic";
/// The step.
pub(crate) const STEP: StepDef = StepDef {
    name: NAME,
    plan,
    finish,
};

fn plan(_: &mut Task) -> Result<Vec<Action>, Stop> {
    Ok(vec![Action {
        outputs: Vec::new(),
        command: false,
        until: Until::Panoramic,
        timeout: RobotDuration::from_secs(5),
        label: "panoramic frame",
    }])
}

fn finish(task: &mut Task) -> Result<Next, Stop> {
    task.judge_panoramic(NAME)
}
