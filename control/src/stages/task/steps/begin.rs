//! `begin`: the wind gate at the start. Open: on. Too windy: a wind-gated wait that sends
//! nothing, so a gust at the start is waited out like one during the task (and refused,
//! `wind_above_limit`, after the hold timeout). No reading: refused (`no_wind_reading`).

use msgs::RobotDuration;

use crate::stages::task::Task;
use crate::stages::task::action::Action;
use crate::stages::task::flow::{StepDef, Stop, next_in_flow};
use crate::tasks::safety::WindVerdict;

/// The step's event name.
pub(crate) const NAME: &str = "begin";
/// The step.
pub(crate) const STEP: StepDef = StepDef {
    name: NAME,
    plan,
    finish: next_in_flow,
};

fn plan(task: &mut Task) -> Result<Vec<Action>, Stop> {
    let verdict = task.robot.gate.verdict(task.robot.now);
    match verdict {
        WindVerdict::Open { .. } => Ok(Vec::new()),
        WindVerdict::TooWindy { .. } => Ok(vec![Action::wait(
            RobotDuration::ZERO,
            true,
            RobotDuration::from_secs(5),
            "wait for the wind to drop",
        )]),
        WindVerdict::NoReading { .. } => Err(Stop::refused(
            "no_wind_reading",
            format!(
                "{}: the anemometer must report before operating",
                verdict.describe()
            ),
        )),
    }
}
