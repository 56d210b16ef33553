//! The true AUBO i10: the robot crate's nominal DH plus a seeded perturbation, joint tracking
//! within the vendor's speed and acceleration limits, noisy encoders ([`ArmDriver`]).
//!
//! * **Perturbation** (scenario `robot.perturbation`): every DH row gets
//!   `d, a += N(0, 0.2 mm)` and `theta_offset, alpha += N(0, 0.02 deg)` from the seed
//!   ([`PERTURBATION_LENGTH_M`], [`PERTURBATION_ANGLE_RAD`]). Only the world's truth and the
//!   renderer use the true table; the robot's software keeps the nominal one, so hand poses
//!   are never perfect.
//! * **Tracking**: a `/arm/joint_trajectory` (the six arm joints in any order, each point
//!   with six finite positions inside +-175 deg, `time_from_start` non-decreasing) replaces
//!   the running motion. Points are visited in turn, stopping on each: the move to point `i`
//!   is synchronised over the joints ([`crate::motion`]) and takes
//!   `max(time_from_start_i - elapsed, minimum time)`: a too-short time is stretched, never
//!   a limit exceeded (speeds 3.14 rad/s, J3 2.57 rad/s; accelerations 5 / 8 rad/s^2 of
//!   [`robot::aubo_i10`]).
//! * **Encoders**: `/joint_states` (producer `arm_driver`, 100 Hz, `header.stamp` = sample
//!   time): position = true + `N(0, robot.encoder_noise_rad)` (default 5e-5 rad), velocity =
//!   true joint velocity, no effort.

use msgs::drivers::{ArmDriver, DriverError};
use msgs::frames::ARM_JOINT_NAMES;
use msgs::sensor_msgs::JointState;
use msgs::std_msgs::Header;
use msgs::trajectory_msgs::JointTrajectory;
use msgs::{RobotDuration, RobotTime};
use nalgebra::Isometry3;
use robot::dh::DhTable;
use robot::limits::JointLimit;

use crate::motion::{Axis, plan_synchronised};
use crate::rng::{self, streams};

/// Producer name of the arm's joint states.
pub const ARM_DRIVER: &str = "arm_driver";
/// 1-sigma of the length perturbation of each DH row (m).
pub const PERTURBATION_LENGTH_M: f64 = 2e-4;
/// 1-sigma of the angle perturbation of each DH row (rad): 0.02 deg.
pub const PERTURBATION_ANGLE_RAD: f64 = 0.02 * std::f64::consts::PI / 180.0;
/// World tick (s).
pub const TICK_S: f64 = 0.001;
/// World tick (ns).
pub const TICK_NS: u64 = 1_000_000;

/// The nominal table with a seeded perturbation (`enabled = false`: the nominal table).
#[must_use]
pub fn perturbed_dh(nominal: &DhTable, seed: u64, enabled: bool) -> DhTable {
    let mut t = *nominal;
    if !enabled {
        return t;
    }
    for (i, row) in t.rows.iter_mut().enumerate() {
        let n = |k: u64| rng::normal(seed, streams::ARM_PERTURBATION, 4 * i as u64 + k);
        row.d_m += PERTURBATION_LENGTH_M * n(0);
        row.a_m += PERTURBATION_LENGTH_M * n(1);
        row.theta_offset_rad += PERTURBATION_ANGLE_RAD * n(2);
        row.alpha_rad += PERTURBATION_ANGLE_RAD * n(3);
    }
    t
}

/// Steps the devices of the world on the common 1 ms tick grid: `advance` runs every tick
/// whose end time is in `(last, now]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TickClock {
    /// Number of ticks done (state is at `ticks * TICK_NS`).
    pub ticks: u64,
    /// Latest time seen.
    pub last: RobotTime,
}

impl TickClock {
    /// Ticks to run to reach `now`, or an error if `now` went backwards.
    ///
    /// # Errors
    /// [`DriverError::TimeWentBackwards`].
    pub fn ticks_until(&mut self, device: &str, now: RobotTime) -> Result<u64, DriverError> {
        if now < self.last {
            return Err(DriverError::TimeWentBackwards {
                device: device.to_owned(),
                last: self.last,
                now,
            });
        }
        self.last = now;
        let target = now.as_nanos() / TICK_NS;
        let n = target.saturating_sub(self.ticks);
        self.ticks = self.ticks.max(target);
        Ok(n)
    }
}

