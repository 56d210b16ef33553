//! FAST-9 corner detection (Rosten & Drummond, "Machine learning for high-speed corner
//! detection", ECCV 2006).
//!
//! A pixel `p` with intensity `I_p` is a corner at threshold `t` when 9 contiguous pixels of
//! the 16-pixel Bresenham circle of radius 3 are all brighter than `I_p + t` or all darker
//! than `I_p - t`. Any arc of 9 contains one pixel of each opposite pair `{i, i + 8}`, so a
//! pixel lacking a bright (dark) pixel in any of the 8 pairs is rejected early; that test
//! runs over whole rows and vectorises. Blocks of 16 columns holding a survivor then get
//! the exact test for all 16 columns at once (byte lanes), and only corners are scored.
//! The corner score is the largest
//! margin that still makes `p` a corner:
//! `score = max over arcs A of min_{i in A} |I_i - I_p|` (bright arcs with `I_i - I_p`, dark
//! with `I_p - I_i`), so `p` is a corner at every `t < score`. Non-maximum suppression keeps
//! a corner whose score beats its 8 neighbours (ties: the earlier one in raster order wins).

use super::gray::GrayView;
use super::simd;

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

/// [`FastDetector::scan`] as a [`simd::Kernel`].
struct Scan<'a, 'b> {
    det: &'a mut FastDetector,
    img: &'a GrayView<'b>,
    x0: usize,
    x1: usize,
    y0: usize,
    y1: usize,
    t: u8,
}

impl simd::Kernel for Scan<'_, '_> {
    type Output = ();
    #[inline(always)]
    fn run(self) {
        let Self {
            det,
            img,
            x0,
            x1,
            y0,
            y1,
            t,
        } = self;
        det.scan_rows(img, x0, x1, y0, y1, t);
    }
}

/// True when the circular 16-bit mask has 9 contiguous set bits.
#[inline(always)]
fn has_arc9(mask: u32) -> bool {
    let m = mask | (mask << 16);
    let r = m & (m >> 1); // runs of 2
    let r = r & (r >> 2); // runs of 4
    let r = r & (r >> 4); // runs of 8
    let r = r & (m >> 8); // runs of 9
    r & 0xFFFF != 0
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
    /// Score image of the last call (zero except transiently at corners).
    scores: Vec<u8>,
    scores_w: usize,
    /// Early-test result for one row.
    cand: Vec<u8>,
    /// Corners before non-maximum suppression.
    raw: Vec<Corner>,
}

impl FastDetector {
    /// A detector with empty buffers.
    pub fn new() -> Self {
        Self::default()
    }

