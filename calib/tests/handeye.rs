//! Hand-eye solvers on synthetic data: exact recovery of an asymmetric X by every method
//! (through the TUM + JSON path of `rodlog calib handeye`), scale-free recovery, refusals of
//! degenerate input, and accuracy of `ours` on noisy data.
#![allow(
    clippy::unwrap_used,
    reason = "tests: a failed unwrap is a failed test"
)]

#[path = "handeye_support.rs"]
mod support;

use calib::handeye::{
    HandEyeError, HandEyeOptions, Method, PairSelection, PoseFileError, PoseSource, RelativeMotion,
    RobustLoss, StampedPose, calibration_json, pose_file, relative_motions, solve, solve_motions,
    solve_tum,
};
use nalgebra::{Isometry3, Matrix3, Matrix4, Rotation3, Translation3, UnitQuaternion, Vector3};
use support::{Rng, errors, eye_of, perturb, random_hand, true_x};

fn stamped(poses: &[Isometry3<f64>]) -> Vec<StampedPose> {
    poses
        .iter()
        .enumerate()
        .map(|(k, p)| StampedPose {
            timestamp: 100.0 + 0.5 * k as f64,
            pose: *p,
        })
        .collect()
}

/// Every method recovers X to 1e-9 from noise-free TUM files, and the JSON carries it.
#[test]
fn noise_free_every_method_recovers_asymmetric_x_through_tum_and_json() {
    let mut rng = Rng(42);
    let x = true_x();
    let hand = random_hand(&mut rng, 8);
    let eye = eye_of(&hand, &x);
    let hand_txt = pose_file::write_tum(&stamped(&hand));
    let eye_txt = pose_file::write_tum(&stamped(&eye));
    for method in Method::ALL {
        for pairs in [PairSelection::All, PairSelection::Consecutive] {
            let opts = HandEyeOptions {
                method,
                pairs,
                ..HandEyeOptions::default()
            };
            let sol = solve_tum(&hand_txt, &eye_txt, &opts)
                .unwrap_or_else(|e| panic!("{method} {pairs:?}: {e}"));
            let json = calibration_json(&sol, method.name(), "poses", "camera_color_optical_frame");
            let text = serde_json::to_string(&json).unwrap();
            let back: serde_json::Value = serde_json::from_str(&text).unwrap();
            let m = &back["matrix"];
            let est = Matrix4::from_fn(|r, c| m[r][c].as_f64().unwrap());
            let diff = (est - x.to_homogeneous()).amax();
            assert!(diff < 1e-9, "{method} {pairs:?}: matrix off by {diff:e}");
            // The inverse (camera_from_tool0) would be far off: the test can fail.
            assert!((est - x.inverse().to_homogeneous()).amax() > 0.05);
            let t = &back["translation_m"];
            assert!((t[0].as_f64().unwrap() - 0.05).abs() < 1e-9);
            assert_eq!(back["frame"], "tool0");
            assert_eq!(back["method"], method.name());
            assert_eq!(back["views"], 8);
            assert_eq!(back["scale"], 1.0);
            assert!(back["condition"].as_f64().unwrap() > 0.2);
            assert!(back["residual_rot_deg"].as_f64().unwrap() < 1e-8);
            assert!(back["residual_trans_mm"].as_f64().unwrap() < 1e-6);
            let expected_pairs = if pairs == PairSelection::All { 28 } else { 7 };
            assert_eq!(sol.pairs, expected_pairs);
            let q = &back["quaternion_xyzw"];
            let quat = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
                q[3].as_f64().unwrap(),
                q[0].as_f64().unwrap(),
                q[1].as_f64().unwrap(),
                q[2].as_f64().unwrap(),
            ));
            assert!(quat.angle_to(&x.rotation) < 1e-9);
        }
    }
}

