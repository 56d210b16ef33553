//! The self-calibration pipeline end to end ([`self_calibrate`]; steps in the docs of
//! [`super`]).
//!
//! Determinism: features per view and matches/motions per pair run on rayon with ordered
//! collection, each pair's RANSAC has its own seed ([`pair_seed`]), all reductions are
//! sequential: the result does not depend on the thread count.

use nalgebra::{Isometry3, Matrix6, Point2, Point3, Translation3, Vector3};
use rayon::prelude::*;

use super::epipolar::{EpipolarPair, EpipolarParams, hand_error_covariance, refine_epipolar};
use super::eq15::{Eq15Params, Eq15Report};
use super::hand_error::{SharedHandError, ViewHandError};
use super::method::{FinalRefinement, SelfCalMethod, Steps};
use super::motion::{PairMotion, keypoint_depth_support, mono_motion, pair_seed, rgbd_motion};
use super::pairs::{
    PairMatches, PairRejection, Refused, candidate_pairs, extract_features, hand_motion, match_pair,
};
use super::solve::{
    TrackInputs, distinct_views, median, scales_from_x, solve_mono, solve_rgbd, too_few_pairs,
    used_indices,
};
use super::views::{CalibView, validate_views};
use super::{ConsistencyRule, MIN_PAIRS, Mode, SelfCalError};
use crate::features::{GmsParams, MatchParams, OrbParams};
use crate::handeye::refine::pair_residual;
use crate::handeye::{
    HandEyeOptions, HandEyeSolution, Method, RelativeMotion, UncertaintySource, uncertainty,
};
use crate::relpose::{CameraModel, EssentialParams, RigidRansacParams};

/// Parameters of [`self_calibrate`]; every default is documented on its field.
#[derive(Debug, Clone, PartialEq)]
pub struct SelfCalParams {
    /// ORB (default: the paper's, 2000 features, 8 levels x1.2, FAST 20 -> 7, with ours'
    /// keypoint selection, [`SelfCalMethod::keypoint_distribution`]: retain-best).
    pub orb: OrbParams,
    /// Brute-force matching (default: nearest neighbours, no cross-check: GMS wants them all).
    pub matching: MatchParams,
    /// GMS (default: 20x20 grid, alpha 6, no rotation/scale patterns).
    pub gms: GmsParams,
    /// Refuse a view with fewer ORB keypoints than this (default 100).
    pub min_features: usize,
    /// A pair needs at least this many GMS matches (default 30).
    pub min_matches: usize,
    /// A pair needs at least this hand rotation, degrees (default 5).
    pub min_pair_rotation_deg: f64,
    /// 3D-3D RANSAC (default [`RigidRansacParams::default`]: 3 mm, depth-noise refinement;
    /// the noise model's focal length is set from the camera).
    pub rigid: RigidRansacParams,
    /// RGB-D: a pair needs at least this many matches with depth in both views (default 12).
    pub min_depth_points: usize,
    /// Essential-matrix RANSAC (default [`EssentialParams::default`]; its thresholds are
    /// replaced by `essential_threshold_px` converted with the focal length).
    pub essential: EssentialParams,
    /// Sampson inlier threshold, pixels (default 1.0).
    pub essential_threshold_px: f64,
    /// Which steps run ([`Steps`]; default [`Steps::ours`]; the paper's method is
    /// [`Steps::paper`], see [`SelfCalParams::for_method`]).
    pub steps: Steps,
    /// Mono, with [`Steps::angle_prior`]: the camera motion of a pair must rotate by the
    /// hand's angle within this many degrees, as a rigid mount makes it
    /// ([`crate::relpose::essential::RotationAnglePrior`]). Default 3 (the hand-eye solvers'
    /// own consistency limit).
    pub mono_angle_tolerance_deg: f64,
    /// Mono: take a pair's motion from its homography when one explains at least this
    /// fraction of the essential matrix's inliers
    /// ([`crate::relpose::EssentialParams::planar_support_ratio`]); default `None`: on the
    /// simulated cabinet views (a face with handles, 640x512) the homography path took more
    /// pairs but with larger residuals (X rotation error 0.29-0.76 deg with it at 0.8,
    /// 0.26-0.60 deg without, three trials), so only a truly planar scene should turn it on.
    pub mono_planar_support_ratio: Option<f64>,
    /// Hand-eye solver options (default `ours`, Huber; `scale_free` is set by the mode; the
    /// method becomes `kronecker` without [`Steps::pose_refinement`], and the angle-mismatch
    /// rejection is off without [`Steps::pair_rejection`]).
    pub handeye: HandEyeOptions,
    /// Stopping rules and world points of the eq. 15 refinement ([`Steps::final_refinement`]).
    pub eq15: Eq15Params,
    /// A pair is rejected when its residual exceeds this many times the median pair
    /// residual (default 3).
    pub max_pair_residual_factor: f64,
    /// ... but never below this rotation residual, degrees (default 1.0).
    pub min_pair_residual_limit_deg: f64,
    /// Seed of the per-pair RANSAC streams (default 0).
    pub seed: u64,
    /// When the final X is refused as inconsistent (default [`ConsistencyLimits::default`]).
    pub consistency: ConsistencyLimits,
    /// The hand poses' error that every view shares, added to X's covariance (default
    /// [`SharedHandError::AUBO_I10_NOMINAL`]).
    pub shared_hand_error: SharedHandError,
    /// The hand poses' error that varies from view to view, propagated into the monocular
    /// covariance (default [`ViewHandError::AUBO_I10_NOMINAL`]).
    pub view_hand_error: ViewHandError,
}

