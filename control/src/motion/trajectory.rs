//! Time-parameterised joint trajectories within per-joint speed and acceleration limits, and
//! the checker that proves it from the samples alone.
//!
//! # Segments
//! A straight joint-space segment `q(s) = q0 + s Δ`, `s ∈ [0, 1]`, follows a trapezoidal
//! profile `s(t)` (accelerate at `a`, cruise at `v`, decelerate; triangular when short). Every
//! joint moves synchronised (all start and stop together); joint `j` moves at `|Δ_j| ṡ` and
//! `|Δ_j| s̈`, so the fastest profile within the limits is
//! `v = min_j v_max,j / |Δ_j|`, `a = min_j a_max,j / |Δ_j|` (time-optimal for rest-to-rest
//! motion along the straight segment; Biagiotti & Melchiorri, *Trajectory Planning for
//! Automatic Machines and Robots*, 2008, s3.2.2 and s5.1). Durations: `t_a = v / a`,
//! `T = 1/v + v/a` when `v² < a` (trapezoid), else `t_a = 1/sqrt(a)`, `T = 2 t_a`.
//! Multi-segment paths stop at each via point (rest-to-rest), the safe choice for approach and
//! insertion moves. The duration is rounded up to a whole number of sampling periods by
//! slowing the profile uniformly in time (`s'(t) = s(t/k)`, `k >= 1`, scaling velocities by
//! `1/k` and accelerations by `1/k²`), so samples land exactly on the end.
//! Limits are applied scaled by [`LIMIT_SCALE`] (0.95) to leave margin for the controller and
//! the finite-difference checker.
//!
//! # Checker
//! [`check_trajectory`] uses only the `JointTrajectory` points: positions within limits;
//! velocities `(q_{k+1} - q_k) / (t_{k+1} - t_k)` and accelerations
//! `2 (v_{k+1/2} - v_{k-1/2}) / (t_{k+1} - t_{k-1})` by finite differences, each within the
//! limit times `1 + tolerance`; strictly increasing times; consistent sizes; any reported
//! `velocities` within limits. The log checker reuses it on every `/arm/joint_trajectory`.

use super::MotionError;
use msgs::builtin_interfaces::Duration;
use msgs::geometry_msgs::PoseStamped;
use msgs::nav_msgs::Path;
use msgs::std_msgs::Header;
use msgs::trajectory_msgs::{JointTrajectory, JointTrajectoryPoint};
use nalgebra::Isometry3;
use robot::{JointKind, JointLimit, RobotModel};

/// Fraction of each joint's speed and acceleration limit the planner uses.
pub const LIMIT_SCALE: f64 = 0.95;
/// Default sampling period (ns): 10 ms.
pub const DEFAULT_DT_NS: u64 = 10_000_000;

/// A trapezoidal (or triangular) velocity profile over a distance, time-scaled by `k`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrapezoidProfile {
    /// Distance covered (>= 0).
    pub distance: f64,
    /// Cruise speed of the unscaled profile.
    pub velocity: f64,
    /// Acceleration of the unscaled profile.
    pub acceleration: f64,
    /// Acceleration phase duration of the unscaled profile (s).
    pub t_accel_s: f64,
    /// Total duration of the unscaled profile (s).
    pub t_total_s: f64,
    /// Time scale `k >= 1` (the profile is played `k` times slower).
    pub time_scale: f64,
}

impl TrapezoidProfile {
    /// The fastest profile covering `distance` with speed `<= v_max` and acceleration
    /// `<= a_max` (both > 0), starting and ending at rest.
    #[must_use]
    pub fn new(distance: f64, v_max: f64, a_max: f64) -> Self {
        let distance = distance.max(0.0);
        if distance == 0.0 || !(v_max > 0.0 && a_max > 0.0) {
            return Self {
                distance,
                velocity: 0.0,
                acceleration: 0.0,
                t_accel_s: 0.0,
                t_total_s: 0.0,
                time_scale: 1.0,
            };
        }
        let (velocity, t_accel_s, t_total_s) = if v_max * v_max < a_max * distance {
            (v_max, v_max / a_max, distance / v_max + v_max / a_max)
        } else {
            let t_a = (distance / a_max).sqrt();
            (a_max * t_a, t_a, 2.0 * t_a)
        };
        Self {
            distance,
            velocity,
            acceleration: a_max,
            t_accel_s,
            t_total_s,
            time_scale: 1.0,
        }
    }

