//! `rodlog experiment datasets` (ARCHITECTURE.md section 7, the paper's Tables 2-3): ours
//! vs ZHI on two datasets.
//!
//! - **Dataset 1, simulator**: the trials of [`super::noise`] (18 seeded views each) with no
//!   added image noise (the wrist sensor's own noise only); mean (and median) `e_t`, `e_R`
//!   and `theta` against the true mount per method; the improvement of ours over ZHI is
//!   `(zhi - ours) / zhi` of the means. Paper: 25.8 % (`e_t`) and 17.3 % (`e_R`).
//! - **Dataset 2, shecar** (ZHI's own sample, `../shared/data/shecar`, 18 phone photos,
//!   monocular): images resized by [`crate::import::shecar::EXPERIMENT_SCALE`] x `--image-scale`; ours (mono) and ZHI.
//!   There is no exact truth, so each X is scored by the residuals of `B_ij X = X A_ij` over
//!   the 153 pairs `i < j` with a **common** set of eye motions `A_ij`: the chessboard
//!   poses (6x8 inner corners, 28.3 mm squares, `calib::board`) of the two views. Rotation
//!   residual = angle of `(R_B R_X)^T R_X R_A`, translation residual =
//!   `|(R_B - I) t_X + t_B - s R_X t_A|` with the one scale `s` fitted by least squares
//!   (scale-corrected; the board's metric scale is not trusted either); medians over the
//!   pairs. Beside them, each method's residuals over its *own* eye motions (its median
//!   pair residuals, a self-consistency figure) and the distance to the board's own
//!   hand-eye solution, which the README shows is only good to about 1 deg / 2 cm (a sanity
//!   bound, not a truth). Paper: ours 25.3 % / 24.6 % better.

use anyhow::{Context, Result};
use calib::board::{BoardOptions, BoardSpec, board_view};
use calib::handeye::{HandEyeOptions, Method, RelativeMotion, refine::pair_residual};
use calib::relpose::CameraModel;
use calib::selfcal::{CalibView, self_calibrate};
use calib::zhi::{ZhiParams, calibrate_zhi};
use nalgebra::Isometry3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::noise::{
    Cell, METHODS, SimContext, TrialRecord, VIEWS, all_answered, all_answered_table, book_trials,
    box_plots, error_table, ours_params, refusal_table, render_trial, run_methods,
};
use super::progress::Progress;
use super::report::{Comparison, Report, Results, Table, fmt_num, fmt_pct};
use super::stats::Summary;
use super::{Settings, trial_seed};

/// Simulator trials when `--trials` is not given.
pub const DEFAULT_TRIALS: usize = 100;
/// The paper's improvements of ours over ZHI: dataset 1 (e_t, e_R), dataset 2 (e_t, e_R).
pub const PAPER: [(f64, f64); 2] = [(0.258, 0.173), (0.253, 0.246)];

/// Residual figures of one X on shecar.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ShecarScore {
    /// Method.
    pub method: String,
    /// `tool0_from_camera` translation, metres, and quaternion (x, y, z, w).
    pub translation_m: [f64; 3],
    /// Quaternion (x, y, z, w).
    pub quaternion_xyzw: [f64; 4],
    /// Pairs scored with the board motions.
    pub board_pairs: usize,
    /// Median rotation residual over the board motions, degrees.
    pub board_rot_deg: f64,
    /// Median scale-corrected translation residual over the board motions, mm.
    pub board_trans_mm: f64,
    /// The fitted board scale.
    pub board_scale: f64,
    /// The method's own median pair residuals (rotation deg, translation mm).
    pub own_rot_deg: f64,
    /// Own translation residual, mm.
    pub own_trans_mm: f64,
    /// Rotation and translation distance to the board's hand-eye solution (deg, mm).
    pub vs_board_deg: f64,
    /// Translation distance to the board solution, mm.
    pub vs_board_mm: f64,
}

/// One item of the experiment: a simulator trial, or the shecar scoring (the last item),
/// which a shard keeps as it is and a merge books again.
#[derive(Serialize, Deserialize)]
enum DatasetItem {
    Simulator(TrialRecord),
    Shecar(Result<ShecarRecord, String>),
}

