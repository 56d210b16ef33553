//! Grid-based motion statistics (Bian, Lin, Matsushita, Yeung, Nguyen & Cheng, "GMS:
//! Grid-based motion statistics for fast, ultra-robust feature correspondence", CVPR 2017).
//!
//! Motion smoothness makes a true match's neighbourhood hold many other matches into the
//! same neighbourhood of the other image, a false match's hardly any. Both images are cut
//! into a `G x G` grid (G = 20) over coordinates normalised by the image size. For each
//! cell `i` of image A, `j*(i)` is the cell of B receiving most of `i`'s matches (ties: the
//! lowest index). The pair is scored over the 3x3 neighbourhoods,
//! `S_i = sum_{k=1..9} |X_{i_k, j*_k}|` (matches from neighbour `i_k` to neighbour `j*_k`),
//! and kept when `S_i >= tau_i = alpha sqrt(n_i)` with `alpha` = 6 (the threshold factor)
//! and `n_i` the mean number of features in `i`'s (in-grid) neighbours (paper eq. 9 and
//! section 4.3). A match is an inlier when its cell pair was kept. Four grids (unshifted,
//! shifted by half a cell in x, in y, in both) are evaluated and their inliers united, so
//! motion across cell borders is not lost. Options (paper section 4.5): rotation, trying
//! the 8 rotations of the 3x3 neighbour pattern by 45 degrees; scale, trying B-grids of
//! `G r` cells, `r` in {1, 1/2, 1/sqrt 2, sqrt 2, 2}; the mask with most inliers wins.
//! Matches whose indices fall outside the keypoint slices are marked outliers.

use super::Keypoint;
use super::matcher::Match;

/// GMS options.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GmsParams {
    /// Try the 8 rotated neighbour patterns (default false).
    pub with_rotation: bool,
    /// Try the 5 relative grid scales (default false).
    pub with_scale: bool,
    /// `alpha` of `tau = alpha sqrt(n)` (default 6, the paper's value).
    pub threshold_factor: f64,
    /// Cells per side of image A's grid (default 20).
    pub grid: usize,
}

impl Default for GmsParams {
    fn default() -> Self {
        Self {
            with_rotation: false,
            with_scale: false,
            threshold_factor: 6.0,
            grid: 20,
        }
    }
}

/// Relative grid scales tried with [`GmsParams::with_scale`].
pub const SCALE_RATIOS: [f64; 5] = [
    1.0,
    0.5,
    std::f64::consts::FRAC_1_SQRT_2,
    std::f64::consts::SQRT_2,
    2.0,
];

/// Ring of the 8 neighbours (row-major 3x3 indices), clockwise from the top-left.
const RING: [usize; 8] = [0, 1, 2, 5, 8, 7, 6, 3];

/// The 3x3 neighbour pattern rotated by `r * 45` degrees: entry `k` is the index of B's
/// neighbour paired with A's neighbour `k`.
pub fn rotation_pattern(r: usize) -> [usize; 9] {
    let mut p = [4usize; 9];
    for i in 0..8 {
        p[RING[i]] = RING[(i + 8 - (r % 8)) % 8];
    }
    p
}

/// The 3x3 neighbourhood of `cell` in a `w x h` grid, row-major, `None` outside.
fn nb9(cell: usize, w: usize, h: usize) -> [Option<usize>; 9] {
    let (cx, cy) = ((cell % w) as isize, (cell / w) as isize);
    std::array::from_fn(|k| {
        let (x, y) = (cx + (k % 3) as isize - 1, cy + (k / 3) as isize - 1);
        (x >= 0 && y >= 0 && x < w as isize && y < h as isize).then(|| y as usize * w + x as usize)
    })
}

/// GMS inlier mask of `matches` between keypoints `kps_a` of an image of `size_a =
/// (width, height)` pixels and `kps_b` of `size_b` (module docs).
pub fn gms_filter(
    kps_a: &[Keypoint],
    size_a: (usize, usize),
    kps_b: &[Keypoint],
    size_b: (usize, usize),
    matches: &[Match],
    params: &GmsParams,
) -> Vec<bool> {
    let norm = |k: &Keypoint, s: (usize, usize)| [k.x / s.0.max(1) as f32, k.y / s.1.max(1) as f32];
    let mut valid = vec![false; matches.len()];
    let mut pa = Vec::with_capacity(matches.len());
    let mut pb = Vec::with_capacity(matches.len());
    for (m, v) in matches.iter().zip(valid.iter_mut()) {
        if let (Some(a), Some(b)) = (kps_a.get(m.query as usize), kps_b.get(m.train as usize)) {
            pa.push(norm(a, size_a));
            pb.push(norm(b, size_b));
            *v = true;
        }
    }
    let sub = gms_filter_points(&pa, &pb, params);
    let mut it = sub.into_iter();
    valid
        .iter()
        .map(|&v| v && it.next().unwrap_or(false))
        .collect()
}

/// GMS on matched point pairs already normalised to `[0, 1)` by their image sizes:
/// `a[i] <-> b[i]`. Returns the inlier mask.
pub fn gms_filter_points(a: &[[f32; 2]], b: &[[f32; 2]], params: &GmsParams) -> Vec<bool> {
    let n = a.len().min(b.len());
    let mut gms = Gms::new(params.grid.max(1));
    let scales: &[f64] = if params.with_scale {
        &SCALE_RATIOS
    } else {
        &SCALE_RATIOS[..1]
    };
    let rotations = if params.with_rotation { 8 } else { 1 };
    let mut best: Option<(usize, Vec<bool>)> = None;
    for &s in scales {
        let gr = ((params.grid as f64 * s) as usize).max(1);
        for r in 0..rotations {
            let mask = gms.run(&a[..n], &b[..n], gr, r, params.threshold_factor);
            let count = mask.iter().filter(|&&m| m).count();
            if best.as_ref().is_none_or(|(c, _)| count > *c) {
                best = Some((count, mask));
            }
        }
    }
    best.map(|(_, m)| m).unwrap_or_default()
}

