//! Hand-eye **self**-calibration from natural scene features (the paper's pipeline,
//! ARCHITECTURE.md section 6): no board, only the wrist camera's views and the hand poses.
//!
//! # Conventions
//!
//! `X = tool0_from_camera` (maps camera coordinates to flange coordinates). For views `i`, `j`
//! (ARCHITECTURE.md section 6):
//!
//! ```text
//! B_j  = base_from_tool0 at view j                    (kinematics, from /tf)
//! B_ij = tool_i_from_tool_j = B_i^-1 B_j              (hand motion)
//! A_ij = cam_i_from_cam_j                             (camera motion, from the images)
//! B_ij X = X A_ij                                     (rigid mount)
//! ```
//!
//! The paper writes `A X_p = X_p B` with `X_p = camera_from_tool0 = X^-1`.
//!
//! # Pipeline ([`pipeline::self_calibrate`])
//!
//! 1. ORB with the ORB-SLAM quadtree on every view ([`crate::features`]); a view with fewer
//!    than [`SelfCalParams::min_features`] keypoints (dark, over-exposed or textureless) is
//!    refused with its count and mean intensity.
//! 2. Pairs ([`pairs`]): every `i < j` whose hand rotation is at least
//!    [`SelfCalParams::min_pair_rotation_deg`]; brute-force Hamming + GMS; a pair needs
//!    [`SelfCalParams::min_matches`] GMS inliers (overlap).
//! 3. Relative camera motion per pair ([`motion`]): RGB-D: keypoints back-projected with their
//!    registered depth through the undistorted camera model, 3D-3D RANSAC + Umeyama + depth-
//!    noise-weighted refinement; mono: undistorted normalised points, 5-point essential
//!    LO-RANSAC with cheirality, `|t_A| = 1`, every hypothesis constrained to rotate by the
//!    hand's angle (screw congruence, [`SelfCalParams::mono_angle_tolerance_deg`]).
//! 4. Linear initialisation over all pairs (the paper's Kronecker form, eqs. 10-13,
//!    [`crate::handeye::kronecker`]), then Levenberg-Marquardt on the pose residuals (`ours`,
//!    Huber); pairs whose rotation residual exceeds `max_pair_residual_factor` x the median
//!    (at least `min_pair_residual_limit_deg`) are rejected and the LM is re-run on the
//!    others.
//! 5. RGB-D, when [`Steps::final_refinement`] asks for it (the paper's method,
//!    [`SelfCalMethod::Paper`]): Levenberg-Marquardt on the paper's eq. 15 over the features
//!    tracked across the views ([`tracks`]) with triangulated world points ([`eq15`]), or
//!    over X and the world points jointly ([`ba`], `paper+ba`). Off in ours: with noisy hand
//!    poses it is less accurate than step 4.
//!
//! # Methods and steps
//!
//! [`SelfCalMethod::Paper`] runs the paper's method as written; ours adds the [`Steps`]
//! (3D-3D RANSAC, the pose LM, pair rejection, the mono angle prior, guided round and
//! epipolar refinement, the consistency refusal), each switchable ([`method`]).
//!
//! # Monocular scale
//!
//! Each essential matrix gives `t_A` only up to its own scale `s_ij` (no global SfM frame is
//! built). The paper's `[t_A]x` form cancels it: with `u = R_X t_A / |t_A|`,
//! `[u]x ((R_B - I) t_X + t_B) = 0` holds whatever `s_ij` is. So:
//!
//! 1. `R_X` from the rotations alone (Kronecker null space, scale-free);
//! 2. with `R_X` fixed, `t_X` by linear least squares on the projected equations
//!    `(I - u u^T)(R_B - I) t_X = -(I - u u^T) t_B` ([`motion::mono_translation`]), and each
//!    pair's scale `s_ij = u^T((R_B - I) t_X + t_B)` (metres; a pair with `s_ij <= 0`
//!    contradicts its own cheirality and is rejected);
//! 3. with the scales fixed, the metric motions `(R_A, s_ij t_A)` go to the `ours` LM
//!    (`scale_free = false`: the scales are already metric), which refines `R_X` and `t_X`;
//! 4. back to 2 with the new `R_X`, [`MONO_SCALE_ALTERNATIONS`] times; before the last round
//!    pairs whose rotation residual exceeds `max_pair_residual_factor` x the median are
//!    rejected.
//!
//! Steps 2 and 3 minimise the same cost (the pose residuals of `B X = X A` with free per-pair
//! scales) over complementary blocks, so this is block-coordinate descent to the joint
//! least-squares optimum over X and the per-pair scales. [`crate::handeye::HandEyeSolution::scale`] is
//! then 1;
//! the per-pair scales are in [`pipeline::PairReport::scale`]. The eq. 15 point refinement
//! runs in RGB-D mode only (mono points would carry the per-pair scales).
//!
//! **Two rounds in mono.** A scene dominated by one plane (a cabinet face) leaves the
//! essential matrix weakly determined, so blind estimates scatter by degrees. The X of a
//! first round (no consistency refusal) predicts every pair's motion `A = X^-1 B X`; each
//! pair is re-estimated from that prediction by Sampson refinement with guided inlier
//! selection ([`crate::relpose::essential::refine_essential_guided`], free to move away from
//! the prediction), keeping its blind estimate where that fails, and the second round is
//! solved and checked. On the simulated cabinet views (640x512, noise 0.05) this lowered
//! the median pair rotation residual from 1.61 to 1.27 deg.
//!
//! # Over the log ([`stage`])
//!
//! The calibration stage runs this pipeline over the message stream: it pairs every capture
//! with the hand pose from its TF buffer, keeps the informative views, publishes
//! `/calibration/hand_eye`, `/calibration/matches` and the camera edge on `/tf` (the nominal
//! mount of [`robot::camera_mount`] until a calibration is accepted), and its refusals on
//! `/rosout`.
//!
//! # Drift check ([`drift`])
//!
//! Before operating (self-maintenance), [`check_drift`] runs steps 1-3 on a few
//! views of the check motion ([`CHECK_MOTION`]) and tests the `X` in use against their
//! AX=XB residuals: Consistent, Drifted (with the estimated change of the mount) or
//! CannotTell (with the reason), thresholds from the measurement noise.
//!
//! # Refusals (never a wrong X)
//!
//! An X that its own pairs do not support ([`ConsistencyLimits`]: too few of the pairs with a
//! camera motion kept, too little redundancy, large residuals or a large uncertainty), too
//! few views, images of the wrong size, dark/textureless views, too few usable pairs,
//! degenerate hand motion (single rotation axis, pure translation: [`crate::handeye`]'s
//! refusals), missing TF or stamps outside its range, depth without a colour image at the
//! same stamp ([`messages`]). Ground truth (`/sim/...`) is never read.

