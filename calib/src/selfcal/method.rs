//! Which self-calibration: the paper's method as written, with a joint bundle adjustment, or
//! ours (the paper's pipeline with named, switchable additions: [`Steps`]).
//!
//! # The paper's method ([`SelfCalMethod::Paper`])
//!
//! 1. ORB (FAST + Harris, 8 levels x1.2, steered rBRIEF) kept evenly by the ORB-SLAM quadtree;
//! 2. brute-force Hamming matching and GMS neighbourhood scoring for every view pair;
//! 3. RGB-D relative motion of each pair: the GMS matches with registered depth in both
//!    views, back-projected, 3D-3D RANSAC and the closed-form rigid fit (Umeyama) on its
//!    inliers;
//! 4. the linear hand-eye solution over all pairs from the Kronecker form of
//!    `A X_p = X_p B` (eqs. 10-12) and its SVD, translation by least squares (eq. 13)
//!    ([`crate::handeye::kronecker`]);
//! 5. Levenberg-Marquardt on eq. 15, `C(X_p) = sum_i sum_j v_ij |P_C,ij - X_p B_j^-1 P_W,i|^2`,
//!    over the features tracked across the views, each world point `P_W,i` triangulated from
//!    the views that see it ([`super::eq15`]).
//!
//! [`SelfCalMethod::PaperBa`] is the same with step 5 replaced by a bundle adjustment: the
//! same cost minimised over `X_p` and every `P_W,i` jointly ([`super::ba`]).
//!
//! # Ours ([`SelfCalMethod::Ours`], the default)
//!
//! The same front end with the additions of [`Steps`], each one a field that switches it
//! off; `rodlog experiment ablation` measures what each adds on the same trials.
//!
//! # Is RANSAC the paper's?
//!
//! The paper filters matches with GMS, which is meant to make a geometric RANSAC
//! unnecessary, and its description of the RGB-D motion can be read either way; the
//! project's design notes read it as "3D-3D RANSAC + Umeyama on the inliers", which is what
//! [`Steps::paper`] does. Without RANSAC (Umeyama over every GMS match with depth,
//! `--without rigid-ransac`) the few wrong matches GMS lets through wreck the closed-form
//! fits: on the simulator's clean calib-18 recording the linear X is then degrees off and
//! eq. 15 does not recover it (2.19 deg / 4.2 mm), while with RANSAC the paper's method is
//! within 0.05 deg / 0.5 mm. The ablation shows both.
//!
//! The paper's method needs depth (its eq. 15 compares depth-measured points with the
//! triangulated ones): without depth, [`SelfCalMethod::Paper`] and
//! [`SelfCalMethod::PaperBa`] refuse ([`super::SelfCalError::MethodNeedsDepth`]).

use std::fmt;

use crate::features::KeypointDistribution;
use std::str::FromStr;

/// The self-calibration method (module docs); the CLI names are `paper`, `paper+ba`, `ours`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, serde::Serialize)]
pub enum SelfCalMethod {
    /// The paper's pipeline as written (module docs, steps 1-5).
    Paper,
    /// The paper's pipeline with eq. 15 solved jointly over X and the world points.
    PaperBa,
    /// Ours: the paper's front end with the additions of [`Steps::ours`].
    #[default]
    Ours,
}

impl SelfCalMethod {
    /// Every method, in table order.
    pub const ALL: [SelfCalMethod; 3] = [Self::Paper, Self::PaperBa, Self::Ours];

    /// The CLI name.
    pub fn name(self) -> &'static str {
        match self {
            Self::Paper => "paper",
            Self::PaperBa => "paper+ba",
            Self::Ours => "ours",
        }
    }

    /// The steps of this method.
    pub fn steps(self) -> Steps {
        match self {
            Self::Paper => Steps::paper(),
            Self::PaperBa => Steps {
                final_refinement: FinalRefinement::BundleAdjustment,
                ..Steps::paper()
            },
            Self::Ours => Steps::ours(),
        }
    }

    /// The method's ORB keypoint selection. The paper's (and paper+ba's): the ORB-SLAM
    /// quadtree. Ours: retain-best, OpenCV's strongest corners, chosen by measurement
    /// (`rodlog experiment noise --orb-distribution`, `rodlog experiment matchers`): under
    /// image noise the quadtree spends its nodes on weak corners that do not repeat, and our
    /// RGB-D calibration refused most trials from sigma 0.20 with it, where with retain-best
    /// it answers at every level of the paper's figure (sigma 0.05-0.30); on clean views the
    /// two are level. The drift check keeps the quadtree
    /// ([`super::drift::DRIFT_KEYPOINT_DISTRIBUTION`]), with which its statistics were
    /// measured.
    pub fn keypoint_distribution(self) -> KeypointDistribution {
        match self {
            Self::Paper | Self::PaperBa => KeypointDistribution::Quadtree,
            Self::Ours => KeypointDistribution::RetainBest,
        }
    }
}

