//! The `task` stage: the hang and remove task machines over the message stream, with their
//! safety gates and the self-maintenance of the hand-eye calibration.
//!
//! # Flows
//! A task is a list of steps ([`flow`]: one table per task kind); each step, when it
//! starts, plans its motions from what the robot has measured so far (joint states,
//! odometry, the camera edge on `/tf`, perception results) and queues *actions* (a command
//! and the condition that completes it). The next step starts when the queue is empty and
//! the step's result is accepted.
//!
//! | hang | remove |
//! |---|---|
//! | drive to the working spot, stow the arm | same |
//! | check the calibration (drift check views), recalibrate on drift | same |
//! | grasp the rod on the rack, lift it out, carry it upright | raise to the handle, look at it, capture, fit it |
//! | raise the lift, panoramic fix of the wire, look level with it, capture 3x, fit the wire | pre-grasp, approach, grasp (the clamp joint reads the rod's jaw: coupled) |
//! | lower to the hook height behind the wire, approach across it | open the clamp (the wire is free in the hook) |
//! | close the clamp: stops at the wire contact = clamped, runs to full travel = missed (retry) | unhook (back across the wire), lower |
//! | release (back off), stow, lower | put the rod in the rack, release, stow |
//!
//! The rod stays upright throughout ([`crate::tasks::poses`]): captures are level with their
//! target and the hook reaches the wire by lowering the lift and a horizontal approach.
//!
//! # Safety
//! * **Wind** ([`WindGate`](crate::tasks::safety::WindGate)): checked before every command;
//!   a closed gate, at the start or during the task, holds (no command) and refuses
//!   (`wind_above_limit`) after [`WindGateParams::hold_timeout`](crate::tasks::safety::WindGateParams::hold_timeout),
//!   or when the operation's holds add up to [`WindGateParams::hold_budget`](crate::tasks::safety::WindGateParams::hold_budget).
//! * **Perception**: a wire or handle estimate below its confidence threshold refuses
//!   (`low_confidence`), after one more look when the first was refused.
//! * **Motion**: every arm plan is IK within the joint limits, within speed and acceleration
//!   limits ([`crate::motion::trajectory`]) and collision-checked (arm, held rod, robot body,
//!   the site's obstacles and conductors,
//!   [`SiteMap::collision_world`](crate::tasks::site::SiteMap::collision_world)); every lift
//!   move is checked at 5 cm steps. An unplannable motion refuses (`unreachable`,
//!   `collision`): no unsafe command is ever issued.
//! * **Calibration**: with self-maintenance on, the task does not operate on a calibration it
//!   could not verify (`calibration_unverifiable`, e.g. too dark for features) or repair
//!   (`calibration_failed`).
//!
//! # Self-maintenance
//! Before operating, the stage asks the calibration stage for a drift check
//! (`/calibration/command` `check`, calib's [`calib::selfcal::CHECK_MOTION`] views of the site's
//! calibration target, `solve`) and waits for its verdict on `/task/event` (task
//! `calibration`, state `check`, reason `consistent` / `drifted` / `cannot_tell`). On drift,
//! and when the check cannot tell (it could miss a bump that matters), it runs the 18-view
//! calibration motion (`collect`, views, `solve`) and continues when the calibration stage
//! reports `accepted`; the new camera edge arrives on `/tf` and every later plan uses it. A
//! check that cannot tell followed by a recalibration that is not accepted refuses
//! (`calibration_unverifiable`).
//!
//! # The wrist light
//! On a robot with a wrist light (its driver publishes `/wrist_light/state`), the stage lights
//! the scene while an operation runs and the lux meter reads low
//! ([`crate::tasks::lighting`]), announces it on `/task/event` (reason `wrist_light`), and
//! switches it off at the end. The light is not motion: it is commanded whatever the wind.
//!
//! # Outputs
//! Commands (`/arm/joint_trajectory` with `/arm/planned_path`, `/lift/command`,
//! `/base/goal`, `/clamp/command`, `/camera/trigger`, `/wrist_light/command`),
//! `/calibration/command`,
//! `/perception/roi_cloud` and `/perception/target_pose`, and every step change on
//! `/task/event` (task `hang` or `remove`) and `/rosout`. Outputs are stamped
//! `trigger log_time + latency`; timeouts come from `/clock`. No clock, no randomness but the
//! perception's seeded RANSAC: a replay reproduces the stage byte for byte.
//!
//! # Layout
//! | module | holds |
//! |---|---|
//! | this file | [`TaskStage`]: the message dispatch and the driver (enter a step, issue its actions behind the wind gate, time out, judge, move on) |
//! | `config` | [`TaskKind`], [`TaskConfig`] and its scenario keys |
//! | `inputs` | the robot state the stage tracks from its inputs (joints, odometry, cameras, wind) |
//! | `outputs` | stamps, `/task/event` with its `/rosout` line, command re-stamping |
//! | `action` | actions: the command, what completes it, its timeout |
//! | `memory` | what the task has measured and decided (rod, captures, goals, answers) |
//! | `planning` | motions: IK goals, checked plans and detours, straight lines, lift checks, collision worlds, look poses |
//! | `judging` | verdicts: calibration answers, the panoramic fix, the wire estimate, handle fits, clamp contact, grasp coupling |
//! | `flow` | what a step is (`StepDef`: name, plan, finish), where it leads (`Next`), and the table of steps of each task kind |
//! | `steps` | one module per step |
//! | `tests` | message-level tests: a rig that answers the commands; one test per step and per refusal |
//!
//! The wire's perception (panoramic fix, look pose, captures, hanging point) is the
//! [`crate::stages::wire_flow`] component that the `perceive` stage drives too.
//!
//! # Adding a step
//! Write `steps/<name>.rs` with its `NAME` and a `STEP: StepDef` (the event name, `plan`
//! queueing actions from `action`'s constructors, `finish` returning where the flow goes
//! next, or `flow::next_in_flow` when the step has no verdict), declare it in `steps/mod.rs`,
//! and put it in its task's table in `flow` (`PREPARE`, `HANG`, `REMOVE`, `CHECK`). A test
//! beside the others in `tests/steps.rs` drives it through the rig.

