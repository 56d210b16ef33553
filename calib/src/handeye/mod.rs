//! Hand-eye calibration from poses: solvers of `B X = X A` (eye-in-hand).
//!
//! # Conventions
//!
//! Transforms are named `a_from_b` (they map coordinates in `b` to coordinates in `a`);
//! f64, SI units (metres, radians) inside, degrees and millimetres only in reported figures.
//! The unknown is **`X = tool0_from_camera`** (camera coordinates to flange coordinates).
//! Inputs are the hand poses `base_from_tool0` (robot kinematics) and the eye poses
//! `world_from_camera` (a board, an SfM frame, possibly metric only up to one scale).
//! For two views `i`, `j` the relative motions are
//!
//! ```text
//! B_ij = tool_i_from_tool_j = (base_from_tool_i)^-1 base_from_tool_j      (hand motion)
//! A_ij = cam_i_from_cam_j   = (world_from_cam_i)^-1 world_from_cam_j      (eye motion)
//! B_ij X = X A_ij                                                          (rigid mount)
//! ```
//!
//! split into `R_B R_X = R_X R_A` and `(R_B - I) t_X = R_X t_A - t_B`. With an unknown eye
//! scale `s` (metres per eye unit), `t_A` becomes `s t_A`.
//!
//! Pairs are taken in OpenCV's order (`calibrateHandEye`, `calibration_handeye.cpp`): for
//! `i < j` the motion used is the one from view `i` to view `j` expressed in frame `j`, i.e.
//! `B_ji = tool_j_from_tool_i` with `A_ji`, which satisfies the same equation. This makes the
//! classical methods reproduce OpenCV to rounding on identical inputs.
//!
//! # Methods
//!
//! | [`Method`] | source | what it solves |
//! |---|---|---|
//! | `ours` | Kronecker init, then Levenberg-Marquardt ([`refine`]) | robust (Huber) pose residuals over all pairs, lever-decorrelated |
//! | `kronecker` | the paper's eq. (ARCHITECTURE.md section 6), [`kronecker`] | `[I9 - R_A (x) R_B, 0; [t_A]x (x) t_B^T, [t_A]x (I - R_A)] [vec R_Xp; t_Xp] = 0` |
//! | `tsai` | Tsai & Lenz 1989, eq. 12-15, [`tsai`] | modified Rodrigues vectors, then translation |
//! | `park` | Park & Martin 1994, eq. 13-15, [`park`] | `R_X = (M^T M)^-1/2 M^T`, `M = sum beta alpha^T` |
//! | `horaud` | Horaud & Dornaika 1995, sec. 3.1, [`horaud`] | quaternion eigenvector |
//! | `andreff` | Andreff, Horaud & Espiau 1999, eq. 10, [`andreff`] | linear 12-unknown Kronecker system |
//! | `daniilidis` | Daniilidis 1999, eq. 31-35, [`daniilidis`] | dual-quaternion SVD |
//!
//! # Command line
//!
//! `rodlog calib handeye --hand H --eye E [--method M] [--scale-free] [--json]` is
//! [`solve_tum`] on the two files' texts followed by [`calibration_json`] (mode `poses`).
//!
//! # Degenerate cases (refused, never a wrong X)
//!
//! Fewer than 3 poses, non-finite poses, pure translations (all hand rotations below
//! [`HandEyeOptions::min_rotation_deg`]), rotations about a single axis (axis condition below
//! [`HandEyeOptions::min_axis_condition`], see [`degeneracy`]), hand/eye rotation angles that
//! disagree on most pairs, and numerical failures all return a [`HandEyeError`] whose text
//! says what is wrong and what motion fixes it.

use std::fmt;
use std::str::FromStr;

use nalgebra::{Isometry3, Matrix3, Matrix6, Vector3};
use serde::Serialize;

pub mod andreff;
pub mod daniilidis;
pub mod degeneracy;
mod geometry;
pub mod horaud;
pub mod kronecker;
pub mod park;
pub mod pose_file;
pub mod refine;
pub mod translation;
pub mod tsai;
pub mod uncertainty;

