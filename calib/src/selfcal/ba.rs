//! Eq. 15 as a bundle adjustment (`paper+ba`): the paper's cost minimised over X **and**
//! every world point jointly,
//!
//! ```text
//! min_{X, P_W,1..m}  sum_i sum_j v_ij | P_C,ij - (B_j X)^-1 P_W,i |^2
//! ```
//!
//! (notation of [`super::eq15`]). The points start triangulated at the initial X and are then
//! free parameters, so each settles where its depth measurements put it given X (with the
//! 3D residuals of eq. 15, at the mean of `B_j X P_C,ij` over its views), instead of where the
//! rays meet.
//!
//! # Solver
//!
//! Levenberg-Marquardt on the `6 + 3m` parameters (`X <- X exp(delta)`, `P <- P + dp`), with
//! the analytic Jacobian of a residual `r = P_C - q`, `q = (B_j X)^-1 P_W = R_j^T (P_W - t_j)`:
//!
//! ```text
//! dr/d omega = -[q]x,   dr/dv = I,   dr/dP_W = -R_j^T
//! ```
//!
//! The normal matrix `J^T J + lambda diag(J^T J)` is block-arrow sparse (a dense 6x6 block for
//! X, a 3x3 block per point, a 6x3 coupling per point); its lower triangle is factored by
//! faer's sparse Cholesky (`LL^T`, fill-reducing ordering; the symbolic factorisation is done
//! once, the numeric one per damping trial). faer runs sequentially here, so the result does
//! not depend on the thread count.

use faer::Mat;
use faer::Side;
use faer::linalg::solvers::Solve;
use faer::sparse::linalg::solvers::{Llt, SymbolicLlt};
use faer::sparse::{SparseColMat, Triplet};
use nalgebra::{Isometry3, Matrix3, Point3, SMatrix, Vector3, Vector6};

use super::eq15::{
    Eq15Params, Eq15Problem, Eq15Report, WorldPoints, camera_poses, exp_se3, triangulate,
};

type Matrix3x6 = SMatrix<f64, 3, 6>;

fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// One residual: feature index, view, measured point.
struct Obs {
    feature: usize,
    view: usize,
    p_c: Point3<f64>,
}

fn cost(obs: &[Obs], cams: &[Isometry3<f64>], points: &[Point3<f64>]) -> f64 {
    obs.iter()
        .map(|o| match (cams.get(o.view), points.get(o.feature)) {
            (Some(c), Some(p)) => (o.p_c - c.inverse_transform_point(p)).norm_squared(),
            _ => 0.0,
        })
        .sum()
}

/// The normal equations at `(x, points)`: `H_XX`, per point `H_PP` and `H_PX`, gradients.
struct Normal {
    h_xx: nalgebra::Matrix6<f64>,
    g_x: Vector6<f64>,
    h_pp: Vec<Matrix3<f64>>,
    h_px: Vec<Matrix3x6>,
    g_p: Vec<Vector3<f64>>,
}

fn normal_equations(obs: &[Obs], cams: &[Isometry3<f64>], points: &[Point3<f64>]) -> Normal {
    let m = points.len();
    let mut n = Normal {
        h_xx: nalgebra::Matrix6::zeros(),
        g_x: Vector6::zeros(),
        h_pp: vec![Matrix3::zeros(); m],
        h_px: vec![Matrix3x6::zeros(); m],
        g_p: vec![Vector3::zeros(); m],
    };
    for o in obs {
        let (Some(c), Some(p)) = (cams.get(o.view), points.get(o.feature)) else {
            continue;
        };
        let q = c.inverse_transform_point(p);
        let r = o.p_c - q;
        let mut j_x = Matrix3x6::zeros();
        j_x.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&(-skew(&q.coords)));
        j_x.fixed_view_mut::<3, 3>(0, 3)
            .copy_from(&Matrix3::identity());
        let j_p = -c.rotation.to_rotation_matrix().into_inner().transpose();
        n.h_xx += j_x.transpose() * j_x;
        n.g_x += j_x.transpose() * r;
        if let (Some(hpp), Some(hpx), Some(gp)) = (
            n.h_pp.get_mut(o.feature),
            n.h_px.get_mut(o.feature),
            n.g_p.get_mut(o.feature),
        ) {
            *hpp += j_p.transpose() * j_p;
            *hpx += j_p.transpose() * j_x;
            *gp += j_p.transpose() * r;
        }
    }
    n
}

