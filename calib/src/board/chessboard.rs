//! Chessboard inner-corner detection (pixel accuracy; [`super::subpixel`] refines).
//!
//! 1. **Downscale** by an integer box filter so the longer side is at most
//!    [`DetectParams::max_side_px`] (large photos; the lattice only needs pixel accuracy).
//! 2. **Saddle response**: on the image smoothed by a Gaussian of `sigma`, the Hessian
//!    `H = [Lxx Lxy; Lxy Lyy]` of an X-junction (two dark and two bright sectors) has
//!    `det H < 0`; the response is `R = max(0, -det H)`, strong at chessboard corners under
//!    any rotation and moderate perspective, zero on straight edges and positive on blobs.
//!    Local maxima of `R` above [`DetectParams::min_response_rel`] times the image maximum
//!    are candidates, refined by a parabola through the 3x3 neighbourhood.
//! 3. **Sector test** (after ChESS, Bennett & Lasenby 2014): the smoothed intensity on a
//!    circle of radius `r` around a corner alternates dark/bright/dark/bright. With
//!    `F_k = |sum_j s_j e^{-i k theta_j}|` the Fourier magnitudes of the circular profile, a
//!    corner has `F_2 > F_1` and exactly four sign changes of `s - mean`; the four crossing
//!    angles give the two edge directions through the corner (`u(theta_0) - u(theta_2)`,
//!    `u(theta_1) - u(theta_3)`), which are the directions to the neighbouring corners.
//! 4. **Lattice growing** (Geiger, Moosmann, Car & Schuster, ICRA 2012, sec. III-B): from a
//!    seed corner, its nearest candidates along `+d1` and `+d2` and the diagonal completing
//!    the square form a 2x2 lattice; each border row/column is then predicted by
//!    extrapolation (second differences when three are known) and accepted when every
//!    predicted corner has a candidate within [`GROW_TOLERANCE`] of the local spacing. Growth
//!    stops at the board's outer edge (no X-junction beyond it); the lattice must have
//!    exactly `cols x rows` corners and its cells must alternate dark/bright
//!    ([`MIN_CELL_AGREEMENT`]).
//! 5. **Ordering**: row-major with a right-handed board frame; on a board without half-turn
//!    symmetry (`cols + rows` odd) the origin square (diagonally outside the first corner) is
//!    the dark one, on a symmetric board the ordering is the most upright one in the image
//!    (see the [`super`] docs).

use image::GrayImage;
use nalgebra::{Point2, Vector2};

use super::BoardError;

/// Largest relative distance (of the local corner spacing) between a predicted and an
/// accepted corner while growing the lattice.
pub const GROW_TOLERANCE: f64 = 0.3;
/// Largest angle (radians) between a seed's edge direction and the direction to its
/// neighbour.
pub const SEED_ANGLE_RAD: f64 = 0.4;
/// Fraction of the lattice cells that must alternate dark/bright.
pub const MIN_CELL_AGREEMENT: f64 = 0.9;
/// Samples on the circle of the sector test.
const SECTOR_SAMPLES: usize = 48;
/// The smallest image side accepted, pixels.
const MIN_IMAGE_SIDE_PX: u32 = 16;

/// Parameters of [`detect_chessboard`]. Every default is documented on its field.
#[derive(Debug, Clone, PartialEq)]
pub struct DetectParams {
    /// The image is box-downscaled by the smallest integer factor bringing its longer side
    /// to at most this, pixels. Default 1200.
    pub max_side_px: u32,
    /// Gaussian scales (pixels of the downscaled image) tried in order until the board is
    /// found. Default `[1.0, 1.8, 0.7]` (sharp boards with small squares, blurred ones, tiny ones).
    pub sigmas_px: Vec<f64>,
    /// Candidates need a saddle response of at least this fraction of the image maximum.
    /// Default 0.01.
    pub min_response_rel: f64,
    /// Sector-test contrast: `F_2` amplitude of the circular profile, grey levels (0-255).
    /// Default 6.
    pub min_contrast: f64,
    /// At most this many candidates (strongest first). Default 3000.
    pub max_candidates: usize,
    /// At most this many seeds tried per scale (strongest first). Default 400.
    pub max_seeds: usize,
}

