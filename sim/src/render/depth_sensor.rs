//! Structured-light depth: noise growing with z^2 and the ways the pattern gets lost.
//!
//! Triangulation depth error: `sigma_z = sigma_ref (z / z_ref)^2` (disparity noise
//! propagated through `z = f b / d` gives `dz = z^2 / (f b) dd`; Khoshelham & Elberink,
//! Sensors 2012, eq. 10), with the design figure 0.1 mm at 0.5 m (ARCHITECTURE.md section 6).
//! Depth is `z` along the optical axis (not the range along the ray), registered to the colour
//! pixels (same rays).
//!
//! Holes (NaN; 0 in 16UC1) where the projected pattern is not decoded:
//! * outside `[min_range_m, max_range_m]`;
//! * grazing incidence: angle between the ray and the surface normal above
//!   `max_incidence_deg` (75 deg): the pattern is stretched beyond decoding;
//! * very dark surfaces: albedo luminance below `dark_albedo`: holes with probability
//!   `1 - albedo / dark_albedo`;
//! * mirror-like metal seen near its mirror direction (cosine above
//!   `specular_hole_cos`): the projector saturates the camera;
//! * strong sun: the sun's illuminance on the surface `E_s` washes the pattern out with
//!   probability `p = p_max clamp((E_s - E_0) / (E_1 - E_0), 0, 1)`, `E_0` = 50 klx; holes
//!   are blobs, thresholding smooth value noise (8 px cells) against `p`, as real wash-out
//!   is spatially coherent;
//! * depth discontinuities: pixels whose antialiasing sub-samples straddle a depth step
//!   of more than `flying_pixel_ratio` are dropped (the camera's flying-pixel filter).
//!
//! All random draws are keyed by (capture seed, pixel index): thread-count independent.

use crate::render::rgb_sensor::standard_normal;
use crate::scene::noise::{uniform_open, value_lanes};

/// Depth sensor parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DepthSensorParams {
    /// Noise standard deviation at `reference_depth_m` (m). Default 1e-4.
    pub sigma_at_reference_m: f64,
    /// Reference depth of the noise figure (m). Default 0.5.
    pub reference_depth_m: f64,
    /// Nearest measurable depth (m). Default 0.2.
    pub min_range_m: f64,
    /// Farthest measurable depth (m). Default 2.0.
    pub max_range_m: f64,
    /// Largest angle between ray and normal that still decodes (deg). Default 75.
    pub max_incidence_deg: f64,
    /// Albedo below which dark surfaces start dropping out. Default 0.03.
    pub dark_albedo: f64,
    /// Cosine between the view ray and a metal surface's normal above which the projector
    /// saturates. Default 0.998.
    pub specular_hole_cos: f64,
    /// Sun illuminance on the surface where wash-out starts (lx). Default 50 000.
    pub sun_washout_start_lux: f64,
    /// Sun illuminance where wash-out reaches `sun_washout_max_probability` (lx). Default 90 000.
    pub sun_washout_full_lux: f64,
    /// Largest wash-out probability. Default 0.9.
    pub sun_washout_max_probability: f64,
    /// Relative depth step across a pixel's sub-samples that drops it. Default 0.02.
    pub flying_pixel_ratio: f64,
    /// Whether to add noise. Default true.
    pub noise_enabled: bool,
    /// Whether to make holes (range limits still apply when false). Default true.
    pub holes_enabled: bool,
}

impl Default for DepthSensorParams {
    fn default() -> Self {
        Self {
            sigma_at_reference_m: 1e-4,
            reference_depth_m: 0.5,
            min_range_m: 0.2,
            max_range_m: 2.0,
            max_incidence_deg: 75.0,
            dark_albedo: 0.03,
            specular_hole_cos: 0.998,
            sun_washout_start_lux: 50_000.0,
            sun_washout_full_lux: 90_000.0,
            sun_washout_max_probability: 0.9,
            flying_pixel_ratio: 0.02,
            noise_enabled: true,
            holes_enabled: true,
        }
    }
}

/// What the renderer knows about the surface seen by one pixel's centre ray.
#[derive(Clone, Copy, Debug)]
pub struct DepthSample {
    /// Exact depth along the optical axis (m).
    pub z_m: f64,
    /// Cosine between the reversed ray and the normal.
    pub cos_incidence: f64,
    /// Albedo luminance.
    pub albedo: f64,
    /// Direct-sun illuminance on the surface (lx, 0 in shadow).
    pub sun_lux: f64,
    /// Whether the material is a specular metal.
    pub metal: bool,
}

/// Salt separating depth draws from colour draws.
const DEPTH_SALT: u64 = 0xd397_4a11_0c5e_7b21;

