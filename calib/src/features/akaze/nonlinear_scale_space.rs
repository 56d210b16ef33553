//! The AKAZE nonlinear scale space (Alcantarilla, Nuevo & Bartoli, BMVC 2013, sec. 3-4).
//!
//! The image `L` (gray levels scaled to `[0, 1]`) evolves by the Perona-Malik diffusion
//!
//! ```text
//! dL/dt = div( g(|grad L_sigma|) grad L ),   g2 = 1 / (1 + |grad L_sigma|^2 / k^2)
//! ```
//!
//! (paper eq. 1-2, `L_sigma` the image smoothed by a Gaussian of sigma 1, gradients by
//! normalised Scharr). The contrast factor `k` is the 70th percentile of the gradient
//! magnitude histogram (300 bins) of the Gaussian-smoothed input, excluding the empty first
//! bin; it shrinks by 0.75 at each new octave.
//!
//! Levels `i = (o, s)` of `O` octaves and `S` sublevels have the scales
//! `sigma_i = sigma_0 2^(o + s / S)` (`sigma_0 = 1.6`) and the evolution times
//! `t_i = sigma_i^2 / 2` (eq. 3); level 0 is the input blurred by a Gaussian of `sigma_0`.
//! From level `i - 1` to `i` the image is diffused for `t_i - t_(i-1)` by one FED cycle
//! ([`super::fed`]) of explicit steps `L += tau/2 * sum_n (g_c + g_n)(L_n - L_c)` over the four
//! neighbours `n` (missing neighbours at the border contribute nothing: Neumann conditions).
//! At a new octave the image is first halved by 2x2 averaging.
//!
//! Each level also keeps the scale-normalised derivatives of its smoothed image for the
//! detector and descriptor: with the integer derivative scale `s_i = round(1.5 sigma_i / 2^o)`,
//! `Lx`, `Ly` are Scharr-type differences over `2 s_i` pixels ([`super::image::Kernel1`]) and
//! the response is the scale-normalised Hessian determinant (paper eq. 5)
//!
//! ```text
//! L_det = s_i^4 (Lxx Lyy - Lxy^2).
//! ```
//!
//! As in the reference implementation the smoothed image of level `i >= 1` (from which the
//! Hessian is taken) is computed before that level's diffusion steps.

use rayon::prelude::*;

use super::AkazeParams;
use super::fed::{TAU_MAX, fed_steps};
use super::image::{
    Border, FilterScratch, ImageF32, Kernel1, gaussian_blur, gaussian_ksize, half_sample,
    sep_filter,
};
use crate::features::GrayView;

/// Smallest width and height of an octave beyond the first.
const MIN_OCTAVE_SIZE: (usize, usize) = (80, 40);
/// Radius of the M-LDB pattern in units of the scale (`10 sqrt 2`): the detector border.
const DESCRIPTOR_EXTENT: f32 = 14.142_136;

/// One level of the scale space.
#[derive(Clone, Debug, Default)]
pub struct Level {
    /// Octave `o` (the image is `2^o` times smaller than the input).
    pub octave: u8,
    /// Sublevel `s` within the octave.
    pub sublevel: u8,
    /// Scale `sigma_0 2^(o + s/S)` in input pixels.
    pub esigma: f32,
    /// Evolution time `sigma^2 / 2`.
    pub etime: f32,
    /// Integer derivative scale `round(1.5 sigma / 2^o)` in level pixels.
    pub sigma_size: usize,
    /// Border (level pixels) in which no keypoint is detected: `round(10 sqrt2 s) + 1`.
    pub border: usize,
    /// `2^o`.
    pub ratio: f32,
    /// The evolved image.
    pub lt: ImageF32,
    /// First derivative along x at scale `sigma_size` (level pixels).
    pub lx: ImageF32,
    /// First derivative along y.
    pub ly: ImageF32,
    /// Scale-normalised Hessian determinant.
    pub ldet: ImageF32,
    lsmooth: ImageF32,
}

/// The nonlinear scale space of one image.
#[derive(Clone, Debug, Default)]
pub struct ScaleSpace {
    /// Levels, finest first.
    pub levels: Vec<Level>,
    /// Contrast factor `k` of the first octave.
    pub kcontrast: f32,
}

