//! `unhook` (remove): the held rod backs across the wire (rod -x = tool0 -z), then the lift
//! takes it down; farther back ([`BACK_OFF_FACTORS`]) when the way down would pass the wire
//! too close.

use crate::stages::task::Task;
use crate::stages::task::action::Action;
use crate::stages::task::flow::{StepDef, Stop, next_in_flow};
use crate::stages::task::memory::Rod;
use crate::tasks::site::TARGET_WIRE;

/// The step's event name.
pub(crate) const NAME: &str = "unhook";
/// The step.
pub(crate) const STEP: StepDef = StepDef {
    name: NAME,
    plan,
    finish: next_in_flow,
};

/// Factors on [`TaskConfig::approach_m`](crate::stages::task::TaskConfig::approach_m) tried
/// in turn for the back-off: where the rod's head would pass the wire closer than the
/// clearance on the way down (a wire hung lower or nearer than the site's), it backs
/// farther first.
pub(crate) const BACK_OFF_FACTORS: [f64; 3] = [1.0, 1.5, 2.0];

fn plan(task: &mut Task) -> Result<Vec<Action>, Stop> {
    task.memory.rod = Rod::Held;
    let p = task.planner();
    let lift = p.lift()?;
    let mut first_refusal = None;
    for factor in BACK_OFF_FACTORS {
        let attempt = p
            .back_off(
                task.config.approach_m * factor,
                &[("rod_head", TARGET_WIRE)],
                "unhook",
            )
            .and_then(|(plan, q_back)| {
                p.check_lift_move(&q_back, lift, 0.0)?;
                Ok(plan)
            });
        match attempt {
            Ok(plan) => {
                return Ok(vec![
                    p.arm_action(&plan, "unhook"),
                    Action::lift(lift, 0.0, "lower the rod"),
                ]);
            }
            Err(stop) => {
                first_refusal.get_or_insert(stop);
            }
        }
    }
    Err(first_refusal.unwrap_or_else(|| Stop::refused("unreachable", "no back-off to plan")))
}
