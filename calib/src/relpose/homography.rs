//! Relative pose of a planar scene: homography RANSAC and its Euclidean decomposition.
//!
//! Points on one plane `n^T p_b = d` (in camera `b`) map between the views by
//! `x_a ~ H x_b`, `H = R + t n^T / d` for `(R, t) = a_from_b` in normalised coordinates
//! (Hartley & Zisserman 2004, result 13.1). When the plane fills the view, every `E = [t']x H`
//! explains the correspondences equally well, so the essential matrix is undetermined
//! ([`super::essential`], module docs) while `H` is not: it is then the model to estimate.
//!
//! **Estimation** ([`estimate_homography_ransac`]): 4-point normalised DLT samples
//! ([`crate::board::pnp::homography_dlt`]), MSAC on the symmetric transfer error
//! `|x_a - H x_b|^2 + |x_b - H^-1 x_a|^2`, local optimisation by the DLT on all inliers
//! ([`super::ransac::ransac_lo`]).
//!
//! **Decomposition** ([`decompose_homography`]): Faugeras & Lustman, "Motion and structure
//! from motion in a piecewise planar environment", IJPRAI 2(3), 1988: with
//! `H = U diag(d1, d2, d3) V^T` (`d1 > d2 > d3`, `s = det U det V`) the eight `(R, t, n)` of
//! the cases `d' = +-d2`, of which at most two are physical; as in ORB-SLAM's two-view
//! initialisation (Mur-Artal et al., IEEE T-RO 31(5), 2015, sec. IV-C) the one with the most
//! correspondences triangulated in front of both cameras is kept, and an ambiguity between
//! two is refused unless a rotation-angle prior separates them.

use nalgebra::{Isometry3, Matrix3, Point2, Rotation3, Translation3, UnitQuaternion, Vector3};

use super::essential::select;
use super::ransac::{RansacConfig, RansacOutcome, ransac_lo};
use crate::board::pnp::homography_dlt;

/// Minimal sample size of a homography.
pub const HOMOGRAPHY_SAMPLE_SIZE: usize = 4;

/// Smallest relative gap between singular values of `H` for the decomposition (equal ones:
/// no translation, or a plane through the camera centre; the motion is then not recoverable).
pub const MIN_SINGULAR_GAP: f64 = 1e-5;

/// The homography RANSAC's result: `x_a ~ H x_b`.
pub type HomographyOutcome = RansacOutcome<Matrix3<f64>>;

/// Maps `x` by `h`; `None` at infinity.
fn transfer(h: &Matrix3<f64>, x: &Point2<f64>) -> Option<Point2<f64>> {
    let p = h * Vector3::new(x.x, x.y, 1.0);
    (p.z.abs() > 1e-15).then(|| Point2::new(p.x / p.z, p.y / p.z))
}

/// Symmetric transfer error `|x_a - H x_b|^2 + |x_b - H^-1 x_a|^2` (normalised units).
pub fn symmetric_transfer_sq(
    h: &Matrix3<f64>,
    h_inv: &Matrix3<f64>,
    x_a: &Point2<f64>,
    x_b: &Point2<f64>,
) -> f64 {
    match (transfer(h, x_b), transfer(h_inv, x_a)) {
        (Some(pa), Some(pb)) => (pa - x_a).norm_squared() + (pb - x_b).norm_squared(),
        _ => f64::INFINITY,
    }
}

