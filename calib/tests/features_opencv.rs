//! Parity and comparison with OpenCV 4.x (`scripts/features/opencv_ref.py`, run in the
//! reference venv found via `RODLOG_REF_VENV`, default `<repo>/.venv-ref`; the tests are
//! skipped with a notice when it is absent).
//!
//! - GMS: the same keypoints and matches give the same inlier mask as
//!   `cv2.xfeatures2d.matchGMS`, with and without the rotation and scale options, under
//!   rotations of 25, 90 and -45 degrees and scales 0.85, 1, 0.7.
//! - ORB + BF + GMS on a shecar image and a known homography warp of it (skipped when
//!   `../shared/data/shecar` is absent): rodlog keeps at least as many correct matches as
//!   OpenCV ORB + BFMatcher + matchGMS on the same two PNG files, at least at its rate.

use std::path::{Path, PathBuf};
use std::process::Command;

use calib::features::command::{PairMatching, gray_from_encoded, match_pair};
use calib::features::gms::{GmsParams, gms_filter};
use calib::features::gray::{GrayBuf, GrayView};
use calib::features::matcher::Match;
use calib::features::synth::{SplitMix64, apply_homography, similarity, warp_homography};
use calib::features::{Keypoint, MatchResult};
use nalgebra::Matrix3;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn python() -> Option<PathBuf> {
    testkit::venv_tool("python", "OpenCV feature parity")
}

