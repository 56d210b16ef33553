//! The simulator as the default world, end to end through the CLI: `record --scenario
//! sim-smoke` (every simulated driver, low resolution, a camera-mount bump) is byte-identical
//! run to run and for 1 or 2 worker threads, `replay --check` reproduces every stage output,
//! and `--set` reaches the world (a changed world changes the bytes) or is refused by name.

#[path = "support/cli.rs"]
mod cli;
use cli::rodlog;

use std::path::Path;

fn record(out: &Path, extra: &[&str]) {
    let out_s = out.display().to_string();
    let mut args = vec!["record", "--scenario", "sim-smoke", "--out", out_s.as_str()];
    args.extend_from_slice(extra);
    let run = rodlog(&args);
    assert!(
        run.status.success(),
        "record failed: {}",
        String::from_utf8_lossy(&run.stderr)
    );
}

#[test]
fn sim_recordings_are_deterministic_and_replay_identically() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let a = tmp.path().join("a.mcap");
    let b = tmp.path().join("b.mcap");
    let one = tmp.path().join("one_thread.mcap");
    let two = tmp.path().join("two_threads.mcap");
    record(&a, &[]);
    record(&b, &[]);
    record(&one, &["--threads", "1"]);
    record(&two, &["--threads", "2"]);
    let bytes = |p: &Path| std::fs::read(p).expect("read recording");
    assert!(
        bytes(&a) == bytes(&b),
        "same scenario and seed must give the same bytes"
    );
    assert!(
        bytes(&one) == bytes(&two),
        "1 and 2 worker threads must give the same bytes"
    );

    let check = rodlog(&["replay", &a.display().to_string(), "--check"]);
    let stdout = String::from_utf8_lossy(&check.stdout);
    assert!(
        check.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&check.stderr)
    );
    assert!(stdout.contains("all identical"), "{stdout}");

    // A world parameter changes the world: another seed or no arm perturbation differs.
    let other = tmp.path().join("other.mcap");
    record(&other, &["--set", "robot.perturbation=false"]);
    assert!(
        bytes(&other) != bytes(&a),
        "--set robot.perturbation=false must reach the world"
    );
}

#[test]
fn unknown_world_keys_are_refused_by_name() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let out = tmp.path().join("x.mcap").display().to_string();
    let run = rodlog(&[
        "record",
        "--scenario",
        "sim-smoke",
        "--set",
        "robot.bogus=1",
        "--out",
        &out,
    ]);
    assert!(!run.status.success());
    assert!(String::from_utf8_lossy(&run.stderr).contains("robot.bogus"));
}