/// The consistency refusal of the final X (never a wrong X): [`self_calibrate`]
/// refuses with [`SelfCalError::Inconsistent`] when any rule fails, checked in this order:
///
/// 1. **Consensus**: the used pairs are at least `min_kept_fraction` of the pairs that gave
///    a camera motion. When most motions are rejected (angle mismatch, non-positive scale,
///    residual), the survivors' agreement is a minority's, not evidence for X.
/// 2. **Redundancy**: the residuals have at least `min_dof` degrees of freedom
///    (`6 P - 6` in RGB-D, `5 P - 6` in mono where each pair's scale absorbs one
///    translation component). With fewer the residuals and the uncertainty below are not
///    themselves measured: an X fitted to 2 monocular pairs (4 dof) always looks
///    consistent.
/// 3. **Residual**: the median AX=XB rotation residual over the used pairs is at most
///    `max_residual_rot_deg`. It is scale-free, so it is the same test in both modes; a rigid
///    mount leaves only the relative-pose and hand-pose noise (RGB-D ~0.03 deg, mono
///    ~0.5-0.7 deg on the simulator's calib-18 views, 640x512).
/// 4. **Uncertainty**: the 1-sigma uncertainty of X (Gauss-Newton covariance at the
///    optimum, reduced chi-square of its own residuals, pairs of `n` views counted as
///    `n - 1` independent motions, mono scales marginalised) is at most `max_sigma_rot_deg`
///    and `max_sigma_trans_mm`.
///
/// The failure that motivated it (noise experiment, image noise sigma 0.20, mono): 2 of 4
/// pairs with a motion kept, 4 dof, median rotation residual 3.4 deg, 1-sigma 117 deg /
/// 71 mm, and an X 118 deg / 478 mm from the truth. Clean mono runs of the same trials:
/// 84-104 of 153 pairs, residual 0.53-0.73 deg.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConsistencyLimits {
    /// Rule 1: smallest fraction of the pairs with a camera motion that must be used
    /// (default 0.5).
    pub min_kept_fraction: f64,
    /// Rule 2: fewest residual degrees of freedom (default 8: 3 RGB-D pairs give 12, 3 mono
    /// pairs 9, 2 pairs of either too few).
    pub min_dof: usize,
    /// Rule 2, mono: fewest used pairs (default 10). The epipolar refinement's uncertainty
    /// (Gauss-Newton covariance with the keypoint-reuse inflation, [`super::epipolar`]) is
    /// only trustworthy with many pairs: in `experiment noise` at sigma 0.15 (50 trials) the
    /// only two mono results accepted without this rule used 4 and 8 pairs and were
    /// 19 deg / 136 mm and 1.1 deg / 7.7 mm off while claiming 1-sigma 0.94 and 0.32 deg;
    /// the accepted mono results at sigma 0.05 use ~100 pairs.
    pub min_mono_pairs: usize,
    /// Rule 3: largest median AX=XB rotation residual over the used pairs, degrees (default
    /// 2.0: 3x the worst clean mono median above).
    pub max_residual_rot_deg: f64,
    /// Rule 4: largest 1-sigma rotation uncertainty of X, degrees (default 1.0: beyond it X
    /// moves a point at the 0.5 m working distance by more than 9 mm, most of the hook's
    /// +-15 mm capture window).
    pub max_sigma_rot_deg: f64,
    /// Rule 4: largest 1-sigma translation uncertainty of X, millimetres (default 10).
    pub max_sigma_trans_mm: f64,
}

impl Default for ConsistencyLimits {
    fn default() -> Self {
        Self {
            min_kept_fraction: 0.5,
            min_dof: 8,
            min_mono_pairs: 10,
            max_residual_rot_deg: 2.0,
            max_sigma_rot_deg: 1.0,
            max_sigma_trans_mm: 10.0,
        }
    }
}

impl Default for SelfCalParams {
    fn default() -> Self {
        Self {
            orb: OrbParams {
                distribution: SelfCalMethod::Ours.keypoint_distribution(),
                ..OrbParams::default()
            },
            matching: MatchParams::default(),
            gms: GmsParams::default(),
            min_features: 100,
            min_matches: 30,
            min_pair_rotation_deg: 5.0,
            rigid: RigidRansacParams::default(),
            min_depth_points: 12,
            essential: EssentialParams::default(),
            essential_threshold_px: 1.0,
            steps: Steps::ours(),
            mono_angle_tolerance_deg: 3.0,
            mono_planar_support_ratio: None,
            handeye: HandEyeOptions::default(),
            eq15: Eq15Params::default(),
            max_pair_residual_factor: 3.0,
            min_pair_residual_limit_deg: 1.0,
            seed: 0,
            consistency: ConsistencyLimits::default(),
            shared_hand_error: SharedHandError::AUBO_I10_NOMINAL,
            view_hand_error: ViewHandError::AUBO_I10_NOMINAL,
        }
    }
}

/// Reference image area of the paper's defaults: the wrist camera, 1280 x 1024 pixels.
pub const REFERENCE_AREA_PX: f64 = 1280.0 * 1024.0;
/// Upper bound of the area-scaled feature count of [`SelfCalParams::for_camera`].
pub const MAX_SCALED_FEATURES: usize = 8000;
/// From this many features on, [`SelfCalParams::for_camera`] turns on GMS's rotation and
/// scale patterns (their 40 evaluations then cost little next to the brute-force matching).
pub const GMS_PATTERNS_FROM_FEATURES: usize = 4000;

impl SelfCalParams {
    /// Defaults adapted to the image size: the paper's 2000 features are for the 1280x1024
    /// wrist camera; larger images get `2000 * area / (1280 * 1024)` features (keypoint
    /// density kept, at most [`MAX_SCALED_FEATURES`]), and from
    /// [`GMS_PATTERNS_FROM_FEATURES`] on GMS also tries the rotated and scaled neighbourhood
    /// patterns (large viewpoint changes of hand-held style datasets such as shecar:
    /// 3264x1836 -> 8000 features; the median rotation residual there drops from 1.2 deg with
    /// 2000 features to 0.54 deg). Images up to 1280x1024 get [`SelfCalParams::default`].
    pub fn for_camera(camera: &CameraModel) -> Self {
        Self::for_method(camera, SelfCalMethod::Ours)
    }

    /// [`SelfCalParams::for_camera`] with the steps and the keypoint selection of `method`.
    pub fn for_method(camera: &CameraModel, method: SelfCalMethod) -> Self {
        let mut p = Self::default();
        let area = f64::from(camera.width) * f64::from(camera.height);
        let scaled = (p.orb.n_features as f64 * area / REFERENCE_AREA_PX).round() as usize;
        p.orb.n_features = scaled.clamp(p.orb.n_features, MAX_SCALED_FEATURES);
        if p.orb.n_features >= GMS_PATTERNS_FROM_FEATURES {
            p.gms.with_rotation = true;
            p.gms.with_scale = true;
        }
        p.steps = method.steps();
        p.orb.distribution = method.keypoint_distribution();
        p
    }
}

