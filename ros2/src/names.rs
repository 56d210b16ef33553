//! ROS 2 names on DDS, as every ROS 2 middleware (rmw) maps them.
//!
//! | ROS 2 | DDS |
//! |---|---|
//! | topic `/joint_states` | topic `rt/joint_states` |
//! | service `/mecheye/capture` | topics `rq/mecheye/captureRequest`, `rr/mecheye/captureReply` |
//! | type `sensor_msgs/msg/JointState` | type `sensor_msgs::msg::dds_::JointState_` |
//! | type `pkg/srv/Capture_Request` | type `pkg::srv::dds_::Capture_Request_` |
//!
//! Relative names (no leading `/`) resolve against the node's namespace; `~` (private names)
//! is not supported. Source: ROS 2 design article "Topic and Service name mapping to DDS".

use crate::error::Ros2Error;

/// Prefix of ROS topics on DDS.
pub const TOPIC_PREFIX: &str = "rt";
/// Prefix of service request topics on DDS.
pub const REQUEST_PREFIX: &str = "rq";
/// Prefix of service reply topics on DDS.
pub const REPLY_PREFIX: &str = "rr";
/// Largest domain id: the RTPS port of a participant is `7400 + 250 * domain + 10 + 2 * index`,
/// which must stay below 65536 (ROS 2's documentation: 0..=101 and 215..=232 are safe on
/// Linux, the rest may collide with ephemeral ports).
pub const MAX_DOMAIN_ID: u16 = 232;

/// The fully qualified ROS name of `name` in `namespace` (`/` + namespace + `/` + name for a
/// relative name; absolute names as they are), checked.
///
/// # Errors
/// [`Ros2Error::InvalidName`] for an empty name, a `~` name, a trailing `/`, `//`, or a
/// character other than `[A-Za-z0-9_/]`.
pub fn resolve(namespace: &str, name: &str) -> Result<String, Ros2Error> {
    let bad = |reason| Ros2Error::InvalidName {
        name: name.to_string(),
        reason,
    };
    if name.is_empty() {
        return Err(bad("empty"));
    }
    if name.starts_with('~') {
        return Err(bad("private (~) names are not supported"));
    }
    let full = if name.starts_with('/') {
        name.to_string()
    } else {
        let ns = namespace.trim_end_matches('/');
        let ns = if ns.starts_with('/') || ns.is_empty() {
            ns.to_string()
        } else {
            format!("/{ns}")
        };
        format!("{ns}/{name}")
    };
    if full.len() > 1 && full.ends_with('/') {
        return Err(bad("ends with /"));
    }
    if full.contains("//") {
        return Err(bad("contains //"));
    }
    if !full
        .bytes()
        .all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'/')
    {
        return Err(bad("only A-Z, a-z, 0-9, _ and / are allowed"));
    }
    if full
        .split('/')
        .any(|token| token.bytes().next().is_some_and(|b| b.is_ascii_digit()))
    {
        return Err(bad("a name token starts with a digit"));
    }
    Ok(full)
}

/// DDS topic of a fully qualified ROS topic: `/joint_states` -> `rt/joint_states`.
///
/// # Errors
/// [`Ros2Error::InvalidName`] (see [`resolve`]; the name must be absolute).
pub fn dds_topic(ros_topic: &str) -> Result<String, Ros2Error> {
    if !ros_topic.starts_with('/') {
        return Err(Ros2Error::InvalidName {
            name: ros_topic.to_string(),
            reason: "not fully qualified (no leading /)",
        });
    }
    let full = resolve("/", ros_topic)?;
    Ok(format!("{TOPIC_PREFIX}{full}"))
}

/// The ROS topic of a DDS topic, `None` for DDS topics that are not ROS topics (`rq/`, `rr/`,
/// DDS-only topics such as `ros_discovery_info`).
pub fn ros_topic(dds_topic: &str) -> Option<&str> {
    dds_topic
        .strip_prefix(TOPIC_PREFIX)
        .filter(|rest| rest.starts_with('/'))
}

/// The DDS request and reply topics of a fully qualified service name:
/// `/mecheye/capture` -> (`rq/mecheye/captureRequest`, `rr/mecheye/captureReply`).
///
/// # Errors
/// [`Ros2Error::InvalidName`] (see [`dds_topic`]).
pub fn dds_service_topics(ros_service: &str) -> Result<(String, String), Ros2Error> {
    let full = dds_topic(ros_service)?;
    let path = &full[TOPIC_PREFIX.len()..];
    Ok((
        format!("{REQUEST_PREFIX}{path}Request"),
        format!("{REPLY_PREFIX}{path}Reply"),
    ))
}

