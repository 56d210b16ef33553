//! Repositioning (hang): not a step of its own but the recovery ([`super::recover`]) the
//! wire's verdict enters when the hook goal is beyond the arm's reach from where the base
//! stands: the rod back to its carry pose, the lift down, the base straight ahead by the
//! shortfall plus [`REACH_MARGIN_M`], then the look at the wire again
//! ([`super::raise_for_look`] onwards).
//!
//! Why the wire can be out of reach although the survey put the working spot in reach: the
//! spot is known to a few cm, and the base rests on a graded yard that its odometry does not
//! measure. Tilted by a yard's 0.5-2 % grade (up to 1.1 deg), the base's frame carries a wire
//! 3.7 m up by up to 7 cm horizontally. The robot only moves forward (a differential base
//! backs up by turning round beside the rack), by at most [`MAX_REPOSITION_M`], once per hang,
//! and only along a drive the site map clears ([`super::drive::drive_clearance`]); otherwise
//! `to_pre_approach` refuses as before (`unreachable`).

use msgs::rodlog_msgs::TaskEvent;
use nalgebra::Isometry3;

use super::drive::{base_action, drive_clearance};
use super::lift_out::carry_pose;
use super::to_pre_approach::hang_lifts;
use super::{capture_wire, raise_for_look};
use crate::stages::task::Task;
use crate::stages::task::action::Action;
use crate::stages::task::flow::{Next, Stop};
use crate::stages::task::inputs::base_pose_of;
use crate::tasks::poses;
use crate::tasks::site::BasePose;

/// Beyond the least move that brings the hook into reach, the base moves this much farther
/// (m): the second look's estimate differs from the first by millimetres, and the approach
/// wants reach to spare.
pub const REACH_MARGIN_M: f64 = 0.03;
/// The farthest the base moves towards the wire (m): twice the tilt's worst effect; a wire
/// farther out than that is a survey to check, not a correction to make.
pub const MAX_REPOSITION_M: f64 = 0.15;
/// Resolution of the search for the least move (m).
const SEARCH_STEP_M: f64 = 0.01;

/// The recovery that brings `hook` (the hook goal in `base_link`) into the arm's reach
/// (module docs), or `None` when it is in reach, was repositioned for already, or cannot be
/// brought into reach by a clear forward move (`to_pre_approach` then says why).
///
/// # Errors
/// A stop from planning the rod's way back to its carry pose or the lift's way down.
pub(crate) fn toward_reach(task: &mut Task, hook: &Isometry3<f64>) -> Result<Option<Next>, Stop> {
    if task.memory.repositioned {
        return Ok(None);
    }
    let p = task.planner();
    let q = p.q()?;
    if !hang_lifts(&p, &poses::tool0_for_hook(hook), &q)
        .0
        .is_empty()
    {
        return Ok(None);
    }
    let steps = (MAX_REPOSITION_M / SEARCH_STEP_M).round() as usize;
    let Some(least_m) = (1..=steps).map(|k| k as f64 * SEARCH_STEP_M).find(|&d| {
        // The base d ahead sees the hook d nearer.
        let moved = Isometry3::translation(-d, 0.0, 0.0) * hook;
        !hang_lifts(&p, &poses::tool0_for_hook(&moved), &q)
            .0
            .is_empty()
    }) else {
        return Ok(None);
    };
    let move_m = (least_m + REACH_MARGIN_M).min(MAX_REPOSITION_M);
    let here = base_pose_of(&p.base_from_map()?.inverse());
    let goal = BasePose {
        x_m: here.x_m + move_m * here.yaw_rad.cos(),
        y_m: here.y_m + move_m * here.yaw_rad.sin(),
        yaw_rad: here.yaw_rad,
    };
    let (clearance_m, obstacle, _) = drive_clearance(&task.config.site, &here, &goal);
    if clearance_m < super::drive::DRIVE_CLEARANCE_M {
        let text = format!(
            "the hook goal is {:.0} mm beyond the arm's reach, but moving the base {:.0} mm ahead would bring the chassis within {:.0} mm of {obstacle}: not repositioning",
            least_m * 1e3,
            move_m * 1e3,
            clearance_m * 1e3
        );
        task.event(TaskEvent::INFO, capture_wire::NAME, "", text);
        return Ok(None);
    }
    let lift = p.lift()?;
    let q_carry = p.ik_goal(lift, &carry_pose(&p, lift), &q)?;
    let world = p.world(lift)?;
    let to_carry = p.plan_move(&world, lift, &q, &q_carry, "rod back to its carry pose")?;
    p.check_lift_move(&q_carry, lift, 0.0)?;
    let actions = vec![
        p.arm_action(&to_carry, "rod back to its carry pose"),
        Action::lift(lift, 0.0, "lift down to drive"),
        base_action(task, goal, move_m, "base towards the wire"),
    ];
    task.memory.repositioned = true;
    let text = format!(
        "the hook goal ({:.3}, {:.3}, {:.3}) m in base_link is beyond the arm's reach from here by {:.0}-{:.0} mm: lowering the rod and moving the base {:.0} mm ahead, then looking at the wire again",
        hook.translation.x,
        hook.translation.y,
        hook.translation.z,
        (least_m - SEARCH_STEP_M) * 1e3,
        least_m * 1e3,
        move_m * 1e3
    );
    task.event(TaskEvent::INFO, capture_wire::NAME, "repositioning", text);
    Ok(Some(Next::Recover {
        actions,
        then: raise_for_look::NAME,
    }))
}
