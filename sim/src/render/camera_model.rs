//! The simulated cameras' true intrinsics (the one camera model of `robot::camera`) and the
//! renderer's cached inverse of their distortion.
//!
//! The renderer needs, for each pixel, the undistorted `(x, y)` whose distortion is that
//! pixel. [`RayTable`] solves it once per camera (Newton from the left neighbour's solution,
//! [`CameraModel::undistort_pixel_from`]) so a capture does not pay for it.

use nalgebra::Point2;
use rayon::prelude::*;
pub use robot::camera::{CameraError, CameraModel};

/// The wrist RGB-D camera (Mech-Eye NANO class, ARCHITECTURE.md section 6): 1280x1024,
/// fx = fy = 1745 px, principal point slightly off centre, small barrel distortion.
#[must_use]
pub fn wrist_camera() -> CameraModel {
    CameraModel::pinhole(1280, 1024, 1745.0, 1745.0, 641.3, 509.6)
        .with_distortion([-0.052, 0.081, 0.0004, -0.0003, -0.01])
}

/// The panoramic camera on the base: 640x360, ~115 deg horizontal field of view
/// (fx = 260 px with barrel distortion k1 = -0.12, k2 = 0.01; the radial map
/// `r (1 + k1 r^2 + k2 r^4)` stays monotonic, so the model never folds).
#[must_use]
pub fn panoramic_camera() -> CameraModel {
    CameraModel::pinhole(640, 360, 260.0, 260.0, 319.5, 179.5)
        .with_distortion([-0.12, 0.01, 0.0, 0.0, 0.0])
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
    intrinsics: CameraModel,
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
    pub fn new(intrinsics: &CameraModel) -> Result<Self, CameraError> {
        intrinsics.validate()?;
        let w = intrinsics.width as usize;
        let h = intrinsics.height as usize;
        let mut xy = vec![[0.0; 2]; intrinsics.pixel_count()];
        xy.par_chunks_mut(w)
            .enumerate()
            .try_for_each(|(row, out)| {
                let v = row as f64;
                let mut guess = intrinsics.undistort_pixel(&Point2::new(0.0, v))?;
                for (col, o) in out.iter_mut().enumerate() {
                    guess = intrinsics.undistort_pixel_from(&Point2::new(col as f64, v), &guess)?;
                    *o = [guess.x, guess.y];
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
    pub fn intrinsics(&self) -> &CameraModel {
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

    /// The table holds each pixel's undistorted coordinates: they project back onto it.
    #[test]
    fn table_rays_project_back_to_their_pixels() -> Result<(), CameraError> {
        for cam in [wrist_camera().scaled(0.1)?, panoramic_camera()] {
            let table = RayTable::new(&cam)?;
            let w = cam.width as usize;
            for (i, xy) in table.normalized().iter().enumerate() {
                let px = cam.pixel_from_normalised(&Point2::new(xy[0], xy[1]));
                let (u, v) = ((i % w) as f64, (i / w) as f64);
                assert!((px - Point2::new(u, v)).norm() < 1e-9, "{px} vs {u} {v}");
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
            panoramic_camera(),
            wrist_camera().scaled(0.1)?,
            wrist_camera().scaled(0.09)?,
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
}
