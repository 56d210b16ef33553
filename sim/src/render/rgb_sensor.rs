//! Colour sensor: white balance, auto-exposure, shot and read noise, gain, quantisation.
//!
//! Signal chain per pixel and channel (EMVA 1288 linear model):
//!
//! 1. scene radiance `L` (cd/m^2, linear RGB) times white-balance gain `w_c`;
//! 2. electrons `e = S L w_c t` with sensitivity `S` (e-/(cd/m^2 s), lens and QE folded in)
//!    and exposure time `t`;
//! 3. noise: `e' = e + sqrt(e + sigma_r^2) n`, photon shot noise (Poisson, Gaussian
//!    approximation) plus read noise `sigma_r`, `n` ~ N(0, 1) from a counter-based generator
//!    keyed by (capture seed, pixel, channel), clipped to the full well `FW`;
//! 4. analogue gain `g`, normalised `v = e' g / FW`, clipped to [0, 1];
//! 5. sRGB transfer curve and 8-bit quantisation (IEC 61966-2-1).
//!
//! Auto-exposure: like a camera's metering loop at convergence, it picks `k = S t g / FW`
//! so the mean of `srgb(clip(k Y))` over the noise-free luminance histogram equals
//! [`RgbSensorParams::target_mean`] (bisection on `log k`), then realises `k` with the
//! longest useful exposure up to `max_exposure_s` and the remaining factor as gain up to
//! `max_gain`. When light is short the gain rises, so the mean stays while the SNR falls
//! (shot noise `sqrt(e)` relative to `e` grows as `e` shrinks); beyond the gain limit the
//! image darkens.
//!
//! # Dusk: why the image mean falls from ~109/255 at 18:00 to ~9/255 at 18:24
//! That is the exposure running out, not a metering fault. The brightest the sensor can make
//! a scene is `k_max = S t_max g_max / FW` = 60 x 0.1 s x 16 / 10 000 = 0.0096 per cd/m^2; the
//! target mean needs a linear level of 0.171, i.e. a mean scene luminance of 17.8 cd/m^2: a
//! grey (albedo 0.3) Lambertian scene under 186 lx. The renderer's daylight
//! (`super::light`) sets at 18:00 (400 lx) and passes 186 lx at about 18:03; from there the
//! mean follows the light, which drops 200x to the end of civil twilight (3 lx, sun 6 deg
//! below the horizon) at 18:22: the model's elevation `62 deg sin(pi (h - 6) / 12)` sinks
//! 16 deg/h at sunset, where a real equinox sun at the 28 deg latitude its 62 deg noon implies
//! sinks 15 cos(28 deg) = 13 deg/h, so a real dusk lasts about a fifth longer.
//! A longer exposure than 0.1 s blurs the structured-light capture and more gain only adds
//! noise; the fix for dusk is light on the scene (a wrist light), not the metering. The test
//! `auto_exposure_runs_out_three_minutes_after_sunset` pins the numbers.
//!
//! The normal deviates are Irwin-Hall sums of four 16-bit uniforms from one SplitMix64 draw,
//! rescaled to unit variance (exact variance, tails truncated at 3.46 sigma): three orders of
//! magnitude cheaper than Box-Muller and plenty for sensor noise.

use rng::splitmix64;

/// SplitMix64's increment (the golden-ratio odd constant).
const SPLITMIX_GAMMA: u64 = rng::GAMMA;

/// Colour sensor parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RgbSensorParams {
    /// Full-well capacity (e-). Default 10 000.
    pub full_well_electrons: f64,
    /// Read noise (e- rms). Default 4.
    pub read_noise_electrons: f64,
    /// Electrons per second per cd/m^2 of scene luminance. Default 60 (chosen so that at
    /// 400 lx, 100 ms and gain ~6 reach the target mean: dusk is noisy, not dark).
    pub sensitivity_e_per_nit_s: f64,
    /// Shortest exposure (s). Default 20 us.
    pub min_exposure_s: f64,
    /// Longest exposure (s). Default 0.1 s.
    pub max_exposure_s: f64,
    /// Largest analogue gain. Default 16.
    pub max_gain: f64,
    /// Target mean of the sRGB-encoded image in [0, 1]. Default 0.45.
    pub target_mean: f64,
    /// Fraction of the illuminant's colour cast removed by white balance. Default 0.6.
    pub white_balance_strength: f64,
    /// Whether to add shot and read noise. Default true.
    pub noise_enabled: bool,
}

