//! The wrist light during an operation: when to light the scene.
//!
//! A robot with a wrist light (its driver publishes `/wrist_light/state`) lights the wrist
//! camera's scene while an operation runs and the mast's lux meter (`/env/illuminance`) reads
//! below [`LightingParams::on_below_lux`]; above [`LightingParams::off_above_lux`] it lets
//! daylight do (hysteresis: the meter's noise never makes the lamp flicker). Why a lux meter
//! and not the images: the camera's auto-exposure keeps the image mean up until its longest
//! exposure and highest gain run out, so a dark image tells too late, after a capture was
//! lost; the meter tells before the first capture, as a car's light sensor does. The lamp is
//! switched off when the operation ends. A robot without the light never gets a command.
//!
//! # Why 30 lx, not at sunset
//! The lamp turns the silhouettes around: by day the stored rod's dark grip stands against
//! the bright sky; lit by the lamp at night it stands bright against a black one. In between
//! the lamp-lit grip and the twilight sky behind it are about as bright, and the colour
//! confirmation cannot see the grip's edge. Measured on seeded sites (hangs with the
//! self-maintenance on): with the lamp, a site's hang was refused (`low_confidence`, the
//! handle's `colour_contrast`) from 400 lx (18:00) down to 50 lx (18:09) and succeeded from
//! 28 lx (18:12) on; without it, the same hangs succeeded down to 28 lx and were refused from
//! 15 lx (18:15). So the lamp comes on below 30 lx, where the camera alone gives out, and not
//! before, and goes off above 60 lx.
//!
//! What the light reaches: the wrist camera's scene (the wire, the handle, the rack and the
//! calibration target at 0.3-1 m), never the panoramic camera's view of the bay. So when the
//! panoramic camera cannot find the wire in the dark, a lit task looks for it with the wrist
//! camera at the survey's prior instead of refusing.

/// When to light ([`decide`]); every default is documented on its field.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightingParams {
    /// Light the scene while the lux meter reads below this (lx). Default 30 (module docs).
    pub on_below_lux: f64,
    /// Switch off when it reads above this (lx). Default 60.
    pub off_above_lux: f64,
    /// Brightness when on (0..1). Default 1.
    pub brightness: f64,
}

impl Default for LightingParams {
    fn default() -> Self {
        Self {
            on_below_lux: 30.0,
            off_above_lux: 60.0,
            brightness: 1.0,
        }
    }
}

/// What the task knows of the light and the daylight.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Lighting {
    /// The light's reported brightness; `None` until its driver reported (no light).
    pub state: Option<f64>,
    /// The latest lux meter reading (lx).
    pub lux: Option<f64>,
    /// The brightness last commanded.
    pub commanded: Option<f64>,
}

impl Lighting {
    /// Whether the wrist light reports that it is on.
    #[must_use]
    pub fn lit(&self) -> bool {
        self.state.is_some_and(|b| b > 0.0)
    }
}

/// The brightness to command now, if it differs from the last command: `operating` is
/// whether an operation runs (off otherwise). `None` without a light, or when nothing changes.
#[must_use]
pub fn decide(lighting: &Lighting, params: &LightingParams, operating: bool) -> Option<f64> {
    lighting.state?;
    let on = lighting.commanded.is_some_and(|b| b > 0.0);
    let want_on = operating
        && match lighting.lux {
            Some(lux) if on => lux <= params.off_above_lux,
            Some(lux) => lux < params.on_below_lux,
            // No reading yet: keep what it is.
            None => on,
        };
    let want = if want_on { params.brightness } else { 0.0 };
    let current = lighting.commanded.unwrap_or(0.0);
    (want != current).then_some(want)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lights_below_the_threshold_with_hysteresis_and_only_with_a_light() {
        let p = LightingParams::default();
        let mut l = Lighting {
            state: Some(0.0),
            lux: Some(3.0),
            commanded: None,
        };
        assert_eq!(decide(&l, &p, true), Some(1.0));
        l.commanded = Some(1.0);
        assert_eq!(decide(&l, &p, true), None);
        // Noise around the on threshold does not switch it off...
        l.lux = Some(45.0);
        assert_eq!(decide(&l, &p, true), None);
        // ...more light does (sunset's 400 lx: the lamp would hide the grip), and the end of
        // the operation does.
        l.lux = Some(400.0);
        assert_eq!(decide(&l, &p, true), Some(0.0));
        l.lux = Some(3.0);
        assert_eq!(decide(&l, &p, false), Some(0.0));
        // At sunset it stays off.
        let sunset = Lighting {
            state: Some(0.0),
            lux: Some(400.0),
            commanded: None,
        };
        assert_eq!(decide(&sunset, &p, true), None);
        // Daylight: nothing to do.
        let day = Lighting {
            state: Some(0.0),
            lux: Some(50_000.0),
            commanded: None,
        };
        assert_eq!(decide(&day, &p, true), None);
        // No light on this robot: never a command.
        let none = Lighting {
            state: None,
            lux: Some(1.0),
            commanded: None,
        };
        assert_eq!(decide(&none, &p, true), None);
    }
}
