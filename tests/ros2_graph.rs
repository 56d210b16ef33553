//! rodlog on a ROS 2 graph against an independent DDS implementation (Eclipse Cyclone DDS
//! through its Python binding, `scripts/dds/cyclone_peer.py` in the reference venv):
//!
//! - `rodlog record --ros2` records a Cyclone publisher's `sensor_msgs/JointState` (reliable)
//!   and `Image` (best effort) with the same values (the joint states byte for byte), and the
//!   recording replays `--check` clean;
//! - a Cyclone subscriber receives `/joint_states` from `rodlog sim --ros2`, and on its own
//!   `/camera/trigger` it receives a wrist image.
//!
//! All DDS traffic stays on loopback (`ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST` for rodlog,
//! the peer's localhost configuration); each test has its own domain (51..=59). Without the
//! venv a test skips with a notice, never in CI (`RODLOG_NO_SKIP=1`).

use std::time::Duration;

use msgs::Msg;
use replay::{McapReader, ReadFilter};

#[path = "support/cli.rs"]
mod cli;
#[path = "support/graph.rs"]
mod graph;
use graph::{hex, peer_report, spawn_peer, spawn_rodlog, wait};

const JOINT_NAMES: [&str; 6] = [
    "shoulder_joint",
    "upper_arm_joint",
    "fore_arm_joint",
    "wrist1_joint",
    "wrist2_joint",
    "wrist3_joint",
];

/// Pixels of the peer's image `i`: byte k is ((k + i) * 7) mod 251 (cyclone_peer.py).
fn peer_image_data(i: u32, n: usize) -> Vec<u8> {
    (0..n)
        .map(|k| (((k as u64 + u64::from(i % 251)) * 7) % 251) as u8)
        .collect()
}

