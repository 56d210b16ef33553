//! Board front end on ZHI's public shecar sample (`../shared/data/shecar`, 18 photos
//! 3264x1836, 6x8 inner corners, ~28.3 mm squares; skipped with a notice when absent):
//! the board is found in every image with a reprojection RMS < 1 px, and hand-eye over the
//! 18 hand poses and the board poses gives a median AX=XB rotation residual over the 153 pairs
//! <= 0.87 deg (what the OpenCV board reference gets, README of the data).
//!
//! Set `RODLOG_BOARD_CORNERS_OUT=FILE` to write the refined corners as JSON for
//! `scripts/board/compare_corners.py` (comparison with OpenCV's `findChessboardCorners` +
//! `cornerSubPix`).

// Wall-clock timings and hashed sets of a test, bench or example: not a stage, so the
// crate's determinism lints do not apply here.
#![allow(clippy::disallowed_methods, clippy::disallowed_types)]

use std::path::PathBuf;

use calib::board::{BoardOptions, BoardSpec, calibrate_board_views, theia_radial_camera};
use calib::handeye::{self, HandEyeOptions, Method};
use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};

fn data_dir() -> Option<PathBuf> {
    testkit::shared_data("shecar/handposes.txt", "shecar board test")
        .and_then(|p| p.parent().map(std::path::Path::to_path_buf))
}

/// `handposes.txt`: 12 numbers per line, a 3x4 `[R | t]` column by column (base_from_tool0).
fn hand_poses(text: &str) -> Vec<Isometry3<f64>> {
    text.lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let v: Vec<f64> = l
                .split(',')
                .map(|s| s.trim().parse::<f64>().expect("number"))
                .collect();
            assert_eq!(v.len(), 12, "line {l}");
            let r = Matrix3::from_column_slice(&v[0..9]);
            let t = Vector3::new(v[9], v[10], v[11]);
            // The file's rotations carry 5 digits: project onto SO(3).
            let rot = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix(&r));
            Isometry3::from_parts(Translation3::from(t), rot)
        })
        .collect()
}

#[test]
fn board_found_in_all_shecar_images_and_handeye_consistent() {
    let Some(dir) = data_dir() else {
        return;
    };
    let images: Vec<image::GrayImage> = (0..18)
        .map(|i| {
            image::open(dir.join(format!("{i:02}.jpg")))
                .expect("decode jpeg")
                .to_luma8()
        })
        .collect();
    let camera = theia_radial_camera(
        3264, 1836, 2439.50225, 1615.55613, 867.03099, 0.18436, -0.32515,
    );
    let board = BoardSpec::new(6, 8, 0.0283).expect("board");
    let t0 = std::time::Instant::now();
    let views = calibrate_board_views(&images, &camera, &board, &BoardOptions::default())
        .expect("board found in every image");
    eprintln!("18 images in {:.2} s", t0.elapsed().as_secs_f64());
    assert_eq!(views.len(), 18);
    for (i, v) in views.iter().enumerate() {
        eprintln!(
            "image {i:02}: rms {:.3} px, max {:.3} px, square {:.1} px, subpix iters {} rejected {} shift {:.2} px, first corner ({:.1}, {:.1})",
            v.rms_px,
            v.max_error_px,
            v.square_px,
            v.subpix.max_iterations,
            v.subpix.rejected,
            v.subpix.mean_shift_px,
            v.corners_px[0].x,
            v.corners_px[0].y
        );
        assert!(v.rms_px < 1.0, "image {i}: rms {} px", v.rms_px);
        assert_eq!(v.subpix.rejected, 0, "image {i}");
    }
    if let Ok(out) = std::env::var("RODLOG_BOARD_CORNERS_OUT") {
        let json = serde_json::json!({
            "images": views.iter().map(|v| serde_json::json!({
                "corners": v.corners_px.iter().map(|p| [p.x, p.y]).collect::<Vec<_>>(),
                "rms_px": v.rms_px,
                "world_from_camera": (0..4)
                    .map(|r| (0..4).map(|c| v.world_from_camera.to_homogeneous()[(r, c)]).collect::<Vec<_>>())
                    .collect::<Vec<_>>(),
            })).collect::<Vec<_>>()
        });
        std::fs::write(&out, json.to_string()).expect("write corners");
    }

    let hand = hand_poses(&std::fs::read_to_string(dir.join("handposes.txt")).expect("read"));
    assert_eq!(hand.len(), 18);
    let eye: Vec<Isometry3<f64>> = views.iter().map(|v| v.world_from_camera).collect();
    for (method, scale_free) in [
        (Method::Ours, false),
        (Method::Ours, true),
        (Method::Park, false),
        (Method::Park, true),
        (Method::Tsai, false),
        (Method::Kronecker, false),
        (Method::Horaud, false),
    ] {
        let opts = HandEyeOptions {
            scale_free,
            ..HandEyeOptions::with_method(method)
        };
        let sol = handeye::solve(&hand, &eye, &opts).expect("hand-eye on the board poses");
        let x = sol.tool0_from_camera;
        eprintln!(
            "{method} (scale-free {scale_free}, scale {:.4}): X t = ({:.2}, {:.2}, {:.2}) mm, rotation {:.3} deg from identity, pairs {}, rejected {}, median residual {:.3} deg / {:.2} mm",
            sol.scale,
            x.translation.x * 1e3,
            x.translation.y * 1e3,
            x.translation.z * 1e3,
            x.rotation.angle().to_degrees(),
            sol.pairs,
            sol.rejected_pairs.len(),
            sol.residual_rot_deg,
            sol.residual_trans_mm
        );
        assert_eq!(sol.pairs, 153);
        // The board X of the data's README (Park-Martin over the 153 pairs on OpenCV board
        // poses) has a median rotation residual of "0.87 deg" (0.8693 when recomputed with
        // OpenCV 4.14 on its own corners); our poses agree with OpenCV's to 0.005 deg, and the
        // same Park X gives 0.8725 deg on them: require the value that rounds to 0.87.
        if method == Method::Park {
            assert!(sol.residual_rot_deg < 0.875, "{} deg", sol.residual_rot_deg);
        }
        assert!(
            sol.residual_rot_deg < 0.95,
            "{method}: {} deg",
            sol.residual_rot_deg
        );
    }
}
