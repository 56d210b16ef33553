//! Gray image views, owned gray buffers, the image pyramid and the smoothing used by ORB.
//!
//! Images are 8-bit, row-major, with a row `stride >= width` (so sub-views and padded
//! buffers need no copy). All loops run over whole rows (`chunks`/`zip`) so the compiler
//! can vectorise them; nothing allocates per pixel.

use super::FeatureError;
use std::num::Wrapping;

/// A borrowed 8-bit gray image: `data[y * stride + x]` is the pixel in column `x`, row `y`.
#[derive(Clone, Copy, Debug)]
pub struct GrayView<'a> {
    data: &'a [u8],
    width: usize,
    height: usize,
    stride: usize,
}

impl<'a> GrayView<'a> {
    /// A view of a tightly packed image (`stride == width`).
    ///
    /// # Errors
    /// [`FeatureError::BufferTooShort`] when `data` holds fewer than `width * height` bytes.
    pub fn new(data: &'a [u8], width: usize, height: usize) -> Result<Self, FeatureError> {
        Self::with_stride(data, width, height, width)
    }

    /// A view with an explicit row stride (bytes from one row start to the next).
    ///
    /// # Errors
    /// [`FeatureError::BadStride`] when `stride < width`, [`FeatureError::BufferTooShort`]
    /// when `data` ends before the last pixel.
    pub fn with_stride(
        data: &'a [u8],
        width: usize,
        height: usize,
        stride: usize,
    ) -> Result<Self, FeatureError> {
        if stride < width {
            return Err(FeatureError::BadStride { width, stride });
        }
        let needed = if height == 0 {
            0
        } else {
            (height - 1) * stride + width
        };
        if data.len() < needed {
            return Err(FeatureError::BufferTooShort {
                len: data.len(),
                needed,
            });
        }
        Ok(Self {
            data,
            width,
            height,
            stride,
        })
    }

    /// A view of an `image` crate gray image.
    pub fn from_image(img: &'a image::GrayImage) -> Self {
        let (w, h) = img.dimensions();
        Self {
            data: img.as_raw(),
            width: w as usize,
            height: h as usize,
            stride: w as usize,
        }
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Bytes from one row start to the next.
    pub fn stride(&self) -> usize {
        self.stride
    }

    /// The underlying bytes (rows `stride` apart).
    pub fn data(&self) -> &'a [u8] {
        self.data
    }

    /// Row `y` (exactly `width` pixels), or `None` outside the image.
    pub fn row(&self, y: usize) -> Option<&'a [u8]> {
        if y >= self.height {
            return None;
        }
        self.data.get(y * self.stride..y * self.stride + self.width)
    }

    /// Pixel `(x, y)`, or `None` outside the image.
    pub fn get(&self, x: usize, y: usize) -> Option<u8> {
        if x >= self.width || y >= self.height {
            return None;
        }
        self.data.get(y * self.stride + x).copied()
    }
}

/// An owned, tightly packed 8-bit gray image (reused between frames by [`super::OrbExtractor`]).
#[derive(Clone, Debug, Default)]
pub struct GrayBuf {
    /// Pixels, row-major, `width * height` bytes.
    pub data: Vec<u8>,
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
}

impl GrayBuf {
    /// Resizes the buffer (keeping its allocation when large enough); contents unspecified.
    pub fn reshape(&mut self, width: usize, height: usize) {
        self.width = width;
        self.height = height;
        self.data.resize(width * height, 0);
    }

    /// Copies a view into this buffer.
    pub fn copy_from(&mut self, src: &GrayView<'_>) {
        self.reshape(src.width, src.height);
        for (y, dst) in self.data.chunks_exact_mut(src.width.max(1)).enumerate() {
            if let Some(row) = src.row(y) {
                dst.copy_from_slice(row);
            }
        }
    }

    /// A view of this buffer.
    pub fn view(&self) -> GrayView<'_> {
        GrayView {
            data: &self.data,
            width: self.width,
            height: self.height,
            stride: self.width,
        }
    }
}

