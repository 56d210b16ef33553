//! The SIFT descriptor (Lowe 2004, sec. 6.1; details of OpenCV's `calcSIFTDescriptor`).
//!
//! Around the keypoint at octave position `p` and scale `sigma_oct`, with the window rotated
//! by the keypoint orientation `theta`, sample `(i, j)` (row, column offsets) maps to cell
//! coordinates `(c_rot, r_rot) = R(theta) (j, i) / (3 sigma_oct)`, bins
//! `(r_rot + 1.5, c_rot + 1.5)` of a 4x4 grid; its gradient magnitude, weighted by
//! `exp(-(c_rot^2 + r_rot^2) / 8)` (a Gaussian of half the window width, sec. 6.1), is spread
//! by trilinear interpolation over the two nearest rows, columns and of the 8 orientation
//! bins of `angle - theta`. The window radius is `round(3 sigma_oct * sqrt(2) * 5 / 2)`.
//! The 128-vector is normalised, clamped at 0.2 of its norm, renormalised to 512 and
//! rounded to `0..=255` (OpenCV's `SIFT_INT_DESCR_FCTR`). As in OpenCV the computation runs
//! in y-up angles (gradient `dy = L(r - 1) - L(r + 1)`, orientation `360 deg - angle`), so
//! the descriptors are laid out as OpenCV's.

use super::scale_space::Pyramid;
use super::{SIFT_DESCRIPTOR_LEN, SiftDescriptor, SiftKeypoint, SiftParams};

/// Spatial cells per side (Lowe's `d`).
pub const DESCR_WIDTH: usize = 4;
/// Orientation bins per cell (Lowe's `n`).
pub const DESCR_HIST_BINS: usize = 8;
/// Cell width in keypoint sigmas (OpenCV `SIFT_DESCR_SCL_FCTR`).
pub const DESCR_SCL_FCTR: f32 = 3.0;
/// Clamp of normalised entries (Lowe sec. 6.1).
pub const DESCR_MAG_THR: f32 = 0.2;
/// Scale of the final integer descriptor (OpenCV `SIFT_INT_DESCR_FCTR`).
pub const INT_DESCR_FCTR: f32 = 512.0;

/// Describes `k` from the Gaussian image of its octave and layer.
pub fn describe(pyr: &Pyramid, k: &SiftKeypoint, _params: &SiftParams) -> SiftDescriptor {
    let o = i32::from(k.octave) - pyr.first_octave;
    let Some(oct) = usize::try_from(o).ok().and_then(|o| pyr.octaves.get(o)) else {
        return [0.0; SIFT_DESCRIPTOR_LEN];
    };
    let Some(img) = oct.gauss.get(usize::from(k.layer)) else {
        return [0.0; SIFT_DESCRIPTOR_LEN];
    };
    let scale = 2f32.powi(-i32::from(k.octave));
    let (px, py) = (k.x * scale, k.y * scale);
    let scl = k.size * scale * 0.5;
    let mut down_deg = k.angle_rad.to_degrees();
    if down_deg < 0.0 {
        down_deg += 360.0;
    }
    let mut ori = 360.0 - down_deg;
    if (ori - 360.0).abs() < f32::EPSILON {
        ori = 0.0;
    }
    descriptor_at(img, oct.width, oct.height, px, py, ori, scl)
}

