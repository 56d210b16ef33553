//! Which view pairs to use, and their feature matches.
//!
//! A pair `(i, j)`, `i < j`, is a candidate when its hand rotation `angle(R_B_ij)` is at least
//! [`super::SelfCalParams::min_pair_rotation_deg`] (a pair that barely rotates carries no
//! rotation information and makes `(R_B - I) t_X` ill-conditioned). Its overlap is measured
//! by features: ORB (quadtree) in both views, brute-force Hamming nearest neighbours, GMS;
//! the pair is used when at least [`super::SelfCalParams::min_matches`] GMS inliers remain.
//! Rejected pairs keep their reason ([`PairRejection`]) for the report.

use nalgebra::Isometry3;
use rayon::prelude::*;

use super::views::{CalibView, intensity_stats};
use super::{SelfCalError, SelfCalParams};
use crate::features::{Features, GrayView, OrbExtractor, gms_filter, match_brute_force};

/// Why a view pair was not used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PairRejection {
    /// The hands rotate too little between the views.
    #[error("hand rotation {hand_rotation_deg:.2} deg < {min_deg} deg")]
    SmallRotation {
        /// Rotation angle of `B_ij`, degrees.
        hand_rotation_deg: f64,
        /// Threshold, degrees.
        min_deg: f64,
    },
    /// Too few GMS matches (little overlap, poor images).
    #[error("{matches} GMS matches < {need}")]
    TooFewMatches {
        /// Matches kept by GMS.
        matches: usize,
        /// Needed.
        need: usize,
    },
    /// Too few matches with valid depth in both views.
    #[error("{points} matches with valid depth in both views < {need}")]
    TooFewDepthPoints {
        /// Matches with depth.
        points: usize,
        /// Needed.
        need: usize,
    },
    /// The relative-pose estimator refused the pair.
    #[error("relative motion: {reason}")]
    Motion {
        /// The estimator's message.
        reason: String,
    },
    /// The hand-eye solver rejected it (hand/eye rotation angles disagree).
    #[error("hand and camera rotation angles disagree (rejected by the hand-eye solver)")]
    AngleMismatch,
    /// Monocular: the per-pair scale came out non-positive (wrong translation direction).
    #[error(
        "monocular pair scale {scale:.4} <= 0 (translation direction contradicts the hand motion)"
    )]
    NonPositiveScale {
        /// The estimated scale.
        scale: f64,
    },
    /// Its residual after the solve is far above the others'.
    #[error("residual {residual:.3} above the limit {limit:.3} ({unit})")]
    Residual {
        /// The pair's residual.
        residual: f64,
        /// The limit.
        limit: f64,
        /// Unit and kind of residual.
        unit: &'static str,
    },
}

/// How many pairs were rejected for each kind of reason (the refusal figures of
/// [`super::SelfCalError::TooFewPairs`] and the drift check's).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct RejectionCounts {
    /// Pairs used (no rejection).
    pub usable: usize,
    /// [`PairRejection::SmallRotation`].
    pub small_rotation: usize,
    /// [`PairRejection::TooFewMatches`].
    pub too_few_matches: usize,
    /// The motion estimate failed: [`PairRejection::Motion`],
    /// [`PairRejection::TooFewDepthPoints`].
    pub motion_failed: usize,
    /// Rejected after the motion: [`PairRejection::AngleMismatch`],
    /// [`PairRejection::NonPositiveScale`], [`PairRejection::Residual`].
    pub rejected_later: usize,
}

impl RejectionCounts {
    /// Counts the rejections of a list of pairs (`None` = used).
    pub fn of<'a>(rejections: impl IntoIterator<Item = Option<&'a PairRejection>>) -> Self {
        let mut c = Self::default();
        for r in rejections {
            let slot = match r {
                None => &mut c.usable,
                Some(PairRejection::SmallRotation { .. }) => &mut c.small_rotation,
                Some(PairRejection::TooFewMatches { .. }) => &mut c.too_few_matches,
                Some(PairRejection::Motion { .. } | PairRejection::TooFewDepthPoints { .. }) => {
                    &mut c.motion_failed
                }
                Some(
                    PairRejection::AngleMismatch
                    | PairRejection::NonPositiveScale { .. }
                    | PairRejection::Residual { .. },
                ) => &mut c.rejected_later,
            };
            *slot += 1;
        }
        c
    }
}

/// GMS matches of one pair in full-size pixels.
#[derive(Debug, Clone, PartialEq)]
pub struct PairMatches {
    /// First view.
    pub i: usize,
    /// Second view.
    pub j: usize,
    /// Hand rotation angle of `B_ij`, degrees.
    pub hand_rotation_deg: f64,
    /// Brute-force matches before GMS.
    pub raw_matches: usize,
    /// GMS inliers `[x_i, y_i, x_j, y_j]`.
    pub coords: Vec<[f32; 4]>,
    /// Keypoint indices `[index in view i, index in view j]` of each GMS inlier (the feature
    /// tracks of eq. 15 chain them, [`super::tracks`]).
    pub keypoints: Vec<[u32; 2]>,
    /// Pyramid levels `[level_i, level_j]` of the two keypoints of each inlier (their
    /// localisation error grows with `scale_factor^level`).
    pub levels: Vec<[u8; 2]>,
    /// Per GMS match: consistent with the pair's estimated camera motion (the relative-pose
    /// RANSAC verdict, [`super::motion::PairMotion::match_inliers`]). All `false` from
    /// [`match_pair`] and for a pair whose motion could not be estimated; the pipeline fills
    /// it in.
    pub motion_inliers: Vec<bool>,
}

