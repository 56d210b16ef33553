//! `rosgraph_msgs`: Clock.

use serde::{Deserialize, Serialize};

use crate::builtin_interfaces::Time;
use crate::schema::{CLOCK, impl_ros_message};

/// `rosgraph_msgs/msg/Clock`: the robot clock, published on `/clock` every 100 ms of robot
/// time (ARCHITECTURE.md section 2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Clock {
    /// Current time.
    pub clock: Time,
}
impl_ros_message!(Clock, "rosgraph_msgs", "Clock", CLOCK);
