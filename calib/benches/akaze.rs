//! AKAZE on the 1280x1024 bench frame (shecar `00.jpg` cropped, or a synthetic scene) beside
//! OpenCV's `cv2.AKAZE_create()` in the same run, both on one thread.
//!
//! 1. Criterion: `akaze/detect_and_describe/1280x1024` (sequential), the 486-bit Hamming
//!    matcher with the ratio test, and the fundamental-matrix RANSAC on those matches.
//! 2. Comparison (printed after the criterion groups): the frame and its homography warp
//!    (`common/frames.rs`) are written to `target/akaze-bench/{a,b}.png`; the venv's
//!    OpenCV (`.venv-ref/bin/python`, `cv2.setNumThreads(1)`) times `detectAndCompute` on
//!    the same pixels and returns its keypoints; both sides' keypoint counts, repeatability
//!    under the known warp (same metric, computed here) and median times (own loops of
//!    [`RUNS`] runs, interleaved in time with each other) are printed with their ratios.
//!    Skipped with a note when the venv is missing.
//!
//! Run: `cargo bench -p calib --bench akaze`.

// Wall-clock timings and hashed sets of a test, bench or example: not a stage, so the
// crate's determinism lints do not apply here.
#![allow(clippy::disallowed_methods, clippy::disallowed_types)]

use std::hint::black_box;
use std::time::Instant;

use calib::features::Keypoint;
use calib::features::akaze::{
    AkazeParams, MldbMatchParams, detect_and_describe_akaze, match_mldb, verify_fundamental,
};
use calib::relpose::fundamental::FundamentalParams;
use criterion::{Criterion, criterion_group, criterion_main};

#[path = "common/frames.rs"]
mod frames;
use frames::frames;
#[path = "common/side_by_side.rs"]
mod side_by_side;
use side_by_side::{OpenCvSide, json_numbers, json_points, median, repeatability};

/// Runs of the side-by-side timing loops.
const RUNS: usize = 15;

fn seq_params() -> AkazeParams {
    AkazeParams {
        parallel: false,
        ..AkazeParams::default()
    }
}

fn akaze(c: &mut Criterion) {
    let (a, b) = frames();
    let params = seq_params();
    let mut g = c.benchmark_group("akaze");
    g.sample_size(10)
        .warm_up_time(std::time::Duration::from_secs(1))
        .measurement_time(std::time::Duration::from_secs(6));
    g.bench_function("detect_and_describe/1280x1024", |bch| {
        bch.iter(|| {
            detect_and_describe_akaze(black_box(&a.view()), &params).map(|f| f.keypoints.len())
        })
    });
    let (Ok(fa), Ok(fb)) = (
        detect_and_describe_akaze(&a.view(), &params),
        detect_and_describe_akaze(&b.view(), &params),
    ) else {
        panic!("AKAZE failed on the bench frames");
    };
    let mp = MldbMatchParams {
        parallel: false,
        ..MldbMatchParams::default()
    };
    let id = format!("{}x{}", fa.descriptors.len(), fb.descriptors.len());
    g.bench_function(format!("bf_hamming486_ratio/{id}"), |bch| {
        bch.iter(|| match_mldb(black_box(&fa.descriptors), black_box(&fb.descriptors), &mp))
    });
    let matches = match_mldb(&fa.descriptors, &fb.descriptors, &mp);
    let fp = FundamentalParams::default();
    g.bench_function(format!("fundamental_ransac/{}", matches.len()), |bch| {
        bch.iter(|| verify_fundamental(&fa.keypoints, &fb.keypoints, black_box(&matches), &fp, 0).0)
    });
    g.finish();
    compare_with_opencv(&a, &b);
}

fn xy(k: &[Keypoint]) -> Vec<(f64, f64)> {
    k.iter().map(|k| (f64::from(k.x), f64::from(k.y))).collect()
}

const OPENCV_SCRIPT: &str = r#"
import json, statistics, sys, time
import cv2
cv2.setNumThreads(1)
a = cv2.imread(sys.argv[1], cv2.IMREAD_GRAYSCALE)
b = cv2.imread(sys.argv[2], cv2.IMREAD_GRAYSCALE)
runs = int(sys.argv[3])
ak = cv2.AKAZE_create()
ts = []
for _ in range(runs):
    t0 = time.perf_counter()
    ka, da = ak.detectAndCompute(a, None)
    ts.append((time.perf_counter() - t0) * 1e3)
kb, db = ak.detectAndCompute(b, None)
bf = cv2.BFMatcher(cv2.NORM_HAMMING)
tm = []
for _ in range(runs):
    t0 = time.perf_counter()
    knn = bf.knnMatch(da, db, k=2)
    tm.append((time.perf_counter() - t0) * 1e3)
good = [m[0] for m in knn if len(m) == 2 and m[0].distance < 0.8 * m[1].distance]
import numpy as np
pa = np.float64([ka[m.queryIdx].pt for m in good])
pb = np.float64([kb[m.trainIdx].pt for m in good])
F, mask = cv2.findFundamentalMat(pa, pb, cv2.FM_RANSAC, 1.0, 0.999)
print(json.dumps({
    "version": cv2.__version__,
    "detect_ms": ts, "knn_ms": tm,
    "a": [[k.pt[0], k.pt[1], k.size, k.angle] for k in ka],
    "a_desc": [bytes(d).hex() for d in da],
    "b": [[k.pt[0], k.pt[1]] for k in kb],
    "ratio_matches": len(good),
    "ransac_inliers": int(mask.sum()) if mask is not None else 0,
}))
"#;

