//! FAST-9 corner detection (Rosten & Drummond, "Machine learning for high-speed corner
//! detection", ECCV 2006).
//!
//! A pixel `p` with intensity `I_p` is a corner at threshold `t` when 9 contiguous pixels of
//! the 16-pixel Bresenham circle of radius 3 are all brighter than `I_p + t` or all darker
//! than `I_p - t`. The corner score is the largest margin that still makes `p` a corner:
//! `score = max over arcs A of min_{i in A} |I_i - I_p|` (bright arcs with `I_i - I_p`, dark
//! with `I_p - I_i`), so `p` is a corner at `t` exactly when `score > t`. We therefore
//! compute the score of every pixel, 64 pixels at a time on byte lanes (saturating
//! differences, windowed minima by doubling, branch-free so it vectorises), and threshold
//! it: the segment test and the scoring are one computation. Blocks of 64 where no two
//! circle-adjacent compass pixels pass are skipped (a necessary condition of any arc of 9). Non-maximum suppression
//! keeps a corner whose score beats its 8 neighbours (ties: the earlier one in raster order
//! wins).

use super::gray::GrayView;

/// Radius of the Bresenham circle; corners are never closer than this to the border.
pub const FAST_RADIUS: usize = 3;

/// The 16 circle offsets `(dx, dy)`, clockwise from the top.
pub const CIRCLE: [(i32, i32); 16] = [
    (0, -3),
    (1, -3),
    (2, -2),
    (3, -1),
    (3, 0),
    (3, 1),
    (2, 2),
    (1, 3),
    (0, 3),
    (-1, 3),
    (-2, 2),
    (-3, 1),
    (-3, 0),
    (-3, -1),
    (-2, -2),
    (-1, -3),
];

/// A FAST corner in the pixel grid of the image it was found in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Corner {
    /// Column.
    pub x: u32,
    /// Row.
    pub y: u32,
    /// FAST score (see the module docs), `> threshold`.
    pub score: u8,
}

/// A half-open pixel rectangle `[x0, x1) x [y0, y1)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rect {
    /// First column.
    pub x0: usize,
    /// First row.
    pub y0: usize,
    /// One past the last column.
    pub x1: usize,
    /// One past the last row.
    pub y1: usize,
}

/// [`FastDetector::detect`] as a [`simd::Kernel`].
struct Detect<'a, 'b> {
    det: &'a mut FastDetector,
    img: &'a GrayView<'b>,
    scored: Rect,
    inner: Rect,
    t: u8,
    nonmax: bool,
    out: &'a mut Vec<Corner>,
}

impl simd::Kernel for Detect<'_, '_> {
    type Output = ();
    #[inline(always)]
    fn run(self) {
        let Self {
            det,
            img,
            scored,
            inner,
            t,
            nonmax,
            out,
        } = self;
        det.detect_body(img, scored, inner, t, nonmax, out);
    }
}

/// The FAST score of a pixel from its 16 circle differences `d_i = I_i - I_p`: the best
/// over the 16 arcs of 9 of their smallest margin. Windowed minima/maxima are built by
/// doubling (2, 4, 8, then 9 wide) over the circle unrolled twice, so the work is a few
/// lane-wise operations on 16-wide arrays instead of 16 x 9 scalar comparisons.
#[inline(always)]
fn arc_score(d: &[i16; 16]) -> u8 {
    let ext: [i16; 32] = std::array::from_fn(|i| d[i & 15]);
    let mut lo2 = [0i16; 31];
    let mut hi2 = [0i16; 31];
    for i in 0..31 {
        lo2[i] = ext[i].min(ext[i + 1]);
        hi2[i] = ext[i].max(ext[i + 1]);
    }
    let mut lo4 = [0i16; 29];
    let mut hi4 = [0i16; 29];
    for i in 0..29 {
        lo4[i] = lo2[i].min(lo2[i + 2]);
        hi4[i] = hi2[i].max(hi2[i + 2]);
    }
    let mut best = 0i16;
    for i in 0..16 {
        let lo9 = lo4[i].min(lo4[i + 4]).min(ext[i + 8]);
        let hi9 = hi4[i].max(hi4[i + 4]).max(ext[i + 8]);
        best = best.max(lo9).max(-hi9);
    }
    best.clamp(0, 255) as u8
}