    /// Appends to `out` the FAST-9 corners at `threshold` whose centre lies in `rect`
    /// (clipped so the circle stays inside the image), in raster order; with `nonmax`,
    /// only local maxima of the score (over the 8-neighbourhood, neighbours outside `rect`
    /// included) are kept.
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
        self.raw.clear();
        // Scan a one-pixel margin too, so suppression sees neighbours outside the rect.
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
        self.scan(img, sx0, sx1, sy0, sy1, threshold);
        if !nonmax {
            out.extend(self.raw.iter().copied());
            return;
        }
        if self.scores.len() != w * h || self.scores_w != w {
            self.scores.clear();
            self.scores.resize(w * h, 0);
            self.scores_w = w;
        }
        for c in &self.raw {
            self.scores[c.y as usize * w + c.x as usize] = c.score;
        }
        for c in &self.raw {
            let (x, y) = (c.x as usize, c.y as usize);
            if x < x0 || x >= x1 || y < y0 || y >= y1 {
                continue;
            }
            let s = c.score;
            let at = |xx: usize, yy: usize| self.scores[yy * w + xx];
            // Earlier neighbours (raster order) must be strictly lower, later ones not higher.
            let keep = s > at(x - 1, y - 1)
                && s > at(x, y - 1)
                && s > at(x + 1, y - 1)
                && s > at(x - 1, y)
                && s >= at(x + 1, y)
                && s >= at(x - 1, y + 1)
                && s >= at(x, y + 1)
                && s >= at(x + 1, y + 1);
            if keep {
                out.push(*c);
            }
        }
        for c in &self.raw {
            self.scores[c.y as usize * w + c.x as usize] = 0;
        }
    }

    /// Collects all corners (no suppression) with centres in `[x0,x1) x [y0,y1)` into `raw`,
    /// at the CPU's best vector level ([`super::simd`]; the same corners on every level).
    /// The caller guarantees the circle stays inside the image.
    fn scan(&mut self, img: &GrayView<'_>, x0: usize, x1: usize, y0: usize, y1: usize, t: u8) {
        simd::dispatch(Scan {
            det: self,
            img,
            x0,
            x1,
            y0,
            y1,
            t,
        });
    }

    /// The body of [`Self::scan`], inlined into the dispatched function.
    #[inline(always)]
    fn scan_rows(&mut self, img: &GrayView<'_>, x0: usize, x1: usize, y0: usize, y1: usize, t: u8) {
        let n = x1 - x0;
        self.cand.clear();
        self.cand.resize(n, 0);
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
            {
                // Necessary condition on the eight opposite pairs of the circle: any arc
                // of 9 holds one pixel of each pair (i, i + 8), so a corner has a bright
                // (dark) pixel in every pair. Branch-free over whole rows so it vectorises
                // (16 pixels per SSE register).
                let c = &row[x0..x0 + n];
                let p0 = &up[x0..x0 + n];
                let p8 = &dn[x0..x0 + n];
                let p4 = &row[x0 + 3..x0 + 3 + n];
                let p12 = &row[x0 - 3..x0 - 3 + n];
                let p2 = &r1[x0 + 2..x0 + 2 + n];
                let p10 = &r5[x0 - 2..x0 - 2 + n];
                let p6 = &r5[x0 + 2..x0 + 2 + n];
                let p14 = &r1[x0 - 2..x0 - 2 + n];
                let p1 = &up[x0 + 1..x0 + 1 + n];
                let p9 = &dn[x0 - 1..x0 - 1 + n];
                let p3 = &r2[x0 + 3..x0 + 3 + n];
                let p11 = &r4[x0 - 3..x0 - 3 + n];
                let p5 = &r4[x0 + 3..x0 + 3 + n];
                let p13 = &r2[x0 - 3..x0 - 3 + n];
                let p7 = &dn[x0 + 1..x0 + 1 + n];
                let p15 = &up[x0 - 1..x0 - 1 + n];
                let cand = &mut self.cand[..n];
                for i in 0..n {
                    let hi = c[i].saturating_add(t);
                    let lo = c[i].saturating_sub(t);
                    let b = |v: u8| u8::from(v > hi);
                    let d = |v: u8| u8::from(v < lo);
                    let bright = (b(p0[i]) | b(p8[i]))
                        & (b(p4[i]) | b(p12[i]))
                        & (b(p2[i]) | b(p10[i]))
                        & (b(p6[i]) | b(p14[i]))
                        & (b(p1[i]) | b(p9[i]))
                        & (b(p3[i]) | b(p11[i]))
                        & (b(p5[i]) | b(p13[i]))
                        & (b(p7[i]) | b(p15[i]));
                    let dark = (d(p0[i]) | d(p8[i]))
                        & (d(p4[i]) | d(p12[i]))
                        & (d(p2[i]) | d(p10[i]))
                        & (d(p6[i]) | d(p14[i]))
                        & (d(p1[i]) | d(p9[i]))
                        & (d(p3[i]) | d(p11[i]))
                        & (d(p5[i]) | d(p13[i]))
                        & (d(p7[i]) | d(p15[i]));
                    cand[i] = bright | dark;
                }
            }
            let rows = [up, r1, r2, row, r4, r5, dn];
            // Blocks of 16 columns holding a candidate get the full segment test for all
            // 16 at once (lane-wise, vectorised); only corners reach the scalar scoring.
            let full = n / 16 * 16;
            for bx in (0..full).step_by(16) {
                let Some(block) = self.cand.get(bx..bx + 16) else {
                    continue;
                };
                if block.iter().all(|&c| c == 0) {
                    continue;
                }
                let x = x0 + bx;
                let Some(mask) = block_corners(&rows, x, t) else {
                    continue;
                };
                let mut m = mask;
                while m != 0 {
                    let k = m.trailing_zeros() as usize;
                    m &= m - 1;
                    let Some((cv, vals)) = circle(&rows, x + k) else {
                        continue;
                    };
                    let d: [i16; 16] = std::array::from_fn(|j| i16::from(vals[j]) - i16::from(cv));
                    self.raw.push(Corner {
                        x: (x + k) as u32,
                        y: y as u32,
                        score: arc_score(&d),
                    });
                }
            }
            // The remaining columns, candidate by candidate; whole zero words are skipped.
            for (ci, chunk) in self.cand[full..n].chunks(8).enumerate() {
                let mut word = match <[u8; 8]>::try_from(chunk) {
                    Ok(b) => u64::from_le_bytes(b),
                    Err(_) => chunk
                        .iter()
                        .enumerate()
                        .fold(0u64, |w, (k, &b)| w | (u64::from(b) << (8 * k))),
                };
                while word != 0 {
                    let k = (word.trailing_zeros() / 8) as usize;
                    word &= !(0xFFu64 << (8 * k));
                    let x = x0 + full + ci * 8 + k;
                    let Some((cv, vals)) = circle(&rows, x) else {
                        continue;
                    };
                    let hi = cv.saturating_add(t);
                    let lo = cv.saturating_sub(t);
                    let bmask = pack16(&vals.map(|v| u8::from(v > hi)));
                    let dmask = pack16(&vals.map(|v| u8::from(v < lo)));
                    if has_arc9(bmask) || has_arc9(dmask) {
                        let d: [i16; 16] =
                            std::array::from_fn(|k| i16::from(vals[k]) - i16::from(cv));
                        self.raw.push(Corner {
                            x: x as u32,
                            y: y as u32,
                            score: arc_score(&d),
                        });
                    }
                }
            }
        }
    }
}

