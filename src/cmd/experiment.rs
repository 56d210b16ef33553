//! `rodlog experiment NAME [--trials N] [--out DIR] [--seed S] [--image-scale F]
//! [--shard K/N]` and `rodlog experiment merge --out DIR SHARD_DIR...` (ARCHITECTURE.md
//! sections 4 and 7): runs one experiment (or one shard of it) and writes `DIR/report.md`,
//! `DIR/results.json` and `DIR/plots/`; merge recomputes them from the shards' records. The
//! machinery is in `crate::experiment`.

use std::path::PathBuf;

use anyhow::{Context as _, Result, bail};
use clap::{Args, ValueEnum};
use serde::{Deserialize, Serialize};

use crate::experiment::shard::{Mode, Shard, read_shards};
use crate::experiment::{self, OutputDir, Settings};

/// The experiments (ARCHITECTURE.md section 7), and `merge`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ExperimentName {
    /// Feature matchers on image pairs with known geometry.
    Matchers,
    /// Calibration error vs image noise, ours vs ZHI.
    Noise,
    /// Calibration error vs number of motions.
    Motions,
    /// Simulator and shecar datasets, ours vs ZHI.
    Datasets,
    /// From the paper's method to ours, one step at a time, on the same trials.
    Ablation,
    /// Hang and remove after a camera-mount bump, with and without self-calibration.
    Tasks,
    /// Task success and time by hour of day.
    Light,
    /// Task success vs wind speed.
    Wind,
    /// Drift detection per bump size, false alarms.
    Maintenance,
    /// Merge the shards given as folders into one report (`--out DIR SHARD_DIR...`).
    Merge,
}

impl ExperimentName {
    /// The CLI name.
    pub fn name(self) -> &'static str {
        match self {
            ExperimentName::Matchers => "matchers",
            ExperimentName::Noise => "noise",
            ExperimentName::Motions => "motions",
            ExperimentName::Datasets => "datasets",
            ExperimentName::Ablation => "ablation",
            ExperimentName::Tasks => "tasks",
            ExperimentName::Light => "light",
            ExperimentName::Wind => "wind",
            ExperimentName::Maintenance => "maintenance",
            ExperimentName::Merge => "merge",
        }
    }
}

/// The options that decide an experiment's items and numbers (recorded in a shard file, so
/// shards made with other options are not merged).
#[derive(Clone, Debug, PartialEq, Args, Serialize, Deserialize)]
pub struct ExperimentOptions {
    /// Seeded trials per condition (default: the experiment's own, e.g. the paper's 100).
    #[arg(long)]
    pub trials: Option<usize>,
    /// Seed every trial seed derives from (recorded in results.json).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Factor on image sizes (1 = full resolution; CI smoke runs use e.g. 0.25).
    #[arg(long, default_value_t = 1.0)]
    pub image_scale: f64,
    /// Skip the optional OpenCV reference columns even when .venv-ref exists.
    #[arg(long)]
    pub no_reference: bool,
    /// ORB keypoint selection of our self-calibration in noise, motions and datasets (the
    /// other experiments ignore it): quadtree (the paper's) or retain-best (OpenCV's
    /// strongest corners). Default: ours' own (retain-best).
    #[arg(long, value_enum)]
    #[serde(default)]
    pub orb_distribution: Option<super::calib::Distribution>,
    /// Switch a step of our self-calibration on in noise, motions and datasets (repeatable;
    /// the names of `rodlog calib self --with`): measures a step before it becomes a default.
    #[arg(long = "with", value_name = "STEP")]
    #[serde(default)]
    pub with_steps: Vec<String>,
    /// Switch a step of our self-calibration off in noise, motions and datasets (repeatable).
    #[arg(long = "without", value_name = "STEP")]
    #[serde(default)]
    pub without_steps: Vec<String>,
    /// `wind` only: the mean wind speeds to run (m/s, comma-separated, e.g. `2.5,3.0`)
    /// instead of the experiment's own list; a speed of the own list keeps its trials.
    #[arg(long, value_delimiter = ',', value_name = "LIST")]
    #[serde(default)]
    pub speeds: Option<Vec<f64>>,
    /// `light` only: the local solar hours to run (comma-separated, e.g. `18.5,19`) instead
    /// of the experiment's own list; an hour of the own list keeps its trials.
    #[arg(long, value_delimiter = ',', value_name = "LIST")]
    #[serde(default)]
    pub hours: Option<Vec<f64>>,
    /// The task experiments (tasks, light, wind, maintenance): `fixed`, the fixed bay whose
    /// map the robot has built in, or `seeded`, a bay drawn from each trial's seed with the
    /// simulated crew's survey given to the robot (`rodlog survey`).
    #[arg(long, value_enum, default_value_t = Sites::Fixed)]
    #[serde(default)]
    pub sites: Sites,
    /// `light` only: `on` gives the robot a wrist light, which its task switches on when the
    /// lux meter reads low; `off` (default) is the robot without one.
    #[arg(long, value_enum, default_value_t = OnOff::Off)]
    #[serde(default)]
    pub wrist_light: OnOff,
    /// `noise` only: what the wrist camera sees, `substation` (the simulated bay's
    /// calibration cabinet, default) or `photos` (a wall of the shecar photographs with
    /// boxes standing out of it: real image content, exact geometry and depth).
    #[arg(long, value_enum, default_value_t = CalibScene::Substation)]
    #[serde(default)]
    pub scene: CalibScene,
    /// The task experiments: keep the recording of every run that did not succeed in
    /// `OUT/runs/` (for `rodlog log`, `rodlog check task`, `rodlog view`); the others are
    /// deleted. Not recorded in a shard file: it changes no number.
    #[arg(long)]
    #[serde(skip)]
    pub keep_failed: bool,
    /// `matchers` only: no match pictures (they show the pairs' images, and shecar's photos
    /// are GPL-3.0: a committed report leaves them out). Changes no number.
    #[arg(long)]
    #[serde(skip)]
    pub no_pictures: bool,
}

