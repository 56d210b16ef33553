//! AKAZE keypoints: extrema of the scale-normalised Hessian determinant, sub-pixel
//! refinement and the dominant orientation (Alcantarilla, Nuevo & Bartoli, BMVC 2013,
//! sec. 4.1-4.2).
//!
//! **Detection.** A pixel of level `i` (outside its border) is a candidate when
//! `L_det > threshold` and it is larger than its 8 neighbours. Candidates within the
//! keypoint size `s_i` (Euclidean, level pixels) of a stronger one in the same level are
//! dropped (scanned in raster order, as the reference implementation does); then each
//! keypoint is compared with the candidates of the level below and the level above within
//! the upper level's size (projected through the octave ratio), and the weaker one goes.
//!
//! **Refinement.** A 2D quadratic through the 3x3 neighbourhood of `L_det`
//! (`[Dxx Dxy; Dxy Dyy] d = -[Dx; Dy]`, central differences) moves the point by `d`; points
//! with `|d_x| > 1` or `|d_y| > 1` are unstable and dropped. Full-resolution coordinates are
//! `(x + d_x) 2^o + (2^o - 1) / 2` (the centre of the `2^o x 2^o` block a level pixel
//! averages).
//!
//! **Orientation** (SURF-like, Bay et al. 2006): the derivatives `(Lx, Ly)` at the 109
//! points of the disc of radius `6 s_i` (step `s_i`) are weighted by a Gaussian of
//! `sigma = 2.5 s_i`; a window of `pi / 3` slides over their angles (42 slices of `2 pi / 42`)
//! and the orientation is the angle of the largest summed vector.

use rayon::prelude::*;

use super::AkazeParams;
use super::nonlinear_scale_space::{Level, ScaleSpace};
use crate::features::Keypoint;

/// Angular slices of the orientation histogram.
const ORI_SLICES: usize = 42;
/// Slices in the `pi / 3` sliding window.
const ORI_WINDOW: usize = 7;
/// Radius (in units of the scale) of the orientation disc.
const ORI_RADIUS: i32 = 6;
/// Gaussian sigma (in units of the scale) weighting the orientation samples.
const ORI_SIGMA: f32 = 2.5;

/// Index of the first marked pixel of `mask` (raster order) within distance `r` of
/// `(x, y)`, scanning `[y - r, y + r) x [x - r, x + r)` as the reference does.
fn find_neighbour(x: usize, y: usize, mask: &[u8], w: usize, h: usize, r: usize) -> Option<usize> {
    let (x, y, r) = (x as isize, y as isize, r as isize);
    let y0 = (y - r).max(0);
    let y1 = (y + r).min(h as isize);
    let x0 = (x - r).max(0);
    let x1 = (x + r).min(w as isize);
    for i in y0..y1 {
        for j in x0..x1 {
            let idx = (i as usize) * w + j as usize;
            if mask[idx] == 0 {
                continue;
            }
            let (dx, dy) = (j - x, i - y);
            if dx * dx + dy * dy <= r * r {
                return Some(idx);
            }
        }
    }
    None
}

/// Candidate mask of one level: thresholded 3x3 maxima, thinned within the keypoint size.
fn level_extrema(level: &Level, threshold: f32) -> Vec<u8> {
    let d = &level.ldet;
    let (w, h) = (d.width, d.height);
    let mut mask = vec![0u8; w * h];
    let b = level.border;
    if b + 1 >= h || b + 1 >= w {
        return mask;
    }
    let r = level.sigma_size;
    for y in b..h - b {
        let (prev, cur, next) = (d.row(y - 1), d.row(y), d.row(y + 1));
        for x in b..w - b {
            let v = cur[x];
            if v <= threshold
                || v <= cur[x - 1]
                || v <= cur[x + 1]
                || v <= prev[x - 1]
                || v <= prev[x]
                || v <= prev[x + 1]
                || v <= next[x - 1]
                || v <= next[x]
                || v <= next[x + 1]
            {
                continue;
            }
            if let Some(idx) = find_neighbour(x, y, &mask, w, h, r) {
                if v > d.data[idx] {
                    mask[idx] = 0;
                } else {
                    continue;
                }
            }
            mask[y * w + x] = 1;
        }
    }
    mask
}

/// Candidates of every level after the same-level and cross-level suppression.
pub fn find_extrema(space: &ScaleSpace, params: &AkazeParams) -> Vec<Vec<u8>> {
    let levels = &space.levels;
    let mut masks: Vec<Vec<u8>> = if params.parallel {
        levels
            .par_iter()
            .map(|l| level_extrema(l, params.threshold))
            .collect()
    } else {
        levels
            .iter()
            .map(|l| level_extrema(l, params.threshold))
            .collect()
    };
    // Against the lower level.
    for i in 1..levels.len() {
        let (lo, hi) = (&levels[i - 1], &levels[i]);
        let ratio = (hi.ratio / lo.ratio) as usize;
        let r = hi.sigma_size * ratio;
        let w = hi.ldet.width;
        let (lw, lh) = (lo.ldet.width, lo.ldet.height);
        let (done, rest) = masks.split_at_mut(i);
        let (Some(mlo), Some(mhi)) = (done.last_mut(), rest.first()) else {
            continue;
        };
        for (j, _) in mhi.iter().enumerate().filter(|(_, m)| **m != 0) {
            let (x, y) = (j % w, j / w);
            if let Some(idx) = find_neighbour(x * ratio, y * ratio, mlo, lw, lh, r)
                && hi.ldet.data[j] > lo.ldet.data[idx]
            {
                mlo[idx] = 0;
            }
        }
    }
    // Against the upper level.
    for i in (0..levels.len().saturating_sub(1)).rev() {
        let (lo, hi) = (&levels[i], &levels[i + 1]);
        let ratio = (hi.ratio / lo.ratio) as usize;
        let r = hi.sigma_size;
        let w = lo.ldet.width;
        let (hw, hh) = (hi.ldet.width, hi.ldet.height);
        let (done, rest) = masks.split_at_mut(i + 1);
        let (Some(mlo), Some(mhi)) = (done.last(), rest.first_mut()) else {
            continue;
        };
        for (j, _) in mlo.iter().enumerate().filter(|(_, m)| **m != 0) {
            let (x, y) = (j % w, j / w);
            if let Some(idx) = find_neighbour(x / ratio, y / ratio, mhi, hw, hh, r)
                && lo.ldet.data[j] > hi.ldet.data[idx]
            {
                mhi[idx] = 0;
            }
        }
    }
    masks
}

