//! Lift height that puts a target in the arm's dexterous workspace.
//!
//! For a `base_link` target pose of tool0 `T`, each candidate lift `z` (a grid over the lift
//! travel, [`LiftParams::step_m`]) gives the arm-base target `arm_base_from_base(z) T`; its IK
//! solutions within the joint limits are scored by the dexterity
//! `score = min(|sin q5| / s_ref, |sin β| / s_ref, h / h_ref, m / m_ref, 1)`
//! where `q5` is the wrist angle (wrist singularity at 0), `β = -q3` the elbow angle (0 =
//! stretched or folded: the workspace boundary), `h` the wrist centre's distance from the plane
//! of axes 1-2 (shoulder singularity) and `m` the smallest distance of any joint to its limit.
//! A score of 1 means every margin is at least its reference (defaults: `s_ref = sin 45°`,
//! `h_ref = 0.15 m`, `m_ref = 0.5 rad`). The highest score wins; within
//! [`SCORE_TIE`] the lower lift wins (less sway, lower centre of mass), then the solution
//! nearer the seed. Exhaustive over the grid: deterministic, 201 IK calls for 1 cm steps.

use super::MotionError;
use nalgebra::Isometry3;
use robot::{ArmIk, RobotModel};

/// Scores closer than this count as equal.
pub const SCORE_TIE: f64 = 1e-6;

/// Settings of the lift search.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LiftParams {
    /// Grid step over the lift travel (m). Default 0.01.
    pub step_m: f64,
    /// Reference `|sin|` for wrist and elbow margins. Default sin 45°.
    pub sin_ref: f64,
    /// Reference shoulder margin (m). Default 0.15.
    pub shoulder_ref_m: f64,
    /// Reference joint-limit margin (rad). Default 0.5.
    pub limit_margin_ref_rad: f64,
}

impl Default for LiftParams {
    fn default() -> Self {
        Self {
            step_m: 0.01,
            sin_ref: std::f64::consts::FRAC_1_SQRT_2,
            shoulder_ref_m: 0.15,
            limit_margin_ref_rad: 0.5,
        }
    }
}

/// The chosen lift height.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LiftChoice {
    /// Lift position (m).
    pub lift_m: f64,
    /// The arm configuration reaching the target there.
    pub q_rad: [f64; 6],
    /// Dexterity score in `[0, 1]`.
    pub score: f64,
    /// Lift heights tried.
    pub tried: usize,
}

/// Picks the lift height for `base_from_tool0_target` (module docs).
///
/// # Errors
/// [`MotionError::NoLiftHeight`] when no height reaches the target within the limits.
pub fn choose_lift(
    model: &RobotModel,
    ik: &ArmIk,
    base_from_tool0_target: &Isometry3<f64>,
    seed_rad: &[f64; 6],
    params: &LiftParams,
) -> Result<LiftChoice, MotionError> {
    let (lo, hi) = (model.lift_limit.position_min, model.lift_limit.position_max);
    let steps = ((hi - lo) / params.step_m.max(1e-4)).floor().max(0.0) as usize;
    let mut best: Option<(f64, f64, LiftChoice)> = None; // (score, seed distance, choice)
    for k in 0..=steps {
        let lift_m = (lo + k as f64 * params.step_m).min(hi);
        let target = model.arm_base_from_base(lift_m) * base_from_tool0_target;
        let Ok(solutions) = ik.solve(&target, Some(seed_rad)) else {
            continue;
        };
        for s in &solutions.within_limits {
            let limit_margin = s
                .q_rad
                .iter()
                .zip(ik.limits())
                .map(|(q, l)| (q - l.position_min).min(l.position_max - q))
                .fold(f64::INFINITY, f64::min);
            let m = s.margins;
            let score = (m.wrist_sin_q5.abs() / params.sin_ref)
                .min(m.elbow_sin_q3.abs() / params.sin_ref)
                .min(m.shoulder_m.abs() / params.shoulder_ref_m)
                .min(limit_margin / params.limit_margin_ref_rad)
                .min(1.0);
            let distance = ik.joint_distance(&s.q_rad, seed_rad);
            let better = match &best {
                None => true,
                Some((b_score, b_dist, _)) => {
                    score > b_score + SCORE_TIE
                        || ((score - b_score).abs() <= SCORE_TIE && distance < *b_dist - 1e-12 && {
                            // Same lift height: the nearer solution; a higher lift never wins a tie.
                            best.as_ref()
                                .is_some_and(|(_, _, c)| (c.lift_m - lift_m).abs() < 1e-12)
                        })
                }
            };
            if better {
                best = Some((
                    score,
                    distance,
                    LiftChoice {
                        lift_m,
                        q_rad: s.q_rad,
                        score,
                        tried: steps + 1,
                    },
                ));
            }
        }
    }
    best.map(|(_, _, c)| c).ok_or(MotionError::NoLiftHeight {
        min_m: lo,
        max_m: hi,
        tried: steps + 1,
    })
}
