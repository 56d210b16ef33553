//! Closed-form inverse kinematics of the AUBO i10 (a UR-type wrist), all solutions.
//!
//! # Derivation for this DH table
//!
//! Notation: `T_i = Rz(θ_i) Tz(d_i) Tx(a_i) Rx(α_i)` with `θ_i = q_i + offset_i`
//! ([`crate::dh`]); `z_i`, `o_i` are the axes and origins of DH frame `i` in frame 0; `T = T_06`
//! the requested flange pose, `R` its rotation, `p` its position. Required structure (checked by
//! [`ArmIk::new`]): `α = (π/2, π, π, -π/2, π/2, 0)`, `a1 = a4 = a5 = a6 = 0`, `d2 = d3 = 0`; the
//! offsets and the remaining lengths are free. Unlike a UR arm (α2 = α3 = 0) the two `Rx(π)`
//! flip the axes of joints 3 and 4, which the identity `Rx(π) Rz(b) = Rz(-b) Rx(π)` absorbs:
//!
//! ```text
//! T_12 T_23 = Rz(θ2) Tx(a2) Rz(-θ3) Tx(a3)                          (planar 2R, elbow angle -θ3)
//! T_14      = Rz(θ2 - θ3 + θ4) with origin (a2 c2 + a3 c(2-3), a2 s2 + a3 s(2-3), d4),
//!             rotation Rz(ψ) Rx(-π/2),  ψ = θ2 - θ3 + θ4
//! ```
//!
//! so `z_3 = z_1`, `y_4 = -z_1`, and joints 2-4 move the wrist in the plane `⊥ z_1` at height
//! `d4` along `z_1`.
//!
//! 1. **q1.** The wrist centre `p5 = p - d6 R e_z` satisfies `p5 · z_1 = d4` with
//!    `z_1 = (sin θ1, -cos θ1, 0)`, i.e. `r sin(θ1 - φ) = d4` for `p5_xy = r (cos φ, sin φ)`:
//!    `θ1 = φ + atan2(d4, ±h)`, `h = sqrt(r² - d4²)`. Unreachable when `r < d4`; the two
//!    branches merge when `h = 0` (**shoulder singularity**: the wrist centre lies in the plane
//!    of axes 1 and 2; `h` is its distance from that plane).
//! 2. **q5, q6.** `z_1` expressed in the flange frame is `w = Rᵀ z_1 = (-s5 c6, s5 s6, c5)`:
//!    `θ5 = atan2(±sqrt(wx² + wy²), wz)` and `θ6 = atan2(wy / s5, -wx / s5)`. When `s5 = 0`
//!    (**wrist singularity**: axes 2, 3, 4 and 6 all parallel to `z_1`) the flange's rotation
//!    about `z_1` is shared between `ψ` and q6, so the solutions form a one-parameter family:
//!    q6 is free, and q2, q3, q4 follow from it (the forearm swings so that `o_4`, at `d5` from
//!    the wrist centre, moves around a circle). q6 is then taken from the seed (0 without one)
//!    and the solution says so ([`IkSolution::wrist_free`]).
//! 3. **q2, q3, q4.** `T_14 = T_01⁻¹ T (T_45 T_56)⁻¹` gives the planar point `(X, Y)` (its
//!    origin) and `ψ = atan2(R14[1,0], R14[0,0])`. With `β = -θ3`:
//!    `cos β = (X² + Y² - a2² - a3²) / (2 a2 a3)` (**unreachable** when `|cos β| > 1`; branches
//!    merge at `sin β = 0`, the **elbow singularity** with the arm stretched),
//!    `θ2 = atan2(Y, X) - atan2(a3 sin β, a2 + a3 cos β)`, `θ4 = ψ - θ2 + θ3`.
//!
//! Every angle comes from `atan2` of well-scaled arguments (no `acos`/`asin`), so the solutions
//! reproduce the pose to ~1e-15 away from singularities and stay pose-exact near them (where
//! the angles themselves are ill-conditioned but the pose is insensitive to them).
//! Later steps use the already-rounded earlier angles, so errors do not accumulate.
//! Up to 2 x 2 x 2 = 8 solutions; each is wrapped to `(-π, π]` and then every `q + 2kπ`
//! inside the joint limits is offered (none extra for the i10's ±175 deg, which is narrower
//! than a turn; the code handles wider limits).
//!
//! Source: the structure follows Hawkins, *Analytic Inverse Kinematics for the Universal
//! Robots UR-5/UR-10 Arms* (2013), re-derived above for the AUBO table of ARCHITECTURE.md section 6 and
//! verified numerically by the tests (10,000 random poses).