/// What happened to one candidate pair.
#[derive(Debug, Clone, PartialEq)]
pub struct PairReport {
    /// First view.
    pub i: usize,
    /// Second view.
    pub j: usize,
    /// Hand rotation of `B_ij`, degrees.
    pub hand_rotation_deg: f64,
    /// Brute-force matches.
    pub raw_matches: usize,
    /// GMS matches.
    pub matches: usize,
    /// RANSAC inliers of the motion (0 without one).
    pub inliers: usize,
    /// `A_ij = cam_i_from_cam_j` when estimated (mono: `|t| = 1`).
    pub cam_i_from_cam_j: Option<Isometry3<f64>>,
    /// Metres per eye unit of this pair (1 in RGB-D; the per-pair scale in mono).
    pub scale: f64,
    /// Rotation residual of `B X = X A` at the final X, degrees (NaN without a motion).
    pub residual_rot_deg: f64,
    /// Translation residual at the final X (eye translation times `scale` and the global
    /// scale), millimetres (NaN without a motion).
    pub residual_trans_mm: f64,
    /// RGB-D: RMS eq. 15 point residual at the final X, millimetres (NaN otherwise).
    pub eq15_rms_mm: f64,
    /// Why the pair was not used (`None` = used).
    pub rejected: Option<PairRejection>,
}

/// Result of [`self_calibrate`].
#[derive(Debug, Clone, PartialEq)]
pub struct SelfCalResult {
    /// `X = tool0_from_camera` with its figures (residual medians over the used pairs).
    pub solution: HandEyeSolution,
    /// RGB-D or mono.
    pub mode: Mode,
    /// ORB keypoints per view.
    pub features_per_view: Vec<usize>,
    /// Every pair `i < j` with what happened to it.
    pub pairs: Vec<PairReport>,
    /// GMS matches of the candidate pairs, for the viewer.
    pub matches: Vec<PairMatches>,
    /// X of the linear (Kronecker) initialisation.
    pub linear_tool0_from_camera: Isometry3<f64>,
    /// The steps that ran.
    pub steps: Steps,
    /// RGB-D: the final eq. 15 refinement or bundle adjustment ([`Steps::final_refinement`]).
    pub eq15: Option<Eq15Report>,
}

impl SelfCalResult {
    /// Number of pairs used.
    pub fn used_pairs(&self) -> usize {
        self.pairs.iter().filter(|p| p.rejected.is_none()).count()
    }
}

fn centroid(points: &[(Point3<f64>, Point3<f64>)]) -> Vector3<f64> {
    let n = points.len().max(1) as f64;
    points.iter().map(|(p, _)| p.coords).sum::<Vector3<f64>>() / n
}

/// Steps 1-3 of the pipeline (module docs of [`super`]) on `views`: their mode, features,
/// candidate pairs, matches and relative camera motions. Shared by [`self_calibrate`] and
/// the drift check.
#[derive(Debug, Clone)]
pub struct PairMotions {
    /// RGB-D or mono (from the views).
    pub mode: Mode,
    /// ORB keypoints per view.
    pub features_per_view: Vec<usize>,
    /// RGB-D: per view, per keypoint, whether its depth may be used
    /// ([`super::motion::keypoint_depth_support`]; all with [`super::Steps::depth_support`]
    /// off); empty lists in mono.
    pub depth_support: Vec<Vec<bool>>,
    /// GMS matches of the candidate pairs (hand rotation at least
    /// [`SelfCalParams::min_pair_rotation_deg`]), in `(i, j)` order; `motion_inliers` not yet
    /// filled in.
    pub matches: Vec<PairMatches>,
    /// The camera motion of each candidate (index = `matches`'), or why there is none.
    pub estimates: Vec<Result<PairMotion, PairRejection>>,
    /// The pairs refused for a small hand rotation, with their reason.
    pub small: Vec<Refused>,
}

/// Features, candidate pairs, matches and camera motions of `views` ([`PairMotions`]).
///
/// # Errors
/// [`SelfCalError::TooFewViews`], [`SelfCalError::ImageSize`], [`SelfCalError::DepthSize`],
/// [`SelfCalError::MixedDepth`], [`SelfCalError::NonFinitePose`],
/// [`SelfCalError::TooFewFeatures`], [`SelfCalError::Features`].
pub fn pair_motions(
    views: &[CalibView],
    camera: &CameraModel,
    params: &SelfCalParams,
) -> Result<PairMotions, SelfCalError> {
    let mode = validate_views(views, camera)?;
    let features = extract_features(views, params)?;
    let depth_support: Vec<Vec<bool>> = match mode {
        Mode::Rgbd if params.steps.depth_support => views
            .par_iter()
            .zip(&features)
            .map(|(v, f)| keypoint_depth_support(v, f, &params.orb))
            .collect(),
        Mode::Rgbd => features
            .iter()
            .map(|f| vec![true; f.keypoints.len()])
            .collect(),
        Mode::Mono => vec![Vec::new(); views.len()],
    };
    let size = (camera.width as usize, camera.height as usize);
    let (cands, small) = candidate_pairs(views, params.min_pair_rotation_deg);
    let matches: Vec<PairMatches> = cands
        .par_iter()
        .map(|&c| match_pair(&features, size, c, params))
        .collect();
    let estimates: Vec<Result<PairMotion, PairRejection>> = matches
        .par_iter()
        .map(|m| {
            if m.coords.len() < params.min_matches {
                return Err(PairRejection::TooFewMatches {
                    matches: m.coords.len(),
                    need: params.min_matches,
                });
            }
            let seed = pair_seed(params.seed, m.i, m.j);
            match mode {
                Mode::Rgbd => match (views.get(m.i), views.get(m.j)) {
                    (Some(vi), Some(vj)) => {
                        let support =
                            |k: usize| depth_support.get(k).map_or(&[][..], Vec::as_slice);
                        rgbd_motion(
                            vi,
                            vj,
                            camera,
                            m,
                            params,
                            seed,
                            [support(m.i), support(m.j)],
                        )
                    }
                    _ => Err(PairRejection::TooFewMatches {
                        matches: 0,
                        need: params.min_matches,
                    }),
                },
                Mode::Mono => mono_motion(camera, m, params, seed, None),
            }
        })
        .collect();
    Ok(PairMotions {
        mode,
        features_per_view: features.iter().map(|f| f.keypoints.len()).collect(),
        depth_support,
        matches,
        estimates,
        small,
    })
}

/// The hand-eye motion `B_ij X = X A_ij` of a pair with an estimated camera motion: `B_ij`
/// from the views' hand poses, `A_ij` from `motion`, and in RGB-D the eye lever arm at the
/// centroid of its inlier points (their error is mostly a rotation about the camera, see
/// [`crate::handeye::refine`]). `None` when a view index is out of range.
pub fn relative_motion(
    views: &[CalibView],
    mode: Mode,
    i: usize,
    j: usize,
    motion: &PairMotion,
) -> Option<RelativeMotion> {
    let mut rm = RelativeMotion::new(motion.cam_i_from_cam_j, hand_motion(views, i, j)?);
    if mode == Mode::Rgbd {
        rm.eye_lever_m = centroid(&motion.points);
    }
    Some(rm)
}

