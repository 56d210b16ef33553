//! `rodlog record --scenario NAME|FILE [--seed N] [--set k=v]... [--out rec.mcap] [--realtime]
//! [--threads N] [--viz rec.rrd]`: run a scenario in the (test) world through the pipeline and record it.
//!
//! Also the pipeline of stages shared with `rodlog replay` ([`pipeline`]): replay must run the
//! very same stages, built from the same parameters, to reproduce a recording.

use std::path::{Path, PathBuf};

use anyhow::{Context as _, bail};
use msgs::Stage;
use recorder::scenario::{Params, SCENARIO_RECORD};
use recorder::session::SCENARIO_ATTACHMENT;
use recorder::stages::{ArmExerciser, JointLimitMonitor};
use recorder::test_world::{TestWorld, TestWorldConfig};
use recorder::{
    ChunkCompression, MetadataRecord, RecordOptions, RecordingHeader, Scenario, SinkOptions,
};
use replay::McapReader;
use robot::{RobotModel, RobotStateConfig, RobotStateStage};

/// Parameter choosing the world: `sim` (default, the simulator) or `test_world`.
pub const WORLD_PARAM: &str = "world";

/// The embedded default driver: the deterministic simulator (DESIGN.md section 1).
pub const DEFAULT_WORLD: &str = "sim";

/// Arguments of `rodlog record`.
#[derive(Debug, clap::Args)]
pub struct RecordArgs {
    /// Scenario name (recordings/scenarios/NAME.toml), scenario file, or a recording (.mcap):
    /// its scenario, seed and parameters (closed-loop what-if with --set).
    #[arg(long)]
    pub scenario: String,
    /// Override the scenario's seed.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Override the scenario's duration, seconds of robot time.
    #[arg(long)]
    pub duration: Option<f64>,
    /// Override a parameter, `stage.key=value` (repeatable).
    #[arg(long = "set", value_name = "K=V")]
    pub set: Vec<String>,
    /// Output file (default: NAME.mcap in the current directory).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Pace by the wall clock (live runtime); without it the run is as fast as possible with
    /// identical output.
    #[arg(long)]
    pub realtime: bool,
    /// Worker threads stages may use (rayon pool size); output is identical for any N.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Chunk compression: lz4 (default), zstd or none.
    #[arg(long, default_value = "lz4")]
    pub compression: String,
    /// Also draw the run in Rerun: write this .rrd beside the MCAP (the viz sink).
    #[arg(long, value_name = "REC.rrd")]
    pub viz: Option<PathBuf>,
    /// End the recording a few seconds after the scenario's task has ended (done, refused
    /// or failed) instead of at its duration.
    #[arg(long)]
    pub until_done: bool,
}

/// Robot time a recording goes on after its task ended ([`task_end`]).
pub const TASK_END_GRACE: msgs::RobotDuration = msgs::RobotDuration::from_secs(5);

/// The end of the scenario's task as a [`recorder::StopCondition`]: the task stage's final
/// `/task/event` (a refusal or failure of any phase; DONE of the last phase: `remove` for the
/// demo). `None` when the scenario has no task.
///
/// # Errors
/// A mistyped `task` parameter.
pub fn task_end(params: &Params) -> anyhow::Result<Option<recorder::StopCondition>> {
    use msgs::rodlog_msgs::TaskEvent;
    let task = params.str_or("task", "none")?;
    let last_phase = match task.as_str() {
        "hang" | "remove" | "check" => task.clone(),
        "demo" => "remove".to_owned(),
        _ => return Ok(None),
    };
    Ok(Some(recorder::StopCondition {
        topic: msgs::topics::TASK_EVENT.to_owned(),
        is_end: std::sync::Arc::new(move |m: &msgs::Msg| {
            m.get::<TaskEvent>().is_some_and(|e| {
                e.task != "calibration"
                    && (e.kind == TaskEvent::REFUSED
                        || e.kind == TaskEvent::FAILED
                        || (e.kind == TaskEvent::DONE && e.task == last_phase))
            })
        }),
        grace: TASK_END_GRACE,
    }))
}

/// Directories searched for scenario names: `./recordings/scenarios`, then the source tree's.
pub fn scenario_dirs() -> Vec<PathBuf> {
    vec![
        PathBuf::from("recordings/scenarios"),
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("recordings/scenarios"),
    ]
}

