//! Drift check of the hand-eye calibration for self-maintenance (ARCHITECTURE.md section 6:
//! "before operating, the robot checks its hand-eye calibration from what it sees"): a few
//! views of textured structure, their hand poses and the `X = tool0_from_camera` in use
//! decide [`DriftVerdict::Consistent`], [`DriftVerdict::Drifted`] (with the estimated
//! rotation and translation of the mount) or [`DriftVerdict::CannotTell`] (with the reason).
//! Camera and joint data only; pure (no I/O, no clock), deterministic for any thread count.
//!
//! # Measurements
//!
//! The views go through the self-calibration front end ([`pair_motions`]: ORB + quadtree,
//! brute-force Hamming, GMS, then 3D-3D RANSAC in RGB-D or the essential matrix in mono), so
//! every pair `i < j` with enough hand rotation gives a camera motion `A_ij` next to the
//! hand motion `B_ij = B_i^-1 B_j` (ARCHITECTURE.md section 6: `A_ij = cam_i_from_cam_j`,
//! `B_ij = tool_i_from_tool_j`, `B_ij X = X A_ij`). The residuals of a pair under `X` are
//! those of [`crate::handeye::refine`]:
//!
//! ```text
//! r_R = log(R_B R_X R_A^T R_X^T)                 (rotation vector, tool0 frame)
//! r_t = (R_B - I) t_X + t_B - s R_X t_A          (metres)
//! ```
//!
//! with `s = 1` in RGB-D and, in mono, the pair's own scale (its `t_A` has `|t_A| = 1`),
//! `s = u^T((R_B - I) t_X + t_B)`, `u = R_X t_A`: the scale that best explains the pair, which
//! leaves only the component of `r_t` across `u`.
//!
//! # The estimated inconsistency
//!
//! If the mount moved, the views follow another `X' = (exp([d_theta]x) R_X, t_X + d_t)`. The
//! check estimates `(d_theta, d_t)` by robust Gauss-Newton from `X` (Huber, `k = 2`, on the
//! residual blocks normalised by the a-priori noise below), in mono with every pair's scale
//! eliminated by variable projection ([`normal_equations_x`]); its information matrix `H`
//! (6x6, Schur complement of the scales in mono) gives the covariance of the estimate.
//! A mount bump to first order changes the residuals by
//! `dr_R = (R_B - I) d_theta` (any rotation not about the hand axis) and
//! `dr_t = (R_B - I) d_t + [R_X t_A]x d_theta`: rotations of the mount show in both blocks
//! (the second through the camera's lever `|t_A|`), translations through `R_B - I` only, so
//! both need hand rotations of tens of degrees about at least two axes ([`CHECK_MOTION`]).
//!
//! # Statistics of the decision
//!
//! A-priori noise ([`DriftParams::noise_rgbd`], [`DriftParams::noise_mono`]): each pair's
//! residual blocks are taken as `N(0, sigma_R^2 I_3)` and `N(0, sigma_t^2 I_3)` when the
//! mount has not moved: camera-motion noise plus the hand-pose error of both views (encoder
//! noise and the kinematic model's error, which varies with the pose).
//!
//! ```text
//! Sigma_d = H^-1 * (P / M) * max(1, chi^2 / nu)
//! ```
//!
//! `P` pairs built from `n` views carry only `M = n - 1` independent motions (the hand error
//! of a view enters all its pairs), hence `P / M`; `chi^2` is the weighted sum of the
//! normalised residuals at the estimate and `nu = 6P - 6` (mono `5P - 6`) its degrees of
//! freedom: when the data are noisier than the a-priori noise (a vibrating scene, poor
//! images), the covariance grows with them, never shrinks below the prior. The `X` in use has
//! its own error (its calibration): [`DriftParams::x_sigma_rot_deg`],
//! [`DriftParams::x_sigma_trans_mm`] per axis.
//!
//! **The change prior.** Where the views carry no information (in mono with [`CHECK_MOTION`],
//! the camera's translation along its optical axis) the Gauss-Newton estimate would walk
//! along the flat direction of the cost, and the linearised `H^-1` would not bound how far.
//! A Gaussian prior `N(0, diag(sigma_p,R^2 I, sigma_p,t^2 I))` on `(d_theta, d_t)`
//! ([`DriftParams::change_prior_rot_deg`] 5 deg, [`DriftParams::change_prior_trans_mm`]
//! 20 mm, wider than any bump: ARCHITECTURE.md section 6's are 1-3 deg and 3-10 mm) adds its
//! information to `H` and its pull to the gradient: there the estimate stays at the prior's
//! mean and its 1-sigma at the prior's, so such a direction can neither raise a false alarm
//! nor confirm consistency. Where the views do resolve the change it moves the estimate by
//! about `(sigma / sigma_p)^2` of itself (below 0.1 % in RGB-D). `chi^2` counts the
//! measurements only.
//!
//! Per block `b` (rotation, translation), with `s_b = sqrt(lambda_max(Sigma_d,bb) + sigma_X,b^2)`
//! (the worst direction):
//!
//! - under "not moved" `|d_b| / s_b` is at most the norm of a 3-D standard normal, so
//!   `P(|d_b| > k s_b) <= P(chi^2_3 > k^2)`; with `k = sqrt(F^-1_chi2_3(1 - alpha / 2))` and
//!   the union bound over the two blocks the false-alarm probability is at most `alpha`
//!   ([`DriftParams::false_alarm`], 5%: `k = 3.06`). The threshold is
//!   `tau_b = max(k s_b, floor_b)` ([`DriftParams::min_threshold_rot_deg`],
//!   [`DriftParams::min_threshold_trans_mm`]: changes too small to matter are never
//!   reported);
//! - a bump of size `D` in any direction is reported with probability at least
//!   `Phi((D - tau_b) / s_b)` (the estimate's component along the bump alone exceeds
//!   `tau_b`), i.e. at least `1 - beta` ([`DriftParams::detection`], 95%: `z = 1.645`) for
//!   `D >= tau_b + z s_b`, the **detectable size**;
//! - the **upper bound** of the change, `U_b = |d_b| + z s_b`, is a one-sided confidence
//!   bound: for any true change `d` (unit direction `u`), `|d_hat| >= u^T d_hat = |d| + u^T e`
//!   with `u^T e ~ N(0, sigma_u^2)`, `sigma_u <= s_b`, so `P(U_b < |d|) <= P(u^T e < -z s_b)
//!   <= beta`. A check that calls the mount unmoved because `U_b` is under the target misses a
//!   bump of the target size or more with probability at most `beta` (1 - `detection`).
//!
//! Verdict: **Drifted** when `|d_theta| > tau_R` or `|d_t| > tau_t` (a significant change,
//! whatever the resolution); otherwise **Consistent** when both upper bounds are within their
//! targets ([`DriftParams::target_rot_deg`] 0.5 deg, [`DriftParams::target_trans_mm`] 3 mm:
//! the views exclude a bump that matters); otherwise **CannotTell**
//! ([`CannotTell::Unobservable`]: the views can neither show a change nor exclude one of the
//! target size). The decision reads the estimate the views gave, not only their design: a
//! check whose detectable size exceeds the target is still Consistent when its estimate is
//! small enough, which is what lets four views of an unmoved mount answer when their
//! residuals are twice the a-priori noise (a calibration's error in `camera_info` shows as
//! pair residuals the model counts as noise). Refusals before that: invalid or featureless views,
//! pure translation (no pair rotates
//! [`crate::selfcal::SelfCalParams::min_pair_rotation_deg`]), rotations about one axis or
//! hand/eye angles that disagree ([`crate::handeye::degeneracy`]), too few pairs.
//!
//! # Use: against the calibration, or against a reference check
//!
//! The `X` in use carries its own calibration error, and the kinematic model's error is
//! different at the check poses than at the calibration poses, so part of that error shows
//! as a "drift" of its own. Two ways to run the check:
//!
//! 1. **Against the calibrated X**, [`DriftParams::default`]: `x_sigma` is the calibration's
//!    error (0.03 deg / 0.4 mm per axis, typical of an RGB-D self-calibration), or that
//!    calibration's own reported covariance ([`DriftParams::with_x_covariance`]: the
//!    calibration stage uses it for an `X` it calibrated).
//! 2. **Against a reference** (recommended), [`DriftParams::against_reference`]: right after
//!    a calibration is accepted, run the check motion once and keep
//!    [`DriftEstimate::tool0_from_camera`] (the `X` those views support, including the arm's
//!    systematic error at these poses); later checks at the same poses pass it as the `X` in
//!    use. The systematic error cancels and only the check's own noise remains
//!    ([`REFERENCE_SIGMA_ROT_DEG`], [`REFERENCE_SIGMA_TRANS_MM`]).
//!
//! # Figures
//!
//! Synthetic RGB-D views of the textured test scene (640x512, `tests/selfcal_drift.rs`) from
//! [`CHECK_MOTION`], hand error 0.02 deg / 0.2 mm per pose and axis: the true `X` is
//! Consistent (estimate 0.05 deg / 0.49 mm, thresholds 0.15 deg / 1.8 mm, detectable
//! 0.22 deg / 2.7 mm); `X` rotated 0.5 deg about four axes or shifted 3 mm along four
//! directions is Drifted with 0.39-0.59 deg and 2.2-4.0 mm estimated; pure translation and
//! rolls about the optical axis alone are CannotTell.
//!
//! Simulator (scratch harness, 40 seeds, the `experiment noise` trial geometry at 640x512:
//! seeded true mount, perturbed arm, encoder noise; `X` from RGB-D self-calibration of the
//! trial's 18 calib-18-style views; then [`CHECK_MOTION`] at the calibration cabinet with the
//! mount bumped as the simulator does, `(t + dt, R_delta R)`):
//!
//! | against | unbumped: Consistent / Drifted / CannotTell | 0.5 deg | 3 mm | 0.25 deg | 1.5 mm |
//! |---|---|---|---|---|---|
//! | calibrated X (default) | 28 / 5 / 7 | 40/40 | 38/40 | 38/40 | 17/40 |
//! | reference check | 35 / 0 / 5 | 40/40 | 40/40 | 40/40 | 7/40 |
//!
//! Against the calibrated X the 5 false alarms are the runs whose X was 0.3-1.6 mm off
//! (its own 1-sigma said 0.2-0.3 mm: the arm's systematic error does not show in the
//! calibration's residuals); against a reference the unbumped estimates are 0.038 deg /
//! 0.38 mm (median), 0.11 deg / 0.95 mm at most. The CannotTell cases are checks whose
//! residuals exceeded the a-priori noise (chi^2 / nu 1.3-1.7), which widens the detectable
//! size past 3 mm (the table predates the upper bound, which decides most of them).
//! Mono resolves only bumps of ~1.6 deg and more, and no translation along the optical axis
//! (see [`CHECK_MOTION`]): it says CannotTell for smaller ones.
//!
//! Seeded sites (`rodlog experiment maintenance --sites seeded`, 50 runs per bin, the
//! published `camera_info` carrying a calibration's error, four more views when four cannot
//! decide):
//!
//! | the task's check against | unbumped: Consistent / Drifted / CannotTell | 0.5 deg | 3 mm | 1 mm | 0.25 deg |
//! |---|---|---|---|---|---|
//! | the camera edge (the calibrated X) | 49 / 0 / 1 | 50/50 | 48/50, 1 Consistent (a miss), 1 CannotTell | 3/50 | 42/50 |
//! | a reference from an unbumped check of the same robot on another day | 50 / 0 / 0 | 50/50 | 49/50, 1 CannotTell | 2/50 | 41/50 |
//!
//! (49 of the 50 robots' reference runs left a reference; the 50th checks against its edge.
//! The two rows are two designs, not one ablation: the first is 50 independent runs per bin,
//! the second 50 robots each checked once per bin on a day of its own.)
//! Against the edge, the unbumped estimates of 0.55-1.6 mm are the check's own systematic
//! error, the arm's kinematics at the check poses and the `camera_info` error, which the
//! reference cancels: no 3 mm bump is called consistent. The reference is the estimate of
//! the first four views; a check that takes four more compares eight views with it, and the
//! arm's error at the added poses shows (a 1 mm shift estimated at 1.6 mm from eight views).

