//! Counter-based hashing and procedural noise bases (value noise, fbm, cellular noise).
//!
//! Everything here is a pure function of its integer/float arguments and a seed, so textures
//! and sensor noise are identical for any thread count and any evaluation order.
//!
//! * `hash*`: odd-multiplier spreading of the coordinates and one `lowbias32` finaliser
//!   round (Chris Wellons, "Prospecting for hash functions", 2018), and SplitMix64 (Steele et al., OOPSLA 2014)
//!   for 64-bit counters.
//! * Value noise: hashed lattice values in [0, 1) blended with the quintic fade
//!   `6t^5 - 15t^4 + 10t^3` (Perlin, SIGGRAPH 2002).
//! * fbm: `sum_o g^o * noise(l^o * x)` with lacunarity `l` and gain `g`; octaves whose
//!   wavelength is below twice the pixel footprint fade out (a band limit, so textures do not
//!   alias: the analytic half of the renderer's antialiasing).
//! * Cellular noise: distance to the nearest and second-nearest jittered feature point of a
//!   unit grid (Worley, SIGGRAPH 1996), with the id of the nearest cell.

/// `lowbias32` finaliser: a bijective 32-bit avalanche hash.
#[inline]
#[must_use]
pub fn hash_u32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

/// Hash of two integers and a seed: the coordinates are spread by odd multipliers (from
/// the R2 low-discrepancy sequence constants) and mixed by one `lowbias32` round.
#[inline]
#[must_use]
pub fn hash2(x: i32, y: i32, seed: u32) -> u32 {
    hash_u32(
        (x as u32).wrapping_mul(0xc13f_a9a9)
            ^ (y as u32).wrapping_mul(0x91e1_0da5)
            ^ seed.wrapping_mul(0x9e37_79b9),
    )
}

/// Hash of three integers and a seed (see [`hash2`]).
#[inline]
#[must_use]
pub fn hash3(x: i32, y: i32, z: i32, seed: u32) -> u32 {
    hash_u32(
        (x as u32).wrapping_mul(0xc13f_a9a9)
            ^ (y as u32).wrapping_mul(0x91e1_0da5)
            ^ (z as u32).wrapping_mul(0x7f4a_7c15)
            ^ seed.wrapping_mul(0x9e37_79b9),
    )
}

