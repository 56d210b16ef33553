//! [`Node`]: one DDS participant in a ROS 2 domain, the factory of publishers and
//! subscriptions, and the view of the graph.
//!
//! # Domain and discovery
//!
//! The domain is [`NodeOptions::domain_id`], else `ROS_DOMAIN_ID`, else 0. Discovery follows
//! ROS 2 Jazzy's `ROS_AUTOMATIC_DISCOVERY_RANGE` (`LOCALHOST` or `SUBNET`; Humble's
//! `ROS_LOCALHOST_ONLY=1` is read too) unless [`NodeOptions::discovery`] says otherwise;
//! ROS 2's default is the subnet. [`DiscoveryRange::Localhost`] advertises and uses only
//! 127.0.0.1 and finds the other participants of the host by unicast to their well-known
//! ports (no multicast): what the tests and benchmarks use, and what rmw_cyclonedds does with
//! `ROS_LOCALHOST_ONLY=1` (the Cyclone peer, `scripts/dds/cyclone_peer.py`, is set up so).

use std::net::{IpAddr, Ipv4Addr};
use std::sync::Arc;

use rustdds::bytes::Bytes;
use rustdds::{DomainParticipant, DomainParticipantBuilder, QosPolicies, RTPSEntity, TopicKind};

use crate::error::Ros2Error;
use crate::graph::{Endpoint, EndpointKind, LocalEndpoints};
use crate::names;
use crate::publisher::Publisher;
use crate::qos::Qos;
use crate::raw::RawCdr;
use crate::service::{ServiceClient, ServiceMapping};
use crate::subscription::Subscription;

/// Where participants look for each other.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DiscoveryRange {
    /// Only this host, over the loopback interface.
    Localhost,
    /// Every interface (multicast discovery on the LAN): ROS 2's default.
    Subnet,
}

impl DiscoveryRange {
    /// From `ROS_AUTOMATIC_DISCOVERY_RANGE` (`LOCALHOST`, `SUBNET`) or `ROS_LOCALHOST_ONLY=1`;
    /// `None` when neither says.
    pub fn from_env() -> Option<DiscoveryRange> {
        match std::env::var("ROS_AUTOMATIC_DISCOVERY_RANGE").as_deref() {
            Ok("LOCALHOST") => return Some(DiscoveryRange::Localhost),
            Ok("SUBNET") => return Some(DiscoveryRange::Subnet),
            _ => {}
        }
        std::env::var("ROS_LOCALHOST_ONLY")
            .is_ok_and(|v| v == "1")
            .then_some(DiscoveryRange::Localhost)
    }
}

/// How to create a [`Node`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NodeOptions {
    /// Node name (default `rodlog`).
    pub name: String,
    /// Namespace relative topic names resolve in (default `/`).
    pub namespace: String,
    /// Domain; `None`: `ROS_DOMAIN_ID`, else 0 (default `None`).
    pub domain_id: Option<u16>,
    /// Discovery range; `None`: [`DiscoveryRange::from_env`], else subnet (default `None`).
    pub discovery: Option<DiscoveryRange>,
}

impl Default for NodeOptions {
    fn default() -> Self {
        NodeOptions {
            name: "rodlog".to_string(),
            namespace: "/".to_string(),
            domain_id: None,
            discovery: None,
        }
    }
}

/// A ROS 2 node on DDS: one participant, one DDS publisher and subscriber for all topics.
/// Dropping it (or [`Node::shutdown`]) leaves the domain; publishers and subscriptions hold
/// the participant alive until they are dropped too.
pub struct Node {
    name: String,
    namespace: String,
    domain_id: u16,
    discovery: DiscoveryRange,
    participant: DomainParticipant,
    dds_publisher: rustdds::Publisher,
    dds_subscriber: rustdds::Subscriber,
    local: LocalEndpoints,
}

impl std::fmt::Debug for Node {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Node")
            .field("name", &self.name)
            .field("namespace", &self.namespace)
            .field("domain_id", &self.domain_id)
            .field("discovery", &self.discovery)
            .finish()
    }
}

