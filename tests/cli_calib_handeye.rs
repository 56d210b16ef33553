//! `rodlog calib handeye` end to end: noise-free synthetic poses written as TUM files go
//! through the binary, and every method must return the asymmetric X to 1e-9 (ARCHITECTURE.md section 6:
//! an inverted X cannot pass); scale-free data returns its scale; degenerate input is
//! refused with a message and a non-zero exit code.

#[path = "support/cli.rs"]
mod cli;
use cli::rodlog;

use std::path::Path;

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

/// The asymmetric test mount of ARCHITECTURE.md section 6: t = (0.05, 0.02, -0.08) m, 30 deg about a
/// skew axis.
fn true_tool0_from_camera() -> Isometry3<f64> {
    let axis = nalgebra::Unit::new_normalize(Vector3::new(1.0, -2.0, 0.5));
    Isometry3::from_parts(
        Translation3::new(0.05, 0.02, -0.08),
        UnitQuaternion::from_axis_angle(&axis, 30f64.to_radians()),
    )
}

/// Hand poses with well-spread rotation axes (deterministic).
fn hand_poses(n: usize) -> Vec<Isometry3<f64>> {
    (0..n)
        .map(|i| {
            let k = i as f64;
            let axis = nalgebra::Unit::new_normalize(Vector3::new(
                (1.3 * k).sin() + 0.2,
                (0.7 * k + 1.0).cos(),
                (2.1 * k).sin() * 0.8 + 0.3,
            ));
            let angle = 0.3 + 0.5 * ((0.9 * k).sin()).abs();
            Isometry3::from_parts(
                Translation3::new(
                    0.4 + 0.1 * (k * 0.5).cos(),
                    -0.2 + 0.15 * k.sin(),
                    0.8 + 0.05 * k.cos(),
                ),
                UnitQuaternion::from_axis_angle(&axis, angle),
            )
        })
        .collect()
}

fn write_tum(path: &Path, poses: &[Isometry3<f64>], scale: f64) {
    let mut text = String::from("# timestamp tx ty tz qx qy qz qw\n");
    for (i, p) in poses.iter().enumerate() {
        let t = p.translation.vector * scale;
        let q = p.rotation.coords;
        text.push_str(&format!(
            "{i} {} {} {} {} {} {} {}\n",
            t.x, t.y, t.z, q.x, q.y, q.z, q.w
        ));
    }
    std::fs::write(path, text).expect("write pose file");
}

fn matrix_of(json: &serde_json::Value) -> nalgebra::Matrix4<f64> {
    let mut m = nalgebra::Matrix4::zeros();
    for r in 0..4 {
        for c in 0..4 {
            m[(r, c)] = json["matrix"][r][c].as_f64().expect("matrix entry");
        }
    }
    m
}

fn fixture(dir: &Path, scale: f64) -> (String, String) {
    let x = true_tool0_from_camera();
    let world_from_base = Isometry3::from_parts(
        Translation3::new(1.0, -0.5, 0.2),
        UnitQuaternion::from_euler_angles(0.1, -0.2, 0.7),
    );
    let hand = hand_poses(12);
    let eye: Vec<_> = hand.iter().map(|h| world_from_base * h * x).collect();
    let hand_path = dir.join("hand.txt");
    let eye_path = dir.join("eye.txt");
    write_tum(&hand_path, &hand, 1.0);
    write_tum(&eye_path, &eye, scale);
    (
        hand_path.display().to_string(),
        eye_path.display().to_string(),
    )
}

#[test]
fn every_method_recovers_an_asymmetric_x_through_the_cli() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (hand, eye) = fixture(dir.path(), 1.0);
    let truth = true_tool0_from_camera().to_homogeneous();
    for method in [
        "ours",
        "kronecker",
        "tsai",
        "park",
        "horaud",
        "andreff",
        "daniilidis",
    ] {
        let out = rodlog(&[
            "calib", "handeye", "--hand", &hand, "--eye", &eye, "--method", method, "--json",
        ]);
        assert!(
            out.status.success(),
            "{method}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let json: serde_json::Value = serde_json::from_slice(&out.stdout).expect("one JSON object");
        assert_eq!(json["method"], method);
        assert_eq!(json["frame"], "tool0");
        assert_eq!(json["child_frame"], "camera_color_optical_frame");
        let err = (matrix_of(&json) - truth).abs().max();
        assert!(err < 1e-9, "{method}: |X - X_true|_max = {err:e}");
        let inverse_err = (matrix_of(&json) - truth.try_inverse().expect("invertible"))
            .abs()
            .max();
        assert!(inverse_err > 1e-3, "{method}: the inverse would pass too");
    }
}

#[test]
fn scale_free_recovers_the_scale() {
    let dir = tempfile::tempdir().expect("tempdir");
    // Eye translations in a unit that is 1/0.37 of a metre: scale = 0.37 m per unit.
    let (hand, eye) = fixture(dir.path(), 1.0 / 0.37);
    let out = rodlog(&[
        "calib",
        "handeye",
        "--hand",
        &hand,
        "--eye",
        &eye,
        "--scale-free",
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    let scale = json["scale"].as_f64().expect("scale");
    assert!((scale - 0.37).abs() < 1e-9, "scale {scale}");
    let err = (matrix_of(&json) - true_tool0_from_camera().to_homogeneous())
        .abs()
        .max();
    assert!(err < 1e-9, "|X - X_true|_max = {err:e}");
}

#[test]
fn degenerate_and_malformed_inputs_are_refused_with_a_reason() {
    let dir = tempfile::tempdir().expect("tempdir");
    let x = true_tool0_from_camera();
    // Rotations about one axis only: X's rotation about that axis is unobservable.
    let hand: Vec<_> = (0..8)
        .map(|i| {
            Isometry3::from_parts(
                Translation3::new(0.1 * f64::from(i), 0.0, 0.5),
                UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.2 * f64::from(i)),
            )
        })
        .collect();
    let eye: Vec<_> = hand.iter().map(|h| h * x).collect();
    let (h, e) = (dir.path().join("h.txt"), dir.path().join("e.txt"));
    write_tum(&h, &hand, 1.0);
    write_tum(&e, &eye, 1.0);
    let out = rodlog(&[
        "calib",
        "handeye",
        "--hand",
        &h.display().to_string(),
        "--eye",
        &e.display().to_string(),
    ]);
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("refused"), "{stderr}");
    assert!(out.stdout.is_empty(), "nothing on stdout for a refusal");

    // A NaN in the hand file.
    std::fs::write(&h, "0 nan 0 0 0 0 0 1\n1 0 0 0 0 0 0 1\n2 0 0 0 0 0 0 1\n").expect("write");
    let out = rodlog(&[
        "calib",
        "handeye",
        "--hand",
        &h.display().to_string(),
        "--eye",
        &e.display().to_string(),
    ]);
    assert!(!out.status.success());

    // Unknown method.
    let out = rodlog(&[
        "calib", "handeye", "--hand", "a", "--eye", "b", "--method", "magic",
    ]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("unknown hand-eye method"));
}
