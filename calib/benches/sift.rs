//! SIFT on the 1280x1024 bench frame (shecar `00.jpg` cropped, or a synthetic scene) beside
//! OpenCV's `cv2.SIFT_create(enable_precise_upscale=True)` in the same run, both on one
//! thread.
//!
//! 1. Criterion: `sift/detect_and_describe/1280x1024` (all keypoints, sequential) and the
//!    brute-force L2 matcher with Lowe's ratio test 0.8 on those descriptors.
//! 2. Comparison (printed after the criterion groups): the frame and its homography warp
//!    (`common/frames.rs`) are written to `target/sift-bench/{a,b}.png`; the venv's OpenCV
//!    (`.venv-ref/bin/python`, `cv2.setNumThreads(1)`) times `detectAndCompute` and
//!    `BFMatcher(NORM_L2).knnMatch(k=2)` on the same pixels and returns keypoints and ratio
//!    matches; both sides' keypoint counts, repeatability under the known warp, ratio
//!    matches and their share within 3 px of the true warp (the same metrics, computed
//!    here) and median times (own loops of [`RUNS`] runs, one side right after the other)
//!    are printed with their ratios. Skipped with a note when the venv is missing.
//!
//! OpenCV runs with `enable_precise_upscale=True` because rodlog doubles the image that way
//! (no quarter-pixel bias; `scale_space` docs); the cost is the same.
//!
//! Run: `cargo bench -p calib --bench sift`.

// Wall-clock timings and hashed sets of a test, bench or example: not a stage, so the
// crate's determinism lints do not apply here.
#![allow(clippy::disallowed_methods, clippy::disallowed_types)]

use std::hint::black_box;
use std::time::Instant;

use calib::features::GrayBuf;
use calib::features::sift::{
    SiftFeatures, SiftKeypoint, SiftMatchParams, SiftParams, detect_and_describe, match_l2_ratio,
};
use calib::features::synth::apply_homography;
use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::Matrix3;

#[path = "common/frames.rs"]
mod frames;
use frames::frames;
#[path = "common/side_by_side.rs"]
mod side_by_side;
use side_by_side::{OpenCvSide, json_numbers, json_points, json_rows, median, repeatability};

/// Runs of the side-by-side timing loops.
const RUNS: usize = 7;
/// A ratio match is correct when B's keypoint lies within this many pixels of A's mapped.
const CORRECT_PX: f64 = 3.0;

fn seq_params() -> SiftParams {
    SiftParams {
        parallel: false,
        ..SiftParams::default()
    }
}

fn seq_match() -> SiftMatchParams {
    SiftMatchParams {
        parallel: false,
        ..SiftMatchParams::default()
    }
}

fn detect(img: &GrayBuf) -> SiftFeatures {
    match detect_and_describe(&img.view(), &seq_params()) {
        Ok(f) => f,
        Err(e) => panic!("SIFT failed on the bench frame: {e}"),
    }
}

fn sift(c: &mut Criterion) {
    let (a, b) = frames();
    let params = seq_params();
    let mut g = c.benchmark_group("sift");
    g.sample_size(10)
        .warm_up_time(std::time::Duration::from_secs(1))
        .measurement_time(std::time::Duration::from_secs(10));
    g.bench_function("detect_and_describe/1280x1024", |bch| {
        bch.iter(|| detect_and_describe(black_box(&a.view()), &params).map(|f| f.keypoints.len()))
    });
    let (fa, fb) = (detect(&a), detect(&b));
    let mp = seq_match();
    let id = format!("{}x{}", fa.descriptors.len(), fb.descriptors.len());
    g.bench_function(format!("bf_l2_ratio/{id}"), |bch| {
        bch.iter(|| match_l2_ratio(black_box(&fa.descriptors), black_box(&fb.descriptors), &mp))
    });
    g.finish();
    compare_with_opencv(&a, &b);
}

/// Ratio matches `(xa, ya, xb, yb)` within [`CORRECT_PX`] of the warp.
fn correct(pairs: &[[f64; 4]], h: &Matrix3<f64>) -> usize {
    pairs
        .iter()
        .filter(|p| {
            let (x, y) = apply_homography(h, p[0], p[1]);
            (x - p[2]).hypot(y - p[3]) < CORRECT_PX
        })
        .count()
}

fn xy(k: &[SiftKeypoint]) -> Vec<(f64, f64)> {
    k.iter().map(|k| (f64::from(k.x), f64::from(k.y))).collect()
}

const OPENCV_SCRIPT: &str = r#"
import json, sys, time
import cv2
cv2.setNumThreads(1)
a = cv2.imread(sys.argv[1], cv2.IMREAD_GRAYSCALE)
b = cv2.imread(sys.argv[2], cv2.IMREAD_GRAYSCALE)
runs = int(sys.argv[3])
sift = cv2.SIFT_create(enable_precise_upscale=True)
ts = []
for _ in range(runs):
    t0 = time.perf_counter()
    ka, da = sift.detectAndCompute(a, None)
    ts.append((time.perf_counter() - t0) * 1e3)