#[test]
fn json_has_every_field_of_design_s4() {
    let mut rng = Rng(3);
    let hand = random_hand(&mut rng, 5);
    let eye = eye_of(&hand, &true_x());
    let sol = solve(&hand, &eye, &HandEyeOptions::default()).unwrap();
    let json = calibration_json(&sol, "ours", "poses", "camera_color_optical_frame");
    for key in [
        "method",
        "mode",
        "frame",
        "child_frame",
        "translation_m",
        "quaternion_xyzw",
        "matrix",
        "views",
        "pairs",
        "residual_rot_deg",
        "residual_trans_mm",
        "sigma_rot_deg",
        "sigma_trans_mm",
        "covariance",
        "uncertainty",
        "condition",
        "scale",
    ] {
        assert!(json.get(key).is_some(), "missing {key}");
    }
    assert_eq!(json["pairs"], 10);
    assert_eq!(json["mode"], "poses");
    // Five views are too few for the jackknife: the linearised covariance, 6x6.
    assert_eq!(json["uncertainty"], "linearised");
    assert_eq!(json["covariance"].as_array().map(Vec::len), Some(6));
}

#[test]
fn method_names_round_trip() {
    for m in Method::ALL {
        assert_eq!(m.name().parse::<Method>().unwrap(), m);
        assert_eq!(m.to_string(), m.name());
    }
    assert!("opencv".parse::<Method>().is_err());
}

/// Scale-free: eye translations in units of 0.4 m; the supporting methods recover X and
/// the scale, the others refuse.
#[test]
fn scale_free_recovers_x_and_scale() {
    let mut rng = Rng(5);
    let x = true_x();
    let hand = random_hand(&mut rng, 7);
    let metres_per_unit = 0.4;
    let eye: Vec<_> = eye_of(&hand, &x)
        .into_iter()
        .map(|p| {
            Isometry3::from_parts(
                Translation3::from(p.translation.vector / metres_per_unit),
                p.rotation,
            )
        })
        .collect();
    for method in Method::ALL {
        let opts = HandEyeOptions {
            method,
            scale_free: true,
            ..HandEyeOptions::default()
        };
        match solve(&hand, &eye, &opts) {
            Ok(sol) => {
                assert!(method.supports_scale_free());
                let (er, et) = errors(&sol.tool0_from_camera, &x);
                assert!(er < 1e-9 && et < 1e-9, "{method}: {er:e} rad, {et:e} m");
                assert!(
                    (sol.scale - metres_per_unit).abs() < 1e-9,
                    "{method}: scale {}",
                    sol.scale
                );
            }
            Err(HandEyeError::ScaleFreeUnsupported { method: m }) => {
                assert_eq!(m, method);
                assert!(!method.supports_scale_free());
            }
            Err(e) => panic!("{method}: {e}"),
        }
    }
    // Without --scale-free the wrong-unit eye is not silently accepted as metric: ours
    // leaves large translation residuals.
    let sol = solve(&hand, &eye, &HandEyeOptions::default()).unwrap();
    assert!(sol.residual_trans_mm > 10.0, "{}", sol.residual_trans_mm);
}

#[test]
fn scale_free_noisy_ours_estimates_scale() {
    let mut rng = Rng(11);
    let x = true_x();
    let hand = random_hand(&mut rng, 15);
    let eye: Vec<_> = eye_of(&hand, &x)
        .iter()
        .map(|p| perturb(&mut rng, p, 5e-4, 5e-4))
        .map(|p| Isometry3::from_parts(Translation3::from(p.translation.vector * 3.0), p.rotation))
        .collect();
    let opts = HandEyeOptions {
        scale_free: true,
        ..HandEyeOptions::default()
    };
    let sol = solve(&hand, &eye, &opts).unwrap();
    assert!((sol.scale - 1.0 / 3.0).abs() < 2e-3, "scale {}", sol.scale);
    let (er, et) = errors(&sol.tool0_from_camera, &x);
    assert!(er.to_degrees() < 0.2 && et < 5e-3, "{er} rad {et} m");
}

fn all_methods_refuse(
    hand: &[Isometry3<f64>],
    eye: &[Isometry3<f64>],
    check: impl Fn(&HandEyeError) -> bool,
) {
    for method in Method::ALL {
        match solve(hand, eye, &HandEyeOptions::with_method(method)) {
            Ok(sol) => panic!(
                "{method}: accepted degenerate input: {:?}",
                sol.tool0_from_camera
            ),
            Err(e) => {
                assert!(check(&e), "{method}: unexpected refusal {e}");
                assert!(!e.to_string().is_empty());
            }
        }
    }
}

