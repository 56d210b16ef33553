//! `grasp_handle` (remove): pre-grasp behind the measured handle (at the current lift, then
//! the lift to the grasp height), the straight approach onto it; coupled when the clamp
//! joint then reads the rod's jaw on the wire (a miss backs off and looks again). Where the
//! move to the pre-grasp would bring the upper arm onto the lift plate, the arm's other
//! branches and the pre-grasp nearer or farther are tried, as at the rack
//! ([`PREGRASP_FACTORS`]).

use crate::stages::task::Task;
use crate::stages::task::action::{Action, LIFT_ARRIVED_M};
use crate::stages::task::flow::{Next, StepDef, Stop};
use crate::stages::task::memory::HandleSite;
use crate::stages::task::steps::grasp_rack::PREGRASP_FACTORS;
use crate::tasks::poses;

/// The step's event name.
pub(crate) const NAME: &str = "grasp_handle";
/// The step.
pub(crate) const STEP: StepDef = StepDef {
    name: NAME,
    plan,
    finish,
};

fn plan(task: &mut Task) -> Result<Vec<Action>, Stop> {
    let p = task.planner();
    let q = p.q()?;
    let lift = p.lift()?;
    let grasp = task
        .memory
        .grasp_goal
        .ok_or_else(|| Stop::failed("no_target", "no grasp goal"))?;
    let (grasp_lift, q_grasp) = p.comfortable_lift(&grasp, &q, "grasp pose")?;
    let pre_grasps: Vec<_> = PREGRASP_FACTORS
        .iter()
        .map(|f| poses::along_own_z(&grasp, -task.config.pregrasp_m * f))
        .collect();
    let world = p.world(lift)?;
    let grasp_world = p
        .world(grasp_lift)?
        .allowing("tool", "hung_rod_handle")
        .allowing("arm_wrist3_link", "hung_rod_handle");
    p.first_plannable(grasp_lift, &pre_grasps, &q_grasp, |q_pre| {
        // Pre-grasp at the current lift first when the lift has to move (the tool then
        // moves vertically behind the handle).
        let to_pre = p.plan_move(&world, lift, &q, q_pre, "arm to the handle pre-grasp")?;
        let mut actions = vec![p.arm_action(&to_pre, "arm to the pre-grasp")];
        if (grasp_lift - lift).abs() > LIFT_ARRIVED_M {
            p.check_lift_move(q_pre, lift, grasp_lift)?;
            actions.push(Action::lift(lift, grasp_lift, "lift to the grasp height"));
        }
        let line = p.line_waypoints(grasp_lift, q_pre, &grasp)?;
        let approach = p.plan(&grasp_world, grasp_lift, q_pre, &line, "grasp approach")?;
        actions.push(p.arm_action(&approach, "grasp the handle"));
        Ok(actions)
    })
}

fn finish(task: &mut Task) -> Result<Next, Stop> {
    task.judge_grasp(HandleSite::Wire)
}
