//! `rodlog experiment ablation` (ARCHITECTURE.md section 7; not in the paper): what each of
//! our departures from the paper's method adds, on the same trials.
//!
//! # Protocol
//! The trials of [`super::noise`] ([`render_trial`]: 18 seeded calib-18-style views per
//! trial, a seeded true mount, the perturbed arm and the encoder noise, rendered once at
//! 640x512 by default) with the image noise [`SIGMA`] and its depth noise
//! ([`super::noise::calib_views`]). Every variant runs on the same RGB-D views of every
//! trial.
//!
//! # Variants ([`variants`])
//! The paper's method ([`SelfCalMethod::Paper`]), then one step of
//! [`calib::selfcal::STEP_NAMES`] at a time switched to what ours does, in the order the
//! pipeline runs them, then ours' ORB keypoint selection where it differs from the paper's
//! (retain-best), so the last row is ours ([`SelfCalMethod::Ours`]); and `paper+ba`,
//! the paper's method with eq. 15 as a bundle adjustment. Errors against the true mount;
//! each variant's refusals and success rate (Wilson 95%), its errors over its own answers,
//! and every variant's errors over the trials where every variant answered.

use anyhow::{Context, Result};
use calib::selfcal::{STEP_NAMES, SelfCalMethod, SelfCalParams, self_calibrate};
use serde::{Deserialize, Serialize};

use super::noise::{PoseErrors, SimContext, VIEWS, calib_views, render_trial};
use super::progress::Progress;
use super::report::{Report, Results, Table, fmt_num, fmt_pct};
use super::stats::{Summary, wilson_95};
use super::{Settings, trial_seed};

/// Trials when `--trials` is not given.
pub const DEFAULT_TRIALS: usize = 20;
/// Image noise on [0, 1] intensities (the depth noise follows it, module docs).
pub const SIGMA: f64 = 0.10;

const STREAM_NOISE: u64 = 41;

/// One configuration of the pipeline.
#[derive(Clone, Debug)]
pub struct Variant {
    /// Row name.
    pub name: String,
    /// What it changes relative to the row above.
    pub change: String,
    /// Its parameters.
    pub params: SelfCalParams,
}

/// The variants (module docs), for `ctx`'s camera.
///
/// # Errors
/// A step name the calibration does not know (a bug).
pub fn variants(ctx: &SimContext) -> Result<Vec<Variant>> {
    let paper = SelfCalParams::for_method(&ctx.camera, SelfCalMethod::Paper);
    let ours = SelfCalMethod::Ours.steps();
    let mut out = vec![Variant {
        name: "paper".to_owned(),
        change: "the paper's method".to_owned(),
        params: paper.clone(),
    }];
    let mut current = paper.clone();
    for step in STEP_NAMES {
        let want = ours.is_on(step).context("ours' step")?;
        if current.steps.is_on(step).context("the paper's step")? == want {
            continue;
        }
        current.steps.set(step, want).context("setting a step")?;
        out.push(Variant {
            name: format!("{} {step}", if want { "+" } else { "-" }),
            change: format!("{step} {}", if want { "on" } else { "off" }),
            params: current.clone(),
        });
    }
    // Ours' keypoint settings, a row of their own where they differ from the paper's (the
    // ORB keypoint selection); the last row is ours.
    let mut ours_params = ctx.ours.clone();
    ours_params.steps = ours;
    if ours_params.orb != current.orb {
        let selection = ours_params.orb.distribution.name();
        out.push(Variant {
            name: format!("+ {selection}"),
            change: format!("ORB keypoints by {selection}"),
            params: ours_params.clone(),
        });
    }
    if let Some(last) = out.last_mut() {
        last.params = ours_params;
        last.name = format!("{} (= ours)", last.name);
    }
    out.push(Variant {
        name: "paper+ba".to_owned(),
        change: "the paper's method, eq. 15 as a bundle adjustment".to_owned(),
        params: SelfCalParams::for_method(&ctx.camera, SelfCalMethod::PaperBa),
    });
    Ok(out)
}

/// One trial's record: its seed and every variant's outcome, in [`variants`] order.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct AblationRecord {
    /// The trial's seed.
    pub seed: u64,
    /// Per variant: the errors, or the refusal text.
    pub outcomes: Vec<Result<PoseErrors, String>>,
}