use nalgebra::{
    Isometry3, Matrix3, Matrix6, SymmetricEigen, Translation3, UnitQuaternion, Vector3, Vector6,
};

use super::pairs::{PairRejection, RejectionCounts};
use super::pipeline::{PairMotions, SelfCalParams, pair_motions, relative_motion};
use super::solve::{distinct_views, scales_from_x};
use super::views::CalibView;
use super::{Mode, SelfCalError};
use crate::handeye::refine::{apply_x_step, normal_equations_x, pair_residual};
use crate::handeye::{HandEyeError, HandEyeOptions, RelativeMotion, RobustLoss, degeneracy};
use crate::quantiles::{chi2_3_quantile, normal_quantile};
use crate::relpose::CameraModel;

/// One pose of the check motion, in the frame of the structure looked at (module docs of
/// [`check_camera_poses`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CheckPose {
    /// Angle between the viewing direction and the surface normal, degrees.
    pub tilt_deg: f64,
    /// Direction of the tilt about the normal, from the target's x axis, degrees.
    pub azimuth_deg: f64,
    /// Rotation of the camera about its optical axis, degrees.
    pub roll_deg: f64,
    /// Distance from the camera to the looked-at point, metres.
    pub distance_m: f64,
}

/// The proposed check motion: four camera poses around one point of textured structure at
/// 0.45 m (the middle of the wrist camera's 0.3-0.6 m working distance): one frontal, rolled
/// 30 deg about the optical axis, and three tilted 30 deg off the surface normal at
/// azimuths 120 deg apart.
///
/// Why: every pair's relative rotation is 40-53 deg (a unit test checks 30-60 deg); the tilted pairs rotate about axes in the surface
/// plane 60 deg apart and the frontal pairs about axes mixing the tilt with the roll about
/// the optical axis, so the hand rotation vectors span all three directions: the
/// eigenvalues of their scatter ([`crate::handeye::degeneracy`]) have
/// `sqrt(lambda_2 / lambda_1) = 0.95` and `sqrt(lambda_3 / lambda_1) = 0.68`. By the
/// first-order residuals of the module docs, a mount rotation then changes `r_R` by
/// `(R_B - I) d_theta` with `|R_B - I| = 2 sin(angle / 2) = 0.7-0.9` in every direction
/// of some pair, a mount translation changes `r_t` by `(R_B - I) d_t` likewise, and the
/// camera's 0.3-0.4 m translations add `|t_A| |d_theta|` (2.5-3.5 mm per 0.5 deg) to `r_t`.
/// Relative rolls stay within 30 deg so GMS without rotation patterns still matches; all
/// views look at the same point from the same distance, so every pair overlaps. (Views at
/// 0.40-0.55 m doubled the RGB-D pair residuals on the simulator; the price is mono's: with
/// every camera looking at one point from one distance, moving the camera along its optical
/// axis in `X` scales the camera positions about that point and keeps every translation
/// direction, so mono cannot see that component of a translation bump, and the check says
/// [`CannotTell::Unobservable`] rather than Consistent.) The robot reaches these by inverse
/// kinematics from the structure's pose ([`check_camera_poses`], then `X^-1` for the
/// flange), e.g. the calibration cabinet's face; whether all four are reachable from the
/// operating spot is the planner's to check.
pub const CHECK_MOTION: [CheckPose; 4] = [
    CheckPose {
        tilt_deg: 0.0,
        azimuth_deg: 0.0,
        roll_deg: 30.0,
        distance_m: 0.45,
    },
    CheckPose {
        tilt_deg: 30.0,
        azimuth_deg: 0.0,
        roll_deg: 0.0,
        distance_m: 0.45,
    },
    CheckPose {
        tilt_deg: 30.0,
        azimuth_deg: 120.0,
        roll_deg: 0.0,
        distance_m: 0.45,
    },
    CheckPose {
        tilt_deg: 30.0,
        azimuth_deg: 240.0,
        roll_deg: 0.0,
        distance_m: 0.45,
    },
];