/// Converts 8-bit RGB to gray with the ITU-R BT.601 weights OpenCV's `cvtColor` uses,
/// `Y = (4899 R + 9617 G + 1868 B + 2^13) >> 14` (0.299, 0.587, 0.114 in 14-bit fixed point),
/// so rodlog and the OpenCV reference see the same pixels.
pub fn rgb_to_gray(rgb: &image::RgbImage) -> image::GrayImage {
    let (w, h) = rgb.dimensions();
    let data: Vec<u8> = rgb
        .as_raw()
        .chunks_exact(3)
        .map(|p| {
            let y = 4899 * u32::from(p[0]) + 9617 * u32::from(p[1]) + 1868 * u32::from(p[2]);
            ((y + 8192) >> 14) as u8
        })
        .collect();
    image::GrayImage::from_raw(w, h, data).unwrap_or_else(|| image::GrayImage::new(w, h))
}

/// Scratch buffers of [`resize_bilinear`] (kept between calls to avoid allocation).
#[derive(Clone, Debug, Default)]
pub struct ResizeScratch {
    xtab: Vec<(u32, u16)>,
    blocks: Vec<HBlock>,
    h0: Vec<u16>,
    h1: Vec<u16>,
}

/// Destination pixels per vector block of the horizontal pass.
const HBLOCK: usize = 64;

/// The horizontal pass of [`HBLOCK`] destination pixels `x0 .. x0 + 64` as a byte shuffle:
/// source bytes `base + idx[k]` and `base + idx[k] + 1` with weight `w[k]` of the second.
/// Usable when the 128 source bytes from `base` are in the row (`idx[k] + 1 < 128`).
#[derive(Clone, Copy, Debug)]
struct HBlock {
    base: usize,
    idx: [u8; HBLOCK],
    w: [u8; HBLOCK],
    usable: bool,
}

/// The blocks of a destination row of `xtab.len()` pixels from a source row of `sw`.
fn hblocks(xtab: &[(u32, u16)], sw: usize, out: &mut Vec<HBlock>) {
    out.clear();
    for chunk in xtab.chunks_exact(HBLOCK) {
        let base = chunk[0].0 as usize;
        let mut blk = HBlock {
            base,
            idx: [0; HBLOCK],
            w: [0; HBLOCK],
            usable: base + 2 * HBLOCK <= sw,
        };
        for (k, &(i, f)) in chunk.iter().enumerate() {
            let rel = (i as usize).wrapping_sub(base);
            blk.usable &= rel < 2 * HBLOCK - 1;
            blk.idx[k] = rel as u8;
            blk.w[k] = f as u8;
        }
        out.push(blk);
    }
}

/// One source row through the horizontal pass: `out[x] = (128 - f) p_i + f p_{i+1}` for
/// `(i, f) = xtab[x]`, with AVX-512 VBMI byte shuffles on the usable [`HBlock`]s when `vbmi`
/// (the caller's [`simd::vbmi_allowed`], checked once per image), scalar elsewhere; both
/// give the same integers.
fn hrow(row: &[u8], xtab: &[(u32, u16)], blocks: &[HBlock], vbmi: bool, out: &mut [u16]) {
    let vector_done = cfg!(target_arch = "x86_64") && vbmi;
    #[cfg(target_arch = "x86_64")]
    if vector_done {
        // SAFETY: the CPU has the features (vbmi_allowed checked them at run time).
        #[allow(unsafe_code)]
        unsafe {
            hrow_vbmi(row, blocks, out);
        }
    }
    for (c, (o, t)) in out.chunks_mut(HBLOCK).zip(xtab.chunks(HBLOCK)).enumerate() {
        if vector_done && blocks.get(c).is_some_and(|b| b.usable) {
            continue;
        }
        for (o, &(i, f)) in o.iter_mut().zip(t) {
            let i = i as usize;
            let (a, b) = match row.get(i..i + 2) {
                Some(p) => (u16::from(p[0]), u16::from(p[1])),
                None => (0, 0),
            };
            *o = a * (RESIZE_ONE as u16 - f) + b * f;
        }
    }
}

