//! `to_pre_approach` (hang): the arm to the pre-approach configuration of the hang lift,
//! executed at the look lift (the hook [`TaskConfig::approach_m`](crate::stages::task::TaskConfig::approach_m)
//! behind the wire and above it), then the lift lowers the hook to the wire's height. The
//! approach itself must be plannable before committing, preferably with
//! [`APPROACH_REACH_MARGIN_M`] of reach to spare; where it is not at the comfortable lift,
//! lower tool heights ([`HANG_TOOL_HEIGHTS_M`]) reach farther out. A swinging wire's band widens the
//! conductors' clearance; the pre-approach stands back by as much more.
//!
//! Where the arm must change its IK branch on the way (elbow and wrist flipped between the
//! look and the pre-approach), the joint move swings the 2 m rod through a wide arc. When no
//! lift plans with [`Planner::plan_move`]'s fixed detours (on a seeded site every one of them
//! crossed the wire or the cabinet), a path searched around the obstacles is tried at each
//! lift whose move was the refused part ([`Planner::plan_move_around`]).

use nalgebra::Isometry3;

use crate::stages::task::Task;
use crate::stages::task::action::Action;
use crate::stages::task::flow::{StepDef, Stop, next_in_flow};
use crate::stages::task::planning::Planner;
use crate::tasks::poses;
use crate::tasks::site::{CONDUCTOR_SWAY_MARGIN_M, TARGET_WIRE};

/// The step's event name.
pub(crate) const NAME: &str = "to_pre_approach";
/// The step.
pub(crate) const STEP: StepDef = StepDef {
    name: NAME,
    plan,
    finish: next_in_flow,
};

/// Heights of `tool0` above the arm base tried in turn for the hang (m): the comfortable
/// half-bent arm first ([`Planner::comfortable_lift`](crate::stages::task::planning::Planner::comfortable_lift)),
/// then lower, where the arm reaches farther out (the stretched arm reaches farthest with
/// the wrist level with the shoulder): a wire a few cm farther from the working spot than
/// the site's design.
pub(crate) const HANG_TOOL_HEIGHTS_M: [f64; 2] = [0.3, 0.15];
/// The approach line should be able to go on this far beyond the hook (m): the arm then
/// reaches the hook with margin for the few millimetres by which the reached pre-approach
/// differs from the planned one (at the edge of the reach, they decide whether the line ends
/// in the arm's branch). Preferred, not required: a lift with the margin is taken first.
pub(crate) const APPROACH_REACH_MARGIN_M: f64 = 0.03;

/// The lifts (with the arm's configuration there) at which the arm reaches `tool_hang`: the
/// comfortable one, then those of [`HANG_TOOL_HEIGHTS_M`], each lift once (the lift's travel
/// clamps some heights to the same one); and the first refusal among those it does not
/// reach.
pub(crate) fn hang_lifts(
    p: &Planner<'_>,
    tool_hang: &Isometry3<f64>,
    q: &[f64; 6],
) -> (Vec<(f64, [f64; 6])>, Option<Stop>) {
    let mut lifts = vec![p.comfortable_lift(tool_hang, q, "hang pose")];
    lifts.extend(
        HANG_TOOL_HEIGHTS_M
            .iter()
            .map(|&h| p.lift_for_height(tool_hang, h, q, "hang pose")),
    );
    let mut first_refusal = None;
    let mut candidates: Vec<(f64, [f64; 6])> = Vec::new();
    for lift_and_q in lifts {
        match lift_and_q {
            Ok((l, q_hang)) if !candidates.iter().any(|(c, _)| (c - l).abs() < 1e-3) => {
                candidates.push((l, q_hang));
            }
            Ok(_) => {}
            Err(stop) => {
                first_refusal.get_or_insert(stop);
            }
        }
    }
    (candidates, first_refusal)
}

/// How far from the hook goal the pre-approach stands (m), along the approach: the
/// configured `approach_m`, and back by the sway's band beyond the still-air margin so that
/// the hook is lowered clear of the swinging wire. A missed hook backs off as far: the
/// raise to look again starts where the pre-approach stood.
pub(crate) fn approach_distance_m(task: &Task) -> f64 {
    task.config.approach_m
        + (task.memory.conductor_sway_margin_m - CONDUCTOR_SWAY_MARGIN_M).max(0.0)
}

