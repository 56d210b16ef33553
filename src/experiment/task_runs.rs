//! Simulated task runs for the `tasks`, `light`, `wind` and `maintenance` experiments: one
//! scenario per run, recorded through the very pipeline `rodlog record` uses (the simulator,
//! `robot_state`, `calibration`, `task`), then judged by [`crate::judge`] against the
//! simulator's truth. The recording is written to a temporary file and deleted (kept with
//! `keep`), so a failed run can be replayed and looked at.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use recorder::{ChunkCompression, RecordOptions, SinkOptions};
use serde::{Deserialize, Serialize};

use compose::judge::{Verdict, judge};

/// One run's conditions.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunSpec {
    /// Condition label (for tables).
    pub condition: String,
    /// `hang`, `remove` or `check`.
    pub task: String,
    /// World seed.
    pub seed: u64,
    /// Local solar hour at the start.
    pub hour: f64,
    /// Mean of the 3-s mean wind (m/s).
    pub wind_mps: f64,
    /// Camera-mount bump at 0.5 s: `(rotation deg, translation mm)`; `None`: no bump. A
    /// value of NaN is drawn from the seed (ARCHITECTURE.md section 6: 1-3 deg, 3-10 mm).
    pub bump: Option<(f64, f64)>,
    /// The task checks (and repairs) its calibration before operating.
    pub self_maintenance: bool,
    /// Wrist camera resolution factor of 1280x1024.
    pub camera_scale: f64,
    /// Robot time to simulate (s).
    pub duration_s: f64,
    /// The bay is drawn from the seed (`site.layout = "seeded"`) and the robot gets the
    /// simulated crew's survey of it (`sim::survey`); false: the fixed bay, whose map the
    /// robot has built in.
    #[serde(default)]
    pub seeded_site: bool,
    /// The robot has a wrist light (`camera.light`), which its task lights at dusk.
    #[serde(default)]
    pub wrist_light: bool,
    /// The scenario's `noise_seed` (sensor noise, gusts: another day of the same robot and
    /// bay); `None`: the seed's.
    #[serde(default)]
    pub noise_seed: Option<u64>,
    /// A run of the same robot before this one, whose calibration this one starts from
    /// (`rodlog calib carry`: the camera edge and the drift check reference it left).
    #[serde(default)]
    pub earlier_run: Option<Box<RunSpec>>,
    /// The parameters carried from [`Self::earlier_run`] (`[parameters]` lines), filled in by
    /// [`run_selected`] once that run is done; `None` when it left nothing to carry.
    #[serde(default)]
    pub carried: Option<String>,
}

impl RunSpec {
    /// The scenario file of the run.
    #[must_use]
    pub fn scenario_toml(&self) -> String {
        let noise_seed = self
            .noise_seed
            .map_or_else(String::new, |n| format!("noise_seed = {n}\n"));
        let mut t = format!(
            "name = \"{task}-{seed}\"\nseed = {seed}\n{noise_seed}duration_s = {dur:?}\nhour = {hour:?}\ntask = \"{task}\"\n\n[wind]\nmean_mps = {wind:?}\n",
            task = self.task,
            seed = self.seed,
            dur = self.duration_s,
            hour = self.hour,
            wind = self.wind_mps,
        );
        if let Some((rot, trans)) = self.bump {
            t.push_str("\n[bump]\ntime_s = 0.5\n");
            if rot.is_finite() {
                t.push_str(&format!("rot_deg = {rot:?}\n"));
            }
            if trans.is_finite() {
                t.push_str(&format!("trans_mm = {trans:?}\n"));
            }
        }
        if self.task == "remove" {
            t.push_str("\n[robot]\nrod = \"hung\"\n");
        }
        if self.seeded_site {
            t.push_str("\n[site]\nlayout = \"seeded\"\n");
        }
        t.push_str(&format!(
            "\n[camera]\nscale = {:?}\n{}\n[panoramic]\nperiod_s = 1.0\n\n[parameters]\ntask.self_maintenance = {}\n",
            self.camera_scale,
            if self.wrist_light { "light = true\n" } else { "" },
            self.self_maintenance
        ));
        if let Some(carried) = &self.carried {
            t.push_str(carried);
        }
        t
    }
}

