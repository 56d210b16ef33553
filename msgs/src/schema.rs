//! `ros2msg` schema texts (MCAP ros2 profile) and the [`RosMessage`] trait.
//!
//! A schema is the type's own `.msg` text, then for each dependency (transitively, each once,
//! depth-first in field order) a separator line of 80 `=`, a line `MSG: pkg/Type` and that
//! type's `.msg` text. This is the format rosbag2 writes into MCAP schema records and that
//! Foxglove, Rerun, `mcap-ros2-support` and `rosbags` parse.
//!
//! The texts are the ROS 2 Jazzy definitions (ros2/common_interfaces, ros2/geometry2
//! `tf2_msgs`, ros2/rcl_interfaces `rcl_interfaces` and `builtin_interfaces`,
//! ros2/rosgraph_msgs) with long comments trimmed; field order, types, array bounds,
//! default values and constants are kept exactly. The `rodlog_msgs` texts are ARCHITECTURE.md
//! section 3.

use serde::Serialize;
use serde::de::DeserializeOwned;
use std::fmt::Debug;

/// Line separating the sections of a `ros2msg` schema (80 `=`).
pub const SEPARATOR: &str =
    "================================================================================";

/// One message definition: its `pkg/Type` name, `.msg` text and direct dependencies.
#[derive(Debug)]
pub struct MsgDef {
    /// `pkg/Type` as written after `MSG:` (e.g. `std_msgs/Header`).
    pub name: &'static str,
    /// The `.msg` text.
    pub text: &'static str,
    /// Definitions of the non-primitive field types, in field order.
    pub deps: &'static [&'static MsgDef],
}

impl MsgDef {
    /// The full `ros2msg` schema: own text, then every transitive dependency once.
    pub fn schema_text(&'static self) -> String {
        let mut order: Vec<&'static MsgDef> = Vec::new();
        fn visit(def: &'static MsgDef, order: &mut Vec<&'static MsgDef>) {
            for dep in def.deps {
                if !order.iter().any(|d| d.name == dep.name) {
                    order.push(dep);
                    visit(dep, order);
                }
            }
        }
        visit(self, &mut order);
        let mut out = String::from(self.text.trim_end());
        out.push('\n');
        for dep in order {
            out.push_str(SEPARATOR);
            out.push('\n');
            out.push_str("MSG: ");
            out.push_str(dep.name);
            out.push('\n');
            out.push_str(dep.text.trim_end());
            out.push('\n');
        }
        out
    }
}

/// A ROS 2 message type: serde (CDR via [`crate::cdr`]), its ROS type name and schema.
pub trait RosMessage: Serialize + DeserializeOwned + Clone + Debug + PartialEq {
    /// Full ROS 2 type name, e.g. `sensor_msgs/msg/Image` (the MCAP schema name).
    const TYPE_NAME: &'static str;
    /// The `.msg` definition and its dependencies.
    const DEFINITION: &'static MsgDef;

    /// The `ros2msg` schema text (see the module docs).
    fn schema_text() -> String {
        Self::DEFINITION.schema_text()
    }
}

/// Implements [`RosMessage`] for a struct from its package and definition static.
macro_rules! impl_ros_message {
    ($ty:ty, $pkg:literal, $name:literal, $def:expr) => {
        impl $crate::schema::RosMessage for $ty {
            const TYPE_NAME: &'static str = concat!($pkg, "/msg/", $name);
            const DEFINITION: &'static $crate::schema::MsgDef = &$def;
        }
    };
}
pub(crate) use impl_ros_message;

// ---- builtin_interfaces -------------------------------------------------------------------

/// `builtin_interfaces/Time`.
pub static TIME: MsgDef = MsgDef {
    name: "builtin_interfaces/Time",
    text: "# This message communicates ROS Time defined here:
# https://design.ros2.org/articles/clock_and_time.html

# The seconds component, valid over all int32 values.
int32 sec

# The nanoseconds component, valid in the range [0, 1e9), to be added to the seconds component.
# e.g.
# The time -1.7 seconds is represented as {sec: -2, nanosec: 3e8}
# The time 1.7 seconds is represented as {sec: 1, nanosec: 7e8}
uint32 nanosec
",
    deps: &[],
};