impl Node {
    /// Joins the domain.
    ///
    /// # Errors
    /// [`Ros2Error::InvalidDomainIdEnv`], [`Ros2Error::DomainIdOutOfRange`],
    /// [`Ros2Error::InvalidName`] (namespace), [`Ros2Error::Participant`] (sockets).
    pub fn new(options: NodeOptions) -> Result<Node, Ros2Error> {
        let domain_id = match options.domain_id {
            Some(d) => d,
            None => names::domain_id_from_env()?.unwrap_or(0),
        };
        if domain_id > names::MAX_DOMAIN_ID {
            return Err(Ros2Error::DomainIdOutOfRange {
                domain_id,
                max: names::MAX_DOMAIN_ID,
            });
        }
        if options.namespace != "/" {
            names::resolve("/", &options.namespace)?;
        }
        let discovery = options
            .discovery
            .or_else(DiscoveryRange::from_env)
            .unwrap_or(DiscoveryRange::Subnet);
        let mut builder = DomainParticipantBuilder::new(domain_id);
        if discovery == DiscoveryRange::Localhost {
            builder = builder
                .with_only_networks([IpAddr::V4(Ipv4Addr::LOCALHOST)])
                .same_host_loopback(true);
        }
        let participant_err = |e: &dyn std::fmt::Display| Ros2Error::Participant {
            domain_id,
            reason: e.to_string(),
        };
        let participant = builder.build().map_err(|e| participant_err(&e))?;
        let none = QosPolicies::qos_none();
        let dds_publisher = participant
            .create_publisher(&none)
            .map_err(|e| participant_err(&e))?;
        let dds_subscriber = participant
            .create_subscriber(&none)
            .map_err(|e| participant_err(&e))?;
        Ok(Node {
            name: options.name,
            namespace: options.namespace,
            domain_id,
            discovery,
            participant,
            dds_publisher,
            dds_subscriber,
            local: LocalEndpoints::default(),
        })
    }

    /// Node name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Namespace.
    pub fn namespace(&self) -> &str {
        &self.namespace
    }

    /// The domain joined.
    pub fn domain_id(&self) -> u16 {
        self.domain_id
    }

    /// The GUID prefix of this node's participant (the first 12 bytes of every
    /// [`Endpoint::guid`] it owns).
    pub fn guid_prefix(&self) -> [u8; 12] {
        let mut p = [0_u8; 12];
        p.copy_from_slice(&self.participant.guid().to_bytes()[..12]);
        p
    }

    /// The discovery range in force.
    pub fn discovery_range(&self) -> DiscoveryRange {
        self.discovery
    }

    /// Subscribes to `topic` (absolute, or relative to the namespace) of ROS type `type_name`
    /// (`sensor_msgs/msg/Image`).
    ///
    /// # Errors
    /// [`Ros2Error::InvalidName`], [`Ros2Error::InvalidTypeName`],
    /// [`Ros2Error::CreateEndpoint`], [`Ros2Error::Poll`].
    pub fn subscribe_raw(
        &self,
        topic: &str,
        type_name: &str,
        qos: Qos,
    ) -> Result<Subscription, Ros2Error> {
        let (ros_topic, dds_topic, dds_type) = self.names(topic, type_name)?;
        let dds_qos = qos.to_dds();
        let t = self.topic(&ros_topic, &dds_topic, &dds_type, &dds_qos)?;
        let reader = self
            .dds_subscriber
            .create_datareader_no_key::<Vec<u8>, RawCdr>(&t, Some(dds_qos.clone()))
            .map_err(|e| create_err(&ros_topic, "reader", &e))?;
        let guid = reader.guid();
        self.local.insert(Endpoint::new(
            EndpointKind::Reader,
            &dds_topic,
            &dds_type,
            guid,
            true,
            dds_qos.reliability(),
            dds_qos.durability(),
        ));
        Subscription::register(
            Arc::from(ros_topic.as_str()),
            reader,
            self.local.clone(),
            guid.to_bytes(),
            self.guid_prefix(),
        )
    }

