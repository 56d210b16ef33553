//! The lift ([`LiftDriver`]): `lift_joint` height command (m) in, joint state out.
//!
//! Travel `[0, 2.0]` m at up to 0.10 m/s and 0.20 m/s^2 (the robot crate's nominal lift,
//! [`robot::kinematics`]); a command outside the travel or non-finite is rejected. Joint
//! state (producer `lift_driver`, 100 Hz): position + `N(0, 0.1 mm)` encoder noise
//! ([`LIFT_ENCODER_SIGMA_M`], off with `robot.encoder_noise = false`), true velocity. The
//! platform's wind tilt (see [`crate::environment`]) is not measured by the encoder.

use msgs::RobotTime;
use msgs::drivers::{DriverError, LiftDriver};
use msgs::frames::LIFT_JOINT;
use msgs::sensor_msgs::JointState;
use msgs::std_msgs::{Float64, Header};
use robot::kinematics::{LIFT_ACCEL_MAX_M_S2, LIFT_SPEED_MAX_M_S, LIFT_TRAVEL_M};

use crate::arm::{TICK_S, TickClock};
use crate::motion::Axis;
use crate::rng::{self, streams};

/// Producer of the lift's joint state.
pub const LIFT_DRIVER: &str = "lift_driver";
/// Lift encoder noise (m, 1-sigma).
pub const LIFT_ENCODER_SIGMA_M: f64 = 1e-4;

/// The simulated lift.
#[derive(Debug, Clone)]
pub struct LiftSim {
    seed: u64,
    axis: Axis,
    encoder_sigma_m: f64,
    clock: TickClock,
}

impl LiftSim {
    /// A lift at rest at `height_m`.
    #[must_use]
    pub fn new(seed: u64, height_m: f64, encoder_noise: bool) -> Self {
        Self {
            seed,
            axis: Axis::at_rest(height_m, LIFT_SPEED_MAX_M_S, LIFT_ACCEL_MAX_M_S2),
            encoder_sigma_m: if encoder_noise {
                LIFT_ENCODER_SIGMA_M
            } else {
                0.0
            },
            clock: TickClock {
                ticks: 0,
                last: RobotTime::ZERO,
            },
        }
    }

    /// True height (m).
    #[must_use]
    pub fn height_m(&self) -> f64 {
        self.axis.position
    }

    /// Whether it rests on its goal.
    #[must_use]
    pub fn idle(&self) -> bool {
        self.axis.settled()
    }

    /// Advances to `now`.
    ///
    /// # Errors
    /// [`DriverError::TimeWentBackwards`].
    pub fn advance(&mut self, now: RobotTime) -> Result<(), DriverError> {
        let n = self.clock.ticks_until(LIFT_DRIVER, now)?;
        for _ in 0..n {
            self.axis.step(TICK_S);
        }
        Ok(())
    }
}

impl LiftDriver for LiftSim {
    fn command_height(&mut self, now: RobotTime, height_m: &Float64) -> Result<(), DriverError> {
        self.advance(now)?;
        let h = height_m.data;
        if !(0.0..=LIFT_TRAVEL_M).contains(&h) {
            return Err(DriverError::Rejected {
                device: LIFT_DRIVER.to_owned(),
                now,
                reason: format!("height {h} m outside the travel [0, {LIFT_TRAVEL_M}] m"),
            });
        }
        self.axis.goal = h;
        self.axis.v_lim = LIFT_SPEED_MAX_M_S;
        self.axis.a_lim = LIFT_ACCEL_MAX_M_S2;
        Ok(())
    }

    fn joint_state(&mut self, now: RobotTime) -> Result<JointState, DriverError> {
        self.advance(now)?;
        let stamp = now.to_ros().map_err(|e| DriverError::Fault {
            device: LIFT_DRIVER.to_owned(),
            now,
            reason: e.to_string(),
        })?;
        let n = rng::normal(self.seed, streams::LIFT_ENCODER, now.as_nanos());
        Ok(JointState {
            header: Header {
                stamp,
                frame_id: String::new(),
            },
            name: vec![LIFT_JOINT.to_owned()],
            position: vec![self.axis.position + self.encoder_sigma_m * n],
            velocity: vec![self.axis.velocity],
            effort: Vec::new(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rises_at_its_speed_and_rejects_out_of_travel() -> Result<(), DriverError> {
        let mut lift = LiftSim::new(1, 0.0, false);
        lift.command_height(RobotTime::ZERO, &Float64 { data: 1.0 })?;
        let js = lift.joint_state(RobotTime::from_millis(5000))?;
        assert!(
            js.position.first().is_some_and(|p| (0.3..0.6).contains(p)),
            "{:?}",
            js.position
        );
        assert!(
            js.velocity
                .first()
                .is_some_and(|v| (*v - LIFT_SPEED_MAX_M_S).abs() < 1e-9)
        );
        lift.advance(RobotTime::from_millis(12_000))?;
        assert_eq!(lift.height_m(), 1.0);
        assert!(
            lift.command_height(RobotTime::from_millis(12_000), &Float64 { data: 2.5 })
                .is_err()
        );
        assert!(
            lift.command_height(RobotTime::from_millis(12_000), &Float64 { data: f64::NAN })
                .is_err()
        );
        Ok(())
    }
}
