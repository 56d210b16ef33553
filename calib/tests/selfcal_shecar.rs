//! Monocular self-calibration on ZHI's shecar sample (`../shared/data/shecar`, the paper's
//! dataset 2): median `B X = X A` rotation residual over its 153 pairs and X against the
//! README's board reference. Skips with a notice when the data is absent.

// Wall-clock timings and hashed sets of a test, bench or example: not a stage, so the
// crate's determinism lints do not apply here.
#![allow(clippy::disallowed_methods, clippy::disallowed_types)]

use std::path::{Path, PathBuf};

use calib::handeye::RelativeMotion;
use calib::handeye::refine::pair_residual;
use calib::relpose::CameraModel;
use calib::selfcal::{CalibView, Mode, SelfCalParams, self_calibrate};
use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};

fn data_dir() -> Option<PathBuf> {
    testkit::shared_data("shecar/handposes.txt", "shecar self-calibration")
        .and_then(|p| p.parent().map(Path::to_path_buf))
}

/// `handposes.txt`: 3x4 `[R | t]` column by column = base_from_tool0.
fn hand_poses(dir: &Path) -> Vec<Isometry3<f64>> {
    let text = std::fs::read_to_string(dir.join("handposes.txt")).expect("handposes.txt");
    text.lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let n: Vec<f64> = l
                .split(',')
                .map(|s| s.trim().parse().expect("number"))
                .collect();
            assert_eq!(n.len(), 12);
            let r = Matrix3::from_column_slice(&n[..9]);
            let r = Rotation3::from_matrix(&r);
            Isometry3::from_parts(
                Translation3::new(n[9], n[10], n[11]),
                UnitQuaternion::from_rotation_matrix(&r),
            )
        })
        .collect()
}

/// `intrinsic.txt` (Theia): `name f cx cy aspect skew k1 k2` (radial = plumb_bob k1, k2).
fn camera(dir: &Path, width: u32, height: u32) -> CameraModel {
    let text = std::fs::read_to_string(dir.join("intrinsic.txt")).expect("intrinsic.txt");
    let f: Vec<f64> = text
        .lines()
        .next()
        .expect("a line")
        .split_whitespace()
        .skip(1)
        .map(|s| s.parse().expect("number"))
        .collect();
    let mut c = CameraModel::pinhole(width, height, f[0], f[0] * f[3], f[1], f[2]);
    c.k1 = f[5];
    c.k2 = f[6];
    c
}

#[test]
fn selfcal_shecar_mono_residual_and_board_reference() {
    let Some(dir) = data_dir() else {
        return;
    };
    let poses = hand_poses(&dir);
    let views: Vec<CalibView> = poses
        .iter()
        .enumerate()
        .map(|(k, p)| {
            let img = image::open(dir.join(format!("{k:02}.jpg")))
                .expect("jpeg")
                .to_luma8();
            CalibView {
                stamp_ns: (k as u64 + 1) * 1_000_000_000,
                gray: img,
                depth_m: None,
                base_from_tool0: *p,
            }
        })
        .collect();
    let (w, h) = views[0].gray.dimensions();
    let cam = camera(&dir, w, h);
    let params = SelfCalParams::for_camera(&cam);
    assert_eq!(params.orb.n_features, 8000);
    let t0 = std::time::Instant::now();
    let res = self_calibrate(&views, &cam, &params).expect("self-calibration");
    let wall_s = t0.elapsed().as_secs_f64();
    assert_eq!(res.mode, Mode::Mono);
    let x = res.solution.tool0_from_camera;
    // Median rotation residual over every pair with a camera motion (used or not).
    let mut all: Vec<f64> = res
        .pairs
        .iter()
        .filter_map(|p| {
            let a = p.cam_i_from_cam_j?;
            let b = poses[p.i].inverse() * poses[p.j];
            Some(
                pair_residual(&RelativeMotion::new(a, b), &x, 1.0)
                    .0
                    .norm()
                    .to_degrees(),
            )
        })
        .collect();
    all.sort_by(f64::total_cmp);
    let median_all = all[all.len() / 2];
    let t = x.translation.vector * 1e3;
    let angle_deg = x.rotation.angle().to_degrees();
    let board_t = Vector3::new(-2.4, -6.4, -10.1);
    eprintln!(
        "shecar mono ({wall_s:.1} s wall): {} pairs, {} with a motion, {} used; median rotation residual {:.3} deg over the used, {:.3} deg over all {} with a motion; median translation residual {:.1} mm; X rotation {:.3} deg from identity, t = ({:.1}, {:.1}, {:.1}) mm ({:.1} mm from the board reference); linear X t = {:?} mm",
        res.pairs.len(),
        all.len(),
        res.used_pairs(),
        res.solution.residual_rot_deg,
        median_all,
        all.len(),
        res.solution.residual_trans_mm,
        angle_deg,
        t.x,
        t.y,
        t.z,
        (t - board_t).norm(),
        (res.linear_tool0_from_camera.translation.vector * 1e3).as_slice()
    );
    for p in &res.pairs {
        if let Some(r) = &p.rejected {
            eprintln!("  pair {}-{}: {r}", p.i, p.j);
        }
    }
    assert_eq!(res.pairs.len(), 153);
    assert!(all.len() >= 140, "only {} pairs with a motion", all.len());
    assert!(
        median_all < 0.67,
        "median rotation residual {median_all} deg"
    );
    assert!(angle_deg < 1.5, "X rotation {angle_deg} deg from identity");
    assert!((t - board_t).norm() < 20.0, "t = {t:?} mm");
}
