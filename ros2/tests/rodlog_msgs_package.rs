//! The `rodlog_msgs` ROS 2 package (`ros2/rodlog_msgs/`): its `.msg` files are exactly the
//! schemas rodlog records (`msgs::schema`), its build files name every message and dependency,
//! and an independent ROS 2 `.msg` parser and CDR decoder (`rosbags`, in the reference venv)
//! reads rodlog's CDR of each message back to the same field values.

use std::path::PathBuf;
use std::process::{Command, Stdio};

use msgs::Msg;
use msgs::builtin_interfaces::Time;
use msgs::geometry_msgs::{Quaternion, Transform, Vector3};
use msgs::rodlog_msgs::{ClampCommand, FeatureMatches, HandEyeCalibration, TaskEvent};
use msgs::schema::{CLAMP_COMMAND, FEATURE_MATCHES, HAND_EYE_CALIBRATION, MsgDef, TASK_EVENT};
use msgs::std_msgs::Header;
use serde_json::Value;

const DEFS: [(&str, &MsgDef); 4] = [
    ("ClampCommand", &CLAMP_COMMAND),
    ("FeatureMatches", &FEATURE_MATCHES),
    ("HandEyeCalibration", &HAND_EYE_CALIBRATION),
    ("TaskEvent", &TASK_EVENT),
];

fn package() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("rodlog_msgs")
}

#[test]
fn msg_files_are_the_recorded_schemas() -> Result<(), Box<dyn std::error::Error>> {
    let mut on_disk: Vec<String> = std::fs::read_dir(package().join("msg"))?
        .filter_map(Result::ok)
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    on_disk.sort();
    let expected: Vec<String> = DEFS.iter().map(|(n, _)| format!("{n}.msg")).collect();
    assert_eq!(
        on_disk, expected,
        "msg/ holds other files than the four messages"
    );
    for (name, def) in DEFS {
        let text = std::fs::read_to_string(package().join("msg").join(format!("{name}.msg")))?;
        assert_eq!(text, def.text, "{name}.msg differs from msgs::schema");
        assert_eq!(def.name, format!("rodlog_msgs/{name}"));
    }
    Ok(())
}

#[test]
fn build_files_name_every_message_and_dependency() -> Result<(), Box<dyn std::error::Error>> {
    let cmake = std::fs::read_to_string(package().join("CMakeLists.txt"))?;
    let xml = std::fs::read_to_string(package().join("package.xml"))?;
    assert!(cmake.contains("project(rodlog_msgs)"));
    assert!(cmake.contains("rosidl_generate_interfaces(${PROJECT_NAME}"));
    assert!(xml.contains("<name>rodlog_msgs</name>"));
    assert!(xml.contains("<member_of_group>rosidl_interface_packages</member_of_group>"));
    for (name, def) in DEFS {
        assert!(
            cmake.contains(&format!("\"msg/{name}.msg\"")),
            "{name} not generated"
        );
        for dep in def.deps {
            let pkg = dep.name.split('/').next().unwrap_or_default();
            assert!(
                cmake.contains(&format!("find_package({pkg} REQUIRED)"))
                    && cmake.contains(&format!(" {pkg}"))
                    && xml.contains(&format!("<depend>{pkg}</depend>")),
                "{name} needs {pkg}"
            );
        }
    }
    Ok(())
}

fn header() -> Header {
    Header {
        stamp: Time {
            sec: 12,
            nanosec: 345_000_000,
        },
        frame_id: "tool0".into(),
    }
}

