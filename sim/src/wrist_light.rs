//! The wrist light (producer `light_driver`): a dimmable white LED lamp beside the wrist
//! camera's lens, for work at dusk.
//!
//! `/wrist_light/command` (std_msgs/Float64) sets the brightness, 0 (off) to 1 (full); any
//! other value is rejected. The lamp follows [`SWITCH_LATENCY`] later (driver and LED
//! current ramp). `/wrist_light/state` (std_msgs/Float64, [`STATE_PERIOD`]) reports the
//! brightness it gives. A robot without the light (scenario `camera.light = false`, the
//! default) publishes no state and rejects commands, so a task finds out from the state
//! topic whether it can light the scene. The renderer lights the wrist captures with
//! [`crate::render::Lamp::wrist`] at that brightness (falloff and glare on metal: see
//! [`crate::render::shading`]); the lux meter on the mast does not see it.

use msgs::drivers::DriverError;
use msgs::std_msgs::Float64;
use msgs::{RobotDuration, RobotTime};

use crate::render::Lamp;

/// Producer of the wrist light's state.
pub const LIGHT_DRIVER: &str = "light_driver";
/// Command -> the lamp at the new brightness.
pub const SWITCH_LATENCY: RobotDuration = RobotDuration::from_millis(20);
/// Period of `/wrist_light/state` (10 Hz).
pub const STATE_PERIOD: RobotDuration = RobotDuration::from_millis(100);

/// The simulated wrist light.
#[derive(Debug, Clone, PartialEq)]
pub struct WristLightSim {
    brightness: f64,
    /// A commanded brightness and when the lamp reaches it.
    pending: Option<(RobotTime, f64)>,
}

impl Default for WristLightSim {
    fn default() -> Self {
        Self::new()
    }
}

impl WristLightSim {
    /// A light that is off.
    #[must_use]
    pub fn new() -> Self {
        Self {
            brightness: 0.0,
            pending: None,
        }
    }

    /// Applies a due command.
    pub fn advance(&mut self, now: RobotTime) {
        if let Some((_, b)) = self.pending.filter(|(at, _)| *at <= now) {
            self.brightness = b;
            self.pending = None;
        }
    }

    /// A brightness command at `now`.
    ///
    /// # Errors
    /// [`DriverError::Rejected`] outside `[0, 1]` (or not finite).
    pub fn command(&mut self, now: RobotTime, brightness: &Float64) -> Result<(), DriverError> {
        let b = brightness.data;
        if !(0.0..=1.0).contains(&b) {
            return Err(DriverError::Rejected {
                device: LIGHT_DRIVER.to_owned(),
                now,
                reason: format!("brightness {b} outside [0, 1] (0 = off, 1 = full)"),
            });
        }
        self.advance(now);
        self.pending = Some((now + SWITCH_LATENCY, b));
        Ok(())
    }

    /// The brightness the lamp gives now (after [`Self::advance`]).
    #[must_use]
    pub fn brightness(&self) -> f64 {
        self.brightness
    }

    /// The lamp for the renderer, `None` while off.
    #[must_use]
    pub fn lamp(&self) -> Option<Lamp> {
        (self.brightness > 0.0).then(|| Lamp::wrist(self.brightness))
    }

    /// The state message.
    #[must_use]
    pub fn state(&self) -> Float64 {
        Float64 {
            data: self.brightness,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn follows_commands_after_the_latency_and_rejects_out_of_range() {
        let mut l = WristLightSim::new();
        let t0 = RobotTime::from_nanos(1_000_000_000);
        l.command(t0, &Float64 { data: 0.8 }).expect("valid");
        l.advance(t0 + RobotDuration::from_millis(19));
        assert_eq!(l.brightness(), 0.0);
        assert!(l.lamp().is_none());
        l.advance(t0 + SWITCH_LATENCY);
        assert_eq!(l.brightness(), 0.8);
        assert_eq!(l.lamp().map(|x| x.brightness), Some(0.8));
        for bad in [-0.1, 1.5, f64::NAN] {
            let e = l.command(t0 + SWITCH_LATENCY, &Float64 { data: bad });
            assert!(matches!(e, Err(DriverError::Rejected { .. })), "{bad}");
        }
        assert_eq!(l.state().data, 0.8);
    }
}
