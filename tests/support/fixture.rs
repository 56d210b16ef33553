//! Interop fixtures: recordings written by rodlog for other decoders and viewers to read.
//!
//! * [`all_topics`]: one message on every topic of the registry (ARCHITECTURE.md section 3) with
//!   realistic values: small but non-trivial images, non-empty arrays, odd-length strings,
//!   float32 values that are dyadic (exact in JSON, so a decoder's value can be compared
//!   with `==`).
//! * [`rerun_set`]: colour image, depth image in `32FC1` and in `16UC1`, camera info, `/tf`
//!   and `/tf_static`, for `rerun mcap convert`.
//!
//! Shared (via `#[path]`) by `tests/interop.rs` and `examples/interop_fixture.rs`.

#![allow(dead_code)] // each includer uses a part

use std::f64::consts::{FRAC_1_SQRT_2, FRAC_PI_2};
use std::path::Path;

use anyhow::Context as _;
use msgs::Msg;
use msgs::builtin_interfaces::{Duration, Time};
use msgs::geometry_msgs::{
    Point, Pose, PoseStamped, Quaternion, Transform, TransformStamped, Vector3,
};
use msgs::nav_msgs::Path as PathMsg;
use msgs::rcl_interfaces::Log;
use msgs::rodlog_msgs::{ClampCommand, FeatureMatches, HandEyeCalibration, TaskEvent};
use msgs::rosgraph_msgs::Clock;
use msgs::sensor_msgs::{
    CameraInfo, Illuminance, Image, JointState, PointCloud2, PointField, RegionOfInterest,
};
use msgs::std_msgs::{Empty, Float64, Header, String as StringMsg};
use msgs::tf2_msgs::TfMessage;
use msgs::trajectory_msgs::{JointTrajectory, JointTrajectoryPoint};
use msgs::{Msg as M, RobotTime};
use recorder::{ChunkCompression, McapSink, MetadataRecord, SinkOptions};

/// One message of a fixture.
#[derive(Debug, Clone)]
pub struct Entry {
    /// Topic.
    pub topic: &'static str,
    /// Producer (channel metadata).
    pub producer: &'static str,
    /// Log time, ns.
    pub log_time_ns: u64,
    /// Publish time, ns.
    pub publish_time_ns: u64,
    /// The message.
    pub msg: Msg,
}

fn header(log_time_ns: u64, frame_id: &str) -> Header {
    Header {
        stamp: Time {
            sec: (log_time_ns / 1_000_000_000) as i32,
            nanosec: (log_time_ns % 1_000_000_000) as u32,
        },
        frame_id: frame_id.to_owned(),
    }
}

fn quat(x: f64, y: f64, z: f64, w: f64) -> Quaternion {
    Quaternion { x, y, z, w }
}

fn transform(parent: &str, child: &str, t_ns: u64, k: f64) -> TransformStamped {
    TransformStamped {
        header: header(t_ns, parent),
        child_frame_id: child.to_owned(),
        transform: Transform {
            translation: Vector3 {
                x: 0.1 * k,
                y: -0.05 + k * 0.01,
                z: 0.1632 + k,
            },
            rotation: quat(0.0, 0.0, (0.3 * k).sin(), (0.3 * k).cos()),
        },
    }
}

/// An `rgb8` image whose bytes depend on position and channel.
pub fn rgb_image(t_ns: u64, frame: &str, width: u32, height: u32) -> Image {
    let data = (0..height * width * 3)
        .map(|i| ((i * 37 + i / 3 * 11) % 256) as u8)
        .collect();
    Image {
        header: header(t_ns, frame),
        height,
        width,
        encoding: "rgb8".into(),
        is_bigendian: 0,
        step: width * 3,
        data,
    }
}

/// A `32FC1` depth image in metres (0.45 m plane with a ramp), little-endian floats.
pub fn depth_32fc1(t_ns: u64, width: u32, height: u32) -> Image {
    let data = (0..width * height)
        .flat_map(|i| {
            (0.45_f32 + 0.001 * (i % width) as f32 + 0.002 * (i / width) as f32).to_le_bytes()
        })
        .collect();
    Image {
        header: header(t_ns, "camera_color_optical_frame"),
        height,
        width,
        encoding: "32FC1".into(),
        is_bigendian: 0,
        step: width * 4,
        data,
    }
}

