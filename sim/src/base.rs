//! The mobile base ([`BaseDriver`]): goal pose in `map` in, odometry `map -> base_link` out.
//!
//! Motion (true pose): turn in place towards the goal, drive straight, turn to the goal's
//! yaw, at [`BASE_SPEED_M_S`] and [`BASE_TURN_RAD_S`] (goals closer than 5 mm skip the
//! drive). Goals must be in frame `map` (or empty frame id), finite, within
//! [`BASE_MAX_GOAL_DISTANCE_M`] of the current pose, with a unit quaternion.
//!
//! Odometry (`/tf` `map -> base_link`, producer `base_driver`, 50 Hz): integrates the true
//! increments with wheel-slip noise, `ds_odo = ds (1 + N(0, 1 %))` and
//! `dyaw_odo = dyaw (1 + N(0, 2 %)) + N(0, 1e-4) |ds|` per 1 ms tick
//! ([`ODOMETRY_SIGMA_REL`], [`ODOMETRY_YAW_SIGMA_REL`], [`ODOMETRY_YAW_PER_M`]): unbiased,
//! drifting with distance travelled; no drift while standing still.
//!
//! Ground: the base rests on the yard's ground ([`BaseSim::on_ground`]): on a graded yard its
//! true pose is raised to the ground's height and tilted to its normal. The odometry stays
//! planar (wheel encoders measure neither), so the tilt, like the drift, is a difference
//! between the truth and what the robot believes.

use msgs::RobotTime;
use msgs::drivers::{BaseDriver, DriverError};
use msgs::frames::{BASE_LINK, MAP};
use msgs::geometry_msgs::{PoseStamped, TransformStamped};
use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion};
use robot::se3::{planar_pose, wrap_to_pi};

use crate::arm::{TICK_S, TickClock};
use crate::rng::{self, streams};
use crate::scene::GroundPlane;

/// Producer of the odometry.
pub const BASE_DRIVER: &str = "base_driver";
/// Driving speed (m/s).
pub const BASE_SPEED_M_S: f64 = 0.5;
/// Turning speed (rad/s).
pub const BASE_TURN_RAD_S: f64 = 0.6;
/// Farthest accepted goal (m).
pub const BASE_MAX_GOAL_DISTANCE_M: f64 = 100.0;
/// Relative 1-sigma of distance increments.
pub const ODOMETRY_SIGMA_REL: f64 = 0.01;
/// Relative 1-sigma of yaw increments.
pub const ODOMETRY_YAW_SIGMA_REL: f64 = 0.02;
/// Yaw noise per metre driven (rad, 1-sigma per tick scaled by distance).
pub const ODOMETRY_YAW_PER_M: f64 = 1e-4;

/// A planar pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Planar {
    /// x (m).
    pub x_m: f64,
    /// y (m).
    pub y_m: f64,
    /// Yaw (rad).
    pub yaw_rad: f64,
}

impl Planar {
    /// As an isometry.
    #[must_use]
    pub fn isometry(&self) -> Isometry3<f64> {
        planar_pose(self.x_m, self.y_m, self.yaw_rad)
    }
}

/// Goals closer than this are reached by turning in place (m).
pub const BASE_DRIVE_MIN_M: f64 = 0.005;

