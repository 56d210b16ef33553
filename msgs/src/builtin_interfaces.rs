//! `builtin_interfaces`: ROS time stamps and durations.

use serde::{Deserialize, Serialize};

use crate::schema::{DURATION, TIME, impl_ros_message};

/// `builtin_interfaces/msg/Time`: `sec + nanosec * 1e-9` seconds; `nanosec` in `[0, 1e9)`.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default, Serialize, Deserialize,
)]
pub struct Time {
    /// Seconds (may be negative).
    pub sec: i32,
    /// Nanoseconds added to `sec`, `0..1_000_000_000`.
    pub nanosec: u32,
}
impl_ros_message!(Time, "builtin_interfaces", "Time", TIME);

/// `builtin_interfaces/msg/Duration`: `sec + nanosec * 1e-9` seconds; `nanosec` in `[0, 1e9)`.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default, Serialize, Deserialize,
)]
pub struct Duration {
    /// Seconds (may be negative).
    pub sec: i32,
    /// Nanoseconds added to `sec`, `0..1_000_000_000`.
    pub nanosec: u32,
}
impl_ros_message!(Duration, "builtin_interfaces", "Duration", DURATION);