/// One run's result.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct RunResult {
    /// What was run.
    pub spec: RunSpec,
    /// The judge's verdict.
    pub verdict: Verdict,
    /// Wall time of the simulation (s).
    pub wall_s: f64,
    /// The recording, when kept.
    pub recording: Option<PathBuf>,
}

/// Records and judges one run in `dir` (module docs); the recording is deleted unless `keep`
/// says to keep it.
///
/// # Errors
/// Scenario, pipeline, simulator and recording errors (a task refusing or failing is a
/// result, not an error).
pub fn run(spec: &RunSpec, dir: &Path, keep: Keep) -> Result<RunResult> {
    let (out, wall_s) = record(spec, dir)?;
    let verdict = judge(&out)?;
    let recording = if keep == Keep::Failed && !verdict.success {
        Some(out)
    } else {
        std::fs::remove_file(&out).with_context(|| format!("removing {}", out.display()))?;
        None
    };
    Ok(RunResult {
        spec: spec.clone(),
        verdict,
        wall_s,
        recording,
    })
}

/// Records an earlier run ([`RunSpec::earlier_run`]) in `dir` and returns what it leaves for
/// the next run (`rodlog calib carry`), `None` when nothing; the recording is deleted.
///
/// # Errors
/// Those of [`run`], and an unreadable recording.
pub fn carry_of(spec: &RunSpec, dir: &Path) -> Result<Option<String>> {
    let (out, _) = record(spec, dir)?;
    let carried = crate::cmd::calib::read_carry(&out)?
        .finish()
        .map(|c| c.parameters_toml());
    std::fs::remove_file(&out).with_context(|| format!("removing {}", out.display()))?;
    Ok(carried)
}

/// Records `spec` in `dir`: the recording's path and the wall time (s).
fn record(spec: &RunSpec, dir: &Path) -> Result<(PathBuf, f64)> {
    let text = spec.scenario_toml();
    let origin = format!("{}-{}", spec.task, spec.seed);
    let mut scenario = scenario::Scenario::parse(&text, &origin)
        .with_context(|| format!("scenario of run {origin}"))?;
    if spec.seeded_site {
        // The crew's survey of the seeded bay, given to the robot as a site file would be.
        let config = sim::SimConfig::of_scenario(&scenario)?;
        let (_, layout) = sim::world::site(&config)?;
        let survey = sim::survey::survey(&layout, config.seed).map_err(anyhow::Error::msg)?;
        scenario
            .apply_site_text(&survey.to_site_file(), &format!("survey of run {origin}"))
            .with_context(|| format!("survey of run {origin}"))?;
    }
    let plan =
        compose::Plan::new(&scenario).with_context(|| format!("scenario of run {origin}"))?;
    let out = dir.join(format!(
        "{}-{}-{}-{}.mcap",
        spec.condition.replace([' ', '/'], "_"),
        spec.task,
        spec.seed,
        spec.noise_seed.unwrap_or(spec.seed)
    ));
    let options = RecordOptions {
        out: out.clone(),
        sink: SinkOptions {
            compression: ChunkCompression::Lz4,
            ..SinkOptions::default()
        },
        realtime: false,
        threads: Some(1),
        stop: plan.task_end(),
    };
    let started = std::time::Instant::now();
    compose::record(&plan, &options, Vec::new())?;
    Ok((out, started.elapsed().as_secs_f64()))
}

/// Which runs' recordings [`run`] keeps.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Keep {
    /// None (the experiments' default).
    None,
    /// Those of the runs that did not succeed (`--keep-failed`).
    Failed,
}

/// A trial seed as a scenario seed: TOML integers are `i64`, so the top bit is dropped.
#[must_use]
pub fn world_seed(trial_seed: u64) -> u64 {
    trial_seed & (i64::MAX as u64)
}

