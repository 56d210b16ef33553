//! Sub-pixel corner refinement by gradient orthogonality (Förstner & Gülch 1987; the
//! iteration of OpenCV's `cornerSubPix`).
//!
//! Around the true corner `q`, every image gradient `g_i` at a point `p_i` is orthogonal to
//! `p_i - q` (inside a flat square `g_i = 0`, on an edge through `q` the gradient is normal to
//! the edge, which contains `q`). The weighted least-squares solution of `g_i^T (p_i - q) = 0`
//! is
//!
//! ```text
//! q = (sum_i w_i g_i g_i^T)^-1  sum_i w_i g_i g_i^T p_i
//! ```
//!
//! with Gaussian window weights `w_i = exp(-(dx^2 + dy^2) / h^2)` (`h` the half window, as
//! OpenCV). The window is resampled bilinearly around the current estimate and the step is
//! repeated until it moves by less than [`SubPixParams::epsilon_px`]. A corner that moves
//! farther than the half window from its start is left where it was (OpenCV does the same)
//! and counted in [`SubPixReport::rejected`].

use image::GrayImage;
use nalgebra::{Matrix2, Point2, Vector2};

use super::chessboard::Plane;

/// Parameters of [`refine_corners`]. Every default is documented on its field.
#[derive(Debug, Clone, PartialEq)]
pub struct SubPixParams {
    /// Half window side, pixels: the window is `(2 h + 1)^2` pixels. Default 11 (OpenCV's
    /// customary `winSize = (11, 11)`). [`super::board_calibration`] shrinks it to 0.35 of the
    /// square side for small boards so the window never reaches the next corner.
    pub half_window_px: usize,
    /// Maximum iterations per corner. Default 100.
    pub max_iterations: usize,
    /// Stop when an iteration moves the corner by less than this, pixels. Default 0.001.
    pub epsilon_px: f64,
    /// Gaussian pre-smoothing of the image, pixels (0: none). Default 0 (OpenCV parity).
    /// On sharp (synthetic) edges the bilinear resampling biases the corner by up to
    /// ~0.05 px depending on its sub-pixel phase; 1 px of smoothing cuts that to ~0.015 px
    /// (`tests/board_synthetic.rs`), real photos are blurred enough already.
    pub presmooth_sigma_px: f64,
}

impl Default for SubPixParams {
    fn default() -> Self {
        Self {
            half_window_px: 11,
            max_iterations: 100,
            epsilon_px: 1e-3,
            presmooth_sigma_px: 0.0,
        }
    }
}

/// What [`refine_corners`] did.
#[derive(Debug, Clone, PartialEq)]
pub struct SubPixReport {
    /// Largest number of iterations over the corners.
    pub max_iterations: usize,
    /// Largest last step over the converged corners, pixels.
    pub max_last_step_px: f64,
    /// Corners that did not converge within the iteration budget.
    pub not_converged: usize,
    /// Corners left at their initial position (moved beyond the half window, or a singular
    /// gradient matrix: a flat or single-edge window).
    pub rejected: usize,
    /// Mean displacement from the initial positions, pixels.
    pub mean_shift_px: f64,
}

/// Refines corners in place (module equation), in pixels of `image` (OpenCV pixel-centre
/// convention).
pub fn refine_corners(
    image: &GrayImage,
    corners: &mut [Point2<f64>],
    params: &SubPixParams,
) -> SubPixReport {
    let plane = Plane::from_gray(image);
    if params.presmooth_sigma_px > 0.0 {
        refine_on_plane(&plane.gaussian(params.presmooth_sigma_px), corners, params)
    } else {
        refine_on_plane(&plane, corners, params)
    }
}

