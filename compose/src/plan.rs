//! [`Plan`]: a scenario turned into the stages and the world of a run, with every
//! parameter read strictly.
//!
//! [`Plan::new`] reads every config a scenario can reach through one
//! [`scenario::Reader`], in parts:
//!
//! | part | keys | built when |
//! |---|---|---|
//! | composition | `world`, `task`, `perceive.enabled` | always |
//! | robot_state stage | `robot_state.*` | always |
//! | simulator | `hour`, `wind.*`, `bump.*`, `robot.*`, `camera.*`, `panoramic.*` | `world = "sim"` |
//! | ROS 2 graph | `ros2.*` | `world = "ros2"` |
//! | calibration stage | `calibration.*` | `world = "sim"`, or `"ros2"` with `ros2.pipeline = "full"` |
//! | perceive stage | `perceive.*` | as calibration, and `perceive.enabled = true` |
//! | task stage | `task.*` | as calibration, and `task` = `hang`, `remove`, `check` or `demo` |
//! | test world | `test_world.*` | `world = "test_world"` |
//! | arm_exerciser, joint_limit_monitor stages | their own prefix | `world = "test_world"` |
//!
//! and refuses any key that no built part consumes ([`scenario::Reader::finish`]). One
//! exception: with `world = "ros2"` the simulator's keys are accepted and not used
//! ([`Plan::remote_keys`]): the same scenario file drives `rodlog sim --ros2` in another
//! process, which reads them. The same
//! plan gives record, replay, the demo, the experiments and the tests their stages
//! ([`Plan::pipeline`]), in the same order, from the same parameters; that is what makes a
//! replay reproduce a recording. [`Plan::world`] builds the world the stages run against.

use std::collections::BTreeSet;
use std::sync::Arc;

use calib::selfcal::{CalibrationStage, CalibrationStageConfig};
use control::script::ScriptStage;
use control::stages::perceive::{PerceiveConfig, PerceiveStage};
use control::stages::task::{TaskConfig, TaskKind, TaskStage};
use msgs::Stage;
use msgs::rodlog_msgs::TaskEvent;
use recorder::stages::{ArmExerciser, JointLimitMonitor};
use recorder::test_world::{TestWorld, TestWorldConfig};
use recorder::{MetadataRecord, RecordingHeader, StopCondition};
use robot::{RobotModel, RobotStateConfig, RobotStateStage};
use scenario::{CommandKind, Decl, KeyProblem, ParamError, Reader, Scenario};
use sim::{SimConfig, SimWorld};

use crate::error::ComposeError;
use crate::ros2::{Ros2Config, Ros2Pipeline, Ros2World};
use crate::world::World;

/// The key choosing the world.
pub const WORLD_KEY: &str = "world";
/// The key choosing the task.
pub const TASK_KEY: &str = "task";
/// Robot time a recording goes on after its task ended ([`Plan::task_end`]).
pub const TASK_END_GRACE: msgs::RobotDuration = msgs::RobotDuration::from_secs(5);
/// Name of the metadata record that lists the pipeline's stages.
pub const PIPELINE_RECORD: &str = "pipeline";
/// Name of the robot URDF attachment.
pub const URDF_ATTACHMENT: &str = "robot.urdf";

/// Which world a scenario runs in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WorldKind {
    /// The deterministic substation simulator (the default).
    Sim,
    /// The small test world of the recorder (`arm_sweep`).
    Test,
    /// A ROS 2 graph (`record --ros2`).
    Ros2,
}

impl WorldKind {
    /// The value of the `world` key.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Sim => "sim",
            Self::Test => "test_world",
            Self::Ros2 => "ros2",
        }
    }
}

/// The configured world.
#[derive(Debug, Clone)]
enum WorldConfig {
    Sim(Box<SimConfig>),
    Test(TestWorldConfig),
    Ros2 {
        config: Ros2Config,
        /// The simulator configuration the same keys give (`rodlog sim --ros2` reads them;
        /// the judge rebuilds its truth from them).
        remote_sim: Box<SimConfig>,
    },
}

