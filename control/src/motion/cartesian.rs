//! Straight-line Cartesian motion of tool0 (approach and retreat) through the closed-form IK.
//!
//! # Path
//! `X(s) = (p0 + s (p1 - p0), slerp(R0, R1, s))`, `s ∈ [0, 1]`, in `arm_base_link`.
//!
//! # Continuity and refusal
//! The path is first pre-sampled every [`CartesianParams::step_m`] / `step_rad`; at each step
//! the IK solution nearest the previous one is taken ([`robot::ArmIk::nearest`]) and the plan
//! is refused when
//! - its branch (shoulder, elbow, wrist) differs from the start's, or a joint moves more than
//!   [`CartesianParams::max_joint_step_rad`] in one step (a branch jump);
//! - it is near a singularity: `|sin q5|`, `|sin β|` below `min_sin`, or the wrist centre within
//!   `min_shoulder_m` of the plane of axes 1 and 2 (joint speeds blow up there);
//! - a pose is unreachable or outside the joint limits.
//!
//! # Timing
//! From the pre-samples, per joint, `D1_j = max |dq_j/ds|` and `D2_j = max |d²q_j/ds²|`
//! (finite differences, times [`DERIVATIVE_MARGIN`]). Joint speed is `q' ṡ` and acceleration
//! `q' s̈ + q'' ṡ²`, so a trapezoid in `s` with
//! `ṡ_max = min(v_lin / L, ω / θ, min_j v_j / D1_j, min_j sqrt(a_j / (2 D2_j)))` and
//! `s̈_max = min(a_lin / L, min_j (a_j - D2_j ṡ_max²) / D1_j)` keeps every joint within its
//! limits (`v_j, a_j` scaled by [`super::trajectory::LIMIT_SCALE`]). Samples every `dt` solve
//! the IK again at `X(s(t))` (seeded by the previous sample), so the joint motion is the exact
//! straight line, not an interpolation of it; velocities and accelerations are the central
//! differences of the samples (zero at the ends).

use super::MotionError;
use super::trajectory::{LIMIT_SCALE, SampledTrajectory, TrapezoidProfile};
use nalgebra::{Isometry3, Translation3};
use robot::{ArmIk, IkSolution};

/// Safety factor on the finite-difference derivative bounds.
pub const DERIVATIVE_MARGIN: f64 = 1.25;

/// Settings of a Cartesian line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CartesianParams {
    /// Tool speed limit (m/s). Default 0.10 (approach speed near the wire).
    pub max_linear_speed_m_s: f64,
    /// Tool acceleration limit (m/s²). Default 0.25.
    pub max_linear_accel_m_s2: f64,
    /// Tool angular speed limit (rad/s). Default 0.5.
    pub max_angular_speed_rad_s: f64,
    /// Pre-sampling step along the path (m). Default 1 mm.
    pub step_m: f64,
    /// Pre-sampling step in rotation (rad). Default 0.5°.
    pub step_rad: f64,
    /// Largest joint change allowed in one pre-sampling step (rad). Default 0.05.
    pub max_joint_step_rad: f64,
    /// Smallest `|sin q5|` and `|sin β|` allowed. Default 0.05 (~3°).
    pub min_sin: f64,
    /// Smallest shoulder margin (m). Default 0.03.
    pub min_shoulder_m: f64,
    /// Start pose tolerance (m, rad) between `FK(q_start)` and the path start. Default
    /// (1 mm, 0.002 rad).
    pub start_tolerance: (f64, f64),
    /// Sampling period (ns). Default 10 ms.
    pub dt_ns: u64,
}

impl Default for CartesianParams {
    fn default() -> Self {
        Self {
            max_linear_speed_m_s: 0.10,
            max_linear_accel_m_s2: 0.25,
            max_angular_speed_rad_s: 0.5,
            step_m: 0.001,
            step_rad: 0.5f64.to_radians(),
            max_joint_step_rad: 0.05,
            min_sin: 0.05,
            min_shoulder_m: 0.03,
            start_tolerance: (0.001, 0.002),
            dt_ns: super::trajectory::DEFAULT_DT_NS,
        }
    }
}

