//! Images + intrinsics -> per-image board poses (`world_from_camera`, board frame = world)
//! and reprojection RMS: the library side of `rodlog calib board REC.mcap --board COLSxROWS
//! --square M` (ARCHITECTURE.md section 4), whose poses feed [`crate::handeye::solve`] as eye poses.
//!
//! Per image: [`detect_chessboard`] (pixel lattice), [`refine_corners`] at full resolution
//! with a half window of `min(SubPixParams::half_window_px, 0.35 * square side in px)` (the
//! window must not reach the neighbouring corners), [`solve_planar_pnp`], then a refusal
//! when the RMS exceeds [`BoardOptions::max_rms_px`]. Images are processed in parallel
//! (rayon); each image's result depends on that image only, so the output is deterministic.
//!
//! # Theia intrinsics
//!
//! Theia's `PINHOLE_RADIAL_DISTORTION` camera (the shecar `intrinsic.txt`: `f cx cy aspect
//! skew k1 k2`) distorts normalised coordinates `x = X/Z, y = Y/Z` as
//! `x_d = x (1 + k1 r^2 + k2 r^4)`, `r^2 = x^2 + y^2` (Theia `RadialDistortPoint`), i.e. the
//! radial part of `plumb_bob` with `p1 = p2 = k3 = 0`: [`theia_radial_camera`]. On the shecar
//! images this model reprojects the refined corners to 0.2-0.4 px RMS (OpenCV and ours alike).

use image::GrayImage;
use nalgebra::{Isometry3, Point2};
use rayon::prelude::*;

use super::chessboard::{DetectParams, detect_chessboard};
use super::pnp::{PnpParams, solve_planar_pnp};
use super::subpixel::{SubPixParams, SubPixReport, refine_corners};
use super::{BoardError, BoardSpec, MIN_VIEWS};
use crate::relpose::CameraModel;

/// Fraction of the square side (pixels) the sub-pixel half window may reach.
pub const WINDOW_FRACTION_OF_SQUARE: f64 = 0.35;
/// Smallest sub-pixel half window, pixels.
pub const MIN_HALF_WINDOW_PX: usize = 3;

/// Options of [`calibrate_board_views`]. Every default is documented on its field.
#[derive(Debug, Clone, PartialEq)]
pub struct BoardOptions {
    /// Detection. Default [`DetectParams::default`].
    pub detect: DetectParams,
    /// Sub-pixel refinement. Default [`SubPixParams::default`] (half window 11 px, capped at
    /// [`WINDOW_FRACTION_OF_SQUARE`] of the square).
    pub subpix: SubPixParams,
    /// Pose refinement. Default [`PnpParams::default`].
    pub pnp: PnpParams,
    /// Refuse a view whose reprojection RMS exceeds this, pixels. Default 2.0 (a correct
    /// detection with fitting intrinsics is well below 1 px).
    pub max_rms_px: f64,
    /// Minimum number of images. Default [`MIN_VIEWS`] (3, what hand-eye needs).
    pub min_views: usize,
}

impl Default for BoardOptions {
    fn default() -> Self {
        Self {
            detect: DetectParams::default(),
            subpix: SubPixParams::default(),
            pnp: PnpParams::default(),
            max_rms_px: 2.0,
            min_views: MIN_VIEWS,
        }
    }
}

/// The board seen in one image.
#[derive(Debug, Clone, PartialEq)]
pub struct BoardView {
    /// Camera pose in the board frame (= world), metres.
    pub world_from_camera: Isometry3<f64>,
    /// Reprojection RMS of the refined corners, pixels.
    pub rms_px: f64,
    /// Largest reprojection error, pixels.
    pub max_error_px: f64,
    /// Refined inner corners, row-major (index `r * cols + c`), full-resolution pixels.
    pub corners_px: Vec<Point2<f64>>,
    /// Median distance between neighbouring corners, pixels.
    pub square_px: f64,
    /// What the sub-pixel refinement did.
    pub subpix: SubPixReport,
}