use crate::dh::DhTable;
use crate::limits::JointLimit;
use crate::se3::wrap_to_pi;
use nalgebra::{Isometry3, Vector3};
use std::f64::consts::{FRAC_PI_2, PI};

/// Below this magnitude (of `sin q5`, `sin β`, or `h` in metres) two branches are treated as one
/// and, for the wrist, q6 as free.
pub const DEGENERATE_TOLERANCE: f64 = 1e-12;

/// Tolerance on the reach conditions `r >= d4` and `|cos β| <= 1`, absorbing rounding of
/// poses generated exactly on the workspace boundary.
pub const REACH_TOLERANCE: f64 = 1e-12;

/// Tuning of the solver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IkSettings {
    /// Weights `w_i` of the joint distance `Σ w_i (q_i - seed_i)²` used to rank solutions.
    /// Default `(1, 1, 1, 0.5, 0.5, 0.5)`: moving the proximal joints swings the whole arm and
    /// costs more than turning the wrist. The distance is not taken modulo 2π: the joints have
    /// limits and cannot pass through ±180 deg.
    pub joint_weights: [f64; 6],
    /// A solution is flagged near-singular when `|sin q5|` or `|sin β|` is below this.
    /// Default 1e-3.
    pub near_singular_sin: f64,
    /// A solution is flagged shoulder-near-singular when the wrist centre is closer than this to
    /// the plane of axes 1 and 2 (metres). Default 1e-3 m.
    pub near_singular_shoulder_m: f64,
}

impl Default for IkSettings {
    fn default() -> Self {
        Self {
            joint_weights: [1.0, 1.0, 1.0, 0.5, 0.5, 0.5],
            near_singular_sin: 1e-3,
            near_singular_shoulder_m: 1e-3,
        }
    }
}

/// The DH table does not have the structure the closed form needs.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "DH row {row} has {parameter} = {got}, the closed-form IK needs {expected} (UR-type wrist, see robot::ik)"
)]
pub struct IkGeometryError {
    /// 1-based row of the DH table.
    pub row: usize,
    /// Which parameter (`a`, `d` or `alpha`).
    pub parameter: &'static str,
    /// Value the solver requires.
    pub expected: f64,
    /// Value in the table.
    pub got: f64,
}

/// Why a pose has no IK solution.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum IkError {
    /// The requested pose or seed contains NaN or infinity.
    #[error("non-finite input: {what}")]
    NonFinite {
        /// `pose` or `seed`.
        what: &'static str,
    },
    /// The wrist centre is closer to the base axis than the shoulder offset d4.
    #[error(
        "unreachable: wrist centre {radius_m:.6} m from the base axis, less than the shoulder offset d4 = {offset_m} m"
    )]
    InsideShoulderOffset {
        /// Horizontal distance of the wrist centre from the base z axis.
        radius_m: f64,
        /// The offset d4.
        offset_m: f64,
    },
    /// The shoulder-to-wrist distance in the arm plane is outside `[|a2 - a3|, a2 + a3]`.
    #[error(
        "unreachable: shoulder-to-wrist distance {distance_m:.6} m in the arm plane outside [{min_m}, {max_m}] m"
    )]
    OutOfReach {
        /// Distance required (closest to the feasible range over all branches).
        distance_m: f64,
        /// `|a2 - a3|`.
        min_m: f64,
        /// `a2 + a3`.
        max_m: f64,
    },
    /// Every analytic solution has a joint outside its limits.
    #[error(
        "all {analytic} analytic solutions violate the joint limits; the closest has joint {joint} at {angle_deg:.3} deg outside [{min_deg:.1}, {max_deg:.1}] deg"
    )]
    OutsideLimits {
        /// Number of analytic solutions found.
        analytic: usize,
        /// 1-based joint of the worst violation of the least-violating solution.
        joint: usize,
        /// Its angle.
        angle_deg: f64,
        /// Its lower limit.
        min_deg: f64,
        /// Its upper limit.
        max_deg: f64,
    },
}

/// Sign choice of one branch of the closed form.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum BranchSign {
    /// The `+` root.
    Positive,
    /// The `-` root.
    Negative,
}

impl BranchSign {
    fn value(self) -> f64 {
        match self {
            Self::Positive => 1.0,
            Self::Negative => -1.0,
        }
    }
}

