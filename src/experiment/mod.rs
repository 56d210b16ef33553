//! `rodlog experiment NAME`: the paper's evaluations and ours (ARCHITECTURE.md section 7), each
//! writing `DIR/report.md`, `DIR/results.json` and plots (PNG + SVG) under `DIR/plots/`.
//!
//! Table of contents:
//! - [`Settings`]: what every experiment gets from the command line (trials, seed, output
//!   folder, image scale, whether to run the OpenCV reference) and [`trial_seed`].
//! - [`OutputDir`]: the output folder and its `plots/` and `images/` subfolders.
//! - [`report`]: markdown [`report::Table`] and [`report::Report`], [`report::Results`]
//!   for `results.json` (version, seeds, parameters, every table number, exact floats).
//! - [`stats`]: [`stats::Summary`] (median, quartiles, mean, p95; deterministic) and
//!   [`stats::RefusalCounter`] (refusals per condition and method, shown, never dropped).
//! - [`progress`]: [`progress::Progress`], an indicatif bar on stderr, hidden off a terminal.
//! - Plots: `viz::plots` (box plots per condition and method, line plots, bar charts).
//! - Experiments: [`matchers`] (feature matchers on pairs with known geometry), [`noise`],
//!   [`motions`], [`datasets`] (hand-eye calibration: the paper, ours, ZHI), [`ablation`]
//!   (from the paper's method to ours, one step at a time), [`tasks`],
//!   [`light`], [`wind`], [`maintenance`] (the task experiments: simulated runs through the
//!   recording pipeline, [`task_runs`], judged with the simulator's truth).
//!
//! # Writing an experiment
//! A module with `pub fn run(settings: &Settings) -> anyhow::Result<()>` that
//! 1. derives every trial's seed with [`trial_seed`] and records them in
//!    [`report::Results::seeds`],
//! 2. runs trials (rayon is fine: collect results in trial order, not completion order),
//!    ticking a [`progress::Progress`], counting failures in a [`stats::RefusalCounter`],
//! 3. summarises with [`stats::Summary::of`], fills a [`report::Report`] (tables, the
//!    refusal counts, plots from `viz::plots` written into [`OutputDir::plots`]) and a
//!    [`report::Results`] with the same numbers, and writes both into [`OutputDir::root`],
//! 4. prints the path of `report.md` (stdout is for the result, the bar is on stderr).
//!
//! Then add one arm to the `match` in `src/cmd/experiment.rs`.

pub mod ablation;
pub mod datasets;
pub mod light;
pub mod maintenance;
pub mod matchers;
pub mod motions;
pub mod noise;
pub mod photos;
pub mod progress;
pub mod report;
pub mod selfcal_peer;
pub mod shard;
pub mod stats;
pub mod task_runs;
pub mod tasks;
pub mod wind;

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};

/// What every experiment gets from `rodlog experiment NAME [--trials N] [--out DIR] [--seed
/// S] [--image-scale F] [--no-reference]`.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    /// The experiment's name (`matchers`, `noise`, ...).
    pub name: &'static str,
    /// `--trials`: the number of seeded trials per condition, `None` for the experiment's
    /// own default (the paper's count, e.g. 100). CI passes 2.
    pub trials: Option<usize>,
    /// `--seed`: the seed every trial seed derives from ([`trial_seed`]).
    pub seed: u64,
    /// `--image-scale`: factor on image sizes (rendered or loaded), 1.0 = the experiment's
    /// full resolution; CI smoke runs use a small value (e.g. 0.25) to stay fast in debug.
    pub image_scale: f64,
    /// Run the optional OpenCV reference columns when its venv exists ([`reference_python`]);
    /// `--no-reference` turns them off.
    pub reference: bool,
    /// `--orb-distribution`: the ORB keypoint selection of our self-calibration in the
    /// calibration experiments, `None` for ours' own ([`Settings::ours_distribution`]).
    pub orb_distribution: Option<calib::features::KeypointDistribution>,
    /// `--with STEP` / `--without STEP`: our self-calibration's steps in the calibration
    /// experiments (noise, motions, datasets), `None` for [`calib::selfcal::Steps::ours`].
    pub steps: Option<calib::selfcal::Steps>,
    /// `--speeds`: the wind experiment's mean speeds (m/s), `None` for its own list.
    pub speeds_mps: Option<Vec<f64>>,
    /// `--hours`: the light experiment's hours, `None` for its own list.
    pub hours: Option<Vec<f64>>,
    /// `--sites seeded`: the task experiments run on seeded bays with a survey each.
    pub seeded_sites: bool,
    /// `--wrist-light on`: the light experiment's robot has a wrist light.
    pub wrist_light: bool,
    /// `--scene photos`: the noise experiment's views are of a wall of photographs
    /// ([`photos`]) instead of the substation's calibration cabinet.
    pub photo_scene: bool,
    /// `--keep-failed`: the task experiments keep the recordings of the runs that did not
    /// succeed.
    pub keep_failed: bool,
    /// `matchers`: draw the match pictures (`--no-pictures` leaves them out).
    pub pictures: bool,
    /// The output folder (created).
    pub out: OutputDir,
    /// All items, one shard of them, or the records of merged shards ([`shard`]).
    pub mode: shard::Mode,
    /// The options that decide the items and the numbers, as JSON (kept in a shard file).
    pub arguments: String,
}

