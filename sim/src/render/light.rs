//! Daylight from the hour of day: sun direction, direct and diffuse illuminance, colours.
//!
//! Sun path (a simple symmetric day, world x east, y north, z up): sunrise 06:00, sunset
//! 18:00, elevation `e(h) = E_max sin(pi (h - 6) / 12)` with `E_max` = [`NOON_ELEVATION_DEG`],
//! azimuth from north `A(h) = 90 deg + 180 deg (h - 6) / 12` (east -> south -> west).
//!
//! Global horizontal illuminance, anchored to ARCHITECTURE.md section 6 (~100 klx at noon, ~400 lx
//! at sunset, ~3 lx at the end of civil twilight, e = -6 deg):
//! * `e >= 0`: `E = 400 + (100000 - 400) (sin e / sin E_max)^1.3`;
//! * `e < 0`: log-linear, `ln E = ln 400 + (ln 400 - ln 3) e / 6 deg`, floored at
//!   [`NIGHT_LUX`].
//!
//! Split into direct sun and diffuse sky: the direct share of the horizontal illuminance is
//! `0.8 s(e)` with `s` a smoothstep from 0 to 12 deg, and the sun's normal illuminance is
//! that share divided by `sin e`. Colours (luminance-normalised linear RGB) warm up towards
//! the horizon (sun) and the sky turns deep blue in twilight.

use nalgebra::Vector3;

/// Sun elevation at noon (deg).
pub const NOON_ELEVATION_DEG: f64 = 62.0;
/// Global horizontal illuminance at noon (lx).
pub const NOON_LUX: f64 = 100_000.0;
/// At sunset (lx).
pub const SUNSET_LUX: f64 = 400.0;
/// At the end of civil twilight, sun 6 deg below the horizon (lx).
pub const CIVIL_TWILIGHT_END_LUX: f64 = 3.0;
/// Floor (moonless night, lx).
pub const NIGHT_LUX: f64 = 0.001;
/// Distance at which the white balance weighs a lamp's light against daylight (m): the
/// wrist camera's working distance.
pub const LAMP_WHITE_BALANCE_DISTANCE_M: f64 = 0.45;

/// Light of one moment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightConditions {
    /// Unit vector towards the sun (world frame).
    pub sun_direction: Vector3<f64>,
    /// Illuminance of the direct sun on a surface facing it (lx).
    pub sun_normal_lux: f64,
    /// Diffuse sky illuminance on a horizontal surface (lx).
    pub sky_horizontal_lux: f64,
    /// Sun colour (linear RGB, luminance 1).
    pub sun_rgb: [f64; 3],
    /// Sky colour at the zenith (linear RGB, luminance 1).
    pub sky_zenith_rgb: [f64; 3],
    /// Sky colour at the horizon (linear RGB, luminance 1).
    pub sky_horizon_rgb: [f64; 3],
    /// The lamp beside the camera's lens, when it is lit.
    pub lamp: Option<Lamp>,
}

/// A lamp beside the camera's lens (the wrist light): a point source whose beam follows the
/// optical axis.
///
/// Intensity at angle `theta` off the axis: `I(theta) = I_0 b cos(theta)^m`, `b` the
/// brightness commanded (0..1), `m = ln 0.5 / ln cos(theta_half)` so the beam is at half its
/// axial intensity at `theta_half`; the luminous flux is `2 pi I_0 b / (m + 1)`.
/// Illuminance on a surface at distance `r` with incidence cosine `n.l`:
/// `E = I(theta) n.l / r^2` (inverse-square falloff). The lamp casts no shadow rays: it sits
/// [`WRIST_LAMP_OFFSET_M`] from the lens, so the camera sees almost none of its shadows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lamp {
    /// Axial intensity at full brightness, `I_0` (cd).
    pub intensity_cd: f64,
    /// Brightness commanded, `b` (0..1).
    pub brightness: f64,
    /// Half-intensity half-angle of the beam, `theta_half` (deg).
    pub half_angle_deg: f64,
    /// Position in the camera's optical frame (m).
    pub offset_m: [f64; 3],
    /// Colour (linear RGB, luminance 1).
    pub rgb: [f64; 3],
}

/// Axial intensity of the wrist lamp (cd): with [`WRIST_LAMP_HALF_ANGLE_DEG`] about
/// 1,400 lm, a 12-15 W white LED work light; 4,900 lx at the 0.45 m working distance, 1,000 lx
/// at 1 m (overcast daylight is 1-10 klx).
pub const WRIST_LAMP_INTENSITY_CD: f64 = 1_000.0;
/// Half-intensity half-angle of its beam (deg): wider than the wrist camera's 40 x 33 deg
/// view, whose corners (25 deg off the axis) get 71% of the axial intensity.
pub const WRIST_LAMP_HALF_ANGLE_DEG: f64 = 35.0;
/// Its position in the camera's optical frame (m): 4 cm above the lens.
pub const WRIST_LAMP_OFFSET_M: [f64; 3] = [0.0, -0.04, 0.0];
/// Its colour: a 5000 K white LED (linear RGB, luminance 1).
pub const WRIST_LAMP_RGB: [f64; 3] = [1.06, 0.99, 0.86];