impl Default for RgbSensorParams {
    fn default() -> Self {
        Self {
            full_well_electrons: 10_000.0,
            read_noise_electrons: 4.0,
            sensitivity_e_per_nit_s: 60.0,
            min_exposure_s: 20e-6,
            max_exposure_s: 0.1,
            max_gain: 16.0,
            target_mean: 0.45,
            white_balance_strength: 0.6,
            noise_enabled: true,
        }
    }
}

/// Exposure chosen by auto-exposure.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Exposure {
    /// Exposure time (s).
    pub exposure_s: f64,
    /// Analogue gain (>= 1).
    pub gain: f64,
}

/// Luminance histogram bins per octave.
pub const HISTOGRAM_BINS_PER_OCTAVE: usize = 8;
/// Lowest histogram luminance is `2^HISTOGRAM_MIN_LOG2` cd/m^2.
pub const HISTOGRAM_MIN_LOG2: i32 = -24;
/// Number of octaves covered.
pub const HISTOGRAM_OCTAVES: usize = 48;
/// Number of bins (bin 0 also holds everything darker).
pub const HISTOGRAM_BINS: usize = HISTOGRAM_BINS_PER_OCTAVE * HISTOGRAM_OCTAVES;

/// `2^(k/8)`, k = 1..7: the bin edges within an octave.
const OCTAVE_EDGES: [f32; HISTOGRAM_BINS_PER_OCTAVE - 1] = [
    1.090_507_7,
    1.189_207_1,
    1.296_839_6,
    std::f32::consts::SQRT_2,
    1.542_210_8,
    1.681_792_8,
    1.834_008_1,
];

/// Histogram bin of a luminance (cd/m^2): `floor(8 (log2 y + 24))` clamped to the bins,
/// from the float's bits (octave = exponent, eighth of an octave = how many edges
/// `2^(k/8)` the mantissa reaches) instead of a `log2` call.
#[inline]
#[must_use]
pub fn histogram_bin(y: f32) -> usize {
    if y.is_nan() || y <= 0.0 {
        return 0;
    }
    let bits = y.to_bits();
    let octave = ((bits >> 23) & 0xff) as i32 - 127 - HISTOGRAM_MIN_LOG2;
    let mantissa = f32::from_bits((bits & 0x007f_ffff) | 0x3f80_0000);
    let eighths = OCTAVE_EDGES
        .iter()
        .map(|&e| i32::from(mantissa >= e))
        .sum::<i32>();
    let bin = octave * HISTOGRAM_BINS_PER_OCTAVE as i32 + eighths;
    bin.clamp(0, HISTOGRAM_BINS as i32 - 1) as usize
}

fn bin_center(i: usize) -> f64 {
    ((i as f64 + 0.5) / HISTOGRAM_BINS_PER_OCTAVE as f64 + f64::from(HISTOGRAM_MIN_LOG2)).exp2()
}

/// sRGB transfer curve of a linear value in [0, 1].
#[must_use]
pub fn srgb_encode(v: f64) -> f64 {
    let v = v.clamp(0.0, 1.0);
    if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// Entries of the linear -> sRGB byte table.
pub const SRGB_LUT_SIZE: usize = 1 << 16;

/// Table `lut[i] = round(255 srgb(i / (SRGB_LUT_SIZE - 1)))`, computed once per process (a
/// constant: 65 536 `powf` calls are worth skipping on every capture).
#[must_use]
pub fn srgb_lut() -> &'static [u8] {
    static LUT: std::sync::OnceLock<Vec<u8>> = std::sync::OnceLock::new();
    LUT.get_or_init(|| {
        (0..SRGB_LUT_SIZE)
            .map(|i| (255.0 * srgb_encode(i as f64 / (SRGB_LUT_SIZE - 1) as f64)).round() as u8)
            .collect()
    })
}

