//! [`World`]: the worlds a run can be recorded in, behind one [`msgs::drivers::World`].
//!
//! The simulator and the recorder's test world are stepped in lockstep with the stages by the
//! scheduler; the ROS 2 graph of real drivers (or of `rodlog sim --ros2`) delivers on its own
//! clock, so it runs under the live runtime ([`crate::ros2::record`]) and its lockstep face
//! refuses.

use msgs::drivers::{DriverError, DriverOutput};
use msgs::{Msg, RobotTime};
use recorder::test_world::TestWorld;
use sim::SimWorld;

use crate::ros2::Ros2World;

/// A world built by [`crate::Plan::world`].
#[derive(Debug)]
pub enum World {
    /// The deterministic substation simulator.
    Sim(Box<SimWorld>),
    /// The recorder's small test world.
    Test(Box<TestWorld>),
    /// A ROS 2 graph.
    Ros2(Box<Ros2World>),
}

impl msgs::drivers::World for World {
    fn step_until(&mut self, log_time: RobotTime) -> Result<Vec<DriverOutput>, DriverError> {
        match self {
            Self::Sim(w) => w.step_until(log_time),
            Self::Test(w) => w.step_until(log_time),
            Self::Ros2(w) => w.step_until(log_time),
        }
    }

    fn command(&mut self, log_time: RobotTime, topic: &str, msg: &Msg) -> Result<(), DriverError> {
        match self {
            Self::Sim(w) => w.command(log_time, topic, msg),
            Self::Test(w) => w.command(log_time, topic, msg),
            Self::Ros2(w) => w.command(log_time, topic, msg),
        }
    }
}
