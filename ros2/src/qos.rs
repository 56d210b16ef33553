//! [`Qos`]: the three policies ROS 2 drivers set (reliability, durability, keep-last depth),
//! and the presets rodlog uses.
//!
//! Matching rules (DDS 1.4, 2.2.3): a best-effort reader matches reliable and best-effort
//! writers; a reliable reader matches only reliable writers. A volatile reader matches
//! transient-local writers (and gets no history); a transient-local reader matches only
//! transient-local writers. Hence:
//!
//! | role | preset | why |
//! |---|---|---|
//! | sensor subscription (images, joint states, TF) | [`Qos::SENSOR_SUBSCRIPTION`]: best effort, volatile, depth 5 | matches every publisher (rclcpp's `SensorDataQoS`) |
//! | latched subscription (`/tf_static`, camera info, URDF) | [`Qos::LATCHED_SUBSCRIPTION`]: reliable, transient local, depth 100 | gets the history a late joiner needs (tf2's static listener) |
//! | command and ordinary publisher | [`Qos::COMMAND`]: reliable, volatile, depth 10 | rclcpp's default; reliable readers match it |
//! | latched publisher | [`Qos::LATCHED`]: reliable, transient local, depth 1 | tf2's static broadcaster; `msgs::topics::QOS_LATCHED_YAML` |
//!
//! Large images: keep-last depth bounds the memory a slow reader holds (5 x 5.2 MB for depth).

use msgs::TopicSpec;
use rustdds::{QosPolicies, QosPolicyBuilder, policy};

/// Reliability policy.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reliability {
    /// Retransmit until acknowledged (writers block up to [`MAX_BLOCKING_TIME_MS`] when full).
    Reliable,
    /// Send once.
    BestEffort,
}

/// Durability policy.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Durability {
    /// No history for late joiners.
    Volatile,
    /// The writer keeps its last `depth` samples for late-joining readers ("latched").
    TransientLocal,
}

/// How long a reliable write may block while the history is full of unacknowledged samples
/// (rclcpp's default: 100 ms).
pub const MAX_BLOCKING_TIME_MS: u64 = 100;

/// Quality of service of one reader or writer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Qos {
    /// Reliability.
    pub reliability: Reliability,
    /// Durability.
    pub durability: Durability,
    /// Keep-last history depth (samples), at least 1.
    pub depth: u32,
}

impl Qos {
    /// Sensor subscriptions: best effort, volatile, keep last 5.
    pub const SENSOR_SUBSCRIPTION: Qos = Qos {
        reliability: Reliability::BestEffort,
        durability: Durability::Volatile,
        depth: 5,
    };
    /// Latched subscriptions: reliable, transient local, keep last 100.
    pub const LATCHED_SUBSCRIPTION: Qos = Qos {
        reliability: Reliability::Reliable,
        durability: Durability::TransientLocal,
        depth: 100,
    };
    /// Commands and ordinary publishers: reliable, volatile, keep last 10.
    pub const COMMAND: Qos = Qos {
        reliability: Reliability::Reliable,
        durability: Durability::Volatile,
        depth: 10,
    };
    /// Latched publishers: reliable, transient local, keep last 1.
    pub const LATCHED: Qos = Qos {
        reliability: Reliability::Reliable,
        durability: Durability::TransientLocal,
        depth: 1,
    };

    /// The subscription QoS of a registry topic: latched ones get the history, the rest
    /// match any publisher.
    pub fn for_subscription(spec: &TopicSpec) -> Qos {
        if spec.latched {
            Qos::LATCHED_SUBSCRIPTION
        } else {
            Qos::SENSOR_SUBSCRIPTION
        }
    }

    /// The publisher QoS of a registry topic, as its `offered_qos_profiles` says: latched
    /// ones transient local depth 1, the rest reliable depth 10.
    pub fn for_publisher(spec: &TopicSpec) -> Qos {
        if spec.latched {
            Qos::LATCHED
        } else {
            Qos::COMMAND
        }
    }

    /// The same QoS with another depth.
    pub const fn with_depth(self, depth: u32) -> Qos {
        Qos { depth, ..self }
    }

    /// The same QoS, best effort.
    pub const fn best_effort(self) -> Qos {
        Qos {
            reliability: Reliability::BestEffort,
            ..self
        }
    }

    /// RustDDS policies.
    pub(crate) fn to_dds(self) -> QosPolicies {
        let reliability = match self.reliability {
            Reliability::Reliable => policy::Reliability::Reliable {
                max_blocking_time: rustdds::Duration::from_millis(MAX_BLOCKING_TIME_MS as i64),
            },
            Reliability::BestEffort => policy::Reliability::BestEffort,
        };
        let durability = match self.durability {
            Durability::Volatile => policy::Durability::Volatile,
            Durability::TransientLocal => policy::Durability::TransientLocal,
        };
        let depth = i32::try_from(self.depth.max(1)).unwrap_or(i32::MAX);
        QosPolicyBuilder::new()
            .reliability(reliability)
            .durability(durability)
            .history(policy::History::KeepLast { depth })
            .build()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn registry_topics_get_the_qos_their_yaml_says() {
        for spec in msgs::registry() {
            let publ = Qos::for_publisher(spec);
            let sub = Qos::for_subscription(spec);
            if spec.latched {
                assert!(spec.offered_qos_profiles.contains("transient_local"));
                assert_eq!(publ, Qos::LATCHED);
                assert_eq!(sub.durability, Durability::TransientLocal);
                assert_eq!(sub.reliability, Reliability::Reliable);
            } else {
                assert!(spec.offered_qos_profiles.contains("depth: 10"));
                assert_eq!(publ, Qos::COMMAND);
                assert_eq!(sub.reliability, Reliability::BestEffort);
            }
        }
    }

    #[test]
    fn dds_policies_carry_the_settings() {
        let q = Qos::LATCHED_SUBSCRIPTION.to_dds();
        assert!(q.is_reliable());
        assert!(!q.is_volatile());
        assert_eq!(q.history(), Some(policy::History::KeepLast { depth: 100 }));
        let q = Qos::SENSOR_SUBSCRIPTION.with_depth(0).to_dds();
        assert!(!q.is_reliable());
        assert_eq!(q.history(), Some(policy::History::KeepLast { depth: 1 }));
    }
}
