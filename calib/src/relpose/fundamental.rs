//! Fundamental matrix from pixel correspondences: normalised 8-point algorithm inside a
//! seeded RANSAC with the Sampson distance, then a least-squares refit on the inliers. The
//! geometric verification of the "AKAZE + RANSAC" matching baseline: the scenes
//! are 3D, so a homography would reject correct matches off the dominant plane.
//!
//! **Model.** Pixels `x_a`, `x_b` (homogeneous) of one scene point in images `a` and `b`
//! satisfy `x_a^T F x_b = 0` with `F = K_a^-T [t]x R K_b^-1` of rank 2 for `(R, t) =
//! a_from_b` (Hartley & Zisserman 2004, sec. 9.2; the crate's `a_from_b` convention, as
//! [`super::essential`]).
//!
//! **Normalised 8-point** ([`fundamental_eight_point`], Hartley, "In defense of the
//! eight-point algorithm", PAMI 19(6) 1997; H&Z algorithm 11.1). Each image's points are
//! translated to their centroid and scaled to mean distance `sqrt 2` (`T_a`, `T_b`); each
//! pair gives the row `vec(x_a x_b^T)` of `A f = 0`; `f` is the eigenvector of the smallest
//! eigenvalue of `A^T A` (the last right singular vector of `A`, also when `A` has only 8
//! rows); the rank-2 constraint is imposed by zeroing the smallest singular value of `F^`
//! (H&Z sec. 11.1.1), and `F = T_a^T F^ T_b`, scaled to unit Frobenius norm.
//!
//! **Residual.** The Sampson distance (first-order geometric error, H&Z eq. 11.9)
//!
//! ```text
//! d^2 = (x_a^T F x_b)^2 / ((F x_b)_1^2 + (F x_b)_2^2 + (F^T x_a)_1^2 + (F^T x_a)_2^2)
//! ```
//!
//! in pixels. **Robust estimation** ([`estimate_fundamental_ransac`]): RANSAC/MSAC over
//! 8-point samples with the adaptive iteration count `log(1 - p) / log(1 - w^8)` and the
//! counter-based sampler of [`super::ransac`] (same input and seed, same bits); then up to
//! [`FundamentalParams::refit_rounds`] least-squares 8-point refits on all inliers with
//! re-selection, each kept only when it does not lower the inlier count.
//!
//! **Degenerate cases.** Fewer than 8 pairs, non-finite input, coincident points (no
//! normalisation), and fewer than [`FundamentalParams::min_inliers`] inliers are refused.
//! A dominant plane (all inliers on one homography) leaves a one-parameter family of `F`
//! that all explain the points: the estimate then verifies matches correctly but is not the
//! camera geometry (H&Z sec. 11.9.2); matching only needs the former.

use nalgebra::{Matrix3, Point2, SMatrix, SymmetricEigen, Vector3};

use super::ransac::{RansacConfig, ransac};
use super::{RelPoseError, check_lengths};

/// Minimal sample size of the linear fundamental-matrix solver.
pub const FUNDAMENTAL_SAMPLE_SIZE: usize = 8;

/// Parameters of [`estimate_fundamental_ransac`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FundamentalParams {
    /// Inlier threshold on the Sampson distance, pixels; default 1.0 (sub-pixel keypoints;
    /// OpenCV's `findFundamentalMat` defaults to 3).
    pub threshold_px: f64,
    /// Stopping rule; default p = 0.999, 50..5000 iterations.
    pub ransac: RansacConfig,
    /// Least-squares refits on the inliers after RANSAC; default 3.
    pub refit_rounds: usize,
    /// Fewest inliers for an accepted model; default 15.
    pub min_inliers: usize,
}

impl Default for FundamentalParams {
    fn default() -> Self {
        Self {
            threshold_px: 1.0,
            ransac: RansacConfig::default(),
            refit_rounds: 3,
            min_inliers: 15,
        }
    }
}

