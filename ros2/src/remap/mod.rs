//! [`Remap`]: how a vendor driver's ROS 2 interface maps onto rodlog's topics, frames, joint
//! names, units and encodings, read from a TOML *remap file* (`config/remap/*.toml`).
//!
//! A transport concern: the stages only ever see rodlog's vocabulary
//! (`msgs::topics`, `msgs::frames`, SI units, `rgb8`/`32FC1` metres); the remap converts at
//! the edge, before anything is recorded. A recording made through a remap carries the remap
//! files as attachments, so what was converted, and how, stays with the data.
//!
//! # File format
//!
//! Every table and key below is optional except where marked; unknown keys are errors
//! (`deny_unknown_fields`), so a typo never silently falls back to a default.
//!
//! ```toml
//! description = "AUBO i10 through aubo_ros2_driver (ros2_control)"
//! producer = "aubo_driver"              # default producer of the recorded channels
//!
//! [[topic]]                             # one vendor topic recorded as a rodlog topic
//! vendor = "/mechmind/color_image"      # required: the topic on the graph
//! rodlog = "/camera/color/image_raw"    # required: a rodlog topic (msgs::topics)
//! type = "sensor_msgs/msg/Image"        # required: must be the rodlog topic's type
//! producer = "camera_driver"            # default: the file's `producer`
//! qos = "sensor"                        # "sensor" (best effort) or "latched"; default by topic
//! encoding = "rgb8"                     # Image: convert bgr8 -> rgb8
//! depth_scale = 0.001                   # Image 32FC1: vendor unit -> metres (mm -> m)
//!
//! [joints]                              # vendor joint name -> rodlog joint name
//! shoulder_joint = "arm_shoulder_joint"
//! lift = { name = "lift_joint", scale = 0.001, offset = 0.0 }   # mm -> m: rodlog = scale * vendor + offset
//!
//! [frames]                              # vendor frame id -> rodlog frame id, in this file's topics
//! "mechmind_camera/color_map" = "camera_color_optical_frame"
//!
//! [tool0]                               # the vendor flange -> rodlog tool0 offset
//! flange = "wrist3_Link"                # required: the vendor's flange frame
//! xyz_m = [0.0, 0.0, 0.0]               # flange_from_tool0 translation
//! rpy_deg = [0.0, 0.0, 0.0]             # and rotation (fixed axes x, y, z)
//!
//! [command.arm]                         # how a /arm/joint_trajectory reaches the driver
//! mode = "action"                       # "topic" or "action" (FollowJointTrajectory)
//! name = "/joint_trajectory_controller/follow_joint_trajectory"
//!
//! [command.camera_trigger]              # how a /camera/trigger reaches the camera
//! mode = "service"                      # "topic" or "service"
//! services = ["/capture_color_image", "/capture_depth_map"]     # called in order
//! types = ["mecheye_ros_interface/srv/CaptureColorImage", "mecheye_ros_interface/srv/CaptureDepthMap"]
//! mapping = "cyclone"                   # the server's middleware: "cyclone" or "fastdds"
//!
//! [command.lift]                        # lift, base, clamp, light: a topic of the rodlog type
//! name = "/lift_controller/command"
//!
//! [[status]]                            # driver status the command path must respect
//! topic = "/io_and_status_controller/safety_mode"
//! type = "aubo_dashboard_msgs/msg/SafetyMode"
//! field = "uint8"                       # the message is one integer field: int8, uint8 or int32
//! ok = [1, 2]                           # values that allow motion; any other value holds
//! ```
//!
//! Topics a remap does not mention are taken under their rodlog names (identity), so a graph
//! that already speaks rodlog's vocabulary (the simulator node, `rodlog sim --ros2`) needs no
//! remap at all.
//!
//! # Conversions
//!
//! | message | what changes |
//! |---|---|
//! | any with a header | `header.frame_id` through the route's file's `[frames]` |
//! | `JointState` | names through `[joints]`; `position = scale * p + offset`, `velocity` and `effort` times `scale` |
//! | `Image` | `encoding = "rgb8"` swaps a `bgr8` image's channels; `depth_scale` multiplies every `32FC1` value |
//! | `TFMessage` | `frame_id` and `child_frame_id` through `[frames]` |
//!
//! A message the remap leaves unchanged keeps the exact bytes that arrived.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use msgs::Msg;
use serde::Deserialize;
use thiserror::Error;

