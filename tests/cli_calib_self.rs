//! `rodlog calib self` end to end on the simulator: `record --scenario calib-18` with the
//! arm perturbation, encoder noise and camera_info error switched off, then self-calibration from the
//! recording's images, depth and /tf only. The estimate is compared with the simulator's
//! true mount (`/sim/camera_mount`, read here by the test, never by the pipeline): the
//! issue's bar is < 0.02 deg and < 0.2 mm. The true mount is asymmetric (t = (60, -35, 90)
//! mm, ~90 deg about a tilted axis), so an inverted X cannot pass. The same recording carries
//! the calibration stage's outputs (the same X, the camera edge switched to it), replays byte
//! for byte on one thread, and `calib self --out` writes them into a new file.

#[path = "support/cli.rs"]
mod cli;
use cli::rodlog;

#[path = "support/sim_truth.rs"]
mod sim_truth;
use std::path::Path;
use std::process::Command;

use msgs::Msg;
use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion};
use replay::{McapReader, ReadFilter};

fn estimate(json: &serde_json::Value) -> Isometry3<f64> {
    let t: Vec<f64> = (0..3)
        .map(|i| json["translation_m"][i].as_f64().expect("t"))
        .collect();
    let q: Vec<f64> = (0..4)
        .map(|i| json["quaternion_xyzw"][i].as_f64().expect("q"))
        .collect();
    Isometry3::from_parts(
        Translation3::new(t[0], t[1], t[2]),
        UnitQuaternion::from_quaternion(Quaternion::new(q[3], q[0], q[1], q[2])),
    )
}