pub use pose_file::{PoseFileError, StampedPose};
pub use refine::{RobustLoss, Termination};

/// Minimum number of poses (views): two motions with non-parallel axes need three views.
pub const MIN_POSES: usize = 3;
/// Minimum number of relative motions for [`solve_motions`].
pub const MIN_MOTIONS: usize = 2;

/// A hand-eye solver, named as on the CLI (`rodlog calib handeye --method M`, ARCHITECTURE.md section 4).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// `ours`: Kronecker/SVD initialisation, then robust Levenberg-Marquardt on the pose
    /// residuals of all pairs ([`refine`]).
    #[default]
    Ours,
    /// `kronecker`: the paper's linear Kronecker/SVD form ([`kronecker`]).
    Kronecker,
    /// `tsai`: Tsai & Lenz 1989 ([`tsai`]).
    Tsai,
    /// `park`: Park & Martin 1994 ([`park`]).
    Park,
    /// `horaud`: Horaud & Dornaika 1995 ([`horaud`]).
    Horaud,
    /// `andreff`: Andreff, Horaud & Espiau 1999 ([`andreff`]).
    Andreff,
    /// `daniilidis`: Daniilidis 1999 ([`daniilidis`]).
    Daniilidis,
}

impl Method {
    /// All methods, `ours` first.
    pub const ALL: [Method; 7] = [
        Method::Ours,
        Method::Kronecker,
        Method::Tsai,
        Method::Park,
        Method::Horaud,
        Method::Andreff,
        Method::Daniilidis,
    ];

    /// The CLI name (`ours`, `kronecker`, `tsai`, `park`, `horaud`, `andreff`, `daniilidis`).
    pub fn name(self) -> &'static str {
        match self {
            Method::Ours => "ours",
            Method::Kronecker => "kronecker",
            Method::Tsai => "tsai",
            Method::Park => "park",
            Method::Horaud => "horaud",
            Method::Andreff => "andreff",
            Method::Daniilidis => "daniilidis",
        }
    }

    /// Whether the method can estimate the unknown eye scale (`--scale-free`): those whose
    /// rotation does not depend on the eye translations.
    pub fn supports_scale_free(self) -> bool {
        !matches!(self, Method::Andreff | Method::Daniilidis)
    }
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Error of [`Method::from_str`]: the name is not one of [`Method::ALL`].
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "unknown hand-eye method {name:?}; expected one of ours, kronecker, tsai, park, horaud, andreff, daniilidis"
)]
pub struct UnknownMethod {
    /// The name that was given.
    pub name: String,
}

impl FromStr for Method {
    type Err = UnknownMethod;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Method::ALL
            .into_iter()
            .find(|m| m.name().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| UnknownMethod { name: s.to_owned() })
    }
}

/// Which view pairs `(i, j)` become relative motions.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PairSelection {
    /// All `n (n - 1) / 2` pairs `i < j` in lexicographic order (what OpenCV 4.x
    /// `calibrateHandEye` uses, and rodlog's default).
    #[default]
    All,
    /// Consecutive pairs `(i, i + 1)` only (`n - 1` motions; for sequences where distant
    /// views are unrelated, and for comparison with tools that use them).
    Consecutive,
}

/// Which of the two pose sequences a non-finite pose came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PoseSource {
    /// `base_from_tool0`.
    Hand,
    /// `world_from_camera`.
    Eye,
    /// A relative motion given to [`solve_motions`] (its `a` or `b`).
    Motion,
}

impl fmt::Display for PoseSource {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            PoseSource::Hand => "hand",
            PoseSource::Eye => "eye",
            PoseSource::Motion => "motion",
        })
    }
}

