//! A small deterministic [`World`] standing in for the simulator (`sim` crate) in recorder
//! and replay tests: an arm that tracks commanded joint goals within speed limits, a lift
//! that holds its height, and an anemometer.
//!
//! | producer | topic | rate | content |
//! |---|---|---|---|
//! | `arm_driver` | `/joint_states` | `test_world.joint_rate_hz` (50 Hz) | six arm joints: position + seeded Gaussian encoder noise (`test_world.encoder_noise_rad`), velocity |
//! | `lift_driver` | `/joint_states` | same | `lift_joint` at `test_world.lift_m` |
//! | `anemometer` | `/env/wind` | 1 Hz | 3-s mean of an Ornstein-Uhlenbeck wind (`test_world.wind_mean_mps`, `test_world.wind_sigma_mps`) + sensor noise |
//!
//! Arm model: a `/arm/joint_trajectory` command sets each joint's goal to the last point's
//! position; the joint moves at constant speed `min(v_max, |goal - q| / time_from_start)`
//! (`v_max` = AUBO i10's 3.14 rad/s, J3 2.57 rad/s, times `test_world.speed_scale`) and stops
//! on the goal. Goals outside +-175 deg or with unknown joint names are rejected.
//! All randomness comes from `rng::SplitMix64` streams seeded with the scenario seed.

use msgs::drivers::{DriverError, DriverOutput, World};
use msgs::frames::{ARM_JOINT_NAMES, LIFT_JOINT};
use msgs::sensor_msgs::JointState;
use msgs::std_msgs::{Float64, Header};
use msgs::trajectory_msgs::JointTrajectory;
use msgs::{Msg, RobotDuration, RobotTime};

use rng::SplitMix64;
use scenario::{ParamError, Reader};

/// Producer of the arm's joint states.
pub const ARM_DRIVER: &str = "arm_driver";
/// Producer of the lift's joint state.
pub const LIFT_DRIVER: &str = "lift_driver";
/// Producer of `/env/wind`.
pub const ANEMOMETER: &str = "anemometer";
/// Joint limit of every arm joint, rad (+-175 deg).
pub const JOINT_LIMIT_RAD: f64 = 175.0 * std::f64::consts::PI / 180.0;
/// Maximum joint speeds of the AUBO i10, rad/s (J3 is slower).
#[allow(clippy::approx_constant)] // the datasheet's 3.14 rad/s, not an approximation of pi
pub const MAX_SPEED_RAD_S: [f64; 6] = [3.14, 3.14, 2.57, 3.14, 3.14, 3.14];
/// Home pose the arm starts in, rad.
pub const HOME_RAD: [f64; 6] = [0.0, 0.3, 1.2, 0.0, 1.57, 0.0];
/// Wind process step (10 Hz) and averaging window (3 s = 30 steps).
const WIND_STEP_NS: u64 = 100_000_000;
const WIND_WINDOW: usize = 30;
/// Correlation time of the wind process, s.
const WIND_TAU_S: f64 = 4.0;
/// Anemometer noise (1 sigma), m/s.
const ANEMOMETER_NOISE_MPS: f64 = 0.05;

/// Parameters of the [`TestWorld`] (`test_world.*`).
#[derive(Debug, Clone, PartialEq)]
pub struct TestWorldConfig {
    /// Seed of all noise.
    pub seed: u64,
    /// Joint-state rate, Hz. Default 50.
    pub joint_rate_hz: f64,
    /// Encoder noise, 1 sigma, rad. Default 1e-4.
    pub encoder_noise_rad: f64,
    /// Fraction of the arm's maximum speeds used. Default 0.25.
    pub speed_scale: f64,
    /// Lift height, m. Default 0.8.
    pub lift_m: f64,
    /// Mean wind, m/s. Default 1.5.
    pub wind_mean_mps: f64,
    /// Wind fluctuation, 1 sigma, m/s. Default 0.6.
    pub wind_sigma_mps: f64,
}

