//! Painted steel ([`Texture::Painted`](super::Texture::Painted)) and bolted panels
//! ([`Texture::BoltedPanel`](super::Texture::BoltedPanel)) at `N` surface points at once:
//! the equipment boxes, cabinets and doors that fill the wrist camera's view during
//! calibration, so the renderer's hottest textures.
//!
//! * Painted steel: low-frequency grime (fbm) and, with `rust > 0`, run-off rust stains
//!   (a threshold on vertically stretched fbm, with dark rims and fine texture) and paint
//!   chips.
//! * Bolted panels: panels `5 x 4` bolt pitches with dark seams, a tone per panel, bolts
//!   along the panel borders (washer, domed head lit from the upper left, dark rim),
//!   mottling and grime (fbm), rust streaks running down from the bolts, and paint chips.
//! * Paint chips: 2-6 mm cellular flakes where a low-frequency mask is high, with outlines
//!   perturbed by fine value noise (corner-rich detail at the wrist working distance).
//!
//! Every feature is band-limited by the pixel density `px_per_m` (see [`band_weight`] and
//! [`aa_step`]).
//!
//! The points are lanes: every step is an element-wise loop over `[f32; N]` / `[u32; N]`
//! arrays, branches are selects, and the noise comes from the point-lane functions of
//! [`noise`](super::noise) (no memo), so the compiler turns the kernels into vector code
//! over the pixels of a tile ([`albedo_at`] runs them at the CPU's widest level through
//! [`simd::dispatch_at`]), and lane `i` of any `N` at any level is the same function of
//! point `i`, bit for bit (`N = 1` is the scalar texture; tested).

use super::noise::{
    aa_step, band_weight, cellular_nearest_points, fbm2_points, hash_u32, hash2, lattice_index,
    unit_f32, value_lanes,
};

/// Surface points of one texture lookup batch, one per lane, on one face of one material
/// (one texture seed).
#[derive(Clone, Copy, Debug)]
pub struct TexelLanes<const N: usize> {
    /// Texture coordinate u (m, wrapped to the texture period).
    pub u: [f32; N],
    /// Texture coordinate v (m, wrapped).
    pub v: [f32; N],
    /// Pixel density on the surface (pixels per metre, clamped to the finest).
    pub px_per_m: [f32; N],
    /// Texture seed of the material and face.
    pub seed: u32,
}

impl<const N: usize> Default for TexelLanes<N> {
    fn default() -> Self {
        Self {
            u: [0.0; N],
            v: [0.0; N],
            px_per_m: [0.0; N],
            seed: 0,
        }
    }
}

/// Linear rust colour of stains and streaks.
const RUST_RGB: [f32; 3] = [0.23, 0.09, 0.035];
/// Colour of bare metal under a paint chip.
const CHIP_RGB: [f32; 3] = [0.07, 0.07, 0.065];
/// Streak profiles `exp(x)` with `x` below minus this are no streak (1e-4: under a
/// thousandth of a grey level once mixed).
const STREAK_MIN_EXPONENT: f32 = 9.0;
/// Wavelength of the noise perturbing paint-chip outlines (m).
const CHIP_OUTLINE_M: f32 = 0.0012;
/// Paint-chip lattice cell (m): 2-6 mm flakes.
const CHIP_CELL_M: f32 = 0.005;
/// Fraction of chip-mask area that flakes on bolted panels (0..1).
const PANEL_CHIP_AMOUNT: f32 = 0.5;

/// The steel textures of [`albedo_at`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SteelTexture {
    /// [`Texture::Painted`](super::Texture::Painted).
    Painted {
        /// Grime contrast.
        grime: f32,
        /// Rust coverage (0..1).
        rust: f32,
    },
    /// [`Texture::BoltedPanel`](super::Texture::BoltedPanel).
    BoltedPanel {
        /// Bolt spacing (m).
        pitch_m: f32,
        /// Bolt head radius (m).
        bolt_radius_m: f32,
    },
}

