//! `nav_msgs`: Path.

use serde::{Deserialize, Serialize};

use crate::geometry_msgs::PoseStamped;
use crate::schema::{PATH, impl_ros_message};
use crate::std_msgs::Header;

/// `nav_msgs/msg/Path`: a sequence of poses (rodlog: each plan's tool0 path in `base_link`).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Path {
    /// Stamp and frame of the path.
    pub header: Header,
    /// Poses along the path.
    pub poses: Vec<PoseStamped>,
}
impl_ros_message!(Path, "nav_msgs", "Path", PATH);
