//! rodlog's composition root: which stages, in which world, from which parameters.
//!
//! Record, replay, the demo, the experiments and the tests all build a run the same way:
//!
//! 1. [`load`]: a scenario by name, file or recording ([`load_scenario`]), with the key
//!    [`load::MIGRATIONS`] that keep old recordings replayable;
//! 2. [`plan`]: [`Plan::new`] reads every stage and world config strictly (a key no built
//!    part consumes is an error naming it), then gives the pipeline ([`Plan::pipeline`]), the
//!    world ([`Plan::world`]), the recording header and the task's end;
//! 3. [`record`]: a plan recorded to MCAP, with extra sinks; [`replaying`]: a recording's
//!    plan for replay, its recorded parameters tolerated and its recorded stages named;
//! 4. [`judge`]: a simulated run judged against the simulator's truth (not a stage: it reads
//!    `/sim/*`, which no stage may).
//!
//! [`data`] says where the public datasets are. [`world`] holds the [`World`] behind which the
//! simulator, the test world and the ROS 2 graph stand; [`ros2`] runs the pipeline live on a
//! graph (`record --ros2`) and the simulator as a ROS 2 node (`sim --ros2`). The binary keeps
//! only flags, progress and printing.

pub mod data;
pub mod error;
pub mod judge;
pub mod load;
pub mod plan;
pub mod replaying;
pub mod ros2;
pub mod world;

pub use error::ComposeError;
pub use load::{Migrated, load_scenario, scenario_of_recording};
pub use plan::{Plan, WorldKind};
pub use replaying::ReplaySetup;
pub use world::World;

/// Records `plan` (its world and pipeline) to `options.out`, with `extra_sinks` beside the
/// MCAP writer: what `rodlog record` does, and the demo's and the experiments' runs. A plan
/// on a ROS 2 graph records through [`ros2::record::record`] instead (it runs live and
/// returns its own summary).
///
/// # Errors
/// Pipeline, world and recording errors; [`ComposeError::WrongWorld`] for a ROS 2 plan.
pub fn record(
    plan: &Plan,
    options: &recorder::RecordOptions,
    extra_sinks: Vec<Box<dyn recorder::Sink>>,
) -> Result<recorder::RecordSummary, ComposeError> {
    if plan.world_kind() == WorldKind::Ros2 {
        return Err(ComposeError::WrongWorld {
            wanted: "sim or test_world (record a ros2 plan with compose::ros2::record::record)",
            world: WorldKind::Ros2.name().to_owned(),
        });
    }
    let stages = plan.pipeline()?;
    let header = plan.header()?;
    Ok(recorder::record_with_sinks(
        plan.world()?,
        stages,
        &header,
        plan.scenario().duration,
        options,
        extra_sinks,
    )?)
}