/// The stages of the current pipeline, configured from `params` and the scenario's
/// `[[command]]` list, in rank order. The world (`world` parameter, default `sim`) decides
/// which stages stand in front of it:
/// - `sim`: `robot_state` (robot crate), `script` (control crate: plays the commands),
///   `calibration` (calib crate: self-calibration and the camera edge, [`calibration_stage`]);
/// - `test_world`: `robot_state`, `arm_exerciser`, `joint_limit_monitor` (recorder crate).
///
/// Replay builds the same list from the recording's metadata and attached scenario.
///
/// # Errors
/// A stage's configuration error, an unknown world, a malformed command.
pub fn pipeline(
    params: &Params,
    commands: &[toml::Table],
) -> anyhow::Result<Vec<Box<dyn Stage + Send>>> {
    let latency_ms = params.f64_or("robot_state.latency_ms", 1.0)?;
    let robot_state = RobotStateStage::new(
        RobotModel::nominal(),
        RobotStateConfig {
            latency: msgs::RobotDuration::from_secs_f64(latency_ms * 1e-3)
                .context("robot_state.latency_ms")?,
            publish_robot_description: params
                .bool_or("robot_state.publish_robot_description", true)?,
        },
    );
    let world = params.str_or(WORLD_PARAM, DEFAULT_WORLD)?;
    match world.as_str() {
        "sim" => {
            let mut stages: Vec<Box<dyn Stage + Send>> = vec![
                Box::new(robot_state),
                Box::new(script_stage(commands)?),
                Box::new(calibration_stage(params, commands)?),
            ];
            stages.extend(perceive_stage(params)?);
            stages.extend(task_stage(params)?);
            Ok(stages)
        }
        "test_world" => Ok(vec![
            Box::new(robot_state),
            Box::new(ArmExerciser::from_params(params)?),
            Box::new(JointLimitMonitor::from_params(params)?),
        ]),
        other => bail!("unknown world {other:?}: use sim (the simulator) or test_world"),
    }
}

/// The calibration stage (calib crate, DESIGN.md s3) from the `calibration.*` parameters.
/// `calibration.captures` (captures after which it self-calibrates; 0 = never, it then only
/// publishes the nominal camera edge) defaults to the scenario's number of `capture`
/// commands when that is at least [`calib::selfcal::MIN_VIEWS`], else 0; the other keys
/// default to [`calib::selfcal::CalibrationStageConfig::default`].
///
/// # Errors
/// A mistyped or out-of-range parameter.
pub fn calibration_stage(
    params: &Params,
    commands: &[toml::Table],
) -> anyhow::Result<calib::selfcal::CalibrationStage> {
    use calib::selfcal::{CalibrationStage, CalibrationStageConfig, MIN_VIEWS};
    let d = CalibrationStageConfig::default();
    let scripted = commands
        .iter()
        .filter(|c| c.get("kind").and_then(toml::Value::as_str) == Some("capture"))
        .count();
    let default_captures = if scripted >= MIN_VIEWS { scripted } else { 0 };
    let ms = |key: &str, default: msgs::RobotDuration| -> anyhow::Result<msgs::RobotDuration> {
        let v = params.f64_or(key, default.as_secs_f64() * 1e3)?;
        msgs::RobotDuration::from_secs_f64(v * 1e-3).with_context(|| key.to_owned())
    };
    let positive = |key: &str, default: f64| -> anyhow::Result<f64> {
        let v = params.f64_or(key, default)?;
        if !(v.is_finite() && v >= 0.0) {
            bail!("{key} = {v}: must be a finite number >= 0");
        }
        Ok(v)
    };
    let config = CalibrationStageConfig {
        latency: ms("calibration.latency_ms", d.latency)?,
        captures_to_solve: usize::try_from(
            params.u64_or("calibration.captures", default_captures as u64)?,
        )
        .context("calibration.captures")?,
        min_view_rotation_deg: positive(
            "calibration.min_view_rotation_deg",
            d.min_view_rotation_deg,
        )?,
        max_residual_rot_deg: positive("calibration.max_residual_rot_deg", d.max_residual_rot_deg)?,
        max_residual_trans_mm: positive(
            "calibration.max_residual_trans_mm",
            d.max_residual_trans_mm,
        )?,
        depth_wait: ms("calibration.depth_wait_ms", d.depth_wait)?,
        tf_wait: msgs::RobotDuration::from_secs_f64(positive(
            "calibration.tf_wait_s",
            d.tf_wait.as_secs_f64(),
        )?)
        .context("calibration.tf_wait_s")?,
        ignore_depth: params.bool_or("calibration.mono", d.ignore_depth)?,
        seed: params.u64_or("calibration.seed", d.seed)?,
        ..d
    };
    Ok(CalibrationStage::new(config))
}

