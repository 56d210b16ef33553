//! End-to-end determinism of `rodlog record` and `rodlog replay`, through the built
//! binary: same scenario twice -> same bytes; 1 vs 2 worker threads -> same bytes; realtime
//! -> same bytes as fast; `replay --check` passes on fresh and committed recordings and fails,
//! naming topic, log_time and field, when a stage parameter changes; a SIGKILLed recording
//! keeps everything up to its last flush; `--check` with nothing to compare fails.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

use replay::{McapReader, ReadFilter};

type TestResult = Result<(), Box<dyn std::error::Error>>;

fn rodlog(dir: &Path, args: &[&str]) -> Result<Output, std::io::Error> {
    Command::new(env!("CARGO_BIN_EXE_rodlog"))
        .current_dir(dir)
        .args(args)
        .output()
}

fn ok(dir: &Path, args: &[&str]) -> Result<String, Box<dyn std::error::Error>> {
    let out = rodlog(dir, args)?;
    if !out.status.success() {
        return Err(format!(
            "rodlog {args:?} failed: {}\n{}",
            String::from_utf8_lossy(&out.stderr),
            String::from_utf8_lossy(&out.stdout)
        )
        .into());
    }
    Ok(String::from_utf8(out.stdout)?)
}

fn record(dir: &Path, name: &str, extra: &[&str]) -> Result<PathBuf, Box<dyn std::error::Error>> {
    let mut args = vec!["record", "--scenario", "arm_sweep", "--out", name];
    args.extend_from_slice(extra);
    ok(dir, &args)?;
    Ok(dir.join(name))
}

/// (topic, producer, log_time, cdr) of one message.
type Stored = (String, String, u64, Vec<u8>);

/// Every message, in log-time order.
fn messages(path: &Path) -> Result<Vec<Stored>, Box<dyn std::error::Error>> {
    let mut reader = McapReader::open(path)?;
    Ok(reader
        .read_all(&ReadFilter::all())?
        .into_iter()
        .map(|m| {
            (
                m.topic().to_owned(),
                m.producer().unwrap_or_default().to_owned(),
                m.log_time_ns,
                m.data,
            )
        })
        .collect())
}

#[test]
fn same_scenario_twice_and_any_thread_count_give_identical_bytes() -> TestResult {
    let dir = tempfile::tempdir()?;
    let a = record(dir.path(), "a.mcap", &["--duration", "6"])?;
    let b = record(dir.path(), "b.mcap", &["--duration", "6"])?;
    let t1 = record(
        dir.path(),
        "t1.mcap",
        &["--duration", "6", "--threads", "1"],
    )?;
    let t2 = record(
        dir.path(),
        "t2.mcap",
        &["--duration", "6", "--threads", "2"],
    )?;
    let a = std::fs::read(a)?;
    assert!(a.len() > 10_000, "recording is {} bytes", a.len());
    assert!(
        a == std::fs::read(b)?,
        "two recordings of the same scenario differ"
    );
    assert!(
        a == std::fs::read(t1)?,
        "--threads 1 differs from the default"
    );
    assert!(
        a == std::fs::read(t2)?,
        "--threads 2 differs from --threads 1"
    );
    // Another seed changes the sensor data, so the file: the comparison above can fail.
    let s = record(dir.path(), "s.mcap", &["--duration", "6", "--seed", "8"])?;
    assert!(a != std::fs::read(s)?);
    Ok(())
}

#[test]
fn realtime_recording_equals_the_fast_one() -> TestResult {
    let dir = tempfile::tempdir()?;
    let fast = record(dir.path(), "fast.mcap", &["--duration", "2"])?;
    let start = Instant::now();
    let live = record(dir.path(), "live.mcap", &["--duration", "2", "--realtime"])?;
    assert!(
        start.elapsed() >= Duration::from_millis(1900),
        "--realtime did not pace"
    );
    assert!(std::fs::read(fast)? == std::fs::read(live)?);
    Ok(())
}