/// The true poses of the base's motion from `from` to a goal `to` (module docs: turn in place
/// towards the goal, drive straight, turn to the goal's yaw; only the turn for a goal closer
/// than [`BASE_DRIVE_MIN_M`]), sampled every `step_m` along the drive and `step_rad` of a
/// turn, both ends included. For judging a goal against the true scene.
#[must_use]
pub fn motion_path(from: Planar, to: Planar, step_m: f64, step_rad: f64) -> Vec<Planar> {
    let turn = |path: &mut Vec<Planar>, at: Planar, yaw_rad: f64| {
        let delta = wrap_to_pi(yaw_rad - at.yaw_rad);
        let n = (delta.abs() / step_rad).ceil().max(1.0) as usize;
        path.extend((1..=n).map(|k| Planar {
            yaw_rad: at.yaw_rad + delta * k as f64 / n as f64,
            ..at
        }));
    };
    let (dx, dy) = (to.x_m - from.x_m, to.y_m - from.y_m);
    let distance = dx.hypot(dy);
    let mut path = vec![from];
    let mut at = from;
    if distance > BASE_DRIVE_MIN_M {
        let heading = dy.atan2(dx);
        turn(&mut path, at, heading);
        let n = (distance / step_m).ceil().max(1.0) as usize;
        path.extend((1..=n).map(|k| Planar {
            x_m: from.x_m + dx * k as f64 / n as f64,
            y_m: from.y_m + dy * k as f64 / n as f64,
            yaw_rad: heading,
        }));
        at = Planar {
            yaw_rad: heading,
            ..to
        };
    }
    turn(&mut path, at, to.yaw_rad);
    path
}

/// The simulated base.
#[derive(Debug, Clone)]
pub struct BaseSim {
    seed: u64,
    truth: Planar,
    odometry: Planar,
    goal: Option<Planar>,
    drift: bool,
    ground: GroundPlane,
    clock: TickClock,
}

impl BaseSim {
    /// A base at rest at `start` (odometry starts at the truth).
    #[must_use]
    pub fn new(seed: u64, start: Planar, drift: bool) -> Self {
        Self {
            seed,
            truth: start,
            odometry: start,
            goal: None,
            drift,
            ground: GroundPlane::level(0.0),
            clock: TickClock {
                ticks: 0,
                last: RobotTime::ZERO,
            },
        }
    }

    /// The same base resting on `ground` (module docs); level ground at height 0 otherwise.
    #[must_use]
    pub fn on_ground(self, ground: GroundPlane) -> Self {
        Self { ground, ..self }
    }

    /// True `map_from_base_link`: the planar pose raised onto the ground and tilted to its
    /// normal, `T(x, y, h(x, y)) R_tilt R_z(yaw)`.
    #[must_use]
    pub fn map_from_base(&self) -> Isometry3<f64> {
        let planar = self.truth.isometry();
        if self.ground.is_level() && self.ground.height_m == 0.0 {
            return planar;
        }
        let t = &self.truth;
        Isometry3::from_parts(
            Translation3::from(self.ground.point_under(t.x_m, t.y_m).coords),
            self.ground.tilt() * planar.rotation,
        )
    }

    /// True planar pose.
    #[must_use]
    pub fn truth(&self) -> Planar {
        self.truth
    }

    /// Odometry estimate.
    #[must_use]
    pub fn odometry_pose(&self) -> Planar {
        self.odometry
    }

    /// Whether it has no goal left.
    #[must_use]
    pub fn idle(&self) -> bool {
        self.goal.is_none()
    }

    /// Advances to `now`.
    ///
    /// # Errors
    /// [`DriverError::TimeWentBackwards`].
    pub fn advance(&mut self, now: RobotTime) -> Result<(), DriverError> {
        let n = self.clock.ticks_until(BASE_DRIVER, now)?;
        let first = self.clock.ticks - n;
        for k in 0..n {
            self.tick(first + k + 1);
        }
        Ok(())
    }