fn plan(task: &mut Task) -> Result<Vec<Action>, Stop> {
    let p = task.planner();
    let q = p.q()?;
    let lift = p.lift()?;
    let hook = task
        .memory
        .hook_goal
        .ok_or_else(|| Stop::failed("no_target", "no hook goal"))?;
    let tool_hang = poses::tool0_for_hook(&hook);
    let approach_m = approach_distance_m(task);
    let beyond =
        poses::tool0_for_hook(&(hook * Isometry3::translation(APPROACH_REACH_MARGIN_M, 0.0, 0.0)));
    let world = p.world(lift)?;
    let (candidates, first_refusal) = hang_lifts(&p, &tool_hang, &q);
    let pre_hook = hook * Isometry3::translation(-approach_m, 0.0, 0.0);
    let tool_pre = poses::tool0_for_hook(&pre_hook);
    // Each lift planned with the fixed detours: the first with the reach to spare is taken,
    // else the first plannable one (as the arm's reach allows).
    let attempt = |around: bool, hang_lift: f64, q_hang: &[f64; 6]| {
        // The pre-approach configuration for the hang lift, executed first at the look lift
        // ... (a refusal of this move is marked: only such a lift is worth a searched path)
        let q_pre = p
            .ik_goal(hang_lift, &tool_pre, q_hang)
            .map_err(|s| (s, false))?;
        let what = "arm to the pre-approach";
        let to_pre = if around {
            p.plan_move_around(&world, lift, &q, &q_pre, what)
        } else {
            p.plan_move(&world, lift, &q, &q_pre, what)
        }
        .map_err(|s| (s, true))?;
        // ... then the lift lowers the hook to the wire's height.
        let later = || {
            p.check_lift_move(&q_pre, lift, hang_lift)?;
            let line = p.line_waypoints(hang_lift, &q_pre, &tool_hang)?;
            let world_hang = p.world(hang_lift)?.allowing("rod_head", TARGET_WIRE);
            p.plan(&world_hang, hang_lift, &q_pre, &line, "hook approach")?;
            Ok(p.line_waypoints(hang_lift, &q_pre, &beyond).is_ok())
        };
        let spare = later().map_err(|s| (s, false))?;
        let actions = vec![
            p.arm_action(&to_pre, "arm to the pre-approach"),
            Action::lift(lift, hang_lift, "lower to the hook height"),
        ];
        Ok::<_, (Stop, bool)>((actions, spare))
    };
    let (mut without_margin, mut plan_refusal) = (None, None);
    let mut blocked_moves = Vec::new();
    for &(hang_lift, q_hang) in &candidates {
        match attempt(false, hang_lift, &q_hang) {
            Ok((actions, true)) => return Ok(actions),
            Ok((actions, false)) => {
                without_margin.get_or_insert(actions);
            }
            Err((stop, move_blocked)) => {
                if move_blocked {
                    blocked_moves.push((hang_lift, q_hang));
                }
                plan_refusal.get_or_insert(stop);
            }
        }
    }
    // Then, if no lift planned, a searched path at each lift whose move alone was refused
    // (a lift refused later, e.g. at the hook approach, would be refused again).
    if without_margin.is_none() {
        for (hang_lift, q_hang) in blocked_moves {
            // The first searched path taken, with or without the reach to spare.
            match attempt(true, hang_lift, &q_hang) {
                Ok((actions, _)) => return Ok(actions),
                Err((stop, _)) => {
                    plan_refusal.get_or_insert(stop);
                }
            }
        }
    }
    if let Some(actions) = without_margin {
        return Ok(actions);
    }
    // A lift that was planned says more than one the arm could not reach.
    if let Some(stop) = plan_refusal {
        return Err(stop);
    }
    Err(first_refusal.unwrap_or_else(|| Stop::refused("unreachable", "no hang lift to plan for")))
}
