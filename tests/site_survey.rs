//! A seeded site the robot does not know by heart: `rodlog survey` writes the simulated
//! crew's survey (the truth with a survey's error), `record --site` gives it to the robot,
//! and the hang succeeds with no unsafe command. The survey that reached the robot (the
//! recording's parameters) is the file's, and it is not the truth: the surveyed wire point is
//! off the true hanging point by a survey's error (a few cm), not by nothing.

use std::process::Command;

fn rodlog(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_rodlog"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(args)
        .output()
        .expect("run rodlog")
}

#[test]
fn a_hang_on_a_seeded_site_with_a_survey_succeeds_safely() {
    let dir = tempfile::tempdir().expect("tempdir");
    let site = dir.path().join("site.toml");
    let site_s = site.display().to_string();
    let out = rodlog(&[
        "survey",
        "hang",
        "--seed",
        "1",
        "--set",
        "site.layout=seeded",
        "--out",
        &site_s,
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = std::fs::read_to_string(&site).expect("site file");
    let table: toml::Table = text.parse().expect("a site file is TOML");
    let point: Vec<f64> = table["survey"]["wire"]["point_m"]
        .as_array()
        .expect("point_m")
        .iter()
        .map(|v| v.as_float().expect("number"))
        .collect();

    let rec = dir.path().join("hang.mcap");
    let rec_s = rec.display().to_string();
    let out = rodlog(&[
        "record",
        "--scenario",
        "hang",
        "--seed",
        "1",
        "--until-done",
        "--set",
        "site.layout=seeded",
        "--site",
        &site_s,
        "--set",
        "camera.scale=0.2",
        "--set",
        "camera.depth_encoding=16UC1",
        "--set",
        "panoramic.period_s=5",
        "--out",
        &rec_s,
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let judged = rodlog(&["check", "task", &rec_s, "--json"]);
    assert!(
        judged.status.success(),
        "{}",
        String::from_utf8_lossy(&judged.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&judged.stdout).expect("JSON");
    assert_eq!(v["outcome"], "done", "{v}");
    assert_eq!(
        v["unsafe_commands"].as_array().map(Vec::len),
        Some(0),
        "{v}"
    );

    // The true hanging point at the start (/sim/wire_pose) against the survey's.
    let mut reader = replay::McapReader::open(&rec).expect("open");
    let truth = reader
        .read_all(&replay::ReadFilter::all().with_topics([msgs::topics::SIM_WIRE_POSE.to_owned()]))
        .expect("read");
    let first = truth.first().expect("a /sim/wire_pose");
    let msgs::Msg::PoseStamped(pose) = first.decode().expect("decode") else {
        panic!("not a pose");
    };
    let t = [
        pose.pose.position.x,
        pose.pose.position.y,
        pose.pose.position.z,
    ];
    let off_m = (0..3)
        .map(|i| (point[i] - t[i]).powi(2))
        .sum::<f64>()
        .sqrt();
    eprintln!(
        "surveyed wire point {point:?} vs true {t:?}: {:.1} mm off",
        off_m * 1e3
    );
    assert!(
        off_m > 1e-3 && off_m < 5.0 * 0.02 * 3f64.sqrt(),
        "{off_m} m"
    );
    let meta = reader
        .metadata()
        .iter()
        .find(|m| m.name == "scenario")
        .expect("scenario record");
    let recorded = meta
        .entries
        .get("param.survey.wire.point_m")
        .expect("recorded survey");
    assert!(
        recorded.contains(&format!("{:?}", point[0])),
        "{recorded} vs {point:?}"
    );
}

/// `calib-site` at a seeded bay: the task plans the 18 recalibration views from the survey's
/// cabinet (not calib-18's fixed joint list, which was made for the fixed bay), the camera
/// was knocked at 0.5 s (by 1-3 deg, more than the tolerance), and the recalibration lands within the judge's tolerance of the
/// true mount, with no unsafe command.
#[test]
fn self_calibration_at_a_seeded_site_plans_its_views_from_the_survey() {
    let dir = tempfile::tempdir().expect("tempdir");
    let site = dir.path().join("site.toml");
    let site_s = site.display().to_string();
    let seeded = ["--seed", "3", "--set", "site.layout=seeded"];
    let mut args = vec!["survey", "calib-site"];
    args.extend(seeded);
    args.extend(["--out", &site_s]);
    let out = rodlog(&args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rec = dir.path().join("calib.mcap");
    let rec_s = rec.display().to_string();
    let mut args = vec!["record", "--scenario", "calib-site", "--until-done"];
    args.extend(seeded);
    args.extend([
        "--site",
        &site_s,
        "--set",
        "camera.scale=0.2",
        "--set",
        "camera.depth_encoding=16UC1",
        "--out",
        &rec_s,
    ]);
    let out = rodlog(&args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let judged = rodlog(&["check", "task", &rec_s, "--json"]);
    assert!(
        judged.status.success(),
        "{}",
        String::from_utf8_lossy(&judged.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&judged.stdout).expect("JSON");
    eprintln!("{v}");
    assert_eq!(v["task"], "self-calibrate", "{v}");
    assert_eq!(v["outcome"], "done", "{v}");
    assert_eq!(v["reason_code"], "accepted", "{v}");
    assert_eq!(
        v["unsafe_commands"].as_array().map(Vec::len),
        Some(0),
        "{v}"
    );
    assert_eq!(v["success"], true, "{v}");
    let hand_eye = v["hand_eye"].as_array().expect("hand_eye");
    let last = hand_eye.last().expect("a recalibrated mount published");
    let (deg, mm) = compose::judge::SELF_CALIBRATION_TOLERANCE;
    assert!(
        last["rot_error_deg"].as_f64().expect("deg") <= deg,
        "{last}"
    );
    assert!(last["trans_error_mm"].as_f64().expect("mm") <= mm, "{last}");
    // The recording keeps the survey: its replay plans the same views and solves the same.
    let check = rodlog(&["replay", &rec_s, "--check"]);
    assert!(
        check.status.success(),
        "{}{}",
        String::from_utf8_lossy(&check.stdout),
        String::from_utf8_lossy(&check.stderr)
    );
}