impl RgbSensorParams {
    /// Auto-exposure from a luminance histogram (see the module docs).
    #[must_use]
    pub fn auto_exposure(&self, histogram: &[u64]) -> Exposure {
        let total: u64 = histogram.iter().sum();
        if total == 0 {
            return Exposure {
                exposure_s: self.max_exposure_s,
                gain: 1.0,
            };
        }
        let mean_for = |k: f64| {
            let mut s = 0.0;
            for (i, &n) in histogram.iter().enumerate() {
                if n > 0 {
                    s += n as f64 * srgb_encode(k * bin_center(i));
                }
            }
            s / total as f64
        };
        // Bisection on log2 k over a range wide enough for starlight to the sun.
        let (mut lo, mut hi) = (-40.0_f64, 40.0_f64);
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if mean_for(mid.exp2()) < self.target_mean {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let k = (0.5 * (lo + hi)).exp2();
        // k = S t g / FW.
        let t_g = k * self.full_well_electrons / self.sensitivity_e_per_nit_s;
        let exposure_s = t_g.clamp(self.min_exposure_s, self.max_exposure_s);
        let gain = (t_g / exposure_s).clamp(1.0, self.max_gain);
        Exposure { exposure_s, gain }
    }

    /// Converts one pixel's radiance (already white-balanced, cd/m^2) to sRGB bytes.
    #[inline]
    pub fn expose_pixel(
        &self,
        radiance: [f32; 3],
        exposure: &Exposure,
        seed: u64,
        pixel: u64,
        lut: &[u8],
        out: &mut [u8],
    ) {
        let chain = ExposureChain::new(self, exposure);
        if let Ok(o) = <&mut [u8; 3]>::try_from(out) {
            chain.pixels(&[radiance], [1.0; 3], seed, pixel, lut, o);
        }
    }

    /// [`Self::expose_pixel`] (with the [`srgb_lut`] table) for a run of consecutive pixels:
    /// `radiance[j]` is pixel `first_pixel + j` before white balance, `out` holds 3 bytes
    /// per pixel; lane groups run at vector `level` (the same bytes at every level).
    #[allow(clippy::too_many_arguments)]
    pub fn expose_run(
        &self,
        level: simd::Level,
        radiance: &[[f32; 3]],
        white_balance: [f32; 3],
        exposure: &Exposure,
        seed: u64,
        first_pixel: u64,
        out: &mut [u8],
    ) {
        let chain = ExposureChain::new(self, exposure);
        simd::dispatch_at(
            level,
            ExposeRun {
                chain: &chain,
                radiance,
                white_balance,
                seed,
                first_pixel,
                lut: srgb_lut(),
                out,
            },
        );
    }
}

/// Pixels of one [`ExposeRun`] lane group (one AVX-512 vector of f32 per channel).
const EXPOSE_LANES: usize = 16;

/// [`RgbSensorParams::expose_run`] as a [`simd::Kernel`]: [`EXPOSE_LANES`] pixels at a time
/// in lanes (the 64-bit noise hash and the float chain vectorise across pixels), the rest
/// one by one; each pixel's bytes are the same either way.
struct ExposeRun<'a> {
    chain: &'a ExposureChain,
    radiance: &'a [[f32; 3]],
    white_balance: [f32; 3],
    seed: u64,
    first_pixel: u64,
    lut: &'a [u8],
    out: &'a mut [u8],
}

impl simd::Kernel for ExposeRun<'_> {
    type Output = ();
    #[inline(always)]
    fn run(self) {
        let Self {
            chain,
            radiance,
            white_balance,
            seed,
            first_pixel,
            lut,
            out,
        } = self;
        let groups = radiance.len().min(out.len() / 3) / EXPOSE_LANES;
        let (head, tail) = radiance.split_at(groups * EXPOSE_LANES);
        let (out_head, out_tail) = out.split_at_mut(groups * EXPOSE_LANES * 3);
        for (k, (r, o)) in head
            .chunks_exact(EXPOSE_LANES)
            .zip(out_head.chunks_exact_mut(3 * EXPOSE_LANES))
            .enumerate()
        {
            if let (Ok(r), Ok(o)) = (
                <&[[f32; 3]; EXPOSE_LANES]>::try_from(r),
                <&mut [u8; 3 * EXPOSE_LANES]>::try_from(o),
            ) {
                let first = first_pixel + (k * EXPOSE_LANES) as u64;
                chain.pixels(r, white_balance, seed, first, lut, o);
            }
        }
        let first = first_pixel + head.len() as u64;
        for ((j, r), o) in tail.iter().enumerate().zip(out_tail.chunks_exact_mut(3)) {
            if let Ok(o) = <&mut [u8; 3]>::try_from(o) {
                chain.pixels(&[*r], white_balance, seed, first + j as u64, lut, o);
            }
        }
    }
}

