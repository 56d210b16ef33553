//! Pinhole camera with plumb_bob (Brown-Conrady) distortion and its cached inverse.
//!
//! Camera frame: OpenCV optical axes (x right, y down, z forward). A point `p` in the camera
//! frame maps to the normalised coordinates `x = X/Z`, `y = Y/Z`, is distorted by
//!
//! `r^2 = x^2 + y^2`, `k = 1 + k1 r^2 + k2 r^4 + k3 r^6`,
//! `x_d = x k + 2 p1 x y + p2 (r^2 + 2 x^2)`, `y_d = y k + p1 (r^2 + 2 y^2) + 2 p2 x y`
//!
//! (ROS `sensor_msgs/CameraInfo` "plumb_bob", OpenCV `projectPoints`, Brown 1966) and lands on
//! the pixel `u = fx x_d + cx`, `v = fy y_d + cy`, integer coordinates at pixel centres.
//!
//! The renderer needs the inverse: for each pixel, the undistorted `(x, y)` whose distortion
//! is that pixel. It is solved by Newton's method on the 2x2 system with the analytic
//! Jacobian (converges quadratically for the small and moderate distortions used here; a
//! Jacobian determinant <= 0 means the model folds over and is reported). [`RayTable`]
//! caches the result per camera so a capture does not pay for it.

use nalgebra::Point3;
use rayon::prelude::*;

/// Errors of the camera model.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum CameraError {
    /// A parameter is non-finite or out of range.
    #[error("camera parameter {name} = {value} is invalid")]
    InvalidParameter {
        /// Field name.
        name: &'static str,
        /// Its value.
        value: f64,
    },
    /// Newton's method did not converge at this pixel.
    #[error("undistortion did not converge at pixel ({u}, {v}): residual {residual_px} px")]
    NoConvergence {
        /// Pixel column.
        u: f64,
        /// Pixel row.
        v: f64,
        /// Remaining error in pixels.
        residual_px: f64,
    },
}

/// Intrinsics with plumb_bob distortion (pixels; distortion coefficients unitless).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraIntrinsics {
    /// Image width (px).
    pub width: u32,
    /// Image height (px).
    pub height: u32,
    /// Focal length along x (px).
    pub fx: f64,
    /// Focal length along y (px).
    pub fy: f64,
    /// Principal point x (px, pixel centres at integers).
    pub cx: f64,
    /// Principal point y (px).
    pub cy: f64,
    /// Radial r^2 coefficient.
    pub k1: f64,
    /// Radial r^4 coefficient.
    pub k2: f64,
    /// Tangential coefficient p1.
    pub p1: f64,
    /// Tangential coefficient p2.
    pub p2: f64,
    /// Radial r^6 coefficient.
    pub k3: f64,
}

/// Newton iterations cap.
const MAX_NEWTON_ITERATIONS: usize = 30;
/// Convergence threshold on the distorted-coordinate residual (normalised units).
const NEWTON_TOLERANCE: f64 = 1e-14;

impl CameraIntrinsics {
    /// The wrist RGB-D camera (Mech-Eye NANO class, ARCHITECTURE.md section 6): 1280x1024,
    /// fx = fy = 1745 px, principal point slightly off centre, small barrel distortion.
    #[must_use]
    pub fn wrist() -> Self {
        Self {
            width: 1280,
            height: 1024,
            fx: 1745.0,
            fy: 1745.0,
            cx: 641.3,
            cy: 509.6,
            k1: -0.052,
            k2: 0.081,
            p1: 0.0004,
            p2: -0.0003,
            k3: -0.01,
        }
    }

    /// The panoramic camera on the base: 640x360, ~115 deg horizontal field of view
    /// (fx = 260 px with barrel distortion k1 = -0.12, k2 = 0.01; the radial map
    /// `r (1 + k1 r^2 + k2 r^4)` stays monotonic, so the model never folds).
    #[must_use]
    pub fn panoramic() -> Self {
        Self {
            width: 640,
            height: 360,
            fx: 260.0,
            fy: 260.0,
            cx: 319.5,
            cy: 179.5,
            k1: -0.12,
            k2: 0.01,
            p1: 0.0,
            p2: 0.0,
            k3: 0.0,
        }
    }