/// Options of [`solve`] and [`solve_motions`]. Every default is documented on its field.
#[derive(Debug, Clone, PartialEq)]
pub struct HandEyeOptions {
    /// Solver. Default [`Method::Ours`].
    pub method: Method,
    /// The eye translations are metric only up to one unknown scale, which is estimated
    /// (`HandEyeSolution::scale`, metres per eye unit). Default `false`.
    pub scale_free: bool,
    /// Pair selection of [`solve`]. Default [`PairSelection::All`].
    pub pairs: PairSelection,
    /// Robust loss of the refinement (`ours`). Default `Huber { k: 2.0 }` on residuals
    /// normalised by their scale (see [`refine`]).
    pub loss: RobustLoss,
    /// Scale (1 sigma) of a pair's rotation residual, radians. Default `None`: estimated
    /// robustly from the initial residuals (median norm / 1.5382, the median of a 3-D
    /// standard normal's norm), floored at [`refine::MIN_RESIDUAL_SCALE`].
    pub rot_scale_rad: Option<f64>,
    /// Scale (1 sigma) of a pair's translation residual, metres. Default `None`: estimated
    /// like `rot_scale_rad`.
    pub trans_scale_m: Option<f64>,
    /// Maximum Levenberg-Marquardt iterations. Default 100.
    pub max_iterations: usize,
    /// Refuse when the rotation-axis condition (see [`degeneracy`]) is below this.
    /// Default [`degeneracy::MIN_AXIS_CONDITION`] (0.05).
    pub min_axis_condition: f64,
    /// Refuse as a pure translation when no hand motion rotates more than this, degrees.
    /// Default [`degeneracy::MIN_ROTATION_DEG`] (1 deg).
    pub min_rotation_deg: f64,
    /// A pair whose hand and eye rotation angles differ by more than this (degrees; they
    /// are equal for a rigid mount) is rejected; when more than half are, the input is
    /// refused. Default [`degeneracy::MAX_ANGLE_MISMATCH_DEG`] (3 deg).
    pub max_angle_mismatch_deg: f64,
    /// [`solve`] sets each motion's eye lever arm to the world origin seen from the camera
    /// (right for board poses, whose error is mostly a rotation about the camera); `false`
    /// leaves it zero (e.g. SfM poses with an arbitrary origin). Default `true`.
    pub eye_lever: bool,
}

impl Default for HandEyeOptions {
    fn default() -> Self {
        Self {
            method: Method::Ours,
            scale_free: false,
            pairs: PairSelection::All,
            loss: RobustLoss::default(),
            rot_scale_rad: None,
            trans_scale_m: None,
            max_iterations: 100,
            min_axis_condition: degeneracy::MIN_AXIS_CONDITION,
            min_rotation_deg: degeneracy::MIN_ROTATION_DEG,
            max_angle_mismatch_deg: degeneracy::MAX_ANGLE_MISMATCH_DEG,
            eye_lever: true,
        }
    }
}

impl HandEyeOptions {
    /// Default options with the given method.
    pub fn with_method(method: Method) -> Self {
        Self {
            method,
            ..Self::default()
        }
    }
}

/// One relative motion pair for [`solve_motions`]: `b X = X a`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RelativeMotion {
    /// Eye motion `cam_i_from_cam_j` (its translation possibly up to the unknown scale).
    pub a: Isometry3<f64>,
    /// Hand motion `tool_i_from_tool_j` (metric).
    pub b: Isometry3<f64>,
    /// Relative weight (> 0; 1 for all pairs equal). Multiplies the pair's squared
    /// residuals in `ours`/`kronecker` and its equations in the classical methods.
    pub weight: f64,
    /// Eye lever arm (metres, eye units when scale-free): where, in the frame of the
    /// motion's first camera (`cam_i` of `a = cam_i_from_cam_j`), the point lies that the
    /// eye poses were measured against (the board or world origin). Zero (the default)
    /// when unknown. A pose from a board (PnP) errs mostly by a rotation `d` about the
    /// camera, which moves `t_A` by `lever x d`; `ours` uses it to decorrelate the pair's
    /// translation residual from its rotation residual (see [`refine`]). Only `ours` uses it.
    pub eye_lever_m: Vector3<f64>,
}

impl RelativeMotion {
    /// A motion with weight 1 and no lever arm.
    pub fn new(a: Isometry3<f64>, b: Isometry3<f64>) -> Self {
        Self {
            a,
            b,
            weight: 1.0,
            eye_lever_m: Vector3::zeros(),
        }
    }
}