/// The `perceive` stage (control crate: panoramic fix, wrist look motion, captures, hanging
/// point) when `perceive.enabled = true`, configured from `perceive.*`: `panoramic_at_s`,
/// `look_at_s`, `standoff_m`, `captures`, `prior_x_m`/`prior_y_m`/`prior_z_m` (the map's
/// wire prior), `latency_ms`; defaults of [`control::stages::perceive::PerceiveConfig`].
///
/// # Errors
/// Mistyped parameters.
pub fn perceive_stage(params: &Params) -> anyhow::Result<Option<Box<dyn Stage + Send>>> {
    use control::stages::perceive::{PerceiveConfig, PerceiveStage};
    if !params.bool_or("perceive.enabled", false)? {
        return Ok(None);
    }
    let d = PerceiveConfig::default();
    let time = |key: &str, default: f64| -> anyhow::Result<msgs::RobotTime> {
        msgs::RobotTime::from_secs_f64(params.f64_or(key, default)?).with_context(|| key.to_owned())
    };
    let mut prior = d.prior_in_map;
    prior.point = nalgebra::Point3::new(
        params.f64_or("perceive.prior_x_m", prior.point.x)?,
        params.f64_or("perceive.prior_y_m", prior.point.y)?,
        params.f64_or("perceive.prior_z_m", prior.point.z)?,
    );
    let config = PerceiveConfig {
        prior_in_map: prior,
        panoramic_at: time("perceive.panoramic_at_s", 0.0)?,
        look_at: time("perceive.look_at_s", 0.0)?,
        standoff_m: params.f64_or("perceive.standoff_m", d.standoff_m)?,
        captures: usize::try_from(params.u64_or("perceive.captures", d.captures as u64)?)?,
        latency: msgs::RobotDuration::from_secs_f64(
            params.f64_or("perceive.latency_ms", d.latency.as_secs_f64() * 1e3)? * 1e-3,
        )
        .context("perceive.latency_ms")?,
        ..d
    };
    Ok(Some(Box::new(PerceiveStage::new(config)?)))
}

/// The `task` stage (control crate: the hang and remove machines) when the scenario's `task`
/// is `hang` or `remove`, configured from `task.*`: `start_s`, `self_maintenance`,
/// `standoff_m`, `wire_captures`, `handle_captures`, `approach_m`, `attempts`,
/// `clamp_torque_nm`, `operation_timeout_s`, `wind_sigmas`, `wind_hold_timeout_s`,
/// `min_confidence`, `latency_ms`; defaults of [`control::stages::task::TaskConfig`].
///
/// # Errors
/// Mistyped or out-of-range parameters.
pub fn task_stage(params: &Params) -> anyhow::Result<Option<Box<dyn Stage + Send>>> {
    use control::stages::task::{TaskConfig, TaskKind, TaskStage};
    let task = params.str_or("task", "none")?;
    let kind = match task.as_str() {
        "none" | "calibrate" => return Ok(None),
        other => TaskKind::parse(other).with_context(|| {
            format!("task = {other:?}: expected none, calibrate, hang or remove")
        })?,
    };
    let d = TaskConfig::default();
    let secs = |key: &str, default: msgs::RobotDuration| -> anyhow::Result<msgs::RobotDuration> {
        let v = params.f64_or(key, default.as_secs_f64())?;
        msgs::RobotDuration::from_secs_f64(v).with_context(|| key.to_owned())
    };
    let count = |key: &str, default: usize| -> anyhow::Result<usize> {
        let v = params.u64_or(key, default as u64)?;
        if v == 0 {
            bail!("{key} = 0: must be at least 1");
        }
        usize::try_from(v).with_context(|| key.to_owned())
    };
    let mut wind = d.wind;
    wind.sigmas = params.f64_or("task.wind_sigmas", wind.sigmas)?;
    wind.hold_timeout = secs("task.wind_hold_timeout_s", wind.hold_timeout)?;
    let mut thresholds = d.thresholds;
    thresholds.min_score = params.f64_or("task.min_confidence", thresholds.min_score)?;
    let config = TaskConfig {
        kind,
        start_at: msgs::RobotTime::from_secs_f64(
            params.f64_or("task.start_s", d.start_at.as_secs_f64())?,
        )
        .context("task.start_s")?,
        self_maintenance: params.bool_or("task.self_maintenance", d.self_maintenance)?,
        standoff_m: params.f64_or("task.standoff_m", d.standoff_m)?,
        wire_captures: count("task.wire_captures", d.wire_captures)?,
        handle_captures: count("task.handle_captures", d.handle_captures)?,
        approach_m: params.f64_or("task.approach_m", d.approach_m)?,
        attempts: count("task.attempts", d.attempts)?,
        clamp_torque_nm: params.f64_or("task.clamp_torque_nm", d.clamp_torque_nm)?,
        operation_timeout: secs("task.operation_timeout_s", d.operation_timeout)?,
        latency: msgs::RobotDuration::from_secs_f64(
            params.f64_or("task.latency_ms", d.latency.as_secs_f64() * 1e3)? * 1e-3,
        )
        .context("task.latency_ms")?,
        wind,
        thresholds,
        ..d
    };
    Ok(Some(Box::new(TaskStage::new(config)?)))
}