/// The usable blocks of [`hrow`]; unusable ones are left to the scalar loop.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw,avx512vbmi")]
#[allow(unsafe_code)]
fn hrow_vbmi(row: &[u8], blocks: &[HBlock], out: &mut [u16]) {
    use std::arch::x86_64::*;
    let one = _mm512_set1_epi8(1);
    let full = _mm512_set1_epi16(RESIZE_ONE as i16);
    for (b, blk) in blocks.iter().enumerate() {
        let (Some(src), Some(dst)) = (
            row.get(blk.base..blk.base + 2 * HBLOCK),
            out.get_mut(b * HBLOCK..(b + 1) * HBLOCK),
        ) else {
            continue;
        };
        if !blk.usable {
            continue;
        }
        // SAFETY: `src` holds 128 bytes, `blk.idx`/`blk.w` 64, `dst` 64 u16 (128 bytes):
        // every unaligned load and store below stays inside them.
        unsafe {
            let lo = _mm512_loadu_si512(src.as_ptr().cast());
            let hi = _mm512_loadu_si512(src.as_ptr().add(HBLOCK).cast());
            let idx = _mm512_loadu_si512(blk.idx.as_ptr().cast());
            let w = _mm512_loadu_si512(blk.w.as_ptr().cast());
            let p0 = _mm512_permutex2var_epi8(lo, idx, hi);
            let p1 = _mm512_permutex2var_epi8(lo, _mm512_add_epi8(idx, one), hi);
            let halves = [
                (
                    _mm512_castsi512_si256(p0),
                    _mm512_castsi512_si256(p1),
                    _mm512_castsi512_si256(w),
                ),
                (
                    _mm512_extracti64x4_epi64::<1>(p0),
                    _mm512_extracti64x4_epi64::<1>(p1),
                    _mm512_extracti64x4_epi64::<1>(w),
                ),
            ];
            for (h, (a, c, f)) in halves.into_iter().enumerate() {
                let (a, c, f) = (
                    _mm512_cvtepu8_epi16(a),
                    _mm512_cvtepu8_epi16(c),
                    _mm512_cvtepu8_epi16(f),
                );
                let r = _mm512_add_epi16(
                    _mm512_mullo_epi16(a, _mm512_sub_epi16(full, f)),
                    _mm512_mullo_epi16(c, f),
                );
                _mm512_storeu_si512(dst.as_mut_ptr().add(h * 32).cast(), r);
            }
        }
    }
}

/// Fixed-point bilinear weights: 7 bits per axis (sum 128).
const RESIZE_ONE: u32 = 128;

/// Source index `i` (with `i + 1` valid) and weight of `i + 1` for destination index `x`,
/// `u = (x + 0.5) s - 0.5` clamped to `[0, n - 1]`.
fn resize_tab(x: usize, s: f64, n: usize) -> (u32, u16) {
    let u = ((x as f64 + 0.5) * s - 0.5).clamp(0.0, (n - 1) as f64);
    let i = (u.floor() as usize).min(n.saturating_sub(2));
    let f = (u - i as f64).clamp(0.0, 1.0);
    (i as u32, (f * f64::from(RESIZE_ONE)).round() as u16)
}

/// Bilinear resize of `src` into `dst` (`dst.width`, `dst.height` already set), with the
/// pixel-centre convention of OpenCV's `INTER_LINEAR`: source coordinate
/// `u = (x + 0.5) * sx - 0.5`, clamped to the image, `sx = src.width / dst.width`.
/// Separable in 7-bit fixed point: each source row is interpolated horizontally once
/// (`h = (128 - f) p_i + f p_{i+1}`, cached for the next output row), then rows are
/// blended vertically, `out = ((128 - g) h_j + g h_{j+1} + 2^13) >> 14`.
/// Sources narrower or shorter than 2 pixels are not resized (`dst` is left as is).
pub fn resize_bilinear(src: &GrayView<'_>, dst: &mut GrayBuf, scratch: &mut ResizeScratch) {
    simd::dispatch(Resize { src, dst, scratch });
}

/// [`resize_bilinear`] as a [`simd::Kernel`].
struct Resize<'a, 'b> {
    src: &'a GrayView<'b>,
    dst: &'a mut GrayBuf,
    scratch: &'a mut ResizeScratch,
}

impl simd::Kernel for Resize<'_, '_> {
    type Output = ();
    #[inline(always)]
    fn run(self) {
        resize_bilinear_rows(self.src, self.dst, self.scratch);
    }
}

