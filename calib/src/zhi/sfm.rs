//! Geometry of ZHI's reconstruction: feature tracks, multi-view triangulation, camera
//! resection (PnP) and the resection-intersection refinement.
//!
//! # Conventions
//!
//! Camera poses are `cam_from_world` (`p_in_cam = R p_in_world + t`), observations are
//! normalised undistorted image points `x = (X/Z, Y/Z)`; pixel errors are normalised errors
//! times the mean focal length `f`.
//!
//! # Methods
//!
//! - **Tracks**: union-find over the `(view, keypoint)` nodes joined by the verified
//!   (essential-RANSAC inlier) matches of every pair (Snavely et al., "Photo tourism", 2006,
//!   sec. 4.1); a view holding two keypoints of one track is ambiguous and left out of it
//!   (the track is kept when at least two views remain).
//! - **Triangulation** ([`triangulate_track`]): linear DLT over all observations (Hartley &
//!   Zisserman 2004, sec. 12.2: rows `x P^3 - P^1`, `y P^3 - P^2`, the eigenvector of the
//!   smallest eigenvalue of `A^T A`), then 3 Gauss-Newton steps on the reprojection error;
//!   accepted when every observation reprojects within the threshold, lies in front of its
//!   camera, and the widest pair of rays spans at least the minimum triangulation angle.
//! - **Resection** ([`pnp_ransac`]): the 6-point DLT of the projection matrix (H&Z 2004,
//!   sec. 7.1, with the 3D points normalised to zero mean and unit RMS distance) inside
//!   RANSAC/MSAC on the pixel reprojection error; `M = P_{3x3}` is made a rotation by
//!   `R = U V^T` of its SVD and `t = p_4 / mean(sigma)`; then [`refine_pose`]
//!   (Gauss-Newton/Levenberg-Marquardt with Huber weights, left-multiplicative update
//!   `R <- exp([w]x) R`, `t <- exp([w]x) t + dt`) on the inliers.
//!
//! Degenerate cases: fewer than 6 correspondences or coplanar samples (the DLT has a
//! 2-dimensional null space): no model; non-finite values are skipped.

use std::collections::BTreeMap;

use nalgebra::{
    DMatrix, Isometry3, Matrix3, Matrix4, Matrix6, Point2, Point3, Rotation3, Translation3,
    UnitQuaternion, Vector2, Vector3, Vector4, Vector6,
};

use crate::relpose::ransac::{RansacConfig, ransac};

/// Minimal sample of the DLT resection.
pub const PNP_SAMPLE_SIZE: usize = 6;

/// Verified matches of one view pair: `(view_i, view_j, [(keypoint_i, keypoint_j)])`.
pub type PairMatches = (usize, usize, Vec<(usize, usize)>);

/// One observation of a track.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Observation {
    /// View index.
    pub view: usize,
    /// Keypoint index in that view.
    pub keypoint: usize,
    /// Normalised undistorted image point.
    pub x: Point2<f64>,
}

/// A feature track: the observations of one scene point.
#[derive(Debug, Clone, PartialEq)]
pub struct Track {
    /// Observations, one per view, ordered by view.
    pub observations: Vec<Observation>,
    /// The triangulated point (world = the first camera of the initial pair).
    pub point: Option<Point3<f64>>,
}

fn find(parent: &mut [usize], mut a: usize) -> usize {
    while let Some(&p) = parent.get(a) {
        if p == a {
            break;
        }
        let gp = parent.get(p).copied().unwrap_or(p);
        if let Some(slot) = parent.get_mut(a) {
            *slot = gp;
        }
        a = gp;
    }
    a
}

