//! The Modified-Local Difference Binary (M-LDB) descriptor of AKAZE (Alcantarilla, Nuevo &
//! Bartoli, BMVC 2013, sec. 4.3; LDB: Yang & Cheng, ISMAR 2012).
//!
//! Around a keypoint of level scale `s` and orientation `theta`, a square of side `20 s`
//! (pattern size 10) is divided into 2x2, 3x3 and 4x4 grids (cell sides `10 s`, `7 s` and
//! `5 s`). Each cell yields the means of three channels over its samples (one per level
//! pixel step `s`, nearest-pixel lookup, points outside the image skipped): the intensity
//! `L_t`, and the derivatives along the rotated axes `Lx' = -Lx sin + Ly cos`,
//! `Ly' = Lx cos + Ly sin` (the reference's channel order). Sample `(k, l)` of the grid sits at
//! `(x, y) + s (k cos - l sin, k sin + l cos)`, so the pattern turns with the keypoint.
//! Every pair of cells of a grid is compared per channel, bit = `value_i > value_j`; bits
//! run grid by grid (coarse first), channel by channel, pair by pair (`i < j`, row-major in
//! the reference's cell order): `3 (6 + 36 + 120) = 486` bits.

use rayon::prelude::*;

use super::nonlinear_scale_space::{Level, ScaleSpace};
use crate::features::Keypoint;

/// Bits of the full M-LDB descriptor.
pub const MLDB_BITS: usize = 486;
/// Half side of the pattern in units of the scale.
const PATTERN_SIZE: i32 = 10;
/// Cell sides of the three grids: `10`, `ceil(20 / 3)`, `ceil(10 / 2)`.
const SAMPLE_STEPS: [i32; 3] = [10, 7, 5];

/// A 486-bit M-LDB descriptor in eight words; bit `i` is bit `i % 64` of word `i / 64` (the
/// byte order of OpenCV's 61-byte AKAZE descriptors read as little-endian words); bits
/// 486..512 are zero.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub struct MldbDescriptor(pub [u64; 8]);

impl MldbDescriptor {
    /// Bit `i` (false beyond 486).
    pub fn bit(&self, i: usize) -> bool {
        self.0.get(i / 64).is_some_and(|w| (w >> (i % 64)) & 1 == 1)
    }

    /// The 61 bytes of OpenCV's layout.
    pub fn to_bytes(&self) -> [u8; 61] {
        let mut out = [0u8; 61];
        for (i, b) in out.iter_mut().enumerate() {
            *b = (self.0[i / 8] >> (8 * (i % 8))) as u8;
        }
        out
    }
}

/// Hamming distance of two M-LDB descriptors (eight `popcount`s).
#[inline]
pub fn hamming486(a: &MldbDescriptor, b: &MldbDescriptor) -> u32 {
    let mut d = 0;
    for k in 0..8 {
        d += (a.0[k] ^ b.0[k]).count_ones();
    }
    d
}

/// Fills `values` (3 per cell) for one grid of cell side `step`.
/// Where and how the pattern sits: centre `(xf, yf)` in level pixels, `cos`, `sin` of the
/// orientation, scale `s` in level pixels.
#[derive(Clone, Copy, Debug)]
struct Pose {
    xf: f32,
    yf: f32,
    co: f32,
    si: f32,
    scale: f32,
}

fn fill_values(level: &Level, pose: Pose, step: i32, values: &mut [f32]) {
    let Pose {
        xf,
        yf,
        co,
        si,
        scale,
    } = pose;
    let (w, h) = (level.lt.width as i32, level.lt.height as i32);
    let mut pos = 0;
    let mut i = -PATTERN_SIZE;
    while i < PATTERN_SIZE {
        let mut j = -PATTERN_SIZE;
        while j < PATTERN_SIZE {
            let (mut di, mut dx, mut dy) = (0f32, 0f32, 0f32);
            let mut n = 0u32;
            for k in i..i + step {
                for l in j..j + step {
                    let (kf, lf) = (k as f32, l as f32);
                    let sy = yf + (lf * co * scale + kf * si * scale);
                    let sx = xf + (-lf * si * scale + kf * co * scale);
                    let (y1, x1) = (sy.round_ties_even() as i32, sx.round_ties_even() as i32);
                    if y1 < 0 || y1 >= h || x1 < 0 || x1 >= w {
                        continue;
                    }
                    let idx = (y1 * w + x1) as usize;
                    di += level.lt.data[idx];
                    let (rx, ry) = (level.lx.data[idx], level.ly.data[idx]);
                    dx += -rx * si + ry * co;
                    dy += rx * co + ry * si;
                    n += 1;
                }
            }
            if n > 0 {
                let inv = 1.0 / n as f32;
                di *= inv;
                dx *= inv;
                dy *= inv;
            }
            if let Some(v) = values.get_mut(pos..pos + 3) {
                v.copy_from_slice(&[di, dx, dy]);
            }
            pos += 3;
            j += step;
        }
        i += step;
    }
}

/// The M-LDB descriptor of `kp` in its level (module docs).
pub fn describe(level: &Level, kp: &Keypoint) -> MldbDescriptor {
    let scale = level.sigma_size as f32;
    let (xf, yf) = (kp.x / level.ratio, kp.y / level.ratio);
    let (si, co) = kp.angle_rad.sin_cos();
    let pose = Pose {
        xf,
        yf,
        co,
        si,
        scale,
    };
    let mut desc = MldbDescriptor::default();
    let mut values = [0f32; 16 * 3];
    let mut dpos = 0usize;
    for (g, &step) in SAMPLE_STEPS.iter().enumerate() {
        let count = (g + 2) * (g + 2);
        fill_values(level, pose, step, &mut values);
        for ch in 0..3 {
            for i in 0..count {
                let vi = values[3 * i + ch];
                for j in i + 1..count {
                    if vi > values[3 * j + ch] {
                        desc.0[dpos / 64] |= 1u64 << (dpos % 64);
                    }
                    dpos += 1;
                }
            }
        }
    }
    desc
}

/// Descriptors of all keypoints (parallel over keypoints when asked; each descriptor
/// depends only on its keypoint, so the output is independent of the thread count).
pub fn describe_all(space: &ScaleSpace, kps: &[Keypoint], parallel: bool) -> Vec<MldbDescriptor> {
    let f = |kp: &Keypoint| {
        space
            .levels
            .get(kp.level as usize)
            .map_or_else(MldbDescriptor::default, |l| describe(l, kp))
    };
    if parallel {
        kps.par_iter().map(f).collect()
    } else {
        kps.iter().map(f).collect()
    }
}