/// The `script` stage from a scenario's `[[command]]` tables (`t_s`, `kind`, `values`,
/// optional `duration_s`).
///
/// # Errors
/// A command with a missing or mistyped field (naming its index), and the script stage's
/// own validation errors.
pub fn script_stage(commands: &[toml::Table]) -> anyhow::Result<control::script::ScriptStage> {
    let mut parts: Vec<(f64, String, Vec<f64>, f64)> = Vec::with_capacity(commands.len());
    for (i, c) in commands.iter().enumerate() {
        let number = |v: &toml::Value| v.as_float().or_else(|| v.as_integer().map(|n| n as f64));
        let t_s = c
            .get("t_s")
            .and_then(number)
            .with_context(|| format!("[[command]] {i}: missing or non-numeric t_s"))?;
        let kind = c
            .get("kind")
            .and_then(toml::Value::as_str)
            .with_context(|| format!("[[command]] {i}: missing kind"))?;
        let values = match c.get("values") {
            None => Vec::new(),
            Some(toml::Value::Array(a)) => a
                .iter()
                .map(|v| {
                    number(v).with_context(|| format!("[[command]] {i}: values must be numbers"))
                })
                .collect::<anyhow::Result<Vec<f64>>>()?,
            Some(_) => bail!("[[command]] {i}: values must be an array of numbers"),
        };
        let duration_s = c.get("duration_s").and_then(number).unwrap_or(0.0);
        parts.push((t_s, kind.to_owned(), values, duration_s));
    }
    Ok(control::script::ScriptStage::from_parts(
        parts
            .iter()
            .map(|(t, k, v, d)| (*t, k.as_str(), v.as_slice(), *d)),
    )?)
}

/// The simulator for a scenario: its file text (the source or the recording's attached
/// copy) with the seed and every parameter of the simulator's own sections applied (so
/// `--set robot.perturbation=false` and a recording's stored overrides reach the world).
///
/// # Errors
/// Invalid scenario text or values (the simulator's errors name the key).
pub fn sim_world(scenario: &Scenario) -> anyhow::Result<sim::SimWorld> {
    let origin = scenario
        .source_path
        .as_ref()
        .map_or_else(|| scenario.name.clone(), |p| p.display().to_string());
    let mut s = sim::Scenario::parse(&scenario.source_text, &origin)?;
    let overrides: Vec<(String, String)> = scenario
        .params
        .iter()
        .filter(|(k, _)| *k != WORLD_PARAM)
        .map(|(k, v)| (k.to_owned(), v.to_string()))
        .collect();
    // Keys that are not the simulator's are stage parameters: the pipeline reads them.
    let _stage_keys = s.apply_overrides(&overrides)?;
    // After the overrides: the file's own `seed` key must not undo `--seed`.
    s.seed = scenario.seed;
    Ok(sim::SimWorld::from_scenario(&s)?)
}

/// Parses `--compression`.
///
/// # Errors
/// Unknown names.
pub fn compression(name: &str) -> anyhow::Result<ChunkCompression> {
    Ok(match name {
        "lz4" => ChunkCompression::Lz4,
        "zstd" => ChunkCompression::Zstd,
        "none" => ChunkCompression::None,
        other => bail!("unknown --compression {other:?} (lz4, zstd or none)"),
    })
}

/// The scenario of a recording: its `scenario` metadata record and attached scenario file.
///
/// # Errors
/// Unreadable files, a recording without a `scenario` record.
pub fn scenario_of_recording(path: &Path) -> anyhow::Result<Scenario> {
    let mut reader =
        McapReader::open(path).with_context(|| format!("cannot read {}", path.display()))?;
    let Some(meta) = reader.metadata_named(SCENARIO_RECORD).cloned() else {
        bail!("{} has no scenario metadata record", path.display());
    };
    let attachment = reader
        .attachments()
        .iter()
        .find(|a| a.name == SCENARIO_ATTACHMENT)
        .cloned();
    let text = match attachment {
        Some(a) => Some(String::from_utf8(reader.read_attachment(&a)?)?),
        None => None,
    };
    Ok(Scenario::from_metadata(
        &meta.entries,
        text.as_deref(),
        &path.display().to_string(),
    )?)
}

