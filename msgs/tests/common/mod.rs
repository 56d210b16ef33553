//! Sample messages shared by the integration tests: every `Msg` variant with non-empty
//! arrays and odd-length strings in front of 8-byte fields (alignment padding exercised).
#![allow(dead_code)] // each test binary uses a different subset

use msgs::builtin_interfaces::{Duration, Time};
use msgs::geometry_msgs::{
    Point, Pose, PoseStamped, Quaternion, Transform, TransformStamped, Vector3,
};
use msgs::nav_msgs::Path;
use msgs::rcl_interfaces::Log;
use msgs::rodlog_msgs::{ClampCommand, FeatureMatches, HandEyeCalibration, TaskEvent};
use msgs::rosgraph_msgs::Clock;
use msgs::sensor_msgs::{
    CameraInfo, Illuminance, Image, JointState, PointCloud2, PointField, RegionOfInterest,
};
use msgs::std_msgs::{Empty, Float64, Header, String as StringMsg};
use msgs::tf2_msgs::TfMessage;
use msgs::trajectory_msgs::{JointTrajectory, JointTrajectoryPoint};
use msgs::{Msg, frames};

/// A header whose frame_id has odd length 3 (string ends at a non-multiple of 4/8).
pub fn header(sec: i32) -> Header {
    Header {
        stamp: Time {
            sec,
            nanosec: 123_456_789,
        },
        frame_id: "abc".to_string(),
    }
}

pub fn transform_stamped(i: i32) -> TransformStamped {
    TransformStamped {
        header: header(10 + i),
        child_frame_id: "x".repeat(1 + i as usize),
        transform: Transform {
            translation: Vector3 {
                x: 0.05,
                y: 0.02 * f64::from(i),
                z: -0.08,
            },
            rotation: Quaternion {
                x: 0.1,
                y: -0.2,
                z: 0.3,
                w: 0.927_361_849_549_570_4,
            },
        },
    }
}

pub fn pose_stamped(i: i32) -> PoseStamped {
    PoseStamped {
        header: Header {
            stamp: Time { sec: i, nanosec: 7 },
            frame_id: frames::BASE_LINK.to_string(),
        },
        pose: Pose {
            position: Point {
                x: 1.5,
                y: -2.25,
                z: f64::from(i),
            },
            orientation: Quaternion::IDENTITY,
        },
    }
}

pub fn image() -> Image {
    let (width, height) = (5u32, 3u32);
    let step = width * 3;
    Image {
        header: header(1),
        height,
        width,
        encoding: "rgb8".to_string(),
        is_bigendian: 0,
        step,
        data: (0..step * height).map(|v| (v * 7 % 256) as u8).collect(),
    }
}

pub fn camera_info() -> CameraInfo {
    CameraInfo {
        header: header(2),
        height: 1024,
        width: 1280,
        distortion_model: "plumb_bob".to_string(),
        d: vec![-0.01, 0.02, 0.0001, -0.0002, 0.003],
        k: [1745.0, 0.0, 640.5, 0.0, 1745.5, 512.25, 0.0, 0.0, 1.0],
        r: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        p: [
            1745.0, 0.0, 640.5, 0.0, 0.0, 1745.5, 512.25, 0.0, 0.0, 0.0, 1.0, 0.0,
        ],
        binning_x: 1,
        binning_y: 2,
        roi: RegionOfInterest {
            x_offset: 3,
            y_offset: 4,
            height: 5,
            width: 6,
            do_rectify: true,
        },
    }
}

pub fn joint_state() -> JointState {
    JointState {
        header: header(3),
        name: frames::JOINT_NAMES.iter().map(|s| s.to_string()).collect(),
        position: (0..8).map(|i| f64::from(i) * 0.1 - 0.3).collect(),
        velocity: vec![0.5; 8],
        effort: vec![],
    }
}

