//! Relative camera motion `A_ij = cam_i_from_cam_j` of one view pair from its GMS matches,
//! and the monocular translation with per-pair scales (module docs of [`super`]).
//!
//! - RGB-D: a keypoint has depth only where the depth over its support (FAST's circle at its
//!   level) is one surface ([`keypoint_depth_support`]): a keypoint on an occluding contour
//!   is no fixed 3D point. Keeping them put rendered trials' estimates 0.04-0.085 deg off
//!   about the same axis at every noise level (a bias common to all views, which no
//!   resampling of the views can see); without them the RGB-D error of 8 noise trials at
//!   sigma 0.05 fell from 0.054 deg / 0.53 mm to 0.042 deg / 0.37 mm (medians). Each match `(u_i, u_j)` with depth in both views (and no depth step
//!   around it, [`CalibView::depth_at`]) becomes `p_in_cam_i = backproject(u_i, z_i)`,
//!   `p_in_cam_j = backproject(u_j, z_j)` through the plumb_bob model (undistorted first);
//!   [`estimate_rigid_ransac`] (3-point RANSAC, Umeyama/Horn, depth-noise-weighted LM) gives
//!   `cam_i_from_cam_j` in metres and its inlier point pairs ([`super::Steps::rigid_ransac`];
//!   without it, the paper's closed-form Umeyama fit over every match with depth).
//! - Mono: normalised undistorted points, [`estimate_essential_ransac`] (5-point, Sampson,
//!   cheirality, LM on `SO(3) x S^2`): `cam_i_from_cam_j` with `|t| = 1`, constrained to
//!   rotate by the hand's angle ([`SelfCalParams::mono_angle_tolerance_deg`], with
//!   [`super::Steps::angle_prior`]).

use nalgebra::{Isometry3, Matrix3, Point2, Point3, Vector3};

use super::image_motion::{ImageMatch, refine_image_motion};
use super::pairs::{PairMatches, PairRejection};
use super::pipeline::SelfCalParams;
use super::views::CalibView;
use crate::features::{Features, OrbParams};
use crate::relpose::essential::{RotationAnglePrior, refine_essential_guided};
use crate::relpose::umeyama::rigid_from_correspondences;
use crate::relpose::{CameraModel, estimate_essential_ransac, estimate_rigid_ransac};

/// Largest relative depth step between a keypoint's pixel and its 4-neighbours (2%).
pub const MAX_DEPTH_STEP: f32 = 0.02;

/// The camera motion of one pair.
#[derive(Debug, Clone, PartialEq)]
pub struct PairMotion {
    /// `A_ij = cam_i_from_cam_j` (metres in RGB-D, `|t| = 1` in mono).
    pub cam_i_from_cam_j: Isometry3<f64>,
    /// RANSAC inliers.
    pub inliers: usize,
    /// RMS residual of the inliers: metres (RGB-D) or Sampson distance (mono, normalised
    /// image units).
    pub rms: f64,
    /// RGB-D: inlier points `(p_in_cam_i, p_in_cam_j)`; mono: empty.
    pub points: Vec<(Point3<f64>, Point3<f64>)>,
    /// RGB-D: 1-sigma of `p_in_cam_i - A_ij p_in_cam_j` per inlier, metres (isotropic
    /// approximation: keypoint error `sigma_px scale_factor^level` back-projected at its depth,
    /// plus the depth noise, for both points); mono: empty.
    pub point_sigma_m: Vec<f64>,
    /// The RANSAC verdict per GMS match of the pair (index = [`PairMatches::coords`]'s):
    /// `true` when the match is consistent with `A_ij` (RGB-D: `|p_i - A_ij p_j|` within
    /// the 3D-3D threshold; mono: Sampson distance within the threshold and in front of both
    /// cameras). A match the estimator never saw (no depth in a view, a depth step, a failed
    /// undistortion) is `false`.
    pub match_inliers: Vec<bool>,
}

