//! `tf2_msgs`: TFMessage.

use serde::{Deserialize, Serialize};

use crate::geometry_msgs::TransformStamped;
use crate::schema::{TF_MESSAGE, impl_ros_message};

/// `tf2_msgs/msg/TFMessage`: a batch of transforms for `/tf` or `/tf_static`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct TfMessage {
    /// The transforms (each `header.frame_id _from_ child_frame_id`).
    pub transforms: Vec<TransformStamped>,
}
impl_ros_message!(TfMessage, "tf2_msgs", "TFMessage", TF_MESSAGE);