    /// The same lens on a sensor resampled by `factor` (e.g. 0.25 -> 320x256): focal lengths
    /// scale by `factor`, the principal point by `(c + 0.5) factor - 0.5` (pixel-centre
    /// convention), distortion is unchanged.
    ///
    /// # Errors
    /// [`CameraError::InvalidParameter`] if `factor` is not positive or the size rounds to 0.
    pub fn scaled(&self, factor: f64) -> Result<Self, CameraError> {
        let w = (f64::from(self.width) * factor).round();
        let h = (f64::from(self.height) * factor).round();
        if !(factor > 0.0 && factor.is_finite() && w >= 1.0 && h >= 1.0) {
            return Err(CameraError::InvalidParameter {
                name: "factor",
                value: factor,
            });
        }
        Ok(Self {
            width: w as u32,
            height: h as u32,
            fx: self.fx * factor,
            fy: self.fy * factor,
            cx: (self.cx + 0.5) * factor - 0.5,
            cy: (self.cy + 0.5) * factor - 0.5,
            ..*self
        })
    }

    /// Checks sizes and finiteness.
    ///
    /// # Errors
    /// [`CameraError::InvalidParameter`] naming the first bad field.
    pub fn validate(&self) -> Result<(), CameraError> {
        let bad = |name, value: f64| Err(CameraError::InvalidParameter { name, value });
        if self.width == 0 {
            return bad("width", 0.0);
        }
        if self.height == 0 {
            return bad("height", 0.0);
        }
        for (name, v) in [("fx", self.fx), ("fy", self.fy)] {
            if !(v.is_finite() && v > 0.0) {
                return bad(name, v);
            }
        }
        for (name, v) in [
            ("cx", self.cx),
            ("cy", self.cy),
            ("k1", self.k1),
            ("k2", self.k2),
            ("p1", self.p1),
            ("p2", self.p2),
            ("k3", self.k3),
        ] {
            if !v.is_finite() {
                return bad(name, v);
            }
        }
        Ok(())
    }

    /// Number of pixels.
    #[must_use]
    pub fn pixel_count(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// Distorts normalised coordinates.
    #[inline]
    #[must_use]
    pub fn distort(&self, x: f64, y: f64) -> [f64; 2] {
        let r2 = x * x + y * y;
        let k = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3));
        [
            x * k + 2.0 * self.p1 * x * y + self.p2 * (r2 + 2.0 * x * x),
            y * k + self.p1 * (r2 + 2.0 * y * y) + 2.0 * self.p2 * x * y,
        ]
    }

    /// Projects a point in the camera frame to pixel coordinates (None behind the camera).
    #[must_use]
    pub fn project(&self, p_in_camera: &Point3<f64>) -> Option<[f64; 2]> {
        if p_in_camera.z <= 0.0 {
            return None;
        }
        let [xd, yd] = self.distort(p_in_camera.x / p_in_camera.z, p_in_camera.y / p_in_camera.z);
        Some([self.fx * xd + self.cx, self.fy * yd + self.cy])
    }

    /// Undistorted normalised coordinates `(x, y)` of pixel `(u, v)`, Newton from `guess`.
    ///
    /// # Errors
    /// [`CameraError::NoConvergence`] if the residual stays above tolerance.
    pub fn undistort_from(&self, u: f64, v: f64, guess: [f64; 2]) -> Result<[f64; 2], CameraError> {
        let xd = (u - self.cx) / self.fx;
        let yd = (v - self.cy) / self.fy;
        let [mut x, mut y] = guess;
        let mut res = f64::INFINITY;
        for _ in 0..MAX_NEWTON_ITERATIONS {
            let r2 = x * x + y * y;
            let k = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3));
            let dk = self.k1 + r2 * (2.0 * self.k2 + 3.0 * self.k3 * r2); // dk/d(r^2)
            let fx = x * k + 2.0 * self.p1 * x * y + self.p2 * (r2 + 2.0 * x * x) - xd;
            let fy = y * k + self.p1 * (r2 + 2.0 * y * y) + 2.0 * self.p2 * x * y - yd;
            res = fx.abs().max(fy.abs());
            if res < NEWTON_TOLERANCE {
                return Ok([x, y]);
            }
            let a = k + 2.0 * x * x * dk + 2.0 * self.p1 * y + 6.0 * self.p2 * x;
            let b = 2.0 * x * y * dk + 2.0 * self.p1 * x + 2.0 * self.p2 * y;
            let c = 2.0 * x * y * dk + 2.0 * self.p1 * x + 2.0 * self.p2 * y;
            let d = k + 2.0 * y * y * dk + 6.0 * self.p1 * y + 2.0 * self.p2 * x;
            let det = a * d - b * c;
            if det.is_nan() || det <= 0.0 {
                break;
            }
            x -= (d * fx - b * fy) / det;
            y -= (a * fy - c * fx) / det;
        }
        if res < 1e-10 {
            return Ok([x, y]);
        }
        Err(CameraError::NoConvergence {
            u,
            v,
            residual_px: res * self.fx,
        })
    }

    /// Undistorted normalised coordinates of pixel `(u, v)`.
    ///
    /// # Errors
    /// [`CameraError::NoConvergence`].
    pub fn undistort(&self, u: f64, v: f64) -> Result<[f64; 2], CameraError> {
        self.undistort_from(u, v, [(u - self.cx) / self.fx, (v - self.cy) / self.fy])
    }
}

