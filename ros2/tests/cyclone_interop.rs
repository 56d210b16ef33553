//! The ros2 transport against an independent DDS implementation: Eclipse Cyclone DDS through
//! its Python binding (`cyclonedds`), driven by `scripts/dds/cyclone_peer.py`.
//!
//! The peer runs in the reference venv (`RODLOG_REF_VENV`, default `<repo>/.venv-ref`, made by
//! `scripts/venv.sh`). Without the venv or without `cyclonedds` in it a test prints
//! `NOTICE: ... skipped` and passes, unless `RODLOG_NO_SKIP=1` (CI), where it fails.
//!
//! All traffic stays on the loopback interface (localhost discovery on both sides). Each test
//! has its own domain (41..=49), so the tests may run in parallel without cross-talk.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use msgs::builtin_interfaces::Time;
use msgs::geometry_msgs::{Quaternion, Transform, TransformStamped, Vector3};
use msgs::sensor_msgs::{Image, JointState};
use msgs::std_msgs::Header;
use msgs::tf2_msgs::TfMessage;
use msgs::{Msg, topics};
use ros2::{DiscoveryRange, EndpointKind, Node, NodeOptions, Qos, ServiceMapping};
use serde_json::Value;

const JOINT_NAMES: [&str; 6] = [
    "shoulder_joint",
    "upper_arm_joint",
    "fore_arm_joint",
    "wrist1_joint",
    "wrist2_joint",
    "wrist3_joint",
];

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The venv's python when it has `cyclonedds` (whether the test may skip without it is
/// `testkit`'s decision: never in CI).
fn peer_python(check: &str) -> Option<PathBuf> {
    testkit::venv_python_with("cyclonedds", check)
}

fn node(domain_id: u16) -> Node {
    Node::new(NodeOptions {
        name: "rodlog_test".into(),
        domain_id: Some(domain_id),
        discovery: Some(DiscoveryRange::Localhost),
        ..NodeOptions::default()
    })
    .expect("node")
}

/// Starts the peer with `args`; its JSON report goes to the returned file.
fn spawn_peer(python: &Path, tag: &str, args: &[&str]) -> (Child, PathBuf) {
    let out = std::env::temp_dir().join(format!("rodlog-ros2-{tag}-{}.json", std::process::id()));
    let _ = std::fs::remove_file(&out);
    let child = Command::new(python)
        .arg(repo().join("scripts/dds/cyclone_peer.py"))
        .args(args)
        .arg("--out")
        .arg(&out)
        .env_remove("CYCLONEDDS_URI")
        .stdout(Stdio::null())
        .spawn()
        .expect("start cyclone_peer.py");
    (child, out)
}

fn finish(mut child: Child, out: &Path) -> Value {
    let status = child.wait().expect("wait for peer");
    assert!(status.success(), "cyclone_peer.py failed: {status}");
    let text = std::fs::read_to_string(out).expect("peer report");
    let _ = std::fs::remove_file(out);
    serde_json::from_str(&text).expect("peer JSON")
}

/// What the peer publishes as JointState `i` (cyclone_peer.py `joint_state`).
fn peer_joint_state(i: u32) -> JointState {
    JointState {
        header: Header {
            stamp: Time {
                sec: 1000 + i as i32,
                nanosec: 250_000_000,
            },
            frame_id: String::new(),
        },
        name: JOINT_NAMES.iter().map(|s| s.to_string()).collect(),
        position: (0..6).map(|j| 0.1 * j as f64 + 0.001 * i as f64).collect(),
        velocity: (0..6).map(|j| -0.5 * j as f64).collect(),
        effort: vec![],
    }
}

/// Pixels of the peer's image `i`: byte k is ((k + i) * 7) mod 251 (cyclone_peer.py).
fn peer_image_data(i: u32, n: usize) -> Vec<u8> {
    (0..n)
        .map(|k| (((k as u64 + u64::from(i % 251)) * 7) % 251) as u8)
        .collect()
}

fn recv_all(sub: &mut ros2::Subscription, want: usize, within: Duration) -> Vec<ros2::Received> {
    let end = Instant::now() + within;
    let mut got = Vec::new();
    while got.len() < want && Instant::now() < end {
        if let Some(r) = sub
            .recv_timeout(end.saturating_duration_since(Instant::now()))
            .expect("recv")
        {
            got.push(r);
        }
    }
    got
}