/// The lower triangle of `H + lambda diag(H)` as triplets (X first, then the points).
fn damped_lower(n: &Normal, lambda: f64) -> Vec<Triplet<usize, usize, f64>> {
    let mut t = Vec::with_capacity(21 + n.h_pp.len() * 24);
    for a in 0..6 {
        for b in 0..=a {
            let mut v = n.h_xx[(a, b)];
            if a == b {
                v += lambda * v.max(1e-30);
            }
            t.push(Triplet::new(a, b, v));
        }
    }
    for (k, (hpp, hpx)) in n.h_pp.iter().zip(&n.h_px).enumerate() {
        let base = 6 + 3 * k;
        for a in 0..3 {
            for c in 0..6 {
                t.push(Triplet::new(base + a, c, hpx[(a, c)]));
            }
            for b in 0..=a {
                let mut v = hpp[(a, b)];
                if a == b {
                    v += lambda * v.max(1e-30);
                }
                t.push(Triplet::new(base + a, base + b, v));
            }
        }
    }
    t
}

/// Minimises eq. 15 over X and the world points jointly from `x0` (module docs). Features
/// that do not triangulate at `x0` are left out; with no residual left, `x0` is returned
/// with 0 iterations.
pub fn refine_ba(problem: &Eq15Problem, x0: &Isometry3<f64>, params: &Eq15Params) -> Eq15Report {
    let problem = problem.triangulable_at(x0);
    let cams0 = camera_poses(&problem.base_from_tool0, x0);
    let mut points: Vec<Point3<f64>> = problem
        .features
        .iter()
        .map(|f| triangulate(&cams0, f).unwrap_or_else(Point3::origin))
        .collect();
    let obs: Vec<Obs> = problem
        .features
        .iter()
        .enumerate()
        .flat_map(|(k, f)| {
            f.iter().filter_map(move |o| {
                Some(Obs {
                    feature: k,
                    view: o.view,
                    p_c: o.p_in_camera?,
                })
            })
        })
        .collect();
    let dim = 6 + 3 * points.len();
    let mut x = *x0;
    let mut cams = cams0;
    let initial_cost = cost(&obs, &cams, &points);
    let mut current = initial_cost;
    let mut lambda = 1e-3;
    let mut iterations = 0;
    let mut symbolic: Option<SymbolicLlt<usize>> = None;
    while iterations < params.max_iterations && !obs.is_empty() {
        iterations += 1;
        let n = normal_equations(&obs, &cams, &points);
        let mut rhs = Mat::<f64>::zeros(dim, 1);
        for a in 0..6 {
            rhs[(a, 0)] = -n.g_x[a];
        }
        for (k, g) in n.g_p.iter().enumerate() {
            for a in 0..3 {
                rhs[(6 + 3 * k + a, 0)] = -g[a];
            }
        }
        let mut improved = false;
        let mut converged = false;
        for _ in 0..10 {
            let Ok(h) = SparseColMat::<usize, f64>::try_new_from_triplets(
                dim,
                dim,
                &damped_lower(&n, lambda),
            ) else {
                break;
            };
            let sym = match &symbolic {
                Some(s) => s.clone(),
                None => match SymbolicLlt::try_new(h.symbolic(), Side::Lower) {
                    Ok(s) => {
                        symbolic = Some(s.clone());
                        s
                    }
                    Err(_) => break,
                },
            };
            let Ok(llt) = Llt::try_new_with_symbolic(sym, h.as_ref(), Side::Lower) else {
                lambda *= 10.0;
                continue;
            };
            let mut step = rhs.clone();
            llt.solve_in_place(step.as_mut());
            let dx = Vector6::from_fn(|a, _| step[(a, 0)]);
            let x_new = x * exp_se3(&dx);
            let points_new: Vec<Point3<f64>> = points
                .iter()
                .enumerate()
                .map(|(k, p)| {
                    p + Vector3::new(
                        step[(6 + 3 * k, 0)],
                        step[(6 + 3 * k + 1, 0)],
                        step[(6 + 3 * k + 2, 0)],
                    )
                })
                .collect();
            let cams_new = camera_poses(&problem.base_from_tool0, &x_new);
            let c_new = cost(&obs, &cams_new, &points_new);
            if c_new < current {
                let rel = (current - c_new) / current.max(f64::MIN_POSITIVE);
                let step_norm = (0..dim).map(|i| step[(i, 0)].powi(2)).sum::<f64>().sqrt();
                x = x_new;
                points = points_new;
                cams = cams_new;
                current = c_new;
                lambda = (lambda / 3.0).max(1e-12);
                improved = true;
                converged =
                    step_norm < params.step_tolerance || rel < params.relative_cost_tolerance;
                break;
            }
            lambda *= 10.0;
        }
        if !improved || converged {
            break;
        }
    }
    let observations = obs.len();
    Eq15Report {
        tool0_from_camera: x,
        world_points: WorldPoints::Joint,
        points: problem.features.len(),
        views: problem.views(),
        observations,
        iterations,
        initial_cost,
        final_cost: current,
        rms_m: (current / observations.max(1) as f64).sqrt(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::selfcal::eq15::refine_eq15;
    use crate::selfcal::eq15::tests::{iso, problem};

    #[test]
    fn ba_recovers_x_and_agrees_with_eq15_on_exact_data() {
        let x = iso([1.0, 2.0, 3.0], 30.0, [0.05, 0.02, -0.08]);
        let (p, _) = problem(&x, 8);
        let start = x * iso([0.3, -1.0, 0.5], 1.0, [0.003, -0.002, 0.004]);
        let rep = refine_ba(&p, &start, &Eq15Params::default());
        let d = x.inverse() * rep.tool0_from_camera;
        assert!(
            d.rotation.angle().to_degrees() < 1e-6 && d.translation.vector.norm() < 1e-9,
            "{} deg {} m",
            d.rotation.angle().to_degrees(),
            d.translation.vector.norm()
        );
        assert_eq!(rep.world_points, WorldPoints::Joint);
        assert_eq!((rep.points, rep.observations), (60, 480));
        assert!(rep.final_cost < 1e-20 && rep.initial_cost > 1e-6);
        // Eq. 15 with the points re-triangulated at every X converges to the same X.
        let params = Eq15Params {
            world_points: WorldPoints::Retriangulated,
            ..Eq15Params::default()
        };
        let eq = refine_eq15(&p, &start, &params);
        assert!((eq.tool0_from_camera.translation.vector - x.translation.vector).norm() < 1e-9);
    }

    #[test]
    fn ba_with_depth_noise_stays_close() {
        let x = iso([1.0, 2.0, 3.0], 30.0, [0.05, 0.02, -0.08]);
        let (mut p, _) = problem(&x, 8);
        // Deterministic pseudo-noise of 0.2 mm along each depth ray.
        for (k, o) in p.features.iter_mut().flatten().enumerate() {
            if let Some(pc) = o.p_in_camera.as_mut() {
                let s = ((k as f64) * 12.9898).sin() * 43_758.545_3;
                let u = s - s.floor() - 0.5;
                *pc += pc.coords.normalize() * (u * 0.4e-3);
            }
        }
        let rep = refine_ba(&p, &x, &Eq15Params::default());
        let d = x.inverse() * rep.tool0_from_camera;
        assert!(d.rotation.angle().to_degrees() < 0.05);
        assert!(d.translation.vector.norm() < 0.5e-3);
        assert!(rep.final_cost <= rep.initial_cost);
    }
}