/// Scratch state for one GMS evaluation.
struct Gms {
    g: usize,
    counts: Vec<u32>,
    left_points: Vec<u32>,
    best: Vec<(u32, u32)>,
    pair: Vec<Option<u32>>,
    cells: Vec<(i64, i64)>,
    touched: Vec<usize>,
}

impl Gms {
    fn new(g: usize) -> Self {
        let nl = g * g;
        Self {
            g,
            counts: Vec::new(),
            left_points: vec![0; nl],
            best: vec![(0, 0); nl],
            pair: vec![None; nl],
            cells: Vec::new(),
            touched: Vec::new(),
        }
    }

    /// One rotation / scale hypothesis: the union of the four shifted grids' inliers.
    fn run(
        &mut self,
        a: &[[f32; 2]],
        b: &[[f32; 2]],
        gr: usize,
        rot: usize,
        alpha: f64,
    ) -> Vec<bool> {
        let g = self.g;
        let nl = g * g;
        let nr = gr * gr;
        // All zero between runs (reset sparsely below), so only growth is paid for.
        if self.counts.len() < nl * nr {
            self.counts.resize(nl * nr, 0);
        }
        let pattern = rotation_pattern(rot);
        let mut mask = vec![false; a.len()];
        // B cells do not depend on the shift.
        let right: Vec<i64> = b
            .iter()
            .map(|p| {
                let x = ((p[0] as f64 * gr as f64).floor() as i64).clamp(0, gr as i64 - 1);
                let y = ((p[1] as f64 * gr as f64).floor() as i64).clamp(0, gr as i64 - 1);
                y * gr as i64 + x
            })
            .collect();
        for shift in 0..4 {
            let (sx, sy) = (
                if shift & 1 == 1 { 0.5 } else { 0.0 },
                if shift & 2 == 2 { 0.5 } else { 0.0 },
            );
            self.cells.clear();
            self.touched.clear();
            for (p, &r) in a.iter().zip(right.iter()) {
                let x = (p[0] as f64 * g as f64 + sx).floor() as i64;
                let y = (p[1] as f64 * g as f64 + sy).floor() as i64;
                let l = if x < 0 || y < 0 || x >= g as i64 || y >= g as i64 {
                    -1
                } else {
                    y * g as i64 + x
                };
                self.cells.push((l, r));
                if l >= 0 {
                    let (l, r) = (l as usize, r as usize);
                    if self.left_points[l] == 0 {
                        self.touched.push(l);
                    }
                    self.left_points[l] += 1;
                    self.counts[l * nr + r] += 1;
                }
            }
            // Most popular B cell per A cell, lowest index on ties.
            for &(l, r) in &self.cells {
                if l < 0 {
                    continue;
                }
                let (l, r) = (l as usize, r as u32);
                let c = self.counts[l * nr + r as usize];
                let (bc, br) = self.best[l];
                if c > bc || (c == bc && r < br) {
                    self.best[l] = (c, r);
                }
            }
            for &l in &self.touched {
                let j = self.best[l].1 as usize;
                let nbl = nb9(l, g, g);
                let nbr = nb9(j, gr, gr);
                let (mut score, mut thresh, mut pairs) = (0u64, 0u64, 0u64);
                for k in 0..9 {
                    let (Some(ll), Some(rr)) = (nbl[k], nbr[pattern[k]]) else {
                        continue;
                    };
                    score += u64::from(self.counts[ll * nr + rr]);
                    thresh += u64::from(self.left_points[ll]);
                    pairs += 1;
                }
                let tau = alpha * (thresh as f64 / pairs.max(1) as f64).sqrt();
                self.pair[l] = ((score as f64) >= tau).then_some(j as u32);
            }
            for (m, &(l, r)) in mask.iter_mut().zip(self.cells.iter()) {
                if l >= 0 && self.pair[l as usize] == Some(r as u32) {
                    *m = true;
                }
            }
            // Sparse reset.
            for &(l, r) in &self.cells {
                if l >= 0 {
                    self.counts[l as usize * nr + r as usize] = 0;
                }
            }
            for &l in &self.touched {
                self.left_points[l] = 0;
                self.best[l] = (0, 0);
                self.pair[l] = None;
            }
        }
        mask
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotation_patterns_match_the_paper() {
        assert_eq!(rotation_pattern(0), [0, 1, 2, 3, 4, 5, 6, 7, 8]);
        // GMS's second pattern: 4,1,2 / 7,5,3 / 8,9,6 (1-based).
        assert_eq!(rotation_pattern(1), [3, 0, 1, 6, 4, 2, 7, 8, 5]);
        // 180 degrees reverses the neighbourhood.
        assert_eq!(rotation_pattern(4), [8, 7, 6, 5, 4, 3, 2, 1, 0]);
    }

    #[test]
    fn neighbourhood_at_corner() {
        let nb = nb9(0, 20, 20);
        assert_eq!(
            nb,
            [
                None,
                None,
                None,
                None,
                Some(0),
                Some(1),
                None,
                Some(20),
                Some(21)
            ]
        );
    }
}
