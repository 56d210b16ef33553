//! Topic names of ARCHITECTURE.md section 3 and their registry (type, latching, QoS YAML).
//!
//! `offered_qos_profiles` is the channel-metadata value the MCAP ros2 profile requires, in
//! the YAML form rosbag2 (Jazzy, metadata version 9) writes: a list with one profile per
//! publisher, policies as strings, durations as `{sec, nsec}` with
//! `RMW_DURATION_INFINITE = {sec: 9223372036, nsec: 854775807}`.

use crate::schema::RosMessage;
use crate::{geometry_msgs, nav_msgs, rcl_interfaces, rodlog_msgs, rosgraph_msgs};
use crate::{sensor_msgs, std_msgs, tf2_msgs, trajectory_msgs};

/// Wrist camera colour image (`rgb8`).
pub const CAMERA_COLOR_IMAGE: &str = "/camera/color/image_raw";
/// Wrist camera registered depth (`32FC1` m or `16UC1` mm).
pub const CAMERA_DEPTH_IMAGE: &str = "/camera/depth/image_raw";
/// Wrist camera intrinsics.
pub const CAMERA_COLOR_INFO: &str = "/camera/color/camera_info";
/// Panoramic (base) camera image.
pub const PANORAMIC_IMAGE: &str = "/panoramic/image_raw";
/// Panoramic camera intrinsics.
pub const PANORAMIC_INFO: &str = "/panoramic/camera_info";
/// Joint states of arm, lift and clamp.
pub const JOINT_STATES: &str = "/joint_states";
/// Dynamic transforms.
pub const TF: &str = "/tf";
/// Static transforms (latched).
pub const TF_STATIC: &str = "/tf_static";
/// Robot clock, every 100 ms.
pub const CLOCK: &str = "/clock";
/// URDF (latched).
pub const ROBOT_DESCRIPTION: &str = "/robot_description";
/// Arm trajectory command.
pub const ARM_JOINT_TRAJECTORY: &str = "/arm/joint_trajectory";
/// Planned tool0 path in `base_link`, for the viewer.
pub const ARM_PLANNED_PATH: &str = "/arm/planned_path";
/// Lift height command (m).
pub const LIFT_COMMAND: &str = "/lift/command";
/// Base goal pose.
pub const BASE_GOAL: &str = "/base/goal";
/// Clamp command.
pub const CLAMP_COMMAND: &str = "/clamp/command";
/// Wrist camera capture request.
pub const CAMERA_TRIGGER: &str = "/camera/trigger";
/// Wrist light command: brightness 0..1 (std_msgs/Float64; 0 = off).
pub const WRIST_LIGHT_COMMAND: &str = "/wrist_light/command";
/// Wrist light state: the brightness it gives, 0..1 (std_msgs/Float64), from its driver; a
/// robot without the light publishes none.
pub const WRIST_LIGHT_STATE: &str = "/wrist_light/state";
/// Region-of-interest point cloud (wire or handle).
pub const PERCEPTION_ROI_CLOUD: &str = "/perception/roi_cloud";
/// Hanging point or handle pose in `base_link`.
pub const PERCEPTION_TARGET_POSE: &str = "/perception/target_pose";
/// Feature matches, for the viewer.
pub const CALIBRATION_MATCHES: &str = "/calibration/matches";
/// Hand-eye calibration results.
pub const CALIBRATION_HAND_EYE: &str = "/calibration/hand_eye";
/// The drift check's reference (geometry_msgs/TransformStamped, `tool0 ->
/// camera_color_optical_frame`): after a check that found the camera edge in use consistent,
/// the `X` its views support at the check poses, which later checks at those poses compare
/// with (`rodlog calib carry` carries it to the next run). A project topic beside
/// ARCHITECTURE.md section 3's.
pub const CALIBRATION_CHECK_REFERENCE: &str = "/calibration/check_reference";
/// Requests to the calibration stage (std_msgs/String): `check` (the next captures are drift
/// check views), `collect` (the next captures are calibration views), `solve` (check or
/// calibrate the batch now), `cancel`. The stage answers on [`TASK_EVENT`] (task
/// `calibration`). A project topic beside ARCHITECTURE.md section 3's: the task stages' seam to
/// self-maintenance.
pub const CALIBRATION_COMMAND: &str = "/calibration/command";
/// Task and safety events.
pub const TASK_EVENT: &str = "/task/event";
/// Wind speed, 3-s mean (m/s), as measured by the anemometer.
pub const ENV_WIND: &str = "/env/wind";
/// Illuminance as measured by the lux sensor.
pub const ENV_ILLUMINANCE: &str = "/env/illuminance";
/// Log lines of every stage and driver.
pub const ROSOUT: &str = "/rosout";
/// Simulator truth: `tool0_from_camera`.
pub const SIM_CAMERA_MOUNT: &str = "/sim/camera_mount";
/// Simulator truth: the wrist camera's true intrinsics (the published `camera_info` is a
/// calibration of them, with a calibration's error).
pub const SIM_CAMERA_INFO: &str = "/sim/camera_info";
/// Simulator truth: the panoramic camera's true intrinsics.
pub const SIM_PANORAMIC_INFO: &str = "/sim/panoramic/camera_info";
/// Simulator truth: wire hanging-point pose.
pub const SIM_WIRE_POSE: &str = "/sim/wire_pose";
/// Simulator truth: clamp handle pose.
pub const SIM_HANDLE_POSE: &str = "/sim/handle_pose";
/// Simulator truth: wind (m/s, 3-s mean).
pub const SIM_WIND: &str = "/sim/wind";
/// Simulator truth: illuminance.
pub const SIM_ILLUMINANCE: &str = "/sim/illuminance";
/// Simulator truth: rod state (`on_rack`, `in_gripper`, `hooked`, `clamped`, `dropped`).
pub const SIM_ROD_STATE: &str = "/sim/rod_state";
/// Simulator truth: `map_from_base_link` of the base (odometry drifts; this does not).
pub const SIM_BASE_POSE: &str = "/sim/base_pose";