pub mod ba;
pub mod carry;
pub mod drift;
pub mod epipolar;
pub mod eq15;
pub mod hand_error;
pub mod image_motion;
pub mod messages;
pub mod method;
pub mod motion;
pub mod pairs;
pub mod pipeline;
mod solve;
pub mod stage;
pub mod tracks;
pub mod views;
pub mod yaml;

pub use carry::{AcceptedCalibration, Carried, CarryFinder, CheckReference};
pub use drift::{CHECK_MOTION, CannotTell, DriftParams, DriftReport, DriftVerdict, check_drift};
pub use hand_error::{SharedHandError, ViewHandError};
pub use messages::views_from_messages;
pub use method::{FinalRefinement, STEP_NAMES, SelfCalMethod, Steps};
pub use pipeline::{ConsistencyLimits, SelfCalParams, SelfCalResult, self_calibrate};
pub use stage::{CalibrationStage, CalibrationStageConfig};
pub use views::CalibView;
pub use yaml::{calibration_yaml, result_json};

use crate::features::FeatureError;
use crate::handeye::HandEyeError;

/// Fewest views the pipeline accepts (two independent motions need three views).
pub const MIN_VIEWS: usize = 3;
/// Fewest usable pairs (relative motions) the pipeline accepts.
pub const MIN_PAIRS: usize = 2;
/// Alternations between the per-pair scales and X in mono mode (module docs).
pub const MONO_SCALE_ALTERNATIONS: usize = 4;

/// Depth present (3D-3D motions, metric) or colour only (essential matrices, scale from the
/// hand motions).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Mode {
    /// Registered depth in every view.
    Rgbd,
    /// Colour (or grey) only.
    Mono,
}

impl Mode {
    /// The name of ARCHITECTURE.md section 4 (`rgbd`, `mono`).
    pub fn name(self) -> &'static str {
        match self {
            Mode::Rgbd => "rgbd",
            Mode::Mono => "mono",
        }
    }
}

impl std::fmt::Display for Mode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Which rule of [`ConsistencyLimits`] refused a solution.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ConsistencyRule {
    /// Too few of the pairs with a camera motion agree with X.
    Consensus,
    /// Too few residual degrees of freedom to judge X.
    Redundancy,
    /// The median rotation residual is too large.
    Residual,
    /// The uncertainty of X is too large.
    Uncertainty,
}

