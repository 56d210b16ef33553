//! Interop with the Python ROS 2 / MCAP ecosystem (ARCHITECTURE.md section 3):
//!
//! * a rodlog recording with one message on every topic is decoded by `mcap-ros2-support` and
//!   by `rosbags`, field by field, floats exactly (`scripts/interop/check_decode.py`);
//! * an MCAP written by Python's `mcap_ros2.writer` (zstd chunks) is read by rodlog with the
//!   values Python wrote (`scripts/interop/write_ros2.py`);
//! * `rerun mcap convert` recognises images, depth (32FC1, 16UC1), camera info and TF
//!   (`scripts/interop/check_rerun.py`).
//!
//! The Python tools come from the venv of `scripts/venv.sh`, found via `RODLOG_REF_VENV`
//! (default `<repo>/.venv-ref`). Without it these tests print a notice and pass, unless
//! `RODLOG_NO_SKIP=1` (set by `scripts/interop/run.sh`, i.e. CI), where they fail.

#[path = "support/fixture.rs"]
mod fixture;

#[path = "support/reference_venv.rs"]
mod reference_venv;
use std::path::{Path, PathBuf};
use std::process::Command;

use replay::{McapReader, ReadFilter};
use serde_json::Value;

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn python(venv: &Path, script: &str, args: &[&Path]) -> String {
    let out = Command::new(venv.join("bin/python"))
        .arg(repo().join("scripts/interop").join(script))
        .args(args)
        .output()
        .expect("run python");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success(),
        "{script} failed ({}):\n{stdout}\n{stderr}",
        out.status
    );
    println!("{stdout}");
    stdout
}

#[test]
fn rodlog_recording_of_every_topic_decodes_identically_in_mcap_ros2_and_rosbags() {
    let Some(venv) = reference_venv::venv_dir("interop test") else {
        return;
    };
    let dir = tempfile::tempdir().expect("tmp");
    fixture::write_all(dir.path()).expect("fixture");
    let out = python(
        &venv,
        "check_decode.py",
        &[
            &dir.path().join("all_topics.mcap"),
            &dir.path().join("all_topics.expected.json"),
        ],
    );
    let topics = msgs::topics::registry().len();
    assert!(
        out.contains(&format!("on {topics} topics")),
        "every registry topic checked: {out}"
    );
}

/// Compares JSON values, floats exactly, and names the first differing path.
fn compare(path: &str, want: &Value, got: &Value, errors: &mut Vec<String>) {
    match (want, got) {
        (Value::Object(w), Value::Object(g)) => {
            let (mut wk, mut gk): (Vec<_>, Vec<_>) = (w.keys().collect(), g.keys().collect());
            wk.sort();
            gk.sort();
            if wk != gk {
                errors.push(format!("{path}: fields {wk:?} != {gk:?}"));
            }
            for (k, wv) in w {
                if let Some(gv) = g.get(k) {
                    compare(&format!("{path}.{k}"), wv, gv, errors);
                }
            }
        }
        (Value::Array(w), Value::Array(g)) if w.len() == g.len() => {
            for (i, (wv, gv)) in w.iter().zip(g).enumerate() {
                compare(&format!("{path}[{i}]"), wv, gv, errors);
            }
        }
        (Value::Number(w), Value::Number(g)) => {
            if w.as_f64() != g.as_f64() || w.as_i64() != g.as_i64() && w.is_i64() && g.is_i64() {
                errors.push(format!("{path}: {w} != {g}"));
            }
        }
        _ if want == got => {}
        _ => errors.push(format!("{path}: {want} != {got}")),
    }
}

#[test]
fn python_mcap_ros2_writer_output_is_read_with_the_values_written() {
    let Some(venv) = reference_venv::venv_dir("interop test") else {
        return;
    };
    let dir = tempfile::tempdir().expect("tmp");
    let (rec, json) = (dir.path().join("py.mcap"), dir.path().join("py.json"));
    python(&venv, "write_ros2.py", &[&rec, &json]);
    let expected: Vec<Value> =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("json")).expect("parse");
    let mut reader = McapReader::open(&rec).expect("open");
    assert_eq!(reader.header().profile, "ros2");
    assert!(
        reader.chunks().iter().all(|c| c.compression == "zstd"),
        "{:?}",
        reader.chunks()
    );
    let messages = reader.read_all(&ReadFilter::all()).expect("read");
    assert_eq!(messages.len(), expected.len());
    let mut errors = Vec::new();
    for (m, want) in messages.iter().zip(&expected) {
        assert_eq!(m.topic(), want["topic"]);
        assert_eq!(m.schema_name(), want["type"]);
        assert_eq!(Some(m.log_time_ns), want["log_time_ns"].as_u64());
        assert_eq!(Some(m.publish_time_ns), want["publish_time_ns"].as_u64());
        assert_eq!(Some(u64::from(m.sequence)), want["sequence"].as_u64());
        assert_eq!(
            m.producer(),
            None,
            "foreign channels have no producer (they are inputs)"
        );
        let msg = m.decode().unwrap_or_else(|e| panic!("{}: {e}", m.topic()));
        let got = fixture::fields(&msg).expect("fields");
        compare(m.topic(), &want["fields"], &got, &mut errors);
    }
    assert!(errors.is_empty(), "{errors:#?}");
}

#[test]
fn rerun_recognises_images_depth_camera_info_and_tf() {
    let Some(venv) = reference_venv::venv_dir("interop test") else {
        return;
    };
    let dir = tempfile::tempdir().expect("tmp");
    fixture::write_all(dir.path()).expect("fixture");
    let rerun = venv.join("bin/rerun");
    python(
        &venv,
        "check_rerun.py",
        &[&rerun, &dir.path().join("rerun.mcap"), Path::new("2")],
    );
}
