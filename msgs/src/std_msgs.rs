//! `std_msgs`: Header, String, Float64, Empty.

use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::builtin_interfaces::Time;
use crate::schema::{EMPTY, FLOAT64, HEADER, STRING, impl_ros_message};

/// `std_msgs/msg/Header`: capture stamp and coordinate frame of stamped data.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Header {
    /// Capture time (robot clock, see [`crate::time`]).
    pub stamp: Time,
    /// Frame the data is expressed in (e.g. `camera_color_optical_frame`).
    pub frame_id: std::string::String,
}
impl_ros_message!(Header, "std_msgs", "Header", HEADER);

/// `std_msgs/msg/String`.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct String {
    /// The text.
    pub data: std::string::String,
}
impl_ros_message!(String, "std_msgs", "String", STRING);

/// `std_msgs/msg/Float64`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Float64 {
    /// The value (unit given by the topic, e.g. metres for `/lift/command`).
    pub data: f64,
}
impl_ros_message!(Float64, "std_msgs", "Float64", FLOAT64);

/// `std_msgs/msg/Empty`: no fields.
///
/// rosidl gives every empty struct one member `uint8 structure_needs_at_least_one_member`,
/// so on the wire it is one byte, written as 0 (`00 01 00 00 00`); any value is accepted on
/// read.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Empty;
impl_ros_message!(Empty, "std_msgs", "Empty", EMPTY);

impl Serialize for Empty {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_u8(0)
    }
}

impl<'de> Deserialize<'de> for Empty {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        u8::deserialize(deserializer).map(|_| Empty)
    }
}