/// The level layout for an image of `width x height` (no pixels yet).
pub fn level_layout(width: usize, height: usize, params: &AkazeParams) -> Vec<Level> {
    let mut out = Vec::new();
    for o in 0..params.octaves {
        let power = 1usize << o;
        let (w, h) = (width / power, height / power);
        if o > 0 && (w < MIN_OCTAVE_SIZE.0 || h < MIN_OCTAVE_SIZE.1) {
            break;
        }
        for s in 0..params.sublevels {
            let esigma = params.sigma0 * 2f32.powf(s as f32 / params.sublevels as f32 + o as f32);
            let sigma_size = ((esigma * params.derivative_factor / power as f32).round_ties_even()
                as usize)
                .max(1);
            out.push(Level {
                octave: o as u8,
                sublevel: s as u8,
                esigma,
                etime: 0.5 * esigma * esigma,
                sigma_size,
                border: (DESCRIPTOR_EXTENT * sigma_size as f32).round_ties_even() as usize + 1,
                ratio: power as f32,
                lt: ImageF32 {
                    width: w,
                    height: h,
                    data: Vec::new(),
                },
                ..Level::default()
            });
        }
    }
    out
}

/// Contrast factor: the `percentile` of the gradient magnitudes `|grad|` in a histogram of
/// `bins` bins over `[0, max]`, not counting bin 0 (background); 0.03 for a flat image.
pub fn contrast_factor(lx: &ImageF32, ly: &ImageF32, percentile: f32, bins: usize) -> f32 {
    let (w, h) = (lx.width, lx.height);
    if w < 3 || h < 3 || bins < 3 {
        return 0.03;
    }
    let mut mags = Vec::with_capacity((w - 2) * (h - 2));
    let mut hmax = 0f32;
    for y in 1..h - 1 {
        let (rx, ry) = (lx.row(y), ly.row(y));
        for x in 1..w - 1 {
            let m = (rx[x] * rx[x] + ry[x] * ry[x]).sqrt();
            hmax = hmax.max(m);
            mags.push(m);
        }
    }
    if hmax <= 0.0 {
        return 0.03;
    }
    let mut hist = vec![0usize; bins];
    let f = (bins - 1) as f32 / hmax;
    for m in &mags {
        let b = ((m * f) as usize).min(bins - 1);
        hist[b] += 1;
    }
    let threshold = ((mags.len() - hist[0]) as f32 * percentile) as usize;
    let mut n = 0usize;
    for (k, count) in hist.iter().enumerate().skip(1) {
        if n >= threshold {
            return hmax * k as f32 / bins as f32;
        }
        n += count;
    }
    0.03
}

/// One explicit diffusion step `L += step * sum_n (c_c + c_n)(L_n - L_c)` (module docs).
fn diffusion_step(lt: &mut ImageF32, c: &ImageF32, step: f32, tmp: &mut Vec<f32>, parallel: bool) {
    let (w, h) = (lt.width, lt.height);
    tmp.resize(w * h, 0.0);
    let l = &lt.data;
    let cd = &c.data;
    let row = |y: usize, out: &mut [f32]| {
        let lc = &l[y * w..(y + 1) * w];
        let cc = &cd[y * w..(y + 1) * w];
        let up = (y > 0).then(|| (&l[(y - 1) * w..y * w], &cd[(y - 1) * w..y * w]));
        let dn = (y + 1 < h).then(|| (&l[(y + 1) * w..(y + 2) * w], &cd[(y + 1) * w..(y + 2) * w]));
        // Horizontal fluxes.
        for x in 0..w {
            let mut s = 0.0;
            if x + 1 < w {
                s += (cc[x] + cc[x + 1]) * (lc[x + 1] - lc[x]);
            }
            if x > 0 {
                s += (cc[x] + cc[x - 1]) * (lc[x - 1] - lc[x]);
            }
            out[x] = s;
        }
        if let Some((la, ca)) = up {
            for x in 0..w {
                out[x] += (cc[x] + ca[x]) * (la[x] - lc[x]);
            }
        }
        if let Some((lb, cb)) = dn {
            for x in 0..w {
                out[x] += (cc[x] + cb[x]) * (lb[x] - lc[x]);
            }
        }
        for o in out.iter_mut() {
            *o *= step;
        }
    };
    if parallel {
        tmp.par_chunks_mut(w)
            .enumerate()
            .for_each(|(y, out)| row(y, out));
    } else {
        for (y, out) in tmp.chunks_mut(w).enumerate() {
            row(y, out);
        }
    }
    for (d, s) in lt.data.iter_mut().zip(tmp.iter()) {
        *d += *s;
    }
}

/// Perona-Malik `g2 = 1 / (1 + |grad|^2 / k^2)`.
fn pm_g2(lx: &ImageF32, ly: &ImageF32, k: f32, dst: &mut ImageF32) {
    dst.reshape(lx.width, lx.height);
    let inv = 1.0 / (k * k);
    for ((d, x), y) in dst.data.iter_mut().zip(&lx.data).zip(&ly.data) {
        *d = 1.0 / (1.0 + (x * x + y * y) * inv);
    }
}

