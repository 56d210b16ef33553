//! The Gaussian and difference-of-Gaussian scale space of SIFT (Lowe 2004, sec. 3, eq. 1).
//!
//! Images are `f32` grey values in `0..=255`. The base is the input doubled by bilinear
//! interpolation with `x_up = 2 x` (OpenCV's `enable_precise_upscale`; OpenCV's default
//! `INTER_LINEAR` resize maps pixel centres, `x_up = 2 x + 0.5`, and then reads keypoints
//! back as `x_up / 2`, a quarter-pixel bias we avoid) and blurred by `sqrt(max(sigma^2 - (2 * 0.5)^2,
//! 0.01))` to reach `sigma` given the assumed camera blur 0.5 (Lowe sec. 3.3). Octave `o + 1`
//! starts from layer `s` of octave `o` (blur `2 sigma` there) taking every second pixel.
//! Blurs are separable with OpenCV's float kernel (`2 * round(4 sigma) + 1` taps, sampled
//! Gaussian normalised to 1) and reflect-101 borders.

use rayon::prelude::*;

use super::SiftParams;
use crate::features::GrayView;

/// One octave: `s + 3` Gaussian images and `s + 2` DoG images of `width x height`.
#[derive(Clone, Debug, Default)]
pub struct Octave {
    /// Width in pixels of this octave.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// `gauss[i]` = `L(., ., k^i sigma)` in octave units, row-major.
    pub gauss: Vec<Vec<f32>>,
    /// `dog[i] = gauss[i + 1] - gauss[i]`.
    pub dog: Vec<Vec<f32>>,
}

/// The whole pyramid.
#[derive(Clone, Debug, Default)]
pub struct Pyramid {
    /// Octaves, finest first.
    pub octaves: Vec<Octave>,
    /// Octave number of `octaves[0]`: -1 with upsampling, else 0.
    pub first_octave: i32,
    /// Layers `s` per octave.
    pub n_layers: usize,
}

/// Index of `i` in `0..n` with reflect-101 borders (`-1 -> 1`, `n -> n - 2`), repeated for
/// offsets longer than the image.
#[inline]
pub fn reflect101(i: isize, n: usize) -> usize {
    if n <= 1 {
        return 0;
    }
    let n = n as isize;
    let mut i = i;
    loop {
        if i < 0 {
            i = -i;
        } else if i >= n {
            i = 2 * n - 2 - i;
        } else {
            return i as usize;
        }
    }
}

/// Half of OpenCV's float Gaussian kernel: `k[0]` the centre, `k[t]` at offset `+-t`.
pub fn gaussian_half_kernel(sigma: f32) -> Vec<f32> {
    let ksize = ((f64::from(sigma) * 8.0 + 1.0).round() as usize) | 1;
    let r = ksize / 2;
    let s2 = 2.0 * f64::from(sigma) * f64::from(sigma);
    let full: Vec<f64> = (0..ksize)
        .map(|i| {
            let d = i as f64 - r as f64;
            (-d * d / s2).exp()
        })
        .collect();
    let sum: f64 = full.iter().sum();
    (0..=r).map(|t| (full[r + t] / sum) as f32).collect()
}

/// One output row of the separable blur: vertical pass into `col`, horizontal pass from the
/// reflect-padded `pad` into `dst`. Plain lane loops run through [`simd::dispatch`] (wider
/// vectors when the CPU has them); float operations are neither reassociated nor fused by
/// Rust, so every path gives the same bits.
struct BlurRow<'a> {
    src: &'a [f32],
    w: usize,
    h: usize,
    k: &'a [f32],
    y: usize,
    dst: &'a mut [f32],
    col: &'a mut Vec<f32>,
    pad: &'a mut Vec<f32>,
}

impl simd::Kernel for BlurRow<'_> {
    type Output = ();
    #[inline(always)]
    fn run(self) {
        let BlurRow {
            src,
            w,
            h,
            k,
            y,
            dst,
            col,
            pad,
        } = self;
        let r = k.len() - 1;
        col.clear();
        col.extend_from_slice(&src[y * w..(y + 1) * w]);
        for v in col.iter_mut() {
            *v *= k[0];
        }
        for (t, &kt) in k.iter().enumerate().skip(1) {
            let up = reflect101(y as isize - t as isize, h);
            let dn = reflect101((y + t) as isize, h);
            let (ru, rd) = (&src[up * w..(up + 1) * w], &src[dn * w..(dn + 1) * w]);
            for ((c, &a), &b) in col.iter_mut().zip(ru).zip(rd) {
                *c += kt * (a + b);
            }
        }
        pad.clear();
        pad.extend((0..w + 2 * r).map(|i| col[reflect101(i as isize - r as isize, w)]));
        let centre = &pad[r..r + w];
        for (d, &c) in dst.iter_mut().zip(centre) {
            *d = k[0] * c;
        }
        for (t, &kt) in k.iter().enumerate().skip(1) {
            let left = &pad[r - t..r - t + w];
            let right = &pad[r + t..r + t + w];
            for ((d, &a), &b) in dst.iter_mut().zip(left).zip(right) {
                *d += kt * (a + b);
            }
        }
    }
}

