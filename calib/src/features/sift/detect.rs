//! Scale-space extrema, their sub-pixel refinement and orientation assignment (Lowe 2004,
//! sec. 3.1, 4, 4.1 and 5; details as OpenCV's `findScaleSpaceExtrema`,
//! `adjustLocalExtrema` and `calcOrientationHist`).
//!
//! With `D` scaled to [0, 1] grey units, a candidate `x = (c, r, layer)` of DoG layer
//! `1..=s` with `|D| > floor(0.5 * ct / s * 255) / 255` that is >= (maximum) or <= (minimum)
//! all 26 neighbours is refined by Newton steps `x_hat = -H^-1 g` (eq. 3) with central
//! differences for the gradient `g` and Hessian `H`; while a component of `x_hat` exceeds
//! 0.5 the sample moves by `round(x_hat)` (at most 5 steps, staying 5 pixels inside the
//! border and in layers `1..=s`). It is kept when `|D(x_hat)| * s >= ct` with
//! `D(x_hat) = D + g . x_hat / 2` (eq. 3) and when the spatial Hessian has `det > 0` and
//! `tr^2 * r_e < (r_e + 1)^2 det` (eq. 4). Its orientation histogram is computed on the
//! Gaussian image of its layer at the integer sample (sec. 5).

use std::f32::consts::PI;

use rayon::prelude::*;

use super::scale_space::{Octave, Pyramid};
use super::{SiftKeypoint, SiftParams};

/// Pixels left out at each border of an octave (OpenCV `SIFT_IMG_BORDER`).
pub const IMG_BORDER: usize = 5;
/// Maximum Newton steps (OpenCV `SIFT_MAX_INTERP_STEPS`).
pub const MAX_INTERP_STEPS: usize = 5;
/// Orientation histogram bins (Lowe sec. 5).
pub const ORI_HIST_BINS: usize = 36;
/// Gaussian window of the orientation histogram, in units of the keypoint scale (sec. 5).
pub const ORI_SIG_FCTR: f32 = 1.5;
/// Histogram radius in window sigmas (OpenCV `SIFT_ORI_RADIUS = 3 * 1.5`).
pub const ORI_RADIUS: f32 = 3.0 * ORI_SIG_FCTR;
/// Peaks at least this fraction of the maximum make keypoints (sec. 5).
pub const ORI_PEAK_RATIO: f32 = 0.8;

/// A refined extremum in octave coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Extremum {
    /// Integer sample after refinement (row, column, layer).
    pub r: usize,
    /// Column.
    pub c: usize,
    /// DoG layer `1..=s`.
    pub layer: usize,
    /// Sub-sample offsets `(x_c, x_r, x_layer)`, each in `[-0.5, 0.5]`.
    pub offset: [f32; 3],
    /// `|D(x_hat)|` in [0, 1] units.
    pub response: f32,
}

/// All keypoints of the pyramid, in (octave, layer, row, column, peak) order.
pub fn detect_keypoints(pyr: &Pyramid, params: &SiftParams) -> Vec<SiftKeypoint> {
    let s = pyr.n_layers;
    let jobs: Vec<(usize, usize)> = (0..pyr.octaves.len())
        .flat_map(|o| (1..=s).map(move |l| (o, l)))
        .collect();
    let run = |&(o, l): &(usize, usize)| scan_layer(pyr, o, l, params);
    let found: Vec<Vec<SiftKeypoint>> = if params.parallel {
        jobs.par_iter().map(run).collect()
    } else {
        jobs.iter().map(run).collect()
    };
    found.into_iter().flatten().collect()
}

#[inline]
fn is_extremum(oct: &Octave, layer: usize, i: usize, w: usize, val: f32) -> bool {
    let offs = [
        i - w - 1,
        i - w,
        i - w + 1,
        i - 1,
        i + 1,
        i + w - 1,
        i + w,
        i + w + 1,
    ];
    let (prev, curr, next) = (&oct.dog[layer - 1], &oct.dog[layer], &oct.dog[layer + 1]);
    if val > 0.0 {
        offs.iter().all(|&j| val >= curr[j])
            && offs.iter().all(|&j| val >= prev[j] && val >= next[j])
            && val >= prev[i]
            && val >= next[i]
    } else {
        offs.iter().all(|&j| val <= curr[j])
            && offs.iter().all(|&j| val <= prev[j] && val <= next[j])
            && val <= prev[i]
            && val <= next[i]
    }
}

