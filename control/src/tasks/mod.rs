//! The grounding-rod tasks: hang the rod on the wire and remove it, safely,
//! recalibrating the wrist camera when its mount has moved. The task machines themselves are
//! the `task` stage ([`crate::stages::task`]); this module holds what they plan with.
//!
//! | module | holds |
//! |---|---|
//! | [`site`] | the site map: working spot, wire prior, rack, calibration target, obstacles |
//! | [`survey`] | the crew's survey (`survey.*` keys, a site file) -> the site map |
//! | [`poses`] | the flows' poses: hook goal, level look, grasp, hung rod from its handle |
//! | [`calibration_views`] | wrist views of the calibration target (drift check, recalibration) |
//! | [`safety`] | the wind gate (anemometer with its documented error) |
//! | [`lighting`] | when to light the scene with the wrist light (lux meter, hysteresis) |

pub mod calibration_views;
pub mod lighting;
pub mod poses;
pub mod safety;
pub mod site;
pub mod survey;
