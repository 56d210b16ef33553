//! End to end: the `perceive-wire` scenario through the simulator at low
//! resolution: the `perceive` stage fixes the wire on a panoramic frame, plans and commands
//! the wrist look motion, captures, and answers (pose or refusal); `replay --check`
//! reproduces every stage output; `check motion` passes on the run and fails on a recording
//! whose command breaks the limits.

#[path = "support/cli.rs"]
mod cli;
use cli::rodlog;

use std::path::Path;

fn scenario() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("recordings/scenarios/perceive-wire.toml")
        .display()
        .to_string()
}

#[test]
fn perceive_wire_records_replays_identically_and_its_motion_passes_the_checker() {
    let dir = tempfile::tempdir().expect("temp dir");
    let rec = dir.path().join("perceive.mcap");
    let rec_s = rec.to_str().expect("utf-8 path");
    let out = rodlog(&[
        "record",
        "--scenario",
        &scenario(),
        "--set",
        "camera.scale=0.25",
        "--set",
        "panoramic.scale=0.5",
        "--out",
        rec_s,
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let info = rodlog(&["info", rec_s]);
    let text = String::from_utf8_lossy(&info.stdout);
    for topic in [
        "/arm/joint_trajectory",
        "/arm/planned_path",
        "/camera/trigger",
        "/perception/roi_cloud",
    ] {
        assert!(
            text.lines()
                .any(|l| l.contains(topic) && l.contains("producer=perceive")),
            "{topic} from perceive missing:\n{text}"
        );
    }
    let check = rodlog(&["replay", rec_s, "--check"]);
    assert!(
        check.status.success(),
        "{}{}",
        String::from_utf8_lossy(&check.stdout),
        String::from_utf8_lossy(&check.stderr)
    );
    let motion = rodlog(&["check", "motion", rec_s, "--json"]);
    let json = String::from_utf8_lossy(&motion.stdout);
    assert!(
        motion.status.success(),
        "{json}{}",
        String::from_utf8_lossy(&motion.stderr)
    );
    assert!(json.contains("\"passed\":true"), "{json}");

    // The same run with the look motion commanded too fast is caught: a `joints` command
    // with a 0.05 s duration for a large move (the script stage passes the time through).
    let fast = dir.path().join("fast.toml");
    let text = std::fs::read_to_string(scenario()).expect("scenario");
    std::fs::write(
        &fast,
        format!(
            "{}\n[[command]]\nt_s = 2.0\nkind = \"joints\"\nvalues = [1.0, 0.3, 1.6, 0.2, 1.4, 0.0]\nduration_s = 0.05\n",
            text.replace("duration_s = 60.0", "duration_s = 4.0")
        ),
    )
    .expect("write");
    let rec2 = dir.path().join("fast.mcap");
    let rec2_s = rec2.to_str().expect("utf-8 path");
    let out = rodlog(&[
        "record",
        "--scenario",
        fast.to_str().expect("utf-8"),
        "--set",
        "camera.scale=0.25",
        "--out",
        rec2_s,
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let motion = rodlog(&["check", "motion", rec2_s]);
    let text = String::from_utf8_lossy(&motion.stdout);
    assert!(
        !motion.status.success(),
        "a too fast command passed:\n{text}"
    );
    assert!(text.contains("needs"), "{text}");
}