    /// Duration with the time scale applied (s).
    #[must_use]
    pub fn duration_s(&self) -> f64 {
        self.t_total_s * self.time_scale
    }

    /// The same profile slowed to last `duration_s` (only ever slower: `k = max(1, T'/T)`).
    #[must_use]
    pub fn stretched_to(mut self, duration_s: f64) -> Self {
        if self.t_total_s > 0.0 {
            self.time_scale = (duration_s / self.t_total_s).max(1.0);
        }
        self
    }

    /// `(s, ṡ, s̈)` at time `t_s` (clamped to `[0, duration]`).
    #[must_use]
    pub fn sample(&self, t_s: f64) -> (f64, f64, f64) {
        if self.t_total_s <= 0.0 {
            return (self.distance, 0.0, 0.0);
        }
        let k = self.time_scale;
        let t = (t_s / k).clamp(0.0, self.t_total_s);
        let (a, v, ta, tt) = (
            self.acceleration,
            self.velocity,
            self.t_accel_s,
            self.t_total_s,
        );
        let (s, sd, sdd) = if t < ta {
            (0.5 * a * t * t, a * t, a)
        } else if t <= tt - ta {
            (0.5 * a * ta * ta + v * (t - ta), v, 0.0)
        } else {
            let r = tt - t;
            (self.distance - 0.5 * a * r * r, a * r, -a)
        };
        (s, sd / k, sdd / (k * k))
    }
}

/// Uniformly sampled joint trajectory: sample `k` at `k dt_ns`.
#[derive(Debug, Clone, PartialEq)]
pub struct SampledTrajectory {
    /// Sampling period (ns).
    pub dt_ns: u64,
    /// Positions (rad).
    pub positions: Vec<[f64; 6]>,
    /// Velocities (rad/s).
    pub velocities: Vec<[f64; 6]>,
    /// Accelerations (rad/s²).
    pub accelerations: Vec<[f64; 6]>,
}

impl SampledTrajectory {
    /// A trajectory holding `q` (one sample, at rest).
    #[must_use]
    pub fn at_rest(q: [f64; 6], dt_ns: u64) -> Self {
        Self {
            dt_ns,
            positions: vec![q],
            velocities: vec![[0.0; 6]],
            accelerations: vec![[0.0; 6]],
        }
    }

    /// Duration (s).
    #[must_use]
    pub fn duration_s(&self) -> f64 {
        self.positions.len().saturating_sub(1) as f64 * self.dt_ns as f64 * 1e-9
    }

    /// The last position.
    #[must_use]
    pub fn last(&self) -> Option<[f64; 6]> {
        self.positions.last().copied()
    }

    /// Appends `other`, whose first sample must equal this one's last (it is dropped).
    pub fn append(&mut self, other: &SampledTrajectory) {
        let skip = usize::from(!self.positions.is_empty());
        self.positions.extend(other.positions.iter().skip(skip));
        self.velocities.extend(other.velocities.iter().skip(skip));
        self.accelerations
            .extend(other.accelerations.iter().skip(skip));
    }
}

fn validate(q: &[f64; 6], index: usize, limits: &[JointLimit; 6]) -> Result<(), MotionError> {
    for (j, (value, limit)) in q.iter().zip(limits).enumerate() {
        if !value.is_finite() {
            return Err(MotionError::NonFinite {
                what: "waypoint",
                index,
            });
        }
        if !limit.contains(*value) {
            return Err(MotionError::OutsideLimits {
                waypoint: index,
                joint: j + 1,
                value: *value,
                min: limit.position_min,
                max: limit.position_max,
            });
        }
    }
    Ok(())
}

/// Number of periods covering `duration_s` (at least 1 for a moving segment).
fn periods(duration_s: f64, dt_ns: u64) -> usize {
    let dt = dt_ns as f64 * 1e-9;
    ((duration_s / dt) - 1e-9).ceil().max(1.0) as usize
}

