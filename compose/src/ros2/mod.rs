//! The ROS 2 world: rodlog on a ROS 2 graph of real drivers (or of `rodlog sim --ros2`).
//!
//! | module | what |
//! |---|---|
//! | this one | [`Ros2Config`] (`world = "ros2"`, keys `ros2.*`), [`Ros2World`] (the config with its remap files loaded) |
//! | [`record`] | [`record::record`]: subscribe, stamp, run the pipeline live ([`recorder::run_live`]), record |
//! | [`motion`] | the command path: which outputs leave the process (`--allow-motion`), how |
//! | [`safety`] | e-stop, stale data, driver status: when motion holds; the watchdog |
//! | [`source`] | [`source::TopicSource`]: one DDS subscription as a live source, through the remap |
//! | [`sim_node`] | [`sim_node::run`]: the simulator as a ROS 2 node in real time (`rodlog sim --ros2`) |
//!
//! The graph's drivers deliver on their own clock, so this world runs under the live runtime
//! rather than the lockstep scheduler; its [`msgs::drivers::World`] face only refuses.
//!
//! The one part of compose that reads the wall clock (waiting for discovery, pacing the
//! simulator node, the watchdog): it is the edge, like `recorder::live`; stages only ever
//! see the robot time the runtime hands them.
#![allow(clippy::disallowed_methods)]

use std::path::{Path, PathBuf};

use msgs::RobotDuration;
use ros2::{DiscoveryRange, NodeOptions, Remap};
use scenario::{ParamError, Reader};

use crate::error::ComposeError;

pub mod motion;
pub mod record;
pub mod safety;
pub mod sim_node;
pub mod source;

/// Which stages run on the graph's data.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ros2Pipeline {
    /// Only `robot_state` (`record --ros2` without a scenario: record and compute TF).
    RobotState,
    /// The robot's whole software, as on the simulator: `robot_state`, `script`,
    /// `calibration`, and `perceive` and `task` when the scenario enables them.
    Full,
}

impl Ros2Pipeline {
    /// The key's value.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::RobotState => "robot_state",
            Self::Full => "full",
        }
    }
}

/// Whether robot time follows the graph's `/clock`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SimTime {
    /// Follow `/clock` when a writer of it is on the graph at the start.
    Auto,
    /// Always follow `/clock` (wait for it).
    On,
    /// Never: robot time is wall time since the start.
    Off,
}

/// The ROS 2 world's configuration (`ros2.*`).
#[derive(Debug, Clone, PartialEq)]
pub struct Ros2Config {
    /// Domain; `None`: `ROS_DOMAIN_ID`, else 0.
    pub domain_id: Option<u16>,
    /// Discovery range; `None`: `ROS_AUTOMATIC_DISCOVERY_RANGE` / `ROS_LOCALHOST_ONLY`, else
    /// the subnet.
    pub discovery: Option<DiscoveryRange>,
    /// Remap files, in order (names resolve to `config/remap/NAME.toml`).
    pub remap: Vec<String>,
    /// The stages.
    pub pipeline: Ros2Pipeline,
    /// The node's name on the graph.
    pub node_name: String,
    /// Robot time source.
    pub use_sim_time: SimTime,
    /// How long the runtime waits for late arrivals before processing (robot time).
    pub merge_delay: RobotDuration,
    /// Messages the runtime may fall behind by before inputs are dropped.
    pub input_capacity: usize,
    /// With motion: no `/joint_states` for longer than this (robot time) holds.
    pub joint_states_deadline: RobotDuration,
    /// With motion: a capture without its colour image after this much robot time holds.
    pub capture_deadline: RobotDuration,
}

impl Default for Ros2Config {
    fn default() -> Self {
        Self {
            domain_id: None,
            discovery: None,
            remap: Vec::new(),
            pipeline: Ros2Pipeline::Full,
            node_name: "rodlog".to_owned(),
            use_sim_time: SimTime::Auto,
            merge_delay: RobotDuration::from_millis(30),
            input_capacity: 4096,
            joint_states_deadline: safety::JOINT_STATES_DEADLINE,
            capture_deadline: safety::CAPTURE_DEADLINE,
        }
    }
}

