//! `release` (hang): the rod stays clamped on the wire where the tool holds it; the
//! gripper backs off the handle along the tool's -z.

use crate::stages::task::Task;
use crate::stages::task::action::Action;
use crate::stages::task::flow::{StepDef, Stop, next_in_flow};
use crate::stages::task::memory::Rod;

/// The step's event name.
pub(crate) const NAME: &str = "release";
/// The step.
pub(crate) const STEP: StepDef = StepDef {
    name: NAME,
    plan,
    finish: next_in_flow,
};

fn plan(task: &mut Task) -> Result<Vec<Action>, Stop> {
    let p = task.planner();
    let q = p.q()?;
    let lift = p.lift()?;
    let tool = p.base_from_tool0(lift, &q);
    // The rod is clamped on the wire where the tool holds it.
    task.memory.rod = Rod::OnWire(tool * robot::grounding_rod::rod_from_tool0_grasp().inverse());
    let (plan, _) = task.planner().release_back_off(
        task.config.release_m,
        &[
            ("tool", "hung_rod_handle"),
            ("arm_wrist3_link", "hung_rod_handle"),
        ],
        "release the rod",
    )?;
    Ok(vec![task.planner().arm_action(&plan, "back off the rod")])
}