/// Builds the scale space of `img` (module docs). Levels whose image is smaller than their
/// detection border are kept (they simply yield no keypoints).
pub fn build_scale_space(img: &GrayView<'_>, params: &AkazeParams) -> ScaleSpace {
    let (w, h) = (img.width(), img.height());
    let mut levels = level_layout(w, h, params);
    let mut scratch = FilterScratch::default();
    let mut input = ImageF32::zeros(w, h);
    for y in 0..h {
        if let Some(r) = img.row(y) {
            for (d, s) in input.data[y * w..(y + 1) * w].iter_mut().zip(r) {
                *d = f32::from(*s) / 255.0;
            }
        }
    }
    let Some(first) = levels.first_mut() else {
        return ScaleSpace::default();
    };
    gaussian_blur(
        &input,
        gaussian_ksize(params.sigma0),
        params.sigma0,
        &mut first.lt,
        &mut scratch,
    );
    first.lsmooth = first.lt.clone();

    let d1 = Kernel1::derivative(1);
    let m1 = Kernel1::scharr_smooth(1);
    let mut smooth = ImageF32::default();
    let mut lx = ImageF32::default();
    let mut ly = ImageF32::default();
    gaussian_blur(&input, 5, 1.0, &mut smooth, &mut scratch);
    sep_filter(&smooth, &d1, &m1, Border::Reflect101, &mut lx, &mut scratch);
    sep_filter(&smooth, &m1, &d1, Border::Reflect101, &mut ly, &mut scratch);
    let k0 = contrast_factor(&lx, &ly, params.kcontrast_percentile, params.kcontrast_bins);
    let mut k = k0;
    let mut flow = ImageF32::default();
    let mut tmp = Vec::new();
    for i in 1..levels.len() {
        let (done, rest) = levels.split_at_mut(i);
        let (Some(prev), Some(cur)) = (done.last(), rest.first_mut()) else {
            break;
        };
        if cur.octave > prev.octave {
            half_sample(&prev.lt, &mut cur.lt);
            k *= 0.75;
        } else {
            cur.lt.clone_from(&prev.lt);
        }
        gaussian_blur(&cur.lt, 5, 1.0, &mut cur.lsmooth, &mut scratch);
        sep_filter(
            &cur.lsmooth,
            &d1,
            &m1,
            Border::Reflect101,
            &mut lx,
            &mut scratch,
        );
        sep_filter(
            &cur.lsmooth,
            &m1,
            &d1,
            Border::Reflect101,
            &mut ly,
            &mut scratch,
        );
        pm_g2(&lx, &ly, k, &mut flow);
        for tau in fed_steps(cur.etime - prev.etime, TAU_MAX) {
            diffusion_step(&mut cur.lt, &flow, 0.5 * tau, &mut tmp, params.parallel);
        }
    }
    if params.parallel {
        levels.par_iter_mut().for_each(|l| {
            hessian_response(l, &mut FilterScratch::default());
        });
    } else {
        for l in &mut levels {
            hessian_response(l, &mut scratch);
        }
    }
    ScaleSpace {
        levels,
        kcontrast: k0,
    }
}

/// `Lx`, `Ly` and the scale-normalised Hessian determinant of one level (module docs).
fn hessian_response(level: &mut Level, scratch: &mut FilterScratch) {
    let s = level.sigma_size;
    let (d, m) = (Kernel1::derivative(s), Kernel1::scharr_smooth(s));
    let b = Border::Reflect101;
    sep_filter(&level.lsmooth, &d, &m, b, &mut level.lx, scratch);
    sep_filter(&level.lsmooth, &m, &d, b, &mut level.ly, scratch);
    let mut lxx = ImageF32::default();
    let mut lxy = ImageF32::default();
    let mut lyy = ImageF32::default();
    sep_filter(&level.lx, &d, &m, b, &mut lxx, scratch);
    sep_filter(&level.lx, &m, &d, b, &mut lxy, scratch);
    sep_filter(&level.ly, &m, &d, b, &mut lyy, scratch);
    let s4 = (s * s * s * s) as f32;
    level.ldet.reshape(lxx.width, lxx.height);
    for (((o, a), c), bxy) in level
        .ldet
        .data
        .iter_mut()
        .zip(&lxx.data)
        .zip(&lyy.data)
        .zip(&lxy.data)
    {
        *o = (a * c - bxy * bxy) * s4;
    }
    level.lsmooth = ImageF32::default();
}
