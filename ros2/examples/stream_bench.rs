//! Sustained-stream benchmark of the ros2 transport: the wrist camera's streams over loopback.
//!
//! A publisher process sends 1280x1024 `rgb8` colour (3.9 MB) and 1280x1024 `32FC1` depth
//! (5.2 MB) at `--rate` Hz and `sensor_msgs/JointState` at `--js-rate` Hz for `--duration` s;
//! this process subscribes as the recorder will (best effort, keep last 5) and reports per
//! topic: sent, received, lost (sequence gaps), latency p50/p99 from the publish time (the
//! `header.stamp` each message carries, set when it was written) to its arrival here, and this
//! process's CPU time as a fraction of one core (utime + stime of `/proc/self/stat`).
//!
//! ```sh
//! cargo run --release -p ros2 --example stream_bench -- --publisher rust      # RustDDS -> RustDDS
//! cargo run --release -p ros2 --example stream_bench -- --publisher cyclone   # Cyclone DDS (Python, raw writes) -> RustDDS
//! ```
//! Options: `--duration S` (30), `--rate HZ` (10), `--js-rate HZ` (100), `--domain D` (60),
//! `--reliability reliable|best-effort` (of the image writers; default reliable, as rclcpp
//! publishers are), `--subscription best-effort|reliable` (this process's readers; default
//! best effort, keep last 5, as `Qos::SENSOR_SUBSCRIPTION`; reliable: keep last 5), `--venv DIR` (the Cyclone peer's venv; default `RODLOG_REF_VENV` or
//! `.venv-ref`). Discovery is localhost only. Figures: `ros2/MEASUREMENT.md`.
//!
//! `--role publish` is the Rust publisher process this example spawns of itself.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use msgs::builtin_interfaces::Time;
use msgs::sensor_msgs::{Image, JointState};
use msgs::std_msgs::Header;
use msgs::{Msg, topics};
use ros2::{DiscoveryRange, Node, NodeOptions, Qos, Received};

const WIDTH: u32 = 1280;
const HEIGHT: u32 = 1024;
/// Linux's `sysconf(_SC_CLK_TCK)` on every mainstream architecture (the unit of
/// `/proc/self/stat`'s utime and stime).
const CLOCK_TICKS_PER_S: f64 = 100.0;

#[derive(Debug, Clone)]
struct Args {
    role: String,
    publisher: String,
    duration_s: f64,
    rate_hz: f64,
    js_rate_hz: f64,
    domain: u16,
    reliability: String,
    subscription: String,
    venv: Option<PathBuf>,
}

fn parse_args() -> Result<Args, String> {
    let mut a = Args {
        role: "subscribe".into(),
        publisher: "rust".into(),
        duration_s: 30.0,
        rate_hz: 10.0,
        js_rate_hz: 100.0,
        domain: 60,
        reliability: "reliable".into(),
        subscription: "best-effort".into(),
        venv: None,
    };
    let argv: Vec<String> = std::env::args().skip(1).collect();
    let mut it = argv.iter();
    while let Some(flag) = it.next() {
        let mut value = || {
            it.next()
                .cloned()
                .ok_or_else(|| format!("{flag} needs a value"))
        };
        let num = |v: String| v.parse::<f64>().map_err(|e| format!("{flag} {v}: {e}"));
        match flag.as_str() {
            "--role" => a.role = value()?,
            "--publisher" => a.publisher = value()?,
            "--duration" => a.duration_s = num(value()?)?,
            "--rate" => a.rate_hz = num(value()?)?,
            "--js-rate" => a.js_rate_hz = num(value()?)?,
            "--domain" => {
                let v = value()?;
                a.domain = v.parse().map_err(|e| format!("--domain {v}: {e}"))?;
            }
            "--reliability" => a.reliability = value()?,
            "--subscription" => a.subscription = value()?,
            "--venv" => a.venv = Some(PathBuf::from(value()?)),
            other => return Err(format!("unknown argument {other}")),
        }
    }
    if !["rust", "cyclone"].contains(&a.publisher.as_str()) {
        return Err(format!("--publisher {}: rust or cyclone", a.publisher));
    }
    for v in [&a.reliability, &a.subscription] {
        if !["reliable", "best-effort"].contains(&v.as_str()) {
            return Err(format!("{v}: reliable or best-effort"));
        }
    }
    Ok(a)
}

