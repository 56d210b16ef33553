//! `rodlog experiment maintenance` (ARCHITECTURE.md section 7; not in the paper): how well the
//! robot notices that its camera mount has moved, per bump size, and how often it raises a
//! false alarm.
//!
//! Each run is the `check` task: the drift check views of the calibration target (the
//! calibration stage's [`calib::selfcal`] drift check on `CHECK_MOTION` views) after a
//! bump at 0.5 s of a set size, direction drawn from the seed: rotation-only bins, translation
//! -only bins and combined bins spanning 0.25-3 deg and 1-10 mm, and unbumped runs for the
//! false alarms. Detected = the verdict `drifted`; "cannot tell" is counted on its own (a
//! refusal to judge, not a detection). A check whose four views are `unresolved` takes four
//! more; the table gives the verdict of the four beside the final one. Goal: >= 95 % detected in every bin at
//! >= 0.5 deg or >= 3 mm, <= 5 % false alarms, >= 50 runs each.
//!
//! **Robots and days.** Trial `t` is one robot (a world seed: the bay, the arm's kinematic
//! error, the cameras' calibration errors) checked once per bin, each run on a day of its own
//! (the scenario's `noise_seed`: sensor noise, hour, wind). Before its bins, the robot runs one
//! unbumped check on yet another day (its [`RunSpec::earlier_run`]), and every bin's run starts
//! from what that run left, as `rodlog calib carry` writes it: the camera edge and, when that
//! check found the mount consistent, the drift check reference the later checks compare with
//! (the calibration stage's module docs). So the table measures the check as a field engineer
//! runs it, and a robot whose reference run could not tell checks against its camera edge.

use anyhow::Result;
use serde::Serialize;

use super::report::{Report, Results, Table, fmt_pct};
use super::task_runs::{RunSpec, run_selected, world_seed};
use super::{Settings, trial_seed};

/// Runs per bin when `--trials` is not given.
pub const DEFAULT_TRIALS: usize = 50;
/// The bins: `(label, rotation deg, translation mm)`; `(0, 0)` = unbumped.
pub const BINS: [(&str, f64, f64); 13] = [
    ("none", 0.0, 0.0),
    ("rot 0.25 deg", 0.25, 0.0),
    ("rot 0.5 deg", 0.5, 0.0),
    ("rot 1 deg", 1.0, 0.0),
    ("rot 2 deg", 2.0, 0.0),
    ("rot 3 deg", 3.0, 0.0),
    ("trans 1 mm", 0.0, 1.0),
    ("trans 3 mm", 0.0, 3.0),
    ("trans 5 mm", 0.0, 5.0),
    ("trans 10 mm", 0.0, 10.0),
    ("0.5 deg + 3 mm", 0.5, 3.0),
    ("1 deg + 5 mm", 1.0, 5.0),
    ("3 deg + 10 mm", 3.0, 10.0),
];

/// One bin's counts.
#[derive(Clone, Debug, Default, Serialize)]
pub struct BinResult {
    /// Label.
    pub bin: String,
    /// Rotation (deg).
    pub rot_deg: f64,
    /// Translation (mm).
    pub trans_mm: f64,
    /// Runs.
    pub runs: usize,
    /// Verdict `drifted`.
    pub drifted: usize,
    /// Verdict `consistent`.
    pub consistent: usize,
    /// Verdict `cannot_tell` or `unresolved`, after the extra views when the first four were
    /// unresolved.
    pub cannot_tell: usize,
    /// Runs that ended before the check answered (the task refused earlier, e.g. a drive
    /// that found its way blocked), by the task's reason code: not a verdict of the check.
    pub not_checked: std::collections::BTreeMap<String, usize>,
    /// The first four views' verdict was not `drifted` or `consistent` (what the check would
    /// say without its four extra views).
    pub first_cannot_tell: usize,
    /// The first four views were `unresolved`, and the check took four more.
    pub extended: usize,
    /// Runs that started from a drift check reference their robot's reference run left
    /// (the others check against the camera edge itself).
    pub from_reference: usize,
    /// `drifted / checked` (the detection rate; for the unbumped bin, the false-alarm rate),
    /// over the runs the check answered.
    pub rate: f64,
    /// Wilson 95% interval of `rate` ([`super::stats::wilson_95`]).
    pub rate_95: (f64, f64),
    /// Whether the bin is one the goal applies to (>= 0.5 deg or >= 3 mm).
    pub goal_applies: bool,
}