/// Result of [`solve`] / [`solve_motions`].
#[derive(Debug, Clone, PartialEq)]
pub struct HandEyeSolution {
    /// `X = tool0_from_camera`.
    pub tool0_from_camera: Isometry3<f64>,
    /// Metres per eye translation unit (exactly 1 unless scale-free).
    pub scale: f64,
    /// Method that produced the estimate.
    pub method: Method,
    /// Number of views (poses) given to [`solve`]; for [`solve_motions`], motions + 1.
    pub views: usize,
    /// Number of pairs (relative motions) used.
    pub pairs: usize,
    /// Indices (into the pair list) of pairs rejected for a hand/eye rotation-angle mismatch.
    pub rejected_pairs: Vec<usize>,
    /// Median over the used pairs of the rotation angle of `(B X)^-1 (X A)`, degrees.
    pub residual_rot_deg: f64,
    /// Median over the used pairs of the translation norm of `(B X)^-1 (X A)` (with the
    /// eye translations times `scale`), millimetres.
    pub residual_trans_mm: f64,
    /// 1-sigma rotation uncertainty of X, degrees (see [`uncertainty`]).
    pub sigma_rot_deg: f64,
    /// 1-sigma translation uncertainty of X, millimetres (see [`uncertainty`]).
    pub sigma_trans_mm: f64,
    /// The covariance of X behind the sigmas, parameters `(theta, t)` (rad, m; `theta` the
    /// rotation vector of `R R_X^T`): its 3x3 blocks are what a Mahalanobis test of the
    /// rotation and the translation error takes.
    pub covariance: Option<Matrix6<f64>>,
    /// Where [`Self::covariance`] comes from.
    pub uncertainty: UncertaintySource,
    /// Rotation-axis conditioning of the hand motions in `[0, 1]` (see [`degeneracy`]).
    pub condition: f64,
    /// Largest hand/eye rotation-angle difference over the used pairs, degrees.
    pub max_angle_mismatch_deg: f64,
    /// Levenberg-Marquardt iterations (0 for the linear methods).
    pub iterations: usize,
    /// Why the refinement stopped ([`Termination::Linear`] for the linear methods).
    pub termination: Termination,
}

/// How the uncertainty of a [`HandEyeSolution`] was obtained ([`uncertainty`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum UncertaintySource {
    /// The Gauss-Newton covariance at the estimate, `P / M` inflated.
    Linearised,
    /// The jackknife over views ([`uncertainty::jackknife_over_views`]), from
    /// [`uncertainty::MIN_JACKKNIFE_VIEWS`] views (the self-calibration adds to it the hand
    /// errors no resampling of the views shows, [`crate::selfcal::hand_error`]).
    Jackknife,
}

impl HandEyeSolution {
    /// Takes `covariance` (from `source`) as the solution's uncertainty, its sigmas with it.
    pub fn set_covariance(&mut self, covariance: Matrix6<f64>, source: UncertaintySource) {
        (self.sigma_rot_deg, self.sigma_trans_mm) = uncertainty::sigma_of(&covariance);
        self.covariance = Some(covariance);
        self.uncertainty = source;
    }
}

