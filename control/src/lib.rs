//! Task logic over the message stream: script stage, trajectories, planners, perception, hang/remove task machines, safety gates.
//!
//! | module | holds |
//! |---|---|
//! | [`script`] | the `script` stage: a scenario's timed commands |
//! | [`motion`] | trajectories and their checker, joint-space, Cartesian and base planners, lift choice, collision models |
//! | [`perception`] | wrist depth and colour, panoramic finder, wire and handle fits, confidence, synthetic captures |
//! | [`tasks`] | what the tasks plan with: the site map, task poses, calibration views, the wind gate |
//! | [`stages`] | the stages over the message stream: `perceive`, `task` (its steps, planning, judging), and the wire-perception flow they share |

pub mod motion;
pub mod perception;
pub mod script;
pub mod stages;
pub mod tasks;