/// [`refine_corners`] on a float image.
fn refine_on_plane(
    plane: &Plane,
    corners: &mut [Point2<f64>],
    params: &SubPixParams,
) -> SubPixReport {
    let h = params.half_window_px.max(1) as isize;
    let hf = h as f64;
    let side = (2 * h + 1) as usize;
    let mut weights = Vec::with_capacity(side * side);
    for dy in -h..=h {
        for dx in -h..=h {
            let (x, y) = (dx as f64 / hf, dy as f64 / hf);
            weights.push((-(x * x + y * y)).exp());
        }
    }
    let patch_side = side + 2;
    let mut patch = vec![0.0f64; patch_side * patch_side];
    let mut report = SubPixReport {
        max_iterations: 0,
        max_last_step_px: 0.0,
        not_converged: 0,
        rejected: 0,
        mean_shift_px: 0.0,
    };
    let eps2 = params.epsilon_px * params.epsilon_px;
    let mut total_shift = 0.0;
    for corner in corners.iter_mut() {
        let start = Vector2::new(corner.x, corner.y);
        let mut q = start;
        let mut iterations = 0;
        let mut last_step2 = f64::INFINITY;
        let mut singular = false;
        while iterations < params.max_iterations {
            iterations += 1;
            // Resample a (2h + 3)^2 patch centred on q.
            for (py, row) in patch.chunks_mut(patch_side).enumerate() {
                for (px, v) in row.iter_mut().enumerate() {
                    let x = q.x + px as f64 - (h + 1) as f64;
                    let y = q.y + py as f64 - (h + 1) as f64;
                    *v = plane.bilinear(x, y);
                }
            }
            let at = |x: usize, y: usize| patch.get(y * patch_side + x).copied().unwrap_or(0.0);
            let mut a = Matrix2::zeros();
            let mut b = Vector2::zeros();
            for (k, w) in weights.iter().enumerate() {
                let (i, j) = (k / side, k % side);
                let (x, y) = (j + 1, i + 1);
                let gx = at(x + 1, y) - at(x - 1, y);
                let gy = at(x, y + 1) - at(x, y - 1);
                let g = Vector2::new(gx, gy);
                let ggt = g * g.transpose() * *w;
                let p = Vector2::new(j as f64 - hf, i as f64 - hf);
                a += ggt;
                b += ggt * p;
            }
            let Some(a_inv) = a.try_inverse() else {
                singular = true;
                break;
            };
            if a.determinant().abs() < 1e-12 {
                singular = true;
                break;
            }
            let step = a_inv * b;
            q += step;
            last_step2 = step.norm_squared();
            if last_step2 < eps2 {
                break;
            }
            if (q - start).norm() > 2.0 * hf {
                break;
            }
        }
        let moved = (q - start).norm();
        if singular || moved > hf || !q.iter().all(|v| v.is_finite()) {
            report.rejected += 1;
            continue;
        }
        if last_step2 >= eps2 {
            report.not_converged += 1;
        } else {
            report.max_last_step_px = report.max_last_step_px.max(last_step2.sqrt());
        }
        report.max_iterations = report.max_iterations.max(iterations);
        total_shift += moved;
        *corner = Point2::from(q);
    }
    if !corners.is_empty() {
        report.mean_shift_px = total_shift / corners.len() as f64;
    }
    report
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An antialiased X-junction at `(cx, cy)` (exact area coverage by 16x16 supersampling).
    fn junction(cx: f64, cy: f64) -> GrayImage {
        GrayImage::from_fn(64, 64, |x, y| {
            let mut s = 0.0f64;
            for sy in 0..16 {
                for sx in 0..16 {
                    let px = f64::from(x) - 0.5 + (f64::from(sx) + 0.5) / 16.0 - cx;
                    let py = f64::from(y) - 0.5 + (f64::from(sy) + 0.5) / 16.0 - cy;
                    // Rotated by 20 deg so edges are not pixel-aligned.
                    let (c, sn) = (20f64.to_radians().cos(), 20f64.to_radians().sin());
                    let (u, v) = (c * px + sn * py, -sn * px + c * py);
                    s += if (u > 0.0) == (v > 0.0) { 30.0 } else { 220.0 };
                }
            }
            image::Luma([(s / 256.0).round() as u8])
        })
    }

    #[test]
    fn converges_to_an_antialiased_junction() {
        let (cx, cy) = (31.37, 30.81);
        let img = junction(cx, cy);
        // Without smoothing the bilinear resampling of a sharp edge biases the corner by a few
        // hundredths of a pixel (phase dependent); 1 px of smoothing removes most of it.
        for (sigma, tol) in [(0.0, 0.05), (1.0, 0.02)] {
            let mut c = [Point2::new(33.0, 29.0)];
            let params = SubPixParams {
                presmooth_sigma_px: sigma,
                ..SubPixParams::default()
            };
            let report = refine_corners(&img, &mut c, &params);
            eprintln!("sigma {sigma}: {} vs {cx} {cy}", c[0]);
            assert_eq!(report.rejected, 0);
            assert!(
                (c[0].x - cx).abs() < tol && (c[0].y - cy).abs() < tol,
                "{} vs {cx} {cy}",
                c[0]
            );
            assert!(report.max_last_step_px < 1e-3);
        }
    }

    #[test]
    fn flat_window_is_rejected() {
        let img = GrayImage::from_pixel(64, 64, image::Luma([100]));
        let mut c = [Point2::new(30.0, 30.0)];
        let report = refine_corners(&img, &mut c, &SubPixParams::default());
        assert_eq!(report.rejected, 1);
        assert_eq!(c[0], Point2::new(30.0, 30.0));
    }
}