/// `builtin_interfaces/Duration`.
pub static DURATION: MsgDef = MsgDef {
    name: "builtin_interfaces/Duration",
    text: "# Duration defines a period between two time points.
# Messages of this datatype are of ROS Time following this design:
# https://design.ros2.org/articles/clock_and_time.html

# The seconds component, valid over all int32 values.
int32 sec

# The nanoseconds component, valid in the range [0, 1e9), to be added to the seconds component.
# e.g.
# The duration -1.7 seconds is represented as {sec: -2, nanosec: 3e8}
# The duration 1.7 seconds is represented as {sec: 1, nanosec: 7e8}
uint32 nanosec
",
    deps: &[],
};

// ---- std_msgs -----------------------------------------------------------------------------

/// `std_msgs/Header`.
pub static HEADER: MsgDef = MsgDef {
    name: "std_msgs/Header",
    text: "# Standard metadata for higher-level stamped data types.
# This is generally used to communicate timestamped data
# in a particular coordinate frame.

# Two-integer timestamp that is expressed as seconds and nanoseconds.
builtin_interfaces/Time stamp

# Transform frame with which this data is associated.
string frame_id
",
    deps: &[&TIME],
};

/// `std_msgs/String`.
pub static STRING: MsgDef = MsgDef {
    name: "std_msgs/String",
    text: "# This was originally provided as an example message.
# It is deprecated as of Foxy
# It is recommended to create your own semantically meaningful message.
# However if you would like to continue using this please use the equivalent in example_msgs.

string data
",
    deps: &[],
};

/// `std_msgs/Float64`.
pub static FLOAT64: MsgDef = MsgDef {
    name: "std_msgs/Float64",
    text: "# This was originally provided as an example message.
# It is deprecated as of Foxy
# It is recommended to create your own semantically meaningful message.
# However if you would like to continue using this please use the equivalent in example_msgs.

float64 data
",
    deps: &[],
};

/// `std_msgs/Empty` (no fields; rosidl puts one `uint8` on the wire).
pub static EMPTY: MsgDef = MsgDef {
    name: "std_msgs/Empty",
    text: "",
    deps: &[],
};

// ---- geometry_msgs ------------------------------------------------------------------------

/// `geometry_msgs/Vector3`.
pub static VECTOR3: MsgDef = MsgDef {
    name: "geometry_msgs/Vector3",
    text: "# This represents a vector in free space.

# This is semantically different than a point.
# A vector is always anchored at the origin.
# When a transform is applied to a vector, only the rotational component is applied.

float64 x
float64 y
float64 z
",
    deps: &[],
};

/// `geometry_msgs/Quaternion`.
pub static QUATERNION: MsgDef = MsgDef {
    name: "geometry_msgs/Quaternion",
    text: "# This represents an orientation in free space in quaternion form.

float64 x 0
float64 y 0
float64 z 0
float64 w 1
",
    deps: &[],
};

/// `geometry_msgs/Point`.
pub static POINT: MsgDef = MsgDef {
    name: "geometry_msgs/Point",
    text: "# This contains the position of a point in free space
float64 x
float64 y
float64 z
",
    deps: &[],
};

/// `geometry_msgs/Pose`.
pub static POSE: MsgDef = MsgDef {
    name: "geometry_msgs/Pose",
    text: "# A representation of pose in free space, composed of position and orientation.

Point position
Quaternion orientation
",
    deps: &[&POINT, &QUATERNION],
};

/// `geometry_msgs/PoseStamped`.
pub static POSE_STAMPED: MsgDef = MsgDef {
    name: "geometry_msgs/PoseStamped",
    text: "# A Pose with reference coordinate frame and timestamp

std_msgs/Header header
Pose pose
",
    deps: &[&HEADER, &POSE],
};

/// `geometry_msgs/Transform`.
pub static TRANSFORM: MsgDef = MsgDef {
    name: "geometry_msgs/Transform",
    text: "# This represents the transform between two coordinate frames in free space.

Vector3 translation
Quaternion rotation
",
    deps: &[&VECTOR3, &QUATERNION],
};

/// `geometry_msgs/TransformStamped`.
pub static TRANSFORM_STAMPED: MsgDef = MsgDef {
    name: "geometry_msgs/TransformStamped",
    text: "# This expresses a transform from coordinate frame header.frame_id
# to the coordinate frame child_frame_id at the time of header.stamp
#
# This message is mostly used by the
# <a href=\"https://docs.ros.org/en/rolling/p/tf2/\">tf2</a> package.
# See its documentation for more information.
#
# The child_frame_id is necessary in addition to the frame_id
# in the Header to communicate the full reference for the transform
# in a self contained message.

# The frame id in the header is used as the reference frame of this transform.
std_msgs/Header header

# The frame id of the child frame to which this transform points.
string child_frame_id

# Translation and rotation in 3-dimensions of child_frame_id from header.frame_id.
Transform transform
",
    deps: &[&HEADER, &TRANSFORM],
};