/// Plans rest-to-rest synchronised trapezoidal segments through `waypoints` (module docs),
/// sampled every `dt_ns`. The first sample is `waypoints[0]`.
///
/// # Errors
/// [`MotionError::NonFinite`], [`MotionError::OutsideLimits`], [`MotionError::BadPeriod`].
pub fn plan_joint_path(
    waypoints: &[[f64; 6]],
    limits: &[JointLimit; 6],
    dt_ns: u64,
) -> Result<SampledTrajectory, MotionError> {
    if dt_ns == 0 {
        return Err(MotionError::BadPeriod { dt_ns });
    }
    let Some(first) = waypoints.first() else {
        return Err(MotionError::NonFinite {
            what: "empty waypoint list",
            index: 0,
        });
    };
    for (i, q) in waypoints.iter().enumerate() {
        validate(q, i, limits)?;
    }
    let mut out = SampledTrajectory::at_rest(*first, dt_ns);
    let dt = dt_ns as f64 * 1e-9;
    for pair in waypoints.windows(2) {
        let [q0, q1] = [pair[0], pair[1]];
        let delta: [f64; 6] = std::array::from_fn(|j| q1[j] - q0[j]);
        let (mut v, mut a) = (f64::INFINITY, f64::INFINITY);
        for (d, limit) in delta.iter().zip(limits) {
            if d.abs() > 1e-12 {
                v = v.min(LIMIT_SCALE * limit.velocity_max / d.abs());
                a = a.min(LIMIT_SCALE * limit.acceleration_max / d.abs());
            }
        }
        if !v.is_finite() {
            continue; // identical waypoints
        }
        let profile = TrapezoidProfile::new(1.0, v, a);
        let n = periods(profile.duration_s(), dt_ns);
        let profile = profile.stretched_to(n as f64 * dt);
        for k in 1..=n {
            let (s, sd, sdd) = profile.sample(k as f64 * dt);
            // The last sample is the waypoint itself (no rounding drift across segments).
            out.positions.push(if k == n {
                q1
            } else {
                std::array::from_fn(|j| q0[j] + delta[j] * s)
            });
            out.velocities.push(std::array::from_fn(|j| delta[j] * sd));
            out.accelerations
                .push(std::array::from_fn(|j| delta[j] * sdd));
        }
    }
    Ok(out)
}

/// `Duration` of `ns` nanoseconds (saturating at `i32::MAX` seconds).
#[must_use]
pub fn duration_from_ns(ns: u64) -> Duration {
    let sec = i32::try_from(ns / 1_000_000_000).unwrap_or(i32::MAX);
    Duration {
        sec,
        nanosec: (ns % 1_000_000_000) as u32,
    }
}

/// The trajectory as a `trajectory_msgs/JointTrajectory` (positions, velocities,
/// accelerations; `time_from_start = k dt`).
#[must_use]
pub fn to_joint_trajectory(
    trajectory: &SampledTrajectory,
    joint_names: &[&str],
    header: Header,
) -> JointTrajectory {
    let points = trajectory
        .positions
        .iter()
        .enumerate()
        .map(|(k, q)| JointTrajectoryPoint {
            positions: q.to_vec(),
            velocities: trajectory
                .velocities
                .get(k)
                .map(|v| v.to_vec())
                .unwrap_or_default(),
            accelerations: trajectory
                .accelerations
                .get(k)
                .map(|a| a.to_vec())
                .unwrap_or_default(),
            effort: Vec::new(),
            time_from_start: duration_from_ns(k as u64 * trajectory.dt_ns),
        })
        .collect();
    JointTrajectory {
        header,
        joint_names: joint_names.iter().map(|s| (*s).to_owned()).collect(),
        points,
    }
}

/// tool0 poses in `base_link` of every `stride`-th sample (and the last), for
/// `/arm/planned_path`.
#[must_use]
pub fn tool0_path(
    model: &RobotModel,
    lift_m: f64,
    trajectory: &SampledTrajectory,
    stride: usize,
) -> Vec<Isometry3<f64>> {
    let n = trajectory.positions.len();
    trajectory
        .positions
        .iter()
        .enumerate()
        .filter(|(k, _)| k % stride.max(1) == 0 || *k + 1 == n)
        .map(|(_, q)| model.base_from_tool0(lift_m, q))
        .collect()
}