/// Albedo (linear RGB, 0..1) of `texture` with base colour `b` at the points `t`, computed
/// at `level` or the best level below it that this CPU has (the same bits at every level).
#[inline]
#[must_use]
pub fn albedo_at<const N: usize>(
    level: simd::Level,
    texture: SteelTexture,
    t: &TexelLanes<N>,
    b: [f32; 3],
) -> [[f32; 3]; N] {
    simd::dispatch_at(level, Albedo { texture, t, b })
}

/// [`albedo`] as a [`simd::Kernel`].
struct Albedo<'a, const N: usize> {
    texture: SteelTexture,
    t: &'a TexelLanes<N>,
    b: [f32; 3],
}

impl<const N: usize> simd::Kernel for Albedo<'_, N> {
    type Output = [[f32; 3]; N];
    #[inline(always)]
    fn run(self) -> Self::Output {
        albedo(self.texture, self.t, self.b)
    }
}

/// Albedo of `texture` with base colour `b` at the points `t` at the build's baseline
/// level (see [`albedo_at`]).
#[inline(always)]
#[must_use]
pub fn albedo<const N: usize>(
    texture: SteelTexture,
    t: &TexelLanes<N>,
    b: [f32; 3],
) -> [[f32; 3]; N] {
    match texture {
        SteelTexture::Painted { grime, rust } => painted(t, b, grime, rust),
        SteelTexture::BoltedPanel {
            pitch_m,
            bolt_radius_m,
        } => bolted_panel(t, b, pitch_m, bolt_radius_m),
    }
}

/// Painted steel of base colour `b`, grime contrast `grime` and rust coverage `rust`.
#[inline(always)]
fn painted<const N: usize>(t: &TexelLanes<N>, b: [f32; 3], grime: f32, rust: f32) -> [[f32; 3]; N] {
    let (u, v, ppm, seed) = (&t.u, &t.v, &t.px_per_m, t.seed);
    let g = fbm2_points(*u, *v, 0.5, 3, *ppm, seed);
    let mut out = [[0.0_f32; 3]; N];
    for i in 0..N {
        out[i] = scale(b, 1.0 + 2.0 * grime * g[i]);
    }
    if rust > 0.0 {
        rust_stains(t, rust, &mut out);
    }
    out
}

/// Rust stains and chips over painted steel `out` with rust coverage `rust` (> 0).
#[inline(always)]
fn rust_stains<const N: usize>(t: &TexelLanes<N>, rust: f32, out: &mut [[f32; 3]; N]) {
    let (u, v, ppm, seed) = (&t.u, &t.v, &t.px_per_m, t.seed);
    // Stains stretched vertically (run-off), threshold on fbm; dark rims give corners.
    let stain = fbm2_points(
        u.map(|x| x * 1.6),
        v.map(|y| y * 0.6),
        0.06,
        5,
        *ppm,
        seed ^ 0xabc,
    );
    let fine_noise = value_lanes(
        u.map(|x| x * (1.0 / 0.003)),
        v.map(|y| y * (1.0 / 0.003)),
        [seed; N],
    );
    let chip = paint_chips(u, v, ppm, seed ^ 0x77, rust);
    let th = 0.5 + 0.3 * (1.0 - rust);
    for i in 0..N {
        let s = stain[i] + 0.5;
        let inside = aa_step(th, s, 1.0 / (0.02 + 3.0 / ppm[i]));
        let rim =
            (1.0 - ((s - th).abs() * (1.0 / 0.015))).clamp(0.0, 1.0) * band_weight(0.004, ppm[i]);
        let fine = 0.75 + 0.5 * fine_noise[i] * band_weight(0.003, ppm[i]);
        let mut c = mix(out[i], scale(RUST_RGB, fine), inside);
        c = scale(c, 1.0 - 0.45 * rim);
        out[i] = mix(c, scale(RUST_RGB, 0.7), chip[i]);
    }
}