impl fmt::Display for SelfCalMethod {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// An unknown method name.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown self-calibration method {name:?}: use paper, paper+ba or ours")]
pub struct UnknownSelfCalMethod {
    /// The name given.
    pub name: String,
}

impl FromStr for SelfCalMethod {
    type Err = UnknownSelfCalMethod;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::ALL
            .into_iter()
            .find(|m| m.name().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| UnknownSelfCalMethod { name: s.to_owned() })
    }
}

/// How the hand-eye estimate is finished after the pose solve.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FinalRefinement {
    /// No point refinement: the pose solve's X stands (ours).
    None,
    /// Levenberg-Marquardt over X on eq. 15 with triangulated world points (the paper's,
    /// [`super::eq15`]).
    Eq15,
    /// Eq. 15 over X and the world points jointly ([`super::ba`]).
    BundleAdjustment,
}

impl FinalRefinement {
    /// Short name for reports (`none`, `eq15`, `ba`).
    pub fn name(self) -> &'static str {
        match self {
            Self::None => "none",
            Self::Eq15 => "eq15",
            Self::BundleAdjustment => "ba",
        }
    }
}

/// The steps of a self-calibration: the paper's method is [`Steps::paper`], ours
/// [`Steps::ours`]; every field of ours that the paper lacks switches one addition.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Steps {
    /// RGB-D: a keypoint has depth only where the depth over its support is one surface
    /// ([`super::motion::keypoint_depth_support`]); keypoints on occluding contours are no
    /// fixed 3D points. Off: every keypoint with depth at its pixel.
    pub depth_support: bool,
    /// RGB-D pair motion by 3D-3D RANSAC (3-point samples) and Umeyama on its inliers
    /// ([`crate::relpose::estimate_rigid_ransac`]; on in the paper's method, see the module
    /// docs). Off: Umeyama over every GMS match with depth in both views.
    pub rigid_ransac: bool,
    /// RGB-D pair motion refined on its 3D inliers with the depth-noise covariances
    /// (Mahalanobis, [`crate::relpose::refine::refine_rigid`]) instead of Umeyama's
    /// unweighted fit.
    pub depth_weighted_motion: bool,
    /// RGB-D pair motion refined in the image: each frame's depth points reprojected into
    /// the other frame's keypoints, both ways ([`super::image_motion`]), instead of the 3D
    /// residuals where the depth noise along the ray dominates.
    pub image_motion: bool,
    /// Robust (Huber) Levenberg-Marquardt on the pose residuals of all pairs after the
    /// Kronecker solve, with the eye lever decorrelation ([`crate::handeye::refine`]). Off:
    /// the Kronecker/SVD solution (eqs. 10-13) is the pose solve.
    pub pose_refinement: bool,
    /// Pair rejection: pairs whose hand and eye rotation angles differ by more than
    /// [`crate::handeye::HandEyeOptions::max_angle_mismatch_deg`], and pairs whose rotation
    /// residual exceeds [`super::SelfCalParams::max_pair_residual_factor`] x the median, are
    /// dropped and the solve re-run.
    pub pair_rejection: bool,
    /// The refinement after the pose solve.
    pub final_refinement: FinalRefinement,
    /// Mono: the camera motion of a pair must rotate by the hand's angle
    /// ([`super::SelfCalParams::mono_angle_tolerance_deg`]).
    pub angle_prior: bool,
    /// Mono: a second round re-estimates every pair from the motion the first X predicts.
    pub guided_round: bool,
    /// Mono: X refined on every used pair's epipolar constraints ([`super::epipolar`]).
    pub epipolar_refinement: bool,
    /// The consistency refusal of the final X ([`super::ConsistencyLimits`]).
    pub consistency: bool,
}

impl Steps {
    /// The paper's method (module docs).
    pub fn paper() -> Self {
        Self {
            depth_support: false,
            rigid_ransac: true,
            depth_weighted_motion: false,
            image_motion: false,
            pose_refinement: false,
            pair_rejection: false,
            final_refinement: FinalRefinement::Eq15,
            angle_prior: false,
            guided_round: false,
            epipolar_refinement: false,
            consistency: false,
        }
    }