/// A `16UC1` depth image in millimetres, with a hole (0) in the corner.
pub fn depth_16uc1(t_ns: u64, width: u32, height: u32) -> Image {
    let data = (0..width * height)
        .flat_map(|i| (if i == 0 { 0_u16 } else { 450 + (i % 97) as u16 }).to_le_bytes())
        .collect();
    Image {
        header: header(t_ns, "camera_color_optical_frame"),
        height,
        width,
        encoding: "16UC1".into(),
        is_bigendian: 0,
        step: width * 2,
        data,
    }
}

/// Plumb-bob intrinsics of the wrist camera scaled to `width` x `height`.
pub fn camera_info(t_ns: u64, frame: &str, width: u32, height: u32) -> CameraInfo {
    let s = f64::from(width) / 1280.0;
    let (fx, fy, cx, cy) = (1745.31 * s, 1744.87 * s, 639.52 * s, 511.73 * s);
    CameraInfo {
        header: header(t_ns, frame),
        height,
        width,
        distortion_model: "plumb_bob".into(),
        d: vec![-0.0123, 0.0456, 0.00012, -0.00034, -0.0011],
        k: [fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0],
        r: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        p: [fx, 0.0, cx, 0.0, 0.0, fy, cy, 0.0, 0.0, 0.0, 1.0, 0.0],
        binning_x: 0,
        binning_y: 0,
        roi: RegionOfInterest {
            x_offset: 0,
            y_offset: 0,
            height: 0,
            width: 0,
            do_rectify: false,
        },
    }
}

fn pose(t_ns: u64, frame: &str, x: f64, y: f64, z: f64) -> PoseStamped {
    PoseStamped {
        header: header(t_ns, frame),
        pose: Pose {
            position: Point { x, y, z },
            orientation: quat(0.0, FRAC_1_SQRT_2, 0.0, FRAC_1_SQRT_2),
        },
    }
}

const JOINTS: [&str; 8] = [
    "lift_joint",
    "arm_shoulder_joint",
    "arm_upperarm_joint",
    "arm_forearm_joint",
    "arm_wrist1_joint",
    "arm_wrist2_joint",
    "arm_wrist3_joint",
    "clamp_joint",
];

