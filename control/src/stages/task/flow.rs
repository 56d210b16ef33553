//! Steps and flows: what a step is ([`StepDef`]), where it leads ([`Next`]) or how it ends
//! the task ([`Stop`]), and the table of steps of each task kind ([`Flow::of`]).
//!
//! A flow is a list of entries, each a step, the operation (phase) it belongs to and whether
//! it runs on the way through ([`When`]). After a step's actions are done its `finish`
//! judges the result: [`Next::Following`] goes on to the next entry that runs; the other
//! [`Next`]s jump within the phase (look again, recalibrate, recover). The demo's flow is
//! the hang's then the remove's operation: when the flow moves into an entry of another
//! phase, the driver reports the first phase done and starts the second.

use msgs::rodlog_msgs::TaskEvent;

use super::Task;
use super::action::Action;
use super::config::{TaskConfig, TaskKind};
use super::steps::{
    approach, begin, capture_empty_rack, capture_handle, capture_rack, capture_wire,
    capture_wire_more, check_calibration, check_more, close_clamp, drive, grasp_handle, grasp_rack,
    lift_out, look_empty_rack, look_handle, look_rack, look_wire, open_clamp, panoramic, rack,
    raise_for_look, recalibrate, release, retreat, stow, to_pre_approach, unhook,
};

/// One step: its `/task/event` state name, the plan of its actions when it starts, the
/// verdict on its result when they are done.
pub(crate) struct StepDef {
    /// The `/task/event` state name.
    pub name: &'static str,
    /// Plans the step's actions from what the robot has measured so far (or stops the task:
    /// an unplannable motion, a missing input).
    pub plan: fn(&mut Task) -> Result<Vec<Action>, Stop>,
    /// Judges the step once its actions are done: where the flow goes next, or a stop.
    pub finish: fn(&mut Task) -> Result<Next, Stop>,
}

impl std::fmt::Debug for StepDef {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("StepDef").field("name", &self.name).finish()
    }
}

/// The `finish` of a step without a verdict: on to the next step of the flow.
///
/// # Errors
/// Never.
pub(crate) fn next_in_flow(_: &mut Task) -> Result<Next, Stop> {
    Ok(Next::Following)
}