    /// Subscribes to a registry topic with its type and [`Qos::for_subscription`].
    ///
    /// # Errors
    /// See [`Node::subscribe_raw`].
    pub fn subscribe_spec(&self, spec: &msgs::TopicSpec) -> Result<Subscription, Ros2Error> {
        self.subscribe_raw(spec.name, spec.type_name, Qos::for_subscription(spec))
    }

    /// A publisher on `topic` (absolute, or relative to the namespace) of ROS type
    /// `type_name`.
    ///
    /// # Errors
    /// [`Ros2Error::InvalidName`], [`Ros2Error::InvalidTypeName`],
    /// [`Ros2Error::CreateEndpoint`].
    pub fn publisher_raw(
        &self,
        topic: &str,
        type_name: &str,
        qos: Qos,
    ) -> Result<Publisher, Ros2Error> {
        let (ros_topic, dds_topic, dds_type) = self.names(topic, type_name)?;
        let dds_qos = qos.to_dds();
        let t = self.topic(&ros_topic, &dds_topic, &dds_type, &dds_qos)?;
        let writer = self
            .dds_publisher
            .create_datawriter_no_key::<Bytes, RawCdr>(&t, Some(dds_qos.clone()))
            .map_err(|e| create_err(&ros_topic, "writer", &e))?;
        let guid = writer.guid();
        self.local.insert(Endpoint::new(
            EndpointKind::Writer,
            &dds_topic,
            &dds_type,
            guid,
            true,
            dds_qos.reliability(),
            dds_qos.durability(),
        ));
        Ok(Publisher {
            topic: ros_topic,
            writer,
            local: self.local.clone(),
            guid: guid.to_bytes(),
            published: Arc::default(),
        })
    }

    /// A publisher on a registry topic with its type and [`Qos::for_publisher`].
    ///
    /// # Errors
    /// See [`Node::publisher_raw`].
    pub fn publisher_spec(&self, spec: &msgs::TopicSpec) -> Result<Publisher, Ros2Error> {
        self.publisher_raw(spec.name, spec.type_name, Qos::for_publisher(spec))
    }

    /// A raw client of `service` (absolute, or relative to the namespace) of type `srv_type`
    /// (`pkg/srv/Name`, or an action's `pkg/action/Name_SendGoal`), matching replies as the
    /// server's middleware does (`mapping`).
    ///
    /// # Errors
    /// [`Ros2Error::InvalidName`], [`Ros2Error::InvalidServiceType`],
    /// [`Ros2Error::CreateEndpoint`], [`Ros2Error::Poll`].
    pub fn service_client_raw(
        &self,
        service: &str,
        srv_type: &str,
        mapping: ServiceMapping,
    ) -> Result<ServiceClient, Ros2Error> {
        let ros_service = names::resolve(&self.namespace, service)?;
        let (rq, rr) = names::dds_service_topics(&ros_service)?;
        let types = (srv_type.contains("/srv/") || srv_type.contains("/action/"))
            .then(|| {
                Some((
                    names::dds_type(&format!("{srv_type}_Request")).ok()?,
                    names::dds_type(&format!("{srv_type}_Response")).ok()?,
                ))
            })
            .flatten();
        let Some((rq_type, rr_type)) = types else {
            return Err(Ros2Error::InvalidServiceType {
                type_name: srv_type.to_string(),
            });
        };
        let qos = Qos::COMMAND.to_dds();
        let rq_topic = self.topic(&ros_service, &rq, &rq_type, &qos)?;
        let rr_topic = self.topic(&ros_service, &rr, &rr_type, &qos)?;
        let writer = self
            .dds_publisher
            .create_datawriter_no_key::<Bytes, RawCdr>(&rq_topic, Some(qos.clone()))
            .map_err(|e| create_err(&ros_service, "request writer", &e))?;
        let reader = self
            .dds_subscriber
            .create_datareader_no_key::<Vec<u8>, RawCdr>(&rr_topic, Some(qos.clone()))
            .map_err(|e| create_err(&ros_service, "reply reader", &e))?;
        for (kind, topic, type_name, guid) in [
            (EndpointKind::Writer, &rq, &rq_type, writer.guid()),
            (EndpointKind::Reader, &rr, &rr_type, reader.guid()),
        ] {
            self.local.insert(Endpoint::new(
                kind,
                topic,
                type_name,
                guid,
                true,
                qos.reliability(),
                qos.durability(),
            ));
        }
        ServiceClient::new(ros_service, mapping, writer, reader, self.local.clone())
    }

