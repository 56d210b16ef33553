//! rodlog's ROS 2 transport: raw CDR topics over DDS (RustDDS), so rodlog joins a ROS 2 graph.
//!
//! A transport at the edge: it converts names and QoS, moves the CDR bytes that
//! `msgs` encodes and decodes, stamps what arrives and counts what was lost. No stage logic;
//! stages never see DDS types. Why RustDDS, and the measured figures: `MEASUREMENT.md`.
//!
//! | module | what |
//! |---|---|
//! | [`node`] | [`Node`], [`NodeOptions`], [`DiscoveryRange`]: one DDS participant per node, `ROS_DOMAIN_ID` |
//! | [`subscription`] | [`Subscription`] yielding [`Received`] (raw CDR, source stamp, arrival instant); [`TopicCounters`] |
//! | [`publisher`] | [`Publisher`]: `publish(&[u8])` of CDR with its encapsulation header |
//! | [`action`] | [`FollowJointTrajectoryClient`]: a raw FollowJointTrajectory action client (joint_trajectory_controller) |
//! | [`service`] | [`ServiceClient`]: a raw ROS 2 service client, [`ServiceMapping`] Cyclone or Fast DDS |
//! | [`graph`] | [`Endpoint`]: the writers and readers of a topic, local and discovered |
//! | [`names`] | ROS 2 names on DDS: `rt/<topic>`, `pkg::msg::dds_::Type_`, `rq/`/`rr/` services |
//! | [`remap`] | [`Remap`]: vendor topics, frames, joint names, units and encodings to rodlog's (TOML remap files) |
//! | [`qos`] | [`Qos`] and the presets real drivers use ([`Qos::for_subscription`], [`Qos::for_publisher`]) |
//! | [`error`] | [`Ros2Error`] |
//!
//! # Wire contract
//!
//! Payloads are XCDR1 with the 4-byte encapsulation header, exactly what `msgs::Msg::encode`
//! writes and `msgs::Msg::decode` reads. Received payloads are not decoded and re-encoded: the
//! bytes handed out are the serialized payload of the RTPS DATA (fragments reassembled) behind
//! the representation identifier; only the two representation-option bytes, which RustDDS does
//! not pass on, are written as `00 00` (ROS 2 writers send `00 00` for XCDR1, the tests check it).
//!
//! # Threads
//!
//! [`Subscription::recv_timeout`] blocks (a `mio` poll on the reader), [`Subscription::try_recv`]
//! does not; a subscription belongs to one thread at a time (move it to a dedicated thread, or
//! into `tokio::task::spawn_blocking`). [`TopicCounters`] are atomics shared with any thread.
//!
//! # Discovery takes time, both ways
//!
//! A reader drops samples of a writer it has not matched yet, and matching needs both sides'
//! announcements (0.1-0.5 s on one host). A writer that starts as soon as *it* sees the reader
//! lost its first sample in 3 of 7 test runs (Cyclone publishing at 100 Hz); the
//! tests and the Cyclone peer wait for the match, then settle, before sending.
#![warn(missing_docs)]

pub mod action;
pub mod error;
pub mod graph;
pub mod names;
pub mod node;
pub mod publisher;
pub mod qos;
mod raw;
pub mod remap;
pub mod service;
pub mod subscription;

pub use action::{ActionEvent, FollowJointTrajectoryClient};
pub use error::Ros2Error;
pub use graph::{Endpoint, EndpointKind};
pub use node::{DiscoveryRange, Node, NodeOptions};
pub use publisher::Publisher;
pub use qos::{Durability, Qos, Reliability};
pub use remap::{Remap, RemapError, Route};
pub use service::{ServiceClient, ServiceMapping};
pub use subscription::{Received, Subscription, TopicCounters};