fn main() {
    let result = parse_args().and_then(|args| {
        if args.role == "publish" {
            publish(&args)
        } else {
            subscribe(&args)
        }
    });
    if let Err(e) = result {
        eprintln!("stream_bench: {e}");
        std::process::exit(1);
    }
}

fn node(domain: u16, name: &str) -> Result<Node, String> {
    Node::new(NodeOptions {
        name: name.into(),
        domain_id: Some(domain),
        discovery: Some(DiscoveryRange::Localhost),
        ..NodeOptions::default()
    })
    .map_err(|e| e.to_string())
}

fn now_ns() -> i64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| i64::try_from(d.as_nanos()).unwrap_or(i64::MAX))
}

/// Writes `ns` into `header.stamp` (the first field, right after the encapsulation header).
fn patch_stamp(cdr: &mut [u8], ns: i64) {
    let sec = i32::try_from(ns / 1_000_000_000).unwrap_or(i32::MAX);
    let nanosec = u32::try_from(ns % 1_000_000_000).unwrap_or(0);
    if let Some(s) = cdr.get_mut(4..8) {
        s.copy_from_slice(&sec.to_le_bytes());
    }
    if let Some(s) = cdr.get_mut(8..12) {
        s.copy_from_slice(&nanosec.to_le_bytes());
    }
}

/// `header.stamp` of a stamped message's CDR, in ns.
fn stamp_ns(cdr: &[u8]) -> Option<i64> {
    let sec = i32::from_le_bytes(cdr.get(4..8)?.try_into().ok()?);
    let nanosec = u32::from_le_bytes(cdr.get(8..12)?.try_into().ok()?);
    Some(i64::from(sec) * 1_000_000_000 + i64::from(nanosec))
}

fn image(encoding: &str, bytes_per_pixel: u32) -> Image {
    let n = (WIDTH * HEIGHT * bytes_per_pixel) as usize;
    Image {
        header: Header {
            stamp: Time::default(),
            frame_id: "camera_color_optical_frame".into(),
        },
        height: HEIGHT,
        width: WIDTH,
        encoding: encoding.into(),
        is_bigendian: 0,
        step: WIDTH * bytes_per_pixel,
        data: (0..n).map(|k| (k % 251) as u8).collect(),
    }
}