/// Which of the (up to) 8 branches a solution is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct IkBranch {
    /// Sign of `h` in `θ1 = φ + atan2(d4, ±h)` (which side of the base the wrist centre is on).
    pub shoulder: BranchSign,
    /// Sign of `sin θ5` (wrist flipped or not).
    pub wrist: BranchSign,
    /// Sign of `sin β = -sin θ3` (elbow up or down).
    pub elbow: BranchSign,
}

/// Distances from the three singularities, as computed by the solver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SingularityMargins {
    /// `sin θ5`: 0 at the wrist singularity.
    pub wrist_sin_q5: f64,
    /// `h`: distance of the wrist centre from the plane of axes 1 and 2 (m); 0 at the shoulder
    /// singularity.
    pub shoulder_m: f64,
    /// `sin β = -sin θ3`: 0 at the elbow singularity (arm stretched or folded).
    pub elbow_sin_q3: f64,
}

/// One IK solution.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IkSolution {
    /// Joint angles q1..q6 (rad).
    pub q_rad: [f64; 6],
    /// The branch it comes from.
    pub branch: IkBranch,
    /// How far it is from each singularity.
    pub margins: SingularityMargins,
    /// True at an exact wrist singularity (`|sin q5| <= DEGENERATE_TOLERANCE`): the pose does not
    /// determine q6 (a one-parameter family of solutions); q6 was taken from the seed (0 without
    /// one) and q2, q3, q4 computed for it.
    pub wrist_free: bool,
    /// True when any margin is below the settings' near-singular thresholds: the angles are
    /// ill-conditioned (small pose changes move them a lot).
    pub near_singular: bool,
}

/// All solutions of one IK query.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct IkSolutions {
    /// Solutions with every joint inside its limits (including `±2π` equivalents), sorted by
    /// weighted distance from the seed when a seed was given, else in branch order.
    pub within_limits: Vec<IkSolution>,
    /// Analytic solutions (wrapped to `(-π, π]`) with at least one joint outside its limits.
    pub outside_limits: Vec<IkSolution>,
}

impl IkSolutions {
    /// Every solution, those within limits first.
    pub fn all(&self) -> impl Iterator<Item = &IkSolution> {
        self.within_limits.iter().chain(&self.outside_limits)
    }
}

/// Closed-form IK solver for a UR-type arm with the AUBO i10's axis layout.
#[derive(Debug, Clone, PartialEq)]
pub struct ArmIk {
    dh: DhTable,
    limits: [JointLimit; 6],
    settings: IkSettings,
}