/// The simulated arm.
#[derive(Debug, Clone)]
pub struct ArmSim {
    seed: u64,
    true_dh: DhTable,
    limits: [JointLimit; 6],
    axes: [Axis; 6],
    /// Remaining points `(positions, absolute arrival time)`.
    queue: Vec<([f64; 6], RobotTime)>,
    encoder_sigma_rad: f64,
    clock: TickClock,
    /// Largest |velocity| / limit ratio seen (1.0 = at the limit), for tests and diagnostics.
    pub peak_speed_ratio: f64,
}

impl ArmSim {
    /// An arm at rest at `home_rad` with the true table `true_dh`.
    #[must_use]
    pub fn new(seed: u64, true_dh: DhTable, home_rad: [f64; 6], encoder_sigma_rad: f64) -> Self {
        let limits = robot::aubo_i10::aubo_i10_limits();
        let axes = std::array::from_fn(|i| {
            let l = limits[i];
            Axis::at_rest(home_rad[i], l.velocity_max, l.acceleration_max)
        });
        Self {
            seed,
            true_dh,
            limits,
            axes,
            queue: Vec::new(),
            encoder_sigma_rad,
            clock: TickClock {
                ticks: 0,
                last: RobotTime::ZERO,
            },
            peak_speed_ratio: 0.0,
        }
    }

    /// The true DH table.
    #[must_use]
    pub fn true_dh(&self) -> &DhTable {
        &self.true_dh
    }

    /// True joint positions (rad).
    #[must_use]
    pub fn q_rad(&self) -> [f64; 6] {
        std::array::from_fn(|i| self.axes[i].position)
    }

    /// True joint velocities (rad/s).
    #[must_use]
    pub fn velocity_rad_s(&self) -> [f64; 6] {
        std::array::from_fn(|i| self.axes[i].velocity)
    }

    /// True `arm_base_from_tool0`.
    #[must_use]
    pub fn arm_base_from_tool0(&self) -> Isometry3<f64> {
        self.true_dh.forward(&self.q_rad())
    }

    /// Whether the arm rests with no motion queued.
    #[must_use]
    pub fn idle(&self) -> bool {
        self.queue.is_empty() && self.axes.iter().all(Axis::settled)
    }

    /// Advances the motion to `now` (1 ms ticks).
    ///
    /// # Errors
    /// [`DriverError::TimeWentBackwards`].
    pub fn advance(&mut self, now: RobotTime) -> Result<(), DriverError> {
        let n = self.clock.ticks_until(ARM_DRIVER, now)?;
        for k in 0..n {
            let tick_time = RobotTime::from_nanos((self.clock.ticks - n + k + 1) * TICK_NS);
            if self.axes.iter().all(Axis::settled) && !self.queue.is_empty() {
                let (goal, arrive) = self.queue.remove(0);
                let requested = arrive.saturating_duration_since(tick_time).as_secs_f64();
                let lim: [(f64, f64); 6] = std::array::from_fn(|i| {
                    (self.limits[i].velocity_max, self.limits[i].acceleration_max)
                });
                plan_synchronised(&mut self.axes, &goal, &lim, requested);
            }
            for (ax, l) in self.axes.iter_mut().zip(&self.limits) {
                ax.step(TICK_S);
                self.peak_speed_ratio = self
                    .peak_speed_ratio
                    .max(ax.velocity.abs() / l.velocity_max);
            }
        }
        Ok(())
    }

    fn reject(now: RobotTime, reason: String) -> DriverError {
        DriverError::Rejected {
            device: ARM_DRIVER.to_owned(),
            now,
            reason,
        }
    }

