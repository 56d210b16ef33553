//! Sharded experiments: `--shard K/N` runs a deterministic slice of the items, and
//! `rodlog experiment merge` recomputes every table from the shards' records, so the merged
//! results.json equals one unsharded run's, timing fields aside; shards of other arguments
//! are refused.

use std::path::Path;
use std::process::{Command, Output};

fn rodlog(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_rodlog"))
        .args(args)
        .output()
        .expect("run rodlog")
}

fn ok(args: &[&str]) {
    let out = rodlog(args);
    assert!(
        out.status.success(),
        "rodlog {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// results.json without the fields that are wall times (kept per shard) or name the shards.
fn without_timing(path: &Path) -> serde_json::Value {
    fn strip(v: &mut serde_json::Value) {
        match v {
            serde_json::Value::Object(m) => {
                m.retain(|k, _| !(k.contains("time_ms") || k.contains("wall_s") || k == "shards"));
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
fn matchers_split_in_two_and_merged_equals_one_run() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let dir = |s: &str| tmp.path().join(s).display().to_string();
    let common = ["--trials", "2", "--image-scale", "0.25", "--no-reference"];
    let run = |extra: &[&str]| {
        let mut args = vec!["experiment", "matchers"];
        args.extend_from_slice(&common);
        args.extend_from_slice(extra);
        ok(&args);
    };
    run(&["--out", &dir("whole")]);
    run(&["--shard", "0/2", "--out", &dir("s0")]);
    run(&["--shard", "1/2", "--out", &dir("s1")]);
    assert!(
        !tmp.path().join("s0/report.md").exists(),
        "a shard writes no report"
    );
    ok(&[
        "experiment",
        "merge",
        "--out",
        &dir("merged"),
        &dir("s0"),
        &dir("s1"),
    ]);
    let whole = without_timing(&tmp.path().join("whole/results.json"));
    let merged = without_timing(&tmp.path().join("merged/results.json"));
    assert_eq!(whole, merged);
    assert!(tmp.path().join("merged/report.md").is_file());
    let merged_raw: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(tmp.path().join("merged/results.json")).expect("read"),
    )
    .expect("json");
    assert_eq!(
        merged_raw["sections"]["shards"].as_array().map(Vec::len),
        Some(2)
    );
    // The pictures come with the shards.
    let pngs = std::fs::read_dir(tmp.path().join("merged/images"))
        .expect("images")
        .count();
    assert!(pngs > 0);

    // A shard of another seed, a missing shard, and a repeated one are refused.
    run(&["--shard", "1/2", "--seed", "9", "--out", &dir("other")]);
    let out = rodlog(&[
        "experiment",
        "merge",
        "--out",
        &dir("m2"),
        &dir("s0"),
        &dir("other"),
    ]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("different arguments"), "{err}");
    let out = rodlog(&["experiment", "merge", "--out", &dir("m3"), &dir("s0")]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("missing shards: 1/2"));
    let out = rodlog(&[
        "experiment",
        "matchers",
        "--shard",
        "2/2",
        "--out",
        &dir("bad"),
    ]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("expected K/N"));
}

/// The calibration experiments shard by trial (datasets: shecar is one more item), and their
/// merged tables equal one run's.
#[test]
fn calibration_experiments_split_in_two_and_merged_equal_one_run() {
    let tmp = tempfile::tempdir().expect("tempdir");
    for name in ["noise", "datasets"] {
        let dir = |s: &str| tmp.path().join(name).join(s).display().to_string();
        let common = ["--trials", "2", "--image-scale", "0.3", "--no-reference"];
        let run = |extra: &[&str]| {
            let mut args = vec!["experiment", name];
            args.extend_from_slice(&common);
            args.extend_from_slice(extra);
            ok(&args);
        };
        run(&["--out", &dir("whole")]);
        run(&["--shard", "0/2", "--out", &dir("s0")]);
        run(&["--shard", "1/2", "--out", &dir("s1")]);
        ok(&[
            "experiment",
            "merge",
            "--out",
            &dir("merged"),
            &dir("s0"),
            &dir("s1"),
        ]);
        let whole = without_timing(&tmp.path().join(name).join("whole/results.json"));
        let merged = without_timing(&tmp.path().join(name).join("merged/results.json"));
        assert_eq!(whole, merged, "{name}");
        assert_eq!(whole["seeds"].as_array().map(Vec::len), Some(2), "{name}");
    }
}