/// Four more poses for a check that could not resolve a bump of the target size
/// ([`CannotTell::Unobservable`]): frontal without roll and tilted 30 deg at the azimuths
/// halfway between [`CHECK_MOTION`]'s, same point, same distance. Joined to the first four
/// (the calibration stage's `extend`), the check has 8 views and 28 pairs carrying `M = 7`
/// independent motions instead of 3 (module docs: `Sigma_d = H^-1 (P / M)`, `H` growing with
/// `P`), so the estimate's 1-sigma shrinks by about `sqrt(3 / 7) = 0.65`. Every new pose is
/// 29-60 deg from each other pose (a unit test checks 20-60 deg): each pairs with all of
/// them.
pub const CHECK_MOTION_MORE: [CheckPose; 4] = [
    CheckPose {
        tilt_deg: 0.0,
        azimuth_deg: 0.0,
        roll_deg: 0.0,
        distance_m: 0.45,
    },
    CheckPose {
        tilt_deg: 30.0,
        azimuth_deg: 60.0,
        roll_deg: 0.0,
        distance_m: 0.45,
    },
    CheckPose {
        tilt_deg: 30.0,
        azimuth_deg: 180.0,
        roll_deg: 0.0,
        distance_m: 0.45,
    },
    CheckPose {
        tilt_deg: 30.0,
        azimuth_deg: 300.0,
        roll_deg: 0.0,
        distance_m: 0.45,
    },
];

/// `world_from_camera` of each check pose. `world_from_target`: the looked-at point at its
/// origin, its z axis the surface normal pointing towards the camera side. Camera axes are
/// OpenCV's (z forward): the camera sits at `d * (sin tilt cos az, sin tilt sin az, cos tilt)`
/// in the target frame, looks at the origin, its x axis is the target's x axis made
/// orthogonal to the viewing direction (the target's y axis when they are parallel), then it
/// is rolled about its z axis.
pub fn check_camera_poses(
    world_from_target: &Isometry3<f64>,
    poses: &[CheckPose],
) -> Vec<Isometry3<f64>> {
    poses
        .iter()
        .map(|p| {
            let (tilt, az) = (p.tilt_deg.to_radians(), p.azimuth_deg.to_radians());
            let dir = Vector3::new(tilt.sin() * az.cos(), tilt.sin() * az.sin(), tilt.cos());
            let z = -dir;
            let reference = if Vector3::x().cross(&z).norm() > 1e-6 {
                Vector3::x()
            } else {
                Vector3::y()
            };
            let x = (reference - z * reference.dot(&z)).normalize();
            let y = z.cross(&x);
            let look = UnitQuaternion::from_matrix(&Matrix3::from_columns(&[x, y, z]));
            let roll = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), p.roll_deg.to_radians());
            world_from_target
                * Isometry3::from_parts(Translation3::from(dir * p.distance_m), look * roll)
        })
        .collect()
}

/// A-priori 1-sigma (per axis) of a pair's AX=XB residual blocks when the mount has not
/// moved (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PairNoise {
    /// Rotation block, degrees.
    pub rot_deg: f64,
    /// Translation block, millimetres.
    pub trans_mm: f64,
}

/// The drift check's ORB keypoint selection: the quadtree, with which its a-priori pair
/// noise ([`DriftParams::noise_rgbd`], [`DriftParams::noise_mono`]) and its statistics (the
/// module docs' figures, `tests/selfcal_drift.rs`) were measured. With retain-best the
/// synthetic checks estimate a 0.5 deg bump 0.12 deg off and lose the mono check's
/// resolution: a front end change needs the check re-measured first.
pub const DRIFT_KEYPOINT_DISTRIBUTION: crate::features::KeypointDistribution =
    crate::features::KeypointDistribution::Quadtree;

/// The drift check's front end from a calibration's `selfcal`: the keypoint selection
/// [`DRIFT_KEYPOINT_DISTRIBUTION`], and every keypoint's depth kept
/// ([`super::Steps::depth_support`] off). Its statistics were measured so; with the depth
/// support, the 4-view check of the golden hang recording (256x205) widened its thresholds
/// from 0.71 deg / 5.7 mm to 1.43 deg / 12.3 mm, fewer points left near the bay's contours.
#[must_use]
pub fn drift_front_end(mut selfcal: SelfCalParams) -> SelfCalParams {
    selfcal.orb.distribution = DRIFT_KEYPOINT_DISTRIBUTION;
    selfcal.steps.depth_support = false;
    selfcal
}