impl ArmIk {
    /// Builds a solver for `dh` with the given limits and settings.
    ///
    /// # Errors
    /// [`IkGeometryError`] when the table does not have the structure of the derivation in the
    /// module docs (tolerance 1e-12).
    pub fn new(
        dh: DhTable,
        limits: [JointLimit; 6],
        settings: IkSettings,
    ) -> Result<Self, IkGeometryError> {
        let required: [(usize, &'static str, f64, f64); 12] = [
            (1, "alpha", dh.rows[0].alpha_rad, FRAC_PI_2),
            (2, "alpha", dh.rows[1].alpha_rad, PI),
            (3, "alpha", dh.rows[2].alpha_rad, PI),
            (4, "alpha", dh.rows[3].alpha_rad, -FRAC_PI_2),
            (5, "alpha", dh.rows[4].alpha_rad, FRAC_PI_2),
            (6, "alpha", dh.rows[5].alpha_rad, 0.0),
            (1, "a", dh.rows[0].a_m, 0.0),
            (4, "a", dh.rows[3].a_m, 0.0),
            (5, "a", dh.rows[4].a_m, 0.0),
            (6, "a", dh.rows[5].a_m, 0.0),
            (2, "d", dh.rows[1].d_m, 0.0),
            (3, "d", dh.rows[2].d_m, 0.0),
        ];
        for (row, parameter, got, expected) in required {
            let matches = (got - expected).abs() <= 1e-12; // false for NaN
            if !matches {
                return Err(IkGeometryError {
                    row,
                    parameter,
                    expected,
                    got,
                });
            }
        }
        for (row, parameter, got) in [(2, "a", dh.rows[1].a_m), (3, "a", dh.rows[2].a_m)] {
            let positive = got > 0.0; // false for NaN
            if !positive {
                return Err(IkGeometryError {
                    row,
                    parameter,
                    expected: 1.0,
                    got,
                });
            }
        }
        Ok(Self {
            dh,
            limits,
            settings,
        })
    }

    /// The AUBO i10 solver with its vendor limits and default settings.
    #[must_use]
    pub fn aubo_i10() -> Self {
        Self {
            dh: crate::aubo_i10::AUBO_I10_DH,
            limits: crate::aubo_i10::aubo_i10_limits(),
            settings: IkSettings::default(),
        }
    }

    /// The DH table solved for.
    #[must_use]
    pub fn dh(&self) -> &DhTable {
        &self.dh
    }

    /// The joint limits applied.
    #[must_use]
    pub fn limits(&self) -> &[JointLimit; 6] {
        &self.limits
    }

    /// The settings in use.
    #[must_use]
    pub fn settings(&self) -> &IkSettings {
        &self.settings
    }

    /// Weighted squared joint distance `Σ w_i (a_i - b_i)²` used to rank solutions.
    #[must_use]
    pub fn joint_distance(&self, a_rad: &[f64; 6], b_rad: &[f64; 6]) -> f64 {
        (0..6)
            .map(|i| self.settings.joint_weights[i] * (a_rad[i] - b_rad[i]).powi(2))
            .sum()
    }

    /// All IK solutions for the flange pose `arm_base_from_tool0` (tool0 = DH frame 6).
    ///
    /// `seed_rad`, when given, ranks the solutions (nearest first) and supplies q6 at an exact
    /// wrist singularity.
    ///
    /// # Errors
    /// [`IkError::NonFinite`], [`IkError::InsideShoulderOffset`] or [`IkError::OutOfReach`] when
    /// no branch reaches the pose. Solutions outside the joint limits are not an error here;
    /// they are listed in [`IkSolutions::outside_limits`].
    pub fn solve(
        &self,
        arm_base_from_tool0: &Isometry3<f64>,
        seed_rad: Option<&[f64; 6]>,
    ) -> Result<IkSolutions, IkError> {
        let t = &arm_base_from_tool0.translation.vector;
        let q = arm_base_from_tool0.rotation.coords;
        if !(t.iter().all(|v| v.is_finite()) && q.iter().all(|v| v.is_finite())) {
            return Err(IkError::NonFinite { what: "pose" });
        }
        if let Some(seed) = seed_rad
            && !seed.iter().all(|v| v.is_finite())
        {
            return Err(IkError::NonFinite { what: "seed" });
        }
        let analytic = self.analytic(arm_base_from_tool0, seed_rad)?;
        let mut out = IkSolutions::default();
        let single_turn = self
            .limits
            .iter()
            .all(|l| l.position_max - l.position_min < std::f64::consts::TAU);
        for solution in analytic {
            if single_turn {
                // Fast path (the i10): at most one representative per joint, no allocation.
                let mut q_rad = solution.q_rad;
                let all_inside = q_rad.iter_mut().zip(&self.limits).all(|(q, limit)| {
                    use std::f64::consts::TAU;
                    match [*q, *q - TAU, *q + TAU]
                        .into_iter()
                        .find(|c| limit.contains(*c))
                    {
                        Some(c) => {
                            *q = c;
                            true
                        }
                        None => false,
                    }
                });
                if all_inside {
                    out.within_limits.push(IkSolution { q_rad, ..solution });
                } else {
                    out.outside_limits.push(solution);
                }
                continue;
            }
            let equivalents: Vec<Vec<f64>> = (0..6)
                .map(|i| self.limits[i].revolute_equivalents(solution.q_rad[i]))
                .collect();
            if equivalents.iter().any(Vec::is_empty) {
                out.outside_limits.push(solution);
                continue;
            }
            // Cartesian product of the per-joint equivalents (one each for +-175 deg limits).
            let mut combos: Vec<[f64; 6]> = vec![solution.q_rad];
            for (i, values) in equivalents.iter().enumerate() {
                combos = combos
                    .iter()
                    .flat_map(|c| {
                        values.iter().map(move |&v| {
                            let mut c = *c;
                            c[i] = v;
                            c
                        })
                    })
                    .collect();
            }
            out.within_limits.extend(
                combos
                    .into_iter()
                    .map(|q_rad| IkSolution { q_rad, ..solution }),
            );
        }
        if let Some(seed) = seed_rad {
            out.within_limits.sort_by(|a, b| {
                self.joint_distance(&a.q_rad, seed)
                    .total_cmp(&self.joint_distance(&b.q_rad, seed))
            });
        }
        Ok(out)
    }

    /// The solution inside the joint limits nearest to `seed_rad` (weighted joint distance).
    ///
    /// # Errors
    /// Those of [`ArmIk::solve`], and [`IkError::OutsideLimits`] when every analytic solution
    /// violates a limit.
    pub fn nearest(
        &self,
        arm_base_from_tool0: &Isometry3<f64>,
        seed_rad: &[f64; 6],
    ) -> Result<IkSolution, IkError> {
        let solutions = self.solve(arm_base_from_tool0, Some(seed_rad))?;
        if let Some(best) = solutions.within_limits.first() {
            return Ok(*best);
        }
        // Report the least-violating solution's worst joint.
        let violation = |q: f64, l: &JointLimit| -> f64 {
            (l.position_min - q).max(q - l.position_max).max(0.0)
        };
        let mut best: Option<(f64, usize, f64)> = None;
        for s in &solutions.outside_limits {
            let mut total = 0.0;
            let mut worst = (0.0, 0usize);
            for i in 0..6 {
                let v = violation(s.q_rad[i], &self.limits[i]);
                total += v;
                if v > worst.0 {
                    worst = (v, i);
                }
            }
            if best.is_none_or(|(b, _, _)| total < b) {
                best = Some((total, worst.1, s.q_rad[worst.1]));
            }
        }
        let (_, joint, angle) = best.unwrap_or((0.0, 0, f64::NAN));
        let limit = self.limits.get(joint).copied().unwrap_or(self.limits[0]);
        Err(IkError::OutsideLimits {
            analytic: solutions.outside_limits.len(),
            joint: joint + 1,
            angle_deg: angle.to_degrees(),
            min_deg: limit.position_min.to_degrees(),
            max_deg: limit.position_max.to_degrees(),
        })
    }

    /// The analytic solutions, each wrapped to `(-π, π]`, in branch order.
    fn analytic(
        &self,
        pose: &Isometry3<f64>,
        seed_rad: Option<&[f64; 6]>,
    ) -> Result<Vec<IkSolution>, IkError> {
        let rows = &self.dh.rows;
        let offsets = rows.map(|r| r.theta_offset_rad);
        let (d4, d6) = (rows[3].d_m, rows[5].d_m);
        let (a2, a3) = (rows[1].a_m, rows[2].a_m);
        let rot = pose.rotation.to_rotation_matrix();
        let p = pose.translation.vector;
        let p5 = p - d6 * (rot * Vector3::z());

        // Step 1: q1.
        let r2 = p5.x * p5.x + p5.y * p5.y;
        let h2 = r2 - d4 * d4;
        if h2 < -REACH_TOLERANCE {
            return Err(IkError::InsideShoulderOffset {
                radius_m: r2.sqrt(),
                offset_m: d4.abs(),
            });
        }
        let h = h2.max(0.0).sqrt();
        let phi = p5.y.atan2(p5.x);
        let shoulder_branches: &[BranchSign] = if h <= DEGENERATE_TOLERANCE {
            &[BranchSign::Positive]
        } else {
            &[BranchSign::Positive, BranchSign::Negative]
        };

        let mut solutions = Vec::with_capacity(8);
        let mut reach_violation: Option<f64> = None;
        for &shoulder in shoulder_branches {
            let theta1 = phi + d4.atan2(shoulder.value() * h);
            let (s1, c1) = theta1.sin_cos();
            let z1 = Vector3::new(s1, -c1, 0.0);
            // Step 2: q5, q6 from z1 in the flange frame.
            let w = rot.transpose() * z1;
            let s5_abs = w.x.hypot(w.y);
            let wrist_free = s5_abs <= DEGENERATE_TOLERANCE;
            let wrist_branches: &[BranchSign] = if wrist_free {
                &[BranchSign::Positive]
            } else {
                &[BranchSign::Positive, BranchSign::Negative]
            };
            let q1 = theta1 - offsets[0];
            let frame0_from_frame1 = rows[0].transform(q1);
            for &wrist in wrist_branches {
                let sign5 = wrist.value();
                let theta5 = (sign5 * s5_abs).atan2(w.z);
                let theta6 = if wrist_free {
                    seed_rad.map_or(0.0, |s| s[5]) + offsets[5]
                } else {
                    (sign5 * w.y).atan2(-sign5 * w.x)
                };
                let q5 = theta5 - offsets[4];
                let q6 = theta6 - offsets[5];
                // Step 3: the planar 2R problem in frame 1.
                let frame4_from_frame6 = rows[4].transform(q5) * rows[5].transform(q6);
                let frame1_from_frame4 =
                    frame0_from_frame1.inverse() * pose * frame4_from_frame6.inverse();
                let x = frame1_from_frame4.translation.x;
                let y = frame1_from_frame4.translation.y;
                let r14 = frame1_from_frame4.rotation.to_rotation_matrix();
                let psi = r14[(1, 0)].atan2(r14[(0, 0)]);
                let dist2 = x * x + y * y;
                let cos_beta = (dist2 - a2 * a2 - a3 * a3) / (2.0 * a2 * a3);
                if cos_beta.abs() > 1.0 + REACH_TOLERANCE {
                    let d = dist2.sqrt();
                    let excess = (d - (a2 + a3)).max((a2 - a3).abs() - d);
                    if reach_violation
                        .is_none_or(|v| excess < (v - (a2 + a3)).max((a2 - a3).abs() - v))
                    {
                        reach_violation = Some(d);
                    }
                    continue;
                }
                let cos_beta = cos_beta.clamp(-1.0, 1.0);
                let sin_beta_abs = (1.0 - cos_beta * cos_beta).max(0.0).sqrt();
                let elbow_branches: &[BranchSign] = if sin_beta_abs <= DEGENERATE_TOLERANCE {
                    &[BranchSign::Positive]
                } else {
                    &[BranchSign::Positive, BranchSign::Negative]
                };
                for &elbow in elbow_branches {
                    let sin_beta = elbow.value() * sin_beta_abs;
                    let beta = sin_beta.atan2(cos_beta);
                    let theta2 = y.atan2(x) - (a3 * sin_beta).atan2(a2 + a3 * cos_beta);
                    let theta3 = -beta;
                    let theta4 = psi - theta2 + theta3;
                    let q_rad = [
                        wrap_to_pi(q1),
                        wrap_to_pi(theta2 - offsets[1]),
                        wrap_to_pi(theta3 - offsets[2]),
                        wrap_to_pi(theta4 - offsets[3]),
                        wrap_to_pi(q5),
                        wrap_to_pi(q6),
                    ];
                    let margins = SingularityMargins {
                        wrist_sin_q5: sign5 * s5_abs,
                        shoulder_m: shoulder.value() * h,
                        elbow_sin_q3: sin_beta,
                    };
                    let near_singular = margins.wrist_sin_q5.abs()
                        < self.settings.near_singular_sin
                        || margins.elbow_sin_q3.abs() < self.settings.near_singular_sin
                        || margins.shoulder_m.abs() < self.settings.near_singular_shoulder_m;
                    solutions.push(IkSolution {
                        q_rad,
                        branch: IkBranch {
                            shoulder,
                            wrist,
                            elbow,
                        },
                        margins,
                        wrist_free,
                        near_singular,
                    });
                }
            }
        }
        if solutions.is_empty() {
            return Err(IkError::OutOfReach {
                distance_m: reach_violation.unwrap_or(f64::NAN),
                min_m: (a2 - a3).abs(),
                max_m: a2 + a3,
            });
        }
        Ok(solutions)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::aubo_i10::{AUBO_I10_DH, aubo_i10_limits};
    use crate::se3::rotation_angle_between_rad;
    use nalgebra::{Translation3, UnitQuaternion};
    use std::f64::consts::TAU;

    use rng::SplitMix64;

    fn pose_error(a: &Isometry3<f64>, b: &Isometry3<f64>) -> (f64, f64) {
        (
            (a.translation.vector - b.translation.vector).norm(),
            rotation_angle_between_rad(&a.rotation, &b.rotation),
        )
    }

    fn angle_diff(a: f64, b: f64) -> f64 {
        wrap_to_pi(a - b).abs()
    }

    /// Distance of the wrist centre from the plane of axes 1 and 2 for joint angles q.
    fn shoulder_margin_m(q: &[f64; 6]) -> f64 {
        let frames = AUBO_I10_DH.dh_frames(q);
        let p5 = frames[5].translation.vector;
        let theta1 = q[0] + AUBO_I10_DH.rows[0].theta_offset_rad;
        (p5.x * theta1.cos() + p5.y * theta1.sin()).abs()
    }

    #[test]
    fn random_reachable_poses_round_trip() {
        let ik = ArmIk::aubo_i10();
        let lim = crate::aubo_i10::AUBO_I10_POSITION_LIMIT_RAD;
        let mut rng = SplitMix64::new(0x5EED_0001);
        let samples = 10_000;
        let (mut skipped, mut solutions_total, mut max_dt, mut max_dr) =
            (0usize, 0usize, 0f64, 0f64);
        let mut histogram = [0usize; 9];
        for n in 0..samples {
            let q: [f64; 6] = std::array::from_fn(|_| rng.uniform(-lim, lim));
            let pose = AUBO_I10_DH.forward(&q);
            let sols = ik
                .solve(&pose, None)
                .unwrap_or_else(|e| panic!("sample {n}: {e} for q {q:?}"));
            let all: Vec<&IkSolution> = sols
                .within_limits
                .iter()
                .chain(&sols.outside_limits)
                .collect();
            assert!(all.len() <= 8);
            histogram[sols.within_limits.len().min(8)] += 1;
            solutions_total += all.len();
            for s in &all {
                let (dt, dr) = pose_error(&AUBO_I10_DH.forward(&s.q_rad), &pose);
                max_dt = max_dt.max(dt);
                max_dr = max_dr.max(dr);
                assert!(
                    dt < 1e-9 && dr < 1e-9,
                    "sample {n}: q {q:?} solution {s:?}: {dt:e} m, {dr:e} rad"
                );
            }
            let near_singular =
                q[4].sin().abs() < 1e-3 || q[2].sin().abs() < 1e-3 || shoulder_margin_m(&q) < 1e-3;
            if near_singular {
                skipped += 1;
                continue;
            }
            let found = sols
                .within_limits
                .iter()
                .any(|s| (0..6).all(|i| angle_diff(s.q_rad[i], q[i]) < 1e-7));
            assert!(
                found,
                "sample {n}: generating q {q:?} not among {:?}",
                sols.within_limits
            );
            let nearest = ik
                .nearest(&pose, &q)
                .unwrap_or_else(|e| panic!("sample {n}: {e}"));
            assert!(
                (0..6).all(|i| (nearest.q_rad[i] - q[i]).abs() < 1e-7),
                "sample {n}"
            );
        }
        eprintln!(
            "IK round trip: {samples} poses, {solutions_total} analytic solutions, {skipped} skipped as near-singular, \
             max error {max_dt:e} m / {max_dr:e} rad, within-limit solution counts {histogram:?}"
        );
        assert!(
            skipped < samples / 20,
            "too many near-singular samples: {skipped}"
        );
    }

    #[test]
    fn wrist_singularity_returns_the_determined_part() {
        let ik = ArmIk::aubo_i10();
        let q = [0.4, -0.3, 1.1, 0.5, 0.0, 0.7];
        let pose = AUBO_I10_DH.forward(&q);
        // A seed with another q6: q6 is taken from it, q2..q4 adapt, the pose is reproduced.
        let seed = [0.4, -0.3, 1.1, 0.9, 0.0, 0.3];
        let sols = ik.solve(&pose, Some(&seed)).expect("reachable");
        let free: Vec<&IkSolution> = sols.within_limits.iter().filter(|s| s.wrist_free).collect();
        // On the generating shoulder branch the wrist flip collapses: 2 elbow branches remain.
        assert_eq!(free.len(), 2, "{sols:#?}");
        for s in sols.within_limits.iter().chain(&sols.outside_limits) {
            if s.wrist_free {
                assert!(
                    s.near_singular && (s.q_rad[5] - 0.3).abs() < 1e-12,
                    "q6 from the seed"
                );
            }
            let (dt, dr) = pose_error(&AUBO_I10_DH.forward(&s.q_rad), &pose);
            assert!(dt < 1e-9 && dr < 1e-9, "{s:?}: {dt:e} {dr:e}");
        }
        // Seeded with the generating q6, the generating configuration comes back first.
        let best = ik.nearest(&pose, &q).expect("reachable");
        assert!(best.wrist_free);
        assert!(
            (0..6).all(|i| (best.q_rad[i] - q[i]).abs() < 1e-9),
            "{best:?}"
        );
    }

    #[test]
    fn stretched_elbow_is_reproduced() {
        let ik = ArmIk::aubo_i10();
        for q in [[0.2, 0.3, 0.0, 0.4, 1.0, -0.5], [0.0; 6]] {
            let pose = AUBO_I10_DH.forward(&q);
            let sols = ik
                .solve(&pose, Some(&q))
                .expect("boundary pose is reachable");
            let best = &sols.within_limits[0];
            assert!(best.near_singular);
            assert!(
                (0..6).all(|i| (best.q_rad[i] - q[i]).abs() < 1e-6),
                "{best:?}"
            );
            for s in sols.within_limits.iter().chain(&sols.outside_limits) {
                let (dt, dr) = pose_error(&AUBO_I10_DH.forward(&s.q_rad), &pose);
                assert!(dt < 1e-9 && dr < 1e-9, "{s:?}: {dt:e} {dr:e}");
            }
        }
    }

    #[test]
    fn unreachable_poses_are_errors() {
        let ik = ArmIk::aubo_i10();
        let far =
            Isometry3::from_parts(Translation3::new(2.0, 0.5, 0.8), UnitQuaternion::identity());
        match ik.solve(&far, None) {
            Err(IkError::OutOfReach {
                distance_m, max_m, ..
            }) => {
                assert!(distance_m > max_m);
                assert!((max_m - 1.2475).abs() < 1e-12);
            }
            other => panic!("expected OutOfReach, got {other:?}"),
        }
        // Wrist centre on the base axis: closer than d4 = 0.2013 m.
        let on_axis =
            Isometry3::from_parts(Translation3::new(0.0, 0.0, 0.9), UnitQuaternion::identity());
        let on_axis = on_axis * Translation3::new(0.0, 0.0, 0.094);
        assert!(matches!(
            ik.solve(&on_axis, None),
            Err(IkError::InsideShoulderOffset { offset_m, .. }) if (offset_m - 0.2013).abs() < 1e-12
        ));
        let nan = Isometry3::from_parts(
            Translation3::new(f64::NAN, 0.0, 0.5),
            UnitQuaternion::identity(),
        );
        assert_eq!(
            ik.solve(&nan, None),
            Err(IkError::NonFinite { what: "pose" })
        );
    }

    #[test]
    fn limits_filter_and_report() {
        let narrow = aubo_i10_limits().map(|l| JointLimit {
            position_min: -0.2,
            position_max: 0.2,
            ..l
        });
        let ik = ArmIk::new(AUBO_I10_DH, narrow, IkSettings::default()).expect("valid table");
        let q = [1.0, -0.3, 1.1, 0.5, 0.8, 0.7];
        let pose = AUBO_I10_DH.forward(&q);
        let sols = ik.solve(&pose, None).expect("reachable");
        assert!(sols.within_limits.is_empty() && !sols.outside_limits.is_empty());
        match ik.nearest(&pose, &q) {
            Err(IkError::OutsideLimits {
                joint,
                angle_deg,
                max_deg,
                ..
            }) => {
                assert!((1..=6).contains(&joint));
                assert!(angle_deg.abs() > max_deg);
            }
            other => panic!("expected OutsideLimits, got {other:?}"),
        }
        // Wide limits offer the 2 pi equivalents.
        let wide = aubo_i10_limits().map(|l| JointLimit {
            position_min: -TAU,
            position_max: TAU,
            ..l
        });
        let ik = ArmIk::new(AUBO_I10_DH, wide, IkSettings::default()).expect("valid table");
        let sols = ik.solve(&pose, None).expect("reachable");
        // Every wrapped angle (none exactly 0 or pi here) has two representatives in [-2pi, 2pi].
        let analytic = ArmIk::aubo_i10().solve(&pose, None).expect("reachable");
        let count = analytic.within_limits.len() + analytic.outside_limits.len();
        assert!(count >= 4);
        assert_eq!(sols.within_limits.len(), count * 64);
    }

    #[test]
    fn nearest_follows_the_seed_branch() {
        let ik = ArmIk::aubo_i10();
        let pose = AUBO_I10_DH.forward(&[0.2, 0.3, 1.0, -0.4, 1.0, 0.5]);
        let sols = ik.solve(&pose, None).expect("reachable");
        assert_eq!(
            sols.within_limits.len(),
            8,
            "a pose with all 8 branches inside the limits"
        );
        for s in &sols.within_limits {
            // A seed a little off each solution selects that solution.
            let seed = s.q_rad.map(|q| q + 0.05);
            let best = ik.nearest(&pose, &seed).expect("reachable");
            assert_eq!(best.branch, s.branch);
            let ranked = ik.solve(&pose, Some(&seed)).expect("reachable");
            let d: Vec<f64> = ranked
                .within_limits
                .iter()
                .map(|r| ik.joint_distance(&r.q_rad, &seed))
                .collect();
            assert!(
                d.windows(2).all(|w| w[0] <= w[1]),
                "sorted by distance: {d:?}"
            );
        }
    }

    #[test]
    fn geometry_is_checked() {
        let mut dh = AUBO_I10_DH;
        dh.rows[2].alpha_rad = 0.0;
        let err =
            ArmIk::new(dh, aubo_i10_limits(), IkSettings::default()).expect_err("UR-style alpha3");
        assert_eq!((err.row, err.parameter), (3, "alpha"));
    }
}