fn scan_layer(pyr: &Pyramid, o: usize, layer: usize, params: &SiftParams) -> Vec<SiftKeypoint> {
    let oct = &pyr.octaves[o];
    let (w, h) = (oct.width, oct.height);
    let s = pyr.n_layers;
    let mut out = Vec::new();
    if w <= 2 * IMG_BORDER || h <= 2 * IMG_BORDER {
        return out;
    }
    let threshold = (0.5 * params.contrast_threshold / s as f32 * 255.0).floor();
    let curr = &oct.dog[layer];
    let octave_no = o as i32 + pyr.first_octave;
    let to_input = 2f32.powi(octave_no);
    let mut hist = [0.0f32; ORI_HIST_BINS];
    for r in IMG_BORDER..h - IMG_BORDER {
        for c in IMG_BORDER..w - IMG_BORDER {
            let i = r * w + c;
            let val = curr[i];
            if val.abs() <= threshold || !is_extremum(oct, layer, i, w, val) {
                continue;
            }
            let Some(ext) = refine(oct, s, r, c, layer, params) else {
                continue;
            };
            let [xc, xr, xi] = ext.offset;
            let scl_octv = params.sigma * 2f32.powf((ext.layer as f32 + xi) / s as f32);
            let omax = orientation_histogram(
                &oct.gauss[ext.layer],
                w,
                h,
                ext.c,
                ext.r,
                (ORI_RADIUS * scl_octv).round() as isize,
                ORI_SIG_FCTR * scl_octv,
                &mut hist,
            );
            let base = SiftKeypoint {
                x: (ext.c as f32 + xc) * to_input,
                y: (ext.r as f32 + xr) * to_input,
                size: scl_octv * 2.0 * to_input,
                angle_rad: 0.0,
                response: ext.response,
                octave: octave_no as i8,
                layer: ext.layer as u8,
            };
            for angle_rad in peak_angles(&hist, omax * ORI_PEAK_RATIO) {
                out.push(SiftKeypoint { angle_rad, ..base });
            }
        }
    }
    out
}