/// What the report says of shecar.
#[derive(Serialize, Deserialize)]
struct ShecarRecord {
    scores: Vec<ShecarScore>,
    scale: f64,
    width: u32,
    height: u32,
    board_pairs: usize,
}

fn median(v: &[f64]) -> f64 {
    Summary::of(v).median
}

/// Median rotation (deg) and scale-corrected translation (mm) residuals of `x` over
/// `motions` (module docs), and the fitted scale.
pub fn board_residuals(motions: &[RelativeMotion], x: &Isometry3<f64>) -> (f64, f64, f64) {
    let r_x = x.rotation.to_rotation_matrix().into_inner();
    let (mut num, mut den) = (0.0, 0.0);
    for m in motions {
        let (_, r_t0) = pair_residual(m, x, 0.0); // (R_B - I) t_X + t_B
        let u = r_x * m.a.translation.vector;
        num += u.dot(&r_t0);
        den += u.norm_squared();
    }
    let s = if den > 0.0 { num / den } else { 1.0 };
    let (rot, tr): (Vec<f64>, Vec<f64>) = motions
        .iter()
        .map(|m| {
            let (r, t) = pair_residual(m, x, s);
            (r.norm().to_degrees(), t.norm() * 1e3)
        })
        .unzip();
    (median(&rot), median(&tr), s)
}