/// The Rust publisher process: waits for the subscriber, streams, prints a JSON report.
fn publish(args: &Args) -> Result<(), String> {
    let node = node(args.domain, "stream_bench_publisher")?;
    let image_qos = if args.reliability == "reliable" {
        Qos::COMMAND
    } else {
        Qos::COMMAND.best_effort()
    };
    let img_type = "sensor_msgs/msg/Image";
    let streams = [
        (
            topics::CAMERA_COLOR_IMAGE,
            img_type,
            image_qos,
            image("rgb8", 3).into(),
        ),
        (
            topics::CAMERA_DEPTH_IMAGE,
            img_type,
            image_qos,
            image("32FC1", 4).into(),
        ),
        (
            topics::JOINT_STATES,
            "sensor_msgs/msg/JointState",
            Qos::COMMAND,
            Msg::JointState(JointState {
                name: (1..=6).map(|j| format!("joint{j}")).collect(),
                position: vec![0.1; 6],
                velocity: vec![0.0; 6],
                effort: vec![0.0; 6],
                ..JointState::default()
            }),
        ),
    ];
    let mut pubs = Vec::new();
    for (topic, type_name, qos, msg) in streams {
        let p = node
            .publisher_raw(topic, type_name, qos)
            .map_err(|e| e.to_string())?;
        let cdr = msg.encode().map_err(|e| e.to_string())?;
        pubs.push((p, cdr, Vec::<f64>::new()));
    }
    let end = Instant::now() + Duration::from_secs(20);
    while pubs.iter().any(|(p, _, _)| {
        !node
            .readers_on(p.topic())
            .is_ok_and(|r| r.iter().any(|e| !e.local))
    }) {
        if Instant::now() > end {
            return Err("the subscriber was not discovered within 20 s".into());
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    std::thread::sleep(Duration::from_millis(500));
    let start = Instant::now();
    let (img_period, js_period) = (1.0 / args.rate_hz, 1.0 / args.js_rate_hz);
    let (mut next_img, mut next_js) = (0.0_f64, 0.0_f64);
    let mut failed = 0_u64;
    loop {
        let t = start.elapsed().as_secs_f64();
        if t >= args.duration_s {
            break;
        }
        let mut due = Vec::new();
        if t >= next_js {
            due.push(2);
            next_js += js_period;
        }
        if t >= next_img {
            due.extend([0, 1]);
            next_img += img_period;
        }
        for i in due {
            let Some((p, cdr, calls_ms)) = pubs.get_mut(i) else {
                continue;
            };
            let ns = now_ns();
            patch_stamp(cdr, ns);
            let t0 = Instant::now();
            if p.publish_at(cdr, ns).is_err() {
                failed += 1;
            }
            calls_ms.push(t0.elapsed().as_secs_f64() * 1e3);
        }
        let next = next_img.min(next_js);
        let wait = next - start.elapsed().as_secs_f64();
        if wait > 0.0 {
            std::thread::sleep(Duration::from_secs_f64(wait));
        }
    }
    std::thread::sleep(Duration::from_secs(1));
    let mut report = BTreeMap::new();
    for (p, _, mut calls) in pubs {
        calls.sort_by(f64::total_cmp);
        report.insert(
            p.topic().to_string(),
            serde_json::json!({
                "sent": p.published(),
                "publish_ms_p50": percentile(&calls, 0.5),
                "publish_ms_max": calls.last().copied(),
            }),
        );
    }
    println!(
        "{}",
        serde_json::json!({ "publisher": "rust", "failed": failed, "topics": report })
    );
    Ok(())
}

fn percentile(sorted: &[f64], q: f64) -> Option<f64> {
    if sorted.is_empty() {
        return None;
    }
    let i = ((sorted.len() - 1) as f64 * q).round() as usize;
    sorted.get(i).copied()
}

/// utime + stime of this process, in s.
fn cpu_s() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else {
        return f64::NAN;
    };
    // Fields after the command name (which may contain spaces) closed by ')'.
    let Some(rest) = stat.rsplit_once(')').map(|(_, r)| r) else {
        return f64::NAN;
    };
    let fields: Vec<&str> = rest.split_whitespace().collect();
    // utime and stime are fields 14 and 15 of the line, 12 and 13 after ')'.
    let ticks = |i: usize| fields.get(i).and_then(|v| v.parse::<f64>().ok());
    match (ticks(11), ticks(12)) {
        (Some(u), Some(s)) => (u + s) / CLOCK_TICKS_PER_S,
        _ => f64::NAN,
    }
}

#[derive(Debug, Default)]
struct TopicStats {
    latencies_ms: Vec<f64>,
    with_source_stamp: u64,
    received: u64,
    lost: u64,
}

/// This process: subscribes, spawns the publisher, receives, reports.
fn subscribe(args: &Args) -> Result<(), String> {
    let node = node(args.domain, "stream_bench_subscriber")?;
    let names = [
        topics::CAMERA_COLOR_IMAGE,
        topics::CAMERA_DEPTH_IMAGE,
        topics::JOINT_STATES,
    ];
    let mut subs = Vec::new();
    for name in names {
        let spec = topics::lookup(name).ok_or(format!("{name} not in the registry"))?;
        let sub = if args.subscription == "reliable" {
            node.subscribe_raw(spec.name, spec.type_name, Qos::COMMAND.with_depth(5))
        } else {
            node.subscribe_spec(spec)
        };
        subs.push(sub.map_err(|e| e.to_string())?);
    }
    let publisher = spawn_publisher(args)?;
    let window = Duration::from_secs_f64(args.duration_s + 25.0);
    let cpu0 = cpu_s();
    let t0 = Instant::now();
    let handles: Vec<_> = subs
        .into_iter()
        .map(|mut sub| {
            std::thread::spawn(move || {
                let mut stats = TopicStats::default();
                let end = Instant::now() + window;
                let mut last: Option<Instant> = None;
                while Instant::now() < end {
                    // Stop 3 s after the stream went quiet.
                    if last.is_some_and(|l| l.elapsed() > Duration::from_secs(3)) {
                        break;
                    }
                    match sub.recv_timeout(Duration::from_millis(200)) {
                        Ok(Some(r)) => {
                            last = Some(r.received_at);
                            record(&mut stats, &r);
                        }
                        Ok(None) => {}
                        Err(e) => {
                            eprintln!("{}: {e}", sub.topic());
                            break;
                        }
                    }
                }
                let c = sub.counters();
                stats.received = c.received();
                stats.lost = c.lost();
                (sub.topic().to_string(), stats, last)
            })
        })
        .collect();
    let mut results = Vec::new();
    for h in handles {
        results.push(h.join().map_err(|_| "a receiving thread panicked")?);
    }
    // CPU over the streaming window (to the last arrival), not the idle tail.
    let last = results.iter().filter_map(|r| r.2).max();
    let cpu = cpu_s() - cpu0;
    let busy_s = last
        .map_or(t0.elapsed(), |l| l.duration_since(t0))
        .as_secs_f64();
    let out = publisher
        .wait_with_output()
        .map_err(|e| format!("publisher: {e}"))?;
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).map_err(|e| {
        format!(
            "publisher report: {e}: {}",
            String::from_utf8_lossy(&out.stderr)
        )
    })?;
    println!(
        "publisher {} ({}), images {} Hz {} writers, {} readers, joint states {} Hz, {} s, domain {}",
        args.publisher,
        report["mode"].as_str().unwrap_or("rust"),
        args.rate_hz,
        args.reliability,
        args.subscription,
        args.js_rate_hz,
        args.duration_s,
        args.domain
    );
    println!(
        "| topic | sent | received | lost (gaps) | dropped (sent - received) | latency p50 ms | p99 ms | max ms | with source stamp |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for (topic, mut s, _) in results {
        s.latencies_ms.sort_by(f64::total_cmp);
        let sent = report["topics"][&topic]["sent"].as_u64().unwrap_or(0);
        println!(
            "| {topic} | {sent} | {} | {} | {} | {:.1} | {:.1} | {:.1} | {} |",
            s.received,
            s.lost,
            sent.saturating_sub(s.received),
            percentile(&s.latencies_ms, 0.5).unwrap_or(f64::NAN),
            percentile(&s.latencies_ms, 0.99).unwrap_or(f64::NAN),
            s.latencies_ms.last().copied().unwrap_or(f64::NAN),
            s.with_source_stamp
        );
    }
    println!(
        "receiving process CPU: {:.3} core ({cpu:.1} s over {busy_s:.1} s)",
        cpu / busy_s
    );
    println!("publisher report: {report}");
    Ok(())
}