/// Parameters of [`check_drift`]; every default is documented on its field.
#[derive(Debug, Clone, PartialEq)]
pub struct DriftParams {
    /// Front end (features, matching, relative pose, smallest pair rotation). Default
    /// [`SelfCalParams::default`], with the mono rotation-angle prior
    /// ([`super::Steps::angle_prior`]): the essential matrix is estimated with the hand
    /// rotation's angle as a prior, so the mono pairs agree better. The translation along the
    /// optical axis stays as poorly determined as without it; the change prior
    /// ([`DriftParams::change_prior_trans_mm`]) keeps the estimate there, where a check
    /// without it once reported a 467 mm "drift" of an unmoved mount against a 297 mm
    /// threshold. Use [`SelfCalParams::for_camera`] for large images, through
    /// [`drift_front_end`] (its keypoint selection and depth, whatever the calibration's).
    pub selfcal: SelfCalParams,
    /// A-priori pair noise in RGB-D. Default 0.045 deg / 0.35 mm: the per-axis RMS of the
    /// pair residuals at the true mount measured on the simulator (640x512 renders of
    /// [`CHECK_MOTION`] at the calibration cabinet, the seeded kinematic perturbation
    /// ~0.2 mm / ~0.02 deg per joint and encoder noise 5e-5 rad; 16 seeds: 0.028-0.071 deg,
    /// 0.27-0.66 mm, median 0.042 deg / 0.33 mm). The hand-pose error dominates: the 3D-3D
    /// motions alone are ~0.01 deg / 0.1 mm.
    pub noise_rgbd: PairNoise,
    /// A-priori pair noise in mono. Default 0.3 deg / 1.5 mm: essential-matrix rotations and
    /// translation directions of 0.1-0.5 deg at 640x512 (the clean calib-18 median rotation
    /// residual is 0.5-0.7 deg), the same hand error.
    pub noise_mono: PairNoise,
    /// 1-sigma error of the `X` in use, per axis, degrees (its calibration). Default 0.03
    /// (RGB-D self-calibration on the simulated calib-18 views with the perturbed arm, 16
    /// seeds at 640x512: 0.018-0.12 deg, median 0.04 deg).
    pub x_sigma_rot_deg: f64,
    /// ... millimetres. Default 0.4 (same runs: 0.02-1.56 mm, median 0.4 mm).
    pub x_sigma_trans_mm: f64,
    /// Largest probability of reporting a drift when the mount has not moved (default 0.05).
    pub false_alarm: f64,
    /// Smallest probability of reporting a bump of the target size, and the confidence of
    /// the upper bounds that call the mount unmoved (default 0.95: a bump of the target size
    /// is called Consistent with probability at most 5%).
    pub detection: f64,
    /// Rotation bump that must be detected, degrees (default 0.5).
    pub target_rot_deg: f64,
    /// Translation bump that must be detected, millimetres (default 3).
    pub target_trans_mm: f64,
    /// Rotation threshold never below this, degrees (default 0.1).
    pub min_threshold_rot_deg: f64,
    /// Translation threshold never below this, millimetres (default 0.75).
    pub min_threshold_trans_mm: f64,
    /// Prior 1-sigma of the mount's change, per axis, degrees (default 5: the bumps that
    /// knock a wrist camera are 1-3 deg). A Gaussian prior on `d_theta` keeps the estimate
    /// where the views say nothing (module docs, "the change prior").
    pub change_prior_rot_deg: f64,
    /// ... on `d_t`, millimetres (default 20: bumps move it 3-10 mm).
    pub change_prior_trans_mm: f64,
    /// Fewest pairs with a camera motion (default 3: 3 views give 3 pairs).
    pub min_pairs: usize,
    /// Robust loss on the normalised residual blocks (default Huber, `k = 2`).
    pub loss: RobustLoss,
    /// Gauss-Newton iterations at most (default 20).
    pub max_iterations: usize,
}

impl Default for DriftParams {
    fn default() -> Self {
        Self {
            selfcal: drift_front_end(SelfCalParams::default()),
            noise_rgbd: PairNoise {
                rot_deg: 0.045,
                trans_mm: 0.35,
            },
            noise_mono: PairNoise {
                rot_deg: 0.3,
                trans_mm: 1.5,
            },
            x_sigma_rot_deg: 0.03,
            x_sigma_trans_mm: 0.4,
            false_alarm: 0.05,
            detection: 0.95,
            target_rot_deg: 0.5,
            target_trans_mm: 3.0,
            min_threshold_rot_deg: 0.1,
            min_threshold_trans_mm: 0.75,
            change_prior_rot_deg: 5.0,
            change_prior_trans_mm: 20.0,
            min_pairs: 3,
            loss: RobustLoss::Huber { k: 2.0 },
            max_iterations: 20,
        }
    }
}

/// Per-axis 1-sigma of a reference taken by a check at the same poses, degrees (module
/// docs: two unbumped simulated checks differ by 0.038 deg median, 0.11 deg at most, over
/// 40 seeds).
pub const REFERENCE_SIGMA_ROT_DEG: f64 = 0.035;
/// ... millimetres (same runs: 0.38 mm median, 0.95 mm at most).
pub const REFERENCE_SIGMA_TRANS_MM: f64 = 0.35;

impl DriftParams {
    /// The parameters of a check against an `X` whose calibration reported `covariance`
    /// (of `(theta, t)`, radians and metres: [`crate::handeye::HandEyeSolution::covariance`]):
    /// `x_sigma` per axis is the square root of each block's largest eigenvalue, the
    /// calibration's own figure in place of the default's typical one (a covariance that is
    /// not finite leaves the defaults).
    #[must_use]
    pub fn with_x_covariance(self, covariance: &Matrix6<f64>) -> Self {
        if !covariance.iter().all(|v| v.is_finite()) {
            return self;
        }
        let rot = largest_eigenvalue(&covariance.fixed_view::<3, 3>(0, 0).into_owned());
        let trans = largest_eigenvalue(&covariance.fixed_view::<3, 3>(3, 3).into_owned());
        Self {
            x_sigma_rot_deg: rot.max(0.0).sqrt().to_degrees(),
            x_sigma_trans_mm: trans.max(0.0).sqrt() * 1e3,
            ..self
        }
    }

    /// The parameters of a check against a reference check at the same poses (module docs):
    /// `x_sigma` = [`REFERENCE_SIGMA_ROT_DEG`], [`REFERENCE_SIGMA_TRANS_MM`].
    #[must_use]
    pub fn against_reference(self) -> Self {
        Self {
            x_sigma_rot_deg: REFERENCE_SIGMA_ROT_DEG,
            x_sigma_trans_mm: REFERENCE_SIGMA_TRANS_MM,
            ..self
        }
    }
}

/// Gauss-Newton stops when the step is below this (radians + metres).
pub const STEP_TOLERANCE: f64 = 1e-10;

