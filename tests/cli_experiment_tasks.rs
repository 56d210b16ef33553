//! `rodlog experiment tasks|maintenance` smoke runs: one trial each, judged
//! against the simulator's truth, write report.md, results.json (every run, seeds) and the
//! plots. The full experiments run outside CI (README).

use std::path::Path;
use std::process::Command;

fn run_experiment(name: &str, out: &Path) -> serde_json::Value {
    let out_s = out.display().to_string();
    let run = Command::new(env!("CARGO_BIN_EXE_rodlog"))
        .args(["experiment", name, "--trials", "1", "--out", &out_s])
        .output()
        .expect("run rodlog");
    assert!(
        run.status.success(),
        "{name}: {}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert!(out.join("report.md").is_file());
    let results: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).expect("json"))
            .expect("results.json parses");
    assert_eq!(results["experiment"], name);
    results
}

#[test]
fn task_experiments_smoke_runs() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let tasks = run_experiment("tasks", &tmp.path().join("tasks"));
    // One seed: hang and remove, each with and without self-calibration.
    let runs = tasks["sections"]["runs"].as_array().expect("runs");
    assert_eq!(runs.len(), 4, "{tasks}");
    assert!(runs.iter().all(|r| r["outcome"].is_string()), "{tasks}");
    assert_eq!(tasks["sections"]["unsafe_commands"], 0, "{tasks}");
    for stem in ["success", "time"] {
        let p = tmp.path().join("tasks/plots").join(format!("{stem}.png"));
        assert!(p.is_file(), "{} missing", p.display());
    }

    let maintenance = run_experiment("maintenance", &tmp.path().join("maintenance"));
    let bins = maintenance["sections"]["bins"].as_array().expect("bins");
    assert_eq!(bins.len(), 13, "{maintenance}");
    assert!(bins.iter().all(|b| b["runs"] == 1), "{maintenance}");
    // The robot's reference run (unbumped, another day) found its mount consistent, and
    // every bin's check compares with the reference it left.
    assert!(
        bins.iter().all(|b| b["from_reference"] == 1),
        "{maintenance}"
    );
    assert_eq!(
        maintenance["sections"]["references"][0][2], true,
        "{maintenance}"
    );
    let unbumped = bins.iter().find(|b| b["bin"] == "none").expect("bin");
    assert_eq!(unbumped["consistent"], 1, "{maintenance}");
    // A 3 deg + 10 mm knock is never missed.
    let big = bins
        .iter()
        .find(|b| b["bin"] == "3 deg + 10 mm")
        .expect("bin");
    assert_eq!(big["drifted"], 1, "{maintenance}");
}

/// results.json without wall times (kept per shard) and the shard list.
fn without_timing(path: &Path) -> serde_json::Value {
    fn strip(v: &mut serde_json::Value) {
        match v {
            serde_json::Value::Object(m) => {
                m.retain(|k, _| !(k.contains("wall_s") || k == "shards"));
                m.values_mut().for_each(strip);
            }
            serde_json::Value::Array(a) => a.iter_mut().for_each(strip),
            _ => {}
        }
    }
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(path).expect("results.json")).expect("json");
    strip(&mut v);
    v
}

#[test]
fn tasks_split_in_two_and_merged_equals_one_run() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let dir = |s: &str| tmp.path().join(s).display().to_string();
    let run = |args: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_rodlog"))
            .args(args)
            .output()
            .expect("run rodlog");
        assert!(
            out.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    };
    let whole = dir("whole");
    run(&["experiment", "tasks", "--trials", "1", "--out", &whole]);
    for k in ["0/2", "1/2"] {
        let d = dir(&format!("s{}", &k[..1]));
        run(&[
            "experiment",
            "tasks",
            "--trials",
            "1",
            "--shard",
            k,
            "--out",
            &d,
        ]);
    }
    run(&[
        "experiment",
        "merge",
        "--out",
        &dir("merged"),
        &dir("s0"),
        &dir("s1"),
    ]);
    assert_eq!(
        without_timing(&tmp.path().join("whole/results.json")),
        without_timing(&tmp.path().join("merged/results.json"))
    );
}