/// `nav_msgs/Path` of poses (all stamped with the header's stamp and frame).
#[must_use]
pub fn to_path(poses: &[Isometry3<f64>], header: Header) -> Path {
    Path {
        poses: poses
            .iter()
            .map(|p| crate::perception::wire::to_pose_stamped(p, header.clone()))
            .collect::<Vec<PoseStamped>>(),
        header,
    }
}

/// A trajectory that breaks a limit or is malformed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Violation {
    /// Limits and joint names differ in count.
    #[error("{names} joint names but {limits} limits")]
    LimitsMismatch {
        /// Joint names.
        names: usize,
        /// Limits given.
        limits: usize,
    },
    /// A joint name has no known limit.
    #[error("unknown joint {name}")]
    UnknownJoint {
        /// The name.
        name: String,
    },
    /// A point has the wrong number of values.
    #[error("point {point}: {field} has {got} values, expected {expected}")]
    SizeMismatch {
        /// Point index.
        point: usize,
        /// `positions` or `velocities`.
        field: &'static str,
        /// Values expected.
        expected: usize,
        /// Values present.
        got: usize,
    },
    /// A non-finite value.
    #[error("point {point}: joint {joint} is not finite")]
    NonFinite {
        /// Point index.
        point: usize,
        /// Joint index (0-based, in `joint_names` order).
        joint: usize,
    },
    /// Time does not increase.
    #[error("point {point}: time {t_s} s is not after the previous {previous_s} s")]
    NonMonotonicTime {
        /// Point index.
        point: usize,
        /// Its time.
        t_s: f64,
        /// The previous point's time.
        previous_s: f64,
    },
    /// Position outside the limits.
    #[error("point {point}: joint {joint} at {value} outside [{min}, {max}]")]
    Position {
        /// Point index.
        point: usize,
        /// Joint index.
        joint: usize,
        /// Value.
        value: f64,
        /// Lower limit.
        min: f64,
        /// Upper limit.
        max: f64,
    },
    /// Speed above the limit.
    #[error("point {point}: joint {joint} speed {speed} above {limit}")]
    Velocity {
        /// Point index (interval start).
        point: usize,
        /// Joint index.
        joint: usize,
        /// Speed magnitude.
        speed: f64,
        /// Limit.
        limit: f64,
    },
    /// Acceleration above the limit.
    #[error("point {point}: joint {joint} acceleration {acceleration} above {limit}")]
    Acceleration {
        /// Point index (centre).
        point: usize,
        /// Joint index.
        joint: usize,
        /// Acceleration magnitude.
        acceleration: f64,
        /// Limit.
        limit: f64,
    },
}

/// Allowed excess over the limits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CheckTolerance {
    /// Relative excess of speed and acceleration. Default 0.01.
    pub relative: f64,
    /// Absolute excess of positions (rad or m). Default 1e-9.
    pub position_abs: f64,
}

impl Default for CheckTolerance {
    fn default() -> Self {
        Self {
            relative: 0.01,
            position_abs: 1e-9,
        }
    }
}

/// Peaks found by a passing check.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CheckReport {
    /// Points checked.
    pub points: usize,
    /// Largest `speed / limit` over joints and intervals.
    pub peak_velocity_ratio: f64,
    /// Largest `acceleration / limit`.
    pub peak_acceleration_ratio: f64,
}

/// The limits of `names` in order (arm joints and the lift of `model`).
///
/// # Errors
/// [`Violation::UnknownJoint`].
pub fn limits_for_names(
    model: &RobotModel,
    names: &[String],
) -> Result<Vec<JointLimit>, Violation> {
    names
        .iter()
        .map(|name| match JointKind::from_name(name) {
            Some(JointKind::Lift) => Ok(model.lift_limit),
            Some(JointKind::Arm(i)) => model
                .arm_limits
                .get(i)
                .copied()
                .ok_or_else(|| Violation::UnknownJoint { name: name.clone() }),
            None => Err(Violation::UnknownJoint { name: name.clone() }),
        })
        .collect()
}

/// [`check_trajectory_with`] with the default tolerance.
///
/// # Errors
/// The first [`Violation`].
pub fn check_trajectory(
    trajectory: &JointTrajectory,
    limits: &[JointLimit],
) -> Result<CheckReport, Violation> {
    check_trajectory_with(trajectory, limits, &CheckTolerance::default())
}