/// Per-capture constants of the signal chain (module docs, steps 2-5).
///
/// Electrons are f32 (24-bit mantissa against a 10 000 e- full well: far finer than the
/// 8-bit output), so [`ExposeRun`] holds 16 pixels' channel values per AVX-512 vector.
struct ExposureChain {
    /// Electrons per cd/m^2: `S t`.
    e_scale: f32,
    /// Table index per electron: `g / FW (SRGB_LUT_SIZE - 1)`.
    index_per_e: f32,
    read2: f32,
    full_well: f32,
    noise: bool,
}

impl ExposureChain {
    fn new(p: &RgbSensorParams, exposure: &Exposure) -> Self {
        Self {
            e_scale: (p.sensitivity_e_per_nit_s * exposure.exposure_s) as f32,
            index_per_e: (exposure.gain / p.full_well_electrons * (SRGB_LUT_SIZE - 1) as f64)
                as f32,
            read2: (p.read_noise_electrons * p.read_noise_electrons) as f32,
            full_well: p.full_well_electrons as f32,
            noise: p.noise_enabled,
        }
    }

    /// Steps 1-5 for the `N` consecutive pixels from `first` (radiance before white balance
    /// `white_balance`), 3 bytes per pixel into `out`.
    #[inline(always)]
    fn pixels<const N: usize, const B: usize>(
        &self,
        radiance: &[[f32; 3]; N],
        white_balance: [f32; 3],
        seed: u64,
        first: u64,
        lut: &[u8],
        out: &mut [u8; B],
    ) {
        const LAST: f32 = (SRGB_LUT_SIZE - 1) as f32;
        let mut n = [[0.0_f32; N]; 3];
        if self.noise {
            for i in 0..N {
                let d = standard_normal_rgb(seed, first + i as u64);
                for (nc, dc) in n.iter_mut().zip(d) {
                    nc[i] = dc;
                }
            }
        }
        let mut index = [[0_u32; N]; 3];
        for c in 0..3 {
            for i in 0..N {
                // Finite values: plain comparisons for the clips.
                let e = radiance[i][c] * white_balance[c] * self.e_scale;
                let e = if e > 0.0 { e } else { 0.0 };
                let e = e + (e + self.read2).sqrt() * n[c][i];
                let e = if e > 0.0 { e } else { 0.0 };
                let e = if e < self.full_well {
                    e
                } else {
                    self.full_well
                };
                // Normalised value `e g / FW` clipped to [0, 1], as the nearest table index:
                // adding 2^23 leaves round(x) in the low mantissa bits (x in 0..=65535).
                let x = e * self.index_per_e;
                let x = if x < LAST { x } else { LAST };
                index[c][i] = (x + ROUND_MAGIC)
                    .to_bits()
                    .wrapping_sub(ROUND_MAGIC.to_bits());
            }
        }
        for (i, o) in out.chunks_exact_mut(3).enumerate().take(N) {
            for (c, b) in o.iter_mut().enumerate() {
                *b = lut.get(index[c][i] as usize).copied().unwrap_or(255);
            }
        }
    }
}

/// `2^23`: adding it to a float in `[0, 2^22)` rounds it to an integer held in the low
/// mantissa bits.
const ROUND_MAGIC: f32 = 8_388_608.0;