/// Runs the experiment (module docs).
///
/// # Errors
/// Rendering, plotting or writing failures.
pub fn run(settings: &Settings) -> Result<()> {
    let trials = settings.trials_or(DEFAULT_TRIALS);
    let ctx = SimContext::new(settings)?;
    let variants = variants(&ctx)?;
    let records = settings.run_items(trials, |ids| {
        let progress = Progress::new("ablation", (ids.len() * (1 + variants.len())) as u64);
        let records = ids
            .iter()
            .map(|&t| -> Result<AblationRecord> {
                let seed = trial_seed(settings.seed, 5, t as u64);
                let trial = render_trial(&ctx, seed, VIEWS)?;
                let noise_seed = sim::rng::key(seed, STREAM_NOISE, 0);
                let views = calib_views(&ctx, &trial, VIEWS, SIGMA, noise_seed, true)?;
                progress.inc(1);
                let outcomes = variants
                    .iter()
                    .map(|v| {
                        let o = self_calibrate(&views, &ctx.camera, &v.params)
                            .map(|r| {
                                PoseErrors::of(&r.solution.tool0_from_camera, &trial.true_mount)
                            })
                            .map_err(|e| e.to_string());
                        progress.inc(1);
                        o
                    })
                    .collect();
                Ok(AblationRecord { seed, outcomes })
            })
            .collect::<Result<Vec<_>>>();
        progress.finish();
        records
    })?;
    let Some(records) = records else {
        return Ok(());
    };

    let mut report = Report::new("Experiment ablation: from the paper's method to ours");
    report.paragraph(&format!(
        "{trials} trials x {VIEWS} RGB-D views ({}x{} renders, wrist lens), image noise sigma \
         {SIGMA} on [0, 1] intensities with its depth noise. Each row switches one step of the \
         row above to what ours does, from the paper's method down to ours; every row runs on \
         the same views. Errors against the simulator's true mount. 'answered' counts the \
         trials a variant answered (its refusals are the rest), with the Wilson 95% interval; \
         the errors are over its own answers, and then over the trials every variant answered.",
        ctx.camera.width, ctx.camera.height
    ));
    let all_answered: Vec<bool> = records
        .iter()
        .map(|r| r.outcomes.iter().all(Result::is_ok))
        .collect();
    let n_common = all_answered.iter().filter(|&&a| a).count();
    let mut table = Table::new(&[
        "variant",
        "change",
        "answered",
        "95% interval (Wilson)",
        "e_R mean",
        "e_t mm mean",
        "e_t mm median",
        &format!("e_R mean, all answered ({n_common})"),
        &format!("e_t mm mean, all answered ({n_common})"),
    ]);
    let mut rows = Vec::new();
    for (k, v) in variants.iter().enumerate() {
        let answers: Vec<&PoseErrors> = records
            .iter()
            .filter_map(|r| r.outcomes.get(k)?.as_ref().ok())
            .collect();
        let common: Vec<&PoseErrors> = records
            .iter()
            .zip(&all_answered)
            .filter(|(_, a)| **a)
            .filter_map(|(r, _)| r.outcomes.get(k)?.as_ref().ok())
            .collect();
        let stats = |e: &[&PoseErrors]| {
            (
                Summary::of(&e.iter().map(|e| e.e_r).collect::<Vec<_>>()),
                Summary::of(&e.iter().map(|e| e.e_t_mm).collect::<Vec<_>>()),
            )
        };
        let (er, et) = stats(&answers);
        let (cer, cet) = stats(&common);
        let (lo, hi) = wilson_95(answers.len(), records.len());
        table.row(vec![
            v.name.clone(),
            v.change.clone(),
            format!("{}/{}", answers.len(), records.len()),
            format!("{} - {}", fmt_pct(lo, 0), fmt_pct(hi, 0)),
            fmt_num(er.mean, 5),
            fmt_num(et.mean, 2),
            fmt_num(et.median, 2),
            fmt_num(cer.mean, 5),
            fmt_num(cet.mean, 2),
        ]);
        rows.push(serde_json::json!({
            "variant": v.name,
            "change": v.change,
            "trials": records.len(),
            "answered": answers.len(),
            "answered_95": [lo, hi],
            "e_r": er,
            "e_t_mm": et,
            "all_answered_trials": n_common,
            "e_r_all_answered": cer,
            "e_t_mm_all_answered": cet,
            "refusals": records
                .iter()
                .filter_map(|r| r.outcomes.get(k)?.as_ref().err().cloned())
                .collect::<Vec<_>>(),
        }));
    }
    report.table(&table);
    let mut results = Results::new("ablation", settings.seed);
    results.seeds = records.iter().map(|r| r.seed).collect();
    results.parameter("trials", trials)?;
    results.parameter("views", VIEWS)?;
    results.parameter("sigma", SIGMA)?;
    results.parameter("width", ctx.camera.width)?;
    results.parameter("height", ctx.camera.height)?;
    results.section("variants", &rows)?;
    report.write(settings.out.root())?;
    settings.write_results(&results)?;
    crate::cmd::print_stdout(&format!(
        "{}",
        settings.out.root().join("report.md").display()
    ))?;
    Ok(())
}