impl Default for DetectParams {
    fn default() -> Self {
        Self {
            max_side_px: 1200,
            sigmas_px: vec![1.0, 1.8, 0.7],
            min_response_rel: 0.01,
            min_contrast: 6.0,
            max_candidates: 3000,
            max_seeds: 400,
        }
    }
}

/// A float image, row-major, `data[y * width + x]`.
#[derive(Debug, Clone)]
pub(crate) struct Plane {
    pub(crate) width: usize,
    pub(crate) height: usize,
    pub(crate) data: Vec<f32>,
}

impl Plane {
    /// From an 8-bit image (grey levels 0-255).
    pub(crate) fn from_gray(image: &GrayImage) -> Self {
        Self {
            width: image.width() as usize,
            height: image.height() as usize,
            data: image.as_raw().iter().map(|&v| f32::from(v)).collect(),
        }
    }

    /// Pixel with clamped coordinates.
    #[inline]
    pub(crate) fn at(&self, x: isize, y: isize) -> f32 {
        let xc = x.clamp(0, self.width as isize - 1) as usize;
        let yc = y.clamp(0, self.height as isize - 1) as usize;
        self.data.get(yc * self.width + xc).copied().unwrap_or(0.0)
    }

    /// Bilinear interpolation with clamped borders (pixel centres at integers).
    #[inline]
    pub(crate) fn bilinear(&self, x: f64, y: f64) -> f64 {
        let x0 = x.floor();
        let y0 = y.floor();
        let fx = x - x0;
        let fy = y - y0;
        let (xi, yi) = (x0 as isize, y0 as isize);
        let a = f64::from(self.at(xi, yi));
        let b = f64::from(self.at(xi + 1, yi));
        let c = f64::from(self.at(xi, yi + 1));
        let d = f64::from(self.at(xi + 1, yi + 1));
        (a * (1.0 - fx) + b * fx) * (1.0 - fy) + (c * (1.0 - fx) + d * fx) * fy
    }

    /// Integer box downscale by `factor` (output pixel `k` averages input pixels
    /// `factor k .. factor k + factor - 1`, so its centre is at `factor k + (factor - 1) / 2`).
    fn downscale(&self, factor: usize) -> Self {
        if factor <= 1 {
            return self.clone();
        }
        let width = self.width / factor;
        let height = self.height / factor;
        let mut data = vec![0.0f32; width * height];
        let norm = 1.0 / (factor * factor) as f32;
        for (y, row) in data.chunks_mut(width.max(1)).enumerate() {
            for (x, out) in row.iter_mut().enumerate() {
                let mut s = 0.0f32;
                for dy in 0..factor {
                    let base = (y * factor + dy) * self.width + x * factor;
                    if let Some(src) = self.data.get(base..base + factor) {
                        s += src.iter().sum::<f32>();
                    }
                }
                *out = s * norm;
            }
        }
        Self {
            width,
            height,
            data,
        }
    }

    /// Separable Gaussian smoothing (kernel radius `ceil(3 sigma)`, clamped borders).
    pub(crate) fn gaussian(&self, sigma: f64) -> Self {
        if sigma <= 0.0 {
            return self.clone();
        }
        let radius = (3.0 * sigma).ceil() as isize;
        let mut kernel: Vec<f32> = (-radius..=radius)
            .map(|i| (-(i * i) as f64 / (2.0 * sigma * sigma)).exp() as f32)
            .collect();
        let total: f32 = kernel.iter().sum();
        kernel.iter_mut().for_each(|k| *k /= total);
        let mut tmp = vec![0.0f32; self.data.len()];
        for y in 0..self.height {
            for x in 0..self.width {
                let mut s = 0.0;
                for (k, w) in kernel.iter().enumerate() {
                    s += w * self.at(x as isize + k as isize - radius, y as isize);
                }
                if let Some(t) = tmp.get_mut(y * self.width + x) {
                    *t = s;
                }
            }
        }
        let horizontal = Self {
            width: self.width,
            height: self.height,
            data: tmp,
        };
        let mut out = vec![0.0f32; self.data.len()];
        for y in 0..self.height {
            for x in 0..self.width {
                let mut s = 0.0;
                for (k, w) in kernel.iter().enumerate() {
                    s += w * horizontal.at(x as isize, y as isize + k as isize - radius);
                }
                if let Some(o) = out.get_mut(y * self.width + x) {
                    *o = s;
                }
            }
        }
        Self {
            width: self.width,
            height: self.height,
            data: out,
        }
    }
}

