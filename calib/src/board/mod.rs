//! Chessboard calibration front end: inner-corner detection, sub-pixel refinement,
//! planar PnP, per-image board poses for the AX=XB solvers of [`crate::handeye`].
//!
//! # Conventions
//!
//! Transforms are named `a_from_b` (`p_in_a = a_from_b * p_in_b`, ARCHITECTURE.md section 6). The board
//! frame is the world frame of the eye poses: its origin is the first inner corner, `x` runs
//! along a row (the `cols` direction), `y` down the rows, `z = x cross y` points into the
//! board, away from a camera that sees its printed side (OpenCV's `calibrateCamera`
//! convention). Board point of corner `(c, r)`: `(c * square_m, r * square_m, 0)`; corners
//! are listed row-major, index `r * cols + c`. Pixels: OpenCV convention, the centre of the
//! top-left pixel is `(0, 0)`; camera frames use OpenCV optical axes (x right, y down, z
//! forward); f64, metres and radians inside.
//!
//! # Pipeline ([`calibrate_board_views`])
//!
//! | step | module | method |
//! |---|---|---|
//! | detection | [`chessboard`] | saddle response `-det(Hessian)` on a downscaled, Gaussian-smoothed image, non-maximum suppression, a circular-profile test (four alternating sectors, ChESS-like, Bennett & Lasenby 2014), then lattice growing from seed corners along the local edge directions (Geiger et al. 2012, sec. III) until the `cols x rows` grid is complete |
//! | sub-pixel | [`subpixel`] | gradient orthogonality (Förstner & Gülch 1987; OpenCV `cornerSubPix`) at full resolution |
//! | pose | [`pnp`] | normalised DLT homography (Hartley & Zisserman 2004, alg. 4.2), pose from homography (Zhang 2000, sec. 3.1 / app. C), Levenberg-Marquardt on the pixel reprojection error through the `plumb_bob` camera ([`crate::relpose::CameraModel`]) |
//!
//! # Orientation of the board
//!
//! The board frame is kept right-handed (`z` away from the camera), which leaves a half turn
//! (and for square boards quarter turns) undecided. When `cols + rows` is odd the board is
//! not symmetric under a half turn: the two candidate origin squares (diagonally outside the
//! first and the last corner) differ in colour, and the origin is put at the **dark** one,
//! whatever the view. When `cols + rows` is even (e.g. 6x8 inner corners, 7x9 squares) the
//! board looks the same after a half turn, so the image alone cannot say which end is the
//! origin: of the remaining orderings the detector takes the one whose in-image rotation is
//! closest to upright (`x` towards the image's +u, `y` towards +v; what OpenCV's
//! `findChessboardCorners` returns on the shecar views). All views then agree as long as the
//! camera rolls less than 90 deg about its axis relative to the board between views, which
//! is true of every hand-eye data set here; `tests/board_synthetic.rs` pins both behaviours.
//!
//! # Accuracy (measured)
//!
//! - shecar (18 photos 3264x1836, 6x8 board, 44-80 px squares; `tests/board_shecar.rs`):
//!   found in all 18, reprojection RMS 0.16-0.41 px; corners agree with OpenCV 4.14
//!   `findChessboardCorners` + `cornerSubPix` (11x11) to 0.005 px median (max 0.033 px),
//!   same ordering in every view, poses to 0.005 deg / 0.12 mm
//!   (`scripts/board/compare_corners.py`). Hand-eye (Park-Martin) on these poses:
//!   median rotation residual over the 153 pairs 0.873 deg, X 0.36 deg from identity,
//!   t = (-2.5, -6.4, -10.2) mm, as the data's OpenCV reference.
//! - rendered boards (1280x1024, f = 1745 px, `plumb_bob`, 2 grey levels of noise;
//!   `tests/board_synthetic.rs`): corners 0.04 px median (0.02 px with 1 px pre-smoothing,
//!   [`SubPixParams::presmooth_sigma_px`]); 12 views -> hand-eye X within 0.003 deg /
//!   0.014 mm of an asymmetric truth. Still found with 60 deg tilt, 14 px squares, noise
//!   of 10 grey levels, 6 px blur or 40 grey levels of contrast, in 20-50 ms per image.
//!
//! # Degenerate cases (refused with a [`BoardError`])
//!
//! Boards with fewer than 2 inner corners per side, a non-positive square, a board not found
//! (occluded corner, too small, too blurred), fewer than [`MIN_POINTS`] correspondences, a
//! homography of a degenerate configuration, a pose behind the camera and a reprojection RMS
//! above [`BoardOptions::max_rms_px`] (a wrong lattice or wrong intrinsics).