/// Hand-eye self-calibration of `views` (module docs of [`super`]): `X = tool0_from_camera`.
///
/// # Errors
/// [`SelfCalError::TooFewViews`], [`SelfCalError::ImageSize`], [`SelfCalError::DepthSize`],
/// [`SelfCalError::MixedDepth`], [`SelfCalError::NonFinitePose`],
/// [`SelfCalError::TooFewFeatures`] (dark/textureless view, with its numbers),
/// [`SelfCalError::TooFewPairs`] (with the count of each rejection reason),
/// [`SelfCalError::HandEye`] (degenerate motion: single rotation axis, pure translation,
/// inconsistent motions, ...), [`SelfCalError::Features`].
pub fn self_calibrate(
    views: &[CalibView],
    camera: &CameraModel,
    params: &SelfCalParams,
) -> Result<SelfCalResult, SelfCalError> {
    let mode = validate_views(views, camera)?;
    if mode == Mode::Mono && params.steps.final_refinement != FinalRefinement::None {
        return Err(SelfCalError::MethodNeedsDepth {
            refinement: params.steps.final_refinement.name(),
        });
    }
    let check = if params.steps.consistency {
        Check::Consistency
    } else {
        Check::None
    };
    let motions = pair_motions(views, camera, params)?;
    match motions.mode {
        Mode::Rgbd => solve_pair_motions(views, camera, params, motions, check),
        Mode::Mono if !params.steps.guided_round => {
            solve_pair_motions(views, camera, params, motions, check)
        }
        Mode::Mono => {
            // Round 1 (blind essential matrices) gives X_1; round 2 re-estimates every pair
            // from the motion X_1^-1 B X_1 predicts (module docs of [`super`]) and is the one
            // that must pass the consistency refusal.
            let first =
                solve_pair_motions(views, camera, params, motions.clone(), Check::FirstRound)?;
            let guided = guided_mono_motions(views, camera, params, motions, &first.solution);
            solve_pair_motions(views, camera, params, guided, check)
        }
    }
}

/// The epipolar refinement's input, built once for the estimate and its uncertainty: per used
/// pair, its views `(i, j)`, its hand motion and its motion-inlier keypoints, undistorted and
/// normalised.
struct EpipolarSet {
    views: Vec<(usize, usize)>,
    pairs: Vec<EpipolarPair>,
}

fn epipolar_pairs(
    camera: &CameraModel,
    matches: &[PairMatches],
    reports: &[PairReport],
    motions: &[RelativeMotion],
) -> EpipolarSet {
    let (views, pairs) = used_indices(reports)
        .iter()
        .filter_map(|&k| {
            let (m, rm, r) = (matches.get(k)?, motions.get(k)?, reports.get(k)?);
            let (mut x_i, mut x_j) = (Vec::new(), Vec::new());
            for (c, _) in m.coords.iter().zip(&m.motion_inliers).filter(|(_, f)| **f) {
                let a = camera.undistort_pixel(&Point2::new(f64::from(c[0]), f64::from(c[1])));
                let b = camera.undistort_pixel(&Point2::new(f64::from(c[2]), f64::from(c[3])));
                if let (Ok(a), Ok(b)) = (a, b) {
                    x_i.push(a);
                    x_j.push(b);
                }
            }
            Some((
                (r.i, r.j),
                EpipolarPair {
                    hand: rm.b,
                    x_i: x_i.into(),
                    x_j: x_j.into(),
                },
            ))
        })
        .unzip();
    EpipolarSet { views, pairs }
}

/// The epipolar refinement's parameters for `camera`: the Huber scale is the essential
/// matrix threshold in normalised units.
fn epipolar_params(camera: &CameraModel, params: &SelfCalParams) -> EpipolarParams {
    EpipolarParams {
        huber: params.essential_threshold_px / (0.5 * (camera.fx + camera.fy)),
        ..EpipolarParams::default()
    }
}

/// The final round's covariance over views: the `jackknife`, and in mono what no resampling
/// of the views shows, the view-to-view hand error propagated through the epipolar
/// refinement (`view_hand`, [`hand_error_covariance`]) or, where that is not modelled, the
/// `disagreement` `d` of the pose solve's X from the epipolar X (rotation vector).
///
/// The two estimates answer the same question from the same views; where their rotations
/// disagree by `d`, at least one is off by `|d| / 2`, which no resampling shows (on calib-18
/// in mono they differ by 0.29 deg and the epipolar X's rotation is 0.37 deg off, its
/// jackknife 0.28 deg), so `Sigma_theta += d d^T`, along its own direction only. Not the
/// translation: there the pose solve is the weak one (its per-pair scales absorb the
/// translation; on calib-18 it sits 6.5 mm from the epipolar X, which is 1.1 mm off with a
/// jackknife of 1.2 mm). The disagreement is the hand error's trace, so with the hand error
/// propagated it would count it twice. Over 100 rendered noise trials at sigma 0.05-0.15
/// (`rodlog experiment noise`'s), with both the mono rotation held its 95 % ellipsoid in
/// 98.9 % of 279 answers, mean squared distance 1.84 against chi-square(3)'s 3, and 21 were
/// refused on their sigma; with the propagation alone all 300 answer, 95.0 % held, mean 2.78.
fn over_views_covariance(
    jackknife: Matrix6<f64>,
    view_hand: Option<Matrix6<f64>>,
    disagreement: Option<Vector3<f64>>,
) -> Matrix6<f64> {
    let mut cov = jackknife;
    match (view_hand, disagreement) {
        (Some(hand), _) => cov += hand,
        (None, Some(d)) => {
            let mut rot = cov.fixed_view_mut::<3, 3>(0, 0);
            rot += d * d.transpose();
        }
        (None, None) => {}
    }
    cov
}

/// The covariance of the epipolar X over views ([`uncertainty::jackknife_over_views`]): each
/// view of the used pairs left out in turn, the epipolar refinement runs again from the final
/// X on the other pairs' inliers. The replicates are the same estimator as the X they judge
/// (a pose-solve jackknife would judge the pose solve, whose mono translation is far weaker).
fn jackknife_epipolar(
    set: &EpipolarSet,
    ep: &EpipolarParams,
    x: &Isometry3<f64>,
) -> Option<nalgebra::Matrix6<f64>> {
    let views = distinct_views(set.views.iter().copied());
    uncertainty::jackknife_over_views(views.len(), x, |k| {
        let left_out = *views.get(k)?;
        let subset: Vec<EpipolarPair> = set
            .views
            .iter()
            .zip(&set.pairs)
            .filter(|((i, j), _)| *i != left_out && *j != left_out)
            .map(|(_, e)| e.clone())
            .collect();
        refine_epipolar(&subset, x, ep).map(|r| r.tool0_from_camera)
    })
}