/// Tracks from pairwise matches (module docs). `points[v][k]` is the normalised point of
/// keypoint `k` of view `v` (`None` when its undistortion failed); `matches` holds
/// `(view_i, view_j, [(keypoint_i, keypoint_j)])`. Views with two keypoints in a track are
/// left out of it; tracks with fewer than 2 views are dropped. Deterministic order (by
/// smallest node).
pub fn build_tracks(points: &[Vec<Option<Point2<f64>>>], matches: &[PairMatches]) -> Vec<Track> {
    let mut offset = Vec::with_capacity(points.len() + 1);
    let mut total = 0;
    for p in points {
        offset.push(total);
        total += p.len();
    }
    let node = |v: usize, k: usize| offset.get(v).map(|o| o + k);
    let mut parent: Vec<usize> = (0..total).collect();
    for (vi, vj, m) in matches {
        for &(ki, kj) in m {
            let (Some(a), Some(b)) = (node(*vi, ki), node(*vj, kj)) else {
                continue;
            };
            if a >= total || b >= total {
                continue;
            }
            let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
            if ra != rb {
                let (lo, hi) = (ra.min(rb), ra.max(rb));
                if let Some(s) = parent.get_mut(hi) {
                    *s = lo;
                }
            }
        }
    }
    let mut groups: BTreeMap<usize, Vec<(usize, usize)>> = BTreeMap::new();
    for (v, pv) in points.iter().enumerate() {
        for k in 0..pv.len() {
            let Some(n) = node(v, k) else { continue };
            let r = find(&mut parent, n);
            groups.entry(r).or_default().push((v, k));
        }
    }
    groups
        .into_values()
        .filter(|g| g.len() >= 2)
        .filter_map(|mut g| {
            g.sort_unstable();
            // Views holding two keypoints of the track are ambiguous: drop those views.
            let views: Vec<usize> = g.iter().map(|n| n.0).collect();
            g.retain(|n| views.iter().filter(|v| **v == n.0).count() == 1);
            let observations: Vec<Observation> = g
                .iter()
                .filter_map(|&(view, keypoint)| {
                    let x = (*points.get(view)?.get(keypoint)?)?;
                    Some(Observation { view, keypoint, x })
                })
                .collect();
            (observations.len() >= 2).then_some(Track {
                observations,
                point: None,
            })
        })
        .collect()
}

/// Reprojection error of `p_in_world` in a camera, normalised units; `None` behind it.
pub fn reprojection_error(
    cam_from_world: &Isometry3<f64>,
    p_in_world: &Point3<f64>,
    x: &Point2<f64>,
) -> Option<f64> {
    let p = cam_from_world * p_in_world;
    if p.z <= 0.0 {
        return None;
    }
    Some(((p.x / p.z - x.x).powi(2) + (p.y / p.z - x.y).powi(2)).sqrt())
}

/// Acceptance rules of [`triangulate_track`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TriangulationRules {
    /// Largest reprojection error of any used observation, normalised units.
    pub max_error: f64,
    /// Smallest angle between the widest pair of rays, radians.
    pub min_angle_rad: f64,
}

/// Multi-view DLT + Gauss-Newton triangulation of `obs` seen by `cams` (module docs).
/// Returns the point when it passes `rules`.
pub fn triangulate_track(
    cams: &[Isometry3<f64>],
    obs: &[Point2<f64>],
    rules: &TriangulationRules,
) -> Option<Point3<f64>> {
    if cams.len() < 2 || cams.len() != obs.len() {
        return None;
    }
    let mut ata = Matrix4::<f64>::zeros();
    for (c, x) in cams.iter().zip(obs) {
        let p = c.to_homogeneous();
        let (r0, r1, r2) = (p.row(0), p.row(1), p.row(2));
        for row in [x.x * r2 - r0, x.y * r2 - r1] {
            let n = row.norm();
            if n > 0.0 {
                let r = row.transpose() / n;
                ata += r * r.transpose();
            }
        }
    }
    let eig = ata.symmetric_eigen();
    let (k, _) = eig
        .eigenvalues
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(b.1))?;
    let h: Vector4<f64> = eig.eigenvectors.column(k).into_owned();
    if h.w.abs() <= 1e-12 * h.norm() {
        return None;
    }
    let mut p = Point3::new(h.x / h.w, h.y / h.w, h.z / h.w);
    // Gauss-Newton on the reprojection error.
    for _ in 0..3 {
        let mut jtj = Matrix3::<f64>::zeros();
        let mut jtr = Vector3::<f64>::zeros();
        for (c, x) in cams.iter().zip(obs) {
            let q = c * p;
            if q.z <= 0.0 {
                return None;
            }
            let r = Vector2::new(q.x / q.z - x.x, q.y / q.z - x.y);
            let dproj = nalgebra::Matrix2x3::new(
                1.0 / q.z,
                0.0,
                -q.x / (q.z * q.z),
                0.0,
                1.0 / q.z,
                -q.y / (q.z * q.z),
            );
            let j = dproj * c.rotation.to_rotation_matrix().matrix();
            jtj += j.transpose() * j;
            jtr += j.transpose() * r;
        }
        let Some(step) = jtj.try_inverse().map(|inv| inv * jtr) else {
            break;
        };
        p -= step;
        if step.norm() < 1e-12 * p.coords.norm().max(1e-12) {
            break;
        }
    }
    let mut centres = Vec::with_capacity(cams.len());
    for (c, x) in cams.iter().zip(obs) {
        if reprojection_error(c, &p, x)? > rules.max_error {
            return None;
        }
        centres.push(c.inverse_transform_point(&Point3::origin()));
    }
    let mut widest = 0.0f64;
    for (a, ca) in centres.iter().enumerate() {
        for cb in centres.iter().skip(a + 1) {
            widest = widest.max((ca - p).angle(&(cb - p)));
        }
    }
    (widest >= rules.min_angle_rad).then_some(p)
}