#[test]
fn record_ros2_records_cyclone_joint_states_and_images_and_replays_clean() {
    let test = "record_ros2_records_cyclone_joint_states_and_images_and_replays_clean";
    let Some(python) = testkit::venv_python_with("cyclonedds", test) else {
        return;
    };
    let domain = 51;
    let dir = tempfile::tempdir().expect("tempdir");
    let rec = dir.path().join("graph.mcap");
    let rec_s = rec.display().to_string();
    let recorder = spawn_rodlog(
        domain,
        &["record", "--ros2", "--duration", "8", "--out", &rec_s],
    );
    let d = domain.to_string();
    let js_out = dir.path().join("js.json");
    let js = spawn_peer(
        &python,
        &js_out,
        &[
            "pub-joint-states",
            "--domain",
            &d,
            "--count",
            "50",
            "--rate",
            "50",
            "--readers",
            "1",
            "--wait-match",
            "20",
        ],
    );
    let img_out = dir.path().join("img.json");
    let img = spawn_peer(
        &python,
        &img_out,
        &[
            "pub-image",
            "--domain",
            &d,
            "--count",
            "10",
            "--rate",
            "10",
            "--width",
            "160",
            "--height",
            "120",
            "--readers",
            "1",
            "--wait-match",
            "20",
        ],
    );
    let js = peer_report(js, &js_out, Duration::from_secs(40));
    let img = peer_report(img, &img_out, Duration::from_secs(40));
    assert_eq!(js["matched"], true, "{js}");
    assert_eq!(img["matched"], true, "{img}");
    let out = wait(recorder, Duration::from_secs(60), "rodlog record --ros2");
    assert!(
        out.status.success(),
        "record --ros2 failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );

    let mut reader = McapReader::open(&rec).expect("open the recording");
    let msgs = reader
        .read_all(
            &ReadFilter::all()
                .with_topics([msgs::topics::JOINT_STATES, msgs::topics::CAMERA_COLOR_IMAGE]),
        )
        .expect("read the recording");
    let cdr_hex: Vec<Vec<u8>> = js["cdr_hex"]
        .as_array()
        .expect("cdr_hex")
        .iter()
        .map(|v| hex(v.as_str().expect("hex string")))
        .collect();
    let mut joint_states = Vec::new();
    let mut images = Vec::new();
    for m in &msgs {
        assert_eq!(m.producer(), Some("ros2_graph"), "{}", m.topic());
        match m.decode().expect("decode") {
            Msg::JointState(s) => joint_states.push((s, m.data.clone())),
            Msg::Image(i) => images.push(i),
            other => panic!("unexpected {}", other.type_name()),
        }
    }
    assert_eq!(joint_states.len(), 50, "joint states recorded");
    for (i, (s, bytes)) in joint_states.iter().enumerate() {
        let i = i as u32;
        assert_eq!(s.header.stamp.sec, 1000 + i as i32);
        assert_eq!(s.header.stamp.nanosec, 250_000_000);
        assert_eq!(s.name, JOINT_NAMES);
        let want: Vec<f64> = (0..6)
            .map(|j| 0.1 * j as f64 + 0.001 * f64::from(i))
            .collect();
        assert_eq!(s.position, want);
        assert_eq!(
            s.velocity,
            (0..6).map(|j| -0.5 * j as f64).collect::<Vec<_>>()
        );
        assert_eq!(
            bytes, &cdr_hex[i as usize],
            "joint state {i}: the recorded bytes are not Cyclone's"
        );
    }
    assert_eq!(images.len(), 10, "images recorded (best effort, loopback)");
    for (i, im) in images.iter().enumerate() {
        let i = i as u32;
        assert_eq!(im.header.stamp.sec, 2000 + i as i32);
        assert_eq!(
            (im.width, im.height, im.encoding.as_str()),
            (160, 120, "rgb8")
        );
        assert_eq!(im.header.frame_id, "camera_color_optical_frame");
        assert_eq!(
            im.data,
            peer_image_data(i, 160 * 120 * 3),
            "image {i} pixels"
        );
    }
    // Stamped on arrival on the robot clock: log times increase, within the 8 s run.
    let times: Vec<u64> = msgs.iter().map(|m| m.log_time_ns).collect();
    assert!(times.windows(2).all(|w| w[0] <= w[1]));
    assert!(times.last().is_some_and(|&t| t <= 8_000_000_000));
    let inputs = reader
        .metadata_named("live_inputs")
        .expect("live_inputs record");
    let js_count = inputs
        .entries
        .get("/joint_states")
        .expect("joint state counters");
    assert!(
        js_count.starts_with("received=50 lost=0 dropped=0 late=0"),
        "{js_count}"
    );

    let check = cli::rodlog(&["replay", &rec_s, "--check"]);
    assert!(
        check.status.success(),
        "replay --check: {}{}",
        String::from_utf8_lossy(&check.stdout),
        String::from_utf8_lossy(&check.stderr)
    );
    let text = String::from_utf8_lossy(&check.stdout);
    assert!(text.contains("all identical"), "{text}");
    let info = cli::rodlog(&["info", &rec_s]);
    let text = String::from_utf8_lossy(&info.stdout);
    assert!(
        text.contains("live inputs:") && text.contains("received=50 lost=0"),
        "{text}"
    );
}

#[test]
fn a_cyclone_subscriber_gets_joint_states_and_its_own_capture_from_sim_ros2() {
    let test = "a_cyclone_subscriber_gets_joint_states_and_its_own_capture_from_sim_ros2";
    let Some(python) = testkit::venv_python_with("cyclonedds", test) else {
        return;
    };
    let domain = 52;
    let sim = spawn_rodlog(
        domain,
        &[
            "sim",
            "--ros2",
            "--scenario",
            "sim-smoke",
            "--duration",
            "20",
            "--rate",
            "1",
        ],
    );
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("client.json");
    let d = domain.to_string();
    let client = spawn_peer(
        &python,
        &out,
        &[
            "sim-client",
            "--domain",
            &d,
            "--count",
            "30",
            "--timeout",
            "25",
        ],
    );
    let report = peer_report(client, &out, Duration::from_secs(40));
    let sim_out = wait(sim, Duration::from_secs(40), "rodlog sim --ros2");
    assert!(
        sim_out.status.success(),
        "sim --ros2 failed: {}",
        String::from_utf8_lossy(&sim_out.stderr)
    );
    let js = report["joint_states"].as_array().expect("joint_states");
    assert!(js.len() >= 30, "{} joint states", js.len());
    let names: Vec<String> = js
        .iter()
        .flat_map(|s| s["name"].as_array().cloned().unwrap_or_default())
        .filter_map(|n| n.as_str().map(str::to_owned))
        .collect();
    for joint in msgs::frames::ARM_JOINT_NAMES {
        assert!(names.iter().any(|n| n == joint), "no {joint} in {names:?}");
    }
    assert_eq!(report["trigger_matched"], true, "{report}");
    let images = report["images"].as_array().expect("images");
    let image = images.first().expect("no wrist image after the trigger");
    assert_eq!(image["encoding"], "rgb8");
    assert_eq!(image["frame_id"], "camera_color_optical_frame");
    let (w, h) = (
        image["width"].as_u64().expect("width"),
        image["height"].as_u64().expect("height"),
    );
    assert!(w > 0 && h > 0);
    assert_eq!(image["data_len"].as_u64(), Some(w * h * 3));
    let stdout = String::from_utf8_lossy(&sim_out.stdout);
    assert!(
        stdout.contains("1 commands received (0 rejected)"),
        "{stdout}"
    );
}

#[test]
fn record_ros2_against_sim_ros2_follows_its_clock_and_replays_identically() {
    let test = "record_ros2_against_sim_ros2_follows_its_clock_and_replays_identically";
    if testkit::venv_python_with("cyclonedds", test).is_none() {
        // Needs no Cyclone peer, but runs with the interop tests (two DDS processes).
        return;
    }
    let domain = 53;
    let dir = tempfile::tempdir().expect("tempdir");
    let rec = dir.path().join("smoke.mcap");
    let rec_s = rec.display().to_string();
    // The full pipeline (script, calibration) on the simulator node's data, no motion.
    let recorder = spawn_rodlog(
        domain,
        &[
            "record",
            "--ros2",
            "--scenario",
            "sim-smoke",
            "--duration",
            "6",
            "--out",
            &rec_s,
        ],
    );
    std::thread::sleep(Duration::from_millis(300));
    let sim = spawn_rodlog(
        domain,
        &[
            "sim",
            "--ros2",
            "--scenario",
            "sim-smoke",
            "--duration",
            "12",
            "--rate",
            "2",
        ],
    );
    let out = wait(recorder, Duration::from_secs(60), "rodlog record --ros2");
    let _ = wait(sim, Duration::from_secs(30), "rodlog sim --ros2");
    assert!(
        out.status.success(),
        "record --ros2 failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("graph /clock"), "{stdout}");

    let mut reader = McapReader::open(&rec).expect("open the recording");
    let ros2 = reader.metadata_named("ros2").expect("ros2 record");
    assert_eq!(
        ros2.entries.get("clock").map(String::as_str),
        Some("graph /clock")
    );
    let all = reader.read_all(&ReadFilter::all()).expect("read");
    let count = |topic: &str, producer: &str| {
        all.iter()
            .filter(|m| m.topic() == topic && m.producer() == Some(producer))
            .count()
    };
    // The simulator's drivers and truth arrived, under the graph's producer.
    assert!(count("/joint_states", "ros2_graph") > 500, "joint states");
    assert!(
        count("/sim/base_pose", "ros2_graph") > 0,
        "no /sim truth recorded"
    );
    // The stages ran on them: robot_state's TF, the script's commands (recorded, not sent).
    assert!(count("/tf", "robot_state") > 500, "robot_state did not run");
    assert!(
        count("/lift/command", "script") == 1,
        "the script did not run"
    );
    // Robot time is the simulator's: the runtime's /clock follows it to the end of the run.
    let last_clock = all
        .iter()
        .filter(|m| m.topic() == "/clock")
        .map(|m| m.log_time_ns)
        .max()
        .unwrap_or(0);
    assert!(
        last_clock >= 5_900_000_000,
        "last /clock at {last_clock} ns"
    );

    let check = cli::rodlog(&["replay", &rec_s, "--check"]);
    let text = String::from_utf8_lossy(&check.stdout);
    assert!(
        check.status.success() && text.contains("all identical"),
        "replay --check: {text}{}",
        String::from_utf8_lossy(&check.stderr)
    );
}

#[test]
fn record_ros2_ends_cleanly_on_sigint() {
    let test = "record_ros2_ends_cleanly_on_sigint";
    if testkit::venv_python_with("cyclonedds", test).is_none() {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let rec = dir.path().join("sigint.mcap");
    let rec_s = rec.display().to_string();
    // No --duration: the `ros2` scenario runs for a day unless stopped.
    let recorder = spawn_rodlog(54, &["record", "--ros2", "--out", &rec_s]);
    std::thread::sleep(Duration::from_secs(4));
    let pid = recorder.id().to_string();
    let sent = std::process::Command::new("kill")
        .args(["-INT", &pid])
        .status()
        .expect("kill -INT");
    assert!(sent.success());
    let out = wait(
        recorder,
        Duration::from_secs(20),
        "rodlog record --ros2 after SIGINT",
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success() && stdout.contains("ended: Interrupted"),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let info = cli::rodlog(&["info", &rec_s]);
    let text = String::from_utf8_lossy(&info.stdout);
    assert!(
        info.status.success() && text.contains("recovered:   no (file intact)"),
        "{text}"
    );
    assert!(text.contains("/clock"), "{text}");
}
