//! End to end: the `task` stage hangs and removes the rod in the simulator, the
//! independent judge (`rodlog check task`) confirms it with the simulator's truth, the runs
//! replay byte for byte, and the judge catches what is unsafe (a colliding command, commands
//! in high wind) while a windy start is waited for, then refused without a single command.

#[path = "support/cli.rs"]
mod cli;
use cli::rodlog;

use std::path::{Path, PathBuf};

fn scenario(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("recordings/scenarios")
        .join(format!("{name}.toml"))
        .display()
        .to_string()
}

fn record(name: &str, out: &Path, sets: &[&str]) {
    let mut args = vec![
        "record".to_owned(),
        "--scenario".to_owned(),
        scenario(name),
        "--out".to_owned(),
        out.display().to_string(),
    ];
    for s in sets {
        args.push("--set".to_owned());
        args.push((*s).to_owned());
    }
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    run_ok(&args);
}

/// Runs `rodlog ARGS`, which must succeed.
fn run_ok(args: &[&str]) -> std::process::Output {
    let run = rodlog(args);
    assert!(
        run.status.success(),
        "rodlog {}: {}",
        args.join(" "),
        String::from_utf8_lossy(&run.stderr)
    );
    run
}

fn judge(rec: &Path) -> (bool, serde_json::Value) {
    let out = rodlog(&["check", "task", rec.to_str().expect("utf-8"), "--json"]);
    let v = serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!(
            "judge JSON: {e}\n{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        )
    });
    (out.status.success(), v)
}

/// The judge found no unsafe command.
fn assert_no_unsafe_command(v: &serde_json::Value) {
    assert_eq!(
        v["unsafe_commands"].as_array().map(Vec::len),
        Some(0),
        "{v}"
    );
}

/// `rodlog replay REC --check` regenerates every stage output byte for byte.
fn assert_replays_identically(rec: &Path) {
    let check = rodlog(&["replay", rec.to_str().expect("utf-8"), "--check"]);
    assert!(
        check.status.success(),
        "{}: {}{}",
        rec.display(),
        String::from_utf8_lossy(&check.stdout),
        String::from_utf8_lossy(&check.stderr)
    );
}

/// A quick, well-lit, unbumped run with the calibration left as it is.
const QUICK: [&str; 5] = [
    "task.self_maintenance=false",
    "bump.rot_deg=0",
    "bump.trans_mm=0",
    "camera.scale=0.25",
    "panoramic.scale=0.5",
];

#[test]
fn the_rod_is_hung_and_removed_safely_and_both_runs_replay_identically() {
    let dir = tempfile::tempdir().expect("tmp");
    for task in ["hang", "remove"] {
        let rec: PathBuf = dir.path().join(format!("{task}.mcap"));
        record(task, &rec, &QUICK);
        let (ok, v) = judge(&rec);
        assert!(ok, "{v}");
        assert_eq!(v["task"], task, "{v}");
        assert_eq!(v["outcome"], "done", "{v}");
        assert_eq!(v["success"], true, "{v}");
        assert_no_unsafe_command(&v);
        assert!(v["commands"].as_u64().unwrap_or(0) > 8, "{v}");
        assert!(
            v["operation_s"].as_f64().unwrap_or(f64::INFINITY) < 300.0,
            "{v}"
        );
        if task == "hang" {
            assert_eq!(v["rod_state"], "clamped", "{v}");
            let fraction = v["hook"]["window_fraction"].as_f64().unwrap_or(f64::NAN);
            assert!(fraction < 0.5, "hook at {fraction} of its window: {v}");
        } else {
            assert_eq!(v["rod_state"], "on_rack", "{v}");
        }
        assert_replays_identically(&rec);
    }
}