/// Why a hand-eye calibration was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum HandEyeError {
    /// Hand and eye sequences differ in length.
    #[error("{hand} hand poses but {eye} eye poses: they must pair one to one")]
    LengthMismatch {
        /// Number of hand poses.
        hand: usize,
        /// Number of eye poses.
        eye: usize,
    },
    /// Too few poses.
    #[error(
        "{got} poses given, at least {need} needed: record more views, rotating the wrist about at least two non-parallel axes by more than 10 deg between them"
    )]
    TooFewPoses {
        /// Poses given.
        got: usize,
        /// Poses needed.
        need: usize,
    },
    /// Too few relative motions (after rejection of inconsistent pairs).
    #[error(
        "{got} relative motions usable, at least {need} needed: add motions rotating about at least two non-parallel axes by more than 10 deg"
    )]
    TooFewMotions {
        /// Motions usable.
        got: usize,
        /// Motions needed.
        need: usize,
    },
    /// A pose has NaN or infinite entries.
    #[error("{which} pose {index} has NaN or infinite entries: fix or drop that view")]
    NonFinitePose {
        /// Index in its sequence.
        index: usize,
        /// Which sequence.
        which: PoseSource,
    },
    /// A motion weight is not finite and positive.
    #[error("motion {index} has weight {weight}: weights must be finite and > 0")]
    InvalidWeight {
        /// Motion index.
        index: usize,
        /// The weight.
        weight: f64,
    },
    /// No hand motion rotates: the rotation of X is unobservable.
    #[error(
        "pure translation: the largest hand rotation between views is {max_angle_deg:.3} deg (< {min_deg} deg), so the camera rotation cannot be observed; rotate the wrist about at least two non-parallel axes by more than 10 deg between views"
    )]
    PureTranslation {
        /// Largest hand rotation angle over the pairs, degrees.
        max_angle_deg: f64,
        /// Threshold, degrees.
        min_deg: f64,
    },
    /// The hand rotation axes are (nearly) parallel: X is not determined about that axis.
    #[error(
        "degenerate rotations: rotation-axis condition {condition:.3e} < {threshold} (the hand rotates about nearly one axis, ({axis_x:.3}, {axis_y:.3}, {axis_z:.3}) in tool0); X is undetermined about it. Rotate about at least two non-parallel axes by more than 10 deg (e.g. tilt the wrist as well as turning it)"
    )]
    DegenerateRotations {
        /// `sqrt(lambda_2 / lambda_1)` of the rotation-vector scatter.
        condition: f64,
        /// Refusal threshold.
        threshold: f64,
        /// Dominant axis, x component.
        axis_x: f64,
        /// Dominant axis, y component.
        axis_y: f64,
        /// Dominant axis, z component.
        axis_z: f64,
    },
    /// Hand and eye rotation angles disagree on most pairs (a rigid mount keeps them equal).
    #[error(
        "inconsistent motions: {rejected} of {pairs} pairs have hand and eye rotation angles differing by more than {threshold_deg} deg (worst {worst_deg:.3} deg at pair {worst_pair}); check that hand and eye poses are paired at the same instants, are poses of the moving frame in the fixed frame, and that the camera is rigidly mounted"
    )]
    InconsistentMotions {
        /// Rejected pairs.
        rejected: usize,
        /// Pairs.
        pairs: usize,
        /// Threshold, degrees.
        threshold_deg: f64,
        /// Worst mismatch, degrees.
        worst_deg: f64,
        /// Index of the worst pair.
        worst_pair: usize,
    },
    /// Scale-free: the eye translations are all (nearly) zero.
    #[error(
        "scale-free: the eye translations are too small to estimate the scale (largest {max_norm:.3e} units); translate the camera between views"
    )]
    ScaleUnobservable {
        /// Largest eye translation norm.
        max_norm: f64,
    },
    /// Scale-free: the estimated scale is not positive.
    #[error(
        "scale-free: estimated scale {scale:.6e} is not positive: the eye translations do not agree with the hand motions (wrong pairing or a mirrored eye frame?)"
    )]
    NonPositiveScale {
        /// The estimate.
        scale: f64,
    },
    /// The method cannot estimate an unknown eye scale.
    #[error(
        "method {method} does not support scale-free input; use ours, kronecker, tsai, park or horaud"
    )]
    ScaleFreeUnsupported {
        /// The method.
        method: Method,
    },
    /// The solver's linear algebra failed or produced non-finite numbers.
    #[error("{method}: numerical failure ({what}); the motions are degenerate or inconsistent")]
    NumericalFailure {
        /// The method.
        method: Method,
        /// What failed.
        what: &'static str,
    },
    /// A pose file could not be read.
    #[error(transparent)]
    PoseFile(#[from] PoseFileError),
}