/// Topics that command the robot: stage outputs delivered to the world's drivers (the
/// simulator, or the ROS 2 graph behind `--allow-motion`), ARCHITECTURE.md section 3.
pub const COMMANDS: [&str; 6] = [
    ARM_JOINT_TRAJECTORY,
    LIFT_COMMAND,
    BASE_GOAL,
    CLAMP_COMMAND,
    CAMERA_TRIGGER,
    WRIST_LIGHT_COMMAND,
];

/// Whether `topic` commands the robot ([`COMMANDS`]).
pub fn is_command(topic: &str) -> bool {
    COMMANDS.contains(&topic)
}

/// Prefix of simulator ground-truth topics (never an input to calibration, perception or
/// control).
pub const SIM_PREFIX: &str = "/sim/";

/// QoS of ordinary topics: reliable, volatile, keep last 10 (rclcpp's default publisher).
pub const QOS_VOLATILE_YAML: &str = "- history: keep_last
  depth: 10
  reliability: reliable
  durability: volatile
  deadline:
    sec: 9223372036
    nsec: 854775807
  lifespan:
    sec: 9223372036
    nsec: 854775807
  liveliness: automatic
  liveliness_lease_duration:
    sec: 9223372036
    nsec: 854775807
  avoid_ros_namespace_conventions: false
";

/// QoS of latched topics: reliable, transient local, keep last 1 (tf2's static broadcaster).
pub const QOS_LATCHED_YAML: &str = "- history: keep_last
  depth: 1
  reliability: reliable
  durability: transient_local
  deadline:
    sec: 9223372036
    nsec: 854775807
  lifespan:
    sec: 9223372036
    nsec: 854775807
  liveliness: automatic
  liveliness_lease_duration:
    sec: 9223372036
    nsec: 854775807
  avoid_ros_namespace_conventions: false