/// Runs every spec (in parallel; results in spec order, whatever the thread count),
/// ticking `progress` once per run.
///
/// The runs go to plain worker threads (as many as rayon's global pool has) pulling from a
/// shared index, not to rayon: each run installs its own single-thread pool
/// ([`RecordOptions::threads`]), and `install` called from a worker of another pool makes that
/// worker steal further runs while it waits, stacking whole simulations on one thread's stack
/// until it overflows (seen at 200 runs).
///
/// # Errors
/// The first run (in spec order) that could not be simulated.
pub fn run_all(
    specs: &[RunSpec],
    dir: &Path,
    keep: Keep,
    progress: &super::progress::Progress,
) -> Result<Vec<RunResult>> {
    in_parallel(specs, progress, |spec| run(spec, dir, keep))
}

/// `each` of `specs` on plain worker threads ([`run_all`]), results in spec order.
fn in_parallel<T: Send>(
    specs: &[RunSpec],
    progress: &super::progress::Progress,
    each: impl Fn(&RunSpec) -> Result<T> + Sync,
) -> Result<Vec<T>> {
    use std::sync::Mutex;
    use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
    let next = AtomicUsize::new(0);
    let failed = AtomicBool::new(false);
    let results: Mutex<Vec<Option<Result<T>>>> =
        Mutex::new((0..specs.len()).map(|_| None).collect());
    let workers = rayon::current_num_threads().clamp(1, specs.len().max(1));
    std::thread::scope(|scope| {
        for _ in 0..workers {
            scope.spawn(|| {
                while !failed.load(Ordering::Relaxed) {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(spec) = specs.get(i) else { break };
                    let r = each(spec);
                    if r.is_err() {
                        failed.store(true, Ordering::Relaxed);
                    }
                    progress.inc(1);
                    if let Ok(mut slots) = results.lock() {
                        slots[i] = Some(r);
                    }
                }
            });
        }
    });
    let slots = results
        .into_inner()
        .map_err(|_| anyhow::anyhow!("a run's worker thread panicked"))?;
    let mut out = Vec::with_capacity(specs.len());
    for (spec, slot) in specs.iter().zip(slots) {
        match slot {
            Some(r) => out.push(r?),
            // Indices are claimed in order and every claimed run finishes, so a gap only
            // follows the failure that stopped the workers, which `r?` has returned.
            None => anyhow::bail!(
                "run {} {} seed {} was not simulated because another run failed",
                spec.condition,
                spec.task,
                spec.seed
            ),
        }
    }
    Ok(out)
}

/// Outcome counts and times of a group of runs.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct GroupSummary {
    /// The group (condition) label.
    pub condition: String,
    /// Runs.
    pub runs: usize,
    /// Runs that ended DONE with the rod where the task wanted it and no unsafe command
    /// (judged with truth).
    pub success: usize,
    /// Runs the robot refused (a safety gate or an unverifiable state), by the robot's word.
    pub refused: usize,
    /// Runs that failed (a miss, a timeout) or ended DONE but were judged unsuccessful.
    pub failed: usize,
    /// Unsafe commands over the group (judged with truth).
    pub unsafe_commands: usize,
    /// `success / runs`.
    pub success_rate: f64,
    /// Wilson 95% interval of `success_rate` ([`super::stats::wilson_95`]).
    pub success_rate_95: (f64, f64),
    /// Median operation time of the successful runs (s).
    pub median_s: f64,
    /// Longest operation time of any run that ended (s).
    pub max_s: f64,
    /// Runs whose operation took 300 s or more.
    pub over_5_min: usize,
    /// End reasons (`reason_code`) with counts.
    pub reasons: std::collections::BTreeMap<String, usize>,
    /// Median fraction of the hook's capture window used (successful hangs).
    pub median_hook_fraction: f64,
}