/// Unit viewing direction `(x, y, 1) / |(x, y, 1)|` of undistorted normalised coordinates
/// `xy` (camera frame), with the norm as `((x x + y y) + 1)^(1/2)`: the one expression for
/// tabulated and interpolated rays, so both give the same bits.
#[inline(always)]
#[must_use]
pub fn unit_direction(xy: [f64; 2]) -> [f64; 3] {
    let (x, y) = (xy[0], xy[1]);
    let inv = 1.0 / ((x * x + y * y) + 1.0).sqrt();
    [x * inv, y * inv, inv]
}

/// Edge of the square pixel tiles a capture is rendered in (px); a band of `RAY_TILE` rows
/// is one parallel work item.
pub const RAY_TILE: usize = 16;

/// Per-pixel undistorted normalised coordinates of one camera (row-major) and, for the
/// renderer's tiles, their unit viewing directions and coordinate bounds.
///
/// The directions are stored tile by tile ([`Self::tile`]): a tile's 256 rays are one
/// contiguous run the hardware prefetcher streams, where row-major rows would be 16 short
/// runs a full image row apart (each a cache miss: the table is 31 MB at 1280x1024).
#[derive(Clone, Debug)]
pub struct RayTable {
    intrinsics: CameraIntrinsics,
    xy: Vec<[f64; 2]>,
    /// [`unit_direction`] of each `xy` (a square root and a division per pixel saved on
    /// every capture), in tile order: band `b` (rows `r0 .. r0 + rows`) starts at `r0 w`,
    /// its tile at column `c0` at `r0 w + rows c0`, row-major inside the tile.
    tile_dirs: Vec<[f64; 3]>,
    /// Per tile (band-major): the `[min, max]` of its pixels' x and y.
    tile_bounds: Vec<TileBounds>,
}

/// `[[min x, max x], [min y, max y]]` of a tile's normalised coordinates.
type TileBounds = [[f64; 2]; 2];

/// One tile of a [`RayTable`].
#[derive(Clone, Debug)]
pub struct RayTile<'a> {
    /// The tile's pixel columns.
    pub cols: std::ops::Range<usize>,
    /// Unit camera-frame directions, row-major within the tile (`cols.len()` per row).
    pub dirs: &'a [[f64; 3]],
    /// `[min, max]` of the tile's normalised x.
    pub x_range: [f64; 2],
    /// `[min, max]` of the tile's normalised y.
    pub y_range: [f64; 2],
}