/// Spreads the estimator's inlier flags (one per point it was given, `used[k]` the match
/// index of its point `k`) over all `n` matches of the pair; the others are `false`.
fn match_flags(n: usize, used: &[usize], inliers: &[bool]) -> Vec<bool> {
    let mut flags = vec![false; n];
    for (&k, &inlier) in used.iter().zip(inliers) {
        if let Some(f) = flags.get_mut(k) {
            *f = inlier;
        }
    }
    flags
}

/// Radius of a keypoint's support at pyramid level `level`, full-resolution pixels: FAST's
/// circle ([`crate::features::fast::FAST_RADIUS`]) at that level, plus one pixel for the
/// bilinear depth lookup.
pub fn support_radius_px(level: u8, scale_factor: f32) -> usize {
    let r = crate::features::fast::FAST_RADIUS as f32 * scale_factor.powi(i32::from(level));
    r.ceil() as usize + 1
}

/// Per keypoint of `features` (found in `view`): whether its depth may be used, i.e. the
/// depth over its support is one surface ([`CalibView::depth_support`] over
/// [`support_radius_px`], steps up to [`MAX_DEPTH_STEP`]). All `false` without depth.
pub fn keypoint_depth_support(view: &CalibView, features: &Features, orb: &OrbParams) -> Vec<bool> {
    let (w, h) = (view.gray.width(), view.gray.height());
    features
        .keypoints
        .iter()
        .map(|k| {
            let (x, y) = orb.full_res_position(k, w, h);
            let r = support_radius_px(k.level, orb.scale_factor);
            view.depth_support(x, y, r, MAX_DEPTH_STEP)
        })
        .collect()
}

/// Deterministic per-pair seed.
pub fn pair_seed(seed: u64, i: usize, j: usize) -> u64 {
    let mut z = seed ^ ((i as u64) << 32 | j as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z ^ (z >> 31)
}

/// What the two views measured of one match: undistorted normalised keypoints, registered
/// depth (metres, `None` where the view has none or a depth step), pyramid levels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MatchMeasurement {
    /// Keypoint in view `i`, undistorted normalised.
    pub x_i: Point2<f64>,
    /// Keypoint in view `j`, undistorted normalised.
    pub x_j: Point2<f64>,
    /// Depth at the keypoint in view `i`.
    pub z_i: Option<f64>,
    /// Depth at the keypoint in view `j`.
    pub z_j: Option<f64>,
    /// Pyramid levels `[i, j]`.
    pub levels: [u8; 2],
}

/// The measurements of a pair's matches (index = [`PairMatches::coords`]'s; `None` where a
/// keypoint cannot be undistorted). `support` is [`keypoint_depth_support`] of views `i` and
/// `j`: a keypoint without it has no depth.
pub fn measure_matches(
    view_i: &CalibView,
    view_j: &CalibView,
    camera: &CameraModel,
    matches: &PairMatches,
    support: [&[bool]; 2],
) -> Vec<Option<MatchMeasurement>> {
    // A match without keypoint indices (never from `match_pair`) has no depth.
    let supported = |view: usize, k: usize| {
        let index = matches.keypoints.get(k).map(|kp| kp[view] as usize);
        index
            .and_then(|i| support[view].get(i))
            .copied()
            .unwrap_or(false)
    };
    matches
        .coords
        .iter()
        .enumerate()
        .map(|(k, c)| {
            let x_i = camera
                .undistort_pixel(&Point2::new(f64::from(c[0]), f64::from(c[1])))
                .ok()?;
            let x_j = camera
                .undistort_pixel(&Point2::new(f64::from(c[2]), f64::from(c[3])))
                .ok()?;
            Some(MatchMeasurement {
                x_i,
                x_j,
                z_i: supported(0, k)
                    .then(|| view_i.depth_at(c[0], c[1], MAX_DEPTH_STEP))
                    .flatten(),
                z_j: supported(1, k)
                    .then(|| view_j.depth_at(c[2], c[3], MAX_DEPTH_STEP))
                    .flatten(),
                levels: matches.levels.get(k).copied().unwrap_or([0, 0]),
            })
        })
        .collect()
}

