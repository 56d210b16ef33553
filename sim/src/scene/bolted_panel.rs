//! The bolted-panel texture ([`Texture::BoltedPanel`](super::Texture::BoltedPanel)) at `N`
//! surface points at once: the equipment boxes and cabinet doors that fill the wrist
//! camera's view during calibration, so the renderer's hottest texture.
//!
//! Panels `5 x 4` bolt pitches with dark seams, a tone per panel, bolts along the panel
//! borders (washer, domed head lit from the upper left, dark rim), low-frequency mottling
//! and grime (fbm), rust streaks running down from the bolts, and paint chips (cellular
//! flakes where a low-frequency mask is high). Every feature is band-limited by the pixel
//! density `px_per_m` (see [`band_weight`] and [`aa_step`]).
//!
//! The points are lanes: every step is an element-wise loop over `[f32; N]` / `[u32; N]`
//! arrays, branches are selects, and the noise comes from the point-lane functions of
//! [`noise`](super::noise) (no memo), so the compiler turns the kernel into SSE vector code
//! over the pixels of a tile, and lane `i` of any `N` is the same function of point `i`
//! bit for bit (`N = 1` is the scalar texture; tested).

use super::noise::{
    aa_step, band_weight, cellular_nearest_points, fbm2_points, hash_u32, hash2, unit_f32,
    value_lanes,
};

/// Surface points of one texture lookup batch, one per lane.
#[derive(Clone, Copy, Debug)]
pub struct TexelLanes<const N: usize> {
    /// Texture coordinate u (m, wrapped to the texture period).
    pub u: [f32; N],
    /// Texture coordinate v (m, wrapped).
    pub v: [f32; N],
    /// Pixel density on the surface (pixels per metre, clamped to the finest).
    pub px_per_m: [f32; N],
    /// Texture seed of the point's material and face.
    pub seed: [u32; N],
}

impl<const N: usize> Default for TexelLanes<N> {
    fn default() -> Self {
        Self {
            u: [0.0; N],
            v: [0.0; N],
            px_per_m: [0.0; N],
            seed: [0; N],
        }
    }
}

/// Linear rust colour of the streaks (and of [`super::textures`]' rust stains).
pub const RUST_RGB: [f32; 3] = [0.23, 0.09, 0.035];
/// Colour of bare metal under a paint chip.
const CHIP_RGB: [f32; 3] = [0.07, 0.07, 0.065];
/// Streak profiles `exp(x)` with `x` below minus this are no streak (1e-4: under a
/// thousandth of a grey level once mixed).
const STREAK_MIN_EXPONENT: f32 = 9.0;
/// Wavelength of the noise perturbing paint-chip outlines (m).
pub const CHIP_OUTLINE_M: f32 = 0.0012;
/// Paint-chip lattice cell (m): 2-6 mm flakes.
const CHIP_CELL_M: f32 = 0.005;
/// Fraction of chip-mask area that flakes (0..1).
const CHIP_AMOUNT: f32 = 0.5;