    fn tick(&mut self, index: u64) {
        let Some(goal) = self.goal else {
            return;
        };
        let (dx, dy) = (goal.x_m - self.truth.x_m, goal.y_m - self.truth.y_m);
        let dist = dx.hypot(dy);
        let max_turn = BASE_TURN_RAD_S * TICK_S;
        let (ds, dyaw) = if dist > BASE_DRIVE_MIN_M {
            let heading_err = wrap_to_pi(dy.atan2(dx) - self.truth.yaw_rad);
            if heading_err.abs() > 1e-3 {
                (0.0, heading_err.clamp(-max_turn, max_turn))
            } else {
                ((BASE_SPEED_M_S * TICK_S).min(dist), heading_err)
            }
        } else {
            let yaw_err = wrap_to_pi(goal.yaw_rad - self.truth.yaw_rad);
            if yaw_err.abs() <= max_turn {
                self.truth = goal;
                self.goal = None;
                (0.0, yaw_err)
            } else {
                (0.0, yaw_err.clamp(-max_turn, max_turn))
            }
        };
        if self.goal.is_some() {
            self.truth.x_m += ds * self.truth.yaw_rad.cos();
            self.truth.y_m += ds * self.truth.yaw_rad.sin();
            self.truth.yaw_rad = wrap_to_pi(self.truth.yaw_rad + dyaw);
        }
        let (ds_o, dyaw_o) = if self.drift && (ds != 0.0 || dyaw != 0.0) {
            let n = |k: u64| {
                rng::normal(
                    self.seed,
                    streams::ODOMETRY,
                    index.wrapping_mul(4).wrapping_add(k),
                )
            };
            (
                ds * (1.0 + ODOMETRY_SIGMA_REL * n(0)),
                dyaw * (1.0 + ODOMETRY_YAW_SIGMA_REL * n(1)) + ODOMETRY_YAW_PER_M * ds.abs() * n(2),
            )
        } else {
            (ds, dyaw)
        };
        self.odometry.x_m += ds_o * self.odometry.yaw_rad.cos();
        self.odometry.y_m += ds_o * self.odometry.yaw_rad.sin();
        self.odometry.yaw_rad = wrap_to_pi(self.odometry.yaw_rad + dyaw_o);
    }
}

impl BaseDriver for BaseSim {
    fn command_goal(&mut self, now: RobotTime, goal: &PoseStamped) -> Result<(), DriverError> {
        self.advance(now)?;
        let reject = |reason: String| DriverError::Rejected {
            device: BASE_DRIVER.to_owned(),
            now,
            reason,
        };
        let frame = goal.header.frame_id.as_str();
        if !(frame.is_empty() || frame == MAP) {
            return Err(reject(format!("goal in frame {frame:?}, expected {MAP:?}")));
        }
        let p = goal.pose.position;
        let o = goal.pose.orientation;
        if ![p.x, p.y, p.z, o.x, o.y, o.z, o.w]
            .iter()
            .all(|v| v.is_finite())
        {
            return Err(reject("non-finite goal".to_owned()));
        }
        let norm2 = o.x * o.x + o.y * o.y + o.z * o.z + o.w * o.w;
        if (norm2 - 1.0).abs() > 0.01 {
            return Err(reject(format!("quaternion |q|^2 = {norm2} is not unit")));
        }
        let d = (p.x - self.truth.x_m).hypot(p.y - self.truth.y_m);
        if d > BASE_MAX_GOAL_DISTANCE_M {
            return Err(reject(format!(
                "goal {d:.1} m away, farther than {BASE_MAX_GOAL_DISTANCE_M} m"
            )));
        }
        let q = UnitQuaternion::from_quaternion(Quaternion::new(o.w, o.x, o.y, o.z));
        let (_, _, yaw) = q.euler_angles();
        self.goal = Some(Planar {
            x_m: p.x,
            y_m: p.y,
            yaw_rad: yaw,
        });
        Ok(())
    }