use crate::names;

mod convert;
use crate::service::ServiceMapping;
use convert::{scale_depth, swap_bgr};

/// Errors of reading, validating or applying a remap.
#[derive(Debug, Error)]
pub enum RemapError {
    /// The file could not be read.
    #[error("cannot read remap file {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// The file is not valid TOML or has an unknown or mistyped key.
    #[error("remap file {origin}: {reason}")]
    Toml {
        /// The file (or text origin).
        origin: String,
        /// The parser's explanation (names the key).
        reason: String,
    },
    /// A value is out of range or inconsistent.
    #[error("remap file {origin}: {key}: {reason}")]
    Invalid {
        /// The file (or text origin).
        origin: String,
        /// The key (`topic[2].rodlog`, `joints.lift`, ...).
        key: String,
        /// What is wrong.
        reason: String,
    },
    /// Two remap files disagree.
    #[error("remap files {first} and {second} both define {what}")]
    Conflict {
        /// The first file.
        first: String,
        /// The second file.
        second: String,
        /// What both define.
        what: String,
    },
    /// A received message could not be decoded as its route's type.
    #[error("{topic}: cannot decode {type_name}: {reason}")]
    Decode {
        /// The vendor topic.
        topic: String,
        /// The expected type.
        type_name: &'static str,
        /// The codec's explanation.
        reason: String,
    },
    /// A received message cannot be converted (wrong encoding, sizes that disagree).
    #[error("{topic}: cannot convert: {reason}")]
    Convert {
        /// The vendor topic.
        topic: String,
        /// What is wrong.
        reason: String,
    },
}

/// QoS class of a subscription.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum QosClass {
    /// Best effort, volatile: matches every publisher ([`crate::Qos::SENSOR_SUBSCRIPTION`]).
    Sensor,
    /// Reliable, transient local: gets a latched topic's history
    /// ([`crate::Qos::LATCHED_SUBSCRIPTION`]; matches transient-local publishers only).
    Latched,
}

impl QosClass {
    /// The default class of a rodlog topic: `/tf_static` and `/robot_description` are latched
    /// by every ROS 2 publisher of them (tf2's static broadcaster, robot_state_publisher);
    /// everything else is subscribed best effort, which matches any publisher (camera info
    /// is latched by some drivers and not by others, so it is not subscribed as latched).
    #[must_use]
    pub fn default_for(rodlog_topic: &str) -> QosClass {
        if rodlog_topic == msgs::topics::TF_STATIC
            || rodlog_topic == msgs::topics::ROBOT_DESCRIPTION
        {
            QosClass::Latched
        } else {
            QosClass::Sensor
        }
    }

    /// The subscription QoS.
    #[must_use]
    pub fn qos(self) -> crate::Qos {
        match self {
            QosClass::Sensor => crate::Qos::SENSOR_SUBSCRIPTION,
            QosClass::Latched => crate::Qos::LATCHED_SUBSCRIPTION,
        }
    }
}

/// One vendor topic recorded as a rodlog topic.
#[derive(Debug, Clone, PartialEq)]
pub struct Route {
    /// The topic on the graph.
    pub vendor: String,
    /// The rodlog topic it is recorded as.
    pub rodlog: &'static str,
    /// Its type (the rodlog topic's registry type).
    pub type_name: &'static str,
    /// Producer of the recorded channel.
    pub producer: String,
    /// Subscription QoS.
    pub qos: QosClass,
    /// Convert a `bgr8` image to this encoding (`rgb8`).
    pub encoding: Option<String>,
    /// Multiply `32FC1` depth by this (vendor unit to metres).
    pub depth_scale: Option<f64>,
    /// The file that declared it (`identity` for rodlog's own names).
    pub origin: String,
    /// Vendor frame id -> rodlog frame id, from the same file (a frame map applies to its
    /// own file's topics only: `/tf` from another driver keeps its frames).
    pub frames: BTreeMap<String, String>,
}