/// The pose at `s` on the straight line from `start` to `goal`.
#[must_use]
pub fn interpolate(start: &Isometry3<f64>, goal: &Isometry3<f64>, s: f64) -> Isometry3<f64> {
    let p = start.translation.vector.lerp(&goal.translation.vector, s);
    let r = start.rotation.slerp(&goal.rotation, s);
    Isometry3::from_parts(Translation3::from(p), r)
}

fn step_solution(
    ik: &ArmIk,
    pose: &Isometry3<f64>,
    previous: &IkSolution,
    step: usize,
    steps: usize,
    params: &CartesianParams,
) -> Result<IkSolution, MotionError> {
    let solution = ik
        .nearest(pose, &previous.q_rad)
        .map_err(|source| MotionError::Ik {
            step,
            steps,
            source,
        })?;
    let m = solution.margins;
    if m.wrist_sin_q5.abs() < params.min_sin
        || m.elbow_sin_q3.abs() < params.min_sin
        || m.shoulder_m.abs() < params.min_shoulder_m
    {
        return Err(MotionError::NearSingularity {
            step,
            wrist_sin: m.wrist_sin_q5.abs(),
            elbow_sin: m.elbow_sin_q3.abs(),
            shoulder_m: m.shoulder_m.abs(),
        });
    }
    let mut worst = (0.0f64, 0usize);
    for j in 0..6 {
        let jump = (solution.q_rad[j] - previous.q_rad[j]).abs();
        if jump > worst.0 {
            worst = (jump, j);
        }
    }
    if solution.branch != previous.branch || worst.0 > params.max_joint_step_rad {
        return Err(MotionError::BranchJump {
            step,
            joint: worst.1 + 1,
            jump_rad: worst.0,
            max_rad: params.max_joint_step_rad,
        });
    }
    Ok(solution)
}

/// A planned Cartesian line.
#[derive(Debug, Clone, PartialEq)]
pub struct CartesianPlan {
    /// The sampled joint trajectory (starts at `q_start`, at rest at both ends).
    pub trajectory: SampledTrajectory,
    /// Path length (m).
    pub length_m: f64,
    /// Rotation angle (rad).
    pub angle_rad: f64,
    /// Pre-sampling steps.
    pub steps: usize,
}

