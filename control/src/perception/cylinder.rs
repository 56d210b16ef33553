//! Cylinder of known radius: RANSAC from 2 points with normals, then Levenberg-Marquardt on
//! the point-to-surface distance.
//!
//! # Model
//! Axis through `c` with unit direction `d`, radius `r`. For a point `p`: `v = p - c`,
//! `w = v - (v·d) d` (the part of `v` across the axis), `ρ = |w|`, residual `e = ρ - r`
//! (signed distance to the surface).
//!
//! # Minimal sample (2 points + normals)
//! A surface point `p` with outward unit normal `n` (oriented toward the camera, which sees
//! the outside of the cylinder) has its axis point at `c = p - r n`. Two samples give
//! `c1, c2`; the hypothesis is the line through them, `d = (c2 - c1) / |c2 - c1|`, accepted
//! only when both normals are nearly perpendicular to it (`|n_k · d| < sin 15°`) and the
//! samples are at least [`RansacParams::min_sample_span_m`] apart along the axis (a long
//! baseline makes `d` accurate despite ~2-3° normal noise). Unlike the `n1 × n2` construction,
//! this works for points on the same generatrix. Normals come from the organised depth image
//! (PCA, [`super::point_cloud::DepthImage::normal`]) and are computed only for sampled points.
//! Degenerate scenes: a plane yields hypotheses tangent to it, whose inlier band is only
//! `2 sqrt(2 r t)` wide (~10 mm for r = 13.4 mm, t = 1 mm) against the wire's ~24 mm, so
//! the wire wins the MSAC score (Torr & Zisserman 2000: cost `Σ min(e², t²)`), scored on a
//! fixed seeded subsample.
//!
//! # Refinement (LM)
//! Four parameters around the current `(c, d)`: with `b1, b2` an orthonormal basis of `d⊥`,
//! `d' = normalize(d + α b1 + β b2)`, `c' = c + s b1 + t b2`. With `u = w / ρ`:
//! `∂e/∂α = -(v·d)(u·b1)`, `∂e/∂β = -(v·d)(u·b2)`, `∂e/∂s = -u·b1`, `∂e/∂t = -u·b2`
//! (and `∂e/∂r = -1` when the radius is freed, used only as a diagnostic: the fitted radius
//! should match the known one). `c` is re-centred at the inliers' centroid's projection before
//! each step so the rotation parameters are well-conditioned. Damping: Marquardt's
//! `(JᵀJ + λ diag JᵀJ) δ = -Jᵀe`, λ /10 on success and x10 on failure (Madsen, Nielsen,
//! Tingleff, *Methods for non-linear least squares problems*, 2004, s3.2). Inliers are
//! re-selected after each LM round ([`RansacParams::refine_rounds`]).

use super::PerceptionError;
use nalgebra::{Matrix4, Matrix5, Point3, Vector3, Vector4, Vector5};
use rng::SplitMix64;

/// An infinite cylinder: axis line and radius.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cylinder {
    /// A point on the axis.
    pub point: Point3<f64>,
    /// Unit axis direction (sign arbitrary).
    pub direction: Vector3<f64>,
    /// Radius (m).
    pub radius_m: f64,
}

impl Cylinder {
    /// Distance of `p` from the axis.
    #[must_use]
    pub fn axis_distance(&self, p: &Point3<f64>) -> f64 {
        let v = p - self.point;
        (v - self.direction * v.dot(&self.direction)).norm()
    }

    /// Signed distance to the surface, `ρ - r`.
    #[must_use]
    pub fn residual(&self, p: &Point3<f64>) -> f64 {
        self.axis_distance(p) - self.radius_m
    }

    /// The point of the axis nearest `q`.
    #[must_use]
    pub fn axis_point_nearest(&self, q: &Point3<f64>) -> Point3<f64> {
        self.point + self.direction * (q - self.point).dot(&self.direction)
    }

    /// Angle between the two axes (rad, in `[0, π/2]`, sign-free).
    #[must_use]
    pub fn axis_angle_to(&self, other: &Cylinder) -> f64 {
        self.direction.dot(&other.direction).abs().min(1.0).acos()
    }