/// RGB-D motion of a pair (module docs): [`measure_matches`] (with the views' keypoint
/// depth `support`), then [`rgbd_motion_from`] with the camera's mean focal length.
///
/// # Errors
/// As [`rgbd_motion_from`].
pub fn rgbd_motion(
    view_i: &CalibView,
    view_j: &CalibView,
    camera: &CameraModel,
    matches: &PairMatches,
    params: &SelfCalParams,
    seed: u64,
    support: [&[bool]; 2],
) -> Result<PairMotion, PairRejection> {
    let meas = measure_matches(view_i, view_j, camera, matches, support);
    rgbd_motion_from(&meas, 0.5 * (camera.fx + camera.fy), params, seed)
}

/// RGB-D motion of a pair from its match measurements (`f`: focal length, pixels): the 3D
/// points of the matches with depth in both views, 3D-3D RANSAC and Umeyama on its inliers
/// ([`super::Steps::rigid_ransac`], else Umeyama over all of them) refined with the depth
/// noise model ([`super::Steps::depth_weighted_motion`]), then with [`super::Steps::image_motion`] the
/// refinement in the image ([`super::image_motion`]) over every match with depth in at least
/// one view, started from the 3D estimate and its inliers (the 3D estimate stands when the
/// refinement fails).
///
/// # Errors
/// [`PairRejection::TooFewDepthPoints`] when fewer than
/// [`SelfCalParams::min_depth_points`] matches have depth in both views;
/// [`PairRejection::Motion`] when RANSAC refuses.
pub fn rgbd_motion_from(
    meas: &[Option<MatchMeasurement>],
    f: f64,
    params: &SelfCalParams,
    seed: u64,
) -> Result<PairMotion, PairRejection> {
    let scale_factor = f64::from(params.orb.scale_factor);
    let min_points = params.min_depth_points;
    let steps = params.steps;
    let rigid = &params.rigid;
    let mut noise = rigid.noise.unwrap_or_default();
    noise.focal_px = f;
    let sigma_px = |level: u8| noise.sigma_pixel_px * scale_factor.powi(i32::from(level));
    let var = |z: f64, level: u8| {
        let lateral = z * sigma_px(level) / f;
        lateral * lateral + noise.sigma_depth_m(z).powi(2)
    };
    let point = |x: &Point2<f64>, z: f64| Point3::new(x.x * z, x.y * z, z);
    let mut p_i = Vec::with_capacity(meas.len());
    let mut p_j = Vec::with_capacity(meas.len());
    let mut sig = Vec::with_capacity(meas.len());
    let mut used = Vec::with_capacity(meas.len());
    for (k, m) in meas.iter().enumerate() {
        let Some(m) = m else { continue };
        let (Some(zi), Some(zj)) = (m.z_i, m.z_j) else {
            continue;
        };
        p_i.push(point(&m.x_i, zi));
        p_j.push(point(&m.x_j, zj));
        sig.push((var(zi, m.levels[0]) + var(zj, m.levels[1])).sqrt());
        used.push(k);
    }
    if p_i.len() < min_points {
        return Err(PairRejection::TooFewDepthPoints {
            points: p_i.len(),
            need: min_points,
        });
    }
    let three_d = if steps.rigid_ransac {
        let mut rp = *rigid;
        rp.refine = rp.refine && steps.depth_weighted_motion;
        if let Some(n) = rp.noise.as_mut() {
            n.focal_px = f;
        }
        let est =
            estimate_rigid_ransac(&p_i, &p_j, &rp, seed).map_err(|e| PairRejection::Motion {
                reason: e.to_string(),
            })?;
        PairMotion {
            cam_i_from_cam_j: est.a_from_b,
            inliers: est.inlier_count,
            rms: est.rms_m,
            points: Vec::new(),
            point_sigma_m: Vec::new(),
            match_inliers: match_flags(meas.len(), &used, &est.inliers),
        }
    } else {
        umeyama_motion(&p_i, &p_j, &used, meas.len())?
    };
    let mut motion = three_d;
    if steps.image_motion {
        let image: Vec<ImageMatch> = meas
            .iter()
            .map(|m| match m {
                Some(m) => ImageMatch {
                    x_i: m.x_i,
                    x_j: m.x_j,
                    p_i: m.z_i.map(|z| point(&m.x_i, z)),
                    p_j: m.z_j.map(|z| point(&m.x_j, z)),
                    sigma_i_px: sigma_px(m.levels[0]),
                    sigma_j_px: sigma_px(m.levels[1]),
                },
                None => ImageMatch {
                    x_i: Point2::origin(),
                    x_j: Point2::origin(),
                    p_i: None,
                    p_j: None,
                    sigma_i_px: 1.0,
                    sigma_j_px: 1.0,
                },
            })
            .collect();
        let need = rigid.min_inliers.max(3);
        if let Some(r) = refine_image_motion(
            &image,
            &motion.match_inliers,
            &motion.cam_i_from_cam_j,
            f,
            &noise,
            need,
        ) {
            motion.cam_i_from_cam_j = r.cam_i_from_cam_j;
            motion.inliers = r.inlier_count;
            motion.match_inliers = r.inliers;
        }
    }
    // The inlier point pairs with depth in both views at the final motion (eq. 15 figures,
    // the eye lever arm).
    let a = motion.cam_i_from_cam_j;
    let (mut sum, mut n) = (0.0, 0usize);
    for ((pi, pj), (s, &k)) in p_i.iter().zip(&p_j).zip(sig.iter().zip(&used)) {
        if motion.match_inliers.get(k).copied().unwrap_or(false) {
            sum += (pi - a * pj).norm_squared();
            n += 1;
            motion.points.push((*pi, *pj));
            motion.point_sigma_m.push(*s);
        }
    }
    motion.rms = (sum / n.max(1) as f64).sqrt();
    Ok(motion)
}

