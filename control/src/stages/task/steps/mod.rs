//! The steps of the task flows, one module each: its `/task/event` name (`NAME`), and its
//! [`StepDef`](super::flow::StepDef) (`STEP`: what it plans, how it is judged). The tables
//! of [`super::flow`] put them in order per task kind.
//!
//! | step | flow | plans | judged by |
//! |---|---|---|---|
//! | [`begin`] | all | a wait while the wind gate is closed | - |
//! | [`drive`] | all | the base to the working spot | - |
//! | [`stow`] | all | arm to stow, lift down | - |
//! | [`check_calibration`] | all (self-maintenance; the check task) | the drift check's views | the calibration stage's verdict |
//! | [`check_more`] | all (on an `unresolved` check) | four more drift check views | the calibration stage's verdict on all eight |
//! | [`recalibrate`] | hang, remove (on drift) | the 18 calibration views | the calibration stage's answer |
//! | [`look_rack`] | hang | coupling probe, camera on the stored rod | - |
//! | [`capture_rack`] | hang | wrist captures | the stored rod's handle fit |
//! | [`grasp_rack`] | hang | pre-grasp, approach | the clamp joint (coupled) |
//! | [`lift_out`] | hang | rod out of the rack, carried upright | - |
//! | [`raise_for_look`] | hang | the lift to the wire's look height | - |
//! | [`panoramic`] | hang | a wait for a panoramic frame | the panoramic fix |
//! | [`look_wire`] | hang | camera level with the wire | - |
//! | [`capture_wire`] | hang | wrist captures | the wire estimate |
//! | [`capture_wire_more`] | hang (when the captures see the wire swing) | more wrist captures | the wire estimate and its sway over all |
//! | [`to_pre_approach`] | hang | arm to the pre-approach, lift to the hook height | - |
//! | [`approach`] | hang | the hook across the wire | - |
//! | [`close_clamp`] | hang | close the clamp | the clamp's travel (clamped or missed) |
//! | [`release`] | hang | back off the hung rod | - |
//! | [`look_empty_rack`] | remove | camera on the empty rack (unless the stored rod was seen) | - |
//! | [`capture_empty_rack`] | remove | wrist captures | the rack's post fit: where the rod goes back |
//! | [`look_handle`] | remove | camera level with the hung rod's handle | - |
//! | [`capture_handle`] | remove | wrist captures | the hung rod's handle fit (sway) |
//! | [`grasp_handle`] | remove | pre-grasp, lift, approach | the clamp joint (coupled) |
//! | [`open_clamp`] | remove | open the clamp | - |
//! | [`unhook`] | remove | back across the wire, lift down | - |
//! | [`rack`] | remove | rod into the rack, release | - (the rod is on the rack) |
//! | [`retreat`] | all | stow (backing off first when blocked), lift down | - |
//! | [`recover`] | after a miss | the verdict's recovery actions | - (back to the named step) |
//!
//! [`reposition`] is a recovery the wire's verdict plans when the hook goal is beyond the
//! arm's reach: the base moves a few cm towards the wire and the look is repeated.

pub(crate) mod approach;
pub(crate) mod begin;
pub(crate) mod capture_empty_rack;
pub(crate) mod capture_handle;
pub(crate) mod capture_rack;
pub(crate) mod capture_wire;
pub(crate) mod capture_wire_more;
pub(crate) mod check_calibration;
pub(crate) mod check_more;
pub(crate) mod close_clamp;
pub(crate) mod drive;
pub(crate) mod grasp_handle;
pub(crate) mod grasp_rack;
pub(crate) mod lift_out;
pub(crate) mod look_empty_rack;
pub(crate) mod look_handle;
pub(crate) mod look_rack;
pub(crate) mod look_wire;
pub(crate) mod open_clamp;
pub(crate) mod panoramic;
pub(crate) mod rack;
pub(crate) mod raise_for_look;
pub(crate) mod recalibrate;
pub(crate) mod recover;
pub(crate) mod release;
pub(crate) mod reposition;
pub(crate) mod retreat;
pub(crate) mod stow;
pub(crate) mod to_pre_approach;
pub(crate) mod unhook;

use super::Task;
use super::action::Action;

/// `n` (at least one) wrist captures for a capture step; the previous step's captures are
/// forgotten.
fn wrist_captures(task: &mut Task, n: usize) -> Vec<Action> {
    task.memory.captures.clear();
    (0..n.max(1))
        .map(|_| Action::capture("wrist capture"))
        .collect()
}