/// Homography `x_a ~ H x_b` by RANSAC (module docs); an inlier's symmetric transfer error is
/// at most `2 threshold^2`. Deterministic for a given `seed`.
pub fn estimate_homography_ransac(
    x_a: &[Point2<f64>],
    x_b: &[Point2<f64>],
    threshold: f64,
    config: &RansacConfig,
    seed: u64,
) -> HomographyOutcome {
    let n = x_a.len().min(x_b.len());
    // (H, H^-1) pairs, so the residual does not invert per datum.
    let with_inverse = |h: Matrix3<f64>| h.try_inverse().map(|hi| (h, hi));
    let outcome = ransac_lo(
        n,
        HOMOGRAPHY_SAMPLE_SIZE,
        2.0 * threshold * threshold,
        config,
        seed,
        |s, models| {
            let src: Vec<_> = s.iter().filter_map(|&q| x_b.get(q).copied()).collect();
            let dst: Vec<_> = s.iter().filter_map(|&q| x_a.get(q).copied()).collect();
            if let Some(m) = homography_dlt(&src, &dst).ok().and_then(with_inverse) {
                models.push(m);
            }
        },
        |(h, hi), i| match (x_a.get(i), x_b.get(i)) {
            (Some(a), Some(b)) => symmetric_transfer_sq(h, hi, a, b),
            _ => f64::INFINITY,
        },
        |_, mask, models| {
            let src = select(x_b, mask);
            let dst = select(x_a, mask);
            if let Some(m) = homography_dlt(&src, &dst).ok().and_then(with_inverse) {
                models.push(m);
            }
        },
    );
    RansacOutcome {
        model: outcome.model.map(|(h, _)| h),
        inliers: outcome.inliers,
        inlier_count: outcome.inlier_count,
        cost: outcome.cost,
        iterations: outcome.iterations,
    }
}

/// One decomposition of a homography: `a_from_b` with `|t| = 1` and the plane normal in
/// camera `b`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlanarMotion {
    /// `a_from_b`, unit translation.
    pub a_from_b: Isometry3<f64>,
    /// Unit plane normal in camera `b`, pointing towards the camera (`n_z > 0`).
    pub normal_in_b: Vector3<f64>,
}