#[test]
fn two_poses_are_refused() {
    let mut rng = Rng(1);
    let hand = random_hand(&mut rng, 2);
    let eye = eye_of(&hand, &true_x());
    all_methods_refuse(&hand, &eye, |e| {
        matches!(e, HandEyeError::TooFewPoses { got: 2, need: 3 })
    });
}

#[test]
fn length_mismatch_is_refused() {
    let mut rng = Rng(1);
    let hand = random_hand(&mut rng, 5);
    let eye = eye_of(&hand[..4], &true_x());
    all_methods_refuse(&hand, &eye, |e| {
        matches!(e, HandEyeError::LengthMismatch { hand: 5, eye: 4 })
    });
}

#[test]
fn rotation_about_one_axis_only_is_refused() {
    let x = true_x();
    let axis = Vector3::new(0.3, -0.2, 0.9).normalize();
    let hand: Vec<_> = (0..8)
        .map(|k| {
            Isometry3::from_parts(
                Translation3::new(0.5 + 0.05 * k as f64, 0.1 * (k % 3) as f64, 0.4),
                UnitQuaternion::from_scaled_axis(axis * (10.0 + 12.0 * k as f64).to_radians()),
            )
        })
        .collect();
    let eye = eye_of(&hand, &x);
    all_methods_refuse(&hand, &eye, |e| match e {
        HandEyeError::DegenerateRotations {
            condition,
            axis_x,
            axis_y,
            axis_z,
            ..
        } => {
            let dominant = Vector3::new(*axis_x, *axis_y, *axis_z);
            *condition < 1e-6
                && dominant.dot(&axis).abs() > 0.999
                && e.to_string().contains("two non-parallel axes")
        }
        _ => false,
    });
}

#[test]
fn pure_translations_are_refused() {
    let x = true_x();
    let r = UnitQuaternion::from_scaled_axis(Vector3::new(0.1, 0.5, -0.2));
    let hand: Vec<_> = (0..6)
        .map(|k| Isometry3::from_parts(Translation3::new(0.1 * k as f64, 0.3, -0.05 * k as f64), r))
        .collect();
    let eye = eye_of(&hand, &x);
    all_methods_refuse(&hand, &eye, |e| {
        matches!(e, HandEyeError::PureTranslation { .. })
    });
}

#[test]
fn nan_pose_is_refused_with_its_index() {
    let mut rng = Rng(9);
    let hand = random_hand(&mut rng, 6);
    let mut eye = eye_of(&hand, &true_x());
    eye[4].translation.vector.y = f64::NAN;
    all_methods_refuse(&hand, &eye, |e| {
        matches!(
            e,
            HandEyeError::NonFinitePose {
                index: 4,
                which: PoseSource::Eye
            }
        )
    });
    let mut hand2 = hand.clone();
    hand2[1].rotation =
        UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(f64::INFINITY, 0., 0., 0.));
    let eye2 = eye_of(&hand, &true_x());
    all_methods_refuse(&hand2, &eye2, |e| {
        matches!(
            e,
            HandEyeError::NonFinitePose {
                index: 1,
                which: PoseSource::Hand
            }
        )
    });
}

/// Eye poses in the wrong order (a pairing error): the rotation angles disagree.
#[test]
fn mispaired_poses_are_refused() {
    let mut rng = Rng(21);
    let hand = random_hand(&mut rng, 8);
    let mut eye = eye_of(&hand, &true_x());
    eye.reverse();
    all_methods_refuse(&hand, &eye, |e| {
        matches!(e, HandEyeError::InconsistentMotions { .. })
    });
}