impl Ros2Config {
    /// Reads `ros2.*` through `r`.
    ///
    /// # Errors
    /// [`ParamError::Value`] for a wrong type or an out-of-range value.
    pub fn from_params(r: &mut Reader<'_>) -> Result<Self, ParamError> {
        let d = Self::default();
        let mut s = r.section("ros2");
        let domain = s.f64_opt(
            "domain_id",
            "ROS_DOMAIN_ID, else 0",
            "",
            "the ROS 2 domain to join",
        )?;
        let domain_id = match domain {
            None => None,
            Some(v)
                if v.fract() == 0.0
                    && (0.0..=f64::from(ros2::names::MAX_DOMAIN_ID)).contains(&v) =>
            {
                Some(v as u16)
            }
            Some(v) => {
                return Err(ParamError::Value {
                    key: "ros2.domain_id".to_owned(),
                    value: v.to_string(),
                    reason: format!(
                        "a domain id is an integer in 0..={}",
                        ros2::names::MAX_DOMAIN_ID
                    ),
                });
            }
        };
        let discovery = match s
            .choice(
                "discovery",
                "env",
                &["env", "localhost", "subnet"],
                "where to look for the other nodes: env (ROS_AUTOMATIC_DISCOVERY_RANGE, ROS_LOCALHOST_ONLY), localhost, subnet",
            )?
            .as_str()
        {
            "localhost" => Some(DiscoveryRange::Localhost),
            "subnet" => Some(DiscoveryRange::Subnet),
            _ => None,
        };
        let remap_text = s.string(
            "remap",
            "",
            "remap files, comma-separated: paths, or names in config/remap/ (aubo_i10, mecheye_nano)",
        )?;
        let remap = remap_text
            .split(',')
            .map(str::trim)
            .filter(|p| !p.is_empty())
            .map(str::to_owned)
            .collect();
        let pipeline = if s.choice(
            "pipeline",
            d.pipeline.name(),
            &[Ros2Pipeline::Full.name(), Ros2Pipeline::RobotState.name()],
            "the stages: full (as on the simulator) or robot_state only",
        )? == Ros2Pipeline::RobotState.name()
        {
            Ros2Pipeline::RobotState
        } else {
            Ros2Pipeline::Full
        };
        let node_name = s.string("node_name", &d.node_name, "the node's name on the graph")?;
        let use_sim_time = match s
            .choice(
                "use_sim_time",
                "auto",
                &["auto", "on", "off"],
                "robot time from the graph's /clock: auto (when one is published), on, off (wall time)",
            )?
            .as_str()
        {
            "on" => SimTime::On,
            "off" => SimTime::Off,
            _ => SimTime::Auto,
        };
        let merge_delay = s.millis(
            "merge_delay_ms",
            d.merge_delay,
            "how long the runtime waits for late arrivals before processing (robot time)",
        )?;
        let input_capacity = s.count(
            "input_capacity",
            d.input_capacity,
            1,
            "messages the runtime may fall behind by before inputs are dropped",
        )?;
        let joint_states_deadline = s.millis(
            "joint_states_deadline_ms",
            d.joint_states_deadline,
            "with --allow-motion: no /joint_states for longer than this (robot time) holds motion",
        )?;
        let capture_deadline = s.seconds(
            "capture_deadline_s",
            d.capture_deadline,
            "with --allow-motion: a capture without its image after this much robot time holds motion",
        )?;
        Ok(Self {
            domain_id,
            discovery,
            remap,
            pipeline,
            node_name,
            use_sim_time,
            merge_delay,
            input_capacity,
            joint_states_deadline,
            capture_deadline,
        })
    }

    /// The node options.
    #[must_use]
    pub fn node_options(&self) -> NodeOptions {
        NodeOptions {
            name: self.node_name.clone(),
            domain_id: self.domain_id,
            discovery: self.discovery,
            ..NodeOptions::default()
        }
    }
}

/// The folders remap names are looked up in: `config/remap` here and in the source tree.
#[must_use]
pub fn remap_dirs() -> Vec<PathBuf> {
    vec![
        PathBuf::from("config/remap"),
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../config/remap"),
    ]
}