/// Albedo (linear RGB, 0..1) of a bolted panel of base colour `b`, bolt pitch `pitch_m` and
/// bolt head radius `r_m` at the points `t`.
#[inline(always)]
#[must_use]
pub fn bolted_panel<const N: usize>(
    t: &TexelLanes<N>,
    b: [f32; 3],
    pitch_m: f32,
    r_m: f32,
) -> [[f32; 3]; N] {
    let (pitch, r) = (pitch_m, r_m);
    // Reciprocals once: the per-point divisions become multiplications.
    let inv_pitch = 1.0 / pitch;
    let inv_r = 1.0 / r;
    let wp = pitch * 5.0;
    let hp = pitch * 4.0;
    let margin = 0.5 * pitch;
    let (u, v, ppm, seed) = (&t.u, &t.v, &t.px_per_m, &t.seed);

    // Panel geometry: panel indices, position in the panel, seams, nearest border bolt.
    let mut panel_k = [0.0_f32; N];
    let mut panel_key = [0_u32; N];
    let mut pu = [0.0_f32; N];
    let mut pv = [0.0_f32; N];
    let mut du = [0.0_f32; N];
    let mut dv = [0.0_f32; N];
    let mut d = [0.0_f32; N];
    let mut top_u = [0.0_f32; N];
    let mut col_u = [0.0_f32; N];
    let mut above = [0.0_f32; N];
    for i in 0..N {
        let pi = (u[i] * (0.2 * inv_pitch)).floor() as i32;
        let pj = (v[i] * (0.25 * inv_pitch)).floor() as i32;
        let (x, y) = (u[i] - pi as f32 * wp, v[i] - pj as f32 * hp);
        (pu[i], pv[i]) = (x, y);
        panel_key[i] = (pi.wrapping_mul(131) ^ pj) as u32;
        let tone = 0.85 + 0.3 * unit_f32(hash2(pi, pj, seed[i]));
        let seam_d = x.min(wp - x).min(y).min(hp - y);
        let seam = 0.25 + 0.75 * aa_step(0.0015, seam_d, ppm[i]);
        panel_k[i] = tone * seam;
        // Bolts sit on the border rows and columns, `pitch` apart from `margin` on.
        let snap = |x: f32, len: f32| {
            (margin + ((x - margin) * inv_pitch).round() * pitch).clamp(margin, len - margin)
        };
        let row_v = if y < hp * 0.5 { margin } else { hp - margin };
        col_u[i] = if x < wp * 0.5 { margin } else { wp - margin };
        top_u[i] = snap(x, wp);
        let c1 = (top_u[i], row_v);
        let c2 = (col_u[i], snap(y, hp));
        let d1 = ((x - c1.0) * (x - c1.0) + (y - c1.1) * (y - c1.1)).sqrt();
        let d2 = ((x - c2.0) * (x - c2.0) + (y - c2.1) * (y - c2.1)).sqrt();
        let (bc, dist) = if d1 < d2 { (c1, d1) } else { (c2, d2) };
        (du[i], dv[i], d[i]) = (x - bc.0, y - bc.1, dist);
        above[i] = (margin + ((y - margin) * inv_pitch).ceil() * pitch).min(hp - margin);
    }

    // Low-frequency mottling (0.3 m) and grime (12 mm), the streak modulation (4 x 20 mm)
    // and the chips' mask (0.12 m) and outline wobble (1.2 mm).
    let chip_seed = seed.map(|s| s ^ 0x3c3c);
    let mottle = fbm_lanes(u, v, 0.3, 3, ppm, seed, 1);
    let grime = fbm_lanes(u, v, 0.012, 2, ppm, seed, 2);
    let mask_fbm = fbm_lanes(u, v, 0.12, 2, ppm, &chip_seed, 0);
    let streak_noise = value_lanes(
        u.map(|x| x * (1.0 / 0.004)),
        v.map(|y| y * (1.0 / 0.02)),
        *seed,
    );
    let outline = value_lanes(
        u.map(|x| x * (1.0 / CHIP_OUTLINE_M)),
        v.map(|y| y * (1.0 / CHIP_OUTLINE_M)),
        chip_seed.map(|s| s ^ 0x9999),
    );
    let (chip_f1, chip_id) = cellular_nearest_lanes(u, v, &chip_seed);

    // Rust streaks run down (-v) from the top-row bolts and from the side-column bolts above
    // the point; each bolt bleeds with its own strength `s_b` and profile
    // `exp(-|du| / 0.6 r + dv / 14 r)`, modulated by one streaky noise
    // `n = 0.6 + 0.8 value2(u / 4 mm, v / 20 mm)`; since `n > 0` the stronger streak is
    // picked before multiplying by `n`. A profile below `e^-9` is no streak, and none is
    // drawn where bolts are below the band limit.
    let mut exponent = [[0.0_f32; N]; 2];
    let mut strength = [[0.0_f32; N]; 2];
    for i in 0..N {
        let sources = [
            (
                pu[i] - top_u[i],
                pv[i] - (hp - margin),
                (top_u[i] * inv_pitch) as i32,
            ),
            (
                pu[i] - col_u[i],
                pv[i] - above[i],
                1000 + (above[i] * inv_pitch) as i32 + (col_u[i] * inv_pitch) as i32 * 7,
            ),
        ];
        for (k, (sdu, sdv, id)) in sources.into_iter().enumerate() {
            let e = sdv * ((1.0 / 14.0) * inv_r) - sdu.abs() * ((1.0 / 0.6) * inv_r);
            let reaches = sdv < 0.0 && sdu.abs() <= 4.0 * r && sdv >= -60.0 * r;
            let on = reaches && e >= -STREAK_MIN_EXPONENT;
            // Off lanes take exp(0), kept finite and then dropped.
            exponent[k][i] = if on { e } else { 0.0 };
            let s = unit_f32(hash2(id, panel_key[i] as i32, seed[i] ^ 0x5151));
            strength[k][i] = if on { s } else { 0.0 };
        }
    }
    let profile = [exp_lanes(exponent[0]), exp_lanes(exponent[1])];

    let mut out = [[0.0_f32; 3]; N];
    for i in 0..N {
        let k = panel_k[i] * (1.0 + 0.12 * mottle[i] + 0.16 * grime[i]);
        let wb = band_weight(2.0 * r, ppm[i]);
        let s = (strength[0][i] * profile[0][i]).max(strength[1][i] * profile[1][i]);
        let s = if s > 0.0 {
            s * (0.6 + 0.8 * streak_noise[i])
        } else {
            s
        };
        let rust_t = if wb > 0.0 {
            (0.7 * s).clamp(0.0, 1.0) * wb
        } else {
            0.0
        };

        // Paint chips: cells whose unit value is below the mask flake off, with an
        // outline perturbed by fine noise.
        let w_chip = band_weight(CHIP_CELL_M, ppm[i]);
        let mask = ((mask_fbm[i] + 0.5 - 0.5) * 5.0).clamp(0.0, 1.0) * CHIP_AMOUNT;
        let radius = 0.2 + 0.3 * unit_f32(hash_u32(chip_id[i]));
        let wobble = 0.5 * (outline[i] - 0.5) * band_weight(CHIP_OUTLINE_M, ppm[i]);
        let flake =
            w_chip * 0.85 * (1.0 - aa_step(radius, chip_f1[i] + wobble, ppm[i] * CHIP_CELL_M));
        let chipped = w_chip > 0.0 && mask > 0.0 && unit_f32(chip_id[i]) <= mask;
        let chip = if chipped { flake } else { 0.0 };

        let mut c = mix(scale(b, k), RUST_RGB, rust_t);
        c = mix(c, CHIP_RGB, chip);
        // Washer ring, then a domed head lit from the upper left.
        let head = 1.0 - aa_step(r * 0.75, d[i], ppm[i]);
        let washer = 1.0 - aa_step(r, d[i], ppm[i]);
        let lit = 1.0 + 0.8 * ((-du[i] + dv[i]) / (r * 1.414)).clamp(-1.0, 1.0);
        let rim = 1.0 - 0.6 * (1.0 - aa_step(0.0, (d[i] - r * 0.78).abs() - r * 0.05, ppm[i]));
        let kb = 1.0 + (washer * 0.9 - washer) + head * (lit - 1.0) * 0.8;
        let bolt = scale(b, kb * rim);
        let bolted = mix(c, bolt, washer * wb);
        out[i] = if d[i] < 1.4 * r { bolted } else { c };
    }
    out
}

