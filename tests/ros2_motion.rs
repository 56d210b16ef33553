//! Commands over ROS 2 and their safety, against an independent robot: the Cyclone DDS peer
//! (`cyclone_peer.py robot`) publishes `/joint_states`, listens on every command topic, serves
//! a FollowJointTrajectory action, publishes a driver status or an `/estop`, and watches the
//! graph for writers (Cyclone's built-in DCPSPublication topic).
//!
//! A small scenario on the graph (`world = "ros2"`) has the script stage command the arm at
//! 0.5 s, the lift at 3.0 s, the clamp at 3.3 s and a capture at 3.6 s of robot time:
//! - without `--allow-motion`, no writer appears on any command topic (rodlog's own graph API
//!   and Cyclone's both say so) and the robot receives nothing;
//! - with it, the robot receives exactly the recorded commands (the trajectory with its stamp
//!   zero, "start when received");
//! - an `/estop` stops the arm and holds every later command; joint states that stop do the
//!   same; a protective stop (the driver's safety mode) holds every command;
//! - through a FollowJointTrajectory action the goal is the recorded trajectory, and its
//!   acceptance and result are recorded.
//!
//! Each test has its own domain (61..=66); they run one at a time (a lock), so the 100 ms
//! joint-state deadline is not tested against a machine loaded by the other tests.

use std::sync::Mutex;
use std::time::Duration;

use msgs::Msg;
use msgs::trajectory_msgs::JointTrajectory;
use replay::{McapMessage, McapReader, ReadFilter};
use serde_json::Value;

#[path = "support/graph.rs"]
mod graph;
use graph::{hex, peer_report, spawn_peer, spawn_rodlog, wait};

static ONE_AT_A_TIME: Mutex<()> = Mutex::new(());

const SCENARIO: &str = r#"name = "motion-probe"
duration_s = 6.0
world = "ros2"
task = "none"

[ros2]
use_sim_time = "off"
JOINT_STATES_DEADLINE

[[command]]
t_s = 0.5
kind = "joints"
values = [0.1, 0.3, 1.5, 0.0, -1.2, 0.0]
duration_s = 1.0

[[command]]
t_s = 3.0
kind = "lift"
values = [0.3]

[[command]]
t_s = 3.3
kind = "clamp"
values = [1, 6.0]

[[command]]
t_s = 3.6
kind = "capture"
"#;

const COMMAND_TOPICS: [&str; 5] = [
    "/arm/joint_trajectory",
    "/lift/command",
    "/base/goal",
    "/clamp/command",
    "/camera/trigger",
];

struct Run {
    peer: Value,
    recording: Vec<McapMessage>,
    metadata: std::collections::BTreeMap<String, std::collections::BTreeMap<String, String>>,
    stdout: String,
    writers_seen_by_rustdds: Vec<String>,
}

/// Runs the probe scenario on `domain` against the robot peer (`peer_args`), with rodlog's
/// `extra` flags; `deadline_ms` is the joint-state deadline (the stale test keeps the default
/// 100 ms, the others allow for a loaded machine).
fn run(
    test: &str,
    domain: u16,
    extra: &[&str],
    peer_args: &[&str],
    deadline_ms: Option<u32>,
    remap: Option<&str>,
) -> Option<Run> {
    let python = testkit::venv_python_with("cyclonedds", test)?;
    let _one = ONE_AT_A_TIME
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    let dir = tempfile::tempdir().expect("tempdir");
    let scenario = dir.path().join("motion-probe.toml");
    let deadline = deadline_ms.map_or(String::new(), |ms| {
        format!("joint_states_deadline_ms = {ms}")
    });
    std::fs::write(
        &scenario,
        SCENARIO.replace("JOINT_STATES_DEADLINE", &deadline),
    )
    .expect("scenario");
    let rec = dir.path().join("motion.mcap");
    let (scenario_s, rec_s) = (scenario.display().to_string(), rec.display().to_string());
    let remap_path = dir.path().join("robot.toml");
    let mut args = vec![
        "record",
        "--ros2",
        "--scenario",
        &scenario_s,
        "--out",
        &rec_s,
    ];
    let remap_s = remap_path.display().to_string();
    if let Some(text) = remap {
        std::fs::write(&remap_path, text).expect("remap file");
        args.extend(["--remap", &remap_s]);
    }
    args.extend(extra);
    let d = domain.to_string();
    let out = dir.path().join("robot.json");
    let mut p = vec![
        "robot",
        "--domain",
        &d,
        "--duration",
        "11",
        "--js-rate",
        "100",
    ];
    p.extend(peer_args);
    let peer = spawn_peer(&python, &out, &p);
    // rodlog's own graph API, in a third participant: which writers exist on the command
    // topics while the recording runs.
    let observer = ros2::Node::new(ros2::NodeOptions {
        name: "test_observer".into(),
        domain_id: Some(domain),
        discovery: Some(ros2::DiscoveryRange::Localhost),
        ..ros2::NodeOptions::default()
    })
    .expect("observer node");
    let recorder = spawn_rodlog(domain, &args);
    let mut writers_seen_by_rustdds = Vec::new();
    for _ in 0..70 {
        std::thread::sleep(Duration::from_millis(100));
        for t in COMMAND_TOPICS
            .iter()
            .chain(&["/tf_static", "/rosout", "/task/event"])
        {
            let remote = observer
                .writers_on(t)
                .expect("writers_on")
                .iter()
                .any(|e| !e.local);
            if remote && !writers_seen_by_rustdds.iter().any(|w| w == t) {
                writers_seen_by_rustdds.push((*t).to_owned());
            }
        }
    }
    let rec_out = wait(recorder, Duration::from_secs(60), "rodlog record --ros2");
    let peer = peer_report(peer, &out, Duration::from_secs(60));
    assert!(
        rec_out.status.success(),
        "record --ros2: {}",
        String::from_utf8_lossy(&rec_out.stderr)
    );
    let mut reader = McapReader::open(&rec).expect("open the recording");
    let recording = reader.read_all(&ReadFilter::all()).expect("read");
    let metadata = reader
        .metadata()
        .iter()
        .map(|m| (m.name.clone(), m.entries.clone()))
        .collect();
    Some(Run {
        peer,
        recording,
        metadata,
        stdout: String::from_utf8_lossy(&rec_out.stdout).into_owned(),
        writers_seen_by_rustdds,
    })
}