/// A corner candidate in the downscaled image.
#[derive(Debug, Clone, Copy)]
struct Candidate {
    p: Vector2<f64>,
    response: f64,
    /// Unit edge directions (signs arbitrary).
    d1: Vector2<f64>,
    d2: Vector2<f64>,
}

/// Detects the `cols x rows` inner corners of a chessboard; returns them row-major in
/// full-resolution pixels (OpenCV pixel-centre convention), at about 1 px accuracy before
/// [`super::subpixel::refine_corners`].
///
/// # Errors
/// [`BoardError::InvalidBoard`], [`BoardError::ImageTooSmall`], and
/// [`BoardError::NotFound`] (with `image = 0`; [`BoardError::with_image`] renames it) when no
/// scale of [`DetectParams::sigmas_px`] yields the complete lattice.
pub fn detect_chessboard(
    image: &GrayImage,
    cols: usize,
    rows: usize,
    params: &DetectParams,
) -> Result<Vec<Point2<f64>>, BoardError> {
    if cols < 2 || rows < 2 {
        return Err(BoardError::InvalidBoard { cols, rows });
    }
    let (w, h) = image.dimensions();
    if w < MIN_IMAGE_SIDE_PX || h < MIN_IMAGE_SIDE_PX {
        return Err(BoardError::ImageTooSmall {
            image: 0,
            width: w,
            height: h,
        });
    }
    let full = Plane::from_gray(image);
    let max_side = params.max_side_px.max(MIN_IMAGE_SIDE_PX) as usize;
    let factor = (w.max(h) as usize).div_ceil(max_side).max(1);
    let small = full.downscale(factor);
    let mut most_candidates = 0usize;
    let mut largest = (0usize, 0usize);
    for &sigma in &params.sigmas_px {
        let smooth = small.gaussian(sigma);
        let candidates = find_candidates(&smooth, sigma, params);
        most_candidates = most_candidates.max(candidates.len());
        match grow_lattice(&smooth, &candidates, cols, rows, params.max_seeds) {
            Ok(grid) => {
                let offset = (factor as f64 - 1.0) / 2.0;
                return Ok(grid
                    .into_iter()
                    .map(|p| {
                        Point2::new(p.x * factor as f64 + offset, p.y * factor as f64 + offset)
                    })
                    .collect());
            }
            Err((a, b)) => {
                if a * b > largest.0 * largest.1 {
                    largest = (a, b);
                }
            }
        }
    }
    Err(BoardError::NotFound {
        image: 0,
        cols,
        rows,
        candidates: most_candidates,
        best_a: largest.0,
        best_b: largest.1,
    })
}