impl RayTable {
    /// Solves the inverse distortion for every pixel centre (rows in parallel; the result
    /// does not depend on the thread count since each row is independent).
    ///
    /// # Errors
    /// [`CameraError`] for invalid intrinsics or a pixel where the model cannot be inverted.
    pub fn new(intrinsics: &CameraIntrinsics) -> Result<Self, CameraError> {
        intrinsics.validate()?;
        let w = intrinsics.width as usize;
        let h = intrinsics.height as usize;
        let mut xy = vec![[0.0; 2]; intrinsics.pixel_count()];
        xy.par_chunks_mut(w)
            .enumerate()
            .try_for_each(|(row, out)| {
                let v = row as f64;
                let mut guess = intrinsics.undistort(0.0, v)?;
                for (col, o) in out.iter_mut().enumerate() {
                    guess = intrinsics.undistort_from(col as f64, v, guess)?;
                    *o = guess;
                }
                Ok::<(), CameraError>(())
            })?;
        // Bands of tiles in parallel, concatenated in band order.
        let bands: Vec<(Vec<[f64; 3]>, Vec<TileBounds>)> = (0..h.div_ceil(RAY_TILE))
            .into_par_iter()
            .map(|band| {
                let rows = band * RAY_TILE..((band + 1) * RAY_TILE).min(h);
                let mut dirs = Vec::with_capacity(rows.len() * w);
                let mut bounds = Vec::with_capacity(w.div_ceil(RAY_TILE));
                for col0 in (0..w).step_by(RAY_TILE) {
                    let cols = col0..(col0 + RAY_TILE).min(w);
                    let mut x_range = [f64::INFINITY, f64::NEG_INFINITY];
                    let mut y_range = [f64::INFINITY, f64::NEG_INFINITY];
                    for row in rows.clone() {
                        let run = xy.get(row * w + cols.start..row * w + cols.end);
                        for p in run.unwrap_or(&[]) {
                            x_range = grow(x_range, p[0]);
                            y_range = grow(y_range, p[1]);
                            dirs.push(unit_direction(*p));
                        }
                    }
                    bounds.push([x_range, y_range]);
                }
                (dirs, bounds)
            })
            .collect();
        let mut tile_dirs = Vec::with_capacity(xy.len());
        let mut tile_bounds = Vec::new();
        for (dirs, bounds) in bands {
            tile_dirs.extend(dirs);
            tile_bounds.extend(bounds);
        }
        Ok(Self {
            intrinsics: *intrinsics,
            xy,
            tile_dirs,
            tile_bounds,
        })
    }

    /// The camera this table was made for.
    #[must_use]
    pub fn intrinsics(&self) -> &CameraIntrinsics {
        &self.intrinsics
    }

    /// Normalised coordinates of all pixels (row-major).
    #[must_use]
    pub fn normalized(&self) -> &[[f64; 2]] {
        &self.xy
    }

    /// The tile whose top-left pixel is `(col0, row0)` (both multiples of [`RAY_TILE`];
    /// `None` outside the image): rows `row0 .. min(row0 + RAY_TILE, h)`, columns
    /// `col0 .. min(col0 + RAY_TILE, w)`.
    #[must_use]
    pub fn tile(&self, col0: usize, row0: usize) -> Option<RayTile<'_>> {
        let w = self.intrinsics.width as usize;
        let h = self.intrinsics.height as usize;
        if col0 >= w
            || row0 >= h
            || !col0.is_multiple_of(RAY_TILE)
            || !row0.is_multiple_of(RAY_TILE)
        {
            return None;
        }
        let rows = RAY_TILE.min(h - row0);
        let cols = RAY_TILE.min(w - col0);
        let start = row0 * w + rows * col0;
        let tiles_per_row = w.div_ceil(RAY_TILE);
        let [x_range, y_range] = *self
            .tile_bounds
            .get((row0 / RAY_TILE) * tiles_per_row + col0 / RAY_TILE)?;
        Some(RayTile {
            cols: col0..col0 + cols,
            dirs: self.tile_dirs.get(start..start + rows * cols)?,
            x_range,
            y_range,
        })
    }
}