/// Checks positions, finite-difference speeds and accelerations (module docs); `limits` are
/// in `joint_names` order.
///
/// # Errors
/// The first [`Violation`] found (points in order).
pub fn check_trajectory_with(
    trajectory: &JointTrajectory,
    limits: &[JointLimit],
    tolerance: &CheckTolerance,
) -> Result<CheckReport, Violation> {
    let n_joints = trajectory.joint_names.len();
    if limits.len() != n_joints {
        return Err(Violation::LimitsMismatch {
            names: n_joints,
            limits: limits.len(),
        });
    }
    let mut report = CheckReport {
        points: trajectory.points.len(),
        ..CheckReport::default()
    };
    let mut times = Vec::with_capacity(trajectory.points.len());
    for (k, point) in trajectory.points.iter().enumerate() {
        if point.positions.len() != n_joints {
            return Err(Violation::SizeMismatch {
                point: k,
                field: "positions",
                expected: n_joints,
                got: point.positions.len(),
            });
        }
        if !point.velocities.is_empty() && point.velocities.len() != n_joints {
            return Err(Violation::SizeMismatch {
                point: k,
                field: "velocities",
                expected: n_joints,
                got: point.velocities.len(),
            });
        }
        let t_s =
            f64::from(point.time_from_start.sec) + f64::from(point.time_from_start.nanosec) * 1e-9;
        if let Some(&previous_s) = times.last()
            && t_s <= previous_s
        {
            return Err(Violation::NonMonotonicTime {
                point: k,
                t_s,
                previous_s,
            });
        }
        times.push(t_s);
        for (j, (q, limit)) in point.positions.iter().zip(limits).enumerate() {
            if !q.is_finite() {
                return Err(Violation::NonFinite { point: k, joint: j });
            }
            if *q < limit.position_min - tolerance.position_abs
                || *q > limit.position_max + tolerance.position_abs
            {
                return Err(Violation::Position {
                    point: k,
                    joint: j,
                    value: *q,
                    min: limit.position_min,
                    max: limit.position_max,
                });
            }
        }
        for (j, (v, limit)) in point.velocities.iter().zip(limits).enumerate() {
            if !v.is_finite() {
                return Err(Violation::NonFinite { point: k, joint: j });
            }
            if v.abs() > limit.velocity_max * (1.0 + tolerance.relative) {
                return Err(Violation::Velocity {
                    point: k,
                    joint: j,
                    speed: v.abs(),
                    limit: limit.velocity_max,
                });
            }
        }
    }
    let points = &trajectory.points;
    let speed = |k: usize, j: usize| -> f64 {
        let (Some(a), Some(b)) = (points.get(k), points.get(k + 1)) else {
            return 0.0;
        };
        let (Some(qa), Some(qb)) = (a.positions.get(j), b.positions.get(j)) else {
            return 0.0;
        };
        let (Some(ta), Some(tb)) = (times.get(k), times.get(k + 1)) else {
            return 0.0;
        };
        (qb - qa) / (tb - ta)
    };
    for k in 0..points.len().saturating_sub(1) {
        for (j, limit) in limits.iter().enumerate() {
            let v = speed(k, j).abs();
            report.peak_velocity_ratio = report.peak_velocity_ratio.max(v / limit.velocity_max);
            if v > limit.velocity_max * (1.0 + tolerance.relative) {
                return Err(Violation::Velocity {
                    point: k,
                    joint: j,
                    speed: v,
                    limit: limit.velocity_max,
                });
            }
        }
    }
    for k in 1..points.len().saturating_sub(1) {
        let (Some(t0), Some(t2)) = (times.get(k - 1), times.get(k + 1)) else {
            continue;
        };
        for (j, limit) in limits.iter().enumerate() {
            let a = (2.0 * (speed(k, j) - speed(k - 1, j)) / (t2 - t0)).abs();
            report.peak_acceleration_ratio = report
                .peak_acceleration_ratio
                .max(a / limit.acceleration_max);
            if a > limit.acceleration_max * (1.0 + tolerance.relative) {
                return Err(Violation::Acceleration {
                    point: k,
                    joint: j,
                    acceleration: a,
                    limit: limit.acceleration_max,
                });
            }
        }
    }
    Ok(report)
}