/// Saddle-response maxima that pass the sector test (module steps 2-3).
fn find_candidates(smooth: &Plane, sigma: f64, params: &DetectParams) -> Vec<Candidate> {
    let (w, h) = (smooth.width, smooth.height);
    let mut response = vec![0.0f32; w * h];
    let mut max_r = 0.0f32;
    for y in 1..h.saturating_sub(1) {
        for x in 1..w.saturating_sub(1) {
            let (xi, yi) = (x as isize, y as isize);
            let c = smooth.at(xi, yi);
            let lxx = smooth.at(xi + 1, yi) - 2.0 * c + smooth.at(xi - 1, yi);
            let lyy = smooth.at(xi, yi + 1) - 2.0 * c + smooth.at(xi, yi - 1);
            let lxy =
                (smooth.at(xi + 1, yi + 1) - smooth.at(xi + 1, yi - 1) - smooth.at(xi - 1, yi + 1)
                    + smooth.at(xi - 1, yi - 1))
                    * 0.25;
            let r = (lxy * lxy - lxx * lyy).max(0.0);
            if let Some(o) = response.get_mut(y * w + x) {
                *o = r;
            }
            max_r = max_r.max(r);
        }
    }
    if max_r <= 0.0 {
        return Vec::new();
    }
    let threshold = params.min_response_rel as f32 * max_r;
    let nms = (1.5 * sigma).round().max(1.0) as isize;
    let rat = |x: isize, y: isize| -> f32 {
        if x < 0 || y < 0 || x >= w as isize || y >= h as isize {
            return 0.0;
        }
        response
            .get(y as usize * w + x as usize)
            .copied()
            .unwrap_or(0.0)
    };
    let radius = (2.5 * sigma).max(3.0);
    let border = (radius.ceil() as isize + 1).max(nms);
    let mut peaks: Vec<(f32, isize, isize)> = Vec::new();
    for y in border..h as isize - border {
        for x in border..w as isize - border {
            let r = rat(x, y);
            if r < threshold {
                continue;
            }
            let mut is_max = true;
            'nms: for dy in -nms..=nms {
                for dx in -nms..=nms {
                    if (dx, dy) == (0, 0) {
                        continue;
                    }
                    let o = rat(x + dx, y + dy);
                    // Ties broken by scan order so a plateau yields one peak.
                    if o > r || (o == r && (dy, dx) < (0, 0)) {
                        is_max = false;
                        break 'nms;
                    }
                }
            }
            if is_max {
                peaks.push((r, x, y));
            }
        }
    }
    peaks.sort_by(|a, b| b.0.total_cmp(&a.0).then((a.2, a.1).cmp(&(b.2, b.1))));
    peaks.truncate(params.max_candidates);
    let mut out = Vec::with_capacity(peaks.len());
    for (r, x, y) in peaks {
        // Parabola through the 3x3 neighbourhood, per axis.
        let sub = |m: f32, c: f32, p: f32| -> f64 {
            let den = f64::from(m - 2.0 * c + p);
            if den.abs() < 1e-12 {
                0.0
            } else {
                (0.5 * f64::from(m - p) / den).clamp(-0.5, 0.5)
            }
        };
        let dx = sub(rat(x - 1, y), r, rat(x + 1, y));
        let dy = sub(rat(x, y - 1), r, rat(x, y + 1));
        let p = Vector2::new(x as f64 + dx, y as f64 + dy);
        if let Some((d1, d2)) = sector_test(smooth, &p, radius, params.min_contrast) {
            out.push(Candidate {
                p,
                response: f64::from(r),
                d1,
                d2,
            });
        }
    }
    out
}