/// OpenCV's regression_24871 (test_calibration_hand_eye.cpp): four exact poses for which
/// OpenCV once returned wrong results; every method must give the true cam2gripper.
#[test]
fn opencv_regression_24871_is_solved_exactly() {
    let r_target2cam = [
        [
            0.04964505493834381,
            0.5136826827431226,
            0.8565427426404346,
            -0.3923117691818854,
            0.7987004864191318,
            -0.4562554205214679,
            -0.9184916136152514,
            -0.3133809733274676,
            0.2411752915926112,
        ],
        [
            -0.3048000068139332,
            0.6971848192711539,
            0.6488684640388026,
            -0.9377589344241749,
            -0.3387497187353627,
            -0.07652979135179161,
            0.1664486009369332,
            -0.6318084803439735,
            0.7570422097951847,
        ],
        [
            -0.590234879685801,
            -0.7051138289845309,
            -0.3929850823848928,
            0.6017371069678565,
            -0.7088332765096816,
            0.3680595606834615,
            -0.5380847896941907,
            -0.01923211603859842,
            0.8426712792141644,
        ],
        [
            0.7643667483125168,
            -0.08523002870239212,
            0.63912386614923,
            -0.2583463792779588,
            0.8676987164647345,
            0.424683512464778,
            -0.5907627462764713,
            -0.489729292214425,
            0.6412211770980741,
        ],
    ];
    let t_target2cam = [
        [-1.588728904724121, 0.07843752950429916, -1.002813339233398],
        [-1.906493663787842, -0.07281044125556946, 0.6088893413543701],
        [
            -0.9809040427207947,
            -0.2707894444465637,
            -0.2577074766159058,
        ],
        [-1.58987033367157, -1.924914002418518, -0.3109001517295837],
    ];
    let r_gripper2base = [
        [
            -0.4143743581399177,
            -0.6105088815982459,
            -0.6749613298595637,
            -0.1598851232573451,
            -0.6812625208693498,
            0.71436554019614,
            -0.895952364066927,
            0.4039310376145889,
            0.1846864320259794,
        ],
        [
            0.7262439860936567,
            -0.201662933718935,
            -0.6571923111439066,
            -0.4640017362244384,
            -0.8491808316335328,
            -0.2521791108852766,
            -0.5072199339965884,
            0.4880819361030014,
            -0.7102844234575628,
        ],
        [
            0.2541996332132083,
            0.6186461729765909,
            0.7434106934499181,
            0.2194912986375709,
            0.711701808961156,
            -0.6673111005698995,
            -0.9419161938817396,
            0.3328024155303503,
            0.04512688689130734,
        ],
        [
            0.116348305340805,
            -0.9917998080681939,
            0.0528792261688552,
            -0.2760629007224059,
            0.01884966191381591,
            0.9609547154213178,
            -0.9540714578526358,
            -0.1264034452126562,
            -0.2716060057313114,
        ],
    ];
    let t_gripper2base = [
        [-1.249274406461827, -1.916570771580279, 2.005069553422765],
        [-0.7375172846804027, -2.579760910816792, 1.336561572270101],
        [-1.040123533893404, -0.1303773962721222, 1.068029475621886],
        [-2.551899142554571, -2.986937398237611, 1.317613923218308],
    ];
    let iso = |r: &[f64; 9], t: &[f64; 3]| {
        let m = Matrix3::from_row_slice(r);
        Isometry3::from_parts(
            Translation3::new(t[0], t[1], t[2]),
            UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix(&m)),
        )
    };
    let hand: Vec<_> = (0..4)
        .map(|k| iso(&r_gripper2base[k], &t_gripper2base[k]))
        .collect();
    let eye: Vec<_> = (0..4)
        .map(|k| iso(&r_target2cam[k], &t_target2cam[k]).inverse())
        .collect();
    let truth = Isometry3::from_parts(
        Translation3::new(0.1, 0.2, 0.3),
        UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(Matrix3::new(
            0., 0., -1., 1., 0., 0., 0., -1., 0.,
        ))),
    );
    for method in Method::ALL {
        let sol = solve(&hand, &eye, &HandEyeOptions::with_method(method))
            .unwrap_or_else(|e| panic!("{method}: {e}"));
        let (er, et) = errors(&sol.tool0_from_camera, &truth);
        // The file's rotations carry ~1e-16 rounding; 1e-9 is far below any wrong answer.
        assert!(er < 1e-9 && et < 1e-9, "{method}: {er:e} rad {et:e} m");
    }
}

/// Random, inconsistent poses never produce a NaN X: a refusal or a finite estimate.
#[test]
fn garbage_never_gives_nan() {
    let mut rng = Rng(77);
    for trial in 0..40 {
        let n = 3 + trial % 5;
        let hand = random_hand(&mut rng, n);
        let eye = random_hand(&mut rng, n);
        for method in Method::ALL {
            let opts = HandEyeOptions {
                method,
                max_angle_mismatch_deg: 180.0,
                ..HandEyeOptions::default()
            };
            if let Ok(sol) = solve(&hand, &eye, &opts) {
                let m = sol.tool0_from_camera.to_homogeneous();
                assert!(m.iter().all(|v| v.is_finite()), "{method} trial {trial}");
            }
        }
    }
}