/// 6-point DLT resection of normalised 3D points (module docs); `None` when degenerate.
fn pnp_dlt(world: &[Point3<f64>], image: &[Point2<f64>]) -> Option<Isometry3<f64>> {
    let n = world.len();
    if n < PNP_SAMPLE_SIZE || image.len() != n {
        return None;
    }
    let c = world.iter().map(|p| p.coords).sum::<Vector3<f64>>() / n as f64;
    let rms = (world
        .iter()
        .map(|p| (p.coords - c).norm_squared())
        .sum::<f64>()
        / n as f64)
        .sqrt();
    if !(rms > 0.0 && rms.is_finite()) {
        return None;
    }
    let s = rms / 3f64.sqrt();
    let mut a = DMatrix::<f64>::zeros(2 * n, 12);
    for (i, (p, x)) in world.iter().zip(image).enumerate() {
        let q = (p.coords - c) / s;
        let hq = [q.x, q.y, q.z, 1.0];
        for (col, v) in hq.iter().enumerate() {
            a[(2 * i, col)] = *v;
            a[(2 * i, 8 + col)] = -x.x * v;
            a[(2 * i + 1, 4 + col)] = *v;
            a[(2 * i + 1, 8 + col)] = -x.y * v;
        }
    }
    let ata = a.transpose() * &a;
    let eig = ata.symmetric_eigen();
    let mut order: Vec<usize> = (0..12).collect();
    order.sort_by(|&i, &j| {
        eig.eigenvalues
            .get(i)
            .unwrap_or(&f64::INFINITY)
            .total_cmp(eig.eigenvalues.get(j).unwrap_or(&f64::INFINITY))
    });
    let k = *order.first()?;
    let k2 = *order.get(1)?;
    // A second (near-)null vector: the sample does not determine P (e.g. coplanar points).
    let (Some(&l2), max) = (eig.eigenvalues.get(k2), eig.eigenvalues.amax()) else {
        return None;
    };
    if l2 <= 1e-10 * max.max(1e-300) {
        return None;
    }
    let v = eig.eigenvectors.column(k);
    let pm = nalgebra::Matrix3x4::from_fn(|r, col| v[4 * r + col]);
    let m0 = pm.fixed_view::<3, 3>(0, 0) / s;
    let p4 = pm.column(3) - m0 * c;
    let (mut m, mut p4) = (m0, p4.into_owned());
    if m.determinant() < 0.0 {
        m = -m;
        p4 = -p4;
    }
    let svd = m.svd(true, true);
    let (u, vt) = (svd.u?, svd.v_t?);
    let r = u * vt;
    let scale = svd.singular_values.mean();
    if !(scale > 0.0 && scale.is_finite()) || r.determinant() <= 0.0 {
        return None;
    }
    let t = p4 / scale;
    Some(Isometry3::from_parts(
        Translation3::from(t),
        UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r)),
    ))
}

/// Result of [`pnp_ransac`].
#[derive(Debug, Clone, PartialEq)]
pub struct PnpEstimate {
    /// `cam_from_world`.
    pub cam_from_world: Isometry3<f64>,
    /// Inlier flags (reprojection within the threshold after refinement).
    pub inliers: Vec<bool>,
    /// Number of inliers.
    pub inlier_count: usize,
}