/// The FAST-9 segment test at threshold `t` for the 16 columns `x .. x + 16` of the
/// middle row of `rows` (`y - 3 ..= y + 3`): bit `k` of the result is set when column `x + k`
/// is a corner. All 16 columns are tested together on byte arrays (16 lanes), so the
/// comparisons and the arc search (windowed ANDs of width 2, 4, 8, then 9 over the circle)
/// vectorise. `None` when the circle leaves the rows.
#[inline(always)]
fn block_corners(rows: &[&[u8]; 7], x: usize, t: u8) -> Option<u32> {
    let lane = |r: usize, dx: i32| -> Option<[u8; 16]> {
        let start = (x as isize + dx as isize) as usize;
        rows.get(r)?.get(start..start + 16)?.try_into().ok()
    };
    let c = lane(3, 0)?;
    let mut vals = [[0u8; 16]; 16];
    for (v, &(dx, dy)) in vals.iter_mut().zip(CIRCLE.iter()) {
        *v = lane((dy + 3) as usize, dx)?;
    }
    let mut bright = [[0u8; 16]; 16];
    let mut dark = [[0u8; 16]; 16];
    for k in 0..16 {
        for i in 0..16 {
            let (v, p) = (vals[k][i], c[i]);
            bright[k][i] = u8::from(v > p.saturating_add(t));
            dark[k][i] = u8::from(v < p.saturating_sub(t));
        }
    }
    let (b, d) = (arcs9(&bright), arcs9(&dark));
    let mut mask = 0u32;
    for i in 0..16 {
        mask |= u32::from(b[i] | d[i]) << i;
    }
    Some(mask)
}

/// Lane-wise: 1 where the 16 circle flags `m[k][lane]` hold 9 contiguous ones.
#[inline(always)]
fn arcs9(m: &[[u8; 16]; 16]) -> [u8; 16] {
    let mut r2 = [[0u8; 16]; 16];
    for k in 0..16 {
        for i in 0..16 {
            r2[k][i] = m[k][i] & m[(k + 1) & 15][i];
        }
    }
    let mut r4 = [[0u8; 16]; 16];
    for k in 0..16 {
        for i in 0..16 {
            r4[k][i] = r2[k][i] & r2[(k + 2) & 15][i];
        }
    }
    let mut any = [0u8; 16];
    for k in 0..16 {
        for i in 0..16 {
            any[i] |= r4[k][i] & r4[(k + 4) & 15][i] & m[(k + 8) & 15][i];
        }
    }
    any
}

/// Packs 16 bytes of 0/1 into a 16-bit mask (byte `k` -> bit `k`): per 8 bytes,
/// `(x * 0x0102040810204080) >> 56` sums `b_i 2^i` into the top byte without carries.
#[inline(always)]
fn pack16(b: &[u8; 16]) -> u32 {
    const MAGIC: u64 = 0x0102_0408_1020_4080;
    let lo = u64::from_le_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]]);
    let hi = u64::from_le_bytes([b[8], b[9], b[10], b[11], b[12], b[13], b[14], b[15]]);
    ((lo.wrapping_mul(MAGIC) >> 56) | ((hi.wrapping_mul(MAGIC) >> 56) << 8)) as u32
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

    #[test]
    fn pack16_maps_bytes_to_bits() {
        let mut b = [0u8; 16];
        assert_eq!(pack16(&b), 0);
        b[0] = 1;
        b[9] = 1;
        b[15] = 1;
        assert_eq!(pack16(&b), 1 | (1 << 9) | (1 << 15));
        assert_eq!(pack16(&[1; 16]), 0xFFFF);
    }

    #[test]
    fn arc_detection() {
        assert!(has_arc9(0b1_1111_1111));
        assert!(!has_arc9(0b1111_1111));
        // wraps around: bits 12..15 and 0..4
        assert!(has_arc9(0b1111_0000_0001_1111));
        assert!(!has_arc9(0b0111_0000_0001_1111));
    }

    /// The scalar segment test of one column, for comparison with [`block_corners`].
    fn scalar_corner(rows: &[&[u8]; 7], x: usize, t: u8) -> bool {
        let Some((cv, vals)) = circle(rows, x) else {
            return false;
        };
        let (hi, lo) = (cv.saturating_add(t), cv.saturating_sub(t));
        has_arc9(pack16(&vals.map(|v| u8::from(v > hi))))
            || has_arc9(pack16(&vals.map(|v| u8::from(v < lo))))
    }

    #[test]
    fn block_test_equals_scalar_test() {
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
        for _ in 0..3000 {
            let data: Vec<Vec<u8>> = (0..7)
                .map(|_| {
                    let base = (next() % 256) as u8;
                    (0..22)
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
            for t in [1u8, 7, 20, 60] {
                let Some(mask) = block_corners(&rows, 3, t) else {
                    panic!("block inside the rows was rejected");
                };
                for k in 0..16 {
                    let want = scalar_corner(&rows, 3 + k, t);
                    assert_eq!(mask >> k & 1 == 1, want, "column {k}, t = {t}");
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
        let short = [[0u8; 10]; 7];
        let rows: [&[u8]; 7] = std::array::from_fn(|k| short[k].as_slice());
        assert_eq!(block_corners(&rows, 3, 7), None);
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
