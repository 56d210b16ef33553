//! Benchmark harness of `record --ros2`: a Cyclone DDS publisher (`cyclone_peer.py
//! bench-pub`, in the reference venv) sends 1280x1024 `rgb8` colour and `32FC1` depth at
//! 10 Hz and `JointState` at 100 Hz over loopback; this process records them exactly as
//! `rodlog record --ros2` does ([`compose::ros2::record::record`], the `ros2` scenario:
//! robot_state only) and measures, per topic: messages sent and recorded, lost, dropped and
//! late; latency from the publisher's write (`header.stamp`, wall clock) to the moment the
//! runtime hands the message to the stages, p50 and p99; and this process's CPU over the
//! run, as a fraction of one core.
//!
//! ```sh
//! RODLOG_REF_VENV=/path/to/.venv-ref cargo run --release -p compose --example ros2_record_bench -- [--duration 30] [--domain 61] [--reliability best-effort|reliable]
//! ```
//!
//! Not a test: the figures depend on the machine and its load (ros2/MEASUREMENT.md).
#![allow(clippy::unwrap_used, clippy::disallowed_methods)]

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{SystemTime, UNIX_EPOCH};

use compose::ros2::record::{Ros2RunOptions, record};
use msgs::{Msg, RobotTime};
use recorder::{LiveOutput, Popped, RecordOptions, SinkOptions};

/// Latencies (ms) of the inputs handed to the stages, per topic; the process CPU time and
/// the wall time at the first and the last one (the streaming window).
#[derive(Clone, Default)]
struct Probe(Arc<Mutex<ProbeData>>);

#[derive(Default)]
struct ProbeData {
    latency_ms: BTreeMap<String, Vec<f64>>,
    first: Option<(f64, std::time::Instant)>,
    last: Option<(f64, std::time::Instant)>,
}

impl LiveOutput for Probe {
    fn popped(&mut self, popped: &Popped, _now: RobotTime) {
        if popped.is_output() {
            return;
        }
        let stamp = match &popped.envelope.msg {
            Some(Msg::Image(i)) => i.header.stamp,
            Some(Msg::JointState(j)) => j.header.stamp,
            _ => return,
        };
        let sent_ns = i128::from(stamp.sec) * 1_000_000_000 + i128::from(stamp.nanosec);
        let now_ns = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos() as i128);
        let ms = (now_ns - sent_ns) as f64 / 1e6;
        if let Ok(mut d) = self.0.lock() {
            d.latency_ms
                .entry(popped.envelope.topic().to_owned())
                .or_default()
                .push(ms);
            let at = (cpu_s(), std::time::Instant::now());
            d.first.get_or_insert(at);
            d.last = Some(at);
        }
    }
}

fn cpu_s() -> f64 {
    // utime + stime of this process (fields 14 and 15 of /proc/self/stat), in clock ticks
    // of 1/100 s (USER_HZ on Linux).
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let after = stat.rsplit(')').next().unwrap_or_default();
    let f: Vec<&str> = after.split_whitespace().collect();
    let ticks = |i: usize| f.get(i).and_then(|v| v.parse::<f64>().ok()).unwrap_or(0.0);
    (ticks(11) + ticks(12)) / 100.0
}

fn percentile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let i = ((sorted.len() as f64 - 1.0) * q).round() as usize;
    sorted[i.min(sorted.len() - 1)]
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let arg = |name: &str, default: &str| {
        args.iter()
            .position(|a| a == name)
            .and_then(|i| args.get(i + 1).cloned())
            .unwrap_or_else(|| default.to_owned())
    };
    let duration: f64 = arg("--duration", "30").parse().unwrap();
    let domain: u16 = arg("--domain", "61").parse().unwrap();
    let reliability = arg("--reliability", "best-effort");
    let repo = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let venv =
        std::env::var_os("RODLOG_REF_VENV").map_or_else(|| repo.join(".venv-ref"), PathBuf::from);
    let python = venv.join("bin/python");
    let dir = std::env::temp_dir().join(format!("rodlog-ros2-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("bench.mcap");
    let peer_out = dir.join("peer.json");

    let mut scenario = compose::load_scenario("ros2").unwrap().0;
    scenario
        .set_from_arg(&format!("ros2.domain_id={domain}"))
        .unwrap();
    scenario
        .set_from_arg("ros2.discovery=\"localhost\"")
        .unwrap();
    scenario.set_from_arg("ros2.use_sim_time=\"off\"").unwrap();
    scenario.duration = msgs::RobotDuration::from_secs_f64(duration + 6.0).unwrap();
    let plan = compose::Plan::new(&scenario).unwrap();

    let peer = Command::new(&python)
        .arg(repo.join("scripts/dds/cyclone_peer.py"))
        .args([
            "bench-pub",
            "--domain",
            &domain.to_string(),
            "--width",
            "1280",
            "--height",
            "1024",
            "--rate",
            "10",
            "--js-rate",
            "100",
            "--duration",
            &duration.to_string(),
            "--readers",
            "1",
            "--reliability",
            &reliability,
            "--out",
        ])
        .arg(&peer_out)
        .env_remove("CYCLONEDDS_URI")
        .stdout(Stdio::null())
        .spawn()
        .expect("start cyclone_peer.py (RODLOG_REF_VENV)");

    let probe = Probe::default();
    let options = RecordOptions {
        out: out.clone(),
        sink: SinkOptions::default(),
        realtime: true,
        threads: None,
        stop: None,
    };
    let run = Ros2RunOptions {
        observer: Some(Box::new(probe.clone())),
        ..Ros2RunOptions::default()
    };
    let summary = record(&plan, &options, run, Vec::new()).expect("record");
    let status = peer.wait_with_output().expect("peer").status;
    assert!(status.success(), "peer failed");
    let peer: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&peer_out).unwrap()).unwrap();

    println!(
        "record --ros2 bench: {duration} s of 1280x1024 rgb8 + 32FC1 at 10 Hz and JointState at 100 Hz, Cyclone publisher ({reliability}), loopback"
    );
    println!(
        "| topic | sent | recorded | lost | dropped | late | latency p50 / p99 ms (publish to stage input) |"
    );
    println!("|---|---|---|---|---|---|---|");
    let data = probe.0.lock().unwrap();
    let lat = data.latency_ms.clone();
    let (cpu, wall) = match (data.first, data.last) {
        (Some(a), Some(b)) => (b.0 - a.0, (b.1 - a.1).as_secs_f64()),
        _ => (f64::NAN, f64::NAN),
    };
    for topic in [
        "/camera/color/image_raw",
        "/camera/depth/image_raw",
        "/joint_states",
    ] {
        let sent = peer["topics"][topic]["sent"].as_u64().unwrap_or(0);
        let c = summary.live.inputs.get(topic).copied().unwrap_or_default();
        let mut l = lat.get(topic).cloned().unwrap_or_default();
        l.sort_by(f64::total_cmp);
        println!(
            "| {topic} | {sent} | {} | {} | {} | {} | {:.1} / {:.1} |",
            c.received,
            c.lost,
            c.dropped,
            c.late,
            percentile(&l, 0.5),
            percentile(&l, 0.99)
        );
    }
    println!(
        "recorder CPU: {:.3} core ({cpu:.1} s over the {wall:.1} s from the first message to the last); file {:.1} MB; publisher CPU {:.3} core",
        cpu / wall,
        std::fs::metadata(&out).map_or(0.0, |m| m.len() as f64 / 1e6),
        peer["cpu_core_fraction"].as_f64().unwrap_or(f64::NAN)
    );
    let _ = std::fs::remove_dir_all(&dir);
}