fn received<'a>(peer: &'a Value, topic: &str) -> Vec<&'a Value> {
    peer["commands"]
        .as_array()
        .expect("commands")
        .iter()
        .filter(|c| c["topic"] == topic)
        .collect()
}

fn recorded<'a>(run: &'a Run, topic: &str, producer: &str) -> Vec<&'a McapMessage> {
    run.recording
        .iter()
        .filter(|m| m.topic() == topic && m.producer() == Some(producer))
        .collect()
}

fn events(run: &Run, topic: &str) -> Vec<(String, String)> {
    run.recording
        .iter()
        .filter(|m| m.topic() == topic)
        .filter_map(|m| match m.decode() {
            Ok(Msg::TaskEvent(e)) => Some((e.state, e.reason_code)),
            _ => None,
        })
        .collect()
}

fn trajectory(bytes: &[u8]) -> JointTrajectory {
    match Msg::decode("trajectory_msgs/msg/JointTrajectory", bytes) {
        Ok(Msg::JointTrajectory(t)) => t,
        other => panic!("not a trajectory: {other:?}"),
    }
}

/// Whether a received payload is `sent` (RTPS pads payloads to 4 bytes: up to 3 trailing
/// zeros are the transport's, not the message's).
fn same_payload(received: &[u8], sent: &[u8]) -> bool {
    received.len() >= sent.len()
        && received.len() - sent.len() <= 3
        && received[..sent.len()] == *sent
        && received[sent.len()..].iter().all(|&b| b == 0)
}

/// The recorded trajectory as it goes to a driver: stamp zero.
fn as_sent(m: &McapMessage) -> Vec<u8> {
    let mut t = trajectory(&m.data);
    t.header.stamp = msgs::builtin_interfaces::Time::default();
    Msg::JointTrajectory(t).encode().expect("encode")
}

#[test]
fn without_allow_motion_no_writer_appears_on_any_command_topic() {
    let test = "without_allow_motion_no_writer_appears_on_any_command_topic";
    let Some(run) = run(test, 61, &[], &[], Some(1000), None) else {
        return;
    };
    // The stages computed their commands; they are in the recording.
    for topic in [
        "/arm/joint_trajectory",
        "/lift/command",
        "/clamp/command",
        "/camera/trigger",
    ] {
        assert_eq!(
            recorded(&run, topic, "script").len(),
            1,
            "{topic} not recorded"
        );
    }
    // Nothing reached the robot, and nobody saw a command writer.
    assert_eq!(
        run.peer["commands"].as_array().map(Vec::len),
        Some(0),
        "{}",
        run.peer
    );
    let cyclone: Vec<&str> = run.peer["writer_topics"]
        .as_array()
        .expect("writer_topics")
        .iter()
        .filter_map(Value::as_str)
        .collect();
    for t in COMMAND_TOPICS {
        assert!(
            !cyclone.contains(&format!("rt{t}").as_str()),
            "Cyclone saw a writer on {t}"
        );
        assert!(
            !run.writers_seen_by_rustdds.iter().any(|w| w == t),
            "RustDDS saw a writer on {t}"
        );
    }
    // ... while both did see rodlog's other writers: they were looking.
    assert!(
        cyclone.contains(&"rt/tf_static") && cyclone.contains(&"rt/rosout"),
        "{cyclone:?}"
    );
    assert!(
        run.writers_seen_by_rustdds
            .iter()
            .any(|w| w == "/tf_static")
    );
    assert_eq!(
        run.metadata["ros2"]
            .get("command_writers")
            .map(String::as_str),
        Some("")
    );
    assert!(
        run.stdout.contains("command writers: none"),
        "{}",
        run.stdout
    );
}

