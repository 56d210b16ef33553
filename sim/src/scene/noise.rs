//! Counter-based hashing and procedural noise bases (value noise, fbm, cellular noise).
//!
//! Everything here is a pure function of its integer/float arguments and a seed, so textures
//! and sensor noise are identical for any thread count and any evaluation order.
//!
//! * `hash*`: odd-multiplier spreading of the coordinates and one `lowbias32` finaliser
//!   round (Chris Wellons, "Prospecting for hash functions", 2018), and SplitMix64 (Steele et al., OOPSLA 2014)
//!   for 64-bit counters.
//! * Value noise: hashed lattice values in [0, 1) blended with the quintic fade
//!   `6t^5 - 15t^4 + 10t^3` (Perlin, SIGGRAPH 2002). The lattice hash is the spread key
//!   finished by half a `lowbias32` round (one multiply: value noise is the renderer's hot
//!   spot, and only the top 24 bits are used); lattice indices come from the float bits
//!   (exact below `2^22` cells, deterministic wrap beyond).
//! * Cellular noise uses one hash per cell (both jitter coordinates) and squared distances.
//! * fbm: `sum_o g^o * noise(l^o * x)` with lacunarity `l` and gain `g`; octaves whose
//!   wavelength is below twice the pixel footprint fade out (a band limit, so textures do not
//!   alias: the analytic half of the renderer's antialiasing).
//! * Cellular noise: distance to the nearest and second-nearest jittered feature point of a
//!   unit grid (Worley, SIGGRAPH 1996), with the id of the nearest cell.
//!
//! * [`NoiseCache`]: per-thread memo for textures (interpolated low-frequency fbm, cellular
//!   feature points per cell); its results never depend on what it held before.
//!
//! Speed without `unsafe`: fbm octaves and the 9 cells of a cellular lookup are independent,
//! so they are computed in lanes (`[f32; N]` / `[u32; N]` arrays whose element-wise loops
//! the compiler turns into SSE4.1 vectors: `roundps`, `pmulld`, `cvtdq2ps`), and only the
//! final reductions run in the sequential order; results equal the scalar definitions bit
//! for bit (tested).

use rng::splitmix64;

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
        (x as u32).wrapping_mul(SPREAD_X)
            ^ (y as u32).wrapping_mul(SPREAD_Y)
            ^ seed.wrapping_mul(SPREAD_SEED),
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
    // `h >> 8 < 2^24` fits an i32: one signed conversion, same value.
    ((h >> 8) as i32) as f32 * (1.0 / 16_777_216.0)
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

/// Odd multiplier spreading the x lattice coordinate (see [`hash2`]).
const SPREAD_X: u32 = 0xc13f_a9a9;
/// Odd multiplier spreading the y lattice coordinate (see [`hash2`]).
const SPREAD_Y: u32 = 0x91e1_0da5;
/// Odd multiplier spreading the seed (see [`hash2`]).
const SPREAD_SEED: u32 = 0x9e37_79b9;

/// Lattice hash of value noise: the spread key `x K_x ^ y K_y ^ seed K_s` of [`hash2`]
/// finished by one xorshift-multiply-xorshift round (half of `lowbias32`; only the top 24
/// bits are used, and those depend on every key bit).
#[inline(always)]
fn lattice_lanes<const N: usize>(mut x: [u32; N]) -> [u32; N] {
    for v in &mut x {
        *v ^= *v >> 16;
        *v = v.wrapping_mul(LATTICE_MUL);
        *v ^= *v >> 15;
    }
    x
}

/// Multiplier of the value-noise lattice hash (the first `lowbias32` constant).
const LATTICE_MUL: u32 = 0x7feb_352d;

/// 2-D value noise in [0, 1) at (x, y) (lattice spacing 1): bilinear blend (quintic fade)
/// of the four corner values `unit_f32(lattice hash)`.
#[inline]
#[must_use]
pub fn value2(x: f32, y: f32, seed: u32) -> f32 {
    let xf = x.floor();
    let yf = y.floor();
    let (ix, iy) = (lattice_index(xf), lattice_index(yf));
    let (tx, ty) = (fade(x - xf), fade(y - yf));
    let s = seed.wrapping_mul(SPREAD_SEED);
    let x0 = ix.wrapping_mul(SPREAD_X);
    let x1 = ix.wrapping_add(1).wrapping_mul(SPREAD_X);
    let y0 = iy.wrapping_mul(SPREAD_Y) ^ s;
    let y1 = iy.wrapping_add(1).wrapping_mul(SPREAD_Y) ^ s;
    let [a, b, c, d] = lattice_lanes([x0 ^ y0, x1 ^ y0, x0 ^ y1, x1 ^ y1]).map(unit_f32);
    let ab = a + (b - a) * tx;
    let cd = c + (d - c) * tx;
    ab + (cd - ab) * ty
}