/// A FAST detector with reusable buffers (no allocation after warm-up).
#[derive(Clone, Debug, Default)]
pub struct FastDetector {
    /// Scores of the last scan over the scanned rectangle plus a one-pixel frame of zeros
    /// (row-major, `scores_w` wide): the score where it beats the threshold, else 0.
    scores: Vec<u8>,
    scores_w: usize,
    /// One row of surviving scores (0 where suppressed or no corner).
    kept: Vec<u8>,
}

/// Pixels scored together: one 512-bit vector of bytes.
const LANES: usize = 64;

impl FastDetector {
    /// A detector with empty buffers.
    pub fn new() -> Self {
        Self::default()
    }

    /// Appends to `out` the FAST-9 corners at `threshold` whose centre lies in `rect`
    /// (clipped so the circle stays inside the image), in raster order; with `nonmax`,
    /// only local maxima of the score (over the 8-neighbourhood, neighbours outside `rect`
    /// included) are kept.
    ///
    /// Every corner carries its score, which does not depend on `threshold`; so the
    /// corners at a higher threshold `t'` are exactly those of this call with
    /// `score > t'`, suppression included (a neighbour that is a corner at `threshold` but
    /// not at `t'` has a score `<= t'` below the corner's and cannot suppress it).
    pub fn detect(
        &mut self,
        img: &GrayView<'_>,
        rect: Rect,
        threshold: u8,
        nonmax: bool,
        out: &mut Vec<Corner>,
    ) {
        let (w, h) = (img.width(), img.height());
        if w <= 2 * FAST_RADIUS || h <= 2 * FAST_RADIUS {
            return;
        }
        let r = FAST_RADIUS;
        let x0 = rect.x0.max(r);
        let x1 = rect.x1.min(w - r);
        let y0 = rect.y0.max(r);
        let y1 = rect.y1.min(h - r);
        if x0 >= x1 || y0 >= y1 {
            return;
        }
        // Score a one-pixel margin too, so suppression sees neighbours outside the rect.
        let (sx0, sx1, sy0, sy1) = if nonmax {
            (
                x0.saturating_sub(1).max(r),
                (x1 + 1).min(w - r),
                y0.saturating_sub(1).max(r),
                (y1 + 1).min(h - r),
            )
        } else {
            (x0, x1, y0, y1)
        };
        // The score buffer covers [sx0 - 1, sx1 + 1) x [sy0 - 1, sy1 + 1): the frame
        // outside the scored pixels stays 0, like a pixel that is no corner.
        let sw = sx1 - sx0 + 2;
        self.scores.clear();
        self.scores.resize(sw * (sy1 - sy0 + 2), 0);
        self.scores_w = sw;
        simd::dispatch(Detect {
            det: self,
            img,
            scored: Rect {
                x0: sx0,
                x1: sx1,
                y0: sy0,
                y1: sy1,
            },
            inner: Rect { x0, y0, x1, y1 },
            t: threshold,
            nonmax,
            out,
        });
    }

    /// The body of [`Self::detect`] after clipping, inlined into the dispatched function:
    /// scores over `scored`, then suppression and collection over `inner`.
    #[inline(always)]
    fn detect_body(
        &mut self,
        img: &GrayView<'_>,
        scored: Rect,
        inner: Rect,
        t: u8,
        nonmax: bool,
        out: &mut Vec<Corner>,
    ) {
        let Rect {
            x0: sx0,
            x1: sx1,
            y0: sy0,
            y1: sy1,
        } = scored;
        let Rect { x0, y0, x1, y1 } = inner;
        let sw = self.scores_w;
        self.score_rows(img, sx0, sx1, sy0, sy1, t);
        // Buffer coordinates of image pixel (x, y): (x - sx0 + 1, y - sy0 + 1).
        let (bx0, bx1) = (x0 - sx0 + 1, x1 - sx0 + 1);
        let n = bx1 - bx0;
        let mut kept = std::mem::take(&mut self.kept);
        kept.clear();
        kept.resize(n, 0);
        for y in y0..y1 {
            let by = y - sy0 + 1;
            let Some(rows) = self.scores.get((by - 1) * sw..(by + 2) * sw) else {
                continue;
            };
            let (up, rest) = rows.split_at(sw);
            let (mid, dn) = rest.split_at(sw);
            if nonmax {
                suppress_row(up, mid, dn, bx0, &mut kept);
            } else {
                kept.copy_from_slice(&mid[bx0..bx1]);
            }
            // Non-zero bytes, a word of 8 at a time (most words are empty).
            for (ci, chunk) in kept.chunks(8).enumerate() {
                let mut word = match <[u8; 8]>::try_from(chunk) {
                    Ok(b) => u64::from_le_bytes(b),
                    Err(_) => chunk
                        .iter()
                        .enumerate()
                        .fold(0u64, |w, (k, &b)| w | (u64::from(b) << (8 * k))),
                };
                while word != 0 {
                    let k = (word.trailing_zeros() / 8) as usize;
                    let score = (word >> (8 * k)) as u8;
                    word &= !(0xFFu64 << (8 * k));
                    out.push(Corner {
                        x: (x0 + ci * 8 + k) as u32,
                        y: y as u32,
                        score,
                    });
                }
            }
        }
        self.kept = kept;
    }

