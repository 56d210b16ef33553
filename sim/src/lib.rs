//! Deterministic substation world implementing the driver traits of `msgs` (the default robot).
//!
//! | module | what |
//! |---|---|
//! | [`scene`], [`render`] | the substation geometry and the RGB-D renderer |
//! | [`world`] | [`SimWorld`]: the robot and its environment behind [`msgs::World`] |
//! | [`config`] | [`SimConfig`], the simulator's keys of a scenario |
//! | [`arm`], [`lift`], [`base`], [`clamp`], [`cameras`], [`environment`] | the simulated drivers (they implement the `msgs` driver traits) |
//! | [`motion`] | speed/acceleration-limited axis tracking |
//! | [`bump`], [`rod`], [`truth`] | camera-mount bump, grounding-rod tolerances and states, `/sim/...` truth |
//! | [`rng`] | counter-based randomness (seed, stream, index) |
//! | [`survey`] | the simulated crew's survey of the bay: a site file with a survey's error |
//!
//! # The driver seam
//! The traits of [`msgs::drivers`] are where a real driver plugs in: an AUBO controller SDK
//! behind [`msgs::ArmDriver`] (joint trajectories in; joint states at 100 Hz, rad), a lift and
//! a base controller ([`msgs::LiftDriver`] m, [`msgs::BaseDriver`] goals in `map`, odometry at
//! 50 Hz), the end effector's motor controller ([`msgs::ClampDriver`], lead-screw travel m,
//! torque N m), a Mech-Eye API behind [`msgs::CameraDriver`] (capture on request, ~1 s,
//! colour + registered depth stamped at exposure), an anemometer and a lux meter
//! ([`msgs::EnvironmentSensors`], 1 Hz, m/s 3-s mean and lx). Every call takes the robot-clock
//! time; a device refuses with `Busy`/`Rejected` (with the reason), reports `Fault` with the
//! vendor's text, and never blocks. The simulator's drivers document their rates, stamps,
//! units, noise and errors in their modules; [`SimWorld`] is the [`msgs::World`] the
//! scheduler steps in lockstep.
pub mod arm;
pub mod base;
pub mod bump;
pub mod cameras;
pub mod clamp;
pub mod config;
pub mod environment;
pub mod lift;
pub mod motion;
pub mod render;
pub mod rng;
pub mod rod;
pub mod scene;
pub mod survey;
pub mod truth;
pub mod world;
pub mod wrist_light;

pub use config::{SimConfig, SiteLayout};
pub use world::SimWorld;

/// Errors of the simulator.
#[derive(Debug, PartialEq, thiserror::Error)]
pub enum SimError {
    /// A configuration value the simulator cannot use (a duration beyond the robot clock).
    #[error("{key}: {reason}")]
    Config {
        /// Dotted key.
        key: String,
        /// What is wrong.
        reason: String,
    },
    /// The substation could not be built.
    #[error(transparent)]
    Scene(#[from] scene::substation::SubstationError),
    /// A scene object could not be moved.
    #[error(transparent)]
    SceneObject(#[from] scene::SceneError),
    /// Rendering failed.
    #[error(transparent)]
    Render(#[from] render::RenderError),
    /// An invalid camera.
    #[error(transparent)]
    Camera(#[from] render::CameraError),
    /// A driver failed or time went backwards.
    #[error(transparent)]
    Driver(#[from] msgs::DriverError),
    /// The scenario asks for something the bay's layout cannot give.
    #[error("layout: {reason}")]
    Layout {
        /// What is missing.
        reason: String,
    },
}
