//! `rodlog experiment motions` (ARCHITECTURE.md section 7, the paper's Fig. 14): hand-eye
//! error against the number of motions (views), 12..18, the paper's method and ours vs ZHI.
//!
//! Protocol: the trials of [`super::noise`] ([`super::noise::render_trial`]: 18 seeded views
//! per trial, rendered once); condition `k` calibrates from the first `k` views of each
//! trial, with a fixed image noise of [`NOISE_SIGMA`] on [0, 1] intensities and the depth
//! noise that goes with it in [`super::noise`] (the same noise realisation for every `k`, so
//! the conditions differ only by the views used). Methods,
//! errors and refusals as in [`super::noise`]. Paper: errors stabilise from 16 motions.

use anyhow::Result;

use super::Settings;
use super::noise::CellSummary;
use super::noise::{
    METHODS, SimContext, TrialPlan, VIEWS, all_answered, all_answered_table, book_trials,
    box_plots, error_table, refusal_table, run_trials,
};
use super::report::{Report, Results, fmt_pct};
use super::stats::Summary;

/// Trials when `--trials` is not given (the paper's).
pub const DEFAULT_TRIALS: usize = 100;
/// Fewest motions.
pub const MIN_VIEWS: usize = 12;
/// Fixed image noise, standard deviation on [0, 1] intensities.
pub const NOISE_SIGMA: f64 = 0.05;

const STREAM_NOISE: u64 = 31;

/// Runs the experiment (module docs).
///
/// # Errors
/// Rendering, plotting or writing failures.
pub fn run(settings: &Settings) -> Result<()> {
    let trials = settings.trials_or(DEFAULT_TRIALS);
    let ctx = SimContext::new(settings)?;
    let counts: Vec<usize> = (MIN_VIEWS..=VIEWS).collect();
    let conditions: Vec<String> = counts.iter().map(|k| format!("{k}")).collect();
    let plan = TrialPlan {
        name: "motions",
        stream: 1,
        trials,
        conditions: counts.len(),
    };
    let records = run_trials(settings, &ctx, plan, None, |seed, c| {
        let k = counts.get(c).copied().unwrap_or(VIEWS);
        (k, NOISE_SIGMA, sim::rng::key(seed, STREAM_NOISE, 0))
    })?;
    let Some(records) = records else {
        return Ok(());
    };
    let (cells, refusals, seeds) = book_trials(&records, &conditions);
    let mut report = Report::new("Experiment motions: hand-eye error vs number of motions");
    if let Some(note) = settings.ours_variant_note() {
        report.paragraph(&note);
    }
    report.paragraph(&format!(
        "{trials} trials; condition k uses the first k of the trial's {VIEWS} views \
         ({}x{} renders, wrist lens), image noise sigma {NOISE_SIGMA} on [0, 1] intensities. \
         Paper (Fig. 14): errors stable from 16 motions.",
        ctx.camera.width, ctx.camera.height
    ));
    let (table, rows) = error_table(&conditions, &cells, &refusals, "motions");
    report.table(&table);
    let mut comparisons = super::noise::below_zhi_everywhere(&rows, "number of motions (Fig. 14)");
    comparisons.extend(stable_from(&rows, &conditions, &counts, STABLE_FROM));
    let (common, common_trials) = all_answered(&records, &conditions);
    let (common_table, common_rows) =
        all_answered_table(&conditions, &common, &common_trials, "motions");
    report.heading("Over the trials every method answered");
    report.table(&common_table);
    box_plots(
        settings,
        &mut report,
        &conditions,
        &cells,
        "motions (views)",
        "motions",
    )?;
    // Median lines.
    let series: Vec<viz::plots::Line> = METHODS
        .iter()
        .enumerate()
        .map(|(m, name)| viz::plots::Line {
            name: (*name).to_owned(),
            points: counts
                .iter()
                .enumerate()
                .filter_map(|(c, k)| {
                    let s = Summary::of(&cells.get(c)?.get(m)?.e_t_mm);
                    s.median.is_finite().then_some((*k as f64, s.median))
                })
                .collect(),
            band: Vec::new(),
        })
        .collect();
    let line = viz::plots::LinePlot {
        title: "median e_t vs motions".to_owned(),
        x_label: "motions (views)".to_owned(),
        y_label: "median e_t (mm)".to_owned(),
        series,
        // ZHI's translation is tens of millimetres off; ours is under one.
        log_y: true,
    };
    let files = viz::plots::write_line_plot(&line, &settings.out.plot_stem("motions_median_e_t"))?;
    report.image(&line.title, &settings.out.relative(&files.png));
    if refusals.total_refused() > 0 {
        report.heading("Refusals");
        report.table(&refusal_table(&refusals));
    }
    let mut results = Results::new("motions", settings.seed);
    results.seeds = seeds;
    results.parameter("trials", trials)?;
    results.parameter("views", &counts)?;
    results.parameter("orb_distribution", settings.ours_distribution().name())?;
    results.parameter("ours_steps", settings.steps_changed())?;
    results.parameter("noise_sigma", NOISE_SIGMA)?;
    results.parameter("width", ctx.camera.width)?;
    results.parameter("height", ctx.camera.height)?;
    results.section("cells", &rows)?;
    results.section("cells_all_answered", &common_rows)?;
    results.section("refusals", &refusals)?;
    report.comparisons(&comparisons);
    results.section("comparisons", &comparisons)?;
    report.write(settings.out.root())?;
    settings.write_results(&results)?;
    crate::cmd::print_stdout(&format!(
        "{}",
        settings.out.root().join("report.md").display()
    ))?;
    Ok(())
}

/// The paper's Fig. 14: the error is stable from this many motions.
pub const STABLE_FROM: usize = 16;
/// "Stable": every median from [`STABLE_FROM`] motions on within this fraction of the median
/// at the most motions.
pub const STABLE_WITHIN: f64 = 0.2;

/// A median of a cell.
type Pick = fn(&CellSummary) -> f64;

/// The paper's "stable from `from` motions" beside ours-rgbd's and ours-mono's median `e_t`
/// and `e_R` (`rows` of [`error_table`], `conditions[k]` the label of `counts[k]` motions).
fn stable_from(
    rows: &[CellSummary],
    conditions: &[String],
    counts: &[usize],
    from: usize,
) -> Vec<super::report::Comparison> {
    let mut out = Vec::new();
    let Some(last) = conditions.last() else {
        return out;
    };
    for method in ["ours-rgbd", "ours-mono"] {
        let median = |cond: &str, pick: Pick| {
            rows.iter()
                .find(|r| r.method == method && r.condition == cond)
                .map_or(f64::NAN, pick)
        };
        let picks: [Pick; 2] = [|c| c.e_r.median, |c| c.e_t_mm.median];
        let mut worst: f64 = 0.0;
        for pick in picks {
            let reference = median(last, pick);
            for (cond, _) in conditions.iter().zip(counts).filter(|(_, n)| **n >= from) {
                worst = worst.max((median(cond, pick) / reference - 1.0).abs());
            }
        }
        out.push(super::report::Comparison::new(
            &format!("{method}: median e_R and e_t stable from {from} motions (Fig. 14)"),
            "yes",
            if worst.is_finite() {
                format!(
                    "within {} of the median at {} motions",
                    fmt_pct(worst, 0),
                    counts.last().copied().unwrap_or(0)
                )
            } else {
                "not measured at these counts".to_owned()
            },
            worst.is_nan() || worst > STABLE_WITHIN,
        ));
    }
    out
}