/// Result of [`estimate_fundamental_ransac`].
#[derive(Debug, Clone, PartialEq)]
pub struct FundamentalEstimate {
    /// `F` with `x_a^T F x_b = 0`, rank 2, unit Frobenius norm.
    pub f: Matrix3<f64>,
    /// `inliers[i]`: correspondence `i` is within the threshold.
    pub inliers: Vec<bool>,
    /// Number of inliers.
    pub inlier_count: usize,
    /// RANSAC iterations run.
    pub iterations: usize,
    /// Root mean square Sampson distance of the inliers, pixels.
    pub rms_sampson_px: f64,
}

/// Hartley's similarity: centroid to the origin, mean distance `sqrt 2`; `None` when the
/// points coincide or are not finite.
fn normalisation(p: &[Point2<f64>], idx: &[usize]) -> Option<Matrix3<f64>> {
    let n = idx.len() as f64;
    let (mut cx, mut cy) = (0.0, 0.0);
    for &i in idx {
        let q = p.get(i)?;
        cx += q.x;
        cy += q.y;
    }
    cx /= n;
    cy /= n;
    let mut d = 0.0;
    for &i in idx {
        let q = p.get(i)?;
        d += ((q.x - cx).powi(2) + (q.y - cy).powi(2)).sqrt();
    }
    d /= n;
    if !(d.is_finite() && d > 1e-12) {
        return None;
    }
    let s = std::f64::consts::SQRT_2 / d;
    Some(Matrix3::new(
        s,
        0.0,
        -s * cx,
        0.0,
        s,
        -s * cy,
        0.0,
        0.0,
        1.0,
    ))
}

/// The 8-point solution on the subset `idx` (module docs); `None` when degenerate.
fn eight_point_subset(
    x_a: &[Point2<f64>],
    x_b: &[Point2<f64>],
    idx: &[usize],
) -> Option<Matrix3<f64>> {
    if idx.len() < FUNDAMENTAL_SAMPLE_SIZE {
        return None;
    }
    let ta = normalisation(x_a, idx)?;
    let tb = normalisation(x_b, idx)?;
    let mut ata = SMatrix::<f64, 9, 9>::zeros();
    for &i in idx {
        let (pa, pb) = (x_a.get(i)?, x_b.get(i)?);
        let a = ta * Vector3::new(pa.x, pa.y, 1.0);
        let b = tb * Vector3::new(pb.x, pb.y, 1.0);
        let mut row = [0.0; 9];
        for m in 0..3 {
            for k in 0..3 {
                row[3 * m + k] = a[m] * b[k];
            }
        }
        for r in 0..9 {
            for c in r..9 {
                ata[(r, c)] += row[r] * row[c];
            }
        }
    }
    for r in 0..9 {
        for c in 0..r {
            ata[(r, c)] = ata[(c, r)];
        }
    }
    let eig = SymmetricEigen::try_new(ata, 1e-14, 1000)?;
    let (mut k, mut best) = (0, f64::INFINITY);
    for (j, v) in eig.eigenvalues.iter().enumerate() {
        if *v < best {
            best = *v;
            k = j;
        }
    }
    let v = eig.eigenvectors.column(k);
    let f_hat = Matrix3::from_fn(|m, n| v[3 * m + n]);
    let svd = f_hat.try_svd(true, true, 1e-14, 1000)?;
    let (u, v_t) = (svd.u?, svd.v_t?);
    let mut s = svd.singular_values;
    // nalgebra sorts singular values in decreasing order.
    s[2] = 0.0;
    let f2 = u * Matrix3::from_diagonal(&s) * v_t;
    let f = ta.transpose() * f2 * tb;
    let norm = f.norm();
    if !(norm.is_finite() && norm > 0.0) {
        return None;
    }
    let mut f = f / norm;
    // Fix the sign: largest-magnitude entry positive (for reproducible output).
    let imax = f.iamax_full();
    if f[imax] < 0.0 {
        f = -f;
    }
    Some(f)
}

