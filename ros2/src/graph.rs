//! [`Endpoint`]: a writer or reader in the domain, this node's own or discovered from another
//! participant. "No writer exists on any command topic" is `node.endpoints()` filtered.

use std::collections::BTreeMap;
use std::sync::{Arc, Mutex, PoisonError};

use rustdds::{GUID, policy};

use crate::names;
use crate::qos::{Durability, Reliability};

/// Writer or reader.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum EndpointKind {
    /// A DataWriter (a ROS publisher, or a service client's request writer).
    Writer,
    /// A DataReader (a ROS subscription).
    Reader,
}

/// One writer or reader on a topic.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Endpoint {
    /// Writer or reader.
    pub kind: EndpointKind,
    /// The DDS topic (`rt/joint_states`).
    pub dds_topic: String,
    /// The ROS topic (`/joint_states`), `None` for DDS topics that are not ROS topics.
    pub ros_topic: Option<String>,
    /// The DDS type name (`sensor_msgs::msg::dds_::JointState_`).
    pub dds_type: String,
    /// The endpoint's GUID (participant prefix, 12 bytes, then entity id).
    pub guid: [u8; 16],
    /// Created by this node (`false`: discovered from another participant).
    pub local: bool,
    /// Reliability, when announced.
    pub reliability: Option<Reliability>,
    /// Durability, when announced.
    pub durability: Option<Durability>,
}

impl Endpoint {
    pub(crate) fn new(
        kind: EndpointKind,
        dds_topic: &str,
        dds_type: &str,
        guid: GUID,
        local: bool,
        reliability: Option<policy::Reliability>,
        durability: Option<policy::Durability>,
    ) -> Endpoint {
        Endpoint {
            kind,
            dds_topic: dds_topic.to_string(),
            ros_topic: names::ros_topic(dds_topic).map(str::to_string),
            dds_type: dds_type.to_string(),
            guid: guid.to_bytes(),
            local,
            reliability: reliability.map(|r| match r {
                policy::Reliability::Reliable { .. } => Reliability::Reliable,
                policy::Reliability::BestEffort => Reliability::BestEffort,
            }),
            durability: durability.map(|d| match d {
                policy::Durability::Volatile => Durability::Volatile,
                _ => Durability::TransientLocal,
            }),
        }
    }
}

/// This node's own endpoints; publishers and subscriptions remove themselves when dropped.
#[derive(Debug, Default, Clone)]
pub(crate) struct LocalEndpoints(Arc<Mutex<BTreeMap<[u8; 16], Endpoint>>>);

impl LocalEndpoints {
    pub(crate) fn insert(&self, e: Endpoint) {
        self.0
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .insert(e.guid, e);
    }

    pub(crate) fn remove(&self, guid: &[u8; 16]) {
        self.0
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .remove(guid);
    }

    pub(crate) fn all(&self) -> Vec<Endpoint> {
        self.0
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .values()
            .cloned()
            .collect()
    }
}