/// The paper's RGB-D motion (without [`super::Steps::rigid_ransac`]): the closed-form rigid fit
/// (Umeyama) over every match with depth in both views; all of them count as inliers.
fn umeyama_motion(
    p_i: &[Point3<f64>],
    p_j: &[Point3<f64>],
    used: &[usize],
    n_matches: usize,
) -> Result<PairMotion, PairRejection> {
    let a_from_b =
        rigid_from_correspondences(p_i, p_j, None).map_err(|e| PairRejection::Motion {
            reason: e.to_string(),
        })?;
    Ok(PairMotion {
        cam_i_from_cam_j: a_from_b,
        inliers: p_i.len(),
        rms: f64::NAN,
        points: Vec::new(),
        point_sigma_m: Vec::new(),
        match_inliers: match_flags(n_matches, used, &vec![true; p_i.len()]),
    })
}

/// Monocular motion of a pair (module docs); the essential inlier threshold
/// ([`SelfCalParams::essential_threshold_px`]) is converted with the mean focal length.
///
/// `guess`: `None` searches blindly ([`estimate_essential_ransac`]); `Some(A)` refines from
/// the motion `A = X^-1 B X` a first hand-eye estimate predicts
/// ([`refine_essential_guided`], the second round of [`super::self_calibrate`] in mono).
///
/// # Errors
/// [`PairRejection::Motion`] (undistortion failures drop single points; estimator refusals:
/// too few points, pure rotation, no consensus, a rotation angle unlike the hand's).
pub fn mono_motion(
    camera: &CameraModel,
    matches: &PairMatches,
    params: &SelfCalParams,
    seed: u64,
    guess: Option<&Isometry3<f64>>,
) -> Result<PairMotion, PairRejection> {
    let coords = &matches.coords;
    let threshold_px = params.essential_threshold_px;
    let prior = params.steps.angle_prior.then(|| RotationAnglePrior {
        angle_rad: matches.hand_rotation_deg.to_radians(),
        tolerance_rad: params.mono_angle_tolerance_deg.to_radians(),
    });
    let planar = params.mono_planar_support_ratio;
    let params = &params.essential;
    let mut x_i = Vec::with_capacity(coords.len());
    let mut x_j = Vec::with_capacity(coords.len());
    let mut used = Vec::with_capacity(coords.len());
    for (k, c) in coords.iter().enumerate() {
        let a = camera.undistort_pixel(&Point2::new(f64::from(c[0]), f64::from(c[1])));
        let b = camera.undistort_pixel(&Point2::new(f64::from(c[2]), f64::from(c[3])));
        if let (Ok(a), Ok(b)) = (a, b) {
            x_i.push(a);
            x_j.push(b);
            used.push(k);
        }
    }
    let f = 0.5 * (camera.fx + camera.fy);
    let mut ep = *params;
    ep.inlier_threshold = threshold_px / f;
    ep.pure_rotation_threshold_rad = 2.0 * threshold_px / f;
    ep.rotation_angle_prior = prior;
    ep.planar_support_ratio = planar;
    let est = match guess {
        None => estimate_essential_ransac(&x_i, &x_j, &ep, seed),
        Some(a) => refine_essential_guided(&x_i, &x_j, a, &ep, seed),
    }
    .map_err(|e| PairRejection::Motion {
        reason: e.to_string(),
    })?;
    Ok(PairMotion {
        cam_i_from_cam_j: est.a_from_b,
        inliers: est.inlier_count,
        rms: est.rms_sampson,
        points: Vec::new(),
        point_sigma_m: Vec::new(),
        match_inliers: match_flags(coords.len(), &used, &est.inliers),
    })
}