/// Separable Gaussian blur of a `w x h` image (reflect-101 borders). Rows are independent,
/// so the parallel result equals the sequential one.
pub fn gaussian_blur(src: &[f32], w: usize, h: usize, sigma: f32, parallel: bool) -> Vec<f32> {
    let k = gaussian_half_kernel(sigma);
    let mut out = vec![0.0f32; w * h];
    if w == 0 || h == 0 {
        return out;
    }
    let level = simd::max_level();
    let row_job = |(y, dst): (usize, &mut [f32]), (col, pad): &mut (Vec<f32>, Vec<f32>)| {
        simd::dispatch_at(
            level,
            BlurRow {
                src,
                w,
                h,
                k: &k,
                y,
                dst,
                col,
                pad,
            },
        );
    };
    if parallel {
        out.par_chunks_mut(w)
            .enumerate()
            .for_each_init(|| (Vec::new(), Vec::new()), |s, job| row_job(job, s));
    } else {
        let mut s = (Vec::new(), Vec::new());
        for job in out.chunks_mut(w).enumerate() {
            row_job(job, &mut s);
        }
    }
    out
}

/// The input as `f32`, doubled by bilinear interpolation with `x_up = 2 x` (module docs):
/// even samples copy the input, odd ones average their two neighbours, the last row and
/// column repeat the border (OpenCV's `enable_precise_upscale`).
pub fn upsample2(img: &GrayView<'_>) -> (Vec<f32>, usize, usize) {
    let (w, h) = (img.width(), img.height());
    let (w2, h2) = (2 * w, 2 * h);
    // Horizontal doubling of each source row.
    let mut rows = vec![0.0f32; w2 * h];
    for y in 0..h {
        let Some(src) = img.row(y) else { continue };
        let dst = &mut rows[y * w2..(y + 1) * w2];
        for x in 0..w {
            let c = f32::from(src[x]);
            let r = f32::from(src[(x + 1).min(w - 1)]);
            dst[2 * x] = c;
            dst[2 * x + 1] = 0.5 * (c + r);
        }
    }
    let mut out = vec![0.0f32; w2 * h2];
    for y in 0..h {
        let c = &rows[y * w2..(y + 1) * w2];
        let yd = (y + 1).min(h - 1);
        let d = &rows[yd * w2..(yd + 1) * w2];
        let (even, odd) = out[2 * y * w2..(2 * y + 2) * w2].split_at_mut(w2);
        even.copy_from_slice(c);
        for ((o, &a), &b) in odd.iter_mut().zip(c).zip(d) {
            *o = 0.5 * (a + b);
        }
    }
    (out, w2, h2)
}

/// Every second pixel of every second row (`(w / 2) x (h / 2)`).
pub fn downsample2(src: &[f32], w: usize, h: usize) -> (Vec<f32>, usize, usize) {
    let (w2, h2) = (w / 2, h / 2);
    let mut out = Vec::with_capacity(w2 * h2);
    for y in 0..h2 {
        let row = &src[2 * y * w..2 * y * w + w];
        out.extend((0..w2).map(|x| row[2 * x]));
    }
    (out, w2, h2)
}

/// Number of octaves for a `w x h` input: `round(log2(min(w, h))) - 2 - first_octave`
/// (OpenCV), at least 1.
pub fn octave_count(w: usize, h: usize, first_octave: i32) -> usize {
    let m = w.min(h).max(1) as f64;
    let n = m.log2().round() as i32 - 2 - first_octave;
    n.max(1) as usize
}