/// The body of [`resize_bilinear`], inlined into the dispatched function ([`super::simd`]).
#[inline(always)]
fn resize_bilinear_rows(src: &GrayView<'_>, dst: &mut GrayBuf, scratch: &mut ResizeScratch) {
    let (sw, sh, dw, dh) = (src.width, src.height, dst.width, dst.height);
    if sw < 2 || sh < 2 || dw == 0 || dh == 0 {
        return;
    }
    let sx = sw as f64 / dw as f64;
    let sy = sh as f64 / dh as f64;
    scratch.xtab.clear();
    scratch.xtab.extend((0..dw).map(|x| resize_tab(x, sx, sw)));
    scratch.h0.resize(dw, 0);
    scratch.h1.resize(dw, 0);
    let vbmi = simd::vbmi_allowed();
    if vbmi {
        hblocks(&scratch.xtab, sw, &mut scratch.blocks);
    } else {
        scratch.blocks.clear();
    }
    // Source rows currently held in h0 / h1.
    let mut held: (usize, usize) = (usize::MAX, usize::MAX);
    for (y, out) in dst.data.chunks_exact_mut(dw).enumerate() {
        let (iy, fy) = resize_tab(y, sy, sh);
        let iy = iy as usize;
        if held != (iy, iy + 1) {
            if held.1 == iy {
                std::mem::swap(&mut scratch.h0, &mut scratch.h1);
            } else if let Some(r) = src.row(iy) {
                hrow(r, &scratch.xtab, &scratch.blocks, vbmi, &mut scratch.h0);
            }
            if let Some(r) = src.row(iy + 1) {
                hrow(r, &scratch.xtab, &scratch.blocks, vbmi, &mut scratch.h1);
            }
            held = (iy, iy + 1);
        }
        let (g1, g0) = (u32::from(fy), RESIZE_ONE - u32::from(fy));
        for ((o, &a), &b) in out.iter_mut().zip(scratch.h0.iter()).zip(scratch.h1.iter()) {
            *o = ((u32::from(a) * g0 + u32::from(b) * g1 + (1 << 13)) >> 14) as u8;
        }
    }
}

/// Integer 7-tap Gaussian (sigma = 2) weights, summing to 256: `round(256 g(k) / sum g)`,
/// `g(k) = exp(-k^2 / 8)`, k = -3..3, adjusted so the sum is exactly 256. ORB's rBRIEF
/// compares smoothed intensities (Rublee et al., ICCV 2011, section 4; OpenCV smooths with
/// a 7x7, sigma 2 Gaussian); integer weights keep the result exact and fast. The exact
/// weights are 17.96, 33.56, 48.82, 55.32; the centre is rounded down to make the sum 256.
/// Its 7-pixel support approximates the 5x5 sub-window means of the ORB paper's tests.
pub const GAUSS7: [u16; 7] = [18, 34, 49, 54, 49, 34, 18];

/// Scratch rows of [`gaussian_blur7`].
#[derive(Clone, Debug, Default)]
pub struct BlurScratch {
    mid: Vec<u16>,
}

/// Separable 7x7 Gaussian smoothing ([`GAUSS7`]) with replicated borders, `src` -> `dst`.
/// Vertical pass `v = (sum_k w_k p_{y+k} + 128) >> 8`, then horizontal
/// `out = (sum_k w_k v_{x+k} + 128) >> 8`; every intermediate fits in u16, and each pass
/// runs over whole rows, so both vectorise (8 lanes per SSE register).
pub fn gaussian_blur7(src: &GrayView<'_>, dst: &mut GrayBuf, scratch: &mut BlurScratch) {
    simd::dispatch(Blur { src, dst, scratch });
}

/// [`gaussian_blur7`] as a [`simd::Kernel`].
struct Blur<'a, 'b> {
    src: &'a GrayView<'b>,
    dst: &'a mut GrayBuf,
    scratch: &'a mut BlurScratch,
}

impl simd::Kernel for Blur<'_, '_> {
    type Output = ();
    #[inline(always)]
    fn run(self) {
        gaussian_blur7_rows(self.src, self.dst, self.scratch);
    }
}