/// Why the check cannot decide. Every variant carries the numbers that explain it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CannotTell {
    /// The views are unusable (too few, wrong size, dark or textureless: the front end's
    /// refusal).
    #[error("views unusable: {0}")]
    Views(SelfCalError),
    /// No pair of views rotates enough: the mount's rotation and translation are not
    /// observable.
    #[error(
        "pure translation: the largest hand rotation between the views is {max_rotation_deg:.2} deg (< {min_deg} deg): move the wrist through the check motion (30-60 deg between views about different axes)"
    )]
    PureTranslation {
        /// Largest hand rotation between two views, degrees.
        max_rotation_deg: f64,
        /// Smallest usable, degrees.
        min_deg: f64,
    },
    /// Too few pairs gave a camera motion.
    #[error(
        "only {usable} of {candidates} view pairs gave a camera motion, need {need} ({too_few_matches} with too few matches, {motion_failed} where the motion estimate failed, {rejected} rejected): point the camera at textured, lit structure that all views see"
    )]
    TooFewPairs {
        /// Pairs with a usable motion.
        usable: usize,
        /// Pairs with enough hand rotation.
        candidates: usize,
        /// Pairs needed.
        need: usize,
        /// Pairs with too few matches.
        too_few_matches: usize,
        /// Pairs whose motion estimation failed.
        motion_failed: usize,
        /// Pairs rejected by the hand-eye consistency checks (angle mismatch, scale).
        rejected: usize,
    },
    /// The hand motions are degenerate (one rotation axis) or inconsistent with the camera's.
    #[error("degenerate or inconsistent motion: {0}")]
    Degenerate(HandEyeError),
    /// The views neither show a significant change nor exclude one of the target size.
    #[error(
        "no drift above the thresholds ({rotation_deg:.3} deg, {translation_mm:.2} mm estimated), but the mount may have moved up to {bound_rot_deg:.2} deg / {bound_trans_mm:.2} mm ({confidence_pct:.0}% bound; targets {target_rot_deg} deg / {target_trans_mm} mm; 1-sigma {sigma_rot_deg:.3} deg / {sigma_trans_mm:.2} mm, {pairs} pairs, chi^2/dof {reduced_chi2:.2}; bumps of {detectable_rot_deg:.2} deg / {detectable_trans_mm:.2} mm would be seen): use larger wrist rotations about more axes, more views, or better images"
    )]
    Unobservable {
        /// Estimated rotation of the mount, degrees.
        rotation_deg: f64,
        /// Estimated translation, millimetres.
        translation_mm: f64,
        /// Upper confidence bound of the rotation ([`DriftEstimate::bound_rot_deg`]), degrees.
        bound_rot_deg: f64,
        /// ... of the translation, millimetres.
        bound_trans_mm: f64,
        /// The bounds' confidence ([`DriftParams::detection`]), percent.
        confidence_pct: f64,
        /// Smallest rotation bump detected with the target probability, degrees.
        detectable_rot_deg: f64,
        /// ... translation, millimetres.
        detectable_trans_mm: f64,
        /// Target rotation, degrees.
        target_rot_deg: f64,
        /// Target translation, millimetres.
        target_trans_mm: f64,
        /// 1-sigma of the rotation estimate, worst axis, degrees.
        sigma_rot_deg: f64,
        /// ... of the translation estimate, millimetres.
        sigma_trans_mm: f64,
        /// Pairs used.
        pairs: usize,
        /// `chi^2 / nu` at the estimate.
        reduced_chi2: f64,
    },
}

/// The decision of [`check_drift`].
#[derive(Debug, Clone, PartialEq)]
pub enum DriftVerdict {
    /// The views agree with the `X` in use within the thresholds, and a bump of the target
    /// size would have been seen.
    Consistent,
    /// The mount has moved: the estimated change (see [`DriftEstimate`]).
    Drifted {
        /// Rotation of the mount, degrees.
        rotation_deg: f64,
        /// Translation of the mount, millimetres.
        translation_mm: f64,
    },
    /// No decision (refusal with its reason).
    CannotTell(CannotTell),
}

/// One pair of the check.
#[derive(Debug, Clone, PartialEq)]
pub struct DriftPair {
    /// First view.
    pub i: usize,
    /// Second view.
    pub j: usize,
    /// Hand rotation of `B_ij`, degrees.
    pub hand_rotation_deg: f64,
    /// GMS matches.
    pub matches: usize,
    /// Relative-pose RANSAC inliers (0 without a motion).
    pub inliers: usize,
    /// Rotation residual under the `X` in use, degrees (NaN without a motion).
    pub residual_rot_deg: f64,
    /// Translation residual under the `X` in use (mono: across the pair's direction),
    /// millimetres (NaN without a motion).
    pub residual_trans_mm: f64,
    /// Why it is not used (`None` = used).
    pub rejected: Option<PairRejection>,
}

/// The estimated change of the mount and the statistics of the decision (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct DriftEstimate {
    /// The `X` the views support, `(exp([d_theta]x) R_X, t_X + d_t)`.
    pub tool0_from_camera: Isometry3<f64>,
    /// `d_theta` (tool0 frame), radians.
    pub d_theta_rad: Vector3<f64>,
    /// `d_t` (tool0 frame), metres.
    pub d_t_m: Vector3<f64>,
    /// `|d_theta|`, degrees.
    pub rotation_deg: f64,
    /// `|d_t|`, millimetres.
    pub translation_mm: f64,
    /// `s_R`: 1-sigma of the rotation decision (estimate, worst axis, and the `X` in use),
    /// degrees.
    pub sigma_rot_deg: f64,
    /// `s_t`, millimetres.
    pub sigma_trans_mm: f64,
    /// `tau_R`, degrees.
    pub threshold_rot_deg: f64,
    /// `tau_t`, millimetres.
    pub threshold_trans_mm: f64,
    /// `tau_R + z s_R`, degrees.
    pub detectable_rot_deg: f64,
    /// `tau_t + z s_t`, millimetres.
    pub detectable_trans_mm: f64,
    /// `U_R = |d_theta| + z s_R`: the change is below this with probability `detection`
    /// (module docs), degrees.
    pub bound_rot_deg: f64,
    /// `U_t = |d_t| + z s_t`, millimetres.
    pub bound_trans_mm: f64,
    /// Weighted chi^2 of the normalised residuals at the estimate.
    pub chi2: f64,
    /// Its degrees of freedom `nu`.
    pub dof: usize,
    /// Gauss-Newton iterations.
    pub iterations: usize,
}

/// Result of [`check_drift`].
#[derive(Debug, Clone, PartialEq)]
pub struct DriftReport {
    /// The decision.
    pub verdict: DriftVerdict,
    /// RGB-D or mono (`None` when the views were refused).
    pub mode: Option<Mode>,
    /// Every pair `i < j` with enough hand rotation, in `(i, j)` order.
    pub pairs: Vec<DriftPair>,
    /// The estimate (`None` when refused before it).
    pub estimate: Option<DriftEstimate>,
}

impl DriftReport {
    fn refused(reason: CannotTell, mode: Option<Mode>, pairs: Vec<DriftPair>) -> Self {
        Self {
            verdict: DriftVerdict::CannotTell(reason),
            mode,
            pairs,
            estimate: None,
        }
    }
}

