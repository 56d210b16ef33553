//! `geometry_msgs`: vectors, points, quaternions (x, y, z, w), poses and transforms.
//!
//! A `TransformStamped` with `header.frame_id = a` and `child_frame_id = b` is `a_from_b`:
//! it maps coordinates in `b` to coordinates in `a` (tf2 convention).

use serde::{Deserialize, Serialize};

use crate::schema::{
    POINT, POSE, POSE_STAMPED, QUATERNION, TRANSFORM, TRANSFORM_STAMPED, VECTOR3, impl_ros_message,
};
use crate::std_msgs::Header;

/// `geometry_msgs/msg/Vector3`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Vector3 {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
}
impl_ros_message!(Vector3, "geometry_msgs", "Vector3", VECTOR3);

/// `geometry_msgs/msg/Quaternion` (Hamilton, x y z w); default is the identity (w = 1, as
/// the `.msg` default values say).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
    /// w (scalar part).
    pub w: f64,
}
impl_ros_message!(Quaternion, "geometry_msgs", "Quaternion", QUATERNION);

impl Default for Quaternion {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Quaternion {
    /// The identity rotation.
    pub const IDENTITY: Self = Self {
        x: 0.0,
        y: 0.0,
        z: 0.0,
        w: 1.0,
    };
}

/// `geometry_msgs/msg/Point`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Point {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
}
impl_ros_message!(Point, "geometry_msgs", "Point", POINT);

/// `geometry_msgs/msg/Pose`: the pose of a frame in its parent (`parent_from_frame`).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Pose {
    /// Position (m).
    pub position: Point,
    /// Orientation.
    pub orientation: Quaternion,
}
impl_ros_message!(Pose, "geometry_msgs", "Pose", POSE);

/// `geometry_msgs/msg/PoseStamped`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct PoseStamped {
    /// Stamp and the frame the pose is expressed in.
    pub header: Header,
    /// The pose.
    pub pose: Pose,
}
impl_ros_message!(PoseStamped, "geometry_msgs", "PoseStamped", POSE_STAMPED);

/// `geometry_msgs/msg/Transform`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Transform {
    /// Translation (m).
    pub translation: Vector3,
    /// Rotation.
    pub rotation: Quaternion,
}
impl_ros_message!(Transform, "geometry_msgs", "Transform", TRANSFORM);

/// `geometry_msgs/msg/TransformStamped`: `header.frame_id _from_ child_frame_id`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct TransformStamped {
    /// Stamp and parent frame.
    pub header: Header,
    /// Child frame.
    pub child_frame_id: String,
    /// `parent_from_child`.
    pub transform: Transform,
}
impl_ros_message!(
    TransformStamped,
    "geometry_msgs",
    "TransformStamped",
    TRANSFORM_STAMPED
);