/// The eight candidate motions of `x_a ~ H x_b` (module docs; Faugeras & Lustman 1988 in
/// the form of ORB-SLAM's `ReconstructH`). `None` when two singular values coincide (no
/// translation, or the camera on the plane) or the SVD fails.
pub fn decompose_homography(h: &Matrix3<f64>) -> Option<Vec<PlanarMotion>> {
    let svd = h.svd(true, true);
    let (u, v_t) = (svd.u?, svd.v_t?);
    let mut order = [0usize, 1, 2];
    order.sort_by(|&i, &j| svd.singular_values[j].total_cmp(&svd.singular_values[i]));
    let u = Matrix3::from_columns(&order.map(|k| u.column(k).into_owned()));
    let v = Matrix3::from_columns(&order.map(|k| v_t.row(k).transpose()));
    let [d1, d2, d3] = order.map(|k| svd.singular_values[k]);
    if d3.is_nan()
        || d3 <= 0.0
        || d1 / d2 < 1.0 + MIN_SINGULAR_GAP
        || d2 / d3 < 1.0 + MIN_SINGULAR_GAP
    {
        return None;
    }
    let s = u.determinant() * v.determinant();
    let (d1s, d2s, d3s) = (d1 * d1, d2 * d2, d3 * d3);
    let aux1 = ((d1s - d2s) / (d1s - d3s)).sqrt();
    let aux3 = ((d2s - d3s) / (d1s - d3s)).sqrt();
    let x1 = [aux1, aux1, -aux1, -aux1];
    let x3 = [aux3, -aux3, aux3, -aux3];
    let root = ((d1s - d2s) * (d2s - d3s)).sqrt();
    let mut out = Vec::with_capacity(8);
    let mut push = |rp: Matrix3<f64>, tp: Vector3<f64>, np: Vector3<f64>| {
        let r = s * u * rp * v.transpose();
        let t = u * tp;
        let mut n = v * np;
        if n.z < 0.0 {
            n = -n;
        }
        let tn = t.norm();
        if tn > 0.0 && tn.is_finite() {
            let rot = Rotation3::from_matrix_unchecked(r);
            out.push(PlanarMotion {
                a_from_b: Isometry3::from_parts(
                    Translation3::from(t / tn),
                    UnitQuaternion::from_rotation_matrix(&rot),
                ),
                normal_in_b: n.normalize(),
            });
        }
    };
    // d' = d2.
    let st = root / ((d1 + d3) * d2);
    let ct = (d2s + d1 * d3) / ((d1 + d3) * d2);
    for (i, sti) in [st, -st, -st, st].into_iter().enumerate() {
        let rp = Matrix3::new(ct, 0.0, -sti, 0.0, 1.0, 0.0, sti, 0.0, ct);
        push(
            rp,
            Vector3::new(x1[i], 0.0, -x3[i]) * (d1 - d3),
            Vector3::new(x1[i], 0.0, x3[i]),
        );
    }
    // d' = -d2.
    let sp = root / ((d1 - d3) * d2);
    let cp = (d1 * d3 - d2s) / ((d1 - d3) * d2);
    for (i, spi) in [sp, -sp, -sp, sp].into_iter().enumerate() {
        let rp = Matrix3::new(cp, 0.0, spi, 0.0, -1.0, 0.0, spi, 0.0, -cp);
        push(
            rp,
            Vector3::new(x1[i], 0.0, x3[i]) * (d1 + d3),
            Vector3::new(x1[i], 0.0, x3[i]),
        );
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::relpose::ransac::RansacConfig;
    use nalgebra::{Point3, Unit};

    fn motion() -> Isometry3<f64> {
        Isometry3::from_parts(
            Translation3::new(0.12, -0.04, 0.03),
            UnitQuaternion::from_axis_angle(
                &Unit::new_normalize(Vector3::new(0.3, 1.0, -0.2)),
                0.35,
            ),
        )
    }

    /// Points of the plane `z = 0.45 + 0.2 x` in camera b, seen by both cameras.
    fn plane_views(a_from_b: &Isometry3<f64>) -> (Vec<Point2<f64>>, Vec<Point2<f64>>) {
        let mut xa = Vec::new();
        let mut xb = Vec::new();
        for i in 0..15 {
            for j in 0..12 {
                let x = -0.15 + 0.02 * f64::from(i);
                let y = -0.12 + 0.02 * f64::from(j);
                let p_b = Point3::new(x, y, 0.45 + 0.2 * x);
                let p_a = a_from_b * p_b;
                xb.push(Point2::new(p_b.x / p_b.z, p_b.y / p_b.z));
                xa.push(Point2::new(p_a.x / p_a.z, p_a.y / p_a.z));
            }
        }
        (xa, xb)
    }

    #[test]
    fn the_true_motion_is_among_the_decompositions() {
        let m = motion();
        let (xa, mut xb) = plane_views(&m);
        // A tenth of the correspondences are gross outliers.
        for (k, p) in xb.iter_mut().enumerate().filter(|(k, _)| k % 10 == 3) {
            p.x += 0.05 * (k as f64).sin();
        }
        let out = estimate_homography_ransac(&xa, &xb, 1e-4, &RansacConfig::default(), 3);
        assert_eq!(out.inlier_count, xa.len() - xa.len().div_ceil(10));
        let h = out.model.expect("homography");
        let cands = decompose_homography(&h).expect("decomposable");
        assert_eq!(cands.len(), 8);
        let t = m.translation.vector.normalize();
        let best = cands
            .iter()
            .map(|c| {
                let dr = (c.a_from_b.rotation.inverse() * m.rotation).angle();
                let dt = (c.a_from_b.translation.vector - t).norm();
                dr + dt
            })
            .fold(f64::INFINITY, f64::min);
        assert!(best < 1e-8, "closest candidate off by {best}");
    }

    #[test]
    fn a_pure_rotation_is_not_decomposed() {
        let r = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), 0.2);
        let h = r.to_rotation_matrix().into_inner();
        assert!(decompose_homography(&h).is_none());
    }
}