impl TestWorldConfig {
    /// Reads `test_world.*` through `r`, with `seed`.
    ///
    /// # Errors
    /// [`ParamError::Value`] for wrong types or out-of-range values.
    pub fn from_params(seed: u64, r: &mut Reader<'_>) -> Result<Self, ParamError> {
        let mut s = r.section("test_world");
        Ok(Self {
            seed,
            joint_rate_hz: s.f64_in(
                "joint_rate_hz",
                50.0,
                1e-3..=1000.0,
                "Hz",
                "joint-state rate",
            )?,
            encoder_noise_rad: s.non_negative(
                "encoder_noise_rad",
                1e-4,
                "rad",
                "encoder noise, 1-sigma",
            )?,
            speed_scale: s.f64_in(
                "speed_scale",
                0.25,
                1e-3..=1.0,
                "",
                "fraction of the arm's maximum speeds",
            )?,
            lift_m: s.f64("lift_m", 0.8, "m", "lift height")?,
            wind_mean_mps: s.f64("wind_mean_mps", 1.5, "m/s", "mean wind")?,
            wind_sigma_mps: s.non_negative(
                "wind_sigma_mps",
                0.6,
                "m/s",
                "wind fluctuation, 1-sigma",
            )?,
        })
    }
}

/// The deterministic test world. See the module docs.
#[derive(Debug, Clone)]
pub struct TestWorld {
    config: TestWorldConfig,
    period_ns: u64,
    /// Time the state is integrated to.
    now: RobotTime,
    /// Last `step_until` target (`None` before the first step).
    stepped_to: Option<RobotTime>,
    next_joint_tick: u64,
    next_wind_step_ns: u64,
    q_rad: [f64; 6],
    speed_rad_s: [f64; 6],
    goal_rad: [f64; 6],
    arm_noise: SplitMix64,
    wind_rng: SplitMix64,
    wind_true_mps: f64,
    wind_window: Vec<f64>,
}

impl TestWorld {
    /// A world at the home pose at time 0.
    pub fn new(config: TestWorldConfig) -> Self {
        let period_ns = (1e9 / config.joint_rate_hz).round().max(1.0) as u64;
        let arm_noise = SplitMix64::new(config.seed ^ 0xA5A5_0000_0000_0001);
        let wind_rng = SplitMix64::new(config.seed ^ 0x5A5A_0000_0000_0002);
        let wind = config.wind_mean_mps;
        Self {
            config,
            period_ns,
            now: RobotTime::ZERO,
            stepped_to: None,
            next_joint_tick: 0,
            next_wind_step_ns: 0,
            q_rad: HOME_RAD,
            speed_rad_s: [0.0; 6],
            goal_rad: HOME_RAD,
            arm_noise,
            wind_rng,
            wind_true_mps: wind,
            wind_window: Vec::with_capacity(WIND_WINDOW),
        }
    }

    /// True joint positions (no noise), rad.
    pub fn joint_positions_rad(&self) -> [f64; 6] {
        self.q_rad
    }

    fn integrate_to(&mut self, t: RobotTime) {
        let Some(dt) = t.checked_duration_since(self.now) else {
            return;
        };
        let dt_s = dt.as_secs_f64();
        for j in 0..6 {
            let err = self.goal_rad[j] - self.q_rad[j];
            let step = self.speed_rad_s[j] * dt_s;
            if err.abs() <= step {
                self.q_rad[j] = self.goal_rad[j];
                self.speed_rad_s[j] = 0.0;
            } else {
                self.q_rad[j] += step.copysign(err);
            }
        }
        self.now = t;
    }

    fn step_wind(&mut self) {
        // Ornstein-Uhlenbeck, exact discretisation at 10 Hz.
        let dt_s = WIND_STEP_NS as f64 * 1e-9;
        let a = (-dt_s / WIND_TAU_S).exp();
        let noise = self.config.wind_sigma_mps * (1.0 - a * a).sqrt() * self.wind_rng.normal();
        self.wind_true_mps = self.config.wind_mean_mps
            + a * (self.wind_true_mps - self.config.wind_mean_mps)
            + noise;
        if self.wind_window.len() == WIND_WINDOW {
            self.wind_window.remove(0);
        }
        self.wind_window.push(self.wind_true_mps.max(0.0));
    }