/// The circular-profile test of the module docs (step 3); returns the two edge directions.
fn sector_test(
    smooth: &Plane,
    p: &Vector2<f64>,
    radius: f64,
    min_contrast: f64,
) -> Option<(Vector2<f64>, Vector2<f64>)> {
    let n = SECTOR_SAMPLES;
    let mut s = [0.0f64; SECTOR_SAMPLES];
    let step = std::f64::consts::TAU / n as f64;
    for (j, v) in s.iter_mut().enumerate() {
        let t = j as f64 * step;
        *v = smooth.bilinear(p.x + radius * t.cos(), p.y + radius * t.sin());
    }
    let mean = s.iter().sum::<f64>() / n as f64;
    let (mut a1, mut b1, mut a2, mut b2) = (0.0, 0.0, 0.0, 0.0);
    for (j, v) in s.iter().enumerate() {
        let t = j as f64 * step;
        a1 += v * t.cos();
        b1 += v * t.sin();
        a2 += v * (2.0 * t).cos();
        b2 += v * (2.0 * t).sin();
    }
    let f1 = 2.0 * a1.hypot(b1) / n as f64;
    let f2 = 2.0 * a2.hypot(b2) / n as f64;
    if f2 < min_contrast || f2 < f1 {
        return None;
    }
    // Sign changes with a dead band of a quarter of the amplitude.
    let band = 0.25 * f2;
    let labels: Vec<(usize, i8)> = s
        .iter()
        .enumerate()
        .filter_map(|(j, v)| {
            let d = v - mean;
            if d > band {
                Some((j, 1))
            } else if d < -band {
                Some((j, -1))
            } else {
                None
            }
        })
        .collect();
    let m = labels.len();
    if m < 4 {
        return None;
    }
    let mut crossings = Vec::with_capacity(4);
    for k in 0..m {
        let (i, li) = labels.get(k).copied()?;
        let (j, lj) = labels.get((k + 1) % m).copied()?;
        if li == lj {
            continue;
        }
        // Zero of s - mean between samples i and j (cyclically), linearly interpolated.
        let span = (j + n - i) % n;
        let mut angle = None;
        for q in 0..span {
            let ia = (i + q) % n;
            let ib = (i + q + 1) % n;
            let (va, vb) = (s.get(ia)? - mean, s.get(ib)? - mean);
            if (va > 0.0) != (vb > 0.0) || vb == 0.0 {
                let f = if (va - vb).abs() > 1e-12 {
                    va / (va - vb)
                } else {
                    0.5
                };
                angle = Some((i + q) as f64 * step + f * step);
                break;
            }
        }
        crossings.push(angle?);
    }
    if crossings.len() != 4 {
        return None;
    }
    crossings.sort_by(f64::total_cmp);
    let u = |t: f64| Vector2::new(t.cos(), t.sin());
    let d1 = (u(crossings[0]) - u(crossings[2])).try_normalize(1e-9)?;
    let d2 = (u(crossings[1]) - u(crossings[3])).try_normalize(1e-9)?;
    // Edges of a corner are far from parallel even under strong perspective.
    if d1.dot(&d2).abs() > 0.9 {
        return None;
    }
    Some((d1, d2))
}

/// Lattice growing (module step 4) and ordering (step 5). On failure returns the largest
/// lattice size seen.
fn grow_lattice(
    smooth: &Plane,
    cands: &[Candidate],
    cols: usize,
    rows: usize,
    max_seeds: usize,
) -> Result<Vec<Vector2<f64>>, (usize, usize)> {
    let mut best = (0usize, 0usize);
    let mut order: Vec<usize> = (0..cands.len()).collect();
    order.sort_by(|&a, &b| {
        let ra = cands.get(a).map_or(0.0, |c| c.response);
        let rb = cands.get(b).map_or(0.0, |c| c.response);
        rb.total_cmp(&ra).then(a.cmp(&b))
    });
    for &seed in order.iter().take(max_seeds) {
        let Some(grid) = seed_lattice(cands, seed) else {
            continue;
        };
        let grown = grow(cands, grid, cols.max(rows));
        let (nr, nc) = (grown.len(), grown.first().map_or(0, Vec::len));
        if nr * nc > best.0 * best.1 {
            best = (nr, nc);
        }
        if (nr == rows && nc == cols) || (nr == cols && nc == rows) {
            let pts: Vec<Vec<Vector2<f64>>> = grown
                .iter()
                .map(|row| {
                    row.iter()
                        .map(|&i| cands.get(i).map_or(Vector2::zeros(), |c| c.p))
                        .collect()
                })
                .collect();
            if !squares_alternate(&pts, smooth) {
                continue;
            }
            if let Some(ordered) = order_lattice(&pts, cols, rows, smooth) {
                return Ok(ordered);
            }
        }
    }
    Err(best)
}

