//! The experiment's report: tables, plots and the matches drawn.

use super::*;

#[allow(clippy::too_many_arguments)] // One call site; the report needs all of it.
pub(super) fn write_report(
    settings: &Settings,
    n: usize,
    sets: &[PairSet],
    methods: &[String],
    summaries: &[CellSummary],
    scores: &[PairScore],
    refusals: &RefusalCounter,
    pictures: &BTreeMap<(PairSet, String), PathBuf>,
    notes: &[String],
    with_reference: bool,
) -> Result<Report> {
    let mut r = Report::new("Experiment: feature matchers on pairs with known geometry");
    r.paragraph(&format!(
        "{n} seeded pairs per set (seed {}), image scale {}. A match is **true** when the \
         geometry puts it within {TRUE_MATCH_PX} px (never the method's own verdict); the true \
         rate is true / judged matches. Spread: fraction of the {SPREAD_GRID}x{SPREAD_GRID} \
         grid cells over image A holding a true match. Time: detect + match + filter, one \
         run each on this machine (median over pairs). Refused: the method errored or \
         accepted no match (its rate is then left out, its counts are 0).{}",
        settings.seed,
        settings.image_scale,
        if with_reference {
            format!(
                " `{OPENCV_METHOD}`: OpenCV {FEATURES}-feature ORB + BFMatcher + matchGMS \
                 (scripts/features/opencv_ref.py), judged the same way; no time (process start-up)."
            )
        } else {
            " (OpenCV reference column not run: no .venv-ref or --no-reference.)".to_owned()
        }
    ));
    for note in notes {
        r.paragraph(&format!("Note: {note}"));
    }
    for &set in sets {
        r.heading(&format!(
            "{} pairs: judged by {}",
            set.name(),
            set.judged_by()
        ));
        let shecar = set == PairSet::Shecar;
        let mut head = vec![
            "method",
            "refused",
            "keypoints",
            "matches",
            "true matches",
            "true rate (median [q1, q3])",
            "pooled rate",
            "spread",
            "time ms",
        ];
        if shecar {
            head.push("epipolar-consistent");
        }
        let mut t = Table::new(&head);
        for s in summaries.iter().filter(|s| s.set == set) {
            let cell = refusals.cell(set.name(), &s.method);
            let mut row = vec![
                s.method.clone(),
                cell.fraction(),
                fmt_num(s.keypoints.median, 0),
                fmt_num(s.matches.median, 0),
                fmt_num(s.true_matches.median, 0),
                format!(
                    "{} [{}, {}]",
                    fmt_pct(s.true_rate.median, 1),
                    fmt_pct(s.true_rate.q1, 1),
                    fmt_pct(s.true_rate.q3, 1)
                ),
                fmt_pct(s.pooled_true_rate, 1),
                fmt_num(s.spread.median, 2),
                fmt_num(s.time_ms.median, 1),
            ];
            if let Some(e) = &s.epipolar_rate {
                row.push(fmt_pct(e.median, 1));
            }
            t.row(row);
        }
        r.table(&t);
        let reasons: Vec<String> = methods
            .iter()
            .flat_map(|m| {
                refusals
                    .cell(set.name(), m)
                    .reasons
                    .into_iter()
                    .map(move |(why, k)| format!("{m}: {k} x {why}"))
            })
            .collect();
        if !reasons.is_empty() {
            r.paragraph(&format!("Refusals: {}.", reasons.join("; ")));
        }
        for m in methods {
            if let Some(p) = pictures.get(&(set, m.clone())) {
                r.image(
                    &format!(
                        "{} {m}: accepted matches, green when the geometry confirms them, red \
                         otherwise{}",
                        set.name(),
                        if set == PairSet::Shecar {
                            " (or off the board, not judged)"
                        } else {
                            ""
                        }
                    ),
                    &settings.out.relative(p),
                );
            }
        }
    }

    // Plots: bars of the median true rate and true matches, box plots of the rate.
    let categories: Vec<String> = sets.iter().map(|s| s.name().to_owned()).collect();
    let per_method = |f: &dyn Fn(&CellSummary) -> f64| -> Vec<(String, Vec<f64>)> {
        methods
            .iter()
            .map(|m| {
                let v = sets
                    .iter()
                    .map(|&set| {
                        summaries
                            .iter()
                            .find(|s| s.set == set && &s.method == m)
                            .map_or(f64::NAN, f)
                    })
                    .collect();
                (m.clone(), v)
            })
            .collect()
    };
    r.heading("Plots");
    let rate_bars = viz::plots::BarChart {
        title: "Median true inlier rate per pair set".into(),
        x_label: "pair set".into(),
        y_label: "true matches / judged matches".into(),
        categories: categories.clone(),
        series: per_method(&|s| s.true_rate.median),
    };
    let files = viz::plots::write_bar_chart(&rate_bars, &settings.out.plot_stem("true_rate"))?;
    r.image("median true rate", &settings.out.relative(&files.png));
    let count_bars = viz::plots::BarChart {
        title: "Median number of true matches per pair".into(),
        x_label: "pair set".into(),
        y_label: "true matches".into(),
        categories: categories.clone(),
        series: per_method(&|s| s.true_matches.median),
    };
    let files = viz::plots::write_bar_chart(&count_bars, &settings.out.plot_stem("true_matches"))?;
    r.image("median true matches", &settings.out.relative(&files.png));
    let samples = |f: &dyn Fn(&PairScore) -> f64| -> Vec<Vec<Vec<f64>>> {
        sets.iter()
            .map(|&set| {
                methods
                    .iter()
                    .map(|m| {
                        scores
                            .iter()
                            .filter(|s| s.set == set && &s.method == m && s.refused.is_none())
                            .map(f)
                            .collect()
                    })
                    .collect()
            })
            .collect()
    };
    let rate_box = viz::plots::BoxPlot {
        title: "True inlier rate per pair".into(),
        x_label: "pair set".into(),
        y_label: "true matches / judged matches".into(),
        conditions: categories.clone(),
        methods: methods.to_vec(),
        samples: samples(&|s| s.true_rate),
        log_y: false,
    };
    let files = viz::plots::write_box_plot(&rate_box, &settings.out.plot_stem("true_rate_box"))?;
    r.image("true rate per pair", &settings.out.relative(&files.png));
    let time_box = viz::plots::BoxPlot {
        title: "Time per pair (detect + match + filter)".into(),
        x_label: "pair set".into(),
        y_label: "ms".into(),
        conditions: categories,
        methods: methods.to_vec(),
        samples: samples(&|s| s.time_ms),
        log_y: false,
    };
    let files = viz::plots::write_box_plot(&time_box, &settings.out.plot_stem("time_box"))?;
    r.image("time per pair", &settings.out.relative(&files.png));

    r.heading("Per pair");
    let mut t = Table::new(&[
        "pair",
        "method",
        "keypoints A",
        "matches",
        "judged",
        "true",
        "rate",
        "spread",
        "ms",
    ])
    .align(1, crate::experiment::report::Align::Left);
    for s in scores {
        t.row(vec![
            s.pair.clone(),
            s.method.clone(),
            s.keypoints_a.to_string(),
            s.matches.to_string(),
            s.judged.to_string(),
            s.true_matches.to_string(),
            s.refused
                .as_ref()
                .map_or_else(|| fmt_pct(s.true_rate, 1), |why| format!("refused: {why}")),
            fmt_num(s.spread, 2),
            fmt_num(s.time_ms, 1),
        ]);
    }
    r.table(&t);
    Ok(r)
}
