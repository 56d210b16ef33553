//! `rodlog survey SCENARIO [--seed S] [--set k=v]... --out FILE`: the simulated crew's survey
//! of the scenario's bay (`site.layout`, the seed), a site file with a survey's error
//! (`sim::survey`), for `record --site FILE`. The robot gets the survey, never the truth.

use std::path::PathBuf;

use anyhow::{Context, Result};

/// Arguments of `rodlog survey`.
#[derive(Debug, clap::Args)]
pub struct SurveyArgs {
    /// Scenario name (recordings/scenarios/NAME.toml) or file.
    pub scenario: String,
    /// Override the scenario's seed (it draws a seeded site and the survey's error).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Override a parameter, `key=value` (repeatable; e.g. `site.layout=seeded`).
    #[arg(long = "set", value_name = "K=V")]
    pub set: Vec<String>,
    /// The site file to write.
    #[arg(long)]
    pub out: PathBuf,
}

/// Runs `rodlog survey`.
///
/// # Errors
/// An unknown scenario or parameter, a bay that cannot be built, an unwritable file.
pub fn run(args: &SurveyArgs) -> Result<()> {
    let (mut scenario, migrated) = compose::load_scenario(&args.scenario)?;
    for m in &migrated {
        eprintln!("rodlog: note: {m}");
    }
    if let Some(seed) = args.seed {
        scenario.seed = seed;
    }
    for s in &args.set {
        scenario.set_from_arg(s)?;
    }
    let config = sim::SimConfig::of_scenario(&scenario)?;
    let (_, layout) = sim::world::site(&config)?;
    let text = sim::survey::survey(&layout, config.seed)
        .map_err(anyhow::Error::msg)?
        .to_site_file();
    std::fs::write(&args.out, text)
        .with_context(|| format!("cannot write {}", args.out.display()))?;
    super::print_stdout(&format!(
        "wrote the survey of {} (seed {}, site.layout {:?}) to {}",
        scenario.name,
        config.seed,
        config.site_layout,
        args.out.display()
    ))
}