/// Camera resection by DLT RANSAC + refinement (module docs); `threshold` in normalised
/// units. `None` without a model with at least `min_inliers` inliers.
pub fn pnp_ransac(
    world: &[Point3<f64>],
    image: &[Point2<f64>],
    threshold: f64,
    min_inliers: usize,
    seed: u64,
) -> Option<PnpEstimate> {
    let n = world.len();
    if n < PNP_SAMPLE_SIZE.max(min_inliers) || image.len() != n {
        return None;
    }
    let residual = |m: &Isometry3<f64>, i: usize| -> f64 {
        match (world.get(i), image.get(i)) {
            (Some(p), Some(x)) => reprojection_error(m, p, x).map_or(f64::INFINITY, |e| e * e),
            _ => f64::INFINITY,
        }
    };
    let config = RansacConfig {
        confidence: 0.999,
        min_iterations: 100,
        max_iterations: 3000,
    };
    let out = ransac(
        n,
        PNP_SAMPLE_SIZE,
        threshold * threshold,
        &config,
        seed,
        |s, models| {
            let w: Vec<Point3<f64>> = s.iter().filter_map(|&i| world.get(i).copied()).collect();
            let x: Vec<Point2<f64>> = s.iter().filter_map(|&i| image.get(i).copied()).collect();
            if let Some(m) = pnp_dlt(&w, &x) {
                models.push(m);
            }
        },
        residual,
    );
    let mut pose = out.model?;
    let mut inliers = out.inliers;
    for _ in 0..2 {
        let (w, x): (Vec<Point3<f64>>, Vec<Point2<f64>>) = world
            .iter()
            .zip(image)
            .zip(&inliers)
            .filter(|(_, k)| **k)
            .map(|((p, x), _)| (*p, *x))
            .unzip();
        pose = refine_pose(&pose, &w, &x, threshold, 10);
        inliers = (0..n)
            .map(|i| residual(&pose, i) <= threshold * threshold)
            .collect();
    }
    let inlier_count = inliers.iter().filter(|k| **k).count();
    (inlier_count >= min_inliers).then_some(PnpEstimate {
        cam_from_world: pose,
        inliers,
        inlier_count,
    })
}