mod action;
mod config;
mod flow;
mod inputs;
mod judging;
mod memory;
mod outputs;
mod planning;
mod steps;
#[cfg(test)]
mod tests;

use msgs::geometry_msgs::PoseStamped;
use msgs::nav_msgs::Path;
use msgs::rcl_interfaces::Log;
use msgs::rodlog_msgs::{ClampCommand, TaskEvent};
use msgs::sensor_msgs::{Image, PointCloud2};
use msgs::std_msgs::{Empty, Float64, String as StringMsg};
use msgs::topics::{
    ARM_JOINT_TRAJECTORY, ARM_PLANNED_PATH, BASE_GOAL, CALIBRATION_COMMAND, CAMERA_COLOR_IMAGE,
    CAMERA_COLOR_INFO, CAMERA_DEPTH_IMAGE, CAMERA_TRIGGER, CLAMP_COMMAND, CLOCK, ENV_ILLUMINANCE,
    ENV_WIND, JOINT_STATES, LIFT_COMMAND, PANORAMIC_IMAGE, PANORAMIC_INFO, PERCEPTION_ROI_CLOUD,
    PERCEPTION_TARGET_POSE, ROSOUT, TASK_EVENT, TF, TF_STATIC, WRIST_LIGHT_COMMAND,
    WRIST_LIGHT_STATE,
};
use msgs::trajectory_msgs::JointTrajectory;
use msgs::{Msg, RobotDuration, RobotTime, RosMessage, Stage, StageError};
use robot::IkSettings;

use self::action::{Running, Until};
use self::flow::{Flow, Next};
use self::inputs::RobotState;
use self::memory::Memory;
use self::outputs::Outbox;
use self::planning::Arm;
use crate::motion::collision::ArmCollisionModel;
use crate::perception::point_cloud::DepthImage;
use crate::stages::wire_flow::{WireFlow, WristCapture, time_ns};
use crate::tasks::lighting;