// ---- sensor_msgs --------------------------------------------------------------------------

/// `sensor_msgs/Image`.
pub static IMAGE: MsgDef = MsgDef {
    name: "sensor_msgs/Image",
    text: "# This message contains an uncompressed image
# (0, 0) is at top-left corner of image

std_msgs/Header header # Header timestamp should be acquisition time of image
                             # Header frame_id should be optical frame of camera
                             # origin of frame should be optical center of cameara
                             # +x should point to the right in the image
                             # +y should point down in the image
                             # +z should point into to plane of the image
                             # If the frame_id here and the frame_id of the CameraInfo
                             # message associated with the image conflict
                             # the behavior is undefined

uint32 height                # image height, that is, number of rows
uint32 width                 # image width, that is, number of columns

# The legal values for encoding are in file include/sensor_msgs/image_encodings.hpp
# If you want to standardize a new string format, join
# ros-users@lists.ros.org and send an email proposing a new encoding.

string encoding       # Encoding of pixels -- channel meaning, ordering, size
                      # taken from the list of strings in include/sensor_msgs/image_encodings.hpp

uint8 is_bigendian    # is this data bigendian?
uint32 step           # Full row length in bytes
uint8[] data          # actual matrix data, size is (step * rows)
",
    deps: &[&HEADER],
};

/// `sensor_msgs/RegionOfInterest`.
pub static REGION_OF_INTEREST: MsgDef = MsgDef {
    name: "sensor_msgs/RegionOfInterest",
    text: "# This message is used to specify a region of interest within an image.
#
# When used to specify the ROI setting of the camera when the image was
# taken, the height and width fields should either match the height and
# width fields for the associated image; or height = width = 0
# indicates that the full resolution image was captured.

uint32 x_offset  # Leftmost pixel of the ROI
                 # (0 if the ROI includes the left edge of the image)
uint32 y_offset  # Topmost pixel of the ROI
                 # (0 if the ROI includes the top edge of the image)
uint32 height    # Height of ROI
uint32 width     # Width of ROI

# True if a distinct rectified ROI should be calculated from the \"raw\"
# ROI in this message. Typically this should be False if the full image
# is captured (ROI not used), and True if a subwindow is captured (ROI
# used).
bool do_rectify
",
    deps: &[],
};

/// `sensor_msgs/CameraInfo`.
pub static CAMERA_INFO: MsgDef = MsgDef {
    name: "sensor_msgs/CameraInfo",
    text: "# This message defines meta information for a camera. It should be in a
# camera namespace on topic \"camera_info\" and accompanied by up to five
# image topics named:
#
#   image_raw - raw data from the camera driver, possibly Bayer encoded
#   image            - monochrome, distorted
#   image_color      - color, distorted
#   image_rect       - monochrome, rectified
#   image_rect_color - color, rectified

#######################################################################
#                     Image acquisition info                          #
#######################################################################

# Time of image acquisition, camera coordinate frame ID
std_msgs/Header header # Header timestamp should be acquisition time of image
                             # Header frame_id should be optical frame of camera
                             # origin of frame should be optical center of camera
                             # +x should point to the right in the image
                             # +y should point down in the image
                             # +z should point into the plane of the image

#######################################################################
#                      Calibration Parameters                         #
#######################################################################

# The image dimensions with which the camera was calibrated.
uint32 height
uint32 width

# The distortion model used. Supported models are listed in
# sensor_msgs/distortion_models.hpp. For most cameras, \"plumb_bob\" - a
# simple model of radial and tangential distortion - is sufficent.
string distortion_model

# The distortion parameters, size depending on the distortion model.
# For \"plumb_bob\", the 5 parameters are: (k1, k2, t1, t2, k3).
float64[] d

# Intrinsic camera matrix for the raw (distorted) images.
#     [fx  0 cx]
# K = [ 0 fy cy]
#     [ 0  0  1]
float64[9]  k # 3x3 row-major matrix

# Rectification matrix (stereo cameras only)
float64[9]  r # 3x3 row-major matrix

# Projection/camera matrix
#     [fx'  0  cx' Tx]
# P = [ 0  fy' cy' Ty]
#     [ 0   0   1   0]
float64[12] p # 3x4 row-major matrix

#######################################################################
#                      Operational Parameters                         #
#######################################################################

# Binning refers here to any camera setting which combines rectangular
#  neighborhoods of pixels into larger \"super-pixels.\"
uint32 binning_x
uint32 binning_y

# Region of interest (subwindow of full camera resolution), given in
#  full resolution (unbinned) image coordinates.
RegionOfInterest roi
",
    deps: &[&HEADER, &REGION_OF_INTEREST],
};