/// The configured stages of each world.
#[derive(Debug, Clone)]
enum Stages {
    Sim {
        calibration: Box<CalibrationStageConfig>,
        perceive: Option<Box<PerceiveConfig>>,
        task: Option<Box<TaskConfig>>,
    },
    Test {
        exerciser: ArmExerciser,
        monitor: JointLimitMonitor,
    },
    /// `robot_state` only.
    RobotState,
}

/// A scenario's run, composed (module docs).
#[derive(Debug, Clone)]
pub struct Plan {
    scenario: Scenario,
    world: WorldConfig,
    task: String,
    robot_state: RobotStateConfig,
    stages: Stages,
    declarations: Vec<Decl>,
    tolerated: Vec<KeyProblem>,
    remote: Vec<String>,
}

const TASKS: [&str; 7] = [
    "none",
    "calibrate",
    "hang",
    "remove",
    "check",
    "demo",
    "self-calibrate",
];

impl Plan {
    /// Composes `scenario`, every key strictly checked.
    ///
    /// # Errors
    /// [`ComposeError::Param`] for a mistyped value or a key no built part consumes (naming
    /// the key and the nearest valid one).
    pub fn new(scenario: &Scenario) -> Result<Self, ComposeError> {
        Self::tolerating(scenario, &BTreeSet::new())
    }

    /// Composes `scenario`, accepting the keys of `tolerated` even when no built part
    /// consumes them: a replay tolerates keys it read from the recording (this version may
    /// no longer know them) and reports them ([`Plan::unconsumed_tolerated`]), while a key
    /// the user typed is still an error.
    ///
    /// # Errors
    /// As [`Plan::new`], for keys not in `tolerated`.
    pub fn tolerating(
        scenario: &Scenario,
        tolerated: &BTreeSet<String>,
    ) -> Result<Self, ComposeError> {
        let mut r = Reader::new(&scenario.params);
        r.part("composition");
        let world_name = r.section("").choice(
            WORLD_KEY,
            WorldKind::Sim.name(),
            &[
                WorldKind::Sim.name(),
                WorldKind::Test.name(),
                WorldKind::Ros2.name(),
            ],
            "the world the stages run against: the simulator, the recorder's test world, or a ROS 2 graph",
        )?;
        let kind = if world_name == WorldKind::Test.name() {
            WorldKind::Test
        } else if world_name == WorldKind::Ros2.name() {
            WorldKind::Ros2
        } else {
            WorldKind::Sim
        };
        let task = r.section("").choice(
            TASK_KEY,
            "none",
            &TASKS,
            "the task stage's job (none and calibrate run no task stage: calibrate follows the scenario's scripted views; self-calibrate plans its views from the site map)",
        )?;
        let perceive_enabled = r.section("perceive").bool(
            "enabled",
            false,
            "run the perceive stage (wire perception on its own, without a task)",
        )?;
        r.part("robot_state stage");
        let robot_state = RobotStateConfig::from_params(&mut r)?;

        let not_sim = format!("world = {:?}", kind.name());
        let not_test = not_sim.clone();
        if kind == WorldKind::Ros2 {
            r.part("ROS 2 graph");
        } else {
            r.inactive_part("ROS 2 graph", &not_sim);
        }
        let ros2 = Ros2Config::from_params(&mut r)?;
        let robot_software = match kind {
            WorldKind::Sim => true,
            WorldKind::Test => false,
            WorldKind::Ros2 => ros2.pipeline == Ros2Pipeline::Full,
        };
        let sim = {
            if kind == WorldKind::Sim {
                r.part("simulator");
            } else {
                r.inactive_part("simulator", &not_sim);
            }
            SimConfig::from_params(&mut r, scenario.seed, scenario.duration.as_secs_f64())?
        };
        let not_built = if kind == WorldKind::Ros2 {
            format!("ros2.pipeline = {:?}", ros2.pipeline.name())
        } else {
            not_sim.clone()
        };
        let sim_part = |r: &mut Reader<'_>, name: &str, why_not: Option<String>| {
            match (robot_software, why_not) {
                (true, None) => r.part(name),
                (true, Some(why)) => r.inactive_part(name, &why),
                (false, _) => r.inactive_part(name, &not_built),
            };
        };
        sim_part(&mut r, "calibration stage", None);
        let captures = scenario
            .commands
            .iter()
            .filter(|c| c.kind == CommandKind::Capture)
            .count();
        let calibration = CalibrationStageConfig::from_params(&mut r, captures)?;
        sim_part(
            &mut r,
            "perceive stage",
            (!perceive_enabled).then(|| "perceive.enabled = false".to_owned()),
        );
        let mut perceive = PerceiveConfig::from_params(&mut r)?;
        // The camera edge the calibration stage publishes from the start (nominal, or carried
        // from an earlier run) is also what perception and the task assume before its first
        // `/tf`.
        perceive.nominal_tool0_from_camera = calibration.nominal_tool0_from_camera;
        let task_kind = TaskKind::parse(&task);
        sim_part(
            &mut r,
            "task stage",
            task_kind.is_none().then(|| format!("task = {task:?}")),
        );
        let mut task_config = TaskConfig::from_params(&mut r, task_kind.unwrap_or(TaskKind::Hang))?;
        task_config.nominal_tool0_from_camera = calibration.nominal_tool0_from_camera;

