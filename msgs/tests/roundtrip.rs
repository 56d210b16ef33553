//! Round trip of every message type through `to_cdr`/`from_cdr` and `Msg::encode`/`decode`.

// Wall-clock timings and hashed sets of a test, bench or example: not a stage, so the
// crate's determinism lints do not apply here.
#![allow(clippy::disallowed_methods, clippy::disallowed_types)]

mod common;

use msgs::builtin_interfaces::{Duration, Time};
use msgs::geometry_msgs::{Point, Pose, Quaternion, Transform, Vector3};
use msgs::sensor_msgs::{PointField, RegionOfInterest};
use msgs::std_msgs::Header;
use msgs::trajectory_msgs::JointTrajectoryPoint;
use msgs::{Msg, MsgPayload, RosMessage, from_cdr, to_cdr, to_cdr_into};

fn roundtrip<T: RosMessage>(value: &T) {
    let bytes = to_cdr(value).expect("encode");
    assert_eq!(&bytes[..4], &[0, 1, 0, 0], "{}: LE header", T::TYPE_NAME);
    let back: T = from_cdr(&bytes).expect("decode");
    assert_eq!(&back, value, "{}", T::TYPE_NAME);
}

#[test]
fn every_msg_variant_roundtrips_through_cdr_and_msg() {
    let samples = common::samples();
    assert_eq!(
        samples.len(),
        Msg::TYPE_NAMES.len(),
        "one sample per variant"
    );
    let mut seen: Vec<&str> = Vec::new();
    let mut buf = Vec::new();
    for msg in &samples {
        let bytes = msg.encode().expect("encode");
        msg.encode_into(&mut buf).expect("encode_into");
        assert_eq!(bytes, buf, "{}", msg.type_name());
        let back = Msg::decode(msg.type_name(), &bytes).expect("decode");
        assert_eq!(&back, msg, "{}", msg.type_name());
        // The short form pkg/Type is accepted too.
        let short = msg.type_name().replace("/msg/", "/");
        assert_eq!(&Msg::decode(&short, &bytes).expect("decode short"), msg);
        seen.push(msg.type_name());
    }
    seen.sort_unstable();
    seen.dedup();
    assert_eq!(seen.len(), Msg::TYPE_NAMES.len(), "all variants distinct");
}

#[test]
fn every_top_level_struct_roundtrips_through_to_cdr() {
    fn check<T: MsgPayload>(msg: &Msg) -> bool {
        match msg.get::<T>() {
            Some(v) => {
                roundtrip(v);
                true
            }
            None => false,
        }
    }
    use msgs::geometry_msgs::{PoseStamped, TransformStamped};
    use msgs::nav_msgs::Path;
    use msgs::rcl_interfaces::Log;
    use msgs::rodlog_msgs::{ClampCommand, FeatureMatches, HandEyeCalibration, TaskEvent};
    use msgs::rosgraph_msgs::Clock;
    use msgs::sensor_msgs::{CameraInfo, Illuminance, Image, JointState, PointCloud2};
    use msgs::std_msgs::{Empty, Float64, String as StringMsg};
    use msgs::tf2_msgs::TfMessage;
    use msgs::trajectory_msgs::JointTrajectory;
    for msg in &common::samples() {
        let hit = check::<Image>(msg)
            || check::<CameraInfo>(msg)
            || check::<JointState>(msg)
            || check::<PointCloud2>(msg)
            || check::<Illuminance>(msg)
            || check::<PoseStamped>(msg)
            || check::<TransformStamped>(msg)
            || check::<TfMessage>(msg)
            || check::<Clock>(msg)
            || check::<JointTrajectory>(msg)
            || check::<Path>(msg)
            || check::<Log>(msg)
            || check::<StringMsg>(msg)
            || check::<Float64>(msg)
            || check::<Empty>(msg)
            || check::<ClampCommand>(msg)
            || check::<FeatureMatches>(msg)
            || check::<HandEyeCalibration>(msg)
            || check::<TaskEvent>(msg);
        assert!(hit, "{} not covered", msg.type_name());
    }
}

#[test]
fn nested_types_roundtrip() {
    roundtrip(&Time {
        sec: -2,
        nanosec: 300_000_000,
    });
    roundtrip(&Duration {
        sec: 7,
        nanosec: 999_999_999,
    });
    roundtrip(&common::header(42));
    roundtrip(&Header::default());
    roundtrip(&Vector3 {
        x: 1.0,
        y: -0.0,
        z: f64::MAX,
    });
    roundtrip(&Quaternion::IDENTITY);
    roundtrip(&Point {
        x: f64::MIN_POSITIVE,
        y: 2.0,
        z: 3.0,
    });
    roundtrip(&Pose::default());
    roundtrip(&Transform::default());
    roundtrip(&RegionOfInterest {
        x_offset: 1,
        y_offset: 2,
        height: 3,
        width: 4,
        do_rectify: true,
    });
    roundtrip(&PointField {
        name: "rgb".into(),
        offset: 16,
        datatype: PointField::UINT32,
        count: 1,
    });
    roundtrip(&JointTrajectoryPoint::default());
}