#[test]
fn self_calibration_on_clean_calib18_recovers_the_true_mount() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let rec = tmp.path().join("calib18.mcap");
    let rec_s = rec.display().to_string();
    let run = rodlog(&[
        "record",
        "--scenario",
        "calib-18",
        "--set",
        "robot.perturbation=false",
        "--set",
        "robot.encoder_noise=false",
        "--set",
        "camera.info_error=false",
        "--out",
        &rec_s,
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );

    let yaml = tmp.path().join("x.yaml");
    let out = rodlog(&[
        "calib",
        "self",
        &rec_s,
        "--json",
        "--yaml",
        &yaml.display().to_string(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    assert_eq!(json["mode"], "rgbd");
    assert_eq!(json["frame"], "tool0");
    assert_eq!(json["views"], 18);

    let truth = sim_truth::true_mount(&rec);
    let est = estimate(&json);
    let err = truth.inverse() * est;
    let rot_deg = err.rotation.angle().to_degrees();
    let trans_mm = (est.translation.vector - truth.translation.vector).norm() * 1e3;
    assert!(rot_deg < 0.02, "rotation error {rot_deg} deg");
    assert!(trans_mm < 0.2, "translation error {trans_mm} mm");
    let inverted = (est.inverse().translation.vector - truth.translation.vector).norm() * 1e3;
    assert!(inverted > 10.0, "the inverse would pass too");

    // The paper's keypoint selection (the quadtree) instead of ours (retain-best): as good
    // here, and really used (a different estimate from the same views).
    let qt = rodlog(&[
        "calib",
        "self",
        &rec_s,
        "--json",
        "--distribution",
        "quadtree",
    ]);
    assert!(
        qt.status.success(),
        "{}",
        String::from_utf8_lossy(&qt.stderr)
    );
    let qt_est = estimate(&serde_json::from_slice(&qt.stdout).expect("JSON"));
    let (qt_rot_deg, qt_t_m) = calib::handeye::pose_error(&truth, &qt_est);
    assert!(
        qt_rot_deg < 0.05 && qt_t_m < 0.5e-3,
        "quadtree: {qt_rot_deg} deg, {} mm",
        qt_t_m * 1e3
    );
    let (d_rot, d_t) = calib::handeye::pose_error(&est, &qt_est);
    assert!(d_rot > 1e-6 || d_t > 1e-9, "--distribution changed nothing");

    // The paper's method as written (Umeyama pair motions, Kronecker/SVD, LM on eq. 15 over
    // the tracked features) and its bundle-adjusted variant, on the same clean views: within
    // 0.05 deg / 0.5 mm of the true mount, and eq. 15 really ran (its cost fell).
    for method in ["paper", "paper+ba"] {
        let run = rodlog(&["calib", "self", &rec_s, "--json", "--method", method]);
        assert!(
            run.status.success(),
            "--method {method}: {}",
            String::from_utf8_lossy(&run.stderr)
        );
        let json: serde_json::Value = serde_json::from_slice(&run.stdout).expect("JSON");
        assert_eq!(json["method"], method);
        let eq15 = &json["eq15"];
        let points = eq15["points"].as_u64().expect("eq15.points");
        let observations = eq15["observations"].as_u64().expect("eq15.observations");
        assert_eq!(eq15["views"], 18, "{eq15}");
        assert!(points >= 100 && observations > 2 * points, "{eq15}");
        let initial = eq15["initial_cost"].as_f64().expect("initial_cost");
        let last = eq15["final_cost"].as_f64().expect("final_cost");
        assert!(last < initial, "eq. 15 did not lower its cost: {eq15}");
        let (rot_deg, t_m) = calib::handeye::pose_error(&truth, &estimate(&json));
        eprintln!(
            "--method {method}: {rot_deg:.4} deg, {:.3} mm from the true mount; eq15 {eq15}",
            t_m * 1e3
        );
        assert!(
            rot_deg < 0.05 && t_m < 0.5e-3,
            "--method {method}: {rot_deg} deg, {} mm",
            t_m * 1e3
        );
    }

    let text = std::fs::read_to_string(&yaml).expect("yaml");
    assert!(text.contains("direction: tool0_from_camera"));
    assert!(text.contains("camera_from_tool0"));

    // The calibration stage of the record pipeline computed the same X from the same views.
    let (stage_x, edges_after) = stage_outputs(&rec);
    let (r, t) = calib::handeye::pose_error(&stage_x, &est);
    assert!(r < 1e-6 && t < 1e-9, "stage vs calib self: {r} deg {t} m");
    assert!(edges_after > 0, "the camera edge follows the calibration");

    // The recording replays byte for byte, also on one worker thread.
    let check = Command::new(env!("CARGO_BIN_EXE_rodlog"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .env("RAYON_NUM_THREADS", "1")
        .args(["replay", &rec_s, "--check"])
        .output()
        .expect("run rodlog");
    let stdout = String::from_utf8_lossy(&check.stdout);
    assert!(
        check.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&check.stderr)
    );
    assert!(stdout.contains("/calibration/hand_eye"), "{stdout}");

    // --out: inputs + the calibration stage's outputs, the same X.
    let out_path = tmp.path().join("out.mcap");
    let out_s = out_path.display().to_string();
    let run = rodlog(&["calib", "self", &rec_s, "--out", &out_s]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let (out_x, _) = stage_outputs(&out_path);
    let (r, t) = calib::handeye::pose_error(&out_x, &est);
    assert!(r < 1e-6 && t < 1e-9, "--out vs JSON: {r} deg {t} m");
    let mut reader = McapReader::open(&out_path).expect("open out");
    let images = reader
        .read_all(&ReadFilter::all().with_topics(["/camera/color/image_raw".to_owned()]))
        .expect("read");
    assert_eq!(images.len(), 18, "the inputs are copied");
    // No half-written file when --out cannot be written.
    let bad = tmp.path().join("no_such_dir/out.mcap");
    let run = rodlog(&["calib", "self", &rec_s, "--out", &bad.display().to_string()]);
    assert!(!run.status.success());
    assert!(!bad.exists());
    assert!(
        std::fs::read_dir(tmp.path()).expect("ls").all(|e| !e
            .expect("entry")
            .file_name()
            .to_string_lossy()
            .ends_with(".partial")),
        "no temporary file left"
    );
}

/// The calibration stage's `/calibration/hand_eye` X in a recording (exactly one), and how
/// many camera edges on `/tf` (producer `calibration`) after it carry that X.
fn stage_outputs(rec: &Path) -> (Isometry3<f64>, usize) {
    let mut reader = McapReader::open(rec).expect("open");
    let filter = ReadFilter::all().with_topics([
        "/calibration/hand_eye".to_owned(),
        "/tf".to_owned(),
        "/rosout".to_owned(),
    ]);
    let msgs = reader.read_all(&filter).expect("read");
    let mut x: Option<(u64, Isometry3<f64>)> = None;
    let mut after = 0;
    for m in &msgs {
        match m.decode().expect("decode") {
            Msg::HandEyeCalibration(c) => {
                assert!(x.is_none(), "one calibration");
                assert_eq!(
                    (c.mode.as_str(), c.views, c.header.frame_id.as_str()),
                    ("rgbd", 18, "tool0")
                );
                assert!(c.sigma_rot_deg > 0.0 && c.sigma_trans_mm > 0.0);
                let iso =
                    robot::conversions::isometry_from_msg(&c.tool0_from_camera).expect("finite");
                x = Some((m.log_time_ns, iso));
            }
            Msg::TfMessage(tf) if m.channel.producer() == Some("calibration") => {
                assert_eq!(tf.transforms.len(), 1);
                assert_eq!(
                    tf.transforms[0].child_frame_id,
                    "camera_color_optical_frame"
                );
                if let Some((t0, xe)) = &x
                    && m.log_time_ns > *t0
                {
                    let e = robot::conversions::isometry_from_msg(&tf.transforms[0].transform)
                        .expect("finite");
                    let (r, t) = calib::handeye::pose_error(&e, xe);
                    assert!(r < 1e-6 && t < 1e-9);
                    after += 1;
                }
            }
            Msg::Log(l) if m.channel.producer() == Some("calibration") => {
                assert!(l.msg.contains("accepted"), "{}", l.msg);
            }
            _ => {}
        }
    }
    let (_, x) = x.expect("the calibration stage published /calibration/hand_eye");
    (x, after)
}

#[test]
fn self_calibration_refuses_a_recording_without_images() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let rec = tmp.path().join("smoke.mcap").display().to_string();
    // arm_sweep (test world) has no camera at all.
    let run = rodlog(&["record", "--scenario", "arm_sweep", "--out", &rec]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let out_mcap = tmp.path().join("out.mcap");
    let out = rodlog(&[
        "calib",
        "self",
        &rec,
        "--out",
        &out_mcap.display().to_string(),
    ]);
    assert!(!out.status.success());
    assert!(out.stdout.is_empty());
    assert!(!String::from_utf8_lossy(&out.stderr).is_empty());
    assert!(!out_mcap.exists(), "a refusal writes no --out file");
}
