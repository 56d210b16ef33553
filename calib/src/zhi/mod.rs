//! The "ZHI" baseline of the paper's comparisons (ARCHITECTURE.md sections 6-7): hand-eye calibration
//! without a target after Zhi & Schwertfeger, "Simultaneous hand-eye calibration and
//! reconstruction", IROS 2017, as the paper under reproduction summarises it: SIFT, ratio
//! test 0.8, RANSAC, structure from motion, SVD hand-eye with an unknown scale, no
//! refinement of X.
//!
//! # Pipeline ([`calibrate_zhi`])
//!
//! 1. SIFT keypoints and descriptors per view ([`frontend`]); views with fewer than
//!    [`ZhiParams::min_features`] are refused (dark/textureless).
//! 2. Every pair `i < j`: L2 nearest neighbours with Lowe's ratio test (0.8), then the 5-point
//!    essential RANSAC of [`crate::relpose`] on the undistorted normalised points (Sampson
//!    threshold [`ZhiParams::essential_threshold_px`], cheirality, pure-rotation refusal);
//!    pairs with at least [`ZhiParams::min_pair_inliers`] inliers are *verified*. The images
//!    alone decide (no hand poses are used for pair selection, unlike `ours`).
//! 3. Tracks by union-find over the verified inlier matches ([`sfm::build_tracks`]).
//! 4. Incremental SfM (the classic pipeline, Snavely et al. 2006; Schönberger & Frahm 2016):
//!    the initial pair = the verified pair with the most inliers that triangulate (two-view,
//!    within the reprojection threshold and above the minimum triangulation angle); world = its
//!    first camera, its second camera at the essential motion with `|t| = 1` (this fixes the
//!    one global scale of the reconstruction); triangulation of the tracks seen by both;
//!    then repeatedly the unregistered view that sees most triangulated tracks is resected
//!    ([`sfm::pnp_ransac`]: DLT RANSAC + reprojection LM), new tracks are triangulated and
//!    [`ZhiParams::refine_rounds`] rounds of resection-intersection refine all cameras and
//!    points; after the last view, [`ZhiParams::final_refine_rounds`] more rounds.
//! 5. Hand-eye: the registered views' camera poses `world_from_camera` (up to the global
//!    scale) and hand poses `base_from_tool0` go to the Kronecker/SVD solver with an unknown
//!    scale ([`crate::handeye::kronecker`], the paper's eq. 13 form, `scale_free`), over
//!    all pairs of registered views. No nonlinear refinement of X.
//!
//! # Where this differs from Zhi & Schwertfeger's own pipeline
//!
//! Their paper iterates triangulation and bundle adjustment *with the camera poses expressed
//! through the hand poses and X* (simultaneous calibration and reconstruction); the baseline
//! the substation paper compares against, and this module, is the plain "SfM, then SVD"
//! variant (ARCHITECTURE.md section 6: no refinement). The SfM refinement here is resection-intersection
//! (alternating per-camera pose LM and per-point triangulation, the block-coordinate form
//! of bundle adjustment) instead of a joint sparse Levenberg-Marquardt; the resection uses
//! the 6-point DLT in RANSAC instead of P3P. The camera intrinsics are known (as in the
//! paper's experiments). ZHI uses colour only: with RGB-D input it ignores the depth.
//!
//! # Refusals
//!
//! Too few views or wrong image sizes ([`ZhiError::Views`]), dark views
//! ([`ZhiError::TooFewFeatures`]), no verified initial pair ([`ZhiError::NoInitialPair`]),
//! fewer than 3 registered views ([`ZhiError::TooFewRegistered`]), and the hand-eye solver's
//! refusals (degenerate motion, [`ZhiError::HandEye`]). Ground truth is never read.

pub mod frontend;
pub mod sfm;

use nalgebra::{Isometry3, Point2, Point3};
use rayon::prelude::*;

pub use frontend::Detector;
use sfm::{Track, TriangulationRules, build_tracks, pnp_ransac, refine_pose, triangulate_track};

use crate::handeye::{self, HandEyeError, HandEyeOptions, HandEyeSolution, Method};
use crate::relpose::{CameraModel, EssentialParams, estimate_essential_ransac};
use crate::selfcal::motion::pair_seed;
use crate::selfcal::views::validate_views;
use crate::selfcal::{CalibView, SelfCalError};

/// Fewest registered views for the hand-eye solve.
pub const MIN_REGISTERED: usize = 3;