/// Solves `h x = g` (3x3) by Cramer's rule in f64; zero when `h` is singular.
fn solve3(h: [[f32; 3]; 3], g: [f32; 3]) -> [f32; 3] {
    let m = h.map(|r| r.map(f64::from));
    let b = g.map(f64::from);
    let det3 = |m: &[[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det3(&m);
    if d == 0.0 || !d.is_finite() {
        return [0.0; 3];
    }
    let mut x = [0.0f32; 3];
    for (k, xk) in x.iter_mut().enumerate() {
        let mut mk = m;
        for row in 0..3 {
            mk[row][k] = b[row];
        }
        *xk = (det3(&mk) / d) as f32;
    }
    x
}

/// Gradient and Hessian of `D` (scaled to [0, 1]) at `(r, c, layer)`, order (x, y, s).
fn derivatives(oct: &Octave, r: usize, c: usize, layer: usize) -> ([f32; 3], [[f32; 3]; 3]) {
    let w = oct.width;
    let img_scale = 1.0 / 255.0;
    let (ds, sds, cds) = (img_scale * 0.5, img_scale, img_scale * 0.25);
    let (prev, img, next) = (&oct.dog[layer - 1], &oct.dog[layer], &oct.dog[layer + 1]);
    let i = r * w + c;
    let g = [
        (img[i + 1] - img[i - 1]) * ds,
        (img[i + w] - img[i - w]) * ds,
        (next[i] - prev[i]) * ds,
    ];
    let v2 = img[i] * 2.0;
    let dxx = (img[i + 1] + img[i - 1] - v2) * sds;
    let dyy = (img[i + w] + img[i - w] - v2) * sds;
    let dss = (next[i] + prev[i] - v2) * sds;
    let dxy = (img[i + w + 1] - img[i + w - 1] - img[i - w + 1] + img[i - w - 1]) * cds;
    let dxs = (next[i + 1] - next[i - 1] - prev[i + 1] + prev[i - 1]) * cds;
    let dys = (next[i + w] - next[i - w] - prev[i + w] + prev[i - w]) * cds;
    (g, [[dxx, dxy, dxs], [dxy, dyy, dys], [dxs, dys, dss]])
}

/// Newton refinement and the contrast and edge tests (module docs).
pub fn refine(
    oct: &Octave,
    s: usize,
    r0: usize,
    c0: usize,
    layer0: usize,
    params: &SiftParams,
) -> Option<Extremum> {
    let (w, h) = (oct.width as isize, oct.height as isize);
    let b = IMG_BORDER as isize;
    let (mut r, mut c, mut layer) = (r0 as isize, c0 as isize, layer0 as isize);
    let mut x = [0.0f32; 3];
    let mut converged = false;
    for _ in 0..MAX_INTERP_STEPS {
        let (g, hm) = derivatives(oct, r as usize, c as usize, layer as usize);
        let sol = solve3(hm, g);
        x = [-sol[0], -sol[1], -sol[2]];
        if x.iter().all(|v| v.abs() < 0.5) {
            converged = true;
            break;
        }
        if x.iter()
            .any(|v| !v.is_finite() || v.abs() > (i32::MAX / 3) as f32)
        {
            return None;
        }
        c += x[0].round() as isize;
        r += x[1].round() as isize;
        layer += x[2].round() as isize;
        if layer < 1 || layer > s as isize || c < b || c >= w - b || r < b || r >= h - b {
            return None;
        }
    }
    if !converged {
        return None;
    }
    let (r, c, layer) = (r as usize, c as usize, layer as usize);
    let (g, hm) = derivatives(oct, r, c, layer);
    let t = g[0] * x[0] + g[1] * x[1] + g[2] * x[2];
    let contr = oct.dog[layer][r * oct.width + c] / 255.0 + t * 0.5;
    if contr.abs() * (s as f32) < params.contrast_threshold {
        return None;
    }
    let (dxx, dyy, dxy) = (hm[0][0], hm[1][1], hm[0][1]);
    let tr = dxx + dyy;
    let det = dxx * dyy - dxy * dxy;
    let e = params.edge_threshold;
    if det <= 0.0 || tr * tr * e >= (e + 1.0) * (e + 1.0) * det {
        return None;
    }
    Some(Extremum {
        r,
        c,
        layer,
        offset: x,
        response: contr.abs(),
    })
}

/// The smoothed 36-bin histogram of gradient directions (image axes, y down; bin `b`
/// covers `b * 10` degrees) around `(px, py)` within `radius`, weighted by magnitude and a
/// Gaussian of `sigma`; returns its maximum (Lowe sec. 5).
#[allow(clippy::too_many_arguments)] // an image (data, w, h), a point, the window, the output
pub fn orientation_histogram(
    img: &[f32],
    w: usize,
    h: usize,
    px: usize,
    py: usize,
    radius: isize,
    sigma: f32,
    hist: &mut [f32; ORI_HIST_BINS],
) -> f32 {
    let n = ORI_HIST_BINS;
    let mut raw = [0.0f32; ORI_HIST_BINS];
    let expf_scale = -1.0 / (2.0 * sigma * sigma);
    let (px, py) = (px as isize, py as isize);
    // The Gaussian weight is separable: exp(s (i^2 + j^2)) = exp(s i^2) exp(s j^2).
    let g1: Vec<f32> = (-radius..=radius)
        .map(|t| ((t * t) as f32 * expf_scale).exp())
        .collect();
    for i in -radius..=radius {
        let y = py + i;
        if y <= 0 || y >= h as isize - 1 {
            continue;
        }
        let y = y as usize;
        let wi = g1[(i + radius) as usize];
        for j in -radius..=radius {
            let x = px + j;
            if x <= 0 || x >= w as isize - 1 {
                continue;
            }
            let x = x as usize;
            let dx = img[y * w + x + 1] - img[y * w + x - 1];
            let dy = img[(y + 1) * w + x] - img[(y - 1) * w + x];
            let weight = wi * g1[(j + radius) as usize];
            let ori = super::fast_atan2_deg(dy, dx);
            let mut bin = ((n as f32 / 360.0) * ori).round() as isize;
            if bin >= n as isize {
                bin -= n as isize;
            }
            if bin < 0 {
                bin += n as isize;
            }
            raw[bin as usize] += weight * (dx * dx + dy * dy).sqrt();
        }
    }
    let at = |k: isize| raw[k.rem_euclid(n as isize) as usize];
    let mut maxval = 0.0f32;
    for (k, hk) in hist.iter_mut().enumerate() {
        let k = k as isize;
        *hk = (at(k - 2) + at(k + 2)) * (1.0 / 16.0)
            + (at(k - 1) + at(k + 1)) * (4.0 / 16.0)
            + at(k) * (6.0 / 16.0);
        maxval = maxval.max(*hk);
    }
    maxval
}

/// Angles (radians in `(-pi, pi]`) of the local peaks `>= threshold` of a circular
/// histogram, each refined by the parabola through it and its neighbours.
pub fn peak_angles(hist: &[f32; ORI_HIST_BINS], threshold: f32) -> Vec<f32> {
    let n = ORI_HIST_BINS;
    let mut out = Vec::new();
    for j in 0..n {
        let l = if j > 0 { j - 1 } else { n - 1 };
        let r = if j + 1 < n { j + 1 } else { 0 };
        let (hl, hc, hr) = (hist[l], hist[j], hist[r]);
        if hc > hl && hc > hr && hc >= threshold {
            let mut bin = j as f32 + 0.5 * (hl - hr) / (hl - 2.0 * hc + hr);
            if bin < 0.0 {
                bin += n as f32;
            } else if bin >= n as f32 {
                bin -= n as f32;
            }
            let mut a = bin * (2.0 * PI / n as f32);
            if a > PI {
                a -= 2.0 * PI;
            }
            out.push(a);
        }
    }
    out
}

/// Drops exact duplicates (same position, size and angle; they arise when two samples
/// refine to the same extremum), keeping the first, in the original order.
pub fn remove_duplicates(kps: Vec<SiftKeypoint>) -> Vec<SiftKeypoint> {
    let key = |k: &SiftKeypoint| (k.x, k.y, k.size, k.angle_rad);
    let mut idx: Vec<usize> = (0..kps.len()).collect();
    idx.sort_by(|&a, &b| {
        let (ka, kb) = (key(&kps[a]), key(&kps[b]));
        ka.0.total_cmp(&kb.0)
            .then(ka.1.total_cmp(&kb.1))
            .then(ka.2.total_cmp(&kb.2))
            .then(ka.3.total_cmp(&kb.3))
            .then(a.cmp(&b))
    });
    let mut keep = vec![true; kps.len()];
    for win in idx.windows(2) {
        if key(&kps[win[0]]) == key(&kps[win[1]]) {
            keep[win[1]] = false;
        }
    }
    kps.into_iter()
        .zip(keep)
        .filter_map(|(k, keep)| keep.then_some(k))
        .collect()
}

/// The `n` strongest keypoints by response (ties to the earlier one), in the original order.
pub fn retain_best(kps: Vec<SiftKeypoint>, n: usize) -> Vec<SiftKeypoint> {
    let mut idx: Vec<usize> = (0..kps.len()).collect();
    idx.sort_by(|&a, &b| kps[b].response.total_cmp(&kps[a].response).then(a.cmp(&b)));
    idx.truncate(n);
    idx.sort_unstable();
    idx.into_iter().map(|i| kps[i]).collect()
}