/// The covariance the view-to-view hand error makes in the epipolar X
/// ([`hand_error_covariance`] over the used pairs' inliers, seeded by the RANSAC seed);
/// `None` when a replicate's refinement fails.
fn epipolar_hand_error(
    set: &EpipolarSet,
    ep: &EpipolarParams,
    params: &SelfCalParams,
    x: &Isometry3<f64>,
) -> Option<Matrix6<f64>> {
    let e = params.view_hand_error;
    hand_error_covariance(
        &set.pairs,
        &set.views,
        x,
        ep,
        e.rot_deg.to_radians(),
        e.trans_mm * 1e-3,
        params.seed,
    )
}

/// Mono: X refined on all used pairs' epipolar constraints ([`super::epipolar`]); the
/// motions' per-pair scales and the solution's residual medians then follow the new X.
/// Its 1-sigma replaces the pair-scatter uncertainty. `false` (X left as it was) when the
/// refinement cannot run.
fn refine_mono_epipolar(
    set: &EpipolarSet,
    ep: &EpipolarParams,
    reports: &[PairReport],
    motions: &mut [RelativeMotion],
    solution: &mut HandEyeSolution,
) -> bool {
    let used = used_indices(reports);
    let Some(rep) = refine_epipolar(&set.pairs, &solution.tool0_from_camera, ep) else {
        return false;
    };
    let x = rep.tool0_from_camera;
    solution.tool0_from_camera = x;
    let current: Vec<_> = motions.iter().map(|m| (m.a, m.b, m.weight)).collect();
    for (m, s) in motions.iter_mut().zip(scales_from_x(&current, &x)) {
        if s > 0.0 {
            m.a =
                Isometry3::from_parts(Translation3::from(m.a.translation.vector * s), m.a.rotation);
        }
    }
    let (rot, trans): (Vec<f64>, Vec<f64>) = used
        .iter()
        .filter_map(|&k| motions.get(k))
        .map(|m| {
            let (r, t) = pair_residual(m, &x, 1.0);
            (r.norm().to_degrees(), t.norm() * 1e3)
        })
        .unzip();
    solution.residual_rot_deg = median(rot);
    solution.residual_trans_mm = median(trans);
    // Each view's keypoints recur in about (pairs / independent motions) pairs, so the
    // residuals are not independent: the covariance's variance is inflated by that factor.
    let reuse = (used.len() as f64 / independent_motions(reports).max(1) as f64).max(1.0);
    solution.sigma_rot_deg = rep.sigma_rot_deg * reuse.sqrt();
    solution.sigma_trans_mm = rep.sigma_trans_mm * reuse.sqrt();
    // The pose solve's covariance described the pose solve's X, not this one.
    solution.covariance = None;
    solution.uncertainty = UncertaintySource::Linearised;
    true
}

/// Whether [`solve_pair_motions`] applies the consistency refusal.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Check {
    /// A first round whose X only guides the second: no refusal, no uncertainty over views.
    FirstRound,
    /// The final round without the consistency refusal.
    None,
    /// The final round ([`ConsistencyLimits`]).
    Consistency,
}

/// Mono round 2: every candidate pair with enough matches re-estimated by
/// [`mono_motion`] from the motion `A = X^-1 B X` that `first` predicts; where that fails,
/// the round-1 estimate is kept.
fn guided_mono_motions(
    views: &[CalibView],
    camera: &CameraModel,
    params: &SelfCalParams,
    mut motions: PairMotions,
    first: &HandEyeSolution,
) -> PairMotions {
    let x = first.tool0_from_camera;
    motions.estimates = motions
        .matches
        .par_iter()
        .zip(&motions.estimates)
        .map(|(m, old)| {
            if m.coords.len() < params.min_matches {
                return old.clone();
            }
            let Some(b) = hand_motion(views, m.i, m.j) else {
                return old.clone();
            };
            let guess = x.inverse() * b * x;
            let seed = pair_seed(params.seed, m.i, m.j);
            // A first X far off (few pairs) can mislead the guided inlier selection: the
            // blind estimate then stands.
            match mono_motion(camera, m, params, seed, Some(&guess)) {
                Ok(guided) => Ok(guided),
                Err(e) => old.clone().map_err(|_| e),
            }
        })
        .collect();
    motions
}