/// Consistency check of a complete lattice: the cells between its corners must alternate
/// dark/bright like a chessboard (at least [`MIN_CELL_AGREEMENT`] of them), which rejects
/// lattices grown on other regular structures.
fn squares_alternate(pts: &[Vec<Vector2<f64>>], smooth: &Plane) -> bool {
    let mut values = Vec::new();
    for (r, pair) in pts.windows(2).enumerate() {
        let (Some(top), Some(bottom)) = (pair.first(), pair.get(1)) else {
            continue;
        };
        for c in 0..top.len().saturating_sub(1) {
            let (Some(a), Some(b), Some(d), Some(e)) =
                (top.get(c), top.get(c + 1), bottom.get(c), bottom.get(c + 1))
            else {
                continue;
            };
            let centre = (a + b + d + e) / 4.0;
            values.push(((r + c) % 2 == 0, smooth.bilinear(centre.x, centre.y)));
        }
    }
    if values.is_empty() {
        return false;
    }
    // Dark and bright cells are equally many (within one): their mean separates them.
    let threshold = values.iter().map(|v| v.1).sum::<f64>() / values.len() as f64;
    // Agreement with "even cells dark" and with "even cells bright".
    let dark_even = values
        .iter()
        .filter(|(even, v)| *even == (*v < threshold))
        .count();
    let best = dark_even.max(values.len() - dark_even);
    best as f64 >= MIN_CELL_AGREEMENT * values.len() as f64
}

/// Nearest candidate (not `from`, not in `used`) within [`SEED_ANGLE_RAD`] of direction `d`
/// from candidate `from`, sharing its edge directions.
fn neighbour_along(
    cands: &[Candidate],
    from: usize,
    d: &Vector2<f64>,
    used: &[usize],
) -> Option<usize> {
    let p = cands.get(from)?;
    let cos_max = SEED_ANGLE_RAD.cos();
    let mut best: Option<(f64, usize)> = None;
    for (k, c) in cands.iter().enumerate() {
        if k == from || used.contains(&k) {
            continue;
        }
        let v = c.p - p.p;
        let dist = v.norm();
        if dist < 2.0 {
            continue;
        }
        if v.dot(d) / dist < cos_max {
            continue;
        }
        // The neighbour shares (roughly) the seed's edge directions.
        let compatible = |e: &Vector2<f64>| c.d1.dot(e).abs().max(c.d2.dot(e).abs()) > 0.8;
        if !(compatible(&p.d1) && compatible(&p.d2)) {
            continue;
        }
        if best.is_none_or(|(bd, _)| dist < bd) {
            best = Some((dist, k));
        }
    }
    best.map(|(_, k)| k)
}

/// The 2x2 seed lattice `[[seed, right], [down, diagonal]]`.
fn seed_lattice(cands: &[Candidate], seed: usize) -> Option<Vec<Vec<usize>>> {
    let c = cands.get(seed)?;
    let right = neighbour_along(cands, seed, &c.d1, &[])?;
    let down = neighbour_along(cands, seed, &c.d2, &[right])?;
    let (pr, pd) = (cands.get(right)?.p, cands.get(down)?.p);
    let (lr, ld) = ((pr - c.p).norm(), (pd - c.p).norm());
    if lr > 3.0 * ld || ld > 3.0 * lr {
        return None;
    }
    let predicted = pr + pd - c.p;
    let diag = nearest_within(
        cands,
        &predicted,
        GROW_TOLERANCE * lr.min(ld),
        &[seed, right, down],
    )?;
    Some(vec![vec![seed, right], vec![down, diag]])
}

/// Nearest candidate to `p` within `radius`, excluding `used`.
fn nearest_within(
    cands: &[Candidate],
    p: &Vector2<f64>,
    radius: f64,
    used: &[usize],
) -> Option<usize> {
    let mut best: Option<(f64, usize)> = None;
    for (k, c) in cands.iter().enumerate() {
        let d = (c.p - p).norm();
        if d <= radius && !used.contains(&k) && best.is_none_or(|(bd, _)| d < bd) {
            best = Some((d, k));
        }
    }
    best.map(|(_, k)| k)
}

/// Extrapolates one point beyond `p0` from the inner points `p1` (and `p2`).
fn extrapolate(p0: Vector2<f64>, p1: Vector2<f64>, p2: Option<Vector2<f64>>) -> Vector2<f64> {
    let d = p0 - p1;
    match p2 {
        Some(p2) => {
            let d_prev = p1 - p2;
            // Second differences, damped: perspective shrinks or stretches the spacing.
            p0 + d + (d - d_prev)
        }
        None => p0 + d,
    }
}

