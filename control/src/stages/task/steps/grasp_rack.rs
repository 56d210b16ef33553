//! `grasp_rack` (hang): pre-grasp behind the stored rod's handle, the straight approach
//! onto it; coupled when the clamp joint then reads the rod's open jaw (a miss backs off
//! and looks again). The arm reaches the rack over the base's edge with the lift lowered:
//! where the pre-grasp at [`TaskConfig::pregrasp_m`](crate::stages::task::TaskConfig::pregrasp_m)
//! would bring the upper arm onto the chassis or the lift plate (a rack placed a few cm
//! off, turned a few degrees), the arm's other branches for the pre-grasp, and the pre-grasp
//! nearer or farther ([`PREGRASP_FACTORS`]), are tried, the first that is free.

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

/// Factors on [`TaskConfig::pregrasp_m`](crate::stages::task::TaskConfig::pregrasp_m) tried
/// in turn for the pre-grasp (0.2 m: 0.2, 0.15, 0.25, 0.12 m).
pub(crate) const PREGRASP_FACTORS: [f64; 4] = [1.0, 0.75, 1.25, 0.6];

fn plan(task: &mut Task) -> Result<Vec<Action>, Stop> {
    let p = task.planner();
    let q0 = p.q()?;
    let lift = p.lift()?;
    let grasp = poses::grasp_tool0(&p.stored_rod_in_base()?);
    let world = p.world(lift)?;
    let grasp_world = world
        .clone()
        .allowing("tool", "stored_rod_handle")
        .allowing("arm_wrist3_link", "stored_rod_handle");
    let pre_grasps: Vec<_> = PREGRASP_FACTORS
        .iter()
        .map(|f| poses::along_own_z(&grasp, -task.config.pregrasp_m * f))
        .collect();
    p.first_plannable(lift, &pre_grasps, &q0, |q_pre| {
        let to_pre = p.plan_move(&world, lift, &q0, q_pre, "rack pre-grasp")?;
        let line = p.line_waypoints(lift, q_pre, &grasp)?;
        let approach = p.plan(&grasp_world, lift, q_pre, &line, "rack grasp approach")?;
        Ok(vec![
            p.arm_action(&to_pre, "arm to the rack pre-grasp"),
            p.arm_action(&approach, "grasp the rod"),
        ])
    })
}

fn finish(task: &mut Task) -> Result<Next, Stop> {
    task.judge_grasp(HandleSite::Rack)
}