/// The hand-eye solution from the pair motions (the body of [`self_calibrate`]).
fn solve_pair_motions(
    views: &[CalibView],
    camera: &CameraModel,
    params: &SelfCalParams,
    motions: PairMotions,
    check: Check,
) -> Result<SelfCalResult, SelfCalError> {
    let PairMotions {
        mode,
        features_per_view,
        depth_support,
        mut matches,
        estimates,
        small,
    } = motions;
    for (m, est) in matches.iter_mut().zip(&estimates) {
        if let Ok(pm) = est {
            m.motion_inliers.clone_from(&pm.match_inliers);
        }
    }

    // Reports: candidates first (index k = motion k), then the small-rotation pairs.
    let nan = f64::NAN;
    let mut reports: Vec<PairReport> = Vec::with_capacity(matches.len() + small.len());
    let mut motions: Vec<RelativeMotion> = Vec::with_capacity(matches.len());
    let mut points: Vec<Vec<(Point3<f64>, Point3<f64>)>> = Vec::with_capacity(matches.len());
    for (m, est) in matches.iter().zip(&estimates) {
        let (a, inliers, pts, rejected) = match est {
            Ok(pm) => (
                Some(pm.cam_i_from_cam_j),
                pm.inliers,
                pm.points.clone(),
                None,
            ),
            Err(e) => (None, 0, Vec::new(), Some(e.clone())),
        };
        // A pair without a camera motion keeps a placeholder (never used: it is rejected).
        let rm = est
            .as_ref()
            .ok()
            .and_then(|pm| relative_motion(views, mode, m.i, m.j, pm))
            .unwrap_or_else(|| {
                let b = hand_motion(views, m.i, m.j).unwrap_or_else(Isometry3::identity);
                RelativeMotion::new(Isometry3::identity(), b)
            });
        motions.push(rm);
        points.push(pts);
        reports.push(PairReport {
            i: m.i,
            j: m.j,
            hand_rotation_deg: m.hand_rotation_deg,
            raw_matches: m.raw_matches,
            matches: m.coords.len(),
            inliers,
            cam_i_from_cam_j: a,
            scale: 1.0,
            residual_rot_deg: nan,
            residual_trans_mm: nan,
            eq15_rms_mm: nan,
            rejected,
        });
    }
    let n_motion = reports.len();
    for (i, j, why) in small {
        let deg = match &why {
            PairRejection::SmallRotation {
                hand_rotation_deg, ..
            } => *hand_rotation_deg,
            _ => nan,
        };
        reports.push(PairReport {
            i,
            j,
            hand_rotation_deg: deg,
            raw_matches: 0,
            matches: 0,
            inliers: 0,
            cam_i_from_cam_j: None,
            scale: 1.0,
            residual_rot_deg: nan,
            residual_trans_mm: nan,
            eq15_rms_mm: nan,
            rejected: Some(why),
        });
    }
    if used_indices(&reports).len() < MIN_PAIRS {
        return Err(too_few_pairs(&reports));
    }

    let opts = handeye_options(params);
    let mut before_epipolar = None;
    // Mono with the epipolar refinement: its pairs, for its uncertainty too.
    let mut epipolar_set = None;
    let ep = epipolar_params(camera, params);
    let (mut solution, linear, eq15) = match mode {
        Mode::Rgbd => {
            let inputs = TrackInputs {
                views,
                camera,
                matches: &matches,
                keypoints_per_view: &features_per_view,
                depth_support: &depth_support,
            };
            solve_rgbd(&mut reports, &motions, &inputs, &opts, params)?
        }
        Mode::Mono => {
            let (mut sol, linear, eq15) = solve_mono(&mut reports, &mut motions, &opts, params)?;
            let pose_x = sol.tool0_from_camera;
            if params.steps.epipolar_refinement {
                let set = epipolar_pairs(camera, &matches, &reports, &motions);
                if refine_mono_epipolar(&set, &ep, &reports, &mut motions, &mut sol) {
                    epipolar_set = Some(set);
                    before_epipolar = Some(pose_x);
                }
            }
            (sol, linear, eq15)
        }
    };

    solution.views = views.len();
    if epipolar_set.is_none() {
        // (The epipolar refinement sets the uncertainty of its own estimate.)
        reestimate_uncertainty(&reports, &motions, mode, &opts, &mut solution);
    }
    // Over views, when there are enough: the spread a view's own error makes
    // (`uncertainty::jackknife_over_views`), in place of either linearised figure.
    let final_round = check != Check::FirstRound;
    let x = solution.tool0_from_camera;
    let jackknife = || match &epipolar_set {
        Some(set) => jackknife_epipolar(set, &ep, &x),
        None => jackknife_over_views(&reports, &motions, mode, &opts, &solution),
    };
    // Mono: the hand error from view to view, which the epipolar X follows and no resampling
    // of the views shows (`epipolar::hand_error_covariance`). Its replicates refine the same
    // pairs the estimate was refined on, so it fails only where that refinement would.
    let view_hand = epipolar_set
        .as_ref()
        .filter(|_| final_round)
        .and_then(|set| epipolar_hand_error(set, &ep, params, &x));
    if let Some(jackknife) = final_round.then(jackknife).flatten() {
        let modelled = view_hand.filter(|_| params.view_hand_error != ViewHandError::NONE);
        let disagreement =
            before_epipolar.map(|pose_x| (pose_x.rotation * x.rotation.inverse()).scaled_axis());
        let cov = over_views_covariance(jackknife, modelled, disagreement);
        solution.set_covariance(cov, UncertaintySource::Jackknife);
    } else if let Some(hand) = view_hand {
        // Too few views for the jackknife: the hand error joins the epipolar sigmas.
        let (r, t) = uncertainty::sigma_of(&hand);
        solution.sigma_rot_deg = solution.sigma_rot_deg.hypot(r);
        solution.sigma_trans_mm = solution.sigma_trans_mm.hypot(t);
    }
    // The hand error every view shares, which neither figure can show.
    let shared = params.shared_hand_error.covariance();
    match solution.covariance {
        Some(cov) => solution.set_covariance(cov + shared, solution.uncertainty),
        None => {
            let (r, t) = uncertainty::sigma_of(&shared);
            solution.sigma_rot_deg = solution.sigma_rot_deg.hypot(r);
            solution.sigma_trans_mm = solution.sigma_trans_mm.hypot(t);
        }
    }
    if check == Check::Consistency {
        check_consistency(&reports, &solution, mode, &params.consistency)?;
    }
    // Final per-pair residuals (metric eye translations).
    let x = solution.tool0_from_camera;
    for (k, rep) in reports.iter_mut().enumerate().take(n_motion) {
        if rep.cam_i_from_cam_j.is_none() {
            continue;
        }
        let Some(m) = motions.get(k) else { continue };
        // Mono motions already carry their metric per-pair scales (see `solve_mono`).
        let eye_scale = if mode == Mode::Mono {
            1.0
        } else {
            solution.scale
        };
        let (r, t) = pair_residual(m, &x, eye_scale);
        rep.residual_rot_deg = r.norm().to_degrees();
        rep.residual_trans_mm = t.norm() * 1e3;
        if let Some(pts) = points.get(k).filter(|p| !p.is_empty()) {
            let m_ij = x.inverse() * m.b * x;
            let s: f64 = pts
                .iter()
                .map(|(pi, pj)| (pi - m_ij * pj).norm_squared())
                .sum();
            rep.eq15_rms_mm = (s / pts.len() as f64).sqrt() * 1e3;
        }
    }
    reports.sort_by_key(|r| (r.i, r.j));
    Ok(SelfCalResult {
        solution,
        mode,
        features_per_view,
        pairs: reports,
        matches,
        linear_tool0_from_camera: linear,
        steps: params.steps,
        eq15,
    })
}

/// The hand-eye options of `params` under its steps: `scale_free` off (mono motions carry
/// metric per-pair scales, module docs of [`super`]), the Kronecker/SVD solve without
/// [`Steps::pose_refinement`], no angle-mismatch rejection without [`Steps::pair_rejection`].
fn handeye_options(params: &SelfCalParams) -> HandEyeOptions {
    let mut opts = params.handeye.clone();
    opts.scale_free = false;
    if !params.steps.pose_refinement {
        opts.method = Method::Kronecker;
    }
    if !params.steps.pair_rejection {
        opts.max_angle_mismatch_deg = f64::INFINITY;
    }
    opts
}

/// Views that appear in the used pairs, minus one: the number of independent motions the
/// `P` used pairs are built from ([`uncertainty`]'s `M`).
fn independent_motions(reports: &[PairReport]) -> usize {
    distinct_views(
        reports
            .iter()
            .filter(|r| r.rejected.is_none())
            .map(|r| (r.i, r.j)),
    )
    .len()
    .saturating_sub(1)
}