/// Normalised 8-point fundamental matrix of all `n >= 8` correspondences (module docs).
///
/// # Errors
/// [`RelPoseError::LengthMismatch`], [`RelPoseError::TooFewCorrespondences`],
/// [`RelPoseError::NonFinite`], [`RelPoseError::Degenerate`] (coincident points or a failed
/// decomposition).
pub fn fundamental_eight_point(
    x_a: &[Point2<f64>],
    x_b: &[Point2<f64>],
) -> Result<Matrix3<f64>, RelPoseError> {
    check_lengths(x_a.len(), x_b.len(), FUNDAMENTAL_SAMPLE_SIZE)?;
    check_finite(x_a, x_b)?;
    let idx: Vec<usize> = (0..x_a.len()).collect();
    eight_point_subset(x_a, x_b, &idx).ok_or_else(|| RelPoseError::Degenerate {
        reason: format!(
            "8-point system of {} correspondences has no unique solution",
            x_a.len()
        ),
    })
}

fn check_finite(x_a: &[Point2<f64>], x_b: &[Point2<f64>]) -> Result<(), RelPoseError> {
    for (i, (a, b)) in x_a.iter().zip(x_b).enumerate() {
        if !(a.x.is_finite() && a.y.is_finite() && b.x.is_finite() && b.y.is_finite()) {
            return Err(RelPoseError::NonFinite { index: i });
        }
    }
    Ok(())
}

/// Squared Sampson distance (pixels^2) of `x_a <-> x_b` for `F` (module equation); infinite
/// when the denominator vanishes.
pub fn sampson_distance_sq(f: &Matrix3<f64>, x_a: &Point2<f64>, x_b: &Point2<f64>) -> f64 {
    let xa = Vector3::new(x_a.x, x_a.y, 1.0);
    let xb = Vector3::new(x_b.x, x_b.y, 1.0);
    let fb = f * xb;
    let fa = f.transpose() * xa;
    let r = xa.dot(&fb);
    let d = fb.x * fb.x + fb.y * fb.y + fa.x * fa.x + fa.y * fa.y;
    if d > 0.0 { r * r / d } else { f64::INFINITY }
}

fn select(
    f: &Matrix3<f64>,
    x_a: &[Point2<f64>],
    x_b: &[Point2<f64>],
    t2: f64,
) -> (Vec<bool>, usize, f64) {
    let mut sum = 0.0;
    let mut count = 0;
    let flags = x_a
        .iter()
        .zip(x_b)
        .map(|(a, b)| {
            let d2 = sampson_distance_sq(f, a, b);
            let inl = d2 <= t2;
            if inl {
                sum += d2;
                count += 1;
            }
            inl
        })
        .collect();
    (flags, count, sum)
}

