//! Structured-light depth: noise growing with z^2 and the ways the pattern gets lost.
//!
//! Triangulation depth error: `sigma_z = sigma_ref (z / z_ref)^2` (disparity noise
//! propagated through `z = f b / d` gives `dz = z^2 / (f b) dd`; Khoshelham & Elberink,
//! Sensors 2012, eq. 10), with the design figure 0.1 mm at 0.5 m (DESIGN.md section 6).
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
use crate::scene::noise::{uniform_open, value2};

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
        if !(s.z_m >= self.min_range_m && s.z_m <= self.max_range_m) {
            return f32::NAN;
        }
        let seed = seed ^ DEPTH_SALT;
        if self.holes_enabled {
            if s.cos_incidence < max_incidence_cos {
                return f32::NAN;
            }
            if s.metal && s.cos_incidence > self.specular_hole_cos {
                return f32::NAN;
            }
            if s.albedo < self.dark_albedo {
                let p = 1.0 - s.albedo / self.dark_albedo;
                if uniform_open(seed, pixel) < p {
                    return f32::NAN;
                }
            }
            if s.sun_lux > self.sun_washout_start_lux {
                let span = (self.sun_washout_full_lux - self.sun_washout_start_lux).max(1.0);
                let p = self.sun_washout_max_probability
                    * ((s.sun_lux - self.sun_washout_start_lux) / span).clamp(0.0, 1.0);
                let blob = value2(
                    col as f32 / 8.0,
                    row as f32 / 8.0,
                    (seed ^ (seed >> 32)) as u32,
                );
                // value2 is concentrated around 0.5; stretch it to roughly uniform.
                let q = f64::from(((blob - 0.5) * 1.8 + 0.5).clamp(0.0, 1.0));
                if q < p {
                    return f32::NAN;
                }
            }
        }
        let z = if self.noise_enabled {
            s.z_m + self.sigma_m(s.z_m) * standard_normal(seed, pixel)
        } else {
            s.z_m
        };
        z as f32
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