        let test_part = |r: &mut Reader<'_>, name: &str| {
            if kind == WorldKind::Test {
                r.part(name);
            } else {
                r.inactive_part(name, &not_test);
            }
        };
        test_part(&mut r, "test world");
        let test = TestWorldConfig::from_params(scenario.seed, &mut r)?;
        test_part(&mut r, "arm_exerciser stage");
        let exerciser = ArmExerciser::from_params(&mut r)?;
        test_part(&mut r, "joint_limit_monitor stage");
        let monitor = JointLimitMonitor::from_params(&mut r)?;

        // On a ROS 2 graph the simulator, if any, is another process reading the same file.
        let (remote, problems): (Vec<KeyProblem>, Vec<KeyProblem>) =
            r.problems().into_iter().partition(|p| {
                kind == WorldKind::Ros2
                    && matches!(p, KeyProblem::Inactive { part, .. } if part == "simulator")
            });
        let remote: Vec<String> = remote.iter().map(|p| p.key().to_owned()).collect();
        let (problems, tolerated_problems): (Vec<KeyProblem>, Vec<KeyProblem>) = problems
            .into_iter()
            .partition(|p| !tolerated.contains(p.key()));
        if !problems.is_empty() {
            return Err(ParamError::Unused(problems).into());
        }
        let declarations = r.declarations().to_vec();
        let software = Stages::Sim {
            calibration: Box::new(calibration),
            perceive: perceive_enabled.then(|| Box::new(perceive)),
            task: task_kind.map(|_| Box::new(task_config)),
        };
        let (world, stages) = match kind {
            WorldKind::Sim => (WorldConfig::Sim(Box::new(sim)), software),
            WorldKind::Test => (WorldConfig::Test(test), Stages::Test { exerciser, monitor }),
            WorldKind::Ros2 => (
                WorldConfig::Ros2 {
                    config: ros2,
                    remote_sim: Box::new(sim),
                },
                if robot_software {
                    software
                } else {
                    Stages::RobotState
                },
            ),
        };
        Ok(Self {
            scenario: scenario.clone(),
            world,
            task,
            robot_state,
            stages,
            declarations,
            tolerated: tolerated_problems,
            remote,
        })
    }

    /// The scenario composed.
    #[must_use]
    pub fn scenario(&self) -> &Scenario {
        &self.scenario
    }

    /// The world's kind.
    #[must_use]
    pub fn world_kind(&self) -> WorldKind {
        match self.world {
            WorldConfig::Sim(_) => WorldKind::Sim,
            WorldConfig::Test(_) => WorldKind::Test,
            WorldConfig::Ros2 { .. } => WorldKind::Ros2,
        }
    }

    /// The simulator's configuration, for a simulator run.
    #[must_use]
    pub fn sim_config(&self) -> Option<&SimConfig> {
        match &self.world {
            WorldConfig::Sim(c) => Some(c),
            WorldConfig::Test(_) | WorldConfig::Ros2 { .. } => None,
        }
    }

    /// The simulator configuration of a run on a ROS 2 graph: what `rodlog sim --ros2` with
    /// the same scenario simulates (the judge rebuilds its truth from it). `None` in the other
    /// worlds.
    #[must_use]
    pub fn remote_sim_config(&self) -> Option<&SimConfig> {
        match &self.world {
            WorldConfig::Ros2 { remote_sim, .. } => Some(remote_sim),
            _ => None,
        }
    }

    /// The ROS 2 world's configuration, for a run on a graph.
    #[must_use]
    pub fn ros2_config(&self) -> Option<&Ros2Config> {
        match &self.world {
            WorldConfig::Ros2 { config, .. } => Some(config),
            _ => None,
        }
    }

    /// Keys the scenario sets that only the simulator reads, on a ROS 2 graph: accepted and not
    /// used by this process (`rodlog sim --ros2` with the same scenario uses them).
    #[must_use]
    pub fn remote_keys(&self) -> &[String] {
        &self.remote
    }

    /// The `task` key's value.
    #[must_use]
    pub fn task(&self) -> &str {
        &self.task
    }

    /// Every key any part declared (what `rodlog params` lists), in declaration order.
    #[must_use]
    pub fn declarations(&self) -> &[Decl] {
        &self.declarations
    }

    /// Tolerated keys ([`Plan::tolerating`]) that no built part consumed.
    #[must_use]
    pub fn unconsumed_tolerated(&self) -> &[KeyProblem] {
        &self.tolerated
    }

    /// The stages, in rank order: the simulator's (and a full ROS 2 pipeline's)
    /// `robot_state`, `script`, `calibration`, then `perceive` and `task` when enabled; the
    /// test world's `robot_state`, `arm_exerciser`, `joint_limit_monitor`; `robot_state`
    /// alone on a ROS 2 graph with `ros2.pipeline = "robot_state"`.
    ///
    /// # Errors
    /// A stage's own validation (a script command beyond the robot clock, an unreachable
    /// configuration).
    pub fn pipeline(&self) -> Result<Vec<Box<dyn Stage + Send>>, ComposeError> {
        let robot_state = RobotStateStage::new(RobotModel::nominal(), self.robot_state.clone());
        let mut stages: Vec<Box<dyn Stage + Send>> = vec![Box::new(robot_state)];
        match &self.stages {
            Stages::Sim {
                calibration,
                perceive,
                task,
            } => {
                stages.push(Box::new(ScriptStage::from_commands(
                    &self.scenario.commands,
                )?));
                stages.push(Box::new(CalibrationStage::new((**calibration).clone())));
                if let Some(p) = perceive {
                    stages.push(Box::new(PerceiveStage::new((**p).clone())?));
                }
                if let Some(t) = task {
                    stages.push(Box::new(TaskStage::new((**t).clone())?));
                }
            }
            Stages::Test { exerciser, monitor } => {
                stages.push(Box::new(exerciser.clone()));
                stages.push(Box::new(monitor.clone()));
            }
            Stages::RobotState => {}
        }
        Ok(stages)
    }

    /// The world the stages run against.
    ///
    /// # Errors
    /// The simulator's errors (its scene, a bay that cannot give what the scenario asks); the
    /// ROS 2 world's remap files.
    pub fn world(&self) -> Result<World, ComposeError> {
        Ok(match &self.world {
            WorldConfig::Sim(c) => World::Sim(Box::new(SimWorld::new(c)?)),
            WorldConfig::Test(c) => World::Test(Box::new(TestWorld::new(c.clone()))),
            WorldConfig::Ros2 { config, .. } => World::Ros2(Box::new(Ros2World::new(config)?)),
        })
    }

    /// The end of the scenario's task as a [`StopCondition`]: the task stage's final
    /// `/task/event` (a refusal or failure of any phase; DONE of the last phase, `remove`
    /// for the demo). `None` without a task.
    #[must_use]
    pub fn task_end(&self) -> Option<StopCondition> {
        let last_phase = match self.task.as_str() {
            "hang" | "remove" | "check" => self.task.clone(),
            "demo" => "remove".to_owned(),
            _ => return None,
        };
        Some(StopCondition {
            topic: msgs::topics::TASK_EVENT.to_owned(),
            is_end: Arc::new(move |m: &msgs::Msg| {
                m.get::<TaskEvent>().is_some_and(|e| {
                    e.task != "calibration"
                        && (e.kind == TaskEvent::REFUSED
                            || e.kind == TaskEvent::FAILED
                            || (e.kind == TaskEvent::DONE && e.task == last_phase))
                })
            }),
            grace: TASK_END_GRACE,
        })
    }

    /// The header of a recording of this plan: `robot_info`, `scenario` (seed, duration,
    /// every parameter), `build`, `pipeline` (the stages, so a replay can tell stage
    /// outputs from inputs), and the scenario file and the URDF as attachments.
    ///
    /// # Errors
    /// A stage that cannot be built (the pipeline is built to name its stages).
    pub fn header(&self) -> Result<RecordingHeader, ComposeError> {
        let robot_info = MetadataRecord::new("robot_info")
            .with("robot", "AUBO i10 arm + lift + mobile base")
            .with("model", "nominal DH (robot::aubo_i10)")
            .with("world", self.world_kind().name())
            .with("joints", msgs::frames::JOINT_NAMES.join(","));
        let mut scenario_rec = MetadataRecord::new(scenario::SCENARIO_RECORD);
        scenario_rec.entries = self.scenario.metadata_entries();
        let build = MetadataRecord::new("build")
            .with("rodlog_version", env!("CARGO_PKG_VERSION"))
            .with("library", recorder::library_string())
            .with(
                "git_commit",
                option_env!("RODLOG_GIT_COMMIT").unwrap_or("unknown"),
            );
        let names: Vec<String> = self
            .pipeline()?
            .iter()
            .map(|s| s.name().to_owned())
            .collect();
        let pipeline = MetadataRecord::new(PIPELINE_RECORD).with("stages", names.join(","));
        Ok(RecordingHeader {
            metadata: vec![robot_info, scenario_rec, build, pipeline],
            attachments: vec![
                (
                    scenario::SCENARIO_ATTACHMENT.to_owned(),
                    "application/toml".to_owned(),
                    self.scenario.source_text.clone().into_bytes(),
                ),
                (
                    URDF_ATTACHMENT.to_owned(),
                    "application/xml".to_owned(),
                    robot::robot_urdf(&RobotModel::nominal()).into_bytes(),
                ),
            ],
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plan_of(name: &str, sets: &[&str]) -> Result<Plan, ComposeError> {
        let mut s = Scenario::find(name)?;
        for set in sets {
            s.set_from_arg(set)?;
        }
        Plan::new(&s)
    }

    #[test]
    fn every_committed_scenario_composes() -> Result<(), ComposeError> {
        for name in [
            "arm_sweep",
            "calib-18",
            "demo",
            "hang",
            "hang-dusk",
            "hang-dusk-lit",
            "hang-windy",
            "op-5min",
            "perceive-wire",
            "remove",
            "sim-smoke",
        ] {
            let plan = plan_of(name, &[])?;
            assert!(plan.pipeline()?.len() >= 3, "{name}");
        }
        Ok(())
    }

    #[test]
    fn on_a_ros2_graph_the_stages_are_the_robots_and_simulator_keys_are_remote()
    -> Result<(), ComposeError> {
        let names = |p: &Plan| -> Result<Vec<String>, ComposeError> {
            Ok(p.pipeline()?.iter().map(|s| s.name().to_owned()).collect())
        };
        let plan = plan_of("hang", &["world=\"ros2\""])?;
        assert_eq!(plan.world_kind(), WorldKind::Ros2);
        assert_eq!(
            names(&plan)?,
            ["robot_state", "script", "calibration", "task"]
        );
        assert!(
            plan.remote_keys().iter().any(|k| k == "hour"),
            "{:?}",
            plan.remote_keys()
        );
        assert!(plan.remote_sim_config().is_some() && plan.sim_config().is_none());
        let plan = plan_of("ros2", &[])?;
        assert_eq!(names(&plan)?, ["robot_state"]);
        let err = plan_of("ros2", &["task.standoff_m=0.5"])
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(err.contains("ros2.pipeline"), "{err}");
        let err = plan_of("hang", &["world=\"ros2\"", "hours=3"])
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(err.contains("hours"), "{err}");
        let err = plan_of("hang", &["ros2.domain_id=3"])
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(err.contains("ROS 2 graph"), "{err}");
        Ok(())
    }

    #[test]
    fn stage_lists_follow_the_world_and_the_task() -> Result<(), ComposeError> {
        let names = |p: &Plan| -> Result<Vec<String>, ComposeError> {
            Ok(p.pipeline()?.iter().map(|s| s.name().to_owned()).collect())
        };
        assert_eq!(
            names(&plan_of("hang", &[])?)?,
            ["robot_state", "script", "calibration", "task"]
        );
        assert_eq!(
            names(&plan_of("perceive-wire", &[])?)?,
            ["robot_state", "script", "calibration", "perceive"]
        );
        assert_eq!(
            names(&plan_of("arm_sweep", &[])?)?,
            ["robot_state", "arm_exerciser", "joint_limit_monitor"]
        );
        Ok(())
    }

    #[test]
    fn a_typo_is_an_error_naming_the_key_and_the_nearest() {
        let err = plan_of("hang", &["task.standof_m=0.5"])
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(
            err.contains("task.standof_m") && err.contains("did you mean \"task.standoff_m\""),
            "{err}"
        );
    }

    #[test]
    fn keys_of_parts_not_built_say_why() {
        let err = plan_of("calib-18", &["task.standoff_m=0.5"])
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(
            err.contains("task stage") && err.contains("task = \"calibrate\""),
            "{err}"
        );
        let err = plan_of("arm_sweep", &["camera.scale=0.5"])
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(
            err.contains("simulator") && err.contains("test_world"),
            "{err}"
        );
    }

    #[test]
    fn tolerated_keys_are_reported_not_refused() -> Result<(), ComposeError> {
        let mut s = Scenario::find("hang")?;
        s.set_from_arg("task.retired_knob=3")?;
        let tolerated: BTreeSet<String> = ["task.retired_knob".to_owned()].into();
        let plan = Plan::tolerating(&s, &tolerated)?;
        assert_eq!(plan.unconsumed_tolerated().len(), 1);
        assert!(Plan::new(&s).is_err());
        Ok(())
    }

    #[test]
    fn declarations_cover_every_part_with_units() -> Result<(), ComposeError> {
        let plan = plan_of("hang", &[])?;
        let keys: Vec<&str> = plan.declarations().iter().map(|d| d.key.as_str()).collect();
        for key in [
            "world",
            "task",
            "hour",
            "wind.mean_mps",
            "camera.scale",
            "calibration.captures",
            "task.standoff_m",
            "test_world.lift_m",
        ] {
            assert!(keys.contains(&key), "{key} missing from {keys:?}");
        }
        let standoff = plan
            .declarations()
            .iter()
            .find(|d| d.key == "task.standoff_m");
        assert_eq!(standoff.map(|d| d.unit), Some("m"));
        Ok(())
    }

    #[test]
    fn the_header_names_the_stages() -> Result<(), ComposeError> {
        let header = plan_of("hang", &[])?.header()?;
        let pipeline = header.metadata.iter().find(|m| m.name == PIPELINE_RECORD);
        assert_eq!(
            pipeline
                .and_then(|m| m.entries.get("stages"))
                .map(String::as_str),
            Some("robot_state,script,calibration,task")
        );
        Ok(())
    }
}