impl Settings {
    /// Our self-calibration's keypoint selection: `--orb-distribution`, else ours' own.
    pub fn ours_distribution(&self) -> calib::features::KeypointDistribution {
        self.orb_distribution
            .unwrap_or(calib::selfcal::SelfCalMethod::Ours.keypoint_distribution())
    }

    /// The report's line on how "ours" differs from the default self-calibration
    /// (`--orb-distribution`, `--with`, `--without`), `None` when it does not.
    pub fn ours_variant_note(&self) -> Option<String> {
        let mut parts = Vec::new();
        if self.ours_distribution() != calib::selfcal::SelfCalMethod::Ours.keypoint_distribution() {
            parts.push(format!(
                "ORB keypoints by {}",
                self.ours_distribution().name()
            ));
        }
        let changed = self.steps_changed();
        if !changed.is_empty() {
            parts.push(format!("steps {}", changed.join(" ")));
        }
        (!parts.is_empty()).then(|| {
            format!(
                "**Ours is not the default here:** {} (`--orb-distribution`, `--with`, `--without`).",
                parts.join("; ")
            )
        })
    }

    /// The steps `--with` / `--without` changed from [`calib::selfcal::Steps::ours`], as
    /// `+name` / `-name` in pipeline order (empty for ours as it is).
    pub fn steps_changed(&self) -> Vec<String> {
        let ours = calib::selfcal::Steps::ours();
        let Some(steps) = self.steps else {
            return Vec::new();
        };
        calib::selfcal::STEP_NAMES
            .iter()
            .filter_map(|name| {
                let on = steps.is_on(name).ok()?;
                (ours.is_on(name).ok()? != on)
                    .then(|| format!("{}{name}", if on { '+' } else { '-' }))
            })
            .collect()
    }

    /// The `sites` parameter of the task experiments' results.
    pub fn sites_label(&self) -> &'static str {
        if self.seeded_sites {
            "seeded, with a survey"
        } else {
            "fixed"
        }
    }

    /// The task experiments' reports say on which bays they ran.
    pub fn sites_sentence(&self) -> &'static str {
        if self.seeded_sites {
            "Sites: a bay drawn from each trial's seed, the robot given the simulated crew's survey of it (`rodlog survey`)."
        } else {
            "Sites: the fixed bay, whose map the robot has built in."
        }
    }

    /// `--trials` or the experiment's `default`, at least 1.
    pub fn trials_or(&self, default: usize) -> usize {
        self.trials.unwrap_or(default).max(1)
    }

    /// The conditions of a sweep: `given` (`--speeds`, `--hours`) or the experiment's `own`
    /// list, each with the seed stream of its trials. A value of the own list keeps its
    /// stream `base + index` (the same trials with or without the flag); any other value gets
    /// a stream of its own from its millesimal value.
    pub fn sweep(given: Option<&[f64]>, own: &[f64], base: u64) -> Vec<(f64, u64)> {
        given
            .unwrap_or(own)
            .iter()
            .map(|v| {
                let stream = own
                    .iter()
                    .position(|o| o == v)
                    .map_or(10_000 + (v * 1000.0).round() as u64, |k| base + k as u64);
                (*v, stream)
            })
            .collect()
    }

    /// The records of the experiment's `items`, run as [`Settings::mode`] says
    /// ([`shard::run_items`]): `run` gets the indices to run and returns their records.
    /// `None` for a shard run, which then ends without a report.
    ///
    /// # Errors
    /// `run`'s errors; merged records that do not fit.
    pub fn run_items<R, F>(&self, items: usize, run: F) -> Result<Option<Vec<R>>>
    where
        R: serde::Serialize + serde::de::DeserializeOwned,
        F: FnOnce(&[usize]) -> Result<Vec<R>>,
    {
        shard::run_items(
            &self.mode,
            self.name,
            &self.arguments,
            items,
            self.out.root(),
            run,
        )
    }

    /// Writes `results.json`; a merged run adds a `shards` section (each shard's wall time
    /// and folder: the timing fields that stay per shard).
    ///
    /// # Errors
    /// Serialisation or file system errors.
    pub fn write_results(&self, results: &report::Results) -> Result<PathBuf> {
        let mut results = results.clone();
        if let shard::Mode::Merged(m) = &self.mode {
            let shards: Vec<serde_json::Value> = m
                .shards
                .iter()
                .map(|(s, wall_s, dir)| {
                    serde_json::json!({
                        "shard": s.to_string(),
                        "wall_s": wall_s,
                        "folder": dir.display().to_string(),
                    })
                })
                .collect();
            results.section("shards", shards)?;
        }
        results.write(self.out.root())
    }
}