impl std::fmt::Display for ConsistencyRule {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            ConsistencyRule::Consensus => "most pairs with a camera motion disagree with it",
            ConsistencyRule::Redundancy => "too few pairs agree to judge it",
            ConsistencyRule::Residual => "the hand and camera motions disagree under it",
            ConsistencyRule::Uncertainty => "it is too uncertain",
        })
    }
}

/// Why a self-calibration was refused. Every variant carries the numbers that explain it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SelfCalError {
    /// Fewer views than [`MIN_VIEWS`].
    #[error(
        "too few views: got {got}, need at least {need} (capture more views with varied wrist rotations)"
    )]
    TooFewViews {
        /// Views given.
        got: usize,
        /// Views needed.
        need: usize,
    },
    /// An image does not have the camera model's size.
    #[error(
        "view {index}: image is {width}x{height}, the camera model is {expected_width}x{expected_height}"
    )]
    ImageSize {
        /// View index.
        index: usize,
        /// Image width.
        width: u32,
        /// Image height.
        height: u32,
        /// Camera width.
        expected_width: u32,
        /// Camera height.
        expected_height: u32,
    },
    /// A depth image has the wrong number of pixels.
    #[error("view {index}: depth has {got} pixels, the image has {expected}")]
    DepthSize {
        /// View index.
        index: usize,
        /// Depth pixels.
        got: usize,
        /// Image pixels.
        expected: usize,
    },
    /// Some views have depth and others do not.
    #[error(
        "{with_depth} views have depth and {without_depth} do not: depth must be in all views or none"
    )]
    MixedDepth {
        /// Views with depth.
        with_depth: usize,
        /// Views without.
        without_depth: usize,
    },
    /// A hand pose is not finite.
    #[error("view {index}: hand pose base_from_tool0 is not finite")]
    NonFinitePose {
        /// View index.
        index: usize,
    },
    /// Too few ORB keypoints in a view: too dark, washed out or textureless.
    #[error(
        "view {index} (stamp {stamp_ns} ns): only {features} ORB features, need {need}; mean intensity {mean_intensity:.1}/255, contrast (std) {contrast:.1}: the image is too dark, washed out or textureless"
    )]
    TooFewFeatures {
        /// View index.
        index: usize,
        /// Its stamp.
        stamp_ns: u64,
        /// Keypoints found.
        features: usize,
        /// Keypoints needed.
        need: usize,
        /// Mean grey level.
        mean_intensity: f64,
        /// Standard deviation of the grey levels.
        contrast: f64,
    },
    /// Too few view pairs gave a relative motion.
    #[error(
        "only {usable} of {candidates} view pairs gave a camera motion, need {need} ({too_little_rotation} with too little hand rotation, {too_few_matches} with too few matches, {motion_failed} where the motion estimate failed, {rejected_later} rejected by residual): views overlap too little or the images are too poor"
    )]
    TooFewPairs {
        /// Pairs with a motion.
        usable: usize,
        /// All pairs considered.
        candidates: usize,
        /// Pairs needed.
        need: usize,
        /// Pairs dropped for a small hand rotation.
        too_little_rotation: usize,
        /// Pairs dropped for too few matches.
        too_few_matches: usize,
        /// Pairs whose motion estimation failed.
        motion_failed: usize,
        /// Pairs rejected by residual.
        rejected_later: usize,
    },
    /// The final X fails a consistency rule ([`ConsistencyLimits`]): it is not returned.
    #[error(
        "inconsistent {mode} self-calibration refused ({rule}): {pairs_used} of {pairs_with_motion} pairs with a camera motion used (need {:.0}%), {dof} residual degrees of freedom (need {}{}), median residual {residual_rot_deg:.3} deg / {residual_trans_mm:.2} mm (limit {} deg), 1-sigma {sigma_rot_deg:.3} deg / {sigma_trans_mm:.2} mm (limits {} deg / {} mm); the views do not determine X reliably: capture more views that overlap (a textured, well-lit scene at the working distance, wrist rotations of 10-40 deg between neighbours){}",
        100.0 * limits.min_kept_fraction,
        limits.min_dof,
        if *mode == Mode::Mono { format!(" and {} pairs", limits.min_mono_pairs) } else { String::new() },
        limits.max_residual_rot_deg,
        limits.max_sigma_rot_deg,
        limits.max_sigma_trans_mm,
        if *mode == Mode::Mono { ", or use depth (mode rgbd)" } else { "" }
    )]
    Inconsistent {
        /// RGB-D or mono.
        mode: Mode,
        /// The first rule that failed.
        rule: ConsistencyRule,
        /// Pairs used by the final X.
        pairs_used: usize,
        /// Pairs that gave a camera motion.
        pairs_with_motion: usize,
        /// Residual degrees of freedom.
        dof: usize,
        /// Median rotation residual over the used pairs, degrees.
        residual_rot_deg: f64,
        /// Median translation residual over the used pairs, millimetres.
        residual_trans_mm: f64,
        /// 1-sigma rotation uncertainty of X, degrees.
        sigma_rot_deg: f64,
        /// 1-sigma translation uncertainty of X, millimetres.
        sigma_trans_mm: f64,
        /// The limits applied.
        limits: ConsistencyLimits,
        /// The X that was refused: for analysing the failure (and for experiments that score
        /// what a refusal prevented), never to be used as a calibration.
        refused_tool0_from_camera: Box<nalgebra::Isometry3<f64>>,
    },
    /// The method's final refinement compares depth-measured points (eq. 15): no depth, no
    /// answer.
    #[error(
        "the {refinement} refinement (the paper's eq. 15) needs registered depth in every view; these views have none (use --method ours for the monocular path)"
    )]
    MethodNeedsDepth {
        /// The refinement asked for (`eq15`, `ba`).
        refinement: &'static str,
    },
    /// The hand-eye solver refused the motions (degenerate motion etc.).
    #[error("hand-eye solve: {0}")]
    HandEye(#[from] HandEyeError),
    /// The feature front end failed (bad parameters, image too small).
    #[error("features: {0}")]
    Features(String),
    /// No colour image in the messages.
    #[error("no colour image on {topic} ({messages} messages read)")]
    NoImages {
        /// Topic searched.
        topic: String,
        /// Messages given.
        messages: usize,
    },
    /// No camera_info in the messages.
    #[error("no camera intrinsics on {topic}")]
    NoCameraInfo {
        /// Topic searched.
        topic: String,
    },
    /// The camera_info cannot be used.
    #[error("camera_info unusable: {reason}")]
    BadCameraInfo {
        /// What is wrong.
        reason: String,
    },
    /// An image encoding this pipeline does not read.
    #[error(
        "{topic}: unsupported encoding {encoding:?} (colour: rgb8, bgr8, mono8; depth: 32FC1, 16UC1)"
    )]
    UnsupportedEncoding {
        /// Topic.
        topic: String,
        /// Encoding.
        encoding: String,
    },
    /// An image message whose buffer does not hold its pixels.
    #[error(
        "{topic} at {stamp_ns} ns: {width}x{height} image with step {step} needs {needed} bytes, has {len}"
    )]
    BadImageBuffer {
        /// Topic.
        topic: String,
        /// Stamp.
        stamp_ns: u64,
        /// Width.
        width: u32,
        /// Height.
        height: u32,
        /// Row step, bytes.
        step: u32,
        /// Bytes needed.
        needed: usize,
        /// Bytes present.
        len: usize,
    },
    /// A stamp that cannot be converted to the robot clock.
    #[error("{topic}: invalid stamp ({reason})")]
    BadStamp {
        /// Topic.
        topic: String,
        /// Why.
        reason: String,
    },
    /// No hand pose for an image: TF missing or the stamp outside the buffered range.
    #[error("view {index} (image stamp {stamp_ns} ns): no hand pose {parent} -> {child}: {reason}")]
    MissingTf {
        /// View index.
        index: usize,
        /// Image stamp.
        stamp_ns: u64,
        /// Parent frame.
        parent: String,
        /// Child frame.
        child: String,
        /// The TF buffer's explanation (unknown frame, extrapolation with the range).
        reason: String,
    },
    /// A depth image without a colour image at the same stamp (or the reverse in RGB-D).
    #[error(
        "depth/colour stamp mismatch: {what} at {stamp_ns} ns has no partner within {tolerance_ns} ns (nearest {nearest_ns:?} ns)"
    )]
    StampMismatch {
        /// `depth image` or `colour image`.
        what: &'static str,
        /// Its stamp.
        stamp_ns: u64,
        /// Nearest stamp of the other stream, if any.
        nearest_ns: Option<u64>,
        /// Tolerance used.
        tolerance_ns: u64,
    },
}

impl From<FeatureError> for SelfCalError {
    fn from(e: FeatureError) -> Self {
        SelfCalError::Features(e.to_string())
    }
}
