//! `rodlog experiment NAME [--trials N] [--out DIR] [--seed S] [--image-scale F]`
//! (DESIGN.md sections 4 and 7): runs one experiment and writes `DIR/report.md`,
//! `DIR/results.json` and `DIR/plots/`. The machinery is in `crate::experiment`.

use std::path::PathBuf;

use anyhow::{Result, bail};
use clap::{Args, ValueEnum};

use crate::experiment::{self, OutputDir, Settings};

/// The experiments of DESIGN.md section 7.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ExperimentName {
    /// Feature matchers on image pairs with known geometry (issue 6).
    Matchers,
    /// Calibration error vs image noise, ours vs ZHI (issue 9).
    Noise,
    /// Calibration error vs number of motions (issue 9).
    Motions,
    /// Simulator and shecar datasets, ours vs ZHI (issue 9).
    Datasets,
    /// Hang and remove after a camera-mount bump, with and without self-calibration (issue 12).
    Tasks,
    /// Task success and time by hour of day (issue 12).
    Light,
    /// Task success vs wind speed (issue 12).
    Wind,
    /// Drift detection per bump size, false alarms (issue 12).
    Maintenance,
}

impl ExperimentName {
    /// The CLI name.
    pub fn name(self) -> &'static str {
        match self {
            ExperimentName::Matchers => "matchers",
            ExperimentName::Noise => "noise",
            ExperimentName::Motions => "motions",
            ExperimentName::Datasets => "datasets",
            ExperimentName::Tasks => "tasks",
            ExperimentName::Light => "light",
            ExperimentName::Wind => "wind",
            ExperimentName::Maintenance => "maintenance",
        }
    }
}

/// Arguments of `rodlog experiment`.
#[derive(Debug, Args)]
pub struct ExperimentArgs {
    /// Which experiment.
    pub name: ExperimentName,
    /// Seeded trials per condition (default: the experiment's own, e.g. the paper's 100).
    #[arg(long)]
    pub trials: Option<usize>,
    /// Output folder (default: experiment-NAME in the current folder).
    #[arg(long)]
    pub out: Option<PathBuf>,
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
    /// strongest corners).
    #[arg(long, value_enum, default_value_t = super::calib::Distribution::Quadtree)]
    pub orb_distribution: super::calib::Distribution,
}

/// Runs the experiment.
///
/// # Errors
/// Bad arguments and the experiment's own errors.
pub fn run(args: &ExperimentArgs) -> Result<()> {
    if !(args.image_scale > 0.0 && args.image_scale <= 4.0) {
        bail!("--image-scale must be in (0, 4], got {}", args.image_scale);
    }
    if args.trials == Some(0) {
        bail!("--trials must be at least 1");
    }
    let name = args.name.name();
    // Made only by the experiments that exist, so a refused name leaves no folder behind.
    let settings = || -> Result<Settings> {
        let out_path = args
            .out
            .clone()
            .unwrap_or_else(|| PathBuf::from(format!("experiment-{name}")));
        Ok(Settings {
            name,
            trials: args.trials,
            seed: args.seed,
            image_scale: args.image_scale,
            reference: !args.no_reference,
            orb_distribution: args.orb_distribution.into(),
            out: OutputDir::create(&out_path)?,
        })
    };
    match args.name {
        ExperimentName::Matchers => experiment::matchers::run(&settings()?),
        ExperimentName::Noise => experiment::noise::run(&settings()?),
        ExperimentName::Motions => experiment::motions::run(&settings()?),
        ExperimentName::Datasets => experiment::datasets::run(&settings()?),
        ExperimentName::Tasks => experiment::tasks::run(&settings()?),
        ExperimentName::Light => experiment::light::run(&settings()?),
        ExperimentName::Wind => experiment::wind::run(&settings()?),
        ExperimentName::Maintenance => experiment::maintenance::run(&settings()?),
    }
}