#[test]
fn too_few_motions_and_bad_weights_are_refused() {
    let mut rng = Rng(4);
    let hand = random_hand(&mut rng, 4);
    let eye = eye_of(&hand, &true_x());
    let motions = relative_motions(&hand, &eye, PairSelection::All);
    let opts = HandEyeOptions::default();
    assert!(matches!(
        solve_motions(&motions[..1], &opts),
        Err(HandEyeError::TooFewMotions { got: 1, need: 2 })
    ));
    let mut bad = motions.clone();
    bad[2].weight = -1.0;
    assert!(matches!(
        solve_motions(&bad, &opts),
        Err(HandEyeError::InvalidWeight { index: 2, .. })
    ));
    let sol = solve_motions(&motions, &opts).unwrap();
    assert_eq!(sol.pairs, 6);
    let (er, et) = errors(&sol.tool0_from_camera, &true_x());
    assert!(er < 1e-9 && et < 1e-9);
}

#[test]
fn tum_errors_name_the_line_and_timestamp() {
    let err = pose_file::parse_tum("# header\n1 0 0 0 0 0 0 1\n\n2 0 0 0 0 0 1\n").unwrap_err();
    assert_eq!(err, PoseFileError::FieldCount { line: 4, found: 7 });
    let err = pose_file::parse_tum("1 0 0 x 0 0 0 1\n").unwrap_err();
    assert!(matches!(
        err,
        PoseFileError::NotANumber {
            line: 1,
            field: 4,
            ..
        }
    ));
    let err = pose_file::parse_tum("1 0 0 0 0 0 0 2\n").unwrap_err();
    assert!(matches!(
        err,
        PoseFileError::NotUnitQuaternion { line: 1, .. }
    ));
    let err = pose_file::parse_tum("1 0 0 nan 0 0 0 1\n").unwrap_err();
    assert!(matches!(
        err,
        PoseFileError::NonFinite {
            line: 1,
            field: 4,
            ..
        }
    ));
    let hand = pose_file::parse_tum("1 0 0 0 0 0 0 1\n2 0 0 0 0 0 0 1\n").unwrap();
    let eye = pose_file::parse_tum("1 0 0 0 0 0 0 1 # c\n3 0 0 0 0 0 0 1\n").unwrap();
    let err = pose_file::pair_by_timestamp(&hand, &eye).unwrap_err();
    assert_eq!(
        err,
        PoseFileError::UnpairedTimestamp {
            timestamp: 2.0,
            present_in: "hand",
            missing_in: "eye"
        }
    );
    assert!(err.to_string().contains("timestamp 2"));
    // Round trip of the writer is exact.
    let mut rng = Rng(8);
    let poses = stamped(&random_hand(&mut rng, 5));
    let back = pose_file::parse_tum(&pose_file::write_tum(&poses)).unwrap();
    for (a, b) in poses.iter().zip(&back) {
        assert_eq!(a.timestamp, b.timestamp);
        assert_eq!(a.pose.translation, b.pose.translation);
        assert!(a.pose.rotation.angle_to(&b.pose.rotation) < 1e-15);
    }
}

fn mean_errors(
    seed: u64,
    eye_noise: impl Fn(&mut Rng, &Isometry3<f64>) -> Isometry3<f64>,
    opts_of: impl Fn(Method) -> HandEyeOptions,
) -> Vec<(f64, f64)> {
    let mut rng = Rng(seed);
    let x = true_x();
    let trials = 40;
    let mut sum = vec![(0.0, 0.0); Method::ALL.len()];
    for _ in 0..trials {
        let hand_true = random_hand(&mut rng, 12);
        let eye_true = eye_of(&hand_true, &x);
        let hand: Vec<_> = hand_true
            .iter()
            .map(|p| perturb(&mut rng, p, 3e-4, 3e-4))
            .collect();
        let eye: Vec<_> = eye_true.iter().map(|p| eye_noise(&mut rng, p)).collect();
        for (k, method) in Method::ALL.into_iter().enumerate() {
            let sol = solve(&hand, &eye, &opts_of(method)).unwrap();
            let (er, et) = errors(&sol.tool0_from_camera, &x);
            sum[k].0 += er.to_degrees() / trials as f64;
            sum[k].1 += et * 1e3 / trials as f64;
            assert!(sol.sigma_rot_deg.is_finite() && sol.sigma_trans_mm.is_finite());
        }
    }
    for (k, method) in Method::ALL.into_iter().enumerate() {
        println!("{method:>10}: mean {:.4} deg {:.3} mm", sum[k].0, sum[k].1);
    }
    sum
}