pub fn point_cloud2() -> PointCloud2 {
    let names = ["x", "y", "z"];
    PointCloud2 {
        header: header(4),
        height: 1,
        width: 2,
        fields: names
            .iter()
            .enumerate()
            .map(|(i, n)| PointField {
                name: n.to_string(),
                offset: 4 * i as u32,
                datatype: PointField::FLOAT32,
                count: 1,
            })
            .collect(),
        is_bigendian: false,
        point_step: 12,
        row_step: 24,
        data: [1.0f32, 2.0, 3.0, -4.0, 5.5, 6.25]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect(),
        is_dense: true,
    }
}

pub fn samples() -> Vec<Msg> {
    vec![
        image().into(),
        camera_info().into(),
        joint_state().into(),
        point_cloud2().into(),
        Illuminance {
            header: header(5),
            illuminance: 412.5,
            variance: 3.0,
        }
        .into(),
        pose_stamped(6).into(),
        transform_stamped(1).into(),
        TfMessage {
            transforms: vec![transform_stamped(0), transform_stamped(2)],
        }
        .into(),
        Clock {
            clock: Time {
                sec: 12,
                nanosec: 500_000_000,
            },
        }
        .into(),
        JointTrajectory {
            header: header(7),
            joint_names: frames::ARM_JOINT_NAMES
                .iter()
                .map(|s| s.to_string())
                .collect(),
            points: vec![
                JointTrajectoryPoint {
                    positions: vec![0.0, -0.5, 1.0, 0.25, 1.5, -3.0],
                    velocities: vec![0.1; 6],
                    accelerations: vec![],
                    effort: vec![],
                    time_from_start: Duration { sec: 0, nanosec: 0 },
                },
                JointTrajectoryPoint {
                    positions: vec![0.1, -0.4, 1.1, 0.35, 1.6, -2.9],
                    velocities: vec![],
                    accelerations: vec![0.01; 6],
                    effort: vec![1.0],
                    time_from_start: Duration {
                        sec: 2,
                        nanosec: 250_000_000,
                    },
                },
            ],
        }
        .into(),
        Path {
            header: header(8),
            poses: vec![pose_stamped(1), pose_stamped(2), pose_stamped(3)],
        }
        .into(),
        Log {
            stamp: Time { sec: 9, nanosec: 1 },
            level: Log::WARN,
            name: "calib".to_string(),
            msg: "mount moved: 1.2 deg, 4.5 mm".to_string(),
            file: "calib/src/stage.rs".to_string(),
            function: "on_message".to_string(),
            line: 123,
        }
        .into(),
        StringMsg {
            data: "<robot name=\"rodlog\"/>".to_string(),
        }
        .into(),
        Float64 { data: 1.875 }.into(),
        Empty.into(),
        ClampCommand {
            header: header(10),
            action: ClampCommand::CLOSE,
            max_torque_nm: 4.5,
        }
        .into(),
        FeatureMatches {
            header: header(11),
            stamp_a: Time { sec: 1, nanosec: 2 },
            stamp_b: Time { sec: 3, nanosec: 4 },
            method: "orb-gms".to_string(),
            keypoints_a: vec![1.5, 2.5, 100.25, 200.75, 3.0],
            keypoints_b: vec![1.0, 2.0, 101.0],
            pairs: vec![0, 1, 2, 0],
            inlier: vec![true, false],
        }
        .into(),
        HandEyeCalibration {
            header: header(12),
            child_frame_id: frames::CAMERA_COLOR_OPTICAL_FRAME.to_string(),
            tool0_from_camera: transform_stamped(3).transform,
            method: "ours".to_string(),
            mode: "rgbd".to_string(),
            views: 18,
            pairs: 153,
            residual_rot_deg: 0.05,
            residual_trans_mm: 0.4,
            sigma_rot_deg: 0.01,
            sigma_trans_mm: 0.1,
            condition: 3.5,
            scale: 1.0,
        }
        .into(),
        TaskEvent {
            header: header(13),
            task: "hang".to_string(),
            state: "approach".to_string(),
            kind: TaskEvent::REFUSED,
            reason_code: "wind_above_limit".to_string(),
            text: "wind 2.4 m/s > 2.0 m/s".to_string(),
        }
        .into(),
    ]
}