/// The 1-sigma uncertainty of the final X over the used pairs, with the two corrections the
/// generic [`crate::handeye::solve_motions`] figure lacks here: the `P` pairs of `n` views
/// carry only `M = n - 1` independent motions (covariance inflated by `P / M`), and in mono
/// the per-pair scales are free parameters, marginalised
/// ([`uncertainty::evaluate_per_motion_scale`]) instead of held fixed.
fn reestimate_uncertainty(
    reports: &[PairReport],
    motions: &[RelativeMotion],
    mode: Mode,
    opts: &HandEyeOptions,
    solution: &mut HandEyeSolution,
) {
    let sel: Vec<RelativeMotion> = used_indices(reports)
        .iter()
        .filter_map(|&k| motions.get(k).copied())
        .collect();
    let m = independent_motions(reports);
    let x = &solution.tool0_from_camera;
    let stats = match mode {
        Mode::Rgbd => uncertainty::evaluate(&sel, x, solution.scale, opts, m),
        Mode::Mono => uncertainty::evaluate_per_motion_scale(&sel, x, opts, m),
    };
    solution.sigma_rot_deg = stats.sigma_rot_deg;
    solution.sigma_trans_mm = stats.sigma_trans_mm;
}

/// The covariance of the final X over views ([`uncertainty::jackknife_over_views`]): each
/// view of the used pairs left out in turn, X is refined again from the final one on the
/// other pairs by the pose Levenberg-Marquardt ([`crate::handeye::refine::refine`]); in mono
/// each pair's scale is fitted again to the replicate's X first (as [`solve_mono`]
/// alternates them), since the scales are estimated with X. The pairs' motions are reused:
/// no image is matched again.
fn jackknife_over_views(
    reports: &[PairReport],
    motions: &[RelativeMotion],
    mode: Mode,
    opts: &HandEyeOptions,
    solution: &HandEyeSolution,
) -> Option<nalgebra::Matrix6<f64>> {
    let used = used_indices(reports);
    let views = distinct_views(
        used.iter()
            .filter_map(|&k| reports.get(k))
            .map(|r| (r.i, r.j)),
    );
    let x = solution.tool0_from_camera;
    uncertainty::jackknife_over_views(views.len(), &x, |k| {
        let left_out = *views.get(k)?;
        let mut subset: Vec<RelativeMotion> = used
            .iter()
            .filter(|&&p| {
                reports
                    .get(p)
                    .is_some_and(|r| r.i != left_out && r.j != left_out)
            })
            .filter_map(|&p| motions.get(p).copied())
            .collect();
        let mut xk = x;
        let rounds = if mode == Mode::Mono { 2 } else { 1 };
        for _ in 0..rounds {
            if mode == Mode::Mono {
                let unit: Vec<_> = subset
                    .iter()
                    .map(|m| {
                        let t = m.a.translation.vector;
                        let n = t.norm();
                        let a = Isometry3::from_parts(
                            Translation3::from(if n > 0.0 { t / n } else { t }),
                            m.a.rotation,
                        );
                        (a, m.b, m.weight)
                    })
                    .collect();
                for (m, (s, u)) in subset
                    .iter_mut()
                    .zip(scales_from_x(&unit, &xk).into_iter().zip(&unit))
                {
                    m.a = Isometry3::from_parts(
                        Translation3::from(u.0.translation.vector * s.max(0.0)),
                        m.a.rotation,
                    );
                }
            }
            xk = crate::handeye::refine::refine(&subset, &xk, solution.scale, opts)
                .ok()?
                .tool0_from_camera;
        }
        Some(xk)
    })
}

/// `value <= limit`, false for NaN (an undetermined figure never passes).
fn within(value: f64, limit: f64) -> bool {
    value <= limit
}