fn assert_ours_best(sum: &[(f64, f64)], tolerance: f64) {
    let ours = sum[0];
    for (k, method) in Method::ALL.into_iter().enumerate().skip(1) {
        assert!(
            ours.0 <= sum[k].0 * tolerance,
            "{method} rotation {} < ours {}",
            sum[k].0,
            ours.0
        );
        assert!(
            ours.1 <= sum[k].1 * tolerance,
            "{method} translation {} < ours {}",
            sum[k].1,
            ours.1
        );
    }
}

/// Board-pose noise (the board tilts about its origin, 1 mrad and 1 mm per axis; hand
/// 0.3 mrad, 0.3 mm): over 40 trials `ours` (default options) is on average at least as
/// accurate as every linear method, in rotation and in translation.
#[test]
fn noisy_board_poses_ours_at_least_as_accurate_as_linear_methods() {
    let sum = mean_errors(
        2024,
        |rng, p| support::pnp_noise(rng, p, 1e-3, 1e-3),
        HandEyeOptions::with_method,
    );
    assert_ours_best(&sum, 1.0);
}

/// Camera-centred noise (orientation error about the camera centre, e.g. SfM poses; the
/// lever model does not apply): with `eye_lever: false`, `ours` stays within 5% of every
/// linear method (measured: best in translation, 2% behind Daniilidis in rotation).
#[test]
fn noisy_camera_centred_poses_ours_comparable_without_lever() {
    let sum = mean_errors(
        2025,
        |rng, p| perturb(rng, p, 1e-3, 1e-3),
        |method| HandEyeOptions {
            eye_lever: false,
            ..HandEyeOptions::with_method(method)
        },
    );
    assert_ours_best(&sum, 1.05);
}

/// One grossly wrong eye pose: the robust loss keeps `ours` close while Kronecker drifts.
#[test]
fn robust_loss_limits_a_bad_view() {
    let mut rng = Rng(99);
    let x = true_x();
    let hand = random_hand(&mut rng, 12);
    let mut eye: Vec<_> = eye_of(&hand, &x)
        .iter()
        .map(|p| perturb(&mut rng, p, 2e-4, 2e-4))
        .collect();
    eye[5] = perturb(&mut rng, &eye[5], 0.02, 0.03);
    let ours = solve(&hand, &eye, &HandEyeOptions::default()).unwrap();
    let plain = solve(
        &hand,
        &eye,
        &HandEyeOptions {
            loss: RobustLoss::None,
            ..HandEyeOptions::default()
        },
    )
    .unwrap();
    let kron = solve(&hand, &eye, &HandEyeOptions::with_method(Method::Kronecker)).unwrap();
    let (eo, to) = errors(&ours.tool0_from_camera, &x);
    let (ep, tp) = errors(&plain.tool0_from_camera, &x);
    let (ek, tk) = errors(&kron.tool0_from_camera, &x);
    println!("robust {eo:.2e} {to:.2e}  plain {ep:.2e} {tp:.2e}  kronecker {ek:.2e} {tk:.2e}");
    assert!(to < tk && to < tp, "robust {to} plain {tp} kronecker {tk}");
    assert!(ours.iterations > 0);
}