/// Checks `tool0_from_camera` (the `X` in use) against `views` (module docs).
///
/// The verdict is [`DriftVerdict::CannotTell`] for unusable views (fewer than
/// [`super::MIN_VIEWS`], wrong size, dark or textureless), pure translation, rotations about
/// one axis, too few pairs, or a motion that cannot resolve the target bump.
pub fn check_drift(
    views: &[CalibView],
    camera: &CameraModel,
    tool0_from_camera: &Isometry3<f64>,
    params: &DriftParams,
) -> DriftReport {
    let x0 = *tool0_from_camera;
    let pm = match pair_motions(views, camera, &params.selfcal) {
        Ok(p) => p,
        Err(e) => return DriftReport::refused(CannotTell::Views(e), None, Vec::new()),
    };
    let PairMotions {
        mode,
        matches,
        estimates,
        small,
        ..
    } = &pm;
    let mode = *mode;
    if matches.is_empty() {
        let max_rotation_deg = small
            .iter()
            .filter_map(|(_, _, r)| match r {
                PairRejection::SmallRotation {
                    hand_rotation_deg, ..
                } => Some(*hand_rotation_deg),
                _ => None,
            })
            .fold(0.0, f64::max);
        return DriftReport::refused(
            CannotTell::PureTranslation {
                max_rotation_deg,
                min_deg: params.selfcal.min_pair_rotation_deg,
            },
            Some(mode),
            Vec::new(),
        );
    }
    // Pairs and their motions (unit-translation in mono).
    let mut pairs: Vec<DriftPair> = Vec::with_capacity(matches.len());
    let mut motions: Vec<(usize, RelativeMotion)> = Vec::new();
    for (m, est) in matches.iter().zip(estimates) {
        let motion = est
            .as_ref()
            .ok()
            .and_then(|e| relative_motion(views, mode, m.i, m.j, e));
        let rejected = match (est, &motion) {
            (Err(e), _) => Some(e.clone()),
            (Ok(_), None) => Some(PairRejection::Motion {
                reason: "view index out of range".to_owned(),
            }),
            (Ok(_), Some(_)) => None,
        };
        if let Some(rm) = motion {
            motions.push((pairs.len(), rm));
        }
        pairs.push(DriftPair {
            i: m.i,
            j: m.j,
            hand_rotation_deg: m.hand_rotation_deg,
            matches: m.coords.len(),
            inliers: est.as_ref().map_or(0, |e| e.inliers),
            residual_rot_deg: f64::NAN,
            residual_trans_mm: f64::NAN,
            rejected,
        });
    }
    let noise = match mode {
        Mode::Rgbd => params.noise_rgbd,
        Mode::Mono => params.noise_mono,
    };
    let opts = HandEyeOptions::default();
    // Degeneracy (pure translation, one axis) and hand/eye angle consistency.
    let all: Vec<RelativeMotion> = motions.iter().map(|(_, m)| *m).collect();
    if all.len() >= params.min_pairs.max(crate::handeye::MIN_MOTIONS) {
        match degeneracy::analyse(&all, &opts) {
            Ok(report) => {
                for &k in &report.rejected {
                    if let Some(p) = motions.get(k).and_then(|(p, _)| pairs.get_mut(*p)) {
                        p.rejected = Some(PairRejection::AngleMismatch);
                    }
                }
                let kept: Vec<(usize, RelativeMotion)> = report
                    .kept
                    .iter()
                    .filter_map(|&k| motions.get(k).copied())
                    .collect();
                motions = kept;
            }
            Err(e) => return DriftReport::refused(CannotTell::Degenerate(e), Some(mode), pairs),
        }
    }
    // Mono: a pair whose scale under X is not positive contradicts its own direction.
    if mode == Mode::Mono {
        let scales = pair_scales(&motions, &x0);
        let mut kept = Vec::with_capacity(motions.len());
        for ((p, m), s) in motions.into_iter().zip(scales) {
            if s > 0.0 {
                kept.push((p, m));
            } else if let Some(pair) = pairs.get_mut(p) {
                pair.rejected = Some(PairRejection::NonPositiveScale { scale: s });
            }
        }
        motions = kept;
    }
    if motions.len() < params.min_pairs {
        return DriftReport::refused(too_few_pairs(&pairs, params.min_pairs), Some(mode), pairs);
    }
    for ((p, _), m) in motions.iter().zip(metric(&motions, &x0, mode)) {
        if let Some(pair) = pairs.get_mut(*p) {
            let (r, t) = pair_residual(&m, &x0, 1.0);
            pair.residual_rot_deg = r.norm().to_degrees();
            pair.residual_trans_mm = t.norm() * 1e3;
        }
    }
    let estimate = estimate_change(&motions, &pairs, &x0, mode, noise, params);
    let verdict = decide(&estimate, motions.len(), params);
    DriftReport {
        verdict,
        mode: Some(mode),
        pairs,
        estimate: Some(estimate),
    }
}

/// `(d_theta, d_t)` of `x` against `x0` (module docs: `x = (exp([d_theta]x) R_0, t_0 + d_t)`).
fn change_from(x0: &Isometry3<f64>, x: &Isometry3<f64>) -> Vector6<f64> {
    let d_theta = (x.rotation * x0.rotation.inverse()).scaled_axis();
    let d_t = x.translation.vector - x0.translation.vector;
    Vector6::new(d_theta.x, d_theta.y, d_theta.z, d_t.x, d_t.y, d_t.z)
}

/// Each motion's scale under `x` (mono, [`scales_from_x`]).
fn pair_scales(motions: &[(usize, RelativeMotion)], x: &Isometry3<f64>) -> Vec<f64> {
    let unit: Vec<_> = motions.iter().map(|(_, m)| (m.a, m.b, m.weight)).collect();
    scales_from_x(&unit, x)
}

/// The motions with metric eye translations under `x`: as they are in RGB-D, each times its
/// scale under `x` in mono.
fn metric(
    motions: &[(usize, RelativeMotion)],
    x: &Isometry3<f64>,
    mode: Mode,
) -> Vec<RelativeMotion> {
    let mut out: Vec<RelativeMotion> = motions.iter().map(|(_, m)| *m).collect();
    if mode == Mode::Mono {
        for (m, s) in out.iter_mut().zip(pair_scales(motions, x)) {
            m.a.translation.vector *= s;
        }
    }
    out
}

fn too_few_pairs(pairs: &[DriftPair], need: usize) -> CannotTell {
    let c = RejectionCounts::of(pairs.iter().map(|p| p.rejected.as_ref()));
    CannotTell::TooFewPairs {
        usable: c.usable,
        candidates: pairs.len(),
        need,
        too_few_matches: c.too_few_matches,
        motion_failed: c.motion_failed,
        rejected: c.rejected_later,
    }
}