/// Our self-calibration's steps under `--with` / `--without` (`None` without either).
fn ours_steps(
    name: ExperimentName,
    options: &ExperimentOptions,
) -> Result<Option<calib::selfcal::Steps>> {
    if options.with_steps.is_empty() && options.without_steps.is_empty() {
        return Ok(None);
    }
    if !matches!(
        name,
        ExperimentName::Noise | ExperimentName::Motions | ExperimentName::Datasets
    ) {
        bail!(
            "--with/--without are options of the calibration experiments (noise, motions, datasets); `rodlog experiment ablation` switches the steps itself"
        );
    }
    let mut steps = calib::selfcal::Steps::ours();
    for (names, on) in [(&options.with_steps, true), (&options.without_steps, false)] {
        for step in names {
            steps
                .set(step, on)
                .map_err(|e| anyhow::anyhow!("experiment --with/--without: {e}"))?;
        }
    }
    Ok(Some(steps))
}

/// `--wrist-light`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, Serialize, Deserialize)]
pub enum OnOff {
    /// Without.
    #[default]
    Off,
    /// With.
    On,
}

/// `--scene` of the noise experiment.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, Serialize, Deserialize)]
pub enum CalibScene {
    /// The simulated substation's calibration cabinet.
    #[default]
    Substation,
    /// A wall of real photographs with boxes (the shecar sample's photos).
    Photos,
}

/// `--sites` of the task experiments.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, Serialize, Deserialize)]
pub enum Sites {
    /// The fixed bay (the robot's built-in map).
    #[default]
    Fixed,
    /// A seeded bay per trial, with a survey.
    Seeded,
}

/// A `--speeds` / `--hours` list: non-empty, every value finite within `range`, no value
/// twice.
fn check_list(flag: &str, values: &[f64], range: std::ops::RangeInclusive<f64>) -> Result<()> {
    if values.is_empty() {
        bail!("{flag}: give at least one value");
    }
    for (i, v) in values.iter().enumerate() {
        if !(v.is_finite() && range.contains(v)) {
            bail!(
                "{flag}: {v} is outside [{}, {}]",
                range.start(),
                range.end()
            );
        }
        if values[..i].contains(v) {
            bail!("{flag}: {v} is given twice");
        }
    }
    Ok(())
}

/// Arguments of `rodlog experiment`.
#[derive(Debug, Args)]
pub struct ExperimentArgs {
    /// Which experiment (or `merge`).
    pub name: ExperimentName,
    /// `merge` only: the shard folders to merge.
    #[arg(value_name = "SHARD_DIR")]
    pub shard_dirs: Vec<PathBuf>,
    /// Output folder (default: experiment-NAME in the current folder).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Run only shard K of N (0-based): the experiment's items are dealt to N shards (a fixed
    /// shuffle, then round robin) and this runs hand K; writes DIR/shard.cbor for
    /// `rodlog experiment merge` instead of a report.
    #[arg(long, value_name = "K/N")]
    pub shard: Option<String>,
    /// The experiment's options.
    #[command(flatten)]
    pub options: ExperimentOptions,
}