/// Monocular translation of X with one unknown scale per pair (module docs of [`super`]):
/// given `R_X`, minimises `sum_k w_k |(I - u_k u_k^T)((R_B - I) t_X + t_B)|^2` with
/// `u_k = R_X t_A / |t_A|`, then returns `t_X` and the per-pair scales
/// `s_k = u_k^T((R_B - I) t_X + t_B) / |t_A|` (metres per eye unit).
///
/// `motions[k] = (A_k, B_k, w_k)`. `None` when the 3x3 normal matrix is singular (all hand
/// rotations about one axis leave the translation along it unobservable).
pub fn mono_translation(
    motions: &[(Isometry3<f64>, Isometry3<f64>, f64)],
    r_x: &Matrix3<f64>,
) -> Option<(Vector3<f64>, Vec<f64>)> {
    let mut n = Matrix3::zeros();
    let mut rhs = Vector3::zeros();
    let mut proj = Vec::with_capacity(motions.len());
    for (a, b, w) in motions {
        let ta = a.translation.vector;
        let na = ta.norm();
        if na <= 0.0 {
            proj.push(None);
            continue;
        }
        let u = r_x * ta / na;
        let p = Matrix3::identity() - u * u.transpose();
        let rb = b.rotation.to_rotation_matrix().into_inner();
        let m = p * (rb - Matrix3::identity());
        let c = p * b.translation.vector;
        n += *w * m.transpose() * m;
        rhs -= *w * m.transpose() * c;
        proj.push(Some((u, na)));
    }
    let t_x = n.try_inverse()? * rhs;
    let scales = motions
        .iter()
        .zip(&proj)
        .map(|((_, b, _), p)| match p {
            Some((u, na)) => {
                let rb = b.rotation.to_rotation_matrix().into_inner();
                u.dot(&((rb - Matrix3::identity()) * t_x + b.translation.vector)) / na
            }
            None => 0.0,
        })
        .collect();
    Some((t_x, scales))
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Translation3, Unit, UnitQuaternion};

    #[test]
    fn a_keypoint_without_depth_support_has_no_depth() {
        let (w, h) = (40_u32, 30_u32);
        let view = |z: f32| CalibView {
            stamp_ns: 0,
            gray: image::GrayImage::new(w, h),
            depth_m: Some(vec![z; (w * h) as usize]),
            base_from_tool0: Isometry3::identity(),
        };
        let (vi, vj) = (view(0.5), view(0.6));
        let camera = CameraModel::pinhole(w, h, 50.0, 50.0, 19.5, 14.5);
        let matches = PairMatches {
            i: 0,
            j: 1,
            hand_rotation_deg: 10.0,
            raw_matches: 2,
            coords: vec![[10.0, 10.0, 12.0, 11.0], [20.0, 15.0, 22.0, 16.0]],
            // Keypoint indices in each view's features, in a different order.
            keypoints: vec![[3, 0], [1, 2]],
            levels: vec![[0, 0]; 2],
            motion_inliers: vec![false; 2],
        };
        // View i: keypoint 3 supported, 1 not; view j: keypoint 0 not, 2 supported.
        let support_i = [false, false, false, true];
        let support_j = [false, false, true];
        let m = measure_matches(&vi, &vj, &camera, &matches, [&support_i, &support_j]);
        let depths: Vec<_> = m.iter().map(|m| m.map(|m| (m.z_i, m.z_j))).collect();
        assert_eq!(
            depths,
            vec![
                Some((Some(0.5), None)),
                Some((None, Some(0.6000000238418579)))
            ]
        );
        // Without support lists (a view without keypoints), no depth at all.
        let m = measure_matches(&vi, &vj, &camera, &matches, [&[], &[]]);
        assert!(
            m.iter()
                .all(|m| m.is_some_and(|m| m.z_i.is_none() && m.z_j.is_none()))
        );
    }

    fn iso(axis: [f64; 3], deg: f64, t: [f64; 3]) -> Isometry3<f64> {
        Isometry3::from_parts(
            Translation3::new(t[0], t[1], t[2]),
            UnitQuaternion::from_axis_angle(
                &Unit::new_normalize(Vector3::new(axis[0], axis[1], axis[2])),
                deg.to_radians(),
            ),
        )
    }

    #[test]
    fn mono_translation_is_exact_with_arbitrary_pair_scales() {
        let x = iso([1.0, 2.0, 3.0], 30.0, [0.05, 0.02, -0.08]);
        let hands = [
            iso([1.0, 0.0, 0.2], 25.0, [0.1, -0.05, 0.02]),
            iso([0.0, 1.0, -0.3], 35.0, [-0.04, 0.12, 0.03]),
            iso([0.2, 0.1, 1.0], 40.0, [0.07, 0.01, -0.09]),
            iso([1.0, 1.0, 0.0], 20.0, [0.0, 0.05, 0.11]),
        ];
        let scales = [0.3, 2.0, 7.5, 0.9];
        let motions: Vec<_> = hands
            .iter()
            .zip(scales)
            .map(|(b, s)| {
                let a = x.inverse() * b * x; // B X = X A
                let unit = Isometry3::from_parts(
                    Translation3::from(a.translation.vector / a.translation.vector.norm() * s),
                    a.rotation,
                );
                (unit, *b, 1.0)
            })
            .collect();
        let r_x = x.rotation.to_rotation_matrix().into_inner();
        let (t_x, got) = mono_translation(&motions, &r_x).expect("solvable");
        assert!((t_x - x.translation.vector).norm() < 1e-12, "{t_x:?}");
        for ((a, b, _), s) in motions.iter().zip(&got) {
            let true_a = x.inverse() * b * x;
            let metric = a.translation.vector * *s;
            assert!((metric - true_a.translation.vector).norm() < 1e-12);
        }
    }

    #[test]
    fn mono_translation_refuses_single_axis() {
        let r_x = Matrix3::identity();
        let b = iso([0.0, 0.0, 1.0], 30.0, [0.1, 0.0, 0.0]);
        let a = iso([0.0, 0.0, 1.0], 30.0, [0.0, 1.0, 0.0]);
        let motions = vec![(a, b, 1.0), (a, b, 1.0)];
        // One rotation axis (z): t_X along it is unobservable, the normal matrix singular.
        assert!(mono_translation(&motions, &r_x).is_none());
    }

    #[test]
    fn pair_seeds_differ_and_are_stable() {
        assert_eq!(pair_seed(0, 1, 2), pair_seed(0, 1, 2));
        assert_ne!(pair_seed(0, 1, 2), pair_seed(0, 2, 1));
        assert_ne!(pair_seed(0, 1, 2), pair_seed(1, 1, 2));
    }
}