/// OpenCV's `calcSIFTDescriptor` with `d = 4`, `n = 8` on image `img` (`w x h`) at
/// `(px, py)`, orientation `ori_deg` (y-up degrees) and scale `scl` (module docs).
pub fn descriptor_at(
    img: &[f32],
    w: usize,
    h: usize,
    px: f32,
    py: f32,
    ori_deg: f32,
    scl: f32,
) -> SiftDescriptor {
    const D: usize = DESCR_WIDTH;
    const N: usize = DESCR_HIST_BINS;
    let (cx, cy) = (px.round() as isize, py.round() as isize);
    let (sin_t, cos_t) = ori_deg.to_radians().sin_cos();
    let bins_per_deg = N as f32 / 360.0;
    let exp_scale = -1.0 / (D as f32 * D as f32 * 0.5);
    let hist_width = DESCR_SCL_FCTR * scl;
    let radius = (hist_width * std::f32::consts::SQRT_2 * (D as f32 + 1.0) * 0.5).round();
    let diag = ((w * w + h * h) as f32).sqrt();
    let radius = radius.min(diag) as isize;
    let (cos_t, sin_t) = (cos_t / hist_width, sin_t / hist_width);
    let mut hist = [0.0f32; (D + 2) * (D + 2) * (N + 2)];
    let half = D as f32 / 2.0 - 0.5;
    let inv_hw2 = 1.0 / (hist_width * hist_width);
    let g1: Vec<f32> = (-radius..=radius)
        .map(|t| ((t * t) as f32 * inv_hw2 * exp_scale).exp())
        .collect();
    for i in -radius..=radius {
        let r = cy + i;
        if r <= 0 || r >= h as isize - 1 {
            continue;
        }
        let r = r as usize;
        let wi = g1[(i + radius) as usize];
        for j in -radius..=radius {
            let c_rot = j as f32 * cos_t - i as f32 * sin_t;
            let r_rot = j as f32 * sin_t + i as f32 * cos_t;
            let rbin = r_rot + half;
            let cbin = c_rot + half;
            let c = cx + j;
            if !(rbin > -1.0 && rbin < D as f32 && cbin > -1.0 && cbin < D as f32) {
                continue;
            }
            if c <= 0 || c >= w as isize - 1 {
                continue;
            }
            let c = c as usize;
            let dx = img[r * w + c + 1] - img[r * w + c - 1];
            let dy = img[(r - 1) * w + c] - img[(r + 1) * w + c];
            // c_rot^2 + r_rot^2 = (i^2 + j^2) / hist_width^2 (a rotation keeps lengths), so
            // the Gaussian weight is separable in (i, j).
            let weight = wi * g1[(j + radius) as usize];
            let angle = super::fast_atan2_deg(dy, dx);
            let mag = (dx * dx + dy * dy).sqrt() * weight;
            let obin = (angle - ori_deg) * bins_per_deg;
            let (r0, c0, o0) = (rbin.floor(), cbin.floor(), obin.floor());
            let (fr, fc, fo) = (rbin - r0, cbin - c0, obin - o0);
            let mut o0 = o0 as isize;
            if o0 < 0 {
                o0 += N as isize;
            }
            if o0 >= N as isize {
                o0 -= N as isize;
            }
            let (r0, c0, o0) = (
                (r0 as isize + 1) as usize,
                (c0 as isize + 1) as usize,
                o0 as usize,
            );
            let v_r1 = mag * fr;
            let v_r0 = mag - v_r1;
            let v_rc11 = v_r1 * fc;
            let v_rc10 = v_r1 - v_rc11;
            let v_rc01 = v_r0 * fc;
            let v_rc00 = v_r0 - v_rc01;
            let v_rco111 = v_rc11 * fo;
            let v_rco110 = v_rc11 - v_rco111;
            let v_rco101 = v_rc10 * fo;
            let v_rco100 = v_rc10 - v_rco101;
            let v_rco011 = v_rc01 * fo;
            let v_rco010 = v_rc01 - v_rco011;
            let v_rco001 = v_rc00 * fo;
            let v_rco000 = v_rc00 - v_rco001;
            let idx = (r0 * (D + 2) + c0) * (N + 2) + o0;
            let row = (D + 2) * (N + 2);
            hist[idx] += v_rco000;
            hist[idx + 1] += v_rco001;
            hist[idx + N + 2] += v_rco010;
            hist[idx + N + 3] += v_rco011;
            hist[idx + row] += v_rco100;
            hist[idx + row + 1] += v_rco101;
            hist[idx + row + N + 2] += v_rco110;
            hist[idx + row + N + 3] += v_rco111;
        }
    }
    let mut dst = [0.0f32; SIFT_DESCRIPTOR_LEN];
    for i in 0..D {
        for j in 0..D {
            let idx = ((i + 1) * (D + 2) + (j + 1)) * (N + 2);
            hist[idx] += hist[idx + N];
            hist[idx + 1] += hist[idx + N + 1];
            for k in 0..N {
                dst[(i * D + j) * N + k] = hist[idx + k];
            }
        }
    }
    let nrm2: f32 = dst.iter().map(|v| v * v).sum();
    let thr = nrm2.sqrt() * DESCR_MAG_THR;
    for v in dst.iter_mut() {
        *v = v.min(thr);
    }
    let nrm2: f32 = dst.iter().map(|v| v * v).sum();
    let scale = INT_DESCR_FCTR / nrm2.sqrt().max(f32::EPSILON);
    for v in dst.iter_mut() {
        *v = (*v * scale).round().clamp(0.0, 255.0);
    }
    dst
}
