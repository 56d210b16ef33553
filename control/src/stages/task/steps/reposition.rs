//! Repositioning: not a step of its own but the recovery ([`super::recover`]) a verdict
//! enters when its target is beyond the arm's reach from where the base stands. The hang's
//! wire verdict, for the hook goal: the rod back to its carry pose, the lift down, the base
//! straight ahead by the shortfall plus [`REACH_MARGIN_M`], then the look at the wire again
//! ([`super::raise_for_look`] onwards). The remove's handle verdict, for the grasp of the hung
//! rod: the lift down, the base ahead, the look at the handle again.
//!
//! Why the wire can be out of reach although the survey put the working spot in reach: the
//! spot is known to a few cm, and the base rests on a graded yard that its odometry does not
//! measure. Tilted by a yard's 0.5-2 % grade (up to 1.1 deg), the base's frame carries a wire
//! 3.7 m up by up to 7 cm horizontally. The robot only moves forward (a differential base
//! backs up by turning round beside the rack), by at most [`MAX_REPOSITION_M`], once per task,
//! and only along a drive the site map clears ([`super::drive::drive_clearance`]); otherwise
//! `to_pre_approach` or `grasp_handle` refuses as before (`unreachable`).

use msgs::rodlog_msgs::TaskEvent;
use nalgebra::Isometry3;

use super::drive::{DRIVE_CLEARANCE_M, base_action, drive_clearance};
use super::lift_out::carry_pose;
use super::to_pre_approach::hang_lifts;
use super::{capture_handle, capture_wire, look_handle, raise_for_look};
use crate::stages::task::Task;
use crate::stages::task::action::Action;
use crate::stages::task::flow::{AfterRecovery, Next, Stop};
use crate::stages::task::inputs::base_pose_of;
use crate::stages::task::memory::Rod;
use crate::stages::task::planning::Planner;
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
    let reaches = |p: &Planner<'_>, q: &[f64; 6], hook: &Isometry3<f64>| {
        !hang_lifts(p, &poses::tool0_for_hook(hook), q).0.is_empty()
    };
    let Some(moving) = forward_move(task, hook, reaches, capture_wire::NAME)? else {
        return Ok(None);
    };
    let p = task.planner();
    let (q, lift) = (p.q()?, p.lift()?);
    let q_carry = p.ik_goal(lift, &carry_pose(&p, lift), &q)?;
    let world = p.world(lift)?;
    let to_carry = p.plan_move(&world, lift, &q, &q_carry, "rod back to its carry pose")?;
    p.check_lift_move(&q_carry, lift, 0.0)?;
    let actions = vec![
        p.arm_action(&to_carry, "rod back to its carry pose"),
        Action::lift(lift, 0.0, "lift down to drive"),
        base_action(task, moving.goal, moving.move_m, "base towards the wire"),
    ];
    announce(
        task,
        capture_wire::NAME,
        "hook goal",
        hook,
        &moving,
        "lowering the rod",
    );
    Ok(Some(Next::Recover {
        actions,
        then: AfterRecovery::Step(raise_for_look::NAME),
    }))
}

/// The same for the remove's `grasp` of the hung rod's handle (`base_link`): the lift down,
/// the base ahead, then the look at the handle again ([`super::look_handle`] onwards).
///
/// # Errors
/// A stop from planning the lift's way down.
pub(crate) fn toward_handle(task: &mut Task, grasp: &Isometry3<f64>) -> Result<Option<Next>, Stop> {
    let reaches = |p: &Planner<'_>, q: &[f64; 6], grasp: &Isometry3<f64>| {
        p.comfortable_lift(grasp, q, "grasp pose").is_ok()
    };
    let Some(moving) = forward_move(task, grasp, reaches, capture_handle::NAME)? else {
        return Ok(None);
    };
    let p = task.planner();
    let (q, lift) = (p.q()?, p.lift()?);
    p.check_lift_move(&q, lift, 0.0)?;
    let actions = vec![
        Action::lift(lift, 0.0, "lift down to drive"),
        base_action(
            task,
            moving.goal,
            moving.move_m,
            "base towards the hung rod",
        ),
    ];
    announce(
        task,
        capture_handle::NAME,
        "grasp of the handle",
        grasp,
        &moving,
        "lowering the lift",
    );
    Ok(Some(Next::Recover {
        actions,
        then: AfterRecovery::Step(look_handle::NAME),
    }))
}