/// A vendor joint's rodlog name and unit conversion.
#[derive(Debug, Clone, PartialEq)]
pub struct JointMap {
    /// The rodlog joint name (`msgs::frames::JOINT_NAMES`).
    pub name: String,
    /// `rodlog = scale * vendor + offset` (positions); velocity and effort are scaled.
    pub scale: f64,
    /// Position offset in rodlog units.
    pub offset: f64,
}

/// The vendor flange frame and `flange_from_tool0`.
#[derive(Debug, Clone, PartialEq)]
pub struct Tool0Offset {
    /// The vendor's flange frame id.
    pub flange: String,
    /// Translation (m).
    pub xyz_m: [f64; 3],
    /// Rotation as a unit quaternion `(x, y, z, w)`.
    pub quaternion_xyzw: [f64; 4],
}

/// How the arm's trajectories reach the driver.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ArmCommand {
    /// Publish `trajectory_msgs/msg/JointTrajectory` on this topic.
    Topic(String),
    /// Send `control_msgs/action/FollowJointTrajectory` goals to this action.
    Action(String),
}

/// How a `/camera/trigger` reaches the camera.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum TriggerCommand {
    /// Publish `std_msgs/msg/Empty` on this topic.
    Topic(String),
    /// Call these services in order (empty requests), `(service, type)`.
    Services {
        /// `(service name, pkg/srv/Type)` in call order.
        calls: Vec<(String, String)>,
        /// The server's middleware mapping.
        mapping: ServiceMapping,
    },
}

/// Where the stages' commands go on the graph; `None`: rodlog's own topic name.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Commands {
    /// Arm trajectories.
    pub arm: Option<ArmCommand>,
    /// Camera captures.
    pub camera_trigger: Option<TriggerCommand>,
    /// Lift height commands (`std_msgs/msg/Float64`).
    pub lift: Option<String>,
    /// Base goals (`geometry_msgs/msg/PoseStamped`).
    pub base: Option<String>,
    /// Clamp commands (`rodlog_msgs/msg/ClampCommand`).
    pub clamp: Option<String>,
    /// Wrist light (`std_msgs/msg/Float64`, 0..1), where the robot has one.
    pub light: Option<String>,
}

/// Width of a status message's one integer field.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StatusField {
    /// `int8`.
    Int8,
    /// `uint8`.
    Uint8,
    /// `int32`.
    Int32,
}

/// A driver status topic whose value gates motion.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StatusTopic {
    /// The topic.
    pub topic: String,
    /// Its ROS type (`pkg/msg/Type`).
    pub type_name: String,
    /// Its one integer field.
    pub field: StatusField,
    /// Values that allow motion.
    pub ok: Vec<i64>,
}

impl StatusTopic {
    /// The value of a received status message (CDR with header).
    ///
    /// # Errors
    /// [`RemapError::Decode`] for a payload too short for the field.
    pub fn value(&self, cdr: &[u8]) -> Result<i64, RemapError> {
        let h = msgs::cdr::HEADER_LEN;
        let little = cdr.get(1).is_some_and(|k| k & 1 == 1);
        let err = || RemapError::Decode {
            topic: self.topic.clone(),
            type_name: "status",
            reason: format!(
                "{} bytes, too short for its {:?} field",
                cdr.len(),
                self.field
            ),
        };
        Ok(match self.field {
            StatusField::Int8 => i64::from(*cdr.get(h).ok_or_else(err)? as i8),
            StatusField::Uint8 => i64::from(*cdr.get(h).ok_or_else(err)?),
            StatusField::Int32 => {
                let b: [u8; 4] = cdr
                    .get(h..h + 4)
                    .and_then(|s| s.try_into().ok())
                    .ok_or_else(err)?;
                i64::from(if little {
                    i32::from_le_bytes(b)
                } else {
                    i32::from_be_bytes(b)
                })
            }
        })
    }

    /// Whether `value` allows motion.
    #[must_use]
    pub fn allows(&self, value: i64) -> bool {
        self.ok.contains(&value)
    }
}