/// Maps a hash to a float in [0, 1).
#[inline]
#[must_use]
pub fn unit_f32(h: u32) -> f32 {
    (h >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// SplitMix64 finaliser (bijective on u64).
#[inline]
#[must_use]
pub fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// Counter-based uniform in (0, 1) keyed by (seed, counter): a pure function, so each pixel
/// draws its own numbers regardless of which thread renders it.
#[inline]
#[must_use]
pub fn uniform_open(seed: u64, counter: u64) -> f64 {
    let h = splitmix64(seed ^ splitmix64(counter));
    ((h >> 11) as f64 + 0.5) * (1.0 / 9_007_199_254_740_992.0)
}

/// Two independent standard normal numbers from (seed, counter) by the Box-Muller transform
/// `sqrt(-2 ln u1) * (cos 2 pi u2, sin 2 pi u2)`.
#[inline]
#[must_use]
pub fn normal_pair(seed: u64, counter: u64) -> (f64, f64) {
    let u1 = uniform_open(seed, counter.wrapping_mul(2));
    let u2 = uniform_open(seed, counter.wrapping_mul(2).wrapping_add(1));
    let r = (-2.0 * u1.ln()).sqrt();
    let (s, c) = (std::f64::consts::TAU * u2).sin_cos();
    (r * c, r * s)
}

#[inline]
fn fade(t: f32) -> f32 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

/// 2-D value noise in [0, 1) at (x, y) (lattice spacing 1).
#[inline]
#[must_use]
pub fn value2(x: f32, y: f32, seed: u32) -> f32 {
    let xf = x.floor();
    let yf = y.floor();
    let (ix, iy) = (xf as i32, yf as i32);
    let (tx, ty) = (fade(x - xf), fade(y - yf));
    let a = unit_f32(hash2(ix, iy, seed));
    let b = unit_f32(hash2(ix.wrapping_add(1), iy, seed));
    let c = unit_f32(hash2(ix, iy.wrapping_add(1), seed));
    let d = unit_f32(hash2(ix.wrapping_add(1), iy.wrapping_add(1), seed));
    let ab = a + (b - a) * tx;
    let cd = c + (d - c) * tx;
    ab + (cd - ab) * ty
}

/// Band-limit weight of a feature of wavelength `wavelength_m` seen with pixel footprint
/// `footprint_m`: 1 when the feature spans >= 4 pixels, 0 below 2 pixels, linear between.
#[inline]
#[must_use]
pub fn band_weight(wavelength_m: f32, footprint_m: f32) -> f32 {
    ((wavelength_m / footprint_m.max(1e-9) - 2.0) * 0.5).clamp(0.0, 1.0)
}

/// Fractal value noise in roughly [-0.5, 0.5]: `sum_o gain^o (value2(2.1^o p / scale) - 0.5)`,
/// normalised by the sum of weights, octaves below the pixel footprint faded out.
#[must_use]
pub fn fbm2(x: f32, y: f32, scale_m: f32, octaves: u32, footprint_m: f32, seed: u32) -> f32 {
    let mut freq = 1.0 / scale_m;
    let mut amp = 1.0;
    let mut sum = 0.0;
    let mut norm = 0.0;
    for o in 0..octaves {
        let w = band_weight(1.0 / freq, footprint_m);
        if w <= 0.0 {
            break;
        }
        sum += amp * w * (value2(x * freq, y * freq, seed.wrapping_add(o * 0x9e37)) - 0.5);
        norm += amp;
        freq *= 2.13;
        amp *= 0.55;
    }
    if norm > 0.0 { sum / norm } else { 0.0 }
}

/// Result of [`cellular2`].
#[derive(Clone, Copy, Debug)]
pub struct Cell {
    /// Distance to the nearest feature point (cell units).
    pub f1: f32,
    /// Distance to the second-nearest feature point (cell units).
    pub f2: f32,
    /// Hash of the nearest feature's cell.
    pub id: u32,
}

/// Worley cellular noise on a unit grid with one jittered feature point per cell.
#[must_use]
pub fn cellular2(x: f32, y: f32, seed: u32) -> Cell {
    let xf = x.floor();
    let yf = y.floor();
    let (ix, iy) = (xf as i32, yf as i32);
    let mut f1 = f32::MAX;
    let mut f2 = f32::MAX;
    let mut id = 0;
    for dy in -1..=1 {
        for dx in -1..=1 {
            let cx = ix.wrapping_add(dx);
            let cy = iy.wrapping_add(dy);
            let h = hash2(cx, cy, seed);
            let px = cx as f32 + 0.1 + 0.8 * unit_f32(h);
            let py = cy as f32 + 0.1 + 0.8 * unit_f32(hash_u32(h));
            let d = ((px - x) * (px - x) + (py - y) * (py - y)).sqrt();
            if d < f1 {
                f2 = f1;
                f1 = d;
                id = h;
            } else if d < f2 {
                f2 = d;
            }
        }
    }
    Cell { f1, f2, id }
}

/// Antialiased step: 0 below `edge - w/2`, 1 above `edge + w/2`, linear in between, where
/// `w` is the pixel footprint in the same units as `x`.
#[inline]
#[must_use]
pub fn aa_step(edge: f32, x: f32, w: f32) -> f32 {
    let w = w.max(1e-9);
    ((x - edge) / w + 0.5).clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn value_noise_is_deterministic_and_bounded() {
        for i in 0..1000 {
            let x = i as f32 * 0.37 - 100.0;
            let v = value2(x, x * 0.3, 7);
            assert!((0.0..1.0).contains(&v));
            assert_eq!(v.to_bits(), value2(x, x * 0.3, 7).to_bits());
        }
    }

    #[test]
    fn normal_pair_has_unit_variance() {
        let n = 20_000;
        let mut s = 0.0;
        let mut s2 = 0.0;
        for i in 0..n {
            let (a, b) = normal_pair(42, i);
            s += a + b;
            s2 += a * a + b * b;
        }
        let m = s / (2 * n) as f64;
        let v = s2 / (2 * n) as f64 - m * m;
        assert!(m.abs() < 0.02, "mean {m}");
        assert!((v - 1.0).abs() < 0.03, "var {v}");
    }
}