    /// The body of the scoring kernel, inlined into the dispatched function: the score of
    /// every pixel of `[x0, x1) x [y0, y1)` where it exceeds `t` (else 0) into the score
    /// buffer. The caller keeps the circle inside the image.
    #[inline(always)]
    fn score_rows(
        &mut self,
        img: &GrayView<'_>,
        x0: usize,
        x1: usize,
        y0: usize,
        y1: usize,
        t: u8,
    ) {
        let sw = self.scores_w;
        let (w, n) = (img.width(), x1 - x0);
        for y in y0..y1 {
            let (Some(up), Some(r1), Some(r2), Some(row), Some(r4), Some(r5), Some(dn)) = (
                img.row(y - 3),
                img.row(y - 2),
                img.row(y - 1),
                img.row(y),
                img.row(y + 1),
                img.row(y + 2),
                img.row(y + 3),
            ) else {
                continue;
            };
            let rows = [up, r1, r2, row, r4, r5, dn];
            let start = (y - y0 + 1) * sw + 1;
            let Some(out) = self.scores.get_mut(start..start + n) else {
                continue;
            };
            if w >= LANES + 2 * FAST_RADIUS {
                // Whole vectors, each starting at most at x1 - LANES (and at least at the
                // circle's margin), so a short or ragged span is covered by shifting the
                // vector rather than by a scalar tail; recomputed pixels get equal scores.
                let mut x = x0;
                while x < x1 {
                    let xs = x.min(x1.saturating_sub(LANES)).max(FAST_RADIUS);
                    if !block_may_have_corner(&rows, xs, t) {
                        let (lo, hi) = (xs.max(x0), (xs + LANES).min(x1));
                        if let Some(dst) = out.get_mut(lo - x0..hi - x0) {
                            dst.fill(0);
                        }
                    } else if let Some(scores) = block_scores(&rows, xs) {
                        let (lo, hi) = (xs.max(x0), (xs + LANES).min(x1));
                        if let Some(dst) = out.get_mut(lo - x0..hi - x0) {
                            for (d, &s) in dst.iter_mut().zip(&scores[lo - xs..hi - xs]) {
                                *d = if s > t { s } else { 0 };
                            }
                        }
                    }
                    x = xs + LANES;
                }
            } else {
                for (k, d) in out.iter_mut().enumerate() {
                    let Some((cv, vals)) = circle(&rows, x0 + k) else {
                        continue;
                    };
                    let diff: [i16; 16] =
                        std::array::from_fn(|j| i16::from(vals[j]) - i16::from(cv));
                    let s = arc_score(&diff);
                    *d = if s > t { s } else { 0 };
                }
            }
        }
    }
}

/// Non-maximum suppression of one score row: `kept[i]` = `mid[b]` (`b = b0 + i`) when that
/// score is non-zero and beats its 8 neighbours in `up`, `mid`, `dn` (earlier ones in raster
/// order strictly, later ones or equal), else 0. Branch-free so it vectorises; the rows
/// carry a zero frame, so `b - 1` and `b + 1` are always inside.
#[inline(always)]
fn suppress_row(up: &[u8], mid: &[u8], dn: &[u8], b0: usize, kept: &mut [u8]) {
    let n = kept.len();
    let (Some(u), Some(m), Some(d)) = (
        up.get(b0 - 1..b0 + n + 1),
        mid.get(b0 - 1..b0 + n + 1),
        dn.get(b0 - 1..b0 + n + 1),
    ) else {
        return;
    };
    for i in 0..n {
        let s = m[i + 1];
        let keep = (s > u[i])
            & (s > u[i + 1])
            & (s > u[i + 2])
            & (s > m[i])
            & (s >= m[i + 2])
            & (s >= d[i])
            & (s >= d[i + 1])
            & (s >= d[i + 2]);
        kept[i] = if keep { s } else { 0 };
    }
}