/// Band-limit weight of a feature of wavelength `wavelength_m` seen at `px_per_m` pixels
/// per metre of surface (the reciprocal of the pixel footprint): 1 when the feature spans
/// >= 4 pixels, 0 below 2 pixels, linear between.
#[inline]
#[must_use]
pub fn band_weight(wavelength_m: f32, px_per_m: f32) -> f32 {
    ((wavelength_m * px_per_m - 2.0) * 0.5).clamp(0.0, 1.0)
}

/// Frequency ratio of successive fbm octaves.
const LACUNARITY: f32 = 2.13;
/// Amplitude ratio of successive fbm octaves.
const GAIN: f32 = 0.55;

/// `1.5 * 2^23`: adding it to an integral f32 of magnitude below `2^22` leaves the integer
/// in the low mantissa bits (a branch-free, saturation-free float-to-int for the lattice).
const INT_MAGIC: f32 = 12_582_912.0;

/// Lattice index of an integral float (`floor` output) as wrapping u32; exact for
/// `|xf| < 2^22` (lattice coordinates beyond that wrap deterministically).
#[inline(always)]
pub(crate) fn lattice_index(xf: f32) -> u32 {
    (xf + INT_MAGIC).to_bits().wrapping_sub(INT_MAGIC.to_bits())
}

/// Octaves evaluated together in one lane group of [`fbm2`] (4 or 8 lanes: one or two SSE
/// vectors).
const FBM_LANES_SMALL: usize = 4;
/// Lanes of the wide group of [`fbm2`] (5 to 8 octaves).
const FBM_LANES_WIDE: usize = 8;

/// Fractal value noise in roughly [-0.5, 0.5]: `sum_o gain^o (value2(2.13^o p / scale) - 0.5)`,
/// normalised by the sum of weights, octaves shorter than two pixels (at `px_per_m` pixels
/// per metre) faded out.
///
/// The octaves are independent value-noise lookups, so they are evaluated side by side in
/// lanes (`[f32; N]` arrays the compiler maps to SSE vectors: floor, lattice hash, fade
/// and blend of up to 8 octaves at once); the weighted sum is then taken in octave order,
/// so the result equals the octave-by-octave loop bit for bit.
#[inline(always)]
#[must_use]
pub fn fbm2(x: f32, y: f32, scale_m: f32, octaves: u32, px_per_m: f32, seed: u32) -> f32 {
    let mut acc = FbmAcc {
        freq: 1.0 / scale_m,
        // Octave wavelength in pixels (the band_weight argument).
        wavelength_px: scale_m * px_per_m,
        amp: 1.0,
        sum: 0.0,
        norm: 0.0,
    };
    if octaves as usize <= FBM_LANES_SMALL {
        fbm_lanes::<FBM_LANES_SMALL>(x, y, 0, octaves, seed, &mut acc);
    } else {
        let mut o = 0;
        while o < octaves && fbm_lanes::<FBM_LANES_WIDE>(x, y, o, octaves - o, seed, &mut acc) {
            o += FBM_LANES_WIDE as u32;
        }
    }
    if acc.norm > 0.0 {
        acc.sum / acc.norm
    } else {
        0.0
    }
}

/// Running state of [`fbm2`] across lane groups.
struct FbmAcc {
    freq: f32,
    wavelength_px: f32,
    amp: f32,
    sum: f32,
    norm: f32,
}

/// Octaves `first .. first + min(count, N)` of [`fbm2`] in `N` lanes; returns whether all
/// `N` were in band and more remain (another group is needed).
#[inline(always)]
fn fbm_lanes<const N: usize>(
    x: f32,
    y: f32,
    first: u32,
    count: u32,
    seed: u32,
    acc: &mut FbmAcc,
) -> bool {
    // Per-octave constants by the same running products as a sequential loop, so every
    // frequency and weight has the sequential loop's bits.
    let mut freq = [0.0_f32; N];
    let mut wl = [0.0_f32; N];
    let mut amp = [0.0_f32; N];
    for i in 0..N {
        freq[i] = acc.freq;
        wl[i] = acc.wavelength_px;
        amp[i] = acc.amp;
        acc.freq *= LACUNARITY;
        acc.wavelength_px *= 1.0 / LACUNARITY;
        acc.amp *= GAIN;
    }
    // The wavelengths fall with the octave, so the in-band octaves are a prefix (the
    // sequential loop's early exit).
    let mut weight = [0.0_f32; N];
    let mut xs = [0.0_f32; N];
    let mut ys = [0.0_f32; N];
    let mut seeds = [0_u32; N];
    let mut active = [false; N];
    for i in 0..N {
        let w = ((wl[i] - 2.0) * 0.5).clamp(0.0, 1.0);
        active[i] = (i as u32) < count && w > 0.0;
        weight[i] = if active[i] { amp[i] * w } else { 0.0 };
        xs[i] = x * freq[i];
        ys[i] = y * freq[i];
        seeds[i] = seed.wrapping_add((first + i as u32).wrapping_mul(0x9e37));
    }
    let v = value_lanes(xs, ys, seeds);
    for i in 0..N {
        // Inactive lanes add +0.0, which changes no sum.
        acc.norm += if active[i] { amp[i] } else { 0.0 };
        acc.sum += weight[i] * (v[i] - 0.5);
    }
    active[N - 1] && count as usize > N
}