fn samples() -> Vec<(&'static str, Msg)> {
    vec![
        (
            "ClampCommand",
            Msg::ClampCommand(ClampCommand {
                header: header(),
                action: ClampCommand::CLOSE,
                max_torque_nm: 6.5,
            }),
        ),
        (
            "FeatureMatches",
            Msg::FeatureMatches(FeatureMatches {
                header: header(),
                stamp_a: Time { sec: 3, nanosec: 5 },
                stamp_b: Time { sec: 4, nanosec: 6 },
                method: "orb-gms".into(),
                keypoints_a: vec![1.5, -2.25, 640.0, 0.125],
                keypoints_b: vec![3.0, 4.5],
                pairs: vec![0, 1, 1, 0],
                inlier: vec![true, false],
            }),
        ),
        (
            "HandEyeCalibration",
            Msg::HandEyeCalibration(HandEyeCalibration {
                header: header(),
                child_frame_id: "camera_color_optical_frame".into(),
                tool0_from_camera: Transform {
                    translation: Vector3 {
                        x: 0.06,
                        y: -0.035,
                        z: 0.04,
                    },
                    rotation: Quaternion {
                        x: 0.0,
                        y: 0.0,
                        z: std::f64::consts::FRAC_1_SQRT_2,
                        w: std::f64::consts::FRAC_1_SQRT_2,
                    },
                },
                method: "ours".into(),
                mode: "rgbd".into(),
                views: 18,
                pairs: 153,
                residual_rot_deg: 0.05,
                residual_trans_mm: 0.4,
                sigma_rot_deg: 0.01,
                sigma_trans_mm: 0.2,
                condition: 3.5,
                scale: 1.0,
            }),
        ),
        (
            "TaskEvent",
            Msg::TaskEvent(TaskEvent {
                header: header(),
                task: "hang".into(),
                state: "hook".into(),
                kind: TaskEvent::DONE,
                reason_code: "ok".into(),
                text: "clamped on the wire".into(),
            }),
        ),
    ]
}

/// Registers the package's `.msg` files with rosbags, decodes each hex CDR line of stdin as
/// its type and prints the values as JSON (dataclasses as objects, arrays as lists).
const DECODE: &str = r#"
import json, os, sys
from rosbags.typesys import get_types_from_msg, get_typestore, Stores
ts = get_typestore(Stores.ROS2_JAZZY)
pkg = sys.argv[1]
for f in sorted(os.listdir(os.path.join(pkg, "msg"))):
    ts.register(get_types_from_msg(open(os.path.join(pkg, "msg", f)).read(), "rodlog_msgs/msg/" + f[:-4]))
def plain(v):
    if hasattr(v, "__dataclass_fields__"):
        return {k: plain(getattr(v, k)) for k in v.__dataclass_fields__ if k != "__msgtype__" and not k.isupper()}
    if hasattr(v, "tolist"):
        return v.tolist()
    if isinstance(v, list):
        return [plain(x) for x in v]
    return v
out = []
for line in sys.stdin:
    name, hexcdr = line.split()
    out.append(plain(ts.deserialize_cdr(bytes.fromhex(hexcdr), "rodlog_msgs/msg/" + name)))
print(json.dumps(out))
"#;

#[test]
fn an_independent_ros2_decoder_reads_rodlogs_cdr_through_the_msg_files()
-> Result<(), Box<dyn std::error::Error>> {
    let Some(python) = testkit::venv_python_with(
        "rosbags",
        "an_independent_ros2_decoder_reads_rodlogs_cdr_through_the_msg_files",
    ) else {
        return Ok(());
    };
    let samples = samples();
    let mut input = String::new();
    for (name, msg) in &samples {
        let cdr = msg.encode()?;
        let hex: String = cdr.iter().map(|b| format!("{b:02x}")).collect();
        input.push_str(&format!("{name} {hex}\n"));
    }
    let mut child = Command::new(python)
        .args(["-c", DECODE])
        .arg(package())
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()?;
    {
        use std::io::Write as _;
        let mut stdin = child.stdin.take().ok_or("no stdin")?;
        stdin.write_all(input.as_bytes())?;
    }
    let out = child.wait_with_output()?;
    assert!(out.status.success(), "rosbags failed: {}", out.status);
    let decoded: Vec<Value> = serde_json::from_slice(&out.stdout)?;
    assert_eq!(decoded.len(), samples.len());
    for ((name, msg), got) in samples.iter().zip(&decoded) {
        let want = match msg {
            Msg::ClampCommand(m) => serde_json::to_value(m)?,
            Msg::FeatureMatches(m) => serde_json::to_value(m)?,
            Msg::HandEyeCalibration(m) => serde_json::to_value(m)?,
            Msg::TaskEvent(m) => serde_json::to_value(m)?,
            _ => return Err("unexpected sample".into()),
        };
        assert_eq!(got, &want, "{name}: rosbags decoded other values");
    }
    Ok(())
}