/// A forward move of the base towards a target beyond reach.
struct ForwardMove {
    /// The least move that brings the target into reach (m, to [`SEARCH_STEP_M`]).
    least_m: f64,
    /// The move made: `least_m` plus [`REACH_MARGIN_M`] (m).
    move_m: f64,
    /// The base's goal in `map`.
    goal: BasePose,
}

/// The least forward move (m, to [`SEARCH_STEP_M`]) that brings `target` (`base_link`) into
/// reach by `reaches`, and the base's goal that much plus [`REACH_MARGIN_M`] ahead (its
/// distance, the pose); `None` when the target is in reach, the base was repositioned
/// already, no move up to [`MAX_REPOSITION_M`] reaches it, or the drive is not clear (said
/// in an event of `step`).
fn forward_move(
    task: &mut Task,
    target: &Isometry3<f64>,
    reaches: impl Fn(&Planner<'_>, &[f64; 6], &Isometry3<f64>) -> bool,
    step: &str,
) -> Result<Option<ForwardMove>, Stop> {
    if task.memory.repositioned {
        return Ok(None);
    }
    let p = task.planner();
    let q = p.q()?;
    if reaches(&p, &q, target) {
        return Ok(None);
    }
    let steps = (MAX_REPOSITION_M / SEARCH_STEP_M).round() as usize;
    let Some(least_m) = (1..=steps).map(|k| k as f64 * SEARCH_STEP_M).find(|&d| {
        // The base d ahead sees the target d nearer.
        reaches(&p, &q, &(Isometry3::translation(-d, 0.0, 0.0) * target))
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
    if clearance_m < DRIVE_CLEARANCE_M {
        let text = format!(
            "the target is {:.0} mm beyond the arm's reach, but moving the base {:.0} mm ahead would bring the chassis within {:.0} mm of {obstacle}: not repositioning",
            least_m * 1e3,
            move_m * 1e3,
            clearance_m * 1e3
        );
        task.event(TaskEvent::INFO, step, "", text);
        return Ok(None);
    }
    task.memory.repositioned = true;
    // What was measured in `base_link` (the wire, the rod on it), in the frame of the base
    // moved ahead: where the next plans and looks take them.
    let ahead = Isometry3::translation(-move_m, 0.0, 0.0);
    if let Rod::OnWire(base_from_rod) = task.memory.rod {
        task.memory.rod = Rod::OnWire(ahead * base_from_rod);
    }
    if let Some((point, dir)) = task.memory.wire_in_base {
        task.memory.wire_in_base = Some((ahead * point, dir));
    }
    Ok(Some(ForwardMove {
        least_m,
        move_m,
        goal,
    }))
}

/// The `repositioning` event of `step`.
fn announce(
    task: &mut Task,
    step: &str,
    what: &str,
    target: &Isometry3<f64>,
    moving: &ForwardMove,
    first: &str,
) {
    let t = target.translation.vector;
    let text = format!(
        "the {what} ({:.3}, {:.3}, {:.3}) m in base_link is beyond the arm's reach from here by {:.0}-{:.0} mm: {first} and moving the base {:.0} mm ahead, then looking again",
        t.x,
        t.y,
        t.z,
        (moving.least_m - SEARCH_STEP_M) * 1e3,
        moving.least_m * 1e3,
        moving.move_m * 1e3
    );
    task.event(TaskEvent::INFO, step, "repositioning", text);
}