/// Parameters of [`calibrate_zhi`]; every default is documented on its field.
#[derive(Debug, Clone, PartialEq)]
pub struct ZhiParams {
    /// Detector (default [`Detector::Sift`], the baseline's).
    pub detector: Detector,
    /// Features per view (default 2000, as `ours`).
    pub n_features: usize,
    /// Refuse a view with fewer keypoints (default 100, as `ours`).
    pub min_features: usize,
    /// Lowe's ratio (default 0.8, the baseline's).
    pub ratio: f32,
    /// Sampson threshold of the essential RANSAC, pixels (default 1.0, as `ours`).
    pub essential_threshold_px: f64,
    /// Essential RANSAC settings (thresholds replaced from the pixel values).
    pub essential: EssentialParams,
    /// A pair is verified with at least this many essential inliers (default 30).
    pub min_pair_inliers: usize,
    /// Reprojection threshold of triangulation, resection and refinement, pixels
    /// (default 2.0).
    pub max_reprojection_px: f64,
    /// Smallest triangulation angle, degrees (default 1.5, COLMAP's).
    pub min_triangulation_angle_deg: f64,
    /// A view is resected with at least this many 2D-3D inliers (default 20).
    pub min_pnp_inliers: usize,
    /// Resection-intersection rounds after each registration (default 2).
    pub refine_rounds: usize,
    /// Rounds after the last registration (default 10).
    pub final_refine_rounds: usize,
    /// Seed of the RANSAC streams (default 0).
    pub seed: u64,
}

impl Default for ZhiParams {
    fn default() -> Self {
        Self {
            detector: Detector::Sift,
            n_features: 2000,
            min_features: 100,
            ratio: 0.8,
            essential_threshold_px: 1.0,
            essential: EssentialParams::default(),
            min_pair_inliers: 30,
            max_reprojection_px: 2.0,
            min_triangulation_angle_deg: 1.5,
            min_pnp_inliers: 20,
            refine_rounds: 2,
            final_refine_rounds: 10,
            seed: 0,
        }
    }
}

impl ZhiParams {
    /// Defaults with the feature count scaled to the image area like
    /// [`crate::selfcal::SelfCalParams::for_camera`] (same keypoint density as `ours`).
    pub fn for_camera(camera: &CameraModel) -> Self {
        let ours = crate::selfcal::SelfCalParams::for_camera(camera);
        Self {
            n_features: ours.orb.n_features,
            ..Self::default()
        }
    }
}

/// Why ZHI refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ZhiError {
    /// The views do not fit the camera (too few, wrong size, non-finite pose).
    #[error("{0}")]
    Views(SelfCalError),
    /// The detector failed (parameters).
    #[error("features: {0}")]
    Features(String),
    /// A view has too few keypoints.
    #[error(
        "view {index}: only {features} keypoints, need {need} (dark, washed out or textureless)"
    )]
    TooFewFeatures {
        /// View index.
        index: usize,
        /// Keypoints found.
        features: usize,
        /// Needed.
        need: usize,
    },
    /// No verified pair can start the reconstruction.
    #[error(
        "no initial pair: {verified} of {pairs} view pairs verified (need one with >= {need} essential inliers)"
    )]
    NoInitialPair {
        /// Verified pairs.
        verified: usize,
        /// All pairs.
        pairs: usize,
        /// Inliers needed.
        need: usize,
    },
    /// Too few views were registered by the SfM.
    #[error("only {registered} of {views} views registered by the reconstruction, need {need}")]
    TooFewRegistered {
        /// Registered views.
        registered: usize,
        /// All views.
        views: usize,
        /// Needed.
        need: usize,
    },
    /// The hand-eye solver refused.
    #[error("hand-eye solve: {0}")]
    HandEye(#[from] HandEyeError),
}

/// One pair's two-view verification.
#[derive(Debug, Clone, PartialEq)]
pub struct ZhiPair {
    /// First view.
    pub i: usize,
    /// Second view.
    pub j: usize,
    /// Ratio-test matches.
    pub matches: usize,
    /// Essential RANSAC inliers (0 when refused).
    pub inliers: usize,
    /// Median rotation-compensated parallax of the inliers, degrees (NaN when refused).
    pub median_parallax_deg: f64,
    /// `cam_i_from_cam_j` with `|t| = 1` when estimated.
    pub cam_i_from_cam_j: Option<Isometry3<f64>>,
}