/// Three independent, approximately standard normal deviates (one per channel) keyed by
/// (seed, pixel), one SplitMix64 draw per pixel: channel `c` is the Irwin-Hall sum
/// of the four 5-bit uniforms `(f + 0.5) / 32` in bits `20c .. 20c + 20`, centred and
/// scaled to unit variance (a 5-bit uniform's variance is `(1 - 32^-2) / 12`, hence
/// `sqrt(3 / (1 - 1/1024))`). 125 levels over +-3.46 sigma: far finer than sensor noise
/// needs, at a third of the hashing.
#[inline]
#[must_use]
pub fn standard_normal_rgb(seed: u64, pixel: u64) -> [f32; 3] {
    let h = splitmix64(seed.wrapping_add(pixel.wrapping_mul(SPLITMIX_GAMMA)));
    // Pairwise field sums for all three channels at once (SWAR): fields 0+1 of each channel
    // land in its bits 0..6, fields 2+3 in its bits 10..16 (at most 62: no carry into the
    // next pair).
    let pairs = (h & PAIR_MASK) + ((h >> 5) & PAIR_MASK);
    let mut out = [0.0_f32; 3];
    for (c, o) in out.iter_mut().enumerate() {
        let p = (pairs >> (20 * c)) as u32;
        let s = (p & 63) + ((p >> 10) & 63);
        // Sum of the four uniforms: (s + 2) / 32, mean 2.
        *o = ((s as f32 + 2.0) * (1.0 / 32.0) - 2.0) * RGB_NORMAL_SCALE;
    }
    out
}

/// Fields 0 and 2 (bits 0..5 and 10..15) of each channel's 20 bits.
const PAIR_MASK: u64 = 0x7c1f | (0x7c1f << 20) | (0x7c1f << 40);

/// `sqrt(3 / (1 - 1/1024))`: unit variance for the sum of four 5-bit uniforms.
const RGB_NORMAL_SCALE: f32 = 1.732_897_5;