/// [`value2`] of `N` points at once, lane by lane the same operations (and bits).
#[inline(always)]
pub(crate) fn value_lanes<const N: usize>(x: [f32; N], y: [f32; N], seed: [u32; N]) -> [f32; N] {
    let mut out = [0.0_f32; N];
    for i in 0..N {
        let xf = x[i].floor();
        let yf = y[i].floor();
        let (ix, iy) = (lattice_index(xf), lattice_index(yf));
        let (tx, ty) = (fade(x[i] - xf), fade(y[i] - yf));
        let s = seed[i].wrapping_mul(SPREAD_SEED);
        let x0 = ix.wrapping_mul(SPREAD_X);
        let x1 = ix.wrapping_add(1).wrapping_mul(SPREAD_X);
        let y0 = iy.wrapping_mul(SPREAD_Y) ^ s;
        let y1 = iy.wrapping_add(1).wrapping_mul(SPREAD_Y) ^ s;
        let a = unit_f32(lattice_hash(x0 ^ y0));
        let b = unit_f32(lattice_hash(x1 ^ y0));
        let c = unit_f32(lattice_hash(x0 ^ y1));
        let d = unit_f32(lattice_hash(x1 ^ y1));
        let ab = a + (b - a) * tx;
        let cd = c + (d - c) * tx;
        out[i] = ab + (cd - ab) * ty;
    }
    out
}

/// [`fbm2`] at `N` points sharing scale, octaves and seed: lane `i` equals
/// `fbm2(x[i], y[i], scale_m, octaves, px_per_m[i], seed)` bit for bit. The octaves run in
/// the sequential order, each one `N`-lane value-noise lookup (a texture evaluated at `N`
/// pixels at once; no memo, so nothing depends on the order of the points).
#[inline(always)]
#[must_use]
pub(crate) fn fbm2_points<const N: usize>(
    x: [f32; N],
    y: [f32; N],
    scale_m: f32,
    octaves: u32,
    px_per_m: [f32; N],
    seed: u32,
) -> [f32; N] {
    let mut freq = 1.0 / scale_m;
    let mut wavelength_px = px_per_m.map(|p| scale_m * p);
    let mut amp = 1.0_f32;
    let mut sum = [0.0_f32; N];
    let mut norm = [0.0_f32; N];
    for o in 0..octaves {
        let mut xs = [0.0_f32; N];
        let mut ys = [0.0_f32; N];
        for i in 0..N {
            xs[i] = x[i] * freq;
            ys[i] = y[i] * freq;
        }
        let v = value_lanes(xs, ys, [seed.wrapping_add(o.wrapping_mul(0x9e37)); N]);
        for i in 0..N {
            // Wavelengths fall with the octave, so a lane's in-band octaves are a prefix
            // (the sequential loop's early exit); the others add +0.0, which changes no sum.
            let w = ((wavelength_px[i] - 2.0) * 0.5).clamp(0.0, 1.0);
            let active = w > 0.0;
            sum[i] += if active { amp * w * (v[i] - 0.5) } else { 0.0 };
            norm[i] += if active { amp } else { 0.0 };
            wavelength_px[i] *= 1.0 / LACUNARITY;
        }
        freq *= LACUNARITY;
        amp *= GAIN;
    }
    let mut out = [0.0_f32; N];
    for i in 0..N {
        out[i] = if norm[i] > 0.0 { sum[i] / norm[i] } else { 0.0 };
    }
    out
}

/// The nearest feature point of [`cellular2`] at `N` points sharing a seed: lane `i` holds
/// `(f1, id)` of `cellular2(x[i], y[i], seed)` bit for bit. Each point's 3x3 neighbourhood
/// is scanned in row-major order, one cell per `N`-lane step.
#[inline(always)]
#[must_use]
pub(crate) fn cellular_nearest_points<const N: usize>(
    x: [f32; N],
    y: [f32; N],
    seed: u32,
) -> ([f32; N], [u32; N]) {
    let s = seed.wrapping_mul(SPREAD_SEED);
    let mut ix = [0_u32; N];
    let mut iy = [0_u32; N];
    let mut fx = [0.0_f32; N];
    let mut fy = [0.0_f32; N];
    for i in 0..N {
        let (xf, yf) = (x[i].floor(), y[i].floor());
        (ix[i], iy[i]) = (lattice_index(xf), lattice_index(yf));
        (fx[i], fy[i]) = (x[i] - xf, y[i] - yf);
    }
    let mut best = [f32::MAX; N];
    let mut id = [0_u32; N];
    for k in 0..CELLS {
        for i in 0..N {
            let kx = ix[i].wrapping_add(CELL_DX[k]).wrapping_mul(SPREAD_X);
            let ky = iy[i].wrapping_add(CELL_DY[k]).wrapping_mul(SPREAD_Y) ^ s;
            let h = hash_u32(kx ^ ky);
            let ex = CELL_X[k] + 0.8 * jitter16(h & 0xffff) - fx[i];
            let ey = CELL_Y[k] + 0.8 * jitter16(h >> 16) - fy[i];
            let d = ex * ex + ey * ey;
            // Strictly nearer: the first cell attaining the minimum keeps it.
            let nearer = d < best[i];
            best[i] = if nearer { d } else { best[i] };
            id[i] = if nearer { h } else { id[i] };
        }
    }
    (best.map(f32::sqrt), id)
}