/// Result of [`calibrate_zhi`].
#[derive(Debug, Clone, PartialEq)]
pub struct ZhiResult {
    /// `X = tool0_from_camera`, its scale (metres per reconstruction unit) and figures.
    pub solution: HandEyeSolution,
    /// Keypoints per view.
    pub features_per_view: Vec<usize>,
    /// Every pair's verification.
    pub pairs: Vec<ZhiPair>,
    /// The initial pair.
    pub initial_pair: (usize, usize),
    /// Tracks built.
    pub tracks: usize,
    /// Tracks triangulated at the end.
    pub points: usize,
    /// `cam_from_world` of every registered view (`None` = not registered).
    pub cam_from_world: Vec<Option<Isometry3<f64>>>,
    /// RMS reprojection error over the observations used, pixels.
    pub reprojection_rms_px: f64,
}

impl ZhiResult {
    /// Number of registered views.
    pub fn registered(&self) -> usize {
        self.cam_from_world.iter().filter(|c| c.is_some()).count()
    }

    /// Number of verified pairs.
    pub fn verified_pairs(&self, min_inliers: usize) -> usize {
        self.pairs
            .iter()
            .filter(|p| p.inliers >= min_inliers)
            .count()
    }
}

/// The ZHI baseline on `views` (module docs): `X = tool0_from_camera`.
///
/// # Errors
/// Every refusal of the module docs.
pub fn calibrate_zhi(
    views: &[CalibView],
    camera: &CameraModel,
    params: &ZhiParams,
) -> Result<ZhiResult, ZhiError> {
    validate_views(views, camera).map_err(ZhiError::Views)?;
    let feats = frontend::detect_all(views, params)?;
    for (index, f) in feats.iter().enumerate() {
        if f.points_px.len() < params.min_features {
            return Err(ZhiError::TooFewFeatures {
                index,
                features: f.points_px.len(),
                need: params.min_features,
            });
        }
    }
    let normalised: Vec<Vec<Option<Point2<f64>>>> = feats
        .iter()
        .map(|f| {
            f.points_px
                .iter()
                .map(|p| {
                    camera
                        .undistort_pixel(&Point2::new(f64::from(p[0]), f64::from(p[1])))
                        .ok()
                })
                .collect()
        })
        .collect();
    let focal = 0.5 * (camera.fx + camera.fy);
    let mut ep = params.essential;
    ep.inlier_threshold = params.essential_threshold_px / focal;
    ep.pure_rotation_threshold_rad = 2.0 * params.essential_threshold_px / focal;

    // 2. Two-view verification of every pair.
    let n = views.len();
    let cands: Vec<(usize, usize)> = (0..n)
        .flat_map(|i| (i + 1..n).map(move |j| (i, j)))
        .collect();
    let verified: Vec<(ZhiPair, Vec<(usize, usize)>)> = cands
        .par_iter()
        .map(|&(i, j)| verify_pair(&feats, &normalised, (i, j), params, &ep))
        .collect();
    let min_in = params.min_pair_inliers;
    let pairs: Vec<ZhiPair> = verified.iter().map(|(p, _)| p.clone()).collect();
    let matches: Vec<sfm::PairMatches> = verified
        .into_iter()
        .filter(|(p, _)| p.inliers >= min_in)
        .map(|(p, m)| (p.i, p.j, m))
        .collect();
    // 3. Tracks.
    let mut tracks = build_tracks(&normalised, &matches);
    // 4. Initial pair: the verified pair whose inliers triangulate best (two views, the
    // acceptance rules of the reconstruction).
    let thr = params.max_reprojection_px / focal;
    let rules = TriangulationRules {
        max_error: thr,
        min_angle_rad: params.min_triangulation_angle_deg.to_radians(),
    };
    let init_scores: Vec<(usize, usize, usize, usize, Isometry3<f64>)> = matches
        .par_iter()
        .filter_map(|(i, j, m)| {
            let p = pairs.iter().find(|p| p.i == *i && p.j == *j)?;
            let a_ij = p.cam_i_from_cam_j?;
            let cams2 = [Isometry3::identity(), a_ij.inverse()];
            let (Some(ni), Some(nj)) = (normalised.get(*i), normalised.get(*j)) else {
                return None;
            };
            let good = m
                .iter()
                .filter(|(ki, kj)| {
                    let (Some(Some(xi)), Some(Some(xj))) = (ni.get(*ki), nj.get(*kj)) else {
                        return false;
                    };
                    triangulate_track(&cams2, &[*xi, *xj], &rules).is_some()
                })
                .count();
            Some((good, p.inliers, *i, *j, a_ij))
        })
        .collect();
    let Some(&(init_points, _, i0, j0, a_ij)) = init_scores.iter().max_by(|a, b| {
        (a.0, a.1, std::cmp::Reverse((a.2, a.3))).cmp(&(b.0, b.1, std::cmp::Reverse((b.2, b.3))))
    }) else {
        return Err(ZhiError::NoInitialPair {
            verified: matches.len(),
            pairs: pairs.len(),
            need: min_in,
        });
    };
    if init_points < params.min_pnp_inliers {
        return Err(ZhiError::NoInitialPair {
            verified: matches.len(),
            pairs: pairs.len(),
            need: min_in,
        });
    }
    let mut cams: Vec<Option<Isometry3<f64>>> = vec![None; n];
    if let Some(c) = cams.get_mut(i0) {
        *c = Some(Isometry3::identity());
    }
    if let Some(c) = cams.get_mut(j0) {
        *c = Some(a_ij.inverse());
    }
    triangulate_missing(&mut tracks, &cams, &rules);
    // Per view: (track, observation) lists.
    let mut view_obs: Vec<Vec<(usize, Point2<f64>)>> = vec![Vec::new(); n];
    for (t, tr) in tracks.iter().enumerate() {
        for o in &tr.observations {
            if let Some(v) = view_obs.get_mut(o.view) {
                v.push((t, o.x));
            }
        }
    }
    let mut failed = vec![false; n];
    loop {
        let next = (0..n)
            .filter(|&v| cams.get(v).is_some_and(|c| c.is_none()) && !failed[v])
            .map(|v| {
                let seen = view_obs[v]
                    .iter()
                    .filter(|(t, _)| tracks.get(*t).is_some_and(|tr| tr.point.is_some()))
                    .count();
                (seen, v)
            })
            .max_by(|a, b| a.0.cmp(&b.0).then(b.1.cmp(&a.1)));
        let Some((seen, v)) = next else { break };
        if seen < params.min_pnp_inliers {
            break;
        }
        let (w, x): (Vec<Point3<f64>>, Vec<Point2<f64>>) = view_obs[v]
            .iter()
            .filter_map(|(t, x)| Some((tracks.get(*t)?.point?, *x)))
            .unzip();
        match pnp_ransac(
            &w,
            &x,
            thr,
            params.min_pnp_inliers,
            pair_seed(params.seed ^ 0x5FA, v, n),
        ) {
            Some(est) => {
                cams[v] = Some(est.cam_from_world);
                // New points may now let a view that failed be resected.
                failed.iter_mut().for_each(|f| *f = false);
            }
            None => {
                failed[v] = true;
                continue;
            }
        }
        triangulate_missing(&mut tracks, &cams, &rules);
        for _ in 0..params.refine_rounds {
            refine_round(&mut tracks, &mut cams, &view_obs, i0, &rules);
        }
    }
    for _ in 0..params.final_refine_rounds {
        refine_round(&mut tracks, &mut cams, &view_obs, i0, &rules);
    }
    let registered = cams.iter().filter(|c| c.is_some()).count();
    if registered < MIN_REGISTERED {
        return Err(ZhiError::TooFewRegistered {
            registered,
            views: n,
            need: MIN_REGISTERED,
        });
    }
    // RMS reprojection over the inlier observations.
    let (mut sum, mut count) = (0.0, 0usize);
    for tr in &tracks {
        let Some(p) = tr.point else { continue };
        for o in &tr.observations {
            if let Some(Some(c)) = cams.get(o.view)
                && let Some(e) = sfm::reprojection_error(c, &p, &o.x)
                && e <= thr
            {
                sum += (e * focal).powi(2);
                count += 1;
            }
        }
    }
    // 5. Hand-eye, scale-free Kronecker/SVD, no refinement.
    let (hand, eye): (Vec<Isometry3<f64>>, Vec<Isometry3<f64>>) = views
        .iter()
        .zip(&cams)
        .filter_map(|(v, c)| Some((v.base_from_tool0, c.as_ref()?.inverse())))
        .unzip();
    let opts = HandEyeOptions {
        method: Method::Kronecker,
        scale_free: true,
        eye_lever: false,
        ..HandEyeOptions::default()
    };
    let solution = handeye::solve(&hand, &eye, &opts)?;
    Ok(ZhiResult {
        solution,
        features_per_view: feats.iter().map(|f| f.points_px.len()).collect(),
        pairs,
        initial_pair: (i0, j0),
        tracks: tracks.len(),
        points: tracks.iter().filter(|t| t.point.is_some()).count(),
        cam_from_world: cams,
        reprojection_rms_px: if count > 0 {
            (sum / count as f64).sqrt()
        } else {
            f64::NAN
        },
    })
}