/// The consistency refusal ([`ConsistencyLimits`]): the final X must be supported by most of
/// the pairs that gave a camera motion, with enough redundancy to judge it, small residuals
/// and a small uncertainty; otherwise [`SelfCalError::Inconsistent`] with every figure.
fn check_consistency(
    reports: &[PairReport],
    solution: &HandEyeSolution,
    mode: Mode,
    limits: &ConsistencyLimits,
) -> Result<(), SelfCalError> {
    let with_motion = reports
        .iter()
        .filter(|r| r.cam_i_from_cam_j.is_some())
        .count();
    let used = reports.iter().filter(|r| r.rejected.is_none()).count();
    // Residual components per pair (3 rotation + 3 translation, 2 in mono where the scale
    // absorbs one) minus the 6 parameters of X.
    let per_pair = match mode {
        Mode::Rgbd => 6,
        Mode::Mono => 5,
    };
    let dof = (per_pair * used).saturating_sub(6);
    let s = solution;
    let kept_fraction = used as f64 / with_motion.max(1) as f64;
    let failed = if kept_fraction < limits.min_kept_fraction {
        Some(ConsistencyRule::Consensus)
    } else if dof < limits.min_dof || (mode == Mode::Mono && used < limits.min_mono_pairs) {
        Some(ConsistencyRule::Redundancy)
    } else if !within(s.residual_rot_deg, limits.max_residual_rot_deg) {
        Some(ConsistencyRule::Residual)
    } else if !(within(s.sigma_rot_deg, limits.max_sigma_rot_deg)
        && within(s.sigma_trans_mm, limits.max_sigma_trans_mm))
    {
        Some(ConsistencyRule::Uncertainty)
    } else {
        None
    };
    match failed {
        None => Ok(()),
        Some(rule) => Err(SelfCalError::Inconsistent {
            mode,
            rule,
            pairs_used: used,
            pairs_with_motion: with_motion,
            dof,
            residual_rot_deg: s.residual_rot_deg,
            residual_trans_mm: s.residual_trans_mm,
            sigma_rot_deg: s.sigma_rot_deg,
            sigma_trans_mm: s.sigma_trans_mm,
            limits: *limits,
            refused_tool0_from_camera: Box::new(s.tool0_from_camera),
        }),
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::UnitQuaternion;

    use super::super::solve::solve_used;
    use super::*;

    /// SplitMix64 + Box-Muller, for the synthetic calibrations below.
    struct Rng(u64);

    impl Rng {
        fn uniform(&mut self) -> f64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
        }
        fn gauss(&mut self) -> f64 {
            let u = self.uniform().max(f64::MIN_POSITIVE);
            (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * self.uniform()).cos()
        }
        fn vector(&mut self, sigma: f64) -> Vector3<f64> {
            Vector3::new(self.gauss(), self.gauss(), self.gauss()) * sigma
        }
        fn pose_error(&mut self, deg: f64, mm: f64) -> Isometry3<f64> {
            Isometry3::from_parts(
                Translation3::from(self.vector(mm * 1e-3)),
                UnitQuaternion::from_scaled_axis(self.vector(deg.to_radians())),
            )
        }
    }

    /// A synthetic calibration of 18 views (no images): the wrist at poses rotated 10-50 deg
    /// about random axes, each view's hand pose off by the arm's error (0.02 deg / 0.2 mm
    /// per axis) and its camera pose by the image's (`camera_deg`, `camera_mm`), every pair
    /// motion with its own estimation error (`pair_deg`, `pair_mm`); in mono the camera
    /// translations are directions only. Returns the reports, the motions and the true X.
    fn synthetic(
        rng: &mut Rng,
        mode: Mode,
        camera: (f64, f64),
        pair: (f64, f64),
    ) -> (Vec<PairReport>, Vec<RelativeMotion>, Isometry3<f64>) {
        let x = Isometry3::from_parts(
            Translation3::new(0.03, -0.06, 0.09),
            UnitQuaternion::from_scaled_axis(Vector3::new(0.4, -0.2, 1.4)),
        );
        let n = 18;
        let mut hand = Vec::new();
        let mut cams = Vec::new();
        for _ in 0..n {
            let axis = rng.vector(1.0).normalize();
            let angle = (10.0 + 40.0 * rng.uniform()).to_radians();
            let h = Isometry3::from_parts(
                Translation3::new(
                    0.4 + 0.3 * rng.uniform(),
                    -0.2 + 0.4 * rng.uniform(),
                    0.5 + 0.3 * rng.uniform(),
                ),
                UnitQuaternion::from_scaled_axis(axis * angle),
            );
            cams.push(h * x * rng.pose_error(camera.0, camera.1));
            hand.push(h * rng.pose_error(0.02, 0.2));
        }
        let (mut reports, mut motions) = (Vec::new(), Vec::new());
        for i in 0..n {
            for j in i + 1..n {
                let b = hand[i].inverse() * hand[j];
                let mut a = cams[i].inverse() * cams[j] * rng.pose_error(pair.0, pair.1);
                if mode == Mode::Mono {
                    a.translation.vector = a.translation.vector.normalize();
                }
                motions.push(RelativeMotion::new(a, b));
                reports.push(PairReport {
                    i,
                    j,
                    hand_rotation_deg: b.rotation.angle().to_degrees(),
                    raw_matches: 0,
                    matches: 0,
                    inliers: 0,
                    cam_i_from_cam_j: Some(a),
                    scale: 1.0,
                    residual_rot_deg: f64::NAN,
                    residual_trans_mm: f64::NAN,
                    eq15_rms_mm: f64::NAN,
                    rejected: None,
                });
            }
        }
        (reports, motions, x)
    }

    /// The view-to-view hand error, where it is propagated, takes the place of the
    /// disagreement term (which traces the same error); otherwise the disagreement joins
    /// the rotation block along its own direction only.
    #[test]
    fn the_propagated_hand_error_replaces_the_disagreement() {
        let jackknife = Matrix6::from_diagonal_element(1e-6);
        let hand = Matrix6::from_diagonal_element(4e-6);
        let d = Vector3::new(3e-3, -1e-3, 2e-3);
        assert_eq!(
            over_views_covariance(jackknife, Some(hand), Some(d)),
            jackknife + hand
        );
        let with_d = over_views_covariance(jackknife, None, Some(d));
        let mut expected = jackknife;
        expected
            .fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&(jackknife.fixed_view::<3, 3>(0, 0) + d * d.transpose()));
        assert_eq!(with_d, expected);
        assert_eq!(with_d[(0, 1)], -3e-6);
        assert_eq!(over_views_covariance(jackknife, None, None), jackknife);
    }

    /// The squared Mahalanobis distances of the rotation and translation errors.
    fn mahalanobis(s: &HandEyeSolution, truth: &Isometry3<f64>) -> (f64, f64) {
        uncertainty::mahalanobis(s, truth).unwrap_or((f64::INFINITY, f64::INFINITY))
    }

    /// An uncertainty that can be trusted, in both modes (no rendering: pair motions with
    /// per-view and per-pair error): over 400 self-calibrations each, the squared
    /// Mahalanobis distance of the rotation and of the translation error against the
    /// reported covariance (the jackknife over views) is under chi-square(3)'s 95 % point
    /// 7.81 in 90-99 % of them.
    #[test]
    fn the_self_calibration_covariance_covers_its_error() {
        let params = SelfCalParams::default();
        let opts = handeye_options(&params);
        for (mode, camera, pair) in [
            (Mode::Rgbd, (0.02, 0.2), (0.01, 0.1)),
            (Mode::Mono, (0.05, 0.3), (0.1, 0.5)),
        ] {
            let mut rng = Rng(31);
            let (mut rot_in, mut trans_in, trials) = (0, 0, 400);
            let (mut lin_rot_in, mut lin_trans_in) = (0, 0);
            for _ in 0..trials {
                let (mut reports, mut motions, x) = synthetic(&mut rng, mode, camera, pair);
                let mut solution = match mode {
                    Mode::Rgbd => {
                        let used = used_indices(&reports);
                        solve_used(&mut reports, &used, &motions, &opts).expect("rgbd solve")
                    }
                    Mode::Mono => {
                        solve_mono(&mut reports, &mut motions, &opts, &params)
                            .expect("mono solve")
                            .0
                    }
                };
                reestimate_uncertainty(&reports, &motions, mode, &opts, &mut solution);
                let (r2, t2) = mahalanobis(&solution, &x);
                lin_rot_in += usize::from(r2 <= 7.81);
                lin_trans_in += usize::from(t2 <= 7.81);
                let cov = jackknife_over_views(&reports, &motions, mode, &opts, &solution)
                    .expect("a jackknife over 18 views");
                solution.set_covariance(cov, UncertaintySource::Jackknife);
                let (r2, t2) = mahalanobis(&solution, &x);
                rot_in += usize::from(r2 <= 7.81);
                trans_in += usize::from(t2 <= 7.81);
            }
            let (r, t) = (
                rot_in as f64 / f64::from(trials),
                trans_in as f64 / f64::from(trials),
            );
            eprintln!(
                "{mode:?}: rotation {r:.3}, translation {t:.3} within chi2(3) 95% (linearised: {:.3}, {:.3})",
                lin_rot_in as f64 / f64::from(trials),
                lin_trans_in as f64 / f64::from(trials)
            );
            assert!((0.90..=0.99).contains(&r), "{mode:?} rotation {r:.3}");
            assert!((0.90..=0.99).contains(&t), "{mode:?} translation {t:.3}");
        }
    }
}
