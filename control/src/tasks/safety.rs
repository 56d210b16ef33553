//! Safety gates of the tasks: wind (from the robot's anemometer), perception confidence, and
//! the motion checks every plan passes before it is commanded.
//!
//! # Wind gate
//! Operations are allowed at a 3-s mean wind of at most [`WIND_LIMIT_MPS`] (ARCHITECTURE.md
//! section 6): 4 m/s, twice the paper's 2 m/s, because the hang tracks the wire's sway
//! ([`crate::perception::sway`]) instead of assuming a still wire. A site may set a lower
//! limit (`task.wind_limit_mps`, e.g. the paper's 2).
//! The robot only has its anemometer: `/env/wind`, the 3-s mean ending at the sample time,
//! 1 Hz, with a documented 1-sigma error `sigma(w) = 0.05 m/s + 2 % w` (`sim::environment`;
//! a real Gill or Vaisala sensor states the same form). So the gate refuses at
//!
//! `w_pred >= w_limit - k sigma(w_limit)`, `w_pred = w_last + max(0, dw/dt) (age + 1 s)`
//!
//! with `k` = [`WindGateParams::sigmas`] (default 3: a true wind at the limit reads below the
//! threshold with probability ~0.1 %), `dw/dt` the slope between the last two readings (a
//! rising wind is extrapolated over the reading's age plus the time until the next reading;
//! a falling one is not credited), and `age` the time since the last reading. With no
//! reading for longer than [`WindGateParams::max_age`] the gate is closed too (the sensor is
//! silent: the robot cannot know the wind). The gate is checked before every command; a task
//! whose gate is closed holds (issues nothing) and refuses when it stays closed for
//! [`WindGateParams::hold_timeout`], or when its holds add up to
//! [`WindGateParams::hold_budget`] in one operation (gusts that keep stopping the work:
//! refused with time to spare, not at the operation's time limit).
//!
//! # Settling after a gust
//! A gust leaves the conductor swinging after the 3-s mean has dropped: it swings about its
//! chord as a pendulum of length about `0.8 sag` (period `2 pi sqrt(0.8 sag / g)`, 1.6 s for a
//! bay's 0.8 m sag) whose amplitude decays as `exp(-zeta omega t)`. A bare conductor's swing is
//! lightly damped (`zeta` of a few percent: at 5 %, an e-folding time of `1 / (zeta omega)` =
//! 5 s for that sag). While the rod is on the wire the arm works at its handle, so a command
//! sent the moment the gate reopens meets the handle where the swing carries it: on seeded
//! sites at 3.5-4 m/s, 2 of 100 releases planned before a gust and sent as it passed went 4
//! and 12 mm into the handle. So after a hold, while the tool works at the handle of a rod on
//! the wire (the release; the remove's grasp, unclamping and unhook), commands wait until the
//! gate has been open for [`WindGateParams::settle_on_wire`] (default 8 s: 1.6 e-folding
//! times, the swing down to a fifth, inside the plans' clearance); a gust within that time
//! starts a new hold, and the hold timeout and budget count the time the gate was closed.
//! Longer, or wider, costs operations: at 15 s for every step at the wire (the hook's
//! approach and the retreat included) and counting the settling as holding, the 3.5 m/s
//! hangs fell from 40 to 4 of 50, refused for the wind.

use msgs::{RobotDuration, RobotTime};

/// The robot's operating limit on the 3-s mean wind (m/s), ARCHITECTURE.md section 6.
pub const WIND_LIMIT_MPS: f64 = 4.0;
/// The anemometer's documented absolute 1-sigma error (m/s).
pub const ANEMOMETER_SIGMA_MPS: f64 = 0.05;
/// The anemometer's documented relative 1-sigma error (fraction of the reading).
pub const ANEMOMETER_SIGMA_REL: f64 = 0.02;