";

/// One topic of the log vocabulary.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TopicSpec {
    /// Topic name.
    pub name: &'static str,
    /// Full ROS type name (`pkg/msg/Type`).
    pub type_name: &'static str,
    /// Transient local: replay from `--start` first feeds the latest earlier message.
    pub latched: bool,
    /// `offered_qos_profiles` channel metadata (YAML).
    pub offered_qos_profiles: &'static str,
}

const fn spec(name: &'static str, type_name: &'static str, latched: bool) -> TopicSpec {
    TopicSpec {
        name,
        type_name,
        latched,
        offered_qos_profiles: if latched {
            QOS_LATCHED_YAML
        } else {
            QOS_VOLATILE_YAML
        },
    }
}

static REGISTRY: &[TopicSpec] = &[
    spec(CAMERA_COLOR_IMAGE, sensor_msgs::Image::TYPE_NAME, false),
    spec(CAMERA_DEPTH_IMAGE, sensor_msgs::Image::TYPE_NAME, false),
    spec(CAMERA_COLOR_INFO, sensor_msgs::CameraInfo::TYPE_NAME, true),
    spec(PANORAMIC_IMAGE, sensor_msgs::Image::TYPE_NAME, false),
    spec(PANORAMIC_INFO, sensor_msgs::CameraInfo::TYPE_NAME, true),
    spec(JOINT_STATES, sensor_msgs::JointState::TYPE_NAME, false),
    spec(TF, tf2_msgs::TfMessage::TYPE_NAME, false),
    spec(TF_STATIC, tf2_msgs::TfMessage::TYPE_NAME, true),
    spec(CLOCK, rosgraph_msgs::Clock::TYPE_NAME, false),
    spec(ROBOT_DESCRIPTION, std_msgs::String::TYPE_NAME, true),
    spec(
        ARM_JOINT_TRAJECTORY,
        trajectory_msgs::JointTrajectory::TYPE_NAME,
        false,
    ),
    spec(ARM_PLANNED_PATH, nav_msgs::Path::TYPE_NAME, false),
    spec(LIFT_COMMAND, std_msgs::Float64::TYPE_NAME, false),
    spec(BASE_GOAL, geometry_msgs::PoseStamped::TYPE_NAME, false),
    spec(CLAMP_COMMAND, rodlog_msgs::ClampCommand::TYPE_NAME, false),
    spec(CAMERA_TRIGGER, std_msgs::Empty::TYPE_NAME, false),
    spec(WRIST_LIGHT_COMMAND, std_msgs::Float64::TYPE_NAME, false),
    spec(WRIST_LIGHT_STATE, std_msgs::Float64::TYPE_NAME, false),
    spec(
        PERCEPTION_ROI_CLOUD,
        sensor_msgs::PointCloud2::TYPE_NAME,
        false,
    ),
    spec(
        PERCEPTION_TARGET_POSE,
        geometry_msgs::PoseStamped::TYPE_NAME,
        false,
    ),
    spec(
        CALIBRATION_MATCHES,
        rodlog_msgs::FeatureMatches::TYPE_NAME,
        false,
    ),
    spec(
        CALIBRATION_HAND_EYE,
        rodlog_msgs::HandEyeCalibration::TYPE_NAME,
        false,
    ),
    spec(
        CALIBRATION_CHECK_REFERENCE,
        geometry_msgs::TransformStamped::TYPE_NAME,
        false,
    ),
    spec(CALIBRATION_COMMAND, std_msgs::String::TYPE_NAME, false),
    spec(TASK_EVENT, rodlog_msgs::TaskEvent::TYPE_NAME, false),
    spec(ENV_WIND, std_msgs::Float64::TYPE_NAME, false),
    spec(ENV_ILLUMINANCE, sensor_msgs::Illuminance::TYPE_NAME, false),
    spec(ROSOUT, rcl_interfaces::Log::TYPE_NAME, false),
    spec(
        SIM_CAMERA_MOUNT,
        geometry_msgs::TransformStamped::TYPE_NAME,
        false,
    ),
    spec(SIM_CAMERA_INFO, sensor_msgs::CameraInfo::TYPE_NAME, false),
    spec(
        SIM_PANORAMIC_INFO,
        sensor_msgs::CameraInfo::TYPE_NAME,
        false,
    ),
    spec(SIM_WIRE_POSE, geometry_msgs::PoseStamped::TYPE_NAME, false),
    spec(
        SIM_HANDLE_POSE,
        geometry_msgs::PoseStamped::TYPE_NAME,
        false,
    ),
    spec(SIM_WIND, std_msgs::Float64::TYPE_NAME, false),
    spec(SIM_ILLUMINANCE, sensor_msgs::Illuminance::TYPE_NAME, false),
    spec(SIM_ROD_STATE, std_msgs::String::TYPE_NAME, false),
    spec(SIM_BASE_POSE, geometry_msgs::PoseStamped::TYPE_NAME, false),
];