/// Where a finished step leads.
#[derive(Debug)]
pub(crate) enum Next {
    /// The next entry of the flow that runs.
    Following,
    /// The entry that follows the named step (skipping it).
    After(&'static str),
    /// The named step of the current phase (again, or an earlier one).
    Goto(&'static str),
    /// The end of the task (done).
    Finished,
    /// The `recover` step with these actions (back off after a miss, hold for a sway), then
    /// where `then` leads.
    Recover {
        /// The recovery's actions.
        actions: Vec<Action>,
        /// Where the recovery leads.
        then: AfterRecovery,
    },
}

/// Where a recovery leads ([`Next::Recover`]).
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum AfterRecovery {
    /// The named step of the current phase.
    Step(&'static str),
    /// The end of the task with this stop, once the recovery has made the robot safe (the
    /// hook's last miss backs off the wire before refusing).
    Stop(Stop),
}

/// How a task ends early.
#[derive(Debug, Clone, PartialEq)]
pub struct Stop {
    /// [`TaskEvent::REFUSED`] or [`TaskEvent::FAILED`].
    pub kind: u8,
    /// Machine-readable reason.
    pub reason_code: &'static str,
    /// What happened and what to do.
    pub text: String,
}

impl Stop {
    /// A refusal: the task will not do something unsafe or unverified.
    pub fn refused(reason_code: &'static str, text: impl Into<String>) -> Self {
        Self {
            kind: TaskEvent::REFUSED,
            reason_code,
            text: text.into(),
        }
    }

    /// A failure: something did not happen as commanded.
    pub fn failed(reason_code: &'static str, text: impl Into<String>) -> Self {
        Self {
            kind: TaskEvent::FAILED,
            reason_code,
            text: text.into(),
        }
    }
}

/// When an entry runs on the way through the flow (a jump to it always runs it).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum When {
    /// Always.
    Always,
    /// With [`TaskConfig::self_maintenance`] on.
    SelfMaintenance,
    /// Never on the way through: only when a verdict goes to it ([`Next::Goto`]).
    OnRequest,
}

/// One entry of a flow.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Entry {
    /// The operation it belongs to (`hang` or `remove`; the demo has both).
    pub phase: TaskKind,
    /// The step.
    pub step: &'static StepDef,
    /// When it runs on the way through.
    pub when: When,
}

/// Drive to the working spot, stow, and the calibration's self-maintenance: the start of
/// the hang and of the remove. The check's verdict leads to four more views (unresolved),
/// the recalibration (drifted, cannot tell) or past it (consistent).
const PREPARE: [(&StepDef, When); 6] = [
    (&begin::STEP, When::Always),
    (&drive::STEP, When::Always),
    (&stow::STEP, When::Always),
    (&check_calibration::STEP, When::SelfMaintenance),
    (&check_more::STEP, When::OnRequest),
    (&recalibrate::STEP, When::SelfMaintenance),
];

/// The hang's operation, after [`PREPARE`]. Captures that see the wire swing lead to more
/// captures to track it (`capture_wire_more`).
const HANG: [(&StepDef, When); 14] = [
    (&look_rack::STEP, When::Always),
    (&capture_rack::STEP, When::Always),
    (&grasp_rack::STEP, When::Always),
    (&lift_out::STEP, When::Always),
    (&raise_for_look::STEP, When::Always),
    (&panoramic::STEP, When::Always),
    (&look_wire::STEP, When::Always),
    (&capture_wire::STEP, When::Always),
    (&capture_wire_more::STEP, When::OnRequest),
    (&to_pre_approach::STEP, When::Always),
    (&approach::STEP, When::Always),
    (&close_clamp::STEP, When::Always),
    (&release::STEP, When::Always),
    (&retreat::STEP, When::Always),
];

/// The remove's operation, after [`PREPARE`] (or after the hang, in the demo).
const REMOVE: [&StepDef; 9] = [
    &look_empty_rack::STEP,
    &capture_empty_rack::STEP,
    &look_handle::STEP,
    &capture_handle::STEP,
    &grasp_handle::STEP,
    &open_clamp::STEP,
    &unhook::STEP,
    &rack::STEP,
    &retreat::STEP,
];

/// The calibration check on its own: its verdict ends the task (after four more views
/// when it was unresolved).
const CHECK: [(&StepDef, When); 6] = [
    (&begin::STEP, When::Always),
    (&drive::STEP, When::Always),
    (&stow::STEP, When::Always),
    (&check_calibration::STEP, When::Always),
    (&check_more::STEP, When::OnRequest),
    (&retreat::STEP, When::Always),
];

/// The calibration on demand: the recalibration's views without a check first; the
/// stage's acceptance goes on to the retreat, anything else refuses.
const SELF_CALIBRATE: [&StepDef; 5] = [
    &begin::STEP,
    &drive::STEP,
    &stow::STEP,
    &recalibrate::STEP,
    &retreat::STEP,
];

/// The steps of a task, in order.
#[derive(Debug, Clone)]
pub(crate) struct Flow {
    entries: Vec<Entry>,
}

impl Flow {
    /// The flow of a task of `kind`: hang and remove are [`PREPARE`] then their operation
    /// ([`HANG`], [`REMOVE`]); the demo is [`PREPARE`], [`HANG`], [`REMOVE`]; the check
    /// is [`CHECK`], the calibration on demand [`SELF_CALIBRATE`].
    pub fn of(kind: TaskKind) -> Self {
        let listed = |phase, steps: &'static [(&'static StepDef, When)]| {
            steps
                .iter()
                .map(move |&(step, when)| Entry { phase, step, when })
        };
        let prepare = |phase| listed(phase, &PREPARE);
        let operation = |phase, steps: &'static [&'static StepDef]| {
            steps.iter().map(move |&step| Entry {
                phase,
                step,
                when: When::Always,
            })
        };
        let entries = match kind {
            TaskKind::Hang => prepare(TaskKind::Hang)
                .chain(listed(TaskKind::Hang, &HANG))
                .collect(),
            TaskKind::Remove => prepare(TaskKind::Remove)
                .chain(operation(TaskKind::Remove, &REMOVE))
                .collect(),
            TaskKind::Demo => prepare(TaskKind::Hang)
                .chain(listed(TaskKind::Hang, &HANG))
                .chain(operation(TaskKind::Remove, &REMOVE))
                .collect(),
            TaskKind::Check => listed(TaskKind::Check, &CHECK).collect(),
            TaskKind::SelfCalibrate => {
                operation(TaskKind::SelfCalibrate, &SELF_CALIBRATE).collect()
            }
        };
        Self { entries }
    }

    /// The step of entry `k`.
    pub fn step_at(&self, k: usize) -> Option<&'static StepDef> {
        self.entries.get(k).map(|e| e.step)
    }

    /// The phase of entry `k`.
    pub fn phase_at(&self, k: usize) -> Option<TaskKind> {
        self.entries.get(k).map(|e| e.phase)
    }

    /// The next entry after `k` that runs with `config`.
    pub fn following(&self, k: usize, config: &TaskConfig) -> Option<usize> {
        self.entries
            .iter()
            .enumerate()
            .skip(k + 1)
            .find(|(_, e)| match e.when {
                When::Always => true,
                When::SelfMaintenance => config.self_maintenance,
                When::OnRequest => false,
            })
            .map(|(j, _)| j)
    }

    /// The entry of the step named `name` in `phase`.
    pub fn position(&self, name: &str, phase: TaskKind) -> Option<usize> {
        self.entries
            .iter()
            .position(|e| e.step.name == name && e.phase == phase)
    }

    /// Every entry, in order.
    #[cfg(test)]
    pub fn entries(&self) -> &[Entry] {
        &self.entries
    }
}
