//! Degeneracy analysis of a set of motions, run before every solver.
//!
//! The rotation of X follows from `R_B R_X = R_X R_A`, i.e. `k_B = R_X k_A` for the rotation
//! vectors `k = axis * angle` of each pair (Shiu & Ahmad 1989; Tsai & Lenz 1989, sec. III):
//! two motions with non-parallel axes determine `R_X`, one axis leaves a free rotation about
//! it (and the translation along it). The **rotation-axis condition** is
//!
//! ```text
//! S = sum_k w_k k_B k_B^T   (3x3 scatter of the hand rotation vectors, radians^2)
//! condition = sqrt(lambda_2(S) / lambda_1(S))  in [0, 1]
//! ```
//!
//! 0 when every axis is parallel (or every rotation is zero), 1 when the rotation vectors
//! are spread over at least a plane evenly. Two equal rotations whose axes are `delta`
//! apart give `tan(delta / 2)`: the default threshold 0.05 refuses axes closer than ~5.7 deg.
//! Small rotations weigh little, as they should: their axes are noise.
//!
//! A rigid mount also keeps the rotation angles of `A` and `B` equal (they are conjugate);
//! pairs whose angles differ by more than a threshold are rejected (wrong pairing, a bad
//! eye pose), and the input is refused when more than half are.

use nalgebra::{Matrix3, SymmetricEigen};

use super::geometry::{rot, rotation_angle, rotation_log};
use super::{HandEyeError, HandEyeOptions, MIN_MOTIONS, RelativeMotion};

/// Default refusal threshold of the rotation-axis condition.
pub const MIN_AXIS_CONDITION: f64 = 0.05;
/// Default pure-translation threshold: no hand rotation above this (degrees) is refused.
pub const MIN_ROTATION_DEG: f64 = 1.0;
/// Default hand/eye rotation-angle mismatch (degrees) beyond which a pair is rejected.
pub const MAX_ANGLE_MISMATCH_DEG: f64 = 3.0;

/// What [`analyse`] found.
#[derive(Debug, Clone, PartialEq)]
pub struct DegeneracyReport {
    /// Rotation-axis condition of the kept motions (module docs).
    pub condition: f64,
    /// Dominant rotation axis (unit, tool0 frame).
    pub dominant_axis: [f64; 3],
    /// Indices of the kept motions.
    pub kept: Vec<usize>,
    /// Indices of the motions rejected for an angle mismatch.
    pub rejected: Vec<usize>,
    /// Largest hand/eye rotation-angle difference over the kept motions, degrees.
    pub max_angle_mismatch_deg: f64,
    /// Largest hand rotation angle, degrees.
    pub max_rotation_deg: f64,
}

/// Rotation-axis condition `sqrt(lambda_2 / lambda_1)` of the weighted scatter of the hand
/// rotation vectors, and the dominant axis (module docs). `(0, [0, 0, 0])` without rotation.
pub fn axis_condition(motions: &[RelativeMotion]) -> (f64, [f64; 3]) {
    let mut scatter = Matrix3::zeros();
    for m in motions {
        let k = rotation_log(&rot(&m.b));
        scatter += m.weight * k * k.transpose();
    }
    let eig = SymmetricEigen::new(scatter);
    let mut order = [0usize, 1, 2];
    order.sort_by(|&i, &j| eig.eigenvalues[j].total_cmp(&eig.eigenvalues[i]));
    let l1 = eig.eigenvalues[order[0]];
    let l2 = eig.eigenvalues[order[1]].max(0.0);
    if !l1.is_finite() || l1 <= 0.0 {
        return (0.0, [0.0; 3]);
    }
    let axis = eig.eigenvectors.column(order[0]);
    ((l2 / l1).sqrt(), [axis[0], axis[1], axis[2]])
}

/// Checks the motions and selects the consistent ones.
///
/// # Errors
///
/// [`HandEyeError::PureTranslation`], [`HandEyeError::InconsistentMotions`],
/// [`HandEyeError::TooFewMotions`], [`HandEyeError::DegenerateRotations`].
pub fn analyse(
    motions: &[RelativeMotion],
    opts: &HandEyeOptions,
) -> Result<DegeneracyReport, HandEyeError> {
    let angles: Vec<(f64, f64)> = motions
        .iter()
        .map(|m| {
            (
                rotation_angle(&rot(&m.b)).to_degrees(),
                rotation_angle(&rot(&m.a)).to_degrees(),
            )
        })
        .collect();
    let max_rotation_deg = angles.iter().map(|a| a.0).fold(0.0, f64::max);
    if max_rotation_deg < opts.min_rotation_deg {
        return Err(HandEyeError::PureTranslation {
            max_angle_deg: max_rotation_deg,
            min_deg: opts.min_rotation_deg,
        });
    }
    let mut kept = Vec::new();
    let mut rejected = Vec::new();
    let mut worst = (0usize, 0.0f64);
    let mut max_kept = 0.0f64;
    for (k, (b, a)) in angles.iter().enumerate() {
        let mismatch = (a - b).abs();
        if mismatch > worst.1 {
            worst = (k, mismatch);
        }
        if mismatch > opts.max_angle_mismatch_deg {
            rejected.push(k);
        } else {
            kept.push(k);
            max_kept = max_kept.max(mismatch);
        }
    }
    if rejected.len() * 2 > motions.len() {
        return Err(HandEyeError::InconsistentMotions {
            rejected: rejected.len(),
            pairs: motions.len(),
            threshold_deg: opts.max_angle_mismatch_deg,
            worst_deg: worst.1,
            worst_pair: worst.0,
        });
    }
    if kept.len() < MIN_MOTIONS {
        return Err(HandEyeError::TooFewMotions {
            got: kept.len(),
            need: MIN_MOTIONS,
        });
    }
    let used: Vec<RelativeMotion> = kept
        .iter()
        .filter_map(|&k| motions.get(k).copied())
        .collect();
    let (condition, axis) = axis_condition(&used);
    if condition.is_nan() || condition < opts.min_axis_condition {
        return Err(HandEyeError::DegenerateRotations {
            condition,
            threshold: opts.min_axis_condition,
            axis_x: axis[0],
            axis_y: axis[1],
            axis_z: axis[2],
        });
    }
    Ok(DegeneracyReport {
        condition,
        dominant_axis: axis,
        kept,
        rejected,
        max_angle_mismatch_deg: max_kept,
        max_rotation_deg,
    })
}