/// Gauss-Newton/LM refinement of `cam_from_world` on the reprojection errors of
/// `world <-> image` (normalised units), Huber weights with knee `huber` (module docs).
pub fn refine_pose(
    cam_from_world: &Isometry3<f64>,
    world: &[Point3<f64>],
    image: &[Point2<f64>],
    huber: f64,
    iterations: usize,
) -> Isometry3<f64> {
    let cost = |pose: &Isometry3<f64>| -> f64 {
        world
            .iter()
            .zip(image)
            .map(|(p, x)| {
                let e = reprojection_error(pose, p, x).unwrap_or(10.0 * huber);
                if e <= huber {
                    0.5 * e * e
                } else {
                    huber * (e - 0.5 * huber)
                }
            })
            .sum()
    };
    let mut pose = *cam_from_world;
    let mut current = cost(&pose);
    let mut lambda = 1e-6;
    for _ in 0..iterations {
        let mut h = Matrix6::<f64>::zeros();
        let mut g = Vector6::<f64>::zeros();
        for (p, x) in world.iter().zip(image) {
            let q = pose * p;
            if q.z <= 0.0 {
                continue;
            }
            let r = Vector2::new(q.x / q.z - x.x, q.y / q.z - x.y);
            let e = r.norm();
            let w = if e <= huber { 1.0 } else { huber / e };
            let dproj = nalgebra::Matrix2x3::new(
                1.0 / q.z,
                0.0,
                -q.x / (q.z * q.z),
                0.0,
                1.0 / q.z,
                -q.y / (q.z * q.z),
            );
            let mut j = nalgebra::Matrix2x6::<f64>::zeros();
            j.fixed_view_mut::<2, 3>(0, 0)
                .copy_from(&(dproj * -crate::relpose::skew(&q.coords)));
            j.fixed_view_mut::<2, 3>(0, 3).copy_from(&dproj);
            h += w * j.transpose() * j;
            g += w * j.transpose() * r;
        }
        let mut improved = false;
        for _ in 0..8 {
            let mut hd = h;
            for d in 0..6 {
                hd[(d, d)] += lambda * (1.0 + h[(d, d)]);
            }
            let Some(step) = hd.try_inverse().map(|inv| -(inv * g)) else {
                lambda *= 10.0;
                continue;
            };
            let w = Vector3::new(step[0], step[1], step[2]);
            let dt = Vector3::new(step[3], step[4], step[5]);
            let dr = UnitQuaternion::from_scaled_axis(w);
            let cand = Isometry3::from_parts(
                Translation3::from(dr * pose.translation.vector + dt),
                dr * pose.rotation,
            );
            let c = cost(&cand);
            if c <= current {
                let rel = (current - c) / current.max(1e-300);
                pose = cand;
                current = c;
                lambda = (lambda * 0.1).max(1e-12);
                improved = rel > 1e-12;
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    pose
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Unit;

    fn iso(axis: [f64; 3], deg: f64, t: [f64; 3]) -> Isometry3<f64> {
        Isometry3::from_parts(
            Translation3::new(t[0], t[1], t[2]),
            UnitQuaternion::from_axis_angle(
                &Unit::new_normalize(Vector3::new(axis[0], axis[1], axis[2])),
                deg.to_radians(),
            ),
        )
    }

    fn cloud(n: usize) -> Vec<Point3<f64>> {
        (0..n)
            .map(|i| {
                let f = i as f64;
                Point3::new(
                    0.3 * (f * 0.731).sin(),
                    0.25 * (f * 1.37).cos(),
                    2.0 + 0.4 * (f * 0.53).sin(),
                )
            })
            .collect()
    }

    fn project(c: &Isometry3<f64>, p: &Point3<f64>) -> Point2<f64> {
        let q = c * p;
        Point2::new(q.x / q.z, q.y / q.z)
    }

    #[test]
    fn pnp_recovers_pose_with_outliers() {
        let pts = cloud(120);
        let cam = iso([0.2, 1.0, 0.1], 12.0, [0.1, -0.05, 0.2]);
        let mut img: Vec<Point2<f64>> = pts.iter().map(|p| project(&cam, p)).collect();
        for (i, x) in img.iter_mut().enumerate() {
            if i % 4 == 0 {
                *x = Point2::new(x.x + 0.05, x.y - 0.03); // 25% gross outliers
            }
        }
        let est = pnp_ransac(&pts, &img, 2.0 / 1745.0, 20, 7).expect("pose");
        let d = est.cam_from_world.inverse() * cam;
        assert!(d.translation.vector.norm() < 1e-9, "{d:?}");
        assert!(d.rotation.angle() < 1e-9);
        assert_eq!(est.inlier_count, 90);
        assert!(!est.inliers[0] && est.inliers[1]);
    }

    #[test]
    fn triangulation_is_exact_and_refuses_small_angles() {
        let p = Point3::new(0.1, -0.2, 2.5);
        let cams = [
            Isometry3::identity(),
            iso([0.0, 1.0, 0.0], 5.0, [-0.3, 0.0, 0.0]),
            iso([1.0, 0.0, 0.0], -4.0, [0.0, 0.25, 0.05]),
        ];
        let obs: Vec<Point2<f64>> = cams.iter().map(|c| project(c, &p)).collect();
        let rules = TriangulationRules {
            max_error: 1e-6,
            min_angle_rad: 1f64.to_radians(),
        };
        let got = triangulate_track(&cams, &obs, &rules).expect("point");
        assert!((got - p).norm() < 1e-9);
        // Two cameras 1 mm apart: the rays are nearly parallel.
        let near = [
            Isometry3::identity(),
            iso([0.0, 1.0, 0.0], 0.0, [-0.001, 0.0, 0.0]),
        ];
        let obs2: Vec<Point2<f64>> = near.iter().map(|c| project(c, &p)).collect();
        assert!(triangulate_track(&near, &obs2, &rules).is_none());
    }

    #[test]
    fn tracks_join_pairs_and_drop_conflicts() {
        let pt = |x: f64| Some(Point2::new(x, 0.0));
        let points = vec![
            vec![pt(0.0), pt(0.1)],
            vec![pt(1.0), pt(1.1)],
            vec![pt(2.0)],
        ];
        // 0:0 - 1:0 - 2:0 forms one track, 0:1 - 1:1 another.
        let matches = vec![(0, 1, vec![(0, 0), (1, 1)]), (1, 2, vec![(0, 0)])];
        let tracks = build_tracks(&points, &matches);
        assert_eq!(tracks.len(), 2);
        let views: Vec<Vec<usize>> = tracks
            .iter()
            .map(|t| t.observations.iter().map(|o| o.view).collect())
            .collect();
        assert_eq!(views, vec![vec![0, 1, 2], vec![0, 1]]);
        // 0:0 - 1:0 - 0:1 puts two keypoints of view 0 into one track: view 0 is left out,
        // one view remains, the track is dropped; with 2:0 joined, 1:0 - 2:0 remains.
        let conflicting = vec![(0, 1, vec![(0, 0), (1, 0)])];
        assert!(build_tracks(&points, &conflicting).is_empty());
        let partial = vec![(0, 1, vec![(0, 0), (1, 0)]), (1, 2, vec![(0, 0)])];
        let t = build_tracks(&points, &partial);
        assert_eq!(t.len(), 1);
        let v: Vec<usize> = t[0].observations.iter().map(|o| o.view).collect();
        assert_eq!(v, vec![1, 2]);
    }
}
