//! `grasp_rack` (hang): pre-grasp behind the stored rod's handle, the straight approach
//! onto it; coupled when the clamp joint then reads the rod's open jaw (a miss backs off
//! and looks again).

use crate::stages::task::Task;
use crate::stages::task::action::Action;
use crate::stages::task::flow::{Next, StepDef, Stop};
use crate::stages::task::memory::HandleSite;
use crate::tasks::poses;

/// The step's event name.
pub(crate) const NAME: &str = "grasp_rack";
/// The step.
pub(crate) const STEP: StepDef = StepDef {
    name: NAME,
    plan,
    finish,
};

fn plan(task: &mut Task) -> Result<Vec<Action>, Stop> {
    let p = task.planner();
    let q0 = p.q()?;
    let lift = p.lift()?;
    let grasp = poses::grasp_tool0(&p.stored_rod_in_base()?);
    let pre = poses::along_own_z(&grasp, -task.config.pregrasp_m);
    let world = p.world(lift)?;
    let q_pre = p.ik_goal(lift, &pre, &q0)?;
    let to_pre = p.plan_move(&world, lift, &q0, &q_pre, "rack pre-grasp")?;
    let line = p.line_waypoints(lift, &q_pre, &grasp)?;
    let world = world
        .allowing("tool", "stored_rod_handle")
        .allowing("arm_wrist3_link", "stored_rod_handle");
    let approach = p.plan(&world, lift, &q_pre, &line, "rack grasp approach")?;
    Ok(vec![
        p.arm_action(&to_pre, "arm to the rack pre-grasp"),
        p.arm_action(&approach, "grasp the rod"),
    ])
}

fn finish(task: &mut Task) -> Result<Next, Stop> {
    task.judge_grasp(HandleSite::Rack)
}