#[test]
fn check_passes_on_a_fresh_recording_and_what_if_output() -> TestResult {
    let dir = tempfile::tempdir()?;
    record(dir.path(), "rec.mcap", &[])?;
    let out = ok(dir.path(), &["replay", "rec.mcap", "--check"])?;
    assert!(out.contains("check passed: 1210 outputs compared"), "{out}");

    // What-if: new parameter, outputs beside the recorded inputs, open-loop labelling.
    let out = ok(
        dir.path(),
        &[
            "replay",
            "rec.mcap",
            "--set",
            "arm_exerciser.amplitude_rad=0.5",
            "--out",
            "w.mcap",
        ],
    )?;
    assert!(
        out.contains("changed parameters: arm_exerciser.amplitude_rad=0.5"),
        "{out}"
    );
    assert!(out.contains("open-loop from 0.510000000 s"), "{out}");
    let reader = McapReader::open(dir.path().join("w.mcap"))?;
    let whatif = reader.metadata_named("whatif").ok_or("no whatif record")?;
    assert_eq!(
        whatif.entries.get("open_loop_from_ns").map(String::as_str),
        Some("510000000")
    );
    assert_eq!(
        whatif
            .entries
            .get("first_divergent_command_topic")
            .map(String::as_str),
        Some("/arm/joint_trajectory")
    );
    // The what-if file carries its parameters, so it checks against itself.
    let out = ok(dir.path(), &["replay", "w.mcap", "--check"])?;
    assert!(out.contains("check passed"), "{out}");
    // ... and its inputs are the recorded ones.
    let inputs = |p: &Path| -> Result<Vec<_>, Box<dyn std::error::Error>> {
        Ok(messages(p)?
            .into_iter()
            .filter(|m| {
                ["scheduler", "arm_driver", "lift_driver", "anemometer"].contains(&m.1.as_str())
            })
            .collect())
    };
    assert_eq!(
        inputs(&dir.path().join("rec.mcap"))?,
        inputs(&dir.path().join("w.mcap"))?
    );
    Ok(())
}

#[test]
fn changed_stage_parameter_makes_check_fail_naming_the_divergence() -> TestResult {
    let dir = tempfile::tempdir()?;
    record(dir.path(), "rec.mcap", &["--duration", "4"])?;
    let out = rodlog(
        dir.path(),
        &[
            "replay",
            "rec.mcap",
            "--check",
            "--set",
            "arm_exerciser.amplitude_rad=0.5",
        ],
    )?;
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8(out.stderr)?;
    assert!(err.contains("/arm/joint_trajectory"), "{err}");
    assert!(err.contains("log_time 0.510000000 s"), "{err}");
    assert!(
        err.contains("points[0].positions[1]: 0.8781349112503158 != 0.7817790927085965"),
        "{err}"
    );

    // A latency change moves log times of every /tf.
    let out = rodlog(
        dir.path(),
        &[
            "replay",
            "rec.mcap",
            "--check",
            "--set",
            "robot_state.latency_ms=2",
        ],
    )?;
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8(out.stderr)?;
    assert!(
        err.contains("/robot_description (producer robot_state) at log_time 0.001000000 s"),
        "{err}"
    );
    assert!(err.contains("log_time: 1000000 != 2000000 ns"), "{err}");
    Ok(())
}

#[test]
fn check_with_nothing_to_compare_fails() -> TestResult {
    let dir = tempfile::tempdir()?;
    record(dir.path(), "rec.mcap", &["--duration", "2"])?;
    // Only a topic no stage writes.
    let out = rodlog(
        dir.path(),
        &["replay", "rec.mcap", "--check", "--topics", "/env/wind"],
    )?;
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8(out.stderr)?.contains("nothing to compare"));
    // A window before any output.
    let out = rodlog(
        dir.path(),
        &["replay", "rec.mcap", "--check", "--end", "0.0005"],
    )?;
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8(out.stderr)?.contains("nothing to compare"));
    Ok(())
}

#[test]
fn committed_recording_replays_identically() -> TestResult {
    let rec = Path::new(env!("CARGO_MANIFEST_DIR")).join("recordings/arm_sweep.mcap");
    assert!(
        std::fs::metadata(&rec)?.len() <= 5 * 1024 * 1024,
        "committed recordings must stay <= 5 MB"
    );
    let out = ok(
        Path::new(env!("CARGO_MANIFEST_DIR")),
        &["replay", "recordings/arm_sweep.mcap", "--check"],
    )?;
    assert!(out.contains("check passed"), "{out}");
    Ok(())
}

#[test]
fn sigkilled_recording_keeps_everything_up_to_its_last_flush() -> TestResult {
    let dir = tempfile::tempdir()?;
    let full = record(dir.path(), "full.mcap", &[])?;
    let mut child = Command::new(env!("CARGO_BIN_EXE_rodlog"))
        .current_dir(dir.path())
        .args([
            "record",
            "--scenario",
            "arm_sweep",
            "--out",
            "killed.mcap",
            "--realtime",
        ])
        .stdout(std::process::Stdio::null())
        .spawn()?;
    let start = Instant::now();
    std::thread::sleep(Duration::from_millis(2300));
    child.kill()?; // SIGKILL on Unix
    // Robot time starts after the process does, so this overestimates the loss slightly.
    let killed_after = start.elapsed().as_secs_f64();
    child.wait()?;

    let killed = messages(&dir.path().join("killed.mcap"))?;
    let last_ns = killed.last().map_or(0, |m| m.2);
    let lost_s = killed_after - last_ns as f64 * 1e-9;
    assert!(last_ns >= 900_000_000, "only {last_ns} ns recovered");
    assert!(
        lost_s <= 1.3,
        "{lost_s} s of robot time lost (killed after {killed_after} s)"
    );
    // What survived is exactly the start of the complete recording.
    let full = messages(&full)?;
    let prefix: Vec<_> = full.into_iter().filter(|m| m.2 <= last_ns).collect();
    assert_eq!(killed.len(), prefix.len());
    assert!(
        killed == prefix,
        "recovered messages differ from the complete run"
    );
    // And it replays.
    let out = ok(dir.path(), &["replay", "killed.mcap", "--check"])?;
    assert!(out.contains("recording was not finished"), "{out}");
    assert!(out.contains("check passed"), "{out}");
    Ok(())
}