impl Pyramid {
    /// Builds the Gaussian and DoG pyramids of `img` (module docs).
    pub fn build(img: &GrayView<'_>, params: &SiftParams) -> Self {
        let s = params.n_octave_layers;
        let sigma = params.sigma;
        let par = params.parallel;
        let (base, w0, h0, first_octave, init_blur) = if params.upsample {
            let (b, w, h) = upsample2(img);
            (b, w, h, -1, 1.0f32)
        } else {
            let (w, h) = (img.width(), img.height());
            let mut b = Vec::with_capacity(w * h);
            for y in 0..h {
                if let Some(row) = img.row(y) {
                    b.extend(row.iter().map(|&p| f32::from(p)));
                }
            }
            (b, w, h, 0, 0.5f32)
        };
        let sig_diff = (sigma * sigma - init_blur * init_blur).max(0.01).sqrt();
        let base = gaussian_blur(&base, w0, h0, sig_diff, par);
        // Incremental blurs: sig[i]^2 = (k^i sigma)^2 - (k^(i-1) sigma)^2.
        let k = 2f64.powf(1.0 / s as f64);
        let sig: Vec<f32> = (0..s + 3)
            .map(|i| {
                if i == 0 {
                    sigma
                } else {
                    let prev = k.powi(i as i32 - 1) * f64::from(sigma);
                    let total = prev * k;
                    (total * total - prev * prev).sqrt() as f32
                }
            })
            .collect();
        let n_oct = octave_count(img.width(), img.height(), first_octave);
        let mut octaves: Vec<Octave> = Vec::with_capacity(n_oct);
        for o in 0..n_oct {
            let (first, w, h) = match octaves.last() {
                None => (base.clone(), w0, h0),
                Some(prev) => downsample2(&prev.gauss[s], prev.width, prev.height),
            };
            if w < 3 || h < 3 {
                break;
            }
            let mut gauss = Vec::with_capacity(s + 3);
            gauss.push(first);
            for &si in sig.iter().skip(1) {
                let next = gaussian_blur(&gauss[gauss.len() - 1], w, h, si, par);
                gauss.push(next);
            }
            let diff = |i: usize| -> Vec<f32> {
                gauss[i + 1]
                    .iter()
                    .zip(&gauss[i])
                    .map(|(a, b)| a - b)
                    .collect()
            };
            let dog: Vec<Vec<f32>> = if par {
                (0..s + 2).into_par_iter().map(diff).collect()
            } else {
                (0..s + 2).map(diff).collect()
            };
            let _ = o;
            octaves.push(Octave {
                width: w,
                height: h,
                gauss,
                dog,
            });
        }
        Pyramid {
            octaves,
            first_octave,
            n_layers: s,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reflect101_borders() {
        assert_eq!(reflect101(-1, 5), 1);
        assert_eq!(reflect101(-2, 5), 2);
        assert_eq!(reflect101(5, 5), 3);
        assert_eq!(reflect101(6, 5), 2);
        assert_eq!(reflect101(3, 5), 3);
        assert_eq!(reflect101(-7, 3), 1);
        assert_eq!(reflect101(4, 1), 0);
    }

    #[test]
    fn kernel_sums_to_one_and_has_opencv_size() {
        let k = gaussian_half_kernel(1.6);
        // ksize = round(1.6 * 8 + 1) | 1 = 15 -> radius 7.
        assert_eq!(k.len(), 8);
        let sum: f32 = k[0] + 2.0 * k[1..].iter().sum::<f32>();
        assert!((sum - 1.0).abs() < 1e-5, "{sum}");
    }

    #[test]
    fn blur_keeps_constant_and_spreads_impulse_with_right_variance() {
        let (w, h) = (41, 37);
        let flat = vec![7.0f32; w * h];
        let b = gaussian_blur(&flat, w, h, 2.0, false);
        assert!(b.iter().all(|v| (v - 7.0).abs() < 1e-4));
        let mut imp = vec![0.0f32; w * h];
        imp[18 * w + 20] = 1.0;
        let b = gaussian_blur(&imp, w, h, 2.0, true);
        let (mut m, mut var) = (0.0f64, 0.0f64);
        for y in 0..h {
            for x in 0..w {
                let v = f64::from(b[y * w + x]);
                m += v;
                var += v * ((x as f64 - 20.0).powi(2));
            }
        }
        assert!((m - 1.0).abs() < 1e-4);
        assert!((var - 4.0).abs() < 0.05, "variance {var}");
        assert_eq!(b, gaussian_blur(&imp, w, h, 2.0, false));
    }

    #[test]
    fn upsample_keeps_samples_on_even_positions() {
        let data = [0u8, 100, 200, 40, 40, 40];
        let v = GrayView::new(&data, 3, 2).expect("view");
        let (u, w, h) = upsample2(&v);
        assert_eq!((w, h), (6, 4));
        assert_eq!(&u[0..6], &[0.0, 50.0, 100.0, 150.0, 200.0, 200.0]);
        assert_eq!(&u[6..12], &[20.0, 45.0, 70.0, 95.0, 120.0, 120.0]);
        assert_eq!(&u[12..18], &[40.0; 6]);
        assert_eq!(&u[18..24], &[40.0; 6]);
    }
}
