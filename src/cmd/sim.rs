//! `rodlog sim --ros2 --scenario S [--duration SECONDS] [--rate R] [--domain N]`: the
//! simulator as its own ROS 2 node in real time ([`compose::ros2::sim_node`]): it publishes
//! the sensor topics, `/clock` and the `/sim/*` truth, and carries out the commands any node
//! publishes on the command topics.

use anyhow::{Context as _, bail};
use compose::ros2::sim_node::{SimNodeOptions, run as run_node};
use ros2::{DiscoveryRange, NodeOptions};

/// Arguments of `rodlog sim`.
#[derive(Debug, clap::Args)]
pub struct SimArgs {
    /// Run as a ROS 2 node (the only mode: `rodlog record` runs the simulator in-process).
    #[arg(long)]
    pub ros2: bool,
    /// Scenario name (recordings/scenarios/NAME.toml) or file; its world must be the simulator.
    #[arg(long)]
    pub scenario: String,
    /// Override the scenario's seed.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Robot time to simulate, seconds (default: the scenario's duration).
    #[arg(long)]
    pub duration: Option<f64>,
    /// Robot time runs R times faster than wall time (`/clock` tells the other nodes).
    #[arg(long, default_value_t = 1.0)]
    pub rate: f64,
    /// Override a parameter, `key=value` (repeatable).
    #[arg(long = "set", value_name = "K=V")]
    pub set: Vec<String>,
    /// The crew's survey of the bay, a site file (`config/sites/*.toml`, ARCHITECTURE.md
    /// section 5): what the robot plans with instead of the built-in fixed bay.
    #[arg(long, value_name = "FILE")]
    pub site: Option<std::path::PathBuf>,
    /// The ROS 2 domain (default: ROS_DOMAIN_ID, else 0).
    #[arg(long)]
    pub domain: Option<u16>,
    /// Discovery: localhost or subnet (default: ROS_AUTOMATIC_DISCOVERY_RANGE /
    /// ROS_LOCALHOST_ONLY, else subnet).
    #[arg(long)]
    pub discovery: Option<String>,
}

/// Runs `rodlog sim`.
///
/// # Errors
/// No --ros2, a bad rate or discovery, the scenario's and the node's errors.
pub fn run(args: &SimArgs) -> anyhow::Result<()> {
    if !args.ros2 {
        bail!("rodlog sim needs --ros2 (to run the simulator in-process, use rodlog record)");
    }
    if !(args.rate.is_finite() && args.rate > 0.0 && args.rate <= 100.0) {
        bail!("--rate {} must be in (0, 100]", args.rate);
    }
    let discovery = match args.discovery.as_deref() {
        None => None,
        Some("localhost") => Some(DiscoveryRange::Localhost),
        Some("subnet") => Some(DiscoveryRange::Subnet),
        Some(other) => bail!("--discovery {other:?}: expected localhost or subnet"),
    };
    let plan = super::record::plan(
        &args.scenario,
        args.seed,
        args.duration,
        &args.set,
        args.site.as_deref(),
    )?;
    let options = SimNodeOptions {
        rate: args.rate,
        duration: plan.scenario().duration,
        node: NodeOptions {
            name: "rodlog_sim".to_owned(),
            domain_id: args.domain,
            discovery,
            ..NodeOptions::default()
        },
        ..SimNodeOptions::default()
    };
    eprintln!(
        "rodlog sim: scenario {} on the ROS 2 graph, {} s of robot time at {}x (Ctrl-C stops)",
        plan.scenario().name,
        plan.scenario().duration.as_secs_f64(),
        args.rate
    );
    let s = run_node(&plan, &options)
        .with_context(|| format!("simulating {} as a ROS 2 node", plan.scenario().name))?;
    super::print_stdout(&format!(
        "simulated {} of robot time{}: published {} messages ({} refused by writers), {} commands received ({} rejected), {} chunks behind real time",
        s.end,
        if s.interrupted { " (interrupted)" } else { "" },
        s.published,
        s.publish_errors,
        s.commands,
        s.rejected,
        s.late_chunks
    ))
}