/// The 1-sigma figures are of the right size: over repeated noisy trials the spread of the
/// errors matches the reported sigma within a factor of 2.
#[test]
fn sigma_matches_observed_spread() {
    let mut rng = Rng(31);
    let x = true_x();
    let (mut e_rot, mut e_t, mut s_rot, mut s_t) = (0.0, 0.0, 0.0, 0.0);
    let trials = 40;
    for _ in 0..trials {
        let hand = random_hand(&mut rng, 12);
        let eye: Vec<_> = eye_of(&hand, &x)
            .iter()
            .map(|p| perturb(&mut rng, p, 1e-3, 1e-3))
            .collect();
        let sol = solve(&hand, &eye, &HandEyeOptions::default()).unwrap();
        let (er, et) = errors(&sol.tool0_from_camera, &x);
        e_rot += er.to_degrees().powi(2) / trials as f64;
        e_t += (et * 1e3).powi(2) / trials as f64;
        s_rot += sol.sigma_rot_deg.powi(2) / trials as f64;
        s_t += sol.sigma_trans_mm.powi(2) / trials as f64;
    }
    let (e_rot, e_t, s_rot, s_t) = (e_rot.sqrt(), e_t.sqrt(), s_rot.sqrt(), s_t.sqrt());
    println!("rms error {e_rot:.4} deg {e_t:.3} mm; rms sigma {s_rot:.4} deg {s_t:.3} mm");
    assert!(
        s_rot > e_rot / 2.0 && s_rot < e_rot * 2.0,
        "rot sigma {s_rot} vs {e_rot}"
    );
    assert!(
        s_t > e_t / 2.0 && s_t < e_t * 2.0,
        "trans sigma {s_t} vs {e_t}"
    );
}

#[test]
fn weights_are_honoured() {
    let mut rng = Rng(6);
    let hand = random_hand(&mut rng, 5);
    let eye = eye_of(&hand, &true_x());
    let mut motions: Vec<RelativeMotion> =
        relative_motions(&hand, &eye, PairSelection::Consecutive);
    for (k, m) in motions.iter_mut().enumerate() {
        m.weight = 1.0 + k as f64;
    }
    for method in Method::ALL {
        let sol = solve_motions(&motions, &HandEyeOptions::with_method(method)).unwrap();
        let (er, et) = errors(&sol.tool0_from_camera, &true_x());
        assert!(er < 1e-9 && et < 1e-9, "{method}");
    }
}

mod property {
    use super::*;
    use proptest::prelude::*;

    fn pose(v: [f64; 6]) -> Isometry3<f64> {
        Isometry3::from_parts(
            Translation3::new(v[0], v[1], v[2]),
            UnitQuaternion::from_scaled_axis(Vector3::new(v[3], v[4], v[5])),
        )
    }

    proptest! {
        #![proptest_config(ProptestConfig {
            cases: 48,
            rng_seed: proptest::test_runner::RngSeed::Fixed(0x5EED_0048),
            failure_persistence: None,
            ..ProptestConfig::default()
        })]
        /// For any X and any well-spread noise-free motions, `ours` and `kronecker`
        /// recover X (B X = X A holds exactly), never its inverse.
        #[test]
        fn any_x_is_recovered(
            x in prop::array::uniform6(-1.0f64..1.0),
            seed in 0u64..1_000_000,
        ) {
            let x = pose(x);
            let mut rng = Rng(seed);
            let hand = random_hand(&mut rng, 6);
            let eye = eye_of(&hand, &x);
            for method in [Method::Ours, Method::Kronecker, Method::Park, Method::Daniilidis] {
                match solve(&hand, &eye, &HandEyeOptions::with_method(method)) {
                    Ok(sol) => {
                        let (er, et) = errors(&sol.tool0_from_camera, &x);
                        // Exact up to rounding: a linear solve of six poorly spread poses
                        // can lose a few digits of the translation (3e-8 m seen).
                        prop_assert!(er < 1e-8 && et < 1e-7, "{method}: {er:e} {et:e}");
                    }
                    // Six random poses can be badly spread; a refusal is allowed, a wrong X is not.
                    Err(HandEyeError::DegenerateRotations { .. }) => {}
                    Err(e) => prop_assert!(false, "{method}: {e}"),
                }
            }
        }
    }
}