#[test]
fn a_knocked_camera_is_noticed_recalibrated_and_the_rod_still_hung() {
    // hang.toml: seed 21, the mount bumped at 0.5 s (1.8 deg / 7.6 mm), self-maintenance on.
    let dir = tempfile::tempdir().expect("tmp");
    let rec = dir.path().join("hang.mcap");
    record("hang", &rec, &["panoramic.scale=0.5"]);
    let (ok, v) = judge(&rec);
    assert!(ok, "{v}");
    let answers = calibration_answers(&v);
    let answers: Vec<(&str, &str)> = answers
        .iter()
        .map(|(s, r)| (s.as_str(), r.as_str()))
        .collect();
    assert_eq!(
        answers,
        [("check", "drifted"), ("calibrate", "accepted")],
        "{v}"
    );
    // The new calibration, against the simulator's true (bumped) mount.
    let he = &v["hand_eye"][0];
    assert!(
        he["rot_error_deg"].as_f64().unwrap_or(f64::NAN) < 0.2,
        "{v}"
    );
    assert!(
        he["trans_error_mm"].as_f64().unwrap_or(f64::NAN) < 2.0,
        "{v}"
    );
    assert_eq!(v["success"], true, "{v}");
    assert_no_unsafe_command(&v);
    assert!(
        v["operation_s"].as_f64().unwrap_or(f64::INFINITY) < 300.0,
        "{v}"
    );
    // The drift check, the 18 views, the solve and the hang after it replay identically.
    assert_replays_identically(&rec);
}

/// The verdicts of the calibration stage a judged run received, `(state, reason_code)`.
fn calibration_answers(v: &serde_json::Value) -> Vec<(String, String)> {
    v["calibration"]
        .as_array()
        .map(|a| {
            a.iter()
                .map(|c| {
                    (
                        c["state"].as_str().unwrap_or("").to_owned(),
                        c["reason_code"].as_str().unwrap_or("").to_owned(),
                    )
                })
                .collect()
        })
        .unwrap_or_default()
}

#[test]
fn a_calibration_carried_to_the_next_run_is_checked_not_redone() {
    // The golden run found its bump and recalibrated; `calib carry` writes that calibration
    // as parameters. The same bay and bump again, started from it: the drift check finds
    // the mount where the carried calibration says, and the rod is hung without a second
    // calibration (at camera.scale 0.5: the golden 0.2 is too coarse for the check to
    // confirm a mount, it recalibrates after "cannot tell"). That run's check leaves its
    // reference, and a third day's check compares with it.
    let golden = Path::new(env!("CARGO_MANIFEST_DIR")).join("recordings/hang.mcap");
    let dir = tempfile::tempdir().expect("tmp");
    let (text, sets) = carry(&golden, &dir.path().join("carried.toml"));
    assert_eq!(sets.len(), 4, "{text}");
    let rec = dir.path().join("carried.mcap");
    record_golden_with(&golden, &rec, &[], &sets);
    let (v, answers) = judged_consistent(&rec);
    assert!(answers.iter().all(|(s, _)| s == "check"), "{v}");
    assert_eq!(v["success"], true, "{v}");
    assert_no_unsafe_command(&v);
    assert_replays_identically(&rec);
    // Nothing was accepted in this run, but its check found the carried mount consistent:
    // the run leaves that mount and the check's reference.
    let (text, sets) = carry(&rec, &dir.path().join("reference.toml"));
    assert_eq!(
        sets.len(),
        4,
        "mount and reference, no sigma (none accepted): {text}"
    );
    assert!(text.contains("calibration.reference_xyz_m"), "{text}");
    assert!(text.contains("the camera edge the run kept"), "{text}");
    // Another day of the same robot (other sensor noise), a check only: it compares with
    // the reference and finds the mount where it was.
    let day3 = dir.path().join("day3.mcap");
    record_golden_with(&golden, &day3, &["task=check", "noise_seed=7"], &sets);
    judged_consistent(&day3);
    let log = rodlog(&["log", day3.to_str().expect("utf-8")]);
    let log = String::from_utf8_lossy(&log.stdout);
    assert!(log.contains("against the reference carried"), "{log}");
    assert_replays_identically(&day3);
}

/// The judge's verdict of `rec` and its calibration answers, the last a consistent check.
fn judged_consistent(rec: &Path) -> (serde_json::Value, Vec<(String, String)>) {
    let (ok, v) = judge(rec);
    assert!(ok, "{v}");
    let answers = calibration_answers(&v);
    assert_eq!(
        answers.last().map(|(s, r)| (s.as_str(), r.as_str())),
        Some(("check", "consistent")),
        "{v}"
    );
    (v, answers)
}

