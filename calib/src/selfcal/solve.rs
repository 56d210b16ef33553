//! The hand-eye solve over the pair motions of [`super::pipeline`]: RGB-D ([`solve_rgbd`]:
//! Kronecker, the pose LM when [`Steps::pose_refinement`], pair rejection when
//! [`Steps::pair_rejection`], then the final refinement of [`Steps::final_refinement`]) and
//! mono ([`solve_mono`]: the per-pair scale alternation of [`super`]'s module docs).

use nalgebra::{Isometry3, Translation3, UnitQuaternion};

use super::ba::refine_ba;
use super::eq15::{Eq15Problem, Eq15Report, refine_eq15};
use super::method::FinalRefinement;
use super::motion::mono_translation;
use super::pairs::{PairMatches, PairRejection, RejectionCounts};
use super::pipeline::{PairReport, SelfCalParams};
use super::tracks::build_tracks;
use super::views::CalibView;
use super::{MIN_PAIRS, MONO_SCALE_ALTERNATIONS, SelfCalError};
use crate::handeye::refine::pair_residual;
use crate::handeye::{
    HandEyeError, HandEyeOptions, HandEyeSolution, RelativeMotion, degeneracy, kronecker,
    solve_motions, uncertainty,
};
use crate::relpose::CameraModel;

pub(crate) fn median(mut v: Vec<f64>) -> f64 {
    v.retain(|x| x.is_finite());
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Runs the solve on the pairs `used` (indices into `reports`) and marks the pairs the
/// hand-eye solver rejects.
pub(crate) fn solve_used(
    reports: &mut [PairReport],
    used: &[usize],
    motions: &[RelativeMotion],
    opts: &HandEyeOptions,
) -> Result<HandEyeSolution, SelfCalError> {
    let sel: Vec<RelativeMotion> = used
        .iter()
        .filter_map(|&k| motions.get(k).copied())
        .collect();
    let sol = solve_motions(&sel, opts)?;
    for &r in &sol.rejected_pairs {
        if let Some(rep) = used.get(r).and_then(|&k| reports.get_mut(k)) {
            rep.rejected = Some(PairRejection::AngleMismatch);
        }
    }
    Ok(sol)
}

pub(crate) fn too_few_pairs(reports: &[PairReport]) -> SelfCalError {
    let c = RejectionCounts::of(reports.iter().map(|r| r.rejected.as_ref()));
    SelfCalError::TooFewPairs {
        usable: c.usable,
        candidates: reports.len(),
        need: MIN_PAIRS,
        too_little_rotation: c.small_rotation,
        too_few_matches: c.too_few_matches,
        motion_failed: c.motion_failed,
        rejected_later: c.rejected_later,
    }
}

pub(crate) fn used_indices(reports: &[PairReport]) -> Vec<usize> {
    (0..reports.len())
        .filter(|&k| reports.get(k).is_some_and(|r| r.rejected.is_none()))
        .collect()
}

/// The distinct views (ascending) of the pairs `(i, j)`.
pub(crate) fn distinct_views(pairs: impl IntoIterator<Item = (usize, usize)>) -> Vec<usize> {
    let mut views: Vec<usize> = pairs.into_iter().flat_map(|(i, j)| [i, j]).collect();
    views.sort_unstable();
    views.dedup();
    views
}

pub(crate) type Solved = (HandEyeSolution, Isometry3<f64>, Option<Eq15Report>);

/// What the final refinement of [`solve_rgbd`] needs besides the motions: the views, the
/// camera and the pairs' matches (for the feature tracks of eq. 15).
pub(crate) struct TrackInputs<'a> {
    pub views: &'a [CalibView],
    pub camera: &'a CameraModel,
    pub matches: &'a [PairMatches],
    pub keypoints_per_view: &'a [usize],
    /// Per view, per keypoint: whether its depth may be used.
    pub depth_support: &'a [Vec<bool>],
}