    fn odometry(&mut self, now: RobotTime) -> Result<TransformStamped, DriverError> {
        self.advance(now)?;
        let stamp = now.to_ros().map_err(|e| DriverError::Fault {
            device: BASE_DRIVER.to_owned(),
            now,
            reason: e.to_string(),
        })?;
        Ok(robot::conversions::transform_stamped(
            MAP,
            BASE_LINK,
            stamp,
            &self.odometry.isometry(),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use msgs::geometry_msgs::{Point, Pose};

    /// A goal beside the base turns it a quarter turn, drives, turns back; a goal where it
    /// stands only turns.
    #[test]
    fn the_motion_path_turns_drives_and_turns() {
        let at = Planar {
            x_m: 1.0,
            y_m: 2.0,
            yaw_rad: 0.0,
        };
        let beside = Planar { y_m: 2.02, ..at };
        let path = motion_path(at, beside, 0.05, 0.02);
        let max_yaw = path.iter().map(|p| p.yaw_rad).fold(0.0, f64::max);
        assert!((max_yaw - std::f64::consts::FRAC_PI_2).abs() < 1e-9);
        assert_eq!(path.last().copied(), Some(beside));
        let turned = Planar { yaw_rad: 0.1, ..at };
        let path = motion_path(at, turned, 0.05, 0.02);
        assert!(path.iter().all(|p| p.x_m == at.x_m && p.y_m == at.y_m));
        assert!(path.iter().all(|p| (0.0..=0.1).contains(&p.yaw_rad)));
        assert_eq!(path.len(), 6);
    }

    /// On a graded yard the true base rests on the ground (origin on the plane, z axis
    /// along its normal, heading kept), while the odometry stays planar; on level ground the
    /// truth is the planar pose.
    #[test]
    fn the_true_base_rests_on_the_graded_ground() {
        let start = Planar {
            x_m: 4.0,
            y_m: -1.0,
            yaw_rad: 0.7,
        };
        let ground = GroundPlane {
            height_m: 0.0,
            origin_xy_m: [0.0, 0.0],
            grade: [0.015, -0.008],
        };
        let b = BaseSim::new(1, start, false).on_ground(ground);
        let pose = b.map_from_base();
        let o = pose.translation.vector;
        assert!((o.z - ground.height_at(4.0, -1.0)).abs() < 1e-12 && o.z.abs() > 0.05);
        assert!((pose.rotation * nalgebra::Vector3::z() - ground.normal()).norm() < 1e-12);
        let forward = pose.rotation * nalgebra::Vector3::x();
        assert!((forward.y.atan2(forward.x) - 0.7).abs() < 1e-3);
        assert!(forward.dot(&ground.normal()).abs() < 1e-12);
        assert_eq!(b.odometry_pose(), start);
        let level = BaseSim::new(1, start, false);
        assert_eq!(level.map_from_base(), start.isometry());
    }

    #[test]
    fn drives_to_the_goal_and_odometry_drifts_a_little() -> Result<(), DriverError> {
        let mut b = BaseSim::new(
            4,
            Planar {
                x_m: 0.0,
                y_m: 0.0,
                yaw_rad: 0.0,
            },
            true,
        );
        let q = UnitQuaternion::from_euler_angles(0.0, 0.0, 1.0);
        let goal = PoseStamped {
            header: msgs::std_msgs::Header {
                frame_id: MAP.to_owned(),
                ..Default::default()
            },
            pose: Pose {
                position: Point {
                    x: 3.0,
                    y: 4.0,
                    z: 0.0,
                },
                orientation: msgs::geometry_msgs::Quaternion {
                    x: q.i,
                    y: q.j,
                    z: q.k,
                    w: q.w,
                },
            },
        };
        b.command_goal(RobotTime::ZERO, &goal)?;
        b.advance(RobotTime::from_millis(20_000))?;
        assert!(b.idle());
        let t = b.truth();
        assert!(
            (t.x_m - 3.0).abs() < 1e-9
                && (t.y_m - 4.0).abs() < 1e-9
                && (t.yaw_rad - 1.0).abs() < 1e-9
        );
        let o = b.odometry_pose();
        let err = (o.x_m - 3.0).hypot(o.y_m - 4.0);
        assert!(err > 1e-6 && err < 0.2, "odometry error {err}");
        let mut wrong = goal.clone();
        wrong.header.frame_id = "base_link".to_owned();
        assert!(
            b.command_goal(RobotTime::from_millis(20_000), &wrong)
                .is_err()
        );
        Ok(())
    }
}