/// Successes and runs pooled over the groups whose condition value (`values[k]` for
/// `groups[k]`) `inside` accepts, and over the others: `((ok, runs) inside, (ok, runs)
/// outside)`.
pub fn pooled_split(
    values: &[(f64, u64)],
    groups: &[GroupSummary],
    inside: impl Fn(f64) -> bool,
) -> ((usize, usize), (usize, usize)) {
    let (mut a, mut b) = ((0, 0), (0, 0));
    for ((v, _), g) in values.iter().zip(groups) {
        let pool = if inside(*v) { &mut a } else { &mut b };
        pool.0 += g.success;
        pool.1 += g.runs;
    }
    (a, b)
}

/// `"ok/runs (p%)"`.
pub fn fmt_share((ok, runs): (usize, usize)) -> String {
    format!(
        "{ok}/{runs} ({})",
        super::report::fmt_pct(ok as f64 / runs.max(1) as f64, 0)
    )
}

/// Runs `specs` as `settings.mode` says (all, one shard, or none for merged shards) with a
/// progress bar named `name`; `None` for a shard run.
///
/// # Errors
/// Those of [`run_all`] and [`runs_dir`].
pub fn run_selected(
    settings: &super::Settings,
    name: &str,
    specs: &[RunSpec],
) -> Result<Option<Vec<RunResult>>> {
    settings.run_items(specs.len(), |ids| {
        let mut chosen: Vec<RunSpec> = ids.iter().filter_map(|&i| specs.get(i).cloned()).collect();
        // The earlier runs the chosen ones start from, each once, before them; told apart by
        // their JSON (a NaN bump, drawn from the seed, is not equal to itself).
        let key = |s: &RunSpec| serde_json::to_string(s).unwrap_or_default();
        let mut earlier: Vec<RunSpec> = Vec::new();
        for e in chosen.iter().filter_map(|s| s.earlier_run.as_deref()) {
            if !earlier.iter().any(|x| key(x) == key(e)) {
                earlier.push(e.clone());
            }
        }
        let progress = super::progress::Progress::new(name, (chosen.len() + earlier.len()) as u64);
        let keep = if settings.keep_failed {
            Keep::Failed
        } else {
            Keep::None
        };
        let dir = runs_dir(&settings.out)?;
        let carried = in_parallel(&earlier, &progress, |spec| carry_of(spec, &dir))?;
        for spec in &mut chosen {
            if let Some(e) = spec.earlier_run.as_deref() {
                spec.carried = earlier
                    .iter()
                    .position(|x| key(x) == key(e))
                    .and_then(|i| carried[i].clone());
            }
        }
        let results = run_all(&chosen, &dir, keep, &progress);
        progress.finish();
        results
    })
}

/// Runs `specs` (conditions in blocks of `trials`, as the experiments build them) with
/// [`run_selected`], and summarises each condition in order; `None` for a shard run.
///
/// # Errors
/// Those of [`run_selected`].
pub fn run_conditions(
    settings: &super::Settings,
    name: &str,
    specs: &[RunSpec],
    trials: usize,
) -> Result<Option<(Vec<RunResult>, Vec<GroupSummary>)>> {
    let Some(results) = run_selected(settings, name, specs)? else {
        return Ok(None);
    };
    let groups = specs
        .iter()
        .step_by(trials.max(1))
        .map(|s| {
            let runs: Vec<_> = results
                .iter()
                .filter(|r| r.spec.condition == s.condition)
                .collect();
            summarize(&s.condition, &runs)
        })
        .collect();
    Ok(Some((results, groups)))
}

/// Summarises `runs` under `condition`.
#[must_use]
pub fn summarize(condition: &str, runs: &[&RunResult]) -> GroupSummary {
    let mut g = GroupSummary {
        condition: condition.to_owned(),
        runs: runs.len(),
        ..GroupSummary::default()
    };
    let mut times = Vec::new();
    let mut hooks = Vec::new();
    for r in runs {
        let v = &r.verdict;
        g.unsafe_commands += v.unsafe_commands.len();
        if v.success {
            g.success += 1;
            if let Some(t) = v.operation_s {
                times.push(t);
            }
            if let Some(h) = v.hook {
                hooks.push(h.window_fraction);
            }
        } else if v.outcome == "refused" {
            g.refused += 1;
        } else {
            g.failed += 1;
        }
        if let Some(t) = v.operation_s {
            g.max_s = g.max_s.max(t);
            if t >= 300.0 {
                g.over_5_min += 1;
            }
        }
        let reason = if v.success {
            "done".to_owned()
        } else if v.reason_code.is_empty() || v.reason_code == "done" {
            format!("{} ({})", v.outcome, v.rod_state)
        } else {
            v.reason_code.clone()
        };
        *g.reasons.entry(reason).or_insert(0) += 1;
    }
    g.success_rate = if g.runs == 0 {
        f64::NAN
    } else {
        g.success as f64 / g.runs as f64
    };
    g.success_rate_95 = super::stats::wilson_95(g.success, g.runs);
    g.median_s = super::stats::Summary::of(&times).median;
    g.median_hook_fraction = super::stats::Summary::of(&hooks).median;
    g
}

