//! `rodlog experiment tasks` (ARCHITECTURE.md section 7; the paper's task experiment): hangs and
//! removes after a camera-mount bump, with and without self-calibration.
//!
//! Every trial `t` is one world seed, run four times: hang and remove, each with the
//! self-maintenance on (drift check, recalibration on drift) and off (the calibration from
//! before the bump). The bump happens at 0.5 s, its size drawn from the seed as ARCHITECTURE.md section 6
//! says (1-3 deg, 3-10 mm); the hour (8:00-16:00) and the mean wind (0-1.5 m/s, gusts
//! above it are normal) are drawn from the seed too. Runs are judged by [`crate::judge`]
//! against the simulator's truth: success = the task reported DONE and the rod is where it
//! should be (hang: clamped with the hook inside its capture window; remove: on the rack),
//! plus every command checked for unsafety. Paper: +16 points (hang) and +24 points
//! (remove) with self-calibration.

use anyhow::Result;
use serde::Serialize;

use super::report::{Comparison, Report, Results, fmt_num, fmt_pct};
use super::task_runs::{GroupSummary, RunSpec, outcome_table, run_selected, summarize, world_seed};
use super::{Settings, trial_seed};

/// Trials per task when `--trials` is not given (50 hangs + 50 removes, each with and
/// without self-calibration: 200 runs).
pub const DEFAULT_TRIALS: usize = 50;
/// Wrist camera resolution factor at `--image-scale 1` (640x512).
pub const CAMERA_SCALE: f64 = 0.5;
/// The paper's gains of self-calibration (hang, remove), in success-rate points.
pub const PAPER_GAIN_POINTS: [f64; 2] = [16.0, 24.0];

/// Per-run line of results.json.
#[derive(Clone, Debug, Serialize)]
struct RunLine {
    task: String,
    self_calibration: bool,
    seed: u64,
    hour: f64,
    wind_mps: f64,
    success: bool,
    outcome: String,
    reason_code: String,
    operation_s: Option<f64>,
    rod_state: String,
    hook_window_fraction: Option<f64>,
    unsafe_commands: usize,
    wall_s: f64,
}

/// The specs of one trial (hang and remove, with and without self-calibration).
#[must_use]
pub fn trial_specs(seed: u64, camera_scale: f64, seeded_site: bool) -> Vec<RunSpec> {
    let u = |k: u64| sim::rng::uniform(seed, 0x7A5C, k);
    let hour = 8.0 + 8.0 * u(0);
    let wind = 1.5 * u(1);
    let mut specs = Vec::new();
    for task in ["hang", "remove"] {
        for with in [true, false] {
            specs.push(RunSpec {
                condition: format!(
                    "{task}, {}",
                    if with {
                        "with self-calibration"
                    } else {
                        "without"
                    }
                ),
                task: task.to_owned(),
                seed,
                hour,
                wind_mps: wind,
                bump: Some((f64::NAN, f64::NAN)),
                self_maintenance: with,
                camera_scale,
                duration_s: 320.0,
                seeded_site,
                wrist_light: false,
                noise_seed: None,
                earlier_run: None,
                carried: None,
            });
        }
    }
    specs
}