impl DepthSensorParams {
    /// Noise standard deviation at depth `z_m`: `sigma_ref (z / z_ref)^2`.
    #[must_use]
    pub fn sigma_m(&self, z_m: f64) -> f64 {
        let r = z_m / self.reference_depth_m;
        self.sigma_at_reference_m * r * r
    }

    /// Measured depth (NaN = hole) of a pixel at `(col, row)` with index `pixel`.
    #[must_use]
    pub fn measure(&self, s: &DepthSample, seed: u64, pixel: u64, col: u32, row: u32) -> f32 {
        self.measure_with(self.max_incidence_cos(), s, seed, pixel, col, row)
    }

    /// Cosine of [`Self::max_incidence_deg`] (the grazing-hole threshold).
    #[must_use]
    pub fn max_incidence_cos(&self) -> f64 {
        self.max_incidence_deg.to_radians().cos()
    }

    /// [`Self::measure`] with the grazing threshold `max_incidence_cos`
    /// ([`Self::max_incidence_cos`]) computed once per capture instead of per pixel.
    #[must_use]
    pub fn measure_with(
        &self,
        max_incidence_cos: f64,
        s: &DepthSample,
        seed: u64,
        pixel: u64,
        col: u32,
        row: u32,
    ) -> f32 {
        let mut one = DepthLanes::<1>::default();
        one.set(0, s, pixel, col, row);
        self.measure_lanes(max_incidence_cos, &one, seed)[0]
    }

    /// [`Self::measure_with`] of `N` pixels at once (lane `i` is pixel `i`'s measurement,
    /// bit for bit): every hole test is evaluated in all lanes and selected, and the draws
    /// a test needs (dark-surface dropout, sun wash-out blobs) are skipped for batches where
    /// no lane reaches it.
    // Lanes are indexed in step across several arrays (the vectorised form).
    #[allow(clippy::needless_range_loop)]
    #[inline(always)]
    #[must_use]
    pub fn measure_lanes<const N: usize>(
        &self,
        max_incidence_cos: f64,
        s: &DepthLanes<N>,
        seed: u64,
    ) -> [f32; N] {
        let seed = seed ^ DEPTH_SALT;
        let mut hole = [false; N];
        let mut any_dark = false;
        let mut any_sun = false;
        for i in 0..N {
            let z = s.z_m[i];
            hole[i] = !(z >= self.min_range_m && z <= self.max_range_m);
            if self.holes_enabled {
                let c = s.cos_incidence[i];
                hole[i] |= c < max_incidence_cos || (s.metal[i] && c > self.specular_hole_cos);
                any_dark |= s.albedo[i] < self.dark_albedo;
                any_sun |= s.sun_lux[i] > self.sun_washout_start_lux;
            }
        }
        if any_dark {
            for i in 0..N {
                let dark = s.albedo[i] < self.dark_albedo;
                let p = 1.0 - s.albedo[i] / self.dark_albedo;
                hole[i] |= dark && uniform_open(seed, s.pixel[i]) < p;
            }
        }
        if any_sun {
            let span = (self.sun_washout_full_lux - self.sun_washout_start_lux).max(1.0);
            let blob = value_lanes(
                s.col.map(|c| c as f32 / 8.0),
                s.row.map(|r| r as f32 / 8.0),
                [(seed ^ (seed >> 32)) as u32; N],
            );
            for i in 0..N {
                let sunny = s.sun_lux[i] > self.sun_washout_start_lux;
                let p = self.sun_washout_max_probability
                    * ((s.sun_lux[i] - self.sun_washout_start_lux) / span).clamp(0.0, 1.0);
                // value2 is concentrated around 0.5; stretch it to roughly uniform.
                let q = f64::from(((blob[i] - 0.5) * 1.8 + 0.5).clamp(0.0, 1.0));
                hole[i] |= sunny && q < p;
            }
        }
        let mut out = [0.0_f32; N];
        for i in 0..N {
            let z = s.z_m[i];
            let z = if self.noise_enabled {
                z + self.sigma_m(z) * standard_normal(seed, s.pixel[i])
            } else {
                z
            };
            out[i] = if hole[i] { f32::NAN } else { z as f32 };
        }
        out
    }
}

/// Depth samples of `N` pixels (one per lane) with their pixel index and position, the
/// input of [`DepthSensorParams::measure_lanes`].
#[derive(Clone, Copy, Debug)]
pub struct DepthLanes<const N: usize> {
    /// [`DepthSample::z_m`] per lane.
    pub z_m: [f64; N],
    /// [`DepthSample::cos_incidence`] per lane.
    pub cos_incidence: [f64; N],
    /// [`DepthSample::albedo`] per lane.
    pub albedo: [f64; N],
    /// [`DepthSample::sun_lux`] per lane.
    pub sun_lux: [f64; N],
    /// [`DepthSample::metal`] per lane.
    pub metal: [bool; N],
    /// Pixel index (the draws' counter) per lane.
    pub pixel: [u64; N],
    /// Pixel column per lane.
    pub col: [u32; N],
    /// Pixel row per lane.
    pub row: [u32; N],
}