impl Lamp {
    /// The wrist lamp ([`WRIST_LAMP_INTENSITY_CD`] ...) at `brightness` (clamped to 0..1).
    #[must_use]
    pub fn wrist(brightness: f64) -> Self {
        Self {
            intensity_cd: WRIST_LAMP_INTENSITY_CD,
            brightness: brightness.clamp(0.0, 1.0),
            half_angle_deg: WRIST_LAMP_HALF_ANGLE_DEG,
            offset_m: WRIST_LAMP_OFFSET_M,
            rgb: normalized(WRIST_LAMP_RGB),
        }
    }

    /// The beam exponent `m` (struct docs).
    #[must_use]
    pub fn beam_exponent(&self) -> f64 {
        0.5_f64.ln() / self.half_angle_deg.to_radians().cos().ln().min(-1e-9)
    }

    /// Intensity (cd) at `cos_theta` off the axis (0 behind the lamp).
    #[must_use]
    pub fn intensity_at(&self, cos_theta: f64) -> f64 {
        if cos_theta <= 0.0 {
            return 0.0;
        }
        self.intensity_cd * self.brightness * cos_theta.powf(self.beam_exponent())
    }

    /// Luminous flux (lm): `2 pi I_0 b / (m + 1)`.
    #[must_use]
    pub fn flux_lm(&self) -> f64 {
        2.0 * std::f64::consts::PI * self.intensity_cd * self.brightness
            / (self.beam_exponent() + 1.0)
    }
}

fn smoothstep(a: f64, b: f64, x: f64) -> f64 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Rec. 709 luminance of a linear RGB triple.
#[must_use]
pub fn luminance(c: [f64; 3]) -> f64 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

fn normalized(c: [f64; 3]) -> [f64; 3] {
    let y = luminance(c).max(1e-12);
    [c[0] / y, c[1] / y, c[2] / y]
}

fn mix(a: [f64; 3], b: [f64; 3], t: f64) -> [f64; 3] {
    [
        a[0] + (b[0] - a[0]) * t,
        a[1] + (b[1] - a[1]) * t,
        a[2] + (b[2] - a[2]) * t,
    ]
}

/// Sun elevation (rad) at local solar hour `hour` (0..24).
#[must_use]
pub fn sun_elevation_rad(hour: f64) -> f64 {
    NOON_ELEVATION_DEG.to_radians() * (std::f64::consts::PI * (hour - 6.0) / 12.0).sin()
}

/// Global horizontal illuminance (lx) for a sun elevation (rad).
#[must_use]
pub fn global_illuminance_lux(elevation_rad: f64) -> f64 {
    if elevation_rad >= 0.0 {
        let s = elevation_rad.sin() / NOON_ELEVATION_DEG.to_radians().sin();
        SUNSET_LUX + (NOON_LUX - SUNSET_LUX) * s.powf(1.3)
    } else {
        let slope = (SUNSET_LUX / CIVIL_TWILIGHT_END_LUX).ln() / 6.0_f64.to_radians();
        (SUNSET_LUX.ln() + slope * elevation_rad)
            .exp()
            .max(NIGHT_LUX)
    }
}

impl LightConditions {
    /// Daylight at local solar hour `hour` (0..24, wraps).
    #[must_use]
    pub fn from_hour(hour: f64) -> Self {
        let h = hour.rem_euclid(24.0);
        let e = sun_elevation_rad(h);
        let az = (90.0 + 180.0 * (h - 6.0) / 12.0).to_radians();
        let sun_direction =
            Vector3::new(az.sin() * e.cos(), az.cos() * e.cos(), e.sin()).normalize();
        let total = global_illuminance_lux(e);
        let e_deg = e.to_degrees();
        let direct_share = 0.8 * smoothstep(0.0, 12.0, e_deg);
        let sun_normal_lux = if e > 0.0 {
            direct_share * total / e.sin().max(0.02)
        } else {
            0.0
        };
        let sky_horizontal_lux = total * (1.0 - direct_share);
        let warm = smoothstep(0.0, 25.0, e_deg);
        let sun_rgb = normalized(mix([1.0, 0.55, 0.25], [1.0, 0.96, 0.9], warm));
        let twilight = smoothstep(-6.0, 4.0, e_deg);
        let sky_zenith_rgb = normalized(mix([0.25, 0.35, 1.0], [0.55, 0.7, 1.0], twilight));
        let horizon_day = [0.85, 0.9, 1.0];
        let horizon_dusk = [1.0, 0.65, 0.45];
        let sky_horizon_rgb = normalized(mix(
            horizon_dusk,
            horizon_day,
            smoothstep(-2.0, 15.0, e_deg),
        ));
        Self {
            sun_direction,
            sun_normal_lux,
            sky_horizontal_lux,
            sun_rgb,
            sky_zenith_rgb,
            sky_horizon_rgb,
            lamp: None,
        }
    }