/// A realistic message of `type_name` for `topic`.
fn sample(topic: &str, type_name: &str, t: u64) -> anyhow::Result<Msg> {
    Ok(match type_name {
        "sensor_msgs/msg/Image" if topic.contains("depth") => M::Image(depth_32fc1(t, 6, 5)),
        "sensor_msgs/msg/Image" if topic.contains("panoramic") => {
            M::Image(rgb_image(t, "panoramic_optical_frame", 9, 3))
        }
        "sensor_msgs/msg/Image" => M::Image(rgb_image(t, "camera_color_optical_frame", 7, 5)),
        "sensor_msgs/msg/CameraInfo" if topic.contains("panoramic") => {
            M::CameraInfo(camera_info(t, "panoramic_optical_frame", 9, 3))
        }
        "sensor_msgs/msg/CameraInfo" => M::CameraInfo(camera_info(t, "camera_color_optical_frame", 7, 5)),
        "sensor_msgs/msg/JointState" => M::JointState(JointState {
            header: header(t, ""),
            name: JOINTS.iter().map(|s| (*s).to_owned()).collect(),
            position: vec![1.25, 0.1, -1.2345678901234567, 2.0, -0.5, FRAC_PI_2, 0.3, 0.0125],
            velocity: vec![0.0, 0.01, -0.02, 0.03, 0.0, 0.0, 0.1, 0.0],
            effort: vec![120.5, 3.25, 8.0, 1.5, 0.25, 0.125, 0.0625, 4.0],
        }),
        "tf2_msgs/msg/TFMessage" if topic == "/tf_static" => M::TfMessage(TfMessage {
            transforms: vec![
                transform("base_link", "lift_link", t, 0.0),
                transform("arm_wrist3_link", "tool0", t, 0.5),
            ],
        }),
        "tf2_msgs/msg/TFMessage" => M::TfMessage(TfMessage {
            transforms: vec![
                transform("map", "base_link", t, 1.0),
                transform("arm_base_link", "arm_shoulder_link", t, 2.0),
                transform("tool0", "camera_color_optical_frame", t, 3.0),
            ],
        }),
        "rosgraph_msgs/msg/Clock" => M::Clock(Clock { clock: header(t, "").stamp }),
        "std_msgs/msg/String" if topic == "/robot_description" => M::String(StringMsg {
            data: "<?xml version=\"1.0\"?>\n<robot name=\"rodlog\"><link name=\"base_link\"/></robot>\n".into(),
        }),
        "std_msgs/msg/String" => M::String(StringMsg { data: "in_gripper".into() }),
        "trajectory_msgs/msg/JointTrajectory" => M::JointTrajectory(JointTrajectory {
            header: header(t, "base_link"),
            joint_names: JOINTS[1..7].iter().map(|s| (*s).to_owned()).collect(),
            points: vec![
                JointTrajectoryPoint {
                    positions: vec![0.1, -0.2, 0.3, -0.4, 0.5, -0.6],
                    velocities: vec![0.0; 6],
                    accelerations: vec![],
                    effort: vec![],
                    time_from_start: Duration { sec: 0, nanosec: 500_000_000 },
                },
                JointTrajectoryPoint {
                    positions: vec![0.15, -0.25, 0.35, -0.45, 0.55, -0.65],
                    velocities: vec![0.1, 0.1, 0.1, 0.1, 0.1, 0.1],
                    accelerations: vec![0.01; 6],
                    effort: vec![],
                    time_from_start: Duration { sec: 1, nanosec: 250_000_000 },
                },
            ],
        }),
        "nav_msgs/msg/Path" => M::Path(PathMsg {
            header: header(t, "base_link"),
            poses: vec![pose(t, "base_link", 0.5, 0.1, 1.2), pose(t, "base_link", 0.55, 0.12, 1.3)],
        }),
        "std_msgs/msg/Float64" if topic.contains("wind") => M::Float64(Float64 { data: 1.7320508075688772 }),
        "std_msgs/msg/Float64" => M::Float64(Float64 { data: 2.345 }),
        "geometry_msgs/msg/PoseStamped" => M::PoseStamped(pose(t, "base_link", 3.25, -1.5, 0.0)),
        "rodlog_msgs/msg/ClampCommand" => M::ClampCommand(ClampCommand {
            header: header(t, "tool0"),
            action: ClampCommand::CLOSE,
            max_torque_nm: 12.5,
        }),
        "std_msgs/msg/Empty" => M::Empty(Empty),
        "sensor_msgs/msg/PointCloud2" => {
            let pts: [[f32; 3]; 3] = [[0.5, 0.25, 1.75], [0.5, 0.3125, 1.75], [0.5, 0.375, 1.8125]];
            let field = |name: &str, offset| PointField {
                name: name.into(),
                offset,
                datatype: PointField::FLOAT32,
                count: 1,
            };
            M::PointCloud2(PointCloud2 {
                header: header(t, "base_link"),
                height: 1,
                width: 3,
                fields: vec![field("x", 0), field("y", 4), field("z", 8)],
                is_bigendian: false,
                point_step: 12,
                row_step: 36,
                data: pts.iter().flatten().flat_map(|v| v.to_le_bytes()).collect(),
                is_dense: true,
            })
        }
        "rodlog_msgs/msg/FeatureMatches" => M::FeatureMatches(FeatureMatches {
            header: header(t, "camera_color_optical_frame"),
            stamp_a: Time { sec: 10, nanosec: 0 },
            stamp_b: Time { sec: 11, nanosec: 500 },
            method: "orb-gms".into(),
            keypoints_a: vec![100.5, 200.25, 640.0, 512.75, 3.125, 7.5],
            keypoints_b: vec![101.5, 199.25, 641.0, 511.75, 4.125, 8.5],
            pairs: vec![0, 0, 1, 2, 2, 1],
            inlier: vec![true, false, true],
        }),
        "rodlog_msgs/msg/HandEyeCalibration" => M::HandEyeCalibration(HandEyeCalibration {
            header: header(t, "tool0"),
            child_frame_id: "camera_color_optical_frame".into(),
            tool0_from_camera: Transform {
                translation: Vector3 { x: 0.05, y: 0.02, z: -0.08 },
                rotation: quat(0.1305261922200516, 0.0, 0.0, 0.9914448613738104),
            },
            method: "ours".into(),
            mode: "rgbd".into(),
            views: 17,
            pairs: 136,
            residual_rot_deg: 0.0123,
            residual_trans_mm: 0.456,
            sigma_rot_deg: 0.01,
            sigma_trans_mm: 0.2,
            condition: 12.75,
            scale: 1.0,
        }),
        "rodlog_msgs/msg/TaskEvent" => M::TaskEvent(TaskEvent {
            header: header(t, ""),
            task: "hang".into(),
            state: "approach".into(),
            kind: TaskEvent::REFUSED,
            reason_code: "wind".into(),
            text: "wind 2.3 m/s > 2.0".into(),
        }),
        "sensor_msgs/msg/Illuminance" => M::Illuminance(Illuminance {
            header: header(t, "base_link"),
            illuminance: 412.5,
            variance: 25.0,
        }),
        "rcl_interfaces/msg/Log" => M::Log(Log {
            stamp: header(t, "").stamp,
            level: Log::WARN,
            name: "calib".into(),
            msg: "only 11 views".into(),
            file: "calib/src/stage.rs".into(),
            function: "on_message".into(),
            line: 123,
        }),
        "geometry_msgs/msg/TransformStamped" => {
            M::TransformStamped(transform("tool0", "camera_color_optical_frame", t, 0.25))
        }
        other => anyhow::bail!("no sample for {other} (topic {topic}): extend the fixture"),
    })
}