/// `sensor_msgs/JointState`.
pub static JOINT_STATE: MsgDef = MsgDef {
    name: "sensor_msgs/JointState",
    text: "# This is a message that holds data to describe the state of a set of torque controlled joints.
#
# The state of each joint (revolute or prismatic) is defined by:
#  * the position of the joint (rad or m),
#  * the velocity of the joint (rad/s or m/s) and
#  * the effort that is applied in the joint (Nm or N).
#
# Each joint is uniquely identified by its name
# The header specifies the time at which the joint states were recorded. All the joint states
# in one message have to be recorded at the same time.
#
# This message consists of a multiple arrays, one for each part of the joint state.
# The goal is to make each of the fields optional. When e.g. your joints have no
# effort associated with them, you can leave the effort array empty.
#
# All arrays in this message should have the same size, or be empty.
# This is the only way to uniquely associate the joint name with the correct
# states.

std_msgs/Header header

string[] name
float64[] position
float64[] velocity
float64[] effort
",
    deps: &[&HEADER],
};

/// `sensor_msgs/PointField`.
pub static POINT_FIELD: MsgDef = MsgDef {
    name: "sensor_msgs/PointField",
    text: "# This message holds the description of one point entry in the
# PointCloud2 message format.
uint8 INT8    = 1
uint8 UINT8   = 2
uint8 INT16   = 3
uint8 UINT16  = 4
uint8 INT32   = 5
uint8 UINT32  = 6
uint8 FLOAT32 = 7
uint8 FLOAT64 = 8

# Common PointField names are x, y, z, intensity, rgb, rgba
string name      # Name of field
uint32 offset    # Offset from start of point struct
uint8  datatype  # Datatype enumeration, see above
uint32 count     # How many elements in the field
",
    deps: &[],
};

/// `sensor_msgs/PointCloud2`.
pub static POINT_CLOUD2: MsgDef = MsgDef {
    name: "sensor_msgs/PointCloud2",
    text: "# This message holds a collection of N-dimensional points, which may
# contain additional information such as normals, intensity, etc. The
# point data is stored as a binary blob, its layout described by the
# contents of the \"fields\" array.
#
# The point cloud data may be organized 2d (image-like) or 1d (unordered).
# Point clouds organized as 2d images may be produced by camera depth sensors
# such as stereo or time-of-flight.

# Time of sensor data acquisition, and the coordinate frame ID (for 3d points).
std_msgs/Header header

# 2D structure of the point cloud. If the cloud is unordered, height is
# 1 and width is the length of the point cloud.
uint32 height
uint32 width

# Describes the channels and their layout in the binary data blob.
PointField[] fields

bool    is_bigendian # Is this data bigendian?
uint32  point_step   # Length of a point in bytes
uint32  row_step     # Length of a row in bytes
uint8[] data         # Actual point data, size is (row_step*height)

bool is_dense        # True if there are no invalid points
",
    deps: &[&HEADER, &POINT_FIELD],
};

/// `sensor_msgs/Illuminance`.
pub static ILLUMINANCE: MsgDef = MsgDef {
    name: "sensor_msgs/Illuminance",
    text: "# Single photometric illuminance measurement.  Light should be assumed to be
# measured along the sensor's x-axis (the area of detection is the y-z plane).
# The illuminance should have a 0 or positive value and be received with
# the sensor's +X axis pointing toward the light source.
#
# Photometric illuminance is the measure of the human eye's sensitivity of the
# intensity of light encountering or passing through a surface.
#
# All other Photometric and Radiometric measurements should not use this message.
# This message cannot represent:
#  - Luminous intensity (candela/light source output)
#  - Luminance (nits/light output per area)
#  - Irradiance (watt/area), etc.

std_msgs/Header header # timestamp is the time the illuminance was measured
                             # frame_id is the location and direction of the reading

float64 illuminance          # Measurement of the Photometric Illuminance in Lux.

float64 variance             # 0 is interpreted as variance unknown
",
    deps: &[&HEADER],
};

// ---- tf2_msgs, rosgraph_msgs, trajectory_msgs, nav_msgs, rcl_interfaces ---------------------