/// Settings of the [`WindGate`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WindGateParams {
    /// The limit (m/s). Default [`WIND_LIMIT_MPS`].
    pub limit_mps: f64,
    /// Margin in anemometer sigmas. Default 3.
    pub sigmas: f64,
    /// Oldest usable reading. Default 2.5 s (the sensor reports at 1 Hz).
    pub max_age: RobotDuration,
    /// Time until the next reading assumed in the extrapolation. Default 1 s.
    pub reading_period: RobotDuration,
    /// A task holding for the wind refuses after this long. Default 60 s.
    pub hold_timeout: RobotDuration,
    /// A task whose holds for the wind add up to this in one operation refuses. Default 100 s
    /// (a hang takes about 150-200 s: it then ends before the 300 s limit).
    pub hold_budget: RobotDuration,
    /// After a hold, while the tool works at the handle of a rod on the wire, commands wait
    /// until the gate has been open this long: the gust's swing of the conductor, and of the
    /// rod clamped on it, settles before the arm moves there. Default 8 s (module docs).
    pub settle_on_wire: RobotDuration,
}

impl Default for WindGateParams {
    fn default() -> Self {
        Self {
            limit_mps: WIND_LIMIT_MPS,
            sigmas: 3.0,
            max_age: RobotDuration::from_millis(2500),
            reading_period: RobotDuration::from_secs(1),
            hold_timeout: RobotDuration::from_secs(60),
            hold_budget: RobotDuration::from_secs(100),
            settle_on_wire: RobotDuration::from_secs(8),
        }
    }
}

impl WindGateParams {
    /// The refusal threshold `w_limit - k sigma(w_limit)` (m/s).
    #[must_use]
    pub fn threshold_mps(&self) -> f64 {
        self.limit_mps
            - self.sigmas * (ANEMOMETER_SIGMA_MPS + ANEMOMETER_SIGMA_REL * self.limit_mps)
    }
}

/// The gate's verdict at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum WindVerdict {
    /// Commands may be issued.
    Open {
        /// The predicted 3-s mean (m/s).
        predicted_mps: f64,
    },
    /// Too windy: hold.
    TooWindy {
        /// The predicted 3-s mean (m/s).
        predicted_mps: f64,
        /// The threshold it reached (m/s).
        threshold_mps: f64,
        /// The limit the threshold keeps a margin from (m/s).
        limit_mps: f64,
    },
    /// No usable reading: hold.
    NoReading {
        /// Age of the last reading, if any (s).
        age_s: Option<f64>,
    },
}

impl WindVerdict {
    /// Whether commands may be issued.
    #[must_use]
    pub fn is_open(&self) -> bool {
        matches!(self, Self::Open { .. })
    }

    /// One line for events and logs.
    #[must_use]
    pub fn describe(&self) -> String {
        match self {
            Self::Open { predicted_mps } => format!("wind {predicted_mps:.2} m/s"),
            Self::TooWindy {
                predicted_mps,
                threshold_mps,
                limit_mps,
            } => format!(
                "wind {predicted_mps:.2} m/s >= {threshold_mps:.2} m/s (limit {limit_mps} m/s minus the anemometer's 3-sigma error)"
            ),
            Self::NoReading { age_s: Some(a) } => {
                format!("no /env/wind reading for {a:.1} s")
            }
            Self::NoReading { age_s: None } => "no /env/wind reading yet".to_owned(),
        }
    }
}

/// The wind gate (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct WindGate {
    params: WindGateParams,
    last: Option<(RobotTime, f64)>,
    previous: Option<(RobotTime, f64)>,
}

impl WindGate {
    /// A gate with no reading yet (closed).
    #[must_use]
    pub fn new(params: WindGateParams) -> Self {
        Self {
            params,
            last: None,
            previous: None,
        }
    }

    /// The settings.
    #[must_use]
    pub fn params(&self) -> &WindGateParams {
        &self.params
    }

