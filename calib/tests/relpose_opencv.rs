//! OpenCV comparison of the relative pose estimators on identical noisy synthetic sets
//! (`scripts/relpose/opencv_relpose.py`: `findEssentialMat` + `recoverPose`, RANSAC and
//! USAC_ACCURATE; `estimateAffine3D(force_rotation)` for Umeyama parity).
//!
//! Needs the reference venv (`scripts/venv.sh`; path from `RODLOG_REF_VENV`, default
//! `<repo>/.venv-ref`); skipped with a notice when it is absent (`testkit`: never in CI). Prints the accuracy table
//! (`cargo test -p calib --test relpose_opencv -- --nocapture`).

// Wall-clock timings and hashed sets of a test, bench or example: not a stage, so the
// crate's determinism lints do not apply here.
#![allow(clippy::disallowed_methods, clippy::disallowed_types)]

#[path = "relpose_support.rs"]
mod support;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use calib::relpose::{
    EssentialParams, estimate_essential_ransac, rigid_from_correspondences,
    similarity_from_correspondences,
};
use nalgebra::{Isometry3, Matrix3, Point3, Rotation3, Translation3, UnitQuaternion};
use serde_json::{Value, json};
use support::{SceneSpec, direction_error_rad, generate, rotation_error_rad, true_a_from_b};

/// Named so that `cargo test -p calib relpose` selects these tests.
mod relpose {
    use super::*;

    const SETS: u64 = 20;
    const MATCHES: usize = 500;
    const OUTLIERS: f64 = 0.3;