/// `tf2_msgs/TFMessage`.
pub static TF_MESSAGE: MsgDef = MsgDef {
    name: "tf2_msgs/TFMessage",
    text: "geometry_msgs/TransformStamped[] transforms
",
    deps: &[&TRANSFORM_STAMPED],
};

/// `rosgraph_msgs/Clock`.
pub static CLOCK: MsgDef = MsgDef {
    name: "rosgraph_msgs/Clock",
    text: "# This message communicates the current time.
#
# For more information, see https://design.ros2.org/articles/clock_and_time.html.
builtin_interfaces/Time clock
",
    deps: &[&TIME],
};

/// `trajectory_msgs/JointTrajectoryPoint`.
pub static JOINT_TRAJECTORY_POINT: MsgDef = MsgDef {
    name: "trajectory_msgs/JointTrajectoryPoint",
    text: "# Each trajectory point specifies either positions[, velocities[, accelerations]]
# or positions[, effort] for the trajectory to be executed.
# All specified values are in the same order as the joint names in JointTrajectory.msg.

# Single DOF joint positions for each joint relative to their \"0\" position.
# The units depend on the specific joint type: radians for revolute or
# continuous joints, and meters for prismatic joints.
float64[] positions

# The rate of change in position of each joint. Units are joint type dependent.
# Radians/second for revolute or continuous joints, and meters/second for
# prismatic joints.
float64[] velocities

# Rate of change in velocity of each joint. Units are joint type dependent.
# Radians/second^2 for revolute or continuous joints, and meters/second^2 for
# prismatic joints.
float64[] accelerations

# The torque or the force to be applied at each joint.
# For revolute/continuous joints effort denotes a torque in newton-meters.
# For prismatic joints, effort denotes a force in newtons.
float64[] effort

# Desired time from the trajectory start to arrive at this trajectory point.
builtin_interfaces/Duration time_from_start
",
    deps: &[&DURATION],
};

/// `trajectory_msgs/JointTrajectory`.
pub static JOINT_TRAJECTORY: MsgDef = MsgDef {
    name: "trajectory_msgs/JointTrajectory",
    text: "# The header is used to specify the coordinate frame and the reference time for
# the trajectory durations
std_msgs/Header header

# The names of the active joints in each trajectory point. These names are
# ordered and must correspond to the values in each trajectory point.
string[] joint_names

# Array of trajectory points, which describe the positions, velocities,
# accelerations and/or efforts of the joints at each time point.
JointTrajectoryPoint[] points
",
    deps: &[&HEADER, &JOINT_TRAJECTORY_POINT],
};

/// `nav_msgs/Path`.
pub static PATH: MsgDef = MsgDef {
    name: "nav_msgs/Path",
    text: "# An array of poses that represents a Path for a robot to follow.

# Indicates the frame_id of the path.
std_msgs/Header header

# Array of poses to follow.
geometry_msgs/PoseStamped[] poses
",
    deps: &[&HEADER, &POSE_STAMPED],
};

/// `rcl_interfaces/Log`.
pub static LOG: MsgDef = MsgDef {
    name: "rcl_interfaces/Log",
    text: "##
## Severity level constants
##
## These logging levels follow the Python Standard
## https://docs.python.org/3/library/logging.html#logging-levels
## And are implemented in rcutils as well
## https://github.com/ros2/rcutils/blob/35f29850064e0c33a4063cbc947ebbfeada11dba/include/rcutils/logging.h#L164-L172
## This leaves space for other standard logging levels to be inserted in the middle in the future,
## as well as custom user defined levels.
## Since there are several other logging enumeration standard for different implementations,
## other logging implementations may need to provide level mappings to match their internal implementations.
##

# Debug is for pedantic information, which is useful when debugging issues.
byte DEBUG=10

# Info is the standard informational level and is used to report expected
# information.
byte INFO=20

# Warning is for information that may potentially cause issues or possibly unexpected
# behavior.
byte WARN=30

# Error is for information that this node cannot resolve.
byte ERROR=40

# Information about a impending node shutdown.
byte FATAL=50

##
## Fields
##

# Timestamp when this message was generated by the node.
builtin_interfaces/Time stamp

# Corresponding log level, see above definitions.
uint8 level

# The name representing the logger this message came from.
string name

# The full log message.
string msg

# The file the message came from.
string file

# The function the message came from.
string function

# The line in the file the message came from.
uint32 line
",
    deps: &[&TIME],
};

// ---- rodlog_msgs (ARCHITECTURE.md section 3) ------------------------------------------------------