    /// A `/env/wind` reading (its header-less Float64 is stamped with the log time). Non-finite
    /// readings are ignored (the gate then ages towards closed).
    pub fn on_reading(&mut self, log_time: RobotTime, wind_mps: f64) {
        if !wind_mps.is_finite() {
            return;
        }
        self.previous = self.last;
        self.last = Some((log_time, wind_mps.max(0.0)));
    }

    /// The verdict at `now`.
    #[must_use]
    pub fn verdict(&self, now: RobotTime) -> WindVerdict {
        let Some((t, w)) = self.last else {
            return WindVerdict::NoReading { age_s: None };
        };
        let age = now.saturating_duration_since(t);
        if age > self.params.max_age {
            return WindVerdict::NoReading {
                age_s: Some(age.as_secs_f64()),
            };
        }
        let slope = match self.previous {
            Some((t0, w0)) if t > t0 => (w - w0) / t.saturating_duration_since(t0).as_secs_f64(),
            _ => 0.0,
        };
        let horizon = (age + self.params.reading_period).as_secs_f64();
        let predicted_mps = w + slope.max(0.0) * horizon;
        let threshold_mps = self.params.threshold_mps();
        if predicted_mps >= threshold_mps {
            WindVerdict::TooWindy {
                predicted_mps,
                threshold_mps,
                limit_mps: self.params.limit_mps,
            }
        } else {
            WindVerdict::Open { predicted_mps }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(s: f64) -> RobotTime {
        RobotTime::from_secs_f64(s).unwrap_or(RobotTime::ZERO)
    }

    /// The gate at the paper's 2 m/s limit (the numbers below are worked out for it).
    fn paper() -> WindGateParams {
        WindGateParams {
            limit_mps: 2.0,
            ..WindGateParams::default()
        }
    }

    #[test]
    fn threshold_is_the_limit_minus_three_sigma() {
        assert!((paper().threshold_mps() - (2.0 - 3.0 * 0.09)).abs() < 1e-12);
        let d = WindGateParams::default();
        assert!((d.threshold_mps() - (4.0 - 3.0 * (0.05 + 0.08))).abs() < 1e-12);
    }

    #[test]
    fn closed_without_readings_open_when_calm_closed_when_windy_or_stale() {
        let mut g = WindGate::new(paper());
        assert!(!g.verdict(at(0.0)).is_open());
        g.on_reading(at(1.0), 0.8);
        assert!(g.verdict(at(1.5)).is_open());
        g.on_reading(at(2.0), 1.9);
        assert!(matches!(g.verdict(at(2.0)), WindVerdict::TooWindy { .. }));
        g.on_reading(at(3.0), 1.0);
        assert!(g.verdict(at(3.2)).is_open());
        // Silent sensor.
        assert!(matches!(
            g.verdict(at(6.0)),
            WindVerdict::NoReading { age_s: Some(_) }
        ));
    }

    #[test]
    fn a_rising_wind_closes_the_gate_before_it_reaches_the_threshold() {
        let mut g = WindGate::new(paper());
        g.on_reading(at(10.0), 1.3);
        g.on_reading(at(11.0), 1.5); // +0.2 m/s per s
        // 1.5 + 0.2 * (0.0 + 1.0) = 1.7 < 1.73: open right at the reading ...
        assert!(g.verdict(at(11.0)).is_open());
        // ... closed 0.5 s later (1.5 + 0.2 * 1.5 = 1.8).
        assert!(!g.verdict(at(11.5)).is_open());
        // A falling wind is not credited.
        let mut f = WindGate::new(paper());
        f.on_reading(at(10.0), 2.5);
        f.on_reading(at(11.0), 1.8);
        assert!(!f.verdict(at(11.0)).is_open());
    }

    #[test]
    fn non_finite_readings_are_ignored() {
        let mut g = WindGate::new(paper());
        g.on_reading(at(1.0), 0.5);
        g.on_reading(at(2.0), f64::NAN);
        assert!(g.verdict(at(2.0)).is_open());
    }
}