/// Every topic of ARCHITECTURE.md section 3, each once.
pub fn registry() -> &'static [TopicSpec] {
    REGISTRY
}

/// The registry entry of a topic.
pub fn lookup(name: &str) -> Option<&'static TopicSpec> {
    REGISTRY.iter().find(|t| t.name == name)
}

/// Whether the topic is latched (transient local); unknown topics are not.
pub fn is_latched(name: &str) -> bool {
    lookup(name).is_some_and(|t| t.latched)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Msg;

    #[test]
    fn registry_names_are_unique_and_types_are_msg_variants() {
        let reg = registry();
        for (i, t) in reg.iter().enumerate() {
            assert!(t.name.starts_with('/'), "{}", t.name);
            assert!(
                reg.iter().skip(i + 1).all(|u| u.name != t.name),
                "{} twice",
                t.name
            );
            assert!(
                Msg::TYPE_NAMES.contains(&t.type_name),
                "{}: {} is not a Msg type",
                t.name,
                t.type_name
            );
        }
        assert_eq!(reg.len(), 37);
    }

    #[test]
    fn latched_topics_are_exactly_the_transient_local_ones() {
        let latched: Vec<&str> = registry()
            .iter()
            .filter(|t| t.latched)
            .map(|t| t.name)
            .collect();
        assert_eq!(
            latched,
            [
                CAMERA_COLOR_INFO,
                PANORAMIC_INFO,
                TF_STATIC,
                ROBOT_DESCRIPTION
            ]
        );
        for t in registry() {
            let transient = t
                .offered_qos_profiles
                .contains("durability: transient_local");
            assert_eq!(transient, t.latched, "{}", t.name);
            assert!(t.offered_qos_profiles.starts_with("- history: keep_last\n"));
        }
        assert!(is_latched(TF_STATIC));
        assert!(!is_latched(TF));
        assert!(!is_latched("/nope"));
        assert_eq!(
            lookup(CAMERA_TRIGGER).map(|t| t.type_name),
            Some("std_msgs/msg/Empty")
        );
    }

    #[test]
    fn qos_yaml_has_every_rosbag2_key_in_order() {
        let keys = [
            "history:",
            "depth:",
            "reliability:",
            "durability:",
            "deadline:",
            "lifespan:",
            "liveliness:",
            "liveliness_lease_duration:",
            "avoid_ros_namespace_conventions:",
        ];
        for yaml in [QOS_VOLATILE_YAML, QOS_LATCHED_YAML] {
            let mut from = 0;
            for key in keys {
                let at = yaml[from..]
                    .find(key)
                    .unwrap_or_else(|| panic!("{key} missing or out of order"));
                from += at + key.len();
            }
            assert_eq!(yaml.matches("sec: 9223372036\n").count(), 3);
            assert_eq!(yaml.matches("nsec: 854775807\n").count(), 3);
        }
    }
}