/// The body of [`gaussian_blur7`], inlined into the dispatched function ([`super::simd`]).
#[inline(always)]
fn gaussian_blur7_rows(src: &GrayView<'_>, dst: &mut GrayBuf, scratch: &mut BlurScratch) {
    let (w, h) = (src.width, src.height);
    dst.reshape(w, h);
    if w == 0 || h == 0 {
        return;
    }
    let BlurScratch { mid } = scratch;
    mid.clear();
    mid.resize(w + 6, 0);
    for (y, out) in dst.data.chunks_exact_mut(w).enumerate() {
        let rows: [&[u8]; 7] = std::array::from_fn(|k| {
            let yy = (y as isize + k as isize - 3).clamp(0, h as isize - 1) as usize;
            src.row(yy).unwrap_or(&[])
        });
        // Vertical pass into mid, one fused pass over the seven rows; the kernel is
        // symmetric, so mirrored taps are added before the multiply.
        let (Some(r0), Some(r1), Some(r2), Some(r3), Some(r4), Some(r5), Some(r6)) = (
            rows[0].get(..w),
            rows[1].get(..w),
            rows[2].get(..w),
            rows[3].get(..w),
            rows[4].get(..w),
            rows[5].get(..w),
            rows[6].get(..w),
        ) else {
            continue;
        };
        let [g0, g1, g2, g3, ..] = GAUSS7;
        // Written out in the loop: a closure over the seven rows was not inlined, so it ran
        // once per pixel without the dispatched function's target features. Wrapping
        // arithmetic: the sums fit in u16 (the weights sum to 256, so at most
        // 255 * 256 + 128), and overflow checks, on in test builds, stop the loop from
        // vectorising.
        let w16 = Wrapping;
        let (g0, g1, g2, g3) = (w16(g0), w16(g1), w16(g2), w16(g3));
        let px = |r: &[u8], i: usize| w16(u16::from(r[i]));
        for (i, m) in mid[3..w + 3].iter_mut().enumerate() {
            let v = g0 * (px(r0, i) + px(r6, i))
                + g1 * (px(r1, i) + px(r5, i))
                + g2 * (px(r2, i) + px(r4, i))
                + g3 * px(r3, i);
            *m = ((v + w16(128)) >> 8).0;
        }
        let (first, last) = (mid[3], mid[w + 2]);
        mid[..3].fill(first);
        mid[w + 3..].fill(last);
        // Horizontal pass, fused the same way over seven shifted views of mid.
        // Every view cut to the same length, so the loop has no bounds checks and vectorises.
        let n = out.len().min(mid.len().saturating_sub(6));
        let m: [&[u16]; 7] = std::array::from_fn(|k| &mid[k..k + n]);
        let [m0, m1, m2, m3, m4, m5, m6] = m;
        let at = |m: &[u16], i: usize| w16(m[i]);
        for (i, o) in out[..n].iter_mut().enumerate() {
            let h = g0 * (at(m0, i) + at(m6, i))
                + g1 * (at(m1, i) + at(m5, i))
                + g2 * (at(m2, i) + at(m4, i))
                + g3 * at(m3, i);
            *o = ((h + w16(128)) >> 8).0 as u8;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_weights_sum_to_256() {
        assert_eq!(GAUSS7.iter().map(|&w| u32::from(w)).sum::<u32>(), 256);
    }

    #[test]
    fn blur_keeps_constant_image() {
        let data = vec![77u8; 20 * 9];
        let v = GrayView::new(&data, 20, 9).expect("view");
        let mut out = GrayBuf::default();
        gaussian_blur7(&v, &mut out, &mut BlurScratch::default());
        assert!(out.data.iter().all(|&p| p == 77));
    }

    /// The vectorised blur equals the formula of its docs evaluated pixel by pixel in u32
    /// (so no u16 sum can have wrapped), on a pattern with a saturated patch.
    #[test]
    fn blur_equals_the_separable_formula() {
        let (w, h) = (37usize, 23usize);
        let data: Vec<u8> = (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                if x < 9 && y < 9 {
                    255
                } else {
                    ((x * 53 + y * 97 + x * y * 7) % 256) as u8
                }
            })
            .collect();
        let v = GrayView::new(&data, w, h).expect("view");
        let mut out = GrayBuf::default();
        gaussian_blur7(&v, &mut out, &mut BlurScratch::default());
        let at = |x: isize, y: isize| {
            let (x, y) = (
                x.clamp(0, w as isize - 1) as usize,
                y.clamp(0, h as isize - 1) as usize,
            );
            u32::from(data[y * w + x])
        };
        let g = |k: usize| u32::from(GAUSS7[k]);
        for y in 0..h as isize {
            for x in 0..w as isize {
                let vert = |xx: isize| {
                    ((0..7)
                        .map(|k| g(k) * at(xx, y + k as isize - 3))
                        .sum::<u32>()
                        + 128)
                        >> 8
                };
                let sum: u32 = (0..7).map(|k| g(k) * vert(x + k as isize - 3)).sum();
                let want = ((sum + 128) >> 8) as u8;
                assert_eq!(out.data[y as usize * w + x as usize], want, "({x}, {y})");
            }
        }
        assert_eq!(out.data[0], 255);
    }

    #[test]
    fn resize_halves_a_ramp() {
        let data: Vec<u8> = (0..16 * 4).map(|i| ((i % 16) * 10) as u8).collect();
        let v = GrayView::new(&data, 16, 4).expect("view");
        let mut out = GrayBuf::default();
        out.reshape(8, 2);
        resize_bilinear(&v, &mut out, &mut ResizeScratch::default());
        // x_dst = 0 samples u = 0.5: mean of 0 and 10.
        assert_eq!(out.data[0], 5);
        assert_eq!(out.data[7], 145);
    }

    #[test]
    fn hblock_encoding_reproduces_the_scalar_pass() {
        // What the VBMI shuffle computes, emulated on any CPU: every usable block's
        // (idx, w) must give the scalar pass's value for each of its 64 pixels.
        let row: Vec<u8> = (0..1280u32).map(|i| (i * 37 % 251) as u8).collect();
        for (sw, dw) in [
            (1280usize, 1067usize),
            (1067, 889),
            (300, 250),
            (600, 300),
            (130, 64),
        ] {
            let s = sw as f64 / dw as f64;
            let xtab: Vec<(u32, u16)> = (0..dw).map(|x| resize_tab(x, s, sw)).collect();
            let mut blocks = Vec::new();
            hblocks(&xtab, sw, &mut blocks);
            assert_eq!(blocks.len(), dw / HBLOCK);
            let mut usable = 0;
            for (b, blk) in blocks.iter().enumerate() {
                if !blk.usable {
                    continue;
                }
                usable += 1;
                for k in 0..HBLOCK {
                    let (i, f) = xtab[b * HBLOCK + k];
                    let want =
                        u16::from(row[i as usize]) * (128 - f) + u16::from(row[i as usize + 1]) * f;
                    let at = blk.base + usize::from(blk.idx[k]);
                    let w = u16::from(blk.w[k]);
                    let got = u16::from(row[at]) * (128 - w) + u16::from(row[at + 1]) * w;
                    assert_eq!(got, want, "{sw} -> {dw}, block {b}, pixel {k}");
                }
            }
            // Only the blocks whose 128 source bytes run past the row are left out.
            assert!(
                usable + 2 >= blocks.len(),
                "{sw} -> {dw}: {usable} of {}",
                blocks.len()
            );
        }
    }

    #[test]
    fn resize_is_the_same_on_every_simd_level() {
        if !simd::vbmi_allowed() {
            eprintln!("no AVX-512 VBMI here: only the scalar resize is compared");
        }
        use simd::{Level, with_max_level};
        // Pyramid-like ratios, widths around and below the 64-pixel vector block, a
        // strided view, and 2x (where blocks span more source bytes).
        let mut state = 0x2545_F491_4F6C_DD1Du64;
        let data: Vec<u8> = (0..700 * 300)
            .map(|_| {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                state as u8
            })
            .collect();
        for (sw, sh, dw, dh, stride) in [
            (700, 300, 583, 250, 700),
            (640, 300, 533, 250, 700),
            (129, 40, 107, 33, 700),
            (90, 30, 75, 25, 700),
            (600, 200, 300, 100, 700),
            (200, 100, 199, 99, 700),
        ] {
            let Ok(v) = GrayView::with_stride(&data, sw, sh, stride) else {
                panic!("view {sw}x{sh}");
            };
            let run = |level| {
                with_max_level(level, || {
                    let mut out = GrayBuf::default();
                    out.reshape(dw, dh);
                    resize_bilinear(&v, &mut out, &mut ResizeScratch::default());
                    out.data
                })
            };
            let base = run(Level::Baseline);
            assert_eq!(run(Level::Avx512), base, "{sw}x{sh} -> {dw}x{dh}");
        }
    }

    #[test]
    fn view_rejects_short_buffer() {
        assert!(matches!(
            GrayView::new(&[0u8; 10], 4, 3),
            Err(FeatureError::BufferTooShort {
                len: 10,
                needed: 12
            })
        ));
    }
}