    /// The same daylight with `lamp` beside the camera (`None`, or a brightness of 0: unlit).
    #[must_use]
    pub fn with_lamp(mut self, lamp: Option<Lamp>) -> Self {
        self.lamp = lamp.filter(|l| l.brightness > 0.0 && l.intensity_cd > 0.0);
        self
    }

    /// Global horizontal illuminance (lx): `E_sun max(0, sin e) + E_sky`.
    #[must_use]
    pub fn horizontal_lux(&self) -> f64 {
        self.sun_normal_lux * self.sun_direction.z.max(0.0) + self.sky_horizontal_lux
    }

    /// The same sun and colours with both components scaled so the global horizontal
    /// illuminance is `lux` (e.g. overcast days, or test conditions).
    #[must_use]
    pub fn with_horizontal_lux(mut self, lux: f64) -> Self {
        let k = lux.max(0.0) / self.horizontal_lux().max(1e-12);
        self.sun_normal_lux *= k;
        self.sky_horizontal_lux *= k;
        self
    }

    /// Sky radiance (cd/m^2 per channel, linear RGB) seen along the unit direction `d`.
    ///
    /// Luminance `E_sky / pi * g(d)` with `g` rising from 0.8 at the zenith to 1.4 at the
    /// horizon, brightened towards the sun (forward scattering), colour blended from zenith to
    /// horizon; below the horizon a dim ground haze.
    #[must_use]
    pub fn sky_radiance(&self, d: &Vector3<f64>) -> [f64; 3] {
        let up = d.z.clamp(-1.0, 1.0);
        let base = self.sky_horizontal_lux / std::f64::consts::PI;
        if up < 0.0 {
            let k = base * 0.35;
            return [
                k * self.sky_horizon_rgb[0],
                k * self.sky_horizon_rgb[1],
                k * self.sky_horizon_rgb[2],
            ];
        }
        let t = (1.0 - up).powi(3);
        let toward_sun = d.dot(&self.sun_direction).max(0.0);
        let glow = 1.0 + 1.5 * toward_sun.powi(8);
        let g = (0.8 + 0.6 * t) * glow;
        let c = mix(self.sky_zenith_rgb, self.sky_horizon_rgb, t);
        [base * g * c[0], base * g * c[1], base * g * c[2]]
    }

    /// Mean illuminant colour seen by a camera (for white balance): the horizontal mix of
    /// sun and sky colours and, when lit, the lamp's at [`LAMP_WHITE_BALANCE_DISTANCE_M`] on
    /// its axis, luminance-normalised.
    #[must_use]
    pub fn illuminant_rgb(&self) -> [f64; 3] {
        let es = self.sun_normal_lux * self.sun_direction.z.max(0.0);
        let ek = self.sky_horizontal_lux;
        let sky = mix(self.sky_zenith_rgb, self.sky_horizon_rgb, 0.5);
        let (el, lamp) = self.lamp.map_or((0.0, [0.0; 3]), |l| {
            (
                l.intensity_at(1.0) / LAMP_WHITE_BALANCE_DISTANCE_M.powi(2),
                l.rgb,
            )
        });
        normalized([
            es * self.sun_rgb[0] + ek * sky[0] + el * lamp[0],
            es * self.sun_rgb[1] + ek * sky[1] + el * lamp[1],
            es * self.sun_rgb[2] + ek * sky[2] + el * lamp[2],
        ])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn anchors_of_the_design() {
        let noon = LightConditions::from_hour(12.0);
        assert!((noon.horizontal_lux() - NOON_LUX).abs() < 1.0);
        let sunset = LightConditions::from_hour(18.0);
        assert!((sunset.horizontal_lux() - SUNSET_LUX).abs() < 1e-6);
        // Civil twilight ends when the elevation is -6 deg.
        let hour = 18.0 + 12.0 / std::f64::consts::PI * (6.0 / NOON_ELEVATION_DEG).asin();
        let dusk = LightConditions::from_hour(hour);
        assert!((dusk.horizontal_lux() - CIVIL_TWILIGHT_END_LUX).abs() < 1e-6);
        assert!(noon.sun_direction.y < 0.0, "noon sun is in the south");
    }
}