fn wait_for_remote(node: &Node, topic: &str, kind: EndpointKind, within: Duration) -> bool {
    let end = Instant::now() + within;
    while Instant::now() < end {
        let eps = match kind {
            EndpointKind::Reader => node.readers_on(topic),
            EndpointKind::Writer => node.writers_on(topic),
        }
        .expect("topic name");
        if eps.iter().any(|e| !e.local) {
            return true;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    false
}

#[test]
fn cyclone_joint_states_reliable_arrive_byte_identical() {
    let Some(python) = peer_python("cyclone_joint_states_reliable_arrive_byte_identical") else {
        return;
    };
    let node = node(41);
    let spec = topics::lookup(topics::JOINT_STATES).expect("registered");
    // Best effort as a recorder subscribes, with room for 1 s of a stalled test thread (the
    // image test runs beside this one): what is checked here is the bytes, not the depth.
    let qos = Qos::for_subscription(spec).with_depth(100);
    let mut sub = node
        .subscribe_raw(spec.name, spec.type_name, qos)
        .expect("subscribe");
    let (peer, out) = spawn_peer(
        &python,
        "js",
        &[
            "pub-joint-states",
            "--domain",
            "41",
            "--count",
            "50",
            "--rate",
            "100",
        ],
    );
    let got = recv_all(&mut sub, 50, Duration::from_secs(30));
    let report = finish(peer, &out);
    assert_eq!(report["matched"], true, "{report}");
    let sent_cdr: Vec<Vec<u8>> = report["cdr_hex"]
        .as_array()
        .expect("cdr_hex")
        .iter()
        .map(|h| hex(h.as_str().expect("hex")))
        .collect();
    assert_eq!(got.len(), 50, "received {} of 50", got.len());
    for (i, r) in got.iter().enumerate() {
        assert_eq!(&*r.topic, "/joint_states");
        // The bytes Cyclone serialised are the bytes handed out: nothing decoded and re-encoded.
        assert_eq!(r.cdr, sent_cdr[i], "message {i} bytes differ");
        let Ok(Msg::JointState(js)) = Msg::decode(spec.type_name, &r.cdr) else {
            panic!("message {i} is not a JointState");
        };
        assert_eq!(js, peer_joint_state(i as u32));
        assert!(r.source_timestamp_ns.is_some(), "message {i} has no stamp");
    }
    let c = sub.counters();
    assert_eq!((c.received(), c.lost()), (50, 0));
}

#[test]
fn cyclone_images_best_effort_arrive_with_identical_fields() {
    let Some(python) = peer_python("cyclone_images_best_effort_arrive_with_identical_fields")
    else {
        return;
    };
    let node = node(42);
    let spec = topics::lookup(topics::CAMERA_COLOR_IMAGE).expect("registered");
    let mut sub = node.subscribe_spec(spec).expect("subscribe");
    let (w, h) = (1280_u32, 1024_u32);
    let (peer, out) = spawn_peer(
        &python,
        "img",
        &[
            "pub-image",
            "--domain",
            "42",
            "--count",
            "10",
            "--rate",
            "5",
            "--width",
            "1280",
            "--height",
            "1024",
            "--encoding",
            "rgb8",
        ],
    );
    let got = recv_all(&mut sub, 10, Duration::from_secs(40));
    let report = finish(peer, &out);
    assert_eq!(report["matched"], true, "{report}");
    let c = sub.counters();
    eprintln!(
        "images: received {} lost {} of 10 (best effort)",
        c.received(),
        c.lost()
    );
    assert!(got.len() >= 8, "received only {} of 10 images", got.len());
    for r in &got {
        let Ok(Msg::Image(img)) = Msg::decode(spec.type_name, &r.cdr) else {
            panic!("not an Image");
        };
        let i = (img.header.stamp.sec - 2000) as u32;
        let want = Image {
            header: Header {
                stamp: Time {
                    sec: 2000 + i as i32,
                    nanosec: 500,
                },
                frame_id: "camera_color_optical_frame".into(),
            },
            height: h,
            width: w,
            encoding: "rgb8".into(),
            is_bigendian: 0,
            step: 3 * w,
            data: peer_image_data(i, (3 * w * h) as usize),
        };
        assert!(img == want, "image {i} differs from what the peer sent");
        // 4-byte header + the CDR of the fields: the image arrived whole (no trailing bytes).
        assert_eq!(r.cdr, want_cdr(&want), "image {i} bytes");
    }
}

fn want_cdr(img: &Image) -> Vec<u8> {
    Msg::Image(img.clone()).encode().expect("encode")
}

#[test]
fn rust_joint_states_reach_a_cyclone_subscriber() {
    let Some(python) = peer_python("rust_joint_states_reach_a_cyclone_subscriber") else {
        return;
    };
    let node = node(43);
    let spec = topics::lookup(topics::JOINT_STATES).expect("registered");
    let publisher = node.publisher_spec(spec).expect("publisher");
    let (peer, out) = spawn_peer(
        &python,
        "jssub",
        &[
            "sub",
            "--domain",
            "43",
            "--topic",
            "/joint_states",
            "--type",
            "joint_state",
            "--reliability",
            "reliable",
            "--count",
            "20",
            "--timeout",
            "30",
        ],
    );
    assert!(
        wait_for_remote(
            &node,
            "/joint_states",
            EndpointKind::Reader,
            Duration::from_secs(20)
        ),
        "the Cyclone reader was not discovered"
    );
    // Discovery is two-way: give the peer time to match this writer too.
    std::thread::sleep(Duration::from_millis(500));
    let sent: Vec<JointState> = (0..20).map(|i| peer_joint_state(i + 100)).collect();
    for js in &sent {
        let cdr = Msg::JointState(js.clone()).encode().expect("encode");
        publisher.publish(&cdr).expect("publish");
        std::thread::sleep(Duration::from_millis(10));
    }
    let report = finish(peer, &out);
    let received = report["received"].as_array().expect("received");
    assert_eq!(received.len(), 20, "{report}");
    for (r, js) in received.iter().zip(&sent) {
        assert_eq!(r["stamp"][0], js.header.stamp.sec);
        assert_eq!(r["stamp"][1], js.header.stamp.nanosec);
        assert_eq!(r["frame_id"], "");
        let names: Vec<&str> = r["name"]
            .as_array()
            .expect("name")
            .iter()
            .filter_map(Value::as_str)
            .collect();
        assert_eq!(names, JOINT_NAMES);
        let f64s = |key: &str| -> Vec<f64> {
            r[key]
                .as_array()
                .expect(key)
                .iter()
                .filter_map(Value::as_f64)
                .collect()
        };
        assert_eq!(f64s("position"), js.position);
        assert_eq!(f64s("velocity"), js.velocity);
        assert!(f64s("effort").is_empty());
    }
    assert_eq!(publisher.published(), 20);
}

#[test]
fn tf_static_reaches_a_late_joining_cyclone_subscriber() {
    let Some(python) = peer_python("tf_static_reaches_a_late_joining_cyclone_subscriber") else {
        return;
    };
    let node = node(44);
    let spec = topics::lookup(topics::TF_STATIC).expect("registered");
    assert_eq!(Qos::for_publisher(spec), Qos::LATCHED);
    let publisher = node.publisher_spec(spec).expect("publisher");
    let tf = TfMessage {
        transforms: vec![
            TransformStamped {
                header: Header {
                    stamp: Time { sec: 7, nanosec: 8 },
                    frame_id: "tool0".into(),
                },
                child_frame_id: "camera_link".into(),
                transform: Transform {
                    translation: Vector3 {
                        x: 0.05,
                        y: -0.02,
                        z: 0.1,
                    },
                    rotation: Quaternion {
                        x: 0.0,
                        y: 0.0,
                        z: std::f64::consts::FRAC_1_SQRT_2,
                        w: std::f64::consts::FRAC_1_SQRT_2,
                    },
                },
            },
            TransformStamped {
                header: Header {
                    stamp: Time { sec: 7, nanosec: 8 },
                    frame_id: "base_link".into(),
                },
                child_frame_id: "lift_link".into(),
                transform: Transform {
                    translation: Vector3 {
                        x: 0.0,
                        y: 0.0,
                        z: 0.5,
                    },
                    rotation: Quaternion {
                        x: 0.0,
                        y: 0.0,
                        z: 0.0,
                        w: 1.0,
                    },
                },
            },
        ],
    };
    // Published before any reader exists: only transient-local durability can deliver it.
    publisher
        .publish(&Msg::TfMessage(tf.clone()).encode().expect("encode"))
        .expect("publish");
    std::thread::sleep(Duration::from_millis(300));
    let (peer, out) = spawn_peer(
        &python,
        "tf",
        &[
            "sub",
            "--domain",
            "44",
            "--topic",
            "/tf_static",
            "--type",
            "tf",
            "--reliability",
            "reliable",
            "--durability",
            "transient-local",
            "--depth",
            "100",
            "--count",
            "1",
            "--timeout",
            "20",
        ],
    );
    let report = finish(peer, &out);
    let received = report["received"].as_array().expect("received");
    assert_eq!(received.len(), 1, "{report}");
    let transforms = received[0]["transforms"].as_array().expect("transforms");
    assert_eq!(transforms.len(), 2);
    for (t, want) in transforms.iter().zip(&tf.transforms) {
        assert_eq!(t["frame_id"], want.header.frame_id.as_str());
        assert_eq!(t["child_frame_id"], want.child_frame_id.as_str());
        assert_eq!(t["stamp"][0], want.header.stamp.sec);
        let tr = &want.transform.translation;
        let q = &want.transform.rotation;
        assert_eq!(t["translation"], serde_json::json!([tr.x, tr.y, tr.z]));
        assert_eq!(t["rotation"], serde_json::json!([q.x, q.y, q.z, q.w]));
    }
}

#[test]
fn a_node_on_another_domain_receives_nothing() {
    let Some(python) = peer_python("a_node_on_another_domain_receives_nothing") else {
        return;
    };
    // The peer publishes on 45 (from ROS_DOMAIN_ID, as a ROS 2 node would); a node there
    // receives, proving the traffic exists; a node on 46 sees neither samples nor the writer.
    let same = node(45);
    let other = node(46);
    let spec = topics::lookup(topics::JOINT_STATES).expect("registered");
    let mut sub_same = same.subscribe_spec(spec).expect("subscribe");
    let mut sub_other = other.subscribe_spec(spec).expect("subscribe");
    let out = std::env::temp_dir().join(format!("rodlog-ros2-iso-{}.json", std::process::id()));
    let peer = Command::new(&python)
        .arg(repo().join("scripts/dds/cyclone_peer.py"))
        .args([
            "pub-joint-states",
            "--readers",
            "0",
            "--count",
            "300",
            "--rate",
            "100",
        ])
        .arg("--out")
        .arg(&out)
        .env("ROS_DOMAIN_ID", "45")
        .env_remove("CYCLONEDDS_URI")
        .stdout(Stdio::null())
        .spawn()
        .expect("start peer");
    let got_same = recv_all(&mut sub_same, 20, Duration::from_secs(20));
    let got_other = recv_all(&mut sub_other, 1, Duration::from_secs(1));
    let saw_writer = other
        .writers_on(topics::JOINT_STATES)
        .expect("name")
        .iter()
        .any(|e| !e.local);
    finish(peer, &out);
    assert_eq!(
        got_same.len(),
        20,
        "the control node on domain 45 received too little"
    );
    assert!(
        got_other.is_empty(),
        "domain 46 received {}",
        got_other.len()
    );
    assert!(!saw_writer, "domain 46 discovered the domain-45 writer");
    assert_eq!(sub_other.counters().received(), 0);
}

/// `std_srvs/srv/Trigger` response.
#[derive(Debug, serde::Deserialize)]
struct TriggerResponse {
    success: bool,
    message: String,
}

#[test]
fn a_raw_service_client_calls_a_cyclone_mapped_server() {
    let Some(python) = peer_python("a_raw_service_client_calls_a_cyclone_mapped_server") else {
        return;
    };
    let node = node(47);
    let mut client = node
        .service_client_raw(
            "/mecheye/capture",
            "std_srvs/srv/Trigger",
            ServiceMapping::Cyclone,
        )
        .expect("client");
    let (peer, out) = spawn_peer(
        &python,
        "srv",
        &[
            "serve-trigger",
            "--domain",
            "47",
            "--topic",
            "/mecheye/capture",
            "--count",
            "3",
        ],
    );
    let end = Instant::now() + Duration::from_secs(20);
    while !node.service_available("/mecheye/capture").expect("name") {
        assert!(Instant::now() < end, "the server was not discovered");
        std::thread::sleep(Duration::from_millis(20));
    }
    std::thread::sleep(Duration::from_millis(500));
    // Trigger_Request is `uint8 structure_needs_at_least_one_member`.
    let request = [0x00, 0x01, 0x00, 0x00, 0x00];
    for i in 1..=3 {
        let response = client
            .call_raw(&request, Duration::from_secs(10))
            .expect("call")
            .expect("a response within 10 s");
        let r: TriggerResponse = msgs::from_cdr(&response).expect("Trigger response CDR");
        assert!(r.success);
        assert_eq!(r.message, format!("captured {i}"));
    }
    let report = finish(peer, &out);
    let served = report["served"].as_array().expect("served");
    assert_eq!(served.len(), 3);
    for (i, s) in served.iter().enumerate() {
        assert_eq!(s["sequence"], i + 1);
        // The request on the wire: encapsulation header, 16-byte Cyclone header, the field.
        let hex = s["request_hex"].as_str().expect("hex");
        assert_eq!(&hex[..8], "00010000");
        assert_eq!(&hex[40..42], "00");
    }
}

/// Byte vector of a hex string.
fn hex(s: &str) -> Vec<u8> {
    (0..s.len() / 2)
        .map(|i| u8::from_str_radix(&s[2 * i..2 * i + 2], 16).expect("hex digit"))
        .collect()
}