#[test]
fn ctrl_c_finishes_a_realtime_recording() -> TestResult {
    let dir = tempfile::tempdir()?;
    let child = Command::new(env!("CARGO_BIN_EXE_rodlog"))
        .current_dir(dir.path())
        .args([
            "record",
            "--scenario",
            "arm_sweep",
            "--out",
            "int.mcap",
            "--realtime",
        ])
        .stdout(std::process::Stdio::piped())
        .spawn()?;
    std::thread::sleep(Duration::from_millis(1500));
    let status = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()?;
    assert!(status.success());
    let out = child.wait_with_output()?;
    assert!(out.status.success(), "exit {:?}", out.status);
    assert!(String::from_utf8(out.stdout)?.contains("(interrupted)"));
    let reader = McapReader::open(dir.path().join("int.mcap"))?;
    assert!(
        reader.recovery().is_none(),
        "interrupted file was not finished"
    );
    assert_eq!(reader.index_source(), replay::IndexSource::Summary);
    let out = ok(dir.path(), &["replay", "int.mcap", "--check"])?;
    assert!(out.contains("check passed"), "{out}");
    Ok(())
}

#[test]
fn closed_loop_what_if_re_records_from_the_recordings_metadata() -> TestResult {
    let dir = tempfile::tempdir()?;
    let rec = record(dir.path(), "rec.mcap", &["--duration", "3"])?;
    // Same scenario, seed and parameters from the metadata: the same bytes.
    ok(
        dir.path(),
        &["record", "--scenario", "rec.mcap", "--out", "again.mcap"],
    )?;
    assert!(std::fs::read(&rec)? == std::fs::read(dir.path().join("again.mcap"))?);
    // Changed parameter: the world sees the new commands (closed loop), and the new
    // recording checks against itself.
    ok(
        dir.path(),
        &[
            "record",
            "--scenario",
            "rec.mcap",
            "--set",
            "arm_exerciser.amplitude_rad=0.3",
            "--out",
            "cl.mcap",
        ],
    )?;
    let out = ok(dir.path(), &["replay", "cl.mcap", "--check"])?;
    assert!(out.contains("check passed"), "{out}");
    let arm = |p: &Path| -> Result<Vec<Stored>, Box<dyn std::error::Error>> {
        Ok(messages(p)?
            .into_iter()
            .filter(|m| m.1 == "arm_driver")
            .collect())
    };
    assert_ne!(arm(&rec)?, arm(&dir.path().join("cl.mcap"))?);
    Ok(())
}

#[test]
fn replay_checks_a_folder_of_recordings_and_its_shards() -> TestResult {
    let dir = tempfile::tempdir()?;
    let fleet = dir.path().join("fleet");
    std::fs::create_dir_all(&fleet)?;
    let committed = Path::new(env!("CARGO_MANIFEST_DIR")).join("recordings/arm_sweep.mcap");
    for name in ["a.mcap", "b.mcap", "c.mcap"] {
        std::fs::copy(&committed, fleet.join(name))?;
    }
    let out = ok(dir.path(), &["replay", "fleet", "--check"])?;
    assert!(out.contains("all 3 recordings passed"), "{out}");
    // The two shards of 2 replay every recording exactly once between them.
    let mut seen = Vec::new();
    for shard in ["0/2", "1/2"] {
        let out = ok(
            dir.path(),
            &["replay", "fleet", "--check", "--shard", shard],
        )?;
        for name in ["a.mcap", "b.mcap", "c.mcap"] {
            if out.contains(name) {
                seen.push(name);
            }
        }
    }
    seen.sort_unstable();
    assert_eq!(seen, ["a.mcap", "b.mcap", "c.mcap"]);
    // An unreadable recording fails, the others still run.
    std::fs::write(fleet.join("d.mcap"), b"not an mcap")?;
    let r = rodlog(dir.path(), &["replay", "fleet", "--check"])?;
    assert_eq!(r.status.code(), Some(1));
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(
        err.contains("1 of 4 recordings failed") && err.contains("d.mcap"),
        "{err}"
    );
    Ok(())
}