/// Builds the relative motions of [`solve`] from paired poses (see the module docs for the
/// orientation of each pair), with weight 1 and the world origin as eye lever arm.
///
/// Returns the motions without validation.
pub fn relative_motions(
    hand: &[Isometry3<f64>],
    eye: &[Isometry3<f64>],
    pairs: PairSelection,
) -> Vec<RelativeMotion> {
    let n = hand.len().min(eye.len());
    let mut out = Vec::new();
    let mut push = |i: usize, j: usize| {
        if let (Some(hi), Some(hj), Some(ei), Some(ej)) =
            (hand.get(i), hand.get(j), eye.get(i), eye.get(j))
        {
            let cam_j_from_world = ej.inverse();
            out.push(RelativeMotion {
                // tool_j_from_tool_i and cam_j_from_cam_i (OpenCV's Hg_ij, Hc_ij).
                b: hj.inverse() * hi,
                a: cam_j_from_world * ei,
                weight: 1.0,
                // The world origin seen from cam_j.
                eye_lever_m: cam_j_from_world.translation.vector,
            });
        }
    };
    match pairs {
        PairSelection::All => {
            for i in 0..n {
                for j in i + 1..n {
                    push(i, j);
                }
            }
        }
        PairSelection::Consecutive => {
            for i in 0..n.saturating_sub(1) {
                push(i, i + 1);
            }
        }
    }
    out
}

/// Hand-eye calibration from paired poses: `hand[k] = base_from_tool0`,
/// `eye[k] = world_from_camera` at the same instant. Returns `X = tool0_from_camera`.
///
/// # Errors
///
/// [`HandEyeError::LengthMismatch`], [`HandEyeError::TooFewPoses`] (< [`MIN_POSES`]),
/// [`HandEyeError::NonFinitePose`] (naming the index), and every refusal of
/// [`solve_motions`].
pub fn solve(
    hand: &[Isometry3<f64>],
    eye: &[Isometry3<f64>],
    opts: &HandEyeOptions,
) -> Result<HandEyeSolution, HandEyeError> {
    if hand.len() != eye.len() {
        return Err(HandEyeError::LengthMismatch {
            hand: hand.len(),
            eye: eye.len(),
        });
    }
    if hand.len() < MIN_POSES {
        return Err(HandEyeError::TooFewPoses {
            got: hand.len(),
            need: MIN_POSES,
        });
    }
    for (which, poses) in [(PoseSource::Hand, hand), (PoseSource::Eye, eye)] {
        if let Some(index) = poses.iter().position(|p| !geometry::is_finite_isometry(p)) {
            return Err(HandEyeError::NonFinitePose { index, which });
        }
    }
    // The pair motions of a set of views, with or without the eye lever.
    let motions_of = |hand: &[Isometry3<f64>], eye: &[Isometry3<f64>]| {
        let mut motions = relative_motions(hand, eye, opts.pairs);
        if !opts.eye_lever {
            for m in &mut motions {
                m.eye_lever_m = Vector3::zeros();
            }
        }
        motions
    };
    let motions = motions_of(hand, eye);
    // All pairs of n views carry the information of only n - 1 independent motions: the
    // Jacobian covariance is inflated by pairs / (n - 1) (see `uncertainty`).
    let independent = hand.len() - 1;
    let mut solution = solve_impl(&motions, opts, independent)?;
    solution.views = hand.len();
    // The spread over views, each left out in turn (`uncertainty`).
    let without = |k: usize, poses: &[Isometry3<f64>]| -> Vec<Isometry3<f64>> {
        poses
            .iter()
            .enumerate()
            .filter(|(i, _)| *i != k)
            .map(|(_, p)| *p)
            .collect()
    };
    let jack = uncertainty::jackknife_over_views(hand.len(), &solution.tool0_from_camera, |k| {
        solve_impl(
            &motions_of(&without(k, hand), &without(k, eye)),
            opts,
            independent - 1,
        )
        .ok()
        .map(|s| s.tool0_from_camera)
    });
    if let Some(cov) = jack {
        solution.set_covariance(cov, UncertaintySource::Jackknife);
    }
    Ok(solution)
}

