//! `look_wire` (hang): the wrist camera level with the wire at the lift's height
//! ([`crate::stages::wire_flow`], step 2, from the panoramic fix). When the arm cannot
//! reach the look without a collision (the held rod against the lift mast, on some bays),
//! it takes the look in the arm's other branches, then from beside it: [`LOOK_ALTERNATIVES`]
//! along the wire and farther back, the first that is free; the captures still see the wire
//! around the hanging point.

use crate::stages::task::Task;
use crate::stages::task::action::Action;
use crate::stages::task::flow::{StepDef, Stop, next_in_flow};

/// The step's event name.
pub(crate) const NAME: &str = "look_wire";
/// The step.
pub(crate) const STEP: StepDef = StepDef {
    name: NAME,
    plan,
    finish: next_in_flow,
};

/// Where else the camera may look from when the look at the prior collides: shift of the
/// looked-at point along the wire (m), extra standoff (m). The view spans about +-0.2 m of
/// the wire at 0.45 m, so the hanging point stays in it.
pub(crate) const LOOK_ALTERNATIVES: [(f64, f64); 6] = [
    (0.0, 0.0),
    (0.1, 0.0),
    (-0.1, 0.0),
    (0.0, 0.1),
    (0.1, 0.1),
    (-0.1, 0.1),
];

fn plan(task: &mut Task) -> Result<Vec<Action>, Stop> {
    let p = task.planner();
    let q = p.q()?;
    let lift = p.lift()?;
    let (point, direction) = p.wire_prior_in_base()?;
    let along = direction.normalize();
    let tool0_from_camera = task.robot.tool0_from_camera_now();
    let tools = LOOK_ALTERNATIVES
        .iter()
        .map(|&(shift_m, extra_m)| {
            task.wire
                .look_pose_from(
                    &(point + along * shift_m, direction),
                    &p.arm_base_point(lift),
                    task.wire.params().standoff_m + extra_m,
                )
                .map(|camera| camera * tool0_from_camera.inverse())
                .map_err(|e| Stop::failed("bad_geometry", e.to_string()))
        })
        .collect::<Result<Vec<_>, _>>()?;
    let world = p.world(lift)?;
    p.first_plannable(lift, &tools, &q, |goal| {
        let plan = p.plan_move(&world, lift, &q, goal, "look at the wire")?;
        Ok(vec![p.arm_action(&plan, "camera level with the wire")])
    })
}
