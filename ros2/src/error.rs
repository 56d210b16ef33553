//! [`Ros2Error`]: everything the transport can refuse or fail at, with the names and numbers
//! that explain it.

use thiserror::Error;

/// Errors of the ROS 2 transport.
#[derive(Debug, Error)]
pub enum Ros2Error {
    /// A topic or service name is not a valid ROS 2 name.
    #[error("invalid ROS 2 name {name:?}: {reason}")]
    InvalidName {
        /// The name given.
        name: String,
        /// What is wrong with it.
        reason: &'static str,
    },
    /// A type name is not `pkg/msg/Type` (or `pkg/Type`, `pkg/srv/Type_Request`).
    #[error(
        "invalid ROS 2 type name {type_name:?} (expected pkg/msg/Type, e.g. sensor_msgs/msg/Image)"
    )]
    InvalidTypeName {
        /// The type name given.
        type_name: String,
    },
    /// `ROS_DOMAIN_ID` is set but is not a number.
    #[error("ROS_DOMAIN_ID={value:?} is not a domain id (0..={max})")]
    InvalidDomainIdEnv {
        /// The variable's value.
        value: String,
        /// Largest domain id accepted.
        max: u16,
    },
    /// The domain id is too large for the RTPS port mapping (7400 + 250 * domain + ...).
    #[error("domain id {domain_id} is out of range (0..={max}: RTPS ports must stay below 65536)")]
    DomainIdOutOfRange {
        /// The domain id asked for.
        domain_id: u16,
        /// Largest domain id accepted.
        max: u16,
    },
    /// The DDS participant could not be created (sockets, ports).
    #[error("cannot create the DDS participant on domain {domain_id}: {reason}")]
    Participant {
        /// The domain.
        domain_id: u16,
        /// RustDDS's explanation.
        reason: String,
    },
    /// A topic, reader or writer could not be created.
    #[error("cannot create the {what} for {topic}: {reason}")]
    CreateEndpoint {
        /// ROS topic name.
        topic: String,
        /// `topic`, `reader` or `writer`.
        what: &'static str,
        /// RustDDS's explanation.
        reason: String,
    },
    /// A payload to publish is shorter than the encapsulation header.
    #[error("payload for {topic} is {len} bytes, shorter than the 4-byte CDR encapsulation header")]
    PayloadTooShort {
        /// ROS topic name.
        topic: String,
        /// Payload length.
        len: usize,
    },
    /// A payload to publish is not little-endian plain CDR (`00 01`), what `msgs` writes.
    #[error(
        "payload for {topic} has encapsulation {b0:#04x} {b1:#04x}, expected 0x00 0x01 (XCDR1 little-endian, what msgs::Msg::encode writes)"
    )]
    UnsupportedEncapsulation {
        /// ROS topic name.
        topic: String,
        /// First header byte.
        b0: u8,
        /// Second header byte.
        b1: u8,
    },
    /// The DDS writer refused or timed out (reliable writers block while readers lag).
    #[error("publish on {topic} failed: {reason}")]
    Write {
        /// ROS topic name.
        topic: String,
        /// RustDDS's explanation.
        reason: String,
    },
    /// Taking a sample from the DDS reader failed.
    #[error("receive on {topic} failed: {reason}")]
    Read {
        /// ROS topic name.
        topic: String,
        /// RustDDS's explanation.
        reason: String,
    },
    /// A service reply is too short for the service mapping's header.
    #[error("reply of service {service} is {len} bytes, too short for its request header")]
    ServiceReply {
        /// Service name.
        service: String,
        /// Reply length.
        len: usize,
    },
    /// A service type is not `pkg/srv/Name`.
    #[error(
        "invalid ROS 2 service type {type_name:?} (expected pkg/srv/Name, e.g. std_srvs/srv/Trigger)"
    )]
    InvalidServiceType {
        /// The type name given.
        type_name: String,
    },
    /// Waiting for data (the `mio` poll) failed.
    #[error("waiting for data on {topic} failed: {source}")]
    Poll {
        /// ROS topic name.
        topic: String,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
}