/// Hand-eye calibration from relative motions `b X = X a` (e.g. camera motions estimated
/// from images, translation possibly up to one scale with `scale_free`). `opts.pairs` is
/// ignored. The motions are treated as independent for the uncertainty.
///
/// # Errors
///
/// [`HandEyeError::TooFewMotions`] (< [`MIN_MOTIONS`]), [`HandEyeError::NonFinitePose`],
/// [`HandEyeError::InvalidWeight`], the degeneracy refusals of [`degeneracy::analyse`],
/// [`HandEyeError::ScaleFreeUnsupported`], [`HandEyeError::ScaleUnobservable`],
/// [`HandEyeError::NonPositiveScale`] and [`HandEyeError::NumericalFailure`].
pub fn solve_motions(
    motions: &[RelativeMotion],
    opts: &HandEyeOptions,
) -> Result<HandEyeSolution, HandEyeError> {
    let mut solution = solve_impl(motions, opts, motions.len())?;
    solution.views = motions.len() + 1;
    Ok(solution)
}

fn solve_impl(
    motions: &[RelativeMotion],
    opts: &HandEyeOptions,
    independent_motions: usize,
) -> Result<HandEyeSolution, HandEyeError> {
    if motions.len() < MIN_MOTIONS {
        return Err(HandEyeError::TooFewMotions {
            got: motions.len(),
            need: MIN_MOTIONS,
        });
    }
    for (index, m) in motions.iter().enumerate() {
        if !geometry::is_finite_isometry(&m.a) || !geometry::is_finite_isometry(&m.b) {
            return Err(HandEyeError::NonFinitePose {
                index,
                which: PoseSource::Motion,
            });
        }
        if !(m.weight.is_finite() && m.weight > 0.0) {
            return Err(HandEyeError::InvalidWeight {
                index,
                weight: m.weight,
            });
        }
    }
    let method = opts.method;
    if opts.scale_free && !method.supports_scale_free() {
        return Err(HandEyeError::ScaleFreeUnsupported { method });
    }
    let report = degeneracy::analyse(motions, opts)?;
    let used: Vec<RelativeMotion> = report
        .kept
        .iter()
        .filter_map(|&k| motions.get(k).copied())
        .collect();
    if opts.scale_free {
        let max_norm = used
            .iter()
            .map(|m| m.a.translation.vector.norm())
            .fold(0.0, f64::max);
        if max_norm < 1e-12 {
            return Err(HandEyeError::ScaleUnobservable { max_norm });
        }
    }

    let (x, scale, iterations, termination) = match method {
        Method::Ours => {
            let (x0, s0) = kronecker::solve(&used, opts.scale_free)?;
            let r = refine::refine(&used, &x0, s0, opts)?;
            (r.tool0_from_camera, r.scale, r.iterations, r.termination)
        }
        Method::Kronecker => {
            let (x, s) = kronecker::solve(&used, opts.scale_free)?;
            (x, s, 0, Termination::Linear)
        }
        Method::Tsai | Method::Park | Method::Horaud => {
            let tsai_motions;
            let (r, motions): (Matrix3<f64>, &[RelativeMotion]) = match method {
                Method::Tsai => {
                    tsai_motions = tsai::informative_motions(&used);
                    (tsai::rotation(&tsai_motions)?, &tsai_motions)
                }
                Method::Park => (park::rotation(&used)?, &used),
                _ => (horaud::rotation(&used)?, &used),
            };
            let (t, s) = translation::solve(motions, &r, opts.scale_free, method)?;
            (geometry::isometry(&r, &t), s, 0, Termination::Linear)
        }
        Method::Andreff => (andreff::solve(&used)?, 1.0, 0, Termination::Linear),
        Method::Daniilidis => (daniilidis::solve(&used)?, 1.0, 0, Termination::Linear),
    };
    if !geometry::is_finite_isometry(&x) || !scale.is_finite() {
        return Err(HandEyeError::NumericalFailure {
            method,
            what: "non-finite estimate",
        });
    }
    if scale <= 0.0 {
        return Err(HandEyeError::NonPositiveScale { scale });
    }
    let stats = uncertainty::evaluate(&used, &x, scale, opts, independent_motions);
    Ok(HandEyeSolution {
        tool0_from_camera: x,
        scale,
        method,
        views: 0,
        pairs: used.len(),
        rejected_pairs: report.rejected,
        residual_rot_deg: stats.residual_rot_deg,
        residual_trans_mm: stats.residual_trans_mm,
        sigma_rot_deg: stats.sigma_rot_deg,
        sigma_trans_mm: stats.sigma_trans_mm,
        covariance: stats.covariance,
        uncertainty: UncertaintySource::Linearised,
        condition: report.condition,
        max_angle_mismatch_deg: report.max_angle_mismatch_deg,
        iterations,
        termination,
    })
}

