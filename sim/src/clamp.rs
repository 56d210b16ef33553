//! The lead-screw clamp ([`ClampDriver`]): `clamp_joint` is the travel (m) of the grounding
//! rod's clamp jaw, driven through the end effector's brushless geared motor.
//!
//! Travel `[0, 0.05]` m ([`CLAMP_TRAVEL_M`]) at up to 5 mm/s and 20 mm/s^2, so a full stroke
//! takes about 10 s. `CLOSE` drives towards full travel and stops at the contact travel the
//! world sets (the jaw meeting the conductor, [`WIRE_CONTACT_TRAVEL_M`] for a 26.8 mm wire),
//! where the motor holds `max_torque_nm` (effort); `OPEN` drives back to 0; `STOP` brakes
//! and holds. Joint state (producer `clamp_driver`, 100 Hz): position + `N(0, 0.02 mm)`
//! encoder noise, velocity, effort = motor torque (N m): [`FRICTION_TORQUE_NM`] while moving,
//! the commanded maximum while pressing on a contact, 0 at rest. A jaw already past the
//! contact travel (by more than [`LATE_CONTACT_M`]) when the contact appears has closed in
//! front of the conductor: the wire cannot enter the mouth, and the jaw does not bite it.

use msgs::RobotTime;
use msgs::drivers::{ClampDriver, DriverError};
use msgs::frames::CLAMP_JOINT;
use msgs::rodlog_msgs::ClampCommand;
use msgs::sensor_msgs::JointState;
use msgs::std_msgs::Header;

use crate::arm::{TICK_S, TickClock};
use crate::motion::Axis;
use crate::rng::{self, streams};

/// How far past the contact travel a closing jaw may be when the contact appears and still
/// bite (m): a tenth of a second of travel at the 5 mm/s stroke.
pub const LATE_CONTACT_M: f64 = 5e-4;
/// Producer of the clamp's joint state.
pub const CLAMP_DRIVER: &str = "clamp_driver";
pub use robot::grounding_rod::{CLAMP_TRAVEL_M, WIRE_CONTACT_TRAVEL_M};
/// Screw speed limit (m/s).
pub const CLAMP_SPEED_M_S: f64 = 0.005;
/// Screw acceleration limit (m/s^2).
pub const CLAMP_ACCEL_M_S2: f64 = 0.02;
/// Motor torque while moving freely (N m).
pub const FRICTION_TORQUE_NM: f64 = 0.3;
/// Torque limit used when a command gives 0 (N m).
pub const DEFAULT_MAX_TORQUE_NM: f64 = 5.0;
/// Largest accepted torque limit (N m).
pub const MAX_TORQUE_LIMIT_NM: f64 = 20.0;
/// Encoder noise (m, 1-sigma).
pub const CLAMP_ENCODER_SIGMA_M: f64 = 2e-5;

/// The simulated clamp.
#[derive(Debug, Clone)]
pub struct ClampSim {
    seed: u64,
    axis: Axis,
    closing: bool,
    max_torque_nm: f64,
    contact_travel_m: Option<f64>,
    encoder_sigma_m: f64,
    clock: TickClock,
}

impl ClampSim {
    /// An open clamp at rest.
    #[must_use]
    pub fn new(seed: u64, encoder_noise: bool) -> Self {
        Self {
            seed,
            axis: Axis::at_rest(0.0, CLAMP_SPEED_M_S, CLAMP_ACCEL_M_S2),
            closing: false,
            max_torque_nm: DEFAULT_MAX_TORQUE_NM,
            contact_travel_m: None,
            encoder_sigma_m: if encoder_noise {
                CLAMP_ENCODER_SIGMA_M
            } else {
                0.0
            },
            clock: TickClock {
                ticks: 0,
                last: RobotTime::ZERO,
            },
        }
    }

    /// True travel (m).
    #[must_use]
    pub fn travel_m(&self) -> f64 {
        self.axis.position
    }

    /// Whether the screw rests (at its goal, or pressing on a contact).
    #[must_use]
    pub fn idle(&self) -> bool {
        self.axis.settled()
    }

    /// Whether the jaw presses on its contact.
    #[must_use]
    pub fn pressing(&self) -> bool {
        self.closing
            && self
                .contact_travel_m
                .is_some_and(|c| self.axis.position >= c)
            && self.axis.settled()
    }

    /// Sets (or clears) the travel where the jaw meets something; a closing jaw reaching it
    /// is stopped there. A jaw already past it by more than [`LATE_CONTACT_M`] (closed in
    /// front of the conductor, which swung in late) meets nothing.
    pub fn set_contact(&mut self, contact_travel_m: Option<f64>) {
        let contact_travel_m =
            contact_travel_m.filter(|c| self.axis.position <= c + LATE_CONTACT_M);
        self.contact_travel_m = contact_travel_m;
        if self.closing {
            self.axis.goal = contact_travel_m
                .unwrap_or(CLAMP_TRAVEL_M)
                .min(CLAMP_TRAVEL_M);
            if self.axis.position > self.axis.goal {
                self.axis.position = self.axis.goal;
                self.axis.velocity = 0.0;
            }
        }
    }

    /// Couples the motor to a rod screw at `travel_m` (the end effector engaging a rod): the
    /// axis jumps there and holds (a closing command keeps pressing if at the contact).
    pub fn couple(&mut self, travel_m: f64) {
        let t = travel_m.clamp(0.0, CLAMP_TRAVEL_M);
        self.axis.position = t;
        self.axis.velocity = 0.0;
        self.axis.goal = t;
        self.closing = self.contact_travel_m.is_some_and(|c| t >= c);
    }