pub use self::action::{
    ARRIVED_RAD, AT_REST_RAD_S, BASE_ARRIVED_M, BASE_ARRIVED_RAD, BASE_STILL_FOR, BASE_STILL_M,
    BASE_STILL_RAD, CLAMP_REST_FOR, CLAMP_REST_M_S, LIFT_ARRIVED_M,
};
pub use self::config::{TaskConfig, TaskKind};
pub use self::flow::Stop;
pub use self::judging::{
    CLAMP_CONTACT_TOLERANCE_M, MAX_SWAY_HOLDS, RACK_AXIS_TOLERANCE_RAD, SWAY_HOLD_S,
};
pub use self::planning::{
    CHECK_LOOK_ABOVE_M, COMFORT_HEIGHT_M, DETOUR_LINE_STEP_M, DETOUR_RISE_M, LIFT_CHECK_STEP_M,
    RACK_LOOK_ELEVATIONS_DEG,
};

/// Stage name (channel metadata `producer=task`).
pub const STAGE_NAME: &str = "task";
/// Task name of the calibration stage's answers on `/task/event`.
pub const CALIBRATION_TASK: &str = "calibration";
/// The `file` of the stage's `/rosout` lines: this file, the stage's root module.
const LOG_FILE: &str = file!();

/// What the steps work on: the configuration, the robot as measured, the arm's planning
/// models, what the task knows, the wire-perception flow and the outputs being gathered.
#[derive(Debug)]
pub(crate) struct Task {
    /// The configuration.
    pub config: TaskConfig,
    /// The robot as its inputs report it.
    pub robot: RobotState,
    /// The arm's IK and collision model.
    pub arm: Arm,
    /// What the task has measured and decided.
    pub memory: Memory,
    /// The wire's perception (the hang).
    pub wire: WireFlow,
    /// Outputs of the message being handled.
    pub out: Outbox,
}

impl Task {
    /// Appends a `/task/event` (and its `/rosout` line) of the current operation.
    pub fn event(&mut self, kind: u8, state: &str, reason_code: &str, text: String) {
        self.out
            .event(self.robot.now, kind, state, reason_code, text);
    }
}

/// Where the driver is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum At {
    /// Before `start_at`.
    Waiting,
    /// At entry `k` of the flow.
    Step(usize),
    /// Recovering after a miss of the step at entry `k`.
    Recover(usize),
    /// Ended (done, refused or failed).
    Finished,
}

/// The `task` stage (module docs).
#[derive(Debug)]
pub struct TaskStage {
    task: Task,
    flow: Flow,
    at: At,
    queue: Vec<action::Action>,
    running: Option<Running>,
    holding_since: Option<RobotTime>,
    /// Since when the gate has been open again within a hold that waits for the wire's swing
    /// to settle ([`WindGateParams::settle_on_wire`](crate::tasks::safety::WindGateParams::settle_on_wire)).
    settling_since: Option<RobotTime>,
    /// Time spent in finished wind holds this operation.
    held_for_wind: RobotDuration,
    began: Option<RobotTime>,
}

impl TaskStage {
    /// A stage with `config`.
    ///
    /// # Errors
    /// [`StageError::Failed`] when the model's IK cannot be built.
    pub fn new(config: TaskConfig) -> Result<Self, StageError> {
        let ik = config
            .model
            .arm_ik(IkSettings::default())
            .map_err(|e| StageError::Failed {
                stage: STAGE_NAME.to_owned(),
                log_time: RobotTime::ZERO,
                reason: e.to_string(),
            })?;
        let collision = ArmCollisionModel {
            model: config.model.clone(),
            ..ArmCollisionModel::nominal()
        };
        let flow = Flow::of(config.kind);
        let phase = flow.phase_at(0).unwrap_or(config.kind);
        Ok(Self {
            task: Task {
                robot: RobotState::new(&config),
                arm: Arm { ik, collision },
                memory: Memory::new(config.kind),
                wire: WireFlow::new(config.wire_flow_params()),
                out: Outbox::new(config.latency, phase),
                config,
            },
            flow,
            at: At::Waiting,
            queue: Vec::new(),
            running: None,
            holding_since: None,
            settling_since: None,
            held_for_wind: RobotDuration::ZERO,
            began: None,
        })
    }