/// `rodlog calib carry REC --out FILE`: the file's text and its lines as `--set` values.
fn carry(rec: &Path, out: &Path) -> (String, Vec<String>) {
    run_ok(&[
        "calib",
        "carry",
        rec.to_str().expect("utf-8"),
        "--out",
        out.to_str().expect("utf-8"),
    ]);
    let text = std::fs::read_to_string(out).expect("carried parameters");
    let sets = text
        .lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .map(|l| l.replacen(" = ", "=", 1))
        .collect();
    (text, sets)
}

/// The golden recording's scenario again at camera.scale 0.5, with `extra` and `carried`
/// as `--set`s, into `out`.
fn record_golden_with(golden: &Path, out: &Path, extra: &[&str], carried: &[String]) {
    let mut args = vec![
        "record",
        "--scenario",
        golden.to_str().expect("utf-8"),
        "--until-done",
        "--set",
        "camera.scale=0.5",
        "--out",
        out.to_str().expect("utf-8"),
    ];
    for s in extra
        .iter()
        .copied()
        .chain(carried.iter().map(String::as_str))
    {
        args.extend(["--set", s]);
    }
    run_ok(&args);
}

#[test]
fn a_windy_start_is_waited_for_then_refused_without_a_command() {
    let dir = tempfile::tempdir().expect("tmp");
    let rec = dir.path().join("windy.mcap");
    let mut sets = QUICK.to_vec();
    sets.push("wind.mean_mps=8.0");
    record("hang", &rec, &sets);
    let (ok, v) = judge(&rec);
    assert!(ok, "{v}");
    assert_eq!(v["outcome"], "refused", "{v}");
    assert_eq!(v["reason_code"], "wind_above_limit", "{v}");
    assert_eq!(v["commands"], 0, "{v}");
    let log = rodlog(&["log", rec.to_str().expect("utf-8")]);
    let text = String::from_utf8_lossy(&log.stdout);
    // It held for the wind's hold timeout (60 s) before giving up, announcing the hold once.
    assert_eq!(text.matches("[holding_for_wind]").count(), 1, "{text}");
    assert!(text.contains("held 6"), "{text}");
    assert!(text.contains("wind_above_limit"), "{text}");
    // No calibration and no check: nothing to carry, and `calib carry` says so.
    let none = rodlog(&["calib", "carry", rec.to_str().expect("utf-8")]);
    assert!(!none.status.success());
    let err = String::from_utf8_lossy(&none.stderr);
    assert!(err.contains("nothing to carry"), "{err}");
}

#[test]
fn in_a_3_mps_wind_the_hang_tracks_the_swing_hooks_and_replays_identically() {
    let dir = tempfile::tempdir().expect("tmp");
    let rec = dir.path().join("windy.mcap");
    record(
        "hang-windy",
        &rec,
        &[
            "task.self_maintenance=false",
            "camera.scale=0.25",
            "panoramic.scale=0.5",
        ],
    );
    let (ok, v) = judge(&rec);
    assert!(ok, "{v}");
    assert_eq!(v["outcome"], "done", "{v}");
    assert_eq!(v["success"], true, "{v}");
    assert_eq!(v["rod_state"], "clamped", "{v}");
    assert_no_unsafe_command(&v);
    // Commands went out above the paper's 2 m/s, below rodlog's 4 m/s.
    let max_wind = v["max_wind_at_command_mps"].as_f64().unwrap_or(f64::NAN);
    assert!((2.0..=4.0).contains(&max_wind), "{v}");
    let log = rodlog(&["log", rec.to_str().expect("utf-8")]);
    let text = String::from_utf8_lossy(&log.stdout);
    assert!(text.contains("[wire_sway]"), "{text}");
    assert!(text.contains("3 more captures to track it"), "{text}");
    assert!(text.contains("the hook goes to the centre"), "{text}");
    assert_replays_identically(&rec);
}

