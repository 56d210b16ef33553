//! [`World`]: the worlds a run can be recorded in, behind one [`msgs::drivers::World`].
//!
//! The simulator and the recorder's test world today; a ROS 2 graph of real drivers is the
//! next variant (its drivers deliver on their own clock, so it runs under the live runtime
//! rather than the lockstep scheduler).

use msgs::drivers::{DriverError, DriverOutput};
use msgs::{Msg, RobotTime};
use recorder::test_world::TestWorld;
use sim::SimWorld;

/// A world built by [`crate::Plan::world`].
#[derive(Debug)]
pub enum World {
    /// The deterministic substation simulator.
    Sim(Box<SimWorld>),
    /// The recorder's small test world.
    Test(Box<TestWorld>),
}

impl msgs::drivers::World for World {
    fn step_until(&mut self, log_time: RobotTime) -> Result<Vec<DriverOutput>, DriverError> {
        match self {
            Self::Sim(w) => w.step_until(log_time),
            Self::Test(w) => w.step_until(log_time),
        }
    }

    fn command(&mut self, log_time: RobotTime, topic: &str, msg: &Msg) -> Result<(), DriverError> {
        match self {
            Self::Sim(w) => w.command(log_time, topic, msg),
            Self::Test(w) => w.command(log_time, topic, msg),
        }
    }
}