/// `B_ij = tool_i_from_tool_j = B_i^-1 B_j`.
pub fn hand_motion(views: &[CalibView], i: usize, j: usize) -> Option<Isometry3<f64>> {
    Some(views.get(i)?.base_from_tool0.inverse() * views.get(j)?.base_from_tool0)
}

/// ORB features of every view (in parallel, collected in view order).
///
/// # Errors
/// [`SelfCalError::Features`] (parameters), [`SelfCalError::TooFewFeatures`] for the first
/// view with fewer than `params.min_features` keypoints (dark, washed out, textureless).
pub fn extract_features(
    views: &[CalibView],
    params: &SelfCalParams,
) -> Result<Vec<Features>, SelfCalError> {
    OrbExtractor::new(params.orb.clone())?;
    let all: Vec<Result<Features, SelfCalError>> = views
        .par_iter()
        .map(|v| {
            let mut ex = OrbExtractor::new(params.orb.clone())?;
            let mut f = Features::default();
            ex.detect_and_describe(&GrayView::from_image(&v.gray), &mut f)?;
            Ok(f)
        })
        .collect();
    let mut out = Vec::with_capacity(all.len());
    for (index, (f, v)) in all.into_iter().zip(views).enumerate() {
        let f = f?;
        if f.keypoints.len() < params.min_features {
            let (mean_intensity, contrast) = intensity_stats(&v.gray);
            return Err(SelfCalError::TooFewFeatures {
                index,
                stamp_ns: v.stamp_ns,
                features: f.keypoints.len(),
                need: params.min_features,
                mean_intensity,
                contrast,
            });
        }
        out.push(f);
    }
    Ok(out)
}

/// A candidate pair `(i, j, hand rotation in degrees)`.
pub type Candidate = (usize, usize, f64);
/// A pair refused before matching `(i, j, reason)`.
pub type Refused = (usize, usize, PairRejection);

/// Candidate pairs `(i, j)` with their hand rotation (degrees), and the pairs refused for a
/// small rotation.
pub fn candidate_pairs(
    views: &[CalibView],
    min_rotation_deg: f64,
) -> (Vec<Candidate>, Vec<Refused>) {
    let mut keep = Vec::new();
    let mut drop = Vec::new();
    for i in 0..views.len() {
        for j in i + 1..views.len() {
            let Some(b) = hand_motion(views, i, j) else {
                continue;
            };
            let deg = b.rotation.angle().to_degrees();
            if deg < min_rotation_deg {
                drop.push((
                    i,
                    j,
                    PairRejection::SmallRotation {
                        hand_rotation_deg: deg,
                        min_deg: min_rotation_deg,
                    },
                ));
            } else {
                keep.push((i, j, deg));
            }
        }
    }
    (keep, drop)
}

/// Brute-force + GMS matches of view `i` (query) to view `j` (train).
pub fn match_pair(
    features: &[Features],
    size: (usize, usize),
    (i, j, hand_rotation_deg): (usize, usize, f64),
    params: &SelfCalParams,
) -> PairMatches {
    let (Some(fa), Some(fb)) = (features.get(i), features.get(j)) else {
        return PairMatches {
            i,
            j,
            hand_rotation_deg,
            raw_matches: 0,
            coords: Vec::new(),
            keypoints: Vec::new(),
            levels: Vec::new(),
            motion_inliers: Vec::new(),
        };
    };
    let (width, height) = (size.0 as u32, size.1 as u32);
    let mut mp = params.matching;
    mp.parallel = false; // pairs already run in parallel
    let matches = match_brute_force(&fa.descriptors, &fb.descriptors, &mp);
    let mask = gms_filter(
        &fa.keypoints,
        size,
        &fb.keypoints,
        size,
        &matches,
        &params.gms,
    );
    let mut coords = Vec::new();
    let mut levels = Vec::new();
    let mut keypoints = Vec::new();
    for (m, _) in matches.iter().zip(&mask).filter(|(_, k)| **k) {
        let (Some(a), Some(b)) = (
            fa.keypoints.get(m.query as usize),
            fb.keypoints.get(m.train as usize),
        ) else {
            continue;
        };
        let (ax, ay) = params.orb.full_res_position(a, width, height);
        let (bx, by) = params.orb.full_res_position(b, width, height);
        coords.push([ax, ay, bx, by]);
        levels.push([a.level, b.level]);
        keypoints.push([m.query, m.train]);
    }
    let motion_inliers = vec![false; coords.len()];
    PairMatches {
        i,
        j,
        hand_rotation_deg,
        raw_matches: matches.len(),
        coords,
        keypoints,
        levels,
        motion_inliers,
    }
}