    /// The `/task/event` state name of the current step (`waiting` before the start,
    /// `finished` at the end).
    #[must_use]
    pub fn step(&self) -> &'static str {
        match self.at {
            At::Waiting => "waiting",
            At::Step(k) => self.flow.step_at(k).map_or("finished", |s| s.name),
            At::Recover(_) => steps::recover::STEP.name,
            At::Finished => "finished",
        }
    }

    fn elapsed_s(&self) -> f64 {
        self.began.map_or(0.0, |b| {
            self.task
                .robot
                .now
                .saturating_duration_since(b)
                .as_secs_f64()
        })
    }

    /// The definition of the current step.
    fn step_def(&self) -> Option<&'static flow::StepDef> {
        match self.at {
            At::Step(k) => self.flow.step_at(k),
            At::Recover(_) => Some(&steps::recover::STEP),
            At::Waiting | At::Finished => None,
        }
    }

    /// Moves to where `next` leads from the current step: a step of the flow (announcing
    /// the hand-over when it begins a new phase of the demo), the recovery, or the end.
    fn go(&mut self, next: Next) {
        let k = match self.at {
            At::Step(k) | At::Recover(k) => k,
            At::Waiting | At::Finished => 0,
        };
        let phase = self.task.out.phase();
        let target = match next {
            Next::Following => self.flow.following(k, &self.task.config),
            Next::After(name) => self
                .flow
                .position(name, phase)
                .and_then(|j| self.flow.following(j, &self.task.config)),
            Next::Goto(name) => self.flow.position(name, phase),
            Next::Finished => None,
            Next::Recover { actions, then } => {
                self.task.memory.recovery = Some((actions, then));
                self.enter(At::Recover(k));
                return;
            }
        };
        let Some(j) = target else {
            self.enter(At::Finished);
            return;
        };
        if let Some(next_phase) = self.flow.phase_at(j)
            && next_phase != phase
        {
            self.hand_over(next_phase);
        }
        self.enter(At::Step(j));
    }

    /// The demo's hang is done: report it and start the remove from here.
    fn hand_over(&mut self, phase: TaskKind) {
        let text = format!(
            "{} done in {:.1} s",
            self.task.out.phase().name(),
            self.elapsed_s()
        );
        self.task.event(TaskEvent::DONE, At::FINISHED, "done", text);
        self.task.out.set_phase(phase);
        self.began = Some(self.task.robot.now);
        self.held_for_wind = RobotDuration::ZERO;
        self.task.memory.attempts = 0;
        self.task.memory.sway_holds = 0;
        self.task.memory.wire_sway_holds = 0;
        self.task.event(
            TaskEvent::INFO,
            "started",
            "",
            format!(
                "{} started; the rod hangs where the hang left it",
                phase.name()
            ),
        );
    }

    /// Enters `at`: announces the step and queues its actions (or ends the task).
    fn enter(&mut self, at: At) {
        self.at = at;
        if at == At::Finished {
            let memory = &self.task.memory;
            let mut text = format!(
                "{} done in {:.1} s",
                self.task.out.phase().name(),
                self.elapsed_s()
            );
            if !memory.done_text.is_empty() {
                text = format!("{text}: {}", memory.done_text);
            }
            let reason = memory.done_reason;
            self.task.event(TaskEvent::DONE, At::FINISHED, reason, text);
            return;
        }
        let Some(step) = self.step_def() else {
            return;
        };
        match (step.plan)(&mut self.task) {
            Ok(actions) => {
                let text = format!(
                    "{} ({} actions) at {:.1} s",
                    step.name,
                    actions.len(),
                    self.elapsed_s()
                );
                self.task.event(TaskEvent::INFO, step.name, "", text);
                self.queue = actions;
                self.running = None;
            }
            Err(stop) => self.end(&stop),
        }
    }

    /// Ends the task early.
    fn end(&mut self, stop: &Stop) {
        let text = format!("{} (after {:.1} s)", stop.text, self.elapsed_s());
        let state = self.step();
        self.task.event(stop.kind, state, stop.reason_code, text);
        self.at = At::Finished;
        self.queue.clear();
        self.running = None;
    }

    /// Runs the machine after every input.
    fn advance(&mut self) -> Vec<(String, Msg)> {
        let now = self.task.robot.now;
        if self.at == At::Waiting {
            if now >= self.task.config.start_at
                && self.task.robot.q.is_some()
                && self.task.robot.lift_m.is_some()
            {
                self.began = Some(now);
                let text = format!(
                    "{} started; self-maintenance {}",
                    self.task.out.phase().name(),
                    if self.task.config.self_maintenance {
                        "on"
                    } else {
                        "off"
                    }
                );
                self.task.event(TaskEvent::INFO, "started", "", text);
                self.enter(At::Step(0));
            }
            return self.task.out.take();
        }
        // Bounded: each pass either waits or makes progress.
        for _ in 0..64 {
            if self.at == At::Finished {
                break;
            }
            if let Some(b) = self.began
                && now.saturating_duration_since(b) > self.task.config.operation_timeout
            {
                let holding = self
                    .holding_since
                    .map_or(RobotDuration::ZERO, |h| now.saturating_duration_since(h));
                let held = self.held_for_wind + holding;
                let limit_s = self.task.config.operation_timeout.as_secs_f64();
                // Out of time because gusts kept stopping the work: the wind gate's refusal,
                // not a fault of the robot's.
                let stop = if held > RobotDuration::ZERO {
                    Stop::refused(
                        "wind_above_limit",
                        format!(
                            "the operation could not finish within {limit_s:.0} s: held {:.0} s for the wind in gusts",
                            held.as_secs_f64()
                        ),
                    )
                } else {
                    Stop::failed(
                        "timeout",
                        format!("the operation took longer than {limit_s:.0} s"),
                    )
                };
                self.end(&stop);
                break;
            }
            if let Some(running) = &self.running {
                if running.done(&self.task.robot) {
                    self.running = None;
                    continue;
                }
                if now.saturating_duration_since(running.started) > running.action.timeout {
                    let stop = Stop::failed(
                        "timeout",
                        format!(
                            "{} did not complete within {:.1} s",
                            running.action.label,
                            running.action.timeout.as_secs_f64()
                        ),
                    );
                    self.end(&stop);
                }
                break;
            }
            if let Some(first) = self.queue.first() {
                if first.command && !self.wind_allows_commands() {
                    break;
                }
                let mut action = self.queue.remove(0);
                // Re-stamp the outputs: the action may have been planned earlier.
                let stamp = self.task.out.stamp(now);
                for (_, msg) in &mut action.outputs {
                    outputs::restamp(msg, stamp);
                }
                self.task.out.extend(action.outputs.iter().cloned());
                if action.until == Until::ClampRest {
                    self.task.robot.clamp_rest_since = None;
                    self.task.robot.clamp_pressed_m = None;
                }
                self.running = Some(Running {
                    action,
                    started: now,
                });
                continue;
            }
            let Some(step) = self.step_def() else {
                break;
            };
            match (step.finish)(&mut self.task) {
                Ok(next) => self.go(next),
                Err(stop) => self.end(&stop),
            }
        }
        if self.at == At::Finished && self.task.robot.lighting.commanded.is_some_and(|b| b > 0.0) {
            self.light();
        }
        self.task.out.take()
    }

    /// Commands the wrist light when [`crate::tasks::lighting::decide`] says so, with an
    /// event that says why.
    fn light(&mut self) {
        let operating = matches!(self.at, At::Step(_) | At::Recover(_));
        let lighting = self.task.robot.lighting;
        let Some(b) = lighting::decide(&lighting, &self.task.config.lighting, operating) else {
            return;
        };
        self.task.robot.lighting.commanded = Some(b);
        self.task
            .out
            .push(WRIST_LIGHT_COMMAND, Msg::Float64(Float64 { data: b }));
        let lux = lighting.lux.map_or("no reading".to_owned(), |l| {
            if l < 10.0 {
                format!("{l:.2} lx")
            } else {
                format!("{l:.0} lx")
            }
        });
        let text = if b > 0.0 {
            format!(
                "wrist light on at {:.0}%: the lux meter reads {lux} (< {:.0} lx)",
                100.0 * b,
                self.task.config.lighting.on_below_lux
            )
        } else if operating {
            format!("wrist light off: the lux meter reads {lux}")
        } else {
            "wrist light off: the operation ended".to_owned()
        };
        let state = self.step();
        self.task.event(TaskEvent::INFO, state, "wrist_light", text);
    }

    /// The wind gate before a command: open, or hold (announced once per hold) and refuse
    /// after the hold timeout. At the rod on the wire ([`Self::at_the_wire`]) a hold is
    /// followed by the settling time, with the gate open, before a command goes (the gust's
    /// swing of the conductor dies down); a gust within it starts a new hold. The hold
    /// timeout and budget count the time the gate was closed.
    fn wind_allows_commands(&mut self) -> bool {
        let now = self.task.robot.now;
        let verdict = self.task.robot.gate.verdict(now);
        if verdict.is_open() {
            if let Some(since) = self.holding_since.take() {
                self.held_for_wind = self.held_for_wind + now.saturating_duration_since(since);
                let settle = self.task.config.wind.settle_on_wire;
                if self.at_the_wire() && settle > RobotDuration::ZERO {
                    self.settling_since = Some(now);
                    let state = self.step();
                    self.task.event(
                        TaskEvent::INFO,
                        state,
                        "settling_after_wind",
                        format!(
                            "the gust has passed ({}): waiting {:.0} s for the wire's swing to settle before moving at the rod on the wire",
                            verdict.describe(),
                            settle.as_secs_f64()
                        ),
                    );
                }
            }
            return match self.settling_since {
                Some(t)
                    if now.saturating_duration_since(t) < self.task.config.wind.settle_on_wire =>
                {
                    false
                }
                _ => {
                    self.settling_since = None;
                    true
                }
            };
        }
        self.settling_since = None;
        // Announced once per hold: `advance` runs for every message of a tick, so
        // "since == now" would repeat it within the first tick.
        let announce = self.holding_since.is_none();
        let since = *self.holding_since.get_or_insert(now);
        if announce {
            let state = self.step();
            self.task.event(
                TaskEvent::INFO,
                state,
                "holding_for_wind",
                format!("holding: {}", verdict.describe()),
            );
        }
        let holding = now.saturating_duration_since(since);
        let held = self.held_for_wind + holding;
        let wind = &self.task.config.wind;
        if holding > wind.hold_timeout || held > wind.hold_budget {
            let stop = Stop::refused(
                "wind_above_limit",
                format!(
                    "held {:.0} s for the wind ({:.0} s in all this operation; limits {:.0} s and {:.0} s): {}",
                    holding.as_secs_f64(),
                    held.as_secs_f64(),
                    wind.hold_timeout.as_secs_f64(),
                    wind.hold_budget.as_secs_f64(),
                    verdict.describe()
                ),
            );
            self.end(&stop);
        }
        false
    }

    /// Whether the tool works at the handle of a rod on the wire, which swings with the
    /// conductor: the hang's release, and the remove's grasp of the hung rod, the clamp's
    /// opening and the unhook. (The retreat after the release starts 20 cm clear of it.)
    fn at_the_wire(&self) -> bool {
        [
            steps::release::NAME,
            steps::grasp_handle::NAME,
            steps::open_clamp::NAME,
            steps::unhook::NAME,
        ]
        .contains(&self.step())
    }

    /// Whether the running action waits for `until`.
    fn waiting_for(&self, until: Until) -> bool {
        self.running
            .as_ref()
            .is_some_and(|r| r.action.until == until)
    }

    fn on_colour(&mut self, image: &Image) {
        if !self.waiting_for(Until::Capture) {
            return;
        }
        self.task
            .robot
            .colour
            .keep(time_ns(&image.header.stamp), image);
    }

    /// A depth image completes the capture in progress (images stamped before its trigger
    /// belong to an earlier one).
    fn on_depth(&mut self, image: &Image) {
        let Some(running) = &self.running else {
            return;
        };
        if running.action.until != Until::Capture {
            return;
        }
        let stamp_ns = time_ns(&image.header.stamp);
        if stamp_ns < running.started.as_nanos() {
            return; // an earlier capture's images
        }
        let Ok(depth) = DepthImage::from_image(image) else {
            let stop = Stop::failed(
                "bad_depth",
                format!("depth image {} is not 32FC1 or 16UC1", image.encoding),
            );
            self.end(&stop);
            return;
        };
        let robot = &mut self.task.robot;
        let Ok(base_from_tool0) = robot.base_from_tool0_at(stamp_ns) else {
            let stop = Stop::failed("no_tf", "no base_link -> tool0 at the capture");
            self.end(&stop);
            return;
        };
        let capture = WristCapture {
            depth,
            colour: robot.colour.take_for(stamp_ns),
            base_from_camera: base_from_tool0 * robot.tool0_from_camera(stamp_ns),
            stamp: image.header.stamp,
        };
        self.task.memory.captures.push(capture);
        self.running = None;
    }
}

