//! `retreat`: stow and lower; when the direct move to the stow configuration collides (the
//! hung rod in front of the tool), back off further along the tool's -z first.

use crate::stages::task::Task;
use crate::stages::task::action::{Action, LIFT_ARRIVED_M};
use crate::stages::task::flow::{StepDef, Stop, next_in_flow};
use crate::tasks::poses;

/// The step's event name.
pub(crate) const NAME: &str = "retreat";
/// The step.
pub(crate) const STEP: StepDef = StepDef {
    name: NAME,
    plan,
    finish: next_in_flow,
};

/// The back-off before stowing when the direct stow collides (m).
const BACK_OFF_M: f64 = 0.3;

fn plan(task: &mut Task) -> Result<Vec<Action>, Stop> {
    let p = task.planner();
    let direct = match p.stow() {
        Ok(actions) => return Ok(actions),
        Err(direct) => direct,
    };
    let q = p.q()?;
    let lift = p.lift()?;
    let tool = p.base_from_tool0(lift, &q);
    let back = poses::along_own_z(&tool, -BACK_OFF_M);
    let q_back = p.ik_goal(lift, &back, &q)?;
    let world = p.world(lift)?;
    let plan = p
        .plan_move(&world, lift, &q, &q_back, "back off before stowing")
        .map_err(|s| Stop {
            text: format!("{}; direct stow: {}", s.text, direct.text),
            ..s
        })?;
    let stow = task.config.stow_rad;
    let plan2 = p.plan_move(&world, lift, &q_back, &stow, "stow")?;
    let mut actions = vec![
        p.arm_action(&plan, "back off"),
        p.arm_action(&plan2, "arm to stow"),
    ];
    if lift > LIFT_ARRIVED_M {
        p.check_lift_move(&stow, lift, 0.0)?;
        actions.push(Action::lift(lift, 0.0, "lift down"));
    }
    Ok(actions)
}