/// Runs `rodlog experiment`.
///
/// # Errors
/// Bad arguments and the experiment's own errors.
pub fn run(args: &ExperimentArgs) -> Result<()> {
    if args.name == ExperimentName::Merge {
        return merge(args);
    }
    if !args.shard_dirs.is_empty() {
        bail!(
            "unexpected arguments {:?}: only `rodlog experiment merge` takes folders",
            args.shard_dirs
        );
    }
    let mode = match &args.shard {
        Some(s) => Mode::Shard(Shard::parse(s)?),
        None => Mode::All,
    };
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from(format!("experiment-{}", args.name.name())));
    run_named(args.name, &args.options, &out, mode)
}

/// `rodlog experiment merge --out DIR SHARD_DIR...`.
fn merge(args: &ExperimentArgs) -> Result<()> {
    let Some(out) = &args.out else {
        bail!("experiment merge needs --out DIR for the merged report");
    };
    if args.shard.is_some() {
        bail!("experiment merge does not take --shard");
    }
    let (first, merged) = read_shards(&args.shard_dirs)?;
    let name: ExperimentName =
        serde_json::from_value(serde_json::Value::String(first.experiment.clone()))
            .with_context(|| format!("shards of an unknown experiment {:?}", first.experiment))?;
    let options: ExperimentOptions = serde_json::from_str(&first.arguments)
        .with_context(|| format!("the shards' arguments {}", first.arguments))?;
    run_named(name, &options, out, Mode::Merged(merged))
}

fn run_named(
    name: ExperimentName,
    options: &ExperimentOptions,
    out: &std::path::Path,
    mode: Mode,
) -> Result<()> {
    if !(options.image_scale > 0.0 && options.image_scale <= 4.0) {
        bail!(
            "--image-scale must be in (0, 4], got {}",
            options.image_scale
        );
    }
    if options.trials == Some(0) {
        bail!("--trials must be at least 1");
    }
    match (&options.speeds, &options.hours) {
        (Some(_), _) if name != ExperimentName::Wind => {
            bail!("--speeds is an option of `rodlog experiment wind` only")
        }
        (_, Some(_)) if name != ExperimentName::Light => {
            bail!("--hours is an option of `rodlog experiment light` only")
        }
        (Some(speeds), _) => check_list("--speeds", speeds, 0.0..=40.0)?,
        (_, Some(hours)) => check_list("--hours", hours, 0.0..=24.0)?,
        (None, None) => {}
    }
    if options.wrist_light == OnOff::On && name != ExperimentName::Light {
        bail!("--wrist-light is an option of `rodlog experiment light` only");
    }
    if options.sites == Sites::Seeded
        && !matches!(
            name,
            ExperimentName::Tasks
                | ExperimentName::Light
                | ExperimentName::Wind
                | ExperimentName::Maintenance
        )
    {
        bail!("--sites is an option of the task experiments (tasks, light, wind, maintenance)");
    }
    if options.scene == CalibScene::Photos && name != ExperimentName::Noise {
        bail!("--scene is an option of `rodlog experiment noise`");
    }
    if options.no_pictures && name != ExperimentName::Matchers {
        bail!("--no-pictures is an option of `rodlog experiment matchers`");
    }
    let steps = ours_steps(name, options)?;
    let settings = || -> Result<Settings> {
        Ok(Settings {
            name: name.name(),
            trials: options.trials,
            seed: options.seed,
            image_scale: options.image_scale,
            reference: !options.no_reference,
            orb_distribution: options.orb_distribution.map(Into::into),
            steps,
            speeds_mps: options.speeds.clone(),
            hours: options.hours.clone(),
            seeded_sites: options.sites == Sites::Seeded,
            wrist_light: options.wrist_light == OnOff::On,
            photo_scene: options.scene == CalibScene::Photos,
            keep_failed: options.keep_failed,
            pictures: !options.no_pictures,
            out: OutputDir::create(out)?,
            mode: mode.clone(),
            arguments: serde_json::to_string(options)?,
        })
    };
    match name {
        ExperimentName::Matchers => experiment::matchers::run(&settings()?),
        ExperimentName::Noise => experiment::noise::run(&settings()?),
        ExperimentName::Motions => experiment::motions::run(&settings()?),
        ExperimentName::Datasets => experiment::datasets::run(&settings()?),
        ExperimentName::Ablation => experiment::ablation::run(&settings()?),
        ExperimentName::Tasks => experiment::tasks::run(&settings()?),
        ExperimentName::Light => experiment::light::run(&settings()?),
        ExperimentName::Wind => experiment::wind::run(&settings()?),
        ExperimentName::Maintenance => experiment::maintenance::run(&settings()?),
        ExperimentName::Merge => bail!("a shard file names the experiment `merge`"),
    }
}