    /// Ours: every addition on, no point refinement (with noisy hand poses the pose solve is
    /// the more accurate, see [`super::eq15`]).
    pub fn ours() -> Self {
        Self {
            depth_support: true,
            rigid_ransac: true,
            depth_weighted_motion: true,
            image_motion: false,
            pose_refinement: true,
            pair_rejection: true,
            final_refinement: FinalRefinement::None,
            angle_prior: true,
            guided_round: true,
            epipolar_refinement: true,
            consistency: true,
        }
    }
}

/// The names of the switchable steps (`--with NAME`, `--without NAME`), in pipeline order.
pub const STEP_NAMES: [&str; 11] = [
    "depth-support",
    "rigid-ransac",
    "depth-weighted-motion",
    "image-motion",
    "pose-refinement",
    "pair-rejection",
    "angle-prior",
    "guided-round",
    "epipolar-refinement",
    "consistency",
    "eq15",
];

/// A step name not in [`STEP_NAMES`].
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown step {name:?}; steps: {}", STEP_NAMES.join(", "))]
pub struct UnknownStep {
    /// The name given.
    pub name: String,
}

impl Steps {
    /// Switches the step `name` ([`STEP_NAMES`]) on or off. `eq15` on sets the final
    /// refinement to [`FinalRefinement::Eq15`], off to [`FinalRefinement::None`].
    ///
    /// # Errors
    /// [`UnknownStep`] for a name not in [`STEP_NAMES`].
    pub fn set(&mut self, name: &str, on: bool) -> Result<(), UnknownStep> {
        let flag = match name {
            "depth-support" => &mut self.depth_support,
            "rigid-ransac" => &mut self.rigid_ransac,
            "depth-weighted-motion" => &mut self.depth_weighted_motion,
            "image-motion" => &mut self.image_motion,
            "pose-refinement" => &mut self.pose_refinement,
            "pair-rejection" => &mut self.pair_rejection,
            "angle-prior" => &mut self.angle_prior,
            "guided-round" => &mut self.guided_round,
            "epipolar-refinement" => &mut self.epipolar_refinement,
            "consistency" => &mut self.consistency,
            "eq15" => {
                self.final_refinement = if on {
                    FinalRefinement::Eq15
                } else {
                    FinalRefinement::None
                };
                return Ok(());
            }
            _ => {
                return Err(UnknownStep {
                    name: name.to_owned(),
                });
            }
        };
        *flag = on;
        Ok(())
    }
}

impl Steps {
    /// Whether the step `name` ([`STEP_NAMES`]) is on; `eq15` is on when the final refinement
    /// is [`FinalRefinement::Eq15`].
    ///
    /// # Errors
    /// [`UnknownStep`] for a name not in [`STEP_NAMES`].
    pub fn is_on(&self, name: &str) -> Result<bool, UnknownStep> {
        Ok(match name {
            "depth-support" => self.depth_support,
            "rigid-ransac" => self.rigid_ransac,
            "depth-weighted-motion" => self.depth_weighted_motion,
            "image-motion" => self.image_motion,
            "pose-refinement" => self.pose_refinement,
            "pair-rejection" => self.pair_rejection,
            "angle-prior" => self.angle_prior,
            "guided-round" => self.guided_round,
            "epipolar-refinement" => self.epipolar_refinement,
            "consistency" => self.consistency,
            "eq15" => self.final_refinement == FinalRefinement::Eq15,
            _ => {
                return Err(UnknownStep {
                    name: name.to_owned(),
                });
            }
        })
    }
}

impl Default for Steps {
    fn default() -> Self {
        Self::ours()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_step_reads_back_what_was_set() {
        for name in STEP_NAMES {
            for on in [false, true] {
                let mut s = Steps::ours();
                s.set(name, on).expect("known step");
                assert_eq!(s.is_on(name), Ok(on), "{name}");
            }
        }
        assert!(Steps::ours().is_on("nope").is_err());
    }

    #[test]
    fn method_names_round_trip() {
        for m in SelfCalMethod::ALL {
            assert_eq!(m.name().parse::<SelfCalMethod>(), Ok(m));
        }
        assert!("zhi".parse::<SelfCalMethod>().is_err());
        assert_eq!(SelfCalMethod::default(), SelfCalMethod::Ours);
        assert_eq!(
            SelfCalMethod::PaperBa.steps().final_refinement,
            FinalRefinement::BundleAdjustment
        );
        let mut s = Steps::paper();
        for name in STEP_NAMES {
            s.set(name, true).expect("known step");
        }
        assert_eq!(s.final_refinement, FinalRefinement::Eq15);
        assert!(s.image_motion && s.consistency && s.depth_weighted_motion);
        assert!(s.set("ransac", true).is_err());
    }
}
