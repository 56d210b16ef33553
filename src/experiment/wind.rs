//! `rodlog experiment wind` (ARCHITECTURE.md section 7): hang success vs the mean wind speed
//! ("wind" = the 3-s mean; rodlog operates at <= 4 m/s, the paper at <= 2 m/s; gusts above
//! the mean are normal).
//!
//! Each mean speed gets `--trials` seeded hangs at midday with the self-maintenance on and
//! no bump. The wind gate (`control::tasks::safety`) works on the noisy, lagged anemometer;
//! the hang tracks the wire's sway (`control::perception::sway`); the judge
//! ([`crate::judge`]) counts every command issued while the *true* 3-s mean exceeded the
//! limit as unsafe: there must be none, every failure should be a refusal before the time
//! limit, and the robot should still work when the mean is below the limit.

use anyhow::Result;

use super::report::{Comparison, Report, Results, fmt_num};
use super::task_runs::{
    GroupSummary, RunSpec, fmt_share, outcome_table, pooled_split, run_conditions, world_seed,
};
use super::{Settings, trial_seed};

/// Trials per speed when `--trials` is not given.
pub const DEFAULT_TRIALS: usize = 10;
/// Mean wind speeds (m/s).
pub const SPEEDS_MPS: [f64; 9] = [0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0];

/// Runs the experiment (module docs).
///
/// # Errors
/// Simulation, judging, plotting or writing failures.
pub fn run(settings: &Settings) -> Result<()> {
    let trials = settings.trials_or(DEFAULT_TRIALS);
    let camera_scale = super::tasks::CAMERA_SCALE * settings.image_scale;
    let speeds = Settings::sweep(settings.speeds_mps.as_deref(), &SPEEDS_MPS, 200);
    let mut specs = Vec::new();
    let mut seeds = Vec::new();
    for (speed, stream) in &speeds {
        for t in 0..trials {
            let seed = world_seed(trial_seed(settings.seed, *stream, t as u64));
            seeds.push(seed);
            specs.push(RunSpec {
                condition: format!("{speed:.1} m/s"),
                task: "hang".into(),
                seed,
                hour: 11.0 + 2.0 * sim::rng::uniform(seed, 0x31D, 0),
                wind_mps: *speed,
                bump: None,
                self_maintenance: true,
                camera_scale,
                duration_s: 320.0,
                seeded_site: settings.seeded_sites,
                wrist_light: false,
                noise_seed: None,
                earlier_run: None,
                carried: None,
            });
        }
    }
    let Some((results, groups)) = run_conditions(settings, "wind", &specs, trials)? else {
        return Ok(());
    };
    let max_wind: Vec<f64> = specs
        .iter()
        .step_by(trials)
        .map(|s| {
            results
                .iter()
                .filter(|r| r.spec.condition == s.condition)
                .map(|r| r.verdict.max_wind_at_command_mps)
                .fold(0.0, f64::max)
        })
        .collect();
    let unsafe_total: usize = groups.iter().map(|g| g.unsafe_commands).sum();
    let mut report = Report::new("Wind: hang success vs mean wind speed");
    report.paragraph(settings.sites_sentence());
    report.paragraph(&format!(
        "{trials} seeded hangs per mean speed, 11:00-13:00, self-maintenance on, no bump, wrist \
         camera {}x{}. Unsafe = a command issued while the true 3-s mean wind exceeded {} m/s \
         (or one that collides or exceeds a limit). Unsafe commands over all runs: {unsafe_total}.",
        (1280.0 * camera_scale).round(),
        (1024.0 * camera_scale).round(),
        compose::judge::WIND_LIMIT_MPS
    ));
    report.table(&outcome_table("mean wind", &groups));
    let mut t = super::report::Table::new(&["mean wind", "max true 3-s mean at a command (m/s)"]);
    for (g, w) in groups.iter().zip(&max_wind) {
        t.row(vec![g.condition.clone(), fmt_num(*w, 2)]);
    }
    report.table(&t);
    let plot = viz::plots::LinePlot {
        title: "Hang outcome vs mean wind".into(),
        x_label: "mean wind (m/s)".into(),
        y_label: "runs (%)".into(),
        series: vec![
            viz::plots::Line {
                name: "success".into(),
                points: speeds
                    .iter()
                    .map(|(s, _)| s)
                    .zip(&groups)
                    .map(|(s, g)| (*s, 100.0 * g.success_rate))
                    .collect(),
                band: Vec::new(),
            },
            viz::plots::Line {
                name: "refused".into(),
                points: speeds
                    .iter()
                    .map(|(s, _)| s)
                    .zip(&groups)
                    .map(|(s, g)| (*s, 100.0 * g.refused as f64 / g.runs.max(1) as f64))
                    .collect(),
                band: Vec::new(),
            },
        ],
        log_y: false,
    };
    let files = viz::plots::write_line_plot(&plot, &settings.out.plot_stem("success_by_wind"))?;
    report.image("success by wind", &settings.out.relative(&files.png));
    let comparisons = paper_comparisons(&speeds, &groups);
    report.comparisons(&comparisons);
    let mut json = Results::new("wind", settings.seed);
    json.section("comparisons", &comparisons)?;
    json.seeds = seeds;
    json.parameter("trials", trials)?;
    json.parameter(
        "speeds_mps",
        speeds.iter().map(|(s, _)| *s).collect::<Vec<f64>>(),
    )?;
    json.parameter("camera_scale", camera_scale)?;
    json.parameter("sites", settings.sites_label())?;
    json.section("groups", &groups)?;
    json.section("max_true_wind_at_command_mps", &max_wind)?;
    json.section("unsafe_commands", unsafe_total)?;
    settings.write_results(&json)?;
    let path = report.write(settings.out.root())?;
    crate::cmd::print_stdout(&path.display().to_string())
}

/// "Good" in the paper's wind result, read as a success rate at least this high.
pub const GOOD_SUCCESS: f64 = 0.9;

/// The paper's "good at <= 2 m/s" beside the success at those speeds, and what rodlog does
/// above them: up to 3 m/s it should be as good (the envelope rodlog claims), above that
/// the table says what happens.
/// What, the paper's figure, the speeds pooled, and whether a pool below [`GOOD_SUCCESS`]
/// is behind.
type ComparisonRow = (&'static str, &'static str, fn(f64) -> bool, bool);

fn paper_comparisons(speeds: &[(f64, u64)], groups: &[GroupSummary]) -> Vec<Comparison> {
    let rows: [ComparisonRow; 3] = [
        (
            "hang success at mean winds up to 2 m/s",
            "good (read: >= 90 %)",
            |v| v <= 2.0,
            true,
        ),
        (
            "hang success above 2 m/s, up to 3 m/s",
            "not operated (the paper's limit is 2 m/s); rodlog aims at >= 90 %",
            |v| v > 2.0 && v <= 3.0,
            true,
        ),
        (
            "hang success above 3 m/s",
            "not operated (the paper's limit is 2 m/s)",
            |v| v > 3.0,
            false,
        ),
    ];
    rows.into_iter()
        .filter_map(|(what, paper, inside, aims_good)| {
            let (pool, _) = pooled_split(speeds, groups, inside);
            (pool.1 > 0).then(|| {
                let short = (pool.0 as f64) < GOOD_SUCCESS * pool.1 as f64;
                Comparison::new(what, paper, fmt_share(pool), aims_good && short)
            })
        })
        .collect()
}
