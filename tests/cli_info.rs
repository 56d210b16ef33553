//! End-to-end tests of `rodlog info`: text and JSON output of an intact, a crashed and a
//! broken recording, and errors on stderr with a non-zero exit code.

#[path = "support/cli.rs"]
mod cli;
use cli::rodlog;

#[path = "support/fixture.rs"]
mod fixture;

use std::path::Path;

use recorder::ChunkCompression;
use serde_json::Value;

fn info_json(path: &Path) -> Value {
    let out = rodlog(&["info", path.to_str().expect("utf-8 path"), "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("one JSON object")
}

#[test]
fn info_describes_channels_time_chunks_metadata_and_compression() {
    let dir = tempfile::tempdir().expect("tmp");
    let path = dir.path().join("rec.mcap");
    let entries = fixture::all_topics().expect("fixture");
    fixture::write_mcap(&path, &entries, ChunkCompression::Zstd).expect("write");
    let v = info_json(&path);
    assert_eq!(v["profile"], "ros2");
    assert_eq!(v["messages"], entries.len());
    assert_eq!(v["channels"].as_array().map(Vec::len), Some(entries.len()));
    assert_eq!(v["start_ns"], 5_000_000_000_u64);
    assert_eq!(
        v["end_ns"],
        5_000_000_000_u64 + (entries.len() as u64 - 1) * 10_000_000
    );
    assert_eq!(v["recovered"], false);
    assert_eq!(v["index"], "summary");
    assert!(v["compression"]["zstd"]["chunks"].as_u64() >= Some(1));
    assert!(v["compressed_bytes"].as_u64() < v["uncompressed_bytes"].as_u64());
    let names: Vec<&str> = v["metadata"]
        .as_array()
        .expect("metadata")
        .iter()
        .filter_map(|m| m["name"].as_str())
        .collect();
    assert_eq!(names, ["robot_info", "scenario", "build"]);
    let image = v["channels"]
        .as_array()
        .expect("channels")
        .iter()
        .find(|c| c["topic"] == "/camera/color/image_raw")
        .expect("image channel");
    assert_eq!(image["type"], "sensor_msgs/msg/Image");
    assert_eq!(image["producer"], "camera");
    assert_eq!(image["count"], 1);
    let out = rodlog(&["info", path.to_str().expect("utf-8")]);
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    let messages = format!("messages:    {}", msgs::topics::registry().len());
    for needle in [
        "profile:     ros2",
        messages.as_str(),
        "zstd: [",
        "/camera/color/image_raw",
        "producer=camera",
        "robot_info, scenario, build",
        "recovered:   no",
    ] {
        assert!(text.contains(needle), "{needle:?} missing from:\n{text}");
    }
}

#[test]
fn info_reports_a_crashed_recording_as_recovered_with_the_loss() {
    let dir = tempfile::tempdir().expect("tmp");
    let path = dir.path().join("rec.mcap");
    fixture::write_mcap(&path, &fixture::rerun_set(), ChunkCompression::Lz4).expect("write");
    let bytes = std::fs::read(&path).expect("read");
    let cut = dir.path().join("cut.mcap");
    std::fs::write(&cut, &bytes[..bytes.len() - 100]).expect("write cut");
    let v = info_json(&cut);
    assert_eq!(v["recovered"], true);
    assert_eq!(v["index"], "scan");
    assert!(v["recovery"]["lost_bytes"].as_u64() > Some(0), "{v}");
    assert!(v["recovery"]["reason"].is_string(), "{v}");
    assert_eq!(
        v["messages"], 6,
        "the summary was cut, all data chunks survive"
    );
    let text = String::from_utf8_lossy(&rodlog(&["info", cut.to_str().expect("utf-8")]).stdout)
        .into_owned();
    assert!(
        text.contains("recovered:   yes") && text.contains("lost "),
        "{text}"
    );
}

#[test]
fn info_fails_clearly_on_missing_empty_and_foreign_files() {
    let dir = tempfile::tempdir().expect("tmp");
    let empty = dir.path().join("zero.mcap");
    std::fs::write(&empty, b"").expect("write");
    let garbage = dir.path().join("garbage.mcap");
    std::fs::write(&garbage, b"PK\x03\x04 not an mcap").expect("write");
    for (path, needle) in [
        (dir.path().join("missing.mcap"), "No such file"),
        (empty, "is empty"),
        (garbage, "not an MCAP file"),
    ] {
        let out = rodlog(&["info", path.to_str().expect("utf-8")]);
        assert!(!out.status.success(), "{}", path.display());
        assert!(out.stdout.is_empty());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.contains(needle) && err.contains("rodlog: error"),
            "{err}"
        );
        assert_eq!(err.matches(needle).count(), 1, "cause printed once: {err}");
    }
}