    fn repo_root() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
    }

    fn venv_python() -> Option<PathBuf> {
        testkit::venv_tool("python", "OpenCV relpose test")
    }

    fn pose_of(v: &Value) -> Option<Isometry3<f64>> {
        let r = v.get("rotation")?.as_array()?;
        let mut m = Matrix3::zeros();
        for (i, row) in r.iter().enumerate() {
            for (j, x) in row.as_array()?.iter().enumerate() {
                m[(i, j)] = x.as_f64()?;
            }
        }
        let t: Vec<f64> = v
            .get("translation")?
            .as_array()?
            .iter()
            .filter_map(Value::as_f64)
            .collect();
        Some(Isometry3::from_parts(
            Translation3::new(*t.first()?, *t.get(1)?, *t.get(2)?),
            UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix(&m)),
        ))
    }

    /// Errors and times of one method over the sets.
    struct Row {
        name: &'static str,
        rot_deg: Vec<f64>,
        dir_deg: Vec<f64>,
        time_ms: Vec<f64>,
    }

    impl Row {
        fn push(&mut self, est: &Isometry3<f64>, truth: &Isometry3<f64>, time_ms: Option<f64>) {
            self.rot_deg
                .push(rotation_error_rad(est, truth).to_degrees());
            self.dir_deg
                .push(direction_error_rad(est, truth).to_degrees());
            if let Some(t) = time_ms {
                self.time_ms.push(t);
            }
        }
    }

    fn median(v: &mut [f64]) -> f64 {
        v.sort_by(f64::total_cmp);
        v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
    }

    #[test]
    fn essential_accuracy_against_opencv_on_identical_noisy_sets() {
        let Some(python) = venv_python() else {
            return;
        };
        let truth = true_a_from_b();
        let params = EssentialParams::default();
        let mut sets = Vec::new();
        let mut ours = Vec::new();
        let mut scenes = Vec::new();
        let mut our_ms = Vec::new();
        for seed in 0..SETS {
            let s = generate(&SceneSpec::noisy(MATCHES, OUTLIERS, 5000 + seed), &truth);
            let t0 = Instant::now();
            let est = estimate_essential_ransac(&s.x_a, &s.x_b, &params, seed).expect("ours");
            our_ms.push(t0.elapsed().as_secs_f64() * 1e3);
            ours.push(est.a_from_b);
            let (pa, pb): (Vec<Point3<f64>>, Vec<Point3<f64>>) = s
                .p_in_a
                .iter()
                .zip(&s.p_in_b)
                .zip(&s.is_inlier)
                .filter(|(_, m)| **m)
                .map(|((a, b), _)| (*a, *b))
                .unzip();
            sets.push(json!({
                "x_a": s.x_a.iter().map(|p| [p.x, p.y]).collect::<Vec<_>>(),
                "x_b": s.x_b.iter().map(|p| [p.x, p.y]).collect::<Vec<_>>(),
                "threshold": params.inlier_threshold,
                "p_in_a": pa.iter().map(|p| [p.x, p.y, p.z]).collect::<Vec<_>>(),
                "p_in_b": pb.iter().map(|p| [p.x, p.y, p.z]).collect::<Vec<_>>(),
            }));
            scenes.push((pa, pb));
        }
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("sets.json");
        std::fs::write(&path, json!({ "sets": sets }).to_string()).expect("write sets");
        let script = repo_root().join("scripts/relpose/opencv_relpose.py");
        let out = Command::new(&python)
            .arg(&script)
            .arg(&path)
            .output()
            .expect("run opencv_relpose.py");
        assert!(
            out.status.success(),
            "opencv_relpose.py failed: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let results: Vec<Value> = serde_json::from_slice(&out.stdout).expect("opencv json");
        assert_eq!(results.len(), SETS as usize);

        let row = |name: &'static str, time_ms: Vec<f64>| Row {
            name,
            rot_deg: Vec::new(),
            dir_deg: Vec::new(),
            time_ms,
        };
        let mut table = [
            row("rodlog (5-pt RANSAC + Sampson LM)", our_ms.clone()),
            row("OpenCV findEssentialMat RANSAC", Vec::new()),
            row("OpenCV findEssentialMat USAC_ACCURATE", Vec::new()),
        ];
        for (k, r) in results.iter().enumerate() {
            let our = ours.get(k).expect("ours");
            table[0].push(our, &truth, None);
            for (row, key) in [(1, "ransac"), (2, "usac_accurate")] {
                let cv = pose_of(&r[key]).expect("opencv pose");
                table[row].push(&cv, &truth, r[key]["time_ms"].as_f64());
            }
            // Umeyama parity on the true inliers (OpenCV's force_rotation variant estimates the
            // similarity: its 3x3 block is c R).
            let (pa, pb) = scenes.get(k).expect("scene");
            let cv = pose_of(&r["umeyama"]).expect("opencv umeyama");
            let cv_scale = r["umeyama"]["scale"].as_f64().expect("scale");
            let sim = similarity_from_correspondences(pa, pb, None).expect("umeyama");
            let dr = rotation_error_rad(&sim.isometry, &cv);
            let dt = (sim.isometry.translation.vector - cv.translation.vector).norm();
            let ds = (sim.scaling() - cv_scale).abs();
            assert!(
                dr < 1e-9 && dt < 1e-9 && ds < 1e-9,
                "Umeyama parity: {dr:e} rad, {dt:e} m, scale {ds:e}"
            );
            let rigid = rigid_from_correspondences(pa, pb, None).expect("rigid");
            assert!(rotation_error_rad(&rigid, &cv) < 1e-9);
        }
        eprintln!(
            "\n{SETS} sets x {MATCHES} matches, {:.0}% outliers, 0.5 px noise, 1 px Sampson threshold, \
             true motion 20 deg / (0.08, -0.03, 0.02) m",
            OUTLIERS * 100.0
        );
        eprintln!(
            "| method | median rot err (deg) | mean rot err (deg) | median t-dir err (deg) | mean t-dir err (deg) | median time (ms) |"
        );
        eprintln!("|---|---|---|---|---|---|");
        let mut medians = Vec::new();
        for Row {
            name,
            rot_deg: rot,
            dir_deg: dir,
            time_ms: ms,
        } in &mut table
        {
            let mean_r = rot.iter().sum::<f64>() / rot.len() as f64;
            let mean_d = dir.iter().sum::<f64>() / dir.len() as f64;
            let (mr, md, mt) = (median(rot), median(dir), median(ms));
            eprintln!("| {name} | {mr:.4} | {mean_r:.4} | {md:.4} | {mean_d:.4} | {mt:.2} |");
            medians.push((mr, md));
        }
        let (ours_r, ours_d) = medians[0];
        let (ransac_r, ransac_d) = medians[1];
        let (usac_r, usac_d) = medians[2];
        // Ours must beat OpenCV's plain RANSAC (no local optimisation) and be no worse than
        // USAC_ACCURATE (GC-RANSAC local optimisation) beyond 10%.
        assert!(
            ours_r <= ransac_r && ours_d <= ransac_d,
            "worse than OpenCV RANSAC"
        );
        assert!(
            ours_r <= 1.1 * usac_r && ours_d <= 1.1 * usac_d,
            "worse than OpenCV USAC_ACCURATE"
        );
    }
}