/// Runs the experiment (module docs).
///
/// # Errors
/// Simulation, judging, plotting or writing failures.
pub fn run(settings: &Settings) -> Result<()> {
    let trials = settings.trials_or(DEFAULT_TRIALS);
    let camera_scale = CAMERA_SCALE * settings.image_scale;
    let seeds: Vec<u64> = (0..trials)
        .map(|t| world_seed(trial_seed(settings.seed, 12, t as u64)))
        .collect();
    let specs: Vec<RunSpec> = seeds
        .iter()
        .flat_map(|&s| trial_specs(s, camera_scale, settings.seeded_sites))
        .collect();
    let Some(results) = run_selected(settings, "tasks", &specs)? else {
        return Ok(());
    };
    let conditions: Vec<String> = specs.iter().take(4).map(|s| s.condition.clone()).collect();
    let groups: Vec<GroupSummary> = conditions
        .iter()
        .map(|c| {
            let runs: Vec<_> = results.iter().filter(|r| &r.spec.condition == c).collect();
            summarize(c, &runs)
        })
        .collect();
    let rate = |i: usize| groups.get(i).map_or(f64::NAN, |g| g.success_rate);
    let gains = [100.0 * (rate(0) - rate(1)), 100.0 * (rate(2) - rate(3))];
    let unsafe_total: usize = groups.iter().map(|g| g.unsafe_commands).sum();

    let mut report = Report::new("Tasks: hang and remove after a camera-mount bump");
    report.paragraph(&format!(
        "{trials} seeded trials, each a hang and a remove with and without self-calibration \
         ({} runs). Bump at 0.5 s, 1-3 deg / 3-10 mm from the seed; 8:00-16:00; mean wind \
         0-1.5 m/s; wrist camera {}x{}. Success is judged with the simulator's truth \
         (`rodlog check task`). {}",
        specs.len(),
        (1280.0 * camera_scale).round(),
        (1024.0 * camera_scale).round(),
        settings.sites_sentence()
    ));
    report.table(&outcome_table("condition", &groups));
    report.paragraph(&format!(
        "Gain of self-calibration: hang {} points (paper +{}), remove {} points (paper +{}). \
         Unsafe commands over all runs: {unsafe_total}.",
        fmt_num(gains[0], 0),
        PAPER_GAIN_POINTS[0],
        fmt_num(gains[1], 0),
        PAPER_GAIN_POINTS[1]
    ));
    let chart = viz::plots::BarChart {
        title: "Success rate after a camera-mount bump".into(),
        x_label: "task".into(),
        y_label: "success (%)".into(),
        categories: vec!["hang".into(), "remove".into()],
        series: vec![
            (
                "with self-calibration".into(),
                vec![100.0 * rate(0), 100.0 * rate(2)],
            ),
            ("without".into(), vec![100.0 * rate(1), 100.0 * rate(3)]),
        ],
    };
    let files = viz::plots::write_bar_chart(&chart, &settings.out.plot_stem("success"))?;
    report.image("success rate", &settings.out.relative(&files.png));
    let times: Vec<Vec<Vec<f64>>> = conditions
        .iter()
        .map(|c| {
            vec![
                results
                    .iter()
                    .filter(|r| &r.spec.condition == c)
                    .filter_map(|r| r.verdict.operation_s)
                    .collect(),
            ]
        })
        .collect();
    let boxes = viz::plots::BoxPlot {
        title: "Operation time (every run that ended)".into(),
        x_label: "condition".into(),
        y_label: "time (s)".into(),
        conditions: conditions.clone(),
        methods: vec!["time".into()],
        samples: times,
        log_y: false,
    };
    let files = viz::plots::write_box_plot(&boxes, &settings.out.plot_stem("time"))?;
    report.image("operation time", &settings.out.relative(&files.png));

    let comparisons = paper_comparisons(&groups, gains);
    report.comparisons(&comparisons);
    let mut json = Results::new("tasks", settings.seed);
    json.section("comparisons", &comparisons)?;
    json.seeds.clone_from(&seeds);
    json.parameter("trials", trials)?;
    json.parameter("camera_scale", camera_scale)?;
    json.parameter("sites", settings.sites_label())?;
    json.section("groups", &groups)?;
    json.section("gain_points", gains)?;
    json.section("unsafe_commands", unsafe_total)?;
    let lines: Vec<RunLine> = results
        .iter()
        .map(|r| RunLine {
            task: r.spec.task.clone(),
            self_calibration: r.spec.self_maintenance,
            seed: r.spec.seed,
            hour: r.spec.hour,
            wind_mps: r.spec.wind_mps,
            success: r.verdict.success,
            outcome: r.verdict.outcome.clone(),
            reason_code: r.verdict.reason_code.clone(),
            operation_s: r.verdict.operation_s,
            rod_state: r.verdict.rod_state.clone(),
            hook_window_fraction: r.verdict.hook.map(|h| h.window_fraction),
            unsafe_commands: r.verdict.unsafe_commands.len(),
            wall_s: r.wall_s,
        })
        .collect();
    json.section("runs", &lines)?;
    settings.write_results(&json)?;
    let path = report.write(settings.out.root())?;
    crate::cmd::print_stdout(&path.display().to_string())
}

/// The paper's success rate with self-calibration after a bump (Table 4, about 95 %).
pub const PAPER_SUCCESS: f64 = 0.95;

/// Table 4 beside the paper: the success with self-calibration (hang `groups[0]`, remove
/// `groups[2]`), the gains in points, and the operation time under 5 minutes.
fn paper_comparisons(groups: &[GroupSummary], gains: [f64; 2]) -> Vec<Comparison> {
    let mut out = Vec::new();
    for (k, task) in [(0, "hang"), (2, "remove")] {
        let Some(g) = groups.get(k) else { continue };
        out.push(Comparison::new(
            &format!("{task} success with self-calibration after a bump (Table 4)"),
            "about 95 %",
            format!(
                "{} ({} - {}, {}/{})",
                fmt_pct(g.success_rate, 0),
                fmt_pct(g.success_rate_95.0, 0),
                fmt_pct(g.success_rate_95.1, 0),
                g.success,
                g.runs
            ),
            g.success_rate.is_nan() || g.success_rate < PAPER_SUCCESS,
        ));
    }
    for (k, task) in ["hang", "remove"].iter().enumerate() {
        out.push(Comparison::new(
            &format!("{task}: gain of self-calibration (Table 4)"),
            &format!("+{} points", PAPER_GAIN_POINTS[k]),
            format!("{} points", fmt_num(gains[k], 0)),
            gains[k].is_nan() || gains[k] < PAPER_GAIN_POINTS[k],
        ));
    }
    let over: usize = groups.iter().map(|g| g.over_5_min).sum();
    let max_s = groups.iter().map(|g| g.max_s).fold(0.0, f64::max);
    out.push(Comparison::new(
        "every operation under 5 minutes (Table 4)",
        "yes",
        format!("{over} at 5 min or more; longest {} s", fmt_num(max_s, 0)),
        over > 0,
    ));
    out
}