#[test]
fn with_allow_motion_the_robot_receives_the_recorded_commands() {
    let test = "with_allow_motion_the_robot_receives_the_recorded_commands";
    let Some(run) = run(test, 62, &["--allow-motion"], &[], Some(1000), None) else {
        return;
    };
    let arm = received(&run.peer, "/arm/joint_trajectory");
    let rec_arm = recorded(&run, "/arm/joint_trajectory", "script");
    assert_eq!((arm.len(), rec_arm.len()), (1, 1), "{}", run.peer);
    assert!(
        same_payload(
            &hex(arm[0]["cdr_hex"].as_str().expect("hex")),
            &as_sent(rec_arm[0])
        ),
        "the trajectory the robot received is not the recorded one"
    );
    for topic in ["/lift/command", "/clamp/command", "/camera/trigger"] {
        let got = received(&run.peer, topic);
        let rec = recorded(&run, topic, "script");
        assert_eq!((got.len(), rec.len()), (1, 1), "{topic}");
        assert!(
            same_payload(&hex(got[0]["cdr_hex"].as_str().expect("hex")), &rec[0].data),
            "{topic}: the robot received other bytes than the recorded ones"
        );
    }
    let cyclone = run.peer["writer_topics"].to_string();
    assert!(cyclone.contains("rt/arm/joint_trajectory"), "{cyclone}");
    // A healthy robot: nothing held (a hold at the very start, before its first joint states,
    // would be followed by its release).
    let safety = events(&run, "/safety/event");
    assert!(
        safety.last().is_none_or(|e| e.0 == "released"),
        "{safety:?}"
    );
    assert_eq!(
        run.metadata["motion"].get("sent").map(String::as_str),
        Some("4")
    );
    assert_eq!(
        run.metadata["motion"].get("withheld").map(String::as_str),
        Some("0")
    );
}

#[test]
fn an_estop_stops_the_arm_and_holds_every_later_command() {
    let test = "an_estop_stops_the_arm_and_holds_every_later_command";
    let Some(run) = run(
        test,
        63,
        &["--allow-motion"],
        &["--estop-after", "1"],
        Some(1000),
        None,
    ) else {
        return;
    };
    assert_eq!(run.peer["estop_sent"], true);
    let arm = received(&run.peer, "/arm/joint_trajectory");
    assert_eq!(arm.len(), 2, "the trajectory, then the stop: {}", run.peer);
    let stop = trajectory(&hex(arm[1]["cdr_hex"].as_str().expect("hex")));
    assert!(
        stop.points.is_empty() && stop.joint_names.len() == 6,
        "{stop:?}"
    );
    let clamp = received(&run.peer, "/clamp/command");
    assert_eq!(clamp.len(), 1, "one clamp STOP and nothing else");
    match Msg::decode(
        "rodlog_msgs/msg/ClampCommand",
        &hex(clamp[0]["cdr_hex"].as_str().expect("hex")),
    ) {
        Ok(Msg::ClampCommand(c)) => assert_eq!(c.action, msgs::rodlog_msgs::ClampCommand::STOP),
        other => panic!("{other:?}"),
    }
    assert!(received(&run.peer, "/lift/command").is_empty());
    assert!(received(&run.peer, "/camera/trigger").is_empty());
    let safety = events(&run, "/safety/event");
    assert!(
        safety.contains(&("hold".into(), "estop".into())),
        "{safety:?}"
    );
    assert_eq!(
        safety.last().map(|e| e.0.as_str()),
        Some("hold"),
        "the e-stop latches"
    );
    assert_eq!(
        run.metadata["motion"].get("withheld").map(String::as_str),
        Some("3")
    );
}

