//! Task logic over the message stream: script stage, trajectories, planners, perception, hang/remove task machines, safety gates.

pub mod motion;
pub mod perception;
pub mod script;
pub mod stages;
pub mod tasks;