/// Runs the experiment (module docs).
///
/// # Errors
/// Rendering, reading shecar, plotting or writing failures.
pub fn run(settings: &Settings) -> Result<()> {
    let trials = settings.trials_or(DEFAULT_TRIALS);
    let ctx = SimContext::new(settings)?;
    let cond = "simulator".to_owned();
    // Items 0..trials are the simulator's trials, item `trials` is shecar.
    let items = settings.run_items(trials + 1, |ids| {
        let progress = Progress::new("datasets", (2 * ids.len() + 3) as u64);
        let items = ids
            .iter()
            .map(|&i| -> Result<DatasetItem> {
                if i == trials {
                    let shecar = shecar_scores(settings, &progress)
                        .map(|(scores, scale, camera, board_pairs)| ShecarRecord {
                            scores,
                            scale,
                            width: camera.width,
                            height: camera.height,
                            board_pairs,
                        })
                        .map_err(|e| format!("{e:#}"));
                    return Ok(DatasetItem::Shecar(shecar));
                }
                let seed = trial_seed(settings.seed, 2, i as u64);
                let trial = render_trial(&ctx, seed, VIEWS)?;
                progress.inc(1);
                let outcomes = run_methods(&ctx, &trial, VIEWS, 0.0, 0)?;
                progress.inc(1);
                Ok(DatasetItem::Simulator(TrialRecord {
                    seed,
                    outcomes: vec![outcomes],
                    peer: Vec::new(),
                }))
            })
            .collect::<Result<Vec<_>>>();
        progress.finish();
        items
    })?;
    let Some(items) = items else {
        return Ok(());
    };
    let mut records = Vec::with_capacity(trials);
    let mut shecar = Err("shecar was not run".to_owned());
    for item in items {
        match item {
            DatasetItem::Simulator(r) => records.push(r),
            DatasetItem::Shecar(s) => shecar = s,
        }
    }
    let conditions = vec![cond.clone()];
    let (cells, refusals, seeds) = book_trials(&records, &conditions);
    let mut report = Report::new("Experiment datasets: ours vs ZHI (paper Tables 2-3)");
    if let Some(note) = settings.ours_variant_note() {
        report.paragraph(&note);
    }
    report.heading("Dataset 1: simulator");
    report.paragraph(&format!(
        "{trials} trials x {VIEWS} views ({}x{} renders, wrist lens), no added image noise. \
         Errors against the simulator's true mount.",
        ctx.camera.width, ctx.camera.height
    ));
    let (table, rows) = error_table(&conditions, &cells, &refusals, "dataset");
    report.table(&table);
    let (common, common_trials) = all_answered(&records, &conditions);
    let (common_table, common_rows) =
        all_answered_table(&conditions, &common, &common_trials, "dataset");
    report.paragraph("Over the trials every method answered:");
    report.table(&common_table);
    let summary_of = |m: usize, f: fn(&Cell) -> &Vec<f64>| -> Summary {
        cells
            .first()
            .and_then(|v| v.get(m))
            .map_or_else(|| Summary::of(&[]), |c| Summary::of(f(c)))
    };
    let mean_of = |m: usize, f: fn(&Cell) -> &Vec<f64>| -> f64 { summary_of(m, f).mean };
    let zhi = METHODS.iter().position(|m| *m == "zhi").unwrap_or(2);
    let mut imp = Table::new(&[
        "ours mode",
        "mean e_t ours / ZHI (mm)",
        "e_t better by",
        "mean e_R ours / ZHI",
        "e_R better by",
        "paper (e_t / e_R)",
    ]);
    let mut improvements = Vec::new();
    let mut comparisons = Vec::new();
    for (m, name) in METHODS.iter().enumerate().filter(|(m, _)| *m != zhi) {
        let (ot, zt) = (mean_of(m, |c| &c.e_t_mm), mean_of(zhi, |c| &c.e_t_mm));
        let (or, zr) = (mean_of(m, |c| &c.e_r), mean_of(zhi, |c| &c.e_r));
        let (it, ir) = ((zt - ot) / zt, (zr - or) / zr);
        imp.row(vec![
            (*name).to_owned(),
            format!("{} / {}", fmt_num(ot, 2), fmt_num(zt, 2)),
            fmt_pct(it, 1),
            format!("{} / {}", fmt_num(or, 5), fmt_num(zr, 5)),
            fmt_pct(ir, 1),
            format!("{} / {}", fmt_pct(PAPER[0].0, 1), fmt_pct(PAPER[0].1, 1)),
        ]);
        improvements.push(serde_json::json!({"method": name, "e_t": it, "e_r": ir}));
        if matches!(*name, "ours-rgbd" | "ours-mono") {
            comparisons.push(Comparison::new(
                &format!("{name}: mean e_t and e_R better than ZHI's on dataset 1 (Table 3)"),
                &format!("by {} / {}", fmt_pct(PAPER[0].0, 1), fmt_pct(PAPER[0].1, 1)),
                if it.is_finite() && ir.is_finite() {
                    format!("by {} / {} (simulator)", fmt_pct(it, 1), fmt_pct(ir, 1))
                } else {
                    "no answers to compare (simulator)".to_owned()
                },
                it.is_nan() || ir.is_nan() || it < PAPER[0].0 || ir < PAPER[0].1,
            ));
            // The paper compares means, which ZHI's few large errors dominate; the typical
            // trial is the median.
            let (mt, zmt) = (
                summary_of(m, |c| &c.e_t_mm).median,
                summary_of(zhi, |c| &c.e_t_mm).median,
            );
            let (mr, zmr) = (
                summary_of(m, |c| &c.e_r).median,
                summary_of(zhi, |c| &c.e_r).median,
            );
            comparisons.push(Comparison::new(
                &format!(
                    "{name}: median e_t and e_R against ZHI's on dataset 1 (the typical trial; Table 3 gives means only)"
                ),
                "not reported",
                format!(
                    "{} / {} mm, {} / {} (ours / ZHI, simulator)",
                    fmt_num(mt, 2),
                    fmt_num(zmt, 2),
                    fmt_num(mr, 5),
                    fmt_num(zmr, 5)
                ),
                !(mt <= zmt && mr <= zmr),
            ));
        }
    }
    report.table(&imp);
    box_plots(
        settings,
        &mut report,
        &conditions,
        &cells,
        "dataset",
        "datasets_sim",
    )?;
    if refusals.total_refused() > 0 {
        report.heading("Refusals (dataset 1)");
        report.table(&refusal_table(&refusals));
    }

    // Dataset 2: shecar.
    report.heading("Dataset 2: shecar (ZHI's sample)");
    let mut results = Results::new("datasets", settings.seed);
    results.parameter("orb_distribution", settings.ours_distribution().name())?;
    results.parameter("ours_steps", settings.steps_changed())?;
    match &shecar {
        Ok(ShecarRecord {
            scores,
            scale,
            width,
            height,
            board_pairs,
        }) => {
            report.paragraph(&format!(
                "18 photos resized to {}x{} (x{scale:.2}); eye motions for scoring: the \
                 chessboard poses ({board_pairs} pairs with the board found in both views). \
                 Residuals of B X = X A, medians over the pairs; translation residual with one \
                 least-squares scale. 'own' = the method's residuals over its own eye motions. \
                 'vs board X' = distance to the board's hand-eye solution (good to ~1 deg / \
                 2 cm only: a sanity bound). Paper: ours better by 25.3 % (e_t) and 24.6 % \
                 (e_R).",
                width, height
            ));
            let mut t = Table::new(&[
                "method",
                "rot residual deg (board A)",
                "trans residual mm (board A)",
                "own rot deg",
                "own trans mm",
                "vs board X deg",
                "vs board X mm",
            ]);
            for s in scores {
                t.row(vec![
                    s.method.clone(),
                    fmt_num(s.board_rot_deg, 3),
                    fmt_num(s.board_trans_mm, 2),
                    fmt_num(s.own_rot_deg, 3),
                    fmt_num(s.own_trans_mm, 2),
                    fmt_num(s.vs_board_deg, 3),
                    fmt_num(s.vs_board_mm, 2),
                ]);
            }
            report.table(&t);
            let get = |name: &str| scores.iter().find(|s| s.method == name);
            if let (Some(o), Some(z)) = (get("ours-mono"), get("zhi")) {
                let rot = (z.board_rot_deg - o.board_rot_deg) / z.board_rot_deg;
                let trans = (z.board_trans_mm - o.board_trans_mm) / z.board_trans_mm;
                report.paragraph(&format!(
                    "ours vs ZHI on shecar (board motions): rotation residual better by {}, \
                     translation residual better by {} (paper 24.6 % / 25.3 %).",
                    fmt_pct(rot, 1),
                    fmt_pct(trans, 1)
                ));
                comparisons.push(Comparison::new(
                    "ours-mono: e_t and e_R better than ZHI's on dataset 2, shecar (Table 3)",
                    &format!("by {} / {}", fmt_pct(PAPER[1].0, 1), fmt_pct(PAPER[1].1, 1)),
                    format!(
                        "by {} / {} (AX=XB residuals over the board's motions)",
                        fmt_pct(trans, 1),
                        fmt_pct(rot, 1)
                    ),
                    trans.is_nan() || rot.is_nan() || trans < PAPER[1].0 || rot < PAPER[1].1,
                ));
            }
            results.section("shecar", scores)?;
            results.parameter("shecar_scale", scale)?;
        }
        Err(e) => {
            report.paragraph(&format!("shecar not scored: {e}"));
            results.section("shecar_error", e)?;
            comparisons.push(Comparison::new(
                "ours-mono: e_t and e_R better than ZHI's on dataset 2, shecar (Table 3)",
                &format!("by {} / {}", fmt_pct(PAPER[1].0, 1), fmt_pct(PAPER[1].1, 1)),
                format!("not measured: {e}"),
                true,
            ));
        }
    }
    results.seeds = seeds;
    results.parameter("trials", trials)?;
    results.parameter("views", VIEWS)?;
    results.parameter("width", ctx.camera.width)?;
    results.parameter("height", ctx.camera.height)?;
    results.section("simulator", &rows)?;
    results.section("simulator_all_answered", &common_rows)?;
    results.section("simulator_improvement", &improvements)?;
    results.section("paper_improvement", PAPER)?;
    report.comparisons(&comparisons);
    results.section("comparisons", &comparisons)?;
    results.section("refusals", &refusals)?;
    report.write(settings.out.root())?;
    settings.write_results(&results)?;
    crate::cmd::print_stdout(&format!(
        "{}",
        settings.out.root().join("report.md").display()
    ))?;
    Ok(())
}