pub mod board_calibration;
pub mod chessboard;
pub mod pnp;
pub mod render;
pub mod subpixel;

use nalgebra::Point3;

pub use board_calibration::{
    BoardOptions, BoardView, board_view, calibrate_board_views, theia_radial_camera,
};
pub use chessboard::{DetectParams, detect_chessboard};
pub use pnp::{PnpParams, PnpSolution, solve_planar_pnp};
pub use subpixel::{SubPixParams, SubPixReport, refine_corners};

/// Minimum number of point correspondences of the planar PnP (a homography needs 4).
pub const MIN_POINTS: usize = 4;
/// Minimum number of views [`calibrate_board_views`] accepts by default (hand-eye needs 3).
pub const MIN_VIEWS: usize = 3;

/// A chessboard target: counts of **inner** corners and the square side.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoardSpec {
    /// Inner corners along a row (the board's `x` direction), >= 2.
    pub cols: usize,
    /// Inner corners along a column (the board's `y` direction), >= 2.
    pub rows: usize,
    /// Side of a square, metres (> 0).
    pub square_m: f64,
}

impl BoardSpec {
    /// A validated board.
    ///
    /// # Errors
    /// [`BoardError::InvalidBoard`] for fewer than 2 inner corners along a side,
    /// [`BoardError::InvalidSquare`] for a non-finite or non-positive square.
    pub fn new(cols: usize, rows: usize, square_m: f64) -> Result<Self, BoardError> {
        let spec = Self {
            cols,
            rows,
            square_m,
        };
        spec.validate()?;
        Ok(spec)
    }

    /// From the CLI arguments `--board COLSxROWS --square METRES` (ARCHITECTURE.md section 4): `"6x8"`
    /// (or `6X8`) counts inner corners.
    ///
    /// # Errors
    /// [`BoardError::BoardArgument`] when the text is not `COLSxROWS` with two integers, and
    /// the refusals of [`BoardSpec::new`].
    pub fn from_arg(board: &str, square_m: f64) -> Result<Self, BoardError> {
        let bad = || BoardError::BoardArgument {
            text: board.to_owned(),
        };
        let (c, r) = board.trim().split_once(['x', 'X']).ok_or_else(bad)?;
        let cols = c.trim().parse::<usize>().map_err(|_| bad())?;
        let rows = r.trim().parse::<usize>().map_err(|_| bad())?;
        Self::new(cols, rows, square_m)
    }

    /// Checks the counts and the square size (see [`BoardSpec::new`]).
    ///
    /// # Errors
    /// As [`BoardSpec::new`].
    pub fn validate(&self) -> Result<(), BoardError> {
        if self.cols < 2 || self.rows < 2 {
            return Err(BoardError::InvalidBoard {
                cols: self.cols,
                rows: self.rows,
            });
        }
        if !(self.square_m.is_finite() && self.square_m > 0.0) {
            return Err(BoardError::InvalidSquare {
                square_m: self.square_m,
            });
        }
        Ok(())
    }

    /// Number of inner corners, `cols * rows`.
    pub fn corner_count(&self) -> usize {
        self.cols * self.rows
    }

    /// Inner corners in the board frame, row-major: index `r * cols + c` is
    /// `(c * square_m, r * square_m, 0)`.
    pub fn object_points(&self) -> Vec<Point3<f64>> {
        let mut out = Vec::with_capacity(self.corner_count());
        for r in 0..self.rows {
            for c in 0..self.cols {
                out.push(Point3::new(
                    c as f64 * self.square_m,
                    r as f64 * self.square_m,
                    0.0,
                ));
            }
        }
        out
    }
}

