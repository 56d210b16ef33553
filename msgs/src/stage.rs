//! The [`Stage`] trait: a deterministic function over the message stream (ARCHITECTURE.md
//! section 2).
//!
//! # Determinism rules (live == replay)
//!
//! - A stage reads nothing but its inputs and its config: no wall clock
//!   (`SystemTime::now`, `Instant::now`), no environment, no unseeded randomness, no
//!   `HashMap` iteration order, no thread-count-dependent float reductions (linear algebra
//!   runs sequentially or with fixed chunking and ordered merges).
//! - Time comes only from `log_time` and from the recorded `/clock` input fed every 100 ms
//!   of robot time; timeouts and periodic work are reactions to `/clock`.
//! - Every output's `log_time` is the triggering input's `log_time + latency()`, never
//!   "when the computation finished"; the runner stamps it, the stage only returns
//!   `(topic, msg)` pairs in a deterministic order.
//! - Stages see only what a real robot has: sensor topics, commands, config. Simulator
//!   truth (`/sim/...`) is never an input of calibration, perception or control.

use thiserror::Error;

use crate::msg::Msg;
use crate::time::{RobotDuration, RobotTime};

/// Errors a stage reports. The runner logs them to `/rosout` and decides whether to stop.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum StageError {
    /// An input topic carried another type than the stage expects.
    #[error("stage {stage}: topic {topic} at {log_time} carries {got}, expected {expected}")]
    UnexpectedType {
        /// Stage name.
        stage: String,
        /// Topic.
        topic: String,
        /// Log time of the input.
        log_time: RobotTime,
        /// Expected type name.
        expected: &'static str,
        /// Type name received.
        got: &'static str,
    },
    /// An input message is malformed (sizes disagree, unknown frame, ...).
    #[error("stage {stage}: invalid input on {topic} at {log_time}: {reason}")]
    InvalidInput {
        /// Stage name.
        stage: String,
        /// Topic.
        topic: String,
        /// Log time of the input.
        log_time: RobotTime,
        /// What is wrong.
        reason: String,
    },
    /// The stage's configuration is invalid.
    #[error("stage {stage}: invalid config {key}: {reason}")]
    Config {
        /// Stage name.
        stage: String,
        /// Config key.
        key: String,
        /// What is wrong.
        reason: String,
    },
    /// An unrecoverable internal failure (the stage cannot continue).
    #[error("stage {stage} failed at {log_time}: {reason}")]
    Failed {
        /// Stage name.
        stage: String,
        /// Log time of the triggering input.
        log_time: RobotTime,
        /// What happened.
        reason: String,
    },
}

/// A deterministic processing stage: `on_message` maps one input to zero or more outputs.
///
/// Implementations must follow the module's determinism rules; replay compares their
/// re-generated outputs with the recorded ones byte for byte.
///
/// # Example
///
/// A stage that requests a capture every second of robot time, driven by `/clock`:
///
/// ```
/// use msgs::{Msg, RobotDuration, RobotTime, RosMessage, Stage, StageError};
/// use msgs::std_msgs::Empty;
/// use msgs::topics::{CAMERA_TRIGGER, CLOCK};
///
/// struct Trigger { next: RobotTime }
///
/// impl Stage for Trigger {
///     fn name(&self) -> &str { "trigger" }
///     fn inputs(&self) -> Vec<String> { vec![CLOCK.to_string()] }
///     fn outputs(&self) -> Vec<(String, &'static str)> {
///         vec![(CAMERA_TRIGGER.to_string(), Empty::TYPE_NAME)]
///     }
///     fn latency(&self) -> RobotDuration { RobotDuration::from_millis(1) }
///     fn on_message(&mut self, log_time: RobotTime, _topic: &str, _msg: &Msg)
///         -> Result<Vec<(String, Msg)>, StageError> {
///         if log_time < self.next {
///             return Ok(vec![]);
///         }
///         self.next = log_time + RobotDuration::from_secs(1);
///         Ok(vec![(CAMERA_TRIGGER.to_string(), Empty.into())])
///     }
/// }
///
/// let mut stage: Box<dyn Stage> = Box::new(Trigger { next: RobotTime::ZERO });
/// let clock = Msg::from(msgs::rosgraph_msgs::Clock::default());
/// let mut fired = 0;
/// for tick in 0..25u64 {
///     let t = RobotTime::from_millis(100 * tick);
///     fired += stage.on_message(t, CLOCK, &clock).map_err(|e| e.to_string())?.len();
/// }
/// assert_eq!(fired, 3); // at 0 s, 1 s, 2 s
/// # Ok::<(), String>(())
/// ```
pub trait Stage {
    /// Producer name written in channel metadata (`producer=<name>`); stable across runs.
    fn name(&self) -> &str;

    /// Topics this stage consumes (the runner feeds it only these, plus nothing else).
    fn inputs(&self) -> Vec<String>;

    /// Topics (with full type names `pkg/msg/Type`) this stage may publish.
    fn outputs(&self) -> Vec<(String, &'static str)>;

    /// Fixed latency added to the trigger's `log_time` for every output.
    fn latency(&self) -> RobotDuration;

    /// Handles one input message at `log_time` (robot clock) on `topic`; returns the outputs
    /// `(topic, msg)` in a deterministic order, each logged at `log_time + latency()`.
    ///
    /// # Errors
    /// [`StageError`] for inputs it cannot handle or internal failures.
    fn on_message(
        &mut self,
        log_time: RobotTime,
        topic: &str,
        msg: &Msg,
    ) -> Result<Vec<(String, Msg)>, StageError>;
}