/// A necessary condition for a corner at `t` among the [`LANES`] columns from `x`: an arc of
/// 9 holds two circle-adjacent compass pixels (0 and 4, 4 and 8, 8 and 12, or 12 and 0),
/// both brighter (darker) than the centre by more than `t`. A quarter of the work of
/// [`block_scores`], and false on most blocks of smooth image at any threshold.
#[inline(always)]
fn block_may_have_corner(rows: &[&[u8]; 7], x: usize, t: u8) -> bool {
    let lane = |r: usize, dx: isize| -> Option<&[u8; LANES]> {
        let start = (x as isize + dx) as usize;
        rows.get(r)?.get(start..start + LANES)?.try_into().ok()
    };
    let (Some(c), Some(p0), Some(p4), Some(p8), Some(p12)) =
        (lane(3, 0), lane(0, 0), lane(3, 3), lane(6, 0), lane(3, -3))
    else {
        // Let the full test decide (it refuses the same windows).
        return true;
    };
    let mut any = 0u8;
    for i in 0..LANES {
        let b = |v: u8| v.saturating_sub(c[i]);
        let d = |v: u8| c[i].saturating_sub(v);
        let (b0, b4, b8, b12) = (b(p0[i]), b(p4[i]), b(p8[i]), b(p12[i]));
        let (d0, d4, d8, d12) = (d(p0[i]), d(p4[i]), d(p8[i]), d(p12[i]));
        let m = b0
            .min(b4)
            .max(b4.min(b8))
            .max(b8.min(b12))
            .max(b12.min(b0))
            .max(d0.min(d4).max(d4.min(d8)).max(d8.min(d12)).max(d12.min(d0)));
        any |= u8::from(m > t);
    }
    any != 0
}

/// The FAST score ([`arc_score`]) of the [`LANES`] columns `x .. x + LANES` of the middle
/// row of `rows` (`y - 3 ..= y + 3`), all lanes at once on byte arrays so it vectorises:
/// the bright margins `m_k = (I_k - I_p)^+` and dark margins `(I_p - I_k)^+` (saturating),
/// their minima over the 16 circular windows of 9 built by doubling (2, 4, 8, then 9
/// wide), and the maximum over windows and both polarities. A pixel is a corner at `t`
/// exactly when its score is `> t`. `None` when the circle leaves the rows.
#[inline(always)]
fn block_scores(rows: &[&[u8]; 7], x: usize) -> Option<[u8; LANES]> {
    let lane = |r: usize, dx: i32| -> Option<[u8; LANES]> {
        let start = (x as isize + dx as isize) as usize;
        rows.get(r)?.get(start..start + LANES)?.try_into().ok()
    };
    let c = lane(3, 0)?;
    let mut bright = [[0u8; LANES]; 16];
    let mut dark = [[0u8; LANES]; 16];
    for (k, &(dx, dy)) in CIRCLE.iter().enumerate() {
        let v = lane((dy + 3) as usize, dx)?;
        for i in 0..LANES {
            bright[k][i] = v[i].saturating_sub(c[i]);
            dark[k][i] = c[i].saturating_sub(v[i]);
        }
    }
    let b = arc_min9_max(&bright);
    let d = arc_min9_max(&dark);
    let mut best = [0u8; LANES];
    for i in 0..LANES {
        best[i] = b[i].max(d[i]);
    }
    Some(best)
}