/// Producer written for `topic`, after ARCHITECTURE.md section 3's table.
fn producer(topic: &str) -> &'static str {
    match topic {
        t if t.starts_with("/sim/") => "sim",
        t if t.starts_with("/camera/color") || t.starts_with("/camera/depth") => "camera",
        t if t.starts_with("/panoramic") => "panoramic",
        "/joint_states" => "arm",
        "/tf" | "/tf_static" => "robot_state",
        "/clock" => "scheduler",
        "/robot_description" => "robot",
        "/perception/roi_cloud" | "/perception/target_pose" => "perception",
        t if t.starts_with("/calibration") => "calib",
        "/env/wind" => "anemometer",
        "/env/illuminance" => "lux",
        "/rosout" => "calib",
        _ => "task",
    }
}

/// One message on every registered topic, 10 ms apart from t = 5 s.
///
/// # Errors
/// When a registered type has no sample here.
pub fn all_topics() -> anyhow::Result<Vec<Entry>> {
    msgs::topics::registry()
        .iter()
        .enumerate()
        .map(|(i, spec)| {
            let t = 5_000_000_000 + i as u64 * 10_000_000;
            Ok(Entry {
                topic: spec.name,
                producer: producer(spec.name),
                log_time_ns: t,
                publish_time_ns: t - 1_000_000,
                msg: sample(spec.name, spec.type_name, t)?,
            })
        })
        .collect()
}

/// The set for Rerun: colour, depth `32FC1` then `16UC1`, camera info, `/tf`, `/tf_static`.
pub fn rerun_set() -> Vec<Entry> {
    let e = |topic, producer, t: u64, msg| Entry {
        topic,
        producer,
        log_time_ns: t,
        publish_time_ns: t,
        msg,
    };
    let t0 = 1_000_000_000;
    vec![
        e(
            "/tf_static",
            "robot_state",
            t0,
            sample("/tf_static", "tf2_msgs/msg/TFMessage", t0).unwrap_or(M::Empty(Empty)),
        ),
        e(
            "/tf",
            "robot_state",
            t0,
            sample("/tf", "tf2_msgs/msg/TFMessage", t0).unwrap_or(M::Empty(Empty)),
        ),
        e(
            "/camera/color/camera_info",
            "camera",
            t0,
            M::CameraInfo(camera_info(t0, "camera_color_optical_frame", 64, 48)),
        ),
        e(
            "/camera/color/image_raw",
            "camera",
            t0,
            M::Image(rgb_image(t0, "camera_color_optical_frame", 64, 48)),
        ),
        e(
            "/camera/depth/image_raw",
            "camera",
            t0,
            M::Image(depth_32fc1(t0, 64, 48)),
        ),
        e(
            "/camera/depth/image_raw",
            "camera",
            t0 + 1_000_000_000,
            M::Image(depth_16uc1(t0 + 1_000_000_000, 64, 48)),
        ),
    ]
}