/// Seed of trial `trial` of set `set` (e.g. a condition index) under the run seed `seed`:
/// `sim::rng::key(seed, set, trial)` (SplitMix64 mixing), so trials are independent of each
/// other, of the order they run in and of the thread count, and any one of them can be rerun
/// alone from the seed in `results.json`.
pub fn trial_seed(seed: u64, set: u64, trial: u64) -> u64 {
    sim::rng::key(seed, set, trial)
}

/// The output folder of a run: `root/report.md`, `root/results.json`, `root/plots/*.{png,svg}`,
/// `root/images/*.png` (example pictures, e.g. match drawings).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct OutputDir {
    root: PathBuf,
}

impl OutputDir {
    /// Creates `root`, `root/plots` and `root/images` (existing files in them are
    /// overwritten by the run, others are left alone).
    ///
    /// # Errors
    /// When a folder cannot be created (e.g. `root` is a file).
    pub fn create(root: &Path) -> Result<Self> {
        for d in [root.to_path_buf(), root.join("plots"), root.join("images")] {
            std::fs::create_dir_all(&d)
                .with_context(|| format!("creating output folder {}", d.display()))?;
        }
        Ok(Self {
            root: root.to_path_buf(),
        })
    }

    /// The folder itself (report.md and results.json go here).
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// `root/plots/STEM` (no extension: `viz::plots` writers add `.png` and `.svg`).
    pub fn plot_stem(&self, stem: &str) -> PathBuf {
        self.root.join("plots").join(stem)
    }

    /// `root/images/NAME`.
    pub fn image(&self, name: &str) -> PathBuf {
        self.root.join("images").join(name)
    }

    /// `path` relative to the root, with `/` separators, for links in report.md (the path
    /// itself when it is not under the root).
    pub fn relative(&self, path: &Path) -> String {
        let p = path.strip_prefix(&self.root).unwrap_or(path);
        p.components()
            .map(|c| c.as_os_str().to_string_lossy().into_owned())
            .collect::<Vec<_>>()
            .join("/")
    }
}

/// The Python of the OpenCV reference venv (`scripts/venv.sh`), if there is one: the
/// `RODLOG_REF_VENV` environment variable, else `.venv-ref` in the current folder, else in
/// the source tree the binary was built from. `None` when none holds `bin/python`.
pub fn reference_python() -> Option<PathBuf> {
    let mut roots: Vec<PathBuf> = Vec::new();
    if let Some(v) = std::env::var_os("RODLOG_REF_VENV") {
        roots.push(PathBuf::from(v));
    }
    roots.push(PathBuf::from(".venv-ref"));
    roots.push(Path::new(env!("CARGO_MANIFEST_DIR")).join(".venv-ref"));
    roots
        .into_iter()
        .map(|r| r.join("bin").join("python"))
        .find(|p| p.is_file())
}

/// A script of the source tree (`scripts/...`), for the reference columns; `None` when the
/// binary runs away from its source tree.
pub fn source_script(relative: &str) -> Option<PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join(relative);
    p.is_file().then_some(p)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A value of the own list keeps its stream; other values get distinct streams of their
    /// own, outside the own list's.
    #[test]
    fn sweeps_keep_the_own_lists_streams() {
        let own = [0.0, 0.5, 2.5, 3.0];
        assert_eq!(
            Settings::sweep(None, &own, 200),
            vec![(0.0, 200), (0.5, 201), (2.5, 202), (3.0, 203)]
        );
        let given = [3.0, 3.5, 4.0];
        let s = Settings::sweep(Some(&given), &own, 200);
        assert_eq!(s[0], (3.0, 203));
        assert_eq!((s[1].1, s[2].1), (13_500, 14_000));
    }

    #[test]
    fn trial_seeds_differ_and_are_stable() {
        assert_eq!(trial_seed(1, 0, 0), trial_seed(1, 0, 0));
        assert_ne!(trial_seed(1, 0, 0), trial_seed(1, 0, 1));
        assert_ne!(trial_seed(1, 0, 0), trial_seed(1, 1, 0));
        assert_ne!(trial_seed(1, 0, 0), trial_seed(2, 0, 0));
    }

    #[test]
    fn output_dir_makes_subfolders_and_relative_links() {
        let tmp = tempfile::tempdir().expect("tempdir");
        let out = OutputDir::create(&tmp.path().join("x")).expect("create");
        assert!(out.root().join("plots").is_dir() && out.root().join("images").is_dir());
        assert_eq!(
            out.relative(&out.plot_stem("a").with_extension("png")),
            "plots/a.png"
        );
    }
}