/// Lane-wise `max_k min_{j < 9} m[(k + j) mod 16]`: the best window of 9 contiguous circle
/// margins.
#[inline(always)]
fn arc_min9_max(m: &[[u8; LANES]; 16]) -> [u8; LANES] {
    let mut m2 = [[0u8; LANES]; 16];
    for k in 0..16 {
        for i in 0..LANES {
            m2[k][i] = m[k][i].min(m[(k + 1) & 15][i]);
        }
    }
    let mut m4 = [[0u8; LANES]; 16];
    for k in 0..16 {
        for i in 0..LANES {
            m4[k][i] = m2[k][i].min(m2[(k + 2) & 15][i]);
        }
    }
    let mut best = [0u8; LANES];
    for k in 0..16 {
        for i in 0..LANES {
            let m9 = m4[k][i].min(m4[(k + 4) & 15][i]).min(m[(k + 8) & 15][i]);
            best[i] = best[i].max(m9);
        }
    }
    best
}

/// The centre value and the 16 circle values of column `x`, from the seven rows
/// `y - 3 ..= y + 3`; `None` when the circle leaves the rows. Fixed-size windows keep the
/// gathers free of per-pixel bounds checks.
#[inline(always)]
fn circle(rows: &[&[u8]; 7], x: usize) -> Option<(u8, [u8; 16])> {
    let lo = x.checked_sub(3)?;
    let w0: [u8; 3] = rows[0].get(x - 1..x + 2)?.try_into().ok()?;
    let w1: [u8; 5] = rows[1].get(x - 2..x + 3)?.try_into().ok()?;
    let w2: [u8; 7] = rows[2].get(lo..x + 4)?.try_into().ok()?;
    let w3: [u8; 7] = rows[3].get(lo..x + 4)?.try_into().ok()?;
    let w4: [u8; 7] = rows[4].get(lo..x + 4)?.try_into().ok()?;
    let w5: [u8; 5] = rows[5].get(x - 2..x + 3)?.try_into().ok()?;
    let w6: [u8; 3] = rows[6].get(x - 1..x + 2)?.try_into().ok()?;
    Some((
        w3[3],
        [
            w0[1], w0[2], w1[4], w2[6], w3[6], w4[6], w5[4], w6[2], w6[1], w6[0], w5[0], w4[0],
            w3[0], w2[0], w1[0], w0[0],
        ],
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// True when the circular 16-bit mask has 9 contiguous set bits: the definition of the
    /// segment test, bit by bit, as the reference for the vector code.
    fn has_arc9(mask: u32) -> bool {
        (0..16).any(|k| (0..9).all(|j| mask >> ((k + j) % 16) & 1 == 1))
    }

    #[test]
    fn arc_detection() {
        assert!(has_arc9(0b1_1111_1111));
        assert!(!has_arc9(0b1111_1111));
        // wraps around: bits 12..15 and 0..4
        assert!(has_arc9(0b1111_0000_0001_1111));
        assert!(!has_arc9(0b0111_0000_0001_1111));
    }

    /// The scalar segment test of one column (Rosten & Drummond's definition).
    fn scalar_corner(rows: &[&[u8]; 7], x: usize, t: u8) -> bool {
        let Some((cv, vals)) = circle(rows, x) else {
            return false;
        };
        let (hi, lo) = (cv.saturating_add(t), cv.saturating_sub(t));
        let mask = |f: &dyn Fn(u8) -> bool| {
            vals.iter()
                .enumerate()
                .fold(0u32, |m, (k, &v)| m | (u32::from(f(v)) << k))
        };
        has_arc9(mask(&|v| v > hi)) || has_arc9(mask(&|v| v < lo))
    }

    #[test]
    fn block_scores_equal_scalar_scores_and_segment_test() {
        // Random rows with runs of extreme values (saturation at 0 and 255) and of a
        // constant, so both corners and near-corners occur.
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let (mut corners, mut tested) = (0, 0);
        for _ in 0..1000 {
            let data: Vec<Vec<u8>> = (0..7)
                .map(|_| {
                    let base = (next() % 256) as u8;
                    (0..LANES + 6)
                        .map(|_| match next() % 4 {
                            0 => 0,
                            1 => 255,
                            2 => base,
                            _ => (next() % 256) as u8,
                        })
                        .collect()
                })
                .collect();
            let rows: [&[u8]; 7] = std::array::from_fn(|k| data[k].as_slice());
            let Some(scores) = block_scores(&rows, 3) else {
                panic!("block inside the rows was rejected");
            };
            for (k, &score) in scores.iter().enumerate() {
                let Some((cv, vals)) = circle(&rows, 3 + k) else {
                    panic!("column {k} inside the rows was rejected");
                };
                let d: [i16; 16] = std::array::from_fn(|j| i16::from(vals[j]) - i16::from(cv));
                assert_eq!(score, arc_score(&d), "column {k}");
                for t in [1u8, 7, 20, 60] {
                    let want = scalar_corner(&rows, 3 + k, t);
                    assert_eq!(score > t, want, "column {k}, t = {t}");
                    corners += usize::from(want);
                    tested += 1;
                }
            }
        }
        assert!(
            corners * 100 > tested,
            "too few corners ({corners}) to test anything"
        );
        // Out of the rows: no answer rather than a wrong one.
        let short = [[0u8; LANES]; 7];
        let rows: [&[u8]; 7] = std::array::from_fn(|k| short[k].as_slice());
        assert_eq!(block_scores(&rows, 3), None);
    }

    /// The definition, pixel by pixel: scores by [`arc_score`], corners where `score > t`
    /// inside the clipped rect, suppression against the 8 neighbours' scores (0 where no
    /// corner), earlier neighbours strictly lower, later ones not higher.
    fn brute_force(img: &GrayView<'_>, rect: Rect, t: u8, nonmax: bool) -> Vec<Corner> {
        let (w, h) = (img.width(), img.height());
        let r = FAST_RADIUS;
        let score = |x: usize, y: usize| -> u8 {
            if x < r || y < r || x + r >= w || y + r >= h {
                return 0;
            }
            let rows: [&[u8]; 7] = std::array::from_fn(|k| img.row(y + k - 3).unwrap_or(&[]));
            let Some((cv, vals)) = circle(&rows, x) else {
                return 0;
            };
            let d: [i16; 16] = std::array::from_fn(|j| i16::from(vals[j]) - i16::from(cv));
            let s = arc_score(&d);
            if s > t { s } else { 0 }
        };
        let mut out = Vec::new();
        for y in rect.y0.max(r)..rect.y1.min(h.saturating_sub(r)) {
            for x in rect.x0.max(r)..rect.x1.min(w.saturating_sub(r)) {
                let s = score(x, y);
                if s == 0 {
                    continue;
                }
                let keep = !nonmax
                    || (s > score(x - 1, y - 1)
                        && s > score(x, y - 1)
                        && s > score(x + 1, y - 1)
                        && s > score(x - 1, y)
                        && s >= score(x + 1, y)
                        && s >= score(x - 1, y + 1)
                        && s >= score(x, y + 1)
                        && s >= score(x + 1, y + 1));
                if keep {
                    out.push(Corner {
                        x: x as u32,
                        y: y as u32,
                        score: s,
                    });
                }
            }
        }
        out
    }

    #[test]
    fn detect_equals_the_definition() {
        use simd::{Level, with_max_level};
        // Odd sizes (narrower than a vector block too), rects at the border, inside, small.
        for (w, h, seed) in [
            (157usize, 61usize, 3u64),
            (64, 40, 5),
            (40, 30, 7),
            (301, 45, 9),
        ] {
            let img = crate::features::synth::textured_image(w, h, seed);
            let view = img.view();
            let rects = [
                Rect {
                    x0: 0,
                    y0: 0,
                    x1: w,
                    y1: h,
                },
                Rect {
                    x0: 19,
                    y0: 19,
                    x1: w - 19,
                    y1: h - 19,
                },
                Rect {
                    x0: 5,
                    y0: 4,
                    x1: 35,
                    y1: 26,
                },
                Rect {
                    x0: w - 10,
                    y0: 2,
                    x1: w,
                    y1: h,
                },
            ];
            let mut det = FastDetector::new();
            for rect in rects {
                for (t, nonmax) in [(7u8, true), (20, true), (7, false), (1, true)] {
                    let want = brute_force(&view, rect, t, nonmax);
                    for level in [Level::Baseline, Level::Avx512] {
                        let mut got = Vec::new();
                        with_max_level(level, || {
                            det.detect(&view, rect, t, nonmax, &mut got);
                        });
                        assert_eq!(
                            got, want,
                            "{w}x{h} {rect:?} t={t} nonmax={nonmax} {level:?}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn score_is_the_largest_margin() {
        let mut d = [0i16; 16];
        for (k, v) in d.iter_mut().enumerate().take(9) {
            *v = 30 + k as i16;
        }
        assert_eq!(arc_score(&d), 30);
    }
}
