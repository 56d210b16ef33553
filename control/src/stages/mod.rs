//! Stages of the control crate that adapt the perception and motion algorithms to the
//! message stream (DESIGN.md s2: `log_time` of an output = trigger + fixed latency).
//!
//! | stage | module | does |
//! |---|---|---|
//! | `perceive` | [`perceive`] | panoramic fix -> wrist look motion -> captures -> hanging point |
//! | `task` | [`task`] | the hang and remove task machines, their safety gates and self-maintenance |

pub mod perceive;
pub mod task;