    /// Distance from `other`'s axis point nearest `q` to this axis: how far apart the two
    /// axes are near `q`.
    #[must_use]
    pub fn axis_offset_near(&self, other: &Cylinder, q: &Point3<f64>) -> f64 {
        self.axis_distance(&other.axis_point_nearest(q))
    }
}

/// RANSAC and refinement settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RansacParams {
    /// Known radius (m).
    pub radius_m: f64,
    /// Hypotheses to score. Default 300.
    pub iterations: usize,
    /// MSAC inlier threshold on `|e|` (m). Default 1.0 mm (~7σ of the depth noise at 0.6 m).
    pub inlier_threshold_m: f64,
    /// Threshold of the final inlier set after refinement (m). Default 0.6 mm.
    pub final_threshold_m: f64,
    /// Points scored per hypothesis (seeded subsample). Default 3000.
    pub score_subsample: usize,
    /// Minimum distance between the two samples' axis points (m). Default 20 mm.
    pub min_sample_span_m: f64,
    /// Maximum `|n·d|` for a sample normal (sine of its tilt from perpendicular). Default
    /// sin 15°.
    pub max_normal_tilt_sin: f64,
    /// Minimum inliers of the final fit. Default 200.
    pub min_inliers: usize,
    /// LM rounds, each followed by inlier re-selection. Default 3.
    pub refine_rounds: usize,
    /// Seed of the sampler.
    pub seed: u64,
}

impl Default for RansacParams {
    fn default() -> Self {
        Self {
            radius_m: super::WIRE_RADIUS_M,
            iterations: 300,
            inlier_threshold_m: 0.001,
            final_threshold_m: 0.0006,
            score_subsample: 3000,
            min_sample_span_m: 0.02,
            max_normal_tilt_sin: 15f64.to_radians().sin(),
            min_inliers: 200,
            refine_rounds: 3,
            seed: 0x5EED_C11D,
        }
    }
}

/// How the LM loop ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Termination {
    /// The step fell below 1e-10 (relative).
    SmallStep,
    /// The cost stopped decreasing (relative change < 1e-12).
    SmallCostChange,
    /// The iteration cap was hit.
    MaxIterations,
    /// λ grew beyond 1e12 without an improving step.
    DampingExhausted,
}

/// Result of one LM refinement.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LmReport {
    /// Iterations taken.
    pub iterations: usize,
    /// `Σ e²` before (m²).
    pub initial_cost: f64,
    /// `Σ e²` after (m²).
    pub final_cost: f64,
    /// Why it stopped.
    pub termination: Termination,
}

/// A fitted cylinder and the measured quality of the fit.
#[derive(Debug, Clone, PartialEq)]
pub struct CylinderFit {
    /// The refined cylinder (radius = the known radius).
    pub cylinder: Cylinder,
    /// Indices of the final inliers (`|e| <= final_threshold_m`).
    pub inliers: Vec<usize>,
    /// `inliers / points`.
    pub inlier_ratio: f64,
    /// RMS of `e` over the inliers (m).
    pub rms_residual_m: f64,
    /// Radius of a free-radius refit of the inliers (m): a consistency check.
    pub free_radius_m: f64,
    /// Hypotheses scored.
    pub hypotheses: usize,
    /// The last LM round.
    pub lm: LmReport,
}

/// Orthonormal basis of the plane perpendicular to unit `d`.
fn perpendicular_basis(d: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let helper = if d.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let b1 = d.cross(&helper).normalize();
    (b1, d.cross(&b1))
}