    /// Advances to `now`.
    ///
    /// # Errors
    /// [`DriverError::TimeWentBackwards`].
    pub fn advance(&mut self, now: RobotTime) -> Result<(), DriverError> {
        let n = self.clock.ticks_until(CLAMP_DRIVER, now)?;
        for _ in 0..n {
            self.axis.step(TICK_S);
        }
        Ok(())
    }

    fn effort_nm(&self) -> f64 {
        if self.pressing() {
            self.max_torque_nm
        } else if self.axis.velocity != 0.0 {
            FRICTION_TORQUE_NM * self.axis.velocity.signum()
        } else {
            0.0
        }
    }
}

impl ClampDriver for ClampSim {
    fn command(&mut self, now: RobotTime, command: &ClampCommand) -> Result<(), DriverError> {
        self.advance(now)?;
        let reject = |reason: String| DriverError::Rejected {
            device: CLAMP_DRIVER.to_owned(),
            now,
            reason,
        };
        match command.action {
            ClampCommand::OPEN => {
                self.closing = false;
                self.axis.goal = 0.0;
            }
            ClampCommand::CLOSE => {
                let t = command.max_torque_nm;
                if !(0.0..=MAX_TORQUE_LIMIT_NM).contains(&t) {
                    return Err(reject(format!(
                        "max_torque_nm {t} outside [0, {MAX_TORQUE_LIMIT_NM}]"
                    )));
                }
                self.max_torque_nm = if t == 0.0 { DEFAULT_MAX_TORQUE_NM } else { t };
                self.closing = true;
                self.axis.goal = self
                    .contact_travel_m
                    .unwrap_or(CLAMP_TRAVEL_M)
                    .min(CLAMP_TRAVEL_M);
            }
            ClampCommand::STOP => {
                self.closing = false;
                let v = self.axis.velocity;
                let stop = self.axis.position + v * v.abs() / (2.0 * CLAMP_ACCEL_M_S2);
                self.axis.goal = stop.clamp(0.0, CLAMP_TRAVEL_M);
            }
            other => {
                return Err(reject(format!(
                    "unknown action {other} (0 open, 1 close, 2 stop)"
                )));
            }
        }
        self.axis.v_lim = CLAMP_SPEED_M_S;
        self.axis.a_lim = CLAMP_ACCEL_M_S2;
        Ok(())
    }

    fn joint_state(&mut self, now: RobotTime) -> Result<JointState, DriverError> {
        self.advance(now)?;
        let stamp = now.to_ros().map_err(|e| DriverError::Fault {
            device: CLAMP_DRIVER.to_owned(),
            now,
            reason: e.to_string(),
        })?;
        let n = rng::normal(self.seed, streams::CLAMP_ENCODER, now.as_nanos());
        Ok(JointState {
            header: Header {
                stamp,
                frame_id: String::new(),
            },
            name: vec![CLAMP_JOINT.to_owned()],
            position: vec![self.axis.position + self.encoder_sigma_m * n],
            velocity: vec![self.axis.velocity],
            effort: vec![self.effort_nm()],
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cmd(action: u8, torque: f64) -> ClampCommand {
        ClampCommand {
            action,
            max_torque_nm: torque,
            ..Default::default()
        }
    }

    #[test]
    fn closing_takes_time_and_stops_on_contact_with_torque() -> Result<(), DriverError> {
        let mut c = ClampSim::new(1, false);
        c.set_contact(Some(WIRE_CONTACT_TRAVEL_M));
        c.command(RobotTime::ZERO, &cmd(ClampCommand::CLOSE, 8.0))?;
        c.advance(RobotTime::from_millis(5000))?;
        assert!(
            c.travel_m() < WIRE_CONTACT_TRAVEL_M,
            "still closing after 5 s"
        );
        let js = c.joint_state(RobotTime::from_millis(12_000))?;
        assert_eq!(js.position, vec![WIRE_CONTACT_TRAVEL_M]);
        assert_eq!(js.effort, vec![8.0]);
        assert!(c.pressing());
        c.command(
            RobotTime::from_millis(12_000),
            &cmd(ClampCommand::OPEN, 0.0),
        )?;
        c.advance(RobotTime::from_millis(25_000))?;
        assert_eq!(c.travel_m(), 0.0);
        assert!(
            c.command(RobotTime::from_millis(25_000), &cmd(7, 1.0))
                .is_err()
        );
        // Closed fully on nothing, the jaw does not bite a wire that swings in afterwards.
        let mut late = ClampSim::new(1, false);
        late.command(RobotTime::ZERO, &cmd(ClampCommand::CLOSE, 8.0))?;
        late.advance(RobotTime::from_millis(12_000))?;
        assert!((late.travel_m() - CLAMP_TRAVEL_M).abs() < 1e-9);
        late.set_contact(Some(WIRE_CONTACT_TRAVEL_M));
        late.advance(RobotTime::from_millis(13_000))?;
        assert!((late.travel_m() - CLAMP_TRAVEL_M).abs() < 1e-9);
        assert!(!late.pressing());
        assert!(
            c.command(
                RobotTime::from_millis(25_000),
                &cmd(ClampCommand::CLOSE, 99.0)
            )
            .is_err()
        );
        Ok(())
    }
}