impl At {
    /// The `/task/event` state of the end.
    const FINISHED: &'static str = "finished";
}

impl Stage for TaskStage {
    fn name(&self) -> &str {
        STAGE_NAME
    }

    fn inputs(&self) -> Vec<String> {
        [
            CLOCK,
            TF,
            TF_STATIC,
            JOINT_STATES,
            ENV_WIND,
            PANORAMIC_IMAGE,
            PANORAMIC_INFO,
            CAMERA_COLOR_INFO,
            CAMERA_COLOR_IMAGE,
            CAMERA_DEPTH_IMAGE,
            TASK_EVENT,
            ENV_ILLUMINANCE,
            WRIST_LIGHT_STATE,
        ]
        .iter()
        .map(|s| (*s).to_owned())
        .collect()
    }

    fn outputs(&self) -> Vec<(String, &'static str)> {
        vec![
            (ARM_JOINT_TRAJECTORY.to_owned(), JointTrajectory::TYPE_NAME),
            (ARM_PLANNED_PATH.to_owned(), Path::TYPE_NAME),
            (LIFT_COMMAND.to_owned(), Float64::TYPE_NAME),
            (BASE_GOAL.to_owned(), PoseStamped::TYPE_NAME),
            (CLAMP_COMMAND.to_owned(), ClampCommand::TYPE_NAME),
            (CAMERA_TRIGGER.to_owned(), Empty::TYPE_NAME),
            (WRIST_LIGHT_COMMAND.to_owned(), Float64::TYPE_NAME),
            (CALIBRATION_COMMAND.to_owned(), StringMsg::TYPE_NAME),
            (PERCEPTION_ROI_CLOUD.to_owned(), PointCloud2::TYPE_NAME),
            (PERCEPTION_TARGET_POSE.to_owned(), PoseStamped::TYPE_NAME),
            (TASK_EVENT.to_owned(), TaskEvent::TYPE_NAME),
            (ROSOUT.to_owned(), Log::TYPE_NAME),
        ]
    }