/// Fits a cylinder of radius `params.radius_m` to `points`; `normal_of(i)` gives the outward
/// unit normal of point `i` (or `None`), called only for sampled points.
///
/// # Errors
/// [`PerceptionError::TooFewPoints`] below `params.min_inliers` points;
/// [`PerceptionError::NoCylinder`] when the best hypothesis keeps fewer than
/// `params.min_inliers` inliers after refinement.
pub fn fit_cylinder<F>(
    points: &[Point3<f64>],
    mut normal_of: F,
    params: &RansacParams,
) -> Result<CylinderFit, PerceptionError>
where
    F: FnMut(usize) -> Option<Vector3<f64>>,
{
    let n = points.len();
    if n < params.min_inliers.max(2) {
        return Err(PerceptionError::TooFewPoints {
            got: n,
            needed: params.min_inliers.max(2),
        });
    }
    let mut rng = SplitMix64::new(params.seed);
    let subsample: Vec<Point3<f64>> = if n <= params.score_subsample {
        points.to_vec()
    } else {
        (0..params.score_subsample)
            .filter_map(|_| points.get(rng.below(n)).copied())
            .collect()
    };
    let t2 = params.inlier_threshold_m * params.inlier_threshold_m;
    let msac = |c: &Cylinder| -> f64 {
        subsample
            .iter()
            .map(|p| c.residual(p).powi(2).min(t2))
            .sum()
    };
    let r = params.radius_m;
    let mut best: Option<(f64, Cylinder)> = None;
    let mut hypotheses = 0usize;
    let max_attempts = params.iterations.saturating_mul(30);
    let mut attempts = 0usize;
    while hypotheses < params.iterations && attempts < max_attempts {
        attempts += 1;
        let (i, j) = (rng.below(n), rng.below(n));
        let (Some(p1), Some(p2)) = (points.get(i), points.get(j)) else {
            continue;
        };
        if (p2 - p1).norm() < params.min_sample_span_m {
            continue;
        }
        let Some(n1) = normal_of(i) else { continue };
        let Some(n2) = normal_of(j) else { continue };
        let (c1, c2) = (p1 - n1 * r, p2 - n2 * r);
        let span = c2 - c1;
        let Some(d) = span.try_normalize(params.min_sample_span_m) else {
            continue;
        };
        if n1.dot(&d).abs() > params.max_normal_tilt_sin
            || n2.dot(&d).abs() > params.max_normal_tilt_sin
        {
            continue;
        }
        hypotheses += 1;
        let candidate = Cylinder {
            point: Point3::from((c1.coords + c2.coords) * 0.5),
            direction: d,
            radius_m: r,
        };
        let cost = msac(&candidate);
        if best.is_none_or(|(b, _)| cost < b) {
            // Local optimisation (LO-RANSAC): refine on the subsample's inliers, keep if better.
            let sub_inliers: Vec<Point3<f64>> = subsample
                .iter()
                .filter(|p| candidate.residual(p).abs() <= params.inlier_threshold_m)
                .copied()
                .collect();
            let mut refined = candidate;
            if sub_inliers.len() >= 10 {
                let _ = refine(&mut refined, &sub_inliers, false, 10);
            }
            let refined_cost = msac(&refined);
            let (cost, cylinder) = if refined_cost < cost {
                (refined_cost, refined)
            } else {
                (cost, candidate)
            };
            if best.is_none_or(|(b, _)| cost < b) {
                best = Some((cost, cylinder));
            }
        }
    }
    let Some((_, mut cylinder)) = best else {
        return Err(PerceptionError::NoCylinder {
            inliers: 0,
            points: n,
            needed: params.min_inliers,
        });
    };
    // Refinement on all points: widening-then-tightening inlier sets.
    let mut lm = LmReport {
        iterations: 0,
        initial_cost: 0.0,
        final_cost: 0.0,
        termination: Termination::SmallStep,
    };
    let rounds = params.refine_rounds.max(1);
    for round in 0..rounds {
        let threshold = if round + 1 == rounds {
            params.final_threshold_m
        } else {
            params.inlier_threshold_m
        };
        let inlier_points: Vec<Point3<f64>> = points
            .iter()
            .filter(|p| cylinder.residual(p).abs() <= threshold)
            .copied()
            .collect();
        if inlier_points.len() < params.min_inliers {
            return Err(PerceptionError::NoCylinder {
                inliers: inlier_points.len(),
                points: n,
                needed: params.min_inliers,
            });
        }
        lm = refine(&mut cylinder, &inlier_points, false, 50).0;
    }
    let inliers: Vec<usize> = points
        .iter()
        .enumerate()
        .filter(|(_, p)| cylinder.residual(p).abs() <= params.final_threshold_m)
        .map(|(k, _)| k)
        .collect();
    if inliers.len() < params.min_inliers {
        return Err(PerceptionError::NoCylinder {
            inliers: inliers.len(),
            points: n,
            needed: params.min_inliers,
        });
    }
    let inlier_points: Vec<Point3<f64>> = inliers
        .iter()
        .filter_map(|&k| points.get(k))
        .copied()
        .collect();
    let rms_residual_m = (inlier_points
        .iter()
        .map(|p| cylinder.residual(p).powi(2))
        .sum::<f64>()
        / inlier_points.len() as f64)
        .sqrt();
    let mut free = cylinder;
    let _ = refine(&mut free, &inlier_points, true, 50);
    Ok(CylinderFit {
        cylinder,
        inlier_ratio: inliers.len() as f64 / n as f64,
        inliers,
        rms_residual_m,
        free_radius_m: free.radius_m,
        hypotheses,
        lm,
    })
}

