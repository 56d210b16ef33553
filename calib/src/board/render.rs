//! A small ray/plane renderer of a chessboard seen through a `plumb_bob` camera, for
//! ground-truth tests and experiments of the board pipeline.
//!
//! Each pixel is split into `s x s` sub-samples; sub-sample `(u, v)` is undistorted (through
//! the per-camera [`RayMap`]) to the ray `(x, y, 1)`, intersected with the board plane
//! `Z_board = 0` (`p = t + lambda R (x, y, 1)` in board coordinates), and shaded by the
//! square it hits (box-filter antialiasing: the pixel value is the mean of its sub-samples).
//! The board has `(cols + 1) x (rows + 1)` squares, the outer ones dark (so square `(-1, -1)`
//! at the origin corner is dark), a white margin of [`RenderOptions::margin_squares`] and a
//! uniform background. Gaussian noise of [`RenderOptions::noise_sigma`] grey levels (seeded
//! SplitMix64) is added before rounding to 8 bits.

use image::GrayImage;
use nalgebra::{Isometry3, Point2, Vector3};

use super::BoardSpec;
use crate::relpose::CameraModel;
use crate::relpose::ransac::SplitMix64;

/// Options of [`render_board`]. Every default is documented on its field.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderOptions {
    /// Sub-samples per pixel side. Default 6.
    pub supersample: usize,
    /// White margin around the squares, in squares. Default 0.6.
    pub margin_squares: f64,
    /// Grey level of the dark squares. Default 35.
    pub dark: f64,
    /// Grey level of the light squares and the margin. Default 215.
    pub light: f64,
    /// Grey level of the background. Default 110.
    pub background: f64,
    /// Standard deviation of the additive Gaussian noise, grey levels. Default 2.
    pub noise_sigma: f64,
    /// Seed of the noise. Default 7.
    pub seed: u64,
}

impl Default for RenderOptions {
    fn default() -> Self {
        Self {
            supersample: 6,
            margin_squares: 0.6,
            dark: 35.0,
            light: 215.0,
            background: 110.0,
            noise_sigma: 2.0,
            seed: 7,
        }
    }
}

/// Undistorted normalised coordinates of every pixel centre of a camera (and of a one-pixel
/// frame around the image), NaN where the pixel has no preimage under the distortion model.
/// Sub-sample rays are interpolated bilinearly between pixel centres (the undistortion map
/// is smooth: the interpolation error is below 1e-6 px for camera-grade distortion), so the
/// memory is independent of the supersampling.
#[derive(Debug, Clone)]
pub struct RayMap {
    camera: CameraModel,
    /// `(width + 2) x (height + 2)` grid, entry `(x + 1, y + 1)` for pixel `(x, y)`.
    grid: Vec<[f64; 2]>,
}

impl RayMap {
    /// Precomputes the undistortion of `camera`.
    pub fn new(camera: &CameraModel) -> Self {
        let (w, h) = (camera.width as usize + 2, camera.height as usize + 2);
        let mut grid = Vec::with_capacity(w * h);
        for y in 0..h {
            for x in 0..w {
                let px = Point2::new(x as f64 - 1.0, y as f64 - 1.0);
                grid.push(
                    camera
                        .undistort_pixel(&px)
                        .map_or([f64::NAN, f64::NAN], |n| [n.x, n.y]),
                );
            }
        }
        Self {
            camera: *camera,
            grid,
        }
    }

    /// The camera the rays belong to.
    pub fn camera(&self) -> &CameraModel {
        &self.camera
    }