#[test]
fn the_judge_catches_a_colliding_command_and_commands_in_high_wind() {
    let dir = tempfile::tempdir().expect("tmp");
    // The forearm hanging beside the lowered platform hits the chassis; the wind is 6 m/s.
    let text = "name = \"unsafe\"\nseed = 3\nduration_s = 6.0\nhour = 11.0\ntask = \"none\"\n\n\
                [wind]\nmean_mps = 6.0\n\n[camera]\nscale = 0.1\n\n[panoramic]\nperiod_s = 0.0\n\n\
                [[command]]\nt_s = 2.0\nkind = \"joints\"\nvalues = [0.0, -1.5707963, 1.5707963, 0.0, 0.0, 0.0]\n\n\
                [[command]]\nt_s = 4.0\nkind = \"capture\"\n";
    let file = dir.path().join("unsafe.toml");
    std::fs::write(&file, text).expect("write");
    let rec = dir.path().join("unsafe.mcap");
    run_ok(&[
        "record",
        "--scenario",
        file.to_str().expect("utf-8"),
        "--out",
        rec.to_str().expect("utf-8"),
    ]);
    let (ok, v) = judge(&rec);
    assert!(!ok, "the judge passed an unsafe run: {v}");
    let unsafe_commands = v["unsafe_commands"].as_array().expect("list");
    assert_eq!(unsafe_commands.len(), 2, "{v}");
    let reasons: Vec<&str> = unsafe_commands
        .iter()
        .filter_map(|u| u["reason"].as_str())
        .collect();
    assert!(
        reasons[0].contains("collision") && reasons[0].contains("chassis"),
        "{reasons:?}"
    );
    assert!(reasons.iter().all(|r| r.contains("wind")), "{reasons:?}");
}

#[test]
fn the_demo_recalibrates_hangs_and_removes() {
    let dir = tempfile::tempdir().expect("tmp");
    let out = dir.path().join("demo");
    let run = rodlog(&["demo", "--out", out.to_str().expect("utf-8"), "--no-viz"]);
    let stdout = String::from_utf8_lossy(&run.stdout).into_owned();
    assert!(
        run.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&run.stderr)
    );
    for needle in [
        "calibration check: drifted",
        "calibrate: accepted",
        "hang done",
        "remove done",
    ] {
        assert!(stdout.contains(needle), "no {needle:?} in:\n{stdout}");
    }
    let (ok, v) = judge(&out.join("demo.mcap"));
    assert!(ok, "{v}");
    assert_eq!(v["success"], true, "{v}");
}

#[test]
fn a_dusk_refusal_replays_identically_and_a_what_if_is_labelled_open_loop() {
    let dir = tempfile::tempdir().expect("tmp");
    let rec = dir.path().join("dusk.mcap");
    record("hang-dusk", &rec, &["panoramic.scale=0.5"]);
    let (ok, v) = judge(&rec);
    assert!(ok, "{v}");
    assert_eq!(v["outcome"], "refused", "{v}");
    assert_eq!(v["reason_code"], "calibration_unverifiable", "{v}");
    assert_eq!(v["rod_state"], "on_rack", "{v}");
    assert_no_unsafe_command(&v);
    let rec_s = rec.to_str().expect("utf-8");
    assert_replays_identically(&rec);
    // What if the task had skipped the check? Open-loop: the recorded world never saw the
    // new commands, and the what-if file says from when.
    let whatif = dir.path().join("whatif.mcap");
    let out = rodlog(&[
        "replay",
        rec_s,
        "--set",
        "task.self_maintenance=false",
        "--out",
        whatif.to_str().expect("utf-8"),
    ]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}");
    assert!(text.contains("open-loop from"), "{text}");
    assert!(text.contains("task.self_maintenance=false"), "{text}");
    let log = rodlog(&["log", whatif.to_str().expect("utf-8")]);
    let log_text = String::from_utf8_lossy(&log.stdout);
    assert!(log_text.contains("self-maintenance off"), "{log_text}");
    assert!(!log_text.contains("calibration_unverifiable"), "{log_text}");
    let rrd = dir.path().join("whatif.rrd");
    let view = rodlog(&[
        "view",
        whatif.to_str().expect("utf-8"),
        "--out",
        rrd.to_str().expect("utf-8"),
    ]);
    assert!(
        view.status.success(),
        "{}",
        String::from_utf8_lossy(&view.stderr)
    );
    assert!(std::fs::metadata(&rrd).map(|m| m.len()).unwrap_or(0) > 0);
}