/// Robust Gauss-Newton from `x0` and the statistics of the module docs.
fn estimate_change(
    motions: &[(usize, RelativeMotion)],
    pairs: &[DriftPair],
    x0: &Isometry3<f64>,
    mode: Mode,
    noise: PairNoise,
    params: &DriftParams,
) -> DriftEstimate {
    let sigmas = (noise.rot_deg.to_radians(), noise.trans_mm * 1e-3);
    let per_scale = mode == Mode::Mono;
    // The change prior (module docs): information P on (d_theta, d_t) about x0, cost
    // 0.5 delta^T P delta, kept out of chi^2 (it is not a measurement).
    let prior_info = Vector6::new(
        params.change_prior_rot_deg.to_radians().powi(-2),
        params.change_prior_rot_deg.to_radians().powi(-2),
        params.change_prior_rot_deg.to_radians().powi(-2),
        (params.change_prior_trans_mm * 1e-3).powi(-2),
        (params.change_prior_trans_mm * 1e-3).powi(-2),
        (params.change_prior_trans_mm * 1e-3).powi(-2),
    );
    let normal = |x: &Isometry3<f64>| {
        let mut n =
            normal_equations_x(&metric(motions, x, mode), x, sigmas, params.loss, per_scale);
        let delta = change_from(x0, x);
        n.h += Matrix6::from_diagonal(&prior_info);
        n.g += prior_info.component_mul(&delta);
        n.cost += 0.5 * delta.dot(&prior_info.component_mul(&delta));
        n
    };
    let mut x = *x0;
    let mut n = normal(&x);
    let mut iterations = 0;
    while iterations < params.max_iterations {
        let Some(chol) = n.h.cholesky() else { break };
        let mut step = -chol.solve(&n.g);
        // Backtracking: halve the step until the robust cost does not increase.
        let mut accepted = None;
        for _ in 0..20 {
            let x_new = apply_x_step(&x, &step);
            let n_new = normal(&x_new);
            if n_new.cost <= n.cost {
                accepted = Some((x_new, n_new));
                break;
            }
            step *= 0.5;
        }
        let Some((x_new, n_new)) = accepted else {
            break;
        };
        x = x_new;
        n = n_new;
        iterations += 1;
        if step.norm() < STEP_TOLERANCE {
            break;
        }
    }
    let p = motions.len();
    let per_pair = if per_scale { 5 } else { 6 };
    let dof = (per_pair * p).saturating_sub(6);
    let views = distinct_views(
        motions
            .iter()
            .filter_map(|(k, _)| pairs.get(*k))
            .map(|pr| (pr.i, pr.j)),
    );
    let independent = views.len().saturating_sub(1).clamp(1, p.max(1));
    let inflation = p as f64 / independent as f64 * (n.chi2 / dof.max(1) as f64).max(1.0);
    let (var_rot, var_t) = match n.h.try_inverse() {
        Some(cov) => (
            largest_eigenvalue(&cov.fixed_view::<3, 3>(0, 0).into_owned()) * inflation,
            largest_eigenvalue(&cov.fixed_view::<3, 3>(3, 3).into_owned()) * inflation,
        ),
        None => (f64::INFINITY, f64::INFINITY),
    };
    let s_rot = (var_rot + params.x_sigma_rot_deg.to_radians().powi(2)).sqrt();
    let s_t = (var_t + (params.x_sigma_trans_mm * 1e-3).powi(2)).sqrt();
    let d_theta_rad = (x.rotation * x0.rotation.inverse()).scaled_axis();
    let d_t_m = x.translation.vector - x0.translation.vector;
    let rot = BlockFigures::new(
        d_theta_rad.norm().to_degrees(),
        s_rot.to_degrees(),
        params.min_threshold_rot_deg,
        params,
    );
    let trans = BlockFigures::new(
        d_t_m.norm() * 1e3,
        s_t * 1e3,
        params.min_threshold_trans_mm,
        params,
    );
    DriftEstimate {
        tool0_from_camera: x,
        d_theta_rad,
        d_t_m,
        chi2: n.chi2,
        dof,
        iterations,
        ..DriftEstimate::of_blocks(&rot, &trans)
    }
}

impl DriftEstimate {
    /// The decision figures of the rotation and translation blocks; the change itself,
    /// `chi^2` and the iterations left at their zero values for the caller to fill in.
    fn of_blocks(rot: &BlockFigures, trans: &BlockFigures) -> Self {
        Self {
            tool0_from_camera: Isometry3::identity(),
            d_theta_rad: Vector3::zeros(),
            d_t_m: Vector3::zeros(),
            rotation_deg: rot.change,
            translation_mm: trans.change,
            sigma_rot_deg: rot.sigma,
            sigma_trans_mm: trans.sigma,
            threshold_rot_deg: rot.threshold,
            threshold_trans_mm: trans.threshold,
            detectable_rot_deg: rot.detectable,
            detectable_trans_mm: trans.detectable,
            bound_rot_deg: rot.bound,
            bound_trans_mm: trans.bound,
            chi2: 0.0,
            dof: 0,
            iterations: 0,
        }
    }
}

/// The decision figures of one block (rotation in degrees, translation in millimetres) from
/// its estimated change `|d_b|` and 1-sigma `s_b` (module docs): threshold
/// `tau_b = max(k s_b, floor_b)`, detectable size `tau_b + z s_b`, upper bound
/// `|d_b| + z s_b`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct BlockFigures {
    change: f64,
    sigma: f64,
    threshold: f64,
    detectable: f64,
    bound: f64,
}

impl BlockFigures {
    fn new(change: f64, sigma: f64, floor: f64, params: &DriftParams) -> Self {
        let k = chi2_3_quantile(1.0 - 0.5 * params.false_alarm).sqrt();
        let z = normal_quantile(params.detection);
        let threshold = (k * sigma).max(floor);
        Self {
            change,
            sigma,
            threshold,
            detectable: threshold + z * sigma,
            bound: change + z * sigma,
        }
    }
}

/// The verdict of the module docs from the estimate.
fn decide(e: &DriftEstimate, pairs: usize, params: &DriftParams) -> DriftVerdict {
    if e.rotation_deg > e.threshold_rot_deg || e.translation_mm > e.threshold_trans_mm {
        return DriftVerdict::Drifted {
            rotation_deg: e.rotation_deg,
            translation_mm: e.translation_mm,
        };
    }
    // NaN-safe: an undetermined figure cannot confirm consistency.
    if !(e.bound_rot_deg <= params.target_rot_deg && e.bound_trans_mm <= params.target_trans_mm) {
        return DriftVerdict::CannotTell(CannotTell::Unobservable {
            rotation_deg: e.rotation_deg,
            translation_mm: e.translation_mm,
            bound_rot_deg: e.bound_rot_deg,
            bound_trans_mm: e.bound_trans_mm,
            confidence_pct: 100.0 * params.detection,
            detectable_rot_deg: e.detectable_rot_deg,
            detectable_trans_mm: e.detectable_trans_mm,
            target_rot_deg: params.target_rot_deg,
            target_trans_mm: params.target_trans_mm,
            sigma_rot_deg: e.sigma_rot_deg,
            sigma_trans_mm: e.sigma_trans_mm,
            pairs,
            reduced_chi2: e.chi2 / e.dof.max(1) as f64,
        });
    }
    DriftVerdict::Consistent
}