/// The file of a remap name or path: an existing file, else `NAME.toml` in [`remap_dirs`].
///
/// # Errors
/// [`ComposeError::Remap`] naming every place tried.
pub fn find_remap(name_or_path: &str) -> Result<PathBuf, ComposeError> {
    let direct = PathBuf::from(name_or_path);
    if direct.is_file() {
        return Ok(direct);
    }
    let mut tried = vec![direct.display().to_string()];
    for dir in remap_dirs() {
        let p = dir.join(format!("{name_or_path}.toml"));
        if p.is_file() {
            return Ok(p);
        }
        tried.push(p.display().to_string());
    }
    Err(ComposeError::Remap(Box::new(ros2::RemapError::Io {
        path: PathBuf::from(name_or_path),
        source: std::io::Error::new(
            std::io::ErrorKind::NotFound,
            format!("no such remap file (tried {})", tried.join(", ")),
        ),
    })))
}

/// The ROS 2 world: its configuration with the remap files read and validated.
#[derive(Debug, Clone)]
pub struct Ros2World {
    /// The configuration.
    pub config: Ros2Config,
    /// The merged remap.
    pub remap: Remap,
}

impl Ros2World {
    /// Reads the remap files of `config`.
    ///
    /// # Errors
    /// [`ComposeError::Remap`]: a file that is missing, malformed or in conflict with another.
    pub fn new(config: &Ros2Config) -> Result<Self, ComposeError> {
        let paths = config
            .remap
            .iter()
            .map(|n| find_remap(n))
            .collect::<Result<Vec<_>, _>>()?;
        let remap = Remap::load(&paths).map_err(|e| ComposeError::Remap(Box::new(e)))?;
        Ok(Self {
            config: config.clone(),
            remap,
        })
    }
}

impl msgs::drivers::World for Ros2World {
    fn step_until(
        &mut self,
        log_time: msgs::RobotTime,
    ) -> Result<Vec<msgs::drivers::DriverOutput>, msgs::drivers::DriverError> {
        Err(msgs::drivers::DriverError::Fault {
            device: "ros2".to_owned(),
            now: log_time,
            reason: "the ROS 2 graph runs on its own clock under the live runtime (compose::ros2::record), not stepped in lockstep".to_owned(),
        })
    }

    fn command(
        &mut self,
        log_time: msgs::RobotTime,
        topic: &str,
        _msg: &msgs::Msg,
    ) -> Result<(), msgs::drivers::DriverError> {
        Err(msgs::drivers::DriverError::Rejected {
            device: "ros2".to_owned(),
            now: log_time,
            reason: format!("{topic}: commands reach the graph only through the live command path"),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use scenario::Params;

    fn config(sets: &[&str]) -> Result<Ros2Config, ParamError> {
        let mut p = Params::new();
        for s in sets {
            p.set_from_arg(s)?;
        }
        Ros2Config::from_params(&mut Reader::new(&p))
    }

    #[test]
    fn keys_are_read_and_checked() -> Result<(), Box<dyn std::error::Error>> {
        let c = config(&[
            "ros2.domain_id=17",
            "ros2.discovery=\"localhost\"",
            "ros2.remap=\"aubo_i10, mecheye_nano\"",
            "ros2.pipeline=\"robot_state\"",
        ])?;
        assert_eq!(c.domain_id, Some(17));
        assert_eq!(c.discovery, Some(DiscoveryRange::Localhost));
        assert_eq!(c.remap, ["aubo_i10", "mecheye_nano"]);
        assert_eq!(c.pipeline, Ros2Pipeline::RobotState);
        let world = Ros2World::new(&c)?;
        assert_eq!(world.remap.files.len(), 2);
        assert!(config(&["ros2.domain_id=300"]).is_err());
        assert!(config(&["ros2.domain_id=1.5"]).is_err());
        assert!(config(&["ros2.discovery=\"lan\""]).is_err());
        let missing = Ros2World::new(&config(&["ros2.remap=\"no_such_driver\""])?)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(missing.contains("no_such_driver"), "{missing}");
        Ok(())
    }
}