/// Robust fundamental matrix (module docs). Deterministic for a given `seed`.
///
/// # Errors
/// [`RelPoseError::LengthMismatch`], [`RelPoseError::TooFewCorrespondences`] (< 8),
/// [`RelPoseError::NonFinite`], [`RelPoseError::InvalidParameter`] (threshold not positive),
/// [`RelPoseError::NoConsensus`] (fewer than `min_inliers` inliers).
pub fn estimate_fundamental_ransac(
    x_a: &[Point2<f64>],
    x_b: &[Point2<f64>],
    params: &FundamentalParams,
    seed: u64,
) -> Result<FundamentalEstimate, RelPoseError> {
    check_lengths(x_a.len(), x_b.len(), FUNDAMENTAL_SAMPLE_SIZE)?;
    check_finite(x_a, x_b)?;
    if !(params.threshold_px.is_finite() && params.threshold_px > 0.0) {
        return Err(RelPoseError::InvalidParameter {
            name: "threshold_px",
            value: params.threshold_px,
        });
    }
    let t2 = params.threshold_px * params.threshold_px;
    let needed = params.min_inliers.max(FUNDAMENTAL_SAMPLE_SIZE);
    let out = ransac(
        x_a.len(),
        FUNDAMENTAL_SAMPLE_SIZE,
        t2,
        &params.ransac,
        seed,
        |s, models| {
            if let Some(f) = eight_point_subset(x_a, x_b, s) {
                models.push(f);
            }
        },
        |f, i| match (x_a.get(i), x_b.get(i)) {
            (Some(a), Some(b)) => sampson_distance_sq(f, a, b),
            _ => f64::INFINITY,
        },
    );
    let Some(mut f) = out.model else {
        return Err(RelPoseError::NoConsensus {
            best_inliers: 0,
            needed,
        });
    };
    let (mut flags, mut count, mut sum) = select(&f, x_a, x_b, t2);
    for _ in 0..params.refit_rounds {
        let idx: Vec<usize> = (0..flags.len()).filter(|&i| flags[i]).collect();
        let Some(g) = eight_point_subset(x_a, x_b, &idx) else {
            break;
        };
        let (gf, gc, gs) = select(&g, x_a, x_b, t2);
        // Keep the refit when it keeps at least as many inliers (ties: lower cost).
        if gc > count || (gc == count && gs < sum) {
            let same = gf == flags;
            (f, flags, count, sum) = (g, gf, gc, gs);
            if same {
                break;
            }
        } else {
            break;
        }
    }
    if count < needed {
        return Err(RelPoseError::NoConsensus {
            best_inliers: count,
            needed,
        });
    }
    Ok(FundamentalEstimate {
        f,
        inliers: flags,
        inlier_count: count,
        iterations: out.iterations,
        rms_sampson_px: (sum / count as f64).sqrt(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::relpose::ransac::SplitMix64;
    use crate::relpose::skew;
    use nalgebra::Rotation3;

    /// Two 1280x1024 pinhole views (f = 1000 px) of a 3D cloud 2-6 m deep; returns the true
    /// `F` (`x_a^T F x_b = 0`), the pixel pairs and the inlier truth after replacing
    /// `outlier_fraction` of them by random pairs; `noise_px` Gaussian noise on inliers.
    /// True `F`, pixels in `a`, pixels in `b`, inlier truth.
    type Scene = (Matrix3<f64>, Vec<Point2<f64>>, Vec<Point2<f64>>, Vec<bool>);

    fn scene(n: usize, outlier_fraction: f64, noise_px: f64, seed: u64) -> Scene {
        let k = Matrix3::new(1000.0, 0.0, 640.0, 0.0, 1000.0, 512.0, 0.0, 0.0, 1.0);
        let r = Rotation3::from_euler_angles(0.05, -0.2, 0.1).into_inner();
        let t = Vector3::new(0.6, -0.1, 0.15);
        // a_from_b: p_a = R p_b + t.
        let k_inv = k.try_inverse().unwrap_or_else(Matrix3::identity);
        let f_true = k_inv.transpose() * skew(&t) * r * k_inv;
        let f_true = f_true / f_true.norm();
        let mut rng = SplitMix64::new(seed);
        let (mut xa, mut xb, mut truth) = (Vec::new(), Vec::new(), Vec::new());
        while xa.len() < n {
            let pb = Vector3::new(
                (rng.next_f64() - 0.5) * 4.0,
                (rng.next_f64() - 0.5) * 3.0,
                2.0 + 4.0 * rng.next_f64(),
            );
            let pa = r * pb + t;
            let (qa, qb) = (k * pa, k * pb);
            let a = Point2::new(qa.x / qa.z, qa.y / qa.z);
            let b = Point2::new(qb.x / qb.z, qb.y / qb.z);
            let inside =
                |p: &Point2<f64>| (0.0..1280.0).contains(&p.x) && (0.0..1024.0).contains(&p.y);
            if pa.z <= 0.0 || !inside(&a) || !inside(&b) {
                continue;
            }
            if rng.next_f64() < outlier_fraction {
                xa.push(a);
                xb.push(Point2::new(
                    rng.next_f64() * 1280.0,
                    rng.next_f64() * 1024.0,
                ));
                truth.push(false);
            } else {
                xa.push(Point2::new(
                    a.x + noise_px * rng.normal(),
                    a.y + noise_px * rng.normal(),
                ));
                xb.push(Point2::new(
                    b.x + noise_px * rng.normal(),
                    b.y + noise_px * rng.normal(),
                ));
                truth.push(true);
            }
        }
        (f_true, xa, xb, truth)
    }

    fn same_up_to_sign(f: &Matrix3<f64>, g: &Matrix3<f64>) -> f64 {
        let (f, g) = (f / f.norm(), g / g.norm());
        (f - g).norm().min((f + g).norm())
    }

    #[test]
    fn eight_point_is_exact_on_noise_free_points() {
        let (f_true, xa, xb, _) = scene(30, 0.0, 0.0, 3);
        let f = fundamental_eight_point(&xa, &xb).unwrap_or_else(|e| panic!("{e}"));
        assert!(same_up_to_sign(&f, &f_true) < 1e-8, "{f} vs {f_true}");
        assert!(f.determinant().abs() < 1e-12);
        for (a, b) in xa.iter().zip(&xb) {
            assert!(sampson_distance_sq(&f, a, b) < 1e-12);
        }
    }

    #[test]
    fn ransac_recovers_f_with_40_percent_outliers() {
        let (f_true, xa, xb, truth) = scene(500, 0.4, 0.3, 11);
        let est = estimate_fundamental_ransac(&xa, &xb, &FundamentalParams::default(), 7)
            .unwrap_or_else(|e| panic!("{e}"));
        let true_in = truth.iter().filter(|t| **t).count();
        let hits = est
            .inliers
            .iter()
            .zip(&truth)
            .filter(|(e, t)| **e && **t)
            .count();
        let false_pos = est
            .inliers
            .iter()
            .zip(&truth)
            .filter(|(e, t)| **e && !**t)
            .count();
        // Recall >= 95% of the true inliers (1 px threshold on 0.3 px noise keeps ~99%).
        assert!(hits as f64 >= 0.95 * true_in as f64, "{hits} of {true_in}");
        // A random pair lands within 1 px of an epipolar line with probability ~0.2%.
        assert!(false_pos <= 3, "{false_pos} outliers accepted");
        // The geometry: noise-free pairs of the true F have sub-pixel Sampson error under
        // the estimate, and F agrees with the truth.
        let (_, ca, cb, _) = scene(200, 0.0, 0.0, 99);
        let worst = ca
            .iter()
            .zip(&cb)
            .map(|(a, b)| sampson_distance_sq(&est.f, a, b).sqrt())
            .fold(0.0, f64::max);
        assert!(worst < 0.5, "worst Sampson distance {worst} px");
        assert!(same_up_to_sign(&est.f, &f_true) < 0.02);
        assert!(est.rms_sampson_px < 0.5);
        // Deterministic for a seed.
        let again = estimate_fundamental_ransac(&xa, &xb, &FundamentalParams::default(), 7)
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(est, again);
    }

    #[test]
    fn refuses_degenerate_input() {
        let p = vec![Point2::new(1.0, 2.0); 10];
        assert!(matches!(
            fundamental_eight_point(&p, &p),
            Err(RelPoseError::Degenerate { .. })
        ));
        assert!(matches!(
            fundamental_eight_point(&p[..5], &p[..5]),
            Err(RelPoseError::TooFewCorrespondences { got: 5, need: 8 })
        ));
        let mut q = p.clone();
        q[3].x = f64::NAN;
        assert!(matches!(
            estimate_fundamental_ransac(&q, &p, &FundamentalParams::default(), 1),
            Err(RelPoseError::NonFinite { index: 3 })
        ));
        let (_, xa, _, _) = scene(100, 0.0, 0.0, 5);
        let mut rng = SplitMix64::new(4);
        let random: Vec<Point2<f64>> = (0..100)
            .map(|_| Point2::new(rng.next_f64() * 1280.0, rng.next_f64() * 1024.0))
            .collect();
        let params = FundamentalParams {
            min_inliers: 40,
            ..FundamentalParams::default()
        };
        assert!(matches!(
            estimate_fundamental_ransac(&xa, &random, &params, 1),
            Err(RelPoseError::NoConsensus { .. })
        ));
    }
}