/// `experiment wind --speeds` and `experiment light --hours` run only the listed conditions;
/// a listed value of the experiment's own list keeps its trials (seeds); a flag for the other
/// experiment, a value out of range or given twice is refused before anything runs.
#[test]
fn wind_speeds_and_light_hours_choose_the_conditions() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let run = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_rodlog"))
            .args(args)
            .output()
            .expect("run rodlog")
    };
    let out = tmp.path().join("wind");
    let out_s = out.display().to_string();
    let ok = run(&[
        "experiment",
        "wind",
        "--speeds",
        "3.0",
        "--trials",
        "1",
        "--out",
        &out_s,
    ]);
    assert!(
        ok.status.success(),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
    let results: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).expect("json"))
            .expect("results.json parses");
    assert_eq!(
        results["parameters"]["speeds_mps"],
        serde_json::json!([3.0]),
        "{results}"
    );
    let groups = results["sections"]["groups"].as_array().expect("groups");
    assert_eq!(groups.len(), 1, "{results}");
    assert_eq!(results["sections"]["unsafe_commands"], 0, "{results}");
    // 3.0 m/s is the 7th speed of the own list: the same seed as a run without --speeds.
    let own_seed = results["seeds"][0].as_u64().expect("seed");
    assert_eq!(results["seeds"].as_array().map(Vec::len), Some(1));
    // (The experiments' rule: world seed = key(--seed, 200 + index of the speed, trial)
    // with the sign bit cleared.)
    let expected = sim::rng::key(1, 200 + 6, 0) & (i64::MAX as u64);
    assert_eq!(own_seed, expected);
    for (args, needle) in [
        (
            vec!["experiment", "light", "--speeds", "1"],
            "--speeds is an option of `rodlog experiment wind` only",
        ),
        (
            vec!["experiment", "wind", "--hours", "18"],
            "--hours is an option of `rodlog experiment light` only",
        ),
        (
            vec!["experiment", "light", "--hours", "25"],
            "--hours: 25 is outside [0, 24]",
        ),
        (
            vec!["experiment", "wind", "--speeds", "2,2"],
            "--speeds: 2 is given twice",
        ),
        (
            vec!["experiment", "wind", "--with", "image-motion"],
            "--with/--without are options of the calibration experiments",
        ),
        (
            vec!["experiment", "noise", "--without", "image-moton"],
            "unknown step \"image-moton\"",
        ),
    ] {
        let bad = run(&args);
        let err = String::from_utf8_lossy(&bad.stderr);
        assert!(
            !bad.status.success() && err.contains(needle),
            "{args:?}: {err}"
        );
    }
}

/// `--sites seeded`: each trial's bay is drawn from its seed and the robot gets the
/// simulated crew's survey; the results say so, the hang and the remove succeed with no
/// unsafe command, and the calibration experiments refuse the option.
#[test]
fn task_experiments_run_on_seeded_sites_with_a_survey() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let out = tmp.path().join("tasks");
    let out_s = out.display().to_string();
    let run = Command::new(env!("CARGO_BIN_EXE_rodlog"))
        .args([
            "experiment",
            "tasks",
            "--trials",
            "1",
            "--sites",
            "seeded",
            "--out",
            &out_s,
        ])
        .output()
        .expect("run rodlog");
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let results: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).expect("json"))
            .expect("results.json parses");
    assert_eq!(
        results["parameters"]["sites"], "seeded, with a survey",
        "{results}"
    );
    let runs = results["sections"]["runs"].as_array().expect("runs");
    assert_eq!(runs.len(), 4, "{results}");
    // No run sends an unsafe command, and with the self-maintenance on the hang and the
    // remove (which measures the empty rack the survey places to a few cm) succeed.
    assert_eq!(results["sections"]["unsafe_commands"], 0, "{results}");
    for task in ["hang", "remove"] {
        assert!(
            runs.iter().any(|r| r["task"] == task
                && r["self_calibration"] == true
                && r["success"] == true),
            "{task}: {results}"
        );
    }
    let bad = Command::new(env!("CARGO_BIN_EXE_rodlog"))
        .args(["experiment", "noise", "--sites", "seeded", "--out", &out_s])
        .output()
        .expect("run rodlog");
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(
        !bad.status.success() && err.contains("--sites is an option of the task experiments"),
        "{err}"
    );
}