/// DDS type name of a ROS type: `sensor_msgs/msg/JointState` ->
/// `sensor_msgs::msg::dds_::JointState_`; `pkg/Type` is taken as `pkg/msg/Type`.
///
/// # Errors
/// [`Ros2Error::InvalidTypeName`] unless the name is `pkg/Type` or `pkg/(msg|srv|action)/Type`
/// with identifier characters.
pub fn dds_type(ros_type: &str) -> Result<String, Ros2Error> {
    let bad = || Ros2Error::InvalidTypeName {
        type_name: ros_type.to_string(),
    };
    let parts: Vec<&str> = ros_type.split('/').collect();
    let (pkg, kind, name) = match parts.as_slice() {
        [pkg, name] => (*pkg, "msg", *name),
        [pkg, kind @ ("msg" | "srv" | "action"), name] => (*pkg, *kind, *name),
        _ => return Err(bad()),
    };
    let ident = |s: &str| {
        !s.is_empty()
            && s.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'_')
            && s.bytes().next().is_some_and(|b| b.is_ascii_alphabetic())
    };
    if !ident(pkg) || !ident(name) {
        return Err(bad());
    }
    Ok(format!("{pkg}::{kind}::dds_::{name}_"))
}

/// The domain id in `ROS_DOMAIN_ID`, `None` when unset or empty (ROS 2 then uses 0).
///
/// # Errors
/// [`Ros2Error::InvalidDomainIdEnv`] when it is set to something else than `0..=232`.
pub fn domain_id_from_env() -> Result<Option<u16>, Ros2Error> {
    match std::env::var("ROS_DOMAIN_ID") {
        Ok(v) if v.trim().is_empty() => Ok(None),
        Ok(v) => match v.trim().parse::<u16>() {
            Ok(d) if d <= MAX_DOMAIN_ID => Ok(Some(d)),
            _ => Err(Ros2Error::InvalidDomainIdEnv {
                value: v,
                max: MAX_DOMAIN_ID,
            }),
        },
        Err(_) => Ok(None),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn topics_map_to_rt_and_back() {
        assert_eq!(
            dds_topic("/joint_states").ok().as_deref(),
            Some("rt/joint_states")
        );
        assert_eq!(
            dds_topic("/camera/color/image_raw").ok().as_deref(),
            Some("rt/camera/color/image_raw")
        );
        assert_eq!(ros_topic("rt/tf_static"), Some("/tf_static"));
        assert_eq!(ros_topic("rq/x/yRequest"), None);
        assert_eq!(ros_topic("ros_discovery_info"), None);
        for t in msgs::registry() {
            let dds = dds_topic(t.name).expect(t.name);
            assert_eq!(ros_topic(&dds), Some(t.name));
        }
    }

    #[test]
    fn bad_names_are_refused_with_the_reason() {
        for bad in ["", "joint_states", "/a//b", "/a/", "/a b", "/a/1b", "~/x"] {
            assert!(dds_topic(bad).is_err(), "{bad:?}");
        }
    }

    #[test]
    fn relative_names_resolve_in_the_namespace() {
        assert_eq!(resolve("/", "image").ok().as_deref(), Some("/image"));
        assert_eq!(resolve("", "image").ok().as_deref(), Some("/image"));
        assert_eq!(
            resolve("/camera/color", "image_raw").ok().as_deref(),
            Some("/camera/color/image_raw")
        );
        assert_eq!(resolve("cam", "x").ok().as_deref(), Some("/cam/x"));
        assert_eq!(resolve("/cam", "/abs").ok().as_deref(), Some("/abs"));
    }

    #[test]
    fn types_map_to_dds_names() {
        assert_eq!(
            dds_type("sensor_msgs/msg/JointState").ok().as_deref(),
            Some("sensor_msgs::msg::dds_::JointState_")
        );
        assert_eq!(
            dds_type("tf2_msgs/TFMessage").ok().as_deref(),
            Some("tf2_msgs::msg::dds_::TFMessage_")
        );
        assert_eq!(
            dds_type("mecheye_ros_interface/srv/CaptureColorImage_Request")
                .ok()
                .as_deref(),
            Some("mecheye_ros_interface::srv::dds_::CaptureColorImage_Request_")
        );
        for bad in [
            "Image",
            "a/b/c/d",
            "pkg/foo/T",
            "pkg/msg/",
            "1pkg/T",
            "pkg/T-x",
        ] {
            assert!(dds_type(bad).is_err(), "{bad}");
        }
        for t in msgs::Msg::TYPE_NAMES {
            assert!(dds_type(t).is_ok(), "{t}");
        }
    }

    #[test]
    fn services_map_to_request_and_reply_topics() {
        let (rq, rr) = dds_service_topics("/mecheye/capture").expect("valid");
        assert_eq!(rq, "rq/mecheye/captureRequest");
        assert_eq!(rr, "rr/mecheye/captureReply");
    }
}