#[test]
fn stale_joint_states_hold_motion() {
    let test = "stale_joint_states_hold_motion";
    // The default 100 ms deadline: the robot stops publishing joint states altogether.
    let Some(run) = run(
        test,
        64,
        &["--allow-motion"],
        &["--stop-js-after", "1"],
        None,
        None,
    ) else {
        return;
    };
    let arm = received(&run.peer, "/arm/joint_trajectory");
    assert_eq!(arm.len(), 2, "the trajectory, then the stop: {}", run.peer);
    assert!(
        trajectory(&hex(arm[1]["cdr_hex"].as_str().expect("hex")))
            .points
            .is_empty()
    );
    assert!(received(&run.peer, "/lift/command").is_empty());
    let safety = events(&run, "/safety/event");
    assert!(
        safety.contains(&("hold".into(), "joint_states_stale".into())),
        "{safety:?}"
    );
    let withheld = run
        .recording
        .iter()
        .filter(|m| m.topic() == "/rosout" && m.producer() == Some("command_path"))
        .filter_map(|m| match m.decode() {
            Ok(Msg::Log(l)) => Some(l.msg),
            _ => None,
        })
        .filter(|t| t.starts_with("withheld"))
        .count();
    assert_eq!(withheld, 3, "lift, clamp and capture withheld and logged");
    let gap = run.metadata["motion"]["watchdog_worst_gap_ms"]
        .parse::<f64>()
        .expect("gap");
    assert!(gap > 0.0);
}

const PROTECTIVE_STOP_REMAP: &str = r#"
[[status]]
topic = "/io_and_status_controller/safety_mode"
type = "aubo_dashboard_msgs/msg/SafetyMode"
field = "uint8"
ok = [1, 2]
"#;

#[test]
fn a_protective_stop_holds_every_command() {
    let test = "a_protective_stop_holds_every_command";
    let peer = [
        "--status-topic",
        "/io_and_status_controller/safety_mode",
        "--status-field",
        "uint8",
        "--status-value",
        "3",
    ];
    let Some(run) = run(
        test,
        65,
        &["--allow-motion"],
        &peer,
        Some(1000),
        Some(PROTECTIVE_STOP_REMAP),
    ) else {
        return;
    };
    assert_eq!(
        run.peer["commands"].as_array().map(Vec::len),
        Some(0),
        "{}",
        run.peer
    );
    let safety = events(&run, "/safety/event");
    assert!(
        safety.iter().all(|e| e.0 == "hold"),
        "never released: {safety:?}"
    );
    assert_eq!(
        safety.last().map(|e| e.1.as_str()),
        Some("status"),
        "{safety:?}"
    );
    assert_eq!(
        run.metadata["motion"].get("withheld").map(String::as_str),
        Some("4")
    );
    assert_eq!(
        run.metadata["motion"].get("sent").map(String::as_str),
        Some("0")
    );
}

const ACTION_REMAP: &str = r#"
[command.arm]
mode = "action"
name = "/joint_trajectory_controller/follow_joint_trajectory"
"#;

#[test]
fn through_the_action_the_goal_is_the_recorded_trajectory_and_its_result_is_recorded() {
    let test = "through_the_action_the_goal_is_the_recorded_trajectory_and_its_result_is_recorded";
    let peer = [
        "--action",
        "/joint_trajectory_controller/follow_joint_trajectory",
    ];
    let Some(run) = run(
        test,
        66,
        &["--allow-motion"],
        &peer,
        Some(1000),
        Some(ACTION_REMAP),
    ) else {
        return;
    };
    assert!(
        received(&run.peer, "/arm/joint_trajectory").is_empty(),
        "not on the topic"
    );
    let goals = run.peer["goals"].as_array().expect("goals");
    assert_eq!(goals.len(), 1, "{}", run.peer);
    let rec = recorded(&run, "/arm/joint_trajectory", "script");
    let want = trajectory(&rec[0].data);
    let got = &goals[0]["trajectory"];
    assert_eq!(got["stamp"], serde_json::json!([0, 0]));
    let names: Vec<&str> = got["joint_names"]
        .as_array()
        .expect("names")
        .iter()
        .filter_map(Value::as_str)
        .collect();
    assert_eq!(names, want.joint_names);
    let points = got["points"].as_array().expect("points");
    assert_eq!(points.len(), want.points.len());
    for (g, w) in points.iter().zip(&want.points) {
        let pos: Vec<f64> = g["positions"]
            .as_array()
            .expect("positions")
            .iter()
            .filter_map(Value::as_f64)
            .collect();
        assert_eq!(pos, w.positions);
        assert_eq!(
            g["time_from_start"],
            serde_json::json!([w.time_from_start.sec, w.time_from_start.nanosec])
        );
    }
    let arm = events(&run, "/arm/action");
    let states: Vec<&str> = arm.iter().map(|e| e.0.as_str()).collect();
    assert_eq!(states, ["sent", "accepted", "succeeded"], "{arm:?}");
}