impl<const N: usize> Default for DepthLanes<N> {
    fn default() -> Self {
        Self {
            z_m: [0.0; N],
            cos_incidence: [0.0; N],
            albedo: [0.0; N],
            sun_lux: [0.0; N],
            metal: [false; N],
            pixel: [0; N],
            col: [0; N],
            row: [0; N],
        }
    }
}

impl<const N: usize> DepthLanes<N> {
    /// Puts pixel `(col, row)` with index `pixel` and sample `s` into lane `i` (ignored
    /// beyond `N`).
    #[inline(always)]
    pub fn set(&mut self, i: usize, s: &DepthSample, pixel: u64, col: u32, row: u32) {
        if i < N {
            self.z_m[i] = s.z_m;
            self.cos_incidence[i] = s.cos_incidence;
            self.albedo[i] = s.albedo;
            self.sun_lux[i] = s.sun_lux;
            self.metal[i] = s.metal;
            self.pixel[i] = pixel;
            self.col[i] = col;
            self.row[i] = row;
        }
    }
}

/// Converts metres (NaN = no data) to 16UC1 millimetres (0 = no data, saturating at
/// 65 535 mm), rounding to the nearest millimetre.
#[must_use]
pub fn depth_to_mm(depth_m: &[f32]) -> Vec<u16> {
    depth_m
        .iter()
        .map(|&z| {
            if z.is_finite() && z > 0.0 {
                (f64::from(z) * 1000.0).round().clamp(1.0, 65_535.0) as u16
            } else {
                0
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sigma_grows_with_z_squared() {
        let p = DepthSensorParams::default();
        assert!((p.sigma_m(0.5) - 1e-4).abs() < 1e-15);
        assert!((p.sigma_m(1.0) - 4e-4).abs() < 1e-15);
    }

    /// Lane `i` of a batch is `measure_with` of pixel `i`, bit for bit, across range
    /// limits, grazing, metal, dark and sunlit surfaces.
    #[test]
    fn lanes_equal_single_measurements() {
        let p = DepthSensorParams::default();
        let max_cos = p.max_incidence_cos();
        let mut kinds = [0_usize; 4];
        for k in 0..2000_u64 {
            let mut lanes = DepthLanes::<8>::default();
            let mut samples = [DepthSample {
                z_m: 0.0,
                cos_incidence: 0.0,
                albedo: 0.0,
                sun_lux: 0.0,
                metal: false,
            }; 8];
            for (i, s) in samples.iter_mut().enumerate() {
                let x = (k * 8 + i as u64) as f64;
                *s = DepthSample {
                    z_m: 0.1 + (x * 0.618).fract() * 2.3,
                    cos_incidence: (x * 0.414).fract(),
                    albedo: (x * 0.271).fract() * 0.06,
                    sun_lux: (x * 0.173).fract() * 120_000.0,
                    metal: (k + i as u64).is_multiple_of(5),
                };
                lanes.set(i, s, 1000 + x as u64, (x as u32) % 97, (x as u32) / 97);
            }
            let z = p.measure_lanes(max_cos, &lanes, 42);
            for (i, s) in samples.iter().enumerate() {
                let one =
                    p.measure_with(max_cos, s, 42, lanes.pixel[i], lanes.col[i], lanes.row[i]);
                assert_eq!(z[i].to_bits(), one.to_bits(), "batch {k} lane {i}");
                kinds[usize::from(one.is_nan())
                    + 2 * usize::from(s.sun_lux > p.sun_washout_start_lux)] += 1;
            }
        }
        assert!(kinds.iter().all(|&n| n > 500), "{kinds:?}");
    }

    #[test]
    fn grazing_and_range_holes() {
        let p = DepthSensorParams::default();
        let s = DepthSample {
            z_m: 0.5,
            cos_incidence: 0.2,
            albedo: 0.5,
            sun_lux: 0.0,
            metal: false,
        };
        assert!(p.measure(&s, 1, 0, 0, 0).is_nan());
        let s = DepthSample {
            cos_incidence: 0.9,
            z_m: 3.0,
            ..s
        };
        assert!(p.measure(&s, 1, 0, 0, 0).is_nan());
        let s = DepthSample { z_m: 0.5, ..s };
        assert!(p.measure(&s, 1, 0, 0, 0).is_finite());
        assert_eq!(depth_to_mm(&[0.5004, f32::NAN, -1.0]), vec![500, 0, 0]);
    }
}