type ShecarOut = (Vec<ShecarScore>, f64, CameraModel, usize);

fn shecar_scores(settings: &Settings, progress: &Progress) -> Result<ShecarOut> {
    let crate::import::shecar::Resized {
        dataset,
        scale,
        camera,
    } = crate::import::shecar::open_resized(&compose::data::shecar_dir(), settings.image_scale)?;
    let (w, h) = (camera.width, camera.height);
    let views: Vec<CalibView> = dataset
        .views
        .par_iter()
        .enumerate()
        .map(|(i, v)| -> Result<CalibView> {
            let img = image::open(&v.image)
                .with_context(|| format!("decoding {}", v.image.display()))?
                .resize_exact(w, h, image::imageops::FilterType::Triangle)
                .to_luma8();
            Ok(CalibView {
                stamp_ns: i as u64,
                gray: img,
                depth_m: None,
                base_from_tool0: v.base_from_tool0,
            })
        })
        .collect::<Result<_>>()?;
    // Board poses (scoring only).
    let spec = BoardSpec::new(6, 8, 0.0283).context("board spec")?;
    let boards: Vec<Option<Isometry3<f64>>> = views
        .par_iter()
        .map(|v| {
            board_view(&v.gray, &camera, &spec, &BoardOptions::default())
                .ok()
                .map(|b| b.world_from_camera)
        })
        .collect();
    let mut motions = Vec::new();
    for i in 0..views.len() {
        for j in i + 1..views.len() {
            if let (Some(Some(ei)), Some(Some(ej)), Some(vi), Some(vj)) =
                (boards.get(i), boards.get(j), views.get(i), views.get(j))
            {
                motions.push(RelativeMotion::new(
                    ei.inverse() * ej,
                    vi.base_from_tool0.inverse() * vj.base_from_tool0,
                ));
            }
        }
    }
    let (hand, eye): (Vec<Isometry3<f64>>, Vec<Isometry3<f64>>) = views
        .iter()
        .zip(&boards)
        .filter_map(|(v, b)| Some((v.base_from_tool0, (*b)?)))
        .unzip();
    let board_x = calib::handeye::solve(
        &hand,
        &eye,
        &HandEyeOptions {
            method: Method::Park,
            scale_free: true,
            ..HandEyeOptions::default()
        },
    )
    .map(|s| s.tool0_from_camera)
    .context("board hand-eye reference")?;
    progress.inc(1);
    let mut scores = Vec::new();
    let score = |method: &str, x: &Isometry3<f64>, own: (f64, f64)| {
        let (r, t, s) = board_residuals(&motions, x);
        let (vd, vt) = calib::handeye::pose_error(x, &board_x);
        let q = x.rotation.coords;
        ShecarScore {
            method: method.to_owned(),
            translation_m: [x.translation.x, x.translation.y, x.translation.z],
            quaternion_xyzw: [q.x, q.y, q.z, q.w],
            board_pairs: motions.len(),
            board_rot_deg: r,
            board_trans_mm: t,
            board_scale: s,
            own_rot_deg: own.0,
            own_trans_mm: own.1,
            vs_board_deg: vd,
            vs_board_mm: vt * 1e3,
        }
    };
    scores.push(score("board", &board_x, (f64::NAN, f64::NAN)));
    let ours = self_calibrate(&views, &camera, &ours_params(&camera, settings))
        .map_err(|e| anyhow::anyhow!("ours refused on shecar: {e}"))?;
    progress.inc(1);
    scores.push(score(
        "ours-mono",
        &ours.solution.tool0_from_camera,
        (
            ours.solution.residual_rot_deg,
            ours.solution.residual_trans_mm,
        ),
    ));
    let zhi = calibrate_zhi(&views, &camera, &ZhiParams::for_camera(&camera))
        .map_err(|e| anyhow::anyhow!("ZHI refused on shecar: {e}"))?;
    progress.inc(1);
    scores.push(score(
        "zhi",
        &zhi.solution.tool0_from_camera,
        (
            zhi.solution.residual_rot_deg,
            zhi.solution.residual_trans_mm,
        ),
    ));
    Ok((scores, scale, camera, motions.len()))
}