    fn latency(&self) -> RobotDuration {
        self.task.config.latency
    }

    fn on_message(
        &mut self,
        log_time: RobotTime,
        topic: &str,
        msg: &Msg,
    ) -> Result<Vec<(String, Msg)>, StageError> {
        self.task.robot.now = log_time;
        match (topic, msg) {
            (TF, Msg::TfMessage(m)) => self.task.robot.on_tf(m),
            (TF_STATIC, Msg::TfMessage(m)) => self.task.robot.on_tf_static(m),
            (JOINT_STATES, Msg::JointState(js)) => self.task.robot.on_joint_state(js),
            (ENV_WIND, Msg::Float64(w)) => self.task.robot.gate.on_reading(log_time, w.data),
            // The light's inputs change nothing but the light.
            (ENV_ILLUMINANCE, Msg::Illuminance(lx)) => {
                self.task.robot.lighting.lux = Some(lx.illuminance);
                self.light();
                return Ok(self.task.out.take());
            }
            (WRIST_LIGHT_STATE, Msg::Float64(b)) => {
                self.task.robot.lighting.state = Some(b.data);
                self.light();
                return Ok(self.task.out.take());
            }
            (PANORAMIC_INFO, Msg::CameraInfo(info)) => self.task.robot.on_panoramic_info(info),
            (CAMERA_COLOR_INFO, Msg::CameraInfo(info)) => self.task.robot.on_wrist_info(info),
            (PANORAMIC_IMAGE, Msg::Image(image))
                if self.running.as_ref().is_some_and(|r| {
                    r.action.until == Until::Panoramic && log_time >= r.started
                }) =>
            {
                self.task.memory.panoramic_image = Some(image.clone());
                self.running = None;
            }
            (CAMERA_COLOR_IMAGE, Msg::Image(image)) => self.on_colour(image),
            (CAMERA_DEPTH_IMAGE, Msg::Image(image)) => self.on_depth(image),
            (TASK_EVENT, Msg::TaskEvent(e))
                if e.task == CALIBRATION_TASK && self.waiting_for(Until::Calibration) =>
            {
                self.task.memory.calibration_answer = Some(e.clone());
                self.running = None;
            }
            _ => {}
        }
        Ok(self.advance())
    }
}