/// The outcome table of `groups`.
#[must_use]
pub fn outcome_table(first_column: &str, groups: &[GroupSummary]) -> super::report::Table {
    use super::report::{Table, fmt_num, fmt_pct};
    let mut t = Table::new(&[
        first_column,
        "runs",
        "success",
        "rate",
        "95% interval (Wilson)",
        "refused",
        "failed",
        "unsafe",
        "median time (s)",
        "max time (s)",
        ">= 5 min",
        "reasons",
    ]);
    for g in groups {
        let reasons: Vec<String> = g.reasons.iter().map(|(k, v)| format!("{k} {v}")).collect();
        t.row(vec![
            g.condition.clone(),
            g.runs.to_string(),
            g.success.to_string(),
            fmt_pct(g.success_rate, 0),
            format!(
                "{} - {}",
                fmt_pct(g.success_rate_95.0, 0),
                fmt_pct(g.success_rate_95.1, 0)
            ),
            g.refused.to_string(),
            g.failed.to_string(),
            g.unsafe_commands.to_string(),
            fmt_num(g.median_s, 1),
            fmt_num(g.max_s, 1),
            g.over_5_min.to_string(),
            reasons.join(", "),
        ]);
    }
    t
}

/// A temporary folder for the runs' recordings, inside the experiment's output folder.
///
/// # Errors
/// File system errors.
pub fn runs_dir(out: &super::OutputDir) -> Result<PathBuf> {
    let dir = out.root().join("runs");
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    Ok(dir)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A later day of a robot: its scenario has the world's seed, its own noise seed and the
    /// parameters carried from the earlier run, and the simulator and stages read them.
    #[test]
    fn a_later_days_scenario_carries_its_noise_seed_and_parameters() {
        let spec = RunSpec {
            condition: "trans 3 mm".into(),
            task: "check".into(),
            seed: 21,
            hour: 10.0,
            wind_mps: 0.5,
            bump: Some((0.0, 3.0)),
            self_maintenance: true,
            camera_scale: 0.25,
            duration_s: 60.0,
            seeded_site: true,
            wrist_light: false,
            noise_seed: Some(9_007_199_254_740_993),
            earlier_run: None,
            carried: Some(
                "calibration.mount_xyz_m = [0.06, -0.04, 0.09]\n\
                 calibration.mount_rpy_deg = [0.5, -1.1, 90.0]\n\
                 calibration.reference_xyz_m = [0.0601, -0.04, 0.09]\n\
                 calibration.reference_rpy_deg = [0.5, -1.1, 90.0]\n"
                    .into(),
            ),
        };
        let text = spec.scenario_toml();
        let scenario = scenario::Scenario::parse(&text, "t").expect("a scenario");
        assert_eq!(scenario.seed, 21);
        let sim = sim::SimConfig::of_scenario(&scenario).expect("sim config");
        assert_eq!(sim.noise_seed, 9_007_199_254_740_993, "{text}");
        let mut r = scenario::Reader::new(&scenario.params);
        let c = calib::selfcal::CalibrationStageConfig::from_params(&mut r, 0).expect("stage");
        let reference = c.check_reference.expect("the carried reference");
        assert!((reference.translation.x - 0.0601).abs() < 1e-12, "{text}");
    }
}