/// Writes `entries` to `path` through the typed API, with the three metadata records.
///
/// # Errors
/// I/O or encoding failures.
pub fn write_mcap(
    path: &Path,
    entries: &[Entry],
    compression: ChunkCompression,
) -> anyhow::Result<()> {
    let options = SinkOptions {
        compression,
        ..SinkOptions::default()
    };
    let mut sink = McapSink::create(path, &options)?;
    sink.write_metadata(&MetadataRecord::new("robot_info").with("arm", "AUBO i10"))?;
    sink.write_metadata(
        &MetadataRecord::new("scenario")
            .with("name", "interop")
            .with("seed", 1),
    )?;
    sink.write_metadata(&MetadataRecord::new("build").with("version", env!("CARGO_PKG_VERSION")))?;
    for e in entries {
        sink.write_msg(
            e.topic,
            e.producer,
            RobotTime::from_nanos(e.log_time_ns),
            RobotTime::from_nanos(e.publish_time_ns),
            &e.msg,
        )
        .with_context(|| format!("writing {}", e.topic))?;
    }
    sink.finish()?;
    Ok(())
}

/// The message's fields as JSON (ROS field names; `uint8[]` as arrays of numbers).
///
/// # Errors
/// Serialisation failure (none expected).
pub fn fields(msg: &Msg) -> anyhow::Result<serde_json::Value> {
    use serde_json::to_value as v;
    Ok(match msg {
        M::Image(m) => v(m)?,
        M::CameraInfo(m) => v(m)?,
        M::JointState(m) => v(m)?,
        M::PointCloud2(m) => v(m)?,
        M::Illuminance(m) => v(m)?,
        M::PoseStamped(m) => v(m)?,
        M::TransformStamped(m) => v(m)?,
        M::TfMessage(m) => v(m)?,
        M::Clock(m) => v(m)?,
        M::JointTrajectory(m) => v(m)?,
        M::Path(m) => v(m)?,
        M::Log(m) => v(m)?,
        M::String(m) => v(m)?,
        M::Float64(m) => v(m)?,
        M::Empty(_) => serde_json::json!({}),
        M::ClampCommand(m) => v(m)?,
        M::FeatureMatches(m) => v(m)?,
        M::HandEyeCalibration(m) => v(m)?,
        M::TaskEvent(m) => v(m)?,
    })
}

/// The expected-values file of `check_decode.py`: entries in file order.
///
/// # Errors
/// Serialisation failure.
pub fn expected_json(entries: &[Entry]) -> anyhow::Result<serde_json::Value> {
    let list = entries
        .iter()
        .map(|e| {
            Ok(serde_json::json!({
                "topic": e.topic,
                "type": e.msg.type_name(),
                "producer": e.producer,
                "log_time_ns": e.log_time_ns,
                "publish_time_ns": e.publish_time_ns,
                "fields": fields(&e.msg)?,
            }))
        })
        .collect::<anyhow::Result<Vec<_>>>()?;
    Ok(serde_json::Value::Array(list))
}

/// Writes `all_topics.mcap` + `all_topics.expected.json` and `rerun.mcap` into `dir`.
///
/// # Errors
/// I/O or encoding failures.
pub fn write_all(dir: &Path) -> anyhow::Result<()> {
    let entries = all_topics()?;
    write_mcap(
        &dir.join("all_topics.mcap"),
        &entries,
        ChunkCompression::Lz4,
    )?;
    std::fs::write(
        dir.join("all_topics.expected.json"),
        serde_json::to_string_pretty(&expected_json(&entries)?)?,
    )?;
    write_mcap(
        &dir.join("rerun.mcap"),
        &rerun_set(),
        ChunkCompression::Zstd,
    )?;
    Ok(())
}