#[test]
fn at_dusk_the_wrist_light_lets_the_rod_be_hung_and_the_lit_run_replays_identically() {
    let dir = tempfile::tempdir().expect("tmp");
    let rec = dir.path().join("lit.mcap");
    record("hang-dusk-lit", &rec, &["panoramic.scale=0.5"]);
    let (ok, v) = judge(&rec);
    assert!(ok, "{v}");
    assert_eq!(v["outcome"], "done", "{v}");
    assert_eq!(v["success"], true, "{v}");
    assert_eq!(v["rod_state"], "clamped", "{v}");
    assert_no_unsafe_command(&v);
    // The log says why the light went on, that the panoramic camera saw nothing in the dark,
    // and that the light went off at the end; the light's state is recorded beside its
    // commands.
    let rec_s = rec.to_str().expect("utf-8");
    let log = rodlog(&["log", rec_s]);
    let text = String::from_utf8_lossy(&log.stdout);
    assert!(
        text.contains("[wrist_light]: wrist light on at 100%"),
        "{text}"
    );
    assert!(text.contains("[panoramic_dark]"), "{text}");
    assert!(
        text.contains("[wrist_light]: wrist light off: the operation ended"),
        "{text}"
    );
    let info = rodlog(&["info", rec_s]);
    let info_text = String::from_utf8_lossy(&info.stdout);
    for topic in ["/wrist_light/command", "/wrist_light/state"] {
        assert!(info_text.contains(topic), "{topic}: {info_text}");
    }
    assert_replays_identically(&rec);
    // The same dusk without the light is refused (the hang-dusk test), and a robot without
    // the light is never sent a command for it.
    let dark = dir.path().join("dark.mcap");
    record(
        "hang-dusk-lit",
        &dark,
        &[
            "panoramic.scale=0.5",
            "camera.light=false",
            "duration_s=120",
        ],
    );
    let (_, v) = judge(&dark);
    assert_eq!(v["outcome"], "refused", "{v}");
    let info = rodlog(&["info", dark.to_str().expect("utf-8")]);
    let info_text = String::from_utf8_lossy(&info.stdout);
    assert!(!info_text.contains("/wrist_light/"), "{info_text}");
}

/// A seeded bay (a seeded-sites tasks trial) where the arm flips elbow and wrist between the
/// look at the wire and the pre-approach: every fixed detour swings the held 2 m rod into
/// the wire or the cabinet, and the path searched around them hangs the rod.
#[test]
fn where_every_fixed_detour_crosses_the_wire_a_searched_path_hangs_the_rod() {
    let dir = tempfile::tempdir().expect("tmp");
    let scenario = dir.path().join("bay.toml");
    std::fs::write(
        &scenario,
        "name = \"hang-seeded-flip\"\nseed = 5707052935938151362\nduration_s = 200.0\n\
         hour = 8.6\ntask = \"hang\"\n\n[wind]\nmean_mps = 1.3\n\n[site]\nlayout = \"seeded\"\n\n\
         [camera]\nscale = 0.5\n\n[parameters]\ntask.self_maintenance = false\n",
    )
    .expect("scenario");
    let (scenario, site, rec) = (
        scenario.to_str().expect("utf-8"),
        dir.path().join("site.toml"),
        dir.path().join("flip.mcap"),
    );
    let survey = rodlog(&["survey", scenario, "--out", site.to_str().expect("utf-8")]);
    assert!(
        survey.status.success(),
        "{}",
        String::from_utf8_lossy(&survey.stderr)
    );
    let run = rodlog(&[
        "record",
        "--scenario",
        scenario,
        "--site",
        site.to_str().expect("utf-8"),
        "--out",
        rec.to_str().expect("utf-8"),
        "--until-done",
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let (ok, v) = judge(&rec);
    assert!(ok, "{v}");
    assert_eq!(v["success"], true, "{v}");
    assert_no_unsafe_command(&v);
    assert_replays_identically(&rec);
}