/// One eye pose off by 10 deg: most pairs through it have hand/eye rotation angles that
/// disagree and are rejected and reported; the one that slips through (its angle happens
/// to match) costs the linear methods ~0.2 deg while the robust loss of `ours` ignores it.
#[test]
fn pairs_with_angle_mismatch_are_rejected_and_reported() {
    let mut rng = Rng(55);
    let x = true_x();
    let hand = random_hand(&mut rng, 10);
    let mut eye = eye_of(&hand, &x);
    let bad = 3;
    eye[bad] *= Isometry3::rotation(Vector3::new(0.0, 10f64.to_radians(), 0.0));
    for method in Method::ALL {
        let sol = solve(&hand, &eye, &HandEyeOptions::with_method(method)).unwrap();
        // 9 pairs touch the bad view; some may by chance keep the same angle.
        assert!(
            (5..=9).contains(&sol.rejected_pairs.len()),
            "{method}: {:?}",
            sol.rejected_pairs
        );
        assert_eq!(sol.pairs + sol.rejected_pairs.len(), 45);
        let (er, et) = errors(&sol.tool0_from_camera, &x);
        println!(
            "{method}: rejected {} error {er:.2e} rad {et:.2e} m",
            sol.rejected_pairs.len()
        );
        if method == Method::Ours {
            assert!(er < 1e-4 && et < 1e-4, "{method}: {er:e} {et:e}");
        } else {
            assert!(er < 1e-2 && et < 5e-3, "{method}: {er:e} {et:e}");
        }
    }
}

/// The squared Mahalanobis distances `(rotation, translation)` of an estimate's error
/// against the 3x3 blocks of its reported covariance.
fn mahalanobis(s: &calib::handeye::HandEyeSolution, truth: &Isometry3<f64>) -> (f64, f64) {
    calib::handeye::uncertainty::mahalanobis(s, truth).expect("a covariance")
}

/// An uncertainty that can be trusted: over 400 calibrations of 18 views with per-view
/// pose error (hand, eye or both, as the arm's kinematics and a camera's pose estimate make
/// it), the squared Mahalanobis distance of the rotation and of the translation error
/// against the reported covariance falls under the chi-square(3) 95 % point (7.81) in
/// 90-99 % of the trials. The linearised covariance alone holds it for the rotation in
/// only about three quarters of them.
#[test]
fn the_reported_covariance_covers_the_error_at_its_level() {
    let x = true_x();
    let conditions = [
        (0.02, 0.2, 0.02, 0.2),
        (0.0, 0.0, 0.05, 0.3),
        (0.05, 0.5, 0.0, 0.0),
    ];
    let mut rng = Rng(2026);
    let (mut rot_in, mut trans_in, mut lin_rot_in, trials) = (0, 0, 0, 402);
    for k in 0..trials {
        let (hand_deg, hand_mm, eye_deg, eye_mm): (f64, f64, f64, f64) =
            conditions[k % conditions.len()];
        let hand = random_hand(&mut rng, 18);
        let eye = eye_of(&hand, &x);
        let hand: Vec<_> = hand
            .iter()
            .map(|h| perturb(&mut rng, h, hand_deg.to_radians(), hand_mm * 1e-3))
            .collect();
        let eye: Vec<_> = eye
            .iter()
            .map(|e| perturb(&mut rng, e, eye_deg.to_radians(), eye_mm * 1e-3))
            .collect();
        let s = solve(&hand, &eye, &HandEyeOptions::default()).expect("solve");
        assert_eq!(s.uncertainty, calib::handeye::UncertaintySource::Jackknife);
        let (r2, t2) = mahalanobis(&s, &x);
        rot_in += usize::from(r2 <= 7.81);
        trans_in += usize::from(t2 <= 7.81);
        // The linearised covariance of the same solve, for comparison.
        let motions = calib::handeye::relative_motions(&hand, &eye, PairSelection::All);
        let stats = calib::handeye::uncertainty::evaluate(
            &motions,
            &s.tool0_from_camera,
            1.0,
            &HandEyeOptions::default(),
            17,
        );
        let lin = calib::handeye::HandEyeSolution {
            covariance: stats.covariance,
            ..s.clone()
        };
        lin_rot_in += usize::from(mahalanobis(&lin, &x).0 <= 7.81);
    }
    let frac = |n: usize| n as f64 / trials as f64;
    eprintln!(
        "coverage at chi2(3) 95%: rotation {:.3}, translation {:.3} (linearised rotation {:.3}) over {trials} trials",
        frac(rot_in),
        frac(trans_in),
        frac(lin_rot_in)
    );
    for (what, f) in [("rotation", frac(rot_in)), ("translation", frac(trans_in))] {
        assert!((0.90..=0.99).contains(&f), "{what}: {f:.3}");
    }
    assert!(
        frac(lin_rot_in) < 0.85,
        "the linearised figure was expected to fall short"
    );
}