/// Coverage (0..1) of paint chips with seed `seed` and density `amount` (0..1):
/// cells of a 5 mm lattice whose unit value is below a low-frequency mask (0.12 m fbm)
/// flake off, with an outline perturbed by 1.2 mm value noise.
#[inline(always)]
fn paint_chips<const N: usize>(
    u: &[f32; N],
    v: &[f32; N],
    ppm: &[f32; N],
    seed: u32,
    amount: f32,
) -> [f32; N] {
    let mask_fbm = fbm2_points(*u, *v, 0.12, 2, *ppm, seed);
    let mut mask = [0.0_f32; N];
    let mut any = false;
    for i in 0..N {
        mask[i] = ((mask_fbm[i] + 0.5 - 0.5) * 5.0).clamp(0.0, 1.0) * amount;
        any |= band_weight(CHIP_CELL_M, ppm[i]) > 0.0 && mask[i] > 0.0;
    }
    // The mask is low-frequency: most batches lie wholly outside it (no chip in any lane:
    // the cells and outlines below would all be selected away).
    if !any {
        return [0.0; N];
    }
    let outline = value_lanes(
        u.map(|x| x * (1.0 / CHIP_OUTLINE_M)),
        v.map(|y| y * (1.0 / CHIP_OUTLINE_M)),
        [seed ^ 0x9999; N],
    );
    let (f1, id) = cellular_nearest_points(
        u.map(|a| a * (1.0 / CHIP_CELL_M)),
        v.map(|a| a * (1.0 / CHIP_CELL_M)),
        seed ^ 0x1234,
    );
    let mut out = [0.0_f32; N];
    for i in 0..N {
        let w = band_weight(CHIP_CELL_M, ppm[i]);
        let radius = 0.2 + 0.3 * unit_f32(hash_u32(id[i]));
        let wobble = 0.5 * (outline[i] - 0.5) * band_weight(CHIP_OUTLINE_M, ppm[i]);
        let flake = w * 0.85 * (1.0 - aa_step(radius, f1[i] + wobble, ppm[i] * CHIP_CELL_M));
        let chipped = w > 0.0 && mask[i] > 0.0 && unit_f32(id[i]) <= mask[i];
        out[i] = if chipped { flake } else { 0.0 };
    }
    out
}

