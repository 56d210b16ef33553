//! Stages of the control crate that adapt the perception and motion algorithms to the
//! message stream: deterministic functions of their inputs, each output logged at its
//! trigger's `log_time` plus the stage's fixed latency.
//!
//! | stage or part | module | does |
//! |---|---|---|
//! | `perceive` | [`perceive`] | panoramic fix -> wrist look motion -> captures -> hanging point, on its own |
//! | `task` | [`task`] | the hang and remove task machines, their safety gates and self-maintenance |
//! | (shared) | [`wire_flow`] | the wire-perception flow both stages drive: panoramic fix, look pose, captures, fused hanging point |

pub mod perceive;
pub mod task;
pub mod wire_flow;
