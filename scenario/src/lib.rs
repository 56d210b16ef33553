//! Scenario files and strict parameters: what a run is made of, and the one way every stage
//! and world config reads its keys.
//!
//! - [`params`]: [`Params`], dotted keys (`task.standoff_m`) to TOML values, and their
//!   round trip through a recording's `scenario` metadata record.
//! - [`reader`]: [`Reader`], through which each config's `from_params` declares and consumes
//!   its keys (default, unit, doc); afterwards [`Reader::finish`] turns every key that no part
//!   consumed into an error that names it and suggests the nearest valid one.
//! - [`command`]: the scenario's timed `[[command]]` list ([`Command`]).
//! - [`file`]: [`Scenario`], the file format (`recordings/scenarios/NAME.toml`), the one
//!   scenario finder, and the `scenario` metadata record.
//!
//! The composition root (crate `compose`) builds the pipeline and the world from a
//! [`Scenario`]; this crate only knows the format, so the stage crates and the simulator can
//! build their configs from it without depending on each other.

pub mod command;
pub mod error;
pub mod file;
pub mod params;
pub mod reader;

pub use command::{Command, CommandKind};
pub use error::{KeyProblem, ParamError, ScenarioError};
pub use file::{PARAM_PREFIX, SCENARIO_ATTACHMENT, SCENARIO_RECORD, Scenario};
pub use params::Params;
pub use reader::{Decl, Reader, Section};