/// Bolted panel of base colour `b`, bolt pitch `pitch` (m) and bolt head radius `r` (m).
#[inline(always)]
fn bolted_panel<const N: usize>(
    t: &TexelLanes<N>,
    b: [f32; 3],
    pitch: f32,
    r: f32,
) -> [[f32; 3]; N] {
    // Reciprocals once: the per-point divisions become multiplications.
    let inv_pitch = 1.0 / pitch;
    let inv_r = 1.0 / r;
    let wp = pitch * 5.0;
    let hp = pitch * 4.0;
    let margin = 0.5 * pitch;
    let (u, v, ppm, seed) = (&t.u, &t.v, &t.px_per_m, t.seed);

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
        let pi = lattice_index((u[i] * (0.2 * inv_pitch)).floor()) as i32;
        let pj = lattice_index((v[i] * (0.25 * inv_pitch)).floor()) as i32;
        let (x, y) = (u[i] - pi as f32 * wp, v[i] - pj as f32 * hp);
        (pu[i], pv[i]) = (x, y);
        panel_key[i] = (pi.wrapping_mul(131) ^ pj) as u32;
        let tone = 0.85 + 0.3 * unit_f32(hash2(pi, pj, seed));
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
    // and the chips.
    let mottle = fbm2_points(*u, *v, 0.3, 3, *ppm, seed ^ 1);
    let grime = fbm2_points(*u, *v, 0.012, 2, *ppm, seed ^ 2);
    let streak_noise = value_lanes(
        u.map(|x| x * (1.0 / 0.004)),
        v.map(|y| y * (1.0 / 0.02)),
        [seed; N],
    );
    let chip = paint_chips(u, v, ppm, seed ^ 0x3c3c, PANEL_CHIP_AMOUNT);

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
                index_of(top_u[i] * inv_pitch),
            ),
            (
                pu[i] - col_u[i],
                pv[i] - above[i],
                1000 + index_of(above[i] * inv_pitch) + index_of(col_u[i] * inv_pitch) * 7,
            ),
        ];
        for (k, (sdu, sdv, id)) in sources.into_iter().enumerate() {
            let e = sdv * ((1.0 / 14.0) * inv_r) - sdu.abs() * ((1.0 / 0.6) * inv_r);
            let reaches = sdv < 0.0 && sdu.abs() <= 4.0 * r && sdv >= -60.0 * r;
            let on = reaches && e >= -STREAK_MIN_EXPONENT;
            // Off lanes take exp(0), kept finite and then dropped.
            exponent[k][i] = if on { e } else { 0.0 };
            let s = unit_f32(hash2(id, panel_key[i] as i32, seed ^ 0x5151));
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

        let mut c = mix(scale(b, k), RUST_RGB, rust_t);
        c = mix(c, CHIP_RGB, chip[i]);
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

/// `x as i32` for `0 <= x < 2^22` (the bolt indices): floor and the exponent-bias trick of
/// [`lattice_index`], which vectorises, unlike the saturating conversion.
#[inline(always)]
fn index_of(x: f32) -> i32 {
    lattice_index(x.floor()) as i32
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
        let two_n = f32::from_bits(lattice_index(n).wrapping_add(127) << 23);
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

    fn points<const N: usize>(k: usize) -> TexelLanes<N> {
        let mut t = TexelLanes {
            seed: hash_u32(k as u32 % 5),
            ..TexelLanes::default()
        };
        for i in 0..N {
            let j = (k * N + i) as f32;
            t.u[i] = 0.3 + j * 0.000_31 + (k % 7) as f32 * 0.013;
            t.v[i] = 0.2 + (j * 0.618_034).fract() * 0.4;
            // Densities from far (features below the band limit) to very close.
            t.px_per_m[i] = [150.0, 900.0, 2600.0, 3800.0, 12_000.0, 1e5][(k + i / 3) % 6];
        }
        t
    }

    const TEXTURES: [SteelTexture; 3] = [
        SteelTexture::Painted {
            grime: 0.08,
            rust: 0.5,
        },
        SteelTexture::Painted {
            grime: 0.1,
            rust: 0.0,
        },
        SteelTexture::BoltedPanel {
            pitch_m: 0.075,
            bolt_radius_m: 0.0075,
        },
    ];

    /// Lane `i` of `wide` is the 1-lane texture at point `i` of `t`, bit for bit.
    fn assert_lanes_are_points<const N: usize>(
        texture: SteelTexture,
        t: &TexelLanes<N>,
        b: [f32; 3],
        wide: &[[f32; 3]; N],
        what: &str,
    ) {
        for (i, w) in wide.iter().enumerate() {
            let one = TexelLanes {
                u: [t.u[i]],
                v: [t.v[i]],
                px_per_m: [t.px_per_m[i]],
                seed: t.seed,
            };
            let s = albedo(texture, &one, b)[0];
            assert_eq!(
                w.map(f32::to_bits),
                s.map(f32::to_bits),
                "{texture:?} {what} lane {i}"
            );
            assert!(s.iter().all(|x| (0.0..=1.0).contains(x)), "{s:?}");
        }
    }

    /// Lane `i` of an 8-lane batch is the 1-lane texture at point `i` (seeds of five faces).
    #[test]
    fn lanes_equal_the_scalar_texture_bit_for_bit() {
        let b = [0.4, 0.42, 0.37];
        for texture in TEXTURES {
            for k in 0..2000 {
                let t = points::<8>(k);
                let wide = albedo(texture, &t, b);
                assert_lanes_are_points(texture, &t, b, &wide, &format!("batch {k}"));
            }
        }
    }

    /// Every vector level and batch width gives the baseline's 1-lane bits.
    #[test]
    fn every_simd_level_gives_the_same_bits() {
        let b = [0.45, 0.47, 0.42];
        for texture in TEXTURES {
            for k in 0..300 {
                let t = points::<16>(k);
                for level in [
                    simd::Level::Baseline,
                    simd::Level::Avx2,
                    simd::Level::Avx512,
                ] {
                    let wide = albedo_at(level, texture, &t, b);
                    assert_lanes_are_points(texture, &t, b, &wide, &format!("{level:?} {k}"));
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
                    seed: 5,
                };
                for i in 0..8 {
                    t.u[i] = (col * 8 + i) as f32 * 0.001;
                    t.v[i] = row as f32 * 0.001;
                }
                for c in albedo(TEXTURES[2], &t, b) {
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