/// Why a board calibration step was refused; every variant carries the numbers that explain it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BoardError {
    /// Fewer than 2 inner corners along a side.
    #[error("invalid board {cols}x{rows}: --board counts inner corners, at least 2 per side")]
    InvalidBoard {
        /// Inner corners per row.
        cols: usize,
        /// Inner corners per column.
        rows: usize,
    },
    /// The `--board` argument is not `COLSxROWS`.
    #[error("invalid --board {text:?}: expected COLSxROWS inner corners, e.g. 6x8")]
    BoardArgument {
        /// The text given.
        text: String,
    },
    /// The square side is not finite and positive.
    #[error("invalid square side {square_m} m: must be finite and > 0")]
    InvalidSquare {
        /// The value given.
        square_m: f64,
    },
    /// The image is too small to hold a board.
    #[error("image {image} is {width}x{height} px: too small to detect a board")]
    ImageTooSmall {
        /// Image index (0 for a single image).
        image: usize,
        /// Width, pixels.
        width: u32,
        /// Height, pixels.
        height: u32,
    },
    /// The `cols x rows` lattice was not found.
    #[error(
        "board {cols}x{rows} not found in image {image}: {candidates} corner candidates, largest lattice {best_a}x{best_b}; check --board (inner corners), that the whole board is visible, sharp and not too small"
    )]
    NotFound {
        /// Image index (0 for a single image).
        image: usize,
        /// Inner corners per row sought.
        cols: usize,
        /// Inner corners per column sought.
        rows: usize,
        /// Corner candidates that passed the saddle and sector tests.
        candidates: usize,
        /// Largest lattice grown, first side.
        best_a: usize,
        /// Largest lattice grown, second side.
        best_b: usize,
    },
    /// Too few views for a calibration.
    #[error("{got} images given, at least {need} needed")]
    TooFewViews {
        /// Views given.
        got: usize,
        /// Views needed.
        need: usize,
    },
    /// Too few correspondences for the PnP.
    #[error("{got} point correspondences, at least {need} needed")]
    TooFewPoints {
        /// Correspondences given.
        got: usize,
        /// Correspondences needed.
        need: usize,
    },
    /// Object and image point lists differ in length.
    #[error("{object} board points but {image} image points")]
    LengthMismatch {
        /// Board points.
        object: usize,
        /// Image points.
        image: usize,
    },
    /// A pixel could not be undistorted (outside the camera model's valid domain).
    #[error("pixel {index} ({u:.2}, {v:.2}) cannot be undistorted with this camera model")]
    Undistort {
        /// Point index.
        index: usize,
        /// Column, pixels.
        u: f64,
        /// Row, pixels.
        v: f64,
    },
    /// The planar configuration is degenerate (collinear points, non-finite values).
    #[error("degenerate PnP input: {what}")]
    Degenerate {
        /// What is degenerate.
        what: &'static str,
    },
    /// The estimated pose puts board points behind the camera.
    #[error("pose puts board point {index} behind the camera (z = {z_m:.4} m)")]
    BehindCamera {
        /// Point index.
        index: usize,
        /// Depth, metres.
        z_m: f64,
    },
    /// The reprojection error is too large for a correct detection.
    #[error(
        "image {image}: reprojection RMS {rms_px:.3} px > {max_rms_px} px (wrong lattice, wrong --square or wrong intrinsics)"
    )]
    ReprojectionTooLarge {
        /// Image index.
        image: usize,
        /// RMS, pixels.
        rms_px: f64,
        /// Threshold, pixels.
        max_rms_px: f64,
    },
}

impl BoardError {
    /// The same error attributed to image `index` (detection runs per image).
    pub fn with_image(self, index: usize) -> Self {
        match self {
            BoardError::ImageTooSmall { width, height, .. } => BoardError::ImageTooSmall {
                image: index,
                width,
                height,
            },
            BoardError::NotFound {
                cols,
                rows,
                candidates,
                best_a,
                best_b,
                ..
            } => BoardError::NotFound {
                image: index,
                cols,
                rows,
                candidates,
                best_a,
                best_b,
            },
            BoardError::ReprojectionTooLarge {
                rms_px, max_rms_px, ..
            } => BoardError::ReprojectionTooLarge {
                image: index,
                rms_px,
                max_rms_px,
            },
            other => other,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn object_points_are_row_major() {
        let b = BoardSpec::new(3, 2, 0.5).expect("valid");
        let p = b.object_points();
        assert_eq!(p.len(), 6);
        assert_eq!(p[1], Point3::new(0.5, 0.0, 0.0));
        assert_eq!(p[3], Point3::new(0.0, 0.5, 0.0));
    }

    #[test]
    fn board_argument_is_parsed() {
        let b = BoardSpec::from_arg("6x8", 0.0283).expect("valid");
        assert_eq!((b.cols, b.rows), (6, 8));
        assert_eq!(
            BoardSpec::from_arg(" 7X5 ", 0.02).map(|b| (b.cols, b.rows)),
            Ok((7, 5))
        );
        assert!(matches!(
            BoardSpec::from_arg("6-8", 0.02),
            Err(BoardError::BoardArgument { .. })
        ));
        assert!(matches!(
            BoardSpec::from_arg("6x", 0.02),
            Err(BoardError::BoardArgument { .. })
        ));
    }

    #[test]
    fn invalid_boards_are_refused() {
        assert!(matches!(
            BoardSpec::new(1, 8, 0.02),
            Err(BoardError::InvalidBoard { cols: 1, rows: 8 })
        ));
        assert!(matches!(
            BoardSpec::new(6, 8, -1.0),
            Err(BoardError::InvalidSquare { .. })
        ));
    }
}
