//! The ZHI baseline (`calib::zhi`) on synthetic textured scenes: it recovers an asymmetric
//! mount (no inversion) with its reconstruction, and refuses what it cannot do.

mod selfcal_support;

use calib::handeye::pose_error;
use calib::zhi::{ZhiError, ZhiParams, calibrate_zhi};
use selfcal_support as sup;

#[test]
fn zhi_synthetic_recovers_asymmetric_mount_up_to_scale() {
    let x_true = sup::true_x();
    let (views, cam) = sup::views(&sup::camera_poses(16), &x_true, false);
    let res = calibrate_zhi(&views, &cam, &ZhiParams::default()).expect("ZHI calibration");
    let (rot_deg, t_m) = pose_error(&res.solution.tool0_from_camera, &x_true);
    let (rot_inv, _) = pose_error(&res.solution.tool0_from_camera, &x_true.inverse());
    eprintln!(
        "zhi synthetic: X error {rot_deg:.4} deg {:.3} mm; registered {} of 16; points {}; \
         reprojection RMS {:.3} px; scale {:.5}; vs inverse {rot_inv:.2} deg",
        t_m * 1e3,
        res.registered(),
        res.points,
        res.reprojection_rms_px,
        res.solution.scale
    );
    assert_eq!(res.registered(), 16);
    assert!(res.reprojection_rms_px < 0.5, "{}", res.reprojection_rms_px);
    assert!(rot_deg < 0.2, "rotation error {rot_deg} deg");
    assert!(t_m < 5e-3, "translation error {} mm", t_m * 1e3);
    assert!(rot_inv > 5.0);
    // The reconstruction's unit is |t| of the initial pair: the scale is estimated, not 1.
    assert!(res.solution.scale > 0.0 && (res.solution.scale - 1.0).abs() > 1e-3);
}

#[test]
fn zhi_is_deterministic() {
    let x_true = sup::true_x();
    let (views, cam) = sup::views(&sup::camera_poses(8), &x_true, false);
    let a = calibrate_zhi(&views, &cam, &ZhiParams::default()).expect("a");
    let b = calibrate_zhi(&views, &cam, &ZhiParams::default()).expect("b");
    assert_eq!(a, b);
}

#[test]
fn zhi_refuses_too_few_views_and_blank_images() {
    let x_true = sup::true_x();
    let (views, cam) = sup::views(&sup::camera_poses(6), &x_true, false);
    let two = views.get(..2).expect("views").to_vec();
    assert!(matches!(
        calibrate_zhi(&two, &cam, &ZhiParams::default()),
        Err(ZhiError::Views(_))
    ));
    let mut blank = views.clone();
    if let Some(v) = blank.get_mut(3) {
        v.gray.pixels_mut().for_each(|p| p.0 = [90]);
    }
    match calibrate_zhi(&blank, &cam, &ZhiParams::default()) {
        Err(ZhiError::TooFewFeatures { index, .. }) => assert_eq!(index, 3),
        other => panic!("expected a refusal, got {other:?}"),
    }
}