/// RGB-D: the linear (Kronecker) X over the used pairs, the pose solve of `opts` (with pair
/// rejection when [`Steps::pair_rejection`]), then [`Steps::final_refinement`] over the
/// features tracked through the used pairs' motion-consistent matches.
pub(crate) fn solve_rgbd(
    reports: &mut [PairReport],
    motions: &[RelativeMotion],
    inputs: &TrackInputs<'_>,
    opts: &HandEyeOptions,
    params: &SelfCalParams,
) -> Result<Solved, SelfCalError> {
    let used = used_indices(reports);
    let sel: Vec<RelativeMotion> = used
        .iter()
        .filter_map(|&k| motions.get(k).copied())
        .collect();
    let (linear, _) = kronecker::solve(&degeneracy_kept(&sel, opts)?, false)?;
    let mut sol = solve_used(reports, &used, motions, opts)?;
    // Pair rejection by pose residual, then the pose solve again on the kept pairs.
    if params.steps.pair_rejection
        && reject_by_pose_residual(reports, motions, &sol.tool0_from_camera, params) > 0
    {
        if used_indices(reports).len() < MIN_PAIRS {
            return Err(too_few_pairs(reports));
        }
        sol = solve_used(reports, &used_indices(reports), motions, opts)?;
    }
    let refine = params.steps.final_refinement;
    if refine == FinalRefinement::None {
        return Ok((sol, linear, None));
    }
    // The features of eq. 15: tracks over the used pairs' matches that their motion keeps.
    let used = used_indices(reports);
    let mut use_pair = vec![false; inputs.matches.len()];
    for &k in &used {
        if let Some(u) = use_pair.get_mut(k) {
            *u = true;
        }
    }
    let tracks = build_tracks(
        inputs.matches,
        inputs.keypoints_per_view,
        |k| use_pair.get(k).copied().unwrap_or(false),
        |k, m| {
            inputs
                .matches
                .get(k)
                .and_then(|pm| pm.motion_inliers.get(m))
                .copied()
                .unwrap_or(false)
        },
    );
    let problem = Eq15Problem::from_tracks(
        inputs.views,
        inputs.camera,
        &tracks.tracks,
        f64::from(params.orb.scale_factor),
        inputs.depth_support,
    );
    let rep = match refine {
        FinalRefinement::BundleAdjustment => {
            refine_ba(&problem, &sol.tool0_from_camera, &params.eq15)
        }
        _ => refine_eq15(&problem, &sol.tool0_from_camera, &params.eq15),
    };
    // Figures at the refined X over the pairs used.
    let sel: Vec<RelativeMotion> = used
        .iter()
        .filter_map(|&k| motions.get(k).copied())
        .collect();
    let x = rep.tool0_from_camera;
    let stats = uncertainty::evaluate(&sel, &x, 1.0, opts, sel.len());
    sol.tool0_from_camera = x;
    sol.pairs = sel.len();
    sol.residual_rot_deg = stats.residual_rot_deg;
    sol.residual_trans_mm = stats.residual_trans_mm;
    sol.sigma_rot_deg = stats.sigma_rot_deg;
    sol.sigma_trans_mm = stats.sigma_trans_mm;
    sol.iterations += rep.iterations;
    Ok((sol, linear, Some(rep)))
}

/// Rejects the used pairs whose rotation residual of `B X = X A` exceeds
/// `max(max_pair_residual_factor * median, min_pair_residual_limit_deg)` (eye translations
/// taken as they are, i.e. metric). Returns how many were rejected.
pub(crate) fn reject_by_pose_residual(
    reports: &mut [PairReport],
    motions: &[RelativeMotion],
    x: &Isometry3<f64>,
    params: &SelfCalParams,
) -> usize {
    let used = used_indices(reports);
    let res: Vec<f64> = used
        .iter()
        .filter_map(|&k| motions.get(k))
        .map(|m| pair_residual(m, x, 1.0).0.norm().to_degrees())
        .collect();
    let limit = (params.max_pair_residual_factor * median(res.clone()))
        .max(params.min_pair_residual_limit_deg);
    let mut n = 0;
    for (&k, &r) in used.iter().zip(&res) {
        if r > limit
            && let Some(rep) = reports.get_mut(k)
        {
            rep.rejected = Some(PairRejection::Residual {
                residual: r,
                limit,
                unit: "deg, AX=XB rotation",
            });
            n += 1;
        }
    }
    n
}

pub(crate) fn degeneracy_kept(
    motions: &[RelativeMotion],
    opts: &HandEyeOptions,
) -> Result<Vec<RelativeMotion>, SelfCalError> {
    let report = degeneracy::analyse(motions, opts)?;
    Ok(report
        .kept
        .iter()
        .filter_map(|&k| motions.get(k).copied())
        .collect())
}