/// Vector level of [`bolted_panel_at`]: the build's baseline (`x86-64-v2`: SSE4.1), AVX2
/// or AVX-512, detected at run time and capped by the `RODLOG_SIMD` environment variable
/// (`baseline`, `avx2`, `avx512`; the scheme of `calib`'s feature kernels, for A/B runs of
/// one build).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum SimdLevel {
    /// SSE4.1 (the workspace's `x86-64-v2` target).
    Baseline,
    /// AVX2 (the vector part of `x86-64-v3`).
    Avx2,
    /// AVX-512 F/BW/DQ/VL.
    Avx512,
}

impl SimdLevel {
    /// The best level of this CPU, capped by `RODLOG_SIMD` (read once).
    pub fn detected() -> Self {
        static LEVEL: std::sync::OnceLock<SimdLevel> = std::sync::OnceLock::new();
        *LEVEL.get_or_init(|| {
            let cap = match std::env::var("RODLOG_SIMD").as_deref() {
                Ok("baseline") => Self::Baseline,
                Ok("avx2") => Self::Avx2,
                _ => Self::Avx512,
            };
            Self::of_cpu().min(cap)
        })
    }

    fn of_cpu() -> Self {
        #[cfg(target_arch = "x86_64")]
        {
            let avx2 = std::arch::is_x86_feature_detected!("avx2")
                && std::arch::is_x86_feature_detected!("fma");
            if avx2
                && std::arch::is_x86_feature_detected!("avx512f")
                && std::arch::is_x86_feature_detected!("avx512bw")
                && std::arch::is_x86_feature_detected!("avx512dq")
                && std::arch::is_x86_feature_detected!("avx512vl")
            {
                return Self::Avx512;
            }
            if avx2 {
                return Self::Avx2;
            }
        }
        Self::Baseline
    }
}