    /// Whether a server of `service` is discovered: a remote reader of its requests and a
    /// remote writer of its replies.
    ///
    /// # Errors
    /// [`Ros2Error::InvalidName`].
    pub fn service_available(&self, service: &str) -> Result<bool, Ros2Error> {
        let (rq, rr) = names::dds_service_topics(&names::resolve(&self.namespace, service)?)?;
        let all = self.endpoints();
        let has = |kind, topic: &str| {
            all.iter()
                .any(|e| !e.local && e.kind == kind && e.dds_topic == topic)
        };
        Ok(has(EndpointKind::Reader, &rq) && has(EndpointKind::Writer, &rr))
    }

    /// Every writer and reader known: this node's, then those discovered from other
    /// participants (discovery is asynchronous: a remote endpoint appears some 10-500 ms
    /// after it was created).
    pub fn endpoints(&self) -> Vec<Endpoint> {
        let mut all = self.local.all();
        for w in self.participant.discovered_writers() {
            let d = &w.publication_topic_data;
            all.push(Endpoint::new(
                EndpointKind::Writer,
                &d.topic_name,
                &d.type_name,
                d.key,
                false,
                d.reliability,
                d.durability,
            ));
        }
        for r in self.participant.discovered_readers() {
            let d = &r.subscription_topic_data;
            let qos = d.qos();
            all.push(Endpoint::new(
                EndpointKind::Reader,
                d.topic_name(),
                d.type_name(),
                d.key(),
                false,
                qos.reliability(),
                qos.durability(),
            ));
        }
        all
    }

    /// The writers on a ROS topic (absolute, or relative to the namespace), local and remote.
    ///
    /// # Errors
    /// [`Ros2Error::InvalidName`].
    pub fn writers_on(&self, topic: &str) -> Result<Vec<Endpoint>, Ros2Error> {
        self.endpoints_on(topic, EndpointKind::Writer)
    }

    /// The readers on a ROS topic (absolute, or relative to the namespace), local and remote.
    ///
    /// # Errors
    /// [`Ros2Error::InvalidName`].
    pub fn readers_on(&self, topic: &str) -> Result<Vec<Endpoint>, Ros2Error> {
        self.endpoints_on(topic, EndpointKind::Reader)
    }

    fn endpoints_on(&self, topic: &str, kind: EndpointKind) -> Result<Vec<Endpoint>, Ros2Error> {
        let dds_topic = names::dds_topic(&names::resolve(&self.namespace, topic)?)?;
        Ok(self
            .endpoints()
            .into_iter()
            .filter(|e| e.kind == kind && e.dds_topic == dds_topic)
            .collect())
    }

    /// Leaves the domain (the same as dropping the node; publishers and subscriptions still
    /// alive keep the participant until they are dropped).
    pub fn shutdown(self) {}

    fn names(&self, topic: &str, type_name: &str) -> Result<(String, String, String), Ros2Error> {
        let ros_topic = names::resolve(&self.namespace, topic)?;
        let dds_topic = names::dds_topic(&ros_topic)?;
        let dds_type = names::dds_type(type_name)?;
        Ok((ros_topic, dds_topic, dds_type))
    }

    fn topic(
        &self,
        ros_topic: &str,
        dds_topic: &str,
        dds_type: &str,
        qos: &QosPolicies,
    ) -> Result<rustdds::Topic, Ros2Error> {
        self.participant
            .create_topic(
                dds_topic.to_string(),
                dds_type.to_string(),
                qos,
                TopicKind::NoKey,
            )
            .map_err(|e| create_err(ros_topic, "topic", &e))
    }
}

fn create_err(topic: &str, what: &'static str, e: &dyn std::fmt::Display) -> Ros2Error {
    Ros2Error::CreateEndpoint {
        topic: topic.to_string(),
        what,
        reason: e.to_string(),
    }
}