fn reference(py: &Path, args: &[&str]) -> serde_json::Value {
    let out = Command::new(py)
        .arg(repo().join("scripts/features/opencv_ref.py"))
        .args(args)
        .output()
        .expect("run opencv_ref.py");
    assert!(
        out.status.success(),
        "opencv_ref.py failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("json")
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("rodlog-features-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir.join(name)
}

#[test]
fn gms_mask_equals_opencv() {
    let Some(py) = python() else { return };
    let (w, h) = (1280usize, 1024usize);
    for (deg, scale) in [(25.0f64, 0.85), (90.0, 1.0), (-45.0, 0.7)] {
        let hb = similarity(deg.to_radians(), scale, 640.0, 512.0, 10.0, 20.0);
        let mut rng = SplitMix64::new(5);
        let kp = |x: f64, y: f64| Keypoint {
            x: x as f32,
            y: y as f32,
            level: 0,
            angle_rad: 0.0,
            response: 0.0,
            size: 31.0,
        };
        let (mut kps_a, mut kps_b, mut matches) = (Vec::new(), Vec::new(), Vec::new());
        while kps_a.len() < 2500 {
            let (x, y) = (rng.next_f64() * w as f64, rng.next_f64() * h as f64);
            let (bx, by) = if kps_a.len() % 3 != 0 {
                let (bx, by) = apply_homography(&hb, x, y);
                (
                    bx + 2.0 * rng.next_f64() - 1.0,
                    by + 2.0 * rng.next_f64() - 1.0,
                )
            } else {
                (rng.next_f64() * w as f64, rng.next_f64() * h as f64)
            };
            if !(0.0..w as f64).contains(&bx) || !(0.0..h as f64).contains(&by) {
                continue;
            }
            let i = kps_a.len() as u32;
            kps_a.push(kp(x, y));
            kps_b.push(kp(bx, by));
            matches.push(Match {
                query: i,
                train: i,
                distance: 0,
            });
        }
        for (with_rotation, with_scale) in
            [(false, false), (true, false), (false, true), (true, true)]
        {
            let params = GmsParams {
                with_rotation,
                with_scale,
                ..Default::default()
            };
            let ours = gms_filter(&kps_a, (w, h), &kps_b, (w, h), &matches, &params);
            let input = serde_json::json!({
                "size_a": [w, h], "size_b": [w, h],
                "kps_a": kps_a.iter().map(|k| [k.x, k.y]).collect::<Vec<_>>(),
                "kps_b": kps_b.iter().map(|k| [k.x, k.y]).collect::<Vec<_>>(),
                "matches": matches.iter().map(|m| [m.query, m.train]).collect::<Vec<_>>(),
                "with_rotation": with_rotation, "with_scale": with_scale, "threshold_factor": 6.0,
            });
            let path = scratch(&format!("gms_{deg}_{with_rotation}_{with_scale}.json"));
            std::fs::write(&path, input.to_string()).expect("write");
            let theirs: Vec<bool> = reference(&py, &["gms", path.to_str().expect("utf8")])["mask"]
                .as_array()
                .expect("mask")
                .iter()
                .map(|v| v.as_bool().unwrap_or(false))
                .collect();
            let differ = ours.iter().zip(&theirs).filter(|(a, b)| a != b).count();
            let kept = ours.iter().filter(|&&k| k).count();
            eprintln!(
                "{deg} deg x{scale}: rot {with_rotation} scale {with_scale}: {kept} kept, {differ} differ from OpenCV"
            );
            assert_eq!(ours.len(), theirs.len());
            assert_eq!(
                differ, 0,
                "{deg} deg x{scale}: rot {with_rotation} scale {with_scale}"
            );
        }
    }
}

/// (correct within 3 px, correct within 3 px at the keypoint's level = 3 * 1.2^level, kept).
fn score(pairs: &[(f64, f64, u32, f64, f64)], hb: &Matrix3<f64>) -> (usize, usize, usize) {
    let (mut strict, mut level) = (0, 0);
    for &(xa, ya, la, xb, yb) in pairs {
        let (x, y) = apply_homography(hb, xa, ya);
        let e = (x - xb).hypot(y - yb);
        strict += usize::from(e < 3.0);
        level += usize::from(e < 3.0 * 1.2f64.powi(la as i32));
    }
    (strict, level, pairs.len())
}

fn our_pairs(r: &MatchResult) -> Vec<(f64, f64, u32, f64, f64)> {
    r.inlier_matches()
        .map(|m| {
            let a = &r.features_a.keypoints[m.query as usize];
            let b = &r.features_b.keypoints[m.train as usize];
            (
                f64::from(a.x),
                f64::from(a.y),
                u32::from(a.level),
                f64::from(b.x),
                f64::from(b.y),
            )
        })
        .collect()
}

#[test]
fn orb_bf_gms_at_least_matches_opencv_on_known_homographies() {
    let Some(py) = python() else { return };
    let Some(shecar) = testkit::shared_data("shecar", "ORB+BF+GMS against OpenCV on shecar") else {
        return;
    };
    let cases = [
        (
            "00.jpg",
            Matrix3::new(0.95, -0.12, 60.0, 0.10, 0.97, -20.0, 2e-5, -1e-5, 1.0),
        ),
        (
            "05.jpg",
            Matrix3::new(0.85, 0.05, 90.0, -0.04, 0.88, 70.0, -3e-5, 2e-5, 1.0),
        ),
        (
            "10.jpg",
            Matrix3::new(1.1, -0.03, -40.0, 0.03, 1.1, -50.0, 0.0, 0.0, 1.0),
        ),
    ];
    let (mut ours_total, mut cv_total) = ((0, 0, 0), (0, 0, 0));
    for (name, hb) in cases {
        let full =
            gray_from_encoded(&std::fs::read(shecar.join(name)).expect("read")).expect("decode");
        let small =
            image::imageops::resize(&full, 1280, 720, image::imageops::FilterType::Triangle);
        let mut a = GrayBuf::default();
        a.copy_from(&GrayView::from_image(&small));
        let b = warp_homography(&a, &hb, 1280, 720, 0).expect("warp");
        let (pa, pb) = (
            scratch(&format!("a_{name}.png")),
            scratch(&format!("b_{name}.png")),
        );
        for (img, p) in [(&a, &pa), (&b, &pb)] {
            image::GrayImage::from_raw(img.width as u32, img.height as u32, img.data.clone())
                .expect("image")
                .save(p)
                .expect("save png");
        }
        let decoded = |p: &std::path::Path| {
            gray_from_encoded(&std::fs::read(p).expect("read")).expect("decode")
        };
        let r = match_pair(&decoded(&pa), &decoded(&pb), &PairMatching::default()).expect("match");
        let ours = score(&our_pairs(&r), &hb);
        let cv = reference(
            &py,
            &[
                "orb-gms",
                pa.to_str().expect("utf8"),
                pb.to_str().expect("utf8"),
            ],
        );
        let cv_pairs: Vec<(f64, f64, u32, f64, f64)> = cv["matches"]
            .as_array()
            .expect("matches")
            .iter()
            .filter_map(|m| {
                let v = m.as_array()?;
                let f = |i: usize| v.get(i).and_then(serde_json::Value::as_f64);
                Some((f(0)?, f(1)?, f(2)? as u32, f(3)?, f(4)?))
            })
            .collect();
        let theirs = score(&cv_pairs, &hb);
        eprintln!(
            "{name}: rodlog {}/{} correct at 3 px ({}/{} at 3 px x level scale), {} kp; OpenCV {}/{} ({}/{}), {} kp",
            ours.0,
            ours.2,
            ours.1,
            ours.2,
            r.features_a.keypoints.len(),
            theirs.0,
            theirs.2,
            theirs.1,
            theirs.2,
            cv["keypoints_a"]
        );
        ours_total = (
            ours_total.0 + ours.0,
            ours_total.1 + ours.1,
            ours_total.2 + ours.2,
        );
        cv_total = (
            cv_total.0 + theirs.0,
            cv_total.1 + theirs.1,
            cv_total.2 + theirs.2,
        );
    }
    let rate = |t: (usize, usize, usize)| t.1 as f64 / t.2.max(1) as f64;
    eprintln!(
        "total: rodlog {ours_total:?} rate {:.3}; OpenCV {cv_total:?} rate {:.3}",
        rate(ours_total),
        rate(cv_total)
    );
    assert!(
        ours_total.1 >= cv_total.1,
        "correct matches: rodlog {ours_total:?} < OpenCV {cv_total:?}"
    );
    assert!(
        rate(ours_total) >= rate(cv_total),
        "rate: rodlog {ours_total:?} < OpenCV {cv_total:?}"
    );
}