/// One lane of [`lattice_lanes`].
#[inline(always)]
fn lattice_hash(mut v: u32) -> u32 {
    v ^= v >> 16;
    v = v.wrapping_mul(LATTICE_MUL);
    v ^ (v >> 15)
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

/// Worley cellular noise on a unit grid with one jittered feature point per cell: the
/// point of cell `c` is `c + 0.1 + 0.8 (lo16(h), hi16(h)) / 2^16` with `h = hash2(c, seed)`
/// (one hash per cell); distances are compared squared and rooted once.
///
/// The 9 cells of the 3x3 neighbourhood are hashed and measured in lanes; `f1` is the lane
/// minimum, `id` the hash of the first cell (row-major) attaining it and `f2` the minimum
/// of the other lanes, exactly what the sequential scan would keep.
#[must_use]
pub fn cellular2(x: f32, y: f32, seed: u32) -> Cell {
    let xf = x.floor();
    let yf = y.floor();
    let pts = cell_points(lattice_index(xf), lattice_index(yf), seed);
    nearest_points(&pts, x - xf, y - yf)
}

/// Feature points of the 3x3 cells around lattice cell `(ix, iy)` (relative to its corner,
/// lane `i = 3 dy + dx`, padded to [`CELL_LANES`]) and their cell hashes.
#[derive(Clone, Copy, Debug)]
struct CellPoints {
    px: [[f32; 4]; 3],
    py: [[f32; 4]; 3],
    h: [u32; CELL_LANES],
}

#[inline(always)]
fn cell_points(ix: u32, iy: u32, seed: u32) -> CellPoints {
    let s = seed.wrapping_mul(SPREAD_SEED);
    // Cell keys in lanes (3 SSE vectors; the last 3 lanes are padding and never win).
    let mut key = [0_u32; CELL_LANES];
    for i in 0..CELL_LANES {
        let kx = ix.wrapping_add(CELL_DX[i]).wrapping_mul(SPREAD_X);
        let ky = iy.wrapping_add(CELL_DY[i]).wrapping_mul(SPREAD_Y) ^ s;
        key[i] = kx ^ ky;
    }
    let h = key.map(hash_u32);
    let mut px = [[0.0_f32; 4]; 3];
    let mut py = [[0.0_f32; 4]; 3];
    for i in 0..CELL_LANES {
        // Padding lanes sit far away (squared distance ~1e36, finite): they never win.
        let pad = if i < CELLS { 0.0 } else { CELL_PAD_OFFSET };
        px[i / 4][i % 4] = CELL_X[i] + 0.8 * jitter16(h[i] & 0xffff) + pad;
        py[i / 4][i % 4] = CELL_Y[i] + 0.8 * jitter16(h[i] >> 16);
    }
    CellPoints { px, py, h }
}

/// Squared distances from `(fx, fy)` to the feature points of `pts` (padding lanes ~1e36).
#[inline(always)]
fn squared_distances(pts: &CellPoints, fx: f32, fy: f32) -> [[f32; 4]; 3] {
    // Three groups of four lanes (one SSE vector each).
    let mut d = [[0.0_f32; 4]; 3];
    for ((dg, xg), yg) in d.iter_mut().zip(&pts.px).zip(&pts.py) {
        for ((dl, x), y) in dg.iter_mut().zip(xg).zip(yg) {
            let (ex, ey) = (x - fx, y - fy);
            *dl = ex * ex + ey * ey;
        }
    }
    d
}

/// Least lane of `d` (exact in any order: lane-wise over the groups, then across lanes).
#[inline(always)]
fn min_lane(d: &[[f32; 4]; 3]) -> f32 {
    let lt = |a: f32, b: f32| if a < b { a } else { b };
    let mut m = [0.0_f32; 4];
    for l in 0..4 {
        m[l] = lt(lt(d[0][l], d[1][l]), d[2][l]);
    }
    lt(lt(m[0], m[2]), lt(m[1], m[3]))
}

/// Bit mask of the lanes of `d` equal to `f1` (lane `4 g + l` is bit `4 g + l`).
#[inline(always)]
fn lanes_equal(d: &[[f32; 4]; 3], f1: f32) -> u32 {
    let mut equal = 0_u32;
    for (g, dg) in d.iter().enumerate() {
        for (l, &v) in dg.iter().enumerate() {
            equal |= u32::from(v == f1) << (4 * g + l);
        }
    }
    equal
}

/// The first lane of a [`lanes_equal`] mask: the nearest cell in row-major order, as the
/// sequential scan keeps it.
#[inline(always)]
fn first_lane(equal: u32) -> usize {
    (equal.trailing_zeros() as usize).min(CELL_LANES - 1)
}

/// [`Cell`] of the position `(fx, fy)` within the centre cell of `pts`.
#[inline(always)]
fn nearest_points(pts: &CellPoints, fx: f32, fy: f32) -> Cell {
    let d = squared_distances(pts, fx, fy);
    let f1 = min_lane(&d);
    let equal = lanes_equal(&d, f1);
    let k = first_lane(equal);
    let mut above = d;
    for a in above.iter_mut().flatten() {
        *a = if *a > f1 { *a } else { f32::MAX };
    }
    // Second nearest: f1 again if another lane ties with it, else the least of the rest.
    let f2 = if equal.count_ones() >= 2 {
        f1
    } else {
        min_lane(&above)
    };
    Cell {
        f1: f1.sqrt(),
        f2: f2.sqrt(),
        id: pts.h[k],
    }
}

/// Cells of the 3x3 neighbourhood searched by [`cellular2`].
const CELLS: usize = 9;
/// Lanes of [`cellular2`]: the 9 cells padded to a multiple of 4.
const CELL_LANES: usize = 12;
/// x offset of the padding lanes' feature points (cell units): far enough never to be
/// nearest or second nearest, near enough that the squared distance stays finite in f32.
const CELL_PAD_OFFSET: f32 = 1e18;
/// Lattice step `dx - 1` of lane `i = 3 dy + dx` (wrapping u32).
const CELL_DX: [u32; CELL_LANES] = cell_steps(true);
/// Lattice step `dy - 1` of lane `i = 3 dy + dx` (wrapping u32).
const CELL_DY: [u32; CELL_LANES] = cell_steps(false);
/// `dx - 0.9` of lane `i = 3 dy + dx` (feature point x offset before jitter, relative to
/// the centre cell's corner).
const CELL_X: [f32; CELL_LANES] = cell_offsets(true);
/// `dy - 0.9` of lane `i = 3 dy + dx`.
const CELL_Y: [f32; CELL_LANES] = cell_offsets(false);

const fn cell_steps(x: bool) -> [u32; CELL_LANES] {
    let mut out = [0; CELL_LANES];
    let mut i = 0;
    while i < CELL_LANES {
        let k = if x { i % 3 } else { i / 3 };
        out[i] = (k as u32).wrapping_sub(1);
        i += 1;
    }
    out
}

const fn cell_offsets(x: bool) -> [f32; CELL_LANES] {
    let mut out = [0.0; CELL_LANES];
    let mut i = 0;
    while i < CELL_LANES {
        let k = if x { i % 3 } else { i / 3 };
        out[i] = k as f32 - 0.9;
        i += 1;
    }
    out
}

/// Samples per wavelength of the finest octave on the grid of [`NoiseCache::fbm2`].
pub const SMOOTH_SAMPLES_PER_WAVELENGTH: f32 = 8.0;
/// Finest octave wavelength, in pixel footprints, from which [`NoiseCache::fbm2`]
/// interpolates (grid cells of at least 8 pixels, so a cell serves dozens of pixels).
pub const SMOOTH_MIN_WAVELENGTH_PX: f32 = 64.0;
/// Slots of the interpolated-fbm memo (direct-mapped; a power of two).
const SMOOTH_SLOTS: usize = 32;
/// Slots of the cellular-neighbourhood memo (direct-mapped; a power of two).
const CELL_SLOTS: usize = 8;

/// Memo of noise evaluations that neighbouring pixels share, one per thread.
///
/// * Low-frequency fbm ([`Self::fbm2`]): when even the finest octave spans at least
///   [`SMOOTH_MIN_WAVELENGTH_PX`] pixel footprints, the fbm is the bilinear interpolation
///   of its values on a grid of [`SMOOTH_SAMPLES_PER_WAVELENGTH`] samples per finest
///   wavelength (all octaves in band). Interpolating a band-limited function sampled 8
///   times per shortest wavelength errs by at most `(pi/8)^2/2 ~ 8 %` of that octave's
///   amplitude (`h^2/8 max|f''|`; the finest octave holds under a fifth of the fbm's
///   amplitude): below a grey level for every texture contrast here. A grid cell covers at
///   least 8x8 pixels, so its four corners are evaluated once and reused.
/// * Cellular noise ([`Self::cellular2`]): the 9 feature points around a lattice cell are
///   hashed once per cell; every pixel in the cell only measures distances. Bit-identical
///   to [`cellular2`].
///
/// Every value is a pure function of its arguments (entries are keyed by all of them), so
/// results never depend on what the memo held before: any evaluation order and thread
/// count gives the same bytes.
#[derive(Clone, Debug)]
pub struct NoiseCache {
    smooth: [SmoothSlot; SMOOTH_SLOTS],
    cells: [CellSlot; CELL_SLOTS],
}

/// Key of an interpolated-fbm grid cell: seed, scale bits, octaves, cell indices.
type SmoothKey = (u32, u32, u32, u32, u32);

#[derive(Clone, Copy, Debug)]
struct SmoothSlot {
    key: Option<SmoothKey>,
    /// fbm at the corners (ix, iy), (ix+1, iy), (ix, iy+1), (ix+1, iy+1).
    corners: [f32; 4],
}

#[derive(Clone, Copy, Debug)]
struct CellSlot {
    key: Option<(u32, u32, u32)>,
    points: CellPoints,
}

impl SmoothSlot {
    /// Evaluates the cell with lower-left grid node `node` (grid step `step_m`), all octaves
    /// in band (infinite pixel density). Out of line: the rare miss stays off the hot path.
    #[cold]
    #[inline(never)]
    fn refill(
        &mut self,
        key: SmoothKey,
        node: [f32; 2],
        step_m: f32,
        scale_m: f32,
        octaves: u32,
        seed: u32,
    ) {
        let at = |i: f32, j: f32| {
            fbm2(
                i * step_m,
                j * step_m,
                scale_m,
                octaves,
                f32::INFINITY,
                seed,
            )
        };
        let [xf, yf] = node;
        self.corners = [
            at(xf, yf),
            at(xf + 1.0, yf),
            at(xf, yf + 1.0),
            at(xf + 1.0, yf + 1.0),
        ];
        self.key = Some(key);
    }
}

impl CellSlot {
    /// Hashes the feature points around lattice cell `key = (seed, ix, iy)`.
    #[cold]
    #[inline(never)]
    fn refill(&mut self, key: (u32, u32, u32)) {
        let (seed, ix, iy) = key;
        self.points = cell_points(ix, iy, seed);
        self.key = Some(key);
    }
}

impl Default for NoiseCache {
    fn default() -> Self {
        Self::new()
    }
}

impl NoiseCache {
    /// An empty memo.
    #[must_use]
    pub fn new() -> Self {
        Self {
            smooth: [SmoothSlot {
                key: None,
                corners: [0.0; 4],
            }; SMOOTH_SLOTS],
            cells: [CellSlot {
                key: None,
                points: CellPoints {
                    px: [[0.0; 4]; 3],
                    py: [[0.0; 4]; 3],
                    h: [0; CELL_LANES],
                },
            }; CELL_SLOTS],
        }
    }

    /// [`fbm2`] for texturing: interpolated from a grid when all octaves are far above the
    /// pixel footprint (see the type docs), else evaluated directly.
    #[inline(always)]
    pub fn fbm2(
        &mut self,
        x: f32,
        y: f32,
        scale_m: f32,
        octaves: u32,
        px_per_m: f32,
        seed: u32,
    ) -> f32 {
        let Some(finest_m) = octaves
            .checked_sub(1)
            .and_then(|o| FINEST_WAVELENGTH.get(o as usize))
            .map(|k| scale_m * k)
        else {
            return fbm2(x, y, scale_m, octaves, px_per_m, seed);
        };
        // (A NaN density also takes the direct path.)
        let smooth = finest_m * px_per_m >= SMOOTH_MIN_WAVELENGTH_PX;
        if !smooth {
            return fbm2(x, y, scale_m, octaves, px_per_m, seed);
        }
        let step_m = finest_m * (1.0 / SMOOTH_SAMPLES_PER_WAVELENGTH);
        let inv_step = 1.0 / step_m;
        let (gx, gy) = (x * inv_step, y * inv_step);
        let (xf, yf) = (gx.floor(), gy.floor());
        let (tx, ty) = (gx - xf, gy - yf);
        let (ix, iy) = (lattice_index(xf), lattice_index(yf));
        let key = (seed, scale_m.to_bits(), octaves, ix, iy);
        let slot = (hash_u32(
            ix.wrapping_mul(SPREAD_X) ^ iy.wrapping_mul(SPREAD_Y) ^ seed ^ scale_m.to_bits(),
        ) as usize)
            % SMOOTH_SLOTS;
        let entry = &mut self.smooth[slot];
        if entry.key != Some(key) {
            entry.refill(key, [xf, yf], step_m, scale_m, octaves, seed);
        }
        let [a, b, c, d] = entry.corners;
        let ab = a + (b - a) * tx;
        let cd = c + (d - c) * tx;
        ab + (cd - ab) * ty
    }

    /// [`cellular2`] with the cell's feature points memoised (bit-identical).
    #[inline]
    pub fn cellular2(&mut self, x: f32, y: f32, seed: u32) -> Cell {
        let (pts, fx, fy) = self.cell_points_at(x, y, seed);
        nearest_points(pts, fx, fy)
    }

    /// The memoised feature points around the lattice cell of `(x, y)` and the position
    /// within that cell.
    #[inline(always)]
    fn cell_points_at(&mut self, x: f32, y: f32, seed: u32) -> (&CellPoints, f32, f32) {
        let xf = x.floor();
        let yf = y.floor();
        let (ix, iy) = (lattice_index(xf), lattice_index(yf));
        let key = (seed, ix, iy);
        let slot = (hash_u32(ix.wrapping_mul(SPREAD_X) ^ iy.wrapping_mul(SPREAD_Y) ^ seed)
            as usize)
            % CELL_SLOTS;
        let entry = &mut self.cells[slot];
        if entry.key != Some(key) {
            entry.refill(key);
        }
        (&entry.points, x - xf, y - yf)
    }
}

/// Wavelength of octave `o` relative to the first: `LACUNARITY^-o` (the running product
/// of the fbm loop).
const FINEST_WAVELENGTH: [f32; FBM_MAX_OCTAVES_SMOOTH] = finest_wavelengths();
/// Octave counts [`NoiseCache::fbm2`] may interpolate.
const FBM_MAX_OCTAVES_SMOOTH: usize = 12;

const fn finest_wavelengths() -> [f32; FBM_MAX_OCTAVES_SMOOTH] {
    let mut out = [0.0; FBM_MAX_OCTAVES_SMOOTH];
    let mut k = 1.0_f32;
    let mut o = 0;
    while o < FBM_MAX_OCTAVES_SMOOTH {
        out[o] = k;
        k *= 1.0 / LACUNARITY;
        o += 1;
    }
    out
}

/// A 16-bit value as a float in [0, 1).
#[inline(always)]
fn jitter16(h: u32) -> f32 {
    (h as i32) as f32 * (1.0 / 65_536.0)
}

/// Antialiased step: 0 below `edge - w/2`, 1 above `edge + w/2`, linear in between, where
/// `w = 1 / px_per_unit` is one pixel in the units of `x`.
#[inline]
#[must_use]
pub fn aa_step(edge: f32, x: f32, px_per_unit: f32) -> f32 {
    ((x - edge) * px_per_unit + 0.5).clamp(0.0, 1.0)
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
    fn lane_hashes_match_the_scalar_hash() {
        for i in -50..50 {
            let (x, y) = (i as f32 * 0.731 + 0.2, i as f32 * -1.37 + 0.4);
            let (ix, iy) = (x.floor() as i32, y.floor() as i32);
            let (tx, ty) = (fade(x - x.floor()), fade(y - y.floor()));
            let corner = |dx: i32, dy: i32| {
                let k = ((ix + dx) as u32).wrapping_mul(SPREAD_X)
                    ^ ((iy + dy) as u32).wrapping_mul(SPREAD_Y)
                    ^ 99u32.wrapping_mul(SPREAD_SEED);
                unit_f32(lattice_lanes([k])[0])
            };
            let ab = corner(0, 0) + (corner(1, 0) - corner(0, 0)) * tx;
            let cd = corner(0, 1) + (corner(1, 1) - corner(0, 1)) * tx;
            assert_eq!(value2(x, y, 99).to_bits(), (ab + (cd - ab) * ty).to_bits());
            let c = cellular2(x, y, 5);
            assert!(c.f1 <= c.f2 && c.f1 >= 0.0 && c.f2 < 2.0, "{c:?}");
            let near = (-1..=1)
                .flat_map(|dy| (-1..=1).map(move |dx| (dx, dy)))
                .map(|(dx, dy)| {
                    let h = hash2(ix + dx, iy + dy, 5);
                    let px = (ix + dx) as f32 + 0.1 + 0.8 * jitter16(h & 0xffff);
                    let py = (iy + dy) as f32 + 0.1 + 0.8 * jitter16(h >> 16);
                    ((px - x).hypot(py - y), h)
                })
                .fold((f32::MAX, 0), |a, b| if b.0 < a.0 { b } else { a });
            assert_eq!(c.id, near.1);
            assert!((c.f1 - near.0).abs() < 1e-4, "{} {}", c.f1, near.0);
        }
    }

    /// The sequential definitions the lane versions must reproduce bit for bit.
    fn fbm2_sequential(x: f32, y: f32, scale_m: f32, octaves: u32, ppm: f32, seed: u32) -> f32 {
        let mut freq = 1.0 / scale_m;
        let mut wavelength_px = scale_m * ppm;
        let (mut amp, mut sum, mut norm) = (1.0, 0.0, 0.0);
        for o in 0..octaves {
            let w = ((wavelength_px - 2.0) * 0.5).clamp(0.0, 1.0);
            if w <= 0.0 {
                break;
            }
            sum += amp * w * (value2(x * freq, y * freq, seed.wrapping_add(o * 0x9e37)) - 0.5);
            norm += amp;
            freq *= LACUNARITY;
            wavelength_px *= 1.0 / LACUNARITY;
            amp *= GAIN;
        }
        if norm > 0.0 { sum / norm } else { 0.0 }
    }

    fn cellular2_sequential(x: f32, y: f32, seed: u32) -> Cell {
        let (xf, yf) = (x.floor(), y.floor());
        let (fx, fy) = (x - xf, y - yf);
        let (ix, iy) = (lattice_index(xf), lattice_index(yf));
        let s = seed.wrapping_mul(SPREAD_SEED);
        let (mut f1, mut f2, mut id) = (f32::MAX, f32::MAX, 0);
        for dy in 0..3_u32 {
            let ky = iy.wrapping_add(dy).wrapping_sub(1).wrapping_mul(SPREAD_Y) ^ s;
            for dx in 0..3_u32 {
                let h = hash_u32(ix.wrapping_add(dx).wrapping_sub(1).wrapping_mul(SPREAD_X) ^ ky);
                let px = dx as f32 - 0.9 + 0.8 * jitter16(h & 0xffff);
                let py = dy as f32 - 0.9 + 0.8 * jitter16(h >> 16);
                let d = (px - fx) * (px - fx) + (py - fy) * (py - fy);
                if d < f1 {
                    (f2, f1, id) = (f1, d, h);
                } else if d < f2 {
                    f2 = d;
                }
            }
        }
        Cell {
            f1: f1.sqrt(),
            f2: f2.sqrt(),
            id,
        }
    }

    #[test]
    fn lane_fbm_and_cellular_equal_the_sequential_definitions_bit_for_bit() {
        for i in 0..4000_u32 {
            let x = (i as f32 * 0.618_034).fract() * 3.0 - 1.0 + (i / 97) as f32 * 11.3;
            let y = (i as f32 * 0.414_214).fract() * 2.0 - 0.7 - (i / 131) as f32 * 7.1;
            // Footprints from far below to far above the octave wavelengths, so every
            // band-limit cut-off (0 .. all octaves) occurs.
            let ppm = 1e5 / 1.7_f32.powi((i % 23) as i32);
            for octaves in 0..=10 {
                let a = fbm2(x, y, 0.3, octaves, ppm, i);
                let b = fbm2_sequential(x, y, 0.3, octaves, ppm, i);
                assert_eq!(
                    a.to_bits(),
                    b.to_bits(),
                    "fbm x {x} y {y} o {octaves} ppm {ppm}"
                );
            }
            for octaves in 0..=6 {
                let p = fbm2_points(
                    [x, x + 0.3],
                    [y, y - 0.2],
                    0.3,
                    octaves,
                    [ppm, 2.0 * ppm],
                    i,
                );
                let q = [
                    fbm2_sequential(x, y, 0.3, octaves, ppm, i),
                    fbm2_sequential(x + 0.3, y - 0.2, 0.3, octaves, 2.0 * ppm, i),
                ];
                assert_eq!(
                    p.map(f32::to_bits),
                    q.map(f32::to_bits),
                    "points o {octaves}"
                );
            }
            let (c, r) = (cellular2(x, y, i), cellular2_sequential(x, y, i));
            assert_eq!(
                (c.f1.to_bits(), c.f2.to_bits(), c.id),
                (r.f1.to_bits(), r.f2.to_bits(), r.id)
            );
            let (f1, id) = cellular_nearest_points([x, y], [y, x], i);
            let r2 = cellular2_sequential(y, x, i);
            assert_eq!((f1[0].to_bits(), id[0]), (r.f1.to_bits(), r.id));
            assert_eq!((f1[1].to_bits(), id[1]), (r2.f1.to_bits(), r2.id));
        }
    }

    #[test]
    fn memoised_noise_does_not_depend_on_the_memo_and_stays_close_to_the_direct_noise() {
        // Two memos: one fresh per query, one shared across a scan that revisits cells
        // and interleaves seeds and scales (collisions in the direct-mapped slots).
        let mut shared = NoiseCache::new();
        let mut worst = 0.0_f32;
        let mut smooth = 0;
        for i in 0..20_000_u32 {
            let x = (i % 200) as f32 * 0.000_31 + (i / 4000) as f32 * 0.7;
            let y = ((i / 200) % 20) as f32 * 0.000_29 - 0.3;
            let seed = i % 3;
            let ppm = [10_000.0, 3_333.3, 333.3][(i % 7 % 3) as usize];
            for (scale, octaves) in [(0.3, 3), (0.12, 2), (0.012, 2), (0.06, 5)] {
                let a = shared.fbm2(x, y, scale, octaves, ppm, seed);
                let b = NoiseCache::new().fbm2(x, y, scale, octaves, ppm, seed);
                assert_eq!(a.to_bits(), b.to_bits(), "memo state leaked into fbm");
                let exact = fbm2(x, y, scale, octaves, ppm, seed);
                let finest = scale / LACUNARITY.powi(octaves as i32 - 1);
                if finest * ppm >= SMOOTH_MIN_WAVELENGTH_PX {
                    smooth += 1;
                    worst = worst.max((a - exact).abs());
                } else {
                    assert_eq!(a.to_bits(), exact.to_bits());
                }
            }
            let c = shared.cellular2(x / 0.005, y / 0.005, seed);
            let r = cellular2(x / 0.005, y / 0.005, seed);
            assert_eq!(
                (c.f1.to_bits(), c.f2.to_bits(), c.id),
                (r.f1.to_bits(), r.f2.to_bits(), r.id)
            );
        }
        assert!(
            smooth > 10_000,
            "the interpolated path was exercised ({smooth})"
        );
        // fbm spans about [-0.5, 0.5]; the interpolation error bound is a few 1e-3.
        assert!(worst < 0.01, "interpolated fbm off by {worst}");
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