    /// Validates a trajectory into `(positions J1..J6, time_from_start)` points.
    ///
    /// # Errors
    /// [`DriverError::Rejected`] naming the first problem.
    pub fn validate(
        &self,
        now: RobotTime,
        trajectory: &JointTrajectory,
    ) -> Result<Vec<([f64; 6], RobotDuration)>, DriverError> {
        if trajectory.joint_names.len() != 6 {
            return Err(Self::reject(
                now,
                format!(
                    "{} joint names, expected the 6 arm joints",
                    trajectory.joint_names.len()
                ),
            ));
        }
        let mut order = [0usize; 6];
        for (j, name) in ARM_JOINT_NAMES.iter().enumerate() {
            let Some(pos) = trajectory.joint_names.iter().position(|n| n == name) else {
                return Err(Self::reject(
                    now,
                    format!("joint {name} missing (got {:?})", trajectory.joint_names),
                ));
            };
            order[j] = pos;
        }
        if trajectory.points.is_empty() {
            return Err(Self::reject(now, "trajectory has no points".to_owned()));
        }
        let mut out = Vec::with_capacity(trajectory.points.len());
        let mut last = RobotDuration::ZERO;
        for (p, point) in trajectory.points.iter().enumerate() {
            if point.positions.len() != 6 {
                return Err(Self::reject(
                    now,
                    format!(
                        "point {p} has {} positions, expected 6",
                        point.positions.len()
                    ),
                ));
            }
            let mut q = [0.0; 6];
            for j in 0..6 {
                let v = point.positions.get(order[j]).copied().unwrap_or(f64::NAN);
                let l = self.limits[j];
                if !l.contains(v) {
                    return Err(Self::reject(
                        now,
                        format!(
                            "point {p}: {} = {v} rad outside [{}, {}] rad",
                            ARM_JOINT_NAMES[j], l.position_min, l.position_max
                        ),
                    ));
                }
                q[j] = v;
            }
            let tfs = RobotDuration::from_ros(point.time_from_start)
                .map_err(|e| Self::reject(now, format!("point {p}: time_from_start {e}")))?;
            if tfs < last {
                return Err(Self::reject(
                    now,
                    format!("point {p}: time_from_start {tfs} before the previous point's {last}"),
                ));
            }
            last = tfs;
            out.push((q, tfs));
        }
        Ok(out)
    }
}

impl ArmDriver for ArmSim {
    fn execute(&mut self, now: RobotTime, trajectory: &JointTrajectory) -> Result<(), DriverError> {
        self.advance(now)?;
        if trajectory.points.is_empty() {
            // As ros2_control's joint_trajectory_controller: an empty trajectory stops the arm
            // where it can (each joint brakes at its acceleration limit) and holds there.
            self.queue.clear();
            let lim: [(f64, f64); 6] = std::array::from_fn(|i| {
                (self.limits[i].velocity_max, self.limits[i].acceleration_max)
            });
            let goal: [f64; 6] = std::array::from_fn(|i| {
                let (v, a) = (self.axes[i].velocity, lim[i].1.max(1e-9));
                self.axes[i].position + v * v.abs() / (2.0 * a)
            });
            plan_synchronised(&mut self.axes, &goal, &lim, 0.0);
            return Ok(());
        }
        let points = self.validate(now, trajectory)?;
        self.queue = points.into_iter().map(|(q, tfs)| (q, now + tfs)).collect();
        // Preempt: the current move ends where the arm is; the queue starts from there.
        let lim: [(f64, f64); 6] =
            std::array::from_fn(|i| (self.limits[i].velocity_max, self.limits[i].acceleration_max));
        if let Some((goal, arrive)) = (!self.queue.is_empty()).then(|| self.queue.remove(0)) {
            let requested = arrive.saturating_duration_since(now).as_secs_f64();
            plan_synchronised(&mut self.axes, &goal, &lim, requested);
        }
        Ok(())
    }