fn verify_pair(
    feats: &[frontend::ViewFeatures],
    normalised: &[Vec<Option<Point2<f64>>>],
    (i, j): (usize, usize),
    params: &ZhiParams,
    ep: &EssentialParams,
) -> (ZhiPair, Vec<(usize, usize)>) {
    let mut pair = ZhiPair {
        i,
        j,
        matches: 0,
        inliers: 0,
        median_parallax_deg: f64::NAN,
        cam_i_from_cam_j: None,
    };
    let (Some(fa), Some(fb), Some(na), Some(nb)) = (
        feats.get(i),
        feats.get(j),
        normalised.get(i),
        normalised.get(j),
    ) else {
        return (pair, Vec::new());
    };
    let raw = frontend::ratio_matches(fa, fb, params.ratio);
    let usable: Vec<(usize, usize, Point2<f64>, Point2<f64>)> = raw
        .iter()
        .filter_map(|&(a, b)| Some((a, b, (*na.get(a)?)?, (*nb.get(b)?)?)))
        .collect();
    pair.matches = usable.len();
    let xa: Vec<Point2<f64>> = usable.iter().map(|u| u.2).collect();
    let xb: Vec<Point2<f64>> = usable.iter().map(|u| u.3).collect();
    let Ok(est) = estimate_essential_ransac(&xa, &xb, ep, pair_seed(params.seed, i, j)) else {
        return (pair, Vec::new());
    };
    pair.inliers = est.inlier_count;
    pair.median_parallax_deg = est.median_parallax_rad.to_degrees();
    pair.cam_i_from_cam_j = Some(est.a_from_b);
    let kept = usable
        .iter()
        .zip(&est.inliers)
        .filter(|(_, k)| **k)
        .map(|(u, _)| (u.0, u.1))
        .collect();
    (pair, kept)
}