/// LM refinement of `cylinder` on `points` (module docs); `free_radius` adds `r` as a 5th
/// parameter. Returns the report and the final cost.
pub fn refine(
    cylinder: &mut Cylinder,
    points: &[Point3<f64>],
    free_radius: bool,
    max_iterations: usize,
) -> (LmReport, f64) {
    let cost_of = |c: &Cylinder| points.iter().map(|p| c.residual(p).powi(2)).sum::<f64>();
    let centroid = if points.is_empty() {
        cylinder.point
    } else {
        Point3::from(points.iter().map(|p| p.coords).sum::<Vector3<f64>>() / points.len() as f64)
    };
    let initial_cost = cost_of(cylinder);
    let mut cost = initial_cost;
    let mut lambda = 1e-3;
    let mut termination = Termination::MaxIterations;
    let mut iterations = 0;
    while iterations < max_iterations {
        iterations += 1;
        cylinder.point = cylinder.axis_point_nearest(&centroid);
        let d = cylinder.direction;
        let (b1, b2) = perpendicular_basis(&d);
        let mut jtj = Matrix5::<f64>::zeros();
        let mut jte = Vector5::<f64>::zeros();
        for p in points {
            let v = p - cylinder.point;
            let along = v.dot(&d);
            let w = v - d * along;
            let rho = w.norm();
            if rho < 1e-12 {
                continue;
            }
            let u = w / rho;
            let e = rho - cylinder.radius_m;
            let (ub1, ub2) = (u.dot(&b1), u.dot(&b2));
            let row = Vector5::new(-along * ub1, -along * ub2, -ub1, -ub2, -1.0);
            jtj += row * row.transpose();
            jte += row * e;
        }
        let dims = if free_radius { 5 } else { 4 };
        let mut improved = false;
        while lambda < 1e12 {
            let step = if free_radius {
                let mut a = jtj;
                for k in 0..5 {
                    a[(k, k)] += lambda * jtj[(k, k)].max(1e-12);
                }
                a.cholesky().map(|ch| -ch.solve(&jte))
            } else {
                let mut a: Matrix4<f64> = jtj.fixed_view::<4, 4>(0, 0).into_owned();
                for k in 0..4 {
                    a[(k, k)] += lambda * jtj[(k, k)].max(1e-12);
                }
                let g: Vector4<f64> = jte.fixed_rows::<4>(0).into_owned();
                a.cholesky()
                    .map(|ch| -ch.solve(&g))
                    .map(|s| Vector5::new(s[0], s[1], s[2], s[3], 0.0))
            };
            let Some(step) = step else {
                lambda *= 10.0;
                continue;
            };
            let mut trial = *cylinder;
            trial.direction = (d + b1 * step[0] + b2 * step[1]).normalize();
            trial.point = cylinder.point + b1 * step[2] + b2 * step[3];
            if dims == 5 {
                trial.radius_m += step[4];
            }
            let trial_cost = cost_of(&trial);
            if trial_cost < cost {
                let change = (cost - trial_cost) / cost.max(1e-300);
                *cylinder = trial;
                cost = trial_cost;
                lambda = (lambda / 10.0).max(1e-12);
                improved = true;
                let step_norm = step.norm();
                if step_norm < 1e-10 {
                    termination = Termination::SmallStep;
                    iterations = max_iterations + 1;
                } else if change < 1e-12 {
                    termination = Termination::SmallCostChange;
                    iterations = max_iterations + 1;
                }
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            termination = if lambda >= 1e12 {
                Termination::DampingExhausted
            } else {
                Termination::SmallCostChange
            };
            break;
        }
    }
    cylinder.point = cylinder.axis_point_nearest(&centroid);
    (
        LmReport {
            iterations: iterations.min(max_iterations),
            initial_cost,
            final_cost: cost,
            termination,
        },
        cost,
    )
}
