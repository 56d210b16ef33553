//! SIFT end to end on a real photograph (shecar `00.jpg`, a seeded synthetic scene when the
//! public data is absent):
//!
//! - descriptor invariance: the image and its rotation by 30 degrees with scale 0.75 and a
//!   mild perspective (known homography); the ratio-test matches land within 3 px of the
//!   true position at least as often as OpenCV's on the same pair (80% at ratio 0.8, 90% at
//!   0.7; on the synthetic scene of the unit tests, 90% at 0.8);
//! - parity with OpenCV 4.x `cv2.SIFT_create(enable_precise_upscale=True)` on the same
//!   pixels (skipped with a notice without the reference venv `<repo>/.venv-ref`, or
//!   `RODLOG_REF_VENV`): keypoint count within 20% and repeatability under the warp at
//!   least 90% of OpenCV's.

use std::process::Command;

#[path = "../benches/common/frames.rs"]
mod frames;

use calib::features::GrayBuf;
use calib::features::sift::{
    SiftKeypoint, SiftMatchParams, SiftParams, detect_and_describe, match_l2_ratio,
};
use calib::features::synth::{apply_homography, similarity, warp_homography};
use nalgebra::Matrix3;

/// A 640x512 crop of shecar 00 (or a synthetic scene).
fn frame() -> GrayBuf {
    frames::shecar_or_synthetic(640, 512, 7)
}

fn warp() -> Matrix3<f64> {
    let mut h = similarity(30f64.to_radians(), 0.75, 320.0, 256.0, 10.0, -5.0);
    h[(2, 0)] = 1e-4;
    h[(2, 1)] = -5e-5;
    h
}

fn dist_to_truth(h: &Matrix3<f64>, ka: &SiftKeypoint, kb: &SiftKeypoint) -> f64 {
    let (x, y) = apply_homography(h, f64::from(ka.x), f64::from(ka.y));
    (x - f64::from(kb.x)).hypot(y - f64::from(kb.y))
}

#[test]
fn ratio_matches_of_a_rotated_scaled_photo_are_correct() {
    let a = frame();
    let h = warp();
    let b = warp_homography(&a, &h, 640, 512, 0).expect("warp");
    let p = SiftParams::default();
    let fa = detect_and_describe(&a.view(), &p).expect("sift a");
    let fb = detect_and_describe(&b.view(), &p).expect("sift b");
    // (ratio, least share correct): OpenCV 4.14 SIFT + BFMatcher on the same shecar pair
    // gets 79.9% at 0.8 and 89.7% at 0.7 (the photo's chessboards and shelves repeat).
    for (ratio, least) in [(0.8f32, 0.80f64), (0.7, 0.90)] {
        let mp = SiftMatchParams {
            ratio: Some(ratio),
            ..SiftMatchParams::default()
        };
        let m = match_l2_ratio(&fa.descriptors, &fb.descriptors, &mp);
        let good = m
            .iter()
            .filter(|m| {
                dist_to_truth(
                    &h,
                    &fa.keypoints[m.query as usize],
                    &fb.keypoints[m.train as usize],
                ) < 3.0
            })
            .count();
        let rate = good as f64 / m.len().max(1) as f64;
        eprintln!(
            "ratio {ratio}: keypoints {} / {}, matches {}, correct {good} ({:.1}%)",
            fa.keypoints.len(),
            fb.keypoints.len(),
            m.len(),
            100.0 * rate
        );
        assert!(m.len() >= 200, "ratio {ratio}: only {} matches", m.len());
        assert!(
            rate >= least,
            "ratio {ratio}: {good} of {} correct",
            m.len()
        );
    }
}

const OPENCV: &str = r#"
import json, sys
import cv2
cv2.setNumThreads(1)
s = cv2.SIFT_create(enable_precise_upscale=True)
out = {}
for name in ("a", "b"):
    img = cv2.imread(sys.argv[1 if name == "a" else 2], cv2.IMREAD_GRAYSCALE)
    out[name] = [[k.pt[0], k.pt[1]] for k in s.detect(img, None)]
