//! Seeded synthetic images and warps for tests, benchmarks and pattern learning: textured
//! scenes (random rectangles, discs and smoothed noise, blurred) that have corners at every
//! scale, and homography warps with known geometry. Deterministic for a given seed.

use nalgebra::{Matrix3, Vector3};

use super::gray::{BlurScratch, GrayBuf, gaussian_blur7};

/// The seeded generator of the synthetic scenes (rodlog's one SplitMix64).
pub use rng::SplitMix64;

/// A `width x height` textured scene from `seed`: a smooth gradient, ~1 shape per 2500
/// pixels (axis-aligned and rotated rectangles, discs) of random gray levels, blob noise
/// (random 8x8 blocks of noise upsampled), then a 7x7 Gaussian blur.
pub fn textured_image(width: usize, height: usize, seed: u64) -> GrayBuf {
    let mut rng = SplitMix64::new(seed);
    let mut f = vec![0f32; width * height];
    let (gx, gy) = (rng.next_f64() * 60.0 - 30.0, rng.next_f64() * 60.0 - 30.0);
    for y in 0..height {
        for x in 0..width {
            f[y * width + x] = 128.0
                + (gx * x as f64 / width.max(1) as f64 + gy * y as f64 / height.max(1) as f64)
                    as f32;
        }
    }
    let shapes = (width * height / 2500).max(4);
    for _ in 0..shapes {
        let cx = rng.next_f64() * width as f64;
        let cy = rng.next_f64() * height as f64;
        let a = 4.0 + rng.next_f64() * 40.0;
        let b = 4.0 + rng.next_f64() * 40.0;
        let th = rng.next_f64() * std::f64::consts::PI;
        let level = (rng.next_f64() * 255.0) as f32;
        let kind = rng.next_u64() % 3; // modulo, not `below`: the committed scenes and BRIEF pattern were drawn so
        let (s, c) = th.sin_cos();
        let r = a.max(b) * 1.5;
        let (x0, x1) = ((cx - r).max(0.0) as usize, ((cx + r) as usize).min(width));
        let (y0, y1) = ((cy - r).max(0.0) as usize, ((cy + r) as usize).min(height));
        for y in y0..y1 {
            for x in x0..x1 {
                let (dx, dy) = (x as f64 - cx, y as f64 - cy);
                let inside = match kind {
                    0 => dx.abs() < a && dy.abs() < b,
                    1 => {
                        let (u, v) = (c * dx + s * dy, -s * dx + c * dy);
                        u.abs() < a && v.abs() < b
                    }
                    _ => dx * dx + dy * dy < a * a,
                };
                if inside {
                    f[y * width + x] = level;
                }
            }
        }
    }
    // Blob noise: 8x8 blocks of random amplitude +-25, nearest-neighbour upsampled.
    let (bw, bh) = (width.div_ceil(8), height.div_ceil(8));
    let blocks: Vec<f32> = (0..bw * bh)
        .map(|_| (rng.next_f64() * 50.0 - 25.0) as f32)
        .collect();
    let mut img = GrayBuf::default();
    img.reshape(width, height);
    for y in 0..height {
        for x in 0..width {
            let v = f[y * width + x] + blocks[(y / 8) * bw + x / 8];
            img.data[y * width + x] = v.round().clamp(0.0, 255.0) as u8;
        }
    }
    let mut out = GrayBuf::default();
    gaussian_blur7(&img.view(), &mut out, &mut BlurScratch::default());
    out
}

/// Maps `(x, y)` through the homography `h` (row-major 3x3): `(h p) / (h p)_z`.
pub fn apply_homography(h: &Matrix3<f64>, x: f64, y: f64) -> (f64, f64) {
    let p = h * Vector3::new(x, y, 1.0);
    (p.x / p.z, p.y / p.z)
}

/// The image `b` of `width x height` with `b(x) = a(H^-1 x)` for `b_from_a = H`, sampled
/// bilinearly; pixels mapping outside `a` are `fill`. `None` when `H` is singular.
pub fn warp_homography(
    a: &GrayBuf,
    b_from_a: &Matrix3<f64>,
    width: usize,
    height: usize,
    fill: u8,
) -> Option<GrayBuf> {
    let a_from_b = b_from_a.try_inverse()?;
    let mut out = GrayBuf::default();
    out.reshape(width, height);
    let (aw, ah) = (a.width as f64, a.height as f64);
    for y in 0..height {
        for x in 0..width {
            let (u, v) = apply_homography(&a_from_b, x as f64, y as f64);
            let px = if u >= 0.0 && v >= 0.0 && u <= aw - 1.0 && v <= ah - 1.0 {
                let (i, j) = (u.floor() as usize, v.floor() as usize);
                let (fx, fy) = (u - i as f64, v - j as f64);
                let i1 = (i + 1).min(a.width - 1);
                let j1 = (j + 1).min(a.height - 1);
                let g = |xx: usize, yy: usize| f64::from(a.data[yy * a.width + xx]);
                let top = g(i, j) * (1.0 - fx) + g(i1, j) * fx;
                let bot = g(i, j1) * (1.0 - fx) + g(i1, j1) * fx;
                (top * (1.0 - fy) + bot * fy).round() as u8
            } else {
                fill
            };
            out.data[y * width + x] = px;
        }
    }
    Some(out)
}

/// The homography rotating by `angle_rad` and scaling by `scale` about `(cx, cy)`, then
/// translating by `(tx, ty)`.
pub fn similarity(angle_rad: f64, scale: f64, cx: f64, cy: f64, tx: f64, ty: f64) -> Matrix3<f64> {
    let (s, c) = angle_rad.sin_cos();
    let (a, b) = (scale * c, scale * s);
    Matrix3::new(
        a,
        -b,
        cx - a * cx + b * cy + tx,
        b,
        a,
        cy - b * cx - a * cy + ty,
        0.0,
        0.0,
        1.0,
    )
}
