//! Base path planning on a substation occupancy grid: footprint inflation and 8-connected A*.
//!
//! # Grid
//! Row-major cells, `cell (i, j)` covers `[x0 + i res, x0 + (i+1) res) x [y0 + j res, ...)` in
//! `map`; a cell is occupied when its value is `>= OCCUPIED_THRESHOLD` (ROS
//! `nav_msgs/OccupancyGrid` convention: 0 free, 100 occupied, -1/255 unknown = occupied here:
//! the robot never plans through unknown ground).
//!
//! # Inflation
//! The base is a disc of radius `r` around its centre (the footprint's circumscribed circle):
//! every cell within `r` of an occupied cell centre becomes occupied, so the planner can treat
//! the robot as a point. Done with a precomputed disc stencil, `O(cells · stencil)`.
//!
//! # A*
//! 8-connected moves (cost `res` straight, `res sqrt 2` diagonal; a diagonal needs both side
//! cells free, no corner cutting), octile heuristic `res (max(dx,dy) + (sqrt2 - 1) min(dx,dy))`
//! (admissible and consistent, so the first expansion of the goal is optimal; Hart, Nilsson,
//! Raphael 1968). Ties in `f` break toward larger `g` then lower cell index: deterministic.
//! The result is returned as cell centres from start to goal, then shortcut by line-of-sight
//! (Bresenham over the inflated grid), which keeps it collision-free.

use super::MotionError;
use msgs::std_msgs::Header;
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// Cells with a value at or above this (and negative ones) are occupied.
pub const OCCUPIED_THRESHOLD: i8 = 50;

/// An occupancy grid in `map`.
#[derive(Debug, Clone, PartialEq)]
pub struct OccupancyGrid {
    /// Cells along x.
    pub width: usize,
    /// Cells along y.
    pub height: usize,
    /// Cell size (m).
    pub resolution_m: f64,
    /// `map` coordinates of the grid's corner (m).
    pub origin_m: (f64, f64),
    /// `width * height` values, row-major (y rows), ROS convention.
    pub cells: Vec<i8>,
}

impl OccupancyGrid {
    /// An all-free grid.
    #[must_use]
    pub fn free(width: usize, height: usize, resolution_m: f64, origin_m: (f64, f64)) -> Self {
        Self {
            width,
            height,
            resolution_m,
            origin_m,
            cells: vec![0; width * height],
        }
    }

    /// # Errors
    /// [`MotionError::BadGrid`] when `cells.len() != width * height` or the resolution is not
    /// positive.
    pub fn validate(&self) -> Result<(), MotionError> {
        if self.cells.len() != self.width * self.height
            || self.resolution_m.is_nan()
            || self.resolution_m <= 0.0
        {
            return Err(MotionError::BadGrid {
                width: self.width,
                height: self.height,
                expected: self.width * self.height,
                got: self.cells.len(),
            });
        }
        Ok(())
    }

    /// Whether cell `(i, j)` is occupied (outside = occupied).
    #[must_use]
    pub fn occupied(&self, i: i64, j: i64) -> bool {
        if i < 0 || j < 0 || i as usize >= self.width || j as usize >= self.height {
            return true;
        }
        self.cells
            .get(j as usize * self.width + i as usize)
            .is_none_or(|&c| !(0..OCCUPIED_THRESHOLD).contains(&c))
    }

    /// Marks the axis-aligned rectangle `[x0, x1] x [y0, y1]` (m, in `map`) occupied.
    pub fn fill_rect(&mut self, x0: f64, y0: f64, x1: f64, y1: f64) {
        let (i0, j0) = self.cell_of(x0, y0);
        let (i1, j1) = self.cell_of(x1, y1);
        for j in j0.max(0)..=j1.min(self.height as i64 - 1) {
            for i in i0.max(0)..=i1.min(self.width as i64 - 1) {
                if let Some(c) = self.cells.get_mut(j as usize * self.width + i as usize) {
                    *c = 100;
                }
            }
        }
    }

    /// The cell containing `(x, y)` (may be outside).
    #[must_use]
    pub fn cell_of(&self, x_m: f64, y_m: f64) -> (i64, i64) {
        (
            ((x_m - self.origin_m.0) / self.resolution_m).floor() as i64,
            ((y_m - self.origin_m.1) / self.resolution_m).floor() as i64,
        )
    }

    /// The centre of cell `(i, j)` (m).
    #[must_use]
    pub fn centre_of(&self, i: i64, j: i64) -> (f64, f64) {
        (
            self.origin_m.0 + (i as f64 + 0.5) * self.resolution_m,
            self.origin_m.1 + (j as f64 + 0.5) * self.resolution_m,
        )
    }