/// One or more remap files, merged and validated (module docs).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Remap {
    /// Routes declared by the files, in file order.
    pub routes: Vec<Route>,
    /// Vendor joint name -> rodlog joint.
    pub joints: BTreeMap<String, JointMap>,
    /// The flange -> tool0 offset.
    pub tool0: Option<Tool0Offset>,
    /// Where commands go.
    pub commands: Commands,
    /// Status topics gating motion.
    pub status: Vec<StatusTopic>,
    /// The files' names and texts (attached to recordings).
    pub files: Vec<(String, String)>,
}

/// A joint entry: a name, or a table with a unit conversion.
#[derive(Debug, Deserialize)]
#[serde(untagged)]
enum JointEntry {
    Name(String),
    Full {
        name: String,
        #[serde(default)]
        scale: Option<f64>,
        #[serde(default)]
        offset: Option<f64>,
    },
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct TopicFile {
    vendor: String,
    rodlog: String,
    #[serde(rename = "type")]
    type_name: String,
    producer: Option<String>,
    qos: Option<QosClass>,
    encoding: Option<String>,
    depth_scale: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Tool0File {
    flange: String,
    #[serde(default)]
    xyz_m: [f64; 3],
    #[serde(default)]
    rpy_deg: [f64; 3],
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ArmFile {
    mode: String,
    name: String,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct TriggerFile {
    mode: String,
    #[serde(default)]
    name: Option<String>,
    #[serde(default)]
    services: Vec<String>,
    #[serde(default)]
    types: Vec<String>,
    #[serde(default)]
    mapping: Option<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct NamedFile {
    name: String,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct CommandsFile {
    arm: Option<ArmFile>,
    camera_trigger: Option<TriggerFile>,
    lift: Option<NamedFile>,
    base: Option<NamedFile>,
    clamp: Option<NamedFile>,
    light: Option<NamedFile>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct StatusFile {
    topic: String,
    #[serde(rename = "type")]
    type_name: String,
    field: StatusField,
    ok: Vec<i64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RemapFile {
    #[serde(default)]
    description: String,
    #[serde(default)]
    producer: Option<String>,
    #[serde(default)]
    topic: Vec<TopicFile>,
    #[serde(default)]
    joints: BTreeMap<String, JointEntry>,
    #[serde(default)]
    frames: BTreeMap<String, String>,
    #[serde(default)]
    tool0: Option<Tool0File>,
    #[serde(default)]
    command: CommandsFile,
    #[serde(default)]
    status: Vec<StatusFile>,
}

/// Default producer of routes of a file without `producer`.
pub const DEFAULT_PRODUCER: &str = "ros2_graph";
/// Producer of identity routes (rodlog's own names on the graph).
pub const IDENTITY_ORIGIN: &str = "identity";

/// A unit quaternion `(x, y, z, w)` of fixed-axis roll, pitch, yaw (rad):
/// `R = Rz(yaw) Ry(pitch) Rx(roll)`.
#[must_use]
pub fn quaternion_from_rpy(roll: f64, pitch: f64, yaw: f64) -> [f64; 4] {
    let (sr, cr) = (roll * 0.5).sin_cos();
    let (sp, cp) = (pitch * 0.5).sin_cos();
    let (sy, cy) = (yaw * 0.5).sin_cos();
    [
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
        cr * cp * cy + sr * sp * sy,
    ]
}

fn check_name(origin: &str, key: &str, name: &str) -> Result<String, RemapError> {
    if !name.starts_with('/') {
        return Err(RemapError::Invalid {
            origin: origin.to_owned(),
            key: key.to_owned(),
            reason: format!("{name:?} must be an absolute ROS name (leading /)"),
        });
    }
    names::resolve("/", name).map_err(|e| RemapError::Invalid {
        origin: origin.to_owned(),
        key: key.to_owned(),
        reason: e.to_string(),
    })
}

fn check_type(origin: &str, key: &str, type_name: &str, kind: &str) -> Result<(), RemapError> {
    let ok = names::dds_type(type_name).is_ok() && type_name.split('/').nth(1) == Some(kind);
    if ok {
        Ok(())
    } else {
        Err(RemapError::Invalid {
            origin: origin.to_owned(),
            key: key.to_owned(),
            reason: format!("{type_name:?} is not a pkg/{kind}/Name type"),
        })
    }
}

impl Remap {
    /// Reads and merges remap files, in order.
    ///
    /// # Errors
    /// [`RemapError::Io`], and everything [`Remap::parse`] and [`Remap::merge`] refuse.
    pub fn load(paths: &[PathBuf]) -> Result<Remap, RemapError> {
        let mut remap = Remap::default();
        for path in paths {
            let text = std::fs::read_to_string(path).map_err(|source| RemapError::Io {
                path: path.clone(),
                source,
            })?;
            let origin = path.file_name().map_or_else(
                || path.display().to_string(),
                |n| n.to_string_lossy().into(),
            );
            remap.merge(Remap::parse(&text, &origin)?, &origin)?;
        }
        Ok(remap)
    }

    /// Parses and validates one remap file's text; `origin` names it in errors and is the
    /// attachment name.
    ///
    /// # Errors
    /// [`RemapError::Toml`] (syntax, unknown or mistyped keys), [`RemapError::Invalid`].
    pub fn parse(text: &str, origin: &str) -> Result<Remap, RemapError> {
        let file: RemapFile = toml::from_str(text).map_err(|e| RemapError::Toml {
            origin: origin.to_owned(),
            reason: e.to_string().trim_end().to_owned(),
        })?;
        let _ = &file.description;
        let invalid = |key: String, reason: String| RemapError::Invalid {
            origin: origin.to_owned(),
            key,
            reason,
        };
        let producer = file
            .producer
            .clone()
            .unwrap_or_else(|| DEFAULT_PRODUCER.to_owned());
        let mut routes = Vec::new();
        for (i, t) in file.topic.iter().enumerate() {
            let key = |field: &str| format!("topic[{i}].{field}");
            let vendor = check_name(origin, &key("vendor"), &t.vendor)?;
            let Some(spec) = msgs::topics::lookup(&t.rodlog) else {
                return Err(invalid(
                    key("rodlog"),
                    format!("{:?} is not a rodlog topic (msgs::topics)", t.rodlog),
                ));
            };
            if spec.type_name != t.type_name {
                return Err(invalid(
                    key("type"),
                    format!(
                        "{} carries {}, not {:?}",
                        spec.name, spec.type_name, t.type_name
                    ),
                ));
            }
            if msgs::topics::is_command(spec.name) {
                return Err(invalid(
                    key("rodlog"),
                    format!(
                        "{} is a command topic: commands are mapped under [command]",
                        spec.name
                    ),
                ));
            }
            if routes.iter().any(|r: &Route| r.vendor == vendor) {
                return Err(invalid(key("vendor"), format!("{vendor} is routed twice")));
            }
            let is_image =
                spec.type_name == <msgs::sensor_msgs::Image as msgs::RosMessage>::TYPE_NAME;
            if let Some(enc) = &t.encoding
                && (!is_image || enc != "rgb8")
            {
                return Err(invalid(
                    key("encoding"),
                    format!("only Image topics convert, and only to \"rgb8\" (got {enc:?})"),
                ));
            }
            if let Some(s) = t.depth_scale
                && (!is_image || !s.is_finite() || s <= 0.0)
            {
                return Err(invalid(
                    key("depth_scale"),
                    format!("must be a positive number on an Image topic (got {s})"),
                ));
            }
            routes.push(Route {
                vendor,
                rodlog: spec.name,
                type_name: spec.type_name,
                producer: t.producer.clone().unwrap_or_else(|| producer.clone()),
                qos: t.qos.unwrap_or_else(|| QosClass::default_for(spec.name)),
                encoding: t.encoding.clone(),
                depth_scale: t.depth_scale,
                origin: origin.to_owned(),
                frames: file.frames.clone(),
            });
        }
        let mut joints = BTreeMap::new();
        for (vendor, entry) in &file.joints {
            let (name, scale, offset) = match entry {
                JointEntry::Name(n) => (n.clone(), 1.0, 0.0),
                JointEntry::Full {
                    name,
                    scale,
                    offset,
                } => (name.clone(), scale.unwrap_or(1.0), offset.unwrap_or(0.0)),
            };
            let key = format!("joints.{vendor}");
            if !msgs::frames::JOINT_NAMES.contains(&name.as_str()) {
                return Err(invalid(
                    key,
                    format!(
                        "{name:?} is not a rodlog joint ({})",
                        msgs::frames::JOINT_NAMES.join(", ")
                    ),
                ));
            }
            if !scale.is_finite() || scale == 0.0 || !offset.is_finite() {
                return Err(invalid(
                    key,
                    format!(
                        "scale must be finite and non-zero, offset finite (got {scale}, {offset})"
                    ),
                ));
            }
            if let Some((other, _)) = joints
                .iter()
                .find(|(_, j): &(&String, &JointMap)| j.name == name)
            {
                return Err(invalid(
                    key,
                    format!("{name} is already the name of vendor joint {other}"),
                ));
            }
            joints.insert(
                vendor.clone(),
                JointMap {
                    name,
                    scale,
                    offset,
                },
            );
        }
        for (vendor, rodlog) in &file.frames {
            if vendor.is_empty() || rodlog.is_empty() {
                return Err(invalid(
                    format!("frames.{vendor}"),
                    "frame ids must not be empty".to_owned(),
                ));
            }
        }
        let tool0 = match &file.tool0 {
            None => None,
            Some(t) => {
                let finite = t.xyz_m.iter().chain(&t.rpy_deg).all(|v| v.is_finite());
                let norm = t.xyz_m.iter().map(|v| v * v).sum::<f64>().sqrt();
                if !finite || norm > 1.0 || t.flange.is_empty() {
                    return Err(invalid(
                        "tool0".to_owned(),
                        format!(
                            "needs a flange frame and finite values, translation at most 1 m (got {norm:.3} m)"
                        ),
                    ));
                }
                let [r, p, y] = t.rpy_deg.map(f64::to_radians);
                Some(Tool0Offset {
                    flange: t.flange.clone(),
                    xyz_m: t.xyz_m,
                    quaternion_xyzw: quaternion_from_rpy(r, p, y),
                })
            }
        };
        let commands = parse_commands(origin, &file.command)?;
        let mut status = Vec::new();
        for (i, s) in file.status.iter().enumerate() {
            let topic = check_name(origin, &format!("status[{i}].topic"), &s.topic)?;
            check_type(origin, &format!("status[{i}].type"), &s.type_name, "msg")?;
            if s.ok.is_empty() {
                return Err(invalid(
                    format!("status[{i}].ok"),
                    "lists no value that allows motion".to_owned(),
                ));
            }
            status.push(StatusTopic {
                topic,
                type_name: s.type_name.clone(),
                field: s.field,
                ok: s.ok.clone(),
            });
        }
        Ok(Remap {
            routes,
            joints,
            tool0,
            commands,
            status,
            files: vec![(origin.to_owned(), text.to_owned())],
        })
    }

    /// Adds `other` (from the file `origin`) to this remap.
    ///
    /// # Errors
    /// [`RemapError::Conflict`] when both route one vendor topic, name one vendor joint or
    /// frame differently, or both set the tool0 offset or the same command.
    pub fn merge(&mut self, other: Remap, origin: &str) -> Result<(), RemapError> {
        let conflict = |first: &str, what: String| RemapError::Conflict {
            first: first.to_owned(),
            second: origin.to_owned(),
            what,
        };
        for r in other.routes {
            if let Some(old) = self.routes.iter().find(|o| o.vendor == r.vendor) {
                return Err(conflict(&old.origin, format!("a route of {}", r.vendor)));
            }
            self.routes.push(r);
        }
        let first = self.files.first().map_or_else(String::new, |f| f.0.clone());
        for (k, v) in other.joints {
            if self.joints.get(&k).is_some_and(|o| *o != v) {
                return Err(conflict(&first, format!("joint {k}")));
            }
            self.joints.insert(k, v);
        }
        if let Some(t) = other.tool0 {
            if self.tool0.is_some() {
                return Err(conflict(&first, "the tool0 offset".to_owned()));
            }
            self.tool0 = Some(t);
        }
        let c = other.commands;
        let mine = &mut self.commands;
        macro_rules! take {
            ($field:ident) => {
                if let Some(v) = c.$field {
                    if mine.$field.is_some() {
                        return Err(conflict(&first, format!("command.{}", stringify!($field))));
                    }
                    mine.$field = Some(v);
                }
            };
        }
        take!(arm);
        take!(camera_trigger);
        take!(lift);
        take!(base);
        take!(clamp);
        take!(light);
        self.status.extend(other.status);
        self.files.extend(other.files);
        Ok(())
    }

    /// The routes to subscribe: the files' routes, then rodlog's own name for every topic in
    /// `rodlog_topics` that no route records yet (identity, producer `identity_producer`).
    #[must_use]
    pub fn routes_with_identity(
        &self,
        rodlog_topics: &[&'static str],
        identity_producer: &str,
    ) -> Vec<Route> {
        let mut routes = self.routes.clone();
        for &topic in rodlog_topics {
            let taken = routes
                .iter()
                .any(|r| r.rodlog == topic || r.vendor == topic);
            let Some(spec) = msgs::topics::lookup(topic) else {
                continue;
            };
            if !taken {
                routes.push(Route {
                    vendor: topic.to_owned(),
                    rodlog: spec.name,
                    type_name: spec.type_name,
                    producer: identity_producer.to_owned(),
                    qos: QosClass::default_for(topic),
                    encoding: None,
                    depth_scale: None,
                    origin: IDENTITY_ORIGIN.to_owned(),
                    frames: BTreeMap::new(),
                });
            }
        }
        routes
    }

    /// Converts one received payload of `route` (module docs, "Conversions"): the message
    /// and, when the remap changed it, the bytes to record instead of the received ones.
    ///
    /// # Errors
    /// [`RemapError::Decode`] when the payload is not the route's type;
    /// [`RemapError::Convert`] for an image whose encoding or size does not fit.
    pub fn convert(&self, route: &Route, cdr: &[u8]) -> Result<(Msg, Option<Vec<u8>>), RemapError> {
        let decoded = Msg::decode(route.type_name, cdr).map_err(|e| RemapError::Decode {
            topic: route.vendor.clone(),
            type_name: route.type_name,
            reason: e.to_string(),
        })?;
        match self.convert_msg(route, &decoded)? {
            None => Ok((decoded, None)),
            Some(msg) => {
                let bytes = msg.encode().map_err(|e| RemapError::Convert {
                    topic: route.vendor.clone(),
                    reason: e.to_string(),
                })?;
                Ok((msg, Some(bytes)))
            }
        }
    }

    /// The converted message, `None` when the remap changes nothing.
    fn convert_msg(&self, route: &Route, msg: &Msg) -> Result<Option<Msg>, RemapError> {
        let mut out = msg.clone();
        match &mut out {
            Msg::JointState(js) => {
                rename(&route.frames, &mut js.header.frame_id);
                for (i, name) in js.name.iter_mut().enumerate() {
                    let Some(j) = self.joints.get(name.as_str()) else {
                        continue;
                    };
                    name.clone_from(&j.name);
                    if let Some(p) = js.position.get_mut(i) {
                        *p = j.scale * *p + j.offset;
                    }
                    if let Some(v) = js.velocity.get_mut(i) {
                        *v *= j.scale;
                    }
                    if let Some(e) = js.effort.get_mut(i) {
                        *e *= j.scale;
                    }
                }
            }
            Msg::Image(img) => {
                rename(&route.frames, &mut img.header.frame_id);
                if route.encoding.is_some() && img.encoding == "bgr8" {
                    swap_bgr(img).map_err(|reason| RemapError::Convert {
                        topic: route.vendor.clone(),
                        reason,
                    })?;
                }
                if let Some(scale) = route.depth_scale {
                    scale_depth(img, scale).map_err(|reason| RemapError::Convert {
                        topic: route.vendor.clone(),
                        reason,
                    })?;
                }
            }
            Msg::CameraInfo(ci) => rename(&route.frames, &mut ci.header.frame_id),
            Msg::PointCloud2(pc) => rename(&route.frames, &mut pc.header.frame_id),
            Msg::TfMessage(tf) => {
                for t in &mut tf.transforms {
                    rename(&route.frames, &mut t.header.frame_id);
                    rename(&route.frames, &mut t.child_frame_id);
                }
            }
            Msg::PoseStamped(p) => rename(&route.frames, &mut p.header.frame_id),
            Msg::TransformStamped(t) => {
                rename(&route.frames, &mut t.header.frame_id);
                rename(&route.frames, &mut t.child_frame_id);
            }
            Msg::Illuminance(i) => rename(&route.frames, &mut i.header.frame_id),
            _ => {}
        }
        Ok((out != *msg).then_some(out))
    }
}

fn rename(frames: &BTreeMap<String, String>, frame: &mut String) {
    if let Some(f) = frames.get(frame.as_str()) {
        frame.clone_from(f);
    }
}

fn parse_commands(origin: &str, c: &CommandsFile) -> Result<Commands, RemapError> {
    let invalid = |key: &str, reason: String| RemapError::Invalid {
        origin: origin.to_owned(),
        key: key.to_owned(),
        reason,
    };
    let arm = match &c.arm {
        None => None,
        Some(a) => {
            let name = check_name(origin, "command.arm.name", &a.name)?;
            Some(match a.mode.as_str() {
                "topic" => ArmCommand::Topic(name),
                "action" => ArmCommand::Action(name),
                other => {
                    return Err(invalid(
                        "command.arm.mode",
                        format!("{other:?}: expected \"topic\" or \"action\""),
                    ));
                }
            })
        }
    };
    let camera_trigger = match &c.camera_trigger {
        None => None,
        Some(t) => Some(match t.mode.as_str() {
            "topic" => {
                let Some(name) = &t.name else {
                    return Err(invalid(
                        "command.camera_trigger.name",
                        "mode \"topic\" needs a name".to_owned(),
                    ));
                };
                TriggerCommand::Topic(check_name(origin, "command.camera_trigger.name", name)?)
            }
            "service" => {
                if t.services.is_empty() || t.services.len() != t.types.len() {
                    return Err(invalid(
                        "command.camera_trigger.services",
                        format!(
                            "mode \"service\" needs services and as many types ({} services, {} types)",
                            t.services.len(),
                            t.types.len()
                        ),
                    ));
                }
                let mut calls = Vec::new();
                for (i, (s, ty)) in t.services.iter().zip(&t.types).enumerate() {
                    let s =
                        check_name(origin, &format!("command.camera_trigger.services[{i}]"), s)?;
                    check_type(
                        origin,
                        &format!("command.camera_trigger.types[{i}]"),
                        ty,
                        "srv",
                    )?;
                    calls.push((s, ty.clone()));
                }
                let mapping = match t.mapping.as_deref().unwrap_or("cyclone") {
                    "cyclone" => ServiceMapping::Cyclone,
                    "fastdds" => ServiceMapping::FastDds,
                    other => {
                        return Err(invalid(
                            "command.camera_trigger.mapping",
                            format!("{other:?}: expected \"cyclone\" or \"fastdds\""),
                        ));
                    }
                };
                TriggerCommand::Services { calls, mapping }
            }
            other => {
                return Err(invalid(
                    "command.camera_trigger.mode",
                    format!("{other:?}: expected \"topic\" or \"service\""),
                ));
            }
        }),
    };
    let named = |n: &Option<NamedFile>, key: &str| -> Result<Option<String>, RemapError> {
        n.as_ref()
            .map(|n| check_name(origin, key, &n.name))
            .transpose()
    };
    Ok(Commands {
        arm,
        camera_trigger,
        lift: named(&c.lift, "command.lift.name")?,
        base: named(&c.base, "command.base.name")?,
        clamp: named(&c.clamp, "command.clamp.name")?,
        light: named(&c.light, "command.light.name")?,
    })
}

/// The remap files shipped with rodlog (`config/remap/`), relative to the repository root.
pub const SHIPPED: [&str; 2] = [
    "config/remap/aubo_i10.toml",
    "config/remap/mecheye_nano.toml",
];

/// A path's display form, for notes.
#[must_use]
pub fn origin_of(path: &Path) -> String {
    path.display().to_string()
}

#[cfg(test)]
mod tests;