    fn joint_state(&mut self, now: RobotTime) -> Result<JointState, DriverError> {
        self.advance(now)?;
        let stamp = now.to_ros().map_err(|e| DriverError::Fault {
            device: ARM_DRIVER.to_owned(),
            now,
            reason: e.to_string(),
        })?;
        let position = (0..6)
            .map(|j| {
                let n = rng::normal(
                    self.seed,
                    streams::ARM_ENCODER,
                    now.as_nanos().wrapping_mul(8).wrapping_add(j as u64),
                );
                self.axes[j].position + self.encoder_sigma_rad * n
            })
            .collect();
        Ok(JointState {
            header: Header {
                stamp,
                frame_id: String::new(),
            },
            name: ARM_JOINT_NAMES.iter().map(|s| (*s).to_owned()).collect(),
            position,
            velocity: self.axes.iter().map(|a| a.velocity).collect(),
            effort: Vec::new(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use msgs::trajectory_msgs::JointTrajectoryPoint;

    fn traj(names: &[&str], q: &[f64], secs: f64) -> JointTrajectory {
        JointTrajectory {
            joint_names: names.iter().map(|s| (*s).to_owned()).collect(),
            points: vec![JointTrajectoryPoint {
                positions: q.to_vec(),
                time_from_start: RobotDuration::from_secs_f64(secs)
                    .and_then(RobotDuration::to_ros)
                    .unwrap_or_default(),
                ..Default::default()
            }],
            ..Default::default()
        }
    }

    #[test]
    fn reaches_goals_without_exceeding_speed_limits() -> Result<(), DriverError> {
        let nominal = robot::AUBO_I10_DH;
        let mut arm = ArmSim::new(1, perturbed_dh(&nominal, 1, true), [0.0; 6], 0.0);
        let goal = [1.5, -0.8, 2.0, -1.0, 0.7, 3.0];
        arm.execute(RobotTime::ZERO, &traj(&ARM_JOINT_NAMES, &goal, 0.0))?;
        let limits = robot::aubo_i10::aubo_i10_limits();
        let mut prev = arm.q_rad();
        for k in 1..=5000u64 {
            let t = RobotTime::from_millis(k);
            let js = arm.joint_state(t)?;
            for j in 0..6 {
                let v = js.velocity.get(j).copied().unwrap_or(f64::NAN);
                assert!(
                    v.abs() <= limits[j].velocity_max + 1e-9,
                    "joint {j} at {t}: {v}"
                );
                let dq = (arm.q_rad()[j] - prev[j]) / TICK_S;
                assert!(dq.abs() <= limits[j].velocity_max + 1e-9);
            }
            prev = arm.q_rad();
        }
        assert_eq!(arm.q_rad(), goal);
        assert!(
            arm.peak_speed_ratio > 0.5,
            "a long move runs near the limit"
        );
        Ok(())
    }

    #[test]
    fn requested_duration_is_respected_and_bad_commands_are_rejected() -> Result<(), DriverError> {
        let mut arm = ArmSim::new(1, robot::AUBO_I10_DH, [0.0; 6], 0.0);
        let mut names = ARM_JOINT_NAMES;
        names.swap(0, 5);
        // J6 listed first: its value goes to J6.
        arm.execute(
            RobotTime::ZERO,
            &traj(&names, &[0.5, 0.0, 0.0, 0.0, 0.0, 0.1], 3.0),
        )?;
        arm.advance(RobotTime::from_millis(2900))?;
        assert!(!arm.idle(), "a 3 s move is not done at 2.9 s");
        arm.advance(RobotTime::from_millis(3100))?;
        assert!(arm.idle());
        assert_eq!(arm.q_rad()[5], 0.5);
        assert_eq!(arm.q_rad()[0], 0.1);
        let now = RobotTime::from_secs_f64(4.0).unwrap_or_default();
        assert!(matches!(
            arm.execute(
                now,
                &traj(&ARM_JOINT_NAMES, &[4.0, 0.0, 0.0, 0.0, 0.0, 0.0], 1.0)
            ),
            Err(DriverError::Rejected { .. })
        ));
        assert!(
            arm.execute(now, &traj(&ARM_JOINT_NAMES[..5], &[0.0; 5], 1.0))
                .is_err()
        );
        assert!(
            arm.execute(
                now,
                &traj(&ARM_JOINT_NAMES, &[f64::NAN, 0.0, 0.0, 0.0, 0.0, 0.0], 1.0)
            )
            .is_err()
        );
        assert!(matches!(
            arm.advance(RobotTime::from_millis(1)),
            Err(DriverError::TimeWentBackwards { .. })
        ));
        Ok(())
    }

    #[test]
    fn encoders_are_noisy_but_unbiased() -> Result<(), DriverError> {
        let home = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6];
        let sigma = 5e-5;
        let mut arm = ArmSim::new(3, robot::AUBO_I10_DH, home, sigma);
        let n = 2000u64;
        let (mut sum, mut sum2) = ([0.0; 6], [0.0; 6]);
        for k in 1..=n {
            let js = arm.joint_state(RobotTime::from_millis(10 * k))?;
            for j in 0..6 {
                let e = js.position.get(j).copied().unwrap_or(f64::NAN) - home[j];
                sum[j] += e;
                sum2[j] += e * e;
            }
        }
        for j in 0..6 {
            let mean = sum[j] / n as f64;
            let sd = (sum2[j] / n as f64 - mean * mean).sqrt();
            assert!(
                mean.abs() < 4.0 * sigma / (n as f64).sqrt(),
                "joint {j} bias {mean}"
            );
            assert!((sd / sigma - 1.0).abs() < 0.1, "joint {j} sigma {sd}");
        }
        assert_eq!(arm.q_rad(), home, "noise is on the reading, not the joint");
        Ok(())
    }

    #[test]
    fn perturbation_is_small_and_seeded() {
        let nominal = robot::AUBO_I10_DH;
        let a = perturbed_dh(&nominal, 7, true);
        let b = perturbed_dh(&nominal, 7, true);
        assert_eq!(a, b);
        assert_eq!(perturbed_dh(&nominal, 7, false), nominal);
        let q = [0.3, -0.4, 1.1, 0.2, -0.9, 0.5];
        let d = (a.forward(&q).translation.vector - nominal.forward(&q).translation.vector).norm();
        assert!(d > 1e-5 && d < 5e-3, "{d}");
    }
}