    /// The grid with every cell within `radius_m` of an occupied cell occupied (module docs).
    #[must_use]
    pub fn inflated(&self, radius_m: f64) -> Self {
        let reach = (radius_m / self.resolution_m).ceil().max(0.0) as i64;
        let r2 = (radius_m / self.resolution_m).powi(2);
        let stencil: Vec<(i64, i64)> = (-reach..=reach)
            .flat_map(|dj| (-reach..=reach).map(move |di| (di, dj)))
            .filter(|(di, dj)| (di * di + dj * dj) as f64 <= r2)
            .collect();
        let mut out = self.clone();
        for j in 0..self.height as i64 {
            for i in 0..self.width as i64 {
                if !self.occupied(i, j) {
                    continue;
                }
                for (di, dj) in &stencil {
                    let (x, y) = (i + di, j + dj);
                    if x >= 0
                        && y >= 0
                        && (x as usize) < self.width
                        && (y as usize) < self.height
                        && let Some(c) = out.cells.get_mut(y as usize * self.width + x as usize)
                    {
                        *c = 100;
                    }
                }
            }
        }
        out
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Open {
    f: f64,
    g: f64,
    index: usize,
}

impl Eq for Open {}

impl Ord for Open {
    fn cmp(&self, other: &Self) -> Ordering {
        // BinaryHeap is a max-heap: the smallest f (then largest g, then smallest index) first.
        other
            .f
            .total_cmp(&self.f)
            .then(self.g.total_cmp(&other.g))
            .then(other.index.cmp(&self.index))
    }
}

impl PartialOrd for Open {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

/// A planned base path.
#[derive(Debug, Clone, PartialEq)]
pub struct BasePath {
    /// Waypoints `(x, y)` in `map` (m), start and goal included, after shortcutting.
    pub waypoints_m: Vec<(f64, f64)>,
    /// Length of the A* path before shortcutting (m).
    pub grid_length_m: f64,
    /// Cells expanded.
    pub expanded: usize,
}

impl BasePath {
    /// Length of the waypoint polyline (m).
    #[must_use]
    pub fn length_m(&self) -> f64 {
        self.waypoints_m
            .windows(2)
            .map(|w| (w[1].0 - w[0].0).hypot(w[1].1 - w[0].1))
            .sum()
    }
}

/// Whether the straight line between two cells crosses only free cells (Bresenham).
fn line_free(grid: &OccupancyGrid, (x0, y0): (i64, i64), (x1, y1): (i64, i64)) -> bool {
    let (dx, dy) = ((x1 - x0).abs(), -(y1 - y0).abs());
    let (sx, sy) = (if x0 < x1 { 1 } else { -1 }, if y0 < y1 { 1 } else { -1 });
    let (mut x, mut y, mut err) = (x0, y0, dx + dy);
    loop {
        if grid.occupied(x, y) {
            return false;
        }
        if x == x1 && y == y1 {
            return true;
        }
        let e2 = 2 * err;
        let (step_x, step_y) = (e2 >= dy, e2 <= dx);
        // A diagonal step needs both side cells free (as in the search: no corner cutting).
        if step_x && step_y && (grid.occupied(x + sx, y) || grid.occupied(x, y + sy)) {
            return false;
        }
        if step_x {
            err += dy;
            x += sx;
        }
        if step_y {
            err += dx;
            y += sy;
        }
    }
}

/// A* from `start` to `goal` (`(x, y)` in `map`, m) on `grid` (already inflated), module docs.
///
/// # Errors
/// [`MotionError::BadGrid`], [`MotionError::BlockedEndpoint`], [`MotionError::NoPath`].
pub fn plan_base_path(
    grid: &OccupancyGrid,
    start_m: (f64, f64),
    goal_m: (f64, f64),
) -> Result<BasePath, MotionError> {
    grid.validate()?;
    let (s, g) = (
        grid.cell_of(start_m.0, start_m.1),
        grid.cell_of(goal_m.0, goal_m.1),
    );
    for (which, cell, p) in [("start", s, start_m), ("goal", g, goal_m)] {
        if grid.occupied(cell.0, cell.1) {
            return Err(MotionError::BlockedEndpoint {
                which,
                x_m: p.0,
                y_m: p.1,
            });
        }
    }
    let w = grid.width;
    let res = grid.resolution_m;
    let index = |(i, j): (i64, i64)| j as usize * w + i as usize;
    let heuristic = |(i, j): (i64, i64)| {
        let (dx, dy) = ((i - g.0).abs() as f64, (j - g.1).abs() as f64);
        res * (dx.max(dy) + (std::f64::consts::SQRT_2 - 1.0) * dx.min(dy))
    };
    let n = grid.cells.len();
    let mut g_cost = vec![f64::INFINITY; n];
    let mut parent = vec![usize::MAX; n];
    let mut closed = vec![false; n];
    let mut open = BinaryHeap::new();
    let si = index(s);
    if let Some(c) = g_cost.get_mut(si) {
        *c = 0.0;
    }
    open.push(Open {
        f: heuristic(s),
        g: 0.0,
        index: si,
    });
    let gi = index(g);
    let mut expanded = 0usize;
    while let Some(Open {
        g: gc, index: ci, ..
    }) = open.pop()
    {
        if closed.get(ci).copied().unwrap_or(true) {
            continue;
        }
        if let Some(c) = closed.get_mut(ci) {
            *c = true;
        }
        expanded += 1;
        if ci == gi {
            break;
        }
        let (ci_i, ci_j) = ((ci % w) as i64, (ci / w) as i64);
        for (di, dj) in [
            (1, 0),
            (-1, 0),
            (0, 1),
            (0, -1),
            (1, 1),
            (1, -1),
            (-1, 1),
            (-1, -1),
        ] {
            let (ni, nj) = (ci_i + di, ci_j + dj);
            if grid.occupied(ni, nj) {
                continue;
            }
            let diagonal = di != 0 && dj != 0;
            if diagonal && (grid.occupied(ci_i + di, ci_j) || grid.occupied(ci_i, ci_j + dj)) {
                continue;
            }
            let step = if diagonal {
                res * std::f64::consts::SQRT_2
            } else {
                res
            };
            let ni_idx = index((ni, nj));
            let candidate = gc + step;
            if candidate < g_cost.get(ni_idx).copied().unwrap_or(0.0) {
                if let Some(c) = g_cost.get_mut(ni_idx) {
                    *c = candidate;
                }
                if let Some(p) = parent.get_mut(ni_idx) {
                    *p = ci;
                }
                open.push(Open {
                    f: candidate + heuristic((ni, nj)),
                    g: candidate,
                    index: ni_idx,
                });
            }
        }
    }
    if !closed.get(gi).copied().unwrap_or(false) {
        return Err(MotionError::NoPath { expanded });
    }
    let mut cells = vec![gi];
    let mut cur = gi;
    while cur != si {
        let Some(&p) = parent.get(cur) else {
            return Err(MotionError::NoPath { expanded });
        };
        if p == usize::MAX {
            return Err(MotionError::NoPath { expanded });
        }
        cells.push(p);
        cur = p;
    }
    cells.reverse();
    let grid_length_m = g_cost.get(gi).copied().unwrap_or(f64::INFINITY);
    let as_cell = |k: usize| ((k % w) as i64, (k / w) as i64);
    // Line-of-sight shortcutting.
    let mut kept = vec![0usize];
    let mut anchor = 0usize;
    while anchor + 1 < cells.len() {
        let mut next = anchor + 1;
        for k in (anchor + 2..cells.len()).rev() {
            let (Some(&a), Some(&b)) = (cells.get(anchor), cells.get(k)) else {
                continue;
            };
            if line_free(grid, as_cell(a), as_cell(b)) {
                next = k;
                break;
            }
        }
        kept.push(next);
        anchor = next;
    }
    let mut waypoints_m: Vec<(f64, f64)> = kept
        .iter()
        .filter_map(|&k| cells.get(k))
        .map(|&c| {
            let (i, j) = as_cell(c);
            grid.centre_of(i, j)
        })
        .collect();
    if let Some(first) = waypoints_m.first_mut() {
        *first = start_m;
    }
    if let Some(last) = waypoints_m.last_mut() {
        *last = goal_m;
    }
    Ok(BasePath {
        waypoints_m,
        grid_length_m,
        expanded,
    })
}

/// The path as `nav_msgs/Path` poses in `map`, each facing the next waypoint (the last keeps
/// the previous heading).
#[must_use]
pub fn base_path_to_msg(path: &BasePath, header: Header) -> msgs::nav_msgs::Path {
    let mut yaw = 0.0;
    let poses: Vec<Isometry3<f64>> = path
        .waypoints_m
        .iter()
        .enumerate()
        .map(|(k, &(x, y))| {
            if let Some(&(nx, ny)) = path.waypoints_m.get(k + 1) {
                yaw = (ny - y).atan2(nx - x);
            }
            Isometry3::from_parts(
                Translation3::new(x, y, 0.0),
                UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw),
            )
        })
        .collect();
    super::trajectory::to_path(&poses, header)
}