/// Triangulates every track without a point that has at least two registered views.
fn triangulate_missing(
    tracks: &mut [Track],
    cams: &[Option<Isometry3<f64>>],
    rules: &TriangulationRules,
) {
    tracks.par_iter_mut().for_each(|tr| {
        if tr.point.is_some() {
            return;
        }
        let (c, x): (Vec<Isometry3<f64>>, Vec<Point2<f64>>) = tr
            .observations
            .iter()
            .filter_map(|o| Some(((*cams.get(o.view)?)?, o.x)))
            .unzip();
        if c.len() >= 2 {
            tr.point = triangulate_track(&c, &x, rules);
        }
    });
}

/// One resection-intersection round (module docs of [`sfm`]): every point re-triangulated
/// from its registered inlier observations (within 2x the threshold of the current point),
/// then every registered camera but `fixed` re-estimated from its inlier points.
fn refine_round(
    tracks: &mut [Track],
    cams: &mut [Option<Isometry3<f64>>],
    view_obs: &[Vec<(usize, Point2<f64>)>],
    fixed: usize,
    rules: &TriangulationRules,
) {
    let loose = 2.0 * rules.max_error;
    {
        let cams_ro: &[Option<Isometry3<f64>>] = cams;
        tracks.par_iter_mut().for_each(|tr| {
            let (c, x): (Vec<Isometry3<f64>>, Vec<Point2<f64>>) = tr
                .observations
                .iter()
                .filter_map(|o| {
                    let cam = (*cams_ro.get(o.view)?)?;
                    match tr.point {
                        Some(p) => (sfm::reprojection_error(&cam, &p, &o.x)? <= loose)
                            .then_some((cam, o.x)),
                        None => Some((cam, o.x)),
                    }
                })
                .unzip();
            tr.point = if c.len() >= 2 {
                triangulate_track(&c, &x, rules)
            } else {
                None
            };
        });
    }
    let tracks_ro: &[Track] = tracks;
    let updated: Vec<Option<Isometry3<f64>>> = cams
        .par_iter()
        .enumerate()
        .map(|(v, c)| {
            let cam = (*c)?;
            if v == fixed {
                return Some(cam);
            }
            let (w, x): (Vec<Point3<f64>>, Vec<Point2<f64>>) = view_obs
                .get(v)?
                .iter()
                .filter_map(|(t, x)| {
                    let p = tracks_ro.get(*t)?.point?;
                    (sfm::reprojection_error(&cam, &p, x)? <= loose).then_some((p, *x))
                })
                .unzip();
            if w.len() < 6 {
                return Some(cam);
            }
            Some(refine_pose(&cam, &w, &x, rules.max_error, 5))
        })
        .collect();
    for (c, u) in cams.iter_mut().zip(updated) {
        *c = u;
    }
}