fn record(stats: &mut TopicStats, r: &Received) {
    let arrived = now_ns();
    if r.source_timestamp_ns.is_some() {
        stats.with_source_stamp += 1;
    }
    if let Some(stamp) = stamp_ns(&r.cdr) {
        stats.latencies_ms.push((arrived - stamp) as f64 / 1e6);
    }
}

fn spawn_publisher(args: &Args) -> Result<std::process::Child, String> {
    let mut cmd = if args.publisher == "rust" {
        let exe = std::env::current_exe().map_err(|e| e.to_string())?;
        let mut c = Command::new(exe);
        c.args(["--role", "publish", "--publisher", "rust"]);
        c.args(["--duration", &args.duration_s.to_string()]);
        c.args(["--rate", &args.rate_hz.to_string()]);
        c.args(["--js-rate", &args.js_rate_hz.to_string()]);
        c.args(["--domain", &args.domain.to_string()]);
        c.args(["--reliability", &args.reliability]);
        c
    } else {
        let repo = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
        let venv = args.venv.clone().unwrap_or_else(|| {
            std::env::var_os("RODLOG_REF_VENV")
                .map_or_else(|| repo.join(".venv-ref"), PathBuf::from)
        });
        let mut c = Command::new(venv.join("bin/python"));
        c.arg(repo.join("scripts/dds/cyclone_peer.py"));
        c.args([
            "bench-pub",
            "--readers",
            "1",
            "--wait-match",
            "20",
            "--linger",
            "1",
        ]);
        c.args([
            "--width",
            &WIDTH.to_string(),
            "--height",
            &HEIGHT.to_string(),
        ]);
        c.args(["--duration", &args.duration_s.to_string()]);
        c.args(["--rate", &args.rate_hz.to_string()]);
        c.args(["--js-rate", &args.js_rate_hz.to_string()]);
        c.args(["--domain", &args.domain.to_string()]);
        c.args(["--reliability", &args.reliability]);
        c.env_remove("CYCLONEDDS_URI");
        c
    };
    cmd.stdout(Stdio::piped())
        .spawn()
        .map_err(|e| format!("cannot start the {} publisher: {e}", args.publisher))
}