/// [`bolted_panel`] compiled for `level` (or the best level below it that this CPU has):
/// the same bits at every level (element-wise IEEE arithmetic; Rust never fuses
/// multiply-adds), only wider vectors.
// Calling `#[target_feature]` functions, each guarded by the run-time detection.
#[allow(unsafe_code)]
#[inline]
#[must_use]
pub fn bolted_panel_at<const N: usize>(
    level: SimdLevel,
    t: &TexelLanes<N>,
    b: [f32; 3],
    pitch_m: f32,
    r_m: f32,
) -> [[f32; 3]; N] {
    #[cfg(target_arch = "x86_64")]
    {
        match level.min(SimdLevel::detected()) {
            // SAFETY: `detected()` found every feature `bolted_panel_avx512` enables.
            SimdLevel::Avx512 => unsafe { bolted_panel_avx512(t, b, pitch_m, r_m) },
            // SAFETY: as above, for `bolted_panel_avx2`.
            SimdLevel::Avx2 => unsafe { bolted_panel_avx2(t, b, pitch_m, r_m) },
            SimdLevel::Baseline => bolted_panel(t, b, pitch_m, r_m),
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = level;
        bolted_panel(t, b, pitch_m, r_m)
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn bolted_panel_avx2<const N: usize>(
    t: &TexelLanes<N>,
    b: [f32; 3],
    pitch_m: f32,
    r_m: f32,
) -> [[f32; 3]; N] {
    bolted_panel(t, b, pitch_m, r_m)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,avx512f,avx512bw,avx512dq,avx512vl")]
fn bolted_panel_avx512<const N: usize>(
    t: &TexelLanes<N>,
    b: [f32; 3],
    pitch_m: f32,
    r_m: f32,
) -> [[f32; 3]; N] {
    bolted_panel(t, b, pitch_m, r_m)
}

/// [`fbm2_points`] with the seed of each lane `seed[i] ^ salt`: the points of a batch
/// share a material but may lie on different faces (different seeds), so octaves are
/// looked up lane by lane with their own seeds.
#[inline(always)]
fn fbm_lanes<const N: usize>(
    u: &[f32; N],
    v: &[f32; N],
    scale_m: f32,
    octaves: u32,
    ppm: &[f32; N],
    seed: &[u32; N],
    salt: u32,
) -> [f32; N] {
    // One face (the common case): one seed for all lanes.
    let s0 = seed[0] ^ salt;
    if seed.iter().all(|&s| s ^ salt == s0) {
        return fbm2_points(*u, *v, scale_m, octaves, *ppm, s0);
    }
    let mut out = [0.0_f32; N];
    for i in 0..N {
        out[i] = fbm2_points([u[i]], [v[i]], scale_m, octaves, [ppm[i]], seed[i] ^ salt)[0];
    }
    out
}

/// [`cellular_nearest_points`] with a seed per lane (see [`fbm_lanes`]), at the chip
/// lattice (`u / 5 mm`, seed `^ 0x1234`).
#[inline(always)]
fn cellular_nearest_lanes<const N: usize>(
    u: &[f32; N],
    v: &[f32; N],
    seed: &[u32; N],
) -> ([f32; N], [u32; N]) {
    let x = u.map(|a| a * (1.0 / CHIP_CELL_M));
    let y = v.map(|a| a * (1.0 / CHIP_CELL_M));
    let s0 = seed[0] ^ 0x1234;
    if seed.iter().all(|&s| s ^ 0x1234 == s0) {
        return cellular_nearest_points(x, y, s0);
    }
    let mut f1 = [0.0_f32; N];
    let mut id = [0_u32; N];
    for i in 0..N {
        let (f, h) = cellular_nearest_points([x[i]], [y[i]], seed[i] ^ 0x1234);
        (f1[i], id[i]) = (f[0], h[0]);
    }
    (f1, id)
}

/// `e^x` for `x` in `[-80, 80]` in lanes (plain arithmetic, so it vectorises and gives the
/// same bits everywhere): `x = n ln 2 + f` with `n = round(x / ln 2)` (Cody-Waite split
/// of `ln 2`), `|f| <= ln 2 / 2`, `e^f` by its degree-6 Taylor polynomial (relative error
/// below `(ln 2 / 2)^7 / 7! ~ 1.2e-7`) and `2^n` put into the exponent bits.
#[inline(always)]
fn exp_lanes<const N: usize>(x: [f32; N]) -> [f32; N] {
    const LN2_HI: f32 = 0.693_145_75;
    const LN2_LO: f32 = 1.428_606_8e-6;
    let mut out = [0.0_f32; N];
    for i in 0..N {
        let x = x[i].clamp(-80.0, 80.0);
        let n = (x * std::f32::consts::LOG2_E + 0.5).floor();
        let f = x - n * LN2_HI - n * LN2_LO;
        let p = 1.0
            + f * (1.0
                + f * (0.5
                    + f * (1.0 / 6.0 + f * (1.0 / 24.0 + f * (1.0 / 120.0 + f * (1.0 / 720.0))))));
        let two_n = f32::from_bits(((n as i32 + 127) as u32) << 23);
        out[i] = p * two_n;
    }
    out
}

#[inline(always)]
fn scale(c: [f32; 3], k: f32) -> [f32; 3] {
    [
        (c[0] * k).clamp(0.0, 1.0),
        (c[1] * k).clamp(0.0, 1.0),
        (c[2] * k).clamp(0.0, 1.0),
    ]
}

#[inline(always)]
fn mix(a: [f32; 3], b: [f32; 3], t: f32) -> [f32; 3] {
    [
        a[0] + (b[0] - a[0]) * t,
        a[1] + (b[1] - a[1]) * t,
        a[2] + (b[2] - a[2]) * t,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn points<const N: usize>(k: usize, faces: bool) -> TexelLanes<N> {
        let mut t = TexelLanes::default();
        for i in 0..N {
            let j = (k * N + i) as f32;
            t.u[i] = 0.3 + j * 0.000_31 + (k % 7) as f32 * 0.013;
            t.v[i] = 0.2 + (j * 0.618_034).fract() * 0.4;
            // Densities from far (features below the band limit) to very close.
            t.px_per_m[i] = [150.0, 900.0, 2600.0, 3800.0, 12_000.0, 1e5][(k + i / 3) % 6];
            t.seed[i] = if faces { hash_u32(i as u32 % 2) } else { 77 };
        }
        t
    }

    /// Lane `i` of an 8-lane batch is the 1-lane texture at point `i`, bit for bit, with
    /// one face or mixed faces per batch.
    #[test]
    fn lanes_equal_the_scalar_texture_bit_for_bit() {
        let b = [0.4, 0.42, 0.37];
        for k in 0..3000 {
            let t = points::<8>(k, k % 3 == 0);
            let wide = bolted_panel(&t, b, 0.075, 0.0075);
            for (i, w) in wide.iter().enumerate() {
                let one = TexelLanes {
                    u: [t.u[i]],
                    v: [t.v[i]],
                    px_per_m: [t.px_per_m[i]],
                    seed: [t.seed[i]],
                };
                let s = bolted_panel(&one, b, 0.075, 0.0075)[0];
                assert_eq!(
                    w.map(f32::to_bits),
                    s.map(f32::to_bits),
                    "batch {k} lane {i}"
                );
                assert!(s.iter().all(|x| (0.0..=1.0).contains(x)), "{s:?}");
            }
        }
    }

    /// Every vector level and batch width gives the baseline's 1-lane bits.
    #[test]
    fn every_simd_level_gives_the_same_bits() {
        let b = [0.45, 0.47, 0.42];
        for k in 0..500 {
            let t = points::<16>(k, k % 4 == 1);
            for level in [SimdLevel::Baseline, SimdLevel::Avx2, SimdLevel::Avx512] {
                let wide = bolted_panel_at(level, &t, b, 0.09, 0.006);
                for (i, w) in wide.iter().enumerate() {
                    let one = TexelLanes {
                        u: [t.u[i]],
                        v: [t.v[i]],
                        px_per_m: [t.px_per_m[i]],
                        seed: [t.seed[i]],
                    };
                    let s = bolted_panel(&one, b, 0.09, 0.006)[0];
                    assert_eq!(
                        w.map(f32::to_bits),
                        s.map(f32::to_bits),
                        "{level:?} batch {k} lane {i}"
                    );
                }
            }
        }
    }

    #[test]
    fn lane_exp_is_accurate() {
        let mut worst = 0.0_f64;
        for i in 0..=20_000 {
            let x = -20.0 + i as f32 * 0.001_1;
            let got = f64::from(exp_lanes([x])[0]);
            let want = f64::from(x).exp();
            worst = worst.max((got / want - 1.0).abs());
        }
        assert!(worst < 5e-7, "relative error {worst}");
    }

    /// Bolts, seams, chips and streaks all show up at the wrist camera's density.
    #[test]
    fn panel_has_its_features() {
        let b = [0.4, 0.42, 0.37];
        let (mut dark, mut rusty, mut bright) = (0, 0, 0);
        for row in 0..300 {
            for col in 0..40 {
                let mut t = TexelLanes {
                    u: [0.0; 8],
                    v: [0.0; 8],
                    px_per_m: [3800.0; 8],
                    seed: [5; 8],
                };
                for i in 0..8 {
                    t.u[i] = (col * 8 + i) as f32 * 0.001;
                    t.v[i] = row as f32 * 0.001;
                }
                for c in bolted_panel(&t, b, 0.075, 0.0075) {
                    dark += usize::from(c[0] < 0.15);
                    rusty += usize::from(c[0] > 1.3 * c[2]);
                    bright += usize::from(c[1] > 0.5);
                }
            }
        }
        assert!(
            dark > 2000 && rusty > 200 && bright > 40,
            "{dark} {rusty} {bright}"
        );
    }
}
