//! What a replay of a recording runs: the recorded scenario with the user's changes,
//! composed with today's stages, and which recorded producers were stages.
//!
//! The recorded parameters are migrated ([`crate::load::MIGRATIONS`]) and *tolerated*: a key
//! this version no longer knows does not stop the replay, it is reported
//! ([`ReplaySetup::unknown_recorded`]) and `replay --check` counts it as a divergence. A key
//! the user sets (`--config`, `--set`) is checked strictly, like on `record`.

use std::collections::BTreeSet;
use std::path::Path;

use replay::McapReader;
use scenario::{KeyProblem, Params, Scenario};

use crate::error::ComposeError;
use crate::load::{Migrated, scenario_of_recording};
use crate::plan::{PIPELINE_RECORD, Plan, WorldKind};

/// Producers of a recording that are never stages: the drivers of each world, the
/// scheduler's `/clock` and the live runtime.
pub fn world_producers(kind: WorldKind) -> &'static [&'static str] {
    match kind {
        WorldKind::Sim => &[
            sim::arm::ARM_DRIVER,
            sim::lift::LIFT_DRIVER,
            sim::base::BASE_DRIVER,
            sim::clamp::CLAMP_DRIVER,
            sim::cameras::CAMERA_DRIVER,
            sim::cameras::PANORAMIC_DRIVER,
            sim::environment::ANEMOMETER,
            sim::environment::LUX_METER,
            sim::truth::SIM,
            recorder::scheduler::SCHEDULER,
            recorder::live::RUNTIME,
        ],
        WorldKind::Test => &[
            recorder::test_world::ARM_DRIVER,
            recorder::test_world::LIFT_DRIVER,
            recorder::test_world::ANEMOMETER,
            recorder::scheduler::SCHEDULER,
            recorder::live::RUNTIME,
        ],
        WorldKind::Ros2 => &[crate::ros2::record::GRAPH_PRODUCER, recorder::live::RUNTIME],
    }
}

/// A replay's composition (module docs).
#[derive(Debug, Clone)]
pub struct ReplaySetup {
    /// The plan today's stages come from.
    pub plan: Plan,
    /// The parameters as recorded (after migration).
    pub recorded: Params,
    /// Migrations applied to the recorded parameters.
    pub migrated: Vec<Migrated>,
    /// The producers that were stages when the file was recorded.
    pub recorded_stages: BTreeSet<String>,
}

impl ReplaySetup {
    /// The setup of replaying `path` with `config` (a parameter file's parameters) and
    /// `sets` (`--set k=v`) on top of the recorded parameters.
    ///
    /// # Errors
    /// An unreadable recording or one without a scenario; a user key that is mistyped or
    /// that no part consumes.
    pub fn new(
        path: &Path,
        config: Option<&Params>,
        sets: &[String],
    ) -> Result<Self, ComposeError> {
        let (mut scenario, migrated): (Scenario, Vec<Migrated>) = scenario_of_recording(path)?;
        let recorded = scenario.params.clone();
        if let Some(c) = config {
            scenario.params.merge(c);
        }
        for s in sets {
            scenario.set_from_arg(s)?;
        }
        // A recorded key is tolerated unless the user set it again.
        let user: BTreeSet<String> = scenario
            .params
            .changed_keys(&recorded)
            .into_iter()
            .collect();
        let tolerated: BTreeSet<String> = recorded
            .keys()
            .filter(|k| !user.contains(*k))
            .map(str::to_owned)
            .collect();
        let plan = Plan::tolerating(&scenario, &tolerated)?;
        let reader = McapReader::open(path).map_err(|source| ComposeError::Read {
            path: path.to_path_buf(),
            source: Box::new(source),
        })?;
        let recorded_stages = match reader.metadata_named(PIPELINE_RECORD) {
            Some(m) => m
                .entries
                .get("stages")
                .map(|s| {
                    s.split(',')
                        .filter(|n| !n.is_empty())
                        .map(str::to_owned)
                        .collect()
                })
                .unwrap_or_default(),
            // Recordings made before the `pipeline` record: every producer that is not one of
            // the world's drivers was a stage.
            None => {
                let drivers = world_producers(plan.world_kind());
                reader
                    .channels()
                    .values()
                    .filter_map(|c| c.producer())
                    .filter(|p| !drivers.contains(p))
                    .map(str::to_owned)
                    .collect()
            }
        };
        Ok(Self {
            plan,
            recorded,
            migrated,
            recorded_stages,
        })
    }

    /// Recorded keys no part of today's pipeline consumes (neither known nor migrated): the
    /// replay runs without them, and cannot claim to reproduce the recording.
    #[must_use]
    pub fn unknown_recorded(&self) -> &[KeyProblem] {
        self.plan.unconsumed_tolerated()
    }

    /// The parameters changed against the recording, as `key=value` (or `key (removed)`).
    #[must_use]
    pub fn changed_parameters(&self) -> Vec<String> {
        let now = &self.plan.scenario().params;
        now.changed_keys(&self.recorded)
            .into_iter()
            .map(|k| match now.get(&k) {
                Some(v) => format!("{k}={v}"),
                None => format!("{k} (removed)"),
            })
            .collect()
    }
}