/// Grows the lattice side by side until no side extends or a side exceeds `max_side + 1`.
fn grow(cands: &[Candidate], mut grid: Vec<Vec<usize>>, max_side: usize) -> Vec<Vec<usize>> {
    let pos = |k: usize| cands.get(k).map_or(Vector2::zeros(), |c| c.p);
    loop {
        let mut changed = false;
        for side in 0..4 {
            let nr = grid.len();
            let nc = grid.first().map_or(0, Vec::len);
            if nr > max_side + 1 || nc > max_side + 1 {
                return grid;
            }
            // Lines to extrapolate: (edge, inner, inner2) per element of the side.
            let mut used: Vec<usize> = grid.iter().flatten().copied().collect();
            let mut new_line = Vec::new();
            let count = if side < 2 { nc } else { nr };
            let mut ok = count > 0;
            for i in 0..count {
                let get = |r: usize, c: usize| grid.get(r).and_then(|row| row.get(c)).copied();
                let (e, i1, i2) = match side {
                    0 => (get(0, i), get(1, i), if nr > 2 { get(2, i) } else { None }),
                    1 => (
                        get(nr - 1, i),
                        get(nr.wrapping_sub(2), i),
                        if nr > 2 { get(nr - 3, i) } else { None },
                    ),
                    2 => (get(i, 0), get(i, 1), if nc > 2 { get(i, 2) } else { None }),
                    _ => (
                        get(i, nc - 1),
                        get(i, nc.wrapping_sub(2)),
                        if nc > 2 { get(i, nc - 3) } else { None },
                    ),
                };
                let (Some(e), Some(i1)) = (e, i1) else {
                    ok = false;
                    break;
                };
                let (pe, p1) = (pos(e), pos(i1));
                let predicted = extrapolate(pe, p1, i2.map(pos));
                let spacing = (pe - p1).norm();
                match nearest_within(cands, &predicted, GROW_TOLERANCE * spacing, &used) {
                    Some(k) => {
                        used.push(k);
                        new_line.push(k);
                    }
                    None => {
                        ok = false;
                        break;
                    }
                }
            }
            if !ok {
                continue;
            }
            changed = true;
            match side {
                0 => grid.insert(0, new_line),
                1 => grid.push(new_line),
                2 => {
                    for (row, k) in grid.iter_mut().zip(new_line) {
                        row.insert(0, k);
                    }
                }
                _ => {
                    for (row, k) in grid.iter_mut().zip(new_line) {
                        row.push(k);
                    }
                }
            }
        }
        if !changed {
            return grid;
        }
    }
}