/// Approximately standard normal deviate keyed by (seed, counter): Irwin-Hall of 4 uniforms
/// from one 64-bit hash, `(sum - 2) sqrt(3)`, unit variance. The hash is SplitMix64's output
/// at position `counter` of the stream starting at `seed` (one finaliser per draw; the
/// generator is built for consecutive counters).
#[inline]
#[must_use]
pub fn standard_normal(seed: u64, counter: u64) -> f64 {
    let h = splitmix64(seed.wrapping_add(counter.wrapping_mul(SPLITMIX_GAMMA)));
    let s = (h & 0xffff) + ((h >> 16) & 0xffff) + ((h >> 32) & 0xffff) + (h >> 48);
    // Each 16-bit uniform is (x + 0.5) / 65536.
    let u_sum = (s as f64 + 2.0) / 65_536.0;
    (u_sum - 2.0) * 3.0_f64.sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A run (two lane groups and a tail) gives each pixel the bytes of `expose_pixel` on
    /// its white-balanced radiance, at every vector level.
    #[test]
    fn expose_run_equals_expose_pixel_at_every_level() {
        let p = RgbSensorParams::default();
        let exposure = Exposure {
            exposure_s: 0.004,
            gain: 2.0,
        };
        let wb = [0.9, 1.0, 1.3];
        let radiance: Vec<[f32; 3]> = (0..2 * EXPOSE_LANES + 5)
            .map(|i| {
                let x = i as f32;
                [x * 3.1, 40.0 + x * 0.7, (x * 0.37).sin().abs() * 90.0]
            })
            .collect();
        let lut = srgb_lut();
        for level in [
            simd::Level::Baseline,
            simd::Level::Avx2,
            simd::Level::Avx512,
        ] {
            let mut out = vec![0_u8; 3 * radiance.len()];
            simd::with_max_level(level, || {
                p.expose_run(
                    simd::max_level(),
                    &radiance,
                    wb,
                    &exposure,
                    99,
                    1000,
                    &mut out,
                );
            });
            for (i, (r, o)) in radiance.iter().zip(out.chunks_exact(3)).enumerate() {
                let mut one = [0_u8; 3];
                let l = [r[0] * wb[0], r[1] * wb[1], r[2] * wb[2]];
                p.expose_pixel(l, &exposure, 99, 1000 + i as u64, lut, &mut one);
                assert_eq!(o, one, "{level:?} pixel {i}");
            }
        }
    }

    #[test]
    fn normal_has_unit_variance() {
        let n = 100_000;
        let (mut s, mut s2) = (0.0, 0.0);
        for i in 0..n {
            let x = standard_normal(5, i);
            s += x;
            s2 += x * x;
        }
        let m = s / n as f64;
        assert!(m.abs() < 0.01);
        assert!((s2 / n as f64 - m * m - 1.0).abs() < 0.02);
    }

    #[test]
    fn rgb_normals_have_unit_variance_and_independent_channels() {
        let n = 200_000;
        let (mut s, mut s2, mut cross) = ([0.0_f64; 3], [0.0_f64; 3], 0.0_f64);
        for i in 0..n {
            let x = standard_normal_rgb(9, i);
            for c in 0..3 {
                s[c] += f64::from(x[c]);
                s2[c] += f64::from(x[c]) * f64::from(x[c]);
            }
            cross += f64::from(x[0]) * f64::from(x[2]);
        }
        for c in 0..3 {
            let m = s[c] / n as f64;
            assert!(m.abs() < 0.01, "mean {m}");
            assert!(
                (s2[c] / n as f64 - m * m - 1.0).abs() < 0.015,
                "channel {c}"
            );
        }
        assert!((cross / n as f64).abs() < 0.01, "channels correlate");
    }

    /// The SWAR field sums equal the definition: four 5-bit fields per channel, summed.
    #[test]
    fn rgb_normals_sum_the_four_fields_of_each_channel() {
        for i in 0..20_000_u64 {
            let h = splitmix64(77_u64.wrapping_add(i.wrapping_mul(SPLITMIX_GAMMA)));
            let x = standard_normal_rgb(77, i);
            for (c, &xc) in x.iter().enumerate().take(3) {
                let bits = (h >> (20 * c)) as u32;
                let s: u32 = (0..4).map(|f| (bits >> (5 * f)) & 31).sum();
                let want = ((s as f32 + 2.0) * (1.0 / 32.0) - 2.0) * RGB_NORMAL_SCALE;
                assert_eq!(xc.to_bits(), want.to_bits(), "pixel {i} channel {c}");
            }
        }
    }

    /// The dusk numbers of the module docs: a grey scene (albedo 0.3) under the renderer's
    /// daylight reaches the target mean at sunset (400 lx) and at 18:02 (257 lx) with gain
    /// to spare, runs out of exposure and gain by 18:06 (106 lx), and at 18:24 (2 lx) the
    /// mean is below 20/255.
    #[test]
    fn auto_exposure_runs_out_three_minutes_after_sunset() {
        let p = RgbSensorParams::default();
        let mean_at = |hour: f64| {
            let lux = super::super::LightConditions::from_hour(hour).horizontal_lux();
            let luminance = lux * 0.3 / std::f64::consts::PI;
            let mut h = vec![0u64; HISTOGRAM_BINS];
            h[histogram_bin(luminance as f32)] = 1;
            let e = p.auto_exposure(&h);
            let k = e.exposure_s * e.gain * p.sensitivity_e_per_nit_s / p.full_well_electrons;
            (
                lux,
                e,
                255.0 * srgb_encode(k * bin_center(histogram_bin(luminance as f32))),
            )
        };
        let (lux, e, mean) = mean_at(18.0);
        assert!((lux - 400.0).abs() < 1.0 && e.gain < p.max_gain);
        assert!((mean - 255.0 * p.target_mean).abs() < 1.0, "{mean}");
        let (_, e, _) = mean_at(18.0 + 2.0 / 60.0);
        assert!(e.gain < p.max_gain, "{e:?}");
        let (lux, e, mean) = mean_at(18.1);
        assert!(lux < 190.0 && e.gain == p.max_gain && e.exposure_s == p.max_exposure_s);
        assert!(mean < 255.0 * p.target_mean - 5.0, "{mean}");
        let (lux, _, mean) = mean_at(18.4);
        assert!(lux < 3.0 && mean < 20.0, "{lux} lx: {mean}");
    }

    #[test]
    fn auto_exposure_raises_gain_in_low_light() {
        let p = RgbSensorParams::default();
        let mut bright = vec![0u64; HISTOGRAM_BINS];
        let mut dim = vec![0u64; HISTOGRAM_BINS];
        bright[histogram_bin(3000.0)] = 100;
        dim[histogram_bin(12.0)] = 100;
        let eb = p.auto_exposure(&bright);
        let ed = p.auto_exposure(&dim);
        assert!(eb.gain == 1.0 && eb.exposure_s < p.max_exposure_s);
        assert!(ed.gain > 2.0 && ed.exposure_s == p.max_exposure_s, "{ed:?}");
    }
}