/// `[min, max]` grown by `x` (finite values: plain comparisons, one `minsd`/`maxsd` each).
#[inline(always)]
#[must_use]
pub(crate) fn grow(range: [f64; 2], x: f64) -> [f64; 2] {
    [
        if x < range[0] { x } else { range[0] },
        if x > range[1] { x } else { range[1] },
    ]
}

pub use robot::se3::world_from_camera_looking_at;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn undistort_inverts_distort() -> Result<(), CameraError> {
        for cam in [CameraIntrinsics::wrist(), CameraIntrinsics::panoramic()] {
            for &(u, v) in &[
                (0.0, 0.0),
                (100.0, 37.0),
                (f64::from(cam.width) - 1.0, f64::from(cam.height) - 1.0),
            ] {
                let [x, y] = cam.undistort(u, v)?;
                let [px, py] = cam
                    .project(&Point3::new(x, y, 1.0))
                    .unwrap_or([f64::NAN; 2]);
                assert!(
                    (px - u).abs() < 1e-9 && (py - v).abs() < 1e-9,
                    "{px} {py} vs {u} {v}"
                );
            }
        }
        Ok(())
    }

    /// Every pixel's direction sits in its tile, bit for bit [`unit_direction`] of its
    /// coordinates, and the tile bounds are its pixels' extremes, also for partial tiles
    /// (the panoramic camera's 360 rows end in a band of 8; the 115x92 camera has partial
    /// tiles in both directions).
    #[test]
    fn tiles_hold_every_pixel_once() -> Result<(), CameraError> {
        for cam in [
            CameraIntrinsics::panoramic(),
            CameraIntrinsics::wrist().scaled(0.1)?,
            CameraIntrinsics::wrist().scaled(0.09)?,
        ] {
            let table = RayTable::new(&cam)?;
            let (w, h) = (cam.width as usize, cam.height as usize);
            assert!(
                !h.is_multiple_of(RAY_TILE) || !w.is_multiple_of(RAY_TILE),
                "{w}x{h} has partial tiles"
            );
            let mut seen = 0;
            for row0 in (0..h).step_by(RAY_TILE) {
                for col0 in (0..w).step_by(RAY_TILE) {
                    let Some(tile) = table.tile(col0, row0) else {
                        panic!("tile {col0} {row0}");
                    };
                    let cols = RAY_TILE.min(w - col0);
                    let (mut xr, mut yr) = (
                        [f64::INFINITY, -f64::INFINITY],
                        [f64::INFINITY, -f64::INFINITY],
                    );
                    for (k, d) in tile.dirs.iter().enumerate() {
                        let xy = table.normalized()[(row0 + k / cols) * w + col0 + k % cols];
                        assert_eq!(d.map(f64::to_bits), unit_direction(xy).map(f64::to_bits));
                        (xr, yr) = (grow(xr, xy[0]), grow(yr, xy[1]));
                        seen += 1;
                    }
                    assert_eq!((tile.x_range, tile.y_range), (xr, yr));
                }
            }
            assert_eq!(seen, w * h);
            assert!(table.tile(w, 0).is_none() && table.tile(1, 0).is_none());
        }
        Ok(())
    }

    #[test]
    fn scaled_keeps_the_field_of_view() -> Result<(), CameraError> {
        let c = CameraIntrinsics::wrist();
        let s = c.scaled(0.25)?;
        assert_eq!((s.width, s.height), (320, 256));
        // The image corner sees the same normalised direction.
        let a = c.undistort(-0.5, -0.5)?;
        let b = s.undistort(-0.5, -0.5)?;
        assert!((a[0] - b[0]).abs() < 1e-12 && (a[1] - b[1]).abs() < 1e-12);
        Ok(())
    }
}