/// Orders a complete lattice row-major (module step 5): right-handed (`x cross y > 0` in
/// image coordinates with `v` down, i.e. board `z` away from the camera); of the orderings
/// left, on a board without half-turn symmetry (`cols + rows` odd) the one whose origin
/// square (diagonally outside corner 0) is dark, otherwise the most upright one.
fn order_lattice(
    pts: &[Vec<Vector2<f64>>],
    cols: usize,
    rows: usize,
    smooth: &Plane,
) -> Option<Vec<Vector2<f64>>> {
    let nr = pts.len();
    let nc = pts.first().map_or(0, Vec::len);
    if nr < 2 || nc < 2 {
        return None;
    }
    let at = |r: usize, c: usize| pts.get(r).and_then(|row| row.get(c)).copied();
    // Mean direction along the lattice's own columns (c) and rows (r).
    let along_c =
        (at(0, nc - 1)? - at(0, 0)? + at(nr - 1, nc - 1)? - at(nr - 1, 0)?).try_normalize(1e-9)?;
    let along_r =
        (at(nr - 1, 0)? - at(0, 0)? + at(nr - 1, nc - 1)? - at(0, nc - 1)?).try_normalize(1e-9)?;
    let reorder = |transpose: bool, flip_c: bool, flip_r: bool| -> Option<Vec<Vector2<f64>>> {
        let mut out = Vec::with_capacity(cols * rows);
        for y in 0..rows {
            for x in 0..cols {
                let (r, c) = if transpose { (x, y) } else { (y, x) };
                let r = if flip_r { nr - 1 - r } else { r };
                let c = if flip_c { nc - 1 - c } else { c };
                out.push(at(r, c)?);
            }
        }
        Some(out)
    };
    let asymmetric = (cols + rows) % 2 == 1;
    // Candidate orderings: (transpose, flip_c, flip_r); board x along lattice c unless
    // transposed. Score: higher is better.
    let mut best: Option<(f64, Vec<Vector2<f64>>)> = None;
    for transpose in [false, true] {
        let (nx, ny) = if transpose { (nr, nc) } else { (nc, nr) };
        if nx != cols || ny != rows {
            continue;
        }
        for flip_c in [false, true] {
            for flip_r in [false, true] {
                let dc = if flip_c { -along_c } else { along_c };
                let dr = if flip_r { -along_r } else { along_r };
                let (dx, dy) = if transpose { (dr, dc) } else { (dc, dr) };
                let cross = dx.x * dy.y - dx.y * dy.x;
                if cross <= 0.0 {
                    continue;
                }
                let ordered = reorder(transpose, flip_c, flip_r)?;
                let score = if asymmetric {
                    // Brightness of the square diagonally outside corner 0 (negated: dark wins).
                    let p0 = *ordered.first()?;
                    let px = *ordered.get(1)?;
                    let py = *ordered.get(cols)?;
                    let centre = p0 - 0.5 * (px - p0) - 0.5 * (py - p0);
                    -smooth.bilinear(centre.x, centre.y)
                } else {
                    dx.x + dy.y
                };
                if best.as_ref().is_none_or(|(b, _)| score > *b) {
                    best = Some((score, ordered));
                }
            }
        }
    }
    best.map(|(_, ordered)| ordered)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An ideal axis-aligned board image: squares of `sq` px, inner corner (0, 0) at `origin`.
    fn ideal_board(
        w: u32,
        h: u32,
        cols: usize,
        rows: usize,
        sq: f64,
        origin: (f64, f64),
    ) -> GrayImage {
        GrayImage::from_fn(w, h, |x, y| {
            let bx = (f64::from(x) - origin.0) / sq;
            let by = (f64::from(y) - origin.1) / sq;
            let inside = bx > -1.0 && by > -1.0 && bx < cols as f64 && by < rows as f64;
            let v = if inside {
                if (bx.floor() as i64 + by.floor() as i64).rem_euclid(2) == 0 {
                    30
                } else {
                    220
                }
            } else {
                200
            };
            image::Luma([v])
        })
    }

    #[test]
    fn finds_an_axis_aligned_board_row_major() {
        let img = ideal_board(400, 300, 6, 4, 30.0, (80.3, 70.6));
        let corners = detect_chessboard(&img, 6, 4, &DetectParams::default()).expect("found");
        assert_eq!(corners.len(), 24);
        for r in 0..4 {
            for c in 0..6 {
                let p = corners[r * 6 + c];
                // The true corner is at the pixel boundary: origin - 0.5 in pixel-centre
                // coordinates.
                let tx = 80.3 - 0.5 + 30.0 * c as f64;
                let ty = 70.6 - 0.5 + 30.0 * r as f64;
                assert!(
                    (p.x - tx).abs() < 1.5 && (p.y - ty).abs() < 1.5,
                    "{r} {c}: {p} vs {tx} {ty}"
                );
            }
        }
    }

    #[test]
    fn wrong_size_is_not_found() {
        let img = ideal_board(400, 300, 6, 4, 30.0, (80.0, 70.0));
        let err = detect_chessboard(&img, 7, 4, &DetectParams::default());
        assert!(
            matches!(
                err,
                Err(BoardError::NotFound {
                    cols: 7,
                    rows: 4,
                    ..
                })
            ),
            "{err:?}"
        );
    }

    #[test]
    fn blank_image_is_not_found() {
        let img = GrayImage::from_pixel(200, 100, image::Luma([128]));
        assert!(matches!(
            detect_chessboard(&img, 6, 8, &DetectParams::default()),
            Err(BoardError::NotFound { candidates: 0, .. })
        ));
    }
}