    fn joint_state(&mut self, t: RobotTime) -> (JointState, JointState) {
        let stamp = t.to_ros().unwrap_or_default();
        let sigma = self.config.encoder_noise_rad;
        let position = (0..6)
            .map(|j| self.q_rad[j] + sigma * self.arm_noise.normal())
            .collect();
        let velocity = (0..6)
            .map(|j| {
                let err = self.goal_rad[j] - self.q_rad[j];
                if err == 0.0 {
                    0.0
                } else {
                    self.speed_rad_s[j].copysign(err)
                }
            })
            .collect();
        let arm = JointState {
            header: Header {
                stamp,
                frame_id: String::new(),
            },
            name: ARM_JOINT_NAMES.iter().map(|s| (*s).to_owned()).collect(),
            position,
            velocity,
            effort: Vec::new(),
        };
        let lift = JointState {
            header: Header {
                stamp,
                frame_id: String::new(),
            },
            name: vec![LIFT_JOINT.to_owned()],
            position: vec![self.config.lift_m],
            velocity: vec![0.0],
            effort: Vec::new(),
        };
        (arm, lift)
    }
}

fn output(producer: &str, topic: &str, t: RobotTime, msg: Msg) -> DriverOutput {
    DriverOutput {
        producer: producer.to_owned(),
        topic: topic.to_owned(),
        msg,
        log_time: t,
        publish_time: t,
    }
}

impl World for TestWorld {
    fn step_until(&mut self, log_time: RobotTime) -> Result<Vec<DriverOutput>, DriverError> {
        if let Some(last) = self.stepped_to
            && log_time < last
        {
            return Err(DriverError::TimeWentBackwards {
                device: "test_world".to_owned(),
                last,
                now: log_time,
            });
        }
        self.stepped_to = Some(log_time);
        let mut out = Vec::new();
        let end_ns = log_time.as_nanos();
        loop {
            let joint_ns = self.next_joint_tick.saturating_mul(self.period_ns);
            let wind_ns = self.next_wind_step_ns;
            let next_ns = joint_ns.min(wind_ns);
            if next_ns > end_ns {
                break;
            }
            let t = RobotTime::from_nanos(next_ns);
            self.integrate_to(t);
            if wind_ns == next_ns {
                self.step_wind();
                self.next_wind_step_ns += WIND_STEP_NS;
                if wind_ns.is_multiple_of(1_000_000_000) && wind_ns > 0 {
                    let mean =
                        self.wind_window.iter().sum::<f64>() / self.wind_window.len().max(1) as f64;
                    let measured = (mean + ANEMOMETER_NOISE_MPS * self.wind_rng.normal()).max(0.0);
                    out.push(output(
                        ANEMOMETER,
                        msgs::topics::ENV_WIND,
                        t,
                        Msg::Float64(Float64 { data: measured }),
                    ));
                }
            }
            if joint_ns == next_ns {
                let (arm, lift) = self.joint_state(t);
                out.push(output(
                    ARM_DRIVER,
                    msgs::topics::JOINT_STATES,
                    t,
                    Msg::JointState(arm),
                ));
                out.push(output(
                    LIFT_DRIVER,
                    msgs::topics::JOINT_STATES,
                    t,
                    Msg::JointState(lift),
                ));
                self.next_joint_tick += 1;
            }
        }
        // The state is integrated only to sample ticks and command times, never to the step
        // target: the stream then does not depend on how the run is split into steps.
        out.sort_by(|a, b| {
            (a.log_time, &a.producer, &a.topic).cmp(&(b.log_time, &b.producer, &b.topic))
        });
        Ok(out)
    }