/// The header (metadata, attachments) of a recording of `scenario`.
///
/// # Errors
/// A mistyped `world` parameter.
pub fn recording_header(scenario: &Scenario) -> anyhow::Result<RecordingHeader> {
    let world_name = scenario.params.str_or(WORLD_PARAM, DEFAULT_WORLD)?;
    let robot_info = MetadataRecord::new("robot_info")
        .with("robot", "AUBO i10 arm + lift + mobile base")
        .with("model", "nominal DH (DESIGN.md section 6)")
        .with("world", &world_name)
        .with("joints", msgs::frames::JOINT_NAMES.join(","));
    let mut header = RecordingHeader::for_scenario(scenario, robot_info);
    header.attachments.push((
        "robot.urdf".to_owned(),
        "application/xml".to_owned(),
        robot::robot_urdf(&RobotModel::nominal()).into_bytes(),
    ));
    Ok(header)
}

/// Records `scenario` (its world and pipeline) to `options.out`, with `extra_sinks` beside
/// the MCAP writer: what `rodlog record` does, and the experiments' runs.
///
/// # Errors
/// Pipeline, world and recording errors.
pub fn record_scenario(
    scenario: &Scenario,
    options: &RecordOptions,
    extra_sinks: Vec<Box<dyn recorder::Sink>>,
) -> anyhow::Result<recorder::RecordSummary> {
    let world_name = scenario.params.str_or(WORLD_PARAM, DEFAULT_WORLD)?;
    let stages = pipeline(&scenario.params, &scenario.commands)?;
    let header = recording_header(scenario)?;
    let out = &options.out;
    match world_name.as_str() {
        "sim" => recorder::record_with_sinks(
            sim_world(scenario)?,
            stages,
            &header,
            scenario.duration,
            options,
            extra_sinks,
        ),
        _ => recorder::record_with_sinks(
            TestWorld::new(TestWorldConfig::from_params(
                scenario.seed,
                &scenario.params,
            )?),
            stages,
            &header,
            scenario.duration,
            options,
            extra_sinks,
        ),
    }
    .with_context(|| format!("recording scenario {} to {}", scenario.name, out.display()))
}

/// Runs `rodlog record`.
pub fn run(args: &RecordArgs) -> anyhow::Result<()> {
    let from_recording = Path::new(&args.scenario);
    let mut scenario = if args.scenario.ends_with(".mcap") && from_recording.is_file() {
        scenario_of_recording(from_recording)?
    } else {
        Scenario::find(&args.scenario, &scenario_dirs())?
    };
    if let Some(seed) = args.seed {
        scenario.seed = seed;
    }
    if let Some(d) = args.duration {
        scenario.duration = msgs::RobotDuration::from_secs_f64(d).context("--duration")?;
    }
    for s in &args.set {
        scenario.params.set_from_arg(s)?;
    }
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from(format!("{}.mcap", scenario.name)));
    let mut extra_sinks: Vec<Box<dyn recorder::Sink>> = Vec::new();
    if let Some(rrd) = &args.viz {
        let header = recording_header(&scenario)?;
        extra_sinks.push(Box::new(super::view::VizSink::create(
            rrd,
            &header.metadata,
        )?));
    }
    let options = RecordOptions {
        out: out.clone(),
        sink: SinkOptions {
            compression: compression(&args.compression)?,
            ..SinkOptions::default()
        },
        realtime: args.realtime,
        threads: args.threads,
        stop: if args.until_done {
            task_end(&scenario.params)?
        } else {
            None
        },
    };
    let summary = record_scenario(&scenario, &options, extra_sinks)?;
    let mut text = format!(
        "recorded {} messages, {} of robot time, to {}{}\n",
        summary.messages,
        summary.end,
        out.display(),
        if summary.interrupted {
            " (interrupted)"
        } else {
            ""
        }
    );
    text.push_str(&format!(
        "  world {} msgs, /clock {}, stage outputs {}, commands {} ({} rejected)",
        summary.scheduler.world_messages,
        summary.scheduler.clock_messages,
        summary.scheduler.stage_outputs,
        summary.scheduler.commands,
        summary.scheduler.rejected_commands
    ));
    for s in &summary.stages {
        text.push_str(&format!(
            "\n  stage {:<22} inputs {:>7}  errors {}{}",
            s.name,
            s.inputs,
            s.errors,
            if s.disabled { " (stopped)" } else { "" }
        ));
    }
    super::print_stdout(&text)
}