/// `rodlog_msgs/ClampCommand`.
pub static CLAMP_COMMAND: MsgDef = MsgDef {
    name: "rodlog_msgs/ClampCommand",
    text: "# Command to the lead-screw clamp of the grounding rod.
std_msgs/Header header

uint8 OPEN=0
uint8 CLOSE=1
uint8 STOP=2

# One of OPEN, CLOSE, STOP.
uint8 action
# Torque limit of the clamp motor (N m); the motor stops when it is reached.
float64 max_torque_nm
",
    deps: &[&HEADER],
};

/// `rodlog_msgs/FeatureMatches`.
pub static FEATURE_MATCHES: MsgDef = MsgDef {
    name: "rodlog_msgs/FeatureMatches",
    text: "# Feature matches between two images, for the viewer.
std_msgs/Header header
# Capture stamps of image a and image b.
builtin_interfaces/Time stamp_a
builtin_interfaces/Time stamp_b
# Matching method, e.g. orb-gms.
string method
float32[] keypoints_a   # x0,y0,x1,y1,... pixels
float32[] keypoints_b   # x0,y0,x1,y1,... pixels
uint32[] pairs          # ia0,ib0,ia1,ib1,...
bool[] inlier           # one per pair
",
    deps: &[&HEADER, &TIME],
};

/// `rodlog_msgs/HandEyeCalibration`.
pub static HAND_EYE_CALIBRATION: MsgDef = MsgDef {
    name: "rodlog_msgs/HandEyeCalibration",
    text: "# Result of a hand-eye calibration: tool0_from_camera.
std_msgs/Header header    # frame_id tool0
string child_frame_id     # camera_color_optical_frame
geometry_msgs/Transform tool0_from_camera
string method
string mode               # rgbd | mono | poses
uint32 views
uint32 pairs
float64 residual_rot_deg  # median over pairs
float64 residual_trans_mm # median over pairs
float64 sigma_rot_deg     # 1-sigma uncertainty
float64 sigma_trans_mm    # 1-sigma uncertainty
float64 condition         # rotation-axis conditioning
float64 scale             # mono: metres per unit; else 1
",
    deps: &[&HEADER, &TRANSFORM],
};

/// `rodlog_msgs/TaskEvent`.
pub static TASK_EVENT: MsgDef = MsgDef {
    name: "rodlog_msgs/TaskEvent",
    text: "# State change, refusal or failure of a task or safety stage.
std_msgs/Header header
string task
string state

uint8 INFO=0
uint8 REFUSED=1
uint8 FAILED=2
uint8 DONE=3

# One of INFO, REFUSED, FAILED, DONE.
uint8 kind
string reason_code
string text
",
    deps: &[&HEADER],
};

/// Every definition in this crate, for lookups by `pkg/Type`.
pub static ALL_DEFINITIONS: &[&MsgDef] = &[
    &TIME,
    &DURATION,
    &HEADER,
    &STRING,
    &FLOAT64,
    &EMPTY,
    &VECTOR3,
    &QUATERNION,
    &POINT,
    &POSE,
    &POSE_STAMPED,
    &TRANSFORM,
    &TRANSFORM_STAMPED,
    &IMAGE,
    &REGION_OF_INTEREST,
    &CAMERA_INFO,
    &JOINT_STATE,
    &POINT_FIELD,
    &POINT_CLOUD2,
    &ILLUMINANCE,
    &TF_MESSAGE,
    &CLOCK,
    &JOINT_TRAJECTORY_POINT,
    &JOINT_TRAJECTORY,
    &PATH,
    &LOG,
    &CLAMP_COMMAND,
    &FEATURE_MATCHES,
    &HAND_EYE_CALIBRATION,
    &TASK_EVENT,
];

/// Looks a definition up by `pkg/Type` or `pkg/msg/Type`.
pub fn definition(type_name: &str) -> Option<&'static MsgDef> {
    let short = normalize_type_name(type_name);
    ALL_DEFINITIONS.iter().copied().find(|d| d.name == short)
}

/// `pkg/msg/Type` -> `pkg/Type`; other names are returned unchanged.
pub fn normalize_type_name(type_name: &str) -> std::borrow::Cow<'_, str> {
    match type_name.split('/').collect::<Vec<_>>().as_slice() {
        [pkg, "msg", name] => std::borrow::Cow::Owned(format!("{pkg}/{name}")),
        _ => std::borrow::Cow::Borrowed(type_name),
    }
}