/// Plans tool0 along the straight line `arm_base_from_start -> arm_base_from_goal` starting
/// from `q_start` (module docs).
///
/// # Errors
/// [`MotionError::StartMismatch`], [`MotionError::Ik`], [`MotionError::BranchJump`],
/// [`MotionError::NearSingularity`], [`MotionError::BadPeriod`], [`MotionError::NonFinite`].
pub fn plan_line(
    ik: &ArmIk,
    arm_base_from_start: &Isometry3<f64>,
    arm_base_from_goal: &Isometry3<f64>,
    q_start: &[f64; 6],
    params: &CartesianParams,
) -> Result<CartesianPlan, MotionError> {
    if params.dt_ns == 0 {
        return Err(MotionError::BadPeriod { dt_ns: 0 });
    }
    if !q_start.iter().all(|q| q.is_finite()) {
        return Err(MotionError::NonFinite {
            what: "q_start",
            index: 0,
        });
    }
    let fk = ik.dh().forward(q_start);
    let distance_m = (fk.translation.vector - arm_base_from_start.translation.vector).norm();
    let angle_rad = fk.rotation.angle_to(&arm_base_from_start.rotation);
    if !(distance_m <= params.start_tolerance.0 && angle_rad <= params.start_tolerance.1) {
        return Err(MotionError::StartMismatch {
            distance_m,
            angle_rad,
        });
    }
    let length_m =
        (arm_base_from_goal.translation.vector - arm_base_from_start.translation.vector).norm();
    let rotation_rad = arm_base_from_start
        .rotation
        .angle_to(&arm_base_from_goal.rotation);
    if !(length_m.is_finite() && rotation_rad.is_finite()) {
        return Err(MotionError::NonFinite {
            what: "goal pose",
            index: 0,
        });
    }
    let steps = ((length_m / params.step_m).ceil())
        .max((rotation_rad / params.step_rad).ceil())
        .max(2.0) as usize;
    // The start's own solution (its branch): the analytic solution nearest q_start.
    let start_solution =
        ik.nearest(arm_base_from_start, q_start)
            .map_err(|source| MotionError::Ik {
                step: 0,
                steps,
                source,
            })?;
    let mut previous = IkSolution {
        q_rad: *q_start,
        ..start_solution
    };
    let mut samples = Vec::with_capacity(steps + 1);
    samples.push(*q_start);
    for k in 1..=steps {
        let pose = interpolate(
            arm_base_from_start,
            arm_base_from_goal,
            k as f64 / steps as f64,
        );
        previous = step_solution(ik, &pose, &previous, k, steps, params)?;
        samples.push(previous.q_rad);
    }
    let h = 1.0 / steps as f64;
    let mut d1 = [0.0f64; 6];
    let mut d2 = [0.0f64; 6];
    for w in samples.windows(2) {
        for j in 0..6 {
            d1[j] = d1[j].max((w[1][j] - w[0][j]).abs() / h);
        }
    }
    for w in samples.windows(3) {
        for j in 0..6 {
            d2[j] = d2[j].max((w[2][j] - 2.0 * w[1][j] + w[0][j]).abs() / (h * h));
        }
    }
    let limits = ik.limits();
    let mut v_s = f64::INFINITY;
    if length_m > 0.0 {
        v_s = v_s.min(params.max_linear_speed_m_s / length_m);
    }
    if rotation_rad > 0.0 {
        v_s = v_s.min(params.max_angular_speed_rad_s / rotation_rad);
    }
    for j in 0..6 {
        let (vj, aj) = (
            LIMIT_SCALE * limits[j].velocity_max,
            LIMIT_SCALE * limits[j].acceleration_max,
        );
        let (b1, b2) = (d1[j] * DERIVATIVE_MARGIN, d2[j] * DERIVATIVE_MARGIN);
        if b1 > 0.0 {
            v_s = v_s.min(vj / b1);
        }
        if b2 > 0.0 {
            v_s = v_s.min((aj / (2.0 * b2)).sqrt());
        }
    }
    let mut a_s = if length_m > 0.0 {
        params.max_linear_accel_m_s2 / length_m
    } else {
        f64::INFINITY
    };
    for j in 0..6 {
        let aj = LIMIT_SCALE * limits[j].acceleration_max;
        let (b1, b2) = (d1[j] * DERIVATIVE_MARGIN, d2[j] * DERIVATIVE_MARGIN);
        if b1 > 0.0 {
            a_s = a_s.min((aj - b2 * v_s * v_s) / b1);
        }
    }
    let dt = params.dt_ns as f64 * 1e-9;
    let mut trajectory = SampledTrajectory::at_rest(*q_start, params.dt_ns);
    if v_s.is_finite() && a_s.is_finite() && v_s > 0.0 && a_s > 0.0 {
        let profile = TrapezoidProfile::new(1.0, v_s, a_s);
        let n = ((profile.duration_s() / dt) - 1e-9).ceil().max(1.0) as usize;
        let profile = profile.stretched_to(n as f64 * dt);
        let mut previous = IkSolution {
            q_rad: *q_start,
            ..start_solution
        };
        for k in 1..=n {
            let (s, _, _) = profile.sample(k as f64 * dt);
            let s = if k == n { 1.0 } else { s };
            let pose = interpolate(arm_base_from_start, arm_base_from_goal, s);
            previous = step_solution(ik, &pose, &previous, k, n, params)?;
            trajectory.positions.push(previous.q_rad);
        }
        let p = &trajectory.positions;
        let mut velocities = vec![[0.0; 6]; p.len()];
        let mut accelerations = vec![[0.0; 6]; p.len()];
        for (k, w) in p.windows(3).enumerate() {
            let (Some(v), Some(a)) = (velocities.get_mut(k + 1), accelerations.get_mut(k + 1))
            else {
                continue;
            };
            *v = std::array::from_fn(|j| (w[2][j] - w[0][j]) / (2.0 * dt));
            *a = std::array::from_fn(|j| (w[2][j] - 2.0 * w[1][j] + w[0][j]) / (dt * dt));
        }
        trajectory.velocities = velocities;
        trajectory.accelerations = accelerations;
    }
    Ok(CartesianPlan {
        trajectory,
        length_m,
        angle_rad: rotation_rad,
        steps,
    })
}