/// A `plumb_bob` camera from Theia's radial intrinsics (module docs): `fx = f`,
/// `fy = aspect f` (`aspect = 1` in shecar), skew 0, `p1 = p2 = k3 = 0`.
pub fn theia_radial_camera(
    width: u32,
    height: u32,
    f_px: f64,
    cx_px: f64,
    cy_px: f64,
    k1: f64,
    k2: f64,
) -> CameraModel {
    CameraModel {
        k1,
        k2,
        ..CameraModel::pinhole(width, height, f_px, f_px, cx_px, cy_px)
    }
}

/// Median distance between row and column neighbours of a row-major lattice.
fn median_spacing(corners: &[Point2<f64>], cols: usize) -> f64 {
    let mut d: Vec<f64> = Vec::new();
    for (i, p) in corners.iter().enumerate() {
        if (i + 1) % cols != 0
            && let Some(q) = corners.get(i + 1)
        {
            d.push((q - p).norm());
        }
        if let Some(q) = corners.get(i + cols) {
            d.push((q - p).norm());
        }
    }
    d.sort_by(f64::total_cmp);
    d.get(d.len() / 2).copied().unwrap_or(0.0)
}

/// The board in one image: detection, sub-pixel refinement, PnP (module docs).
///
/// # Errors
/// [`BoardError::NotFound`] / [`BoardError::ImageTooSmall`] (image index 0), the PnP
/// refusals of [`solve_planar_pnp`], [`BoardError::ReprojectionTooLarge`].
pub fn board_view(
    image: &GrayImage,
    camera: &CameraModel,
    board: &BoardSpec,
    opts: &BoardOptions,
) -> Result<BoardView, BoardError> {
    board.validate()?;
    let mut corners = detect_chessboard(image, board.cols, board.rows, &opts.detect)?;
    let square_px = median_spacing(&corners, board.cols);
    let cap = (WINDOW_FRACTION_OF_SQUARE * square_px).floor() as usize;
    let subpix_params = SubPixParams {
        half_window_px: opts.subpix.half_window_px.min(cap).max(MIN_HALF_WINDOW_PX),
        ..opts.subpix.clone()
    };
    let subpix = refine_corners(image, &mut corners, &subpix_params);
    let object = board.object_points();
    let sol = solve_planar_pnp(&object, &corners, camera, &opts.pnp)?;
    // NaN RMS is refused too.
    if sol.rms_px.is_nan() || sol.rms_px > opts.max_rms_px {
        return Err(BoardError::ReprojectionTooLarge {
            image: 0,
            rms_px: sol.rms_px,
            max_rms_px: opts.max_rms_px,
        });
    }
    Ok(BoardView {
        world_from_camera: sol.camera_from_board.inverse(),
        rms_px: sol.rms_px,
        max_error_px: sol.max_error_px,
        corners_px: corners,
        square_px,
        subpix,
    })
}

/// Board poses of all images (the entry point of `rodlog calib board`).
///
/// # Errors
/// [`BoardError::TooFewViews`] (fewer than [`BoardOptions::min_views`] images), the board
/// refusals, and the first per-image failure in image order, naming the image index
/// ([`BoardError::NotFound`] "board not found in image i", [`BoardError::ReprojectionTooLarge`]).
pub fn calibrate_board_views(
    images: &[GrayImage],
    camera: &CameraModel,
    board: &BoardSpec,
    opts: &BoardOptions,
) -> Result<Vec<BoardView>, BoardError> {
    board.validate()?;
    if images.len() < opts.min_views {
        return Err(BoardError::TooFewViews {
            got: images.len(),
            need: opts.min_views,
        });
    }
    let results: Vec<Result<BoardView, BoardError>> = images
        .par_iter()
        .map(|img| board_view(img, camera, board, opts))
        .collect();
    results
        .into_iter()
        .enumerate()
        .map(|(i, r)| r.map_err(|e| e.with_image(i)))
        .collect()
}