fn largest_eigenvalue(m: &Matrix3<f64>) -> f64 {
    let sym = 0.5 * (m + m.transpose());
    SymmetricEigen::new(sym)
        .eigenvalues
        .iter()
        .copied()
        .fold(f64::NEG_INFINITY, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An estimate whose blocks are `(d_theta, s_rot)` in degrees and `(d_t, s_t)` in mm.
    fn estimate_of(
        d_theta_deg: Vector3<f64>,
        s_rot_deg: f64,
        d_t_mm: Vector3<f64>,
        s_t_mm: f64,
        params: &DriftParams,
    ) -> DriftEstimate {
        let rot = BlockFigures::new(d_theta_deg.norm(), s_rot_deg, 0.1, params);
        let trans = BlockFigures::new(d_t_mm.norm(), s_t_mm, 0.75, params);
        DriftEstimate {
            d_theta_rad: d_theta_deg.map(f64::to_radians),
            d_t_m: d_t_mm * 1e-3,
            chi2: 6.0,
            dof: 6,
            ..DriftEstimate::of_blocks(&rot, &trans)
        }
    }

    /// Standard normals from a fixed xorshift stream (Box-Muller).
    fn normals(state: &mut u64) -> [f64; 2] {
        let mut uniform = || {
            *state ^= *state << 13;
            *state ^= *state >> 7;
            *state ^= *state << 17;
            ((*state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        let (u, v) = (uniform(), uniform());
        let r = (-2.0 * u.ln()).sqrt();
        let a = std::f64::consts::TAU * v;
        [r * a.cos(), r * a.sin()]
    }

    /// A calibration's covariance sets `x_sigma` to its worst axis per block; a covariance
    /// that is not finite keeps the defaults.
    #[test]
    fn the_x_sigma_comes_from_the_calibrations_covariance() {
        let mut cov = Matrix6::zeros();
        let rot = [0.01_f64, 0.05, 0.02].map(f64::to_radians);
        let trans_m = [0.3e-3, 0.2e-3, 0.9e-3];
        for k in 0..3 {
            cov[(k, k)] = rot[k] * rot[k];
            cov[(k + 3, k + 3)] = trans_m[k] * trans_m[k];
        }
        // A correlation inside the translation block raises its worst axis.
        cov[(3, 5)] = 0.5 * trans_m[0] * trans_m[2];
        cov[(5, 3)] = cov[(3, 5)];
        let p = DriftParams::default().with_x_covariance(&cov);
        assert!(
            (p.x_sigma_rot_deg - 0.05).abs() < 1e-9,
            "{}",
            p.x_sigma_rot_deg
        );
        let worst = largest_eigenvalue(&cov.fixed_view::<3, 3>(3, 3).into_owned());
        assert!((p.x_sigma_trans_mm - worst.sqrt() * 1e3).abs() < 1e-9);
        assert!(p.x_sigma_trans_mm > 0.9, "{}", p.x_sigma_trans_mm);
        cov[(0, 0)] = f64::NAN;
        let d = DriftParams::default();
        let p = d.clone().with_x_covariance(&cov);
        assert_eq!(
            (p.x_sigma_rot_deg, p.x_sigma_trans_mm),
            (d.x_sigma_rot_deg, d.x_sigma_trans_mm)
        );
    }

    /// The upper bound's promise (module docs): a translation bump of exactly the target
    /// size, in any direction, under an anisotropic error whose worst axis is `s_t`, is
    /// called Consistent in at most `1 - detection` of the checks, whatever `s_t`; and an
    /// unmoved mount is called Consistent whenever `s_t` leaves room for it.
    #[test]
    fn a_target_size_bump_is_called_consistent_at_most_beta_of_the_time() {
        let params = DriftParams::default();
        let mut state = 0x9E37_79B9_7F4A_7C15_u64;
        for s_t in [0.3, 0.6, 0.9, 1.2] {
            let (mut consistent, mut unmoved_consistent, trials) = (0, 0, 4000);
            for _ in 0..trials {
                let [a, b] = normals(&mut state);
                let [c, e0] = normals(&mut state);
                let u = Vector3::new(a, b, c).normalize();
                let [e1, e2] = normals(&mut state);
                // The worst axis at s_t, the others at half of it.
                let error = Vector3::new(e0 * s_t, e1 * 0.5 * s_t, e2 * 0.5 * s_t);
                let bumped = u * params.target_trans_mm + error;
                let tiny = Vector3::new(0.01, 0.0, 0.0);
                let e = estimate_of(tiny, 0.05, bumped, s_t, &params);
                if decide(&e, 6, &params) == DriftVerdict::Consistent {
                    consistent += 1;
                }
                let e = estimate_of(tiny, 0.05, error, s_t, &params);
                if decide(&e, 6, &params) == DriftVerdict::Consistent {
                    unmoved_consistent += 1;
                }
            }
            let missed = f64::from(consistent) / f64::from(trials);
            let unmoved = f64::from(unmoved_consistent) / f64::from(trials);
            eprintln!(
                "s_t {s_t} mm: 3 mm bump called consistent {missed:.3}, unmoved consistent {unmoved:.3}"
            );
            assert!(missed <= 1.0 - params.detection, "s_t {s_t}: {missed}");
            if s_t <= 0.9 {
                // Detectable size 4.2 mm at 0.9 mm: the old rule could not call these
                // consistent; the bound does, most of the time.
                assert!(unmoved > 0.5, "s_t {s_t}: {unmoved}");
            }
        }
    }

    #[test]
    fn the_bound_decides_between_consistent_and_cannot_tell() {
        let params = DriftParams::default();
        let z = normal_quantile(params.detection);
        let s_t = 0.8;
        let tiny = Vector3::new(0.01, 0.0, 0.0);
        let edge = params.target_trans_mm - z * s_t;
        let under = estimate_of(
            tiny,
            0.05,
            Vector3::new(0.0, edge - 0.01, 0.0),
            s_t,
            &params,
        );
        assert_eq!(decide(&under, 6, &params), DriftVerdict::Consistent);
        let over = estimate_of(
            tiny,
            0.05,
            Vector3::new(0.0, edge + 0.01, 0.0),
            s_t,
            &params,
        );
        assert!(matches!(
            decide(&over, 6, &params),
            DriftVerdict::CannotTell(CannotTell::Unobservable { .. })
        ));
        // Above the threshold it is a drift, whatever the bound.
        let drift = estimate_of(tiny, 0.05, Vector3::new(0.0, 0.0, 2.5), s_t, &params);
        assert!(matches!(
            decide(&drift, 6, &params),
            DriftVerdict::Drifted { .. }
        ));
    }

    #[test]
    fn check_motion_rotates_30_to_60_deg_about_spread_axes() {
        let poses = check_camera_poses(&Isometry3::identity(), &CHECK_MOTION);
        let mut motions = Vec::new();
        for i in 0..poses.len() {
            for j in i + 1..poses.len() {
                let (Some(a), Some(b)) = (poses.get(i), poses.get(j)) else {
                    continue;
                };
                let rel = a.inverse() * b;
                let deg = rel.rotation.angle().to_degrees();
                assert!(
                    (30.0..=60.0).contains(&deg),
                    "pair ({i}, {j}): {deg:.1} deg"
                );
                motions.push(RelativeMotion::new(rel, rel));
            }
        }
        let (condition, _) = degeneracy::axis_condition(&motions);
        assert!(condition > 0.5, "axis condition {condition:.3}");
        // Every camera looks at the target's origin from its distance.
        for (p, c) in CHECK_MOTION.iter().zip(&poses) {
            let origin_in_cam = c.inverse() * nalgebra::Point3::origin();
            assert!(origin_in_cam.x.abs() < 1e-9 && origin_in_cam.y.abs() < 1e-9);
            assert!((origin_in_cam.z - p.distance_m).abs() < 1e-9);
        }
    }

    #[test]
    fn the_extra_poses_pair_with_every_first_pose() {
        let first = check_camera_poses(&Isometry3::identity(), &CHECK_MOTION);
        let more = check_camera_poses(&Isometry3::identity(), &CHECK_MOTION_MORE);
        let mut angles = Vec::new();
        for (i, a) in more.iter().enumerate() {
            for (j, b) in first.iter().chain(&more[..i]).enumerate() {
                let deg = (a.inverse() * b).rotation.angle().to_degrees();
                assert!(
                    (20.0..=60.0).contains(&deg),
                    "new {i}, old {j}: {deg:.1} deg"
                );
                angles.push(deg);
            }
        }
        angles.sort_by(f64::total_cmp);
        eprintln!(
            "extra pose pairs: {:.1}-{:.1} deg",
            angles[0],
            angles[angles.len() - 1]
        );
    }
}