kb, db = sift.detectAndCompute(b, None)
bf = cv2.BFMatcher(cv2.NORM_L2)
tm = []
for _ in range(runs):
    t0 = time.perf_counter()
    knn = bf.knnMatch(da, db, k=2)
    tm.append((time.perf_counter() - t0) * 1e3)
good = [m[0] for m in knn if len(m) == 2 and m[0].distance < 0.8 * m[1].distance]
print(json.dumps({
    "version": cv2.__version__,
    "detect_ms": ts, "knn_ms": tm,
    "a": [[k.pt[0], k.pt[1]] for k in ka],
    "b": [[k.pt[0], k.pt[1]] for k in kb],
    "pairs": [list(ka[m.queryIdx].pt) + list(kb[m.trainIdx].pt) for m in good],
}))
"#;

fn compare_with_opencv(a: &GrayBuf, b: &GrayBuf) {
    let Some(opencv) = OpenCvSide::prepare("sift-bench", a, b) else {
        return;
    };
    // Our side first (sequential), then OpenCV right after: the same machine load.
    let mut ours = Vec::new();
    for _ in 0..RUNS {
        let t0 = Instant::now();
        black_box(detect(a));
        ours.push(t0.elapsed().as_secs_f64() * 1e3);
    }
    let (fa, fb) = (detect(a), detect(b));
    let mut ours_match = Vec::new();
    let mut matches = Vec::new();
    for _ in 0..RUNS {
        let t0 = Instant::now();
        matches = match_l2_ratio(&fa.descriptors, &fb.descriptors, &seq_match());
        ours_match.push(t0.elapsed().as_secs_f64() * 1e3);
    }
    let our_pairs: Vec<[f64; 4]> = matches
        .iter()
        .map(|m| {
            let (ka, kb) = (
                &fa.keypoints[m.query as usize],
                &fb.keypoints[m.train as usize],
            );
            [ka.x, ka.y, kb.x, kb.y].map(f64::from)
        })
        .collect();
    let Some(v) = opencv.run(OPENCV_SCRIPT, RUNS) else {
        return;
    };
    let cv_pairs: Vec<[f64; 4]> = json_rows(&v, "pairs", 4)
        .iter()
        .map(|r| [r[0], r[1], r[2], r[3]])
        .collect();
    let (cva, cvb) = (json_points(&v, "a"), json_points(&v, "b"));
    let (w, h) = (a.width as f64, a.height as f64);
    let hb = frames::warp();
    let (rep_ours, ca, cb) = repeatability(&xy(&fa.keypoints), &xy(&fb.keypoints), &hb, w, h);
    let (rep_cv, cva_c, cvb_c) = repeatability(&cva, &cvb, &hb, w, h);
    let (t_ours, t_cv) = (
        median(&mut ours),
        median(&mut json_numbers(&v, "detect_ms")),
    );
    let (m_ours, m_cv) = (
        median(&mut ours_match),
        median(&mut json_numbers(&v, "knn_ms")),
    );
    let (ok_ours, ok_cv) = (correct(&our_pairs, &hb), correct(&cv_pairs, &hb));
    let rate = |ok: usize, n: usize| ok as f64 / n.max(1) as f64;
    println!(
        "\nSIFT beside OpenCV {} (1 thread, {}x{}, medians of {RUNS} runs)",
        v["version"], a.width, a.height
    );
    println!("                          rodlog      OpenCV    ratio");
    let ratio = |x: f64, y: f64| x / y.max(1e-9);
    let (na, nb) = (fa.keypoints.len(), fb.keypoints.len());
    println!(
        "keypoints A            {na:8}    {:8}    {:.3}",
        cva.len(),
        ratio(na as f64, cva.len() as f64)
    );
    println!(
        "keypoints B            {nb:8}    {:8}    {:.3}",
        cvb.len(),
        ratio(nb as f64, cvb.len() as f64)
    );
    println!(
        "repeatability (2.5px)     {rep_ours:.3}       {rep_cv:.3}    {:.3}   (common A/B: ours {ca}/{cb}, OpenCV {cva_c}/{cvb_c})",
        ratio(rep_ours, rep_cv)
    );
    println!(
        "ratio-0.8 matches      {:8}    {:8}    {:.3}",
        our_pairs.len(),
        cv_pairs.len(),
        ratio(our_pairs.len() as f64, cv_pairs.len() as f64)
    );
    println!(
        "correct (<3px)         {ok_ours:8}    {ok_cv:8}    {:.3}   (rate ours {:.3}, OpenCV {:.3})",
        ratio(ok_ours as f64, ok_cv as f64),
        rate(ok_ours, our_pairs.len()),
        rate(ok_cv, cv_pairs.len())
    );
    println!(
        "detect+describe ms     {t_ours:8.1}    {t_cv:8.1}    {:.3}",
        ratio(t_ours, t_cv)
    );
    println!(
        "BF 2-NN + ratio ms     {m_ours:8.1}    {m_cv:8.1}    {:.3}",
        ratio(m_ours, m_cv)
    );
}

criterion_group!(benches, sift);
criterion_main!(benches);
