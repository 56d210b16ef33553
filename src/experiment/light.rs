//! `rodlog experiment light` (ARCHITECTURE.md section 7): hang success and time by hour of day,
//! wind at most 2 m/s (the paper: failures only 18:00-19:00, every operation under 5 min).
//!
//! Each hour from 6:00 to 20:00 gets `--trials` seeded hangs with the self-maintenance on
//! and no bump (the light alone decides): the drift check and the panoramic finder work on
//! colour images, whose SNR falls at dusk (ARCHITECTURE.md section 6); the structured-light depth does not
//! care. The robot must refuse what it cannot see, never fail: the table separates refusals
//! (by reason) from failures.

use anyhow::Result;

use super::report::{Comparison, Report, Results};
use super::task_runs::{
    GroupSummary, RunSpec, fmt_share, outcome_table, pooled_split, run_conditions, world_seed,
};
use super::{Settings, trial_seed};

/// Trials per hour when `--trials` is not given.
pub const DEFAULT_TRIALS: usize = 10;
/// The hours (local solar time).
pub const HOURS: [f64; 16] = [
    6.0, 7.0, 8.0, 9.0, 10.0, 11.0, 12.0, 13.0, 14.0, 15.0, 16.0, 17.0, 17.5, 18.0, 18.5, 19.0,
];

/// Runs the experiment (module docs).
///
/// # Errors
/// Simulation, judging, plotting or writing failures.
pub fn run(settings: &Settings) -> Result<()> {
    let trials = settings.trials_or(DEFAULT_TRIALS);
    let camera_scale = super::tasks::CAMERA_SCALE * settings.image_scale;
    let mut specs = Vec::new();
    let mut seeds = Vec::new();
    let hours = Settings::sweep(settings.hours.as_deref(), &HOURS, 100);
    for (hour, stream) in &hours {
        for t in 0..trials {
            let seed = world_seed(trial_seed(settings.seed, *stream, t as u64));
            seeds.push(seed);
            specs.push(RunSpec {
                condition: format!(
                    "{:02}:{:02}",
                    hour.floor() as u32,
                    ((hour.fract()) * 60.0).round() as u32
                ),
                task: "hang".into(),
                seed,
                hour: *hour,
                wind_mps: 1.5 * sim::rng::uniform(seed, 0x11A7, 0),
                bump: None,
                self_maintenance: true,
                camera_scale,
                duration_s: 320.0,
                seeded_site: settings.seeded_sites,
                wrist_light: settings.wrist_light,
                noise_seed: None,
                earlier_run: None,
                carried: None,
            });
        }
    }
    let Some((_, groups)) = run_conditions(settings, "light", &specs, trials)? else {
        return Ok(());
    };
    let mut report = Report::new("Light: hang success and time by hour of day");
    report.paragraph(settings.sites_sentence());
    report.paragraph(&format!(
        "{trials} seeded hangs per hour, self-maintenance on, no bump, mean wind 0-1.5 m/s, wrist \
         camera {}x{}, {}. Judged with the simulator's truth.",
        (1280.0 * camera_scale).round(),
        (1024.0 * camera_scale).round(),
        if settings.wrist_light {
            format!(
                "with the wrist light (lit by the task while the lux meter reads below {} lx)",
                control::tasks::lighting::LightingParams::default().on_below_lux
            )
        } else {
            "without a wrist light".to_owned()
        }
    ));
    report.table(&outcome_table("hour", &groups));
    let lines = vec![
        viz::plots::Line {
            name: "success".into(),
            points: hours
                .iter()
                .map(|(h, _)| h)
                .zip(&groups)
                .map(|(h, g)| (*h, 100.0 * g.success_rate))
                .collect(),
            band: Vec::new(),
        },
        viz::plots::Line {
            name: "refused".into(),
            points: hours
                .iter()
                .map(|(h, _)| h)
                .zip(&groups)
                .map(|(h, g)| (*h, 100.0 * g.refused as f64 / g.runs.max(1) as f64))
                .collect(),
            band: Vec::new(),
        },
    ];
    let plot = viz::plots::LinePlot {
        title: "Hang outcome by hour of day".into(),
        x_label: "hour".into(),
        y_label: "runs (%)".into(),
        series: lines,
        log_y: false,
    };
    let files = viz::plots::write_line_plot(&plot, &settings.out.plot_stem("success_by_hour"))?;
    report.image("success by hour", &settings.out.relative(&files.png));
    let time_plot = viz::plots::LinePlot {
        title: "Median operation time of the successful hangs".into(),
        x_label: "hour".into(),
        y_label: "time (s)".into(),
        series: vec![viz::plots::Line {
            name: "median".into(),
            points: hours
                .iter()
                .map(|(h, _)| h)
                .zip(&groups)
                .filter(|(_, g)| g.median_s.is_finite())
                .map(|(h, g)| (*h, g.median_s))
                .collect(),
            band: Vec::new(),
        }],
        log_y: false,
    };
    let files = viz::plots::write_line_plot(&time_plot, &settings.out.plot_stem("time_by_hour"))?;
    report.image("time by hour", &settings.out.relative(&files.png));
    let comparisons = paper_comparisons(&hours, &groups);
    report.comparisons(&comparisons);
    let mut json = Results::new("light", settings.seed);
    json.section("comparisons", &comparisons)?;
    json.seeds = seeds;
    json.parameter("trials", trials)?;
    json.parameter("hours", hours.iter().map(|(h, _)| *h).collect::<Vec<f64>>())?;
    json.parameter("camera_scale", camera_scale)?;
    json.parameter("sites", settings.sites_label())?;
    json.parameter("wrist_light", settings.wrist_light)?;
    json.section("groups", &groups)?;
    settings.write_results(&json)?;
    let path = report.write(settings.out.root())?;
    crate::cmd::print_stdout(&path.display().to_string())
}

/// Table 5 beside the paper: no failures outside 18:00-19:00, every operation under 5
/// minutes, and what rodlog does in the paper's failing hour.
fn paper_comparisons(hours: &[(f64, u64)], groups: &[GroupSummary]) -> Vec<Comparison> {
    let (dusk, day) = pooled_split(hours, groups, |h| (18.0..=19.0).contains(&h));
    let over: usize = groups.iter().map(|g| g.over_5_min).sum();
    let mut out = Vec::new();
    if day.1 > 0 {
        out.push(Comparison::new(
            "success outside 18:00-19:00 (Table 5)",
            "no failures",
            fmt_share(day),
            day.0 < day.1,
        ));
    }
    if dusk.1 > 0 {
        out.push(Comparison::new(
            "success from 18:00 to 19:00 (Table 5)",
            "failures (the paper's robot stops in this hour)",
            fmt_share(dusk),
            // The paper fails here too: rodlog cannot be behind it.
            false,
        ));
    }
    out.push(Comparison::new(
        "every operation under 5 minutes (Table 5)",
        "yes",
        format!("{over} at 5 min or more"),
        over > 0,
    ));
    out
}