/// Per-pair scales from X: `s = u^T((R_B - I) t_X + t_B) / |t_A|`, `u = R_X t_A / |t_A|`.
pub(crate) fn scales_from_x(
    motions: &[(Isometry3<f64>, Isometry3<f64>, f64)],
    x: &Isometry3<f64>,
) -> Vec<f64> {
    let r_x = x.rotation.to_rotation_matrix().into_inner();
    motions
        .iter()
        .map(|(a, b, _)| {
            let ta = a.translation.vector;
            let na = ta.norm();
            if na <= 0.0 {
                return 0.0;
            }
            let u = r_x * ta / na;
            let rb = b.rotation.to_rotation_matrix().into_inner();
            u.dot(
                &((rb - nalgebra::Matrix3::identity()) * x.translation.vector
                    + b.translation.vector),
            ) / na
        })
        .collect()
}

pub(crate) fn solve_mono(
    reports: &mut [PairReport],
    motions: &mut [RelativeMotion],
    opts: &HandEyeOptions,
    params: &SelfCalParams,
) -> Result<Solved, SelfCalError> {
    // Unit-translation motions as estimated (`|t_A| = 1`).
    let unit: Vec<(Isometry3<f64>, Isometry3<f64>, f64)> =
        motions.iter().map(|m| (m.a, m.b, m.weight)).collect();
    let used = used_indices(reports);
    let sel: Vec<RelativeMotion> = used
        .iter()
        .filter_map(|&k| motions.get(k).copied())
        .collect();
    let kept = degeneracy_kept(&sel, opts)?;
    // Linear: rotation from the Kronecker null space (scale-free), translation with one
    // scale per pair eliminated ([`mono_translation`]).
    let mut r_x = kronecker::rotation_camera_from_tool0(&kept)?.transpose();
    let translation_failure = HandEyeError::NumericalFailure {
        method: opts.method,
        what: "monocular translation with per-pair scales (hand rotations about one axis?)",
    };
    let mut linear = None;
    let mut sol: Option<HandEyeSolution> = None;
    for round in 0..MONO_SCALE_ALTERNATIONS {
        // (1) R_X fixed: t_X and the per-pair scales by linear least squares.
        let used = used_indices(reports);
        let sel_unit: Vec<_> = used.iter().filter_map(|&k| unit.get(k).copied()).collect();
        let (t_x, _) = mono_translation(&sel_unit, &r_x).ok_or(translation_failure.clone())?;
        let x = Isometry3::from_parts(Translation3::from(t_x), UnitQuaternion::from_matrix(&r_x));
        if linear.is_none() {
            linear = Some(x);
        }
        let scales = scales_from_x(&unit, &x);
        for (k, (m, s)) in motions.iter_mut().zip(&scales).enumerate() {
            let Some((a, _, _)) = unit.get(k) else {
                continue;
            };
            m.a = Isometry3::from_parts(Translation3::from(a.translation.vector * *s), a.rotation);
            let Some(r) = reports.get_mut(k) else {
                continue;
            };
            r.scale = *s;
            match r.rejected {
                None if *s <= 0.0 => {
                    r.rejected = Some(PairRejection::NonPositiveScale { scale: *s });
                }
                Some(PairRejection::NonPositiveScale { .. }) if *s > 0.0 => r.rejected = None,
                _ => {}
            }
        }
        let used = used_indices(reports);
        if used.len() < MIN_PAIRS {
            return Err(too_few_pairs(reports));
        }
        // (2) Scales fixed: X by the pose LM on the metric motions.
        let s = solve_used(reports, &used, motions, opts)?;
        r_x = s
            .tool0_from_camera
            .rotation
            .to_rotation_matrix()
            .into_inner();
        if params.steps.pair_rejection && round + 2 == MONO_SCALE_ALTERNATIONS {
            // Pair rejection by residual before the last round.
            reject_by_pose_residual(reports, motions, &s.tool0_from_camera, params);
        }
        sol = Some(s);
    }
    let (Some(sol), Some(linear)) = (sol, linear) else {
        return Err(too_few_pairs(reports));
    };
    Ok((sol, linear, None))
}