impl BinResult {
    /// Runs the check answered.
    pub fn checked(&self) -> usize {
        self.drifted + self.consistent + self.cannot_tell
    }

    /// The runs that never reached the check, e.g. `1 (drive_blocked)`.
    fn not_checked_cell(&self) -> String {
        let n: usize = self.not_checked.values().sum();
        if n == 0 {
            return "0".into();
        }
        let why: Vec<String> = self
            .not_checked
            .iter()
            .map(|(code, k)| format!("{k} {code}"))
            .collect();
        format!("{n} ({})", why.join(", "))
    }
}

/// Runs the experiment (module docs).
///
/// # Errors
/// Simulation, judging, plotting or writing failures.
pub fn run(settings: &Settings) -> Result<()> {
    let trials = settings.trials_or(DEFAULT_TRIALS);
    let camera_scale = super::tasks::CAMERA_SCALE * settings.image_scale;
    let mut specs = Vec::new();
    let mut seeds = Vec::new();
    // Trial-major, so that the runs of one robot follow its reference run.
    for t in 0..trials {
        let seed = world_seed(trial_seed(settings.seed, 300, t as u64));
        seeds.push(seed);
        let day = |noise_seed: u64| RunSpec {
            condition: "reference".to_owned(),
            task: "check".into(),
            seed,
            hour: 9.0 + 6.0 * sim::rng::uniform(noise_seed, 0x3A1, 0),
            wind_mps: 1.0 * sim::rng::uniform(noise_seed, 0x3A1, 1),
            bump: None,
            self_maintenance: true,
            camera_scale,
            duration_s: 60.0,
            seeded_site: settings.seeded_sites,
            wrist_light: false,
            noise_seed: Some(noise_seed),
            earlier_run: None,
            carried: None,
        };
        let reference = day(world_seed(trial_seed(settings.seed, 299, t as u64)));
        for (b, (label, rot, trans)) in BINS.iter().enumerate() {
            let noise_seed = world_seed(trial_seed(settings.seed, 300 + b as u64 + 1, t as u64));
            specs.push(RunSpec {
                condition: (*label).to_owned(),
                bump: (*rot > 0.0 || *trans > 0.0).then_some((*rot, *trans)),
                earlier_run: Some(Box::new(reference.clone())),
                ..day(noise_seed)
            });
        }
    }
    let Some(results) = run_selected(settings, "maintenance", &specs)? else {
        return Ok(());
    };
    let bins: Vec<BinResult> = BINS
        .iter()
        .map(|(label, rot, trans)| {
            let mut r = BinResult {
                bin: (*label).to_owned(),
                rot_deg: *rot,
                trans_mm: *trans,
                goal_applies: *rot >= 0.5 || *trans >= 3.0,
                ..BinResult::default()
            };
            for run in results.iter().filter(|x| x.spec.condition == *label) {
                r.runs += 1;
                if run
                    .spec
                    .carried
                    .as_ref()
                    .is_some_and(|c| c.contains("calibration.reference_xyz_m"))
                {
                    r.from_reference += 1;
                }
                let checks: Vec<&str> = run
                    .verdict
                    .calibration
                    .iter()
                    .filter(|a| a.state == "check")
                    .map(|a| a.reason_code.as_str())
                    .collect();
                match checks.last() {
                    Some(&"drifted") => r.drifted += 1,
                    Some(&"consistent") => r.consistent += 1,
                    Some(_) => r.cannot_tell += 1,
                    None => {
                        *r.not_checked
                            .entry(run.verdict.reason_code.clone())
                            .or_default() += 1;
                        continue;
                    }
                }
                if !matches!(checks.first(), Some(&("drifted" | "consistent"))) {
                    r.first_cannot_tell += 1;
                }
                if checks.first() == Some(&"unresolved") && checks.len() > 1 {
                    r.extended += 1;
                }
            }
            let checked = r.checked();
            r.rate = if checked == 0 {
                f64::NAN
            } else {
                r.drifted as f64 / checked as f64
            };
            r.rate_95 = super::stats::wilson_95(r.drifted, checked);
            r
        })
        .collect();
    let mut report = Report::new("Maintenance: drift detection per bump size");
    report.paragraph(settings.sites_sentence());
    report.paragraph(&format!(
        "{trials} robots (a world seed each: the bay, the arm's kinematic error, the cameras' \
         calibration errors), each checked once per bin on a day of its own (`noise_seed`: \
         sensor noise, hour, wind) by the `check` task (4 drift check views of the calibration \
         cabinet, 4 more when those are unresolved, wrist camera {}x{}, 9:00-15:00, mean wind \
         0-1 m/s); bump at 0.5 s in a direction drawn from the robot's seed. Before its bins, \
         each robot ran one unbumped check on another day, and its runs start from what that \
         run left (`rodlog calib carry`): when that check found the mount consistent, its \
         reference, which the later checks compare with (column \"against a reference\"; \
         the others compare with the camera edge, as a robot without a reference does). Goal: >= 95 % detected at \
         >= 0.5 deg or >= 3 mm and none of those called consistent (a miss); on unbumped runs \
         <= 5 % false alarms and <= 5 % cannot tell. Rates are over the runs the check answered; \
         a run refused before its check (no check) is not a verdict of the check.",
        (1280.0 * camera_scale).round(),
        (1024.0 * camera_scale).round()
    ));
    let mut t = Table::new(&[
        "bin",
        "runs",
        "against a reference",
        "no check (refused before it)",
        "drifted",
        "consistent",
        "cannot tell",
        "4 views: cannot tell",
        "looked again",
        "rate",
        "95% interval (Wilson)",
        "goal",
    ]);
    for b in &bins {
        let goal = if b.bin == "none" {
            let cannot = b.cannot_tell as f64 / b.checked().max(1) as f64;
            match (b.rate <= 0.05, cannot <= 0.05) {
                (true, true) => "<= 5 % false alarms, <= 5 % cannot tell: met",
                (false, _) => "<= 5 % false alarms: NOT met",
                (true, false) => "<= 5 % cannot tell: NOT met",
            }
        } else if b.goal_applies {
            match (b.rate >= 0.95, b.consistent) {
                (true, 0) => ">= 95 %, no miss: met",
                (true, _) => ">= 95 %: met; missed (consistent): NOT met",
                (false, 0) => ">= 95 %: NOT met",
                (false, _) => ">= 95 %, no miss: NOT met",
            }
        } else {
            "(below the goal's size)"
        };
        t.row(vec![
            b.bin.clone(),
            b.runs.to_string(),
            b.from_reference.to_string(),
            b.not_checked_cell(),
            b.drifted.to_string(),
            b.consistent.to_string(),
            b.cannot_tell.to_string(),
            b.first_cannot_tell.to_string(),
            b.extended.to_string(),
            fmt_pct(b.rate, 0),
            format!("{} - {}", fmt_pct(b.rate_95.0, 0), fmt_pct(b.rate_95.1, 0)),
            goal.to_owned(),
        ]);
    }
    report.table(&t);
    let chart = viz::plots::BarChart {
        title: "Drift detected (unbumped: false alarms)".into(),
        x_label: "bump".into(),
        y_label: "verdict drifted (%)".into(),
        categories: bins.iter().map(|b| b.bin.clone()).collect(),
        series: vec![(
            "detected".into(),
            bins.iter().map(|b| 100.0 * b.rate).collect(),
        )],
    };
    let files = viz::plots::write_bar_chart(&chart, &settings.out.plot_stem("detection"))?;
    report.image("detection rate", &settings.out.relative(&files.png));
    let mut json = Results::new("maintenance", settings.seed);
    json.seeds = seeds;
    json.parameter("trials", trials)?;
    json.parameter("camera_scale", camera_scale)?;
    json.parameter("sites", settings.sites_label())?;
    json.section("bins", &bins)?;
    // Each run by its robot's seed and its day's noise seed: any one can be rerun alone.
    let answers: Vec<_> = results
        .iter()
        .map(|r| {
            (
                r.spec.condition.clone(),
                r.spec.seed,
                r.spec.noise_seed,
                r.verdict.calibration.clone(),
            )
        })
        .collect();
    json.section("answers", &answers)?;
    // Per robot: its reference run's noise seed, and whether it left a reference (the
    // others checked against the camera edge).
    let mut references: Vec<(u64, Option<u64>, bool)> = Vec::new();
    for r in &results {
        let has = r
            .spec
            .carried
            .as_ref()
            .is_some_and(|c| c.contains("calibration.reference_xyz_m"));
        if !references.iter().any(|(seed, _, _)| *seed == r.spec.seed) {
            let day = r.spec.earlier_run.as_ref().and_then(|e| e.noise_seed);
            references.push((r.spec.seed, day, has));
        }
    }
    json.section("references", &references)?;
    settings.write_results(&json)?;
    let path = report.write(settings.out.root())?;
    crate::cmd::print_stdout(&path.display().to_string())
}