    fn command(&mut self, log_time: RobotTime, topic: &str, msg: &Msg) -> Result<(), DriverError> {
        let reject = |reason: String| DriverError::Rejected {
            device: ARM_DRIVER.to_owned(),
            now: log_time,
            reason,
        };
        let Some(traj) = msg
            .get::<JointTrajectory>()
            .filter(|_| topic == msgs::topics::ARM_JOINT_TRAJECTORY)
        else {
            return Err(DriverError::UnroutableCommand {
                topic: topic.to_owned(),
                type_name: msg.type_name(),
            });
        };
        let Some(last) = traj.points.last() else {
            return Err(reject("trajectory without points".to_owned()));
        };
        if last.positions.len() != traj.joint_names.len() {
            return Err(reject(format!(
                "{} joint names but {} positions",
                traj.joint_names.len(),
                last.positions.len()
            )));
        }
        let duration_s = RobotDuration::from_ros(last.time_from_start)
            .map_err(|e| reject(e.to_string()))?
            .as_secs_f64();
        let mut goal = self.goal_rad;
        for (name, &p) in traj.joint_names.iter().zip(&last.positions) {
            let Some(j) = ARM_JOINT_NAMES.iter().position(|n| n == name) else {
                return Err(reject(format!("unknown joint {name:?}")));
            };
            if !(p.is_finite() && p.abs() <= JOINT_LIMIT_RAD) {
                return Err(reject(format!("{name} goal {p} rad beyond +-175 deg")));
            }
            goal[j] = p;
        }
        self.integrate_to(log_time.max(self.now));
        for j in 0..6 {
            let v_max = MAX_SPEED_RAD_S[j] * self.config.speed_scale;
            let dist = (goal[j] - self.q_rad[j]).abs();
            self.speed_rad_s[j] = if duration_s > 0.0 {
                (dist / duration_s).min(v_max)
            } else {
                v_max
            };
        }
        self.goal_rad = goal;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use msgs::builtin_interfaces::Duration;
    use msgs::trajectory_msgs::JointTrajectoryPoint;

    fn world(seed: u64) -> Result<TestWorld, ParamError> {
        Ok(TestWorld::new(TestWorldConfig::from_params(
            seed,
            &mut Reader::new(&scenario::Params::new()),
        )?))
    }

    #[test]
    fn rates_and_order() -> Result<(), Box<dyn std::error::Error>> {
        let mut w = world(1)?;
        let out = w.step_until(RobotTime::from_millis(1000))?;
        let joints = out.iter().filter(|o| o.producer == ARM_DRIVER).count();
        let wind = out.iter().filter(|o| o.producer == ANEMOMETER).count();
        assert_eq!(joints, 51); // 0, 20, ..., 1000 ms
        assert_eq!(wind, 1); // at 1 s
        assert!(out.windows(2).all(|p| p[0].log_time <= p[1].log_time));
        assert!(w.step_until(RobotTime::from_millis(500)).is_err());
        Ok(())
    }

    #[test]
    fn same_seed_same_output_other_seed_differs() -> Result<(), Box<dyn std::error::Error>> {
        let a = world(7)?.step_until(RobotTime::from_millis(2000))?;
        let b = world(7)?.step_until(RobotTime::from_millis(2000))?;
        let c = world(8)?.step_until(RobotTime::from_millis(2000))?;
        assert_eq!(a, b);
        assert_ne!(a, c);
        Ok(())
    }

    #[test]
    fn tracks_goal_within_speed_limit() -> Result<(), Box<dyn std::error::Error>> {
        let mut w = world(1)?;
        w.step_until(RobotTime::ZERO)?;
        let mut goal = HOME_RAD;
        goal[0] = 1.0;
        let traj = JointTrajectory {
            joint_names: ARM_JOINT_NAMES.iter().map(|s| (*s).to_owned()).collect(),
            points: vec![JointTrajectoryPoint {
                positions: goal.to_vec(),
                time_from_start: Duration { sec: 0, nanosec: 0 },
                ..Default::default()
            }],
            ..Default::default()
        };
        w.command(
            RobotTime::ZERO,
            msgs::topics::ARM_JOINT_TRAJECTORY,
            &Msg::JointTrajectory(traj.clone()),
        )?;
        w.step_until(RobotTime::from_millis(1000))?;
        // 0.25 * 3.14 rad/s for 1 s.
        assert!((w.joint_positions_rad()[0] - 0.785).abs() < 1e-9);
        w.step_until(RobotTime::from_millis(2000))?;
        assert_eq!(w.joint_positions_rad()[0], 1.0);
        let mut bad = traj;
        bad.joint_names[0] = "nope".into();
        assert!(
            w.command(
                RobotTime::from_millis(2000),
                msgs::topics::ARM_JOINT_TRAJECTORY,
                &Msg::JointTrajectory(bad)
            )
            .is_err()
        );
        Ok(())
    }
}