fn compare_with_opencv(a: &calib::features::GrayBuf, b: &calib::features::GrayBuf) {
    let Some(opencv) = OpenCvSide::prepare("akaze-bench", a, b) else {
        return;
    };
    // Our side first (sequential), then OpenCV right after: the same machine load.
    let params = seq_params();
    let mut ours = Vec::new();
    let mut last = None;
    for _ in 0..RUNS {
        let t0 = Instant::now();
        let f = detect_and_describe_akaze(&a.view(), &params);
        ours.push(t0.elapsed().as_secs_f64() * 1e3);
        last = f.ok();
    }
    let (Some(fa), Ok(fb)) = (last, detect_and_describe_akaze(&b.view(), &params)) else {
        panic!("AKAZE failed");
    };
    let mp = MldbMatchParams {
        parallel: false,
        ..MldbMatchParams::default()
    };
    let mut ours_match = Vec::new();
    let mut matches = Vec::new();
    for _ in 0..RUNS {
        let t0 = Instant::now();
        matches = match_mldb(&fa.descriptors, &fb.descriptors, &mp);
        ours_match.push(t0.elapsed().as_secs_f64() * 1e3);
    }
    let (inl, _) = verify_fundamental(
        &fa.keypoints,
        &fb.keypoints,
        &matches,
        &FundamentalParams::default(),
        0,
    );
    let Some(v) = opencv.run(OPENCV_SCRIPT, RUNS) else {
        return;
    };
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
    println!(
        "\nAKAZE beside OpenCV {} (1 thread, {}x{}, medians of {RUNS} runs)",
        v["version"], a.width, a.height
    );
    println!("                         rodlog      OpenCV    ratio");
    println!(
        "keypoints A           {:8}    {:8}    {:.3}",
        fa.keypoints.len(),
        cva.len(),
        fa.keypoints.len() as f64 / cva.len().max(1) as f64
    );
    println!(
        "keypoints B           {:8}    {:8}    {:.3}",
        fb.keypoints.len(),
        cvb.len(),
        fb.keypoints.len() as f64 / cvb.len().max(1) as f64
    );
    println!(
        "repeatability (2.5px)    {rep_ours:.3}       {rep_cv:.3}    {:.3}   (common A/B: ours {ca}/{cb}, OpenCV {cva_c}/{cvb_c})",
        rep_ours / rep_cv.max(1e-9)
    );
    println!(
        "detect+describe ms    {t_ours:8.1}    {t_cv:8.1}    {:.3}",
        t_ours / t_cv
    );
    println!(
        "BF 2-NN + ratio ms    {m_ours:8.1}    {m_cv:8.1}    {:.3}",
        m_ours / m_cv
    );
    agreement(&fa, &v);
    println!(
        "ratio matches / F-RANSAC inliers: rodlog {} / {}, OpenCV {} / {}",
        matches.len(),
        inl.iter().filter(|x| **x).count(),
        v["ratio_matches"],
        v["ransac_inliers"]
    );
}

/// How far our keypoints, orientations and descriptors of A agree with OpenCV's: keypoints
/// at the same position (0.05 px) and size, their orientation difference and the Hamming
/// distance of their descriptors.
fn agreement(fa: &calib::features::akaze::AkazeFeatures, v: &serde_json::Value) {
    let (Some(kps), Some(descs)) = (v["a"].as_array(), v["a_desc"].as_array()) else {
        return;
    };
    let mut same = 0usize;
    let mut ang = Vec::new();
    let mut ham = Vec::new();
    for (k, d) in kps.iter().zip(descs) {
        let (Some(x), Some(y), Some(size), Some(deg), Some(hex)) = (
            k[0].as_f64(),
            k[1].as_f64(),
            k[2].as_f64(),
            k[3].as_f64(),
            d.as_str(),
        ) else {
            continue;
        };
        let Some((i, kp)) = fa.keypoints.iter().enumerate().find(|(_, q)| {
            (f64::from(q.x) - x).hypot(f64::from(q.y) - y) < 0.05
                && (f64::from(q.size) - size).abs() < 1e-3 * size
        }) else {
            continue;
        };
        same += 1;
        let da = (f64::from(kp.angle_rad).to_degrees() - deg + 180.0).rem_euclid(360.0) - 180.0;
        ang.push(da.abs());
        let bytes: Vec<u8> = (0..hex.len() / 2)
            .filter_map(|j| u8::from_str_radix(hex.get(2 * j..2 * j + 2)?, 16).ok())
            .collect();
        let ours = fa.descriptors[i].to_bytes();
        let dist: u32 = ours
            .iter()
            .zip(&bytes)
            .map(|(a, b)| (a ^ b).count_ones())
            .sum();
        ham.push(f64::from(dist));
    }
    let n = ang.len();
    let within1 = ang.iter().filter(|a| **a < 1.0).count();
    let exact = ham.iter().filter(|h| **h == 0.0).count();
    println!(
        "same keypoints (0.05 px, same size): {same} of {} ours / {} OpenCV; orientation within 1 deg: {within1} of {n} (median diff {:.3} deg); descriptors identical: {exact} of {n}, median Hamming {:.0} of 486 bits",
        fa.keypoints.len(),
        kps.len(),
        median(&mut ang),
        median(&mut ham)
    );
}

criterion_group!(benches, akaze);
criterion_main!(benches);