print(json.dumps(out))
"#;

/// Share of A's keypoints (mapped into B, inside it) with a B keypoint within 2.5 px, over
/// the smaller of the two counts in the common region.
fn repeatability(ka: &[(f64, f64)], kb: &[(f64, f64)], h: &Matrix3<f64>) -> f64 {
    let hinv = h.try_inverse().expect("invertible");
    let inside = |(x, y): (f64, f64)| (0.0..640.0).contains(&x) && (0.0..512.0).contains(&y);
    let a: Vec<(f64, f64)> = ka
        .iter()
        .map(|p| apply_homography(h, p.0, p.1))
        .filter(|p| inside(*p))
        .collect();
    let b: Vec<(f64, f64)> = kb
        .iter()
        .copied()
        .filter(|p| inside(apply_homography(&hinv, p.0, p.1)))
        .collect();
    let hits = a
        .iter()
        .filter(|p| b.iter().any(|q| (q.0 - p.0).hypot(q.1 - p.1) <= 2.5))
        .count();
    hits as f64 / a.len().min(b.len()).max(1) as f64
}

#[test]
fn keypoint_count_and_repeatability_match_opencv() {
    let Some(py) = testkit::venv_tool("python", "SIFT against OpenCV") else {
        return;
    };
    let a = frame();
    let h = warp();
    let b = warp_homography(&a, &h, 640, 512, 0).expect("warp");
    let dir = tempfile::tempdir().expect("tempdir");
    let (pa, pb) = (dir.path().join("a.png"), dir.path().join("b.png"));
    for (img, p) in [(&a, &pa), (&b, &pb)] {
        image::GrayImage::from_raw(640, 512, img.data.clone())
            .expect("image")
            .save(p)
            .expect("save");
    }
    let out = Command::new(&py)
        .arg("-c")
        .arg(OPENCV)
        .arg(&pa)
        .arg(&pb)
        .output()
        .expect("run python");
    let v: serde_json::Value = serde_json::from_slice(&out.stdout)
        .unwrap_or_else(|e| panic!("{e}: {}", String::from_utf8_lossy(&out.stderr)));
    let pts = |k: &str| -> Vec<(f64, f64)> {
        v[k].as_array()
            .expect("points")
            .iter()
            .map(|p| (p[0].as_f64().unwrap_or(0.0), p[1].as_f64().unwrap_or(0.0)))
            .collect()
    };
    let (cva, cvb) = (pts("a"), pts("b"));
    let p = SiftParams::default();
    let fa = detect_and_describe(&a.view(), &p).expect("sift a");
    let fb = detect_and_describe(&b.view(), &p).expect("sift b");
    let xy = |k: &[SiftKeypoint]| -> Vec<(f64, f64)> {
        k.iter().map(|k| (f64::from(k.x), f64::from(k.y))).collect()
    };
    let (ours_a, ours_b) = (xy(&fa.keypoints), xy(&fb.keypoints));
    let rep_ours = repeatability(&ours_a, &ours_b, &h);
    let rep_cv = repeatability(&cva, &cvb, &h);
    eprintln!(
        "keypoints A: rodlog {} OpenCV {}; B: rodlog {} OpenCV {}; repeatability rodlog {rep_ours:.3} OpenCV {rep_cv:.3}",
        ours_a.len(),
        cva.len(),
        ours_b.len(),
        cvb.len()
    );
    for (ours, cv) in [(ours_a.len(), cva.len()), (ours_b.len(), cvb.len())] {
        let r = ours as f64 / cv.max(1) as f64;
        assert!((0.8..=1.2).contains(&r), "count ratio {r} ({ours} vs {cv})");
    }
    assert!(
        rep_ours >= 0.9 * rep_cv,
        "repeatability {rep_ours} vs OpenCV {rep_cv}"
    );
}