/// Hand-eye calibration from two TUM pose files' texts (ARCHITECTURE.md section 5): hand =
/// `base_from_tool0`, eye = `world_from_camera`, paired by equal timestamp. This is all the
/// work of `rodlog calib handeye` except reading the files and printing.
///
/// # Errors
///
/// [`HandEyeError::PoseFile`] for a syntax error (with its line) or a timestamp present in
/// one file only, and every refusal of [`solve`].
pub fn solve_tum(
    hand_text: &str,
    eye_text: &str,
    opts: &HandEyeOptions,
) -> Result<HandEyeSolution, HandEyeError> {
    let hand = pose_file::parse_tum(hand_text)?;
    let eye = pose_file::parse_tum(eye_text)?;
    let (hand, eye) = pose_file::pair_by_timestamp(&hand, &eye)?;
    solve(&hand, &eye, opts)
}

/// The calibration JSON object of ARCHITECTURE.md section 4:
/// `{"method","mode","frame":"tool0","child_frame","translation_m","quaternion_xyzw",
/// "matrix" (4x4 row-major),"views","pairs","residual_rot_deg","residual_trans_mm",
/// "sigma_rot_deg","sigma_trans_mm","covariance" (6x6 of `(theta, t)` in rad and m,
/// row-major, or null),"uncertainty" (`jackknife` or `linearised`),"condition","scale"}`;
/// the transform is `tool0_from_camera`. `mode` is `poses` for `calib handeye` (`rgbd`/`mono`
/// for `calib self`). Non-finite figures become `null`. Print with `serde_json::to_string`
/// (floats round-trip exact).
pub fn calibration_json(
    solution: &HandEyeSolution,
    method: &str,
    mode: &str,
    child_frame: &str,
) -> serde_json::Value {
    let x = &solution.tool0_from_camera;
    let t = x.translation.vector;
    let q = x.rotation.coords; // (x, y, z, w)
    let m = x.to_homogeneous();
    let matrix: Vec<Vec<f64>> = (0..4)
        .map(|r| (0..4).map(|c| m[(r, c)]).collect())
        .collect();
    let covariance: Option<Vec<Vec<f64>>> = solution.covariance.map(|c| {
        (0..6)
            .map(|r| (0..6).map(|k| c[(r, k)]).collect())
            .collect()
    });
    let uncertainty = match solution.uncertainty {
        UncertaintySource::Linearised => "linearised",
        UncertaintySource::Jackknife => "jackknife",
    };
    serde_json::json!({
        "method": method,
        "mode": mode,
        "frame": "tool0",
        "child_frame": child_frame,
        "translation_m": [t.x, t.y, t.z],
        "quaternion_xyzw": [q.x, q.y, q.z, q.w],
        "matrix": matrix,
        "views": solution.views,
        "pairs": solution.pairs,
        "residual_rot_deg": solution.residual_rot_deg,
        "residual_trans_mm": solution.residual_trans_mm,
        "sigma_rot_deg": solution.sigma_rot_deg,
        "sigma_trans_mm": solution.sigma_trans_mm,
        "covariance": covariance,
        "uncertainty": uncertainty,
        "condition": solution.condition,
        "scale": solution.scale,
    })
}

/// Rotation-angle (degrees) and translation (metres) errors of an estimate against a
/// reference, as ARCHITECTURE.md section 6 defines them: `theta` of `R_ref^T R_est`, `||t_est - t_ref||`.
pub fn pose_error(estimate: &Isometry3<f64>, reference: &Isometry3<f64>) -> (f64, f64) {
    let r_err = geometry::rot(reference).transpose() * geometry::rot(estimate);
    let angle = geometry::rotation_angle(&r_err).to_degrees();
    let dt: Vector3<f64> = estimate.translation.vector - reference.translation.vector;
    (angle, dt.norm())
}