/// Sub-pixel keypoints from the candidate masks (module docs); `angle_rad` is 0 until
/// [`orientations`] runs. `size` is the diameter `2 * 1.5 * sigma` in input pixels.
pub fn refine(space: &ScaleSpace, masks: &[Vec<u8>], params: &AkazeParams) -> Vec<Keypoint> {
    let mut out = Vec::new();
    for (li, (level, mask)) in space.levels.iter().zip(masks).enumerate() {
        let d = &level.ldet;
        let w = d.width;
        let at = |x: usize, y: usize| d.data[y * w + x];
        for (j, _) in mask.iter().enumerate().filter(|(_, m)| **m != 0) {
            let (x, y) = (j % w, j / w);
            if x == 0 || y == 0 || x + 1 >= w || y + 1 >= d.height {
                continue;
            }
            let c = at(x, y);
            let dx = 0.5 * (at(x + 1, y) - at(x - 1, y));
            let dy = 0.5 * (at(x, y + 1) - at(x, y - 1));
            let dxx = at(x + 1, y) + at(x - 1, y) - 2.0 * c;
            let dyy = at(x, y + 1) + at(x, y - 1) - 2.0 * c;
            let dxy =
                0.25 * (at(x + 1, y + 1) + at(x - 1, y - 1) - at(x + 1, y - 1) - at(x - 1, y + 1));
            let det = dxx * dyy - dxy * dxy;
            if det == 0.0 || !det.is_finite() {
                continue;
            }
            let ox = (-dx * dyy + dy * dxy) / det;
            let oy = (-dy * dxx + dx * dxy) / det;
            if ox.abs() > 1.0 || oy.abs() > 1.0 {
                continue;
            }
            let ratio = level.ratio;
            out.push(Keypoint {
                x: (x as f32 + ox) * ratio + 0.5 * (ratio - 1.0),
                y: (y as f32 + oy) * ratio + 0.5 * (ratio - 1.0),
                level: li as u8,
                angle_rad: 0.0,
                response: c,
                size: 2.0 * level.esigma * params.derivative_factor,
            });
        }
    }
    out
}

/// Dominant orientation of one keypoint (module docs), radians in `(-pi, pi]`.
pub fn orientation(level: &Level, kp: &Keypoint) -> f32 {
    let s = level.sigma_size as i32;
    let x0 = (kp.x / level.ratio).round_ties_even() as i32;
    let y0 = (kp.y / level.ratio).round_ties_even() as i32;
    let mut sx = [0f32; ORI_SLICES];
    let mut sy = [0f32; ORI_SLICES];
    let step = std::f32::consts::TAU / ORI_SLICES as f32;
    let g = 1.0 / (2.0 * ORI_SIGMA * ORI_SIGMA);
    for i in -ORI_RADIUS..=ORI_RADIUS {
        for j in -ORI_RADIUS..=ORI_RADIUS {
            if i * i + j * j >= ORI_RADIUS * ORI_RADIUS {
                continue;
            }
            let (x, y) = (x0 + j * s, y0 + i * s);
            if x < 0 || y < 0 {
                continue;
            }
            let (Some(gx), Some(gy)) = (
                level.lx.get(x as usize, y as usize),
                level.ly.get(x as usize, y as usize),
            ) else {
                continue;
            };
            let wgt = (-((i * i + j * j) as f32) * g).exp();
            let (rx, ry) = (wgt * gx, wgt * gy);
            let mut a = ry.atan2(rx);
            if a < 0.0 {
                a += std::f32::consts::TAU;
            }
            let b = ((a / step) as usize).min(ORI_SLICES - 1);
            sx[b] += rx;
            sy[b] += ry;
        }
    }
    let (mut best, mut bx, mut by) = (-1f32, 0f32, 0f32);
    for start in 0..ORI_SLICES {
        let (mut x, mut y) = (0f32, 0f32);
        for k in 0..ORI_WINDOW {
            let b = (start + k) % ORI_SLICES;
            x += sx[b];
            y += sy[b];
        }
        let n = x * x + y * y;
        if n > best {
            (best, bx, by) = (n, x, y);
        }
    }
    by.atan2(bx)
}

/// Sets `angle_rad` of every keypoint ([`orientation`]).
pub fn orientations(space: &ScaleSpace, kps: &mut [Keypoint], parallel: bool) {
    let f = |kp: &mut Keypoint| {
        if let Some(level) = space.levels.get(kp.level as usize) {
            kp.angle_rad = orientation(level, kp);
        }
    };
    if parallel {
        kps.par_iter_mut().for_each(f);
    } else {
        kps.iter_mut().for_each(f);
    }
}