    /// The ray `(x, y, 1)` through pixel coordinates `(u, v)` (pixel-centre convention),
    /// `None` outside the map or the model's domain.
    pub fn ray(&self, u: f64, v: f64) -> Option<Vector3<f64>> {
        let w = self.camera.width as usize + 2;
        let (gx, gy) = (u + 1.0, v + 1.0);
        let (x0, y0) = (gx.floor(), gy.floor());
        if x0 < 0.0 || y0 < 0.0 {
            return None;
        }
        let (fx, fy) = (gx - x0, gy - y0);
        let (xi, yi) = (x0 as usize, y0 as usize);
        let g = |x: usize, y: usize| self.grid.get(y * w + x).copied();
        let (a, b, c, d) = (
            g(xi, yi)?,
            g(xi + 1, yi)?,
            g(xi, yi + 1)?,
            g(xi + 1, yi + 1)?,
        );
        let lerp = |k: usize| {
            (a[k] * (1.0 - fx) + b[k] * fx) * (1.0 - fy) + (c[k] * (1.0 - fx) + d[k] * fx) * fy
        };
        let (x, y) = (lerp(0), lerp(1));
        (x.is_finite() && y.is_finite()).then(|| Vector3::new(x, y, 1.0))
    }
}

/// Renders the board seen from `camera_from_board` (module docs).
pub fn render_board(
    rays: &RayMap,
    camera_from_board: &Isometry3<f64>,
    board: &BoardSpec,
    opts: &RenderOptions,
) -> GrayImage {
    let cam = rays.camera;
    let s = opts.supersample.max(1);
    let board_from_camera = camera_from_board.inverse();
    let rot = board_from_camera.rotation;
    let origin = board_from_camera.translation.vector;
    let sq = board.square_m;
    let (x_min, y_min) = (
        -sq * (1.0 + opts.margin_squares),
        -sq * (1.0 + opts.margin_squares),
    );
    let x_max = sq * (board.cols as f64 + opts.margin_squares);
    let y_max = sq * (board.rows as f64 + opts.margin_squares);
    let mut rng = SplitMix64::new(opts.seed);
    let inv = 1.0 / (s * s) as f64;
    GrayImage::from_fn(cam.width, cam.height, |px, py| {
        let mut sum = 0.0;
        for sy in 0..s {
            for sx in 0..s {
                let u = f64::from(px) - 0.5 + (sx as f64 + 0.5) / s as f64;
                let v = f64::from(py) - 0.5 + (sy as f64 + 0.5) / s as f64;
                let shade = rays
                    .ray(u, v)
                    .and_then(|ray| {
                        let d = rot * ray;
                        if d.z.abs() < 1e-12 {
                            return None;
                        }
                        let lambda = -origin.z / d.z;
                        if lambda <= 0.0 {
                            return None;
                        }
                        let p = origin + d * lambda;
                        if p.x < x_min || p.y < y_min || p.x > x_max || p.y > y_max {
                            return None;
                        }
                        let (ix, iy) = ((p.x / sq).floor(), (p.y / sq).floor());
                        let in_squares = ix >= -1.0
                            && iy >= -1.0
                            && ix < board.cols as f64
                            && iy < board.rows as f64;
                        if in_squares && (ix as i64 + iy as i64).rem_euclid(2) == 0 {
                            Some(opts.dark)
                        } else {
                            Some(opts.light)
                        }
                    })
                    .unwrap_or(opts.background);
                sum += shade;
            }
        }
        let v = sum * inv + opts.noise_sigma * rng.normal();
        image::Luma([v.round().clamp(0.0, 255.0) as u8])
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Translation3, UnitQuaternion};

    #[test]
    fn renders_dark_origin_square_and_background() {
        let cam = CameraModel::pinhole(64, 48, 60.0, 60.0, 31.5, 23.5);
        let rays = RayMap::new(&cam);
        let board = BoardSpec::new(2, 2, 0.1).expect("board");
        // Board origin on the optical axis, 1 m ahead, axes aligned with the image.
        let pose =
            Isometry3::from_parts(Translation3::new(0.0, 0.0, 1.0), UnitQuaternion::identity());
        let opts = RenderOptions {
            noise_sigma: 0.0,
            ..RenderOptions::default()
        };
        let img = render_board(&rays, &pose, &board, &opts);
        // Square (-1, -1) is just up-left of the principal point: dark; (0, -1) light.
        assert_eq!(img.get_pixel(28, 20).0[0], 35);
        assert_eq!(img.get_pixel(35, 20).0[0], 215);
        assert_eq!(img.get_pixel(0, 0).0[0], 110);
    }
}