#[test]
fn default_quaternion_is_identity() {
    assert_eq!(Quaternion::default().w, 1.0);
    assert_eq!(Transform::default().rotation, Quaternion::IDENTITY);
}

#[test]
fn to_cdr_into_reuses_and_clears_the_buffer() {
    let mut buf = vec![0xAA; 100];
    to_cdr_into(&common::header(1), &mut buf).expect("encode");
    assert_eq!(buf, to_cdr(&common::header(1)).expect("encode"));
}

#[test]
fn unknown_type_is_a_clear_error() {
    let err = Msg::decode("foo_msgs/msg/Bar", &[0, 1, 0, 0]).expect_err("unknown type");
    assert!(err.to_string().contains("foo_msgs/msg/Bar"), "{err}");
    assert!(Msg::schema_text("foo_msgs/msg/Bar").is_none());
}

#[test]
fn decode_with_wrong_type_fails() {
    // A Float64 payload decoded as a JointState: the sequence counts are garbage.
    let bytes = Msg::from(msgs::std_msgs::Float64 { data: 1.0 })
        .encode()
        .expect("encode");
    assert!(Msg::decode("sensor_msgs/msg/JointState", &bytes).is_err());
}

#[test]
fn big_image_uses_the_bytes_fast_path() {
    // 1280x1024 rgb8, the routine wrist-camera size; check size and content survive.
    let mut img = common::image();
    img.width = 1280;
    img.height = 1024;
    img.step = 1280 * 3;
    img.data = (0..1280 * 1024 * 3).map(|i| (i % 251) as u8).collect();
    let t0 = std::time::Instant::now();
    let bytes = to_cdr(&img).expect("encode");
    let back: msgs::sensor_msgs::Image = from_cdr(&bytes).expect("decode");
    let elapsed = t0.elapsed();
    assert_eq!(back, img);
    // Payload offsets: stamp 0..8, frame_id "abc" 8..16 (len 4 + 4), height/width 16..24,
    // encoding "rgb8" 24..33 (len 4 + 5), is_bigendian 33..34, pad 34..36, step 36..40,
    // data count 40..44, then the pixels; plus the 4-byte encapsulation header.
    assert_eq!(bytes.len(), 4 + 44 + img.data.len());
    println!("3.9 MB image encode+decode: {elapsed:?}");
}

#[test]
fn stamps_and_typed_access() {
    for msg in common::samples() {
        match msg.type_name() {
            "std_msgs/msg/String" | "std_msgs/msg/Float64" | "std_msgs/msg/Empty" => {
                assert_eq!(msg.stamp(), None)
            }
            name => assert!(msg.stamp().is_some(), "{name} has a stamp"),
        }
    }
    let msg = Msg::from(common::joint_state());
    assert_eq!(
        msg.get::<msgs::sensor_msgs::JointState>(),
        Some(&common::joint_state())
    );
    assert!(msg.get::<msgs::sensor_msgs::Image>().is_none());
    assert_eq!(msg.stamp(), Some(common::header(3).stamp));
}

#[test]
fn public_types_are_thread_safe_and_traits_object_safe() {
    fn send_sync<T: Send + Sync + 'static>() {}
    send_sync::<Msg>();
    send_sync::<msgs::CdrError>();
    send_sync::<msgs::DecodeError>();
    send_sync::<msgs::StageError>();
    send_sync::<msgs::DriverError>();
    send_sync::<msgs::DriverOutput>();
    // Each trait must be usable as `dyn` (the runner holds `Box<dyn Stage>` etc.).
    let _: Option<Box<dyn msgs::Stage>> = None;
    let _: Option<Box<dyn msgs::World>> = None;
    let _: Option<Box<dyn msgs::CameraDriver>> = None;
    let _: Option<Box<dyn msgs::ArmDriver>> = None;
    let _: Option<Box<dyn msgs::LiftDriver>> = None;
    let _: Option<Box<dyn msgs::BaseDriver>> = None;
    let _: Option<Box<dyn msgs::ClampDriver>> = None;
    let _: Option<Box<dyn msgs::EnvironmentSensors>> = None;
}
