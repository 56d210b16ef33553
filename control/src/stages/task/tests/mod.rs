//! Message-level tests of the task stage: a [`rig::Rig`] feeds it joint states, `/tf`,
//! camera info, synthetic depth and panoramic images, `/clock`, wind and calibration
//! answers, obeys its commands, and the tests assert the commands and events of every step
//! ([`steps`]) and every refusal and failure ([`refusals`]).

mod refusals;
mod rig;
mod steps;

use msgs::rodlog_msgs::TaskEvent;

use rig::{Event, Rig};

/// Log time a whole task may take in the rig (s).
const LIMIT_S: f64 = 400.0;

/// The final event, which must end the task.
fn outcome(rig: &Rig) -> Event {
    let Some(last) = rig.last_event() else {
        panic!("no event at all");
    };
    assert_eq!(
        rig.stage.step(),
        "finished",
        "the task has not ended: {:#?}",
        rig.events()
    );
    last
}

/// The task ended with `kind` and `reason`.
fn assert_ended(rig: &Rig, kind: u8, reason: &str) -> Event {
    let last = outcome(rig);
    assert_eq!(
        (last.kind, last.reason.as_str()),
        (kind, reason),
        "ended with {last:?}; events {:#?}",
        rig.events()
    );
    last
}

/// The task ended done.
fn assert_done(rig: &Rig) -> Event {
    assert_ended(rig, TaskEvent::DONE, "done")
}

/// The number of outputs on `topic` while `step` was the step.
fn count(rig: &Rig, step: &str, topic: &str) -> usize {
    rig.outputs_in_step(step, topic).len()
}

/// The steps announced after the first `step`, at most `n` of them.
fn steps_after(rig: &Rig, step: &str, n: usize) -> Vec<String> {
    let steps = rig.steps();
    let k = steps.iter().position(|s| s == step);
    k.map(|k| steps[k + 1..].iter().take(n).cloned().collect())
        .unwrap_or_default()
}

/// The events with reason `reason`.
fn with_reason(rig: &Rig, reason: &str) -> Vec<Event> {
    rig.events()
        .into_iter()
        .filter(|e| e.reason == reason)
        .collect()
}
